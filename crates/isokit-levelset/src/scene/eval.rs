//! The compiled shape tree and its pruned evaluation.
//!
//! Every node answers two questions at a point `p`:
//!
//! - its lower bound: a cheap lower bound on its value from bounding boxes alone
//!   (an exact distance field is at least the distance to its box outside the box);
//! - its clamped value: its value "clamped to `±cap`": the returned `r` satisfies
//!   `clamp(r, −cap, cap) == clamp(f(p), −cap, cap)`, so it is exact wherever `|f| < cap`.
//!
//! Clamping lets operations skip work that cannot change the clamped result: a node whose
//! lower bound is already `≥ cap` is not evaluated at all (the bounding box prunes the
//! subtree); a union skips a child whose lower bound is above the best value so far; a
//! difference skips a subtrahend whose lower bound is above `−f_first` (the point lies
//! outside it, so it cannot cut). Sources such as meshes answer band-limited queries that
//! stop early beyond `cap`. With `cap = ∞` nothing is pruned and the value is the full
//! evaluation.

use crate::csg;
use glam::{DQuat, DVec3, Vec3};
use isokit_field::{Aabb, Field, filter::SampledField, primitives::Primitive};
use isokit_kdtree::{QueryStats, mesh::MeshSdf};
use isokit_points::PointSdf;
use std::sync::atomic::{AtomicU64, Ordering};

/// Query counters sharded by thread, so that counting does not make the threads fight over
/// one cache line.
struct Counter([Padded; SHARDS]);

const SHARDS: usize = 16;

#[repr(align(64))]
struct Padded(AtomicU64);

impl Counter {
    fn new() -> Self {
        Self(std::array::from_fn(|_| Padded(AtomicU64::new(0))))
    }
    fn add(&self) {
        let i = rayon::current_thread_index().unwrap_or(0) % SHARDS;
        self.0[i].0.fetch_add(1, Ordering::Relaxed);
    }
    fn get(&self) -> u64 {
        self.0.iter().map(|c| c.0.load(Ordering::Relaxed)).sum()
    }
    fn reset(&self) {
        self.0.iter().for_each(|c| c.0.store(0, Ordering::Relaxed));
    }
}

/// The field behind a source node.
pub(crate) enum SourceField {
    /// An analytic primitive (exact).
    Analytic(Primitive),
    /// A triangle mesh (exact, kd-tree). `box_bound`: the value outside the mesh's box is
    /// at least the distance to the box (true unless the sign comes from pseudonormals on a
    /// mesh that is not watertight and consistently oriented).
    Mesh { sdf: Box<MeshSdf>, box_bound: bool },
    /// A point cloud (partition of unity; approximate).
    Points(Box<PointSdf>),
    /// A sampled volume: `sign · (filter(p) − iso)` inside the volume's box, continued
    /// outside by adding the distance to the box.
    Volume {
        field: Box<SampledField>,
        iso: f32,
        sign: f32,
        /// A lower bound on `sign · (filter(p) − iso)` (the smallest sample, less the
        /// Catmull-Rom filter's undershoot).
        min: f32,
        /// A Lipschitz bound of the continued field, measured from the samples.
        lipschitz: f32,
    },
}

/// A source of the scene: a leaf that is queried, with its query counter.
pub struct Source {
    /// The node's path in the scene, e.g. `shape.difference[1].mesh`.
    pub node: String,
    /// The node's kind (`sphere`, `mesh`, …).
    pub kind: &'static str,
    pub(crate) field: SourceField,
    queries: Counter,
}

impl Source {
    pub(crate) fn new(node: String, kind: &'static str, field: SourceField) -> Self {
        Self {
            node,
            kind,
            field,
            queries: Counter::new(),
        }
    }

    /// How many times the source was evaluated since the last reset.
    pub fn queries(&self) -> u64 {
        self.queries.get()
    }

    pub(crate) fn reset(&self) {
        self.queries.reset();
    }

    /// Box holding the source's surface and interior.
    pub fn bounds(&self) -> Aabb {
        match &self.field {
            SourceField::Analytic(p) => p.bounds(),
            SourceField::Mesh { sdf, .. } => sdf.bounds(),
            SourceField::Points(s) => s.bounds(),
            // Outside the grid the value is the boundary value plus the distance to the
            // grid's box: it can stay negative up to `−min` away.
            SourceField::Volume { field, min, .. } => {
                field.grid().bounds().expanded((-min).max(0.0))
            }
        }
    }

