//! Rigid motions and uniform scale of a field, which keep exact distances exact.
//!
//! [`Transformed`] places a field in world space by `world = t + s · R(local)`:
//! `value(p) = s · inner(R⁻¹(p − t) / s)`. Rotation and translation preserve distances and
//! a uniform scale multiplies them all by `s`, so an exact signed distance field stays exact
//! and a Lipschitz bound stays the same.
//!
//! Non-uniform scale is deliberately not offered: stretching by different factors per axis
//! turns an exact distance into neither a distance nor a bound with Lipschitz constant 1
//! (an ellipsoid is not a stretched sphere's distance), so it would silently break sphere
//! tracing and brick skipping. Use a primitive with the wanted shape instead, e.g.
//! [`crate::primitives::Ellipsoid`].
//!
//! The transform is kept in f64; the local point is rounded to f32 to call the inner field,
//! so values carry one extra f32 rounding of the local point (relative `6e-8` of its size).

use crate::primitives::aabb_outward;
use crate::{Aabb, Field, FieldError};
use glam::{DMat3, DQuat, DVec3, Mat3, Vec3};

/// A field moved by a rotation, a uniform scale and a translation:
/// `value(p) = s · inner(R⁻¹(p − t) / s)`, gradient `R · ∇inner`, Hessian `R H Rᵀ / s`.
///
/// Build it with [`Transformed::new`] and the builders, which compose in the order they are
/// called (each one acts on world space after the previous ones):
///
/// ```
/// use isokit_field::{primitives::Sphere, transform::Transformed, Field};
/// use glam::Vec3;
/// let ball = Sphere::new(Vec3::ZERO, 1.0).unwrap();
/// // Move to x = 2, then spin 90° about z around the world origin: the centre ends at y = 2.
/// let t = Transformed::new(ball).translate(Vec3::new(2.0, 0.0, 0.0)).unwrap()
///     .rotate_axis_degrees(Vec3::Z, 90.0).unwrap();
/// assert!(t.value(Vec3::new(0.0, 2.0, 0.0)) < -0.99);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Transformed<F: Field> {
    inner: F,
    rotation: DQuat,
    translation: DVec3,
    scale: f64,
}

impl<F: Field> Transformed<F> {
    /// The identity transform of `inner`.
    pub fn new(inner: F) -> Self {
        Self {
            inner,
            rotation: DQuat::IDENTITY,
            translation: DVec3::ZERO,
            scale: 1.0,
        }
    }

    /// Then translate by `v` (finite).
    pub fn translate(mut self, v: Vec3) -> Result<Self, FieldError> {
        if !v.is_finite() {
            return Err(FieldError::bad("translation", v, "must be finite"));
        }
        self.translation += v.as_dvec3();
        self.checked()
    }

    /// Then rotate by `degrees` (finite) about `axis` (finite, nonzero) through the world
    /// origin (right-handed). Rotate before translating to spin an object in place.
    pub fn rotate_axis_degrees(mut self, axis: Vec3, degrees: f32) -> Result<Self, FieldError> {
        let a = axis.as_dvec3();
        let m = a.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return Err(FieldError::bad("axis", axis, "must be finite and nonzero"));
        }
        if !degrees.is_finite() {
            return Err(FieldError::bad("degrees", degrees, "must be finite"));
        }
        let q = DQuat::from_axis_angle((a / m).normalize(), (degrees as f64).to_radians());
        self.rotation = (q * self.rotation).normalize();
        self.translation = q * self.translation;
        self.checked()
    }

    /// Then scale uniformly by `s` (finite, > 0) about the world origin.
    pub fn scale(mut self, s: f32) -> Result<Self, FieldError> {
        if !(s.is_finite() && s > 0.0) {
            return Err(FieldError::bad("scale", s, "must be finite and > 0"));
        }
        self.scale *= s as f64;
        self.translation *= s as f64;
        self.checked()
    }

    /// Refuses compositions that leave the f32 range (where values would turn inf or NaN).
    fn checked(self) -> Result<Self, FieldError> {
        let s = self.scale;
        if !(s >= f32::MIN_POSITIVE as f64 && s <= f32::MAX as f64) {
            return Err(FieldError::bad(
                "scale",
                s,
                "the composed scale must stay within the normal f32 range",
            ));
        }
        if !self
            .translation
            .abs()
            .cmple(DVec3::splat(f32::MAX as f64))
            .all()
        {
            return Err(FieldError::bad(
                "translation",
                self.translation,
                "the composed translation must fit in f32",
            ));
        }
        Ok(self)
    }

    /// The transformed field.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// The transformed field, by value.
    pub fn into_inner(self) -> F {
        self.inner
    }

    /// The rotation `R` (unit quaternion).
    pub fn rotation(&self) -> DQuat {
        self.rotation
    }

    /// The translation `t`.
    pub fn translation(&self) -> DVec3 {
        self.translation
    }

    /// The uniform scale `s`.
    pub fn scale_factor(&self) -> f64 {
        self.scale
    }

    /// World point to the inner field's space: `R⁻¹(p − t) / s`, in f64.
    pub fn to_local(&self, p: Vec3) -> DVec3 {
        self.rotation.inverse() * (p.as_dvec3() - self.translation) / self.scale
    }

    /// Inner point to world space: `t + s · R(q)`, in f64.
    pub fn to_world(&self, q: DVec3) -> DVec3 {
        self.translation + self.scale * (self.rotation * q)
    }
}

