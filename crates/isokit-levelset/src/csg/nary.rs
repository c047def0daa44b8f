//! The n-ary combinators: union, intersection, difference and the smooth operations over any
//! number of operands, and the shell. Scenes compile to these.
//!
//! Besides their values they answer the two questions that lazy evaluation asks of every
//! field (see [`Field::lower_bound`] and [`Field::value_clamped`]): a cheap lower bound from
//! boxes, and the value clamped to `±cap`, which lets them skip work that cannot change the
//! clamped result:
//!
//! - a union visits its children in order of their lower bounds and stops once the next
//!   bound is above the best value so far (or the cap); a union of many children first tests
//!   groups of them by a bounding-volume hierarchy over their [`Field::distance_box`]es, so a
//!   union of 50,000 spheres costs about the children near the point;
//! - an intersection stops once its value reaches the cap;
//! - a difference skips every subtrahend the point lies outside of by more than the current
//!   value (it cannot cut there);
//! - the smooth operations evaluate their operands clamped to `cap` plus what the blends can
//!   move the value (`(n − 1)·k/4`) plus `k`, which keeps the blend exact within `cap`.
//!
//! With `cap = ∞` nothing is pruned but the union's bound test, which never changes a value.

use super::bvh::Bvh;
use super::{
    CsgError, blend_union_bounds, chamfer_difference, chamfer_intersection, chamfer_union,
    check_blend_radius, difference, intersection, lip_max, smooth_difference, smooth_intersection,
    smooth_union, stairs_difference, stairs_intersection, stairs_union, union,
};
use glam::{Mat3, Vec3};
use isokit_field::{Aabb, DistanceBox, Field, value_clamped};
use rayon::prelude::*;

/// NaN (e.g. `0 · ∞` in a bound) means nothing is known.
#[inline]
fn known(lb: f32) -> f32 {
    if lb.is_nan() { f32::NEG_INFINITY } else { lb }
}

fn check_nonempty<F>(children: &[F], op: &'static str) -> Result<(), CsgError> {
    if children.is_empty() {
        Err(CsgError::NoOperands { op })
    } else {
        Ok(())
    }
}

/// Index of the first child attaining the extremum (`better(x, best)` true means `x` wins).
fn arg_extreme<F: Field>(children: &[F], p: Vec3, better: impl Fn(f32, f32) -> bool) -> usize {
    let mut best = (0, children[0].value(p));
    for (i, c) in children.iter().enumerate().skip(1) {
        let v = c.value(p);
        if better(v, best.1) {
            best = (i, v);
        }
    }
    best.0
}

/// Batch evaluation folding the children's own `values`.
fn fold_values<F: Field>(
    children: &[F],
    points: &[Vec3],
    out: &mut [f32],
    op: impl Fn(f32, f32) -> f32 + Sync,
) {
    let n = points.len().min(out.len());
    let (points, out) = (&points[..n], &mut out[..n]);
    children[0].values(points, out);
    let mut tmp = vec![0.0; n];
    for c in &children[1..] {
        c.values(points, &mut tmp);
        out.par_iter_mut()
            .zip(tmp.par_iter())
            .for_each(|(o, &v)| *o = op(*o, v));
    }
}

fn lip_of<F: Field>(children: &[F]) -> f32 {
    children.iter().fold(0.0, |l, c| lip_max(l, c.lipschitz()))
}

fn fd_step_of<F: Field>(children: &[F], p: Vec3) -> f32 {
    children
        .iter()
        .map(|c| c.fd_step(p))
        .fold(f32::INFINITY, f32::min)
}

/// The distance box of a union of children: the union of theirs, `None` when one lacks it.
fn union_distance_box<F: Field>(children: &[F]) -> Option<DistanceBox> {
    let mut it = children.iter().map(|c| c.distance_box());
    let first = it.next()??;
    it.try_fold(first, |acc, d| Some(acc.union(&d?)))
}