    /// Lipschitz bound of the source's field.
    pub fn lipschitz(&self) -> f32 {
        match &self.field {
            SourceField::Analytic(p) => p.lipschitz(),
            SourceField::Mesh { sdf, .. } => sdf.lipschitz(),
            SourceField::Points(s) => s.lipschitz(),
            SourceField::Volume { lipschitz, .. } => *lipschitz,
        }
    }

    /// Lower bound on the value at `p` from the box alone (`−∞` when nothing is known).
    fn lower_bound(&self, p: Vec3) -> f32 {
        let outside_box = |b: Aabb| {
            if b.is_finite() && !b.contains(p) {
                b.distance(p)
            } else {
                f32::NEG_INFINITY
            }
        };
        match &self.field {
            // Exact distances: at least the distance to the box, outside it.
            SourceField::Analytic(s) => outside_box(s.bounds()),
            SourceField::Mesh { sdf, box_bound } => {
                if *box_bound {
                    outside_box(sdf.bounds())
                } else {
                    f32::NEG_INFINITY
                }
            }
            // The cloud's field is signed by the nearest samples' normals even far away:
            // nothing is known.
            SourceField::Points(_) => f32::NEG_INFINITY,
            SourceField::Volume { field, min, .. } => field.grid().bounds().distance(p) + min,
        }
    }

    fn eval(&self, p: Vec3, cap: f32) -> f32 {
        self.queries.add();
        match &self.field {
            SourceField::Analytic(s) => s.value(p),
            SourceField::Mesh { sdf, .. } => {
                let mut st = QueryStats::default();
                if cap.is_finite() {
                    sdf.signed_distance_band(p.as_dvec3(), f64::from(cap), &mut st) as f32
                } else {
                    sdf.value(p)
                }
            }
            SourceField::Points(s) => s.value(p),
            SourceField::Volume {
                field, iso, sign, ..
            } => {
                let b = field.grid().bounds();
                let q = p.clamp(b.min, b.max);
                sign * (field.value(q) - iso) + b.distance(p)
            }
        }
    }
}

/// Which smooth operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SmoothKind {
    Union,
    Intersection,
    Difference,
}

/// An operation of the compiled tree.
pub(crate) enum Op {
    Source(usize),
    Union(Vec<Compiled>),
    Intersection(Vec<Compiled>),
    Difference(Vec<Compiled>),
    Complement(Box<Compiled>),
    Smooth {
        kind: SmoothKind,
        k: f32,
        of: Vec<Compiled>,
    },
    Offset {
        by: f32,
        of: Box<Compiled>,
    },
    Shell {
        half: f32,
        of: Box<Compiled>,
    },
    Morph {
        t: f32,
        from: Box<Compiled>,
        to: Box<Compiled>,
    },
    Transform {
        /// World to local rotation (the inverse of the node's rotation).
        inv_rotation: DQuat,
        translation: DVec3,
        scale: f64,
        of: Box<Compiled>,
    },
}

/// A node of the compiled tree with its bounding box (holding the surface and interior,
/// and every point where the value is at most δ once grown by δ) and its Lipschitz bound.
pub(crate) struct Compiled {
    pub(crate) op: Op,
    pub(crate) bounds: Aabb,
    pub(crate) lipschitz: f32,
}

/// How far a smooth operation over `n` operands can move the value from the sharp one:
/// each of the `n − 1` folds of the quadratic blend moves it by at most `k/4`.
fn smooth_reach(k: f32, n: usize) -> f32 {
    0.25 * k * n.saturating_sub(1) as f32
}

/// NaN (e.g. `0 · ∞` in a blend of bounds) means nothing is known.
fn known(lb: f32) -> f32 {
    if lb.is_nan() { f32::NEG_INFINITY } else { lb }
}

