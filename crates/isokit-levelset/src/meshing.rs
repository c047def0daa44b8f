//! Isosurface meshing for export: watertight, 2-manifold triangle meshes of `f = iso`.
//!
//! [`mesh_grid`] meshes a dense [`Grid`], [`mesh_brick_grid`] a sparse [`BrickGrid`] (only
//! where the surface can be); both return an [`isokit_field::TriMesh`] in world coordinates,
//! triangles counter-clockwise seen from outside (outside = values at or above `iso`), ready
//! for `isokit_io::write_mesh`. [`mesh_volume`] and [`mesh_area`] measure the result.
//!
//! ## Method
//! Marching cubes whose polygons are *traced* rather than looked up in a case table:
//!
//! - **Classification.** A sample is inside when `value < iso` and outside otherwise, so a
//!   sample exactly at `iso` is outside and no sample is in two states. **NaN samples are
//!   outside** (`NaN < iso` is false); a crossing between an inside sample and a NaN sample
//!   sits at the middle of the edge.
//! - **Vertices**: one per crossed grid edge, shared by the (up to four) cells around the
//!   edge, at the linear interpolation of the two samples (clamped into the edge; computed
//!   in f64). A sample of exactly `iso` puts the crossings of its inside neighbours' edges at
//!   the sample itself, and an infinite sample (±∞) puts it at the finite end; see
//!   *Samples at the isovalue* for how such vertices are kept apart.
//! - **Faces.** On each face of a cell the crossings (0, 2 or 4) are joined by segments. A
//!   face with 4 crossings (inside samples on one diagonal, outside on the other) is resolved
//!   by the *asymptotic decider* on that face's four samples alone: the inside samples are
//!   joined across the face when the bilinear interpolant's saddle lies inside, i.e. when
//!   `(a − iso)(c − iso) > (b − iso)(d − iso)` for inside diagonal `a, c` and outside diagonal
//!   `b, d` (a saddle exactly at `iso` counts as outside, like a sample). The two cells
//!   sharing a face decide from the same four values, so they draw the same segments: the
//!   mesh has no cracks.
//! - **Loops.** Each crossed edge of a cell lies on exactly two of its faces and so has one
//!   segment on each; the segments chain into disjoint closed loops, oriented so that the
//!   outside is seen counter-clockwise. A vertex belongs to one loop per cell, so loops never
//!   touch each other.
//! - **Triangulation.** A loop of `n > 3` vertices is triangulated by dynamic programming
//!   over its triangulations, maximizing the smallest triangle quality (`2√3 · area / Σ
//!   edge²`, negative for a triangle facing against the loop's normal), with ties broken by
//!   the total. A diagonal between two vertices on the *same cell face* lies in that face,
//!   where the neighbouring cell could draw the same diagonal, and the edge would then
//!   belong to four triangles (this really happens, on ambiguous faces whose two segments
//!   belong to one loop in both cells: dozens of times in a random 12³ grid). Such a
//!   diagonal is drawn only by the cell *below* the face (the face at offset 1 along its
//!   axis); every other diagonal joins two edges of one cell only. When no triangulation
//!   obeys that rule (a few loops in a random 12³ grid, none on smooth fields in the tests),
//!   the loop is fanned around an added vertex at its centroid.
//!
//! Together: every mesh edge is shared by exactly two triangles with opposite directions,
//! and every vertex's link is a single cycle, whenever the surface does not reach the edge of
//! the grid.
//!
//! ## Samples at the isovalue
//! The classification above is a *simulation of simplicity* (Edelsbrunner and Mücke 1990):
//! a sample exactly at `iso` is treated as lying infinitesimally on the outside, so the
//! topology is that of a surface that passes just inside the node. The geometry follows the
//! same rule: every edge vertex is kept at least 1/1024 of a cell from both
//! end nodes of its edge, and, where f32 rounding would still put it on a node's
//! coordinate, one f32 step towards the edge's interior. Several edges that end at one node
//! (a surface through a lattice node, edge or face: a box face on the lattice) therefore
//! get distinct vertices, each in the open interior of its own edge. Three vertices of one
//! loop lie in the open interiors of three different edges of one cube, which no line
//! meets (a line meets a convex cell's boundary twice, or runs along one face, where it
//! meets two edges at most; a closing cap's vertices at boundary samples are corners of its
//! face, and the edge between two of them is not crossed): no triangle is degenerate, and no two vertices coincide, so
//! merging coincident vertices (as trimesh does on load) changes nothing and the mesh stays
//! watertight and 2-manifold. The price is a displacement of at most 1/1024 of a cell. (At
//! coordinates so far from the origin that f32 cannot resolve a step along an edge the
//! guarantee fails; a lattice of spacing `h` at distance `D` needs `D/h < 2^23`.)
//!
//! ## The grid boundary
//! A surface that reaches the grid's boundary is open there unless
//! [`MeshOptions::close_boundary`] (the default) is set: then the grid is treated as if
//! padded with one layer of outside samples (`+∞`), and the surface is capped by flat
//! polygons lying *in* the boundary faces of the grid (their vertices at the boundary
//! samples that are inside, and at the crossings between them). The mesh stays inside the
//! grid's bounds and is closed. A vertex at a boundary sample is shared by all the caps that
//! meet there (at the grid's edges and corners).
//!
//! ## Output order
//! Deterministic whatever the thread count: vertices are sorted by the grid edge they lie on
//! (z, then y, then x, then axis), triangles by block of cells and then by cell. The vertex
//! list of [`mesh_brick_grid`] equals that of [`mesh_grid`] on the expanded grid; triangles
//! are the same set (their order follows the blocks visited).
//!
//! ## Limits
//! The isovalue must be finite and every axis needs at least 2 samples
//! ([`MeshingError`]). Indices are u32: a mesh with more than `u32::MAX` vertices or
//! triangles is refused. The inside is the side *below* `iso`; for densities whose inside
//! lies above (CT-like), mesh the negated grid at `-iso`.

use glam::{DVec3, Vec3};
use isokit_field::TriMesh;
use isokit_field::{BrickGrid, Grid, Job};
use rayon::prelude::*;

/// Options of [`mesh_grid`] and [`mesh_brick_grid`].
///
/// ```
/// use isokit_levelset::meshing::MeshOptions;
/// let opts = MeshOptions { iso: 0.25, ..MeshOptions::default() };
/// assert!(opts.close_boundary);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshOptions {
    /// The isovalue: the surface is `f = iso`, inside where `f < iso`. Default 0.
    pub iso: f32,
    /// Close surfaces where they reach the grid's boundary, as if the grid were padded with
    /// outside samples; the caps lie in the boundary faces. Default `true`. With `false`,
    /// such surfaces are left open along the boundary.
    pub close_boundary: bool,
}

impl Default for MeshOptions {
    fn default() -> Self {
        Self {
            iso: 0.0,
            close_boundary: true,
        }
    }
}

