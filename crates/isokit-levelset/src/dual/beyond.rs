//! Vertices on an edge beyond their cell, and folds undone.
//!
//! A cell can hold both faces of a sharp edge without holding the edge itself: near a convex
//! edge at a general angle to the lattice, the samples of a cell see the two planes while
//! their line passes just outside the cell (the two faces' crossings lie on the cell's
//! edges, the edge in a neighbouring cell's corner region). One vertex inside the cell
//! cannot lie on both planes; clamped into the cell it lies up to about 0.15 cell inside the
//! solid and the edge is cut (Ju et al. 2002, Sec. 2.3: clamping the minimiser is what
//! loses such features). With an exact field, the point of the edge's line nearest the cell
//! is exact; it is used when it lies within half a cell of the cell and on the surface, and
//! the point of the line nearest the clamped vertex is the second choice. Where the
//! crossings hold three planes whose corner is not on the surface near the cell (a plane
//! passing by without meeting the other two there), the edges of two of the planes that are
//! near and on the surface are used the same way, the one nearest the surface first.
//!
//! A vertex outside its cell can fold the mesh, and so can a quad split along the wrong
//! diagonal where it straddles a sharp edge (both its vertices exact, on the two faces), and
//! a vertex on an edge of a faceted field's planes (a mesh operand's facets meet at a few
//! degrees, and their edge can pass anywhere through the cell). So the triangles are checked
//! as the adaptive merging's are ([`super::merge`]): every round, a quad with a triangle that
//! folds ([`folds`]: facing against its crossing's normal and the exact surface's, or
//! degenerate) or crosses another triangle (exactly,
//! [`crate::intersect`]) moves its moved vertices to their second choice or back into their
//! cells or, with none and where every quad it could cross is tested, is split along its
//! other diagonal (once; a quad still flagged after that goes back to its first split for
//! good; the first split is the shorter diagonal, or where a vertex is on a sharp feature
//! the one nearer the exact surface, [`first_diagonals`]). When a round has nothing else to
//! change, the vertices of the quads still flagged go to their loops' mass points of
//! crossings (the vertex of surface nets, inside the cell, moved onto the exact surface: the
//! sharp feature is given up there for a mesh that does not fold; a vertex on a sharp
//! feature first only where its quad crosses another, and when nothing else is left also
//! where it faces the wrong way, [`Smooth::sharp`]), where every quad they
//! could cross is tested. When nothing flagged can change any
//! more the result stands; when changes are still pending after `ROUNDS` rounds, or more
//! crossings are found than listed, every vertex goes back to its first place in its cell
//! and every quad takes its shorter diagonal: the result is either checked or the plain
//! in-cell mesh, so these steps add no fold.
//!
//! Facing and degeneracy are checked on every quad; intersections on the quads within two
//! cells of a cell where the mesh can fold (a vertex clamped, on a sharp feature, on a thin
//! wall's two opposite planes, on an edge or corner of planes at a smaller angle, or beyond its
//! cell, or several vertices in one cell); a quad may take its other diagonal only within
//! one cell of such a place, and a vertex may go to its mass point only in such a cell, so
//! that whatever they could cross is tested. Each quad's triangles lie in the four cells
//! around its lattice edge (half a cell more for a moved vertex), so only quads whose cells
//! are that close can cross; where every vertex lies inside its cell on one plane of
//! crossings the mesh follows the marching-cubes surface, which does not cross itself. On
//! the shipped scenes (faceted mesh operands, thin blends) this leaves no crossing and no
//! triangle facing the wrong way (`demo.json` had 88 crossing pairs among 54,448 triangles
//! without these steps, 46 with moves and flips alone).

use glam::{DVec3, Vec3};
use isokit_field::{Field, Job, TriMesh};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::HashMap;

use crate::meshing::MeshingError;

/// Rounds of checking before every change is taken back.
const ROUNDS: usize = 12;

/// A vertex placed beyond its cell: its index, its position clamped into the cell, and a
/// second place beyond the cell to try before that.
pub(super) struct Moved {
    pub(super) vertex: u32,
    pub(super) in_cell: Vec3,
    pub(super) next: Option<Vec3>,
}

