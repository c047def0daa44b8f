//! Morphing between two distance fields.
//!
//! [`LinearMorph`] is the linear interpolation of 002 Sec. 6.4.3 (Fig. 6.18):
//! `f_t = (1 − t) · fA + t · fB`, evaluated on the fly; [`morph_grids`] does the same on two
//! sampled grids of identical geometry. It is the simplest morph: the intermediate shapes
//! are not distance fields (only bounds, see [`LinearMorph`]), parts of `A` fade out in
//! place rather than moving, and topology changes happen wherever the blend crosses zero.
//! Higher-quality morphs (e.g. variational implicit surfaces) can be sampled into a grid and
//! used wherever a [`Field`] is.
//!
//! # The parameter `t`
//! `t` must be finite ([`MorphError::NonFiniteT`] otherwise; it is not clamped). `t` in
//! `[0, 1]` interpolates; `t` outside extrapolates (`t = 2` moves as far beyond `B` as `B`
//! is from `A`), which is allowed but gives fields with a larger Lipschitz constant
//! `|1 − t| LA + |t| LB` and, in general, unbounded boxes (see [`LinearMorph`]).
//!
//! ```
//! use isokit_field::{primitives::Sphere, Field};
//! use isokit_levelset::morph::LinearMorph;
//! use glam::Vec3;
//! let small = Sphere::new(Vec3::ZERO, 1.0).unwrap();
//! let large = Sphere::new(Vec3::ZERO, 2.0).unwrap();
//! let m = LinearMorph::new(small, large, 0.25).unwrap();
//! // Concentric spheres morph into the sphere of the interpolated radius 1.25.
//! assert!(m.value(Vec3::new(1.25, 0.0, 0.0)).abs() < 1e-6);
//! ```

use crate::csg::{CsgError, combine_grids};
use glam::{Mat3, Vec3};
use isokit_field::{Aabb, DistanceBox, Field, Grid};

/// What can go wrong when morphing.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MorphError {
    /// The morph parameter is NaN or infinite.
    #[error("morph parameter t = {0} must be finite (0 gives the first field, 1 the second)")]
    NonFiniteT(f32),
    /// The two grids cannot be combined (different geometry).
    #[error(transparent)]
    Csg(#[from] CsgError),
}

fn check_t(t: f32) -> Result<f32, MorphError> {
    if t.is_finite() {
        Ok(t)
    } else {
        Err(MorphError::NonFiniteT(t))
    }
}

/// `(1 − t) a + t b`, returning `a` itself at `t = 0` and `b` at `t = 1` (so an infinite
/// value of the unused field cannot turn into NaN).
#[inline]
pub fn lerp_values(a: f32, b: f32, t: f32) -> f32 {
    if t == 0.0 {
        a
    } else if t == 1.0 {
        b
    } else {
        (1.0 - t) * a + t * b
    }
}

/// Linear morph `(1 − t) · f_from + t · f_to` of two fields (002 Sec. 6.4.3).
///
/// - **Exactness**: at `t = 0` and `t = 1` it is the corresponding field and exact when that
///   one is; in between it is not a distance field ([`Field::is_exact`] false). For
///   `t ∈ [0, 1]` and 1-Lipschitz operands it is 1-Lipschitz, so it bounds the distance to its
///   own zero set (it may underestimate it a lot).
/// - **Lipschitz**: `|1 − t| · L_from + |t| · L_to` (equal to the convex combination for
///   `t ∈ [0, 1]`).
/// - **Bounds**: for `t ∈ (0, 1)` the union of the two boxes (a convex combination is `≤ 0`
///   only where one of the operands is, and the property (P) of [`crate::csg`] carries
///   over); `from`'s box at `t = 0` and `to`'s at `t = 1`. Extrapolation can create surface
///   outside both boxes (a sphere of radius 1 morphed towards radius 2 with `t = 2` has
///   radius 3): for two exact operands with finite, non-empty boxes the union box `U` is
///   grown by `s · diag(U)`, `s = −t` or `t − 1` the amount of extrapolation (outside `U`,
///   at distance `D`, the morph is at least `D − s · diag(U)`); otherwise
///   [`Aabb::INFINITE`].
/// - **Gradient and Hessian**: the same combination of the operands'.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearMorph<A, B> {
    from: A,
    to: B,
    t: f32,
}

