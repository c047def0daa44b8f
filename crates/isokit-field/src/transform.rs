//! Transforms of a field: rigid motions and uniform scale, which keep exact distances
//! exact ([`Transformed`]), and general invertible affine maps ([`Affine`]: non-uniform
//! scale, mirror, shear), which give a distance bound.
//!
//! [`Transformed`] places a field in world space by `world = t + s · R(local)`:
//! `value(p) = s · inner(R⁻¹(p − t) / s)`. Rotation and translation preserve distances and
//! a uniform scale multiplies them all by `s`, so an exact signed distance field stays exact
//! and a Lipschitz bound stays the same.
//!
//! Stretching by different factors per axis turns an exact distance into neither a distance
//! nor, unscaled, a bound with Lipschitz constant 1 (an ellipsoid is not a stretched sphere's
//! distance). [`Affine`] therefore multiplies by the smallest singular value of the map:
//! `σ_min(A) · inner(A⁻¹(p − t))` has the Lipschitz constant of `inner` and never exceeds the
//! true distance (Quilez, "distance functions", non-uniform scale), exact only when `A` is a
//! similarity (a mirror, a rotation times a uniform scale). For the exact distance of a
//! stretched sphere use [`crate::primitives::Ellipsoid`].
//!
//! The transforms are kept in f64; the local point is rounded to f32 to call the inner field,
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
    ///
    /// A translation alone (the most common transform, evaluated several times per sample
    /// through the lower bounds) skips the rotation and the division: the identity's
    /// quaternion product and a division by 1 give the same point (a zero's sign aside).
    #[inline]
    pub fn to_local(&self, p: Vec3) -> DVec3 {
        let d = p.as_dvec3() - self.translation;
        if self.scale == 1.0 && self.rotation == DQuat::IDENTITY {
            return d;
        }
        self.rotation.inverse() * d / self.scale
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

    /// `s ·` the inner field clamped to `cap / s` at the local point. The inner field's own
    /// clamped value, without its lower-bound test first: [`crate::value_clamped`] of this
    /// field has just made the same test (`s ·` the inner bound against `cap`), and without
    /// it the inner field's clamped value is the same.
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let local_cap = (cap as f64 / self.scale) as f32;
        let q = self.to_local(p).as_vec3();
        let v = if q.is_finite() {
            self.inner.value_clamped(q, local_cap)
        } else {
            f32::NAN
        };
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

/// The most a map may stretch one direction more than another (`σ_max / σ_min`) in an
/// [`Affine`]: beyond it values would be too small a fraction of the distance to be useful.
pub const MAX_CONDITION: f64 = 1e6;

/// A field under an invertible affine map `world = A · local + t` (non-uniform scale,
/// mirror, shear, any composition with rotations): the value is
///
/// `max(σ_min(A) · inner(A⁻¹(p − t)), box(p))`
///
/// where `σ_min(A)` is the smallest singular value of `A` and `box` the signed distance to
/// the box of the mapped bounds (only when `A` is not a similarity).
///
/// *Why a bound.* `|A⁻¹(p − q)| ≤ |p − q| / σ_min`, so the first term has the Lipschitz
/// constant of `inner`, and a field whose Lipschitz constant is 1 never exceeds the distance
/// to its zero set: the value is a distance bound with the right sign (Quilez, "distance
/// functions", non-uniform scale: `min(s) · f(p / s)`). The box term (1-Lipschitz, ≤ 0 on
/// the solid) changes no sign; it keeps the property every combinator relies on, that the
/// value outside the box is at least the distance to the box, which the scaled term alone
/// loses (it grows like `dist / κ` in the stretched direction).
///
/// Exact ([`Field::is_exact`]) when `A` is a similarity (`σ_max = σ_min`: a mirror, a rotation,
/// a uniform scale) and `inner` is exact. Lipschitz: `inner`'s (at least 1 with the box term).
/// Gradient `σ_min A⁻ᵀ ∇inner` (the box's where the box term is active), Hessian
/// `σ_min A⁻ᵀ H A⁻¹`.
///
/// ```
/// use isokit_field::{primitives::{Ellipsoid, Sphere}, transform::Affine, Field};
/// use glam::Vec3;
/// let ball = Sphere::new(Vec3::ZERO, 1.0).unwrap();
/// let egg = Affine::scale(ball, Vec3::new(2.0, 1.0, 1.0)).unwrap();
/// let exact = Ellipsoid::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)).unwrap();
/// let p = Vec3::new(3.0, 1.0, 0.0);
/// assert!(egg.value(p) > 0.0 && egg.value(p) <= exact.value(p));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Affine<F: Field> {
    inner: F,
    a: DMat3,
    a_inv: DMat3,
    t: DVec3,
    sigma_min: f64,
    similarity: bool,
    bounds: Aabb,
}

