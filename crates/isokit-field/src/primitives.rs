//! Analytic primitives with exact signed distances (negative inside, positive outside).
//!
//! Every primitive here is an **exact** Euclidean signed distance field, inside and outside
//! ([`Field::is_exact`] is true, [`Field::lipschitz`] is 1): [`Sphere`], [`Cuboid`],
//! [`RoundedBox`], [`Torus`] (also the self-intersecting spindle torus, `minor > major`),
//! [`Capsule`], [`CappedCylinder`], [`CappedCone`], [`Plane`] and [`Ellipsoid`] (by
//! Eberly's robust root bisection, not the usual bound). [`Primitive`] wraps them all.
//!
//! Parameters and points are f32, but every evaluation converts the point to f64, keeps
//! the parameters in f64 and rounds once: the value is the exact distance of the given f32
//! point to the shape of the given f32 parameters, up to that final rounding and an f64
//! error of about `1e-15` times the coordinates' magnitude (so also at 1e-6 and 1e6 scale).
//!
//! [`Field::gradient`] is analytic and always a unit vector: `(p - closest) / d`, which is
//! the outward surface normal on the surface. Where it is undefined (the medial axis, e.g.
//! the centre of a sphere) some unit vector is returned, never NaN. Bounds are tight
//! boxes of the solid, rounded outward to f32. Constructors validate their parameters
//! (finite, positive radii, ...) and return [`FieldError::BadParameter`] instead of
//! panicking.

use crate::{Aabb, Field, FieldError};
use glam::{DMat3, DVec2, DVec3, Mat3, Vec3};

/// The f64 core every primitive implements; [`Field`] is derived from it.
trait Sdf64 {
    /// Exact signed distance.
    fn sd(&self, p: DVec3) -> f64;
    /// Unit gradient of [`Sdf64::sd`] (some unit vector where it is undefined).
    fn grad(&self, p: DVec3) -> DVec3;
    /// Tight bounds of the solid.
    fn aabb(&self) -> Aabb;
    /// Closed-form Hessian where one is written; `None` falls back to finite differences.
    fn hess(&self, _p: DVec3) -> Option<Mat3> {
        None
    }
}

macro_rules! field_from_sdf64 {
    ($($t:ty),*) => {$(
        impl Field for $t {
            fn value(&self, p: Vec3) -> f32 {
                self.sd(p.as_dvec3()) as f32
            }
            fn bounds(&self) -> Aabb {
                self.aabb()
            }
            fn lipschitz(&self) -> f32 {
                1.0
            }
            fn is_exact(&self) -> bool {
                true
            }
            fn gradient(&self, p: Vec3) -> Vec3 {
                self.grad(p.as_dvec3()).as_vec3()
            }
            fn hessian(&self, p: Vec3) -> Mat3 {
                self.hess(p.as_dvec3())
                    .unwrap_or_else(|| crate::finite_difference_hessian(self, p))
            }
            fn distance_box(&self) -> Option<crate::DistanceBox> {
                Some(crate::DistanceBox::exact(self.aabb()))
            }
        }
    )*};
}

// ---------------------------------------------------------------- parameter checks

fn finite3(name: &'static str, v: Vec3) -> Result<DVec3, FieldError> {
    if v.is_finite() {
        Ok(v.as_dvec3())
    } else {
        Err(FieldError::bad(name, v, "must be finite"))
    }
}

fn positive(name: &'static str, x: f32) -> Result<f64, FieldError> {
    if x.is_finite() && x > 0.0 {
        Ok(x as f64)
    } else {
        Err(FieldError::bad(name, x, "must be finite and > 0"))
    }
}

fn non_negative(name: &'static str, x: f32) -> Result<f64, FieldError> {
    if x.is_finite() && x >= 0.0 {
        Ok(x as f64)
    } else {
        Err(FieldError::bad(name, x, "must be finite and >= 0"))
    }
}

fn positive3(name: &'static str, v: Vec3) -> Result<DVec3, FieldError> {
    if v.is_finite() && v.cmpgt(Vec3::ZERO).all() {
        Ok(v.as_dvec3())
    } else {
        Err(FieldError::bad(
            name,
            v,
            "every component must be finite and > 0",
        ))
    }
}

// ---------------------------------------------------------------- small f64 helpers

/// `v / |v|`, robust to tiny and huge components; `fallback` when `v` is zero or not finite.
fn unit_or(v: DVec3, fallback: DVec3) -> DVec3 {
    let m = v.abs().max_element();
    if m > 0.0 && m.is_finite() {
        let w = v / m;
        w / w.length()
    } else {
        fallback
    }
}

/// 2D version of [`unit_or`].
pub(crate) fn unit2_or(v: DVec2, fallback: DVec2) -> DVec2 {
    let m = v.abs().max_element();
    if m > 0.0 && m.is_finite() {
        let w = v / m;
        w / w.length()
    } else {
        fallback
    }
}

/// Componentwise sign with `+1` for zero.
fn sgn(v: DVec3) -> DVec3 {
    DVec3::select(v.cmplt(DVec3::ZERO), DVec3::NEG_ONE, DVec3::ONE)
}

fn sgn1(x: f64) -> f64 {
    if x < 0.0 { -1.0 } else { 1.0 }
}

/// The largest f32 not above `x` (f64 to f32 rounding toward −∞).
pub(crate) fn f32_down(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) <= x || y.is_nan() {
        y
    } else if y == 0.0 {
        -f32::from_bits(1)
    } else if y > 0.0 {
        f32::from_bits(y.to_bits() - 1)
    } else {
        f32::from_bits(y.to_bits() + 1)
    }
}

/// The smallest f32 not below `x`.
pub(crate) fn f32_up(x: f64) -> f32 {
    -f32_down(-x)
}

/// The f64 box `[min, max]` rounded outward to f32, so that it still contains the solid.
pub(crate) fn aabb_outward(min: DVec3, max: DVec3) -> Aabb {
    Aabb::new(
        Vec3::new(f32_down(min.x), f32_down(min.y), f32_down(min.z)),
        Vec3::new(f32_up(max.x), f32_up(max.y), f32_up(max.z)),
    )
}

/// Signed distance of `q` (first octant) to the box of half extents `h` centred at the
/// origin, and its gradient in that octant (IQ, "sdBox", exact inside and outside).
fn box_abs(q: DVec3, h: DVec3) -> (f64, DVec3) {
    let d = q - h;
    let out = d.max(DVec3::ZERO);
    if out.cmpgt(DVec3::ZERO).any() {
        let l = out.length();
        (l, unit_or(out, DVec3::X))
    } else {
        let k = d.max_position();
        (d.max_element(), DVec3::AXES[k])
    }
}

/// A local frame along the segment `a`–`b`: (unit axis, length, a unit normal).
fn axis_frame(a: DVec3, b: DVec3) -> (DVec3, f64, DVec3) {
    let ba = b - a;
    let len = ba.length();
    let w = unit_or(ba, DVec3::Z);
    (w, len, w.any_orthonormal_vector())
}

/// Splits `v` into the coordinate along the unit axis `w` and the radial distance from it;
/// also returns the radial unit vector (`e` on the axis).
fn split_axial(v: DVec3, w: DVec3, e: DVec3) -> (f64, f64, DVec3) {
    let y = v.dot(w);
    let r = v - w * y;
    (y, r.length(), unit_or(r, e))
}

// ---------------------------------------------------------------- Sphere

/// A ball of `radius` around `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    center: DVec3,
    radius: f64,
}

impl Sphere {
    /// A sphere; `radius` must be finite and > 0, `center` finite.
    pub fn new(center: Vec3, radius: f32) -> Result<Self, FieldError> {
        Ok(Self {
            center: finite3("center", center)?,
            radius: positive("radius", radius)?,
        })
    }
}

impl Sdf64 for Sphere {
    fn sd(&self, p: DVec3) -> f64 {
        (p - self.center).length() - self.radius
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        unit_or(p - self.center, DVec3::Z)
    }
    fn aabb(&self) -> Aabb {
        aabb_outward(self.center - self.radius, self.center + self.radius)
    }
    /// Analytic `(I − n nᵀ) / |p − c|`; zero at the centre, where it is undefined.
    fn hess(&self, p: DVec3) -> Option<Mat3> {
        let v = p - self.center;
        let n = unit_or(v, DVec3::Z);
        let h = (DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z)) / v.length();
        let h = h.as_mat3();
        Some(if h.is_finite() { h } else { Mat3::ZERO })
    }
}

// ---------------------------------------------------------------- Cuboid

/// An axis-aligned box of half extents `half` around `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cuboid {
    center: DVec3,
    half: DVec3,
}

