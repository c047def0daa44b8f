//! Constructive solid geometry on signed distance fields (negative inside).
//!
//! The operators follow ERRATA 1 (002's Table 2.1 prints them for a positive interior):
//!
//! | operation | formula | exact where |
//! | --- | --- | --- |
//! | union A ∪ B | `min(fA, fB)` | outside the union; inside only a bound |
//! | intersection A ∩ B | `max(fA, fB)` | inside the intersection; outside only a bound |
//! | difference A − B | `max(fA, −fB)` | inside; outside only a bound |
//! | complement | `−fA` | everywhere |
//!
//! "A bound" means: the value has the right sign and its magnitude never exceeds the true
//! distance, so the Lipschitz constant stays 1 and sphere tracing and brick pruning stay
//! sound.

/// Union `A ∪ B = min(fA, fB)`.
#[inline]
pub fn union(a: f32, b: f32) -> f32 {
    a.min(b)
}

/// Intersection `A ∩ B = max(fA, fB)`.
#[inline]
pub fn intersection(a: f32, b: f32) -> f32 {
    a.max(b)
}

/// Difference `A − B = max(fA, −fB)`.
#[inline]
pub fn difference(a: f32, b: f32) -> f32 {
    a.max(-b)
}

/// Complement `−fA`.
#[inline]
pub fn complement(a: f32) -> f32 {
    -a
}

/// Smooth union with blend radius `k` (the quadratic polynomial smooth minimum): equal to
/// `min(a, b)` where `|a − b| ≥ k`, and at most `k/4` below it where the two meet. `k ≤ 0`
/// gives the sharp union.
#[inline]
pub fn smooth_union(a: f32, b: f32, k: f32) -> f32 {
    if k <= 0.0 {
        return union(a, b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - 0.25 * k * h * h
}

/// Smooth intersection with blend radius `k`: `−smooth_union(−a, −b, k)`.
#[inline]
pub fn smooth_intersection(a: f32, b: f32, k: f32) -> f32 {
    -smooth_union(-a, -b, k)
}

/// Smooth difference with blend radius `k`: `smooth_intersection(a, −b, k)`.
#[inline]
pub fn smooth_difference(a: f32, b: f32, k: f32) -> f32 {
    smooth_intersection(a, -b, k)
}