/// The distance box of an intersection (at least each child's value): the smallest child's.
fn intersection_distance_box<F: Field>(children: &[F]) -> Option<DistanceBox> {
    children
        .iter()
        .filter_map(|c| c.distance_box())
        .filter(|d| d.aabb.is_finite() && !d.aabb.is_empty())
        .min_by(|a, b| {
            let v = |d: &DistanceBox| d.aabb.size().to_array().iter().product::<f32>();
            v(a).total_cmp(&v(b))
        })
}

// ---------------------------------------------------------------- union

/// Unions up to this many children order them by their lower bounds on the stack; larger
/// ones build a bounding-volume hierarchy over their distance boxes.
const SMALL_UNION: usize = 8;

/// Union of any number of fields: `min_i f_i`.
///
/// Same exactness as [`super::Union`] (exact outside with exact operands, a bound inside).
/// Bounds: the union of the operands' boxes. Lipschitz: the largest of the operands'.
/// Gradient and Hessian: those of the first operand that attains the minimum. Equal to the
/// left fold of [`super::Union`], value for value. Unions of more than a few children build a
/// bounding-volume hierarchy over the children's [`Field::distance_box`]es, so a point is
/// compared with the children near it only.
pub struct UnionN<F = Box<dyn Field>> {
    children: Vec<F>,
    bounds: Aabb,
    lipschitz: f32,
    dbox: Option<DistanceBox>,
    bvh: Option<Bvh>,
}

impl<F: Field> std::fmt::Debug for UnionN<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UnionN")
            .field("children", &self.children.len())
            .field("bounds", &self.bounds)
            .field("bvh", &self.bvh.is_some())
            .finish()
    }
}

impl<F: Field> UnionN<F> {
    /// The union of `children` ([`CsgError::NoOperands`] when there are none: the empty
    /// union would be `+∞` everywhere).
    pub fn new(children: Vec<F>) -> Result<Self, CsgError> {
        check_nonempty(&children, "union")?;
        let bounds = children
            .iter()
            .fold(Aabb::EMPTY, |b, c| b.union(&c.bounds()));
        let lipschitz = lip_of(&children);
        let dbox = union_distance_box(&children);
        let bvh = (children.len() > SMALL_UNION)
            .then(|| Bvh::build(children.iter().map(|c| c.distance_box()).collect()));
        Ok(Self {
            children,
            bounds,
            lipschitz,
            dbox,
            bvh,
        })
    }
    /// The operands.
    pub fn children(&self) -> &[F] {
        &self.children
    }
    /// Takes the operands back.
    pub fn into_children(self) -> Vec<F> {
        self.children
    }

    /// The pruned union (exact wherever `|f| < cap`; see the module docs).
    fn pruned(&self, p: Vec3, cap: f32) -> f32 {
        let acc = match &self.bvh {
            Some(bvh) => bvh.min(p, cap, |i, limit| {
                let c = &self.children[i];
                if known(c.lower_bound(p)) >= limit {
                    f32::INFINITY
                } else {
                    c.value_clamped(p, cap)
                }
            }),
            None => self.small(p, cap),
        };
        acc.clamp(-cap, cap)
    }

    /// Children in order of their lower bounds, stopping once the next bound is above the
    /// best value (or the cap).
    fn small(&self, p: Vec3, cap: f32) -> f32 {
        let mut order = [(0.0f32, 0usize); SMALL_UNION];
        let order = &mut order[..self.children.len()];
        for (i, (o, c)) in order.iter_mut().zip(&self.children).enumerate() {
            *o = (known(c.lower_bound(p)), i);
        }
        order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut acc = f32::INFINITY;
        for &(lb, i) in order.iter() {
            if lb >= acc.min(cap) {
                break;
            }
            // `lb < cap`: the child's own bound test would pass, skip it.
            acc = union(acc, self.children[i].value_clamped(p, cap));
        }
        acc
    }
}