impl Cuboid {
    /// A box; every component of `half` must be finite and > 0.
    pub fn new(center: Vec3, half: Vec3) -> Result<Self, FieldError> {
        Ok(Self {
            center: finite3("center", center)?,
            half: positive3("half", half)?,
        })
    }
}

impl Sdf64 for Cuboid {
    fn sd(&self, p: DVec3) -> f64 {
        box_abs((p - self.center).abs(), self.half).0
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        let v = p - self.center;
        box_abs(v.abs(), self.half).1 * sgn(v)
    }
    fn aabb(&self) -> Aabb {
        aabb_outward(self.center - self.half, self.center + self.half)
    }
}

// ---------------------------------------------------------------- RoundedBox

/// An axis-aligned box of outer half extents `half` whose edges and corners are rounded
/// with `radius`: the set of points within `radius` of the box of half extents
/// `half − radius` (IQ, "sdRoundBox"; exact because offsetting a convex set is exact).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundedBox {
    center: DVec3,
    inner: DVec3,
    radius: f64,
}

impl RoundedBox {
    /// A rounded box; `half` components finite and > 0, `0 <= radius <= min(half)`
    /// (`radius = 0` is a sharp [`Cuboid`]).
    pub fn new(center: Vec3, half: Vec3, radius: f32) -> Result<Self, FieldError> {
        let half = positive3("half", half)?;
        let radius = non_negative("radius", radius)?;
        if radius > half.min_element() {
            return Err(FieldError::bad(
                "radius",
                radius,
                "must not exceed the smallest half extent",
            ));
        }
        Ok(Self {
            center: finite3("center", center)?,
            inner: half - radius,
            radius,
        })
    }
}

impl Sdf64 for RoundedBox {
    fn sd(&self, p: DVec3) -> f64 {
        box_abs((p - self.center).abs(), self.inner).0 - self.radius
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        let v = p - self.center;
        box_abs(v.abs(), self.inner).1 * sgn(v)
    }
    fn aabb(&self) -> Aabb {
        let h = self.inner + self.radius;
        aabb_outward(self.center - h, self.center + h)
    }
}

// ---------------------------------------------------------------- Torus

/// A torus around the z axis through `center`: the points within `minor` of the circle of
/// radius `major` in the plane `z = center.z`.
///
/// `minor > major` gives the spindle torus (an apple shape whose self-intersection lies
/// inside). Its distance is exact too: inside, the nearest boundary point may be one of the
/// two dimple tips on the axis, which the plain `|(ρ − R, z)| − r` misses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Torus {
    center: DVec3,
    major: f64,
    minor: f64,
}

impl Torus {
    /// A torus; `major` and `minor` finite and > 0 (any ratio).
    pub fn new(center: Vec3, major: f32, minor: f32) -> Result<Self, FieldError> {
        Ok(Self {
            center: finite3("center", center)?,
            major: positive("major", major)?,
            minor: positive("minor", minor)?,
        })
    }

    /// Signed distance and gradient in the meridian half-plane `(ρ, z)`, `ρ >= 0`
    /// (IQ, "sdTorus": `|(ρ − R, z)| − r`; plus the spindle case, see below).
    fn meridian(&self, q: DVec2) -> (f64, DVec2) {
        let (big, r) = (self.major, self.minor);
        let c = q - DVec2::new(big, 0.0);
        let l = c.length();
        let tube = unit2_or(c, DVec2::X);
        if l >= r || r <= big {
            return (l - r, tube);
        }
        // Inside a spindle torus the tube circle is only boundary for ρ >= 0; its mirror
        // (centre (−R, 0)) bounds the other half of the meridian plane. The closest boundary
        // point is the radial projection onto either arc when it lies on the arc, else one
        // of the tips (0, ±h).
        let h = (r * r - big * big).sqrt();
        let tip = DVec2::new(0.0, h.copysign(q.y));
        let mut best = ((q - tip).length(), tip);
        for cx in [big, -big] {
            let u = unit2_or(q - DVec2::new(cx, 0.0), DVec2::X);
            let x = DVec2::new(cx, 0.0) + r * u;
            let d = (x - q).length();
            if x.x * cx >= 0.0 && d < best.0 {
                best = (d, x);
            }
        }
        (-best.0, unit2_or(best.1 - q, tube))
    }

    fn local(&self, p: DVec3) -> (DVec2, DVec3) {
        let v = p - self.center;
        let rho = DVec2::new(v.x, v.y).length();
        let radial = unit_or(DVec3::new(v.x, v.y, 0.0), DVec3::X);
        (DVec2::new(rho, v.z), radial)
    }
}

impl Sdf64 for Torus {
    fn sd(&self, p: DVec3) -> f64 {
        self.meridian(self.local(p).0).0
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        let (q, radial) = self.local(p);
        let g = self.meridian(q).1;
        unit_or(radial * g.x + DVec3::Z * g.y, DVec3::Z)
    }
    fn aabb(&self) -> Aabb {
        let h = DVec3::new(self.major + self.minor, self.major + self.minor, self.minor);
        aabb_outward(self.center - h, self.center + h)
    }
}

// ---------------------------------------------------------------- Capsule

/// The points within `radius` of the segment `a`–`b` (IQ, "sdCapsule"). `a == b` is a sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    a: DVec3,
    b: DVec3,
    radius: f64,
}

impl Capsule {
    /// A capsule; endpoints finite (may coincide), `radius` finite and > 0.
    pub fn new(a: Vec3, b: Vec3, radius: f32) -> Result<Self, FieldError> {
        Ok(Self {
            a: finite3("a", a)?,
            b: finite3("b", b)?,
            radius: positive("radius", radius)?,
        })
    }

    /// `p` minus its closest point on the segment.
    fn offset(&self, p: DVec3) -> DVec3 {
        let (pa, ba) = (p - self.a, self.b - self.a);
        let bb = ba.length_squared();
        let t = if bb > 0.0 {
            (pa.dot(ba) / bb).clamp(0.0, 1.0)
        } else {
            0.0
        };
        pa - ba * t
    }
}

impl Sdf64 for Capsule {
    fn sd(&self, p: DVec3) -> f64 {
        self.offset(p).length() - self.radius
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        let fallback = axis_frame(self.a, self.b).2;
        unit_or(self.offset(p), fallback)
    }
    fn aabb(&self) -> Aabb {
        aabb_outward(
            self.a.min(self.b) - self.radius,
            self.a.max(self.b) + self.radius,
        )
    }
}

// ---------------------------------------------------------------- capped cylinder

/// A solid cylinder of `radius` with flat caps at `a` and `b` (IQ, "capped cylinder -
/// arbitrary", exact; evaluated as the 2D box in (radial, axial) coordinates it reduces to).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CappedCylinder {
    mid: DVec3,
    axis: DVec3,
    normal: DVec3,
    half_len: f64,
    radius: f64,
    a: DVec3,
    b: DVec3,
}

impl CappedCylinder {
    /// A cylinder; `a != b` (finite), `radius` finite and > 0.
    pub fn new(a: Vec3, b: Vec3, radius: f32) -> Result<Self, FieldError> {
        let (a64, b64) = (finite3("a", a)?, finite3("b", b)?);
        let radius = positive("radius", radius)?;
        let (axis, len, normal) = axis_frame(a64, b64);
        if len == 0.0 {
            return Err(FieldError::bad(
                "b",
                b,
                "must differ from a (a cylinder needs a nonzero axis)",
            ));
        }
        Ok(Self {
            mid: 0.5 * (a64 + b64),
            axis,
            normal,
            half_len: 0.5 * len,
            radius,
            a: a64,
            b: b64,
        })
    }

    /// Distance and gradient in the (radial, |axial|) quarter plane, plus the local frame.
    fn eval(&self, p: DVec3) -> (f64, DVec3) {
        let (y, rho, radial) = split_axial(p - self.mid, self.axis, self.normal);
        let q = DVec3::new(rho, y.abs(), 0.0);
        let (d, g) = box_abs(q, DVec3::new(self.radius, self.half_len, f64::INFINITY));
        (d, radial * g.x + self.axis * (g.y * sgn1(y)))
    }
}

impl Sdf64 for CappedCylinder {
    fn sd(&self, p: DVec3) -> f64 {
        self.eval(p).0
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        unit_or(self.eval(p).1, self.axis)
    }
    fn aabb(&self) -> Aabb {
        // Each cap disk extends r·sqrt(1 − w_i²) along axis i.
        let e = self.radius
            * (DVec3::ONE - self.axis * self.axis)
                .max(DVec3::ZERO)
                .powf(0.5);
        aabb_outward(self.a.min(self.b) - e, self.a.max(self.b) + e)
    }
}

// ---------------------------------------------------------------- capped cone

