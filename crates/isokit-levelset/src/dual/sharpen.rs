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
//! triangle that misses it. Every round:
//!
//! - a mesh edge is a candidate where its midpoint lies more than [`CHAMFER`] of a cell off
//!   the surface, a triangle where its centroid does;
//! - the faces on either side are read from the exact gradient a little way in from each
//!   end of the edge ([`PROBES`]: just in, else a quarter of the way); for a triangle, from
//!   each vertex towards the other two and at the centroid. Two faces more than
//!   [`FEATURE_DEGREES`] apart give an edge (the line of their planes, each plane placed by
//!   the field's value where its gradient was read), three a corner;
//! - the split point is the point of that line nearest the mesh edge (inside it), or
//!   nearest the triangle's centroid, or the corner (inside the triangle seen along its
//!   normal); it is used where it lies on the surface (within [`ON_SURFACE`] of a cell),
//!   apart from the ends, not more than a cell beyond the edge or triangle, and where every
//!   new piece is less than half as deep as the whole was;
//! - a deep mesh edge whose quad's other diagonal lies on the surface is flipped (two
//!   triangles forming a tent over a concave corner, whose split point on the crease lies
//!   next to the quad's other two vertices and folds);
//! - a vertex more than [`VERTEX_OFF`] of a cell off the surface (clamped into its cell off
//!   a sharp edge, where every place on the edge folded) moves onto the surface by Newton
//!   steps along the gradient, onto the nearest face, by about as far as it is off; the next
//!   round splits its edges to the other face on the sharp edge. A vertex with a deep edge
//!   and no split point (the feature passes just beyond it: a cell's vertex clamped next to
//!   a corner outside the cell) moves onto the corner of the faces seen towards its
//!   neighbours, or the nearest point of the edge of two of them, where that is within
//!   [`SNAP`] of a cell and each of its edges ends less than half as deep as the deepest
//!   was. Adaptive
//!   meshing's merged vertices are not moved (they lie within the error bound of the
//!   surface by design). Moves go first, then flips, then the deepest splits; a triangle
//!   changes at most once a round;
//! - an edge's two triangles become four around the new vertex, a triangle three, a flip
//!   keeps two (the mesh stays closed, 2-manifold and oriented; a flip whose new edge exists
//!   is not made). A change is taken back where its triangles fold (facing against the
//!   triangle they replace and the exact surface, as `beyond::folds` tests) or are
//!   degenerate, where its new vertex lies within [`APART`] of a cell of another vertex near
//!   it (merging coincident vertices would pinch the mesh there), or where its triangles
//!   cross another triangle (exactly, [`crate::intersect`]);
//! - a mesh edge's split or a vertex's move that is taken back is tried again in the next
//!   round (a change beside it may have been what folded or crossed it; two changes that
//!   cross each other are both taken back and meet again), and otherwise once it is taken
//!   back twice: such a mesh edge is not split again, its ends move onto the feature instead
//!   (an end more than [`VERTEX_OFF`] off the surface onto the nearest face first; as where
//!   no split point exists: a vertex on one face a fraction of a cell from a sharp edge,
//!   whose edge's split point falls behind the edge's next vertex and crosses its
//!   triangle); such a vertex moves onto the edge or corner of the faces around it instead
//!   of the nearest face, and where that too is taken back twice, onto the nearest face
//!   again.
//!
//! Edges and triangles are looked at only around vertices of mesh edges whose two triangles
//! meet at more than [`CREASE_DEGREES`], so smooth parts cost the triangles' normals and one
//! field value per vertex (for the vertices off the surface); up to [`ROUNDS`] rounds change
//! what the round before changed or took back (every later round only around those). A
//! change blocked in its round by another (a triangle already changed) is looked at again
//! only where a change beside it stood or was taken back. Measured on two boxes, one
//! rotated 30° (`isokit-scene`'s `tests/dual.rs`): Hausdorff distance from the surface 0.27
//! voxel without these steps, 0.066 with the splits alone, 0.037 with the moves too (7
//! changes among 16,626 triangles); at resolution 128 two vertices clamped 0.14 and 0.09 cell
//! inside the surface and one 0.1 cell from a corner left 0.14 voxel before they were moved.
//! On random scenes of two boxes (a random rotation; union, difference or intersection;
//! `tests/peers/bench_random_boxes.py`), trying taken-back changes again and otherwise
//! brought 6 of 20 closer to the exact surface (one from 0.29 to 0.09 voxel) and none
//! farther, and the vertices of 2 closer; what is left there lies at features finer than a
//! cell (wedges, shallow creases, facets a cell or less across).

