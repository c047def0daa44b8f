//! Exact, robust single-triangle geometry in `f64`: closest point (with the feature it
//! lies on), signed solid angle, and ray intersection.
//!
//! Everything here works on [`DVec3`] and is written to stay accurate where the naive
//! formulas cancel:
//!
//! - **Local origin.** Differences are taken against a triangle vertex (`p − a`, `b − a`,
//!   …) before any product, so a unit triangle at 10⁶ from the origin, or a 10⁻⁶ triangle
//!   anywhere, is as accurate as one at the origin.
//! - **Slivers.** When the triangle is thin (squared area below `1e-8` of the fourth power
//!   of its longest edge) the normal is recomputed with a compensated (FMA, Kahan)
//!   cross product, so the plane distance stays accurate to a few ulps.
//! - **Degenerate triangles** (squared-area ratio at or below [`DEGENERATE_RATIO`]:
//!   collinear, repeated vertices, zero area, or non-finite) are handled as their three
//!   edges: [`closest_point`] returns the nearest point on the edges (never
//!   [`Feature::Face`]), [`solid_angle`] returns 0 and [`ray_triangle`] misses. No
//!   function here panics or produces NaN from finite input.
//!
//! ## Tolerances
//! - [`closest_point`]: `dist2` is within a few ulps of the exact squared distance to the
//!   triangle whose vertices are the given (exactly represented) points, measured at the
//!   scale `(|p − a| + longest edge)²`; tests hold it to `1e-12` relative at scales 10⁻⁶,
//!   1 and 10⁶. A triangle treated as degenerate has height at most `1e-10` of its longest
//!   edge, which bounds the extra distance error of the edge fallback.
//! - [`solid_angle`]: absolute error of a few ulps of 4π for points not on the triangle;
//!   sums over closed meshes are within `1e-9` of 4π·(winding number).
//! - [`ray_triangle`]: the inside test uses edge functions computed identically (bit for
//!   bit, up to sign) for both triangles that share an edge, so a ray crossing a shared
//!   edge or vertex of a consistently indexed mesh never slips between its triangles.

use glam::DVec3;

/// Squared-area test for degeneracy: a triangle is degenerate when
/// `|(b − a) × (c − a)|² ≤ DEGENERATE_RATIO · L⁴`, `L` its longest edge. The ratio is
/// `(h / L)²` for the height `h` over the longest edge, so degenerate triangles are
/// within `1e-10 · L` of a segment.
pub const DEGENERATE_RATIO: f64 = 1e-20;

/// Below this squared-area ratio the normal is recomputed with compensated products.
const SLIVER_RATIO: f64 = 1e-8;

/// The part of a triangle a closest point lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// The open interior of the face.
    Face,
    /// The interior of an edge: `Edge(0)` = a–b, `Edge(1)` = b–c, `Edge(2)` = c–a.
    Edge(u8),
    /// A corner: `Vertex(0)` = a, `Vertex(1)` = b, `Vertex(2)` = c.
    Vertex(u8),
}

/// The closest point of a triangle to a query point, from [`closest_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// The closest point on the triangle.
    pub point: DVec3,
    /// Squared distance from the query point to `point`.
    pub dist2: f64,
    /// The feature (face, edge or vertex) `point` lies on.
    pub feature: Feature,
    /// Barycentric coordinates of `point` with respect to `(a, b, c)`: non-negative, sum 1
    /// (up to rounding), zero on the vertices not spanning `feature`.
    pub bary: [f64; 3],
}

/// A ray–triangle intersection, from [`ray_triangle`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Ray parameter: the hit point is `origin + t · dir` (in units of `dir`'s length).
    pub t: f64,
    /// Barycentric coordinates of the hit point with respect to `(a, b, c)`: non-negative,
    /// sum 1 (up to rounding).
    pub bary: [f64; 3],
}

/// `a·b − c·d` with one rounding (Kahan's algorithm with FMA).
#[inline]
fn diff_of_products(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    let dop = a.mul_add(b, -cd);
    dop + err
}

/// Cross product with each component correctly rounded up to one ulp.
#[inline]
fn cross_accurate(u: DVec3, v: DVec3) -> DVec3 {
    DVec3::new(
        diff_of_products(u.y, v.z, u.z, v.y),
        diff_of_products(u.z, v.x, u.x, v.z),
        diff_of_products(u.x, v.y, u.y, v.x),
    )
}

/// The (unnormalized) normal `ab × ac` of a triangle given by its edge vectors, or
/// `None` when the triangle is degenerate (or not finite). `bc` is the third edge, used
/// only for its length.
#[inline]
pub(crate) fn face_normal(ab: DVec3, ac: DVec3, bc: DVec3) -> Option<DVec3> {
    let l2 = ab
        .length_squared()
        .max(ac.length_squared())
        .max(bc.length_squared());
    let l4 = l2 * l2;
    let mut n = ab.cross(ac);
    let mut n2 = n.length_squared();
    if n2 < SLIVER_RATIO * l4 {
        n = cross_accurate(ab, ac);
        n2 = n.length_squared();
    }
    // `!(x > y)` also rejects NaN; `l4 > 0` must hold too (n2 > 0 implies it unless l4
    // underflowed, which the ratio handles as degenerate).
    if n2 > DEGENERATE_RATIO * l4 && n2.is_finite() && l4 > 0.0 {
        Some(n)
    } else {
        None
    }
}

/// The unit normal of triangle `(a, b, c)` (counter-clockwise seen from the side it
/// points to), or `None` when the triangle is degenerate (see [`DEGENERATE_RATIO`]) or
/// not finite. Thin triangles get a compensated cross product.
pub fn unit_normal(a: DVec3, b: DVec3, c: DVec3) -> Option<DVec3> {
    let n = face_normal(b - a, c - a, c - b)?;
    let len = n.length();
    (len > 0.0 && len.is_finite()).then(|| n / len)
}

/// Whether triangle `(a, b, c)` is degenerate in the sense of [`DEGENERATE_RATIO`] (or has
/// a non-finite coordinate).
pub fn is_degenerate(a: DVec3, b: DVec3, c: DVec3) -> bool {
    face_normal(b - a, c - a, c - b).is_none()
}

