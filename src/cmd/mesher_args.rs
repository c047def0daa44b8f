//! `--mesher mc|dual [--error E]` (`isokit mesh`, `isokit scene`), what the meshers report,
//! and what `isokit info` says about a mesh.

use anyhow::{Result, bail};
use isokit_levelset::dual::DualStats;
use isokit_scene::Mesher;
use serde_json::{Value, json};
use std::path::Path;

/// `--mesher` on the command line (marching cubes where it is not given).
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MesherArg {
    /// Marching cubes.
    #[default]
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

/// `--mesher` and `--error` of `isokit mesh` and `isokit scene`.
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct MesherOpts {
    /// `mc` (marching cubes: watertight and 2-manifold by construction, sharp edges chamfered
    /// by about a voxel) or `dual` (dual contouring with Hermite data: sharp edges and
    /// corners; normals from a scene's exact field, or from a volume's central differences;
    /// watertight, 2-manifold and oriented; where the lattice cannot resolve a feature,
    /// triangles can fold, which `isokit info --self-intersections` reports) [default: mc].
    #[arg(long, value_enum)]
    pub mesher: Option<MesherArg>,
    /// --mesher dual: adaptive meshing. Cells are merged into octree nodes (up to 256 cells
    /// a side) where one vertex lies within E, in world units, of every crossing's tangent
    /// plane (and of a scene's exact surface), and the merge keeps the surface's topology:
    /// few large triangles where the surface is flat, the cells' own vertices at edges and
    /// corners [default: one vertex per cell].
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    pub error: Option<f64>,
}

impl MesherOpts {
    /// The mesher: `--mesher`, or marching cubes.
    pub fn kind(&self) -> MesherArg {
        self.mesher.unwrap_or_default()
    }

    /// `--error`, checked: only with `--mesher dual`, finite and positive.
    pub fn error(&self) -> Result<Option<f64>> {
        match self.error {
            None => Ok(None),
            Some(_) if self.kind() != MesherArg::Dual => {
                bail!("--error applies to --mesher dual (adaptive dual contouring)")
            }
            Some(e) if !(e.is_finite() && e > 0.0) => {
                bail!("--error {e} must be a finite positive distance in world units")
            }
            Some(e) => Ok(Some(e)),
        }
    }
}

/// Prints what dual contouring reports: its vertices (clamped, beyond their cells, cells of
/// several pieces), its merges when `adaptive`, the edges split onto sharp features, and the
/// triangles still folded or intersecting.
pub fn print_dual_stats(st: &DualStats, adaptive: bool) {
    let merged = if adaptive {
        format!(
            ", {} cells merged into larger octree nodes",
            st.merged_cells
        )
    } else {
        String::new()
    };
    let sharpened = if st.sharpened_edges + st.moved_vertices > 0 {
        format!(
            ", {} mesh edges or triangles split at (or flipped onto) a sharp edge or corner, {} vertices moved onto the surface",
            st.sharpened_edges, st.moved_vertices
        )
    } else {
        String::new()
    };
    let folded = if st.folded_triangles > 0 {
        format!(
            "; {} triangles face against the surface or cross another (`isokit info --self-intersections` counts crossings)",
            st.folded_triangles
        )
    } else {
        String::new()
    };
    let several = st.multi_component_cells;
    eprintln!(
        "dual contouring: {} vertices whose QEF minimiser lay outside their cells ({} of them placed on a sharp edge just beyond the cell, the others clamped into it), {several} {} crossed in more than one piece{merged}{sharpened}{folded}",
        st.clamped,
        st.beyond_cell,
        if several == 1 { "cell" } else { "cells" }
    );
}

/// [`print_dual_stats`] of a scene's mesh, where dual contouring made it.
pub fn print_scene_dual_stats(st: &isokit_scene::MeshStats) {
    if let (Some(clamped), Some(several)) = (st.clamped_vertices, st.multi_component_cells) {
        let dual = DualStats {
            clamped,
            multi_component_cells: several,
            beyond_cell: st.beyond_cell_vertices.unwrap_or(0),
            merged_cells: st.merged_cells.unwrap_or(0),
            folded_triangles: st.folded_triangles.unwrap_or(0),
            sharpened_edges: st.sharpened_edges.unwrap_or(0),
            moved_vertices: st.moved_vertices.unwrap_or(0),
            ..DualStats::default()
        };
        print_dual_stats(&dual, st.merged_cells.is_some());
    }
}

/// Adds dual contouring's counts of `st` to `isokit scene --stats`'s JSON, where the mesher
/// gave them.
pub fn add_dual_counts(j: &mut Value, st: &isokit_scene::MeshStats) -> Result<()> {
    let counts = serde_json::to_value(st)?;
    for k in [
        "clamped_vertices",
        "multi_component_cells",
        "merged_cells",
        "folded_triangles",
        "beyond_cell_vertices",
        "sharpened_edges",
        "moved_vertices",
    ] {
        if let Some(v) = counts.get(k) {
            j[k] = v.clone();
        }
    }
    Ok(())
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
        "non_manifold_vertices": r.non_manifold_vertices,
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
