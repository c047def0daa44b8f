//! Dual contouring with Hermite data (Ju, Losasso, Schaefer and Warren 2002, "Dual
//! Contouring of Hermite Data"): sharp edges and corners that marching cubes chamfers.
//!
//! [`mesh_dual_grid`] meshes a dense [`Grid`], [`mesh_dual_brick_grid`] a sparse
//! [`BrickGrid`]; both take an optional exact [`Field`] for the Hermite data. With
//! [`DualOptions::error`] the meshing is adaptive (Ju et al. 2002's octree simplification): cells are merged
//! into octree nodes where one vertex serves them within the bound and the topology stays
//! (`merge.rs`), so flat parts get few large triangles. The result is
//! an [`isokit_field::TriMesh`] in world units, triangles counter-clockwise seen from
//! outside, with the same classification as [`crate::meshing`]: a sample is inside when
//! `value < iso` (NaN and `iso` itself are outside), and with
//! [`DualOptions::close_boundary`] the grid is padded with one layer of outside samples.
//!
//! ## Method
//! - **Hermite data** (Ju et al. 2002, Sec. 2): on every grid edge whose two samples lie on
//!   different sides, a crossing point and a unit normal. From samples alone the point is the
//!   linear interpolation of the two samples and the normal the linear interpolation of the
//!   central-difference gradients at the two nodes. With an exact field, the crossing is
//!   refined on the field itself (Illinois false position from the edge's two ends, a few
//!   steps; kept on the samples' crossing when the field does not bracket it) and the normal
//!   is the field's gradient there: this is what puts vertices on edges and corners. An edge
//!   into the padding beyond the grid crosses at its in-grid node, normal along the axis,
//!   so the closing caps lie in the boundary faces as with marching cubes.
//! - **One vertex per surface component of a cell**: the components are the loops that
//!   marching cubes traces in the cell ([`crate::meshing`], with its asymptotic decider on
//!   ambiguous faces), so a cell that the surface crosses twice (a wall thinner than a cell,
//!   two surfaces within a cell) gets two vertices, one for each (vertex splitting as in
//!   Schaefer, Ju and Warren 2007, "Manifold Dual Contouring", Sec. 3, and Nielson 2004,
//!   "Dual Marching Cubes"; without their octree simplification). Each vertex is the
//!   minimiser of the quadratic error function `E(x) = Σ (nᵢ · (x − pᵢ))²` over the
//!   crossings of its loop, solved relative to their mass point `c` by the pseudo-inverse
//!   of `AᵀA` with singular values (of `A`) below [`DualOptions::truncation`] of the largest
//!   dropped (Lindstrom 2000, "Out-of-core simplification of large polygonal models",
//!   Sec. 3; Ju et al. 2002, Sec. 2.3): on a flat piece the vertex is the mass point moved
//!   onto the plane, on an edge it is on the edge nearest the mass point, at a corner it is
//!   the corner. Where that minimiser lies outside the cell, the coordinates it violates
//!   are fixed on the cell's faces and the others re-solved (an active-set step), and the
//!   result is clamped to the cell; on an edge (two planes) whose line crosses the cell, the
//!   point of the line inside the cell nearest the minimiser is taken instead. With an
//!   exact field, an edge whose line misses the cell by less than half a cell puts the
//!   vertex on the line beyond the cell where that folds nothing (`beyond`).
//! - **One quad per crossed edge**, joining the vertices (of the loops holding that edge)
//!   of the four cells around it,
//!   split into two triangles along its shorter diagonal and oriented so that the edge's
//!   inside sample is behind it (the marching-cubes convention of [`crate::meshing`]).
//! - **Chamfers split** (`sharpen`): with an exact field, after the mesh is made, a mesh
//!   edge or triangle that still cuts across a sharp edge or corner of the surface (a vertex
//!   on one face joined to the other face's, where the edge clips a cell whose crossings see
//!   one face) is split at a vertex on the edge or corner (the feature point of Kobbelt et
//!   al. 2001, "Feature Sensitive Surface Extraction from Volume Data"), a tent over a
//!   concave corner is flipped, and a vertex left off the surface (clamped into its cell)
//!   moves onto it or onto the corner its edges miss; each change only where it neither
//!   folds, nor comes within 0.05 cell of another vertex, nor crosses another triangle.
//!   Counted in [`DualStats::sharpened_edges`] and [`DualStats::moved_vertices`].
//!
//! ## Guarantees and limits
//! Before the chamfers are split, the mesh is the dual of the marching-cubes polygon mesh (a
//! vertex per loop, a quad per marching-cubes vertex), which is closed, 2-manifold and
//! oriented: so the dual mesh is closed and consistently oriented, and every edge borders
//! exactly two quads; edge splits, triangle splits, flips to an edge that does not exist
//! and vertex moves keep that. One case
//! needs care: an ambiguous cell face whose two segments belong to one loop in *both* cells
//! (the case `crate::meshing` describes under *Triangulation*; in random noise about one
//! face in a hundred) would give the edge joining the two cells' vertices four quads. Such
//! a face's segments are paired the other way (the asymptotic decider's choice reversed, in
//! both cells), which splits the loop in two in each cell, so each segment gets its own
//! vertices; splitting never joins other segments, so one pass over those faces leaves
//! none. Two loops of one cell never share a position (a second vertex that would moves to
//! its loop's mass point of crossings), so merging coincident vertices pinches nothing: the
//! mesh is 2-manifold at every vertex too (tests: random noise, random CSG trees).
//!
//! Vertices clamped into their cells or on edges of planes can make quads fold, so triangles
//! may intersect near features the lattice cannot resolve ([`crate::intersect`] finds them
//! exactly; vertices are kept 1/1024 of a cell inside their cells, so vertices of different
//! cells never coincide and no quad collapses into a degenerate triangle; the vertices the
//! chamfer splits add or move leave their cells, and are kept 0.05 cell from every other
//! vertex near them). The folds are
//! checked and undone (`beyond`: moved vertices sent back, quads split along their other
//! diagonal, and last the vertices of quads still flagged sent to their mass points of
//! crossings, which gives up the feature there; a vertex on a sharp feature first only where
//! its quad crosses another, and when nothing else is left also where it faces the wrong
//! way); what remains is counted in
//! [`DualStats::folded_triangles`]. This is a check, not a construction: where the rounds
//! run out everything is taken back, and crossings would remain. Measured (`isokit-scene`'s
//! `tests/dual.rs` and `tests/scene_cli.rs`): no intersecting pair on 14 random CSG trees at
//! resolution 40 (2 trees and 19 pairs without the checks, 3 pairs with moves and flips
//! alone), on the shipped scenes (`demo.json`, a faceted trefoil mesh blended into a sphere,
//! 88 pairs without the checks) and on a box, a box minus a cylinder and two boxes (one
//! rotated 30°); no degenerate triangle; on the shipped scenes no triangle facing the wrong
//! way (16 of 50,248 on the random trees, where thin capsules and tori are not resolved).
//! Crossings refined on the field are exact to about f32 rounding; normals are the field's
//! gradient (analytic or finite differences). Vertices are not shared across cells, so a
//! vertex of one component never serves another.

use glam::{DVec3, Vec3};
use isokit_field::{BrickGrid, Field, Grid, Job, TriMesh};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::meshing::MeshingError;

mod beyond;
mod merge;
mod sharpen;

/// Options of [`mesh_dual_grid`] and [`mesh_dual_brick_grid`].
///
/// ```
/// use isokit_levelset::dual::DualOptions;
/// let o = DualOptions::default();
/// assert_eq!((o.iso, o.truncation, o.refine_steps, o.error), (0.0, 0.1, 12, None));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualOptions {
    /// The isovalue: the surface is `f = iso`, inside where `f < iso`. Default 0.
    pub iso: f32,
    /// Close surfaces that reach the grid's boundary, as if the grid were padded with
    /// outside samples (the caps lie in the boundary faces). Default `true`.
    pub close_boundary: bool,
    /// Relative threshold of the QEF's rank truncation: singular values of the normal
    /// matrix below this fraction of the largest are dropped. In `[0, 1)`; default 0.1.
    pub truncation: f64,
    /// False-position steps that refine a crossing on the exact field, when one is given.
    /// Default 12.
    pub refine_steps: usize,
    /// Adaptive meshing: cells are merged into octree nodes of up to 256 cells a side where
    /// one vertex lies within this distance (world units) of the tangent plane of every
    /// crossing it replaces (and, with an exact field, of the surface), and the node's
    /// samples pass the topology test of Ju et al. 2002 (the docs of `dual/merge.rs`).
    /// `None` (the default), zero, negative or NaN: one vertex per cell.
    pub error: Option<f64>,
}

