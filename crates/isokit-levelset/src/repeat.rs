//! Repetition: copies of a field on a lattice ([`Repeat`]: infinite along chosen axes, or a
//! finite array) and about an axis ([`CircularArray`]).
//!
//! The value is the union (minimum) of all copies, found exactly as Quilez describes for
//! domain repetition ("domain repetition", 2023): evaluating only the copy in the point's
//! own cell is wrong whenever a neighbour's copy is nearer (a shape off-centre in its cell,
//! or larger than it), so the neighbouring copies are visited too, each only when its
//! distance box (`f ≥ dist(p, box) − slack`, [`Field::distance_box`]) does not already rule it
//! out. The search is therefore exact for the union whatever the shape's size; the union of
//! exact copies is exact when the copies do not overlap (each shape smaller than its cell,
//! [`Field::is_exact`] checks it on the bounds) and otherwise a bound inside, as every union.
//! Lipschitz: the operand's.

use crate::csg::CsgError;
use glam::{DVec3, Vec3};
use isokit_field::{Aabb, DistanceBox, Field, value_clamped};

fn bad(name: &'static str, value: f32, why: &'static str) -> CsgError {
    CsgError::BadParameter { name, value, why }
}

/// The most copies a finite array may have.
pub const MAX_COPIES: u64 = 1 << 24;

/// The most copies a single evaluation may visit before it gives up pruning and reports
/// the bound it has (only reached by operands far larger than their cells).
const MAX_VISITS: usize = 1 << 16;

/// Copies of a field on a lattice: copy `i` (an integer vector) is the operand moved by
/// `i ⊙ period`, with `i` in a box of indices per axis (unbounded for infinite repetition,
/// `0..count` for an array). Axes with period 0 hold one copy.
///
/// Value: `min_i f(p − i ⊙ period)` over every copy whose box is nearer than the best value
/// so far (see the module docs). Exact when the operand is exact and, along every repeated
/// axis, its bounds are narrower than the period; a bound otherwise. Bounds: the union of
/// the copies' boxes (unbounded along infinitely repeated axes). The operand needs a
/// distance box (every bounded primitive and CSG of them has one); a finite array of an
/// operand without one visits every copy.
#[derive(Clone, Debug)]
pub struct Repeat<F> {
    inner: F,
    period: DVec3,
    /// Index range per axis (inclusive); `i64::MIN/MAX` for unbounded.
    lo: [i64; 3],
    hi: [i64; 3],
    dbox: Option<DistanceBox>,
    bounds: Aabb,
    exact: bool,
}

impl<F: Field> Repeat<F> {
    /// `inner` repeated forever with `period` along each axis (finite, ≥ 0; 0 leaves the axis
    /// alone, at least one must be > 0). The operand must have a finite distance box along
    /// the repeated axes.
    pub fn infinite(inner: F, period: Vec3) -> Result<Self, CsgError> {
        if !(period.is_finite() && period.cmpge(Vec3::ZERO).all() && period.max_element() > 0.0) {
            return Err(bad(
                "period",
                period.min_element(),
                "every component must be finite and >= 0, and one > 0",
            ));
        }
        let rep = period.cmpgt(Vec3::ZERO);
        let mut lo = [0i64; 3];
        let mut hi = [0i64; 3];
        for a in 0..3 {
            if rep.test(a) {
                lo[a] = i64::MIN / 4;
                hi[a] = i64::MAX / 4;
            }
        }
        let dbox = inner.distance_box();
        let ok = dbox.is_some_and(|d| {
            d.slack.is_finite()
                && !d.aabb.is_empty()
                && (0..3).all(|a| {
                    !rep.test(a) || (d.aabb.min[a].is_finite() && d.aabb.max[a].is_finite())
                })
        });
        if !ok {
            return Err(bad(
                "period",
                period.max_element(),
                "repeat needs an operand bounded along the repeated axes (with a known distance box)",
            ));
        }
        Self::build(inner, period.as_dvec3(), lo, hi, dbox)
    }