/// What can go wrong when meshing.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum MeshingError {
    /// The isovalue is NaN or infinite.
    #[error("isovalue {0} must be finite")]
    BadIso(f32),
    /// An axis has fewer than 2 samples: there is no cell to mesh.
    #[error("grid of {dims:?} samples is too small to mesh: every axis needs at least 2 samples")]
    GridTooSmall {
        /// The grid's dimensions.
        dims: [usize; 3],
    },
    /// The mesh would not fit 32-bit indices.
    #[error(
        "the mesh would have {vertices} vertices and {triangles} triangles; at most {limit} of each fit 32-bit indices (coarsen the grid)"
    )]
    TooLarge {
        /// Vertices the mesh would have.
        vertices: usize,
        /// Triangles the mesh would have.
        triangles: usize,
        /// The limit for both (`u32::MAX`).
        limit: usize,
    },
    /// The mesh would not fit the memory budget ([`isokit_field::memory`]); found while
    /// meshing, before the pieces are welded.
    #[error(transparent)]
    OverBudget(#[from] isokit_field::FieldError),
    /// The meshing's [`Job`] was cancelled.
    #[error(transparent)]
    Cancelled(#[from] isokit_field::Cancelled),
    /// A lattice given by its sampling function
    /// ([`mesh_dual_lattice_job`](crate::dual::mesh_dual_lattice_job)) whose origin or
    /// spacing is not finite (and positive), or with more nodes than its keys can number.
    #[error("lattice: {0}")]
    BadLattice(String),
    /// A block of a lattice ([`mesh_lattice_block`]) that is empty, reaches beyond the
    /// lattice, or whose samples do not match it; or a lattice too large or with an origin
    /// or spacing that is not finite (and positive).
    #[error(
        "block of {owned:?} samples from {first:?}: not a block of the lattice of {dims:?} samples with its samples and the layer after"
    )]
    BadBlock {
        /// First sample of the block.
        first: [usize; 3],
        /// Samples the block owns.
        owned: [usize; 3],
        /// The lattice's dimensions.
        dims: [usize; 3],
    },
    /// A piece handed to [`weld_pieces`] that is not consistent.
    #[error("mesh piece: {0}")]
    BadPiece(String),
}

/// Bytes one piece holds while meshing and welding: a key and a position per vertex (twice,
/// sorted copy included) and a triangle (twice, remapped copy included).
fn piece_bytes(vertices: usize, triangles: usize) -> u64 {
    (vertices as u64) * 2 * (8 + 12) + (triangles as u64) * 2 * 12
}

/// Meshes the isosurface `f = opts.iso` of a dense grid (see the [module](self) docs for the
/// method and its guarantees). Positions are in world units: sample `(i, j, k)` at
/// `origin + spacing * (i, j, k)`. An empty mesh when no cell is crossed.
///
/// Runs in parallel over blocks of 16³ cells; the result does not depend on the thread
/// count.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, primitives::Sphere, sample_into};
/// use isokit_levelset::meshing::{MeshOptions, mesh_grid, mesh_volume};
///
/// let mut grid = Grid::new([32, 32, 32], Vec3::splat(-1.0), 2.0 / 31.0).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
/// let mesh = mesh_grid(&grid, &MeshOptions::default()).unwrap();
/// let report = mesh.validate();
/// assert!(report.watertight && report.consistently_oriented);
/// assert_eq!(report.genus(), Some(0));
/// let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.7f64.powi(3);
/// assert!((mesh_volume(&mesh) - exact).abs() < 0.01 * exact);
/// ```
pub fn mesh_grid(grid: &Grid, opts: &MeshOptions) -> Result<TriMesh, MeshingError> {
    mesh_grid_job(grid, opts, &Job::new())
}

/// [`mesh_grid`] reporting its progress to `job` (stage `meshing`, in blocks of 16³ cells)
/// and stopping with [`MeshingError::Cancelled`] once the job is cancelled.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, Job, primitives::Sphere, sample_into};
/// use isokit_levelset::meshing::{MeshOptions, MeshingError, mesh_grid_job};
/// use std::sync::{Arc, Mutex};
///
/// let mut grid = Grid::new([40, 40, 40], Vec3::splat(-1.0), 2.0 / 39.0).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
/// let last = Arc::new(Mutex::new((0, 0)));
/// let seen = last.clone();
/// let job = Job::new().with_progress(move |_, done, total| *seen.lock().unwrap() = (done, total));
/// mesh_grid_job(&grid, &MeshOptions::default(), &job).unwrap();
/// let (done, total) = *last.lock().unwrap();
/// assert!(total >= 27 && done == total); // at least 3 x 3 x 3 blocks of 16³ cells
///
/// job.cancel();
/// let err = mesh_grid_job(&grid, &MeshOptions::default(), &job);
/// assert!(matches!(err, Err(MeshingError::Cancelled(_))));
/// ```
pub fn mesh_grid_job(grid: &Grid, opts: &MeshOptions, job: &Job) -> Result<TriMesh, MeshingError> {
    mesh_grid_impl(grid, opts, true, job).map(|(mesh, _)| mesh)
}

/// Meshes the isosurface `f = opts.iso` of a sparse brick grid, visiting only the blocks of
/// cells that can hold the surface: those next to a stored brick whose samples straddle
/// `iso` (by its [`isokit_field::BrickInfo`] min/max; a brick that reads all inside but holds
/// a NaN counts as straddling), or where bricks (stored or absent, including absent bricks
/// that read as inside) or, with [`MeshOptions::close_boundary`], the outside padding beyond
/// the grid meet on different sides of `iso`. Cells across brick boundaries are covered.
///
/// The result has the same vertices (in the same order) and the same set of triangles as
/// [`mesh_grid`] of [`BrickGrid::to_grid`], without expanding the grid. Samples are read
/// with [`BrickGrid::get`].
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{BrickGrid, Grid, primitives::Sphere, sample_into};
/// use isokit_levelset::meshing::{MeshOptions, mesh_brick_grid, mesh_grid};
///
/// let h = 2.0 / 47.0;
/// let mut grid = Grid::new([48, 48, 48], Vec3::splat(-1.0), h).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
/// let bricks = BrickGrid::from_grid(&grid, 8, 1, 2.0 * h, 2.0 * h).unwrap();
/// let opts = MeshOptions::default();
/// let sparse = mesh_brick_grid(&bricks, &opts).unwrap();
/// let dense = mesh_grid(&bricks.to_grid().unwrap(), &opts).unwrap();
/// assert_eq!(sparse.positions, dense.positions);
/// assert_eq!(sparse.triangles.len(), dense.triangles.len());
/// assert!(sparse.validate().watertight);
/// ```
pub fn mesh_brick_grid(grid: &BrickGrid, opts: &MeshOptions) -> Result<TriMesh, MeshingError> {
    mesh_brick_grid_job(grid, opts, &Job::new())
}

/// [`mesh_brick_grid`] reporting its progress to `job` (stage `meshing`, in the blocks that
/// can hold the surface) and stopping with [`MeshingError::Cancelled`] once the job is
/// cancelled.
pub fn mesh_brick_grid_job(
    grid: &BrickGrid,
    opts: &MeshOptions,
    job: &Job,
) -> Result<TriMesh, MeshingError> {
    mesh_brick_grid_impl(grid, opts, true, job).map(|(mesh, _)| mesh)
}

/// One piece of the mesh of a lattice ([`mesh_lattice_block`]): its vertices keyed by what
/// they lie on in the whole lattice (an edge, a boundary sample, a cell's centroid), their
/// positions, and triangles in the piece's own indices. Pieces welded by key give the mesh
/// of the whole lattice ([`weld_pieces`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshPiece {
    /// Per vertex, its key in the whole lattice (equal keys are one vertex).
    pub keys: Vec<u64>,
    /// Per vertex, its position (computed from the whole lattice's origin and spacing).
    pub positions: Vec<Vec3>,
    /// Triangles, indices into this piece's vertices.
    pub triangles: Vec<[u32; 3]>,
}