/// Segment parameter and squared distance for the query `ap = p − a` against the segment
/// from `a` with edge vector `ab`, both relative to `a`. A zero-length segment gives
/// `t = 0`.
#[inline]
fn segment_local(ap: DVec3, ab: DVec3) -> (f64, f64) {
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        // NaN (non-finite input) stays NaN through `clamp` and poisons the distance, as
        // it should.
        (ap.dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d2 = if t == 1.0 {
        (ap - ab).length_squared()
    } else {
        (ap - ab * t).length_squared()
    };
    (t, d2)
}

/// The point of segment `a`–`b` closest to `p`, and its parameter `t ∈ [0, 1]`
/// (`point = a + t·(b − a)`, exactly `a` at `t = 0` and `b` at `t = 1`). A zero-length
/// segment gives `(a, 0)`. Computed relative to `a`, so it is accurate far from the
/// origin.
pub fn closest_point_segment(p: DVec3, a: DVec3, b: DVec3) -> (DVec3, f64) {
    let ab = b - a;
    let (t, _) = segment_local(p - a, ab);
    (lerp_exact(a, b, ab, t), t)
}

/// `a + t·ab`, returning the endpoints exactly at `t = 0` and `t = 1`.
#[inline]
fn lerp_exact(a: DVec3, b: DVec3, ab: DVec3, t: f64) -> DVec3 {
    if t == 0.0 {
        a
    } else if t == 1.0 {
        b
    } else {
        a + ab * t
    }
}

/// Closest point on edge `i` (from vertex `i` to vertex `(i + 1) % 3`), as a
/// [`ClosestPoint`] with the feature set to the edge, or a vertex at its ends.
#[inline]
fn edge_result(i: usize, v: [DVec3; 3], t: f64, dist2: f64) -> ClosestPoint {
    let j = (i + 1) % 3;
    let mut bary = [0.0; 3];
    let (point, feature) = if t == 0.0 {
        bary[i] = 1.0;
        (v[i], Feature::Vertex(i as u8))
    } else if t == 1.0 {
        bary[j] = 1.0;
        (v[j], Feature::Vertex(j as u8))
    } else {
        bary[i] = 1.0 - t;
        bary[j] = t;
        (v[i] + (v[j] - v[i]) * t, Feature::Edge(i as u8))
    };
    ClosestPoint {
        point,
        dist2,
        feature,
        bary,
    }
}

#[inline]
fn vertex_result(i: usize, v: DVec3, dist2: f64) -> ClosestPoint {
    let mut bary = [0.0; 3];
    bary[i] = 1.0;
    ClosestPoint {
        point: v,
        dist2,
        feature: Feature::Vertex(i as u8),
        bary,
    }
}

/// The point of triangle `(a, b, c)` closest to `p`, with its squared distance, the
/// feature it lies on and its barycentric coordinates.
///
/// Voronoi-region method (Ericson, *Real-Time Collision Detection*, 5.1.5) with the
/// region tests written as edge functions `n · (e × (p − v))` in coordinates local to a
/// vertex, and the face distance taken from the plane equation, so there is no
/// cancellation far from the origin, for tiny triangles or for slivers (see the module
/// docs for the tolerance).
///
/// Classification: a point whose closest point is strictly inside the face reports
/// [`Feature::Face`], strictly inside an edge [`Feature::Edge`], at a corner
/// [`Feature::Vertex`]; on region boundaries (within rounding) either neighbour may be
/// reported, with the distance still exact. A degenerate triangle (see
/// [`DEGENERATE_RATIO`]: zero area, collinear, repeated vertices) is handled as the
/// minimum over its three edges and never reports `Face`. Finite input never gives NaN
/// (as long as squared edge lengths do not overflow: coordinates below ~1e75); NaN input
/// gives a NaN distance, never a panic.
pub fn closest_point(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> ClosestPoint {
    let ab = b - a;
    let ac = c - a;
    let bc = c - b;
    let ap = p - a;
    let Some(n) = face_normal(ab, ac, bc) else {
        return closest_point_degenerate(p, [a, b, c]);
    };
    let bp = p - b;
    let cp = p - c;

    // Vertex region of a.
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return vertex_result(0, a, ap.length_squared());
    }
    // Vertex region of b.
    let d3 = ab.dot(bp);
    let d4 = bc.dot(bp);
    if d3 >= 0.0 && d4 <= 0.0 {
        return vertex_result(1, b, bp.length_squared());
    }
    // Edge region of ab.
    let vc = n.dot(ab.cross(ap));
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let (t, d2ab) = segment_local(ap, ab);
        return edge_result(0, [a, b, c], t, d2ab);
    }
    // Vertex region of c.
    let d5 = ac.dot(cp);
    let d6 = bc.dot(cp);
    if d5 >= 0.0 && d6 >= 0.0 {
        return vertex_result(2, c, cp.length_squared());
    }
    // Edge region of ca (Edge(2), parameter from c).
    let vb = n.dot((-ac).cross(cp));
    if vb <= 0.0 && d2 >= 0.0 && d5 <= 0.0 {
        let (t, d2ca) = segment_local(cp, -ac);
        return edge_result(2, [a, b, c], t, d2ca);
    }
    // Edge region of bc.
    let va = n.dot(bc.cross(bp));
    if va <= 0.0 && d4 >= 0.0 && d6 <= 0.0 {
        let (t, d2bc) = segment_local(bp, bc);
        return edge_result(1, [a, b, c], t, d2bc);
    }
    // Face region: project onto the plane.
    let n2 = n.length_squared();
    let h = n.dot(ap);
    let point = p - n * (h / n2);
    let (va, vb, vc) = (va.max(0.0), vb.max(0.0), vc.max(0.0));
    let sum = va + vb + vc;
    let bary = if sum > 0.0 {
        [va / sum, vb / sum, vc / sum]
    } else {
        [1.0 / 3.0; 3]
    };
    ClosestPoint {
        point,
        dist2: h * h / n2,
        feature: Feature::Face,
        bary,
    }
}

/// The closest point of a degenerate triangle: the best of its three edges.
fn closest_point_degenerate(p: DVec3, v: [DVec3; 3]) -> ClosestPoint {
    let mut best: Option<(usize, f64, f64)> = None;
    for i in 0..3 {
        let j = (i + 1) % 3;
        let (t, d2) = segment_local(p - v[i], v[j] - v[i]);
        if best.is_none_or(|(_, _, bd)| d2 < bd) {
            best = Some((i, t, d2));
        }
    }
    // The loop always sets `best` on its first iteration.
    let (i, t, d2) = best.unwrap_or((0, 0.0, (p - v[0]).length_squared()));
    edge_result(i, v, t, d2)
}

