//! A tiny seeded random generator (SplitMix64) for reproducible tests, benchmarks and
//! randomized construction (e.g. approximate medians from a random sample).
//!
//! Not for cryptography. The same seed gives the same sequence on every platform.

use glam::Vec3;

/// The seed tests use unless they say otherwise.
pub const DEFAULT_SEED: u64 = 0x1505_1717_2026_0001;

/// SplitMix64 (Steele, Lea and Flood 2014): 64 bits of state, passes BigCrush.
#[derive(Clone, Debug)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` with 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[0, 1)` with 24 bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// A standard normal deviate (Box–Muller, from two [`SplitMix64::next_f64`] draws).
    pub fn gaussian(&mut self) -> f64 {
        let u = self.next_f64().max(1e-300);
        let v = self.next_f64();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// Uniform integer in `0..n` (`n > 0`), by Lemire's multiply-shift (bias below 2^-32 for
    /// `n < 2^32`).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }

    /// Uniform point in the box `[lo, hi]`.
    pub fn point_in(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }

    /// Uniform direction on the unit sphere.
    pub fn unit_vector(&mut self) -> Vec3 {
        let z = 2.0 * self.next_f64() - 1.0;
        let phi = std::f64::consts::TAU * self.next_f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
    }
}

impl Default for SplitMix64 {
    fn default() -> Self {
        Self::new(DEFAULT_SEED)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_in_range() {
        let mut a = SplitMix64::new(1);
        let mut b = SplitMix64::new(1);
        for _ in 0..1000 {
            assert_eq!(a.next_u64(), b.next_u64());
        }
        for _ in 0..1000 {
            let x = a.next_f32();
            assert!((0.0..1.0).contains(&x));
            assert!(a.below(7) < 7);
            assert!((a.unit_vector().length() - 1.0).abs() < 1e-5);
        }
        // Reference value of SplitMix64 with seed 0 (first output).
        assert_eq!(SplitMix64::new(0).next_u64(), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn mean_is_about_one_half() {
        let mut r = SplitMix64::default();
        let m = (0..20_000).map(|_| r.next_f64()).sum::<f64>() / 20_000.0;
        assert!((m - 0.5).abs() < 0.01, "{m}");
    }
}