use glam::{DMat3, DVec3, Vec3};
use isokit_field::{Field, Job};
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};

use crate::meshing::MeshingError;

/// A mesh edge whose midpoint lies farther than this (in cells) from the surface cuts it.
const CHAMFER: f64 = 0.02;
/// A vertex farther than this (in cells) from the surface moves onto it (a cell's vertex on a
/// curved piece lies off it by about the chord's sag, which is left).
const VERTEX_OFF: f64 = 0.05;
/// The split point must lie this close (in cells) to the surface.
const ON_SURFACE: f64 = 0.005;
/// Gradients at least this far apart belong to different faces.
const FEATURE_DEGREES: f64 = 20.0;
/// Edges whose triangles meet at more than this are where chamfers are looked for.
const CREASE_DEGREES: f64 = 10.0;
/// A new vertex at least this far (in cells) from every other vertex near it.
const APART: f64 = 0.05;
/// How far (in cells) a vertex may move onto a corner or edge its edges miss.
const SNAP: f64 = 0.75;
/// Rounds: a round changes each triangle at most once.
const ROUNDS: usize = 8;
/// Where the faces are read, as fractions of the way in from a vertex: just in, else a
/// quarter of the way (where a vertex on an edge or corner of the surface sees either face).
const PROBES: [f64; 2] = [0.02, 0.25];

/// The exact field and the lattice spacing `h` the tolerances are counted in.
#[derive(Clone, Copy)]
pub(super) struct Surface<'a> {
    pub(super) field: &'a dyn Field,
    pub(super) iso: f32,
    pub(super) h: f64,
}

impl Surface<'_> {
    /// The field's value less the isovalue (about the signed distance).
    fn off(&self, p: DVec3) -> f64 {
        self.field.value(p.as_vec3()) as f64 - self.iso as f64
    }

    /// The unit gradient; zero where it is not finite or vanishes.
    fn normal(&self, p: DVec3) -> DVec3 {
        self.field
            .gradient(p.as_vec3())
            .as_dvec3()
            .normalize_or_zero()
    }

    /// Whether a point `depth` off the surface (NaN: no) is off it as a chamfer is.
    fn cuts(&self, depth: f64) -> bool {
        depth > CHAMFER * self.h
    }

    /// Whether `p` lies on the surface as a split point must.
    fn on(&self, p: DVec3) -> bool {
        self.off(p).abs() <= ON_SURFACE * self.h
    }

    /// The plane of the face seen at `x`: its unit normal `n` and `n · x₀` for its points
    /// `x₀` (placed by the field's value at `x`); `None` where the gradient vanishes.
    fn plane(&self, x: DVec3) -> Option<(DVec3, f64)> {
        let n = self.normal(x);
        (n != DVec3::ZERO).then(|| (n, n.dot(x) - self.off(x)))
    }
}

/// What [`split_chamfers`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Changed {
    /// Mesh edges and triangles split, and mesh edges flipped.
    pub(super) splits: usize,
    /// Vertices moved onto the surface.
    pub(super) moves: usize,
}

/// One change: the triangles it replaced (index and old vertices), those it added at the
/// end, every triangle it wrote with the old triangle that held it, and the vertex it added.
struct Split {
    old: Vec<(usize, [u32; 3])>,
    added: Vec<usize>,
    new: Vec<(usize, [u32; 3])>,
    vertex: Option<u32>,
    /// What it changed, to try otherwise where it is taken back.
    tried: Option<Tried>,
}

/// A change tried: the split of a mesh edge (by key), the move of a vertex onto the nearest
/// face, or onto an edge or corner of the surface.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Tried {
    Edge(u64),
    Move(u32),
    Snap(u32),
}

/// Where a vertex moves: onto the nearest face, or onto an edge or corner of the surface.
#[derive(Clone, Copy, PartialEq)]
enum Onto {
    Face,
    Feature,
}

/// What a change cuts: a mesh edge (its two triangles become four), or a triangle (three);
/// or a vertex off the surface that moves onto it (its triangles, listed, take a new
/// vertex in its place); or a mesh edge flipped (its two triangles take the other diagonal
/// of their quad).
#[derive(Clone)]
enum Cut {
    Edge(Edge),
    Face(u32),
    Vertex(u32, Vec<u32>, Onto),
    Flip(Edge),
}

