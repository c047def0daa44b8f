//! Trilinear interpolation of a cell's eight corner values (corner `n = x + 2y + 4z`).

use glam::Vec3;

/// `a (1 − s) + b s`: exact at both ends, so neighbouring cells agree bit for bit at shared
/// corners.
#[inline]
fn mix(a: f32, b: f32, s: f32) -> f32 {
    a * (1.0 - s) + b * s
}

/// The trilinear interpolation of `c` at `t` in `[0, 1]^3` (cell units).
#[inline]
pub fn trilerp(c: &[f32; 8], t: Vec3) -> f32 {
    let x00 = mix(c[0], c[1], t.x);
    let x10 = mix(c[2], c[3], t.x);
    let x01 = mix(c[4], c[5], t.x);
    let x11 = mix(c[6], c[7], t.x);
    mix(mix(x00, x10, t.y), mix(x01, x11, t.y), t.z)
}

/// The gradient of [`trilerp`] with respect to `t` (per cell edge length; divide by the
/// cell's side for world units).
#[inline]
pub fn trilerp_gradient(c: &[f32; 8], t: Vec3) -> Vec3 {
    let bil = |v: [f32; 4], u: f32, w: f32| mix(mix(v[0], v[1], u), mix(v[2], v[3], u), w);
    let dx = bil(
        [c[1] - c[0], c[3] - c[2], c[5] - c[4], c[7] - c[6]],
        t.y,
        t.z,
    );
    let dy = bil(
        [c[2] - c[0], c[3] - c[1], c[6] - c[4], c[7] - c[5]],
        t.x,
        t.z,
    );
    let dz = bil(
        [c[4] - c[0], c[5] - c[1], c[6] - c[2], c[7] - c[3]],
        t.x,
        t.y,
    );
    Vec3::new(dx, dy, dz)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_trilinear_functions_and_their_gradient() {
        let f = |p: Vec3| {
            0.5 + 2.0 * p.x - p.y + 3.0 * p.z + p.x * p.y - 0.5 * p.y * p.z + p.x * p.y * p.z
        };
        let grad = |p: Vec3| {
            Vec3::new(
                2.0 + p.y + p.y * p.z,
                -1.0 + p.x - 0.5 * p.z + p.x * p.z,
                3.0 - 0.5 * p.y + p.x * p.y,
            )
        };
        let c: [f32; 8] = std::array::from_fn(|n| {
            f(Vec3::new(
                (n & 1) as f32,
                ((n >> 1) & 1) as f32,
                ((n >> 2) & 1) as f32,
            ))
        });
        for t in [
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::new(0.25, 0.5, 0.9),
            Vec3::new(1.0, 0.0, 0.3),
        ] {
            assert!((trilerp(&c, t) - f(t)).abs() < 1e-5);
            assert!((trilerp_gradient(&c, t) - grad(t)).length() < 1e-5);
        }
        // Exact at the corners.
        assert_eq!(trilerp(&c, Vec3::new(1.0, 1.0, 0.0)), c[3]);
    }
}
