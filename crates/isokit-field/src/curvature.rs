//! Differential geometry of level sets: normal, principal curvatures and principal
//! directions of the isosurface through a point, from the gradient `g` and the Hessian `H`
//! of the field there (dissertation 002, Eq. 6.5–6.8, after Kindlmann et al. 2003).
//!
//! ## Conventions
//! - With the inside *below* the isovalue (signed distance fields, [`Inside::Below`]) the
//!   normal is `n = g / |g|`: it points toward increasing values, i.e. outward.
//! - The shape operator is `G = P H P / |g|` with `P = I - n nᵀ` (Eq. 6.5). Its eigenvalue
//!   along `n` is 0; the two others are the principal curvatures `k1 >= k2`. A sphere of
//!   radius `R` seen from outside has **positive** curvatures `1/R`; a saddle has `k2 < 0`.
//! - With the inside *above* the isovalue (CT-like densities, [`Inside::Above`]) `g` and
//!   `H` are negated first, so the normal still points outward and a convex blob still has
//!   positive curvature.
//! - Units: `g` and `H` must be in the same length unit (world units for world positions,
//!   see `crate::filter::Derivatives::to_world`); the curvatures come out in 1/that unit.
//!
//! ## Method
//! Instead of forming `G` in 3D, `H / |g|` is restricted to an orthonormal tangent basis
//! `(u, v)` of `n` (Eq. 6.6), giving a symmetric 2x2 matrix `A = [[a11, a12], [a12, a22]]`.
//! Its trace `T` and Frobenius norm `F` equal those of `G`, so
//! `k1,2 = (T ± sqrt(2F² − T²)) / 2` (Kindlmann's formula); the square root is evaluated as
//! `hypot(a11 − a22, 2 a12)`, which equals `sqrt(2F² − T²)` exactly in real arithmetic and
//! can be neither negative nor cancel. The principal directions come from the closed-form
//! eigenvectors of `A`, `θ = atan2(2 a12, a11 − a22) / 2`, `dir1 = cos θ u + sin θ v`,
//! `dir2 = n × dir1`. Unlike Eq. 6.8 (`e_i = a12 u + (k_i − a11) v`), this stays well
//! defined at umbilics (`k1 = k2`, e.g. on a sphere), where any orthonormal tangent pair is
//! returned. All arithmetic is in f64; results are rounded to f32 once.

#[cfg(test)]
use glam::DMat3;
use glam::{DVec3, Mat3, Vec3};

/// Where the inside of the surface lies relative to the isovalue.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Inside {
    /// Inside is below the isovalue: signed distance fields (negative inside).
    #[default]
    Below,
    /// Inside is above the isovalue: CT-like densities. The gradient and Hessian are negated
    /// so the normal points outward and convex parts have positive curvature.
    Above,
}

/// Differential geometry of the level set through a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curvature {
    /// Unit normal, pointing outward (toward increasing values for [`Inside::Below`]).
    pub normal: Vec3,
    /// Largest principal curvature (positive where the surface is convex seen from outside).
    pub k1: f32,
    /// Smallest principal curvature, `k2 <= k1`.
    pub k2: f32,
    /// Unit principal direction of `k1`, tangent to the surface.
    pub dir1: Vec3,
    /// Unit principal direction of `k2`, tangent to the surface; `dir2 = normal × dir1`.
    pub dir2: Vec3,
    /// Mean curvature `(k1 + k2) / 2`.
    pub mean: f32,
    /// Gaussian curvature `k1 · k2`.
    pub gaussian: f32,
}

/// Default threshold of [`curvature`]: gradients with `|g|` at or below it count as flat.
pub const DEFAULT_MIN_GRADIENT: f32 = 1e-10;

