//! Angle-weighted pseudonormals (Bærentzen and Aanæs 2005) for the sign of a distance.
//!
//! For a closed, manifold, consistently (outward) oriented triangle mesh, the sign of
//! `(p − q) · n` is the inside/outside sign of `p`, where `q` is the closest point of the
//! mesh to `p` and `n` is the *pseudonormal* of the feature `q` lies on:
//!
//! - **face**: the face's unit normal;
//! - **edge**: the sum of the unit normals of the faces sharing the edge, normalized;
//! - **vertex**: the sum of the unit normals of the incident faces, each weighted by the
//!   face's interior angle at the vertex, normalized.
//!
//! The plain face normal is *not* enough: near a sharp edge or vertex a point's closest
//! point can be that edge or vertex, reached from a face whose normal points away from it
//! (the tests show such points). The result is exact for any point not on the surface,
//! given an exact closest point and feature (as [`crate::triangle::closest_point`]
//! computes); with rounding it is reliable for points farther than a few ulps of the
//! mesh's size from the surface.
//!
//! On meshes that are not watertight, not manifold or not consistently oriented the sign
//! is not meaningful near the defects; use the generalized winding number there.
//!
//! ## Memory
//! Per triangle: the unit face normal (24 bytes), its vertex indices (12 bytes) and the
//! ids of its three edges (12 bytes); per vertex one normal (24 bytes); per unique edge
//! one normal (24 bytes, about 1.5 edges per triangle on a closed mesh). About 96 bytes
//! per triangle in all, ~96 MB for a million triangles; the build needs 8 bytes per
//! half-edge temporarily and runs in linear time (edges are matched by a counting sort
//! on their lower vertex, no hash map).

use glam::DVec3;
use rayon::prelude::*;

use crate::triangle::{ClosestPoint, Feature, face_normal};

/// Marks an edge slot of a skipped triangle.
const NO_EDGE: u32 = u32::MAX;

/// Angle-weighted pseudonormals of a triangle mesh: per face, per vertex and per edge.
#[derive(Clone, Debug, Default)]
pub struct Pseudonormals {
    /// Unit normal of each face; zero for degenerate or skipped faces.
    faces: Vec<DVec3>,
    /// Vertex indices of each face (copied so that `normal` needs no mesh).
    corners: Vec<[u32; 3]>,
    /// Edge ids of each face (`Edge(0)` = a–b, `Edge(1)` = b–c, `Edge(2)` = c–a);
    /// [`NO_EDGE`] for skipped faces.
    edges_of: Vec<[u32; 3]>,
    /// Unit pseudonormal of each unique edge (zero when its faces' normals cancel).
    edges: Vec<DVec3>,
    /// Unit pseudonormal of each vertex (zero for unreferenced vertices).
    vertices: Vec<DVec3>,
}

/// Per-face data computed in parallel: unit normal and interior angles at a, b, c.
fn face_data(positions: &[DVec3], t: [u32; 3]) -> Option<(DVec3, [f64; 3])> {
    let [a, b, c] = [
        *positions.get(t[0] as usize)?,
        *positions.get(t[1] as usize)?,
        *positions.get(t[2] as usize)?,
    ];
    let (ab, ac, bc) = (b - a, c - a, c - b);
    let Some(n) = face_normal(ab, ac, bc) else {
        return Some((DVec3::ZERO, [0.0; 3]));
    };
    let len = n.length();
    if !(len > 0.0 && len.is_finite()) {
        return Some((DVec3::ZERO, [0.0; 3]));
    }
    // Interior angles by atan2(|e1 × e2|, e1 · e2): accurate for all angles, and
    // |e1 × e2| = |n| at every corner.
    let angles = [
        len.atan2(ab.dot(ac)),
        len.atan2((-ab).dot(bc)),
        len.atan2(ac.dot(bc)),
    ];
    Some((n / len, angles))
}

/// `v / |v|`, or zero when `v` is zero or not finite.
fn normalize_or_zero(v: DVec3) -> DVec3 {
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        v / len
    } else {
        DVec3::ZERO
    }
}

