//! Deformations of a field — [`Twist`], [`Bend`], [`Taper`], [`Elongate`] — each with its
//! distance bound derived, so that lazy evaluation and sphere tracing stay sound.
//!
//! A deformation moves the solid by a map `T`; evaluating the operand at `T⁻¹(p)` gives the
//! right solid but not a distance: where `T⁻¹` stretches space by a factor up to `L` the
//! slope of `f ∘ T⁻¹` is up to `L` times the operand's (Quilez, "distance functions":
//! twist and bend "are not distance preserving"; fogleman's `sdf` leaves them so). Here each
//! deformation:
//!
//! 1. bounds `L`, the largest singular value of the Jacobian of `T⁻¹`, over a **convex**
//!    region `K` that holds the deformed solid (a cylinder about the twist's axis, a
//!    truncated wedge for the bend);
//! 2. evaluates `f(T⁻¹(π_K(p))) / L`, `π_K` the projection onto `K` (1-Lipschitz because
//!    `K` is convex), which has the operand's slope everywhere;
//! 3. takes the larger of that and the signed distance to `K` (1-Lipschitz, negative on the
//!    solid), which changes no sign and keeps the value at least the distance to the
//!    bounding box outside it.
//!
//! A field with slope at most 1 is never larger than the distance to its zero set (the
//! zero set is the surface: the value rises from 0 at most as fast as one moves), so every
//! result is a distance bound with the right sign, Lipschitz constant `max(operand's, 1)`.
//! [`Elongate`] needs none of this: its map `p − clamp(p, −h, h)` is already 1-Lipschitz.
//!
//! | node | factor `L` of `T⁻¹` over `K` |
//! | --- | --- |
//! | twist, rate `k` (radians per unit), radius `R` of the operand about the axis | `kR/2 + √(1 + (kR/2)²)` |
//! | bend, rate `k`, inner radius `ρ₀ = 1/k − y_max`, half-angle `Θ` | `max(1, 1/(k ρ₀ cos Θ))` |
//! | taper, scale `s(z) = 1 + t z` over the operand's `z` range, radius `R` | `σ_max` of `[[1/s, 0, −u t/s], [0, 1/s, ·], [0, 0, 1]]` at `s_min`, `|u| ≤ R s_max/s_min` |
//! | elongate | 1 |

use crate::csg::CsgError;
use glam::{DVec2, DVec3, Vec3};
use isokit_field::{Aabb, DistanceBox, Field, value_clamped};

fn bad(name: &'static str, value: f32, why: &'static str) -> CsgError {
    CsgError::BadParameter { name, value, why }
}

/// `f32` box of an f64 box, rounded outward.
fn outward(lo: DVec3, hi: DVec3) -> Aabb {
    let down = |x: f64| {
        let y = x as f32;
        if (y as f64) > x { y.next_down() } else { y }
    };
    let up = |x: f64| {
        let y = x as f32;
        if (y as f64) < x { y.next_up() } else { y }
    };
    Aabb::new(
        Vec3::new(down(lo.x), down(lo.y), down(lo.z)),
        Vec3::new(up(hi.x), up(hi.y), up(hi.z)),
    )
}

/// An orthonormal frame whose third axis is a given direction.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AxisFrame {
    e1: DVec3,
    e2: DVec3,
    a: DVec3,
}