/// Splits the chamfering edges and triangles of `triangles`, flips tents and moves vertices
/// onto the surface (module docs). New vertices are appended to `positions` (those of
/// changes taken back stay, unused: the caller compacts), new triangles to `triangles`.
/// Vertices `keep[v]` are not moved (adaptive meshing's merged vertices, which lie within
/// its error bound of the surface by design).
pub(super) fn split_chamfers(
    positions: &mut Vec<Vec3>,
    triangles: &mut Vec<[u32; 3]>,
    surface: Surface,
    keep: &[bool],
    job: &Job,
) -> Result<Changed, MeshingError> {
    let mut changed = Changed::default();
    // After the first round, only where the last round changed (the new triangles' vertices)
    // or took a change back (its vertices).
    let mut focus: Option<Vec<bool>> = None;
    // Changes taken back once (tried again: a change next to it may have been what folded
    // it), and twice: a mesh edge whose split crossed or folded twice has its ends moved
    // onto the feature instead, a vertex whose move onto the nearest face did moves onto the
    // edge or corner of the faces around it.
    let mut once: HashSet<Tried> = HashSet::new();
    let mut blocked: HashSet<Tried> = HashSet::new();
    for _ in 0..ROUNDS {
        job.check()?;
        let mut found = candidates(
            positions,
            triangles,
            focus.as_deref(),
            surface,
            keep,
            &blocked,
        );
        // Changes taken back before go after the others of their kind (moves, flips, splits;
        // their depth orders them only among themselves), so one that keeps folding does not
        // keep its neighbours from changing.
        for (cut, _, depth) in &mut found {
            if cut.tried().is_some_and(|k| once.contains(&k)) {
                *depth *= 1e-6;
            }
        }
        if found.is_empty() {
            break;
        }
        let splits = apply(positions, triangles, found);
        let (kept, back) = check(positions, triangles, splits, surface);
        let fresh: Vec<Tried> = back
            .into_iter()
            .filter(|&k| once.insert(k) || blocked.insert(k))
            .collect();
        if kept.is_empty() && fresh.is_empty() {
            break;
        }
        let mut f = vec![false; positions.len()];
        for k in fresh {
            let ends = match k {
                Tried::Edge(k) => [(k >> 32) as u32, k as u32],
                Tried::Move(v) | Tried::Snap(v) => [v, v],
            };
            for v in ends {
                f[v as usize] = true;
            }
        }
        for (vertices, moved) in &kept {
            if *moved {
                changed.moves += 1;
            } else {
                changed.splits += 1;
            }
            for &v in vertices {
                f[v as usize] = true;
            }
        }
        focus = Some(f);
    }
    Ok(changed)
}

impl Cut {
    /// What a change of this kind is remembered by where it is taken back.
    fn tried(&self) -> Option<Tried> {
        match self {
            Cut::Edge(e) => Some(Tried::Edge(key(e.a, e.b))),
            Cut::Vertex(u, _, Onto::Face) => Some(Tried::Move(*u)),
            Cut::Vertex(u, _, Onto::Feature) => Some(Tried::Snap(*u)),
            _ => None,
        }
    }
}

/// An interior mesh edge: its ends and its two triangles (the first has the edge as
/// `a → b`).
#[derive(Clone, Copy)]
struct Edge {
    a: u32,
    b: u32,
    tris: [u32; 2],
}

impl Edge {
    /// The quad's other two vertices: `c` after `a → b` in the first triangle, `d` after
    /// `b → a` in the second.
    fn opposite(&self, triangles: &[[u32; 3]]) -> (u32, u32) {
        let [t0, t1] = self.tris.map(|t| triangles[t as usize]);
        (third(t0, self.a, self.b), third(t1, self.b, self.a))
    }
}

/// An undirected edge's key.
fn key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
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
                (key(a, b), t, a < b)
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

