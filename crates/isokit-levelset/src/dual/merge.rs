//! Adaptive dual contouring: cells merged bottom-up where one vertex serves them all (Ju,
//! Losasso, Schaefer and Warren 2002, "Dual Contouring of Hermite Data", its octree
//! simplification), so flat and gently curved parts of the surface get few, large polygons
//! while edges and corners keep the fine cells' vertices.
//!
//! The lattice's cells are the leaves of an implicit octree: a node of level `L` covers
//! `2^L` cells along each axis. A node *collapses* (one vertex for all its cells) when
//! 1. each of its eight children collapsed, or holds no crossed cell (then all its samples
//!    lie on one side); a cell crossed in more than one piece never collapses;
//! 2. its box lies within the lattice (padding included when the boundary is closed);
//! 3. the topology test of Ju et al. 2002 holds: where both ends of one of the node's edges
//!    lie on one side, so does the edge's midpoint; where all four corners of a face do, so
//!    does the face's centre; where all eight corners do, so does the centre — so the node's
//!    surface has the topology its corners give it — and its corners' signs are manifold:
//!    no face is ambiguous (two diagonal corners inside, the other two outside, which the
//!    paper's test rejects: the fine cells across such a face may join what the node's
//!    corners separate, or the reverse), and they give one marching-cubes loop;
//! 4. the minimiser of the quadratic error function of all the crossings inside it, kept in
//!    the node's box, lies within the error bound `E` of every crossing's tangent plane
//!    (`|nᵢ · (x − pᵢ)| ≤ E`) and, with an exact field, `|f(x) − iso| ≤ E`.
//!
//! The polygons are the fine quads of [`super`] with every cell's vertex replaced by that of
//! its highest collapsed ancestor: the quads inside a collapsed node vanish (fewer than three
//! distinct vertices), those on a face between two nodes too, and the others become the
//! polygons of the simplified octree (as Ju et al. 2002 contour it: a triangle where one
//! node holds two of the four cells). Copies of one polygon are counted with their
//! orientation and what remains is emitted once; under the topology test an octree edge is
//! crossed at most once at the fine level, so no copy is expected (`repeated_polygons`
//! reports any that remain).
//!
//! The topology test does not keep polygons from folding where a merged vertex moves far
//! within its node next to small neighbours: a triangle that faces against its crossing's
//! normal, is degenerate or intersects another sends its nodes' merges back
//! ([`adaptive_polygons`]).

use super::{CellVerts, Hermite, Lattice, cell_edge, solve_in_cell};
use glam::{DVec3, Vec3};
use isokit_field::{Field, Job, TriMesh};
use rayon::prelude::*;
use std::collections::HashMap;

use crate::meshing::MeshingError;

/// The deepest level merged: nodes of up to 256 cells along each axis.
pub(super) const MAX_LEVEL: u32 = 8;

/// One octree node while merging.
struct Node {
    /// Node coordinates at its level (padded cell coordinates shifted right by the level).
    key: [u32; 3],
    /// Whether it collapsed.
    ok: bool,
    /// Indices of the crossed lattice edges inside it (sorted), while it may still merge.
    edges: Vec<u32>,
}

/// The collapsed nodes, for the polygon pass.
pub(super) struct Merged {
    /// The fine vertices followed by one vertex per collapsed node.
    positions: Vec<Vec3>,
    /// The collapsed nodes of each level (index 0 unused): key → vertex in `positions`.
    collapsed: Vec<HashMap<[u32; 3], u32>>,
    /// The node (level, key) of each merged vertex; `None` for the fine vertices.
    node_of: Vec<Option<(u32, [u32; 3])>>,
    /// Each crossed cell's padded coordinates, where it has one vertex (may merge).
    fine: Vec<Option<[u32; 3]>>,
    /// Each crossed cell's first vertex.
    first: Vec<u32>,
    /// Fine vertices.
    n_fine: usize,
}

/// Octree order of node keys (z, then y, then x).
fn order(k: &[u32; 3]) -> (u32, u32, u32) {
    (k[2], k[1], k[0])
}

