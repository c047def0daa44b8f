//! Distance to a triangle in its local frame (002 Listing 4.1, corrected): the branch-light
//! f32 routine that the WGSL kernel (`shaders/common/prism.wgsl`) mirrors line by line.
//!
//! ## The frame
//! The `r` axis runs along the triangle's longest side, the origin is the foot of the
//! altitude from the opposite corner, `s` points to that corner and `t = r × s` is the face
//! normal. The corners are `A = (a, 0)`, `B = (−b, 0)`, `C = (0, h)` with `a, b, h ≥ 0`
//! (the foot lies on the longest side because the two angles next to it are at most 90°).
//!
//! ## The printed listing and its correction
//! For `r ≥ 0` (after reflecting `r < 0`, which swaps `a` for `b`) the closest point lies in
//! the right half `(0,0), (a,0), (0,h)`. Below the `r` axis it is on the side `AB`; above it
//! a second frame along the hypotenuse from `C` to `A` is used: `r'` is the position along
//! it (0 at `C`, 1 at `A`) and `s'` the signed distance from it, both in units of its length.
//! Listing 4.1 prints `s' = (h·r − a·s − a·h) / lenSqr`, which is not perpendicular to the
//! hypotenuse (it gives `−2ah/lenSqr` at `C` itself); the correct form is
//! `s' = (h·r + a·s − a·h) / lenSqr`. [`distance_printed`] keeps the printed form so a test can
//! show it fails against brute force.
//!
//! Zero-length sides are handled without branches: with `h = 0` the formulas reduce to the
//! distance to a segment, and a side of length zero (`lenSqr = 0`) takes the `s < 0` branch,
//! which is then the distance to the point at the origin.

/// The closest feature found by [`distance`]: which of the triangle's seven sites (face,
/// three edges, three corners) is nearest. Indices match the pseudonormal slots of a prism.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocalFeature {
    /// The open face.
    Face,
    /// Side `AB` (on the `r` axis).
    EdgeAB,
    /// Side `BC` (left of the altitude).
    EdgeBC,
    /// Side `CA` (right of the altitude).
    EdgeCA,
    /// Corner `A = (a, 0)`.
    VertexA,
    /// Corner `B = (−b, 0)`.
    VertexB,
    /// Corner `C = (0, h)`.
    VertexC,
}

impl LocalFeature {
    /// The slot of the feature's pseudonormal in a prism (`None` for the face, whose normal
    /// is the `t` axis): 0 `AB`, 1 `BC`, 2 `CA`, 3 `A`, 4 `B`, 5 `C`.
    pub fn slot(self) -> Option<usize> {
        match self {
            LocalFeature::Face => None,
            LocalFeature::EdgeAB => Some(0),
            LocalFeature::EdgeBC => Some(1),
            LocalFeature::EdgeCA => Some(2),
            LocalFeature::VertexA => Some(3),
            LocalFeature::VertexB => Some(4),
            LocalFeature::VertexC => Some(5),
        }
    }

    fn from_slot(slot: u32) -> Self {
        match slot {
            0 => LocalFeature::EdgeAB,
            1 => LocalFeature::EdgeBC,
            2 => LocalFeature::EdgeCA,
            3 => LocalFeature::VertexA,
            4 => LocalFeature::VertexB,
            5 => LocalFeature::VertexC,
            _ => LocalFeature::Face,
        }
    }
}

/// `select(f, t, cond)` as in WGSL: `t` when `cond`, else `f`.
#[inline(always)]
fn select<T>(f: T, t: T, cond: bool) -> T {
    if cond { t } else { f }
}