impl Default for DualOptions {
    fn default() -> Self {
        Self {
            iso: 0.0,
            close_boundary: true,
            truncation: 0.1,
            refine_steps: 12,
            error: None,
        }
    }
}

/// What [`mesh_dual_grid`] and [`mesh_dual_brick_grid`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DualStats {
    /// Crossed edges (one quad each).
    pub edges: usize,
    /// Crossed cells.
    pub cells: usize,
    /// Vertices: one per surface component of each crossed cell (adaptive: those the merged
    /// mesh uses).
    pub vertices: usize,
    /// Cells whose free QEF minimiser lay outside the cell (solved again on the cell's faces
    /// and clamped into it).
    pub clamped: usize,
    /// Cells the surface crosses in more than one piece (marching-cubes loops), each given
    /// a vertex per piece.
    pub multi_component_cells: usize,
    /// Crossings where the exact field did not bracket the samples' crossing (kept on the
    /// samples' crossing).
    pub unrefined: usize,
    /// Vertices placed on a sharp edge just beyond their cell, where their cell holds both
    /// of the edge's faces but not the edge (with an exact field; kept where they fold
    /// nothing).
    pub beyond_cell: usize,
    /// Adaptive meshing ([`DualOptions::error`]): crossed cells whose vertex was replaced by
    /// that of a merged octree node.
    pub merged_cells: usize,
    /// Adaptive meshing: polygons that remained more than once after the fine quads' copies
    /// were counted with their orientation (0 when the result is 2-manifold there).
    pub repeated_polygons: usize,
    /// Triangles that still face the wrong way (against their crossing's normal and the
    /// exact field's gradient), are degenerate or intersect another triangle after the
    /// checks undid what they could (`beyond`; when adaptive, also after the merges of their
    /// nodes were taken back, at most 16 rounds).
    pub folded_triangles: usize,
    /// With an exact field: mesh edges and triangles that cut across a sharp edge or corner
    /// of the surface (their midpoint or centroid off the surface, their ends on different
    /// faces) split at a vertex on it, and mesh edges flipped where the quad's other diagonal
    /// lies on the surface.
    pub sharpened_edges: usize,
    /// With an exact field: vertices moved onto the surface (more than 0.05 cell off it), or
    /// onto a corner or edge of it within 0.75 cell that their edges cut.
    pub moved_vertices: usize,
}

/// Dual contouring of a dense grid (see the [module](self) docs). With `field`, the Hermite
/// data come from the exact field (which should agree with the samples' signs); without,
/// from the samples.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, primitives::Cuboid, sample_into};
/// use isokit_levelset::dual::{DualOptions, mesh_dual_grid};
///
/// let h = 0.1;
/// let mut grid = Grid::new([21, 21, 21], Vec3::splat(-1.0), h).unwrap();
/// let cube = Cuboid::new(Vec3::splat(0.013), Vec3::splat(0.52)).unwrap();
/// sample_into(&cube, &mut grid);
/// let (mesh, _) = mesh_dual_grid(&grid, Some(&cube), &DualOptions::default()).unwrap();
/// let r = mesh.validate();
/// assert!(r.watertight && r.consistently_oriented);
/// // The corners are reproduced.
/// let corner = Vec3::splat(0.533);
/// assert!(mesh.positions.iter().any(|p| p.distance(corner) < 1e-4));
/// ```
pub fn mesh_dual_grid(
    grid: &Grid,
    field: Option<&dyn Field>,
    opts: &DualOptions,
) -> Result<(TriMesh, DualStats), MeshingError> {
    mesh_dual_grid_job(grid, field, opts, &Job::new())
}

/// [`mesh_dual_grid`] reporting its progress to `job` (stages `meshing (crossed edges)`, in
/// slabs of the lattice, and `meshing (vertices)`, in crossed cells; adaptive, also
/// `meshing (merging cells)`, in octree levels, and `meshing (checking merged polygons)`, in
/// rounds) and stopping with [`MeshingError::Cancelled`] once the job is cancelled.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, Job, primitives::Sphere, sample_into};
/// use isokit_levelset::dual::{DualOptions, mesh_dual_grid_job};
/// use isokit_levelset::meshing::MeshingError;
/// use std::sync::{Arc, Mutex};
///
/// let mut grid = Grid::new([24; 3], Vec3::splat(-1.0), 2.0 / 23.0).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
/// let stages = Arc::new(Mutex::new(Vec::new()));
/// let seen = stages.clone();
/// let job = Job::new().with_progress(move |stage, done, total| {
///     if done == total {
///         seen.lock().unwrap().push(stage.to_owned());
///     }
/// });
/// mesh_dual_grid_job(&grid, None, &DualOptions::default(), &job).unwrap();
/// let stages = stages.lock().unwrap();
/// assert!(stages.iter().any(|s| s == "meshing (crossed edges)"));
/// assert!(stages.iter().any(|s| s == "meshing (vertices)"));
///
/// job.cancel();
/// let err = mesh_dual_grid_job(&grid, None, &DualOptions::default(), &job);
/// assert!(matches!(err, Err(MeshingError::Cancelled(_))));
/// ```
pub fn mesh_dual_grid_job(
    grid: &Grid,
    field: Option<&dyn Field>,
    opts: &DualOptions,
    job: &Job,
) -> Result<(TriMesh, DualStats), MeshingError> {
    let data = grid.data();
    let [nx, ny, _] = grid.dims();
    mesh_dual_lattice_job(
        grid.dims(),
        grid.origin(),
        grid.spacing(),
        |i, j, k| data[i + nx * (j + ny * k)],
        field,
        opts,
        job,
    )
}

/// Dual contouring of a sparse brick grid, read through [`BrickGrid::get`] (absent bricks
/// read their background, whose sign must be right). Visits every cell's samples, but
/// computes Hermite data and vertices only where the surface is.
pub fn mesh_dual_brick_grid(
    grid: &BrickGrid,
    field: Option<&dyn Field>,
    opts: &DualOptions,
) -> Result<(TriMesh, DualStats), MeshingError> {
    mesh_dual_brick_grid_job(grid, field, opts, &Job::new())
}

/// [`mesh_dual_brick_grid`] reporting its progress to `job` and stopping once it is
/// cancelled, as [`mesh_dual_grid_job`] does.
pub fn mesh_dual_brick_grid_job(
    grid: &BrickGrid,
    field: Option<&dyn Field>,
    opts: &DualOptions,
    job: &Job,
) -> Result<(TriMesh, DualStats), MeshingError> {
    mesh_dual_lattice_job(
        grid.dims(),
        grid.origin(),
        grid.spacing(),
        |i, j, k| grid.get(i, j, k),
        field,
        opts,
        job,
    )
}

/// One crossed edge: its key, crossing point (world, f64) and unit normal.
#[derive(Clone, Copy)]
struct Hermite {
    key: u64,
    point: DVec3,
    normal: DVec3,
    /// Whether the edge's lower node is the inside one.
    lower_inside: bool,
}

/// The sampled lattice in padded node coordinates (`-1 ..= n` when closing).
struct Lattice<'a, S> {
    dims: [usize; 3],
    origin: DVec3,
    h: f64,
    iso: f32,
    close: bool,
    sample: S,
    field: Option<&'a dyn Field>,
    steps: usize,
}