impl AxisFrame {
    fn new(axis: Vec3) -> Result<Self, CsgError> {
        let a = axis.as_dvec3();
        let m = a.abs().max_element();
        if !(m > 0.0 && m.is_finite()) {
            return Err(bad("axis", axis.length(), "must be finite and nonzero"));
        }
        let a = (a / m).normalize();
        // The identity frame for the z axis, so that z-aligned operations stay exact to the bit.
        if a == DVec3::Z {
            return Ok(Self {
                e1: DVec3::X,
                e2: DVec3::Y,
                a,
            });
        }
        let e1 = a.any_orthonormal_vector();
        Ok(Self {
            e1,
            e2: a.cross(e1),
            a,
        })
    }
    #[inline]
    fn local(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.dot(self.e1), p.dot(self.e2), p.dot(self.a))
    }
    #[inline]
    fn world(&self, u: DVec3) -> DVec3 {
        self.e1 * u.x + self.e2 * u.y + self.a * u.z
    }
    /// The largest distance from the axis and the axial range of a finite box.
    fn extent(&self, b: &Aabb) -> (f64, f64, f64) {
        let (mut r, mut lo, mut hi) = (0.0f64, f64::INFINITY, f64::NEG_INFINITY);
        for c in b.corners() {
            let u = self.local(c.as_dvec3());
            r = r.max(u.x.hypot(u.y));
            lo = lo.min(u.z);
            hi = hi.max(u.z);
        }
        (r, lo, hi)
    }
    /// The world box of the capped cylinder of radius `r` and axial range `[lo, hi]`.
    fn cylinder_box(&self, r: f64, lo: f64, hi: f64) -> Aabb {
        let e = r * (DVec3::ONE - self.a * self.a).max(DVec3::ZERO).powf(0.5);
        let (p, q) = (self.a * lo, self.a * hi);
        outward(p.min(q) - e, p.max(q) + e)
    }
}

/// A capped cylinder `{ρ ≤ r, lo ≤ z ≤ hi}` in frame coordinates: a convex region.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cylinder {
    r: f64,
    lo: f64,
    hi: f64,
}

impl Cylinder {
    /// The nearest point of the cylinder (the point itself inside).
    #[inline]
    fn project(&self, u: DVec3) -> DVec3 {
        let rho = u.x.hypot(u.y);
        let s = if rho > self.r { self.r / rho } else { 1.0 };
        DVec3::new(u.x * s, u.y * s, u.z.clamp(self.lo, self.hi))
    }
    /// The exact signed distance to the cylinder.
    #[inline]
    fn signed_distance(&self, u: DVec3) -> f64 {
        let mid = 0.5 * (self.lo + self.hi);
        let half = 0.5 * (self.hi - self.lo);
        let w = DVec2::new(u.x.hypot(u.y) - self.r, (u.z - mid).abs() - half);
        w.x.max(w.y).min(0.0) + w.max(DVec2::ZERO).length()
    }
}

/// The finite bounds of an operand, or an error naming the deformation.
fn finite_bounds(inner: &dyn Field, what: &'static str) -> Result<Aabb, CsgError> {
    let b = inner.bounds();
    if b.is_empty() || !b.is_finite() {
        return Err(CsgError::BadParameter {
            name: what,
            value: f32::INFINITY,
            why: "needs a bounded operand (its bound grows with the distance from the axis)",
        });
    }
    Ok(b)
}

/// `max(core, guard)` clamped: the shared last step.
#[inline]
fn guarded(core: f64, guard: f64) -> f32 {
    core.max(guard) as f32
}

// ---------------------------------------------------------------- twist

/// The operand twisted about an axis through the origin: the cross-section at height `z`
/// (along the axis) is turned by `rate · z` radians (right-handed), as fogleman's
/// `twist(k)` and Quilez's `opTwist`, but with the value divided by the twist's stretch
/// factor over the operand's cylinder so that it stays a distance bound.
///
/// With `R` the operand's largest distance from the axis (over its bounds), the inverse map
/// `p ↦ R_z(−k z) p` has the Jacobian `R(−kz) · [[1, 0, −k u_y], [0, 1, k u_x], [0, 0, 1]]`
/// whose largest singular value over the cylinder `ρ ≤ R` is
/// `L = kR/2 + √(1 + (kR/2)²)` (a shear of size `kR`). The value is
/// `max(f(T⁻¹ π(p)) / L, cyl(p))`, `π` the projection onto the capped cylinder that holds the
/// operand's bounds, `cyl` the signed distance to it (see the module docs): a bound, never
/// exact, Lipschitz `max(operand's, 1)`. Bounds: the cylinder's box.
#[derive(Clone, Debug)]
pub struct Twist<F> {
    inner: F,
    rate: f64,
    frame: AxisFrame,
    cyl: Cylinder,
    factor: f64,
    bounds: Aabb,
}