/// A truncated cone from the disk of radius `ra` at `a` to the disk of radius `rb` at `b`
/// (IQ, "capped cone - arbitrary", exact). A zero radius gives a pointed cone.
///
/// Evaluated as IQ does, in the meridian half-plane (radial `x`, axial `y` from `a`):
/// the distance to the nearest of the bottom cap, the slanted side and the top cap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CappedCone {
    a: DVec3,
    b: DVec3,
    axis: DVec3,
    normal: DVec3,
    len: f64,
    ra: f64,
    rb: f64,
}

impl CappedCone {
    /// A cone; `a != b` (finite), `ra, rb` finite and >= 0, not both 0.
    pub fn new(a: Vec3, b: Vec3, ra: f32, rb: f32) -> Result<Self, FieldError> {
        let (a64, b64) = (finite3("a", a)?, finite3("b", b)?);
        let (ra, rb) = (non_negative("ra", ra)?, non_negative("rb", rb)?);
        if ra == 0.0 && rb == 0.0 {
            return Err(FieldError::bad("rb", rb, "ra and rb must not both be 0"));
        }
        let (axis, len, normal) = axis_frame(a64, b64);
        if len == 0.0 {
            return Err(FieldError::bad(
                "b",
                b,
                "must differ from a (a cone needs a nonzero axis)",
            ));
        }
        Ok(Self {
            a: a64,
            b: b64,
            axis,
            normal,
            len,
            ra,
            rb,
        })
    }

    fn eval(&self, p: DVec3) -> (f64, DVec3) {
        let (y, x, radial) = split_axial(p - self.a, self.axis, self.normal);
        let q = DVec2::new(x, y);
        let (a1, b1) = (DVec2::new(self.ra, 0.0), DVec2::new(self.rb, self.len));
        let side_n = unit2_or(DVec2::new(self.len, self.ra - self.rb), DVec2::X);
        let inside = y > 0.0 && y < self.len && (q - a1).dot(side_n) < 0.0;
        // (segment start, end, outward normal): bottom cap, side, top cap.
        let segs = [
            (DVec2::ZERO, a1, DVec2::NEG_Y),
            (a1, b1, side_n),
            (b1, DVec2::new(0.0, self.len), DVec2::Y),
        ];
        let mut best = (f64::INFINITY, DVec2::X);
        for (s, e, n) in segs {
            let se = e - s;
            let ll = se.length_squared();
            let t = if ll > 0.0 {
                ((q - s).dot(se) / ll).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (d, g) = if t > 0.0 && t < 1.0 {
                // Foot of the perpendicular: the distance and direction need no subtraction
                // of nearly equal points.
                let h = (q - s).dot(n);
                (h.abs(), n)
            } else {
                let c = s + se * t;
                let v = if inside { c - q } else { q - c };
                (v.length(), unit2_or(v, n))
            };
            if d < best.0 {
                best = (d, g);
            }
        }
        let d = if inside { -best.0 } else { best.0 };
        (d, radial * best.1.x + self.axis * best.1.y)
    }
}

impl Sdf64 for CappedCone {
    fn sd(&self, p: DVec3) -> f64 {
        self.eval(p).0
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        unit_or(self.eval(p).1, self.axis)
    }
    fn aabb(&self) -> Aabb {
        let k = (DVec3::ONE - self.axis * self.axis)
            .max(DVec3::ZERO)
            .powf(0.5);
        let (ea, eb) = (self.ra * k, self.rb * k);
        aabb_outward(
            (self.a - ea).min(self.b - eb),
            (self.a + ea).max(self.b + eb),
        )
    }
}

// ---------------------------------------------------------------- Plane

/// The half-space `n·p <= offset` (`n` the unit normal, pointing outside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    normal: DVec3,
    offset: f64,
}

impl Plane {
    /// A plane; `normal` finite and nonzero (normalized here), `offset` finite. The value
    /// is `n·p − offset` with the normalized `n`.
    pub fn new(normal: Vec3, offset: f32) -> Result<Self, FieldError> {
        let n = finite3("normal", normal)?;
        if n == DVec3::ZERO {
            return Err(FieldError::bad("normal", normal, "must be nonzero"));
        }
        if !offset.is_finite() {
            return Err(FieldError::bad("offset", offset, "must be finite"));
        }
        Ok(Self {
            normal: unit_or(n, DVec3::Z),
            offset: offset as f64,
        })
    }
}

impl Sdf64 for Plane {
    fn sd(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }
    fn grad(&self, _p: DVec3) -> DVec3 {
        self.normal
    }
    fn aabb(&self) -> Aabb {
        Aabb::INFINITE
    }
}

// ---------------------------------------------------------------- Ellipsoid

/// An axis-aligned ellipsoid with semi-axes `radii` around `center`, with the **exact**
/// Euclidean distance inside and outside (not the common first-order bound): Eberly,
/// "Distance from a Point to an Ellipse, an Ellipsoid, or a Hyperellipsoid" (2013),
/// bisection in f64 for the root of `Σ (r_i z_i / (s + r_i))² − 1` in the first octant
/// with the axes sorted, plus his special cases for points on the coordinate planes.
/// The sign comes from the implicit function `Σ (p_i / radius_i)² − 1`. Equal radii, points
/// on the axes and the centre are handled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    center: DVec3,
    radii: DVec3,
    /// `e[k] = radii[perm[k]]`, with `e` descending.
    e: [f64; 3],
    perm: [usize; 3],
}

/// `max |v_i| * |v / max|v_i||`, without overflow or underflow.
pub(crate) fn robust_len(v: &[f64]) -> f64 {
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if m == 0.0 {
        0.0
    } else {
        m * v.iter().map(|x| (x / m) * (x / m)).sum::<f64>().sqrt()
    }
}

/// Root of a decreasing `f` on `[lo, hi]` (`f(lo) >= 0 >= f(hi)`) by bisection, to the
/// last bit (Eberly's `GetRoot` loop).
fn bisect(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let mut m = 0.5 * (lo + hi);
    for _ in 0..2200 {
        m = 0.5 * (lo + hi);
        if m == lo || m == hi {
            break;
        }
        match f(m) {
            v if v > 0.0 => lo = m,
            v if v < 0.0 => hi = m,
            _ => break,
        }
    }
    m
}

/// Closest point `x` on the (hyper)ellipse of descending semi-axes `e` to `y` (every
/// component > 0), and `y − x` without cancellation near the surface. Eberly: the root `s` of
/// `Σ (r_i z_i / (s + r_i))² = 1`, `r_i = (e_i / e_last)²`, `z_i = y_i / e_i`, gives
/// `x_i = r_i y_i / (s + r_i)`. Deep inside (`s < −1/2`) this bisects on `u = s + 1` instead
/// of `s`, so that `s + r_last = u` stays accurate when tiny (points very close to the plane
/// of the larger axes), where Eberly's form gives 0/0.
fn eberly<const N: usize>(e: [f64; N], y: [f64; N]) -> ([f64; N], [f64; N]) {
    use std::array::from_fn;
    let last = e[N - 1];
    let z: [f64; N] = from_fn(|i| y[i] / e[i]);
    let g = z.iter().map(|z| z * z).sum::<f64>() - 1.0;
    if g == 0.0 {
        return (y, [0.0; N]);
    }
    let r: [f64; N] = from_fn(|i| (e[i] / last).powi(2));
    let rm1: [f64; N] = from_fn(|i| (e[i] - last) * (e[i] + last) / (last * last));
    let n: [f64; N] = from_fn(|i| r[i] * z[i]);
    let f = |den: [f64; N]| n.iter().zip(den).map(|(n, d)| (n / d).powi(2)).sum::<f64>() - 1.0;
    let s_den = |s: f64| -> [f64; N] { from_fn(|i| s + r[i]) };
    let u_den = |u: f64| -> [f64; N] { from_fn(|i| u + rm1[i]) };
    let (s, den) = if g > 0.0 {
        let s = bisect(0.0, robust_len(&n) - 1.0, |s| f(s_den(s)));
        (s, s_den(s))
    } else if f(s_den(-0.5)) >= 0.0 {
        let s = bisect(-0.5, 0.0, |s| f(s_den(s)));
        (s, s_den(s))
    } else {
        let u = bisect(z[N - 1], 0.5, |u| f(u_den(u)));
        (u - 1.0, u_den(u))
    };
    (
        from_fn(|i| r[i] * y[i] / den[i]),
        from_fn(|i| y[i] * s / den[i]),
    )
}

