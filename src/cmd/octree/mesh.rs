//! `isokit octree … -o out.obj`: the tree's surface as a triangle mesh, meshed from the
//! tree's own reconstruction at a chosen level.

use crate::cmd::mesher_args::MesherArg;
use anyhow::{Result, bail};
use glam::UVec3;
use isokit_field::{Field, TriMesh};
use isokit_levelset::dual::{DualOptions, mesh_dual_lattice_job};
use isokit_levelset::meshing::{MeshOptions, mesh_grid_job};
use isokit_octree::{HashedOctree, Octree};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

/// Refuses a mesh level whose lattice exceeds a grid's size limit, before anything is built
/// (dual contouring reads the tree node by node, so the limit is one of time: every node is
/// read).
pub fn check_level(level: u32) -> Result<()> {
    let n = (1usize << level.min(40)) + 1;
    if n.checked_pow(3)
        .is_none_or(|s| s > isokit_field::MAX_SAMPLES)
    {
        bail!(
            "a mesh at level {level} reads (2^{level} + 1)^3 samples, more than {}; use --export-level {} or less",
            isokit_field::MAX_SAMPLES,
            (0..=level.min(21))
                .rev()
                .find(|&l| ((1usize << l) + 1).pow(3) <= isokit_field::MAX_SAMPLES)
                .unwrap_or(0)
        );
    }
    Ok(())
}

/// Meshes the tree's reconstruction sampled at the nodes of `level` (2^level + 1 a side),
/// writes it to `path` and returns what `--json` adds. Marching cubes reads the samples as
/// a grid; dual contouring reads the tree node by node (no grid is stored) and takes its
/// Hermite data from `exact`, the field the tree was built from (`--error E` merges cells
/// as for `isokit mesh`).
pub fn mesh_tree(
    tree: &HashedOctree,
    exact: &dyn Field,
    level: u32,
    mesher: MesherArg,
    error: Option<f64>,
    path: &Path,
) -> Result<Value> {
    let d = tree.domain();
    let n = (1usize << level) + 1;
    let shift = d.max_level() - level;
    let job = crate::cmd::progress::job();
    let t = Instant::now();
    let (mesh, dual): (TriMesh, _) = match mesher {
        MesherArg::Mc => {
            let grid = tree.to_grid(level)?;
            (mesh_grid_job(&grid, &MeshOptions::default(), &job)?, None)
        }
        MesherArg::Dual => {
            let at = |i: usize, j: usize, k: usize| {
                let g = UVec3::new(i as u32, j as u32, k as u32) << shift;
                tree.value_at_grid(g.as_dvec3())
            };
            let opts = DualOptions {
                error,
                ..DualOptions::default()
            };
            let (m, st) = mesh_dual_lattice_job(
                [n; 3],
                d.origin(),
                d.cell_side(level) as f32,
                at,
                Some(exact),
                &opts,
                &job,
            )?;
            crate::cmd::mesher_args::print_dual_stats(&st, error.is_some());
            (m, Some(st))
        }
    };
    let secs = t.elapsed().as_secs_f64();
    isokit_io::write_mesh(path, &mesh)?;
    let r = mesh.validate();
    eprintln!(
        "{} triangles from the tree at level {level} in {secs:.2} s; watertight {} -> {}",
        mesh.triangles.len(),
        r.watertight,
        path.display()
    );
    let mut v = json!({
        "mesher": match mesher { MesherArg::Mc => "mc", MesherArg::Dual => "dual" },
        "mesh_level": level,
        "triangles": mesh.triangles.len(),
        "mesh_seconds": secs,
        "watertight": r.watertight,
    });
    if let Some(st) = dual {
        v["clamped_vertices"] = st.clamped.into();
        v["multi_component_cells"] = st.multi_component_cells.into();
        v["beyond_cell_vertices"] = st.beyond_cell.into();
        v["folded_triangles"] = st.folded_triangles.into();
        v["sharpened_edges"] = st.sharpened_edges.into();
        v["moved_vertices"] = st.moved_vertices.into();
        if error.is_some() {
            v["merged_cells"] = st.merged_cells.into();
        }
    }
    Ok(v)
}