impl Pseudonormals {
    /// Computes the face, vertex and edge pseudonormals of the mesh `(positions,
    /// triangles)`.
    ///
    /// Indices are expected to be valid (the caller validates the mesh); a triangle with
    /// an out-of-range index is skipped (zero normals, no edges, contributes nothing) and
    /// never panics. Degenerate triangles (see [`crate::triangle::DEGENERATE_RATIO`]) get
    /// a zero face normal and contribute nothing to their vertices and edges. Linear time;
    /// the per-face work runs in parallel.
    pub fn new(positions: &[DVec3], triangles: &[[u32; 3]]) -> Self {
        let data: Vec<Option<(DVec3, [f64; 3])>> = triangles
            .par_iter()
            .map(|&t| face_data(positions, t))
            .collect();

        let mut faces = Vec::with_capacity(triangles.len());
        let mut vertex_sum = vec![DVec3::ZERO; positions.len()];
        for (t, d) in triangles.iter().zip(&data) {
            match d {
                Some((n, angles)) => {
                    faces.push(*n);
                    for k in 0..3 {
                        vertex_sum[t[k] as usize] += *n * angles[k];
                    }
                }
                None => faces.push(DVec3::ZERO),
            }
        }
        let vertices: Vec<DVec3> = vertex_sum.into_par_iter().map(normalize_or_zero).collect();
        drop(data);

        let (edges_of, edges) = Self::build_edges(positions.len(), triangles, &faces);
        Self {
            faces,
            corners: triangles.to_vec(),
            edges_of,
            edges,
            vertices,
        }
    }

    /// Matches half-edges into unique edges by a counting sort on the lower vertex index
    /// (then a sort of each small bucket by the upper index), and sums face normals.
    fn build_edges(
        n_vertices: usize,
        triangles: &[[u32; 3]],
        faces: &[DVec3],
    ) -> (Vec<[u32; 3]>, Vec<DVec3>) {
        let valid = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < n_vertices);
        // Bucket sizes by lower vertex.
        let mut start = vec![0usize; n_vertices + 1];
        for t in triangles.iter().filter(|t| valid(t)) {
            for k in 0..3 {
                let lo = t[k].min(t[(k + 1) % 3]);
                start[lo as usize + 1] += 1;
            }
        }
        for i in 0..n_vertices {
            start[i + 1] += start[i];
        }
        // Entries: (upper vertex << 32) | half-edge id (3·triangle + k). Half-edge ids fit
        // in 32 bits for up to ~1.4 G triangles; beyond that the mesh would not fit in
        // memory anyway, but stay safe: such triangles get no edges.
        let total = start[n_vertices];
        let mut entries = vec![0u64; total];
        let mut fill = start.clone();
        for (ti, t) in triangles.iter().enumerate() {
            if !valid(t) {
                continue;
            }
            for k in 0..3 {
                let (u, v) = (t[k], t[(k + 1) % 3]);
                let (lo, hi) = (u.min(v), u.max(v));
                let he = ti * 3 + k;
                let he = u32::try_from(he).unwrap_or(NO_EDGE);
                let slot = &mut fill[lo as usize];
                entries[*slot] = ((hi as u64) << 32) | he as u64;
                *slot += 1;
            }
        }
        drop(fill);
        // Sort each bucket by upper vertex (buckets are small: about half the valence).
        let mut buckets: Vec<&mut [u64]> = Vec::with_capacity(n_vertices);
        let mut rest: &mut [u64] = &mut entries;
        for i in 0..n_vertices {
            let len = start[i + 1] - start[i];
            let (head, tail) = rest.split_at_mut(len);
            buckets.push(head);
            rest = tail;
        }
        buckets.par_iter_mut().for_each(|b| b.sort_unstable());
        drop(buckets);