/// Closest point `x` on the ellipse of semi-axes `e0 >= e1` to `y` (first quadrant), and
/// `y − x`. Eberly's `DistancePointEllipse`.
pub(crate) fn ellipse_closest(e: [f64; 2], y: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    if y[1] > 0.0 {
        if y[0] > 0.0 {
            return eberly(e, y);
        }
        return ([0.0, e[1]], [0.0, y[1] - e[1]]);
    }
    let (num, den) = (e[0] * y[0], e[0] * e[0] - e[1] * e[1]);
    if num < den {
        let xd = num / den;
        let x = [e[0] * xd, e[1] * (1.0 - xd * xd).sqrt()];
        return (x, [y[0] - x[0], -x[1]]);
    }
    ([e[0], 0.0], [y[0] - e[0], 0.0])
}

impl Ellipsoid {
    /// An ellipsoid; every component of `radii` finite and > 0 (any may be equal).
    pub fn new(center: Vec3, radii: Vec3) -> Result<Self, FieldError> {
        let radii = positive3("radii", radii)?;
        let mut perm = [0, 1, 2];
        perm.sort_by(|&i, &j| radii[j].total_cmp(&radii[i]));
        let e = perm.map(|k| radii[k]);
        Ok(Self {
            center: finite3("center", center)?,
            radii,
            e,
            perm,
        })
    }

    /// Closest point and `y − x` in the sorted first octant (Eberly's `DistancePointEllipsoid`,
    /// with its special cases for `y` on the coordinate planes).
    fn closest(&self, y: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let e = self.e;
        if y[2] > 0.0 {
            if y[1] > 0.0 {
                if y[0] > 0.0 {
                    return eberly(e, y);
                }
                let (x, d) = ellipse_closest([e[1], e[2]], [y[1], y[2]]);
                return ([0.0, x[0], x[1]], [y[0], d[0], d[1]]);
            }
            if y[0] > 0.0 {
                let (x, d) = ellipse_closest([e[0], e[2]], [y[0], y[2]]);
                return ([x[0], 0.0, x[1]], [d[0], y[1], d[1]]);
            }
            return ([0.0, 0.0, e[2]], [y[0], y[1], y[2] - e[2]]);
        }
        let den = [e[0] * e[0] - e[2] * e[2], e[1] * e[1] - e[2] * e[2]];
        let num = [e[0] * y[0], e[1] * y[1]];
        if num[0] < den[0] && num[1] < den[1] {
            // Inside, on the plane of the two larger axes: the closest point is off the plane.
            let xd = [num[0] / den[0], num[1] / den[1]];
            let discr = 1.0 - xd[0] * xd[0] - xd[1] * xd[1];
            if discr > 0.0 {
                let x = [e[0] * xd[0], e[1] * xd[1], e[2] * discr.sqrt()];
                return (x, [y[0] - x[0], y[1] - x[1], -x[2]]);
            }
        }
        let (x, d) = ellipse_closest([e[0], e[1]], [y[0], y[1]]);
        ([x[0], x[1], 0.0], [d[0], d[1], y[2]])
    }

    /// (signed distance, gradient) in world axes.
    fn eval(&self, p: DVec3) -> (f64, DVec3) {
        let v = p - self.center;
        let y = self.perm.map(|k| v[k].abs());
        let (x, diff) = self.closest(y);
        let inside = (0..3).map(|k| (y[k] / self.e[k]).powi(2)).sum::<f64>() < 1.0;
        let d = robust_len(&diff);
        let normal = DVec3::from_array(std::array::from_fn(|k| x[k] / (self.e[k] * self.e[k])));
        let g_sorted = if d > 0.0 {
            DVec3::from_array(diff) * if inside { -1.0 } else { 1.0 }
        } else {
            normal
        };
        let mut g = DVec3::ZERO;
        for k in 0..3 {
            g[self.perm[k]] = g_sorted[k];
        }
        (if inside { -d } else { d }, unit_or(g, DVec3::Z) * sgn(v))
    }
}

impl Sdf64 for Ellipsoid {
    fn sd(&self, p: DVec3) -> f64 {
        self.eval(p).0
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        self.eval(p).1
    }
    fn aabb(&self) -> Aabb {
        aabb_outward(self.center - self.radii, self.center + self.radii)
    }
}

field_from_sdf64!(
    Sphere,
    Cuboid,
    RoundedBox,
    Torus,
    Capsule,
    CappedCylinder,
    CappedCone,
    Plane,
    Ellipsoid
);

// ---------------------------------------------------------------- Primitive

/// Any of the primitives, by value; implements [`Field`] by delegation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// A [`Sphere`].
    Sphere(Sphere),
    /// A [`Cuboid`].
    Cuboid(Cuboid),
    /// A [`RoundedBox`].
    RoundedBox(RoundedBox),
    /// A [`Torus`].
    Torus(Torus),
    /// A [`Capsule`].
    Capsule(Capsule),
    /// A [`CappedCylinder`].
    CappedCylinder(CappedCylinder),
    /// A [`CappedCone`].
    CappedCone(CappedCone),
    /// A [`Plane`].
    Plane(Plane),
    /// An [`Ellipsoid`].
    Ellipsoid(Ellipsoid),
}

macro_rules! delegate {
    ($self:ident, $p:ident => $e:expr) => {
        match $self {
            Primitive::Sphere($p) => $e,
            Primitive::Cuboid($p) => $e,
            Primitive::RoundedBox($p) => $e,
            Primitive::Torus($p) => $e,
            Primitive::Capsule($p) => $e,
            Primitive::CappedCylinder($p) => $e,
            Primitive::CappedCone($p) => $e,
            Primitive::Plane($p) => $e,
            Primitive::Ellipsoid($p) => $e,
        }
    };
}

impl Primitive {
    /// The names [`Primitive::name`] returns, in declaration order.
    pub const NAMES: [&'static str; 9] = [
        "sphere",
        "cuboid",
        "rounded_box",
        "torus",
        "capsule",
        "capped_cylinder",
        "capped_cone",
        "plane",
        "ellipsoid",
    ];

    /// Lower-case name of the kind, e.g. `"capped_cone"`.
    pub fn name(&self) -> &'static str {
        let i = match self {
            Primitive::Sphere(_) => 0,
            Primitive::Cuboid(_) => 1,
            Primitive::RoundedBox(_) => 2,
            Primitive::Torus(_) => 3,
            Primitive::Capsule(_) => 4,
            Primitive::CappedCylinder(_) => 5,
            Primitive::CappedCone(_) => 6,
            Primitive::Plane(_) => 7,
            Primitive::Ellipsoid(_) => 8,
        };
        Self::NAMES[i]
    }

    fn as_field(&self) -> &dyn Field {
        delegate!(self, p => p as &dyn Field)
    }
}

macro_rules! primitive_from {
    ($($t:ident),*) => {$(
        impl From<$t> for Primitive {
            fn from(p: $t) -> Self {
                Primitive::$t(p)
            }
        }
    )*};
}
primitive_from!(
    Sphere,
    Cuboid,
    RoundedBox,
    Torus,
    Capsule,
    CappedCylinder,
    CappedCone,
    Plane,
    Ellipsoid
);

impl Field for Primitive {
    fn value(&self, p: Vec3) -> f32 {
        self.as_field().value(p)
    }
    fn bounds(&self) -> Aabb {
        self.as_field().bounds()
    }
    fn lipschitz(&self) -> f32 {
        self.as_field().lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.as_field().is_exact()
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.as_field().gradient(p)
    }
    fn hessian(&self, p: Vec3) -> Mat3 {
        self.as_field().hessian(p)
    }
    fn distance_box(&self) -> Option<crate::DistanceBox> {
        self.as_field().distance_box()
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.as_field().lower_bound(p)
    }
}