impl<S: Fn(usize, usize, usize) -> f32 + Sync> Lattice<'_, S> {
    fn in_grid(&self, g: [i64; 3]) -> bool {
        (0..3).all(|a| g[a] >= 0 && g[a] < self.dims[a] as i64)
    }

    /// Node value; `+∞` in the padding.
    fn value(&self, g: [i64; 3]) -> f32 {
        if self.in_grid(g) {
            (self.sample)(g[0] as usize, g[1] as usize, g[2] as usize)
        } else {
            f32::INFINITY
        }
    }

    fn inside(&self, g: [i64; 3]) -> bool {
        self.value(g) < self.iso
    }

    /// Node range along axis `a` (inclusive).
    fn node_range(&self, a: usize) -> (i64, i64) {
        let n = self.dims[a] as i64;
        if self.close { (-1, n) } else { (0, n - 1) }
    }

    fn padded(&self) -> [u64; 3] {
        self.dims.map(|d| d as u64 + 2)
    }

    fn node_key(&self, g: [i64; 3]) -> u64 {
        let p = g.map(|v| (v + 1) as u64);
        let [nx, ny, _] = self.padded();
        p[0] + nx * (p[1] + ny * p[2])
    }

    /// The node of a key made by [`Lattice::node_key`].
    fn decode_node(&self, key: u64) -> [i64; 3] {
        let [px, py, _] = self.padded();
        [
            (key % px) as i64 - 1,
            ((key / px) % py) as i64 - 1,
            (key / (px * py)) as i64 - 1,
        ]
    }

    fn world(&self, g: DVec3) -> DVec3 {
        self.origin + self.h * g
    }

    /// Central-difference gradient of the samples at in-grid node `g` (one-sided at the
    /// boundary; finite samples only), in world units; zero when nothing is known.
    fn sample_gradient(&self, g: [i64; 3]) -> DVec3 {
        let mut out = DVec3::ZERO;
        let at = |q: [i64; 3]| {
            if self.in_grid(q) {
                let v = self.value(q);
                v.is_finite().then_some(v as f64)
            } else {
                None
            }
        };
        let Some(c) = at(g) else { return out };
        for a in 0..3 {
            let (mut lo, mut hi) = (g, g);
            lo[a] -= 1;
            hi[a] += 1;
            out[a] = match (at(lo), at(hi)) {
                (Some(l), Some(u)) => (u - l) / (2.0 * self.h),
                (Some(l), None) => (c - l) / self.h,
                (None, Some(u)) => (u - c) / self.h,
                (None, None) => 0.0,
            };
        }
        out
    }

    /// Hermite data of the edge along axis `a` from node `g`, whose ends lie on different
    /// sides; `bool` is true when the exact field did not bracket the crossing.
    fn hermite(&self, g: [i64; 3], a: usize) -> (Hermite, bool) {
        let mut g1 = g;
        g1[a] += 1;
        let lower_inside = self.inside(g);
        let key = self.node_key(g) * 3 + a as u64;
        let gp = |q: [i64; 3]| DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
        let mut axis = DVec3::ZERO;
        axis[a] = if lower_inside { 1.0 } else { -1.0 };
        // Into the padding: the crossing at the in-grid node, the normal along the axis.
        if !self.in_grid(g) || !self.in_grid(g1) {
            let node = if self.in_grid(g) { g } else { g1 };
            let h = Hermite {
                key,
                point: self.world(gp(node)),
                normal: axis,
                lower_inside,
            };
            return (h, false);
        }
        let (v0, v1) = (self.value(g) as f64, self.value(g1) as f64);
        let iso = self.iso as f64;
        let t = if v1.is_nan() || v0.is_nan() {
            0.5
        } else {
            match (v0.is_finite(), v1.is_finite()) {
                (true, true) => ((iso - v0) / (v1 - v0)).clamp(0.0, 1.0),
                (true, false) => 0.0,
                (false, true) => 1.0,
                (false, false) => 0.5,
            }
        };
        let (p0, p1) = (self.world(gp(g)), self.world(gp(g1)));
        let mut point = p0 + t * (p1 - p0);
        let mut normal = (1.0 - t) * self.sample_gradient(g) + t * self.sample_gradient(g1);
        let mut unrefined = false;
        if let Some(f) = self.field {
            match refine(f, p0, p1, self.iso, self.steps) {
                Some(p) => {
                    point = p;
                    normal = f.gradient(p.as_vec3()).as_dvec3();
                }
                None => unrefined = true,
            }
        }
        let normal = if normal.is_finite() && normal.length_squared() > 0.0 {
            normal.normalize()
        } else {
            axis
        };
        (
            Hermite {
                key,
                point,
                normal,
                lower_inside,
            },
            unrefined,
        )
    }
}

/// The crossing of `f = iso` on the segment `p0 .. p1` by Illinois false position, or `None`
/// when the field's values at the ends do not lie on different sides.
fn refine(f: &dyn Field, p0: DVec3, p1: DVec3, iso: f32, steps: usize) -> Option<DVec3> {
    let at = |t: f64| p0 + t * (p1 - p0);
    let val = |t: f64| f.value(at(t).as_vec3()) as f64 - iso as f64;
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let (mut fa, mut fb) = (val(a), val(b));
    if !(fa.is_finite() && fb.is_finite()) || (fa < 0.0) == (fb < 0.0) {
        return None;
    }
    let mut side = 0i8;
    for _ in 0..steps {
        let t = if fb != fa {
            (a * fb - b * fa) / (fb - fa)
        } else {
            0.5 * (a + b)
        };
        let t = if t > a && t < b { t } else { 0.5 * (a + b) };
        let ft = val(t);
        if !ft.is_finite() {
            break;
        }
        if ft == 0.0 {
            return Some(at(t));
        }
        if (ft < 0.0) == (fa < 0.0) {
            a = t;
            fa = ft;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        } else {
            b = t;
            fb = ft;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        }
    }
    // The end nearer the surface by the (possibly halved) values' interpolation.
    let t = if fb != fa {
        (a * fb - b * fa) / (fb - fa)
    } else {
        0.5 * (a + b)
    };
    Some(at(t.clamp(a, b)))
}

/// Minimiser of `Σ (nᵢ · (x − pᵢ))²` over the crossings, relative to their mass point, with
/// singular values of the normal matrix below `truncation` of the largest dropped.
#[cfg(test)]
fn solve_qef(points: &[DVec3], normals: &[DVec3], truncation: f64) -> DVec3 {
    solve_qef_fixed(points, normals, truncation, [None; 3])
}

/// [`solve_qef`] with some coordinates fixed (`Some(value)`): the minimiser over the free
/// ones, the truncation applied to the free block of the normal matrix.
fn solve_qef_fixed(
    points: &[DVec3],
    normals: &[DVec3],
    truncation: f64,
    fixed: [Option<f64>; 3],
) -> DVec3 {
    let n = points.len().max(1) as f64;
    let c = points.iter().copied().sum::<DVec3>() / n;
    // y = x − c; fixed coordinates of y are known.
    let mut y0 = DVec3::ZERO;
    for a in 0..3 {
        if let Some(v) = fixed[a] {
            y0[a] = v - c[a];
        }
    }
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for (p, nn) in points.iter().zip(normals) {
        let mut free = *nn;
        for a in 0..3 {
            if fixed[a].is_some() {
                free[a] = 0.0;
            }
        }
        let nv = Vector3::new(free.x, free.y, free.z);
        let d = nn.dot(*p - c) - nn.dot(y0);
        ata += nv * nv.transpose();
        atb += nv * d;
    }
    let svd = ata.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return c + y0;
    };
    // Singular values of AᵀA are the squares of those of A: truncate on A's.
    let smax = svd.singular_values.max().max(0.0).sqrt();
    let mut inv = Matrix3::<f64>::zeros();
    for i in 0..3 {
        let s = svd.singular_values[i].max(0.0).sqrt();
        if smax > 0.0 && s > truncation * smax {
            inv[(i, i)] = 1.0 / (s * s);
        }
    }
    let x = vt.transpose() * inv * u.transpose() * atb;
    let mut y = DVec3::new(x[0], x[1], x[2]);
    for a in 0..3 {
        if fixed[a].is_some() {
            y[a] = y0[a];
        }
    }
    let out = c + y;
    if out.is_finite() { out } else { c + y0 }
}

/// Distance from the surface (voxels, by the exact field) above which a cell's vertex is
/// improved.
const SURFACE_TOL: f64 = 0.01;

/// `Σ nᵢ nᵢᵀ`: the QEF's normal matrix `AᵀA` without fixed coordinates.
fn normal_matrix(normals: &[DVec3]) -> Matrix3<f64> {
    let mut ata = Matrix3::<f64>::zeros();
    for nn in normals {
        let nv = Vector3::new(nn.x, nn.y, nn.z);
        ata += nv * nv.transpose();
    }
    ata
}

/// Rank of the normals after truncation (how many independent planes the QEF sees: 1 on a
/// face, 2 on an edge, 3 at a corner).
fn qef_rank(normals: &[DVec3], truncation: f64) -> usize {
    let sv = normal_matrix(normals).singular_values();
    let smax = sv.max().max(0.0).sqrt();
    sv.iter()
        .filter(|&&v| smax > 0.0 && v.max(0.0).sqrt() > truncation * smax)
        .count()
}