    /// A finite array: `count[a]` copies (≥ 1) `spacing[a]` apart (finite) along each axis,
    /// the first at the operand's place (copy `i` moved by `i ⊙ spacing`), at most
    /// [`MAX_COPIES`] in all.
    pub fn array(inner: F, count: [u32; 3], spacing: Vec3) -> Result<Self, CsgError> {
        if !spacing.is_finite() {
            return Err(bad("spacing", spacing.max_element(), "must be finite"));
        }
        if count.contains(&0) {
            return Err(bad("count", 0.0, "every count must be at least 1"));
        }
        let total: u64 = count.iter().map(|&c| c as u64).product();
        if total > MAX_COPIES {
            return Err(bad(
                "count",
                total as f32,
                "an array may hold at most 2^24 copies",
            ));
        }
        // Negative spacings run the other way: normalise to a positive period and a shifted
        // index range.
        let mut lo = [0i64; 3];
        let mut hi = [0i64; 3];
        let mut period = spacing.as_dvec3();
        for a in 0..3 {
            let n = count[a] as i64 - 1;
            if period[a] < 0.0 {
                period[a] = -period[a];
                lo[a] = -n;
            } else {
                hi[a] = n;
            }
            if period[a] == 0.0 {
                lo[a] = 0;
                hi[a] = 0;
            }
        }
        let dbox = inner.distance_box();
        Self::build(inner, period, lo, hi, dbox)
    }

    fn build(
        inner: F,
        period: DVec3,
        lo: [i64; 3],
        hi: [i64; 3],
        dbox: Option<DistanceBox>,
    ) -> Result<Self, CsgError> {
        let b = inner.bounds();
        let exact = inner.is_exact()
            && dbox.is_some()
            && (0..3).all(|a| lo[a] == hi[a] || ((b.max[a] - b.min[a]) as f64) < period[a]);
        let mut s = Self {
            inner,
            period,
            lo,
            hi,
            dbox,
            bounds: b,
            exact,
        };
        s.bounds = s.span(&b);
        Ok(s)
    }

    /// The box holding every copy of `b` (unbounded along infinitely repeated axes).
    fn span(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        let (mut min, mut max) = (b.min, b.max);
        for a in 0..3 {
            if self.lo[a] == self.hi[a] {
                continue;
            }
            if self.lo[a] == i64::MIN / 4 {
                min[a] = f32::NEG_INFINITY;
                max[a] = f32::INFINITY;
            } else {
                let (l, h) = (
                    self.lo[a] as f64 * self.period[a],
                    self.hi[a] as f64 * self.period[a],
                );
                min[a] = ((b.min[a] as f64 + l) as f32).next_down();
                max[a] = ((b.max[a] as f64 + h) as f32).next_up();
            }
        }
        Aabb::new(min, max)
    }

    /// The operand.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// Per axis, the gap from `p` to the nearest copy's box interval and that copy's index
    /// (the operand's box `[bl, bh]`, copies at `i · period`).
    #[inline]
    fn nearest(&self, p: DVec3, bl: DVec3, bh: DVec3) -> (DVec3, [i64; 3]) {
        let mut gap = DVec3::ZERO;
        let mut idx = [0i64; 3];
        for a in 0..3 {
            let per = self.period[a];
            let i = if self.lo[a] == self.hi[a] || per == 0.0 {
                self.lo[a]
            } else {
                let c = 0.5 * (bl[a] + bh[a]);
                (((p[a] - c) / per).round() as i64).clamp(self.lo[a], self.hi[a])
            };
            let off = i as f64 * per;
            gap[a] = (bl[a] + off - p[a]).max(p[a] - (bh[a] + off)).max(0.0);
            idx[a] = i;
        }
        (gap, idx)
    }

