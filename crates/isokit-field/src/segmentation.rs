//! The segmented distance of 003 ("segmented distance fields", Sec. 3.3.2, Eq. 4–7): one
//! sample holds `f = min(d_E, δ) + D r`, the unsigned distance to the surface clamped at `δ`
//! plus `D` times the index of the region the sample lies in. [`Segmentation`] encodes and
//! decodes it and says where a surface passes between two samples. It lives here, at the
//! bottom, because the meshers (`isokit-levelset`), the samplers (`isokit-scene`) and the
//! renderers (`isokit-render`) all read it.

use crate::FieldError;

/// The constants of 003 Eq. 4: distances clamped at `delta`, regions `period` apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segmentation {
    delta: f32,
    period: f32,
}

/// Regions a [`Segmentation`] encodes, 0 to 4095: an f32 sample `D r + d` keeps `d` to
/// about 6e-8 of `D r`, i.e. to 2e-3 spacings at the last region with `D` of 8 spacings.
pub const MAX_REGIONS: i32 = 1 << 12;

impl Segmentation {
    /// `0 < delta < period`, both finite.
    pub fn new(delta: f32, period: f32) -> Result<Self, FieldError> {
        if !(delta.is_finite() && period.is_finite() && delta > 0.0 && delta < period) {
            return Err(FieldError::BadParameter {
                name: "segmentation",
                value: format!("delta {delta}, period {period}"),
                why: "needs 0 < delta < period, both finite (003 Eq. 4)",
            });
        }
        Ok(Self { delta, period })
    }

    /// For a lattice of spacing `h`: `δ = 4h`, `D = 8h`.
    pub fn for_spacing(h: f32) -> Result<Self, FieldError> {
        Self::new(4.0 * h, 8.0 * h)
    }

    /// The distance clamp `δ`.
    pub fn delta(&self) -> f32 {
        self.delta
    }

    /// The region period `D`.
    pub fn period(&self) -> f32 {
        self.period
    }

    /// 003 Eq. 4: `min(distance, δ) + D region` (`distance ≥ 0`, `0 ≤ region <
    /// MAX_REGIONS`, else an error).
    pub fn encode(&self, distance: f32, region: i32) -> Result<f32, FieldError> {
        if distance.is_nan() || distance < 0.0 || !(0..MAX_REGIONS).contains(&region) {
            return Err(FieldError::BadParameter {
                name: "segmented sample",
                value: format!("distance {distance}, region {region}"),
                why: "needs a distance >= 0 and a region from 0 to 4095",
            });
        }
        Ok(distance.min(self.delta) + self.period * region as f32)
    }

    /// The region and the (clamped) distance of a sample; `None` for a value that is not
    /// one (negative or not finite).
    pub fn decode(&self, f: f32) -> Option<(i32, f32)> {
        if !(f.is_finite() && f >= 0.0) {
            return None;
        }
        let r = (f / self.period).floor();
        let d = (f - r * self.period).clamp(0.0, self.delta);
        Some((r as i32, d))
    }

    /// The largest `d_u + d_v` of Eq. 7 between samples `w` apart, the larger region
    /// `r`: `w (1 + 1e-4)` plus the rounding of both samples' `D r + d` in f32 (4 ulps of
    /// `D (r + 1)`), so no edge perpendicular to a surface is lost at high region indices.
    pub fn reach(&self, w: f32, r: i32) -> f32 {
        w * (1.0 + 1e-4) + 4.0 * f32::EPSILON * self.period * (r as f32 + 1.0)
    }

    /// Whether the surface passes between neighbouring samples `u` and `v` a distance `w`
    /// apart (003 Eq. 5 and 7), and where: `(region of u, region of v, t from u)` (Eq. 6).
    pub fn crossing(&self, u: f32, v: f32, w: f32) -> Option<(i32, i32, f32)> {
        let ((i, du), (j, dv)) = (self.decode(u)?, self.decode(v)?);
        if i == j || du + dv > self.reach(w, i.max(j)) {
            return None;
        }
        let sum = du + dv;
        Some((i, j, if sum > 0.0 { du / sum } else { 0.5 }))
    }
}
