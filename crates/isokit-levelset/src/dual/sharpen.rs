//! Mesh edges and triangles that cut across a sharp edge or corner of the exact surface,
//! split at a vertex on it; vertices off the surface moved onto it.
//!
//! Dual contouring puts a cell's vertex on a sharp edge only where the cell's crossings see
//! both of its faces (Ju et al. 2002, Sec. 2.3). Where the edge clips a cell whose crossings
//! all lie on one face, or where a vertex placed beyond its cell had to go back into it
//! (`beyond`), the vertex lies on one face and the triangles joining it to the other face's
//! vertices cut the edge off: a chamfer up to a third of a cell deep. Adaptive meshing
//! (`merge`) can likewise leave a large triangle across a corner whose three edges lie on
//! the surface. With an exact field these chamfers are found and removed after the mesh is
//! made, as feature-sensitive surface extraction inserts the feature point into a cell's
//! triangle fan (Kobbelt, Botsch, Schwanecke and Seidel 2001, "Feature Sensitive Surface
//! Extraction from Volume Data", Sec. 3); here the point goes into the mesh edge or
//! triangle that misses it:
//!
//! - a mesh edge is a candidate where its midpoint lies more than [`CHAMFER`] of a cell off
//!   the surface, a triangle where its centroid does;
//! - the faces on either side are read from the exact gradient just in from each end of
//!   the edge (or, where both see one face because an end sits on an edge or corner of the
//!   surface, a quarter of the way in); for a triangle, from each vertex towards the other
//!   two and at the centroid. Two faces more than [`FEATURE_DEGREES`] apart give an edge
//!   (the line of their planes, each plane placed by the field's value where its gradient
//!   was read), three a corner;
//! - the split point is the point of that line nearest the mesh edge (inside it), or
//!   nearest the triangle's centroid, or the corner (inside the triangle seen along its
//!   normal); it is used where it lies on the surface (within [`ON_SURFACE`] of a cell),
//!   apart from the ends, not more than a cell beyond the edge or triangle, and where every
//!   new piece lies closer to the surface than the whole did;
//! - a vertex more than [`VERTEX_OFF`] of a cell off the surface (clamped into its cell off a
//!   sharp edge, where no place on the edge folded nothing) moves onto the surface by Newton
//!   steps along the gradient, onto the nearest face; the next round splits its edges to
//!   the other face on the sharp edge. A vertex with a deep edge and no split point (the
//!   feature passes just beyond it: a cell's vertex clamped next to a corner outside the
//!   cell) moves onto the corner of the faces seen towards its neighbours, or the nearest
//!   point of the edge of two of them, where that is within half a cell and halves the depth
//!   of each of its edges. Adaptive meshing's merged vertices are not moved (they lie within
//!   the error bound of the surface by design); vertices move before edges are split;
//! - an edge's two triangles become four around the new vertex, a triangle three (the mesh
//!   stays closed, 2-manifold and oriented); a move or split whose triangles fold (facing
//!   against the triangle they replace and the exact surface, as `beyond::folds` tests), are
//!   degenerate, or cross another triangle (exactly, [`crate::intersect`]) is taken back.
//!
//! Edges and triangles are looked at only around vertices of mesh edges whose two triangles
//! meet at more than [`CREASE_DEGREES`], so smooth parts cost the triangles' normals and one
//! field value per vertex (for the vertices off the surface); up to [`ROUNDS`] rounds split
//! what the changes of the round before made (the second round only around them). Measured on two boxes, one rotated 30° (`isokit-scene`'s
//! `tests/dual.rs`): Hausdorff distance from the surface 0.27 voxel without these steps,
//! 0.066 with the splits alone, 0.037 with the moves too (7 changes among 16,626
//! triangles); at resolution 128 two vertices clamped 0.14 and 0.09 cell inside the surface
//! and one 0.1 cell from a corner left 0.14 voxel before they were moved.

use glam::{DMat3, DVec3, Vec3};
use isokit_field::{Field, Job};
use rayon::prelude::*;

use crate::meshing::MeshingError;