        let mut edges_of = vec![[NO_EDGE; 3]; triangles.len()];
        let mut edges: Vec<DVec3> = Vec::with_capacity(total / 2 + 1);
        for v in 0..n_vertices {
            let (mut i, end) = (start[v], start[v + 1]);
            // Within bucket `v` (lower vertex `v`), runs of equal upper vertex are edges.
            while i < end {
                let hi = entries[i] >> 32;
                let id = u32::try_from(edges.len()).unwrap_or(NO_EDGE);
                let mut sum = DVec3::ZERO;
                while i < end && entries[i] >> 32 == hi {
                    let he = (entries[i] & 0xFFFF_FFFF) as u32;
                    if he != NO_EDGE {
                        let (t, k) = (he as usize / 3, he as usize % 3);
                        edges_of[t][k] = id;
                        sum += faces[t];
                    }
                    i += 1;
                }
                edges.push(normalize_or_zero(sum));
            }
        }
        (edges_of, edges)
    }

    /// The pseudonormal of feature `feature` of triangle `triangle`: the unit face normal
    /// for [`Feature::Face`], the edge pseudonormal for [`Feature::Edge`], the
    /// angle-weighted vertex pseudonormal for [`Feature::Vertex`]. Zero for an
    /// out-of-range triangle or feature index, a degenerate face, or a feature whose
    /// incident normals cancel.
    pub fn normal(&self, triangle: usize, feature: Feature) -> DVec3 {
        let zero = DVec3::ZERO;
        match feature {
            Feature::Face => self.faces.get(triangle).copied().unwrap_or(zero),
            Feature::Edge(k) => self
                .edges_of
                .get(triangle)
                .and_then(|e| e.get(k as usize))
                .and_then(|&e| self.edges.get(e as usize))
                .copied()
                .unwrap_or(zero),
            Feature::Vertex(k) => self
                .corners
                .get(triangle)
                .and_then(|c| c.get(k as usize))
                .and_then(|&v| self.vertices.get(v as usize))
                .copied()
                .unwrap_or(zero),
        }
    }

    /// The sign of `p`: `+1.0` outside, `−1.0` inside, from the sign of
    /// `(p − closest.point) · n` with `n` the pseudonormal of `closest.feature` on
    /// `triangle` (`closest` is the mesh's closest point to `p`, found on `triangle`).
    ///
    /// By convention `+1.0` when the product is zero (a point on the surface, or a zero
    /// pseudonormal) or NaN.
    pub fn sign(&self, p: DVec3, closest: &ClosestPoint, triangle: usize) -> f64 {
        let n = self.normal(triangle, closest.feature);
        if (p - closest.point).dot(n) < 0.0 {
            -1.0
        } else {
            1.0
        }
    }

    /// The unit normal of face `triangle` (zero if degenerate or out of range).
    pub fn face_normal(&self, triangle: usize) -> DVec3 {
        self.normal(triangle, Feature::Face)
    }

    /// The angle-weighted pseudonormal of vertex `vertex` (zero if unreferenced or out of
    /// range).
    pub fn vertex_normal(&self, vertex: usize) -> DVec3 {
        self.vertices.get(vertex).copied().unwrap_or(DVec3::ZERO)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.faces.len()
    }

    /// Number of unique edges.
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// Heap memory held, in bytes.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.faces.capacity() * size_of::<DVec3>()
            + self.corners.capacity() * size_of::<[u32; 3]>()
            + self.edges_of.capacity() * size_of::<[u32; 3]>()
            + self.edges.capacity() * size_of::<DVec3>()
            + self.vertices.capacity() * size_of::<DVec3>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangle::{closest_point, solid_angle};
    use isokit_field::TriMesh;
    use isokit_field::generate::{icosphere, torus, trefoil, tube};
    use isokit_field::rng::{DEFAULT_SEED, SplitMix64};
    use std::f64::consts::PI;

    struct Mesh {
        p: Vec<DVec3>,
        t: Vec<[u32; 3]>,
    }

    impl Mesh {
        fn from(m: &TriMesh) -> Self {
            Self {
                p: m.positions.iter().map(|v| v.as_dvec3()).collect(),
                t: m.triangles.clone(),
            }
        }

        fn corners(&self, t: usize) -> [DVec3; 3] {
            self.t[t].map(|i| self.p[i as usize])
        }

        /// Brute-force closest triangle (first of equals) and its closest point.
        fn closest(&self, q: DVec3) -> (usize, ClosestPoint) {
            let mut best: Option<(usize, ClosestPoint)> = None;
            for t in 0..self.t.len() {
                let [a, b, c] = self.corners(t);
                let cp = closest_point(q, a, b, c);
                if best.as_ref().is_none_or(|(_, b)| cp.dist2 < b.dist2) {
                    best = Some((t, cp));
                }
            }
            best.expect("non-empty mesh")
        }

        /// Exact generalized winding number.
        fn winding(&self, q: DVec3) -> f64 {
            (0..self.t.len())
                .map(|t| {
                    let [a, b, c] = self.corners(t);
                    solid_angle(q, a, b, c)
                })
                .sum::<f64>()
                / (4.0 * PI)
        }

        fn bounds(&self) -> (DVec3, DVec3) {
            let lo = self.p.iter().fold(DVec3::splat(f64::MAX), |m, &v| m.min(v));
            let hi = self.p.iter().fold(DVec3::splat(f64::MIN), |m, &v| m.max(v));
            (lo, hi)
        }
    }

    fn rnd(r: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * r.next_f64()
    }

    fn runit(r: &mut SplitMix64) -> DVec3 {
        loop {
            let v = DVec3::new(rnd(r, -1.0, 1.0), rnd(r, -1.0, 1.0), rnd(r, -1.0, 1.0));
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }

    /// Query points for a mesh: uniform in the padded bounds, and close to vertices and
    /// to edges (random direction, log-uniform offset from 2e-4 to 3e-2 of the diagonal).
    fn query_points(m: &Mesh, n: usize, seed: u64) -> Vec<DVec3> {
        let mut r = SplitMix64::new(seed);
        let (lo, hi) = m.bounds();
        let diag = (hi - lo).length();
        let (lo, hi) = (lo - 0.1 * diag, hi + 0.1 * diag);
        let mut pts = Vec::with_capacity(3 * n);
        for _ in 0..n {
            pts.push(DVec3::new(
                rnd(&mut r, lo.x, hi.x),
                rnd(&mut r, lo.y, hi.y),
                rnd(&mut r, lo.z, hi.z),
            ));
        }
        let offset = |r: &mut SplitMix64| diag * 10f64.powf(rnd(r, -3.7, -1.5));
        for _ in 0..n {
            let v = m.p[r.below(m.p.len())];
            pts.push(v + runit(&mut r) * offset(&mut r));
        }
        for _ in 0..n {
            let t = m.t[r.below(m.t.len())];
            let k = r.below(3);
            let (a, b) = (m.p[t[k] as usize], m.p[t[(k + 1) % 3] as usize]);
            let q = a + (b - a) * r.next_f64();
            pts.push(q + runit(&mut r) * offset(&mut r));
        }
        pts
    }

    /// Outcome of checking one mesh: (points checked, pseudonormal failures, face-normal
    /// failures).
    fn check_mesh(m: &Mesh, n: usize, seed: u64) -> (usize, usize, usize) {
        let pn = Pseudonormals::new(&m.p, &m.t);
        let (lo, hi) = m.bounds();
        let min_dist = 1e-4 * (hi - lo).length();
        let (mut checked, mut pseudo_fail, mut face_fail) = (0, 0, 0);
        for q in query_points(m, n, seed) {
            let (t, cp) = m.closest(q);
            if cp.dist2.sqrt() <= min_dist {
                continue;
            }
            let w = m.winding(q);
            // Exact mesh, points away from it: the winding number is 0 or 1.
            assert!(
                w.abs() < 1e-6 || (w - 1.0).abs() < 1e-6,
                "winding {w} at {q}"
            );
            let truth = if w > 0.5 { -1.0 } else { 1.0 };
            checked += 1;
            if pn.sign(q, &cp, t) != truth {
                pseudo_fail += 1;
                eprintln!("pseudonormal wrong at {q}: {cp:?} on {t}");
            }
            let face = if (q - cp.point).dot(pn.face_normal(t)) < 0.0 {
                -1.0
            } else {
                1.0
            };
            if face != truth {
                face_fail += 1;
            }
        }
        (checked, pseudo_fail, face_fail)
    }

    fn trefoil_tube(sides: usize) -> Mesh {
        Mesh::from(&tube(|u| trefoil(u, 1.0), 0.3, 96, sides))
    }

    fn tetrahedron() -> Mesh {
        let p = vec![
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let mut t = vec![[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        for f in &mut t {
            let [a, b, c] = f.map(|i: u32| p[i as usize]);
            if (b - a).cross(c - a).dot(a) < 0.0 {
                f.swap(1, 2);
            }
        }
        Mesh { p, t }
    }

    #[test]
    fn sign_matches_winding_number_on_icosphere() {
        let m = Mesh::from(&icosphere(glam::Vec3::new(0.2, -0.1, 0.05), 1.0, 3));
        let (checked, fail, _) = check_mesh(&m, 300, DEFAULT_SEED);
        assert!(checked > 800, "{checked}");
        assert_eq!(fail, 0);
    }

    #[test]
    fn sign_matches_winding_number_on_torus() {
        let m = Mesh::from(&torus(1.0, 0.35, 48, 24));
        let (checked, fail, _) = check_mesh(&m, 300, 2);
        assert!(checked > 800, "{checked}");
        assert_eq!(fail, 0);
    }

    #[test]
    fn sign_matches_winding_number_on_trefoil_tube() {
        let m = trefoil_tube(12);
        let (checked, fail, _) = check_mesh(&m, 300, 3);
        assert!(checked > 800, "{checked}");
        assert_eq!(fail, 0);
    }

    #[test]
    fn face_normals_fail_near_sharp_features_where_pseudonormals_do_not() {
        // Sharp meshes: the tetrahedron (faces 109° apart) and a trefoil tube with a
        // triangular cross-section (120° between neighbouring faces). Near their edges
        // and vertices the closest feature is often an edge or vertex reached from a face
        // whose normal points away from the query point.
        let mut face_total = 0;
        for (name, m) in [("tetrahedron", tetrahedron()), ("tube3", trefoil_tube(3))] {
            let (checked, fail, face_fail) = check_mesh(&m, 400, 4);
            eprintln!("{name}: {checked} points, face-normal sign wrong at {face_fail}");
            assert!(checked > 1000, "{name}: {checked}");
            assert_eq!(fail, 0, "{name}");
            assert!(face_fail > 0, "{name}");
            face_total += face_fail;
        }
        assert!(face_total >= 10, "{face_total}");
        // A hand-made case: just outside edge 0–1 of the tetrahedron, in the edge's
        // Voronoi wedge but close to the neighbouring face's normal. The closest point on
        // face f is the edge; f's own normal says "inside", the pseudonormal "outside".
        let m = tetrahedron();
        let pn = Pseudonormals::new(&m.p, &m.t);
        let with_edge: Vec<usize> = (0..4)
            .filter(|&f| m.t[f].contains(&0) && m.t[f].contains(&1))
            .collect();
        let (f, g) = (with_edge[0], with_edge[1]);
        let (nf, ng) = (pn.face_normal(f), pn.face_normal(g));
        assert!(nf.dot(ng) < -0.3, "sharp edge");
        let w = (nf * 0.05 + ng * 0.95).normalize();
        let q = (m.p[0] + m.p[1]) * 0.5 + w * 0.01;
        assert!(m.winding(q).abs() < 1e-12, "outside");
        let [a, b, c] = m.corners(f);
        let cp = closest_point(q, a, b, c);
        assert!(matches!(cp.feature, Feature::Edge(_)), "{cp:?}");
        assert!((cp.dist2.sqrt() - 0.01).abs() < 1e-12);
        assert!((q - cp.point).dot(nf) < 0.0, "face normal says inside");
        assert_eq!(pn.sign(q, &cp, f), 1.0);
        // And just inside, near the same edge: both faces agree on the sign.
        let q = (m.p[0] + m.p[1]) * 0.5 - (nf + ng).normalize() * 0.01;
        let (t, cp) = m.closest(q);
        assert_eq!(pn.sign(q, &cp, t), -1.0);
    }

    #[test]
    fn normals_are_unit_and_edges_unique() {
        let m = Mesh::from(&torus(1.0, 0.35, 48, 24));
        let pn = Pseudonormals::new(&m.p, &m.t);
        assert_eq!(pn.triangle_count(), m.t.len());
        // Closed surface: E = 3F / 2.
        assert_eq!(pn.edge_count(), m.t.len() * 3 / 2);
        for t in 0..m.t.len() {
            for f in [
                Feature::Face,
                Feature::Edge(0),
                Feature::Edge(1),
                Feature::Edge(2),
                Feature::Vertex(0),
                Feature::Vertex(1),
                Feature::Vertex(2),
            ] {
                let n = pn.normal(t, f);
                assert!((n.length() - 1.0).abs() < 1e-12, "{t} {f:?} {n}");
            }
        }
        // Each edge's pseudonormal is the normalized sum of its two faces' normals, and
        // the neighbours across an edge agree on it.
        let [a, b, _] = m.t[0];
        let other = (1..m.t.len())
            .find(|&t| m.t[t].contains(&a) && m.t[t].contains(&b))
            .expect("neighbour across edge 0");
        let want = (pn.face_normal(0) + pn.face_normal(other)).normalize();
        assert!((pn.normal(0, Feature::Edge(0)) - want).length() < 1e-15);
        let k = (0..3)
            .find(|&k| {
                let e = [m.t[other][k], m.t[other][(k + 1) % 3]];
                e.contains(&a) && e.contains(&b)
            })
            .expect("edge in neighbour");
        assert_eq!(
            pn.normal(other, Feature::Edge(k as u8)),
            pn.normal(0, Feature::Edge(0))
        );
        assert!(pn.heap_bytes() > 0);
    }

    #[test]
    fn vertex_normal_is_angle_weighted() {
        // A corner of the unit cube built from uneven triangles: angle weighting makes
        // the pseudonormal the diagonal regardless of how the faces are split.
        let p = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 1.0),
        ];
        // Faces around vertex 0 on the planes x = 0, y = 0, z = 0 (normals -x, -y, -z).
        // The z = 0 square is split along its diagonal from vertex 0, so that vertex 0
        // has two 45° corners there and single 90° corners on the other planes: an
        // unweighted sum would tilt towards -z.
        let t = vec![[0, 2, 4], [0, 4, 1], [0, 1, 3], [0, 3, 2], [3, 5, 2]];
        let pn = Pseudonormals::new(&p, &t);
        let n = pn.vertex_normal(0);
        let want = -DVec3::ONE.normalize();
        assert!((n - want).length() < 1e-12, "{n}");
    }

    #[test]
    fn robust_to_bad_input() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(2.0, 0.0, 0.0)];
        let t = vec![[0, 1, 2], [0, 1, 9], [0, 1, 3], [2, 2, 1], [0, 2, 1]];
        let pn = Pseudonormals::new(&p, &t);
        assert_eq!(pn.normal(1, Feature::Face), DVec3::ZERO); // skipped (index 9)
        assert_eq!(pn.normal(1, Feature::Edge(0)), DVec3::ZERO);
        assert_eq!(pn.normal(1, Feature::Vertex(2)), DVec3::ZERO);
        assert_eq!(pn.normal(2, Feature::Face), DVec3::ZERO); // collinear
        assert_eq!(pn.normal(3, Feature::Face), DVec3::ZERO); // repeated index
        assert_eq!(pn.normal(99, Feature::Face), DVec3::ZERO);
        assert_eq!(pn.normal(0, Feature::Edge(7)), DVec3::ZERO);
        assert_eq!(pn.normal(0, Feature::Vertex(3)), DVec3::ZERO);
        // Triangles 0 and 4 are the same face in opposite orientations: their shared
        // edges' normals cancel to zero; sign falls back to +1.
        assert_eq!(pn.normal(0, Feature::Edge(0)), DVec3::ZERO);
        let cp = closest_point(DVec3::new(0.5, -1.0, 0.0), p[0], p[1], p[2]);
        assert_eq!(cp.feature, Feature::Edge(0));
        assert_eq!(pn.sign(DVec3::new(0.5, -1.0, 0.0), &cp, 0), 1.0);
        // Sign at zero distance is +1.
        let cp = closest_point(DVec3::new(0.2, 0.2, 0.0), p[0], p[1], p[2]);
        assert_eq!(pn.sign(DVec3::new(0.2, 0.2, 0.0), &cp, 0), 1.0);
        // Empty mesh.
        let pn = Pseudonormals::new(&[], &[]);
        assert_eq!(pn.edge_count(), 0);
        assert_eq!(pn.normal(0, Feature::Face), DVec3::ZERO);
    }
}