impl<F: Field> Field for UnionN<F> {
    fn value(&self, p: Vec3) -> f32 {
        if self.bvh.is_some() {
            return self.pruned(p, f32::INFINITY);
        }
        self.children
            .iter()
            .map(|c| c.value(p))
            .reduce(union)
            .unwrap_or(f32::INFINITY)
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        if self.bvh.is_some() {
            out.par_iter_mut()
                .zip(points.par_iter())
                .for_each(|(o, &p)| *o = self.value(p));
        } else {
            fold_values(&self.children, points, out, union);
        }
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        fd_step_of(&self.children, p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let i = arg_extreme(&self.children, p, |x, best| x < best || best.is_nan());
        self.children[i].gradient(p)
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        let i = arg_extreme(&self.children, p, |x, best| x < best || best.is_nan());
        self.children[i].hessian(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.dbox
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        match &self.bvh {
            // The hierarchy's root: the union of the children's distance boxes.
            Some(bvh) => bvh.lower_bound(p),
            None => self
                .children
                .iter()
                .map(|c| known(c.lower_bound(p)))
                .fold(f32::INFINITY, f32::min),
        }
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.pruned(p, cap)
    }
}

// ---------------------------------------------------------------- intersection

/// Intersection of any number of fields: `max_i f_i`.
///
/// Same exactness as [`super::Intersection`] (exact inside with exact operands, a bound
/// outside). Bounds: the intersection of the operands' boxes. Lipschitz: the largest of the
/// operands'. Gradient and Hessian: those of the first operand that attains the maximum.
#[derive(Debug)]
pub struct IntersectionN<F = Box<dyn Field>> {
    children: Vec<F>,
    bounds: Aabb,
    lipschitz: f32,
    dbox: Option<DistanceBox>,
}

impl<F: Field> IntersectionN<F> {
    /// The intersection of `children` ([`CsgError::NoOperands`] when there are none: the
    /// empty intersection would be all of space).
    pub fn new(children: Vec<F>) -> Result<Self, CsgError> {
        check_nonempty(&children, "intersection")?;
        let bounds = children
            .iter()
            .fold(Aabb::INFINITE, |b, c| b.intersection(&c.bounds()));
        let lipschitz = lip_of(&children);
        let dbox = intersection_distance_box(&children);
        Ok(Self {
            children,
            bounds,
            lipschitz,
            dbox,
        })
    }
    /// The operands.
    pub fn children(&self) -> &[F] {
        &self.children
    }
    /// Takes the operands back.
    pub fn into_children(self) -> Vec<F> {
        self.children
    }
}

impl<F: Field> Field for IntersectionN<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.children
            .iter()
            .map(|c| c.value(p))
            .reduce(intersection)
            .unwrap_or(f32::NEG_INFINITY)
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        fold_values(&self.children, points, out, intersection);
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        fd_step_of(&self.children, p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let i = arg_extreme(&self.children, p, |x, best| x > best || best.is_nan());
        self.children[i].gradient(p)
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        let i = arg_extreme(&self.children, p, |x, best| x > best || best.is_nan());
        self.children[i].hessian(p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.dbox
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.children
            .iter()
            .map(|c| known(c.lower_bound(p)))
            .fold(f32::NEG_INFINITY, f32::max)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let mut acc = f32::NEG_INFINITY;
        for c in &self.children {
            acc = intersection(acc, value_clamped(c, p, cap));
            if acc >= cap {
                break;
            }
        }
        acc.clamp(-cap, cap)
    }
}

// ---------------------------------------------------------------- difference

/// A base field with any number of fields cut out of it: `max(f0, −f1, −f2, …)`.
///
/// Same exactness as [`super::Difference`] (exact inside with exact operands, a bound
/// outside). Bounds: the base's box. Lipschitz: the largest of all operands'. With nothing
/// to subtract it is the base itself. Gradient and Hessian: those of the active term.
#[derive(Debug)]
pub struct DifferenceN<A, F = Box<dyn Field>> {
    base: A,
    subtract: Vec<F>,
    lipschitz: f32,
}

impl<A: Field, F: Field> DifferenceN<A, F> {
    /// `base` minus every field of `subtract` (which may be empty).
    pub fn new(base: A, subtract: Vec<F>) -> Self {
        let lipschitz = lip_max(base.lipschitz(), lip_of(&subtract));
        Self {
            base,
            subtract,
            lipschitz,
        }
    }
    /// The base.
    pub fn base(&self) -> &A {
        &self.base
    }
    /// The fields cut out of the base.
    pub fn subtracted(&self) -> &[F] {
        &self.subtract
    }

    /// `None` when the base is active, else the index of the first active subtracted field.
    fn active(&self, p: Vec3) -> Option<usize> {
        let mut best = (None, self.base.value(p));
        for (i, c) in self.subtract.iter().enumerate() {
            let v = -c.value(p);
            if v > best.1 || best.1.is_nan() {
                best = (Some(i), v);
            }
        }
        best.0
    }
}

impl<A: Field, F: Field> Field for DifferenceN<A, F> {
    fn value(&self, p: Vec3) -> f32 {
        self.subtract
            .iter()
            .fold(self.base.value(p), |v, c| difference(v, c.value(p)))
    }
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        let n = points.len().min(out.len());
        let (points, out) = (&points[..n], &mut out[..n]);
        self.base.values(points, out);
        let mut tmp = vec![0.0; n];
        for c in &self.subtract {
            c.values(points, &mut tmp);
            out.par_iter_mut()
                .zip(tmp.par_iter())
                .for_each(|(o, &v)| *o = difference(*o, v));
        }
    }
    fn bounds(&self) -> Aabb {
        self.base.bounds()
    }
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        self.base.fd_step(p).min(fd_step_of(&self.subtract, p))
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        match self.active(p) {
            None => self.base.gradient(p),
            Some(i) => -self.subtract[i].gradient(p),
        }
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        match self.active(p) {
            None => self.base.hessian(p),
            Some(i) => -self.subtract[i].hessian(p),
        }
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        self.base.distance_box()
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.base.lower_bound(p)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let mut acc = self.base.value_clamped(p, cap);
        for b in &self.subtract {
            if acc >= cap {
                break;
            }
            // Outside `b` by more than `−acc`: `−f_b ≤ acc`, no cut.
            if known(b.lower_bound(p)) >= -acc {
                continue;
            }
            // `lb < −acc ≤ cap`: the child's own bound test would pass, skip it.
            acc = difference(acc, b.value_clamped(p, cap));
        }
        acc.clamp(-cap, cap)
    }
}