/// Squared distance from `(r, s, t)` to the triangle `A = (a, 0, 0)`, `B = (−b, 0, 0)`,
/// `C = (0, h, 0)`, and the slot of the closest feature (6 for the face; see
/// [`LocalFeature::slot`]). `inv_a = 1 / (a² + h²)` and `inv_b = 1 / (b² + h²)` (0 where
/// the denominator is 0). The WGSL function `prism_distance2` is this routine, line by line.
#[inline(always)]
#[expect(
    clippy::too_many_arguments,
    reason = "mirrors the WGSL function, which takes the triangle's scalars"
)]
pub fn distance2(
    r: f32,
    s: f32,
    t: f32,
    a: f32,
    b: f32,
    h: f32,
    inv_a: f32,
    inv_b: f32,
) -> (f32, u32) {
    // Reflect to the half r >= 0.
    let left = r < 0.0;
    let rr = r.abs();
    let aa = select(a, b, left);
    let inv = select(inv_a, inv_b, left);
    // Second frame along the hypotenuse from C to (aa, 0): position and offset, in units of
    // its length (the corrected s').
    let r2 = (aa * rr - h * s + h * h) * inv;
    let s2 = (h * rr + aa * s - aa * h) * inv;
    let len2 = aa * aa + h * h;
    // Clamp the components of the vector to the closest point.
    let dr2 = (-r2).max(r2 - 1.0).max(0.0);
    let ds2 = s2.max(0.0);
    let dr = (rr - aa).max(0.0);
    let below = s < 0.0 || inv <= 0.0;
    let d2 = select((dr2 * dr2 + ds2 * ds2) * len2, dr * dr + s * s, below) + t * t;
    // The closest feature (for the pseudonormal sign).
    let corner_ab = select(3u32, 4u32, left); // A, or B when reflected
    let side = select(2u32, 1u32, left); // CA, or BC when reflected
    let above = select(
        select(select(6u32, side, s2 > 0.0), corner_ab, r2 > 1.0),
        5u32,
        r2 < 0.0,
    );
    let feature = select(above, select(0u32, corner_ab, rr > aa), below);
    (d2, feature)
}

/// [`distance2`] as a distance and a [`LocalFeature`].
pub fn distance(r: f32, s: f32, t: f32, a: f32, b: f32, h: f32) -> (f32, LocalFeature) {
    let (inv_a, inv_b) = inverses(a, b, h);
    let (d2, f) = distance2(r, s, t, a, b, h, inv_a, inv_b);
    (d2.sqrt(), LocalFeature::from_slot(f))
}

/// `(1 / (a² + h²), 1 / (b² + h²))`, 0 where a denominator is 0 or not finite.
pub fn inverses(a: f32, b: f32, h: f32) -> (f32, f32) {
    let inv = |x: f32| {
        let l = x * x + h * h;
        if l > 0.0 && (1.0 / l).is_finite() {
            1.0 / l
        } else {
            0.0
        }
    };
    (inv(a), inv(b))
}

