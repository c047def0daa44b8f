//! The CPU twin of `shaders/prism_scan.wgsl` ([`scan_slab`]) and of the row spans and keys of
//! `shaders/common/prism.wgsl` ([`row_span`], [`sample_key`]): the same f32 arithmetic in
//! the same order, the same packed keys. Re-exported by [`crate::scan`].

use crate::local::distance2;
use crate::placed::GpuPrism;

/// The key of a sample no prism reached.
pub const UNWRITTEN: u32 = u32::MAX;

/// The samples `i` of row `(j, k)` inside the prism, as `(first, last)` (empty when
/// `last < first`). Mirrors `row_span` in WGSL.
#[inline]
pub fn row_span(p: &GpuPrism, j: i32, k: i32) -> (i32, i32) {
    let dj = (j - p.base[1]) as f32;
    let dk = (k - p.base[2]) as f32;
    let lo_box = (p.lo[0] - p.base[0]) as f32;
    let hi_box = (p.hi[0] - p.base[0]) as f32;
    let mut lo = lo_box;
    let mut hi = hi_box;
    for pl in &p.planes {
        let rhs = pl[3] - pl[1] * dj - pl[2] * dk;
        if pl[0] > 0.0 {
            lo = lo.max(rhs / pl[0]);
        } else if pl[0] < 0.0 {
            hi = hi.min(rhs / pl[0]);
        } else if rhs > 0.0 {
            hi = lo_box - 1.0;
        }
    }
    lo = lo.min(hi_box + 1.0);
    hi = hi.max(lo_box - 1.0);
    (lo.ceil() as i32 + p.base[0], hi.floor() as i32 + p.base[0])
}

/// A point of feature `f` in the local frame. Mirrors `feature_point` in WGSL.
#[inline]
fn feature_point(f: u32, a: f32, b: f32, h: f32) -> [f32; 3] {
    match f {
        0 | 3 => [a, 0.0, 0.0],
        4 => [-b, 0.0, 0.0],
        1 | 2 | 5 => [0.0, h, 0.0],
        _ => [0.0; 3],
    }
}

#[inline]
fn dot(a: &[f32; 4], q: [f32; 3]) -> f32 {
    a[0] * q[0] + a[1] * q[1] + a[2] * q[2]
}

/// Packs an unsigned distance (grid units) and a sign into a key: the f32 bits of `|d|`
/// shifted left once, the sign in bit 0. Keys order like `(|d|, negative)`.
#[inline]
pub fn pack(distance: f32, negative: bool) -> u32 {
    (distance.to_bits() << 1) | u32::from(negative)
}

/// The distance (grid units) and sign of a key; `None` for [`UNWRITTEN`].
#[inline]
pub fn unpack(key: u32) -> Option<(f32, bool)> {
    (key != UNWRITTEN).then(|| (f32::from_bits(key >> 1), key & 1 == 1))
}

/// The key of sample `(i, j, k)` for prism `p`. Mirrors `sample_key` in WGSL.
#[inline]
pub fn sample_key(p: &GpuPrism, i: i32, j: i32, k: i32, signed: bool) -> u32 {
    let q = [
        (i - p.base[0]) as f32 - p.frac[0],
        (j - p.base[1]) as f32 - p.frac[1],
        (k - p.base[2]) as f32 - p.frac[2],
    ];
    let r = dot(&p.axis_r, q);
    let s = dot(&p.axis_s, q);
    let t = dot(&p.axis_t, q);
    let (d2, feature) = distance2(
        r, s, t, p.shape[0], p.shape[1], p.shape[2], p.inv[0], p.inv[1],
    );
    let slot = feature.min(5) as usize;
    let v = feature_point(feature, p.shape[0], p.shape[1], p.shape[2]);
    let side_feature = dot(&p.normals[slot], [r - v[0], s - v[1], t - v[2]]);
    let side = if feature == 6 { t } else { side_feature };
    pack(d2.sqrt(), signed && side < 0.0)
}

/// Scans slices `k0..=k1` (a slab of `nx × ny × (k1 − k0 + 1)` keys, x fastest) with the
/// prisms `active` (indices into `prisms`), keeping the smallest key per sample. Returns the
/// number of samples evaluated. Mirrors the kernel `scan` in WGSL (one prism at a time).
pub fn scan_slab(
    prisms: &[GpuPrism],
    active: &[u32],
    slab: (i32, i32),
    nx: usize,
    ny: usize,
    signed: bool,
    keys: &mut [u32],
) -> u64 {
    let mut evaluated = 0u64;
    for &a in active {
        let p = &prisms[a as usize];
        let k0 = p.lo[2].max(slab.0);
        let k1 = p.hi[2].min(slab.1);
        for k in k0..=k1 {
            for j in p.lo[1]..=p.hi[1] {
                let (i0, i1) = row_span(p, j, k);
                if i1 < i0 {
                    continue;
                }
                let row = nx * (j as usize + ny * (k - slab.0) as usize);
                for i in i0..=i1 {
                    let key = sample_key(p, i, j, k, signed);
                    let slot = &mut keys[row + i as usize];
                    if key < *slot {
                        *slot = key;
                    }
                }
                evaluated += (i1 - i0 + 1) as u64;
            }
        }
    }
    evaluated
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_order_by_magnitude_then_sign() {
        let ks = [
            pack(0.0, false),
            pack(0.0, true),
            pack(1e-30, false),
            pack(0.5, false),
            pack(0.5, true),
            pack(0.5000001, false),
            pack(3.0e38, true),
        ];
        assert!(ks.windows(2).all(|w| w[0] < w[1]), "{ks:?}");
        assert!(ks.iter().all(|&k| k < UNWRITTEN));
        assert_eq!(unpack(pack(0.25, true)), Some((0.25, true)));
        assert_eq!(unpack(UNWRITTEN), None);
    }
}
