//! The far-field blend weight of 002 Sec. 4.3.5, in the corrected form of ERRATA item 6.
//!
//! From the distances `r` of a point to its k nearest samples, the relative standard
//! deviation `σ̄ = σ(r)/μ(r)` measures how far the point is from the sampled surface relative
//! to the sampling density (Eq. 4.12, with σ the standard deviation). For a dense regular
//! planar sampling, σ̄ depends only on the scale-invariant distance `d = h/ρ` (h the height
//! above the plane, ρ the radius of the disc holding the k samples), Eq. 4.13
//! ([`sigma_bar_regular_plane`]). Its approximate inverse is Eq. 4.14,
//! `d̃ = sqrt(1/σ̄ − √8)` ([`scale_invariant_distance`]), which is 0 on the plane and grows
//! linearly (d̃ ≈ 2.6 d). The weight is the polynomial Gaussian of cutoff 5 in d̃:
//! `w = max(1 − d̃²/25, 0)³` ([`blend_weight`]).
//!
//! σ̄ cannot tell a point above the surface from a point on the surface in a gap of the
//! sampling: in both, every sample is at least some distance away, so the distances spread
//! less than on a dense sampling and the weight falls. On a random cloud the gaps are several
//! spacings wide (the largest empty disc among n random samples grows like `√(ln n)`
//! spacings), so the far field, the distance to the closest sample, leaks into the surface
//! there. [`centroid_distance`] measures the same scale-invariant distance from the
//! positions and normals of the nearest samples instead (the height above their centroid,
//! over the radius of their disc): 0 in a gap as on a dense sampling, and the same slope
//! above a plane.
//!
//! The printed Eq. 4.15 uses `μ²/(μ(r²) − μ²) = 1/σ̄²` in place of `1/σ̄`; on the plane
//! `1/σ̄² = 8`, so it gives `w = (1 − (8 − √8)/25)³ ≈ 0.499` on the surface instead of 1
//! ([`blend_weight_printed`], kept only for the test that shows it).

/// `√8`, the value of `1/σ̄` on a dense regular planar sampling (d = 0).
pub const SQRT8: f64 = 2.828_427_124_746_190_3;

/// Cutoff of the blend weight in the scale-invariant distance (002: "a cutoff radius of 5").
pub const CUTOFF: f64 = 5.0;

/// The slope of Eq. 4.14's `d̃` against `d` on a dense regular planar sampling, measured from
/// Eq. 4.13 (2.63–2.86 over d ∈ [0.5, 8], the test `continuous_plane_formula`).
pub const PLANE_SLOPE: f64 = 2.65;

/// Samples of the disc that Eq. 4.13's `ρ` refers to in the dissertation's setting (its
/// statistics over the 64 nearest samples): [`centroid_distance`] scales its distance to that
/// disc, so that the blend reaches as far whatever number of samples measures it.
pub const REFERENCE_SAMPLES: f64 = 64.0;

/// Relative standard deviation `σ̄ = σ/μ` of the distances `r` (Eq. 4.12, σ the population
/// standard deviation). `None` when `r` is empty or its mean is 0 (the point coincides with
/// all its samples).
pub fn sigma_bar(r: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (mut n, mut s1, mut s2) = (0.0f64, 0.0f64, 0.0f64);
    for x in r {
        n += 1.0;
        s1 += x;
        s2 += x * x;
    }
    if n == 0.0 {
        return None;
    }
    let mu = s1 / n;
    if mu.is_nan() || mu <= 0.0 {
        return None;
    }
    let var = (s2 / n - mu * mu).max(0.0);
    Some(var.sqrt() / mu)
}

/// Eq. 4.13: σ̄ on a dense regular planar sampling at scale-invariant distance `d`.
pub fn sigma_bar_regular_plane(d: f64) -> f64 {
    let a = (1.0 + d * d).powf(1.5) - d * d * d;
    let num = (9.0 + 18.0 * d * d - 8.0 * a * a).max(0.0);
    (1.0 / 8.0f64).sqrt() * num.sqrt() / a
}

/// Eq. 4.14: the scale-invariant distance `sqrt(max(1/σ̄ − √8, 0))`. Infinite for σ̄ = 0
/// (all samples equidistant: the point is as far from the sampling as it can tell).
pub fn scale_invariant_distance(sigma_bar: f64) -> f64 {
    if sigma_bar <= 0.0 {
        return f64::INFINITY;
    }
    (1.0 / sigma_bar - SQRT8).max(0.0).sqrt()
}