/// The unit normal of triangle `t` (zero when degenerate).
fn normal(positions: &[Vec3], t: [u32; 3]) -> DVec3 {
    let p = t.map(|v| positions[v as usize].as_dvec3());
    (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
}

/// The changes to try, each with its new point (unused by flips) and how far off the
/// surface the edge's midpoint, the triangle's centroid or the vertex lies.
fn candidates(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    focus: Option<&[bool]>,
    sf: Surface,
    keep: &[bool],
    blocked: &HashSet<Tried>,
) -> Vec<(Cut, Vec3, f64)> {
    let pos = |v: u32| positions[v as usize].as_dvec3();
    let in_focus = |v: u32| focus.is_none_or(|f| f[v as usize]);
    let movable = |v: u32| in_focus(v) && !keep.get(v as usize).copied().unwrap_or(false);
    // The triangles looked at: all, or those with a vertex in `focus` (every edge at such a
    // vertex has both its triangles among them).
    let looked: Vec<u32> = (0..triangles.len() as u32)
        .into_par_iter()
        .filter(|&t| triangles[t as usize].iter().any(|&v| in_focus(v)))
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
        for v in [e.a, e.b] {
            near[v as usize] = in_focus(v);
        }
    }
    // Mesh edges whose midpoints lie off the surface, with how far.
    let deep: Vec<(Edge, f64)> = edges
        .par_iter()
        .filter(|e| near[e.a as usize] || near[e.b as usize])
        .filter_map(|e| {
            let depth = sf.off(0.5 * (pos(e.a) + pos(e.b))).abs();
            sf.cuts(depth).then_some((*e, depth))
        })
        .collect();
    let splits: Vec<Option<DVec3>> = deep
        .par_iter()
        .map(|(e, _)| {
            if blocked.contains(&Tried::Edge(key(e.a, e.b))) {
                return None;
            }
            PROBES
                .iter()
                .find_map(|&probe| split_point(sf, pos(e.a), pos(e.b), probe))
        })
        .collect();
    let mut found: Vec<(Cut, Vec3, f64)> = Vec::new();
    let mut unsplit: Vec<(u32, f64)> = Vec::new();
    for ((e, depth), s) in deep.iter().zip(&splits) {
        match s {
            Some(s) => found.push((Cut::Edge(*e), s.as_vec3(), *depth)),
            // The ends of deep edges with no split point (the feature passes just beyond an
            // end: a vertex clamped into its cell next to a corner or edge).
            None => unsplit.extend([(e.a, *depth), (e.b, *depth)]),
        }
        // The quad's other diagonal on the surface (a tent over a concave corner, whose
        // split point lies next to the quad's other two vertices and folds): a flip.
        let (c, d) = e.opposite(triangles);
        let better = [[c, e.a, d], [d, e.b, c]]
            .iter()
            .all(|t| sf.off((pos(t[0]) + pos(t[1]) + pos(t[2])) / 3.0).abs() < 0.5 * depth);
        if c != d && !sf.cuts(sf.off(0.5 * (pos(c) + pos(d))).abs()) && better {
            found.push((Cut::Flip(*e), Vec3::ZERO, *depth));
        }
    }
    // Triangles whose middle cuts a corner or an edge (each vertex on a different face or
    // edge of the surface around it).
    found.par_extend(
        looked
            .par_iter()
            .filter(|&&t| triangles[t as usize].iter().any(|&v| near[v as usize]))
            .filter_map(|&t| {
                let p = triangles[t as usize].map(pos);
                let depth = sf.off((p[0] + p[1] + p[2]) / 3.0).abs();
                if !sf.cuts(depth) {
                    return None;
                }
                PROBES
                    .iter()
                    .find_map(|&probe| face_point(sf, p, probe))
                    .map(|s| (Cut::Face(t), s.as_vec3(), depth))
            }),
    );
    // Vertices off the surface (clamped into their cells off a sharp edge): moved onto it by
    // Newton steps along the gradient, to the nearest face (by about as far as they are
    // off); the splits of the next round then put their edges to the other face on the
    // sharp edge. Every vertex in focus is looked at, creased or not: the triangles around
    // a vertex off the surface can lie flat.
    let off: Vec<(u32, f64)> = (0..positions.len() as u32)
        .into_par_iter()
        .filter(|&v| movable(v))
        .map(|v| (v, sf.off(pos(v)).abs()))
        .filter(|&(_, depth)| depth > VERTEX_OFF * sf.h)
        .collect();
    // A vertex whose move onto the nearest face was taken back twice goes onto the edge or
    // corner of the faces around it instead (with the vertices next to a feature their
    // edges miss); where that too was taken back twice, onto the nearest face again (a
    // change beside it may since have made room). Its own depth is the bound its snapped
    // edges must halve.
    let (stuck, off): (Vec<_>, Vec<_>) = off.into_iter().partition(|&(v, _)| {
        blocked.contains(&Tried::Move(v)) && !blocked.contains(&Tried::Snap(v))
    });
    unsplit.extend(stuck);
    let off_surface: Vec<(u32, DVec3, f64)> = off
        .into_par_iter()
        .filter_map(|(v, depth)| {
            super::newton_onto(sf.field, sf.iso, pos(v), sf.h, ON_SURFACE)
                .filter(|s| s.distance(pos(v)) <= 2.0 * depth + ON_SURFACE * sf.h)
                .map(|s| (v, s, depth))
        })
        .collect();
    let moving: HashSet<u32> = off_surface.iter().map(|m| m.0).collect();
    // The vertices next to a corner or edge their deep edges miss, deepest edge first.
    unsplit
        .retain(|&(v, _)| movable(v) && !moving.contains(&v) && !blocked.contains(&Tried::Snap(v)));
    unsplit.sort_by(|x, y| x.0.cmp(&y.0).then(y.1.total_cmp(&x.1)));
    unsplit.dedup_by_key(|x| x.0);
    let mut around: HashMap<u32, Vec<u32>> = moving
        .iter()
        .chain(unsplit.iter().map(|u| &u.0))
        .map(|&v| (v, Vec::new()))
        .collect();
    if around.is_empty() {
        return found;
    }
    for &t in &looked {
        let tri = triangles[t as usize];
        for (i, v) in tri.iter().enumerate() {
            // Once per triangle, also where a vertex repeats.
            if tri[..i].contains(v) {
                continue;
            }
            if let Some(list) = around.get_mut(v) {
                list.push(t);
            }
        }
    }
    let snapped: Vec<(u32, DVec3, f64)> = unsplit
        .par_iter()
        .filter_map(|&(v, depth)| {
            let ring: Vec<DVec3> = around[&v]
                .iter()
                .flat_map(|&t| triangles[t as usize])
                .filter(|&w| w != v)
                .map(pos)
                .collect();
            vertex_point(sf, pos(v), &ring, depth).map(|s| (v, s, depth))
        })
        .collect();
    let onto = off_surface
        .into_iter()
        .map(|m| (m, Onto::Face))
        .chain(snapped.into_iter().map(|m| (m, Onto::Feature)));
    found.extend(onto.map(|((v, s, depth), onto)| {
        let list = around.remove(&v).unwrap_or_default();
        (Cut::Vertex(v, list, onto), s.as_vec3(), depth)
    }));
    found
}