impl<F: Field> Field for Transformed<F> {
    fn value(&self, p: Vec3) -> f32 {
        (self.scale * self.inner.value(self.to_local(p).as_vec3()) as f64) as f32
    }

    /// The world box of the inner box (as [`Field::bounds`] transforms it) with the slack
    /// scaled by `s`: distances to the transformed box are at most `s` times the local ones.
    fn distance_box(&self) -> Option<crate::DistanceBox> {
        let d = self.inner.distance_box()?;
        let aabb = Transformed {
            inner: BoxOnly(d.aabb),
            rotation: self.rotation,
            translation: self.translation,
            scale: self.scale,
        }
        .bounds();
        Some(crate::DistanceBox {
            aabb,
            slack: (self.scale * d.slack as f64) as f32,
        })
    }

    /// `s ·` the inner field's lower bound at the local point.
    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = (self.scale * self.inner.lower_bound(self.to_local(p).as_vec3()) as f64) as f32;
        if lb.is_nan() { f32::NEG_INFINITY } else { lb }
    }

    /// `s ·` the inner field clamped to `cap / s` at the local point.
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let local_cap = (cap as f64 / self.scale) as f32;
        let v = crate::value_clamped(&self.inner, self.to_local(p).as_vec3(), local_cap);
        ((self.scale * v as f64) as f32).clamp(-cap, cap)
    }

    /// The box of the eight transformed corners of the inner bounds (rounded outward);
    /// unbounded inner fields stay [`Aabb::INFINITE`] unless the rotation is the identity.
    fn bounds(&self) -> Aabb {
        let b = self.inner.bounds();
        if b.is_empty() {
            return Aabb::EMPTY;
        }
        if !b.is_finite() {
            if self.rotation != DQuat::IDENTITY {
                return Aabb::INFINITE;
            }
            // Without rotation no infinity meets a zero (which would give NaN).
            let (t, s) = (self.translation, self.scale);
            return aabb_outward(t + s * b.min.as_dvec3(), t + s * b.max.as_dvec3());
        }
        let pts = b.corners().map(|c| self.to_world(c.as_dvec3()));
        let lo = pts.iter().fold(DVec3::INFINITY, |m, &p| m.min(p));
        let hi = pts.iter().fold(DVec3::NEG_INFINITY, |m, &p| m.max(p));
        aabb_outward(lo, hi)
    }

    fn lipschitz(&self) -> f32 {
        self.inner.lipschitz()
    }

    fn is_exact(&self) -> bool {
        self.inner.is_exact()
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let g = self.inner.gradient(self.to_local(p).as_vec3());
        (self.rotation * g.as_dvec3()).as_vec3()
    }

    fn hessian(&self, p: Vec3) -> Mat3 {
        let h = self.inner.hessian(self.to_local(p).as_vec3()).as_dmat3();
        let r = DMat3::from_quat(self.rotation);
        (r * h * r.transpose() / self.scale).as_mat3()
    }
}

/// A field that is only a box, to transform boxes with [`Transformed::bounds`].
struct BoxOnly(Aabb);