/// Eigenvalues of a symmetric 3×3 matrix by cyclic Jacobi rotations (ascending).
fn sym3_eigenvalues(m: DMat3) -> [f64; 3] {
    let mut a = m.to_cols_array_2d();
    for _ in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-34 * diag {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with the rotation J in the (p, q) plane.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
        }
    }
    let mut e = [a[0][0], a[1][1], a[2][2]];
    e.sort_by(f64::total_cmp);
    e
}

/// The box of the image `A·b + t` of a box (interval arithmetic per output axis; exact for
/// finite boxes, and an unbounded input axis only spreads to the outputs it feeds).
fn map_box(a: &DMat3, t: DVec3, b: &Aabb) -> Aabb {
    if b.is_empty() {
        return Aabb::EMPTY;
    }
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    let mut out_lo = t;
    let mut out_hi = t;
    for i in 0..3 {
        for j in 0..3 {
            let c = a.col(j)[i];
            if c == 0.0 {
                continue;
            }
            let (x, y) = (c * lo[j], c * hi[j]);
            out_lo[i] += x.min(y);
            out_hi[i] += x.max(y);
        }
    }
    let fix = |v: DVec3, inf: f64| DVec3::select(v.is_nan_mask(), DVec3::splat(inf), v);
    aabb_outward(fix(out_lo, f64::NEG_INFINITY), fix(out_hi, f64::INFINITY))
}

impl<F: Field> Affine<F> {
    /// `inner` mapped by `world = matrix · local + translation` (`matrix` given by columns):
    /// finite, invertible, with `σ_max / σ_min ≤` [`MAX_CONDITION`].
    pub fn new(inner: F, matrix: DMat3, translation: DVec3) -> Result<Self, FieldError> {
        if !matrix.is_finite() {
            return Err(FieldError::bad("matrix", matrix, "must be finite"));
        }
        if !translation.is_finite() || translation.abs().max_element() > f32::MAX as f64 {
            return Err(FieldError::bad(
                "translation",
                translation,
                "must be finite (and fit in f32)",
            ));
        }
        let e = sym3_eigenvalues(matrix.transpose() * matrix);
        let (smin, smax) = (e[0].max(0.0).sqrt(), e[2].max(0.0).sqrt());
        if !(smin > 0.0 && smax <= MAX_CONDITION * smin) {
            return Err(FieldError::bad(
                "matrix",
                matrix,
                "must be invertible and stretch no direction more than 1e6 times another",
            ));
        }
        if !(smin >= f32::MIN_POSITIVE as f64 && smax <= f32::MAX as f64) {
            return Err(FieldError::bad(
                "matrix",
                matrix,
                "its scale must stay within the normal f32 range",
            ));
        }
        let similarity = smax - smin <= 1e-12 * smax;
        // Rounding in the eigenvalues: a safety margin far below f32 resolution.
        let sigma_min = if similarity {
            smin
        } else {
            smin * (1.0 - 1e-12)
        };
        let bounds = map_box(&matrix, translation, &inner.bounds());
        Ok(Self {
            inner,
            a: matrix,
            a_inv: matrix.inverse(),
            t: translation,
            sigma_min,
            similarity,
            bounds,
        })
    }

    /// `inner` scaled by `s` along the axes about the origin (each component finite and
    /// > 0): `min(s) · inner(p / s)`, exact only when the three are equal.
    pub fn scale(inner: F, s: Vec3) -> Result<Self, FieldError> {
        if !(s.is_finite() && s.cmpgt(Vec3::ZERO).all()) {
            return Err(FieldError::bad(
                "scale",
                s,
                "every component must be finite and > 0",
            ));
        }
        Self::new(inner, DMat3::from_diagonal(s.as_dvec3()), DVec3::ZERO)
    }

