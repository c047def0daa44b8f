//! # isokit-io: file formats for isokit
//!
//! Reading and writing the files that isokit's pipeline starts and ends with:
//!
//! | what | type | read | write |
//! | --- | --- | --- | --- |
//! | triangle meshes | [`TriMesh`] | [`read_mesh`]: OBJ, glTF/GLB, PLY, STL, OFF | [`write_mesh`]: OBJ, PLY (with normals), STL, OFF, glTF/GLB (with normals); [`write_mesh_colored`]: PLY, glTF/GLB with vertex colours |
//! | point clouds | [`PointCloud`] | [`read_points`]: PLY, XYZ | [`write_points`]: PLY, XYZ |
//! | volumes | [`Volume`] | [`read_volume`]: NRRD (+ `.nhdr`), NPY (with its [`lattice`] sidecar), NIfTI-1 (`.nii`, `.nii.gz`), INRIMAGE-4 (`.inr`, `.inr.gz`) | [`write_volume`]: NRRD, NPY; [`write_volume_with`]: NRRD (chosen compression, band/inside/sign key/values), NPY + sidecar |
//! | tetrahedral grids | [`TetGrid`](isokit_field::TetGrid) | [`read_tets`]: VTK legacy `.vtk` (ASCII, binary), VTK XML `.vtu` (ASCII, base64, appended raw/base64, zlib) | — |
//! | arrays (query points) | [`NpyArray`] | [`read_npy`] | [`write_npy_f32`] |
//! | images | RGBA8 / f32 channels | [`read_png`], [`read_exr`] (first layer, all channels), [`read_exr_info`] (header) | [`write_png`], [`write_exr`] |
//!
//! It is *not* a general mesh-processing or imaging library: it reads geometry into
//! isokit's plain types and writes results out, nothing more. Materials, textures, UVs,
//! animations and colours are ignored on read. Mesh *repair* is not done here either;
//! [`TriMesh::validate`] only reports (boundary, non-manifold and duplicate elements,
//! orientation, components, Euler characteristic) so that a caller can decide.
//! Molecules (PDB, mmCIF) are read by the `isokit-molecule` crate, with this crate's
//! [`IoError`] and the helpers in [`reader`].
//!
//! ## Choosing
//! - Pick the function for the *kind* of data ([`read_mesh`], [`read_points`],
//!   [`read_volume`], …); each chooses the format by extension, case-insensitively. A tool
//!   that takes "any input" calls [`detect_kind`] first (a `.ply` may be either a mesh or a
//!   point cloud; its header decides).
//! - Every reader also has a `*_bytes` twin reading from memory, naming the data in its
//!   messages.
//! - Volumes come in as [`Volume`] (per-axis spacing, as files store them). Turn one into an
//!   isokit [`Grid`](isokit_field::Grid) with [`Volume::into_grid`] when the spacing is
//!   uniform, or [`Volume::resample_uniform`] when it is not.
//! - [`generate`] (re-exported from `isokit-field`, as are [`TriMesh`] and [`PointCloud`])
//!   builds small closed meshes (icosphere, torus, tube around a curve) and clouds for tests
//!   and examples.
//! - For meshes to hand to other tools prefer binary PLY or STL (compact, exact f32); OBJ
//!   and OFF are text and also exact (shortest round-trip float formatting).
//!
//! ## Guarantees
//! - **Errors**: one [`IoError`] type; every message names the file and the problem (for
//!   operating-system failures the reason is the error's `source()`: print the chain).
//! - **No panics on input**: malformed, truncated or hostile files give an error. Counts in
//!   headers are checked against the bytes present (and volume sizes against
//!   [`isokit_field::MAX_SAMPLES`]) before anything is allocated; every index read from a
//!   file is range-checked.
//! - **Atomic output**: every writer goes through [`atomic_write`] (temporary file in the
//!   same directory, fsync, rename), so a failed write never leaves a partial file nor
//!   destroys the previous one.
//! - **Conventions** follow isokit: volumes are node-centered with x fastest; images have
//!   row 0 at the top; PNG holds sRGB 8-bit, EXR linear f32.
#![warn(missing_docs)]

mod atomic;
mod error;
mod gltf_read;
mod gltf_write;
mod image;
pub mod inr;
mod kind;
pub mod lattice;
mod mesh;
mod nifti;
mod npy;
mod nrrd;
mod obj;
mod off;
mod ply;
mod points;
mod stl;
mod tets;
mod util;
mod volume;
#[cfg(feature = "zarr")]
pub mod zarr;

/// Building blocks for readers of formats that live in other crates (molecules in
/// `isokit-molecule`): a whole-file read, bounded gzip inflation and the byte excerpts
/// that messages show, so that those readers report errors as this crate's own do.
pub mod reader {
    pub use crate::util::{gunzip, read_file, show};
}

pub use atomic::{atomic_write, temporary_name};
pub use error::IoError;
pub use gltf_write::vertex_normals;
pub use image::{
    ExrCamera, ExrImage, ExrInfo, MAX_EXR_SAMPLES, encode_png, linear_to_srgb8,
    linear_to_srgb8_formula, read_exr, read_exr_bytes, read_exr_info, read_exr_info_bytes,
    read_png, read_png_bytes, srgb8_to_linear, write_exr, write_exr_with_camera, write_png,
};
pub use isokit_field::{DEGENERATE_REL_TOL, MeshReport, PointCloud, TriMesh, generate};
pub use kind::{FileKind, detect_kind};
pub use mesh::{
    MeshFormat, read_mesh, read_mesh_bytes, read_ply_face_properties, write_mesh,
    write_mesh_colored, write_ply_ascii, write_ply_colored, write_ply_regions, write_stl_ascii,
};
pub use npy::{NpyArray, read_npy, read_npy_bytes, write_npy_f32};
pub use nrrd::{
    read_key_values as read_nrrd_key_values, write_key_values as write_nrrd_key_values,
};
pub use points::{PointFormat, read_points, read_points_bytes, write_points};
pub use tets::{TetFormat, read_tets, read_tets_bytes};
pub use util::{shown_path, shown_text};
pub use volume::{
    ISOTROPY_TOL, NrrdEncoding, Volume, VolumeFormat, read_volume, read_volume_bytes, write_nrrd,
    write_nrrd_raw, write_volume, write_volume_with,
};
