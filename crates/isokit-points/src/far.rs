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
//! The printed Eq. 4.15 uses `μ²/(μ(r²) − μ²) = 1/σ̄²` in place of `1/σ̄`; on the plane
//! `1/σ̄² = 8`, so it gives `w = (1 − (8 − √8)/25)³ ≈ 0.499` on the surface instead of 1
//! ([`blend_weight_printed`], kept only for the test that shows it).

/// `√8`, the value of `1/σ̄` on a dense regular planar sampling (d = 0).
pub const SQRT8: f64 = 2.828_427_124_746_190_3;

/// Cutoff of the blend weight in the scale-invariant distance (002: "a cutoff radius of 5").
pub const CUTOFF: f64 = 5.0;

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

/// The corrected blend weight (ERRATA 6): `max(1 − max(1/σ̄ − √8, 0)/25, 0)³`, 1 on the
/// surface, 0 from a scale-invariant distance of 5 on. The inner clamp (absent from the
/// printed formula) keeps w ≤ 1 where an irregular sampling gives σ̄ > 1/√8.
pub fn blend_weight(sigma_bar: f64) -> f64 {
    let d = scale_invariant_distance(sigma_bar);
    if !d.is_finite() {
        return 0.0;
    }
    (1.0 - d * d / (CUTOFF * CUTOFF)).max(0.0).powi(3)
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