/// The direction of the QEF's line of minimisers where the normals span exactly two
/// independent planes after truncation (an edge), or `None`.
fn qef_line(normals: &[DVec3], truncation: f64) -> Option<DVec3> {
    let svd = normal_matrix(normals).svd(false, true);
    let vt = svd.v_t?;
    let smax = svd.singular_values.max().max(0.0).sqrt();
    let kept: Vec<usize> = (0..3)
        .filter(|&i| smax > 0.0 && svd.singular_values[i].max(0.0).sqrt() > truncation * smax)
        .collect();
    if kept.len() != 2 {
        return None;
    }
    let i = (0..3).find(|i| !kept.contains(i))?;
    let d = DVec3::new(vt[(i, 0)], vt[(i, 1)], vt[(i, 2)]);
    (d.is_finite() && d.length_squared() > 0.5).then(|| d.normalize())
}

/// The crossings (indices) grouped by plane: a normal within 20° of a group's first joins
/// it.
fn plane_groups(normals: &[DVec3]) -> Vec<Vec<usize>> {
    let c = 20f64.to_radians().cos();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, n) in normals.iter().enumerate() {
        match groups.iter_mut().find(|g| normals[g[0]].dot(*n) >= c) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    groups
}

/// Crossing normals further apart than this (degrees) make a cell's vertex a sharp feature's
/// for the fold checks (`beyond`); smooth surfaces turn by a few degrees per cell.
const SHARP_DEGREES: f64 = 30.0;

/// Whether two of the normals are more than [`SHARP_DEGREES`] apart.
fn sharp(normals: &[DVec3]) -> bool {
    let c = SHARP_DEGREES.to_radians().cos();
    normals
        .iter()
        .enumerate()
        .any(|(i, a)| normals[i + 1..].iter().any(|b| a.dot(*b) < c))
}

/// Largest plane residual `|nᵢ · (x − pᵢ)|` of the crossings at `x`.
fn residual(points: &[DVec3], normals: &[DVec3], x: DVec3) -> f64 {
    points
        .iter()
        .zip(normals)
        .map(|(p, n)| n.dot(x - *p).abs())
        .fold(0.0, f64::max)
}

/// The QEF minimiser kept in the unit cell `[0, 1]³` (cell units): where the free minimiser
/// leaves the cell, the coordinates it violates are fixed at the cell's faces and the rest
/// re-solved (an active-set step, at most three times), then clamped. Returns the point and
/// whether the free minimiser was outside.
fn solve_in_cell(points: &[DVec3], normals: &[DVec3], truncation: f64) -> (DVec3, bool) {
    let inside = |x: DVec3| (0..3).all(|a| (0.0..=1.0).contains(&x[a]));
    let mut fixed = [None; 3];
    let mut x = solve_qef_fixed(points, normals, truncation, fixed);
    if inside(x) {
        return (x, false);
    }
    // Two planes (an edge): every point of their line minimises the QEF, and the minimiser
    // nearest the mass point may lie outside while the line crosses the cell near one of its
    // corners. The point of the line inside the cell nearest that minimiser is as good a
    // minimiser; the active-set step below would leave the line.
    if let Some(d) = qef_line(normals, truncation) {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d[a].abs() > 1e-12 {
                let (t0, t1) = ((0.0 - x[a]) / d[a], (1.0 - x[a]) / d[a]);
                lo = lo.max(t0.min(t1));
                hi = hi.min(t0.max(t1));
            } else if !(0.0..=1.0).contains(&x[a]) {
                hi = f64::NEG_INFINITY;
            }
        }
        if lo <= hi {
            let y = x + 0.0f64.clamp(lo, hi) * d;
            return (y.clamp(DVec3::ZERO, DVec3::ONE), false);
        }
    }
    for _ in 0..3 {
        let mut changed = false;
        for a in 0..3 {
            if fixed[a].is_none() && !(0.0..=1.0).contains(&x[a]) {
                fixed[a] = Some(x[a].clamp(0.0, 1.0));
                changed = true;
            }
        }
        if !changed {
            break;
        }
        x = solve_qef_fixed(points, normals, truncation, fixed);
        if inside(x) {
            break;
        }
    }
    (x.clamp(DVec3::ZERO, DVec3::ONE), true)
}

/// Where the crossings span two planes (an edge) whose line misses the cell: the point of
/// the line nearest the unit cell, and then the point of the line nearest `x` (the vertex
/// clamped into the cell), each when it lies within `reach` (cell units) of the cell.
fn edge_near_cell(
    points: &[DVec3],
    normals: &[DVec3],
    truncation: f64,
    reach: f64,
    x: DVec3,
) -> [Option<DVec3>; 2] {
    let Some(d) = qef_line(normals, truncation) else {
        return [None; 2];
    };
    let x0 = solve_qef_fixed(points, normals, truncation, [None; 3]);
    let dist = |t: f64| {
        let p = x0 + t * d;
        (p - p.clamp(DVec3::ZERO, DVec3::ONE)).length()
    };
    // The distance to a convex box along a line is convex in t: golden-section search over
    // the stretch of line near the cell.
    let (mut a, mut b) = (
        -(x0 - DVec3::splat(0.5)).length() - 2.0,
        (x0 - DVec3::splat(0.5)).length() + 2.0,
    );
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (c, e) = (b - g * (b - a), a + g * (b - a));
        if dist(c) <= dist(e) {
            b = e;
        } else {
            a = c;
        }
    }
    let t = 0.5 * (a + b);
    let s = d.dot(x - x0);
    [
        (dist(t) <= reach).then(|| x0 + t * d),
        (dist(s) <= reach && (s - t).abs() > 0.05).then(|| x0 + s * d),
    ]
}

/// Edge `q` of a cell (12): axis `q / 4`, offsets along the other two axes.
fn cell_edge(cell: [i64; 3], q: usize) -> ([i64; 3], usize) {
    let a = q / 4;
    let mut g = cell;
    g[(a + 1) % 3] += (q & 1) as i64;
    g[(a + 2) % 3] += ((q >> 1) & 1) as i64;
    (g, a)
}

/// Bytes the meshing holds per crossed edge: its Hermite data, up to four cell keys before
/// they are deduplicated, a share of a cell's vertices, and the two triangles of its quad.
const BYTES_PER_EDGE: u64 = (std::mem::size_of::<(Hermite, bool)>()
    + 4 * std::mem::size_of::<u64>()
    + std::mem::size_of::<CellVerts>()
    + 2 * std::mem::size_of::<[u32; 3]>()) as u64;

/// The vertices of one crossed cell.
struct CellVerts {
    /// One per surface component (loop), with whether its QEF minimiser was clamped.
    verts: Vec<(Vec3, bool)>,
    /// Loop (local vertex) of each of the 12 cube edges.
    of_edge: [u8; 12],
    several: bool,
    /// Per loop, points on an edge beyond the cell ([`beyond`]; a first and a second
    /// choice), where the vertex (in `verts`, clamped into the cell) could not lie on both
    /// planes.
    beyond: [Option<(Vec3, Option<Vec3>)>; 4],
    /// A vertex clamped or on a sharp feature, or several vertices: the mesh can fold here.
    suspect: bool,
    /// Per vertex, its loop's mass point of crossings (inside the cell), the place of last
    /// resort for a vertex whose quads fold ([`beyond`]), and whether its crossings hold a
    /// sharp feature.
    smooth: Vec<(Vec3, bool)>,
}

/// The crossed edge with this key, from the sorted crossed edges.
fn find_edge(edges: &[Hermite], key: u64) -> Option<&Hermite> {
    edges
        .binary_search_by_key(&key, |h| h.key)
        .ok()
        .map(|i| &edges[i])
}