// ---------------------------------------------------------------- smooth, n-ary

/// Which smooth operation a [`SmoothN`] folds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SmoothKind {
    /// [`smooth_union`].
    Union,
    /// [`smooth_intersection`].
    Intersection,
    /// [`smooth_difference`]: the first operand minus the others.
    Difference,
}

/// The shape of the fillet where the operands of a [`SmoothN`] meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Blend {
    /// The quadratic polynomial smooth minimum ([`smooth_union`]): a round fillet of radius
    /// `k`, at most `k/4` from the sharp value.
    #[default]
    Round,
    /// hg_sdf's chamfer ([`chamfer_union`]): a 45° bevel of size `k`, at most `k/2` from the
    /// sharp value.
    Chamfer,
    /// hg_sdf's stairs ([`stairs_union`]) with this many steps over the size `k`, at most
    /// `k/2` from the sharp value.
    Stairs(u32),
}

impl Blend {
    /// How far one fold with radius `k` can move the value from the sharp operation.
    pub fn reach(self, k: f32) -> f32 {
        match self {
            Blend::Round => 0.25 * k,
            Blend::Chamfer | Blend::Stairs(_) => 0.5 * k,
        }
    }

    /// The difference of the operands beyond which a fold is the sharp operation.
    pub fn window(self, k: f32) -> f32 {
        k
    }

    fn union(self, a: f32, b: f32, k: f32) -> f32 {
        match self {
            Blend::Round => smooth_union(a, b, k),
            Blend::Chamfer => chamfer_union(a, b, k),
            Blend::Stairs(n) => stairs_union(a, b, k, n),
        }
    }

    fn intersection(self, a: f32, b: f32, k: f32) -> f32 {
        match self {
            Blend::Round => smooth_intersection(a, b, k),
            Blend::Chamfer => chamfer_intersection(a, b, k),
            Blend::Stairs(n) => stairs_intersection(a, b, k, n),
        }
    }