impl Field for BoxOnly {
    fn value(&self, p: Vec3) -> f32 {
        self.0.distance(p)
    }
    fn bounds(&self) -> Aabb {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::{Capsule, Plane, Sphere};
    use crate::rng::SplitMix64;

    /// The world map of rotate(axis, deg) → scale(s) → translate(t), written independently
    /// (Rodrigues' rotation matrix).
    fn world(axis: Vec3, deg: f64, s: f64, t: Vec3) -> impl Fn(Vec3) -> Vec3 {
        let m = DMat3::from_axis_angle(axis.as_dvec3().normalize(), deg.to_radians());
        move |x| (t.as_dvec3() + s * (m * x.as_dvec3())).as_vec3()
    }

    #[test]
    fn transformed_capsule_equals_direct_capsule() {
        let mut rng = SplitMix64::new(11);
        let (a, b, r) = (Vec3::new(-0.5, 0.2, 0.1), Vec3::new(0.6, -0.3, 0.4), 0.3f32);
        let cap = Capsule::new(a, b, r).unwrap();
        for (s, off) in [(1.0, 1.0), (2.5, 3.0), (1e-6, 1e-6), (1e6, 1e6)] {
            let (axis, deg, t) = (
                Vec3::new(1.0, 2.0, -0.5),
                37.0,
                Vec3::new(0.3, -1.2, 2.0) * off as f32,
            );
            let tf = Transformed::new(cap)
                .rotate_axis_degrees(axis, deg as f32)
                .unwrap()
                .scale(s as f32)
                .unwrap()
                .translate(t)
                .unwrap();
            let w = world(axis, deg, s, t);
            let direct = Capsule::new(w(a), w(b), (s * r as f64) as f32).unwrap();
            assert!(tf.is_exact() && tf.lipschitz() == 1.0);
            let (tb, db) = (tf.bounds(), direct.bounds());
            assert!(
                tb.contains(db.min) && tb.contains(db.max),
                "{tb:?} vs {db:?}"
            );
            assert!(tb.diagonal() < 1.5 * db.diagonal(), "{tb:?} vs {db:?}");
            let lo = db.min - 0.5 * db.size();
            for _ in 0..500 {
                let p = lo
                    + 2.0 * db.size() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let (v, want) = (tf.value(p), direct.value(p));
                let tol = 1e-6 * s as f32;
                assert!((v - want).abs() <= tol, "scale {s}: {v} vs {want} at {p}");
                if v <= 0.0 {
                    assert!(tb.contains(p), "{p} inside but outside {tb:?}");
                }
                if want.abs() > 0.05 * s as f32 {
                    let (g, gw) = (tf.gradient(p), direct.gradient(p));
                    assert!(
                        (g - gw).length() < 1e-5 && (g.length() - 1.0).abs() < 1e-5,
                        "{g} vs {gw} at {p}"
                    );
                }
            }
        }
    }

    #[test]
    fn builders_compose_in_call_order() {
        let ball = Sphere::new(Vec3::ZERO, 1.0).unwrap();
        let moved_then_spun = Transformed::new(ball)
            .translate(Vec3::new(2.0, 0.0, 0.0))
            .unwrap()
            .rotate_axis_degrees(Vec3::Z, 90.0)
            .unwrap();
        assert!((moved_then_spun.value(Vec3::new(0.0, 2.0, 0.0)) + 1.0).abs() < 1e-6);
        let spun_then_moved = Transformed::new(ball)
            .rotate_axis_degrees(Vec3::Z, 90.0)
            .unwrap()
            .translate(Vec3::new(2.0, 0.0, 0.0))
            .unwrap();
        assert!((spun_then_moved.value(Vec3::new(2.0, 0.0, 0.0)) + 1.0).abs() < 1e-6);
        // Two rotations: about x first, then about z. (0, 1, 0) → (0, 0, 1) → (0, 0, 1).
        let off_centre = Sphere::new(Vec3::Y, 0.5).unwrap();
        let twice = Transformed::new(off_centre)
            .rotate_axis_degrees(Vec3::X, 90.0)
            .unwrap()
            .rotate_axis_degrees(Vec3::Z, 90.0)
            .unwrap();
        assert!(
            (twice.value(Vec3::Z) + 0.5).abs() < 1e-6,
            "{}",
            twice.value(Vec3::Z)
        );
        // Scaling after translating scales the offset too.
        let t = Transformed::new(ball)
            .translate(Vec3::X)
            .unwrap()
            .scale(3.0)
            .unwrap();
        assert!((t.value(Vec3::new(3.0, 0.0, 0.0)) + 3.0).abs() < 1e-6);
        assert_eq!(
            t.bounds(),
            Aabb::new(Vec3::new(0.0, -3.0, -3.0), Vec3::new(6.0, 3.0, 3.0))
        );
        assert_eq!(t.scale_factor(), 3.0);
        assert_eq!(t.translation(), DVec3::new(3.0, 0.0, 0.0));
        assert_eq!(*t.inner(), ball);
    }

    #[test]
    fn gradient_and_hessian_rotate() {
        let mut rng = SplitMix64::new(12);
        let (axis, deg, s, t) = (
            Vec3::new(0.0, 1.0, 1.0),
            120.0,
            0.5,
            Vec3::new(1.0, 0.0, -2.0),
        );
        let c = Vec3::new(0.2, -0.1, 0.3);
        let tf = Transformed::new(Sphere::new(c, 0.8).unwrap())
            .rotate_axis_degrees(axis, deg as f32)
            .unwrap()
            .scale(s as f32)
            .unwrap()
            .translate(t)
            .unwrap();
        let direct = Sphere::new(world(axis, deg, s, t)(c), 0.4).unwrap();
        for _ in 0..200 {
            let p = t + 2.0 * rng.unit_vector() * rng.range(0.1, 1.0);
            let (g, gw) = (tf.gradient(p), direct.gradient(p));
            assert!((g - gw).length() < 1e-5, "{g} vs {gw}");
            let (h, hw) = (tf.hessian(p), direct.hessian(p));
            for k in 0..3 {
                let tol = 1e-5 * hw.col(k).length().max(1.0);
                assert!((h.col(k) - hw.col(k)).length() < tol, "{h} vs {hw}");
            }
        }
    }

    #[test]
    fn unbounded_and_inexact_inner_fields() {
        let plane = Plane::new(Vec3::Z, 1.0).unwrap();
        let spun = Transformed::new(plane)
            .rotate_axis_degrees(Vec3::X, 90.0)
            .unwrap();
        assert_eq!(spun.bounds(), Aabb::INFINITE);
        // Rotated plane: z = 1 becomes y = -1, outside towards -y.
        assert!((spun.value(Vec3::new(0.0, -3.0, 0.0)) - 2.0).abs() < 1e-6);
        let moved = Transformed::new(plane)
            .translate(Vec3::ONE)
            .unwrap()
            .scale(2.0)
            .unwrap();
        assert_eq!(moved.bounds(), Aabb::INFINITE);
        assert!((moved.value(Vec3::new(0.0, 0.0, 5.0)) - 1.0).abs() < 1e-6);

        struct Bound;
        impl Field for Bound {
            fn value(&self, p: Vec3) -> f32 {
                2.0 * p.length() - 1.0
            }
            fn bounds(&self) -> Aabb {
                Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5))
            }
            fn lipschitz(&self) -> f32 {
                2.0
            }
        }
        let t = Transformed::new(Bound).scale(4.0).unwrap();
        assert!(!t.is_exact() && t.lipschitz() == 2.0);
        assert!((t.value(Vec3::new(4.0, 0.0, 0.0)) - 4.0).abs() < 1e-6);
        let ident = Transformed::new(crate::primitives::Primitive::from(
            Sphere::new(Vec3::ZERO, 1.0).unwrap(),
        ));
        assert_eq!(
            ident.bounds(),
            Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
        );
    }

    #[test]
    fn bad_parameters_are_errors() {
        let t = || Transformed::new(Sphere::new(Vec3::ZERO, 1.0).unwrap());
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        let errs = [
            t().translate(Vec3::new(nan, 0.0, 0.0)).err(),
            t().translate(Vec3::splat(inf)).err(),
            t().rotate_axis_degrees(Vec3::ZERO, 10.0).err(),
            t().rotate_axis_degrees(Vec3::new(nan, 1.0, 0.0), 10.0)
                .err(),
            t().rotate_axis_degrees(Vec3::new(inf, 1.0, 0.0), 10.0)
                .err(),
            t().rotate_axis_degrees(Vec3::Z, nan).err(),
            t().scale(0.0).err(),
            t().scale(-1.0).err(),
            t().scale(nan).err(),
            t().scale(inf).err(),
            t().scale(1e30).unwrap().scale(1e30).err(),
            t().scale(1e-30).unwrap().scale(1e-30).err(),
            t().translate(Vec3::splat(3e38)).unwrap().scale(10.0).err(),
        ];
        for (i, e) in errs.iter().enumerate() {
            assert!(
                matches!(e, Some(FieldError::BadParameter { .. })),
                "case {i}: {e:?}"
            );
        }
        // A tiny but nonzero axis is fine.
        assert!(
            t().rotate_axis_degrees(Vec3::new(1e-40, 0.0, 0.0), 30.0)
                .is_ok()
        );
    }
}