impl<S: Fn(usize, usize, usize) -> f32 + Sync> Lattice<'_, S> {
    /// The crossed edges of one z slab of nodes, in key order; `bool` as in
    /// [`Lattice::hermite`].
    fn slab_edges(&self, z: i64, r: &[(i64, i64); 3]) -> Vec<(Hermite, bool)> {
        let mut out = Vec::new();
        for y in r[1].0..=r[1].1 {
            for x in r[0].0..=r[0].1 {
                let g = [x, y, z];
                let ins = self.inside(g);
                for a in 0..3 {
                    if g[a] + 1 > r[a].1 {
                        continue;
                    }
                    let mut g1 = g;
                    g1[a] += 1;
                    if self.inside(g1) != ins {
                        out.push(self.hermite(g, a));
                    }
                }
            }
        }
        out
    }

    /// The samples at a cell's eight corners and its inside mask (bit n: corner n).
    fn corners(&self, cell: [i64; 3]) -> ([f32; 8], u8) {
        let mut values = [0f32; 8];
        let mut mask = 0u8;
        for (n, v) in values.iter_mut().enumerate() {
            let g = [
                cell[0] + (n & 1) as i64,
                cell[1] + ((n >> 1) & 1) as i64,
                cell[2] + ((n >> 2) & 1) as i64,
            ];
            *v = self.value(g);
            if *v < self.iso {
                mask |= 1 << n;
            }
        }
        (values, mask)
    }

    /// The ambiguous faces (bit f) whose two segments belong to one loop of the cell, with
    /// the faces in `flip` decided the other way.
    fn faces_in_one_loop(&self, cell: [i64; 3], flip: u8) -> u8 {
        let (values, mask) = self.corners(cell);
        let loops = crate::meshing::cell_loops_flipped(&values, mask, self.iso, flip);
        crate::meshing::faces_in_one_loop(&loops, mask)
    }

    /// `p` moved onto the exact surface by Newton steps along the field's gradient, where
    /// there is an exact field and the steps converge within a cell of `p` (`p` otherwise),
    /// and kept inside `cell` as its vertices are.
    fn onto_surface_in(&self, cell: [i64; 3], p: Vec3) -> Vec3 {
        let lo = self.world(DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64));
        let inset = DVec3::splat(self.h / 1024.0);
        let (lo, hi) = (lo + inset, lo + DVec3::splat(self.h) - inset);
        let p = p.as_dvec3();
        let newton = self
            .field
            .and_then(|f| newton_onto(f, self.iso, p, self.h, SURFACE_TOL));
        let x = newton.unwrap_or(p).clamp(lo, hi).as_vec3();
        x.clamp(lo.as_vec3(), hi.as_vec3())
    }

    /// A vertex per surface component of the crossed cell (per marching-cubes loop of the
    /// cell, with the face decisions of `crate::meshing`, reversed on the faces in `flip`).
    fn cell_vertices(
        &self,
        cell: [i64; 3],
        r: &[(i64, i64); 3],
        edges: &[Hermite],
        truncation: f64,
        flip: u8,
    ) -> CellVerts {
        let (values, mask) = self.corners(cell);
        let loops = crate::meshing::cell_loops_flipped(&values, mask, self.iso, flip);
        let lo = self.world(DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64));
        // Vertices stay 1/1024 of a cell inside their cell (as marching cubes keeps its
        // vertices off the nodes): two cells' vertices never coincide, even where both are
        // clamped onto their common face, so no quad collapses into a degenerate triangle.
        let inset = DVec3::splat(self.h / 1024.0);
        let (lo_in, hi_in) = (lo + inset, lo + DVec3::splat(self.h) - inset);
        let mut of_edge = [0u8; 12];
        let mut verts = Vec::with_capacity(loops.count);
        let mut smooth = Vec::with_capacity(loops.count);
        // Each loop's mass point of crossings (world units), for two loops' vertices that
        // would coincide.
        let mut mass = [DVec3::ZERO; 4];
        let mut beyond = [None; 4];
        // A vertex clamped into the cell, on a sharp feature (two or three planes at more
        // than `SHARP_DEGREES`) or on an edge of planes, or several vertices: where the mesh
        // can fold.
        let mut suspect = loops.count > 1;
        let mut at = 0;
        for l in 0..loops.count.max(1) {
            let len = if loops.count == 0 {
                0
            } else {
                loops.len[l] as usize
            };
            let mut pts = [DVec3::ZERO; 12];
            let mut nrm = [DVec3::ZERO; 12];
            let mut m = 0;
            for &q in &loops.edges[at..at + len] {
                of_edge[q as usize] = l as u8;
                let (g, a) = cell_edge(cell, q as usize);
                if let Some(h) = find_edge(edges, self.node_key(g) * 3 + a as u64) {
                    // Solved in cell units about the cell's corner, for conditioning.
                    pts[m] = (h.point - lo) / self.h;
                    nrm[m] = h.normal;
                    m += 1;
                }
            }
            at += len;
            if m == 0 {
                // No loop traced (cannot happen for a crossed cell): the cell's centre.
                let centre = (lo + 0.5 * self.h * DVec3::ONE).as_vec3();
                verts.push((centre, false));
                smooth.push((centre, false));
                continue;
            }
            mass[l.min(3)] = lo + self.h * pts[..m].iter().sum::<DVec3>() / m as f64;
            let c = mass[l.min(3)].clamp(lo_in, hi_in).as_vec3();
            let (mut x, clamped) = solve_in_cell(&pts[..m], &nrm[..m], truncation);
            smooth.push((c.clamp(lo_in.as_vec3(), hi_in.as_vec3()), sharp(&nrm[..m])));
            // An edge whose corner lies in this cell while the third face crosses only the
            // neighbours' edges (rank 2), or, with an exact field, a vertex off the surface:
            // the crossings of the neighbouring cells are added, and their minimiser kept
            // where all their planes meet in one corner inside this cell and it is no
            // farther from the surface.
            let off = |x: DVec3| {
                self.field.map_or(0.0, |f| {
                    let v = f.value((lo + self.h * x).as_vec3()) as f64 - self.iso as f64;
                    if v.is_finite() {
                        v.abs() / self.h
                    } else {
                        f64::INFINITY
                    }
                })
            };
            let before = off(x);
            let rank = qef_rank(&nrm[..m], truncation);
            // Clamped, on a sharp feature (or a thin wall's opposite normals), or solved on
            // an edge or corner of planes (rank 2 or 3 after truncation, planes more than
            // about 11° apart at the default: a mesh operand's facets meet at such angles
            // without being sharp, and a vertex on their edge can lie anywhere in the cell).
            suspect |= clamped || sharp(&nrm[..m]) || rank >= 2;
            let try_neighbours = match self.field {
                Some(_) => (rank == 2 && !clamped) || (before > SURFACE_TOL && rank >= 2),
                None => rank == 2 && !clamped,
            };
            if try_neighbours {
                let (mut more_p, mut more_n) = (pts[..m].to_vec(), nrm[..m].to_vec());
                for dz in -1..=2 {
                    for dy in -1..=2 {
                        for dx in -1..=2 {
                            let g = [cell[0] + dx, cell[1] + dy, cell[2] + dz];
                            let o = [dx, dy, dz];
                            for a in 0..3 {
                                let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                                // The cell's own edges are in already.
                                let own =
                                    o[a] == 0 && (0..=1).contains(&o[b]) && (0..=1).contains(&o[c]);
                                let in_range = (0..3).all(|i| {
                                    let top = g[i] + (i == a) as i64;
                                    g[i] >= r[i].0 && top <= r[i].1
                                });
                                if o[a] == 2 || own || !in_range {
                                    continue;
                                }
                                if let Some(h) = find_edge(edges, self.node_key(g) * 3 + a as u64) {
                                    more_p.push((h.point - lo) / self.h);
                                    more_n.push(h.normal);
                                }
                            }
                        }
                    }
                }
                if qef_rank(&more_n, truncation) == 3 {
                    let y = solve_qef_fixed(&more_p, &more_n, truncation, [None; 3]);
                    let inside = (0..3).all(|a| (0.0..=1.0).contains(&y[a]));
                    if inside
                        && residual(&more_p, &more_n, y) < 1e-3
                        && off(y) <= before.max(SURFACE_TOL)
                    {
                        x = y;
                    }
                }
            }
            // Both planes of an edge whose line misses the cell: the edge's point nearest
            // the cell, when it is near and on the surface (`beyond`).
            if self.field.is_some() && clamped && rank == 2 && off(x) > SURFACE_TOL && l < 4 {
                let on = edge_near_cell(&pts[..m], &nrm[..m], truncation, 0.5, x)
                    .map(|y| y.filter(|y| off(*y) <= SURFACE_TOL));
                let w = |y: DVec3| (lo + self.h * y).as_vec3();
                beyond[l] = match on {
                    [Some(a), b] => Some((w(a), b.map(w))),
                    [None, Some(b)] => Some((w(b), None)),
                    [None, None] => None,
                };
            }
            // Three planes or more whose corner is not on the surface near the cell (a plane
            // of the crossings passes by without meeting the others there): the edge of two of
            // the planes that is, on the same terms.
            if self.field.is_some() && clamped && rank == 3 && off(x) > SURFACE_TOL && l < 4 {
                let groups = plane_groups(&nrm[..m]);
                // Every pair's edge points near the cell and on the surface, nearest the
                // surface first; an edge through the cell itself, on the surface, first of all
                // (the vertex stays in its cell).
                let mut found: Vec<(f64, DVec3)> = Vec::new();
                let mut through: Option<(f64, DVec3)> = None;
                for (i, gi) in groups.iter().enumerate() {
                    for gj in &groups[i + 1..] {
                        let (mut p2, mut n2) = ([DVec3::ZERO; 12], [DVec3::ZERO; 12]);
                        let mut k = 0;
                        for &c in gi.iter().chain(gj) {
                            p2[k] = pts[c];
                            n2[k] = nrm[c];
                            k += 1;
                        }
                        let (y, outside) = solve_in_cell(&p2[..k], &n2[..k], truncation);
                        let e = off(y);
                        if !outside
                            && residual(&p2[..k], &n2[..k], y) < 1e-3
                            && e <= SURFACE_TOL
                            && through.is_none_or(|t| e < t.0)
                        {
                            through = Some((e, y));
                        }
                        for y in edge_near_cell(&p2[..k], &n2[..k], truncation, 0.5, x)
                            .into_iter()
                            .flatten()
                        {
                            let e = off(y);
                            if e <= SURFACE_TOL {
                                found.push((e, y));
                            }
                        }
                    }
                }
                found.sort_by(|a, b| a.0.total_cmp(&b.0));
                let w = |y: DVec3| (lo + self.h * y).as_vec3();
                if let Some((_, y)) = through {
                    x = y;
                } else if let Some(&(_, y)) = found.first() {
                    beyond[l] = Some((w(y), found.get(1).map(|f| w(f.1))));
                }
            }
            let v = (lo + self.h * x).clamp(lo_in, hi_in).as_vec3();
            // f32 rounding must not put it back onto the cell's boundary.
            let v = v.clamp(lo_in.as_vec3(), hi_in.as_vec3());
            verts.push((v, clamped));
        }
        // Two surface components of one cell must not share a position (both clamped into
        // the same corner, or, without an exact field, the same minimiser): merging
        // coincident vertices would pinch them together. The later one moves to its loop's
        // mass point of crossings, which lies inside the cell on its own crossings' side.
        for j in 1..verts.len() {
            if (0..j).any(|i| verts[i].0 == verts[j].0) {
                let v = mass[j.min(3)].clamp(lo_in, hi_in).as_vec3();
                verts[j].0 = v.clamp(lo_in.as_vec3(), hi_in.as_vec3());
            }
        }
        CellVerts {
            verts,
            of_edge,
            several: loops.count > 1,
            beyond,
            suspect,
            smooth,
        }
    }
}