    /// The union over the copies, clamped to `±cap` (`cap = ∞`: the value).
    fn eval(&self, p: Vec3, cap: f32) -> f32 {
        let pd = p.as_dvec3();
        let local = |i: [i64; 3]| -> Vec3 {
            let off = DVec3::new(
                i[0] as f64 * self.period.x,
                i[1] as f64 * self.period.y,
                i[2] as f64 * self.period.z,
            );
            (pd - off).as_vec3()
        };
        let Some(d) = self.dbox else {
            // No distance box: every copy (finite arrays only), pruned by its lower bound.
            let mut best = f32::INFINITY;
            for i in self.lo[0]..=self.hi[0] {
                for j in self.lo[1]..=self.hi[1] {
                    for k in self.lo[2]..=self.hi[2] {
                        let q = local([i, j, k]);
                        if self.inner.lower_bound(q) < best.min(cap) {
                            best = best.min(value_clamped(&self.inner, q, cap));
                        }
                    }
                }
            }
            return best.clamp(-cap, cap);
        };
        let (bl, bh) = (d.aabb.min.as_dvec3(), d.aabb.max.as_dvec3());
        let slack = d.slack as f64;
        let (_, i0) = self.nearest(pd, bl, bh);
        let mut best = value_clamped(&self.inner, local(i0), cap);
        // Index ranges whose boxes come within the limit along each axis (supersets as
        // `best` shrinks); a box holding `p` bounds nothing (gap 0 is always visited).
        let lim = (best.min(cap) as f64).max(0.0) + slack;
        if !lim.is_finite() {
            return best.clamp(-cap, cap);
        }
        let mut range = [(0i64, 0i64); 3];
        for a in 0..3 {
            let per = self.period[a];
            range[a] = if self.lo[a] == self.hi[a] || per == 0.0 {
                (self.lo[a], self.lo[a])
            } else {
                let l = ((pd[a] - lim - bh[a]) / per).floor() as i64;
                let h = ((pd[a] + lim - bl[a]) / per).ceil() as i64;
                (l.max(self.lo[a]), h.min(self.hi[a]))
            };
        }
        let mut visits = 0usize;
        for i in range[0].0..=range[0].1 {
            for j in range[1].0..=range[1].1 {
                for k in range[2].0..=range[2].1 {
                    let idx = [i, j, k];
                    if idx == i0 {
                        continue;
                    }
                    let off = DVec3::new(
                        i as f64 * self.period.x,
                        j as f64 * self.period.y,
                        k as f64 * self.period.z,
                    );
                    let gap = (bl + off - pd).max(pd - (bh + off)).max(DVec3::ZERO);
                    let g = gap.length();
                    if g > 0.0 && g - slack >= best.min(cap) as f64 {
                        continue;
                    }
                    visits += 1;
                    if visits > MAX_VISITS {
                        // Only operands far larger than their cells get here: the union so
                        // far is an upper bound; report the smaller of it and the lower bound
                        // of what is left, which keeps the value a bound.
                        let lb = (self.lower_bound(p)).min(best);
                        return lb.clamp(-cap, cap);
                    }
                    let q = (pd - off).as_vec3();
                    if self.inner.lower_bound(q) >= best.min(cap) {
                        continue;
                    }
                    best = best.min(value_clamped(&self.inner, q, cap));
                }
            }
        }
        best.clamp(-cap, cap)
    }
}

impl<F: Field> Field for Repeat<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.eval(p, f32::INFINITY)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.inner.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.exact
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        let d = self.dbox?;
        if (0..3).any(|a| self.lo[a] == i64::MIN / 4) {
            return None;
        }
        Some(DistanceBox {
            aabb: self.span(&d.aabb),
            slack: d.slack,
        })
    }
    /// The distance to the union of the copies' boxes (a product of per-axis unions of
    /// intervals) less the slack.
    fn lower_bound(&self, p: Vec3) -> f32 {
        let Some(d) = self.dbox else {
            return f32::NEG_INFINITY;
        };
        let (gap, _) = self.nearest(p.as_dvec3(), d.aabb.min.as_dvec3(), d.aabb.max.as_dvec3());
        if gap == DVec3::ZERO {
            return f32::NEG_INFINITY;
        }
        let lb = ((gap.length() - d.slack as f64) * (1.0 - 1e-7)) as f32;
        if lb.is_nan() { f32::NEG_INFINITY } else { lb }
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.eval(p, cap)
    }
}

// ---------------------------------------------------------------- circular array

/// The most copies a circular array may have.
pub const MAX_RING: u32 = 1 << 16;

/// `count` copies of a field rotated by `360°/count` about an axis through the origin (copy
/// `j` turned by `j · 360°/count`, right-handed; copy 0 in place).
///
/// Value: the union of the copies, visiting the copy of the point's own sector first and
/// then the neighbouring sectors outward, each only when the wedge holding its box is near
/// enough (a point at radius `ρ` and angle `γ` beyond a wedge is at least `ρ sin(min(γ, 90°))`
/// from it) and its own lower bound allows (Quilez's neighbouring-cell evaluation, in angle).
/// Exact when the operand is exact and its box, seen from the axis, spans less than one
/// sector (and does not contain the axis); a bound otherwise. Bounds: the box of the
/// rotated boxes.
#[derive(Clone, Debug)]
pub struct CircularArray<F> {
    inner: F,
    count: u32,
    e1: DVec3,
    e2: DVec3,
    axis: DVec3,
    /// Central angle and half-width of the wedge holding the operand's box; `None` when the
    /// box contains the axis (every copy is visited).
    wedge: Option<(f64, f64)>,
    slack: f64,
    /// The box of the rotated distance boxes, with the operand's slack.
    ring_dbox: Option<DistanceBox>,
    bounds: Aabb,
    exact: bool,
}

