//! Constructive solid geometry on signed distance fields (negative inside).
//!
//! The operators follow ERRATA 1 (002's Table 2.1 and Sec. 6.4.3 print them for a positive
//! interior; only Fig. 6.17's `max(f_sphere, −f_knot)` is right):
//!
//! | operation | formula | with exact operands the result is exact |
//! | --- | --- | --- |
//! | union A ∪ B | `min(fA, fB)` | outside the union; inside only a bound |
//! | intersection A ∩ B | `max(fA, fB)` | inside the intersection; outside only a bound |
//! | difference A − B | `max(fA, −fB)` | inside the difference; outside only a bound |
//! | complement | `−fA` | everywhere |
//! | offset by `r` | `fA − r` | dilation (`r > 0`): outside; erosion (`r < 0`): inside |
//!
//! "A bound" means: the value has the right sign and its magnitude never exceeds the true
//! distance to the result's surface, so a Lipschitz constant of 1 stays valid and sphere
//! tracing and brick pruning stay sound. [`Field::is_exact`] is therefore false for every
//! combinator here except [`Complement`] of an exact field and [`Offset`] by 0.
//!
//! Three layers:
//! - scalar operators on two values ([`union`], [`smooth_union`], ...), shared by every other
//!   module;
//! - [`Field`] combinators ([`Union`], [`Intersection`], [`Difference`], [`Complement`],
//!   [`SmoothUnion`], [`SmoothIntersection`], [`SmoothDifference`], [`Offset`]) and n-ary
//!   versions ([`UnionN`], [`IntersectionN`], [`DifferenceN`]), with bounds, Lipschitz
//!   constants and analytic gradients and Hessians (by the active operand);
//! - elementwise operations on sampled [`Grid`]s of identical geometry ([`union_grids`],
//!   [`offset_grid`], ...) and on [`BrickGrid`]s (through a dense grid, see
//!   [`union_brick_grids`]).
//!
//! # Bounds
//! [`Field::bounds`] promises only that `{f ≤ 0}` lies in the box. The smooth union and the
//! dilation can be negative *outside* their operands' zero sets, so their boxes are grown,
//! and to grow them soundly they rely on a stronger property of their operands:
//!
//! > **(P)** for every `δ ≥ 0`, `{f ≤ δ} ⊂ bounds().expanded(δ)`,
//!
//! i.e. outside its box a field is at least the (axis-wise) distance to the box. Exact signed
//! distance fields have (P), and every combinator in this module keeps it (the box algebra
//! below is chosen for that: boxes that come out inverted, as the intersection of disjoint
//! boxes does, are kept as they are rather than replaced by [`Aabb::EMPTY`], because an
//! inverted box expanded by `δ` is exactly the right answer for the level `δ`). A field that
//! underestimates the distance far away (e.g. a narrow band clamped to a constant
//! background) may not have (P); under a smooth union or a dilation larger than its band its
//! box can then be too small.
//!
//! ```
//! use isokit_field::{primitives::Sphere, Field};
//! use isokit_levelset::csg::{Difference, SmoothUnion, Union};
//! use glam::Vec3;
//! let a = Sphere::new(Vec3::new(-5.0, 0.0, 0.0), 1.0).unwrap();
//! let b = Sphere::new(Vec3::new(5.0, 0.0, 0.0), 1.0).unwrap();
//! let u = Union::new(a, b);
//! // Negative inside (ERRATA 1: the printed `max` would give +9 here).
//! assert_eq!(u.value(Vec3::new(-5.0, 0.0, 0.0)), -1.0);
//! let d = Difference::new(a, Sphere::new(Vec3::new(-5.0, 0.0, 0.0), 0.5).unwrap());
//! assert!(d.value(Vec3::new(-5.0, 0.0, 0.0)) > 0.0);
//! let s = SmoothUnion::new(a, b, 0.5).unwrap();
//! assert_eq!(s.value(Vec3::new(-5.0, 0.0, 0.0)), -1.0);
//! ```

use glam::{Mat3, Vec3};
use isokit_field::{Aabb, BrickGrid, DistanceBox, Field, FieldError, Grid, value_clamped};
use rayon::prelude::*;
use std::fmt;

// ---------------------------------------------------------------- scalar operators

/// Union `A ∪ B = min(fA, fB)`. With exact operands: exact outside the union, a bound inside.
#[inline]
pub fn union(a: f32, b: f32) -> f32 {
    a.min(b)
}

/// Intersection `A ∩ B = max(fA, fB)`. With exact operands: exact inside the intersection, a
/// bound outside.
#[inline]
pub fn intersection(a: f32, b: f32) -> f32 {
    a.max(b)
}

/// Difference `A − B = max(fA, −fB)`. With exact operands: exact inside the difference, a
/// bound outside.
#[inline]
pub fn difference(a: f32, b: f32) -> f32 {
    a.max(-b)
}

/// Complement `−fA`: exact when `fA` is.
#[inline]
pub fn complement(a: f32) -> f32 {
    -a
}

/// Smooth union with blend radius `k` (the quadratic polynomial smooth minimum
/// `min(a, b) − k/4 · h²`, `h = max(k − |a − b|, 0) / k`): equal to `min(a, b)` where
/// `|a − b| ≥ k`, and at most `k/4` below it where the two meet. `k ≤ 0` gives the sharp
/// union; `k` should be finite (the [`Field`] combinators check it). The result is a bound,
/// never exact in the blend region; its Lipschitz constant is at most the larger of the
/// operands' (its partial derivatives are `1 − h/2` and `h/2`, both in `[0, 1]`).
#[inline]
pub fn smooth_union(a: f32, b: f32, k: f32) -> f32 {
    if k <= 0.0 {
        return union(a, b);
    }
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - 0.25 * k * h * h
}