impl Compiled {
    pub(crate) fn new(op: Op, sources: &[Source]) -> Self {
        let bounds = match &op {
            Op::Source(i) => sources[*i].bounds(),
            Op::Union(c) => c.iter().fold(Aabb::EMPTY, |b, c| b.union(&c.bounds)),
            Op::Intersection(c) => c
                .iter()
                .fold(Aabb::INFINITE, |b, c| b.intersection(&c.bounds)),
            Op::Difference(c) => c[0].bounds,
            Op::Complement(_) => Aabb::INFINITE,
            Op::Smooth { kind, k, of } => match kind {
                SmoothKind::Union => of
                    .iter()
                    .fold(Aabb::EMPTY, |b, c| b.union(&c.bounds))
                    .expanded(smooth_reach(*k, of.len())),
                SmoothKind::Intersection => of
                    .iter()
                    .fold(Aabb::INFINITE, |b, c| b.intersection(&c.bounds)),
                SmoothKind::Difference => of[0].bounds,
            },
            Op::Offset { by, of } => of.bounds.expanded(by.max(0.0)),
            Op::Shell { half, of } => of.bounds.expanded(*half),
            Op::Morph { t, from, to } => {
                if *t == 0.0 {
                    from.bounds
                } else if *t == 1.0 {
                    to.bounds
                } else if (0.0..=1.0).contains(t) {
                    from.bounds.union(&to.bounds)
                } else {
                    Aabb::INFINITE
                }
            }
            Op::Transform {
                inv_rotation,
                translation,
                scale,
                of,
            } => {
                if of.bounds.is_finite() && !of.bounds.is_empty() {
                    let rot = inv_rotation.inverse();
                    let corners = of
                        .bounds
                        .corners()
                        .map(|c| (rot * (c.as_dvec3() * *scale) + *translation).as_vec3());
                    Aabb::from_points(corners.iter())
                } else {
                    of.bounds
                }
            }
        };
        let lipschitz = match &op {
            Op::Source(i) => sources[*i].lipschitz(),
            Op::Union(c) | Op::Intersection(c) | Op::Difference(c) | Op::Smooth { of: c, .. } => {
                c.iter().map(|c| c.lipschitz).fold(0.0, f32::max)
            }
            Op::Complement(c)
            | Op::Offset { of: c, .. }
            | Op::Shell { of: c, .. }
            | Op::Transform { of: c, .. } => c.lipschitz,
            Op::Morph { t, from, to } => (1.0 - t).abs() * from.lipschitz + t.abs() * to.lipschitz,
        };
        Self {
            op,
            bounds,
            lipschitz,
        }
    }

    /// A lower bound on the node's value at `p` (`−∞` when nothing is known; never NaN).
    pub(crate) fn lower_bound(&self, p: Vec3, sources: &[Source]) -> f32 {
        known(self.lower_bound_raw(p, sources))
    }

    fn lower_bound_raw(&self, p: Vec3, sources: &[Source]) -> f32 {
        match &self.op {
            Op::Source(i) => sources[*i].lower_bound(p),
            Op::Union(c) => c
                .iter()
                .map(|c| c.lower_bound(p, sources))
                .fold(f32::INFINITY, f32::min),
            Op::Intersection(c) => c
                .iter()
                .map(|c| c.lower_bound(p, sources))
                .fold(f32::NEG_INFINITY, f32::max),
            Op::Difference(c) => c[0].lower_bound(p, sources),
            Op::Complement(_) => f32::NEG_INFINITY,
            Op::Smooth { kind, k, of } => match kind {
                SmoothKind::Union => {
                    of.iter()
                        .map(|c| c.lower_bound(p, sources))
                        .fold(f32::INFINITY, f32::min)
                        - smooth_reach(*k, of.len())
                }
                SmoothKind::Intersection => of
                    .iter()
                    .map(|c| c.lower_bound(p, sources))
                    .fold(f32::NEG_INFINITY, f32::max),
                SmoothKind::Difference => of[0].lower_bound(p, sources),
            },
            Op::Offset { by, of } => of.lower_bound(p, sources) - by,
            Op::Shell { half, of } => of.lower_bound(p, sources).max(0.0) - half,
            Op::Morph { t, from, to } => {
                if *t == 0.0 {
                    from.lower_bound(p, sources)
                } else if *t == 1.0 {
                    to.lower_bound(p, sources)
                } else if (0.0..=1.0).contains(t) {
                    (1.0 - t) * from.lower_bound(p, sources) + t * to.lower_bound(p, sources)
                } else {
                    f32::NEG_INFINITY
                }
            }
            Op::Transform {
                inv_rotation,
                translation,
                scale,
                of,
            } => {
                let q = local(p, *inv_rotation, *translation, *scale);
                (*scale as f32) * of.lower_bound(q, sources)
            }
        }
    }

    /// The value at `p`, exact where `|f| < cap` (see the module docs); the result lies in
    /// `[−cap, cap]`.
    pub(crate) fn eval(&self, p: Vec3, cap: f32, sources: &[Source]) -> f32 {
        if !p.is_finite() {
            return f32::NAN;
        }
        if cap.is_finite() && self.lower_bound(p, sources) >= cap {
            return cap;
        }
        self.eval_unchecked(p, cap, sources)
    }