#[cfg(test)]
impl Sdf64 for Primitive {
    fn sd(&self, p: DVec3) -> f64 {
        delegate!(self, f => f.sd(p))
    }
    fn grad(&self, p: DVec3) -> DVec3 {
        delegate!(self, f => f.grad(p))
    }
    fn aabb(&self) -> Aabb {
        delegate!(self, f => f.aabb())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    /// A surface patch: a map of `[0,1]²` onto the surface and its rough lengths along u, v.
    struct Patch(Box<dyn Fn(f64, f64) -> DVec3>, f64, f64);

    fn patch(f: impl Fn(f64, f64) -> DVec3 + 'static, lu: f64, lv: f64) -> Patch {
        Patch(Box::new(f), lu, lv)
    }

    /// A primitive with an independent description: surface patches and an inside test.
    struct Case {
        f: Primitive,
        patches: Vec<Patch>,
        inside: Box<dyn Fn(DVec3) -> bool>,
        /// Box the random queries are drawn from.
        qbox: (DVec3, DVec3),
        /// Points on axes, centres and symmetry planes, where the special cases live.
        special: Vec<DVec3>,
    }

    impl Case {
        fn new(
            f: impl Into<Primitive>,
            patches: Vec<Patch>,
            inside: impl Fn(DVec3) -> bool + 'static,
        ) -> Self {
            let f = f.into();
            let b = f.bounds();
            let pad = 0.3 * b.diagonal() as f64;
            let qbox = (b.min.as_dvec3() - pad, b.max.as_dvec3() + pad);
            Self {
                f,
                patches,
                inside: Box::new(inside),
                qbox,
                special: vec![],
            }
        }

        fn with_special(mut self, pts: impl IntoIterator<Item = DVec3>) -> Self {
            self.special.extend(pts);
            self
        }

        /// Dense samples of the surface with target spacing `h`, and δ: the largest distance
        /// between grid neighbours, so every surface point is within δ of a sample.
        fn samples(&self, h: f64) -> (Vec<DVec3>, f64) {
            let (mut pts, mut delta) = (vec![], 0.0f64);
            for Patch(f, lu, lv) in &self.patches {
                let nu = (lu / h).ceil().max(1.0) as usize + 1;
                let nv = (lv / h).ceil().max(1.0) as usize + 1;
                let g: Vec<DVec3> = (0..nu * nv)
                    .map(|k| {
                        f(
                            (k % nu) as f64 / (nu - 1) as f64,
                            (k / nu) as f64 / (nv - 1) as f64,
                        )
                    })
                    .collect();
                for k in 0..nu * nv {
                    if k % nu + 1 < nu {
                        delta = delta.max((g[k + 1] - g[k]).length());
                    }
                    if k + nu < nu * nv {
                        delta = delta.max((g[k + nu] - g[k]).length());
                    }
                }
                pts.extend(g);
            }
            (pts, delta)
        }
    }

    fn dir(theta: f64, phi: f64) -> DVec3 {
        DVec3::new(phi.sin() * theta.cos(), phi.sin() * theta.sin(), phi.cos())
    }

    /// An orthonormal frame (e1, e2) perpendicular to unit `w`, built independently of glam.
    fn frame(w: DVec3) -> (DVec3, DVec3) {
        let k = w.abs().min_position();
        let e1 = w.cross(DVec3::AXES[k]).normalize();
        (e1, w.cross(e1))
    }

    /// Patches of the box `c ± inner` offset by `r`: faces, and (for r > 0) edge cylinders
    /// and corner sphere octants.
    fn box_patches(c: DVec3, inner: DVec3, r: f64) -> Vec<Patch> {
        let mut out = vec![];
        for code in 0..27 {
            let s = [code % 3, code / 3 % 3, code / 9].map(|d| d as f64 - 1.0);
            let free: Vec<usize> = (0..3).filter(|&k| s[k] == 0.0).collect();
            let norm: Vec<usize> = (0..3).filter(|&k| s[k] != 0.0).collect();
            if norm.is_empty() || (r == 0.0 && norm.len() > 1) {
                continue;
            }
            let (fr, nr) = (free.clone(), norm.clone());
            let f = move |u: f64, v: f64| {
                let mut p = c;
                for k in 0..3 {
                    p[k] += s[k] * inner[k];
                }
                let t = [u, v];
                for (i, &k) in fr.iter().enumerate() {
                    p[k] += inner[k] * (2.0 * t[i] - 1.0);
                }
                let n: Vec<f64> = match nr.len() {
                    1 => vec![1.0],
                    2 => vec![(v * FRAC_PI_2).cos(), (v * FRAC_PI_2).sin()],
                    _ => dir(u * FRAC_PI_2, v * FRAC_PI_2).to_array().to_vec(),
                };
                for (i, &k) in nr.iter().enumerate() {
                    p[k] += s[k] * r * n[i];
                }
                p
            };
            let (lu, lv) = match norm.len() {
                1 => (2.0 * inner[free[0]], 2.0 * inner[free[1]]),
                2 => (2.0 * inner[free[0]], r * FRAC_PI_2),
                _ => (r * FRAC_PI_2, r * FRAC_PI_2),
            };
            out.push(patch(f, lu, lv));
        }
        out
    }

    /// Side and caps of the solid of revolution from the disk of `ra` at `a` to `rb` at `b`.
    fn frustum_patches(a: DVec3, b: DVec3, ra: f64, rb: f64) -> Vec<Patch> {
        let w = (b - a).normalize();
        let (e1, e2) = frame(w);
        let ring = move |t: f64| (TAU * t).cos() * e1 + (TAU * t).sin() * e2;
        let side = (a - b).length().hypot(rb - ra);
        vec![
            patch(
                move |u, v| a + (b - a) * u + (ra + (rb - ra) * u) * ring(v),
                side,
                TAU * ra.max(rb),
            ),
            patch(move |u, v| a + ra * u * ring(v), ra, TAU * ra),
            patch(move |u, v| b + rb * u * ring(v), rb, TAU * rb),
        ]
    }

    fn dist_to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
        let ab = b - a;
        let t = if ab == DVec3::ZERO {
            0.0
        } else {
            ((p - a).dot(ab) / ab.dot(ab)).clamp(0.0, 1.0)
        };
        (p - (a + t * ab)).length()
    }

    /// Maps unit-scale parameters to scale `s` and offset `o` (rounded to f32).
    #[derive(Clone, Copy)]
    struct Sc(f64, DVec3);
    impl Sc {
        fn p(self, x: f64, y: f64, z: f64) -> Vec3 {
            (self.1 + self.0 * DVec3::new(x, y, z)).as_vec3()
        }
        fn l(self, x: f64) -> f32 {
            (self.0 * x) as f32
        }
    }

    fn sphere_case(c: Vec3, r: f32) -> Case {
        let f = Sphere::new(c, r).unwrap();
        let (c, r) = (c.as_dvec3(), r as f64);
        let surf = patch(move |u, v| c + r * dir(TAU * u, PI * v), TAU * r, PI * r);
        let special = [0.0, 0.5, 1.5].map(|t| c + t * r * DVec3::new(1.0, 0.0, 0.0));
        Case::new(f, vec![surf], move |p| (p - c).length() < r).with_special(special)
    }

    fn rounded_box_case(c: Vec3, half: Vec3, r: f32) -> Case {
        let f: Primitive = if r == 0.0 {
            Cuboid::new(c, half).unwrap().into()
        } else {
            RoundedBox::new(c, half, r).unwrap().into()
        };
        let (c, half, r) = (c.as_dvec3(), half.as_dvec3(), r as f64);
        let inner = half - r;
        let inside = move |p: DVec3| {
            let q = (p - c).abs() - inner;
            q.max(DVec3::ZERO).length() < r || (r == 0.0 && q.cmplt(DVec3::ZERO).all())
        };
        let special = [
            [0.0; 3],
            [0.5, 0.0, 0.0],
            [0.0, 0.7, 0.2],
            [0.9, 0.9, 0.9],
            [1.5, 0.0, 0.0],
            [0.0, 0.0, -1.2],
        ]
        .map(|t| c + half * DVec3::from_array(t));
        Case::new(f, box_patches(c, inner, r), inside).with_special(special)
    }

    fn torus_case(c: Vec3, big: f32, r: f32) -> Case {
        let f = Torus::new(c, big, r).unwrap();
        let (c, big, r) = (c.as_dvec3(), big as f64, r as f64);
        // In the meridian half-plane only the arc with ρ >= 0 is surface.
        let vmax = if r > big { (-big / r).acos() } else { PI };
        let surf = patch(
            move |u, v| {
                let a = vmax * (2.0 * v - 1.0);
                let rho = big + r * a.cos();
                c + DVec3::new(rho * (TAU * u).cos(), rho * (TAU * u).sin(), r * a.sin())
            },
            TAU * (big + r),
            2.0 * vmax * r,
        );
        let inside = move |p: DVec3| {
            let v = p - c;
            (v.x.hypot(v.y) - big).hypot(v.z) < r
        };
        let special = [
            [0.0; 3],
            [0.0, 0.0, 0.3 * r],
            [0.0, 0.0, -0.9 * r],
            [0.0, 0.0, 2.0 * r],
            [0.1 * big, 0.0, 0.1 * r],
            [big, 0.0, 0.0],
            [0.0, big, 0.5 * r],
        ]
        .map(|t| c + DVec3::from_array(t));
        Case::new(f, vec![surf], inside).with_special(special)
    }