/// The point of the line where the planes `a` and `b` (unit normal, offset) meet nearest
/// `near`; `None` where they are (nearly) parallel.
fn line_point(a: (DVec3, f64), b: (DVec3, f64), near: DVec3) -> Option<DVec3> {
    let c = a.0.dot(b.0);
    let det = 1.0 - c * c;
    if det.is_nan() || det <= 1e-9 {
        return None;
    }
    let (ra, rb) = (a.1 - a.0.dot(near), b.1 - b.0.dot(near));
    Some(near + (ra - c * rb) / det * a.0 + (rb - c * ra) / det * b.0)
}

/// The corner of the faces seen at `probes` (each more than [`FEATURE_DEGREES`] from the
/// others), or the point of the edge of the first two nearest `near`; `None` with fewer
/// than two faces.
fn feature_point(sf: Surface, probes: &[DVec3], near: DVec3) -> Option<DVec3> {
    let apart = FEATURE_DEGREES.to_radians().cos();
    let mut planes: Vec<(DVec3, f64)> = Vec::with_capacity(probes.len());
    for &x in probes {
        let plane = sf.plane(x)?;
        if planes.iter().all(|q| plane.0.dot(q.0) < apart) {
            planes.push(plane);
        }
    }
    match planes[..] {
        [a, b, c, ..] if DMat3::from_cols(a.0, b.0, c.0).determinant().abs() > 0.1 => {
            Some(DMat3::from_cols(a.0, b.0, c.0).transpose().inverse() * DVec3::new(a.1, b.1, c.1))
        }
        [a, b, ..] => line_point(a, b, near),
        _ => None,
    }
}

