//! `--mesher mc|dual` (`isokit mesh`, `isokit scene`), what the meshers report, and what
//! `isokit info` says about a mesh.

use anyhow::Result;
use isokit_scene::Mesher;
use serde_json::{Value, json};
use std::path::Path;

/// `--mesher` on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MesherArg {
    /// Marching cubes.
    Mc,
    /// Dual contouring with Hermite data.
    Dual,
}

impl From<MesherArg> for Mesher {
    fn from(m: MesherArg) -> Self {
        match m {
            MesherArg::Mc => Mesher::Mc,
            MesherArg::Dual => Mesher::Dual,
        }
    }
}

/// Prints what dual contouring reports about its vertices.
pub fn print_dual_stats(clamped: usize, several: usize) {
    eprintln!(
        "dual contouring: {clamped} vertices clamped into their cells, {several} cells crossed in more than one piece"
    );
}

/// What `isokit info` says about a mesh file: the validation report (text and JSON), with
/// `self_intersections` the count of intersecting pairs of triangles.
pub fn describe_mesh(path: &Path, self_intersections: bool) -> Result<(String, Value)> {
    let mesh = isokit_io::read_mesh(path)?;
    let r = mesh.validate();
    let mut v = json!({
        "kind": "mesh",
        "vertices": r.vertices,
        "triangles": r.triangles,
        "bounds": super::info::bounds_json(&r.bounds),
        "degenerate_triangles": r.degenerate_triangles,
        "duplicate_triangles": r.duplicate_triangles,
        "duplicate_vertices": r.duplicate_vertices,
        "unreferenced_vertices": r.unreferenced_vertices,
        "non_finite_vertices": r.non_finite_vertices,
        "boundary_edges": r.boundary_edges,
        "non_manifold_edges": r.non_manifold_edges,
        "components": r.components,
        "euler_characteristic": r.euler_characteristic,
        "watertight": r.watertight,
        "consistently_oriented": r.consistently_oriented,
    });
    let mut text = format!("{}: mesh\n{r}", path.display());
    if self_intersections {
        let x = isokit_levelset::intersect::self_intersections(&mesh);
        v["self_intersections"] = x.count.into();
        text += &format!(
            "\nself-intersections: {} pairs of triangles ({} candidate pairs tested)",
            x.count, x.candidates
        );
    }
    Ok((text, v))
}