impl<S: Fn(usize, usize, usize) -> f32 + Sync> Lattice<'_, S> {
    /// Whether the node of `level` at `key` passes tests 2 and 3 (module docs).
    fn node_topology_ok(&self, key: [u32; 3], level: u32, r: &[(i64, i64); 3]) -> bool {
        let side = 1i64 << level;
        // Padded cell coordinates are lattice coordinates + 1.
        let lo = key.map(|v| ((v as i64) << level) - 1);
        if (0..3).any(|a| lo[a] < r[a].0 || lo[a] + side > r[a].1) {
            return false;
        }
        let half = side / 2;
        // Signs on the node's 3 × 3 × 3 points (corners, edge midpoints, face centres, centre).
        let mut ins = [[[false; 3]; 3]; 3];
        for (k, plane) in ins.iter_mut().enumerate() {
            for (j, row) in plane.iter_mut().enumerate() {
                for (i, s) in row.iter_mut().enumerate() {
                    let g = [
                        lo[0] + half * i as i64,
                        lo[1] + half * j as i64,
                        lo[2] + half * k as i64,
                    ];
                    *s = self.inside(g);
                }
            }
        }
        let at = |p: [usize; 3]| ins[p[2]][p[1]][p[0]];
        // Every sub-box of the 3 × 3 × 3 points spanned by corners: an edge (two corners), a
        // face (four) or the node (eight), each with its centre.
        for mask in 1usize..8 {
            let axes: Vec<usize> = (0..3).filter(|&a| mask >> a & 1 == 1).collect();
            let fixed: Vec<usize> = (0..3).filter(|&a| mask >> a & 1 == 0).collect();
            for f in 0..(1usize << fixed.len()) {
                let mut base = [0usize; 3];
                for (n, &a) in fixed.iter().enumerate() {
                    base[a] = 2 * (f >> n & 1);
                }
                let mut centre = base;
                for &a in &axes {
                    centre[a] = 1;
                }
                let corner_signs: Vec<bool> = (0..(1usize << axes.len()))
                    .map(|c| {
                        let mut p = base;
                        for (n, &a) in axes.iter().enumerate() {
                            p[a] = 2 * (c >> n & 1);
                        }
                        at(p)
                    })
                    .collect();
                let first = corner_signs[0];
                if corner_signs.iter().all(|&s| s == first) && at(centre) != first {
                    return false;
                }
            }
        }
        // Manifold corner signs: no ambiguous face (diagonal corners alike, the others not).
        let corner = |c: [usize; 3]| at([2 * c[0], 2 * c[1], 2 * c[2]]);
        for a in 0..3 {
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            for side in 0..2 {
                let mut q = [[0usize; 3]; 4];
                for (n, (u, v)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                    q[n][a] = side;
                    q[n][b] = u;
                    q[n][c] = v;
                }
                let s = q.map(corner);
                if s[0] == s[2] && s[1] == s[3] && s[0] != s[1] {
                    return false;
                }
            }
        }
        // One disc through the node, as its corners give it.
        let mut values = [0f32; 8];
        let mut mask = 0u8;
        for (n, v) in values.iter_mut().enumerate() {
            let g = [
                lo[0] + side * (n & 1) as i64,
                lo[1] + side * ((n >> 1) & 1) as i64,
                lo[2] + side * ((n >> 2) & 1) as i64,
            ];
            *v = self.value(g);
            if *v < self.iso {
                mask |= 1 << n;
            }
        }
        crate::meshing::cell_loops(&values, mask, self.iso).count == 1
    }

    /// The vertex of a node whose children collapsed (test 4 of the module docs), or `None`.
    fn node_vertex(
        &self,
        key: [u32; 3],
        level: u32,
        edges: &[Hermite],
        inside: &[u32],
        truncation: f64,
        error: f64,
    ) -> Option<Vec3> {
        let size = self.h * (1u64 << level) as f64;
        let lo = self.world(DVec3::new(
            ((key[0] as i64) << level) as f64 - 1.0,
            ((key[1] as i64) << level) as f64 - 1.0,
            ((key[2] as i64) << level) as f64 - 1.0,
        ));
        let pts: Vec<DVec3> = inside
            .iter()
            .map(|&i| (edges[i as usize].point - lo) / size)
            .collect();
        let nrm: Vec<DVec3> = inside.iter().map(|&i| edges[i as usize].normal).collect();
        let (x, _) = solve_in_cell(&pts, &nrm, truncation);
        let residual = super::residual(&pts, &nrm, x) * size;
        // NaN residuals fail too.
        if residual.is_nan() || residual > error {
            return None;
        }
        let inset = DVec3::splat(self.h / 1024.0);
        let v = (lo + size * x).clamp(lo + inset, lo + DVec3::splat(size) - inset);
        if let Some(f) = self.field {
            let off = (f.value(v.as_vec3()) as f64 - self.iso as f64).abs();
            if off.is_nan() || off > error {
                return None;
            }
        }
        Some(v.as_vec3())
    }
}