/// Where the vertex at `p` (its neighbours `ring`) goes onto a corner or edge of the surface
/// that its edges, the deepest `depth` off the surface, miss: the corner of the faces seen
/// from it towards its neighbours (a quarter of the way), or the point of the edge of two of
/// them nearest `p`; within [`SNAP`] of a cell of `p`, on the surface, and with every edge to the
/// ring less than half as deep as the deepest was.
fn vertex_point(sf: Surface, p: DVec3, ring: &[DVec3], depth: f64) -> Option<DVec3> {
    let probes: Vec<DVec3> = ring.iter().map(|&w| p + PROBES[1] * (w - p)).collect();
    let s = feature_point(sf, &probes, p)?;
    let moved = s.distance(p);
    (moved <= SNAP * sf.h
        && moved >= APART * sf.h
        && sf.on(s)
        && ring
            .iter()
            .all(|&w| sf.off(0.5 * (s + w)).abs() < 0.5 * depth))
    .then_some(s)
}

/// The split point of the triangle `p` (module docs): the corner of the faces seen from its
/// vertices (gradients taken `probe` of the way in towards the other two) and its centroid,
/// or the point of the edge of two of them nearest the centroid.
fn face_point(sf: Surface, p: [DVec3; 3], probe: f64) -> Option<DVec3> {
    let g = (p[0] + p[1] + p[2]) / 3.0;
    let depth = sf.off(g).abs();
    // From each vertex towards the other two (a vertex on an edge or at a corner sees a
    // different face in each direction), and the centroid.
    let probes: Vec<DVec3> = (0..3)
        .flat_map(|i| [1, 2].map(|k| p[i] + probe * (p[(i + k) % 3] - p[i])))
        .chain([g])
        .collect();
    let s = feature_point(sf, &probes, g)?;
    // Inside the triangle seen along its normal, apart from its vertices, on the surface,
    // and each new triangle less than half as deep.
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let inside = (0..3).all(|i| {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        (b - a).cross(s - a).dot(n) > 0.02 * n.length_squared()
    });
    let better = (0..3).all(|i| sf.off((p[i] + p[(i + 1) % 3] + s) / 3.0).abs() < 0.5 * depth);
    (s.is_finite()
        && inside
        && sf.on(s)
        && s.distance(g) <= p.iter().map(|v| v.distance(g)).fold(0.0, f64::max) + sf.h
        && p.iter().all(|v| s.distance(*v) >= APART * sf.h)
        && better)
        .then_some(s)
}

/// The split point of the mesh edge `a b` (module docs), with the faces' gradients taken
/// `probe` of the way in from either end.
fn split_point(sf: Surface, a: DVec3, b: DVec3, probe: f64) -> Option<DVec3> {
    let (m, w) = (0.5 * (a + b), b - a);
    let depth = sf.off(m).abs();
    let pa = sf.plane(a + probe * w)?;
    let pb = sf.plane(b - probe * w)?;
    if pa.0.dot(pb.0) >= FEATURE_DEGREES.to_radians().cos() {
        return None;
    }
    // The line of both faces' planes: its point p0 nearest m, its direction u.
    let p0 = line_point(pa, pb, m)?;
    let u = pa.0.cross(pb.0).normalize_or_zero();
    // The split point: the point of the line nearest the segment, where that is inside the
    // segment and apart from its ends.
    let d = a - p0;
    let (ww, wu) = (w.length_squared(), w.dot(u));
    let t = (wu * u.dot(d) - w.dot(d)) / (ww - wu * wu);
    if !(t > 0.0 && t < 1.0) {
        return None;
    }
    let s = p0 + u.dot(a + t * w - p0) * u;
    let apart = APART * sf.h;
    let better = |x: DVec3| sf.off(x).abs() < 0.5 * depth;
    (s.is_finite()
        && sf.on(s)
        && s.distance(m) <= 0.5 * w.length() + sf.h
        && s.distance(a) >= apart
        && s.distance(b) >= apart
        && better(0.5 * (a + s))
        && better(0.5 * (s + b)))
    .then_some(s)
}