/// Meshes the cells that belong to one block of a lattice of `dims` samples (sample
/// `(i, j, k)` at `origin + spacing · (i, j, k)`): the block owns the samples `first ..
/// first + owned` per axis and the cells whose lower corner is one of them (plus, with
/// [`MeshOptions::close_boundary`], the padding cells before the lattice's first sample and
/// at its last one, where the block touches them). `values` holds the samples `first ..
/// min(first + owned + 1, dims)` per axis, x fastest: the owned ones and the layer after.
///
/// Blocks that tile the lattice give pieces that [`weld_pieces`] joins into [`mesh_grid`]'s
/// mesh of the whole lattice: the same vertices in the same order and the same triangles
/// (per block, in another order), because each cell is meshed from its own corners and
/// every vertex's key and position come from the whole lattice. This is how a lattice
/// sampled in blocks on several machines is meshed without ever being held whole.
pub fn mesh_lattice_block(
    dims: [usize; 3],
    origin: Vec3,
    spacing: f32,
    first: [usize; 3],
    owned: [usize; 3],
    values: &[f32],
    opts: &MeshOptions,
) -> Result<MeshPiece, MeshingError> {
    let bad = || MeshingError::BadBlock { first, owned, dims };
    // The lattice itself: within the sample limit (so keys fit u64), a valid geometry.
    isokit_field::checked_len(dims).map_err(|_| bad())?;
    Grid::new([1, 1, 1], origin, spacing).map_err(|_| bad())?;
    let geo = Geometry::new(dims, origin, spacing, opts, true)?;
    let end: [usize; 3] = std::array::from_fn(|a| first[a].saturating_add(owned[a]));
    if (0..3).any(|a| owned[a] == 0 || end[a] > dims[a]) {
        return Err(bad());
    }
    let vdims: [usize; 3] = std::array::from_fn(|a| (end[a] + 1).min(dims[a]) - first[a]);
    if values.len() != vdims.iter().product::<usize>() {
        return Err(bad());
    }
    // Cells by lower corner: the owned samples', less the last sample's (no cell) unless
    // closing, plus the padding cell before the first sample when closing.
    let mut lo = [0i64; 3];
    let mut count = [0usize; 3];
    for a in 0..3 {
        let (clo, chi) = geo.cell_range(a);
        let l = (first[a] as i64).max(clo);
        let h = (end[a] as i64 - 1).min(chi);
        let l = if first[a] == 0 { clo } else { l };
        lo[a] = l;
        count[a] = (h - l + 1).max(0) as usize;
    }
    if count.contains(&0) {
        return Ok(MeshPiece::default());
    }
    // In sub-blocks of 16³ cells (as `mesh_grid`), in parallel, counted against the memory
    // budget as they are made.
    let s = DENSE_BLOCK;
    let nb = count.map(|c| c.div_ceil(s));
    let subs: Vec<[usize; 3]> = (0..nb.iter().product::<usize>())
        .map(|n| [n % nb[0], (n / nb[0]) % nb[1], n / (nb[0] * nb[1])])
        .collect();
    let budget = isokit_field::memory::budget();
    let held = std::sync::atomic::AtomicU64::new(0);
    let sample = |g: [i64; 3]| {
        if geo.in_grid(g) {
            let l = [0, 1, 2].map(|a| g[a] as usize - first[a]);
            values[l[0] + vdims[0] * (l[1] + vdims[1] * l[2])]
        } else {
            f32::INFINITY
        }
    };
    let pieces: Vec<BlockMesh> = subs
        .par_iter()
        .filter_map(|&b| {
            if held.load(std::sync::atomic::Ordering::Relaxed) > budget {
                return None;
            }
            let slo: [i64; 3] = std::array::from_fn(|a| lo[a] + (b[a] * s) as i64);
            let sc: [usize; 3] = std::array::from_fn(|a| s.min(count[a] - b[a] * s));
            let [sx, sy, sz] = sc.map(|n| n + 1);
            let mut gathered = Vec::with_capacity(sx * sy * sz);
            let (mut any_in, mut any_out) = (false, false);
            for z in 0..sz {
                for y in 0..sy {
                    for x in 0..sx {
                        let v = sample([slo[0] + x as i64, slo[1] + y as i64, slo[2] + z as i64]);
                        if v < geo.iso {
                            any_in = true;
                        } else {
                            any_out = true;
                        }
                        gathered.push(v);
                    }
                }
            }
            let p = (any_in && any_out).then(|| geo.mesh_block(slo, sc, &gathered))?;
            held.fetch_add(
                piece_bytes(p.positions.len(), p.triangles.len()),
                std::sync::atomic::Ordering::Relaxed,
            );
            Some(p)
        })
        .collect();
    let held = held.into_inner();
    if held > budget {
        isokit_field::memory::check_within(
            budget,
            &format!("the mesh of a block of {owned:?} samples"),
            held as u128,
            "use smaller blocks, or raise the budget",
        )?;
    }
    // One piece: the sub-blocks' vertices (shared ones repeated, welded later by key).
    let vertices: usize = pieces.iter().map(|p| p.keys.len()).sum();
    let triangles: usize = pieces.iter().map(|p| p.triangles.len()).sum();
    if vertices > u32::MAX as usize || triangles > u32::MAX as usize {
        return Err(MeshingError::TooLarge {
            vertices,
            triangles,
            limit: u32::MAX as usize,
        });
    }
    let mut out = MeshPiece::default();
    for p in pieces {
        let base = out.keys.len() as u32;
        out.keys.extend(p.keys);
        out.positions.extend(p.positions);
        out.triangles
            .extend(p.triangles.into_iter().map(|t| t.map(|i| i + base)));
    }
    Ok(out)
}

/// Welds pieces of one lattice's mesh ([`mesh_lattice_block`]) by key: vertices sorted by
/// key (as [`mesh_grid`] orders them), triangles concatenated in the pieces' order. A piece
/// whose keys and positions differ in number, or whose triangles index past its vertices,
/// is refused.
pub fn weld_pieces(pieces: Vec<MeshPiece>) -> Result<TriMesh, MeshingError> {
    for (n, p) in pieces.iter().enumerate() {
        let v = p.keys.len();
        if p.positions.len() != v || p.triangles.iter().flatten().any(|&i| i as usize >= v) {
            return Err(MeshingError::BadPiece(format!(
                "piece {n}: {v} keys, {} positions, triangles indexing up to {}",
                p.positions.len(),
                p.triangles
                    .iter()
                    .flatten()
                    .max()
                    .map_or(0, |&i| i as usize + 1)
            )));
        }
    }
    assemble(
        pieces
            .into_iter()
            .map(|p| BlockMesh {
                keys: p.keys,
                positions: p.positions,
                triangles: p.triangles,
                centroid_loops: 0,
            })
            .collect(),
    )
}

/// Signed volume enclosed by a mesh, by the divergence theorem (sum of the signed volumes
/// of the tetrahedra from the world origin to each triangle), accumulated in f64. Positive
/// for a closed mesh whose triangles are counter-clockwise seen from outside. For an open
/// mesh the value depends on the origin. Triangles with an out-of-range index are skipped.
///
/// ```
/// use glam::Vec3;
/// use isokit_field::TriMesh;
/// use isokit_levelset::meshing::{mesh_area, mesh_volume};
/// // A right tetrahedron with legs 1, faces counter-clockwise seen from outside.
/// let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
/// let t = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
/// let m = TriMesh::new(p, t);
/// assert!((mesh_volume(&m) - 1.0 / 6.0).abs() < 1e-12);
/// assert!((mesh_area(&m) - (1.5 + 3f64.sqrt() / 2.0)).abs() < 1e-12);
/// ```
pub fn mesh_volume(mesh: &TriMesh) -> f64 {
    mesh.triangles
        .iter()
        .filter_map(|t| corners(mesh, t))
        .map(|[a, b, c]| a.dot(b.cross(c)))
        .sum::<f64>()
        / 6.0
}

/// Total area of a mesh's triangles, accumulated in f64. Triangles with an out-of-range
/// index are skipped. See [`mesh_volume`] for an example.
pub fn mesh_area(mesh: &TriMesh) -> f64 {
    mesh.triangles
        .iter()
        .filter_map(|t| corners(mesh, t))
        .map(|[a, b, c]| 0.5 * (b - a).cross(c - a).length())
        .sum()
}

