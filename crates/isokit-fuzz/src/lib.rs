//! # isokit-fuzz: the fuzz targets
//!
//! Every reader of user files as a function of bytes ([`TARGETS`]): OBJ, PLY (mesh and
//! cloud), STL, OFF, glTF, GLB, XYZ, NRRD (attached data, gzip and detached headers),
//! NPY, NIfTI (plain and gzip), INRIMAGE (plain and gzip), tetrahedral grids (legacy VTK and VTK XML), PDB, mmCIF,
//! gzipped molecules, and scene files in JSON and TOML. A target feeds the bytes to the same entry point the command uses and checks what
//! the project promises of any input: no panic, and an error that is one line. Successful
//! reads go one step further (a mesh is validated, a volume becomes a grid, a molecule a
//! splat scene, a scene is compiled and evaluated, a tetrahedral grid is checked and meshed)
//! so that what the readers accept is
//! exercised too.
//!
//! Three harnesses call these functions:
//! - `crates/isokit-fuzz/tests/corpus.rs` replays `fuzz/corpus/<target>/*` in
//!   `cargo test --workspace` (seconds);
//! - `fuzz/afl` (cargo-afl, stable toolchain): the coverage-guided campaign, run by
//!   `tools/fuzz.sh`;
//! - `fuzz/fuzz_targets` (cargo-fuzz, nightly toolchain).
//!
//! It is not a test-data generator and holds no assertions about what a valid file means:
//! the readers' own tests do that.
#![warn(missing_docs)]

use isokit_field::Field;
use isokit_io::{MeshFormat, PointFormat, TetFormat, VolumeFormat};
use isokit_molecule::MoleculeFormat;
use isokit_scene::file::SceneFormat;
use std::path::Path;

/// A fuzz target: bytes in, a panic or a multi-line error message out when something is
/// wrong.
pub type Target = fn(&[u8]);

/// Every target, by the name its corpus folder has (`fuzz/corpus/NAME/`).
pub const TARGETS: &[(&str, Target)] = &[
    ("obj", obj),
    ("ply", ply),
    ("stl", stl),
    ("off", off),
    ("gltf", gltf),
    ("glb", glb),
    ("xyz", xyz),
    ("nrrd", nrrd),
    ("npy", npy),
    ("nifti", nifti),
    ("nifti_gz", nifti_gz),
    ("inr", inr),
    ("vtk", vtk),
    ("vtu", vtu),
    ("pdb", pdb),
    ("mmcif", mmcif),
    ("molecule_gz", molecule_gz),
    ("scene_json", scene_json),
    ("scene_toml", scene_toml),
];

/// The target called `name`.
pub fn target(name: &str) -> Option<Target> {
    TARGETS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// An error's message must be one line (the command prints it as `isokit: error: …`).
fn one_line(e: impl std::fmt::Display) {
    let m = e.to_string();
    assert!(!m.contains('\n'), "an error message spans lines: {m:?}");
}

/// Fuzz inputs name data files relative to a folder that does not exist, so only
/// absolute references reach the file system.
const NOWHERE: &str = "/nonexistent-isokit-fuzz";

fn mesh(data: &[u8], format: MeshFormat, name: &str) {
    match isokit_io::read_mesh_bytes(data, format, &format!("{NOWHERE}/{name}")) {
        Ok(m) => {
            let r = m.validate();
            assert_eq!(r.vertices, m.positions.len());
            let _ = m.bounds();
        }
        Err(e) => one_line(e),
    }
}

fn points(data: &[u8], format: PointFormat, name: &str) {
    match isokit_io::read_points_bytes(data, format, name) {
        Ok(c) => assert!(c.normals_problem().is_none()),
        Err(e) => one_line(e),
    }
}

fn volume(data: &[u8], format: VolumeFormat, name: &str) {
    match isokit_io::read_volume_bytes(data, format, &format!("{NOWHERE}/{name}")) {
        Ok(v) => {
            assert_eq!(v.data.len(), v.dims.iter().product::<usize>());
            if v.is_uniform() {
                if let Err(e) = v.into_grid() {
                    one_line(e);
                }
            }
        }
        Err(e) => one_line(e),
    }
}

fn tets(data: &[u8], format: TetFormat, name: &str) {
    match isokit_io::read_tets_bytes(data, format, None, name) {
        Ok(g) => {
            let r = g.report();
            assert_eq!(r.cells, g.tets().len());
            let iso = r.range.map_or(0.0, |(lo, hi)| lo + 0.5 * (hi - lo));
            if let Err(e) = isokit_levelset::tets::mesh_tets(&g, iso) {
                one_line(e);
            }
        }
        Err(e) => one_line(e),
    }
}

fn molecule(data: &[u8], format: MoleculeFormat, name: &str) {
    match isokit_molecule::read_molecule_bytes(data, name, format) {
        Ok(mut m) => {
            m.infer_bonds(isokit_molecule::DEFAULT_BOND_TOLERANCE);
            if let Err(e) =
                isokit_molecule::molecule_scene(&m, &isokit_molecule::MoleculeOptions::default())
            {
                one_line(e);
            }
        }
        Err(e) => one_line(e),
    }
}

fn scene(data: &[u8], format: SceneFormat, name: &str) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let file = match isokit_scene::file::parse(text, format, name) {
        Ok(f) => f,
        Err(e) => return one_line(e),
    };
    // Octree nodes are built when the scene compiles: keep them small enough to fuzz.
    if text.contains("octree") {
        return;
    }
    match isokit_scene::Scene::from_file(file, Path::new(NOWHERE)) {
        Ok(s) => {
            for p in [glam::Vec3::ZERO, glam::Vec3::ONE, glam::Vec3::splat(-0.3)] {
                let _ = s.value(p);
            }
            let _ = s.bounds();
        }
        Err(e) => one_line(e),
    }
}

