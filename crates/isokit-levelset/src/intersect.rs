//! Exact self-intersection test of a triangle mesh: which pairs of triangles meet anywhere
//! other than in the vertices and edges they share.
//!
//! Every decision is the sign of an orientation determinant of input vertices, evaluated
//! exactly with Shewchuk's adaptive-precision predicates (Shewchuk 1997, "Adaptive
//! Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates", the `robust`
//! crate): the answer holds for the f32 vertices as stored, with no tolerance. Two triangles
//! intersect exactly when an edge of one meets the other (their intersection, when not
//! empty, contains a boundary point of one of them), so the test is six segment–triangle
//! tests, each a few `orient3d` signs (or `orient2d` signs in the triangle's plane when the
//! segment lies in it). Triangles that share vertices are judged as CGAL's
//! `does_self_intersect` judges them: sharing an edge, they intersect only when folded onto
//! each other (coplanar, the opposite vertices on the same side of the edge); sharing one
//! vertex, when the edge opposite it in one meets the other. Vertices are shared when their
//! positions are equal, so an unwelded mesh is judged as its welded form.
//!
//! Pairs are found by hashing the triangles' bounding boxes into a uniform grid (cells about
//! the mean triangle size, at least 1/32 of the largest, and coarsened until the grid holds at
//! most [`MAX_CELLS_PER_TRIANGLE`] entries per triangle, so its memory is linear in the mesh
//! whatever the mix of sizes); each pair is tested once, in the lowest cell the two boxes
//! share. Degenerate triangles (all three vertices on one line, exactly) are skipped and
//! counted. Every intersecting pair is counted; at most [`MAX_LISTED_PAIRS`] are listed (a
//! pile of coincident triangles has quadratically many).

use glam::Vec3;
use isokit_field::TriMesh;
use rayon::prelude::*;
use robust::{Coord, Coord3D, orient2d, orient3d};
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// At most this many intersecting pairs are listed in [`SelfIntersections::pairs`]; all are
/// counted in [`SelfIntersections::count`].
pub const MAX_LISTED_PAIRS: usize = 1 << 20;

/// The bucketing grid is coarsened until it holds at most this many (cell, triangle)
/// entries per triangle on average.
pub const MAX_CELLS_PER_TRIANGLE: u64 = 16;

/// What [`self_intersections`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SelfIntersections {
    /// The intersecting pairs of triangle indices (`i < j`), sorted: all of them when
    /// there are at most [`MAX_LISTED_PAIRS`], else that many (which ones is unspecified).
    pub pairs: Vec<[u32; 2]>,
    /// How many pairs intersect (listed or not).
    pub count: usize,
    /// Triangles skipped because their three vertices are collinear (or have an index out
    /// of range).
    pub degenerate: usize,
    /// Candidate pairs whose boxes overlap (the exact tests made).
    pub candidates: usize,
}

fn c3(p: Vec3) -> Coord3D<f64> {
    Coord3D {
        x: p.x as f64,
        y: p.y as f64,
        z: p.z as f64,
    }
}

