//! Morton (Z-order) codes: points close in space get close codes, so visiting points in code
//! order keeps caches warm and lets each query start from its predecessor's answer.

use glam::{DVec3, UVec3};
use rayon::prelude::*;

/// Spreads the low 21 bits of `v` to every third bit of a u64 (one axis of a Morton code).
#[inline]
pub fn spread3(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    (x | (x << 2)) & 0x1249_2492_4924_9249
}

/// The Morton code of a cell with coordinates below `2^21` (x in the lowest bit).
#[inline]
pub fn encode(q: UVec3) -> u64 {
    spread3(q.x) | (spread3(q.y) << 1) | (spread3(q.z) << 2)
}

/// Indices of `points` sorted along a Morton curve over their bounds (21 bits per axis);
/// non-finite points go last, in input order.
pub fn order(points: &[DVec3]) -> Vec<u32> {
    let finite = points.iter().filter(|p| p.is_finite());
    let lo = finite.clone().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = finite.fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    let scale = ((1u64 << 21) - 1) as f64 / (hi - lo).max_element().max(f64::MIN_POSITIVE);
    let key = |p: &DVec3| {
        if !p.is_finite() {
            return u64::MAX;
        }
        let q = ((*p - lo) * scale).as_uvec3();
        encode(q)
    };
    // Each key computed once (a sort by key would recompute it at every comparison); ties
    // broken by index, so the order equals a stable sort by key.
    let mut keyed: Vec<(u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| (key(p), i as u32))
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_interleave_the_bits_and_order_neighbours_together() {
        assert_eq!(encode(UVec3::new(1, 0, 0)), 1);
        assert_eq!(encode(UVec3::new(0, 1, 0)), 2);
        assert_eq!(encode(UVec3::new(0, 0, 1)), 4);
        assert_eq!(encode(UVec3::splat((1 << 21) - 1)), (1 << 63) - 1);
        let pts = [
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::NAN,
            DVec3::ZERO,
            DVec3::new(0.01, 0.0, 0.0),
        ];
        assert_eq!(order(&pts), vec![2, 3, 0, 1]);
    }
}