/// Curvature of the level set through a point of a field whose inside is below the
/// isovalue (signed distance fields), from its gradient `g` and Hessian `h` (the symmetric
/// part of `h` is used).
///
/// Returns `None` in flat regions (`|g| <= DEFAULT_MIN_GRADIENT`) and when any input or
/// result is not finite.
///
/// ```
/// use isokit_field::curvature::curvature;
/// use glam::{Mat3, Vec3};
/// // f = |p| - 2 at p = (2, 0, 0): g = (1, 0, 0), H = (I - n nᵀ) / 2.
/// let h = Mat3::from_diagonal(Vec3::new(0.0, 0.5, 0.5));
/// let c = curvature(Vec3::X, h).unwrap();
/// assert!((c.k1 - 0.5).abs() < 1e-6 && (c.k2 - 0.5).abs() < 1e-6);
/// assert!(curvature(Vec3::ZERO, h).is_none());
/// ```
pub fn curvature(g: Vec3, h: Mat3) -> Option<Curvature> {
    curvature_with(g, h, Inside::Below, DEFAULT_MIN_GRADIENT)
}

/// Like [`curvature`] for fields whose inside is *above* the isovalue (CT-like densities):
/// `g` and `h` are negated first, so the normal is `-g/|g|` (outward) and a dense blob has
/// positive curvature.
pub fn curvature_inside_above(g: Vec3, h: Mat3) -> Option<Curvature> {
    curvature_with(g, h, Inside::Above, DEFAULT_MIN_GRADIENT)
}

/// The general form of [`curvature`]: the side of the inside and the flat-gradient
/// threshold (`|g| <= min_gradient` gives `None`; in the units of `g`) are parameters.
pub fn curvature_with(g: Vec3, h: Mat3, inside: Inside, min_gradient: f32) -> Option<Curvature> {
    if !g.is_finite() || !h.is_finite() {
        return None;
    }
    let s = match inside {
        Inside::Below => 1.0,
        Inside::Above => -1.0,
    };
    let g = g.as_dvec3() * s;
    let hm = h.as_dmat3() * s;
    let hm = (hm + hm.transpose()) * 0.5;
    let len = g.length();
    // `g` is finite f32, so `len` is finite (and not NaN).
    if len <= f64::from(min_gradient.max(0.0)) {
        return None;
    }
    let n = g / len;
    let (u, v) = tangent_basis(n);
    // Eq. 6.6: A = (u, v)ᵀ H/|g| (u, v), symmetric.
    let hu = hm * u;
    let hv = hm * v;
    let a11 = u.dot(hu) / len;
    let a22 = v.dot(hv) / len;
    let a12 = 0.5 * (u.dot(hv) + v.dot(hu)) / len;
    // T = trace, sqrt(2F² − T²) = hypot(a11 − a22, 2 a12) (never negative, no cancellation).
    let t = a11 + a22;
    let disc = (a11 - a22).hypot(2.0 * a12);
    let k1 = 0.5 * (t + disc);
    let k2 = 0.5 * (t - disc);
    // Closed-form eigenvector of the larger eigenvalue of a symmetric 2x2 matrix; at an
    // umbilic atan2(0, 0) = 0 gives (u, v).
    let theta = 0.5 * (2.0 * a12).atan2(a11 - a22);
    let (sin, cos) = theta.sin_cos();
    let dir1 = (u * cos + v * sin).normalize();
    let dir2 = n.cross(dir1);
    let out = Curvature {
        normal: n.as_vec3(),
        k1: k1 as f32,
        k2: k2 as f32,
        dir1: dir1.as_vec3(),
        dir2: dir2.as_vec3(),
        mean: (0.5 * t) as f32,
        gaussian: (k1 * k2) as f32,
    };
    let finite = [out.k1, out.k2, out.mean, out.gaussian]
        .iter()
        .all(|x| x.is_finite())
        && out.dir1.is_finite()
        && out.dir2.is_finite();
    finite.then_some(out)
}

/// An orthonormal basis `(u, v)` of the plane orthogonal to the unit vector `n`, with
/// `u × v = n` (Duff et al. 2017, branch-free and continuous except across `n.z = 0⁻`).
fn tangent_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let u = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let v = DVec3::new(b, sign + n.y * n.y * a, -n.y);
    (u, v)
}