/// Merges cells bottom-up (module docs). `cells` are the crossed cells' keys (sorted),
/// `per_cell` their vertices, `first` the index of each cell's first vertex in `positions`.
#[allow(clippy::too_many_arguments)]
pub(super) fn merge<S: Fn(usize, usize, usize) -> f32 + Sync>(
    lat: &Lattice<'_, S>,
    r: &[(i64, i64); 3],
    cells: &[u64],
    per_cell: &[CellVerts],
    first: &[u32],
    mut positions: Vec<Vec3>,
    edges: &[Hermite],
    truncation: f64,
    error: f64,
    job: &Job,
) -> Result<Merged, MeshingError> {
    let n_fine = positions.len();
    let counter = job.counter("meshing (merging cells)", MAX_LEVEL as u64);
    // Level 0: the crossed cells, with their crossed edges.
    let mut nodes: Vec<Node> = cells
        .par_iter()
        .zip(per_cell)
        .map(|(&ck, cv)| {
            let c = lat.decode_node(ck);
            let ok = cv.verts.len() == 1;
            let mut inside = Vec::new();
            if ok {
                for q in 0..12 {
                    let (g, a) = cell_edge(c, q);
                    let key = lat.node_key(g) * 3 + a as u64;
                    if let Ok(i) = edges.binary_search_by_key(&key, |h| h.key) {
                        inside.push(i as u32);
                    }
                }
                inside.sort_unstable();
            }
            Node {
                key: c.map(|v| (v + 1) as u32),
                ok,
                edges: inside,
            }
        })
        .collect();
    // The collapsed nodes of each level (index 0 unused): key → vertex in `positions`.
    let mut collapsed: Vec<HashMap<[u32; 3], u32>> = vec![HashMap::new()];
    for level in 1..=MAX_LEVEL {
        job.check()?;
        // Children grouped by parent.
        nodes.par_sort_unstable_by_key(|n| order(&n.key.map(|v| v >> 1)));
        let mut groups: Vec<std::ops::Range<usize>> = Vec::new();
        let mut start = 0;
        for i in 1..=nodes.len() {
            if i == nodes.len() || nodes[i].key.map(|v| v >> 1) != nodes[start].key.map(|v| v >> 1)
            {
                groups.push(start..i);
                start = i;
            }
        }
        let parents: Vec<(Node, Option<Vec3>)> = groups
            .par_iter()
            .map(|g| {
                let kids = &nodes[g.clone()];
                let key = kids[0].key.map(|v| v >> 1);
                let mut node = Node {
                    key,
                    ok: false,
                    edges: Vec::new(),
                };
                if !kids.iter().all(|k| k.ok) || !lat.node_topology_ok(key, level, r) {
                    return (node, None);
                }
                let mut inside: Vec<u32> =
                    kids.iter().flat_map(|k| k.edges.iter().copied()).collect();
                inside.sort_unstable();
                inside.dedup();
                let v = lat.node_vertex(key, level, edges, &inside, truncation, error);
                if v.is_some() {
                    node.ok = true;
                    node.edges = inside;
                }
                (node, v)
            })
            .collect();
        counter.advance(1);
        let mut here = HashMap::new();
        let mut next = Vec::with_capacity(parents.len());
        for (node, v) in parents {
            if let Some(v) = v {
                here.insert(node.key, positions.len() as u32);
                positions.push(v);
            }
            next.push(node);
        }
        let any = !here.is_empty();
        collapsed.push(here);
        nodes = next;
        if !any {
            counter.advance(MAX_LEVEL as u64 - level as u64);
            break;
        }
    }
    let fine: Vec<Option<[u32; 3]>> = cells
        .iter()
        .zip(per_cell)
        .map(|(&ck, cv)| (cv.verts.len() == 1).then(|| lat.decode_node(ck).map(|v| (v + 1) as u32)))
        .collect();
    let mut node_of = vec![None; n_fine];
    for (level, map) in collapsed.iter().enumerate() {
        for (key, &v) in map {
            node_of.resize(node_of.len().max(v as usize + 1), None);
            node_of[v as usize] = Some((level as u32, *key));
        }
    }
    Ok(Merged {
        positions,
        collapsed,
        node_of,
        fine,
        first: first.to_vec(),
        n_fine,
    })
}

