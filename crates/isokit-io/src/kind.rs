//! Guessing what a file holds from its name (and, for PLY, its header).

use std::io::Read;
use std::path::Path;

use crate::util::extension;
use crate::{IoError, ply};

/// What a file holds, for dispatch in tools that accept several kinds of input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FileKind {
    /// A triangle mesh (`.gltf .glb .stl .off`, or `.ply` and `.obj` with faces).
    Mesh,
    /// A point cloud (`.xyz`, or `.ply` and `.obj` without faces).
    PointCloud,
    /// A volume (`.nrrd .nhdr .npy .nii .nii.gz .inr .inr.gz`, or a `.zarr` store).
    Volume,
    /// An image (`.png .exr`). PNG is read by [`crate::read_png`]; of an EXR only the
    /// header is read ([`crate::read_exr_info`]).
    Image,
    /// A tetrahedral grid with point scalars (`.vtk .vtu`), read by [`crate::read_tets`].
    TetGrid,
}

/// Decides the kind of a file by extension (case-insensitive). A `.ply` file is opened and
/// its header read: a `face` element with a count above 0 makes it a mesh, otherwise a point
/// cloud. Likewise an `.obj` file with `f` lines is a mesh, one with only `v` lines a cloud.
pub fn detect_kind(path: &Path) -> Result<FileKind, IoError> {
    let ext = extension(path).unwrap_or_default();
    Ok(match ext.as_str() {
        "gltf" | "glb" | "stl" | "off" => FileKind::Mesh,
        "obj" => {
            if crate::obj::has_faces(&crate::util::read_file(path)?) {
                FileKind::Mesh
            } else {
                FileKind::PointCloud
            }
        }
        "xyz" => FileKind::PointCloud,
        "nrrd" | "nhdr" | "npy" | "nii" | "nii.gz" | "inr" | "inr.gz" | "zarr" => FileKind::Volume,
        "png" | "exr" => FileKind::Image,
        "vtk" | "vtu" => FileKind::TetGrid,
        "ply" => {
            // The header is text at the start of the file; 1 MiB is plenty.
            let mut head = Vec::new();
            std::fs::File::open(path)
                .and_then(|f| f.take(1 << 20).read_to_end(&mut head))
                .map_err(|e| IoError::io(path, e))?;
            let header = ply::parse_header(&head, path)?;
            if header.face_count() > 0 {
                FileKind::Mesh
            } else {
                FileKind::PointCloud
            }
        }
        _ => {
            return Err(IoError::UnknownFormat {
                path: path.to_path_buf(),
                expected: "a mesh (.obj .gltf .glb .ply .stl .off), point cloud (.ply .xyz), volume (.nrrd .nhdr .npy .nii .nii.gz .inr .inr.gz .zarr), tetrahedral grid (.vtk .vtu) or image (.png .exr)",
            });
        }
    })
}