/// Smooth intersection with blend radius `k`: `−smooth_union(−a, −b, k)`, equal to
/// `max(a, b)` where `|a − b| ≥ k` and at most `k/4` above it. A bound.
#[inline]
pub fn smooth_intersection(a: f32, b: f32, k: f32) -> f32 {
    -smooth_union(-a, -b, k)
}

/// Smooth difference with blend radius `k`: `smooth_intersection(a, −b, k)`, equal to
/// `max(a, −b)` where `|a + b| ≥ k` and at most `k/4` above it. A bound.
#[inline]
pub fn smooth_difference(a: f32, b: f32, k: f32) -> f32 {
    smooth_intersection(a, -b, k)
}

/// Chamfered union with bevel size `r` (hg_sdf's `fOpUnionChamfer`): `min(a, b)` where
/// `|a − b| ≥ r`, and the 45° bevel `a + b = r` where the two meet. The bevel term is
/// `(a + b − r)/2` here, not hg_sdf's `(a + b − r)·√½`: the same surface, but a slope of at
/// most the operands' (`|∇a + ∇b|/2 ≤ 1`) where hg_sdf's reaches `√2` when the operands'
/// gradients align, which would break the distance bound. At most `r/2` below `min(a, b)`.
/// `r ≤ 0` gives the sharp union.
#[inline]
pub fn chamfer_union(a: f32, b: f32, r: f32) -> f32 {
    if r <= 0.0 {
        return union(a, b);
    }
    a.min(b).min(0.5 * (a + b - r))
}

/// Chamfered intersection: `−chamfer_union(−a, −b, r)`, the bevel `a + b = −r` on the
/// intersection's edges.
#[inline]
pub fn chamfer_intersection(a: f32, b: f32, r: f32) -> f32 {
    -chamfer_union(-a, -b, r)
}

/// Chamfered difference: `chamfer_intersection(a, −b, r)`.
#[inline]
pub fn chamfer_difference(a: f32, b: f32, r: f32) -> f32 {
    chamfer_intersection(a, -b, r)
}

/// Stepped union with `steps` stairs over the size `r` (hg_sdf's `fOpUnionStairs`):
/// `min(a, b, ½(u + a + |mod(u − a + s, 2s) − s|))` with `u = b − r`, `s = r/steps`. Equal
/// to `min(a, b)` where `|a − b| ≥ r` and at most `r/2` below it; its gradient is always one
/// of the operands' (the triangle wave has slope ±1), so its slope is the operands'.
/// `r ≤ 0` or `steps = 0` gives the sharp union.
#[inline]
pub fn stairs_union(a: f32, b: f32, r: f32, steps: u32) -> f32 {
    if r <= 0.0 || steps == 0 {
        return union(a, b);
    }
    let s = r / steps as f32;
    let u = b - r;
    let tri = ((u - a + s).rem_euclid(2.0 * s) - s).abs();
    a.min(b).min(0.5 * (u + a + tri))
}

/// Stepped intersection: `−stairs_union(−a, −b, r, steps)`.
#[inline]
pub fn stairs_intersection(a: f32, b: f32, r: f32, steps: u32) -> f32 {
    -stairs_union(-a, -b, r, steps)
}

/// Stepped difference: `−stairs_union(−a, b, r, steps)` (hg_sdf's `fOpDifferenceStairs`).
#[inline]
pub fn stairs_difference(a: f32, b: f32, r: f32, steps: u32) -> f32 {
    -stairs_union(-a, b, r, steps)
}

// ---------------------------------------------------------------- errors

/// The geometry of a sampled grid: what two grids must share to be combined elementwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridGeometry {
    /// Samples along x, y, z.
    pub dims: [usize; 3],
    /// Position of sample (0, 0, 0).
    pub origin: Vec3,
    /// Sample spacing.
    pub spacing: f32,
}

impl GridGeometry {
    /// The geometry of a dense grid.
    pub fn of_grid(g: &Grid) -> Self {
        Self {
            dims: g.dims(),
            origin: g.origin(),
            spacing: g.spacing(),
        }
    }

    /// The geometry of a brick grid's virtual dense grid.
    pub fn of_brick_grid(g: &BrickGrid) -> Self {
        Self {
            dims: g.dims(),
            origin: g.origin(),
            spacing: g.spacing(),
        }
    }
}

impl fmt::Display for GridGeometry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:?} samples, origin {}, spacing {}",
            self.dims, self.origin, self.spacing
        )
    }
}

/// What can go wrong in CSG: mismatched grids, invalid parameters, no operands.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CsgError {
    /// Two grids to combine elementwise differ in dimensions, origin or spacing.
    #[error(
        "grids differ in geometry ({a} vs {b}); elementwise CSG needs identical dimensions, \
         origin and spacing: resample one grid onto the other's lattice first"
    )]
    GeometryMismatch {
        /// Geometry of the first grid.
        a: GridGeometry,
        /// Geometry of the second grid.
        b: GridGeometry,
    },
    /// A parameter (blend radius, offset distance) is out of its valid range.
    #[error("invalid parameter {name} = {value}: {why}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f32,
        /// What is allowed.
        why: &'static str,
    },
    /// An n-ary union or intersection was given no operand.
    #[error("an n-ary {op} needs at least one operand")]
    NoOperands {
        /// The operation ("union", "intersection").
        op: &'static str,
    },
    /// Building a grid failed (e.g. a brick grid too large to expand densely).
    #[error(transparent)]
    Field(#[from] FieldError),
}

fn check_blend_radius(k: f32) -> Result<f32, CsgError> {
    if k.is_finite() && k >= 0.0 {
        Ok(k)
    } else {
        Err(CsgError::BadParameter {
            name: "blend radius k",
            value: k,
            why: "must be finite and >= 0 (0 is the sharp operation)",
        })
    }
}