/// Listing 4.1 exactly as printed (with its wrong `s'`), kept only so that a test shows the
/// printed form disagrees with brute force.
pub fn distance_printed(r: f32, s: f32, t: f32, a: f32, b: f32, h: f32) -> f32 {
    let (mut r, mut a) = (r, a);
    if r < 0.0 {
        r = -r;
        a = b;
    }
    let len_sqr = a * a + h * h;
    let rp = (a * r - h * s + h * h) / len_sqr;
    let sp = (h * r - a * s - a * h) / len_sqr;
    let rp = (-rp).max(rp - 1.0).max(0.0);
    let sp = sp.max(0.0);
    let rr = (r - a).max(0.0);
    let dist = if s < 0.0 {
        (rr * rr + s * s + t * t).sqrt()
    } else {
        ((rp * rp + sp * sp) * len_sqr + t * t).sqrt()
    };
    dist.copysign(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use isokit_field::rng::SplitMix64;
    use isokit_kdtree::triangle::{Feature, closest_point};

    /// The triangle's corners in 3D (local frame = world frame).
    fn corners(a: f32, b: f32, h: f32) -> [DVec3; 3] {
        [
            DVec3::new(a as f64, 0.0, 0.0),
            DVec3::new(-b as f64, 0.0, 0.0),
            DVec3::new(0.0, h as f64, 0.0),
        ]
    }

    fn brute(p: [f32; 3], a: f32, b: f32, h: f32) -> (f64, Feature) {
        let [pa, pb, pc] = corners(a, b, h);
        let q = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        let cp = closest_point(q, pa, pb, pc);
        (cp.dist2.sqrt(), cp.feature)
    }

    /// The kd-tree's feature for corners (A, B, C) mapped to ours.
    fn map_feature(f: Feature) -> LocalFeature {
        match f {
            Feature::Face => LocalFeature::Face,
            Feature::Edge(0) => LocalFeature::EdgeAB,
            Feature::Edge(1) => LocalFeature::EdgeBC,
            Feature::Edge(_) => LocalFeature::EdgeCA,
            Feature::Vertex(0) => LocalFeature::VertexA,
            Feature::Vertex(1) => LocalFeature::VertexB,
            Feature::Vertex(_) => LocalFeature::VertexC,
        }
    }

    fn random_triangle(rng: &mut SplitMix64) -> (f32, f32, f32) {
        let a = rng.next_f64() as f32 * 2.0;
        let b = rng.next_f64() as f32 * 2.0;
        let h = rng.next_f64() as f32 * 2.0;
        (a, b, h)
    }

    #[test]
    fn corrected_listing_equals_brute_force() {
        let mut rng = SplitMix64::new(isokit_field::rng::DEFAULT_SEED);
        let mut worst: f64 = 0.0;
        let mut features_agree = 0;
        let n = 200_000;
        for _ in 0..n {
            let (a, b, h) = random_triangle(&mut rng);
            let p = [0, 1, 2].map(|_| (rng.next_f64() as f32 - 0.5) * 8.0);
            let (d, f) = distance(p[0], p[1], p[2], a, b, h);
            let (want, wf) = brute(p, a, b, h);
            let err = (d as f64 - want).abs() / (1.0 + want);
            worst = worst.max(err);
            features_agree += usize::from(map_feature(wf) == f);
        }
        assert!(worst < 2e-6, "worst relative error {worst:e}");
        // Features may differ only on region boundaries (ties), which random points hit
        // with probability ~0.
        assert!(
            features_agree >= n - 5,
            "{features_agree} of {n} features agree"
        );
    }

    #[test]
    fn degenerate_triangles_are_segments_and_points() {
        let mut rng = SplitMix64::new(7);
        for (a, b, h) in [
            (1.0, 0.5, 0.0),
            (1.0, 0.0, 0.0),
            (0.0, 0.0, 0.0),
            (0.0, 0.0, 1.0),
            (1.0, 0.0, 1.0),
            (1e-30, 1e-30, 0.0),
        ] {
            for _ in 0..2000 {
                let p = [0, 1, 2].map(|_| (rng.next_f64() as f32 - 0.5) * 4.0);
                let (d, _) = distance(p[0], p[1], p[2], a, b, h);
                let (want, _) = brute(p, a, b, h);
                assert!(
                    (d as f64 - want).abs() < 1e-5 * (1.0 + want),
                    "({a}, {b}, {h}) at {p:?}: {d} vs {want}"
                );
            }
        }
    }

    #[test]
    fn printed_listing_fails_against_brute_force() {
        // Above the triangle's hypotenuse, next to corner C: the printed s' puts the point
        // inside, the correct one outside.
        let (a, b, h) = (1.0, 1.0, 1.0);
        let p = [0.2f32, 1.2, 0.0];
        let (want, _) = brute(p, a, b, h);
        let printed = distance_printed(p[0], p[1], p[2], a, b, h).abs() as f64;
        let (ours, _) = distance(p[0], p[1], p[2], a, b, h);
        assert!((ours as f64 - want).abs() < 1e-6);
        assert!(
            (printed - want).abs() > 0.1,
            "printed {printed} vs exact {want}"
        );
        // And over random points it is wrong for a large share of them.
        let mut rng = SplitMix64::new(3);
        let mut wrong = 0;
        for _ in 0..10_000 {
            let p = [0, 1, 2].map(|_| (rng.next_f64() as f32 - 0.5) * 4.0);
            let (want, _) = brute(p, a, b, h);
            let printed = distance_printed(p[0], p[1], p[2], a, b, h).abs() as f64;
            wrong += usize::from((printed - want).abs() > 1e-4);
        }
        assert!(wrong > 1000, "only {wrong} wrong");
    }
}