/// A mesh edge whose midpoint lies farther than this (in cells) from the surface cuts it.
const CHAMFER: f64 = 0.02;
/// A vertex farther than this (in cells) from the surface moves onto it (a cell's vertex on a
/// curved piece lies off it by about the chord's sag, which is left).
const VERTEX_OFF: f64 = 0.05;
/// The split point must lie this close (in cells) to the surface.
const ON_SURFACE: f64 = 0.005;
/// The exact gradients at an edge's ends at least this far apart: the ends lie on two faces.
const FEATURE_DEGREES: f64 = 20.0;
/// Edges whose triangles meet at more than this are where chamfers are looked for.
const CREASE_DEGREES: f64 = 10.0;
/// A split point at least this far (in cells) from the edge's ends.
const APART: f64 = 0.05;
/// Rounds of splitting: a round splits at most one edge of each triangle.
const ROUNDS: usize = 4;

/// One split: the triangles it replaced (index and old vertices), those it added at the
/// end, and every triangle it wrote with the old triangle that held it.
struct Split {
    old: Vec<(usize, [u32; 3])>,
    added: Vec<usize>,
    new: Vec<(usize, [u32; 3])>,
}

/// What a split cuts: a mesh edge (its two triangles become four), or a triangle (three);
/// or a vertex off the surface that moves onto it (its triangles, listed, take a new
/// vertex in its place).
#[derive(Clone)]
enum Cut {
    Edge(Edge),
    Face(u32),
    Vertex(u32, Vec<u32>),
}

/// Splits the chamfering edges of `triangles` (module docs) and returns how many splits and
/// moves were kept. New vertices are appended to `positions`, new triangles to `triangles`.
/// `h` is the lattice spacing; vertices `keep[v]` are not moved onto the surface (adaptive
/// meshing's merged vertices, which lie within its error bound of the surface by design).
pub(super) fn split_chamfers(
    positions: &mut Vec<Vec3>,
    triangles: &mut Vec<[u32; 3]>,
    field: &dyn Field,
    iso: f32,
    (h, keep): (f64, &[bool]),
    job: &Job,
) -> Result<usize, MeshingError> {
    let mut kept = 0;
    // After the first round, only where the last round split: the new triangles' vertices.
    let mut focus: Option<Vec<bool>> = None;
    for _ in 0..ROUNDS {
        job.check()?;
        let found = candidates(
            positions,
            triangles,
            focus.as_deref(),
            field,
            iso,
            (h, keep),
        );
        if found.is_empty() {
            break;
        }
        let splits = apply(positions, triangles, found);
        let touched = check(positions, triangles, splits, field);
        if touched.is_empty() {
            break;
        }
        kept += touched.len();
        let mut f = vec![false; positions.len()];
        for t in touched.iter().flatten() {
            f[*t as usize] = true;
        }
        focus = Some(f);
    }
    Ok(kept)
}

/// An interior mesh edge: its ends and its two triangles (the first has the edge as
/// `a → b`).
#[derive(Clone, Copy)]
struct Edge {
    a: u32,
    b: u32,
    tris: [u32; 2],
}

/// The edges of the triangles `looked` (indices into `triangles`) shared by exactly two of
/// them.
fn edges(triangles: &[[u32; 3]], looked: &[u32]) -> Vec<Edge> {
    let mut half: Vec<(u64, u32, bool)> = looked
        .par_iter()
        .flat_map_iter(|&t| {
            let tri = triangles[t as usize];
            (0..3).map(move |i| {
                let (a, b) = (tri[i], tri[(i + 1) % 3]);
                let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
                (key, t, a < b)
            })
        })
        .collect();
    half.par_sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 {
            j += 1;
        }
        // Two triangles (not one with a repeated vertex), holding the edge both ways.
        if j == i + 2 && half[i].2 != half[i + 1].2 && half[i].1 != half[i + 1].1 {
            let (lo, hi) = ((half[i].0 >> 32) as u32, half[i].0 as u32);
            // The triangle holding lo → hi first.
            let (t0, t1) = if half[i].2 {
                (half[i].1, half[i + 1].1)
            } else {
                (half[i + 1].1, half[i].1)
            };
            out.push(Edge {
                a: lo,
                b: hi,
                tris: [t0, t1],
            });
        }
        i = j;
    }
    out
}

/// Whether a midpoint or centroid `depth` off the surface (NaN: no) cuts it.
fn cuts(depth: f64, h: f64) -> bool {
    depth > CHAMFER * h
}