impl<F: Field> Twist<F> {
    /// `inner` twisted by `rate` radians per unit length (finite) about `axis` (finite,
    /// nonzero) through the origin. The operand must be bounded.
    pub fn new(inner: F, rate: f32, axis: Vec3) -> Result<Self, CsgError> {
        if !rate.is_finite() {
            return Err(bad("rate", rate, "must be finite"));
        }
        let frame = AxisFrame::new(axis)?;
        let b = finite_bounds(&inner, "twist")?;
        let (r, lo, hi) = frame.extent(&b);
        let kr = (rate as f64).abs() * r;
        let factor = 0.5 * kr + (1.0 + 0.25 * kr * kr).sqrt();
        Ok(Self {
            inner,
            rate: rate as f64,
            frame,
            cyl: Cylinder { r, lo, hi },
            factor,
            bounds: frame.cylinder_box(r, lo, hi),
        })
    }

    /// The stretch factor `L` the operand's values are divided by.
    pub fn factor(&self) -> f64 {
        self.factor
    }

    /// The operand.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// The operand's point for `p` and the signed distance to the cylinder.
    #[inline]
    fn local(&self, p: Vec3) -> (Vec3, f64) {
        let u = self.frame.local(p.as_dvec3());
        let guard = self.cyl.signed_distance(u);
        let v = self.cyl.project(u);
        let (s, c) = (-self.rate * v.z).sin_cos();
        let w = DVec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z);
        (self.frame.world(w).as_vec3(), guard)
    }
}

/// The `Field` of a map whose `local(p)` gives the operand's point and the guard, and whose
/// `factor` is the largest stretch over its region: the operand's value divided by it, with
/// the guard outside the region; pruned bounds likewise, and the box's bound beside them.
macro_rules! stretch_bounded_field {
    ($map:ident) => {
        impl<F: Field> Field for $map<F> {
            fn value(&self, p: Vec3) -> f32 {
                let (q, g) = self.local(p);
                guarded(self.inner.value(q) as f64 / self.factor, g)
            }
            fn bounds(&self) -> Aabb {
                self.bounds
            }
            fn lipschitz(&self) -> f32 {
                self.inner.lipschitz().max(1.0)
            }
            fn distance_box(&self) -> Option<DistanceBox> {
                Some(DistanceBox::exact(self.bounds))
            }
            fn lower_bound(&self, p: Vec3) -> f32 {
                let (q, g) = self.local(p);
                let lb = self.inner.lower_bound(q) as f64 / self.factor;
                let lb = if lb.is_nan() { f64::NEG_INFINITY } else { lb };
                // The box's bound as the default would give it, and the guard (≤ the value).
                let boxed = DistanceBox::exact(self.bounds).lower_bound(p);
                guarded(lb, g).max(boxed)
            }
            fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
                let (q, g) = self.local(p);
                let inner_cap = (cap as f64 * self.factor) as f32;
                let v = value_clamped(&self.inner, q, inner_cap) as f64 / self.factor;
                guarded(v, g).clamp(-cap, cap)
            }
        }
    };
}

stretch_bounded_field!(Twist);

// ---------------------------------------------------------------- bend

/// The operand bent in the xy-plane: its x axis becomes the arc of radius `1/k` through the
/// origin, centred at `(0, 1/k, 0)` (curving towards +y for `k > 0`, towards −y for
/// `k < 0`); the arc length along the bend is the operand's `x` and the radial depth is its
/// `y` (an isometric bend of the neutral fibre `y = 0`, not the shear of Quilez's
/// `opCheapBend`).
///
/// The inverse map takes `p` at radius `ρ` and angle `φ` about the centre to
/// `(φ/k, 1/k − ρ, z)`: radially it preserves lengths, tangentially it stretches by
/// `1/(kρ)`. The operand's `x` range `[x₀, x₁]` gives the angles `[k x₀, k x₁]` (half-angle
/// `Θ`, at most 90°, so the bend is at most 180°) and its `y` range the radii
/// `ρ ≥ ρ₀ = 1/k − y_max > 0`. The convex region `K` is that wedge cut by the chord of the
/// inner arc (`ρ cos(φ − φ_mid) ≥ ρ₀ cos Θ`), over which the stretch is at most
/// `L = max(1, 1/(k ρ₀ cos Θ))`; the value is
/// `max(f(T⁻¹ π_K(p)) / L, sd_K(p), box(p))` (see the module docs): a bound, never exact,
/// Lipschitz `max(operand's, 1)`. Bounds: the bent annular sector's box.
#[derive(Clone, Debug)]
pub struct Bend<F> {
    inner: F,
    /// `|k|` and the sign that flips y for `k < 0`.
    k: f64,
    flip: f64,
    /// The bisector's direction from the centre and the direction of increasing angle.
    mid: f64,
    dir: DVec2,
    perp: DVec2,
    half_angle: f64,
    /// Distance of the chord from the centre.
    chord: f64,
    factor: f64,
    bounds: Aabb,
}