impl Merged {
    /// Each fine vertex → the vertex of its cell's highest collapsed ancestor (itself where
    /// none collapsed), and how many cells were merged.
    fn remap(&self) -> (Vec<u32>, usize) {
        let mut remap: Vec<u32> = (0..self.n_fine as u32).collect();
        let mut merged_cells = 0;
        for (i, u) in self.fine.iter().enumerate() {
            let Some(u) = u else { continue };
            let mut rep = None;
            for (level, map) in self.collapsed.iter().enumerate().skip(1) {
                match map.get(&u.map(|v| v >> level)) {
                    Some(&v) => rep = Some(v),
                    None => break,
                }
            }
            if let Some(v) = rep {
                remap[self.first[i] as usize] = v;
                merged_cells += 1;
            }
        }
        (remap, merged_cells)
    }

    /// Takes back the merge of the node holding vertex `v` (and of its ancestors, which
    /// needed it); false when `v` is a fine cell's own vertex.
    fn split(&mut self, v: u32) -> bool {
        let Some(Some((level, key))) = self.node_of.get(v as usize).copied() else {
            return false;
        };
        let mut any = false;
        for l in level as usize..self.collapsed.len() {
            let shift = l as u32 - level;
            any |= self.collapsed[l].remove(&key.map(|k| k >> shift)).is_some();
        }
        any
    }
}

/// What [`adaptive_polygons`] gives: the mesh and its counts (as `DualStats` names them).
pub(super) struct AdaptiveMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub merged_cells: usize,
    pub repeated_polygons: usize,
    pub folded_triangles: usize,
    /// Per vertex: a merged node's (placed within the error bound of the surface, not on it).
    pub merged_vertex: Vec<bool>,
}

/// How many times folded polygons send their merged nodes back to their children.
const SPLIT_ROUNDS: usize = 16;