impl<A: Field, B: Field> LinearMorph<A, B> {
    /// The morph from `from` (at `t = 0`) to `to` (at `t = 1`); `t` must be finite
    /// ([`MorphError::NonFiniteT`]), values outside `[0, 1]` extrapolate.
    pub fn new(from: A, to: B, t: f32) -> Result<Self, MorphError> {
        Ok(Self {
            from,
            to,
            t: check_t(t)?,
        })
    }
    /// The morph parameter.
    pub fn t(&self) -> f32 {
        self.t
    }
    /// Sets the morph parameter (finite, else [`MorphError::NonFiniteT`] and `t` unchanged),
    /// e.g. once per frame of an animation.
    pub fn set_t(&mut self, t: f32) -> Result<(), MorphError> {
        self.t = check_t(t)?;
        Ok(())
    }
    /// The two fields, `(from, to)`.
    pub fn operands(&self) -> (&A, &B) {
        (&self.from, &self.to)
    }
    /// Takes the two fields back.
    pub fn into_operands(self) -> (A, B) {
        (self.from, self.to)
    }
    /// Weights of `from` and `to`.
    fn weights(&self) -> (f32, f32) {
        (1.0 - self.t, self.t)
    }
}

impl<A: Field, B: Field> Field for LinearMorph<A, B> {
    fn value(&self, p: Vec3) -> f32 {
        match self.t {
            0.0 => self.from.value(p),
            1.0 => self.to.value(p),
            t => lerp_values(self.from.value(p), self.to.value(p), t),
        }
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        let n = points.len().min(out.len());
        let (points, out) = (&points[..n], &mut out[..n]);
        match self.t {
            0.0 => self.from.values(points, out),
            1.0 => self.to.values(points, out),
            t => {
                self.from.values(points, out);
                let mut tmp = vec![0.0; n];
                self.to.values(points, &mut tmp);
                for (o, &v) in out.iter_mut().zip(&tmp) {
                    *o = lerp_values(*o, v, t);
                }
            }
        }
    }
    fn bounds(&self) -> Aabb {
        let t = self.t;
        let (a, b) = (self.from.bounds(), self.to.bounds());
        if t == 0.0 {
            return a;
        }
        if t == 1.0 {
            return b;
        }
        let u = a.union(&b);
        if (0.0..=1.0).contains(&t) {
            return u;
        }
        let usable = |x: &Aabb| x.is_finite() && !x.is_empty();
        if self.from.is_exact() && self.to.is_exact() && usable(&a) && usable(&b) {
            let s = if t < 0.0 { -t } else { t - 1.0 };
            let grow = s * u.diagonal();
            if grow.is_finite() {
                return u.expanded(grow);
            }
        }
        Aabb::INFINITE
    }
    fn lipschitz(&self) -> f32 {
        match self.t {
            0.0 => self.from.lipschitz(),
            1.0 => self.to.lipschitz(),
            t => (1.0 - t).abs() * self.from.lipschitz() + t.abs() * self.to.lipschitz(),
        }
    }
    fn is_exact(&self) -> bool {
        match self.t {
            0.0 => self.from.is_exact(),
            1.0 => self.to.is_exact(),
            _ => false,
        }
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.from.fd_step(p).min(self.to.fd_step(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        match self.t {
            0.0 => self.from.gradient(p),
            1.0 => self.to.gradient(p),
            _ => {
                let (wa, wb) = self.weights();
                wa * self.from.gradient(p) + wb * self.to.gradient(p)
            }
        }
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        match self.t {
            0.0 => self.from.hessian(p),
            1.0 => self.to.hessian(p),
            _ => {
                let (wa, wb) = self.weights();
                self.from.hessian(p) * wa + self.to.hessian(p) * wb
            }
        }
    }
    /// At `t = 0` and `t = 1` the operand's; in between the union of both (a convex
    /// combination is at least the smaller of two lower bounds); `None` when extrapolating.
    fn distance_box(&self) -> Option<DistanceBox> {
        match self.t {
            0.0 => self.from.distance_box(),
            1.0 => self.to.distance_box(),
            t if (0.0..=1.0).contains(&t) => {
                Some(self.from.distance_box()?.union(&self.to.distance_box()?))
            }
            _ => None,
        }
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = match self.t {
            0.0 => self.from.lower_bound(p),
            1.0 => self.to.lower_bound(p),
            t if (0.0..=1.0).contains(&t) => {
                (1.0 - t) * self.from.lower_bound(p) + t * self.to.lower_bound(p)
            }
            _ => f32::NEG_INFINITY,
        };
        if lb.is_nan() { f32::NEG_INFINITY } else { lb }
    }
    /// A blend can cancel large values of opposite sign, so the operands are evaluated in
    /// full (the morph's own lower bound still prunes, in [`isokit_field::value_clamped`]).
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.value(p).clamp(-cap, cap)
    }
}

/// Linear morph of two sampled fields of identical geometry, sample by sample:
/// `(1 − t) a + t b` (equal to sampling [`LinearMorph`] of the two fields on that lattice).
/// Errors: [`MorphError::NonFiniteT`], and [`MorphError::Csg`] wrapping
/// [`CsgError::GeometryMismatch`] when the grids differ.
pub fn morph_grids(a: &Grid, b: &Grid, t: f32) -> Result<Grid, MorphError> {
    let t = check_t(t)?;
    Ok(combine_grids(a, b, |x, y| lerp_values(x, y, t))?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::primitives::{Cuboid, Sphere};
    use isokit_field::rng::SplitMix64;

    #[test]
    fn t_must_be_finite() {
        let s = Sphere::new(Vec3::ZERO, 1.0).unwrap();
        for t in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert!(matches!(
                LinearMorph::new(s, s, t),
                Err(MorphError::NonFiniteT(_))
            ));
        }
        let mut m = LinearMorph::new(s, s, 0.5).unwrap();
        assert!(m.set_t(f32::NAN).is_err());
        assert_eq!(m.t(), 0.5);
        m.set_t(-0.5).unwrap();
        assert_eq!(m.t(), -0.5);
        let g = Grid::new([2, 2, 2], Vec3::ZERO, 1.0).unwrap();
        assert!(matches!(
            morph_grids(&g, &g, f32::NAN),
            Err(MorphError::NonFiniteT(_))
        ));
    }

    #[test]
    fn endpoints_ignore_the_other_field() {
        struct Inf;
        impl Field for Inf {
            fn value(&self, _: Vec3) -> f32 {
                f32::INFINITY
            }
            fn bounds(&self) -> Aabb {
                Aabb::EMPTY
            }
        }
        let s = Sphere::new(Vec3::ZERO, 1.0).unwrap();
        let m = LinearMorph::new(s, Inf, 0.0).unwrap();
        assert_eq!(m.value(Vec3::ZERO), -1.0);
        assert!(m.is_exact());
        let m = LinearMorph::new(Inf, s, 1.0).unwrap();
        assert_eq!(m.value(Vec3::ZERO), -1.0);
        assert_eq!(m.bounds(), s.bounds());
    }

    #[test]
    fn gradient_and_hessian_are_the_combination() {
        let a = Sphere::new(Vec3::new(0.2, 0.0, 0.0), 1.0).unwrap();
        let b = Cuboid::new(Vec3::ZERO, Vec3::new(1.0, 0.7, 0.5)).unwrap();
        let m = LinearMorph::new(a, b, 0.3).unwrap();
        let mut rng = SplitMix64::new(3);
        for _ in 0..100 {
            let p = rng.point_in(Vec3::splat(-2.0), Vec3::splat(2.0));
            let want = 0.7 * a.gradient(p) + 0.3 * b.gradient(p);
            assert!((m.gradient(p) - want).length() < 1e-6);
        }
        assert!((m.lipschitz() - 1.0).abs() < 1e-6);
        let x = LinearMorph::new(a, b, 1.5).unwrap();
        assert!((x.lipschitz() - 2.0).abs() < 1e-6);
    }
}