impl<F: Field> CircularArray<F> {
    /// `count` (1 to [`MAX_RING`]) copies of `inner` about `axis` (finite, nonzero).
    pub fn new(inner: F, count: u32, axis: Vec3) -> Result<Self, CsgError> {
        if !(1..=MAX_RING).contains(&count) {
            return Err(bad("count", count as f32, "must be 1 to 65536"));
        }
        let a = axis.as_dvec3();
        let m = a.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return Err(bad("axis", axis.length(), "must be finite and nonzero"));
        }
        let a = (a / m).normalize();
        let (e1, e2) = if a == DVec3::Z {
            (DVec3::X, DVec3::Y)
        } else {
            let e1 = a.any_orthonormal_vector();
            (e1, a.cross(e1))
        };
        // About the z axis, a box unbounded in z only (a 2D profile's, z-invariant) turns
        // within its z range: the ring is computed on its xy-extent at z = 0, then the z range
        // is put back.
        let about_z = a == DVec3::Z;
        let xy_finite = |b: &Aabb| {
            about_z
                && !b.is_empty()
                && [b.min.x, b.min.y, b.max.x, b.max.y]
                    .iter()
                    .all(|v| v.is_finite())
        };
        let flat = |b: &Aabb| -> (Aabb, Option<(f32, f32)>) {
            if !b.is_finite() && xy_finite(b) {
                let lo = Vec3::new(b.min.x, b.min.y, 0.0);
                let hi = Vec3::new(b.max.x, b.max.y, 0.0);
                (Aabb::new(lo, hi), Some((b.min.z, b.max.z)))
            } else {
                (*b, None)
            }
        };
        let dbox = inner
            .distance_box()
            .map(|d| DistanceBox {
                aabb: flat(&d.aabb).0,
                slack: d.slack,
            })
            .filter(|d| d.aabb.is_finite() && !d.aabb.is_empty() && d.slack.is_finite());
        let sector = std::f64::consts::TAU / count as f64;
        // The wedge of the box's corners seen from the axis (a convex box's angular extent is
        // its corners'), unless the box surrounds the axis.
        let wedge = dbox.and_then(|d| {
            let pts: Vec<(f64, f64)> = d
                .aabb
                .corners()
                .iter()
                .map(|c| {
                    let c = c.as_dvec3();
                    (c.dot(e1), c.dot(e2))
                })
                .collect();
            let (cx, cy) = pts.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
            let centre = cy.atan2(cx);
            let mut half = 0.0f64;
            for &(x, y) in &pts {
                if x == 0.0 && y == 0.0 {
                    return None;
                }
                let rel = (y.atan2(x) - centre + std::f64::consts::PI)
                    .rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                half = half.max(rel.abs());
            }
            // The projected box surrounds the axis when the corners span half a turn or more.
            (half < 0.5 * std::f64::consts::PI * 0.999).then_some((centre, half))
        });
        let ring = |b: &Aabb| -> Aabb {
            if !b.is_finite() || b.is_empty() {
                return Aabb::INFINITE;
            }
            let mut lo = DVec3::INFINITY;
            let mut hi = DVec3::NEG_INFINITY;
            for j in 0..count {
                let (s, c) = (j as f64 * sector).sin_cos();
                for corner in b.corners() {
                    let p = corner.as_dvec3();
                    let (x, y, z) = (p.dot(e1), p.dot(e2), p.dot(a));
                    let w = e1 * (c * x - s * y) + e2 * (s * x + c * y) + a * z;
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
            let pad = 1e-7 * lo.abs().max(hi.abs()).max_element();
            Aabb::new((lo - pad).as_vec3(), (hi + pad).as_vec3())
        };
        // `ring` of a box flattened by `flat`, with its z range put back.
        let ring_z = |b: &Aabb| -> Aabb {
            match flat(b) {
                (f, Some((z0, z1))) => {
                    let r = ring(&f);
                    Aabb::new(
                        Vec3::new(r.min.x, r.min.y, z0),
                        Vec3::new(r.max.x, r.max.y, z1),
                    )
                }
                (f, None) => ring(&f),
            }
        };
        let bounds = ring_z(&inner.bounds());
        let unbounded_z = inner
            .distance_box()
            .is_some_and(|d| flat(&d.aabb).1.is_some());
        let ring_dbox = dbox.map(|d| {
            let r = ring(&d.aabb);
            DistanceBox {
                aabb: if unbounded_z {
                    Aabb::new(
                        Vec3::new(r.min.x, r.min.y, f32::NEG_INFINITY),
                        Vec3::new(r.max.x, r.max.y, f32::INFINITY),
                    )
                } else {
                    r
                },
                slack: d.slack,
            }
        });
        let exact =
            inner.is_exact() && (count == 1 || wedge.is_some_and(|(_, h)| 2.0 * h < sector));
        Ok(Self {
            slack: dbox.map_or(0.0, |d| d.slack as f64),
            inner,
            count,
            e1,
            e2,
            axis: a,
            wedge,
            ring_dbox,
            bounds,
            exact,
        })
    }

    /// The operand.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// `p` turned back by copy `j`'s angle.
    #[inline]
    fn local(&self, p: DVec3, j: u32) -> Vec3 {
        let ang = -(j as f64) * std::f64::consts::TAU / self.count as f64;
        let (s, c) = ang.sin_cos();
        let (x, y, z) = (p.dot(self.e1), p.dot(self.e2), p.dot(self.axis));
        (self.e1 * (c * x - s * y) + self.e2 * (s * x + c * y) + self.axis * z).as_vec3()
    }

    fn eval(&self, p: Vec3, cap: f32) -> f32 {
        let pd = p.as_dvec3();
        let n = self.count;
        let Some((centre, half)) = self.wedge else {
            let mut best = f32::INFINITY;
            for j in 0..n {
                let q = self.local(pd, j);
                if self.inner.lower_bound(q) < best.min(cap) {
                    best = best.min(value_clamped(&self.inner, q, cap));
                }
            }
            return best.clamp(-cap, cap);
        };
        let sector = std::f64::consts::TAU / n as f64;
        let (x, y) = (pd.dot(self.e1), pd.dot(self.e2));
        let rho = x.hypot(y);
        let theta = y.atan2(x);
        let own = ((theta - centre) / sector).round().rem_euclid(n as f64) as u32 % n;
        let mut best = value_clamped(&self.inner, self.local(pd, own), cap);
        // The lower bound of copy j from its wedge.
        let wedge_lb = |j: u32| -> f64 {
            let c = centre + j as f64 * sector;
            let d = ((theta - c + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI)
                .abs();
            let gamma = d - half;
            if gamma <= 0.0 {
                // In the copy's wedge: its box may hold the point, nothing is known.
                return f64::NEG_INFINITY;
            }
            rho * gamma.min(0.5 * std::f64::consts::PI).sin() - self.slack
        };
        let (mut up, mut down) = (true, true);
        for step in 1..=(n / 2) {
            for (dir, alive) in [(1i64, &mut up), (-1i64, &mut down)] {
                if !*alive || (dir < 0 && 2 * step == n) {
                    continue;
                }
                let j = (own as i64 + dir * step as i64).rem_euclid(n as i64) as u32;
                let lb = wedge_lb(j);
                if lb >= best.min(cap) as f64 {
                    // Further copies this way are at least as far while the angle grows to a
                    // right angle; beyond it they all share the bound ρ − slack ≥ it.
                    *alive = false;
                    continue;
                }
                let q = self.local(pd, j);
                if self.inner.lower_bound(q) >= best.min(cap) {
                    continue;
                }
                best = best.min(value_clamped(&self.inner, q, cap));
            }
            if !up && !down {
                break;
            }
        }
        best.clamp(-cap, cap)
    }
}

impl<F: Field> Field for CircularArray<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.eval(p, f32::INFINITY)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.inner.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.exact
    }
    /// Each copy is at least the distance to its rotated distance box less the slack, so
    /// the union is at least the distance to the box of all of them.
    fn distance_box(&self) -> Option<DistanceBox> {
        self.ring_dbox
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        self.eval(p, cap)
    }
}