fn corners(mesh: &TriMesh, t: &[u32; 3]) -> Option<[DVec3; 3]> {
    let p = |i: u32| mesh.positions.get(i as usize).map(|v| v.as_dvec3());
    Some([p(t[0])?, p(t[1])?, p(t[2])?])
}

// ------------------------------------------------------------------ cube tables

/// Corner `n` of a cell sits at offset `(n & 1, (n >> 1) & 1, (n >> 2) & 1)`.
const fn corner_offset(n: usize) -> [usize; 3] {
    [n & 1, (n >> 1) & 1, (n >> 2) & 1]
}

const fn corner_at(o: [usize; 3]) -> usize {
    o[0] | (o[1] << 1) | (o[2] << 2)
}

/// Edge `e = 4a + q` runs along axis `a` from corner `edge_lo(e)`; bit 0 of `q` is the
/// offset along axis `(a + 1) % 3`, bit 1 along `(a + 2) % 3`.
const fn edge_lo(e: usize) -> usize {
    let a = e / 4;
    let mut o = [0; 3];
    o[(a + 1) % 3] = e & 1;
    o[(a + 2) % 3] = (e >> 1) & 1;
    corner_at(o)
}

/// The edge between two corners that differ along one axis.
const fn edge_between(c0: usize, c1: usize) -> usize {
    let lo = if c0 < c1 { c0 } else { c1 };
    let a = match c0 ^ c1 {
        1 => 0,
        2 => 1,
        _ => 2,
    };
    let o = corner_offset(lo);
    4 * a + o[(a + 1) % 3] + 2 * o[(a + 2) % 3]
}

/// Face `f = 2a + s` (normal along axis `a`, at offset `s`): its corners counter-clockwise
/// about the outward normal.
const FACE_CORNERS: [[usize; 4]; 6] = {
    let mut out = [[0; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let (a, s) = (f / 2, f % 2);
        let uv = if s == 1 {
            [[0, 0], [1, 0], [1, 1], [0, 1]]
        } else {
            [[0, 0], [0, 1], [1, 1], [1, 0]]
        };
        let mut i = 0;
        while i < 4 {
            let mut o = [0; 3];
            o[a] = s;
            o[(a + 1) % 3] = uv[i][0];
            o[(a + 2) % 3] = uv[i][1];
            out[f][i] = corner_at(o);
            i += 1;
        }
        f += 1;
    }
    out
};

/// Edge `i` of face `f` joins its corners `i` and `i + 1`.
const FACE_EDGES: [[usize; 4]; 6] = {
    let mut out = [[0; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            out[f][i] = edge_between(FACE_CORNERS[f][i], FACE_CORNERS[f][(i + 1) % 4]);
            i += 1;
        }
        f += 1;
    }
    out
};

/// Bit `f` set when edge `e` lies on face `f` (two bits per edge).
const EDGE_FACES: [u8; 12] = {
    let mut out = [0u8; 12];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            out[FACE_EDGES[f][i]] |= 1 << f;
            i += 1;
        }
        f += 1;
    }
    out
};

/// Faces `2a` (at offset 0 along their axis): a cell's lower faces, which are the upper
/// faces of its neighbours.
const LOWER_FACES: u8 = 0b01_0101;

// ------------------------------------------------------------------ one cell

/// The closed loops of one cell: `edges[..len[0]]` is the first loop, and so on.
pub(crate) struct Loops {
    pub(crate) edges: [u8; 12],
    pub(crate) len: [u8; 4],
    pub(crate) count: usize,
}

/// Whether the two inside samples of an ambiguous face (inside `a, c` on one diagonal,
/// outside `b, d` on the other) are joined across it: the asymptotic decider, symmetric in
/// the face's corner order so both cells sharing the face agree.
fn inside_joined(inside: [f32; 2], outside: [f32; 2], iso: f32) -> bool {
    let d = |v: f32| v as f64 - iso as f64;
    d(inside[0]) * d(inside[1]) > d(outside[0]) * d(outside[1])
}

/// Traces the loops of a cell with corner `values` and inside mask `mask` (bit n: corner n).
pub(crate) fn cell_loops(values: &[f32; 8], mask: u8, iso: f32) -> Loops {
    cell_loops_flipped(values, mask, iso, 0)
}

/// [`cell_loops`] with the asymptotic decider's choice reversed on the ambiguous faces whose
/// bit is set in `flip` (bit f: face f): the face's two segments are paired the other way.
/// Both cells sharing a face must be given the same choice.
pub(crate) fn cell_loops_flipped(values: &[f32; 8], mask: u8, iso: f32, flip: u8) -> Loops {
    let inside = |c: usize| mask >> c & 1 == 1;
    // next[e]: the edge that follows crossed edge e in its loop.
    let mut next = [u8::MAX; 12];
    for f in 0..6 {
        let c = FACE_CORNERS[f];
        let ins = c.map(inside);
        let crossings = (0..4).filter(|&i| ins[i] != ins[(i + 1) % 4]).count();
        // Edge i enters the inside (outside corner i, inside corner i + 1).
        let entering = |i: usize| !ins[i] && ins[(i + 1) % 4];
        match crossings {
            2 => {
                let from = (0..4).find(|&i| entering(i));
                let to = (0..4).find(|&i| ins[i] && !ins[(i + 1) % 4]);
                if let (Some(from), Some(to)) = (from, to) {
                    next[FACE_EDGES[f][from]] = FACE_EDGES[f][to] as u8;
                }
            }
            4 => {
                let (inn, out) = if ins[0] {
                    ([0, 2], [1, 3])
                } else {
                    ([1, 3], [0, 2])
                };
                let joined =
                    inside_joined(inn.map(|i| values[c[i]]), out.map(|i| values[c[i]]), iso)
                        ^ (flip >> f & 1 == 1);
                for i in (0..4).filter(|&i| entering(i)) {
                    // Separate: the segment goes round inside corner i + 1 to the edge after
                    // it; joined: it goes round outside corner i to the edge before.
                    let to = if joined { (i + 3) % 4 } else { (i + 1) % 4 };
                    next[FACE_EDGES[f][i]] = FACE_EDGES[f][to] as u8;
                }
            }
            _ => {}
        }
    }
    let mut loops = Loops {
        edges: [0; 12],
        len: [0; 4],
        count: 0,
    };
    let mut seen = 0u16;
    let mut n = 0;
    for start in 0..12 {
        if next[start] == u8::MAX || seen >> start & 1 == 1 || loops.count == 4 {
            continue;
        }
        let begin = n;
        let mut e = start;
        // A crossed edge always has a successor; the bound only guards the loop.
        while seen >> e & 1 == 0 && n < 12 {
            seen |= 1 << e;
            loops.edges[n] = e as u8;
            n += 1;
            e = next[e] as usize;
            if e >= 12 {
                break;
            }
        }
        loops.len[loops.count] = (n - begin) as u8;
        loops.count += 1;
    }
    loops
}

/// Bit f set where face f is ambiguous (its four edges crossed) and both of its segments
/// belong to one of the cell's `loops`.
pub(crate) fn faces_in_one_loop(loops: &Loops, mask: u8) -> u8 {
    let mut of_edge = [u8::MAX; 12];
    let mut at = 0;
    for l in 0..loops.count {
        let len = loops.len[l] as usize;
        for &e in &loops.edges[at..at + len] {
            of_edge[e as usize] = l as u8;
        }
        at += len;
    }
    let mut out = 0;
    for f in 0..6 {
        let ins = FACE_CORNERS[f].map(|c| mask >> c & 1 == 1);
        let ambiguous = ins[0] == ins[2] && ins[1] == ins[3] && ins[0] != ins[1];
        let l = FACE_EDGES[f].map(|e| of_edge[e]);
        if ambiguous && l[0] != u8::MAX && l.iter().all(|&x| x == l[0]) {
            out |= 1 << f;
        }
    }
    out
}