/// The place of last resort for a vertex whose quads fold: its loop's mass point of
/// crossings, moved onto the surface (where there is an exact field) when it is used.
#[derive(Clone, Copy)]
pub(super) struct Smooth {
    pub(super) at: Vec3,
    /// The vertex is on a sharp feature (an edge or corner of planes more than
    /// `SHARP_DEGREES` apart, not clamped off it): it goes to `at` where its quads cross
    /// others, and where they merely face the wrong way (a sliver at a corner, where several
    /// cells' vertices meet on the corner point) only when nothing else is left to change
    /// (thin walls twisted across the lattice: `vase.json` at resolution 128).
    pub(super) sharp: bool,
}

/// The quads [`unfold`] checks: `normals[i]` is the crossing normal of quad `i`; `near[i]`:
/// tested for intersections; `flippable[i]`: free to take its other diagonal.
pub(super) struct Checked<'a> {
    pub(super) quads: &'a [[u32; 4]],
    pub(super) normals: &'a [Vec3],
    pub(super) near: &'a [bool],
    pub(super) flippable: &'a [bool],
    /// The diagonal each quad is split along first ([`first_diagonals`]; the shorter where
    /// `None`).
    pub(super) first: &'a [Option<[u32; 2]>],
}

/// What [`unfold`] gives.
pub(super) struct Unfolded {
    /// Two per quad, in quad order.
    pub(super) triangles: Vec<[u32; 3]>,
    /// Moved vertices kept beyond their cells.
    pub(super) beyond: usize,
    /// Triangles still facing the wrong way, degenerate or crossing another at the end (at
    /// least the number of intersecting pairs when more are found than listed).
    pub(super) folded: usize,
    /// The quads split along the diagonal that is not the shorter: their canonical form
    /// (`merge::canonical`) and the diagonal taken (its two vertices, smaller first).
    pub(super) flipped: HashMap<[u32; 4], [u32; 2]>,
}

/// The diagonal of a quad split into the triangles `t` (the two vertices both share),
/// smaller vertex first.
fn diagonal(t: &[[u32; 3]]) -> [u32; 2] {
    let mut d = [u32::MAX; 2];
    let mut n = 0;
    for v in t[0] {
        if n < 2 && t[1].contains(&v) {
            d[n] = v;
            n += 1;
        }
    }
    [d[0].min(d[1]), d[0].max(d[1])]
}

/// The quad `q` split along the diagonal `d` (two of its vertices), keeping its
/// orientation.
pub(super) fn split_along(q: [u32; 4], d: [u32; 2]) -> [[u32; 3]; 2] {
    let [a, b, c, dd] = q;
    if [a.min(c), a.max(c)] == d {
        [[a, b, c], [a, c, dd]]
    } else {
        [[a, b, dd], [b, c, dd]]
    }
}

/// How a quad is split: along its first diagonal (0: `first`, or the shorter one), the
/// other one (1), or the first for good after the other did not help (2).
pub(super) fn split(
    q: [u32; 4],
    positions: &[Vec3],
    first: Option<[u32; 2]>,
    state: u8,
) -> [[u32; 3]; 2] {
    let [a, b, c, d] = q;
    let first = match first {
        Some(diag) => split_along(q, diag),
        None => super::split_quad(q, positions),
    };
    if state != 1 {
        first
    } else if first[0] == [a, b, c] {
        [[a, b, d], [b, c, d]]
    } else {
        [[a, b, c], [a, c, d]]
    }
}