/// OBJ meshes.
pub fn obj(data: &[u8]) {
    mesh(data, MeshFormat::Obj, "fuzz.obj");
    points(data, PointFormat::Obj, "fuzz.obj");
}
/// PLY meshes and clouds.
pub fn ply(data: &[u8]) {
    mesh(data, MeshFormat::Ply, "fuzz.ply");
    points(data, PointFormat::Ply, "fuzz.ply");
}
/// STL, binary and ASCII.
pub fn stl(data: &[u8]) {
    mesh(data, MeshFormat::Stl, "fuzz.stl");
}
/// OFF (and COFF, NOFF, CNOFF).
pub fn off(data: &[u8]) {
    mesh(data, MeshFormat::Off, "fuzz.off");
}
/// glTF JSON with data URIs or (absolute) external buffers.
pub fn gltf(data: &[u8]) {
    mesh(data, MeshFormat::Gltf, "fuzz.gltf");
}
/// Binary glTF.
pub fn glb(data: &[u8]) {
    mesh(data, MeshFormat::Glb, "fuzz.glb");
}
/// XYZ text clouds.
pub fn xyz(data: &[u8]) {
    points(data, PointFormat::Xyz, "fuzz.xyz");
}
/// NRRD: attached raw, ASCII or gzip data, and detached headers.
pub fn nrrd(data: &[u8]) {
    volume(data, VolumeFormat::Nrrd, "fuzz.nrrd");
    volume(data, VolumeFormat::Nhdr, "fuzz.nhdr");
}
/// NPY arrays, as volumes and as query points.
pub fn npy(data: &[u8]) {
    volume(data, VolumeFormat::Npy, "fuzz.npy");
    if let Err(e) = isokit_io::read_npy_bytes(data, "fuzz.npy") {
        one_line(e);
    }
}
/// NIfTI-1.
pub fn nifti(data: &[u8]) {
    volume(data, VolumeFormat::Nifti, "fuzz.nii");
}
/// Gzipped NIfTI-1 (the bounded inflation).
pub fn nifti_gz(data: &[u8]) {
    volume(data, VolumeFormat::NiftiGz, "fuzz.nii.gz");
}
/// INRIMAGE-4, plain and gzipped (the bounded inflation).
pub fn inr(data: &[u8]) {
    volume(data, VolumeFormat::Inr, "fuzz.inr");
}
/// Legacy VTK unstructured grids (ASCII and binary).
pub fn vtk(data: &[u8]) {
    tets(data, TetFormat::Legacy, "fuzz.vtk");
}
/// VTK XML unstructured grids (ASCII, base64, appended raw, zlib).
pub fn vtu(data: &[u8]) {
    tets(data, TetFormat::Vtu, "fuzz.vtu");
}
/// PDB.
pub fn pdb(data: &[u8]) {
    molecule(data, MoleculeFormat::Pdb, "fuzz.pdb");
}
/// mmCIF.
pub fn mmcif(data: &[u8]) {
    molecule(data, MoleculeFormat::Mmcif, "fuzz.cif");
}
/// Gzipped molecules (gzip recognized by content; both formats).
pub fn molecule_gz(data: &[u8]) {
    molecule(data, MoleculeFormat::Pdb, "fuzz.pdb.gz");
    molecule(data, MoleculeFormat::Mmcif, "fuzz.cif.gz");
}
/// Scene files in JSON: parsed, compiled (sources by absolute path only) and evaluated.
pub fn scene_json(data: &[u8]) {
    scene(data, SceneFormat::Json, "fuzz.json");
}
/// Scene files in TOML.
pub fn scene_toml(data: &[u8]) {
    scene(data, SceneFormat::Toml, "fuzz.toml");
}
