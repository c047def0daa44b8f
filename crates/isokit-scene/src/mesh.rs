//! Meshing a scene: the band sampled lazily, then marching cubes or dual contouring over the
//! kept bricks (or over the dense grid, for the baseline).

use crate::{SampleOptions, SampleStats, Scene, SceneError};
use isokit_field::{BrickGrid, Grid, Job, TriMesh};
use isokit_levelset::dual::{DualOptions, mesh_dual_brick_grid_job, mesh_dual_grid_job};
use isokit_levelset::meshing::{mesh_brick_grid_job, mesh_grid_job};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Which isosurface mesher [`mesh_scene`] runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mesher {
    /// Marching cubes with the asymptotic decider (`isokit_levelset::meshing`): watertight
    /// and 2-manifold by construction; chamfers sharp edges by about a voxel. The default.
    #[default]
    Mc,
    /// Dual contouring with Hermite data from the scene's exact field
    /// (`isokit_levelset::dual`): sharp edges and corners, a vertex per surface component
    /// of each cell; watertight, 2-manifold and oriented (also after coincident vertices are
    /// merged).
    Dual,
}

/// What [`mesh_scene`] meshes: the lazily sampled band, or the dense baseline grid.
enum Sampled {
    Dense(Grid),
    Band(BrickGrid),
}

/// Knobs of [`mesh_scene`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshOptions {
    /// How the band is sampled (the apron is always 0 for meshing).
    pub sampling: SampleOptions,
    /// Evaluate every sample of the dense grid instead of the lazy band (the baseline;
    /// the same mesh).
    pub dense: bool,
    /// The mesher (default marching cubes).
    pub mesher: Mesher,
    /// Dual contouring only: adaptive meshing, cells merged where one vertex lies within
    /// this distance (world units) of every crossing's tangent plane and of the surface
    /// (`isokit_levelset::dual::DualOptions::error`). `None`: one vertex per cell.
    pub error: Option<f64>,
}

/// What [`mesh_scene`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshStats {
    /// The sampling's statistics.
    pub sampling: SampleStats,
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Seconds spent meshing (after sampling).
    pub mesh_seconds: f64,
    /// The mesher that ran.
    pub mesher: Mesher,
    /// Dual contouring only: vertices whose QEF minimiser was clamped into its cell.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clamped_vertices: Option<usize>,
    /// Dual contouring only: cells the surface crosses in more than one piece (given a
    /// vertex per piece).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub multi_component_cells: Option<usize>,
    /// Adaptive dual contouring only: crossed cells whose vertex a merged octree node's
    /// replaced.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub merged_cells: Option<usize>,
    /// Dual contouring only: triangles still folded, degenerate or intersecting another
    /// after the checks undid what they could (`isokit_levelset::dual::DualStats`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub folded_triangles: Option<usize>,
    /// Dual contouring only: vertices placed on a sharp edge just beyond their cell (where
    /// the cell holds both of the edge's faces but not the edge).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beyond_cell_vertices: Option<usize>,
    /// Dual contouring only: mesh edges and triangles that cut across a sharp edge or
    /// corner of the exact surface, split at a vertex on it, and edges flipped onto the
    /// surface (`isokit_levelset::dual::DualStats::sharpened_edges`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sharpened_edges: Option<usize>,
    /// Dual contouring only: vertices moved onto the exact surface, or onto a corner or edge
    /// of it that their edges cut.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub moved_vertices: Option<usize>,
}

/// The scene's surface as a triangle mesh: with [`Mesher::Mc`] (the default) watertight and
/// consistently oriented (marching cubes with the asymptotic decider on the sampled band;
/// see `isokit_levelset::meshing`), with [`Mesher::Dual`] dual contouring whose Hermite data
/// come from the scene's exact field (see `isokit_levelset::dual`). An empty mesh when the
/// surface does not cross the sampled domain.
pub fn mesh_scene(
    scene: &Scene,
    opts: &MeshOptions,
    job: &Job,
) -> Result<(TriMesh, MeshStats), SceneError> {
    let sampling = SampleOptions {
        apron: 0,
        ..opts.sampling
    };
    let err = |e: isokit_levelset::meshing::MeshingError| {
        SceneError::new(scene.name(), "", format!("meshing: {e}"))
    };
    // The band (or, for the baseline, the dense grid), then the mesher over it.
    let (sampled, stats) = if opts.dense {
        let (grid, stats) = scene.sample_dense(&sampling)?;
        (Sampled::Dense(grid), stats)
    } else {
        let (grid, stats) = scene.sample_job(&sampling, job)?;
        (Sampled::Band(grid), stats)
    };
    job.check()
        .map_err(|e| SceneError::new(scene.name(), "", e.to_string()))?;
    let t1 = Instant::now();
    let mc = isokit_levelset::meshing::MeshOptions::default();
    let dual = DualOptions {
        error: opts.error,
        ..DualOptions::default()
    };
    // Dual contouring takes its Hermite data from the exact field.
    let field = Some(scene.field());
    let (mesh, dual) = match (opts.mesher, &sampled) {
        (Mesher::Mc, Sampled::Dense(g)) => (mesh_grid_job(g, &mc, job).map_err(err)?, None),
        (Mesher::Mc, Sampled::Band(g)) => (mesh_brick_grid_job(g, &mc, job).map_err(err)?, None),
        (Mesher::Dual, Sampled::Dense(g)) => {
            let (m, d) = mesh_dual_grid_job(g, field, &dual, job).map_err(err)?;
            (m, Some(d))
        }
        (Mesher::Dual, Sampled::Band(g)) => {
            let (m, d) = mesh_dual_brick_grid_job(g, field, &dual, job).map_err(err)?;
            (m, Some(d))
        }
    };
    let triangles = mesh.triangles.len();
    Ok((
        mesh,
        MeshStats {
            sampling: stats,
            triangles,
            mesh_seconds: t1.elapsed().as_secs_f64(),
            mesher: opts.mesher,
            clamped_vertices: dual.map(|d| d.clamped),
            multi_component_cells: dual.map(|d| d.multi_component_cells),
            merged_cells: dual
                .filter(|_| opts.error.is_some())
                .map(|d| d.merged_cells),
            folded_triangles: dual.map(|d| d.folded_triangles),
            beyond_cell_vertices: dual.map(|d| d.beyond_cell),
            sharpened_edges: dual.map(|d| d.sharpened_edges),
            moved_vertices: dual.map(|d| d.moved_vertices),
        },
    ))
}

/// The colour of each vertex of a scene's mesh as 8-bit sRGB, for mesh files that carry
/// colours (PLY): the part that owns the vertex ([`Scene::part_at`], within two lattice
/// spacings `spacing` of its surface: the mesh lies within one of the exact surface), else
/// the scene's `shading.color` (default a light grey). `None` when the scene has no coloured
/// nodes.
pub fn vertex_colors(scene: &Scene, mesh: &TriMesh, spacing: f32) -> Option<Vec<[u8; 3]>> {
    if scene.parts().is_empty() {
        return None;
    }
    let default = scene
        .settings()
        .shading
        .as_ref()
        .and_then(|s| s.color)
        .unwrap_or([0.8; 3]);
    let srgb = |x: f32| {
        let x = x.clamp(0.0, 1.0);
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    Some(
        scene
            .colors_at(&mesh.positions, 2.0 * spacing, default)
            .into_iter()
            .map(|c| c.map(srgb))
            .collect(),
    )
}