/// The diagonal to split each quad along first, where it is not the shorter one: across a
/// sharp feature the shorter diagonal can cut a face near an edge or corner (a triangle from
/// a vertex on one face over to vertices on the edges of another), which chamfers the face
/// by a fraction of a cell. For the quads free to take either diagonal (`flippable`) with a
/// vertex on a sharp feature (`feature`), and an exact field, the split whose triangles'
/// centroids and diagonal's midpoint lie nearer the surface is taken, where it halves the
/// shorter split's largest distance; but where the split so chosen holds a sliver and the
/// other does not ([`unless_sliver`]) and lies no more than 1% of the longer diagonal
/// farther from the surface, the other is taken.
pub(super) fn first_diagonals(
    quads: &[[u32; 4]],
    positions: &[Vec3],
    flippable: &[bool],
    feature: &[bool],
    field: Option<&dyn Field>,
    iso: f32,
) -> Vec<Option<[u32; 2]>> {
    let Some(f) = field else {
        return vec![None; quads.len()];
    };
    let off = |t: [[u32; 3]; 2]| {
        let d = diagonal(&t);
        let mid = (positions[d[0] as usize] + positions[d[1] as usize]) / 2.0;
        let centroid = |t: [u32; 3]| t.map(|v| positions[v as usize]).iter().sum::<Vec3>() / 3.0;
        [mid, centroid(t[0]), centroid(t[1])]
            .iter()
            .map(|&p| (f.value(p) - iso).abs())
            .fold(0.0f32, f32::max)
    };
    quads
        .par_iter()
        .enumerate()
        .map(|(i, &q)| {
            if !flippable[i] || !q.iter().any(|&v| feature[v as usize]) {
                return None;
            }
            let shorter = split(q, positions, None, 0);
            let other = split(q, positions, None, 1);
            let (near_s, near_o) = (off(shorter), off(other));
            let (pick, alt, near_p, near_a) = if near_o < 0.5 * near_s {
                (other, shorter, near_o, near_s)
            } else {
                (shorter, other, near_s, near_o)
            };
            // Three vertices on a sharp edge make a sliver lying on one face (on the
            // surface, so the nearer split), folded back against the other face where the
            // edge curves: the split without it, where that lies about as near.
            let scale = [diagonal(&shorter), diagonal(&other)]
                .iter()
                .map(|d| positions[d[0] as usize].distance(positions[d[1] as usize]))
                .fold(0.0f32, f32::max);
            let chosen = if near_a <= near_p + 0.01 * scale {
                unless_sliver(pick, alt, positions)
            } else {
                pick
            };
            (diagonal(&chosen) != diagonal(&shorter)).then(|| diagonal(&chosen))
        })
        .collect()
}

/// Below this ratio of twice a triangle's area to its longest side squared (its height
/// over its base), a triangle is a sliver for [`unless_sliver`].
const SLIVER: f32 = 0.05;

/// The split `pick`, or `alt` where `pick` holds a sliver (three vertices nearly in a line
/// along a sharp edge, [`SLIVER`]) and `alt`'s thinnest triangle is more than twice as
/// thick: such a sliver lies on one face and folds back against the other where the edge
/// curves.
pub(super) fn unless_sliver(
    pick: [[u32; 3]; 2],
    alt: [[u32; 3]; 2],
    positions: &[Vec3],
) -> [[u32; 3]; 2] {
    let (thin_p, thin_a) = (thinness(pick, positions), thinness(alt, positions));
    if thin_p < SLIVER && thin_a > 2.0 * thin_p {
        alt
    } else {
        pick
    }
}

/// The smaller of the two triangles' ratios of twice the area to the longest side squared.
fn thinness(t: [[u32; 3]; 2], positions: &[Vec3]) -> f32 {
    t.iter()
        .map(|t| {
            let p = t.map(|v| positions[v as usize]);
            let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
            let long = [(0, 1), (1, 2), (2, 0)]
                .iter()
                .map(|&(a, b)| p[a].distance_squared(p[b]))
                .fold(0.0f32, f32::max);
            if long > 0.0 { area2 / long } else { 0.0 }
        })
        .fold(f32::INFINITY, f32::min)
}

/// Whether the triangle `p` folds: degenerate (as `TriMesh::validate` counts them), or facing
/// against `n`, the normal of the crossing it came from, and, with an exact field, against
/// the field's gradient at its centroid too. The crossing is up to a cell away: across a
/// sharp edge whose faces turn by more than a right angle, a triangle lying on one face
/// faces against the other's crossing normal without folding.
pub(super) fn folds(p: [DVec3; 3], n: Vec3, field: Option<&dyn Field>) -> bool {
    let normal = (p[1] - p[0]).cross(p[2] - p[0]);
    if isokit_field::mesh::zero_area(p[0], p[1], p[2]) {
        return true;
    }
    if normal.dot(n.as_dvec3()) > 0.0 {
        return false;
    }
    field.is_none_or(|f| {
        let centroid = ((p[0] + p[1] + p[2]) / 3.0).as_vec3();
        // Not facing along it (NaN included).
        normal
            .dot(f.gradient(centroid).as_dvec3())
            .partial_cmp(&0.0)
            != Some(Ordering::Greater)
    })
}