/// The adaptive mesh: the fine quads (each with the normal of the crossed edge it came
/// from) with their cells' vertices replaced by the merged nodes', as [`polygons`] makes
/// them. Every round, a triangle that folds (faces against its crossing's normal and the
/// surface's, or is degenerate, [`super::beyond::folds`]: where a large node meets small
/// cells across a feature), or that intersects
/// another triangle (exactly, [`crate::intersect`]), takes back the merges of its polygon's
/// nodes, and the polygons are made again (at most `SPLIT_ROUNDS` times): merging adds no
/// self-intersection to what the uniform mesher gives unless the rounds run out. The
/// triangles still folded, degenerate or intersecting at the end include those of the
/// unmerged cells' own polygons, as the uniform mesher makes them.
pub(super) fn adaptive_polygons(
    mut merged: Merged,
    quads: &[[u32; 4]],
    normals: &[Vec3],
    flipped: &HashMap<[u32; 4], [u32; 2]>,
    field: Option<&dyn Field>,
    job: &Job,
) -> Result<AdaptiveMesh, MeshingError> {
    let counter = job.counter(
        "meshing (checking merged polygons)",
        SPLIT_ROUNDS as u64 + 1,
    );
    // The vertices do not change between rounds (only which ones the polygons use).
    let mut mesh = TriMesh::new(std::mem::take(&mut merged.positions), Vec::new());
    let mut round = 0;
    loop {
        job.check()?;
        let (remap, merged_cells) = merged.remap();
        let mapped: Vec<[u32; 4]> = quads.iter().map(|q| q.map(|v| remap[v as usize])).collect();
        let (tris, repeated) = polygons(&mapped, normals, &mesh.positions, flipped);
        // Triangles facing the wrong way or degenerate, and triangles
        // crossing others without facing the wrong way (a large node's triangle reaching over
        // a concave rim of small cells; exact tests).
        let mut flagged: Vec<usize> = tris
            .iter()
            .enumerate()
            .filter(|(_, (t, n, _))| {
                let p = t.map(|v| mesh.positions[v as usize].as_dvec3());
                super::beyond::folds(p, *n, field)
            })
            .map(|(i, _)| i)
            .collect();
        mesh.triangles = tris.iter().map(|(t, _, _)| *t).collect();
        let x = crate::intersect::self_intersections(&mesh);
        flagged.extend(x.pairs.iter().flatten().map(|&t| t as usize));
        flagged.sort_unstable();
        flagged.dedup();
        // Past the listed pairs more triangles intersect than `flagged` holds.
        let unresolved = flagged.len().max(x.count);
        let mut split = false;
        if round < SPLIT_ROUNDS {
            for &i in &flagged {
                // Every merged vertex of the polygon the triangle came from.
                for &v in &tris[i].2 {
                    if v != u32::MAX {
                        split |= merged.split(v);
                    }
                }
            }
        }
        round += 1;
        counter.advance(1);
        if !split {
            counter.advance(SPLIT_ROUNDS as u64 + 1 - round as u64);
            let (positions, tris, kept) = super::compact(&mesh.positions, mesh.triangles);
            let merged_vertex = kept.iter().map(|&v| v as usize >= merged.n_fine).collect();
            return Ok(AdaptiveMesh {
                positions,
                triangles: tris,
                merged_cells,
                repeated_polygons: repeated,
                folded_triangles: unresolved,
                merged_vertex,
            });
        }
    }
}

/// The polygons of the merged cells from the fine quads (module docs): each quad's vertices
/// replaced, repeated vertices dropped, polygons with fewer than three vertices dropped, and
/// copies of one polygon counted with their orientation. Returns the triangles, each with the
/// normal of a crossing it came from and its polygon (`u32::MAX` as the fourth vertex of a
/// triangle), and how many polygons remained more than once (0 on a 2-manifold result).
/// Quads in `flipped` (canonical, as [`canonical`] gives them) are split along the diagonal
/// it gives (the uniform mesher's fold repair, [`super::beyond`]).
#[expect(clippy::type_complexity, reason = "a private helper's triples")]
fn polygons(
    quads: &[[u32; 4]],
    normals: &[Vec3],
    positions: &[Vec3],
    flipped: &HashMap<[u32; 4], [u32; 2]>,
) -> (Vec<([u32; 3], Vec3, [u32; 4])>, usize) {
    // Per polygon (its vertices, zero-padded, and their count): the orientation count and a
    // crossing normal of each orientation.
    type Key = ([u32; 4], usize);
    let mut count: HashMap<Key, (i64, Vec3, Vec3)> = HashMap::new();
    for (q, &normal) in quads.iter().zip(normals) {
        let mut poly = [0u32; 4];
        let mut len = 0;
        for (i, &v) in q.iter().enumerate() {
            if v != q[(i + 3) % 4] {
                poly[len] = v;
                len += 1;
            }
        }
        // Fewer than three vertices, or one repeated non-consecutively (a, b, a, c): no area.
        let mut sorted = poly;
        sorted[..len].sort_unstable();
        if len < 3 || sorted[..len].windows(2).any(|w| w[0] == w[1]) {
            continue;
        }
        let (canon, sign) = canonical(&poly[..len]);
        let e = count
            .entry((canon, len))
            .or_insert((0, Vec3::ZERO, Vec3::ZERO));
        e.0 += sign;
        if sign > 0 { e.1 = normal } else { e.2 = normal }
    }
    let mut repeated = 0;
    let mut keys: Vec<(Key, (i64, Vec3, Vec3))> =
        count.into_iter().filter(|(_, n)| n.0 != 0).collect();
    // A deterministic output order.
    keys.sort_unstable_by_key(|k| k.0);
    let mut out = Vec::with_capacity(keys.len() * 2);
    for ((mut poly, len), (n, forward, backward)) in keys {
        let diagonal = if len == 4 { flipped.get(&poly) } else { None };
        if n.unsigned_abs() > 1 {
            repeated += 1;
        }
        let normal = if n < 0 {
            poly[..len].reverse();
            backward
        } else {
            forward
        };
        for _ in 0..n.unsigned_abs() {
            if len == 3 {
                let t = [poly[0], poly[1], poly[2]];
                out.push((t, normal, [t[0], t[1], t[2], u32::MAX]));
            } else {
                let t = match diagonal {
                    Some(&d) => super::beyond::split_along(poly, d),
                    None => merged_split(poly, positions),
                };
                out.extend(t.map(|t| (t, normal, poly)));
            }
        }
    }
    (out, repeated)
}