    /// `inner` reflected in the plane `n · p = offset` (`normal` finite and nonzero): an
    /// isometry, exact when `inner` is.
    pub fn mirror(inner: F, normal: Vec3, offset: f32) -> Result<Self, FieldError> {
        let n = normal.as_dvec3();
        let m = n.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return Err(FieldError::bad(
                "normal",
                normal,
                "must be finite and nonzero",
            ));
        }
        if !offset.is_finite() {
            return Err(FieldError::bad("offset", offset, "must be finite"));
        }
        let n = (n / m).normalize();
        let a = DMat3::IDENTITY - 2.0 * DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        Self::new(inner, a, 2.0 * offset as f64 * n)
    }

    /// The mapped field.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// The matrix `A`.
    pub fn matrix(&self) -> DMat3 {
        self.a
    }

    /// The translation `t`.
    pub fn translation(&self) -> DVec3 {
        self.t
    }

    /// The factor the inner values are multiplied by: the smallest singular value of `A`.
    pub fn sigma_min(&self) -> f64 {
        self.sigma_min
    }

    /// True when `A` is a similarity (no box term; exact with an exact inner field).
    pub fn is_similarity(&self) -> bool {
        self.similarity
    }

    /// World point to the inner field's space, `A⁻¹(p − t)`, in f64.
    pub fn to_local(&self, p: Vec3) -> DVec3 {
        self.a_inv * (p.as_dvec3() - self.t)
    }

    /// The box term (`−∞` for a similarity, which needs none).
    #[inline]
    fn guard(&self, p: Vec3) -> f32 {
        if self.similarity {
            f32::NEG_INFINITY
        } else {
            self.bounds.signed_distance(p)
        }
    }

    #[inline]
    fn scaled(&self, v: f32) -> f32 {
        (self.sigma_min * v as f64) as f32
    }
}

impl<F: Field> Field for Affine<F> {
    fn value(&self, p: Vec3) -> f32 {
        let v = self.scaled(self.inner.value(self.to_local(p).as_vec3()));
        v.max(self.guard(p))
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn lipschitz(&self) -> f32 {
        let l = self.inner.lipschitz();
        if self.similarity { l } else { l.max(1.0) }
    }

    fn is_exact(&self) -> bool {
        self.similarity && self.inner.is_exact()
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let q = self.to_local(p).as_vec3();
        let core = self.scaled(self.inner.value(q));
        let g = self.guard(p);
        if g > core {
            // The box's gradient: the outward direction of the nearest face or corner.
            let b = self.bounds;
            let d = (b.min - p).max(p - b.max);
            let out = d.max(Vec3::ZERO);
            let n = if out.cmpgt(Vec3::ZERO).any() {
                out.normalize_or_zero()
            } else {
                Vec3::AXES[d.max_position()]
            };
            let s = Vec3::select(p.cmplt(b.center()), -Vec3::ONE, Vec3::ONE);
            return n * s;
        }
        let gi = self.inner.gradient(q).as_dvec3();
        (self.sigma_min * (self.a_inv.transpose() * gi)).as_vec3()
    }

    fn hessian(&self, p: Vec3) -> Mat3 {
        let h = self.inner.hessian(self.to_local(p).as_vec3()).as_dmat3();
        (self.sigma_min * (self.a_inv.transpose() * h * self.a_inv)).as_mat3()
    }

    fn distance_box(&self) -> Option<crate::DistanceBox> {
        if !self.similarity {
            return Some(crate::DistanceBox::exact(self.bounds));
        }
        let d = self.inner.distance_box()?;
        Some(crate::DistanceBox {
            aabb: map_box(&self.a, self.t, &d.aabb),
            slack: (self.sigma_min * d.slack as f64) as f32,
        })
    }

    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = self.scaled(self.inner.lower_bound(self.to_local(p).as_vec3()));
        let lb = if lb.is_nan() { f32::NEG_INFINITY } else { lb };
        lb.max(self.guard(p))
    }

    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let g = self.guard(p);
        let local_cap = (cap as f64 / self.sigma_min) as f32;
        let v = crate::value_clamped(&self.inner, self.to_local(p).as_vec3(), local_cap);
        self.scaled(v).max(g).clamp(-cap, cap)
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