/// Checks the quads' triangles with the moved vertices (already at their positions beyond
/// their cells in `positions`) and undoes what folds (module docs). `smooth[v]`: where
/// vertex `v` may go last, through `onto` (the vertex and the mass point give the place).
pub(super) fn unfold(
    positions: &mut [Vec3],
    mut moved: Vec<Moved>,
    checked: Checked,
    mut smooth: Vec<Option<Smooth>>,
    onto: &(dyn Fn(u32, Vec3) -> Vec3 + Sync),
    field: Option<&dyn Field>,
    job: &Job,
) -> Result<Unfolded, MeshingError> {
    let Checked {
        quads,
        normals,
        near,
        flippable,
        first,
    } = checked;
    // The triangles tested for intersections: those of the quads `near` a place that can
    // fold, as indices into the quads' triangles.
    let tested: Vec<u32> = (0..quads.len() as u32)
        .filter(|&q| near[q as usize])
        .flat_map(|q| [2 * q, 2 * q + 1])
        .collect();
    let mut is_moved = vec![false; positions.len()];
    let mut next: Vec<Option<Vec3>> = vec![None; positions.len()];
    for m in &moved {
        is_moved[m.vertex as usize] = true;
        next[m.vertex as usize] = m.next;
    }
    let mut state = vec![0u8; quads.len()];
    // Vertices sent to their mass points, with where they were.
    let mut smoothed: Vec<(u32, Vec3)> = Vec::new();
    let mut last = false;
    let mut round = 0;
    loop {
        job.check()?;
        let triangles: Vec<[u32; 3]> = quads
            .par_iter()
            .zip(&state)
            .zip(first)
            .flat_map_iter(|((&q, &s), &d)| split(q, positions, d.filter(|_| !last), s))
            .collect();
        // Facing the wrong way, or degenerate.
        let mut flagged: Vec<bool> = triangles
            .par_chunks(2)
            .zip(normals)
            .map(|(pair, &n)| {
                pair.iter()
                    .any(|t| folds(t.map(|v| positions[v as usize].as_dvec3()), n, field))
            })
            .collect();
        let sub = TriMesh::new(
            positions.to_vec(),
            tested.iter().map(|&t| triangles[t as usize]).collect(),
        );
        let x = crate::intersect::self_intersections(&sub);
        let mut crossing = vec![false; quads.len()];
        for &t in x.pairs.iter().flatten() {
            flagged[tested[t as usize] as usize / 2] = true;
            crossing[tested[t as usize] as usize / 2] = true;
        }
        let mesh = TriMesh::new(Vec::new(), triangles);
        let folded = (2 * flagged.iter().filter(|f| **f).count()).max(x.count);
        let done = |mesh: TriMesh, moved: &[Moved], positions: &[Vec3]| {
            let flipped = quads
                .iter()
                .zip(mesh.triangles.chunks(2))
                .filter(|(q, t)| diagonal(t) != diagonal(&super::split_quad(**q, positions)))
                .map(|(q, t)| (super::merge::canonical(q).0, diagonal(t)))
                .collect();
            Unfolded {
                triangles: mesh.triangles,
                beyond: moved.len(),
                folded,
                flipped,
            }
        };
        if last {
            return Ok(done(mesh, &moved, positions));
        }
        // What a flagged quad can still change: a moved vertex to move again or send back,
        // or, where every quad it could cross is tested, a split to try or to settle.
        let can_smooth = |q: usize, v: u32, smooth: &[Option<Smooth>], sharp: bool| {
            smooth[v as usize].is_some_and(|s| crossing[q] || sharp || !s.sharp)
        };
        let can_change = |q: usize, is_moved: &[bool], state: &[u8], smooth: &[Option<Smooth>]| {
            quads[q]
                .iter()
                .any(|&v| is_moved[v as usize] || can_smooth(q, v, smooth, true))
                || (flippable[q] && state[q] < 2)
        };
        let pending = flagged
            .iter()
            .enumerate()
            .any(|(q, f)| *f && can_change(q, &is_moved, &state, &smooth));
        // More crossing pairs than listed: `flagged` is incomplete, and what was changed may
        // cross where it is not seen.
        let unlisted = x.pairs.len() < x.count;
        if !pending && !unlisted {
            return Ok(done(mesh, &moved, positions));
        }
        if round == ROUNDS || unlisted {
            // Out of rounds with changes pending, or crossings not all listed: everything
            // back as it was.
            if moved.is_empty() && smoothed.is_empty() && state.iter().all(|&s| s == 0) {
                return Ok(done(mesh, &moved, positions));
            }
            for m in moved.drain(..) {
                positions[m.vertex as usize] = m.in_cell;
            }
            for (v, p) in smoothed.drain(..) {
                positions[v as usize] = p;
            }
            state.iter_mut().for_each(|s| *s = 0);
            last = true;
            round += 1;
            continue;
        }
        let mut changed = false;
        // Moved vertices changed this round (one step per round, however many of their quads
        // are flagged).
        let mut stepped = vec![false; positions.len()];
        // Flagged quads with no moved vertex and no split left to try.
        let mut stuck = Vec::new();
        for (q, _) in flagged.iter().enumerate().filter(|f| *f.1) {
            // A moved vertex of the quad tries its second place, or goes back.
            let mut sent_back = false;
            for &v in &quads[q] {
                let v = v as usize;
                if !is_moved[v] {
                    continue;
                }
                sent_back = true;
                if std::mem::replace(&mut stepped[v], true) {
                    continue;
                }
                match next[v].take() {
                    Some(p) => positions[v] = p,
                    None => is_moved[v] = false,
                }
            }
            if !sent_back && flippable[q] && state[q] < 2 {
                state[q] += 1;
                changed = true;
            } else if !sent_back {
                stuck.push(q);
            }
            changed |= sent_back;
        }
        // Nothing else left to try: the stuck quads' vertices go to their mass points of
        // crossings (the vertex of surface nets, inside the cell, which gives up the sharp
        // feature for a mesh that does not fold); vertices on a sharp feature only where
        // their quads cross, or last where nothing else is left.
        for sharp in [false, true] {
            if changed {
                break;
            }
            for &q in &stuck {
                for &v in &quads[q] {
                    if can_smooth(q, v, &smooth, sharp) {
                        let s = smooth[v as usize].take().expect("checked");
                        smoothed.push((v, positions[v as usize]));
                        positions[v as usize] = onto(v, s.at);
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            return Ok(done(mesh, &moved, positions));
        }
        moved.retain(|m| {
            is_moved[m.vertex as usize] || {
                positions[m.vertex as usize] = m.in_cell;
                false
            }
        });
        round += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The diagonal read back from a split quad splits it (and any rotation or reversal of
    /// it, as the adaptive polygons write quads) into the same two triangles, each in the
    /// quad's orientation.
    #[test]
    fn a_split_quads_diagonal_splits_it_again_the_same_way() {
        let positions = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::new(1.2, 1.0, 0.0),
            Vec3::new(0.0, 1.1, 0.2),
        ];
        let q = [0, 1, 2, 3];
        let canon = |t: [u32; 3]| {
            let m = (0..3).min_by_key(|&i| t[i]).unwrap();
            [t[m], t[(m + 1) % 3], t[(m + 2) % 3]]
        };
        for state in [0, 1] {
            let tris = split(q, &positions, None, state);
            let d = diagonal(&tris);
            let mut want = tris.map(canon);
            want.sort_unstable();
            for r in 0..4 {
                let rot = [q[r], q[(r + 1) % 4], q[(r + 2) % 4], q[(r + 3) % 4]];
                let mut got = split_along(rot, d).map(canon);
                got.sort_unstable();
                assert_eq!(got, want, "state {state}, rotation {r}");
                let mut rev = rot;
                rev.reverse();
                let mut got = split_along(rev, d).map(|t| canon([t[0], t[2], t[1]]));
                got.sort_unstable();
                assert_eq!(got, want, "state {state}, reversed rotation {r}");
            }
        }
        // The two states take different diagonals.
        assert_ne!(
            diagonal(&split(q, &positions, None, 0)),
            diagonal(&split(q, &positions, None, 1))
        );
    }
}