/// Dual contouring of samples given by a function on a lattice of `dims` nodes from
/// `origin`, `spacing` apart: `sample(i, j, k)` is the value at node (i, j, k). The lattice
/// is never stored (only the crossed edges and their cells are), so it serves sources that
/// hold their samples in another form, such as the leaves of a hashed octree; every node is
/// read a few times, so `sample` should be cheap. As [`mesh_dual_grid_job`] otherwise.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Field, Job, primitives::Sphere};
/// use isokit_levelset::dual::{DualOptions, mesh_dual_lattice_job};
///
/// let s = Sphere::new(Vec3::ZERO, 0.7).unwrap();
/// let (n, h) = (24, 2.0 / 23.0);
/// let at = |i: usize, j: usize, k: usize| {
///     s.value(Vec3::splat(-1.0) + h * Vec3::new(i as f32, j as f32, k as f32))
/// };
/// let (m, _) = mesh_dual_lattice_job([n; 3], Vec3::splat(-1.0), h, at, Some(&s),
///     &DualOptions::default(), &Job::default()).unwrap();
/// assert!(m.validate().watertight);
/// ```
pub fn mesh_dual_lattice_job(
    dims: [usize; 3],
    origin: Vec3,
    spacing: f32,
    sample: impl Fn(usize, usize, usize) -> f32 + Sync,
    field: Option<&dyn Field>,
    opts: &DualOptions,
    job: &Job,
) -> Result<(TriMesh, DualStats), MeshingError> {
    if !opts.iso.is_finite() {
        return Err(MeshingError::BadIso(opts.iso));
    }
    if dims.iter().any(|&d| d < 2) {
        return Err(MeshingError::GridTooSmall { dims });
    }
    if !(spacing.is_finite() && spacing > 0.0 && origin.is_finite()) {
        return Err(MeshingError::BadLattice(format!(
            "origin {origin} and spacing {spacing} must be finite, the spacing positive"
        )));
    }
    // Node keys number the padded lattice's nodes times three axes in a u64.
    let keys = dims
        .iter()
        .try_fold(3u64, |n, &d| n.checked_mul(d as u64 + 2));
    if keys.is_none() {
        return Err(MeshingError::BadLattice(format!(
            "{dims:?} nodes are more than a mesh's keys can number"
        )));
    }
    let lat = Lattice {
        dims,
        origin: origin.as_dvec3(),
        h: spacing as f64,
        iso: opts.iso,
        close: opts.close_boundary,
        sample,
        field,
        steps: opts.refine_steps,
    };
    let truncation = if opts.truncation.is_finite() {
        opts.truncation.clamp(0.0, 0.999)
    } else {
        0.1
    };
    let r = [0, 1, 2].map(|a| lat.node_range(a));
    // Pass 1: the crossed edges, slab by slab (sorted by key). What the meshing will hold is
    // counted as the slabs are made, against the memory budget: a surface too large (noise)
    // stops the meshing once it has used the budget, not when the allocator gives up.
    let budget = isokit_field::memory::budget();
    let held = AtomicU64::new(0);
    let slab_counter = job.counter("meshing (crossed edges)", (r[2].1 - r[2].0 + 1) as u64);
    let slabs: Vec<Vec<(Hermite, bool)>> = (r[2].0..=r[2].1)
        .into_par_iter()
        .map(|z| {
            if held.load(Ordering::Relaxed) > budget || job.is_cancelled() {
                return Vec::new();
            }
            let out = lat.slab_edges(z, &r);
            held.fetch_add(out.len() as u64 * BYTES_PER_EDGE, Ordering::Relaxed);
            slab_counter.advance(1);
            out
        })
        .collect();
    job.check()?;
    let held = held.into_inner();
    if held > budget {
        isokit_field::memory::check_within(
            budget,
            &format!(
                "the dual-contoured mesh of the isosurface (of {} x {} x {} samples)",
                dims[0], dims[1], dims[2]
            ),
            held as u128,
            "mesh a coarser grid, or raise the budget",
        )?;
    }
    let unrefined = slabs.iter().flatten().filter(|h| h.1).count();
    let edges: Vec<Hermite> = slabs.into_iter().flatten().map(|h| h.0).collect();
    // The cells around each crossed edge (those inside the cell range).
    let cell_lo = [0, 1, 2].map(|a| r[a].0);
    let cell_hi = [0, 1, 2].map(|a| r[a].1 - 1);
    let decode = |key: u64| lat.decode_node(key);
    let around = |h: &Hermite| -> [Option<[i64; 3]>; 4] {
        let g = decode(h.key / 3);
        let a = (h.key % 3) as usize;
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        // Counter-clockwise about +a: (−,−), (+,−), (+,+), (−,+) in (b, c).
        [(-1, -1), (0, -1), (0, 0), (-1, 0)].map(|(db, dc)| {
            let mut cell = g;
            cell[b] += db;
            cell[c] += dc;
            (0..3)
                .all(|i| cell[i] >= cell_lo[i] && cell[i] <= cell_hi[i])
                .then_some(cell)
        })
    };
    let mut cells: Vec<u64> = edges
        .par_iter()
        .flat_map_iter(|h| around(h).into_iter().flatten().map(|c| lat.node_key(c)))
        .collect();
    cells.par_sort_unstable();
    cells.dedup();
    let limit = u32::MAX as usize;
    if cells.len() > limit || 2 * edges.len() > limit {
        return Err(MeshingError::TooLarge {
            vertices: cells.len(),
            triangles: 2 * edges.len(),
            limit,
        });
    }
    // Faces decided the other way. Where an ambiguous face's two segments belong to one loop
    // in both cells sharing it, each cell would give both segments one vertex, and the edge
    // between the two vertices would carry the quads of all four crossed edges of the face
    // (a non-manifold edge). Pairing the face's segments the other way splits such a loop in
    // two in each cell (the loop a→b…c→d… becomes a→d… and c→b…), so each segment gets its
    // own pair of vertices. A split never joins other segments into one loop, so one pass
    // over the candidate faces, each tested again in the current state, leaves none.
    let candidates: Vec<u8> = cells
        .par_iter()
        .map(|&ck| lat.faces_in_one_loop(decode(ck), 0))
        .collect();
    let mut flips = vec![0u8; cells.len()];
    for (i, &ck) in cells.iter().enumerate() {
        // Upper faces (f = 2a + 1) only: each shared face once.
        for a in 0..3 {
            let f = 2 * a + 1;
            if candidates[i] >> f & 1 == 0 {
                continue;
            }
            let mut nb = decode(ck);
            nb[a] += 1;
            let Ok(j) = cells.binary_search(&lat.node_key(nb)) else {
                continue;
            };
            if candidates[j] >> (f - 1) & 1 == 0 {
                continue;
            }
            if lat.faces_in_one_loop(decode(ck), flips[i]) >> f & 1 == 1
                && lat.faces_in_one_loop(nb, flips[j]) >> (f - 1) & 1 == 1
            {
                flips[i] |= 1 << f;
                flips[j] |= 1 << (f - 1);
            }
        }
    }
    // Pass 2: a vertex per surface component of each crossed cell.
    let cell_counter = job.counter("meshing (vertices)", cells.len() as u64);
    let per_cell: Vec<CellVerts> = cells
        .par_iter()
        .zip(&flips)
        .map(|(&ck, &flip)| {
            if job.is_cancelled() {
                return CellVerts {
                    verts: Vec::new(),
                    of_edge: [0; 12],
                    several: false,
                    beyond: [None; 4],
                    suspect: false,
                    smooth: Vec::new(),
                };
            }
            let c = lat.cell_vertices(decode(ck), &r, &edges, truncation, flip);
            cell_counter.advance(1);
            c
        })
        .collect();
    job.check()?;
    let mut first = Vec::with_capacity(per_cell.len() + 1);
    let mut total = 0usize;
    for c in &per_cell {
        first.push(total as u32);
        total += c.verts.len();
    }
    if total > limit {
        return Err(MeshingError::TooLarge {
            vertices: total,
            triangles: 2 * edges.len(),
            limit,
        });
    }
    let mut positions: Vec<Vec3> = per_cell
        .iter()
        .flat_map(|c| c.verts.iter().map(|v| v.0))
        .collect();
    // The vertex of cell `c` on lattice edge (`g`, axis `a`).
    let vertex = |c: [i64; 3], g: [i64; 3], a: usize| -> Option<u32> {
        let i = cells.binary_search(&lat.node_key(c)).ok()?;
        let (b, cc) = ((a + 1) % 3, (a + 2) % 3);
        let q = 4 * a + (g[b] - c[b]) as usize + 2 * (g[cc] - c[cc]) as usize;
        Some(first[i] + per_cell[i].of_edge[q] as u32)
    };
    // Pass 3: a quad per crossed edge with all four cells, oriented so that the edge's
    // inside sample is behind it.
    let (quads, sources): (Vec<[u32; 4]>, Vec<u32>) = edges
        .par_iter()
        .enumerate()
        .filter_map(|(e, h)| {
            let g = decode(h.key / 3);
            let a = (h.key % 3) as usize;
            let mut quad = [0u32; 4];
            for (i, c) in around(h).iter().enumerate() {
                quad[i] = c.and_then(|c| vertex(c, g, a))?;
            }
            if !h.lower_inside {
                quad.reverse();
            }
            Some((quad, e as u32))
        })
        .unzip();
    let normals: Vec<Vec3> = sources
        .iter()
        .map(|&e| edges[e as usize].normal.as_vec3())
        .collect();
    // Vertices on edges beyond their cells, kept where they fold nothing.
    let mut moved = Vec::new();
    for (c, &f) in per_cell.iter().zip(&first) {
        for (l, p) in c.beyond.iter().enumerate() {
            if let Some((p, next)) = p {
                let vertex = f + l as u32;
                moved.push(beyond::Moved {
                    vertex,
                    in_cell: positions[vertex as usize],
                    next: *next,
                });
                positions[vertex as usize] = *p;
            }
        }
    }
    // The quads that can cross a folded one: each quad's triangles lie in the four cells
    // around its edge (or half a cell beyond, for a moved vertex), so two quads can cross
    // only where their cells are within two cells of each other. Quads near a suspect cell
    // are tested for intersections (`beyond`); elsewhere every vertex lies in its cell on
    // one plane of crossings and the mesh follows the marching-cubes surface, which does
    // not cross itself.
    // Each crossed cell's distance (in cells, the largest coordinate difference) to the
    // nearest such place, up to 2.
    let mut cell_reach = vec![u8::MAX; cells.len()];
    for (i, c) in per_cell.iter().enumerate() {
        if !(c.suspect || c.beyond.iter().any(Option::is_some)) {
            continue;
        }
        let g = decode(cells[i]);
        for dz in -2i64..=2 {
            for dy in -2i64..=2 {
                for dx in -2i64..=2 {
                    let nb = [g[0] + dx, g[1] + dy, g[2] + dz];
                    if (0..3).all(|a| nb[a] >= cell_lo[a] && nb[a] <= cell_hi[a]) {
                        if let Ok(j) = cells.binary_search(&lat.node_key(nb)) {
                            let d = dx.abs().max(dy.abs()).max(dz.abs()) as u8;
                            cell_reach[j] = cell_reach[j].min(d);
                        }
                    }
                }
            }
        }
    }
    let mut vertex_reach = vec![u8::MAX; positions.len()];
    for (i, c) in per_cell.iter().enumerate() {
        let f = first[i] as usize;
        vertex_reach[f..f + c.verts.len()]
            .iter_mut()
            .for_each(|v| *v = cell_reach[i]);
    }
    // Tested for crossings: quads with a cell within two cells of such a place. Free to take
    // their other diagonal: quads whose four cells are all within one cell of it, so that
    // every quad they could cross is tested.
    let near: Vec<bool> = quads
        .iter()
        .map(|q| q.iter().any(|&v| vertex_reach[v as usize] <= 2))
        .collect();
    let flippable: Vec<bool> = quads
        .iter()
        .map(|q| q.iter().all(|&v| vertex_reach[v as usize] <= 1))
        .collect();
    // Free to move to its mass point: a vertex of such a place itself (its quads' cells are
    // within one cell of it, so whatever they could cross is tested), where that moves it.
    let smooth: Vec<Option<beyond::Smooth>> = per_cell
        .iter()
        .zip(&first)
        .flat_map(|(c, &f)| {
            c.smooth
                .iter()
                .enumerate()
                .zip(&c.verts)
                .map(move |((l, &p), &(_, clamped))| (f as usize + l, p, clamped, c.several))
        })
        .map(|(v, (at, sharp), clamped, several)| {
            // A clamped vertex is off its feature already: it may move as a smooth one. Not
            // in a cell of several loops, whose vertices must keep apart.
            let sharp = sharp && !clamped;
            (vertex_reach[v] == 0 && !several && at != positions[v])
                .then_some(beyond::Smooth { at, sharp })
        })
        .collect();
    // Vertices whose crossings hold a sharp feature, clamped or not (a clamped one still
    // straddles it): their quads take the diagonal nearer the surface first.
    let feature: Vec<bool> = per_cell
        .iter()
        .flat_map(|c| c.smooth.iter().map(|s| s.1))
        .collect();
    let first_diagonals =
        beyond::first_diagonals(&quads, &positions, &flippable, &feature, lat.field, lat.iso);
    // The moved vertices and the quads' splits are settled first; when adaptive, the merged
    // polygons are then checked (and their folds undone) by the merging, which takes the
    // chosen splits of the quads it leaves unmerged.
    // A mass point moved onto the surface, in its vertex's cell.
    let onto = |v: u32, p: Vec3| {
        let i = first.partition_point(|&f| f <= v) - 1;
        lat.onto_surface_in(decode(cells[i]), p)
    };
    let checked = beyond::Checked {
        quads: &quads,
        normals: &normals,
        near: &near,
        flippable: &flippable,
        first: &first_diagonals,
    };
    let u = beyond::unfold(
        &mut positions,
        moved,
        checked,
        smooth,
        &onto,
        lat.field,
        job,
    )?;
    let mut a = match opts.error {
        Some(error) if error > 0.0 => {
            let m = merge::merge(
                &lat, &r, &cells, &per_cell, &first, positions, &edges, truncation, error, job,
            )?;
            merge::adaptive_polygons(m, &quads, &normals, &u.flipped, lat.field, job)?
        }
        _ => merge::AdaptiveMesh {
            positions,
            triangles: u.triangles,
            merged_cells: 0,
            repeated_polygons: 0,
            folded_triangles: u.folded,
            merged_vertex: Vec::new(),
        },
    };
    // Mesh edges and triangles that cut across a sharp edge or corner of the exact surface,
    // split on it; vertices off the surface moved onto it (not merged nodes' vertices, which
    // lie within the error bound of the surface by design).
    let changed = match lat.field {
        Some(field) => {
            let before = a.positions.len();
            let surface = sharpen::Surface {
                field,
                iso: lat.iso,
                h: lat.h,
            };
            let changed = sharpen::split_chamfers(
                &mut a.positions,
                &mut a.triangles,
                surface,
                &a.merged_vertex,
                job,
            )?;
            if a.positions.len() > before {
                (a.positions, a.triangles, _) =
                    compact(&a.positions, std::mem::take(&mut a.triangles));
            }
            changed
        }
        None => sharpen::Changed::default(),
    };
    let (positions, triangles) = (a.positions, a.triangles);
    let stats = DualStats {
        edges: edges.len(),
        cells: cells.len(),
        vertices: positions.len(),
        clamped: per_cell
            .iter()
            .flat_map(|c| c.verts.iter())
            .filter(|v| v.1)
            .count(),
        multi_component_cells: per_cell.iter().filter(|c| c.several).count(),
        unrefined,
        merged_cells: a.merged_cells,
        repeated_polygons: a.repeated_polygons,
        folded_triangles: a.folded_triangles,
        beyond_cell: u.beyond,
        sharpened_edges: changed.splits,
        moved_vertices: changed.moves,
    };
    Ok((TriMesh::new(positions, triangles), stats))
}