    fn capsule_case(a: Vec3, b: Vec3, r: f32) -> Case {
        let f = Capsule::new(a, b, r).unwrap();
        let (a, b, r) = (a.as_dvec3(), b.as_dvec3(), r as f64);
        let w = if a == b {
            DVec3::Z
        } else {
            (b - a).normalize()
        };
        let (e1, e2) = frame(w);
        let cap = move |o: DVec3, w: DVec3| {
            patch(
                move |u, v| {
                    let d = dir(TAU * u, FRAC_PI_2 * v);
                    o + r * (d.x * e1 + d.y * e2 + d.z * w)
                },
                TAU * r,
                FRAC_PI_2 * r,
            )
        };
        let len = (b - a).length();
        let side = patch(
            move |u, v| a + (b - a) * u + r * ((TAU * v).cos() * e1 + (TAU * v).sin() * e2),
            len,
            TAU * r,
        );
        let special = [a, b, 0.5 * (a + b), a - 0.5 * r * w, b + 2.0 * r * w];
        Case::new(f, vec![side, cap(a, -w), cap(b, w)], move |p| {
            dist_to_segment(p, a, b) < r
        })
        .with_special(special)
    }

    fn cone_case(a: Vec3, b: Vec3, ra: f32, rb: f32) -> Case {
        let f: Primitive = if ra == rb {
            CappedCylinder::new(a, b, ra).unwrap().into()
        } else {
            CappedCone::new(a, b, ra, rb).unwrap().into()
        };
        let (a, b, ra, rb) = (a.as_dvec3(), b.as_dvec3(), ra as f64, rb as f64);
        let (w, len) = ((b - a).normalize(), (b - a).length());
        let inside = move |p: DVec3| {
            let t = (p - a).dot(w);
            let radial = ((p - a) - t * w).length();
            t > 0.0 && t < len && radial < ra + (rb - ra) * t / len
        };
        let e1 = frame(w).0;
        let special = [
            a,
            b,
            0.5 * (a + b),
            a + 0.1 * (b - a),
            b + 0.5 * (b - a),
            a + 0.5 * ra * e1,
            b + 2.0 * rb * e1,
        ];
        Case::new(f, frustum_patches(a, b, ra, rb), inside).with_special(special)
    }

    fn plane_case(n: Vec3, off: f32, s: f64) -> Case {
        let f = Plane::new(n, off).unwrap();
        let n = n.as_dvec3().normalize();
        let (e1, e2) = frame(n);
        let q0 = n * off as f64 + 0.3 * s * e1;
        let surf = patch(
            move |u, v| q0 + 5.0 * s * ((u - 0.5) * e1 + (v - 0.5) * e2),
            5.0 * s,
            5.0 * s,
        );
        let mut c =
            Case::new(f, vec![surf], move |p| n.dot(p) < off as f64).with_special([q0, q0 + s * n]);
        c.qbox = (q0 - s, q0 + s);
        c
    }

    fn ellipsoid_case(c: Vec3, radii: Vec3) -> Case {
        let f = Ellipsoid::new(c, radii).unwrap();
        let (c, e) = (c.as_dvec3(), radii.as_dvec3());
        let m = e.max_element();
        let surf = patch(move |u, v| c + e * dir(TAU * u, PI * v), TAU * m, PI * m);
        // The centre, points on the axes and in the coordinate planes, inside and outside.
        let mut special = vec![c];
        for k in 0..3 {
            for t in [0.3, 0.5, 0.7, 0.99, 1.0, 1.5] {
                special.push(c + t * e[k] * DVec3::AXES[k]);
                special.push(c + t * e * (DVec3::ONE - DVec3::AXES[k]) * 0.7);
            }
        }
        Case::new(f, vec![surf], move |p| ((p - c) / e).length_squared() < 1.0)
            .with_special(special)
    }

    /// Every test case of one kind at scale `s` and offset `o`.
    fn cases(kind: &str, sc: Sc) -> Vec<Case> {
        let (p, l) = (|x, y, z| sc.p(x, y, z), |x| sc.l(x));
        match kind {
            "sphere" => vec![sphere_case(p(0.1, -0.2, 0.3), l(0.8))],
            "cuboid" => vec![rounded_box_case(
                p(0.1, 0.2, -0.1),
                p(0.9, 0.5, 0.3) - p(0.0, 0.0, 0.0),
                0.0,
            )],
            "rounded_box" => vec![
                rounded_box_case(p(0.0, 0.1, 0.0), Vec3::new(l(0.9), l(0.6), l(0.4)), l(0.15)),
                // radius = the smallest half extent: a flat inner box.
                rounded_box_case(p(0.1, 0.0, 0.0), Vec3::new(l(0.7), l(0.5), l(0.3)), l(0.3)),
            ],
            "torus" => vec![
                torus_case(p(0.1, 0.0, -0.1), l(0.7), l(0.25)),
                torus_case(p(0.0, 0.1, 0.0), l(0.4), l(0.7)), // spindle
                torus_case(p(0.0, 0.0, 0.1), l(0.5), l(0.5)), // horn
            ],
            "capsule" => vec![
                capsule_case(p(-0.5, 0.2, 0.1), p(0.6, -0.3, 0.4), l(0.3)),
                capsule_case(p(0.2, 0.1, 0.0), p(0.2, 0.1, 0.0), l(0.5)), // a == b
            ],
            "capped_cylinder" => vec![
                cone_case(p(-0.5, 0.2, 0.1), p(0.6, -0.3, 0.4), l(0.35), l(0.35)),
                cone_case(p(0.0, 0.0, -0.1), p(0.0, 0.0, 0.2), l(0.7), l(0.7)), // flat disc
            ],
            "capped_cone" => vec![
                cone_case(p(-0.5, 0.2, 0.1), p(0.6, -0.3, 0.4), l(0.6), l(0.2)),
                cone_case(p(0.0, -0.4, 0.0), p(0.1, 0.6, 0.2), l(0.0), l(0.5)),
                cone_case(p(0.2, 0.0, -0.5), p(0.0, 0.1, 0.5), l(0.45), l(0.0)),
            ],
            "plane" => vec![plane_case(Vec3::new(0.3, -1.0, 2.0), l(0.4), sc.0)],
            "ellipsoid" => vec![
                ellipsoid_case(p(0.1, 0.0, -0.1), Vec3::new(l(1.0), l(0.6), l(0.35))),
                ellipsoid_case(p(0.0, 0.1, 0.0), Vec3::new(l(0.35), l(1.0), l(0.6))),
                ellipsoid_case(p(0.0, 0.0, 0.1), Vec3::new(l(0.5), l(0.9), l(0.5))),
                ellipsoid_case(p(0.0, 0.0, 0.0), Vec3::new(l(0.7), l(0.7), l(0.7))),
                ellipsoid_case(p(0.0, 0.0, 0.0), Vec3::new(l(1.0), l(0.25), l(0.12))),
            ],
            _ => unreachable!(),
        }
    }

    /// The scales of the brute-force and on-surface checks: unit, 1e-6, 1e6, and a unit
    /// shape far from the origin.
    const SCALES: [(f64, [f64; 3]); 4] = [
        (1.0, [0.0; 3]),
        (1e-6, [3e-7, -2e-7, 1e-7]),
        (1e6, [3e5, -2e5, 1e5]),
        (1.0, [1e3, -2e3, 5e2]),
    ];