    /// [`Compiled::eval`] without the node's own lower-bound test (for callers that just
    /// made it).
    fn eval_unchecked(&self, p: Vec3, cap: f32, sources: &[Source]) -> f32 {
        let v = match &self.op {
            Op::Source(i) => sources[*i].eval(p, cap),
            Op::Union(c) => union_pruned(c, p, cap, sources),
            Op::Intersection(c) => {
                let mut acc = f32::NEG_INFINITY;
                for c in c {
                    acc = csg::intersection(acc, c.eval(p, cap, sources));
                    if acc >= cap {
                        break;
                    }
                }
                acc
            }
            Op::Difference(c) => {
                let mut acc = c[0].eval(p, cap, sources);
                for b in &c[1..] {
                    if acc >= cap {
                        break;
                    }
                    // Outside `b` by more than `-acc`: `−f_b ≤ acc`, no cut.
                    if b.lower_bound(p, sources) >= -acc {
                        continue;
                    }
                    // `lb < −acc ≤ cap`: the child's own test would pass, skip it.
                    acc = csg::difference(acc, b.eval_unchecked(p, cap, sources));
                }
                acc
            }
            Op::Complement(c) => csg::complement(c.eval(p, cap, sources)),
            Op::Smooth { kind, k, of } => {
                // Children exact within `cap + reach + k` make the blend exact within `cap`:
                // a clamped child either lies `k` or more above the running value (and
                // does not enter the blend) or the running value already lies above
                // `cap + reach`, which the remaining folds cannot bring below `cap`.
                let inner = cap + smooth_reach(*k, of.len()) + k;
                let mut vals = of.iter().map(|c| c.eval(p, inner, sources));
                let first = vals.next().unwrap_or(f32::INFINITY);
                match kind {
                    SmoothKind::Union => vals.fold(first, |a, b| csg::smooth_union(a, b, *k)),
                    SmoothKind::Intersection => {
                        vals.fold(first, |a, b| csg::smooth_intersection(a, b, *k))
                    }
                    SmoothKind::Difference => {
                        vals.fold(first, |a, b| csg::smooth_difference(a, b, *k))
                    }
                }
            }
            Op::Offset { by, of } => of.eval(p, cap + by.abs(), sources) - by,
            Op::Shell { half, of } => of.eval(p, cap + half, sources).abs() - half,
            Op::Morph { t, from, to } => {
                // A blend can cancel large values of opposite sign, so the operands are
                // evaluated in full; the node's own lower bound still prunes.
                let a = from.eval(p, f32::INFINITY, sources);
                let b = to.eval(p, f32::INFINITY, sources);
                (1.0 - t) * a + t * b
            }
            Op::Transform {
                inv_rotation,
                translation,
                scale,
                of,
            } => {
                let q = local(p, *inv_rotation, *translation, *scale);
                let s = *scale as f32;
                s * of.eval(q, cap / s, sources)
            }
        };
        v.clamp(-cap, cap)
    }
}

/// Union visiting the children in order of their lower bounds and stopping once the next
/// bound is above the best value (or the cap).
fn union_pruned(children: &[Compiled], p: Vec3, cap: f32, sources: &[Source]) -> f32 {
    // A stack buffer for the common small unions; a heap one beyond.
    let mut small = [(0.0f32, 0usize); 8];
    let mut large = Vec::new();
    let order: &mut [(f32, usize)] = if children.len() <= small.len() {
        &mut small[..children.len()]
    } else {
        large.resize(children.len(), (0.0, 0));
        &mut large
    };
    for (i, (o, c)) in order.iter_mut().zip(children).enumerate() {
        *o = (c.lower_bound(p, sources), i);
    }
    order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut acc = f32::INFINITY;
    for &(lb, i) in order.iter() {
        if lb >= acc.min(cap) {
            break;
        }
        // `lb < cap`: the child's own test would pass, skip it.
        acc = csg::union(acc, children[i].eval_unchecked(p, cap, sources));
    }
    acc
}

/// World point to the transform node's local frame: `R⁻¹ (p − t) / s`.
fn local(p: Vec3, inv_rotation: DQuat, translation: DVec3, scale: f64) -> Vec3 {
    (inv_rotation * ((p.as_dvec3() - translation) / scale)).as_vec3()
}