/// Crossing parameter from the inside sample `a` (`a < iso`) towards the outside sample `b`,
/// in `[0, 1]`.
pub(crate) fn crossing(a: f32, b: f32, iso: f32) -> f64 {
    let (a, b, iso) = (a as f64, b as f64, iso as f64);
    if b.is_nan() {
        return 0.5;
    }
    match (a.is_finite(), b.is_finite()) {
        (true, true) => ((iso - a) / (b - a)).clamp(0.0, 1.0),
        (true, false) => 0.0,
        (false, true) => 1.0,
        (false, false) => 0.5,
    }
}

/// Triangle quality `2√3 · area / Σ edge²` (1 for equilateral), negative when the triangle
/// faces against `normal`.
fn quality(a: Vec3, b: Vec3, c: Vec3, normal: Vec3) -> f32 {
    let cross = (b - a).cross(c - a);
    let sum = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if sum <= 0.0 {
        return 0.0;
    }
    let area2 = if normal == Vec3::ZERO {
        cross.length()
    } else {
        cross.dot(normal)
    };
    2.0 * 3f32.sqrt() * area2 / sum
}

/// Triangulates a loop (`n ≤ 12`, vertex ids `ids`, cell-local positions `pts`, cube edges
/// `edges`), appending to `out` in the loop's orientation. Maximizes the smallest quality,
/// then the total. With `constrain`, a diagonal between vertices on a common cell face is
/// used only when that face is the cell's upper face along its axis. Returns false
/// (appending nothing) when no triangulation qualifies.
fn triangulate(
    ids: &[u32],
    pts: &[Vec3],
    edges: &[u8],
    constrain: bool,
    out: &mut Vec<[u32; 3]>,
) -> bool {
    let n = ids.len();
    if n == 3 {
        out.push([ids[0], ids[1], ids[2]]);
        return true;
    }
    // Newell's normal of the loop.
    let normal = (0..n)
        .map(|i| pts[i].cross(pts[(i + 1) % n]))
        .sum::<Vec3>()
        .normalize_or_zero();
    let allowed = |i: usize, j: usize| {
        j == i + 1
            || (i == 0 && j == n - 1)
            || !constrain
            || EDGE_FACES[edges[i] as usize] & EDGE_FACES[edges[j] as usize] & LOWER_FACES == 0
    };
    // best[i][j]: (smallest quality, total quality) of the best triangulation of the
    // sub-polygon i..=j, and the apex k of the triangle on chord (i, j).
    let mut best = [[None::<(f32, f32, u8)>; 12]; 12];
    for i in 0..n - 1 {
        best[i][i + 1] = Some((f32::INFINITY, 0.0, 0));
    }
    for gap in 2..n {
        for i in 0..n - gap {
            let j = i + gap;
            if !allowed(i, j) {
                continue;
            }
            let mut chosen: Option<(f32, f32, u8)> = None;
            for k in i + 1..j {
                let (Some(l), Some(r)) = (best[i][k], best[k][j]) else {
                    continue;
                };
                let q = quality(pts[i], pts[k], pts[j], normal);
                let cand = (l.0.min(r.0).min(q), l.1 + r.1 + q, k as u8);
                let better = match chosen {
                    None => true,
                    Some(c) => cand.0 > c.0 || (cand.0 == c.0 && cand.1 > c.1),
                };
                if better {
                    chosen = Some(cand);
                }
            }
            best[i][j] = chosen;
        }
    }
    if best[0][n - 1].is_none() {
        return false;
    }
    let mut stack = [(0u8, 0u8); 12];
    stack[0] = (0, (n - 1) as u8);
    let mut top = 1;
    while top > 0 {
        top -= 1;
        let (i, j) = (stack[top].0 as usize, stack[top].1 as usize);
        if j <= i + 1 {
            continue;
        }
        let Some((_, _, k)) = best[i][j] else {
            continue;
        };
        let k = k as usize;
        out.push([ids[i], ids[k], ids[j]]);
        if top + 2 <= stack.len() {
            stack[top] = (i as u8, k as u8);
            stack[top + 1] = (k as u8, j as u8);
            top += 2;
        }
    }
    true
}

// ------------------------------------------------------------------ blocks

/// Smallest distance of an edge vertex from the edge's end nodes, in cell units: crossings
/// nearer a node (a sample at or next to the isovalue) are moved to it.
pub(crate) const NODE_GAP: f64 = 1.0 / 1024.0;

/// Cells are processed in cubic blocks of `DENSE_BLOCK` cells a side for dense grids.
const DENSE_BLOCK: usize = 16;
/// Largest block side for brick grids (blocks subdivide bricks).
const MAX_BRICK_BLOCK: usize = 16;

/// The sample grid being meshed, in padded node coordinates where needed.
struct Geometry {
    dims: [usize; 3],
    origin: DVec3,
    spacing: f64,
    iso: f32,
    close: bool,
    /// Draw diagonals in a cell face from the cell below it only (always, except in a test
    /// that shows why).
    constrain: bool,
}

/// Counters for tests and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Stats {
    /// Blocks whose samples were gathered.
    blocks_visited: usize,
    /// Blocks in the whole (padded) cell range.
    blocks_total: usize,
    /// Loops fanned around an added centroid vertex.
    centroid_loops: usize,
}

/// One block's piece of the mesh: vertices keyed by grid edge, triangles in local indices.
#[derive(Default)]
struct BlockMesh {
    keys: Vec<u64>,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    centroid_loops: usize,
}

impl Geometry {
    fn new(
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        opts: &MeshOptions,
        constrain: bool,
    ) -> Result<Self, MeshingError> {
        if !opts.iso.is_finite() {
            return Err(MeshingError::BadIso(opts.iso));
        }
        if dims.iter().any(|&d| d < 2) {
            return Err(MeshingError::GridTooSmall { dims });
        }
        Ok(Self {
            dims,
            origin: origin.as_dvec3(),
            spacing: spacing as f64,
            iso: opts.iso,
            close: opts.close_boundary,
            constrain,
        })
    }

    /// Inclusive range of cells (by lower corner) along axis `a`: with padding it starts
    /// one before the grid and ends at its last sample.
    fn cell_range(&self, a: usize) -> (i64, i64) {
        let n = self.dims[a] as i64;
        if self.close { (-1, n - 1) } else { (0, n - 2) }
    }

    /// Inclusive range of block coordinates along axis `a` for blocks of side `s`.
    fn block_range(&self, a: usize, s: usize) -> (i64, i64) {
        let (lo, hi) = self.cell_range(a);
        (lo.div_euclid(s as i64), hi.div_euclid(s as i64))
    }

    /// First cell and cell count of block `c` along axis `a`.
    fn block_cells(&self, c: i64, a: usize, s: usize) -> (i64, usize) {
        let (lo, hi) = self.cell_range(a);
        let first = (c * s as i64).max(lo);
        let last = (c * s as i64 + s as i64 - 1).min(hi);
        (first, (last - first + 1).max(0) as usize)
    }

    fn in_grid(&self, g: [i64; 3]) -> bool {
        (0..3).all(|a| g[a] >= 0 && g[a] < self.dims[a] as i64)
    }

    /// Key of a vertex: node index in the padded grid times 8, plus 0..3 for the edge along
    /// that axis, 3 for the vertex at a boundary sample (closing caps), 4.. for centroids.
    fn key(&self, g: [i64; 3], code: u64) -> u64 {
        let p = g.map(|v| (v + 1) as u64);
        let [nx, ny, _] = self.dims.map(|d| d as u64 + 2);
        (p[0] + nx * (p[1] + ny * p[2])) * 8 + code
    }

    fn world(&self, p: DVec3) -> Vec3 {
        (self.origin + self.spacing * p).as_vec3()
    }