/// Direction from the bend's centre at angle `φ` (φ = 0 points back at the origin).
#[inline]
fn bend_dir(phi: f64) -> DVec2 {
    DVec2::new(phi.sin(), -phi.cos())
}

impl<F: Field> Bend<F> {
    /// `inner` bent by `rate` radians per unit length (finite, nonzero). The operand must be
    /// bounded, lie on the near side of the centre (`y < 1/rate` for `rate > 0`) and span at
    /// most 180° of the bend (`rate · (x₁ − x₀) < π`).
    pub fn new(inner: F, rate: f32) -> Result<Self, CsgError> {
        if !(rate.is_finite() && rate != 0.0) {
            return Err(bad("rate", rate, "must be finite and nonzero"));
        }
        let b = finite_bounds(&inner, "bend")?;
        let k = (rate as f64).abs();
        let flip = if rate < 0.0 { -1.0 } else { 1.0 };
        let (y_lo, y_hi) = if flip > 0.0 {
            (b.min.y as f64, b.max.y as f64)
        } else {
            (-(b.max.y as f64), -(b.min.y as f64))
        };
        let rho_in = 1.0 / k - y_hi;
        let rho_out = 1.0 / k - y_lo;
        if rho_in.is_nan() || rho_in <= 0.0 {
            return Err(bad(
                "rate",
                rate,
                "bends the shape through the bend's centre (|rate| · y extent must stay below 1)",
            ));
        }
        let (phi0, phi1) = (k * b.min.x as f64, k * b.max.x as f64);
        let half_angle = 0.5 * (phi1 - phi0);
        if half_angle.is_nan() || half_angle >= 0.5 * std::f64::consts::PI - 1e-6 {
            return Err(bad(
                "rate",
                rate,
                "bends the shape by 180° or more (|rate| · x extent must stay below π); bend it in parts",
            ));
        }
        let mid = 0.5 * (phi0 + phi1);
        let chord = rho_in * half_angle.cos();
        let factor = (1.0 / (k * chord)).max(1.0);
        // The sector's box: its corners and the axis directions within its angles.
        let centre = DVec2::new(0.0, 1.0 / k);
        let mut lo = DVec2::INFINITY;
        let mut hi = DVec2::NEG_INFINITY;
        let mut add = |phi: f64| {
            for rho in [rho_in, rho_out] {
                let q = centre + rho * bend_dir(phi);
                lo = lo.min(q);
                hi = hi.max(q);
            }
        };
        add(phi0);
        add(phi1);
        for j in -4..=4 {
            let phi = j as f64 * 0.5 * std::f64::consts::PI;
            if phi > phi0 && phi < phi1 {
                add(phi);
            }
        }
        let (lo, hi) = if flip > 0.0 {
            (lo, hi)
        } else {
            (DVec2::new(lo.x, -hi.y), DVec2::new(hi.x, -lo.y))
        };
        let bounds = outward(
            DVec3::new(lo.x, lo.y, b.min.z as f64),
            DVec3::new(hi.x, hi.y, b.max.z as f64),
        );
        Ok(Self {
            inner,
            k,
            flip,
            mid,
            dir: bend_dir(mid),
            perp: DVec2::new(mid.cos(), mid.sin()),
            half_angle,
            chord,
            factor,
            bounds,
        })
    }

    /// The stretch factor `L` the operand's values are divided by.
    pub fn factor(&self) -> f64 {
        self.factor
    }