/// The split of a quad that the uniform mesh's checks did not set (merged quads, and fine
/// quads left on their shorter diagonal): the shorter diagonal, unless its split holds a
/// sliver and the other does not (`beyond::unless_sliver`, by shape alone; the uniform
/// mesh's `beyond::first_diagonals` also weighs the distance to the surface). The merge's
/// checks below test the result as they test every polygon.
fn merged_split(poly: [u32; 4], positions: &[Vec3]) -> [[u32; 3]; 2] {
    let split = |state| super::beyond::split(poly, positions, None, state);
    super::beyond::unless_sliver(split(0), split(1), positions)
}

/// The polygon (3 or 4 vertices) rotated to start at its smallest vertex, in the
/// orientation whose second vertex is smaller, zero-padded to four, and `+1` if that is the
/// given orientation, `-1` if reversed.
pub(super) fn canonical(poly: &[u32]) -> ([u32; 4], i64) {
    let n = poly.len();
    let m = (0..n).min_by_key(|&i| poly[i]).unwrap_or(0);
    let (mut fwd, mut rev) = ([0u32; 4], [0u32; 4]);
    for i in 0..n {
        fwd[i] = poly[(m + i) % n];
        rev[i] = poly[(m + n - i) % n];
    }
    if fwd <= rev { (fwd, 1) } else { (rev, -1) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_of_a_polygon_cancel_by_orientation() {
        let pos = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let n = [Vec3::Z; 4];
        // (0, 1, 2) three times with alternating orientation: once remains.
        let quads = [[0, 1, 2, 2], [2, 1, 0, 0], [1, 2, 0, 0]];
        let (tris, repeated) = polygons(&quads, &n, &pos, &HashMap::new());
        assert_eq!(tris, vec![([0, 1, 2], Vec3::Z, [0, 1, 2, u32::MAX])]);
        assert_eq!(repeated, 0);
        // A reversed pair leaves nothing; degenerate quads give nothing.
        let quads = [[0, 1, 2, 3], [3, 2, 1, 0], [0, 0, 1, 1], [0, 1, 0, 2]];
        let (tris, _) = polygons(&quads, &n, &pos, &HashMap::new());
        assert!(tris.is_empty(), "{tris:?}");
        // The same orientation twice is reported.
        let (tris, repeated) = polygons(&[[0, 1, 3, 3], [1, 3, 0, 0]], &n, &pos, &HashMap::new());
        assert_eq!((tris.len(), repeated), (2, 1));
    }
}