fn check_offset(r: f32) -> Result<f32, CsgError> {
    if r.is_finite() {
        Ok(r)
    } else {
        Err(CsgError::BadParameter {
            name: "offset r",
            value: r,
            why: "must be finite",
        })
    }
}

// ---------------------------------------------------------------- helpers

/// Evaluates `a` and `b` in batches (so each keeps its own parallel `values`) and combines.
fn combine_values(
    a: &dyn Field,
    b: &dyn Field,
    points: &[Vec3],
    out: &mut [f32],
    op: impl Fn(f32, f32) -> f32 + Sync,
) {
    let n = points.len().min(out.len());
    let (points, out) = (&points[..n], &mut out[..n]);
    a.values(points, out);
    let mut tmp = vec![0.0; n];
    b.values(points, &mut tmp);
    out.par_iter_mut()
        .zip(tmp.par_iter())
        .for_each(|(o, &v)| *o = op(*o, v));
}

/// Outer product `v vᵀ`.
fn outer(v: Vec3) -> Mat3 {
    Mat3::from_cols(v * v.x, v * v.y, v * v.z)
}

/// Largest of two Lipschitz constants (NaN treated as unbounded).
fn lip_max(a: f32, b: f32) -> f32 {
    if a.is_nan() || b.is_nan() {
        f32::INFINITY
    } else {
        a.max(b)
    }
}

/// True when `min(a, b)` takes `a` (ties and a NaN `b` go to `a`).
#[inline]
fn takes_first_min(a: f32, b: f32) -> bool {
    a <= b || b.is_nan()
}

/// True when `max(a, b)` takes `a` (ties and a NaN `b` go to `a`).
#[inline]
fn takes_first_max(a: f32, b: f32) -> bool {
    a >= b || b.is_nan()
}

/// Bounds of `smooth_union` of operands with boxes `a`, `b` and blend radius `k`, sound under
/// (P) (see the module docs).
///
/// Where the blend is at or below `δ` but both operands are above `δ`, with `m = min(a, b)`
/// and `d = |a − b| < k`, the blend needs `m − δ ≤ (k − d)²/(4k)`: so the smaller operand is
/// at most `δ + k/4` and the larger at most `δ + (k − d)²/(4k) + d ≤ δ + k` (that sum grows
/// with `d` and reaches `k` at `d = k`). By (P) the point is in
/// `(A.expanded(k/4) ∩ B.expanded(k)).expanded(δ)` or the same with A and B swapped.
pub fn smooth_union_bounds(a: &Aabb, b: &Aabb, k: f32) -> Aabb {
    blend_union_bounds(a, b, 0.25 * k, k)
}

/// Bounds of a blended union whose value is `min(a, b)` where `|a − b| ≥ window` and at most
/// `reach` below it elsewhere, with bevels that need `a + b ≤ 2δ + window`-like closeness:
/// by the argument of [`smooth_union_bounds`] (the smaller operand at most `δ + reach`, the
/// larger at most `δ + window`), `A.expanded(reach) ∩ B.expanded(window)` or the same with
/// A and B swapped. The quadratic blend has `(k/4, k)`, the chamfer and the stairs `(r/2, r)`
/// (for them `a + b ≤ 2δ + r` with both above `δ` puts the larger below `δ + r`).
pub fn blend_union_bounds(a: &Aabb, b: &Aabb, reach: f32, window: f32) -> Aabb {
    if window <= 0.0 {
        return a.union(b);
    }
    a.union(b)
        .union(&a.expanded(reach).intersection(&b.expanded(window)))
        .union(&a.expanded(window).intersection(&b.expanded(reach)))
}

/// Bounds of [`Offset`] by `r` of a field with box `b` and Lipschitz constant `lipschitz`:
/// grown by `r` for a dilation (sound under (P)); shrunk by `|r| / max(L, 1)` for an erosion
/// (sound for any `L`-Lipschitz field: where `f ≤ r < 0`, the ball of radius `|r|/L` has
/// `f ≤ 0`, so it lies in the box). Not shrunk when `L` is not finite.
pub fn offset_bounds(b: &Aabb, r: f32, lipschitz: f32) -> Aabb {
    if r >= 0.0 {
        b.expanded(r)
    } else if lipschitz.is_finite() {
        b.expanded(r / lipschitz.max(1.0))
    } else {
        *b
    }
}

// ---------------------------------------------------------------- sharp binary combinators

/// Declares a sharp binary combinator type with its doc, `new` and accessors.
macro_rules! binary_type {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Debug, PartialEq)]
        pub struct $name<A, B> {
            a: A,
            b: B,
        }

        impl<A: Field, B: Field> $name<A, B> {
            /// The combination of `a` (first operand) and `b` (second operand).
            pub fn new(a: A, b: B) -> Self {
                Self { a, b }
            }
            /// The two operands.
            pub fn operands(&self) -> (&A, &B) {
                (&self.a, &self.b)
            }
            /// Takes the two operands back.
            pub fn into_operands(self) -> (A, B) {
                (self.a, self.b)
            }
        }
    };
}

binary_type! {
    /// Union `A ∪ B = min(fA, fB)` of two fields.
    ///
    /// With exact operands the value is the exact distance outside the union and only a bound
    /// inside (where the two overlap it underestimates the depth), so [`Field::is_exact`] is
    /// false. Bounds: the union of the operands' boxes. Lipschitz: the larger of the
    /// operands'. Gradient and Hessian: those of the operand that attains the minimum.
    Union
}

binary_type! {
    /// Intersection `A ∩ B = max(fA, fB)` of two fields.
    ///
    /// With exact operands the value is exact inside the intersection and only a bound
    /// outside, so [`Field::is_exact`] is false. Bounds: the intersection of the operands'
    /// boxes (possibly inverted, i.e. empty). Lipschitz: the larger of the operands'.
    /// Gradient and Hessian: those of the operand that attains the maximum.
    Intersection
}