    /// The operand.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    /// Projection onto `K` and the signed distance to it, in (bisector, perpendicular)
    /// coordinates about the centre.
    fn project(&self, ab: DVec2) -> (DVec2, f64) {
        let (t, c) = (self.half_angle.tan(), self.half_angle.cos());
        let h = self.chord;
        let inside = ab.x >= h && ab.y.abs() <= ab.x * t;
        // Boundary pieces: the chord segment x = h, |y| ≤ h t, and the two rays from its ends
        // along the wedge's edges.
        let chord_pt = DVec2::new(h, ab.y.clamp(-h * t, h * t));
        let mut best = (ab - chord_pt).length_squared();
        let mut near = chord_pt;
        for sgn in [-1.0, 1.0] {
            let start = DVec2::new(h, sgn * h * t);
            let d = DVec2::new(c, sgn * self.half_angle.sin());
            let s = (ab - start).dot(d).max(0.0);
            let q = start + d * s;
            let dd = (ab - q).length_squared();
            if dd < best {
                best = dd;
                near = q;
            }
        }
        if inside {
            (ab, -best.sqrt())
        } else {
            (near, best.sqrt())
        }
    }

    /// The operand's point for `p` and the larger of the two guards (K and the box).
    fn local(&self, p: Vec3) -> (Vec3, f64) {
        let v = DVec2::new(p.x as f64, self.flip * p.y as f64 - 1.0 / self.k);
        let ab = DVec2::new(v.dot(self.dir), v.dot(self.perp));
        let (pk, sd) = self.project(ab);
        let rho = pk.length();
        let phi = self.mid + pk.y.atan2(pk.x);
        let q = Vec3::new(
            (phi / self.k) as f32,
            (self.flip * (1.0 / self.k - rho)) as f32,
            p.z,
        );
        (q, sd.max(self.bounds.signed_distance(p) as f64))
    }
}

impl<F: Field> Field for Bend<F> {
    fn value(&self, p: Vec3) -> f32 {
        let (q, g) = self.local(p);
        guarded(self.inner.value(q) as f64 / self.factor, g)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.inner.lipschitz().max(1.0)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        Some(DistanceBox::exact(self.bounds))
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        let (q, g) = self.local(p);
        let lb = self.inner.lower_bound(q) as f64 / self.factor;
        let lb = if lb.is_nan() { f64::NEG_INFINITY } else { lb };
        guarded(lb, g)
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let (q, g) = self.local(p);
        let inner_cap = (cap as f64 * self.factor) as f32;
        let v = value_clamped(&self.inner, q, inner_cap) as f64 / self.factor;
        guarded(v, g).clamp(-cap, cap)
    }
}

// ---------------------------------------------------------------- taper

/// The operand tapered along an axis through the origin: the cross-section at height `z`
/// (along the axis) is scaled by `s(z) = 1 + rate · z` about the axis (libfive's
/// `taper-xy-z` with a linear profile).
///
/// Over the operand's axial range `[z₀, z₁]` the scale lies in `[s_min, s_max]`
/// (`s_min > 0` is required) and the tapered solid lies in the capped cylinder `K` of
/// radius `R s_max` (`R` the operand's largest distance from the axis). The inverse map
/// `(x, y, z) ↦ (x/s, y/s, z)` has the Jacobian `[[1/s, 0, −u_x t/s], [0, 1/s, −u_y t/s],
/// [0, 0, 1]]` (`u = (x, y)/s`, `|u| ≤ R s_max/s_min` on `K`), whose largest singular value
/// is `√λ₊` with `λ₊ = (T + √(T² − 4a²))/2`, `T = a² + c² + 1`, `a = 1/s_min`,
/// `c = |t| R s_max / s_min²` (increasing in `a` and `c`). The value is
/// `max(f(T⁻¹ π_K(p)) / L, sd_K(p))`: a bound, never exact, Lipschitz `max(operand's, 1)`.
/// Bounds: `K`'s box.
#[derive(Clone, Debug)]
pub struct Taper<F> {
    inner: F,
    rate: f64,
    frame: AxisFrame,
    cyl: Cylinder,
    factor: f64,
    bounds: Aabb,
}