/// Sign of the orientation of `d` against the plane through `a`, `b`, `c`.
fn o3(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> i8 {
    let v = orient3d(c3(a), c3(b), c3(c), c3(d));
    (v > 0.0) as i8 - (v < 0.0) as i8
}

/// A triangle projected onto the coordinate plane its normal is most along (which keeps it
/// non-degenerate when it is not: the normal's largest component cannot vanish).
#[derive(Clone, Copy)]
struct Plane2 {
    drop: usize,
}

impl Plane2 {
    fn of(a: Vec3, b: Vec3, c: Vec3) -> Self {
        let n = (b.as_dvec3() - a.as_dvec3()).cross(c.as_dvec3() - a.as_dvec3());
        let n = n.abs();
        let drop = if n.x >= n.y && n.x >= n.z {
            0
        } else if n.y >= n.z {
            1
        } else {
            2
        };
        Self { drop }
    }

    fn p(&self, v: Vec3) -> Coord<f64> {
        let (i, j) = match self.drop {
            0 => (1, 2),
            1 => (2, 0),
            _ => (0, 1),
        };
        Coord {
            x: v[i] as f64,
            y: v[j] as f64,
        }
    }

    fn o2(&self, a: Vec3, b: Vec3, c: Vec3) -> i8 {
        let v = orient2d(self.p(a), self.p(b), self.p(c));
        (v > 0.0) as i8 - (v < 0.0) as i8
    }

    /// Whether `p` (in the plane) lies in the closed triangle `a b c`.
    fn in_triangle(&self, a: Vec3, b: Vec3, c: Vec3, p: Vec3) -> bool {
        let s = [self.o2(a, b, p), self.o2(b, c, p), self.o2(c, a, p)];
        !(s.contains(&1) && s.contains(&-1))
    }

    /// Whether `p` on the line through `a`, `b` lies in the closed segment.
    fn on_segment(&self, a: Vec3, b: Vec3, p: Vec3) -> bool {
        let (pa, pb, pp) = (self.p(a), self.p(b), self.p(p));
        pp.x >= pa.x.min(pb.x)
            && pp.x <= pa.x.max(pb.x)
            && pp.y >= pa.y.min(pb.y)
            && pp.y <= pa.y.max(pb.y)
    }

    /// Whether the closed segments `p q` and `a b` (in the plane) meet.
    fn segments_meet(&self, p: Vec3, q: Vec3, a: Vec3, b: Vec3) -> bool {
        let (d1, d2) = (self.o2(a, b, p), self.o2(a, b, q));
        let (d3, d4) = (self.o2(p, q, a), self.o2(p, q, b));
        if d1 * d2 < 0 && d3 * d4 < 0 {
            return true;
        }
        (d1 == 0 && self.on_segment(a, b, p))
            || (d2 == 0 && self.on_segment(a, b, q))
            || (d3 == 0 && self.on_segment(p, q, a))
            || (d4 == 0 && self.on_segment(p, q, b))
    }
}

/// Whether the closed segment `s t` meets the closed triangle `a b c` (non-degenerate).
fn segment_meets_triangle(s: Vec3, t: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (os, ot) = (o3(a, b, c, s), o3(a, b, c, t));
    if os * ot > 0 {
        return false;
    }
    if os == 0 && ot == 0 {
        // In the triangle's plane.
        let pl = Plane2::of(a, b, c);
        return pl.in_triangle(a, b, c, s)
            || pl.in_triangle(a, b, c, t)
            || pl.segments_meet(s, t, a, b)
            || pl.segments_meet(s, t, b, c)
            || pl.segments_meet(s, t, c, a);
    }
    // The segment reaches the plane: the point where it does lies in the triangle when the
    // line `s t` passes on the same side of (or through) all three edges.
    let e = [o3(s, t, a, b), o3(s, t, b, c), o3(s, t, c, a)];
    !(e.contains(&1) && e.contains(&-1))
}

/// Whether two non-degenerate triangles meet anywhere other than in the vertices (by
/// position) they share.
pub fn triangles_intersect(t: [Vec3; 3], u: [Vec3; 3]) -> bool {
    let shared: Vec<(usize, usize)> = (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .filter(|&(i, j)| t[i] == u[j])
        .collect();
    match shared.len() {
        0 => {
            (0..3).any(|i| segment_meets_triangle(t[i], t[(i + 1) % 3], u[0], u[1], u[2]))
                || (0..3).any(|i| segment_meets_triangle(u[i], u[(i + 1) % 3], t[0], t[1], t[2]))
        }
        1 => {
            // The edges opposite the shared vertex.
            let (i, j) = shared[0];
            let (t1, t2) = (t[(i + 1) % 3], t[(i + 2) % 3]);
            let (u1, u2) = (u[(j + 1) % 3], u[(j + 2) % 3]);
            segment_meets_triangle(t1, t2, u[0], u[1], u[2])
                || segment_meets_triangle(u1, u2, t[0], t[1], t[2])
        }
        2 => {
            // A shared edge: folded onto each other when coplanar with the opposite vertices
            // on the same side of the edge.
            let (ti, ui) = (3 - shared[0].0 - shared[1].0, 3 - shared[0].1 - shared[1].1);
            let (a, b) = (t[shared[0].0], t[shared[1].0]);
            let (c, d) = (t[ti], u[ui]);
            if o3(a, b, c, d) != 0 {
                return false;
            }
            let pl = Plane2::of(a, b, c);
            pl.o2(a, b, c) == pl.o2(a, b, d)
        }
        // The same triangle twice (or a vertex repeated within one: degenerate, not here).
        _ => true,
    }
}

fn degenerate(p: [Vec3; 3]) -> bool {
    // Collinear exactly: every projection onto a coordinate plane is collinear.
    (0..3).all(|drop| Plane2 { drop }.o2(p[0], p[1], p[2]) == 0)
}

/// The pairs of triangles of `mesh` that intersect other than in shared vertices and edges
/// (see the [module](self) docs).
///
/// ```
/// use glam::Vec3;
/// use isokit_field::TriMesh;
/// use isokit_levelset::intersect::self_intersections;
///
/// // Two triangles crossing each other, and a third far away.
/// let p = vec![
///     Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0),
///     Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.9, 0.9, 0.0),
///     Vec3::new(5.0, 5.0, 5.0), Vec3::new(6.0, 5.0, 5.0), Vec3::new(5.0, 6.0, 5.0),
/// ];
/// let mesh = TriMesh::new(p, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
/// assert_eq!(self_intersections(&mesh).pairs, vec![[0, 1]]);
/// ```
pub fn self_intersections(mesh: &TriMesh) -> SelfIntersections {
    let tri = |t: &[u32; 3]| -> Option<[Vec3; 3]> {
        let p = t.map(|i| mesh.positions.get(i as usize).copied());
        match p {
            [Some(a), Some(b), Some(c)] if a.is_finite() && b.is_finite() && c.is_finite() => {
                Some([a, b, c])
            }
            _ => None,
        }
    };
    let tris: Vec<Option<[Vec3; 3]>> = mesh
        .triangles
        .par_iter()
        .map(|t| tri(t).filter(|p| !degenerate(*p)))
        .collect();
    let degenerate = tris.iter().filter(|t| t.is_none()).count();
    let live: Vec<(u32, Vec3, Vec3)> = tris
        .iter()
        .enumerate()
        .filter_map(|(i, t)| {
            t.map(|p| (i as u32, p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2])))
        })
        .collect();
    if live.len() < 2 {
        return SelfIntersections {
            degenerate,
            ..Default::default()
        };
    }
    // Cells of about the mean box size; at most ~8 cells per triangle along each axis.
    let mean = live
        .iter()
        .map(|(_, lo, hi)| (*hi - *lo).max_element() as f64)
        .sum::<f64>()
        / live.len() as f64;
    let (lo, hi) = live.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(l, h), (_, a, b)| (l.min(*a), h.max(*b)),
    );
    let extent = (hi - lo).max_element() as f64;
    let largest = live
        .iter()
        .map(|(_, lo, hi)| (*hi - *lo).max_element() as f64)
        .fold(0.0, f64::max);
    // The largest triangle spans at most ~32 cells per axis, and there are never more than
    // ~2^20 cells per axis, whatever the triangles' sizes.
    let mut cell = mean
        .max(largest / 32.0)
        .max(extent / (1 << 20) as f64)
        .max(f64::MIN_POSITIVE);
    let key_at = |cell: f64, p: Vec3| -> [i64; 3] {
        let q = (p - lo).as_dvec3() / cell;
        [q.x as i64, q.y as i64, q.z as i64]
    };
    // Few large triangles among many small ones span many cells each: coarsen until the
    // entries are bounded (each doubling divides a large triangle's count by about 8).
    let entries = |cell: f64| -> u64 {
        live.iter()
            .map(|(_, a, b)| {
                let (ka, kb) = (key_at(cell, *a), key_at(cell, *b));
                (0..3).map(|i| (kb[i] - ka[i] + 1) as u64).product::<u64>()
            })
            .fold(0, u64::saturating_add)
    };
    while entries(cell) > MAX_CELLS_PER_TRIANGLE * live.len() as u64 {
        cell *= 2.0;
    }
    let key = |p: Vec3| key_at(cell, p);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (k, (_, a, b)) in live.iter().enumerate() {
        let (ka, kb) = (key(*a), key(*b));
        for z in ka[2]..=kb[2] {
            for y in ka[1]..=kb[1] {
                for x in ka[0]..=kb[0] {
                    grid.entry([x, y, z]).or_default().push(k as u32);
                }
            }
        }
    }
    let cells: Vec<([i64; 3], Vec<u32>)> = grid.into_iter().collect();
    let listed = AtomicUsize::new(0);
    let results: Vec<(usize, usize, Vec<[u32; 2]>)> = cells
        .par_iter()
        .map(|(c, members)| {
            let mut found = Vec::new();
            let (mut tested, mut count) = (0, 0);
            for (x, &i) in members.iter().enumerate() {
                for &j in &members[x + 1..] {
                    let (ti, ai, bi) = live[i as usize];
                    let (tj, aj, bj) = live[j as usize];
                    if (0..3).any(|a| ai[a] > bj[a] || aj[a] > bi[a]) {
                        continue;
                    }
                    // Tested in the lowest cell the two boxes share only.
                    let first = key(ai.max(aj));
                    if first != *c {
                        continue;
                    }
                    tested += 1;
                    let (Some(p), Some(q)) = (tris[ti as usize], tris[tj as usize]) else {
                        continue;
                    };
                    if triangles_intersect(p, q) {
                        count += 1;
                        if listed.fetch_add(1, Ordering::Relaxed) < MAX_LISTED_PAIRS {
                            found.push([ti.min(tj), ti.max(tj)]);
                        }
                    }
                }
            }
            (tested, count, found)
        })
        .collect();
    let candidates = results.iter().map(|r| r.0).sum();
    let count = results.iter().map(|r| r.1).sum();
    let mut pairs: Vec<[u32; 2]> = results.into_iter().flat_map(|r| r.2).collect();
    pairs.sort_unstable();
    SelfIntersections {
        pairs,
        count,
        degenerate,
        candidates,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn pairs_in_general_position() {
        let t = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        // Piercing the interior; touching the interior with a vertex; just missing.
        assert!(triangles_intersect(
            t,
            [v(0.2, 0.2, -1.0), v(0.2, 0.2, 1.0), v(3.0, 3.0, 0.0)]
        ));
        assert!(triangles_intersect(
            t,
            [v(0.2, 0.2, 0.0), v(0.2, 0.3, 1.0), v(0.3, 0.2, 1.0)]
        ));
        assert!(!triangles_intersect(
            t,
            [
                v(0.2, 0.2, f32::EPSILON),
                v(0.2, 0.3, 1.0),
                v(0.3, 0.2, 1.0)
            ]
        ));
        // Beyond the hypotenuse by one f32 step: apart; on it: touching.
        let h = 0.5f32;
        let past = f32::from_bits(h.to_bits() + 1);
        assert!(!triangles_intersect(
            t,
            [v(past, past, -1.0), v(past, past, 1.0), v(2.0, 2.0, 0.0)]
        ));
        assert!(triangles_intersect(
            t,
            [v(h, h, -1.0), v(h, h, 1.0), v(2.0, 2.0, 0.0)]
        ));
    }

    #[test]
    fn coplanar_pairs() {
        let t = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        // Inside; overlapping; apart.
        assert!(triangles_intersect(
            t,
            [v(0.1, 0.1, 0.0), v(0.2, 0.1, 0.0), v(0.1, 0.2, 0.0)]
        ));
        assert!(triangles_intersect(
            t,
            [v(0.5, -0.5, 0.0), v(0.5, 0.5, 0.0), v(2.0, 0.0, 0.0)]
        ));
        assert!(!triangles_intersect(
            t,
            [v(0.6, 0.6, 0.0), v(1.6, 0.6, 0.0), v(0.6, 1.6, 0.0)]
        ));
    }

    #[test]
    fn shared_edges_and_vertices() {
        let (a, b) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0));
        // A fold along the shared edge: fine unless flat onto the other side.
        assert!(!triangles_intersect(
            [a, b, v(0.5, 1.0, 0.0)],
            [b, a, v(0.5, -1.0, 0.3)]
        ));
        assert!(!triangles_intersect(
            [a, b, v(0.5, 1.0, 0.0)],
            [b, a, v(0.5, -1.0, 0.0)]
        ));
        assert!(triangles_intersect(
            [a, b, v(0.5, 1.0, 0.0)],
            [b, a, v(0.3, 0.5, 0.0)]
        ));
        // One shared vertex: a fan, and a fin through the first triangle.
        assert!(!triangles_intersect(
            [a, b, v(0.0, 1.0, 0.0)],
            [a, v(0.0, 1.0, 1.0), v(-1.0, 0.0, 1.0)]
        ));
        assert!(triangles_intersect(
            [a, b, v(0.0, 1.0, 0.0)],
            [a, v(0.5, 0.3, -1.0), v(0.3, 0.5, 1.0)]
        ));
    }

    #[test]
    fn the_grid_finds_every_pair_brute_force_finds() {
        // Mostly small triangles and a few large ones; then a tenth large among tiny ones,
        // which spans so many cells of the mean size that the grid is coarsened.
        for (seed, large_every, small) in [(11, 50, 0.05), (12, 10, 0.005)] {
            let mut rng = isokit_field::rng::SplitMix64::new(seed);
            let mut p = Vec::new();
            let mut t = Vec::new();
            for i in 0..400u32 {
                let c = rng.point_in(Vec3::ZERO, Vec3::ONE);
                let r = if i % large_every == 0 { 0.5 } else { small };
                for _ in 0..3 {
                    p.push(c + r * rng.unit_vector());
                }
                t.push([3 * i, 3 * i + 1, 3 * i + 2]);
            }
            let mesh = TriMesh::new(p, t);
            let got = self_intersections(&mesh);
            let tri = |i: usize| mesh.triangles[i].map(|k| mesh.positions[k as usize]);
            let mut want = Vec::new();
            for i in 0..mesh.triangles.len() {
                for j in i + 1..mesh.triangles.len() {
                    if triangles_intersect(tri(i), tri(j)) {
                        want.push([i as u32, j as u32]);
                    }
                }
            }
            assert!(want.len() > 20, "{}", want.len());
            assert_eq!(got.pairs, want);
            assert_eq!(got.count, want.len());
        }
    }

    #[test]
    fn a_pile_of_coincident_triangles_is_counted_and_listed_up_to_the_cap() {
        let n = 1500u32;
        let p = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        let positions: Vec<Vec3> = (0..n).flat_map(|_| p.iter().copied()).collect();
        let triangles = (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let r = self_intersections(&TriMesh::new(positions, triangles));
        let all = (n as usize) * (n as usize - 1) / 2;
        assert!(all > MAX_LISTED_PAIRS);
        assert_eq!(r.count, all);
        assert_eq!(r.pairs.len(), MAX_LISTED_PAIRS);
        assert!(r.pairs.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn a_closed_mesh_has_none_and_two_overlapping_copies_have_some() {
        // A closed, convex mesh.
        let mut mesh = isokit_field::generate::icosphere(Vec3::ZERO, 1.0, 1);
        let (nv, nt) = (mesh.positions.len() as u32, mesh.triangles.len() as u32);
        let r = self_intersections(&mesh);
        assert!(
            r.pairs.is_empty() && r.degenerate == 0 && r.candidates > 0,
            "{r:?}"
        );
        // A second copy beside it: apart by 3, overlapping by half.
        let two = |dx: f32| {
            let mut m = mesh.clone();
            m.positions
                .extend(mesh.positions.iter().map(|p| *p + v(dx, 0.0, 0.0)));
            m.triangles
                .extend(mesh.triangles.iter().map(|t| t.map(|i| i + nv)));
            m
        };
        assert!(self_intersections(&two(3.0)).pairs.is_empty());
        let r = self_intersections(&two(0.5));
        assert!(!r.pairs.is_empty(), "{r:?}");
        assert!(r.pairs.iter().all(|&[i, j]| i < nt && j >= nt), "{r:?}");
        // Degenerate and out-of-range triangles are skipped, not tested.
        mesh.triangles.push([0, 0, 1]);
        mesh.triangles.push([0, 1, nv + 99]);
        assert_eq!(self_intersections(&mesh).degenerate, 2);
    }
}