    /// Brute force (1.), on-surface (2.) and scale (3.) checks for one kind.
    fn check_kind(kind: &str) {
        let mut rng = SplitMix64::new(crate::rng::DEFAULT_SEED ^ kind.len() as u64);
        for (si, (s, o)) in SCALES.into_iter().enumerate() {
            let o = DVec3::from_array(o);
            let all = cases(kind, Sc(s, o));
            let n = all.len();
            for (ci, case) in all.iter().enumerate() {
                // Beyond the first scale, only the first and the last case (to keep it fast).
                if si > 0 && ci != 0 && ci + 1 != n {
                    continue;
                }
                let tag = format!("{kind}[{ci}] scale {s:e} offset {o}");
                let (samples, delta) = case.samples(0.01 * s);
                let delta = 1.05 * delta;
                // Size of the coordinates: the f64 error of the evaluation is about 1e-16 of it.
                let mag = (o.abs().max_element() + 3.0 * s) * 1e-13;
                let (lo, hi) = case.qbox;
                let b = case.f.bounds();
                let (blo, bhi) = if b.is_finite() {
                    (b.min.as_dvec3(), b.max.as_dvec3())
                } else {
                    (lo, hi)
                };
                let mut signs = [0usize; 2];
                let ns = case.special.len();
                for q in 0..130 + ns {
                    let u = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
                    let pd = match q {
                        0..50 => u * (hi - lo) + lo,
                        50..100 => u * (bhi - blo) + blo,
                        100..130 => {
                            samples[rng.below(samples.len())]
                                + 0.05 * s * u.x * rng.unit_vector().as_dvec3()
                        }
                        _ => case.special[q - 130],
                    };
                    let p = pd.as_vec3();
                    let pd = p.as_dvec3();
                    let v = case.f.value(p) as f64;
                    let brute = samples
                        .iter()
                        .map(|x| (*x - pd).length_squared())
                        .fold(f64::INFINITY, f64::min)
                        .sqrt();
                    let tol = 2.0 * f64::from(f32::EPSILON) * v.abs() + mag;
                    assert!(
                        v.abs() <= brute + tol,
                        "{tag}: |{v}| > brute {brute} at {p}"
                    );
                    assert!(
                        v.abs() >= brute - delta - tol,
                        "{tag}: |{v}| < brute {brute} - {delta} at {p}"
                    );
                    if brute > delta + tol {
                        let inside = (case.inside)(pd);
                        assert_eq!(v < 0.0, inside, "{tag}: sign of {v} at {p}");
                        signs[inside as usize] += 1;
                    }
                }
                if kind != "plane" {
                    assert!(
                        signs[1] >= 3 && signs[0] >= 30,
                        "{tag}: too few decided signs {signs:?}"
                    );
                }
                // Points on the surface, rounded to f32: |value| is at most the rounding step.
                for _ in 0..400 {
                    let Patch(f, ..) = &case.patches[rng.below(case.patches.len())];
                    let x = f(rng.next_f64(), rng.next_f64());
                    let p = x.as_vec3();
                    let v = case.f.value(p).abs() as f64;
                    let step = (p.as_dvec3() - x).length();
                    let ulps = 2.0 * f64::from(f32::EPSILON) * p.abs().max_element() as f64;
                    assert!(
                        v <= step * (1.0 + 1e-6) + mag && v <= ulps + mag,
                        "{tag}: {v} on surface at {p}"
                    );
                }
                // Bounds contain the surface and are tight (reached within δ).
                if b.is_finite() {
                    let (bl, bh) = (b.min.as_dvec3(), b.max.as_dvec3());
                    let (mut sl, mut sh) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                    for x in &samples {
                        assert!(
                            x.cmpge(bl).all() && x.cmple(bh).all(),
                            "{tag}: {x} outside {b:?}"
                        );
                        (sl, sh) = (sl.min(*x), sh.max(*x));
                    }
                    let slack = (sl - bl).max(bh - sh).max_element();
                    assert!(
                        slack <= delta + mag,
                        "{tag}: bounds {b:?} not tight ({slack})"
                    );
                }
            }
        }
    }

    /// Gradient checks (4.): unit everywhere, equal to central differences of the f64
    /// distance away from the medial axis.
    fn check_gradient(kind: &str) {
        let mut rng = SplitMix64::new(7 + kind.len() as u64);
        for (ci, case) in cases(kind, Sc(1.0, DVec3::ZERO)).iter().enumerate() {
            let (lo, hi) = case.qbox;
            for &q in &case.special {
                let g = case.f.gradient(q.as_vec3());
                assert!(
                    (g.length() - 1.0).abs() < 1e-6,
                    "{kind}[{ci}]: |{g}| at special {q}"
                );
            }
            let mut used = 0;
            let n = 300;
            for _ in 0..n {
                let p = (DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * (hi - lo)
                    + lo)
                    .as_vec3();
                let g = case.f.gradient(p);
                assert!(
                    (g.length() - 1.0).abs() < 1e-6,
                    "{kind}[{ci}]: |{g}| at {p}"
                );
                let pd = p.as_dvec3();
                let h = 1e-6;
                let fd = DVec3::AXES
                    .map(|e| (case.f.sd(pd + h * e) - case.f.sd(pd - h * e)) / (2.0 * h));
                let fd = DVec3::from_array(fd);
                if (fd.length() - 1.0).abs() < 1e-6 {
                    used += 1;
                    let err = (case.f.grad(pd) - fd).length();
                    assert!(
                        err < 1e-5,
                        "{kind}[{ci}]: gradient {g} vs differences {fd} at {p}"
                    );
                }
            }
            assert!(
                used * 10 >= n * 8,
                "{kind}[{ci}]: only {used} of {n} points off the medial axis"
            );
        }
    }

    #[test]
    fn known_values() {
        let v = |f: Primitive, p: [f32; 3]| f.value(Vec3::from_array(p)) as f64;
        let o = Vec3::ZERO;
        let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        close(
            v(Sphere::new(Vec3::X, 2.0).unwrap().into(), [1.0, 0.0, 0.0]),
            -2.0,
        );
        close(
            v(
                Cuboid::new(o, Vec3::new(1.0, 2.0, 3.0)).unwrap().into(),
                [0.0, 0.0, 0.0],
            ),
            -1.0,
        );
        close(
            v(Cuboid::new(o, Vec3::ONE).unwrap().into(), [2.0, 3.0, 0.5]),
            5f64.sqrt(),
        );
        close(
            v(
                RoundedBox::new(o, Vec3::ONE, 0.5).unwrap().into(),
                [2.0, 2.0, 2.0],
            ),
            0.5 * 27f64.sqrt() - 0.5,
        );
        close(
            v(Torus::new(o, 1.0, 0.25).unwrap().into(), [0.0, 0.0, 0.0]),
            0.75,
        );
        // Spindle torus: the centre is closest to the tips (0, 0, ±sqrt(r² − R²)).
        close(
            v(Torus::new(o, 0.4, 0.7).unwrap().into(), [0.0, 0.0, 0.0]),
            -(0.49f64 - 0.16).sqrt(),
        );
        close(
            v(Torus::new(o, 0.5, 0.5).unwrap().into(), [0.0, 0.0, 0.0]),
            0.0,
        );
        close(
            v(
                Capsule::new(Vec3::X, Vec3::X, 0.5).unwrap().into(),
                [1.0, 2.0, 0.0],
            ),
            1.5,
        );
        close(
            v(
                Capsule::new(o, Vec3::Z, 0.5).unwrap().into(),
                [0.0, 0.0, 0.5],
            ),
            -0.5,
        );
        close(
            v(
                CappedCylinder::new(o, Vec3::Z, 0.25).unwrap().into(),
                [0.0, 0.0, 0.5],
            ),
            -0.25,
        );
        close(
            v(
                CappedCylinder::new(o, Vec3::Z, 0.25).unwrap().into(),
                [1.25, 0.0, 2.0],
            ),
            2f64.sqrt(),
        );
        // Pointed cone of half-angle 45°: the apex is on the surface, the axis below it at
        // distance t / sqrt(2) from the side.
        let cone: Primitive = CappedCone::new(o, Vec3::Z, 1.0, 0.0).unwrap().into();
        close(v(cone, [0.0, 0.0, 1.0]), 0.0);
        close(v(cone, [0.0, 0.0, 0.75]), -0.25 / 2f64.sqrt());
        close(v(cone, [0.0, 0.0, 2.0]), 1.0);
        close(
            v(
                Plane::new(Vec3::new(0.0, 3.0, 4.0), 1.0).unwrap().into(),
                [9.0, 1.0, 2.0],
            ),
            0.6 + 1.6 - 1.0,
        );
        // Ellipsoid: centre at −(smallest radius); an inner point on the longest axis has an
        // off-axis closest point at distance e2 · sqrt(1 − x²/(e0² − e2²)).
        let ell: Primitive = Ellipsoid::new(o, Vec3::new(1.0, 0.6, 0.4)).unwrap().into();
        close(v(ell, [0.0, 0.0, 0.0]), -0.4);
        close(
            v(ell, [0.5, 0.0, 0.0]),
            -0.4 * (1.0 - 0.25 / 0.84f64).sqrt(),
        );
        close(v(ell, [2.0, 0.0, 0.0]), 1.0);
        close(v(ell, [0.0, 0.0, -1.4]), 1.0);
    }

    #[test]
    fn ellipsoid_deep_inside_near_a_plane() {
        // s + 1 underflows next to −1 here; the u = s + 1 bisection keeps it exact.
        let e = Ellipsoid::new(Vec3::ZERO, Vec3::new(1.0, 0.6, 0.4)).unwrap();
        for (z, y) in [(1e-20f32, 0.1f32), (1e-45, 0.0), (1e-30, 1e-30)] {
            let (p, q) = (Vec3::new(0.3, y, z), Vec3::new(0.3, y, 0.0));
            let (a, b) = (e.value(p), e.value(q));
            assert!((a - b).abs() < 1e-7 && a < -0.3, "{a} vs {b} at {p}");
            assert!((e.gradient(p).length() - 1.0).abs() < 1e-6, "{p}");
        }
    }