impl<F: Field> Taper<F> {
    /// `inner` tapered by `rate` per unit length (finite) along `axis` (finite, nonzero);
    /// the operand must be bounded and `1 + rate · z` positive over its axial range.
    pub fn new(inner: F, rate: f32, axis: Vec3) -> Result<Self, CsgError> {
        if !rate.is_finite() {
            return Err(bad("rate", rate, "must be finite"));
        }
        let frame = AxisFrame::new(axis)?;
        let b = finite_bounds(&inner, "taper")?;
        let (r, lo, hi) = frame.extent(&b);
        let t = rate as f64;
        let (s0, s1) = (1.0 + t * lo, 1.0 + t * hi);
        let (smin, smax) = (s0.min(s1), s0.max(s1));
        if smin.is_nan() || smin <= 1e-6 {
            return Err(bad(
                "rate",
                rate,
                "shrinks the shape to nothing within its height (1 + rate · z must stay > 0)",
            ));
        }
        let a = 1.0 / smin;
        let c = t.abs() * r * smax / (smin * smin);
        let tr = a * a + c * c + 1.0;
        let lam = 0.5 * (tr + (tr * tr - 4.0 * a * a).max(0.0).sqrt());
        let factor = lam.sqrt().max(1.0) * (1.0 + 1e-12);
        let cyl = Cylinder {
            r: r * smax,
            lo,
            hi,
        };
        Ok(Self {
            inner,
            rate: t,
            frame,
            cyl,
            factor,
            bounds: frame.cylinder_box(r * smax, lo, hi),
        })
    }

    /// The stretch factor `L` the operand's values are divided by.
    pub fn factor(&self) -> f64 {
        self.factor
    }

    /// The operand.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    #[inline]
    fn local(&self, p: Vec3) -> (Vec3, f64) {
        let u = self.frame.local(p.as_dvec3());
        let guard = self.cyl.signed_distance(u);
        let v = self.cyl.project(u);
        let s = 1.0 + self.rate * v.z;
        let w = DVec3::new(v.x / s, v.y / s, v.z);
        (self.frame.world(w).as_vec3(), guard)
    }
}

stretch_bounded_field!(Taper);

// ---------------------------------------------------------------- elongate

/// The operand cut at the three coordinate planes and its parts moved apart by `by` along
/// each axis (the gap filled by the cross-sections): `f(p − clamp(p, −h, h))`, `h = by/2`
/// (Quilez, "opElongate"). A capsule is an elongated sphere, a rounded box an elongated
/// smaller one.
///
/// The map `p ↦ p − clamp(p, −h, h)` is 1-Lipschitz (slope 0 or 1 per axis), so the value
/// has the operand's slope and is a distance bound with the right sign; exact for
/// `by = 0` (and for convex operands symmetric about the planes, not checked). Bounds and
/// distance box: the operand's, grown by `h` per axis.
#[derive(Clone, Debug)]
pub struct Elongate<F> {
    inner: F,
    h: Vec3,
    bounds: Aabb,
}

impl<F: Field> Elongate<F> {
    /// `inner` elongated by `by` (each component finite and ≥ 0).
    pub fn new(inner: F, by: Vec3) -> Result<Self, CsgError> {
        if !(by.is_finite() && by.cmpge(Vec3::ZERO).all()) {
            return Err(bad(
                "by",
                by.min_element(),
                "every component must be finite and >= 0",
            ));
        }
        let h = 0.5 * by;
        let b = inner.bounds();
        let bounds = if b.is_empty() {
            b
        } else {
            Aabb::new(b.min - h, b.max + h)
        };
        Ok(Self { inner, h, bounds })
    }

    /// The operand.
    pub fn inner(&self) -> &F {
        &self.inner
    }

    #[inline]
    fn local(&self, p: Vec3) -> Vec3 {
        p - p.clamp(-self.h, self.h)
    }
}

impl<F: Field> Field for Elongate<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.inner.value(self.local(p))
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.inner.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.h == Vec3::ZERO && self.inner.is_exact()
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let g = self.inner.gradient(self.local(p));
        let free = p.abs().cmpge(self.h);
        let g = Vec3::select(free, g, Vec3::ZERO);
        // Inside the slabs the operand's cross-section decides: keep the gradient unit.
        g.normalize_or(Vec3::Z)
    }
    fn distance_box(&self) -> Option<DistanceBox> {
        let d = self.inner.distance_box()?;
        if d.aabb.is_empty() {
            return Some(d);
        }
        Some(DistanceBox {
            aabb: Aabb::new(d.aabb.min - self.h, d.aabb.max + self.h),
            slack: d.slack,
        })
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.inner.lower_bound(self.local(p))
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        value_clamped(&self.inner, self.local(p), cap)
    }
}