/// `p` moved onto the surface `f = iso` by four Newton steps along the field's gradient,
/// where they end within `tol` cells (of side `h`) of the surface and within a cell of `p`.
fn newton_onto(f: &dyn Field, iso: f32, p: DVec3, h: f64, tol: f64) -> Option<DVec3> {
    let off = |x: DVec3| f.value(x.as_vec3()) as f64 - iso as f64;
    let mut x = p;
    for _ in 0..4 {
        let g = f.gradient(x.as_vec3()).as_dvec3();
        let (v, gg) = (off(x), g.length_squared());
        if !(v.is_finite() && gg.is_finite() && gg > 1e-12) {
            return None;
        }
        x -= v / gg * g;
    }
    (off(x).abs() <= tol * h && x.distance(p) <= h).then_some(x)
}

/// The two triangles of a quad, split along its shorter diagonal.
fn split_quad(quad: [u32; 4], positions: &[Vec3]) -> [[u32; 3]; 2] {
    let p = quad.map(|v| positions[v as usize]);
    let [a, b, c, d] = quad;
    let (ac, bd) = (p[0].distance_squared(p[2]), p[1].distance_squared(p[3]));
    // Equal diagonals (symmetric flat quads): the one through the smaller vertex index, so
    // the choice does not depend on which vertex the quad is written from.
    if ac < bd || (ac == bd && a.min(c) < b.min(d)) {
        [[a, b, c], [a, c, d]]
    } else {
        [[a, b, d], [b, c, d]]
    }
}