/// Makes the changes: vertices onto the surface first, then flips, then the deepest splits,
/// each triangle at most once.
fn apply(
    positions: &mut Vec<Vec3>,
    triangles: &mut Vec<[u32; 3]>,
    mut found: Vec<(Cut, Vec3, f64)>,
) -> Vec<Split> {
    // Vertices off the surface first (their edges' splits wait for the next round), then
    // flips (no new vertex), then the deepest cuts.
    let rank = |c: &Cut| match c {
        Cut::Vertex(..) => 2,
        Cut::Flip(_) => 1,
        _ => 0,
    };
    found.sort_by(|x, y| rank(&y.0).cmp(&rank(&x.0)).then(y.2.total_cmp(&x.2)));
    // The edges at the flips' new ends: a flip must not make an edge that exists.
    let ends: HashSet<u32> = found
        .iter()
        .filter_map(|(c, ..)| match c {
            Cut::Flip(e) => Some(e.opposite(triangles)),
            _ => None,
        })
        .flat_map(|(c, d)| [c, d])
        .collect();
    let mut existing: HashSet<u64> = HashSet::new();
    if !ends.is_empty() {
        for t in triangles
            .iter()
            .filter(|t| t.iter().any(|v| ends.contains(v)))
        {
            for i in 0..3 {
                existing.insert(key(t[i], t[(i + 1) % 3]));
            }
        }
    }
    let mut used = vec![false; triangles.len()];
    let mut splits = Vec::new();
    for (cut, s, _) in found {
        let tris = match &cut {
            Cut::Edge(e) | Cut::Flip(e) => e.tris.to_vec(),
            Cut::Face(t) => vec![*t],
            Cut::Vertex(_, around, _) => around.clone(),
        };
        if tris.is_empty() || tris.iter().any(|&t| used[t as usize]) {
            continue;
        }
        if let Cut::Flip(e) = &cut {
            let (c, d) = e.opposite(triangles);
            if !existing.insert(key(c, d)) {
                continue;
            }
        }
        let tried = cut.tried();
        let v = positions.len() as u32;
        let vertex = (!matches!(cut, Cut::Flip(_))).then(|| {
            positions.push(s);
            v
        });
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
            Cut::Vertex(u, ..) => old
                .iter()
                .map(|&(_, t)| (t.map(|w| if w == u { v } else { w }), t))
                .collect(),
            Cut::Flip(e) => {
                // The quad c a d b, split along c d instead of a b.
                let (t0, t1) = (old[0].1, old[1].1);
                let (c, d) = (third(t0, e.a, e.b), third(t1, e.b, e.a));
                vec![([c, e.a, d], t0), ([d, e.b, c], t1)]
            }
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
        splits.push(Split {
            old,
            added,
            new,
            vertex,
            tried,
        });
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

/// Takes back the changes whose triangles fold, whose new vertex lies within [`APART`] of a
/// vertex near it (merging coincident vertices would pinch the mesh there), or whose
/// triangles cross others. Returns, per change that stands, its triangles' vertices and
/// whether it was a vertex move, and the edge splits and vertex moves taken back. Taken-back
/// changes leave their vertex unused (dropped when the mesh is compacted) and their added
/// triangles as copies that [`take_back`] removes.
fn check(
    positions: &[Vec3],
    triangles: &mut Vec<[u32; 3]>,
    splits: Vec<Split>,
    sf: Surface,
) -> (Vec<(Vec<u32>, bool)>, Vec<Tried>) {
    // Folded (`beyond::folds`: facing against the triangle it replaces and the exact
    // surface), or degenerate.
    let folds = |s: &Split| {
        s.new.iter().any(|&(t, from)| {
            let p = triangles[t].map(|v| positions[v as usize].as_dvec3());
            super::beyond::folds(p, normal(positions, from).as_vec3(), Some(sf.field))
        })
    };
    let (mut back, mut good): (Vec<Split>, Vec<Split>) = splits.into_iter().partition(folds);
    for s in &back {
        restore(triangles, s);
    }
    // New vertices next to another vertex.
    if !good.is_empty() {
        let new: Vec<usize> = good
            .iter()
            .flat_map(|s| s.new.iter().map(|n| n.0))
            .collect();
        let around = near_triangles(positions, triangles, &new, &back);
        let crowded = crowded(positions, triangles, &around, APART * sf.h);
        let (bad, stay): (Vec<Split>, Vec<Split>) = good
            .into_iter()
            .partition(|s| s.vertex.is_some_and(|v| crowded.contains(&v)));
        good = stay;
        for s in &bad {
            restore(triangles, s);
        }
        back.extend(bad);
    }
    // Crossings: the new triangles against every triangle whose box meets theirs, until no
    // kept change's triangle crosses another.
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
        let crossing: HashSet<usize> = x.pairs.iter().flatten().map(|&t| sub[t as usize]).collect();
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
    let kept = good
        .iter()
        .map(|s| {
            let vertices = s.new.iter().flat_map(|n| triangles[n.0]).collect();
            // A move replaces a vertex in each of its triangles and adds none.
            (vertices, s.vertex.is_some() && s.added.is_empty())
        })
        .collect();
    take_back(triangles, &back);
    (kept, back.iter().filter_map(|s| s.tried).collect())
}

/// The new vertices among the triangles `around` with another vertex within `apart`.
fn crowded(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    around: &[usize],
    apart: f64,
) -> HashSet<u32> {
    let cell = |p: Vec3| (p.as_dvec3() / apart).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<u32>> = HashMap::new();
    let mut vertices: Vec<u32> = around.iter().flat_map(|&t| triangles[t]).collect();
    vertices.sort_unstable();
    vertices.dedup();
    for &v in &vertices {
        grid.entry(cell(positions[v as usize])).or_default().push(v);
    }
    let mut out = HashSet::new();
    for &v in &vertices {
        let (p, c) = (positions[v as usize], cell(positions[v as usize]));
        let close = (-1..=1)
            .flat_map(|z| {
                (-1..=1).flat_map(move |y| (-1..=1).map(move |x| glam::IVec3::new(x, y, z)))
            })
            .filter_map(|d| grid.get(&(c + d)))
            .flatten()
            .any(|&w| w != v && (positions[w as usize].as_dvec3() - p.as_dvec3()).length() < apart);
        if close {
            out.insert(v);
        }
    }
    out
}

/// Puts back the triangles a change replaced.
fn restore(triangles: &mut [[u32; 3]], s: &Split) {
    for &(t, old) in &s.old {
        triangles[t] = old;
    }
}

/// Removes the triangles that taken-back changes added.
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

    /// The wedge x ≤ 0, y ≤ 0 (its edge the z axis): a strip on each face, and between them
    /// a chamfer strip whose diagonal a0 → b1 passes a quarter below the edge. The x = 0
    /// face's outer vertex at z = 0 lies `inside` within the wedge.
    fn wedge_strips(inside: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let positions = vec![
            Vec3::new(0.0, -0.5, 0.0),     // a0
            Vec3::new(0.0, -0.5, 1.0),     // a1
            Vec3::new(-0.5, 0.0, 0.0),     // b0
            Vec3::new(-0.5, 0.0, 1.0),     // b1
            Vec3::new(-inside, -1.5, 0.0), // face x = 0
            Vec3::new(0.0, -1.5, 1.0),
            Vec3::new(-1.5, 0.0, 0.0), // face y = 0
            Vec3::new(-1.5, 0.0, 1.0),
        ];
        let triangles = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 0, 1],
            [4, 1, 5],
            [2, 6, 7],
            [2, 7, 3],
        ];
        (positions, triangles)
    }

    /// [`split_chamfers`] with cells of side 1 and nothing kept.
    fn sharpen(f: &dyn Field, positions: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>) -> Changed {
        let surface = Surface {
            field: f,
            iso: 0.0,
            h: 1.0,
        };
        split_chamfers(positions, triangles, surface, &[], &Job::default()).unwrap()
    }

    #[test]
    fn an_edge_across_a_sharp_edge_is_split_on_it() {
        let f = Planes(vec![Vec3::X, Vec3::Y]);
        let (mut positions, mut triangles) = wedge_strips(0.0);
        facing_out(&positions, &triangles, &f);
        let n = sharpen(&f, &mut positions, &mut triangles);
        assert_eq!(
            n,
            Changed {
                splits: 1,
                moves: 0
            }
        );
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
        // One vertex of the x = 0 face a fifth of a cell inside (as a vertex clamped into its
        // cell off a sharp edge lies).
        let f = Planes(vec![Vec3::X, Vec3::Y]);
        let (mut positions, mut triangles) = wedge_strips(0.2);
        let n = sharpen(&f, &mut positions, &mut triangles);
        assert!(n.moves >= 1, "{n:?}");
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
        let n = sharpen(&f, &mut positions, &mut triangles);
        assert!(n.splits >= 1, "{n:?}");
        assert!(
            positions.iter().any(|p| p.length() < 1e-6),
            "no vertex at the corner: {positions:?}"
        );
        let mesh = isokit_field::TriMesh::new(positions, triangles);
        let r = mesh.validate();
        assert!(r.watertight && r.consistently_oriented, "{r}");
    }
}