binary_type! {
    /// Difference `A − B = max(fA, −fB)` of two fields.
    ///
    /// With exact operands the value is exact inside the difference and only a bound outside,
    /// so [`Field::is_exact`] is false. Bounds: `A`'s box. Lipschitz: the larger of the
    /// operands'. Gradient and Hessian: those of `fA` or of `−fB`, whichever is larger.
    Difference
}

impl<A: Field, B: Field> Field for Union<A, B> {
    fn value(&self, p: Vec3) -> f32 {
        union(self.a.value(p), self.b.value(p))
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        combine_values(&self.a, &self.b, points, out, union);
    }
    fn bounds(&self) -> Aabb {
        self.a.bounds().union(&self.b.bounds())
    }
    fn lipschitz(&self) -> f32 {
        lip_max(self.a.lipschitz(), self.b.lipschitz())
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.a.fd_step(p).min(self.b.fd_step(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if takes_first_min(self.a.value(p), self.b.value(p)) {
            self.a.gradient(p)
        } else {
            self.b.gradient(p)
        }
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        if takes_first_min(self.a.value(p), self.b.value(p)) {
            self.a.hessian(p)
        } else {
            self.b.hessian(p)
        }
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        Some(self.a.distance_box()?.union(&self.b.distance_box()?))
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.a.lower_bound(p).min(self.b.lower_bound(p))
    }
}

impl<A: Field, B: Field> Field for Intersection<A, B> {
    fn value(&self, p: Vec3) -> f32 {
        intersection(self.a.value(p), self.b.value(p))
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        combine_values(&self.a, &self.b, points, out, intersection);
    }
    fn bounds(&self) -> Aabb {
        self.a.bounds().intersection(&self.b.bounds())
    }
    fn lipschitz(&self) -> f32 {
        lip_max(self.a.lipschitz(), self.b.lipschitz())
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.a.fd_step(p).min(self.b.fd_step(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if takes_first_max(self.a.value(p), self.b.value(p)) {
            self.a.gradient(p)
        } else {
            self.b.gradient(p)
        }
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        if takes_first_max(self.a.value(p), self.b.value(p)) {
            self.a.hessian(p)
        } else {
            self.b.hessian(p)
        }
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.a.lower_bound(p).max(self.b.lower_bound(p))
    }
}

impl<A: Field, B: Field> Field for Difference<A, B> {
    fn value(&self, p: Vec3) -> f32 {
        difference(self.a.value(p), self.b.value(p))
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        combine_values(&self.a, &self.b, points, out, difference);
    }
    fn bounds(&self) -> Aabb {
        self.a.bounds()
    }
    fn lipschitz(&self) -> f32 {
        lip_max(self.a.lipschitz(), self.b.lipschitz())
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.a.fd_step(p).min(self.b.fd_step(p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        if takes_first_max(self.a.value(p), -self.b.value(p)) {
            self.a.gradient(p)
        } else {
            -self.b.gradient(p)
        }
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        if takes_first_max(self.a.value(p), -self.b.value(p)) {
            self.a.hessian(p)
        } else {
            -self.b.hessian(p)
        }
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.a.distance_box()
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.a.lower_bound(p)
    }
}

// ---------------------------------------------------------------- complement and offset

/// Complement `−fA`: inside and outside swapped.
///
/// Exact wherever `fA` is ([`Field::is_exact`] forwards). Bounds: [`Aabb::INFINITE`] (the
/// complement of a bounded solid is unbounded; use [`Difference`] to cut a solid out of
/// another and keep a finite box). Lipschitz, gradient and Hessian: those of `fA`, negated
/// where it applies.
#[derive(Clone, Debug, PartialEq)]
pub struct Complement<A> {
    a: A,
}

impl<A: Field> Complement<A> {
    /// The complement of `a`.
    pub fn new(a: A) -> Self {
        Self { a }
    }
    /// The operand.
    pub fn operand(&self) -> &A {
        &self.a
    }
    /// Takes the operand back.
    pub fn into_operand(self) -> A {
        self.a
    }
}

impl<A: Field> Field for Complement<A> {
    fn value(&self, p: Vec3) -> f32 {
        complement(self.a.value(p))
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        let n = points.len().min(out.len());
        self.a.values(&points[..n], &mut out[..n]);
        out[..n].iter_mut().for_each(|v| *v = complement(*v));
    }
    fn bounds(&self) -> Aabb {
        Aabb::INFINITE
    }
    fn lipschitz(&self) -> f32 {
        self.a.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.a.is_exact()
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.a.fd_step(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        -self.a.gradient(p)
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        -self.a.hessian(p)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        complement(value_clamped(&self.a, p, cap))
    }
}

/// Offset `fA − r`: a dilation (the solid grows by `r`) for `r > 0`, an erosion for `r < 0`.
///
/// With an exact operand the value is exact **outside** the result for a dilation and
/// **inside** it for an erosion; on the other side it is only a bound (a dilation closes
/// gaps narrower than `2r`, an erosion removes parts thinner than `2|r|`, and in both cases
/// the true distance there is larger than `|fA − r|`). For convex solids a dilation is
/// exact everywhere (e.g. a dilated [`isokit_field::primitives::Cuboid`] is a
/// [`isokit_field::primitives::RoundedBox`]), but that is not checked, so
/// [`Field::is_exact`] is true only for `r = 0`. For any operand with Lipschitz constant 1
/// the value is at least a bound on both sides.
///
/// Offsetting twice (`−r` then `+r`) gives back `fA`, not the morphological opening, which
/// needs the eroded field to be reinitialized to a distance first: for sampled grids,
/// [`crate::offset`] offsets with reinitialization and provides opening and closing.
///
/// Bounds: see [`offset_bounds`]. Lipschitz, gradient and Hessian: those of `fA`.
#[derive(Clone, Debug, PartialEq)]
pub struct Offset<A> {
    a: A,
    r: f32,
}

impl<A: Field> Offset<A> {
    /// `a` offset by `r` (finite; [`CsgError::BadParameter`] otherwise).
    pub fn new(a: A, r: f32) -> Result<Self, CsgError> {
        Ok(Self {
            a,
            r: check_offset(r)?,
        })
    }
    /// The operand.
    pub fn operand(&self) -> &A {
        &self.a
    }
    /// The offset distance `r`.
    pub fn r(&self) -> f32 {
        self.r
    }
    /// Takes the operand back.
    pub fn into_operand(self) -> A {
        self.a
    }
}

impl<A: Field> Field for Offset<A> {
    fn value(&self, p: Vec3) -> f32 {
        self.a.value(p) - self.r
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        let n = points.len().min(out.len());
        self.a.values(&points[..n], &mut out[..n]);
        out[..n].iter_mut().for_each(|v| *v -= self.r);
    }
    fn bounds(&self) -> Aabb {
        offset_bounds(&self.a.bounds(), self.r, self.a.lipschitz())
    }
    fn lipschitz(&self) -> f32 {
        self.a.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.r == 0.0 && self.a.is_exact()
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.a.fd_step(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.a.gradient(p)
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        self.a.hessian(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.a.distance_box().map(|d| DistanceBox {
            slack: d.slack + self.r,
            ..d
        })
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = self.a.lower_bound(p) - self.r;
        if lb.is_nan() { f32::NEG_INFINITY } else { lb }
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        (value_clamped(&self.a, p, cap + self.r.abs()) - self.r).clamp(-cap, cap)
    }
}

// ---------------------------------------------------------------- smooth combinators

/// The three smooth operations as `o · smooth_union(ca · a, cb · b, k)`.
#[derive(Clone, Copy)]
struct SignedBlend {
    o: f32,
    ca: f32,
    cb: f32,
}

const BLEND_UNION: SignedBlend = SignedBlend {
    o: 1.0,
    ca: 1.0,
    cb: 1.0,
};
const BLEND_INTERSECTION: SignedBlend = SignedBlend {
    o: -1.0,
    ca: -1.0,
    cb: -1.0,
};
const BLEND_DIFFERENCE: SignedBlend = SignedBlend {
    o: -1.0,
    ca: -1.0,
    cb: 1.0,
};

impl SignedBlend {
    /// Weights `(wa, wb)` of the (sign-adjusted) operand gradients and whether the point is in
    /// the blend region (`|a − b| < k`, where the second derivatives pick up `±1/(2k)`).
    fn weights(self, a: f32, b: f32, k: f32) -> (f32, f32, bool) {
        let (x, y) = (self.ca * a, self.cb * b);
        let first = takes_first_min(x, y);
        if k <= 0.0 {
            return if first {
                (1.0, 0.0, false)
            } else {
                (0.0, 1.0, false)
            };
        }
        let h = (k - (x - y).abs()).max(0.0) / k;
        let (w_min, w_max) = (1.0 - 0.5 * h, 0.5 * h);
        let (wx, wy) = if first {
            (w_min, w_max)
        } else {
            (w_max, w_min)
        };
        (wx, wy, h > 0.0)
    }

    fn value(self, a: f32, b: f32, k: f32) -> f32 {
        self.o * smooth_union(self.ca * a, self.cb * b, k)
    }

    /// `∇s = o (wa ca ∇a + wb cb ∇b)`.
    fn gradient(self, a: &dyn Field, b: &dyn Field, k: f32, p: Vec3) -> Vec3 {
        let (wa, wb, _) = self.weights(a.value(p), b.value(p), k);
        let mut g = Vec3::ZERO;
        if wa != 0.0 {
            g += (self.o * self.ca * wa) * a.gradient(p);
        }
        if wb != 0.0 {
            g += (self.o * self.cb * wb) * b.gradient(p);
        }
        g
    }

    /// `H = o (wa ca Ha + wb cb Hb − [blend] (ca ∇a − cb ∇b)(ca ∇a − cb ∇b)ᵀ / (2k))`.
    fn hessian(self, a: &dyn Field, b: &dyn Field, k: f32, p: Vec3) -> Mat3 {
        let (wa, wb, blend) = self.weights(a.value(p), b.value(p), k);
        let mut h = Mat3::ZERO;
        if wa != 0.0 {
            h += a.hessian(p) * (self.o * self.ca * wa);
        }
        if wb != 0.0 {
            h += b.hessian(p) * (self.o * self.cb * wb);
        }
        if blend {
            let v = self.ca * a.gradient(p) - self.cb * b.gradient(p);
            h -= outer(v) * (self.o / (2.0 * k));
        }
        h
    }
}

/// Declares a smooth binary combinator with blend radius `k` and implements [`Field`].
macro_rules! smooth_type {
    ($(#[$doc:meta])* $name:ident, $blend:expr, $bounds:expr) => {
        $(#[$doc])*
        #[derive(Clone, Debug, PartialEq)]
        pub struct $name<A, B> {
            a: A,
            b: B,
            k: f32,
        }

        impl<A: Field, B: Field> $name<A, B> {
            /// The blend of `a` and `b` with radius `k` (finite and `>= 0`; 0 gives the sharp
            /// operation). [`CsgError::BadParameter`] otherwise.
            pub fn new(a: A, b: B, k: f32) -> Result<Self, CsgError> {
                Ok(Self {
                    a,
                    b,
                    k: check_blend_radius(k)?,
                })
            }
            /// The two operands.
            pub fn operands(&self) -> (&A, &B) {
                (&self.a, &self.b)
            }
            /// The blend radius.
            pub fn k(&self) -> f32 {
                self.k
            }
            /// Takes the two operands back.
            pub fn into_operands(self) -> (A, B) {
                (self.a, self.b)
            }
        }

        impl<A: Field, B: Field> Field for $name<A, B> {
            fn value(&self, p: Vec3) -> f32 {
                $blend.value(self.a.value(p), self.b.value(p), self.k)
            }
            fn values(&self, points: &[Vec3], out: &mut [f32]) {
                let k = self.k;
                combine_values(&self.a, &self.b, points, out, |x, y| $blend.value(x, y, k));
            }
            fn bounds(&self) -> Aabb {
                let f: fn(&Aabb, &Aabb, f32) -> Aabb = $bounds;
                f(&self.a.bounds(), &self.b.bounds(), self.k)
            }
            fn lipschitz(&self) -> f32 {
                lip_max(self.a.lipschitz(), self.b.lipschitz())
            }
            fn fd_step(&self, p: Vec3) -> f32 {
                self.a.fd_step(p).min(self.b.fd_step(p))
            }
            fn gradient(&self, p: Vec3) -> Vec3 {
                $blend.gradient(&self.a, &self.b, self.k, p)
            }
            fn hessian(&self, p: Vec3) -> Mat3 {
                $blend.hessian(&self.a, &self.b, self.k, p)
            }
        }
    };
}

smooth_type! {
    /// Smooth union [`smooth_union`]`(fA, fB, k)`: the sharp union where `|fA − fB| ≥ k`, and
    /// up to `k/4` below it (a fillet) where the two meet.
    ///
    /// A bound, never exact ([`Field::is_exact`] false). Lipschitz: the larger of the
    /// operands' (the smooth minimum's partial derivatives `1 − h/2` and `h/2` are convex
    /// weights). Bounds: [`smooth_union_bounds`] — the fillet can be negative outside both
    /// operands' boxes, up to `k/4` beyond one and `k` beyond the other. Gradient and
    /// Hessian: analytic, `(1 − h/2) ∇a + (h/2) ∇b` for `a ≤ b` (and the curvature term of
    /// the blend).
    SmoothUnion,
    BLEND_UNION,
    smooth_union_bounds
}

smooth_type! {
    /// Smooth intersection [`smooth_intersection`]`(fA, fB, k)`: the sharp intersection where
    /// `|fA − fB| ≥ k`, and up to `k/4` above it where the two meet.
    ///
    /// A bound, never exact. Lipschitz: the larger of the operands'. Bounds: the intersection
    /// of the operands' boxes (the value is never below the sharp intersection). Gradient and
    /// Hessian: analytic.
    SmoothIntersection,
    BLEND_INTERSECTION,
    |a, b, _| a.intersection(b)
}

smooth_type! {
    /// Smooth difference [`smooth_difference`]`(fA, fB, k)`: the sharp difference where
    /// `|fA + fB| ≥ k`, and up to `k/4` above it along the cut.
    ///
    /// A bound, never exact. Lipschitz: the larger of the operands'. Bounds: `A`'s box (the
    /// value is never below `fA`). Gradient and Hessian: analytic.
    SmoothDifference,
    BLEND_DIFFERENCE,
    |a, _, _| *a
}

// ---------------------------------------------------------------- n-ary combinators

mod bvh;
mod nary;
pub use nary::{Blend, DifferenceN, IntersectionN, Shell, SmoothKind, SmoothN, UnionN};

// ---------------------------------------------------------------- dense grids

/// `Ok` when the two grids have identical dimensions, origin and spacing (compared exactly:
/// build both on the same lattice, e.g. with [`isokit_field::sample_into`] on clones of one
/// grid), else [`CsgError::GeometryMismatch`].
pub fn check_same_geometry(a: &Grid, b: &Grid) -> Result<(), CsgError> {
    let (ga, gb) = (GridGeometry::of_grid(a), GridGeometry::of_grid(b));
    if ga == gb {
        Ok(())
    } else {
        Err(CsgError::GeometryMismatch { a: ga, b: gb })
    }
}

/// Applies `op` to corresponding samples of two grids of identical geometry (in parallel):
/// the result has that geometry and sample `n` equal to `op(a[n], b[n])`.
/// [`CsgError::GeometryMismatch`] otherwise.
pub fn combine_grids(
    a: &Grid,
    b: &Grid,
    op: impl Fn(f32, f32) -> f32 + Sync + Send,
) -> Result<Grid, CsgError> {
    check_same_geometry(a, b)?;
    let mut out = a.clone();
    out.data_mut()
        .par_iter_mut()
        .zip(b.data().par_iter())
        .for_each(|(o, &v)| *o = op(*o, v));
    Ok(out)
}

/// Union `min(a, b)` of two sampled fields on the same lattice, sample by sample (equal to
/// sampling [`Union`] of the two fields). [`CsgError::GeometryMismatch`] when the grids differ.
pub fn union_grids(a: &Grid, b: &Grid) -> Result<Grid, CsgError> {
    combine_grids(a, b, union)
}

/// Intersection `max(a, b)` of two sampled fields on the same lattice, sample by sample.
/// [`CsgError::GeometryMismatch`] when the grids differ.
pub fn intersection_grids(a: &Grid, b: &Grid) -> Result<Grid, CsgError> {
    combine_grids(a, b, intersection)
}

/// Difference `max(a, −b)` of two sampled fields on the same lattice, sample by sample.
/// [`CsgError::GeometryMismatch`] when the grids differ.
pub fn difference_grids(a: &Grid, b: &Grid) -> Result<Grid, CsgError> {
    combine_grids(a, b, difference)
}

/// Smooth union of two sampled fields with blend radius `k` (finite, `>= 0`), sample by
/// sample. [`CsgError`] on mismatched grids or a bad `k`.
pub fn smooth_union_grids(a: &Grid, b: &Grid, k: f32) -> Result<Grid, CsgError> {
    let k = check_blend_radius(k)?;
    combine_grids(a, b, |x, y| smooth_union(x, y, k))
}

/// Smooth intersection of two sampled fields with blend radius `k` (finite, `>= 0`).
/// [`CsgError`] on mismatched grids or a bad `k`.
pub fn smooth_intersection_grids(a: &Grid, b: &Grid, k: f32) -> Result<Grid, CsgError> {
    let k = check_blend_radius(k)?;
    combine_grids(a, b, |x, y| smooth_intersection(x, y, k))
}

/// Smooth difference of two sampled fields with blend radius `k` (finite, `>= 0`).
/// [`CsgError`] on mismatched grids or a bad `k`.
pub fn smooth_difference_grids(a: &Grid, b: &Grid, k: f32) -> Result<Grid, CsgError> {
    let k = check_blend_radius(k)?;
    combine_grids(a, b, |x, y| smooth_difference(x, y, k))
}

/// Complement `−a` of a sampled field.
pub fn complement_grid(a: &Grid) -> Grid {
    let mut out = a.clone();
    out.data_mut()
        .par_iter_mut()
        .for_each(|v| *v = complement(*v));
    out
}

/// Offset `a − r` of a sampled field (dilation for `r > 0`, erosion for `r < 0`; exactness as
/// for [`Offset`]): a plain shift of every sample, equal to sampling [`Offset`]. For an offset
/// followed by reinitialization to a distance (and for band-clamped inputs), use
/// [`crate::offset`]. [`CsgError::BadParameter`] when `r` is not finite.
pub fn offset_grid(a: &Grid, r: f32) -> Result<Grid, CsgError> {
    let r = check_offset(r)?;
    let mut out = a.clone();
    out.data_mut().par_iter_mut().for_each(|v| *v -= r);
    Ok(out)
}

// ---------------------------------------------------------------- brick grids

/// Applies `op` to corresponding samples of the virtual grids of two brick grids with the same
/// dimensions, origin and spacing, and keeps the bricks of the result that come within `band`
/// of zero (as [`BrickGrid::from_grid`]). The result has `a`'s brick size and apron and the
/// background `op(a.background(), b.background())`.
///
/// **Cost**: this goes through dense grids (`a.to_grid()`, `b.to_grid()` and the result),
/// so it takes time and memory of three dense grids of the virtual size, not of the stored
/// bricks; fine for moderate grids, wasteful for very sparse large ones. Samples are the
/// virtual grids' ([`BrickGrid::get`]: background where no brick is stored), so apron values
/// that a source brick held beyond its neighbours are not carried over.
/// [`CsgError::GeometryMismatch`] when the geometries differ, [`CsgError::Field`] when a dense
/// grid would be too large.
pub fn combine_brick_grids(
    a: &BrickGrid,
    b: &BrickGrid,
    band: f32,
    op: impl Fn(f32, f32) -> f32 + Sync + Send,
) -> Result<BrickGrid, CsgError> {
    let (ga, gb) = (
        GridGeometry::of_brick_grid(a),
        GridGeometry::of_brick_grid(b),
    );
    if ga != gb {
        return Err(CsgError::GeometryMismatch { a: ga, b: gb });
    }
    let background = op(a.background(), b.background());
    let dense = combine_grids(&a.to_grid()?, &b.to_grid()?, op)?;
    Ok(BrickGrid::from_grid(
        &dense,
        a.brick_size(),
        a.apron(),
        band,
        background,
    )?)
}

/// Union of two brick grids (see [`combine_brick_grids`] for the cost and the result's
/// layout): `min` sample by sample, keeping bricks within `band` of zero.
pub fn union_brick_grids(a: &BrickGrid, b: &BrickGrid, band: f32) -> Result<BrickGrid, CsgError> {
    combine_brick_grids(a, b, band, union)
}

/// Intersection of two brick grids (see [`combine_brick_grids`]): `max` sample by sample.
pub fn intersection_brick_grids(
    a: &BrickGrid,
    b: &BrickGrid,
    band: f32,
) -> Result<BrickGrid, CsgError> {
    combine_brick_grids(a, b, band, intersection)
}

/// Difference of two brick grids (see [`combine_brick_grids`]): `max(a, −b)` sample by sample.
pub fn difference_brick_grids(
    a: &BrickGrid,
    b: &BrickGrid,
    band: f32,
) -> Result<BrickGrid, CsgError> {
    combine_brick_grids(a, b, band, difference)
}

/// Offset `a − r` of a brick grid (background shifted too), keeping bricks within `band` of
/// zero; goes through a dense grid like [`combine_brick_grids`]. Note that a narrow band of
/// half-width `w` only describes the offset surface while `|r| < w`.
pub fn offset_brick_grid(a: &BrickGrid, r: f32, band: f32) -> Result<BrickGrid, CsgError> {
    let dense = offset_grid(&a.to_grid()?, r)?;
    Ok(BrickGrid::from_grid(
        &dense,
        a.brick_size(),
        a.apron(),
        band,
        a.background() - r,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::primitives::Sphere;
    use isokit_field::rng::SplitMix64;

    fn sphere(c: Vec3, r: f32) -> Sphere {
        Sphere::new(c, r).unwrap()
    }

    #[test]
    fn smooth_union_limits() {
        // Far apart: the sharp union; equal: k/4 below.
        assert_eq!(smooth_union(0.0, 2.0, 1.0), 0.0);
        assert_eq!(smooth_union(0.3, 0.3, 1.0), 0.3 - 0.25);
        assert_eq!(smooth_union(-1.0, 5.0, 0.0), -1.0);
        assert_eq!(smooth_intersection(0.3, 0.3, 1.0), 0.3 + 0.25);
        assert_eq!(smooth_difference(0.3, -0.3, 1.0), 0.3 + 0.25);
        // Infinite operands do not produce NaN.
        assert_eq!(smooth_union(f32::INFINITY, 1.0, 1.0), 1.0);
        assert_eq!(
            smooth_union(f32::INFINITY, f32::INFINITY, 1.0),
            f32::INFINITY
        );
    }

    #[test]
    fn blend_weights_match_finite_differences() {
        // d/da and d/db of the scalar blend against central differences.
        let mut rng = SplitMix64::new(7);
        for blend in [BLEND_UNION, BLEND_INTERSECTION, BLEND_DIFFERENCE] {
            for _ in 0..500 {
                let (a, b, k) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.8);
                let (wa, wb, _) = blend.weights(a, b, k);
                let e = 1e-3;
                let da = (blend.value(a + e, b, k) - blend.value(a - e, b, k)) / (2.0 * e);
                let db = (blend.value(a, b + e, k) - blend.value(a, b - e, k)) / (2.0 * e);
                // ∂s/∂a = o · ca · wa.
                let (ga, gb) = (blend.o * blend.ca * wa, blend.o * blend.cb * wb);
                let near_kink = ((blend.ca * a - blend.cb * b).abs() - k).abs() < 2.0 * e;
                if !near_kink {
                    assert!((da - ga).abs() < 2e-3, "{a} {b}: {da} vs {ga}");
                    assert!((db - gb).abs() < 2e-3, "{a} {b}: {db} vs {gb}");
                }
                assert!((0.0..=1.0).contains(&wa) && (0.0..=1.0).contains(&wb));
                assert!((wa + wb - 1.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn smooth_hessians_match_finite_differences() {
        let a = sphere(Vec3::new(-0.6, 0.0, 0.0), 1.0);
        let b = sphere(Vec3::new(0.7, 0.1, 0.0), 0.8);
        let fields: [Box<dyn Field>; 3] = [
            Box::new(SmoothUnion::new(a, b, 0.7).unwrap()),
            Box::new(SmoothIntersection::new(a, b, 0.7).unwrap()),
            Box::new(SmoothDifference::new(a, b, 0.7).unwrap()),
        ];
        let mut rng = SplitMix64::new(11);
        for f in &fields {
            let mut checked = 0;
            while checked < 40 {
                let p = rng.point_in(Vec3::splat(-1.5), Vec3::splat(1.5));
                let h = 1e-3;
                let fd = Mat3::from_cols(
                    (f.gradient(p + h * Vec3::X) - f.gradient(p - h * Vec3::X)) / (2.0 * h),
                    (f.gradient(p + h * Vec3::Y) - f.gradient(p - h * Vec3::Y)) / (2.0 * h),
                    (f.gradient(p + h * Vec3::Z) - f.gradient(p - h * Vec3::Z)) / (2.0 * h),
                );
                // Skip points near the sphere centres and the blend's edges (second
                // derivative jumps there).
                let (va, vb) = (a.value(p), b.value(p));
                let edge = [va - vb, va + vb]
                    .iter()
                    .any(|d| (d.abs() - 0.7).abs() < 0.02);
                if va < -0.8 || vb < -0.6 || edge {
                    continue;
                }
                let an = f.hessian(p);
                for c in 0..3 {
                    assert!(
                        (an.col(c) - fd.col(c)).length() < 2e-2,
                        "at {p}: {an} vs {fd}"
                    );
                }
                checked += 1;
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let a = sphere(Vec3::ZERO, 1.0);
        for k in [f32::NAN, -1.0, f32::INFINITY] {
            let e = SmoothUnion::new(a, a, k).unwrap_err();
            assert!(matches!(e, CsgError::BadParameter { .. }), "{e}");
        }
        assert!(Offset::new(a, f32::NAN).is_err());
        let e = UnionN::<Sphere>::new(vec![]).err().unwrap();
        assert_eq!(e, CsgError::NoOperands { op: "union" });
        assert!(IntersectionN::<Sphere>::new(vec![]).is_err());
        let g = Grid::new([2, 2, 2], Vec3::ZERO, 1.0).unwrap();
        assert!(offset_grid(&g, f32::INFINITY).is_err());
        assert!(smooth_union_grids(&g, &g, f32::NAN).is_err());
    }

    #[test]
    fn mismatch_message_names_both_geometries() {
        let a = Grid::new([2, 2, 2], Vec3::ZERO, 1.0).unwrap();
        let b = Grid::new([2, 2, 3], Vec3::ZERO, 1.0).unwrap();
        let msg = union_grids(&a, &b).unwrap_err().to_string();
        assert!(
            msg.contains("[2, 2, 2]") && msg.contains("[2, 2, 3]"),
            "{msg}"
        );
    }

    #[test]
    fn offset_bounds_cases() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        assert_eq!(offset_bounds(&b, 0.5, 1.0), b.expanded(0.5));
        assert_eq!(offset_bounds(&b, -0.5, 1.0), b.expanded(-0.5));
        assert_eq!(offset_bounds(&b, -0.5, 2.0), b.expanded(-0.25));
        assert_eq!(offset_bounds(&b, -0.5, 0.5), b.expanded(-0.5));
        assert_eq!(offset_bounds(&b, -0.5, f32::INFINITY), b);
        assert_eq!(offset_bounds(&b, -0.5, f32::NAN), b);
        // Far apart operands: the blend adds nothing along the separating axis.
        let c = Aabb::new(Vec3::new(9.0, -1.0, -1.0), Vec3::new(11.0, 1.0, 1.0));
        let s = smooth_union_bounds(&b, &c, 1.0);
        assert_eq!((s.min.x, s.max.x), (-1.0, 11.0));
    }
}