/// The vertices the triangles use, renumbered in their order in `positions`, and the old
/// index of each kept vertex.
fn compact(positions: &[Vec3], triangles: Vec<[u32; 3]>) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<u32>) {
    let mut new = vec![u32::MAX; positions.len()];
    for t in &triangles {
        for &v in t {
            new[v as usize] = 0;
        }
    }
    let mut kept = Vec::new();
    for (i, n) in new.iter_mut().enumerate() {
        if *n == 0 {
            *n = kept.len() as u32;
            kept.push(i as u32);
        }
    }
    let out = kept.iter().map(|&i| positions[i as usize]).collect();
    let triangles = triangles
        .into_iter()
        .map(|t| t.map(|v| new[v as usize]))
        .collect();
    (out, triangles, kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qef_finds_planes_edges_and_corners() {
        let x = DVec3::X;
        let y = DVec3::Y;
        let z = DVec3::Z;
        // A corner at (0.3, 0.6, 0.2): three planes.
        let pts = [
            DVec3::new(0.3, 0.0, 0.0),
            DVec3::new(0.3, 1.0, 1.0),
            DVec3::new(0.0, 0.6, 0.0),
            DVec3::new(1.0, 0.6, 1.0),
            DVec3::new(0.0, 1.0, 0.2),
            DVec3::new(1.0, 0.0, 0.2),
        ];
        let nrm = [x, x, y, y, z, z];
        let v = solve_qef(&pts, &nrm, 0.1);
        assert!(v.distance(DVec3::new(0.3, 0.6, 0.2)) < 1e-12, "{v}");
        // One plane x = 0.3: the mass point moved onto it.
        let v = solve_qef(&pts[..2], &nrm[..2], 0.1);
        assert!(v.distance(DVec3::new(0.3, 0.5, 0.5)) < 1e-12, "{v}");
        // Nearly parallel normals are truncated to one plane.
        let tilt = DVec3::new(1.0, 0.01, 0.0).normalize();
        let v = solve_qef(&pts[..2], &[x, tilt], 0.1);
        assert!((v.x - 0.3).abs() < 0.01, "{v}");
    }

    #[test]
    fn minimiser_outside_the_cell_is_solved_on_its_faces() {
        // Planes x = 1.3 (tilted slightly) and y = 0.5: the edge leaves the cell.
        let nx = DVec3::new(1.0, 0.0, 0.05).normalize();
        let pts = [
            DVec3::new(1.3, 0.0, 0.2),
            DVec3::new(1.3, 1.0, 0.8),
            DVec3::new(0.0, 0.5, 0.4),
            DVec3::new(1.0, 0.5, 0.6),
        ];
        let nrm = [nx, nx, DVec3::Y, DVec3::Y];
        let free = solve_qef(&pts, &nrm, 0.1);
        assert!(free.x > 1.0, "{free}");
        let (v, outside) = solve_in_cell(&pts, &nrm, 0.1);
        assert!(outside);
        assert_eq!(v.x, 1.0);
        assert!((v.y - 0.5).abs() < 1e-12, "{v}");
        assert!((0.0..=1.0).contains(&v.z));
    }

    #[test]
    fn edge_through_a_corner_of_the_cell_keeps_its_vertex_on_the_edge() {
        // The edge x − y = 0.9, z = 0.5 crosses the cell only near its corner (1, 0, ·);
        // the crossings' mass point lies far along it, so the free minimiser violates x and
        // y at once. Fixing both faces would put the vertex at (1, 1, 0.5), 0.64 from the
        // first plane; the point of the edge inside the cell has no residual.
        let n1 = DVec3::new(1.0, -1.0, 0.0).normalize();
        let pts = [
            DVec3::new(2.9, 2.0, 0.3),
            DVec3::new(1.9, 1.0, 0.7),
            DVec3::new(1.5, 1.5, 0.5),
            DVec3::new(2.0, 0.6, 0.5),
        ];
        let nrm = [n1, n1, DVec3::Z, DVec3::Z];
        let free = solve_qef(&pts, &nrm, 0.1);
        assert!(free.x > 1.0 && free.y > 1.0, "{free}");
        let (v, outside) = solve_in_cell(&pts, &nrm, 0.1);
        assert!(!outside, "{v}");
        assert!(residual(&pts, &nrm, v) < 1e-12, "{v}");
        assert!(v.distance(DVec3::new(1.0, 0.1, 0.5)) < 1e-12, "{v}");
    }

    #[test]
    fn refinement_finds_the_crossing() {
        let s = isokit_field::primitives::Sphere::new(Vec3::ZERO, 0.5).unwrap();
        let p = refine(&s, DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0), 0.0, 12).unwrap();
        assert!((p.x - 0.5).abs() < 1e-6, "{p}");
        assert!(refine(&s, DVec3::ZERO, DVec3::new(0.2, 0.0, 0.0), 0.0, 12).is_none());
    }
}