    /// One instance of each kind, in [`Primitive::NAMES`] order.
    fn examples() -> [Primitive; 9] {
        let (o, z) = (Vec3::ZERO, Vec3::Z);
        [
            Sphere::new(o, 1.0).unwrap().into(),
            Cuboid::new(o, Vec3::new(1.0, 0.75, 0.5)).unwrap().into(),
            RoundedBox::new(o, Vec3::new(1.0, 0.75, 0.5), 0.2)
                .unwrap()
                .into(),
            Torus::new(o, 0.75, 0.25).unwrap().into(),
            Capsule::new(-0.5 * z, 0.5 * z, 0.5).unwrap().into(),
            CappedCylinder::new(-0.75 * z, 0.75 * z, 0.5)
                .unwrap()
                .into(),
            CappedCone::new(-0.75 * z, 0.75 * z, 0.75, 0.25)
                .unwrap()
                .into(),
            Plane::new(z, 0.0).unwrap().into(),
            Ellipsoid::new(o, Vec3::new(1.0, 0.6, 0.4)).unwrap().into(),
        ]
    }

    #[test]
    fn bad_parameters_are_errors() {
        let (o, n, inf) = (Vec3::ZERO, f32::NAN, f32::INFINITY);
        let errs = [
            Sphere::new(o, 0.0).err(),
            Sphere::new(o, -1.0).err(),
            Sphere::new(Vec3::new(n, 0.0, 0.0), 1.0).err(),
            Sphere::new(o, inf).err(),
            Cuboid::new(o, Vec3::new(1.0, 0.0, 1.0)).err(),
            Cuboid::new(o, Vec3::new(1.0, n, 1.0)).err(),
            RoundedBox::new(o, Vec3::ONE, 1.5).err(),
            RoundedBox::new(o, Vec3::ONE, -0.1).err(),
            Torus::new(o, 1.0, 0.0).err(),
            Torus::new(o, n, 0.5).err(),
            Capsule::new(o, Vec3::splat(inf), 1.0).err(),
            Capsule::new(o, Vec3::X, 0.0).err(),
            CappedCylinder::new(Vec3::X, Vec3::X, 1.0).err(),
            CappedCylinder::new(o, Vec3::X, n).err(),
            CappedCone::new(o, Vec3::X, 0.0, 0.0).err(),
            CappedCone::new(o, o, 1.0, 0.5).err(),
            CappedCone::new(o, Vec3::X, -1.0, 0.5).err(),
            Plane::new(o, 1.0).err(),
            Plane::new(Vec3::X, n).err(),
            Ellipsoid::new(o, Vec3::new(1.0, 1.0, 0.0)).err(),
            Ellipsoid::new(o, Vec3::new(1.0, inf, 1.0)).err(),
        ];
        for (i, e) in errs.iter().enumerate() {
            assert!(
                matches!(e, Some(FieldError::BadParameter { .. })),
                "case {i}: {e:?}"
            );
        }
        let msg = CappedCylinder::new(Vec3::X, Vec3::X, 1.0)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("must differ from a"), "{msg}");
        // Degenerate but valid: radius equal to the smallest half extent, a pointed cone.
        assert!(RoundedBox::new(o, Vec3::new(1.0, 0.5, 2.0), 0.5).is_ok());
        assert!(CappedCone::new(o, Vec3::X, 0.0, 1.0).is_ok());
    }

    #[test]
    fn primitive_names_and_delegation() {
        for (name, p) in Primitive::NAMES.into_iter().zip(examples()) {
            assert_eq!(p.name(), name);
            assert!(p.is_exact() && p.lipschitz() == 1.0);
            let q = Vec3::new(0.3, -0.2, 0.1);
            let pr = &p;
            let direct = delegate!(pr, f => f.value(q));
            assert_eq!(p.value(q), direct);
            assert_eq!(
                p.value(Vec3::ZERO) < 0.0,
                name != "plane" && name != "torus",
                "{name}"
            );
        }
        assert_eq!(examples()[7].bounds(), Aabb::INFINITE);
    }

    #[test]
    fn extreme_points_give_no_nan() {
        let pts = [0.0, 1e-45, -1e-38, 1.0, 1e30, -f32::MAX, f32::MAX];
        for (name, f) in Primitive::NAMES.into_iter().zip(examples()) {
            for &x in &pts {
                for &y in &pts {
                    let p = Vec3::new(x, y, pts[(x.to_bits() % 7) as usize]);
                    assert!(!f.value(p).is_nan(), "{name} at {p}");
                    let g = f.gradient(p);
                    assert!(
                        (g.length() - 1.0).abs() < 1e-6,
                        "{name}: gradient {g} at {p}"
                    );
                }
            }
        }
    }

    /// The curvature pipeline on the library's own primitives: analytic gradient, default
    /// finite-difference Hessian, [`crate::curvature::curvature`], against the closed forms.
    /// Torus (R, r): outer equator k = 1/r and 1/(R + r); inner equator 1/r and −1/(R − r)
    /// (a saddle). Cylinder side: 1/radius and 0. Tolerance: 5e-4 of the largest curvature
    /// (f32 gradients differenced over a step of about 1e-3; measured about 1e-4).
    #[test]
    fn curvature_of_torus_and_cylinder_matches_closed_forms() {
        use crate::curvature::curvature;
        let (big, small) = (1.0f32, 0.25f32);
        let torus = Torus::new(Vec3::ZERO, big, small).unwrap();
        let cyl =
            CappedCylinder::new(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0), 0.5).unwrap();
        let cases: [(&str, &dyn Field, Vec3, [f32; 2]); 5] = [
            (
                "torus outer equator",
                &torus,
                Vec3::new(big + small, 0.0, 0.0),
                [1.0 / small, 1.0 / (big + small)],
            ),
            (
                "torus outer equator, rotated",
                &torus,
                Vec3::new(0.0, -(big + small), 0.0),
                [1.0 / small, 1.0 / (big + small)],
            ),
            (
                "torus inner equator",
                &torus,
                Vec3::new(big - small, 0.0, 0.0),
                [1.0 / small, -1.0 / (big - small)],
            ),
            (
                "torus inner equator, rotated",
                &torus,
                Vec3::new(-(big - small) * 0.6, (big - small) * 0.8, 0.0),
                [1.0 / small, -1.0 / (big - small)],
            ),
            ("cylinder side", &cyl, Vec3::new(0.3, 0.4, 0.2), [2.0, 0.0]),
        ];
        let mut worst = 0.0f32;
        for (name, f, p, [k1, k2]) in cases {
            assert!(f.value(p).abs() < 1e-6, "{name}: {p} is not on the surface");
            let c = curvature(f.gradient(p), f.hessian(p)).expect(name);
            let err = (c.k1 - k1).abs().max((c.k2 - k2).abs());
            eprintln!(
                "{name}: k1 {} (want {k1}), k2 {} (want {k2}), error {err:.2e}",
                c.k1, c.k2
            );
            worst = worst.max(err);
            assert!(
                err < 5e-4 * k1.abs().max(1.0),
                "{name}: k = ({}, {}) vs ({k1}, {k2})",
                c.k1,
                c.k2
            );
        }
        eprintln!("primitive curvature via the finite-difference Hessian: max error {worst:.2e}");
    }

    #[test]
    fn sphere_hessian_is_analytic() {
        let s = Sphere::new(Vec3::new(0.1, 0.2, -0.3), 0.7).unwrap();
        let p = Vec3::new(0.9, -0.4, 0.3);
        let h = s.hessian(p);
        let e = 1e-3;
        for (k, ax) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
            let fd = (s.gradient(p + e * ax) - s.gradient(p - e * ax)) / (2.0 * e);
            assert!((h.col(k) - fd).length() < 1e-4, "{} vs {fd}", h.col(k));
        }
        assert_eq!(s.hessian(Vec3::new(0.1, 0.2, -0.3)), Mat3::ZERO);
    }

    #[test]
    fn outward_rounding() {
        let x = 0.1f64;
        assert!((f32_down(x) as f64) <= x && (f32_up(x) as f64) >= x && f32_down(x) < f32_up(x));
        assert_eq!(f32_down(1.0), 1.0);
        assert_eq!(f32_up(-0.0), 0.0);
        assert!(f32_down(1e-50) == 0.0 && f32_up(1e-50) > 0.0 && f32_down(-1e-50) < 0.0);
    }

    macro_rules! kind_tests {
        ($($name:ident),*) => {$(
            mod $name {
                #[test]
                fn brute_force_surface_and_scales() {
                    super::check_kind(stringify!($name));
                }
                #[test]
                fn gradient() {
                    super::check_gradient(stringify!($name));
                }
            }
        )*};
    }
    kind_tests!(
        sphere,
        cuboid,
        rounded_box,
        torus,
        capsule,
        capped_cylinder,
        capped_cone,
        plane,
        ellipsoid
    );
}
