//! Marching tetrahedra: the isosurface of a [`TetGrid`]'s linear interpolant (004 Sec. 4,
//! isosurfaces of unstructured tetrahedral grids), exact in every cell.
//!
//! In each cell the scalar is linear, so its isosurface is a triangle (one corner on the
//! other side from the three others) or a quadrilateral (two and two), with corners on the
//! cell's edges. A corner is made once per grid edge (keyed by the edge's two point
//! indices), so neighbouring cells that share a face share its corners: the surface is
//! watertight wherever the grid is (where every interior face is shared by two cells), and
//! closed wherever it does not reach the grid's boundary.
//!
//! Inside is `value < iso` (a NaN point is outside), as in [`crate::meshing`]; a crossing is
//! kept a 1/1024 of its edge away from the edge's points (the marching-cubes rule, see
//! [`crate::meshing`]'s "Samples at the isovalue"), so a point exactly at the isovalue
//! gives distinct corners on its edges and no triangle collapses. Triangles face the outside
//! (`value ≥ iso`), by each cell's own orientation, inverted cells included.

use glam::Vec3;
use isokit_field::tet::positive;
use isokit_field::{Job, TetGrid, TriMesh};
use rayon::prelude::*;

use crate::meshing::{self, MeshingError, NODE_GAP};

/// Cells per unit of progress and cancellation check.
const CHUNK: usize = 1 << 14;

/// The isosurface `value = iso` of `grid` (see the module docs).
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Grid, TetGrid, TetSplit, primitives::Sphere, sample_into};
/// use isokit_levelset::tets::mesh_tets;
///
/// let mut g = Grid::new([17, 17, 17], Vec3::splat(-1.0), 0.125).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.6).unwrap(), &mut g);
/// let tets = TetGrid::from_grid(&g, TetSplit::Six).unwrap();
/// let mesh = mesh_tets(&tets, 0.0).unwrap();
/// let r = mesh.validate();
/// assert!(r.watertight && r.consistently_oriented);
/// ```
pub fn mesh_tets(grid: &TetGrid, iso: f32) -> Result<TriMesh, MeshingError> {
    mesh_tets_job(grid, iso, &Job::new())
}

/// [`mesh_tets`] reporting progress to `job` (stage `marching tetrahedra`, in cells, twice:
/// corners, then triangles) and stopping with [`MeshingError::Cancelled`] once it is
/// cancelled.
pub fn mesh_tets_job(grid: &TetGrid, iso: f32, job: &Job) -> Result<TriMesh, MeshingError> {
    if !iso.is_finite() {
        return Err(MeshingError::BadIso(iso));
    }
    let (points, values) = (grid.points(), grid.values());
    let inside = |i: u32| values[i as usize] < iso;
    let cells = grid.tets();
    let key = |a: u32, b: u32| (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
    let counter = job.counter("marching tetrahedra", 2 * cells.len() as u64);
    // Pass 1: every edge that crosses, once.
    let mut edges: Vec<u64> = cells
        .par_chunks(CHUNK)
        .map(|chunk| {
            job.check()?;
            let mut out = Vec::new();
            for t in chunk {
                for a in 0..4 {
                    for b in a + 1..4 {
                        if inside(t[a]) != inside(t[b]) {
                            out.push(key(t[a], t[b]));
                        }
                    }
                }
            }
            counter.advance(chunk.len() as u64);
            Ok(out)
        })
        .collect::<Result<Vec<_>, isokit_field::Cancelled>>()?
        .concat();
    edges.par_sort_unstable();
    edges.dedup();
    if edges.len() > u32::MAX as usize {
        return Err(MeshingError::TooLarge {
            vertices: edges.len(),
            triangles: 2 * cells.len(),
            limit: u32::MAX as usize,
        });
    }
    // A corner on each: from the inside point towards the outside one.
    let positions: Vec<Vec3> = edges
        .par_iter()
        .map(|&k| {
            let (a, b) = ((k >> 32) as u32, k as u32);
            let (i, o) = if inside(a) { (a, b) } else { (b, a) };
            let t = crossing(values[i as usize], values[o as usize], iso);
            let (pi, po) = (points[i as usize].as_dvec3(), points[o as usize].as_dvec3());
            (pi + t * (po - pi)).as_vec3()
        })
        .collect();
    let corner = |a: u32, b: u32| edges.binary_search(&key(a, b)).unwrap_or(0) as u32;
    // Pass 2: the triangles, in cell order.
    let triangles: Vec<[u32; 3]> = cells
        .par_chunks(CHUNK)
        .map(|chunk| {
            job.check()?;
            let mut out = Vec::new();
            for t in chunk {
                cell_triangles(t, points, &inside, &corner, &positions, &mut out);
            }
            counter.advance(chunk.len() as u64);
            Ok(out)
        })
        .collect::<Result<Vec<_>, isokit_field::Cancelled>>()?
        .concat();
    Ok(TriMesh::new(positions, triangles))
}

/// Crossing parameter from the inside value `a` towards the outside value `b`, kept
/// [`NODE_GAP`] off both ends (marching cubes' rule).
fn crossing(a: f32, b: f32, iso: f32) -> f64 {
    meshing::crossing(a, b, iso).clamp(NODE_GAP, 1.0 - NODE_GAP)
}

/// The triangles of one cell, facing the outside.
fn cell_triangles(
    t: &[u32; 4],
    points: &[Vec3],
    inside: &impl Fn(u32) -> bool,
    corner: &impl Fn(u32, u32) -> u32,
    positions: &[Vec3],
    out: &mut Vec<[u32; 3]>,
) {
    let mut ins = [0u32; 4];
    let mut outs = [0u32; 4];
    let (mut ni, mut no) = (0, 0);
    for &i in t {
        if inside(i) {
            ins[ni] = i;
            ni += 1;
        } else {
            outs[no] = i;
            no += 1;
        }
    }
    match ni {
        // One point inside, on its three edges: for a positive (i, a, b, c) the triangle
        // (a, b, c) faces away from i, and so does its image on the edges from i (each
        // corner moved towards i by a positive factor keeps the orientation).
        1 => {
            let q = positive([ins[0], outs[0], outs[1], outs[2]], points);
            out.push([corner(q[0], q[1]), corner(q[0], q[2]), corner(q[0], q[3])]);
        }
        // One point outside: the same triangle for it, reversed to face it.
        3 => {
            let q = positive([outs[0], ins[0], ins[1], ins[2]], points);
            out.push([corner(q[0], q[1]), corner(q[0], q[3]), corner(q[0], q[2])]);
        }
        // Two and two: for a positive (i1, i2, o1, o2) the quadrilateral on the edges
        // (i1 o1), (i1 o2), (i2 o2), (i2 o1) faces the outside points; cut along its shorter
        // diagonal.
        2 => {
            let o = positive([ins[0], ins[1], outs[0], outs[1]], points);
            let q = [
                corner(o[0], o[2]),
                corner(o[0], o[3]),
                corner(o[1], o[3]),
                corner(o[1], o[2]),
            ];
            let at = |i: u32| positions[i as usize];
            if at(q[0]).distance_squared(at(q[2])) <= at(q[1]).distance_squared(at(q[3])) {
                out.push([q[0], q[1], q[2]]);
                out.push([q[0], q[2], q[3]]);
            } else {
                out.push([q[0], q[1], q[3]]);
                out.push([q[1], q[2], q[3]]);
            }
        }
        _ => {}
    }
}