fn normal(positions: &[Vec3], t: [u32; 3]) -> DVec3 {
    let p = t.map(|v| positions[v as usize].as_dvec3());
    (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
}

/// The edges and triangles to split, with their split points and how far their midpoints or
/// centroids lie off the surface.
fn candidates(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    focus: Option<&[bool]>,
    field: &dyn Field,
    iso: f32,
    (h, keep): (f64, &[bool]),
) -> Vec<(Cut, Vec3, f64)> {
    // The triangles looked at: all, or those with a vertex in `focus` (every edge at such a
    // vertex has both its triangles among them).
    let looked: Vec<u32> = (0..triangles.len() as u32)
        .into_par_iter()
        .filter(|&t| focus.is_none_or(|f| triangles[t as usize].iter().any(|&v| f[v as usize])))
        .collect();
    let edges = edges(triangles, &looked);
    let crease = CREASE_DEGREES.to_radians().cos();
    let mut near = vec![false; positions.len()];
    let creased: Vec<&Edge> = edges
        .par_iter()
        .filter(|e| {
            let [n0, n1] = e.tris.map(|t| normal(positions, triangles[t as usize]));
            n0.dot(n1) < crease
        })
        .collect();
    for e in creased {
        near[e.a as usize] = true;
        near[e.b as usize] = true;
    }
    if let Some(focus) = focus {
        near.iter_mut().zip(focus).for_each(|(n, f)| *n &= *f);
    }
    let off = |p: DVec3| field.value(p.as_vec3()) as f64 - iso as f64;
    // Mesh edges whose midpoints lie off the surface, with how far.
    let deep: Vec<(Edge, f64)> = edges
        .par_iter()
        .filter(|e| near[e.a as usize] || near[e.b as usize])
        .filter_map(|e| {
            let m = 0.5 * (positions[e.a as usize] + positions[e.b as usize]).as_dvec3();
            let depth = off(m).abs();
            cuts(depth, h).then_some((*e, depth))
        })
        .collect();
    let splits: Vec<Option<DVec3>> = deep
        .par_iter()
        .map(|(e, _)| {
            let (a, b) = (
                positions[e.a as usize].as_dvec3(),
                positions[e.b as usize].as_dvec3(),
            );
            // The faces on either side, from the gradients just in from either end, or where
            // those do not see two faces (an end on an edge or corner of the surface, whose
            // gradient is either face's) a quarter of the way in.
            [0.02, 0.25]
                .iter()
                .find_map(|&probe| split_point(field, iso, a, b, probe, h))
        })
        .collect();
    let mut found: Vec<(Cut, Vec3, f64)> = deep
        .iter()
        .zip(&splits)
        .filter_map(|((e, depth), s)| s.map(|s| (Cut::Edge(*e), s.as_vec3(), *depth)))
        .collect();
    // The ends of deep edges with no split point (the feature passes just beyond an end:
    // a vertex clamped into its cell next to a corner or edge), deepest edge first.
    let mut unsplit: Vec<(u32, f64)> = deep
        .iter()
        .zip(&splits)
        .filter(|(_, s)| s.is_none())
        .flat_map(|((e, depth), _)| [(e.a, *depth), (e.b, *depth)])
        // Every triangle of a vertex moved must be looked at: in `focus` after the first round.
        .filter(|&(v, _)| {
            !keep.get(v as usize).copied().unwrap_or(false) && focus.is_none_or(|f| f[v as usize])
        })
        .collect();
    unsplit.sort_by(|x, y| x.0.cmp(&y.0).then(y.1.total_cmp(&x.1)));
    unsplit.dedup_by_key(|x| x.0);
    // Triangles whose edges lie on the surface while their middle cuts a corner or an edge
    // (each vertex on a different face or edge of the surface around it).
    found.par_extend(
        looked
            .par_iter()
            .map(|&i| (i as usize, &triangles[i as usize]))
            .filter(|(_, t)| t.iter().any(|&v| near[v as usize]))
            .filter_map(|(i, t)| {
                let p = t.map(|v| positions[v as usize].as_dvec3());
                let depth = off((p[0] + p[1] + p[2]) / 3.0).abs();
                if !cuts(depth, h) {
                    return None;
                }
                [0.02, 0.25]
                    .iter()
                    .find_map(|&probe| face_point(field, iso, p, probe, h))
                    .map(|s| (Cut::Face(i as u32), s.as_vec3(), depth))
            }),
    );
    // Vertices off the surface (clamped into their cells off a sharp edge): moved onto it by
    // Newton steps along the gradient, to the nearest face; the splits of the next round
    // then put the edges to the other face on the sharp edge.
    // Every vertex is looked at (in the first round; later, those in `focus`), creased or
    // not: the triangles around a vertex off the surface can lie flat.
    let off_surface: Vec<(u32, Vec3, f64)> = (0..positions.len() as u32)
        .into_par_iter()
        .filter(|&v| {
            focus.is_none_or(|f| f[v as usize]) && !keep.get(v as usize).copied().unwrap_or(false)
        })
        .filter_map(|v| {
            let p = positions[v as usize].as_dvec3();
            let depth = off(p).abs();
            if depth.is_nan() || depth <= VERTEX_OFF * h {
                return None;
            }
            super::newton_onto(field, iso, p, h, ON_SURFACE).map(|s| (v, s.as_vec3(), depth))
        })
        .collect();
    // Vertices next to a corner or edge their deep edges miss: onto it, where it lies within
    // half a cell and every edge of the vertex comes closer to the surface.
    let moving: std::collections::HashSet<u32> = off_surface.iter().map(|m| m.0).collect();
    let unsplit: Vec<(u32, f64)> = unsplit
        .into_iter()
        .filter(|(v, _)| !moving.contains(v))
        .collect();
    let mut around: std::collections::HashMap<u32, Vec<u32>> = off_surface
        .iter()
        .map(|&(v, ..)| v)
        .chain(unsplit.iter().map(|u| u.0))
        .map(|v| (v, Vec::new()))
        .collect();
    if around.is_empty() {
        return found;
    }
    for &t in &looked {
        for v in triangles[t as usize] {
            if let Some(list) = around.get_mut(&v) {
                list.push(t);
            }
        }
    }
    let snapped: Vec<(u32, Vec3, f64)> = unsplit
        .par_iter()
        .filter_map(|&(v, depth)| {
            let ring: Vec<DVec3> = around[&v]
                .iter()
                .flat_map(|&t| triangles[t as usize])
                .filter(|&w| w != v)
                .map(|w| positions[w as usize].as_dvec3())
                .collect();
            vertex_point(
                field,
                iso,
                positions[v as usize].as_dvec3(),
                &ring,
                (h, depth),
            )
            .map(|s| (v, s.as_vec3(), depth))
        })
        .collect();
    found.extend(off_surface.into_iter().chain(snapped).map(|(v, s, depth)| {
        (
            Cut::Vertex(v, around.remove(&v).unwrap_or_default()),
            s,
            depth,
        )
    }));
    found
}

/// Where the vertex at `p` (its neighbours `ring`) goes onto a corner or edge of the surface
/// that its edges, deepest `depth` off the surface, cut: the corner of the faces seen from it
/// towards its neighbours (gradients a quarter of the way), or the point of the edge of two
/// of them nearest `p`; within half a cell of `p`, on the surface, and with every edge to the
/// ring's vertices at most half as deep as before.
fn vertex_point(
    field: &dyn Field,
    iso: f32,
    p: DVec3,
    ring: &[DVec3],
    (h, depth): (f64, f64),
) -> Option<DVec3> {
    let off = |x: DVec3| field.value(x.as_vec3()) as f64 - iso as f64;
    let probes: Vec<DVec3> = ring.iter().map(|&w| p + 0.25 * (w - p)).collect();
    let s = feature_point(field, iso, &probes, p)?;
    let moved = s.distance(p);
    (moved <= 0.5 * h
        && moved >= APART * h
        && off(s).abs() <= ON_SURFACE * h
        && ring.iter().all(|&w| off(0.5 * (s + w)).abs() < 0.5 * depth))
    .then_some(s)
}

/// The corner of the faces seen at `probes` (planes placed by the field's value and
/// gradient there, each more than [`FEATURE_DEGREES`] from the others), or the point of the
/// edge of the first two nearest `near`; `None` with fewer than two faces.
fn feature_point(field: &dyn Field, iso: f32, probes: &[DVec3], near: DVec3) -> Option<DVec3> {
    let off = |x: DVec3| field.value(x.as_vec3()) as f64 - iso as f64;
    let feature = FEATURE_DEGREES.to_radians().cos();
    // The planes n·x = n·x₀ − f(x₀) of the faces seen, each apart from the others.
    let mut planes: Vec<(DVec3, f64)> = Vec::with_capacity(probes.len());
    for &x in probes {
        let n = field.gradient(x.as_vec3()).as_dvec3().normalize_or_zero();
        if n == DVec3::ZERO {
            return None;
        }
        if planes.iter().all(|q| n.dot(q.0) < feature) {
            planes.push((n, n.dot(x) - off(x)));
        }
    }
    match planes[..] {
        [a, b, c, ..] if DMat3::from_cols(a.0, b.0, c.0).determinant().abs() > 0.1 => {
            Some(DMat3::from_cols(a.0, b.0, c.0).transpose().inverse() * DVec3::new(a.1, b.1, c.1))
        }
        [a, b, ..] => {
            let c = a.0.dot(b.0);
            let (ra, rb) = (a.1 - a.0.dot(near), b.1 - b.0.dot(near));
            let det = 1.0 - c * c;
            Some(near + (ra - c * rb) / det * a.0 + (rb - c * ra) / det * b.0)
        }
        _ => None,
    }
}

/// The split point of the triangle `p` (module docs): the corner of the faces seen from its
/// vertices (gradients taken `probe` of the way in towards the other two) and its centroid,
/// or the point of the edge of two of them nearest the centroid.
fn face_point(field: &dyn Field, iso: f32, p: [DVec3; 3], probe: f64, h: f64) -> Option<DVec3> {
    let off = |x: DVec3| field.value(x.as_vec3()) as f64 - iso as f64;
    let g = (p[0] + p[1] + p[2]) / 3.0;
    let depth = off(g).abs();
    // From each vertex towards the other two (a vertex on an edge or at a corner sees a
    // different face in each direction), and the centroid.
    let probes: Vec<DVec3> = (0..3)
        .flat_map(|i| [1, 2].map(|k| p[i] + probe * (p[(i + k) % 3] - p[i])))
        .chain([g])
        .collect();
    let s = feature_point(field, iso, &probes, g)?;
    // Inside the triangle seen along its normal, apart from its vertices, on the surface,
    // and each new triangle nearer the surface than the old one.
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let inside = (0..3).all(|i| {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        (b - a).cross(s - a).dot(n) > 0.02 * n.length_squared()
    });
    let better = (0..3).all(|i| off((p[i] + p[(i + 1) % 3] + s) / 3.0).abs() < 0.5 * depth);
    (s.is_finite()
        && inside
        && off(s).abs() <= ON_SURFACE * h
        && s.distance(g) <= p.iter().map(|v| v.distance(g)).fold(0.0, f64::max) + h
        && p.iter().all(|v| s.distance(*v) >= APART * h)
        && better)
        .then_some(s)
}

/// The split point of the mesh edge `a b` (module docs), with the faces' gradients taken
/// `probe` of the way in from either end.
fn split_point(
    field: &dyn Field,
    iso: f32,
    a: DVec3,
    b: DVec3,
    probe: f64,
    h: f64,
) -> Option<DVec3> {
    let off = |p: DVec3| field.value(p.as_vec3()) as f64 - iso as f64;
    let (m, w) = (0.5 * (a + b), b - a);
    let depth = off(m).abs();
    let (xa, xb) = (a + probe * w, b - probe * w);
    let ga = field.gradient(xa.as_vec3()).as_dvec3().normalize_or_zero();
    let gb = field.gradient(xb.as_vec3()).as_dvec3().normalize_or_zero();
    let c = ga.dot(gb);
    // (Zero where the gradient is not finite, so `c` is finite.)
    if ga == DVec3::ZERO || gb == DVec3::ZERO || c >= FEATURE_DEGREES.to_radians().cos() {
        return None;
    }
    // The line of both faces' planes (ga·(x − xa) + f(xa) = 0, likewise for b): its point
    // p0 nearest m is m + α ga + β gb.
    let (ra, rb) = (-off(xa) - ga.dot(m - xa), -off(xb) - gb.dot(m - xb));
    let det = 1.0 - c * c;
    let p0 = m + (ra - c * rb) / det * ga + (rb - c * ra) / det * gb;
    let u = ga.cross(gb).normalize();
    // The split point: the point of the line nearest the segment, where that is inside the
    // segment and apart from its ends.
    let d = a - p0;
    let (ww, wu) = (w.length_squared(), w.dot(u));
    let t = (wu * u.dot(d) - w.dot(d)) / (ww - wu * wu);
    if !(t > 0.0 && t < 1.0) {
        return None;
    }
    let s = p0 + u.dot(a + t * w - p0) * u;
    let apart = APART * h;
    let better = |x: DVec3| off(x).abs() < 0.5 * depth;
    (s.is_finite()
        && off(s).abs() <= ON_SURFACE * h
        && s.distance(m) <= 0.5 * w.length() + h
        && s.distance(a) >= apart
        && s.distance(b) >= apart
        && better(0.5 * (a + s))
        && better(0.5 * (s + b)))
    .then_some(s)
}

/// Moves vertices onto the surface and splits the deepest candidates first, each triangle
/// at most once.
fn apply(
    positions: &mut Vec<Vec3>,
    triangles: &mut Vec<[u32; 3]>,
    mut found: Vec<(Cut, Vec3, f64)>,
) -> Vec<Split> {
    // Vertices off the surface first (their edges' splits wait for the next round), then the
    // deepest cuts.
    found.sort_by(|x, y| {
        let vertex = |c: &Cut| matches!(c, Cut::Vertex(..));
        vertex(&y.0).cmp(&vertex(&x.0)).then(y.2.total_cmp(&x.2))
    });
    let mut used = vec![false; triangles.len()];
    let mut splits = Vec::new();
    for (cut, s, _) in found {
        let tris = match &cut {
            Cut::Edge(e) => e.tris.to_vec(),
            Cut::Face(t) => vec![*t],
            Cut::Vertex(_, around) => around.clone(),
        };
        if tris.is_empty() {
            continue;
        }
        if tris.iter().any(|&t| used[t as usize]) {
            continue;
        }
        let v = positions.len() as u32;
        positions.push(s);
        let old: Vec<(usize, [u32; 3])> = tris
            .iter()
            .map(|&t| {
                used[t as usize] = true;
                (t as usize, triangles[t as usize])
            })
            .collect();
        let parts: Vec<([u32; 3], [u32; 3])> = match cut {
            Cut::Edge(e) => {
                // The first triangle holds a → b, the second b → a; each becomes two
                // triangles about v.
                let (a, b) = (e.a, e.b);
                let (t0, t1) = (old[0].1, old[1].1);
                let (c, d) = (third(t0, a, b), third(t1, b, a));
                vec![
                    ([a, v, c], t0),
                    ([v, b, c], t0),
                    ([b, v, d], t1),
                    ([v, a, d], t1),
                ]
            }
            Cut::Face(_) => {
                let [a, b, c] = old[0].1;
                vec![
                    ([a, b, v], old[0].1),
                    ([b, c, v], old[0].1),
                    ([c, a, v], old[0].1),
                ]
            }
            Cut::Vertex(u, _) => old
                .iter()
                .map(|&(_, t)| (t.map(|w| if w == u { v } else { w }), t))
                .collect(),
        };
        // The first parts go where the old triangles were, the rest at the end.
        let mut added = Vec::new();
        let mut new = Vec::new();
        for (k, (tri, from)) in parts.into_iter().enumerate() {
            let at = match old.get(k) {
                Some(&(t, _)) => t,
                None => {
                    triangles.push(tri);
                    added.push(triangles.len() - 1);
                    triangles.len() - 1
                }
            };
            triangles[at] = tri;
            new.push((at, from));
        }
        splits.push(Split { old, added, new });
    }
    splits
}

/// The vertex of `t` that follows the directed edge `a → b` in it.
fn third(t: [u32; 3], a: u32, b: u32) -> u32 {
    let i = (0..3)
        .find(|&i| t[i] == a && t[(i + 1) % 3] == b)
        .expect("the edge is in the triangle");
    t[(i + 2) % 3]
}

/// Takes back the splits whose triangles fold or cross others; returns the vertices of the
/// triangles of those that stand (one entry per split).
/// Taken-back splits leave their vertex unused (dropped when the mesh is compacted) and
/// their two added triangles as copies that [`take_back`] removes.
fn check(
    positions: &[Vec3],
    triangles: &mut Vec<[u32; 3]>,
    mut splits: Vec<Split>,
    field: &dyn Field,
) -> Vec<Vec<u32>> {
    // Folded (`beyond::folds`: facing against the triangle it replaces and the exact
    // surface), or degenerate.
    let folds = |s: &Split| {
        s.new.iter().any(|&(t, from)| {
            let p = triangles[t].map(|v| positions[v as usize].as_dvec3());
            super::beyond::folds(p, normal(positions, from).as_vec3(), Some(field))
        })
    };
    let (mut back, mut good): (Vec<Split>, Vec<Split>) = splits.drain(..).partition(folds);

    for s in &back {
        restore(triangles, s);
    }
    // Crossings: the new triangles against every triangle whose box meets theirs, until no
    // kept split's triangle crosses another.
    loop {
        let new: Vec<usize> = good
            .iter()
            .flat_map(|s| s.new.iter().map(|n| n.0))
            .collect();
        if new.is_empty() {
            break;
        }
        let sub = near_triangles(positions, triangles, &new, &back);
        let mesh = isokit_field::TriMesh::new(
            positions.to_vec(),
            sub.iter().map(|&t| triangles[t]).collect(),
        );
        let x = crate::intersect::self_intersections(&mesh);
        let mut crossing = std::collections::HashSet::new();
        for p in &x.pairs {
            for &t in p {
                crossing.insert(sub[t as usize]);
            }
        }
        let unlisted = x.pairs.len() < x.count;
        let before = good.len();
        let (cross, stay): (Vec<Split>, Vec<Split>) = good
            .into_iter()
            .partition(|s| unlisted || s.new.iter().any(|n| crossing.contains(&n.0)));
        good = stay;

        if good.len() == before {
            break;
        }
        for s in &cross {
            restore(triangles, s);
        }
        back.extend(cross);
    }
    let touched = good
        .iter()
        .map(|s| s.new.iter().flat_map(|n| triangles[n.0]).collect())
        .collect();
    take_back(triangles, &back);
    touched
}

fn restore(triangles: &mut [[u32; 3]], s: &Split) {
    for &(t, old) in &s.old {
        triangles[t] = old;
    }
}

/// Removes the triangles that taken-back splits added.
fn take_back(triangles: &mut Vec<[u32; 3]>, back: &[Split]) {
    let mut gone = vec![false; triangles.len()];
    for s in back {
        for &t in &s.added {
            gone[t] = true;
        }
    }
    let mut i = 0;
    triangles.retain(|_| {
        i += 1;
        !gone[i - 1]
    });
}

/// The triangles `new` and every triangle (not an added one of a taken-back split) whose
/// bounding box meets one of theirs.
fn near_triangles(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    new: &[usize],
    back: &[Split],
) -> Vec<usize> {
    let bbox = |t: usize| {
        let p = triangles[t].map(|v| positions[v as usize]);
        (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
    };
    // The new triangles' boxes sorted by their lower x: a triangle's box meets only those
    // whose lower x lies within the widest new box of its own.
    let mut boxes: Vec<(Vec3, Vec3)> = new.iter().map(|&t| bbox(t)).collect();
    boxes.sort_by(|x, y| x.0.x.total_cmp(&y.0.x));
    let widest = boxes.iter().map(|(l, h)| h.x - l.x).fold(0.0f32, f32::max);
    let mut skip = vec![false; triangles.len()];
    for s in back {
        for &t in &s.added {
            skip[t] = true;
        }
    }
    for &t in new {
        skip[t] = true;
    }
    let meets = |t: usize| {
        let (a, b) = bbox(t);
        let from = boxes.partition_point(|(l, _)| l.x < a.x - widest);
        boxes[from..]
            .iter()
            .take_while(|(l, _)| l.x <= b.x)
            .any(|(l, h)| !(a.cmpgt(*h).any() || b.cmplt(*l).any()))
    };
    let mut out: Vec<usize> = new.to_vec();
    out.par_extend(
        (0..triangles.len())
            .into_par_iter()
            .filter(|&t| !skip[t] && meets(t)),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The intersection of half-spaces `n · p ≤ 0` (a wedge or a corner at the origin),
    /// as the largest of the planes' signed distances.
    struct Planes(Vec<Vec3>);

    impl Field for Planes {
        fn value(&self, p: Vec3) -> f32 {
            self.0.iter().map(|n| n.dot(p)).fold(f32::MIN, f32::max)
        }
        fn bounds(&self) -> isokit_field::Aabb {
            isokit_field::Aabb::from_corners(Vec3::splat(-2.0), Vec3::splat(2.0))
        }
        fn gradient(&self, p: Vec3) -> Vec3 {
            *self
                .0
                .iter()
                .max_by(|a, b| a.dot(p).total_cmp(&b.dot(p)))
                .expect("planes")
        }
    }

    fn facing_out(positions: &[Vec3], triangles: &[[u32; 3]], f: &dyn Field) {
        for &t in triangles {
            let p = t.map(|v| positions[v as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let g = f.gradient((p[0] + p[1] + p[2]) / 3.0);
            assert!(n.dot(g) > 0.0, "{t:?} {p:?} faces {n}, surface {g}");
        }
    }

    #[test]
    fn an_edge_across_a_sharp_edge_is_split_on_it() {
        // The wedge x ≤ 0, y ≤ 0 (its edge the z axis). A strip on each face, and between
        // them a chamfer strip whose diagonal a0 → b1 passes a quarter below the edge.
        let f = Planes(vec![Vec3::X, Vec3::Y]);
        let mut positions = vec![
            Vec3::new(0.0, -0.5, 0.0), // a0
            Vec3::new(0.0, -0.5, 1.0), // a1
            Vec3::new(-0.5, 0.0, 0.0), // b0
            Vec3::new(-0.5, 0.0, 1.0), // b1
            Vec3::new(0.0, -1.5, 0.0), // face x = 0
            Vec3::new(0.0, -1.5, 1.0),
            Vec3::new(-1.5, 0.0, 0.0), // face y = 0
            Vec3::new(-1.5, 0.0, 1.0),
        ];
        let mut triangles = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 0, 1],
            [4, 1, 5],
            [2, 6, 7],
            [2, 7, 3],
        ];
        facing_out(&positions, &triangles, &f);
        let n = split_chamfers(
            &mut positions,
            &mut triangles,
            &f,
            0.0,
            (1.0, &[]),
            &Job::default(),
        )
        .unwrap();
        assert_eq!(n, 1);
        assert_eq!(triangles.len(), 8);
        // The new vertex on the edge, where the diagonal passes nearest it.
        let v = positions[8];
        assert!(v.distance(Vec3::new(0.0, 0.0, 0.5)) < 1e-6, "{v}");
        facing_out(&positions, &triangles, &f);
        // Every edge shared by at most two triangles, in opposite directions.
        let mesh = isokit_field::TriMesh::new(positions, triangles);
        let r = mesh.validate();
        assert!(r.consistently_oriented && r.non_manifold_edges == 0, "{r}");
    }

    #[test]
    fn a_vertex_off_the_surface_moves_onto_it() {
        // The wedge's strips of the first test with one vertex of the x = 0 face a fifth of
        // a cell inside (as a vertex clamped into its cell off a sharp edge lies).
        let f = Planes(vec![Vec3::X, Vec3::Y]);
        let mut positions = vec![
            Vec3::new(0.0, -0.5, 0.0),
            Vec3::new(0.0, -0.5, 1.0),
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(-0.5, 0.0, 1.0),
            Vec3::new(-0.2, -1.5, 0.0),
            Vec3::new(0.0, -1.5, 1.0),
            Vec3::new(-1.5, 0.0, 0.0),
            Vec3::new(-1.5, 0.0, 1.0),
        ];
        let mut triangles = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 0, 1],
            [4, 1, 5],
            [2, 6, 7],
            [2, 7, 3],
        ];
        split_chamfers(
            &mut positions,
            &mut triangles,
            &f,
            0.0,
            (1.0, &[]),
            &Job::default(),
        )
        .unwrap();
        // No triangle uses a vertex off the surface any more.
        for &v in triangles.iter().flatten() {
            let p = positions[v as usize];
            assert!(f.value(p).abs() < 1e-5, "vertex {v} at {p}");
        }
        facing_out(&positions, &triangles, &f);
        let r = isokit_field::TriMesh::new(positions, triangles).validate();
        assert!(r.consistently_oriented && r.non_manifold_edges == 0, "{r}");
    }

    #[test]
    fn a_triangle_across_a_corner_is_split_at_it() {
        // The corner x, y, z ≤ 0 cut off by a triangle whose three edges lie on its three
        // faces (each vertex on one of the corner's edges), closed by a tetrahedron inside.
        let f = Planes(vec![Vec3::X, Vec3::Y, Vec3::Z]);
        let mut positions = vec![
            Vec3::new(0.0, -0.5, 0.0),
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.5),
            Vec3::new(-0.4, -0.4, -0.4),
        ];
        let mut triangles = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        let n = split_chamfers(
            &mut positions,
            &mut triangles,
            &f,
            0.0,
            (1.0, &[]),
            &Job::default(),
        )
        .unwrap();
        assert!(n >= 1, "{n}");
        assert!(
            positions.iter().any(|p| p.length() < 1e-6),
            "no vertex at the corner: {positions:?}"
        );
        let mesh = isokit_field::TriMesh::new(positions, triangles);
        let r = mesh.validate();
        assert!(r.watertight && r.consistently_oriented, "{r}");
    }
}