    /// Coordinate `a` of node `g` in world units, rounded to f32 as vertices are.
    fn world_node(&self, g: [i64; 3], a: usize) -> f32 {
        (self.origin[a] + self.spacing * g[a] as f64) as f32
    }

    /// Meshes one block: cells from `first` with `count` cells per axis; `values` holds the
    /// `count + 1` samples per axis from `first` (x fastest, `+∞` beyond the grid).
    fn mesh_block(&self, first: [i64; 3], count: [usize; 3], values: &[f32]) -> BlockMesh {
        let [sx, sy, sz] = count.map(|c| c + 1);
        let node = |l: [usize; 3]| l[0] + sx * (l[1] + sy * l[2]);
        let mut slots = vec![u32::MAX; sx * sy * sz * 4];
        let mut out = BlockMesh::default();
        let iso = self.iso;
        let mut ids = [0u32; 12];
        let mut pts = [Vec3::ZERO; 12];
        let mut edges = [0u8; 12];
        for lz in 0..count[2] {
            for ly in 0..count[1] {
                for lx in 0..count[0] {
                    let cell = [lx, ly, lz];
                    let mut v = [0f32; 8];
                    let mut mask = 0u8;
                    for (n, vn) in v.iter_mut().enumerate() {
                        let o = corner_offset(n);
                        *vn = values[node([lx + o[0], ly + o[1], lz + o[2]])];
                        if *vn < iso {
                            mask |= 1 << n;
                        }
                    }
                    if mask == 0 || mask == 0xff {
                        continue;
                    }
                    let loops = cell_loops(&v, mask, iso);
                    let mut at = 0;
                    let mut centroids = 0u64;
                    for l in 0..loops.count {
                        let len = loops.len[l] as usize;
                        let mut m = 0;
                        for &e in &loops.edges[at..at + len] {
                            let (id, p) = self.edge_vertex(
                                first, cell, e as usize, &v, &mut slots, &node, &mut out,
                            );
                            // Welded cap vertices can repeat consecutively: keep one.
                            if m > 0 && ids[m - 1] == id {
                                continue;
                            }
                            ids[m] = id;
                            pts[m] = p;
                            edges[m] = e;
                            m += 1;
                        }
                        at += len;
                        while m > 1 && ids[m - 1] == ids[0] {
                            m -= 1;
                        }
                        if m < 3 {
                            continue;
                        }
                        if !triangulate(
                            &ids[..m],
                            &pts[..m],
                            &edges[..m],
                            self.constrain,
                            &mut out.triangles,
                        ) {
                            // Fan around an added vertex at the loop's centroid.
                            let g = [0, 1, 2].map(|a| first[a] + cell[a] as i64);
                            let centre = ids[..m]
                                .iter()
                                .map(|&i| out.positions[i as usize].as_dvec3())
                                .sum::<DVec3>()
                                / m as f64;
                            let c = out.positions.len() as u32;
                            out.keys.push(self.key(g, 4 + centroids));
                            out.positions.push(centre.as_vec3());
                            centroids += 1;
                            out.centroid_loops += 1;
                            for i in 0..m {
                                out.triangles.push([ids[i], ids[(i + 1) % m], c]);
                            }
                        }
                    }
                }
            }
        }
        out
    }

    /// The vertex on cube edge `e` of the cell at local `cell` (created on first use) and its
    /// position in cell units, for triangle quality.
    #[expect(clippy::too_many_arguments, reason = "the block's scratch state")]
    fn edge_vertex(
        &self,
        first: [i64; 3],
        cell: [usize; 3],
        e: usize,
        v: &[f32; 8],
        slots: &mut [u32],
        node: &impl Fn([usize; 3]) -> usize,
        out: &mut BlockMesh,
    ) -> (u32, Vec3) {
        let a = e / 4;
        let c0 = edge_lo(e);
        let c1 = c0 | (1 << a);
        let o0 = corner_offset(c0);
        let l0 = [0, 1, 2].map(|i| cell[i] + o0[i]);
        let g0 = [0, 1, 2].map(|i| first[i] + l0[i] as i64);
        let mut g1 = g0;
        g1[a] += 1;
        let mut l1 = l0;
        l1[a] += 1;
        let (pad0, pad1) = (!self.in_grid(g0), !self.in_grid(g1));
        let (slot, key, local, grid_pos) = if pad0 || pad1 {
            // A cap vertex at the boundary sample, shared by every cap that meets there.
            let (l, g, o) = if pad0 {
                (l1, g1, corner_offset(c1))
            } else {
                (l0, g0, o0)
            };
            (
                node(l) * 4 + 3,
                self.key(g, 3),
                Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32),
                DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64),
            )
        } else {
            let t = if v[c0] < self.iso {
                crossing(v[c0], v[c1], self.iso)
            } else {
                1.0 - crossing(v[c1], v[c0], self.iso)
            };
            // Kept off the edge's end nodes (see the module docs, "Samples at the
            // isovalue"), so that no two vertices coincide.
            let t = t.clamp(NODE_GAP, 1.0 - NODE_GAP);
            let mut lp = Vec3::new(o0[0] as f32, o0[1] as f32, o0[2] as f32);
            lp[a] += t as f32;
            let mut gp = DVec3::new(g0[0] as f64, g0[1] as f64, g0[2] as f64);
            gp[a] += t;
            (node(l0) * 4 + a, self.key(g0, a as u64), lp, gp)
        };
        if slots[slot] == u32::MAX {
            slots[slot] = out.positions.len() as u32;
            out.keys.push(key);
            let mut p = self.world(grid_pos);
            if !(pad0 || pad1) {
                p = crate::weld::off_nodes(p, a, self.world_node(g0, a), self.world_node(g1, a));
            }
            out.positions.push(p);
        }
        (slots[slot], local)
    }

    /// Gathers the samples of block `c` (side `s`) through `sample` (called in range only)
    /// and meshes it; `None` when no cell of it is crossed.
    fn run_block(
        &self,
        c: [i64; 3],
        s: usize,
        sample: &(impl Fn(usize, usize, usize) -> f32 + Sync),
    ) -> Option<BlockMesh> {
        let mut first = [0i64; 3];
        let mut count = [0usize; 3];
        for a in 0..3 {
            (first[a], count[a]) = self.block_cells(c[a], a, s);
        }
        if count.contains(&0) {
            return None;
        }
        let [sx, sy, sz] = count.map(|n| n + 1);
        let mut values = Vec::with_capacity(sx * sy * sz);
        let (mut any_in, mut any_out) = (false, false);
        for z in 0..sz {
            for y in 0..sy {
                for x in 0..sx {
                    let g = [
                        first[0] + x as i64,
                        first[1] + y as i64,
                        first[2] + z as i64,
                    ];
                    let v = if self.in_grid(g) {
                        sample(g[0] as usize, g[1] as usize, g[2] as usize)
                    } else {
                        f32::INFINITY
                    };
                    if v < self.iso {
                        any_in = true;
                    } else {
                        any_out = true;
                    }
                    values.push(v);
                }
            }
        }
        (any_in && any_out).then(|| self.mesh_block(first, count, &values))
    }

    /// Meshes the given blocks in parallel and welds the pieces.
    fn run(
        &self,
        blocks: &[[i64; 3]],
        s: usize,
        sample: impl Fn(usize, usize, usize) -> f32 + Sync,
        job: &Job,
    ) -> Result<(TriMesh, Stats), MeshingError> {
        // Pieces are counted as they are made, against the memory budget: a mesh too large
        // stops the meshing once it has used the budget, not when the allocator gives up.
        let budget = isokit_field::memory::budget();
        let held = std::sync::atomic::AtomicU64::new(0);
        let counter = job.counter("meshing", blocks.len() as u64);
        let pieces: Vec<BlockMesh> = blocks
            .par_iter()
            .filter_map(|&c| {
                if held.load(std::sync::atomic::Ordering::Relaxed) > budget || job.is_cancelled() {
                    return None;
                }
                let p = self.run_block(c, s, &sample);
                counter.advance(1);
                let p = p?;
                held.fetch_add(
                    piece_bytes(p.positions.len(), p.triangles.len()),
                    std::sync::atomic::Ordering::Relaxed,
                );
                Some(p)
            })
            .collect();
        job.check()?;
        let held = held.into_inner();
        if held > budget {
            let cells = blocks.len() as u128 * (s as u128).pow(3);
            isokit_field::memory::check_within(
                budget,
                &format!("the mesh of the isosurface (of up to {cells} cells)"),
                held as u128,
                "mesh a coarser grid, or raise the budget",
            )?;
        }
        let blocks_total = (0..3)
            .map(|a| {
                let (lo, hi) = self.block_range(a, s);
                (hi - lo + 1) as usize
            })
            .product();
        let stats = Stats {
            blocks_visited: blocks.len(),
            blocks_total,
            centroid_loops: pieces.iter().map(|p| p.centroid_loops).sum(),
        };
        Ok((assemble(pieces)?, stats))
    }

    /// Every block of the cell range, z slowest.
    fn all_blocks(&self, s: usize) -> Vec<[i64; 3]> {
        let r = [0, 1, 2].map(|a| self.block_range(a, s));
        let mut out = Vec::new();
        for z in r[2].0..=r[2].1 {
            for y in r[1].0..=r[1].1 {
                for x in r[0].0..=r[0].1 {
                    out.push([x, y, z]);
                }
            }
        }
        out
    }
}