    fn difference(self, a: f32, b: f32, k: f32) -> f32 {
        match self {
            Blend::Round => smooth_difference(a, b, k),
            Blend::Chamfer => chamfer_difference(a, b, k),
            Blend::Stairs(n) => stairs_difference(a, b, k, n),
        }
    }
}

/// A blended operation folded over any number of operands from the left
/// (`op(op(op(f0, f1), f2), …)`), blend size `k`: the round fillet of the smooth minimum
/// (Quilez), or hg_sdf's chamfer or stairs ([`Blend`]).
///
/// A bound, never exact. Lipschitz: the largest of the operands' (the smooth minimum's
/// partial derivatives are convex weights, the chamfer's bevel term is halved so that
/// `|∇a + ∇b|/2 ≤ 1`, and the stairs' gradient is always one operand's). Bounds: for the
/// union, [`blend_union_bounds`] folded the same way; for the intersection, the
/// intersection of the boxes; for the difference, the first operand's box (neither is ever
/// below the sharp value). Gradient and Hessian: finite differences (the default).
#[derive(Debug)]
pub struct SmoothN<F = Box<dyn Field>> {
    kind: SmoothKind,
    blend: Blend,
    k: f32,
    children: Vec<F>,
    bounds: Aabb,
    lipschitz: f32,
}

impl<F: Field> SmoothN<F> {
    /// The `kind` fold of `children` with the round blend of radius `k` (finite and ≥ 0).
    /// Errors: no operands ([`CsgError::NoOperands`]) or a bad radius. One operand is the
    /// operand itself.
    pub fn new(kind: SmoothKind, k: f32, children: Vec<F>) -> Result<Self, CsgError> {
        Self::with_blend(kind, Blend::Round, k, children)
    }

    /// The `kind` fold of `children` with `blend` of size `k` (finite and ≥ 0).
    pub fn with_blend(
        kind: SmoothKind,
        blend: Blend,
        k: f32,
        children: Vec<F>,
    ) -> Result<Self, CsgError> {
        let op = match kind {
            SmoothKind::Union => "smooth union",
            SmoothKind::Intersection => "smooth intersection",
            SmoothKind::Difference => "smooth difference",
        };
        check_nonempty(&children, op)?;
        let k = check_blend_radius(k)?;
        let (reach, window) = (blend.reach(k), blend.window(k));
        let bounds = match kind {
            SmoothKind::Union => children[1..].iter().fold(children[0].bounds(), |b, c| {
                blend_union_bounds(&b, &c.bounds(), reach, window)
            }),
            SmoothKind::Intersection => children
                .iter()
                .fold(Aabb::INFINITE, |b, c| b.intersection(&c.bounds())),
            SmoothKind::Difference => children[0].bounds(),
        };
        let lipschitz = lip_of(&children);
        Ok(Self {
            kind,
            blend,
            k,
            children,
            bounds,
            lipschitz,
        })
    }
    /// The operation.
    pub fn kind(&self) -> SmoothKind {
        self.kind
    }
    /// The fillet's shape.
    pub fn blend(&self) -> Blend {
        self.blend
    }
    /// The blend radius.
    pub fn k(&self) -> f32 {
        self.k
    }
    /// The operands.
    pub fn children(&self) -> &[F] {
        &self.children
    }

    /// How far the whole fold can move the value from the sharp operation.
    fn reach(&self) -> f32 {
        self.blend.reach(self.k) * self.children.len().saturating_sub(1) as f32
    }

    /// The cap [`Field::value_clamped`] evaluates the operands with for a result clamped to
    /// `cap`: exact within it, an operand contributes nothing more (see `value_clamped`).
    /// Each fold adds its window and its reach: `cap + (n − 1)·(window + reach)`.
    pub fn child_cap(&self, cap: f32) -> f32 {
        let folds = self.children.len().saturating_sub(1) as f32;
        cap + folds * (self.blend.window(self.k) + self.blend.reach(self.k))
    }