/// Signed solid angle subtended by triangle `(a, b, c)` at `p`, in steradians
/// (Van Oosterom & Strackee 1983: `2·atan2(det, denom)`).
///
/// Positive when `p` sees the triangle's back side, i.e. when `p` is on the side opposite
/// to the normal `(b − a) × (c − a)`. For a closed mesh oriented outward
/// (counter-clockwise seen from outside) the sum over its triangles divided by 4π is the
/// generalized winding number: 1 inside, 0 outside.
///
/// Returns 0 for a degenerate triangle (see [`DEGENERATE_RATIO`]), for `p` on a vertex
/// and for non-finite input; never NaN. For `p` in the triangle's plane inside it the
/// result is ±2π (the sign of a zero determinant decides).
pub fn solid_angle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let ra = a - p;
    let rb = b - p;
    let rc = c - p;
    let (la, lb, lc) = (ra.length(), rb.length(), rc.length());
    if !(la > 0.0 && lb > 0.0 && lc > 0.0) {
        return 0.0;
    }
    let Some(n) = face_normal(b - a, c - a, c - b) else {
        return 0.0;
    };
    // ra · (rb × rc) == ra · ((b − a) × (c − a)) exactly; the latter does not cancel.
    let det = ra.dot(n);
    let denom = la * lb * lc + ra.dot(rb) * lc + ra.dot(rc) * lb + rb.dot(rc) * la;
    let omega = 2.0 * det.atan2(denom);
    if omega.is_finite() { omega } else { 0.0 }
}

/// `true` when `x` precedes `y` lexicographically by (x, y, z).
#[inline]
fn lex_less(x: DVec3, y: DVec3) -> bool {
    (x.x, x.y, x.z) < (y.x, y.y, y.z)
}

/// Edge function (Plücker side product) of the ray `(o, dir)` with the directed edge
/// `x → y`: `dir · ((x − o) × (y − o))`, evaluated as `dir · ((x − o) × (y − x))` (equal,
/// without the cancellation of two long vectors when `o` is far away). It is computed
/// with the endpoints in a canonical order and negated when swapped, so the two
/// triangles sharing an edge (which traverse it in opposite directions) get exactly
/// opposite values.
#[inline]
fn edge_function(o: DVec3, dir: DVec3, x: DVec3, y: DVec3) -> f64 {
    if lex_less(y, x) {
        -dir.dot((y - o).cross(x - y))
    } else {
        dir.dot((x - o).cross(y - x))
    }
}