/// The scale-invariant distance of `x` from the m nearest samples (positions `p`, unit
/// normals `n`, m ≥ 2), measured from their positions instead of inferred from their
/// distances (Eq. 4.14): `d̃ = PLANE_SLOPE · t / ρ₆₄`.
///
/// - `t` is the height of `x` above the samples' centroid `c`: with `v = x − c` and `m̄` the
///   mean of the normals, `h² = (1 − |m̄|²)|v|² + (m̄·v)²`. Where the normals agree
///   (`|m̄| = 1`) it is the offset along them, so a point on the surface between samples, or
///   in a gap of the sampling, has `h ≈ 0`; where they cancel (a thin sheet seen from both
///   sides, a medial axis, past a sharp edge) it is the whole offset `|v|`.
/// - Beside the samples' disc (past the edge of an open surface, in its plane) the height
///   says nothing: the lateral offset `l` (along the plane of `m̄`) beyond the disc's radius
///   counts too, `t² = h² + |m̄|² max(l − ρ, 0)²`. Within the disc, gaps included, it adds
///   nothing.
/// - `ρ` is the radius of the uniform disc with the samples' second moment about `c`
///   (`ρ² = 2 · mean |p − c|²`), scaled to the disc of [`REFERENCE_SAMPLES`] samples of the
///   same density (`ρ₆₄ = ρ · √(64/m)`).
///
/// On a dense regular plane `t` is the height and `d = t/ρ₆₄` Eq. 4.13's distance, so the
/// blend weight of [`blend_weight_of_distance`] falls as the dissertation's does. `0` when
/// `x` coincides with the centroid; `∞` when the samples coincide away from `x`; NaN for a
/// non-finite `x`; `None` for fewer than 2 samples.
pub fn centroid_distance(
    x: glam::DVec3,
    samples: impl Iterator<Item = (glam::DVec3, glam::DVec3)> + Clone,
) -> Option<f64> {
    use glam::DVec3;
    let (mut m, mut c, mut nsum) = (0usize, DVec3::ZERO, DVec3::ZERO);
    for (p, n) in samples.clone() {
        m += 1;
        c += p;
        nsum += n;
    }
    if m < 2 {
        return None;
    }
    let mf = m as f64;
    c /= mf;
    let mbar = nsum / mf;
    let second: f64 = samples.map(|(p, _)| (p - c).length_squared()).sum::<f64>() / mf;
    let v = x - c;
    let (v2, m2) = (v.length_squared(), mbar.length_squared());
    let h2 = (1.0 - m2).max(0.0) * v2 + mbar.dot(v).powi(2);
    // |m̄|² l² = |v|² − h²: the in-plane offset l, beyond the disc's own radius.
    let excess = if m2 > 0.0 {
        (((v2 - h2).max(0.0) / m2).sqrt() - (2.0 * second).sqrt()).max(0.0)
    } else {
        0.0
    };
    let t2 = h2 + m2 * excess * excess;
    if t2.is_nan() {
        return Some(f64::NAN);
    }
    if t2 == 0.0 {
        return Some(0.0);
    }
    let rho64_2 = 2.0 * second * REFERENCE_SAMPLES / mf;
    if rho64_2 <= 0.0 {
        return Some(f64::INFINITY);
    }
    Some(PLANE_SLOPE * (t2 / rho64_2).sqrt())
}

/// The weight of the scale-invariant distance `d̃`: `max(1 − d̃²/25, 0)³`, 1 on the surface,
/// 0 from [`CUTOFF`] on (0 for a NaN `d̃`).
pub fn blend_weight_of_distance(d: f64) -> f64 {
    if !d.is_finite() {
        return 0.0;
    }
    (1.0 - d * d / (CUTOFF * CUTOFF)).max(0.0).powi(3)
}

/// The corrected blend weight (ERRATA 6): `max(1 − max(1/σ̄ − √8, 0)/25, 0)³`, 1 on the
/// surface, 0 from a scale-invariant distance of 5 on. The inner clamp (absent from the
/// printed formula) keeps w ≤ 1 where an irregular sampling gives σ̄ > 1/√8.
pub fn blend_weight(sigma_bar: f64) -> f64 {
    blend_weight_of_distance(scale_invariant_distance(sigma_bar))
}

/// The printed Eq. 4.15, `max(1 − (1/σ̄² − √8)/25, 0)³`. Wrong (≈ 0.5 on the surface); for
/// the errata test only.
pub fn blend_weight_printed(sigma_bar: f64) -> f64 {
    if sigma_bar <= 0.0 {
        return 0.0;
    }
    (1.0 - (1.0 / (sigma_bar * sigma_bar) - SQRT8) / (CUTOFF * CUTOFF))
        .clamp(0.0, 1.0)
        .powi(3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn continuous_plane_formula() {
        // On the plane σ̄ = 1/√8, so d̃ = 0 and w = 1, while the printed form gives 0.5.
        let s0 = sigma_bar_regular_plane(0.0);
        assert!((s0 - 1.0 / SQRT8).abs() < 1e-12);
        assert!(scale_invariant_distance(s0).abs() < 1e-6);
        assert!((blend_weight(s0) - 1.0).abs() < 1e-9);
        assert!((blend_weight_printed(s0) - 0.499).abs() < 1e-3);
        // d̃ grows linearly with d (slope 2.63–2.86 over d ∈ [0.5, 8]).
        let slope = |d: f64| scale_invariant_distance(sigma_bar_regular_plane(d)) / d;
        for d in [0.5, 1.0, 2.0, 4.0, 8.0] {
            assert!(
                (slope(d) / 2.65 - 1.0).abs() < 0.1,
                "d {d}: slope {}",
                slope(d)
            );
        }
    }

    #[test]
    fn sigma_bar_edge_cases() {
        assert_eq!(sigma_bar([]), None);
        assert_eq!(sigma_bar([0.0, 0.0]), None);
        assert_eq!(sigma_bar([2.0, 2.0, 2.0]), Some(0.0));
        assert_eq!(blend_weight(0.0), 0.0);
        // σ̄ above 1/√8 (irregular sampling near a sample) clamps to w = 1, not above.
        assert_eq!(blend_weight(0.9), 1.0);
    }
}