/// Welds the blocks' vertices by key (sorted, so the order is deterministic) and
/// concatenates their triangles in block order.
fn assemble(pieces: Vec<BlockMesh>) -> Result<TriMesh, MeshingError> {
    let limit = u32::MAX as usize;
    let triangles: usize = pieces.iter().map(|p| p.triangles.len()).sum();
    let mut all: Vec<(u64, Vec3)> = pieces
        .iter()
        .flat_map(|p| p.keys.iter().copied().zip(p.positions.iter().copied()))
        .collect();
    all.par_sort_unstable_by_key(|&(k, _)| k);
    all.dedup_by_key(|&mut (k, _)| k);
    if all.len() > limit || triangles > limit {
        return Err(MeshingError::TooLarge {
            vertices: all.len(),
            triangles,
            limit,
        });
    }
    let keys: Vec<u64> = all.iter().map(|&(k, _)| k).collect();
    let positions: Vec<Vec3> = all.into_iter().map(|(_, p)| p).collect();
    let remapped: Vec<Vec<[u32; 3]>> = pieces
        .par_iter()
        .map(|p| {
            let map: Vec<u32> = p
                .keys
                .iter()
                .map(|k| keys.partition_point(|x| x < k) as u32)
                .collect();
            p.triangles
                .iter()
                .map(|t| t.map(|i| map[i as usize]))
                .collect()
        })
        .collect();
    Ok(TriMesh::new(positions, remapped.concat()))
}

fn mesh_grid_impl(
    grid: &Grid,
    opts: &MeshOptions,
    constrain: bool,
    job: &Job,
) -> Result<(TriMesh, Stats), MeshingError> {
    let geo = Geometry::new(grid.dims(), grid.origin(), grid.spacing(), opts, constrain)?;
    let blocks = geo.all_blocks(DENSE_BLOCK);
    let data = grid.data();
    let [nx, ny, _] = grid.dims();
    geo.run(
        &blocks,
        DENSE_BLOCK,
        |i, j, k| data[i + nx * (j + ny * k)],
        job,
    )
}

/// What a brick position reads as, for skipping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Inside,
    Outside,
    Mixed,
}