/// Intersection of the ray `origin + t·dir`, `0 ≤ t ≤ t_max`, with triangle `(a, b, c)`,
/// from either side.
///
/// This is Möller–Trumbore's barycentric test written in its edge-function (Plücker)
/// form: the three barycentric numerators are the signed volumes
/// `dir · ((x − o) × (y − o))` of the edges, evaluated in a canonical vertex order so that
/// the test is *watertight*: edge- and vertex-inclusive (`≥ 0`), and consistent between
/// the triangles that share an edge, so a ray crossing a shared edge or vertex of an
/// indexed mesh hits at least one of them (a ray exactly through an edge may report both).
/// `t` comes from the plane equation.
///
/// Returns `None` for a degenerate triangle (see [`DEGENERATE_RATIO`]), a ray parallel to
/// the plane (within rounding: `|dir · n| ≤ 8ε·|dir|·|n|`), a hit outside `[0, t_max]`, a
/// zero `dir`, or any NaN input.
pub fn ray_triangle(
    origin: DVec3,
    dir: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
    t_max: f64,
) -> Option<RayHit> {
    // The inside test first: most rays miss.
    let wc = edge_function(origin, dir, a, b);
    let wa = edge_function(origin, dir, b, c);
    let wb = edge_function(origin, dir, c, a);
    let all_pos = wa >= 0.0 && wb >= 0.0 && wc >= 0.0;
    let all_neg = wa <= 0.0 && wb <= 0.0 && wc <= 0.0;
    if !(all_pos || all_neg) {
        return None;
    }
    let n = face_normal(b - a, c - a, c - b)?;
    let dn = dir.dot(n);
    // Written so that NaN also returns.
    let transversal = dn.abs() > 8.0 * f64::EPSILON * dir.length() * n.length();
    if !transversal {
        return None;
    }
    let sum = wa + wb + wc;
    if !(sum != 0.0 && sum.is_finite()) {
        return None;
    }
    let t = (a - origin).dot(n) / dn;
    if !(t >= 0.0 && t <= t_max) {
        return None;
    }
    Some(RayHit {
        t,
        bary: [wa / sum, wb / sum, wc / sum],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::rng::{DEFAULT_SEED, SplitMix64};
    use std::f64::consts::PI;

    fn rnd(r: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * r.next_f64()
    }

    fn rvec(r: &mut SplitMix64, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(rnd(r, lo, hi), rnd(r, lo, hi), rnd(r, lo, hi))
    }

    fn runit(r: &mut SplitMix64) -> DVec3 {
        loop {
            let v = rvec(r, -1.0, 1.0);
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }

    /// Squared distance to a segment, written independently of the code under test
    /// (absolute coordinates, no shared helper).
    fn ref_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
        let d = b - a;
        let l2 = d.dot(d);
        if l2 == 0.0 {
            return (p - a).dot(p - a);
        }
        let t = ((p - a).dot(d) / l2).clamp(0.0, 1.0);
        let q = a + d * t;
        (p - q).dot(p - q)
    }

    /// Independent reference: unconstrained least-squares point of the plane (2×2 normal
    /// equations, Cramer's rule) when it falls inside, otherwise the best edge.
    fn ref_closest(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
        let e0 = ref_segment(p, a, b)
            .min(ref_segment(p, b, c))
            .min(ref_segment(p, c, a));
        let (u, v, w) = (b - a, c - a, p - a);
        let (uu, uv, vv, wu, wv) = (u.dot(u), u.dot(v), v.dot(v), w.dot(u), w.dot(v));
        let det = uu * vv - uv * uv;
        if det > 1e-12 * uu * vv {
            let s = (wu * vv - wv * uv) / det;
            let t = (wv * uu - wu * uv) / det;
            if s >= 0.0 && t >= 0.0 && s + t <= 1.0 {
                let q = a + u * s + v * t;
                return (p - q).dot(p - q).min(e0);
            }
        }
        e0
    }

    /// Upper bound by dense barycentric sampling (`k` steps per side) plus the exact edges.
    fn sampled_closest(p: DVec3, a: DVec3, b: DVec3, c: DVec3, k: usize) -> f64 {
        let mut best = ref_segment(p, a, b)
            .min(ref_segment(p, b, c))
            .min(ref_segment(p, c, a));
        for i in 0..=k {
            for j in 0..=(k - i) {
                let (s, t) = (i as f64 / k as f64, j as f64 / k as f64);
                let q = a + (b - a) * s + (c - a) * t;
                best = best.min((p - q).length_squared());
            }
        }
        best
    }

    /// Checks the internal consistency of a result: finite, point = Σ bary·v, bary ≥ 0
    /// summing to 1, dist2 = |p − point|², the feature matches the zero pattern of bary.
    fn check_consistent(p: DVec3, v: [DVec3; 3], r: &ClosestPoint, scale: f64) {
        assert!(r.dist2.is_finite() && r.point.is_finite(), "{r:?}");
        let sum: f64 = r.bary.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12, "{r:?}");
        assert!(r.bary.iter().all(|&x| x >= 0.0), "{r:?}");
        let q = v[0] * r.bary[0] + v[1] * r.bary[1] + v[2] * r.bary[2];
        assert!(
            (q - r.point).length() <= 1e-12 * scale,
            "{r:?} reconstructed {q}"
        );
        let d = (p - r.point).length();
        assert!(
            (d - r.dist2.sqrt()).abs() <= 1e-12 * scale,
            "{r:?} |p - point| = {d}"
        );
        match r.feature {
            Feature::Face => assert!(r.bary.iter().all(|&x| x > 0.0), "{r:?}"),
            Feature::Edge(i) => {
                let (i, j) = (i as usize, (i as usize + 1) % 3);
                assert_eq!(r.bary[3 - i - j], 0.0, "{r:?}");
                assert!(r.bary[i] > 0.0 && r.bary[j] > 0.0, "{r:?}");
            }
            Feature::Vertex(i) => assert_eq!(r.bary[i as usize], 1.0, "{r:?}"),
        }
    }

    fn scale_of(p: DVec3, v: [DVec3; 3]) -> f64 {
        let l = (v[1] - v[0])
            .length()
            .max((v[2] - v[1]).length())
            .max((v[0] - v[2]).length());
        (p - v[0]).length() + l
    }

    #[test]
    fn matches_independent_reference_on_random_triangles() {
        let mut r = SplitMix64::new(DEFAULT_SEED);
        for _ in 0..20_000 {
            let v = [
                rvec(&mut r, -1.0, 1.0),
                rvec(&mut r, -1.0, 1.0),
                rvec(&mut r, -1.0, 1.0),
            ];
            let p = rvec(&mut r, -2.0, 2.0);
            let res = closest_point(p, v[0], v[1], v[2]);
            let scale = scale_of(p, v);
            check_consistent(p, v, &res, scale);
            let want = ref_closest(p, v[0], v[1], v[2]);
            assert!(
                (res.dist2.sqrt() - want.sqrt()).abs() <= 1e-12 * scale,
                "{res:?} want {want}"
            );
        }
    }

    #[test]
    fn matches_sampling_on_random_triangles_and_points_near_them() {
        let mut r = SplitMix64::new(7);
        for _ in 0..300 {
            let v = [
                rvec(&mut r, -1.0, 1.0),
                rvec(&mut r, -1.0, 1.0),
                rvec(&mut r, -1.0, 1.0),
            ];
            // Points near the triangle (where the face region matters most).
            let q = v[0] * 0.3 + v[1] * 0.3 + v[2] * 0.4;
            let p = q + rvec(&mut r, -0.6, 0.6);
            let res = closest_point(p, v[0], v[1], v[2]);
            let scale = scale_of(p, v);
            check_consistent(p, v, &res, scale);
            // The result lies on the triangle (checked above), so it is an upper bound of
            // the true distance; sampling gives another upper bound that must not beat it.
            let sampled = sampled_closest(p, v[0], v[1], v[2], 200);
            assert!(
                res.dist2 <= sampled + 1e-12 * scale * scale,
                "{res:?} {sampled}"
            );
            // And it is close to the samples (grid spacing 1/200 of the edges).
            assert!(
                sampled.sqrt() - res.dist2.sqrt() <= 0.02,
                "{res:?} {sampled}"
            );
        }
    }

    #[test]
    fn slivers_and_needles() {
        let mut r = SplitMix64::new(11);
        for k in 0..3000 {
            let a = rvec(&mut r, -1.0, 1.0);
            let b = rvec(&mut r, -1.0, 1.0);
            let thin = 10f64.powf(-rnd(&mut r, 3.0, 9.0));
            let c = if k % 2 == 0 {
                // Cap: apex close to the segment a–b.
                a + (b - a) * rnd(&mut r, -0.2, 1.2) + runit(&mut r) * thin
            } else {
                // Needle: c close to b.
                b + runit(&mut r) * thin
            };
            let v = [a, b, c];
            let p = a + (b - a) * rnd(&mut r, -0.3, 1.3) + rvec(&mut r, -0.5, 0.5);
            let res = closest_point(p, a, b, c);
            let scale = scale_of(p, v);
            check_consistent(p, v, &res, scale);
            let sampled = sampled_closest(p, a, b, c, 40);
            assert!(
                res.dist2 <= sampled + 1e-12 * scale * scale,
                "{res:?} {sampled}"
            );
            // Lower bound: the distance to the triangle is at least the distance to its
            // plane... and the triangle is within `thin` of segment a–b for caps, of the
            // edge a–b / a–c for needles, so no point can be closer than that minus `thin`.
            let to_edges = ref_segment(p, a, b).min(ref_segment(p, a, c)).sqrt();
            assert!(res.dist2.sqrt() >= to_edges - thin * 1.01, "{res:?}");
        }
    }

    #[test]
    fn sliver_face_distance_is_accurate() {
        // Thin triangle in the z = 0 plane: the distance of a point above its interior is
        // exactly its height, even though the triangle is 1e-7 thick.
        for &(h, off) in &[(1e-7, 0.0), (1e-9, 0.0), (1e-7, 1e6), (1e-5, -3e5)] {
            let o = DVec3::new(off, off * 0.5, -off);
            let a = o + DVec3::new(0.0, 0.0, 0.0);
            let b = o + DVec3::new(1.0, 0.0, 0.0);
            let c = o + DVec3::new(0.5, h, 0.0);
            // Rotate nothing (keeps exactness); point above the centroid.
            let q = o + DVec3::new(0.5, h / 3.0, 0.0);
            let p = q + DVec3::new(0.0, 0.0, 0.25);
            let res = closest_point(p, a, b, c);
            assert_eq!(res.feature, Feature::Face, "{res:?}");
            assert!((res.dist2.sqrt() - 0.25).abs() < 1e-12 * 1.25, "{res:?}");
        }
    }

    #[test]
    fn rotated_sliver_face_distance_is_accurate() {
        // Rotated slivers: the naive cross product loses ~eps/(h/L) of the normal's
        // direction (1e-9 for h = 1e-7), the compensated one does not. The distance from a
        // point at height 0.25 above the centroid must stay 0.25 to 1e-12 (the rounding of
        // the rotated vertices moves the triangle by ~1e-16 only).
        let mut r = SplitMix64::new(29);
        for k in 0..2000 {
            let h = [1e-5, 1e-7, 1e-9][k % 3];
            let q = glam::DQuat::from_axis_angle(runit(&mut r), rnd(&mut r, 0.0, 2.0 * PI));
            let o = rvec(&mut r, -10.0, 10.0);
            let (ea, eb, ec) = (
                DVec3::new(-0.5, 0.0, 0.0),
                DVec3::new(0.5, 0.0, 0.0),
                DVec3::new(rnd(&mut r, -0.4, 0.4), h, 0.0),
            );
            let centroid = (ea + eb + ec) / 3.0;
            let (a, b, c) = (o + q * ea, o + q * eb, o + q * ec);
            let p = o + q * (centroid + DVec3::Z * 0.25);
            let res = closest_point(p, a, b, c);
            // For h = 1e-9 the rounding of the rotated vertices tilts the plane by ~1e-7,
            // which moves the projection of p by more than the sliver's width: the true
            // closest point may then be on the long edge (same distance).
            if h > 1e-8 {
                assert_eq!(res.feature, Feature::Face, "{h} {res:?}");
            }
            assert!(
                (res.dist2.sqrt() - 0.25).abs() < 1e-12,
                "{h}: {}",
                res.dist2.sqrt() - 0.25
            );
        }
    }

    #[test]
    fn exact_on_vertices_edges_and_faces() {
        let mut r = SplitMix64::new(3);
        for _ in 0..5000 {
            let v = [
                rvec(&mut r, -1.0, 1.0),
                rvec(&mut r, -1.0, 1.0),
                rvec(&mut r, -1.0, 1.0),
            ];
            if is_degenerate(v[0], v[1], v[2]) {
                continue;
            }
            let l = scale_of(v[0], v);
            for (i, &vi) in v.iter().enumerate() {
                let res = closest_point(vi, v[0], v[1], v[2]);
                assert_eq!(res.dist2, 0.0, "{res:?}");
                assert_eq!(res.point, vi);
                assert_eq!(res.feature, Feature::Vertex(i as u8));
            }
            for i in 0..3 {
                let t = rnd(&mut r, 0.01, 0.99);
                let p = v[i] + (v[(i + 1) % 3] - v[i]) * t;
                let res = closest_point(p, v[0], v[1], v[2]);
                assert!(res.dist2.sqrt() <= 4.0 * f64::EPSILON * l, "{res:?}");
                check_consistent(p, v, &res, l);
            }
            let (s, t) = (rnd(&mut r, 0.01, 0.49), rnd(&mut r, 0.01, 0.49));
            let p = v[0] + (v[1] - v[0]) * s + (v[2] - v[0]) * t;
            let res = closest_point(p, v[0], v[1], v[2]);
            assert!(res.dist2.sqrt() <= 4.0 * f64::EPSILON * l, "{res:?}");
            check_consistent(p, v, &res, l);
        }
        // Nicely representable: exactly zero.
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let res = closest_point(DVec3::new(0.5, 0.0, 0.0), a, b, c);
        assert_eq!((res.dist2, res.feature), (0.0, Feature::Edge(0)));
        let res = closest_point(DVec3::new(0.5, 0.5, 0.0), a, b, c);
        assert_eq!(res.dist2, 0.0);
        assert_eq!(res.feature, Feature::Edge(1));
        let res = closest_point(DVec3::new(0.25, 0.25, 0.0), a, b, c);
        assert_eq!((res.dist2, res.feature), (0.0, Feature::Face));
        assert_eq!(res.bary, [0.5, 0.25, 0.25]);
    }

    /// A random well-shaped triangle (all angles above ~15°).
    fn fat_triangle(r: &mut SplitMix64) -> [DVec3; 3] {
        loop {
            let v = [rvec(r, -1.0, 1.0), rvec(r, -1.0, 1.0), rvec(r, -1.0, 1.0)];
            let ok = (0..3).all(|i| {
                let e1 = (v[(i + 1) % 3] - v[i]).normalize();
                let e2 = (v[(i + 2) % 3] - v[i]).normalize();
                e1.dot(e2) < 0.96
            });
            if ok && (v[1] - v[0]).cross(v[2] - v[0]).length() > 0.2 {
                return v;
            }
        }
    }

    #[test]
    fn feature_classification() {
        // Fixed cases on the unit right triangle.
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let cases = [
            (DVec3::new(0.25, 0.25, 1.0), Feature::Face, 1.0),
            (DVec3::new(1.0 / 3.0, 1.0 / 3.0, -2.0), Feature::Face, 4.0),
            (DVec3::new(0.5, -1.0, 0.0), Feature::Edge(0), 1.0),
            (DVec3::new(1.5, 1.5, 0.0), Feature::Edge(1), 2.0),
            (DVec3::new(-2.0, 0.5, 1.0), Feature::Edge(2), 5.0),
            (DVec3::new(-1.0, -1.0, 0.5), Feature::Vertex(0), 2.25),
            (DVec3::new(2.0, -0.5, 0.0), Feature::Vertex(1), 1.25),
            (DVec3::new(-0.5, 3.0, 0.0), Feature::Vertex(2), 4.25),
        ];
        for (p, f, d2) in cases {
            let res = closest_point(p, a, b, c);
            assert_eq!(res.feature, f, "{p} {res:?}");
            assert!((res.dist2 - d2).abs() < 1e-15, "{p} {res:?}");
        }
        // Constructed cases on random triangles: the expected feature and distance are
        // known by construction.
        let mut r = SplitMix64::new(5);
        for _ in 0..5000 {
            let v = fat_triangle(&mut r);
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let h = rnd(&mut r, -1.0, 1.0);
            // Face: above an interior point.
            let (s, t) = (rnd(&mut r, 0.05, 0.9), rnd(&mut r, 0.05, 0.9));
            let (s, t) = if s + t > 0.95 {
                (0.95 - t, 0.95 - s)
            } else {
                (s, t)
            };
            let q = v[0] + (v[1] - v[0]) * s + (v[2] - v[0]) * t;
            let res = closest_point(q + n * h, v[0], v[1], v[2]);
            assert_eq!(res.feature, Feature::Face, "{res:?}");
            assert!((res.dist2.sqrt() - h.abs()).abs() < 1e-13, "{res:?} {h}");
            assert!((res.point - q).length() < 1e-13);
            // Edge: beyond an edge point, outward in the plane, plus a normal offset.
            for i in 0..3 {
                let (vi, vj, vk) = (v[i], v[(i + 1) % 3], v[(i + 2) % 3]);
                let t = rnd(&mut r, 0.05, 0.95);
                let q = vi + (vj - vi) * t;
                let e = (vj - vi).normalize();
                let mut m = n.cross(e);
                if m.dot(vk - vi) > 0.0 {
                    m = -m;
                }
                let s = rnd(&mut r, 0.0, 1.0);
                let res = closest_point(q + m * s + n * h, v[0], v[1], v[2]);
                if s > 1e-6 {
                    assert_eq!(res.feature, Feature::Edge(i as u8), "{res:?}");
                }
                assert!(
                    (res.dist2.sqrt() - (s * s + h * h).sqrt()).abs() < 1e-13,
                    "{res:?}"
                );
                assert!((res.point - q).length() < 1e-13);
            }
            // Vertex: inside the vertex's normal cone (obtuse to both incident edges).
            for i in 0..3 {
                let (vi, vj, vk) = (v[i], v[(i + 1) % 3], v[(i + 2) % 3]);
                let w = loop {
                    let w = runit(&mut r) * rnd(&mut r, 0.01, 2.0);
                    let (e1, e2) = ((vj - vi).normalize(), (vk - vi).normalize());
                    if w.dot(e1) < -1e-3 && w.dot(e2) < -1e-3 {
                        break w;
                    }
                };
                let res = closest_point(vi + w, v[0], v[1], v[2]);
                assert_eq!(res.feature, Feature::Vertex(i as u8), "{res:?}");
                assert_eq!(res.point, vi);
                assert!((res.dist2.sqrt() - w.length()).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn degenerate_triangles_reduce_to_segments() {
        let mut r = SplitMix64::new(9);
        for k in 0..6000 {
            let a = rvec(&mut r, -1.0, 1.0);
            let b = rvec(&mut r, -1.0, 1.0);
            let v = match k % 8 {
                0 => [a, b, a + (b - a) * 0.5],  // collinear, c between
                1 => [a, b, a + (b - a) * 2.5],  // collinear, c beyond b
                2 => [a, a, b],                  // a repeated
                3 => [a, b, a],                  // a repeated as c
                4 => [a, b, b],                  // b repeated
                5 => [a, a, a],                  // a point
                6 => [a + (b - a) * -0.7, a, b], // collinear, a first
                _ => [a, b, a + (b - a) * 0.3 + runit(&mut r) * 1e-14], // near zero area
            };
            assert!(is_degenerate(v[0], v[1], v[2]), "{k}");
            let p = rvec(&mut r, -2.0, 2.0);
            let res = closest_point(p, v[0], v[1], v[2]);
            let scale = scale_of(p, v);
            check_consistent(p, v, &res, scale);
            assert_ne!(res.feature, Feature::Face);
            let want = ref_segment(p, v[0], v[1])
                .min(ref_segment(p, v[1], v[2]))
                .min(ref_segment(p, v[2], v[0]));
            assert!(
                (res.dist2.sqrt() - want.sqrt()).abs() <= 1e-12 * scale,
                "{k} {res:?} {want}"
            );
            // Points exactly on the vertices.
            for &q in &v {
                let res = closest_point(q, v[0], v[1], v[2]);
                assert_eq!(res.dist2, 0.0, "{k} {res:?}");
            }
        }
        // Non-finite input: no panic, and the degenerate path never invents a Face.
        let nan = DVec3::splat(f64::NAN);
        let res = closest_point(DVec3::ZERO, nan, DVec3::X, DVec3::Y);
        assert_ne!(res.feature, Feature::Face);
        let _ = closest_point(nan, DVec3::ZERO, DVec3::X, DVec3::Y);
        let inf = DVec3::splat(f64::INFINITY);
        let _ = closest_point(DVec3::ZERO, inf, DVec3::X, DVec3::Y);
    }

    #[test]
    fn scale_and_translation_invariance() {
        // Coordinates on a 2^-20 grid so that scaling by powers of two and translating by
        // 2^20 are exact: the answers must then agree to a relative 1e-12.
        let mut r = SplitMix64::new(13);
        let grid = |r: &mut SplitMix64| {
            let g = (1u64 << 20) as f64;
            (rvec(r, -1.0, 1.0) * g).round() / g
        };
        for _ in 0..5000 {
            let v = [grid(&mut r), grid(&mut r), grid(&mut r)];
            let p = grid(&mut r) * 2.0;
            let base = closest_point(p, v[0], v[1], v[2]);
            let scale = scale_of(p, v);
            for &(s, off) in &[
                (1.0, 1048576.0),
                (1.0, -3.0 * 1048576.0),
                (1.0 / 1048576.0, 0.0),
                (1.0 / 1048576.0, 1.0),
                (1048576.0, 0.0),
                (1048576.0, 1048576.0 * 1048576.0),
            ] {
                let o = DVec3::new(off, -off, 0.5 * off);
                let t = |x: DVec3| x * s + o;
                let res = closest_point(t(p), t(v[0]), t(v[1]), t(v[2]));
                assert!(
                    (res.dist2.sqrt() / s - base.dist2.sqrt()).abs() <= 1e-12 * scale,
                    "s {s} off {off}: {res:?} vs {base:?}"
                );
            }
            // Decimal scales (inexact): 1e-6 and 1e6, also far from the origin.
            for &(s, off) in &[(1e-6, 0.0), (1e-6, 1.0), (1e6, 0.0), (1.0, 1e6)] {
                let o = DVec3::new(off, off, -off);
                let t = |x: DVec3| x * s + o;
                let (tp, tv) = (t(p), [t(v[0]), t(v[1]), t(v[2])]);
                let res = closest_point(tp, tv[0], tv[1], tv[2]);
                // The reference in coordinates local to the triangle.
                let want = ref_closest(tp - tv[0], DVec3::ZERO, tv[1] - tv[0], tv[2] - tv[0]);
                assert!(
                    (res.dist2.sqrt() - want.sqrt()).abs() <= 1e-12 * scale * s,
                    "s {s} off {off}: {res:?} vs {want}"
                );
                // Absolute coordinates of the point carry ulps of `off`.
                check_consistent(tp, tv, &res, scale * s + 1e-3 * off);
            }
        }
        // Far query point from a unit triangle.
        let res = closest_point(DVec3::new(0.25, 0.25, 1e6), DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(res.feature, Feature::Face);
        assert_eq!(res.dist2, 1e12);
    }

    #[test]
    fn closest_point_segment_basics() {
        let (a, b) = (DVec3::new(1.0, 1.0, 1.0), DVec3::new(3.0, 1.0, 1.0));
        assert_eq!(closest_point_segment(DVec3::ZERO, a, b), (a, 0.0));
        assert_eq!(closest_point_segment(DVec3::splat(9.0), a, b), (b, 1.0));
        let (q, t) = closest_point_segment(DVec3::new(1.5, 5.0, -2.0), a, b);
        assert_eq!((q, t), (DVec3::new(1.5, 1.0, 1.0), 0.25));
        assert_eq!(closest_point_segment(DVec3::ZERO, a, a), (a, 0.0));
    }

    fn tetrahedron() -> ([DVec3; 4], [[usize; 3]; 4]) {
        let v = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let mut f = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        // Orient each face outward (away from the centroid at the origin).
        for t in &mut f {
            let n = (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);
            if n.dot(v[t[0]]) < 0.0 {
                t.swap(1, 2);
            }
        }
        (v, f)
    }

    #[test]
    fn solid_angle_tetrahedron_and_sign() {
        let (v, f) = tetrahedron();
        let mut sum = 0.0;
        for t in f {
            let w = solid_angle(DVec3::ZERO, v[t[0]], v[t[1]], v[t[2]]);
            assert!((w - PI).abs() < 1e-14, "{w}");
            sum += w;
        }
        assert!((sum - 4.0 * PI).abs() < 1e-13);
        // Outside: sums to zero.
        let p = DVec3::new(3.0, -0.5, 0.2);
        let sum: f64 = f
            .iter()
            .map(|t| solid_angle(p, v[t[0]], v[t[1]], v[t[2]]))
            .sum();
        assert!(sum.abs() < 1e-14, "{sum}");
        // Sign: below a +z-facing triangle (its back side) is positive.
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert!(solid_angle(DVec3::new(0.2, 0.2, -1.0), a, b, c) > 0.0);
        assert!(solid_angle(DVec3::new(0.2, 0.2, 1.0), a, b, c) < 0.0);
        // A unit right triangle seen from far along its normal: area / r².
        let w = solid_angle(DVec3::new(0.0, 0.0, -1e4), a, b, c);
        assert!((w - 0.5e-8).abs() < 1e-14, "{w}");
        // Seen from its own plane far away: zero.
        assert_eq!(solid_angle(DVec3::new(1e3, 7.0, 0.0), a, b, c), 0.0);
        let w = solid_angle(DVec3::new(1e3, 7.0, 1e-3), a, b, c);
        assert!(w.abs() < 1e-12, "{w}");
    }

    #[test]
    fn solid_angle_degenerate_cases() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        for p in [a, b, c] {
            assert_eq!(solid_angle(p, a, b, c), 0.0);
        }
        let p = DVec3::new(0.3, 0.1, 0.7);
        assert_eq!(solid_angle(p, a, b, b * 2.0), 0.0);
        assert_eq!(solid_angle(p, a, a, c), 0.0);
        assert_eq!(solid_angle(p, a, a, a), 0.0);
        assert_eq!(solid_angle(a, a, b, b * 2.0), 0.0);
        let nan = DVec3::splat(f64::NAN);
        assert_eq!(solid_angle(nan, a, b, c), 0.0);
        assert_eq!(solid_angle(p, nan, b, c), 0.0);
        // On an edge or the face: finite (±π or ±2π), never NaN.
        assert!(solid_angle(DVec3::new(0.5, 0.0, 0.0), a, b, c).is_finite());
        let w = solid_angle(DVec3::new(0.25, 0.25, 0.0), a, b, c);
        assert!((w.abs() - 2.0 * PI).abs() < 1e-12, "{w}");
    }

    #[test]
    fn solid_angle_sums_to_winding_number_on_icosphere() {
        let mesh = isokit_field::generate::icosphere(glam::Vec3::new(0.1, -0.2, 0.3), 1.0, 3);
        let pos: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        let centre = DVec3::new(0.1, -0.2, 0.3);
        let winding = |p: DVec3| {
            mesh.triangles
                .iter()
                .map(|t| {
                    solid_angle(
                        p,
                        pos[t[0] as usize],
                        pos[t[1] as usize],
                        pos[t[2] as usize],
                    )
                })
                .sum::<f64>()
        };
        let mut r = SplitMix64::new(17);
        for _ in 0..200 {
            let d = runit(&mut r);
            let inside = centre + d * rnd(&mut r, 0.0, 0.98);
            let w = winding(inside);
            assert!((w - 4.0 * PI).abs() < 1e-9, "{w}");
            let outside = centre + d * rnd(&mut r, 1.02, 50.0);
            let w = winding(outside);
            assert!(w.abs() < 1e-9, "{w}");
        }
        // Exactly at a vertex: the 0 from its own triangles, finite overall.
        assert!(winding(pos[0]).is_finite());
    }

    #[test]
    fn ray_grid_matches_plane_intersection() {
        let mut r = SplitMix64::new(19);
        let mut hits = 0;
        for _ in 0..200 {
            let v = fat_triangle(&mut r);
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let o = rvec(&mut r, -3.0, 3.0);
            // Rays aimed at a grid of points of the plane, in and around the triangle.
            for i in 0..=12 {
                for j in 0..=12 {
                    let (s, t) = (i as f64 / 8.0 - 0.25, j as f64 / 8.0 - 0.25);
                    let target = v[0] + (v[1] - v[0]) * s + (v[2] - v[0]) * t;
                    let dir = (target - o) * rnd(&mut r, 0.5, 2.0);
                    let hit = ray_triangle(o, dir, v[0], v[1], v[2], f64::INFINITY);
                    let bary = [1.0 - s - t, s, t];
                    let inside = bary.iter().all(|&x| x > 1e-9);
                    let outside = bary.iter().any(|&x| x < -1e-9);
                    if dir.normalize().dot(n.normalize()).abs() < 1e-6 {
                        continue;
                    }
                    let t_plane = (v[0] - o).dot(n) / dir.dot(n);
                    if inside {
                        let h = hit.expect("inside ray must hit");
                        hits += 1;
                        assert!((h.t - t_plane).abs() < 1e-10 * t_plane.abs().max(1.0));
                        for k in 0..3 {
                            assert!((h.bary[k] - bary[k]).abs() < 1e-10, "{h:?} {bary:?}");
                        }
                        let p = o + dir * h.t;
                        assert!((p - target).length() < 1e-10);
                    } else if outside {
                        assert!(hit.is_none(), "{hit:?} {bary:?}");
                    }
                    // Limited range and backwards rays.
                    if inside {
                        assert!(ray_triangle(o, dir, v[0], v[1], v[2], t_plane * 0.99).is_none());
                        assert!(ray_triangle(o, -dir, v[0], v[1], v[2], 1e9).is_none());
                    }
                }
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_never_slip() {
        let mut r = SplitMix64::new(23);
        for _ in 0..300 {
            // A quad split along its diagonal b–c (non-planar, random), triangles (a, b, c)
            // and (c, b, d), consistently oriented; and a fan of 6 triangles around m.
            let a = rvec(&mut r, -1.0, 1.0);
            let b = rvec(&mut r, -1.0, 1.0);
            let c = rvec(&mut r, -1.0, 1.0);
            let d = b + c - a + rvec(&mut r, -0.3, 0.3);
            let o = (a + b + c + d) * 0.25 + runit(&mut r) * rnd(&mut r, 1.0, 5.0);
            for _ in 0..200 {
                let q = b + (c - b) * r.next_f64();
                let dir = q - o;
                let h1 = ray_triangle(o, dir, a, b, c, f64::INFINITY);
                let h2 = ray_triangle(o, dir, c, b, d, f64::INFINITY);
                // A ray aimed at the shared edge that crosses the surface there (enters
                // both triangles' planes from the same side; otherwise it may legitimately
                // graze past a fold) hits one of them.
                let n1 = (b - a).cross(c - a).normalize();
                let n2 = (b - c).cross(d - c).normalize();
                let dn = dir.normalize();
                let (s1, s2) = (dn.dot(n1), dn.dot(n2));
                if s1.abs() > 1e-3 && s2.abs() > 1e-3 && s1 * s2 > 0.0 {
                    assert!(h1.is_some() || h2.is_some(), "slipped through the edge");
                }
            }
            // Fan around m: rays straight at m hit at least one triangle.
            let m = rvec(&mut r, -1.0, 1.0);
            let ring: Vec<DVec3> = (0..6)
                .map(|k| {
                    let ang = k as f64 * PI / 3.0;
                    m + DVec3::new(ang.cos(), ang.sin(), rnd(&mut r, -0.2, 0.2))
                })
                .collect();
            let o = m + DVec3::new(rnd(&mut r, -0.5, 0.5), rnd(&mut r, -0.5, 0.5), 2.0);
            let dir = m - o;
            let any = (0..6).any(|k| {
                ray_triangle(o, dir, m, ring[k], ring[(k + 1) % 6], f64::INFINITY).is_some()
            });
            assert!(any, "slipped through the vertex");
        }
        // Exactly through the edge of two axis-aligned triangles.
        let (a, b, c, d) = (DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0));
        for k in 1..64 {
            let x = k as f64 / 64.0;
            let o = DVec3::new(x, 1.0 - x, 1.0);
            let h1 = ray_triangle(o, -DVec3::Z, a, b, c, 10.0);
            let h2 = ray_triangle(o, -DVec3::Z, c, b, d, 10.0);
            assert!(h1.is_some() || h2.is_some());
            assert_eq!(h1.or(h2).map(|h| h.t), Some(1.0));
        }
    }

    #[test]
    fn ray_misses_parallel_degenerate_and_nan() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        // Parallel, above and in the plane.
        assert!(ray_triangle(DVec3::new(-1.0, 0.2, 0.5), DVec3::X, a, b, c, 1e9).is_none());
        assert!(ray_triangle(DVec3::new(-1.0, 0.2, 0.0), DVec3::X, a, b, c, 1e9).is_none());
        // Degenerate triangles.
        let o = DVec3::new(0.2, 0.0, 1.0);
        assert!(ray_triangle(o, -DVec3::Z, a, b, b * 2.0, 1e9).is_none());
        assert!(ray_triangle(o, -DVec3::Z, a, a, c, 1e9).is_none());
        assert!(ray_triangle(o, -DVec3::Z, a, a, a, 1e9).is_none());
        // Zero direction, NaN everywhere.
        assert!(ray_triangle(o, DVec3::ZERO, a, b, c, 1e9).is_none());
        let nan = DVec3::splat(f64::NAN);
        assert!(ray_triangle(nan, -DVec3::Z, a, b, c, 1e9).is_none());
        assert!(ray_triangle(o, nan, a, b, c, 1e9).is_none());
        assert!(ray_triangle(o, -DVec3::Z, nan, b, c, 1e9).is_none());
        assert!(ray_triangle(o, -DVec3::Z, a, b, c, f64::NAN).is_none());
        // Both facings hit.
        let up = ray_triangle(DVec3::new(0.2, 0.2, -1.0), DVec3::Z, a, b, c, 1e9).unwrap();
        let down = ray_triangle(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z, a, b, c, 1e9).unwrap();
        assert_eq!((up.t, down.t), (1.0, 1.0));
        assert_eq!(up.bary, down.bary);
        // Far away, tiny triangle (powers of two, so that the input is exact).
        let s = 1.0 / 1048576.0;
        let o = DVec3::new(1048576.0, 1048576.0, 1048576.0);
        let hit = ray_triangle(
            o + DVec3::new(0.25 * s, 0.25 * s, 1.0),
            -DVec3::Z,
            o,
            o + DVec3::X * s,
            o + DVec3::Y * s,
            2.0,
        )
        .unwrap();
        assert!((hit.t - 1.0).abs() < 1e-12, "{hit:?}");
        assert!((hit.bary[0] - 0.5).abs() < 1e-9, "{hit:?}");
        assert!((hit.bary[1] - 0.25).abs() < 1e-9, "{hit:?}");
        // Unit triangle, ray origin 1e6 away.
        let hit = ray_triangle(
            DVec3::new(0.25, 0.25, 1e6),
            -DVec3::Z,
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            2e6,
        )
        .unwrap();
        assert_eq!(hit.t, 1e6);
        assert!((hit.bary[0] - 0.5).abs() < 1e-12, "{hit:?}");
    }
}
