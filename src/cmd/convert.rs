//! `isokit convert IN OUT`: between mesh formats, cloud formats or volume formats.

use anyhow::{Result, bail};
use isokit_io::lattice::{Lattice, read_sidecar};
use isokit_io::{FileKind, detect_kind, read_mesh, read_points, write_mesh, write_points};
use std::path::{Path, PathBuf};

/// Arguments of `isokit convert`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Input file; its kind (mesh, cloud, volume) is taken from the extension and, for PLY,
    /// the header.
    pub input: PathBuf,
    /// Output file of the same kind: mesh .obj .ply .stl .off .glb .gltf (PLY and glTF with
    /// vertex normals); cloud .ply .xyz; volume .nrrd .npy (with its lattice sidecar) .zarr
    /// (a Zarr store). Written to a temporary file (store) and renamed.
    pub output: PathBuf,
    #[command(flatten)]
    pub volume: super::volume_args::VolumeIn,
    #[command(flatten)]
    pub out: super::volume_args::VolumeOut,
}

fn output_kind(path: &Path, input: FileKind) -> Option<FileKind> {
    let name = path.to_string_lossy().to_ascii_lowercase();
    let ext = name.rsplit('.').next().unwrap_or("");
    match ext {
        "obj" | "stl" | "off" | "glb" | "gltf" => Some(FileKind::Mesh),
        "xyz" => Some(FileKind::PointCloud),
        // PLY holds either; follow the input.
        "ply" if matches!(input, FileKind::Mesh | FileKind::PointCloud) => Some(input),
        "nrrd" | "npy" | "zarr" => Some(FileKind::Volume),
        _ => None,
    }
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    let kind = detect_kind(&a.input)?;
    let Some(out_kind) = output_kind(&a.output, kind) else {
        bail!(
            "{}: unknown output format (meshes: .obj .ply .stl .off .glb .gltf; clouds: .ply .xyz; volumes: .nrrd .npy .zarr)",
            a.output.display()
        );
    };
    super::check_output(&a.output, &[])?;
    a.out.check(&a.output)?;
    match (kind, out_kind) {
        (FileKind::Mesh, FileKind::Mesh) => {
            let m = read_mesh(&a.input)?;
            write_mesh(&a.output, &m)?;
            eprintln!(
                "{} vertices, {} triangles -> {}",
                m.positions.len(),
                m.triangles.len(),
                a.output.display()
            );
        }
        (FileKind::Mesh, FileKind::PointCloud) => {
            // A mesh's vertices as a cloud (no normals).
            let m = read_mesh(&a.input)?;
            let c = isokit_io::PointCloud {
                points: m.positions,
                normals: None,
            };
            write_points(&a.output, &c)?;
            eprintln!(
                "{} points (mesh vertices) -> {}",
                c.points.len(),
                a.output.display()
            );
        }
        (FileKind::PointCloud, FileKind::PointCloud) => {
            let c = read_points(&a.input)?;
            write_points(&a.output, &c)?;
            eprintln!("{} points -> {}", c.points.len(), a.output.display());
        }
        (FileKind::Volume, FileKind::Volume) => {
            let v = a.volume.read(&a.input)?;
            // An NPY input's (or a store's) band, inside and sign travel with it.
            let meta = match read_sidecar(&a.input) {
                Ok(Some(m)) => m,
                _ if super::volume_out::is_zarr(&a.input) => {
                    isokit_io::zarr::zarr_info(&a.input)?.lattice
                }
                _ => Lattice::of(&v),
            };
            a.out.write_meta(&a.output, &v, &meta)?;
            eprintln!("{:?} samples -> {}", v.dims, a.output.display());
        }
        (from, to) => bail!(
            "cannot convert {} ({}) to {} ({})",
            a.input.display(),
            kind_name(from),
            a.output.display(),
            kind_name(to)
        ),
    }
    Ok(())
}

fn kind_name(k: FileKind) -> &'static str {
    match k {
        FileKind::Mesh => "mesh",
        FileKind::PointCloud => "point cloud",
        FileKind::Volume => "volume",
        FileKind::Image => "image",
        FileKind::TetGrid => "tetrahedral grid",
    }
}