fn mesh_brick_grid_impl(
    grid: &BrickGrid,
    opts: &MeshOptions,
    constrain: bool,
    job: &Job,
) -> Result<(TriMesh, Stats), MeshingError> {
    let geo = Geometry::new(grid.dims(), grid.origin(), grid.spacing(), opts, constrain)?;
    let iso = opts.iso;
    let b = grid.brick_size();
    let s = b.min(MAX_BRICK_BLOCK);
    let bd = grid.brick_dims();
    let dims = grid.dims();
    let classify = |v: f32| {
        if v < iso {
            State::Inside
        } else {
            State::Outside
        }
    };
    // Brick positions, extended by one padding position on each side when closing (the
    // padding reads outside). A stored brick is uniform when its min/max say so (and, for
    // all-inside, it holds no NaN, which reads outside); an absent brick reads one value.
    let ext = geo.close as i64;
    let edims = bd.map(|d| d + 2 * ext as usize);
    let states: Vec<State> = (0..edims.iter().product::<usize>())
        .into_par_iter()
        .map(|n| {
            let p = [
                (n % edims[0]) as i64 - ext,
                ((n / edims[0]) % edims[1]) as i64 - ext,
                (n / (edims[0] * edims[1])) as i64 - ext,
            ];
            if (0..3).any(|a| p[a] < 0 || p[a] >= bd[a] as i64) {
                return State::Outside;
            }
            let c = p.map(|v| v as usize);
            match grid.brick_at(c) {
                Some(m) => {
                    let info = grid.bricks()[m];
                    if info.min >= iso {
                        State::Outside
                    } else if info.max < iso && !grid.brick_data(m).iter().any(|v| v.is_nan()) {
                        State::Inside
                    } else {
                        State::Mixed
                    }
                }
                None => classify(grid.get(c[0] * b, c[1] * b, c[2] * b)),
            }
        })
        .collect();
    let state_at = |p: [i64; 3]| {
        let q = [0, 1, 2].map(|a| (p[a] + ext) as usize);
        states[q[0] + edims[0] * (q[1] + edims[1] * q[2])]
    };
    // The brick position a node belongs to (padding positions -1 and bd).
    let node_brick = |x: i64, a: usize| {
        if x < 0 {
            -1
        } else if x >= dims[a] as i64 {
            bd[a] as i64
        } else {
            x / b as i64
        }
    };
    // Nodes of brick position p along axis a.
    let brick_nodes = |p: i64, a: usize| -> (i64, i64) {
        if p < 0 {
            (-1, -1)
        } else if p >= bd[a] as i64 {
            (dims[a] as i64, dims[a] as i64)
        } else {
            (
                p * b as i64,
                (p * b as i64 + b as i64 - 1).min(dims[a] as i64 - 1),
            )
        }
    };
    let default = classify(grid.background());
    let ranges = [0, 1, 2].map(|a| geo.block_range(a, s));
    // Candidate blocks: those whose samples reach a brick position that reads differently
    // from plain background.
    let mut candidates: Vec<[i64; 3]> = Vec::new();
    for (n, &st) in states.iter().enumerate() {
        if st == default {
            continue;
        }
        let p = [
            (n % edims[0]) as i64 - ext,
            ((n / edims[0]) % edims[1]) as i64 - ext,
            (n / (edims[0] * edims[1])) as i64 - ext,
        ];
        // Block c (cells c·s .. c·s + s − 1) reads nodes c·s ..= c·s + s.
        let nodes = [0, 1, 2].map(|a| brick_nodes(p[a], a));
        let r = [0, 1, 2].map(|a| {
            let (lo, hi) = nodes[a];
            let from = (lo - 1).div_euclid(s as i64).max(ranges[a].0);
            let to = hi.div_euclid(s as i64).min(ranges[a].1);
            (from, to)
        });
        // Blocks wholly inside a uniform brick (bricks larger than blocks) read one side.
        let within =
            |c: i64, a: usize| c * s as i64 >= nodes[a].0 && (c + 1) * s as i64 <= nodes[a].1;
        for z in r[2].0..=r[2].1 {
            for y in r[1].0..=r[1].1 {
                for x in r[0].0..=r[0].1 {
                    if st != State::Mixed && within(x, 0) && within(y, 1) && within(z, 2) {
                        continue;
                    }
                    candidates.push([x, y, z]);
                }
            }
        }
    }
    candidates.par_sort_unstable_by_key(|c| (c[2], c[1], c[0]));
    candidates.dedup();
    // Keep the blocks whose bricks do not all read one and the same side.
    candidates.retain(|&c| {
        let mut r = [(0i64, 0i64); 3];
        for (a, ra) in r.iter_mut().enumerate() {
            let (first, count) = geo.block_cells(c[a], a, s);
            *ra = (node_brick(first, a), node_brick(first + count as i64, a));
        }
        let mut seen: Option<State> = None;
        for z in r[2].0..=r[2].1 {
            for y in r[1].0..=r[1].1 {
                for x in r[0].0..=r[0].1 {
                    let st = state_at([x, y, z]);
                    if st == State::Mixed || seen.is_some_and(|q| q != st) {
                        return true;
                    }
                    seen = Some(st);
                }
            }
        }
        false
    });
    geo.run(&candidates, s, |i, j, k| grid.get(i, j, k), job)
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::rng::SplitMix64;

    #[test]
    fn tables_are_consistent() {
        for (e, faces) in EDGE_FACES.iter().enumerate() {
            // Every edge lies on two faces, which run along it in opposite directions.
            assert_eq!(faces.count_ones(), 2, "edge {e}");
            let mut dirs = Vec::new();
            for f in 0..6 {
                for i in 0..4 {
                    if FACE_EDGES[f][i] == e {
                        dirs.push((FACE_CORNERS[f][i], FACE_CORNERS[f][(i + 1) % 4]));
                    }
                }
            }
            assert_eq!(dirs.len(), 2);
            assert_eq!(dirs[0], (dirs[1].1, dirs[1].0), "edge {e}");
            let lo = edge_lo(e);
            assert_eq!(edge_between(lo, lo | 1 << (e / 4)), e);
        }
        // Outward orientation: (p1 − p0) × (p3 − p0) points along the face normal.
        for f in 0..6 {
            let p = FACE_CORNERS[f].map(|c| {
                let o = corner_offset(c);
                Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32)
            });
            let n = (p[1] - p[0]).cross(p[3] - p[0]);
            let mut want = Vec3::ZERO;
            want[f / 2] = if f % 2 == 1 { 1.0 } else { -1.0 };
            assert_eq!(n, want, "face {f}");
        }
    }

    /// Every one of the 254 mixed corner patterns gives loops that use each crossed edge
    /// exactly once, whatever the ambiguous faces decide.
    #[test]
    fn every_case_traces_closed_loops() {
        let mut rng = SplitMix64::new(7);
        for mask in 1u8..255 {
            for _ in 0..8 {
                let v: [f32; 8] = std::array::from_fn(|n| {
                    let m = rng.range(0.05, 1.0);
                    if mask >> n & 1 == 1 { -m } else { m }
                });
                let loops = cell_loops(&v, mask, 0.0);
                let total: usize = loops.len[..loops.count].iter().map(|&l| l as usize).sum();
                let crossed = (0..12)
                    .filter(|&e| {
                        let c0 = edge_lo(e);
                        (mask >> c0 & 1) != (mask >> (c0 | 1 << (e / 4)) & 1)
                    })
                    .count();
                assert_eq!(total, crossed, "mask {mask:#010b}");
                assert!(loops.len[..loops.count].iter().all(|&l| l >= 3));
                let mut used = [false; 12];
                for &e in &loops.edges[..total] {
                    assert!(!used[e as usize]);
                    used[e as usize] = true;
                }
            }
        }
    }

    #[test]
    fn decider_is_symmetric_and_ties_separate() {
        assert!(inside_joined([-2.0, -2.0], [1.0, 1.0], 0.0));
        assert!(!inside_joined([-1.0, -1.0], [2.0, 2.0], 0.0));
        assert!(!inside_joined([-1.0, -1.0], [1.0, 1.0], 0.0));
        assert!(!inside_joined([-1.0, -1.0], [f32::NAN, 1.0], 0.0));
        assert_eq!(
            inside_joined([-3.0, -0.5], [1.0, 1.2], 0.0),
            inside_joined([-0.5, -3.0], [1.2, 1.0], 0.0)
        );
    }

    #[test]
    fn crossing_stays_in_the_edge() {
        assert_eq!(crossing(-1.0, 1.0, 0.0), 0.5);
        assert_eq!(crossing(-1.0, 0.0, 0.0), 1.0);
        assert_eq!(crossing(-1.0, f32::INFINITY, 0.0), 0.0);
        assert_eq!(crossing(f32::NEG_INFINITY, 1.0, 0.0), 1.0);
        assert_eq!(crossing(-1.0, f32::NAN, 0.0), 0.5);
        assert_eq!(crossing(-f32::MAX, f32::MAX, 0.0), 0.5);
        let t = crossing(-1e-30, 3e38, 0.0);
        assert!((0.0..=1.0).contains(&t));
    }

    fn random_grid(seed: u64, n: usize) -> Grid {
        let mut rng = SplitMix64::new(seed);
        let data = (0..n * n * n).map(|_| rng.range(-1.0, 1.0)).collect();
        Grid::from_data([n; 3], Vec3::ZERO, 1.0, data).unwrap()
    }

    /// Edges used by more than two triangles.
    fn non_manifold_edges(m: &TriMesh) -> usize {
        m.validate().non_manifold_edges
    }

    /// Without the face-diagonal rule, two cells sharing an ambiguous face can both put the
    /// same diagonal in that face: the edge then has four triangles. With it, never.
    #[test]
    fn face_diagonals_would_break_manifoldness() {
        let opts = MeshOptions::default();
        let mut broken = 0;
        for seed in 0..8 {
            let g = random_grid(seed, 12);
            let (free, _) = mesh_grid_impl(&g, &opts, false, &Job::new()).unwrap();
            broken += non_manifold_edges(&free);
            let (ok, stats) = mesh_grid_impl(&g, &opts, true, &Job::new()).unwrap();
            assert_eq!(non_manifold_edges(&ok), 0, "seed {seed}");
            assert!(ok.validate().watertight);
            eprintln!(
                "seed {seed}: unconstrained {} non-manifold edges; constrained 0, {} centroid loops",
                non_manifold_edges(&free),
                stats.centroid_loops
            );
        }
        assert!(broken > 0, "the hazard did not show on these seeds");
    }

    #[test]
    fn brick_grid_visits_only_blocks_near_the_surface() {
        let n = 96;
        let h = 2.0 / (n - 1) as f32;
        let mut g = Grid::new([n; 3], Vec3::splat(-1.0), h).unwrap();
        for ([i, j, k], _) in g.clone().iter() {
            let p = g.position(i, j, k);
            g.set(i, j, k, p.length() - 0.6);
        }
        let bricks = BrickGrid::from_grid(&g, 8, 1, 2.0 * h, 2.0 * h).unwrap();
        let (sparse, stats) =
            mesh_brick_grid_impl(&bricks, &MeshOptions::default(), true, &Job::new()).unwrap();
        let (dense, _) = mesh_grid_impl(
            &bricks.to_grid().unwrap(),
            &MeshOptions::default(),
            true,
            &Job::new(),
        )
        .unwrap();
        assert_eq!(sparse.positions, dense.positions);
        let f = stats.blocks_visited as f64 / stats.blocks_total as f64;
        eprintln!(
            "brick meshing visited {} of {} blocks ({f:.3})",
            stats.blocks_visited, stats.blocks_total
        );
        assert!(f < 0.35, "visited fraction {f}");
    }
}