/// The shape operator `G = P H P / |g|` (Eq. 6.5) in 3D, for tests and diagnostics.
#[cfg(test)]
fn shape_operator(g: DVec3, h: DMat3) -> DMat3 {
    let n = g.normalize();
    let p = DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z);
    p * h * p * (1.0 / g.length())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn outer(a: DVec3, b: DVec3) -> DMat3 {
        DMat3::from_cols(a * b.x, a * b.y, a * b.z)
    }

    /// f = |p| - R: gradient and Hessian.
    fn sphere(p: DVec3) -> (Vec3, Mat3) {
        let r = p.length();
        let n = p / r;
        let h = (DMat3::IDENTITY - outer(n, n)) * (1.0 / r);
        (n.as_vec3(), h.as_mat3())
    }

    /// f = sqrt(x² + y²) - R (axis z).
    fn cylinder(p: DVec3) -> (Vec3, Mat3) {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        let n = DVec3::new(p.x / rho, p.y / rho, 0.0);
        let pxy = DMat3::from_diagonal(DVec3::new(1.0, 1.0, 0.0)) - outer(n, n);
        (n.as_vec3(), (pxy * (1.0 / rho)).as_mat3())
    }

    /// f = sqrt((ρ - R)² + z²) - r, by the chain rule through D(ρ, z).
    fn torus(p: DVec3, big_r: f64) -> (Vec3, Mat3) {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        let q = rho - big_r;
        let d = (q * q + p.z * p.z).sqrt();
        let grad_rho = DVec3::new(p.x / rho, p.y / rho, 0.0);
        let hess_rho = (DMat3::from_diagonal(DVec3::new(1.0, 1.0, 0.0))
            - outer(grad_rho, grad_rho))
            * (1.0 / rho);
        let (d_r, d_z) = (q / d, p.z / d);
        let d3 = d * d * d;
        let (d_rr, d_rz, d_zz) = (p.z * p.z / d3, -q * p.z / d3, q * q / d3);
        let ez = DVec3::Z;
        let g = grad_rho * d_r + ez * d_z;
        let h = outer(grad_rho, grad_rho) * d_rr
            + (outer(grad_rho, ez) + outer(ez, grad_rho)) * d_rz
            + outer(ez, ez) * d_zz
            + hess_rho * d_r;
        (g.as_vec3(), h.as_mat3())
    }

    fn close(a: f32, b: f64, tol: f64) -> bool {
        (f64::from(a) - b).abs() <= tol * b.abs().max(1.0)
    }

    fn parallel(a: Vec3, b: Vec3) -> bool {
        a.normalize().dot(b.normalize()).abs() > 1.0 - 1e-5
    }

    fn check_frame(c: &Curvature) {
        for v in [c.normal, c.dir1, c.dir2] {
            assert!((v.length() - 1.0).abs() < 1e-5, "{c:?}");
        }
        assert!(c.normal.dot(c.dir1).abs() < 1e-5, "{c:?}");
        assert!(c.normal.dot(c.dir2).abs() < 1e-5, "{c:?}");
        assert!(c.dir1.dot(c.dir2).abs() < 1e-5, "{c:?}");
        assert!(c.k1 >= c.k2);
        assert!((c.mean - 0.5 * (c.k1 + c.k2)).abs() <= 1e-5 * c.mean.abs().max(1.0));
        assert!((c.gaussian - c.k1 * c.k2).abs() <= 1e-5 * c.gaussian.abs().max(1.0));
    }

    #[test]
    fn sphere_has_positive_curvature_one_over_r() {
        let mut rng = SplitMix64::new(11);
        for radius in [0.01, 0.8, 3.0, 250.0] {
            for _ in 0..50 {
                let p = rng.unit_vector().as_dvec3() * radius;
                let (g, h) = sphere(p);
                let c = curvature(g, h).unwrap();
                check_frame(&c);
                let k = 1.0 / radius;
                assert!(close(c.k1, k, 1e-5) && close(c.k2, k, 1e-5), "{c:?} vs {k}");
                assert!(close(c.mean, k, 1e-5), "{c:?}");
                assert!(close(c.gaussian, k * k, 1e-5), "{c:?}");
                assert!(parallel(c.normal, p.as_vec3()) && c.normal.dot(p.as_vec3()) > 0.0);
            }
        }
    }

    #[test]
    fn cylinder_curves_around_the_axis_only() {
        let big_r = 0.7;
        for phi in [0.0f64, 0.3, 1.7, 3.0, -2.2] {
            let p = DVec3::new(big_r * phi.cos(), big_r * phi.sin(), 0.4);
            let (g, h) = cylinder(p);
            let c = curvature(g, h).unwrap();
            check_frame(&c);
            assert!(close(c.k1, 1.0 / big_r, 1e-5), "{c:?}");
            assert!(c.k2.abs() < 1e-5, "{c:?}");
            assert!(c.gaussian.abs() < 1e-5 && close(c.mean, 0.5 / big_r, 1e-5));
            let around = Vec3::new(-phi.sin() as f32, phi.cos() as f32, 0.0);
            assert!(parallel(c.dir1, around), "{c:?}");
            assert!(parallel(c.dir2, Vec3::Z), "{c:?}");
        }
    }

    #[test]
    fn torus_equators_and_generic_points() {
        let (big_r, r) = (1.0f64, 0.25f64);
        // Outer equator: (1/r, 1/(R + r)).
        let (g, h) = torus(DVec3::new(big_r + r, 0.0, 0.0), big_r);
        let c = curvature(g, h).unwrap();
        check_frame(&c);
        let mut want = [1.0 / r, 1.0 / (big_r + r)];
        want.sort_by(|a, b| b.total_cmp(a));
        assert!(
            close(c.k1, want[0], 1e-5) && close(c.k2, want[1], 1e-5),
            "{c:?}"
        );
        assert!(
            parallel(c.dir1, Vec3::Z) && parallel(c.dir2, Vec3::Y),
            "{c:?}"
        );
        assert!(c.normal.x > 0.99);
        // Inner equator: (1/r, -1/(R - r)), a saddle; the normal faces the axis.
        let (g, h) = torus(DVec3::new(big_r - r, 0.0, 0.0), big_r);
        let c = curvature(g, h).unwrap();
        check_frame(&c);
        let mut want = [1.0 / r, -1.0 / (big_r - r)];
        want.sort_by(|a, b| b.total_cmp(a));
        assert!(
            close(c.k1, want[0], 1e-5) && close(c.k2, want[1], 1e-5),
            "{c:?}"
        );
        assert!(c.gaussian < 0.0 && c.normal.x < -0.99);
        assert!(
            parallel(c.dir1, Vec3::Z) && parallel(c.dir2, Vec3::Y),
            "{c:?}"
        );
        // Anywhere on the tube: 1/r along the meridian, cos φ / (R + r cos φ) around.
        for (phi, theta) in [(0.4f64, 0.0f64), (1.2, 2.0), (2.5, -1.0), (-1.9, 4.0)] {
            let rho = big_r + r * phi.cos();
            let p = DVec3::new(rho * theta.cos(), rho * theta.sin(), r * phi.sin());
            let (g, h) = torus(p, big_r);
            let c = curvature(g, h).unwrap();
            check_frame(&c);
            let mut want = [1.0 / r, phi.cos() / rho];
            want.sort_by(|a, b| b.total_cmp(a));
            assert!(
                close(c.k1, want[0], 1e-5) && close(c.k2, want[1], 1e-5),
                "{c:?}"
            );
            let around = Vec3::new(-theta.sin() as f32, theta.cos() as f32, 0.0);
            assert!(parallel(c.dir2, around), "{c:?}");
        }
    }

    #[test]
    fn flat_and_non_finite_give_none() {
        let h = Mat3::from_diagonal(Vec3::ONE);
        assert!(curvature(Vec3::ZERO, h).is_none());
        assert!(curvature(Vec3::splat(1e-12), h).is_none());
        assert!(curvature(Vec3::new(f32::NAN, 1.0, 0.0), h).is_none());
        assert!(curvature(Vec3::new(f32::INFINITY, 1.0, 0.0), h).is_none());
        assert!(curvature(Vec3::X, h * f32::NAN).is_none());
        assert!(curvature_with(Vec3::X * 1e-3, h, Inside::Below, 1e-2).is_none());
        // A plane: zero curvature, any tangent frame.
        let c = curvature(Vec3::new(0.0, 0.0, -2.0), Mat3::ZERO).unwrap();
        check_frame(&c);
        assert_eq!((c.k1, c.k2), (0.0, 0.0));
        assert!(c.normal.z < -0.99);
    }

    #[test]
    fn inside_above_flips_signs() {
        let p = DVec3::new(0.3, -0.5, 0.2);
        let (g, h) = sphere(p);
        let below = curvature(g, h).unwrap();
        // The same field read as a density: convex seen from the other side.
        let above = curvature_inside_above(g, h).unwrap();
        check_frame(&above);
        assert!(close(above.k1, -f64::from(below.k2), 1e-6));
        assert!(close(above.k2, -f64::from(below.k1), 1e-6));
        assert!((above.normal + below.normal).length() < 1e-6);
        assert!(above.k1 < 0.0);
        // A density R - |p| (inside above) has the sphere's positive curvature.
        let dens = curvature_inside_above(-g, -h).unwrap();
        assert!(close(dens.k1, f64::from(below.k1), 1e-6) && dens.k2 > 0.0);
        assert!((dens.normal - below.normal).length() < 1e-6);
        assert_eq!(
            curvature_with(-g, -h, Inside::Above, DEFAULT_MIN_GRADIENT),
            Some(dens)
        );
    }

    /// Against the brute-force 3D shape operator: Kindlmann's T/F formula for k1, k2, and
    /// G dir_i = k_i dir_i, on random gradients and symmetric Hessians.
    #[test]
    fn matches_the_3d_shape_operator_on_random_input() {
        let mut rng = SplitMix64::new(5);
        for _ in 0..2000 {
            let g = rng.unit_vector() * rng.range(0.1, 10.0);
            let m = Mat3::from_cols(
                rng.point_in(Vec3::splat(-3.0), Vec3::splat(3.0)),
                rng.point_in(Vec3::splat(-3.0), Vec3::splat(3.0)),
                rng.point_in(Vec3::splat(-3.0), Vec3::splat(3.0)),
            );
            let h = (m + m.transpose()) * 0.5;
            let c = curvature(g, h).unwrap();
            check_frame(&c);
            let gs = shape_operator(g.as_dvec3(), h.as_dmat3());
            let t = gs.x_axis.x + gs.y_axis.y + gs.z_axis.z;
            let f2 = [gs.x_axis, gs.y_axis, gs.z_axis]
                .iter()
                .map(|c| c.length_squared())
                .sum::<f64>();
            let disc = (2.0 * f2 - t * t).max(0.0).sqrt();
            let scale = f2.sqrt().max(1e-3);
            assert!((f64::from(c.k1) - 0.5 * (t + disc)).abs() < 1e-5 * scale);
            assert!((f64::from(c.k2) - 0.5 * (t - disc)).abs() < 1e-5 * scale);
            for (k, d) in [(c.k1, c.dir1), (c.k2, c.dir2)] {
                let d = d.as_dvec3();
                let r = gs * d - d * f64::from(k);
                assert!(r.length() < 1e-5 * scale, "{r} {c:?}");
            }
            // The normal is an eigenvector of G with eigenvalue 0.
            assert!((gs * c.normal.as_dvec3()).length() < 1e-5 * scale);
        }
    }

    #[test]
    fn tangent_basis_is_orthonormal_and_right_handed() {
        let mut rng = SplitMix64::new(9);
        let special = [DVec3::Z, -DVec3::Z, DVec3::X, DVec3::new(1.0, 0.0, -0.0)];
        let randoms: Vec<DVec3> = (0..500)
            .map(|_| rng.unit_vector().as_dvec3().normalize())
            .collect();
        for n in special.iter().chain(&randoms) {
            let (u, v) = tangent_basis(*n);
            assert!((u.length() - 1.0).abs() < 1e-12 && (v.length() - 1.0).abs() < 1e-12);
            assert!(u.dot(*n).abs() < 1e-12 && v.dot(*n).abs() < 1e-12 && u.dot(v).abs() < 1e-12);
            assert!((u.cross(v) - *n).length() < 1e-12);
        }
    }
}