    /// A non-uniformly scaled ball against the exact ellipsoid distance (Eberly's), and a
    /// sheared ball against the distance to its mapped surface samples: never larger than the
    /// true distance, same sign, at unit, 1e-6 and 1e6 scale; the mapped box holds the solid
    /// and the value is at least the distance to it.
    #[test]
    fn affine_maps_give_bounds_with_the_right_sign() {
        use crate::primitives::Ellipsoid;
        let mut rng = SplitMix64::new(13);
        for s in [1.0f32, 1e-6, 1e6] {
            let radii = Vec3::new(2.0, 0.5, 1.0) * s;
            let ball = Sphere::new(Vec3::ZERO, s).unwrap();
            let egg = Affine::scale(ball, Vec3::new(2.0, 0.5, 1.0)).unwrap();
            let exact = Ellipsoid::new(Vec3::ZERO, radii).unwrap();
            assert!(!egg.is_exact() && egg.lipschitz() == 1.0);
            assert!((egg.sigma_min() - 0.5).abs() < 1e-9);
            for _ in 0..2000 {
                let p = rng.point_in(-3.0 * radii, 3.0 * radii);
                let (v, d) = (egg.value(p), exact.value(p));
                let tol = 1e-6 * s;
                assert!(v.abs() <= d.abs() + tol, "scale {s}: |{v}| > |{d}| at {p}");
                if d.abs() > tol {
                    assert_eq!(v < 0.0, d < 0.0, "scale {s}: sign at {p}");
                }
                let b = egg.bounds();
                if v <= 0.0 {
                    assert!(b.contains(p));
                }
                if !b.contains(p) {
                    assert!(v >= b.distance(p) - tol, "(P) at {p}");
                }
                assert!(egg.lower_bound(p) <= v);
            }
            // Far away the bound still grows like the distance over the stretch.
            let far = Vec3::new(1e3, 0.0, 0.0) * s;
            assert!(egg.value(far) >= exact.value(far) * 0.99 - 1e-6 * s);
        }
        // A shear: the true distance to dense samples of the mapped sphere's surface.
        let m = DMat3::from_cols(
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.8, 1.0, 0.0),
            DVec3::new(0.0, 0.3, 0.7),
        );
        let t = DVec3::new(0.3, -0.2, 0.1);
        let ball = Sphere::new(Vec3::ZERO, 1.0).unwrap();
        let sheared = Affine::new(ball, m, t).unwrap();
        let samples: Vec<DVec3> = (0..200)
            .flat_map(|i| {
                (0..400).map(move |j| {
                    let (th, ph) = (
                        std::f64::consts::TAU * j as f64 / 400.0,
                        std::f64::consts::PI * (i as f64 + 0.5) / 200.0,
                    );
                    DVec3::new(ph.sin() * th.cos(), ph.sin() * th.sin(), ph.cos())
                })
            })
            .map(|u| m * u + t)
            .collect();
        let gap = 0.03;
        for _ in 0..300 {
            let p = rng.point_in(Vec3::splat(-3.0), Vec3::splat(3.0));
            let v = sheared.value(p) as f64;
            let d = samples
                .iter()
                .map(|&x| (x - p.as_dvec3()).length())
                .fold(f64::INFINITY, f64::min);
            assert!(v.abs() <= d + 1e-6, "|{v}| > {d} at {p}");
            let inside = (m.inverse() * (p.as_dvec3() - t)).length() < 1.0;
            if d > gap {
                assert_eq!(v < 0.0, inside, "sign at {p}");
            }
        }
    }

    /// Similarities are exact: a mirror gives the reflected capsule, and a rotation with a
    /// uniform scale gives the same values as [`Transformed`].
    #[test]
    fn mirrors_and_similarities_are_exact() {
        let mut rng = SplitMix64::new(14);
        let (a, b) = (Vec3::new(0.5, 0.2, 0.1), Vec3::new(1.6, -0.3, 0.4));
        let cap = Capsule::new(a, b, 0.3).unwrap();
        let (n, off) = (Vec3::new(1.0, 1.0, 0.0).normalize(), 0.25f32);
        let mirrored = Affine::mirror(cap, Vec3::new(2.0, 2.0, 0.0), off).unwrap();
        let reflect = |x: Vec3| x - 2.0 * (x.dot(n) - off) * n;
        let direct = Capsule::new(reflect(a), reflect(b), 0.3).unwrap();
        assert!(mirrored.is_exact() && mirrored.is_similarity());
        for _ in 0..500 {
            let p = rng.point_in(Vec3::splat(-3.0), Vec3::splat(3.0));
            assert!((mirrored.value(p) - direct.value(p)).abs() < 2e-6, "at {p}");
            let (g, gd) = (mirrored.gradient(p), direct.gradient(p));
            assert!((g - gd).length() < 1e-4, "{g} vs {gd}");
        }
        let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let m = DMat3::from_quat(q) * 2.5;
        let aff = Affine::new(cap, m, DVec3::new(1.0, 0.0, -1.0)).unwrap();
        let tf = Transformed::new(cap)
            .rotate_axis_degrees(Vec3::new(1.0, 2.0, 3.0), 0.7f32.to_degrees())
            .unwrap()
            .scale(2.5)
            .unwrap()
            .translate(Vec3::new(1.0, 0.0, -1.0))
            .unwrap();
        assert!(aff.is_exact());
        for _ in 0..500 {
            let p = rng.point_in(Vec3::splat(-6.0), Vec3::splat(6.0));
            assert!((aff.value(p) - tf.value(p)).abs() < 1e-5, "at {p}");
        }
    }

    /// Measured slopes over random segments never exceed the declared Lipschitz bound.
    #[test]
    fn affine_slopes_stay_within_the_declared_bound() {
        let mut rng = SplitMix64::new(15);
        let ball = Sphere::new(Vec3::new(0.2, 0.0, 0.1), 0.8).unwrap();
        for _ in 0..20 {
            let cols = [0, 1, 2].map(|_| (rng.unit_vector() * rng.range(0.2, 3.0)).as_dvec3());
            let m = DMat3::from_cols(cols[0], cols[1], cols[2]);
            let Ok(f) = Affine::new(ball, m, DVec3::ZERO) else {
                continue;
            };
            let l = f.lipschitz();
            for _ in 0..300 {
                let p = rng.point_in(Vec3::splat(-4.0), Vec3::splat(4.0));
                let len = 10f32.powf(rng.range(-2.0, 0.5));
                let q = p + rng.unit_vector() * len;
                let slope = (f.value(p) - f.value(q)).abs() / (p - q).length();
                assert!(slope <= l * (1.0 + 1e-3) + 1e-4, "slope {slope} > {l}");
            }
        }
    }

    #[test]
    fn singular_and_degenerate_affine_maps_are_refused() {
        let ball = || Sphere::new(Vec3::ZERO, 1.0).unwrap();
        assert!(Affine::new(ball(), DMat3::ZERO, DVec3::ZERO).is_err());
        let flat = DMat3::from_diagonal(DVec3::new(1.0, 1.0, 1e-9));
        assert!(Affine::new(ball(), flat, DVec3::ZERO).is_err());
        assert!(Affine::scale(ball(), Vec3::new(1.0, -1.0, 1.0)).is_err());
        assert!(Affine::scale(ball(), Vec3::new(1.0, f32::NAN, 1.0)).is_err());
        assert!(Affine::mirror(ball(), Vec3::ZERO, 0.0).is_err());
        let nan = DMat3::from_diagonal(DVec3::new(1.0, f64::NAN, 1.0));
        assert!(Affine::new(ball(), nan, DVec3::ZERO).is_err());
        assert!(Affine::new(ball(), DMat3::IDENTITY, DVec3::splat(f64::INFINITY)).is_err());
        // A profile-like unbounded axis stays unbounded only where it is fed.
        let plane = Plane::new(Vec3::Z, 0.0).unwrap();
        let s = Affine::scale(plane, Vec3::new(2.0, 3.0, 1.0)).unwrap();
        assert_eq!(s.bounds(), Aabb::INFINITE);
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