    fn fold(&self, mut vals: impl Iterator<Item = f32>) -> f32 {
        let first = vals.next().unwrap_or(f32::INFINITY);
        let (k, b) = (self.k, self.blend);
        match self.kind {
            SmoothKind::Union => vals.fold(first, |x, y| b.union(x, y, k)),
            SmoothKind::Intersection => vals.fold(first, |x, y| b.intersection(x, y, k)),
            SmoothKind::Difference => vals.fold(first, |x, y| b.difference(x, y, k)),
        }
    }
}

impl<F: Field> Field for SmoothN<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.fold(self.children.iter().map(|c| c.value(p)))
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }
    fn fd_step(&self, p: Vec3) -> f32 {
        fd_step_of(&self.children, p)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        match self.kind {
            SmoothKind::Union => union_distance_box(&self.children).map(|d| DistanceBox {
                slack: d.slack + self.reach(),
                ..d
            }),
            SmoothKind::Intersection => intersection_distance_box(&self.children),
            SmoothKind::Difference => self.children[0].distance_box(),
        }
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = |c: &F| known(c.lower_bound(p));
        known(match self.kind {
            SmoothKind::Union => {
                self.children.iter().map(lb).fold(f32::INFINITY, f32::min) - self.reach()
            }
            SmoothKind::Intersection => self
                .children
                .iter()
                .map(lb)
                .fold(f32::NEG_INFINITY, f32::max),
            SmoothKind::Difference => lb(&self.children[0]),
        })
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        // Children exact within `C = cap + (n − 1)·(window + reach)` make the blend exact
        // within `cap` (for the union; the intersection and the difference mirror it). A
        // child clamped at `C` changes a fold only where the running value lies within a
        // window of `C`, and the changed value is then at least `C − window − reach`. A
        // later fold carries a change on only where the running value lies within a window
        // of the new operand, and then lowers it by at most `window + reach` (the fold is
        // at least the smaller operand less its reach). So a change that reaches the result
        // leaves it, computed and true alike, at `cap` or above, where both are clamped to
        // `cap`. A child clamped at `−C` makes both values `−C` or below: clamped to `−cap`.
        let inner = self.child_cap(cap);
        self.fold(self.children.iter().map(|c| value_clamped(c, p, inner)))
            .clamp(-cap, cap)
    }
}

// ---------------------------------------------------------------- shell

/// A hollow shell of thickness `2h` around the surface: `|f| − h`.
///
/// With an exact operand it is exact (the distance to the shell's two surfaces); with a
/// bound, a bound. Bounds: the operand's box grown by `h`. Lipschitz: the operand's.
/// Gradient and Hessian: the operand's, negated inside.
#[derive(Debug)]
pub struct Shell<A> {
    a: A,
    half: f32,
}

impl<A: Field> Shell<A> {
    /// The shell of wall thickness `thickness` (finite, > 0) around `a`'s surface.
    pub fn new(a: A, thickness: f32) -> Result<Self, CsgError> {
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(CsgError::BadParameter {
                name: "thickness",
                value: thickness,
                why: "must be finite and > 0",
            });
        }
        Ok(Self {
            a,
            half: 0.5 * thickness,
        })
    }
    /// The operand.
    pub fn operand(&self) -> &A {
        &self.a
    }
    /// Half the wall thickness.
    pub fn half_thickness(&self) -> f32 {
        self.half
    }
}

impl<A: Field> Field for Shell<A> {
    fn value(&self, p: Vec3) -> f32 {
        self.a.value(p).abs() - self.half
    }
    fn bounds(&self) -> Aabb {
        self.a.bounds().expanded(self.half)
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
        let g = self.a.gradient(p);
        if self.a.value(p) < 0.0 { -g } else { g }
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        let h = self.a.hessian(p);
        if self.a.value(p) < 0.0 { -h } else { h }
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        // |f| − h ≥ f − h.
        self.a.distance_box().map(|d| DistanceBox {
            slack: d.slack + self.half,
            ..d
        })
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        known(self.a.lower_bound(p).max(0.0) - self.half)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        (value_clamped(&self.a, p, cap + self.half).abs() - self.half).clamp(-cap, cap)
    }
}
