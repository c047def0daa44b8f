//! Profiles: exact signed distances of 2D shapes in the xy-plane, as fields that do not
//! depend on `z`.
//!
//! A profile's value at `(x, y, z)` is the exact 2D signed distance of `(x, y)` to the shape,
//! which is also the exact 3D distance to the infinite prism over it (every point of the
//! prism's wall at height `z` is as near as any other), so a profile is an exact [`Field`]
//! like the 3D primitives, and every CSG combinator, offset and shell applies to it
//! unchanged: the union of two profiles is the profile of the 2D union, with the same
//! exactness rules as in 3D (Quilez, "2D distance functions"). The profile operations of
//! `isokit-levelset` turn them into solids (`extrude`, `revolve`), evaluating them in the
//! plane `z = 0`.
//!
//! Shapes: [`Circle`], [`Rectangle`], [`RoundedRectangle`], [`Polygon`] (any simple polygon
//! from its vertices, exact; regular polygons such as the hexagon by [`Polygon::regular`]),
//! [`Ellipse`] (exact, Eberly's method as for [`crate::primitives::Ellipsoid`]) and [`Slot`]
//! (a stadium: the points within a radius of a segment). [`Profile`] wraps them all.
//!
//! As for the 3D primitives, parameters and points are f32 and every evaluation runs in f64
//! and rounds once, so values are exact to one f32 rounding at 1e-6 and 1e6 scale alike.
//! Bounds are the shape's rectangle (rounded outward) and all of `z`.

use crate::primitives::{aabb_outward, ellipse_closest, f32_down, unit2_or};
use crate::{Aabb, Field, FieldError};
use glam::{DVec2, Vec2, Vec3};
use std::sync::Arc;

/// The f64 core of a profile.
trait Sdf2 {
    /// Exact signed distance of `q` to the shape, and its unit gradient (some unit vector
    /// where it is undefined).
    fn sd(&self, q: DVec2) -> (f64, DVec2);
    /// The shape's rectangle `(min, max)`.
    fn rect(&self) -> (DVec2, DVec2);
}

#[inline]
fn xy(p: Vec3) -> DVec2 {
    DVec2::new(p.x as f64, p.y as f64)
}

/// The box of a profile: its rectangle rounded outward, and all of `z`.
fn profile_bounds(lo: DVec2, hi: DVec2) -> Aabb {
    let b = aabb_outward(lo.extend(0.0), hi.extend(0.0));
    Aabb::new(
        Vec3::new(b.min.x, b.min.y, f32::NEG_INFINITY),
        Vec3::new(b.max.x, b.max.y, f32::INFINITY),
    )
}

/// The distance from `q` to the rectangle outside it, `−∞` inside: a lower bound of any exact
/// profile with that rectangle.
fn rect_lower_bound(lo: DVec2, hi: DVec2, q: DVec2) -> f32 {
    let d = (lo - q).max(q - hi).max(DVec2::ZERO);
    if d == DVec2::ZERO {
        return f32::NEG_INFINITY;
    }
    // Rounded down, so that it never exceeds the f32 value.
    f32_down(d.length() * (1.0 - 4.0 * f64::EPSILON))
}

macro_rules! field_from_sdf2 {
    ($($t:ty),*) => {$(
        impl Field for $t {
            fn value(&self, p: Vec3) -> f32 {
                self.sd(xy(p)).0 as f32
            }
            fn bounds(&self) -> Aabb {
                let (lo, hi) = self.rect();
                profile_bounds(lo, hi)
            }
            fn lipschitz(&self) -> f32 {
                1.0
            }
            fn is_exact(&self) -> bool {
                true
            }
            fn gradient(&self, p: Vec3) -> Vec3 {
                let g = self.sd(xy(p)).1;
                Vec3::new(g.x as f32, g.y as f32, 0.0)
            }
            fn lower_bound(&self, p: Vec3) -> f32 {
                let (lo, hi) = self.rect();
                rect_lower_bound(lo, hi, xy(p))
            }
            /// The rectangle (all of z), slack 0: the profile's operations (extrude,
            /// revolve) read it; a box unbounded in z prunes nothing by itself.
            fn distance_box(&self) -> Option<crate::DistanceBox> {
                Some(crate::DistanceBox::exact(self.bounds()))
            }
        }
    )*};
}

fn finite2(name: &'static str, v: Vec2) -> Result<DVec2, FieldError> {
    if v.is_finite() {
        Ok(v.as_dvec2())
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

fn positive2(name: &'static str, v: Vec2) -> Result<DVec2, FieldError> {
    if v.is_finite() && v.cmpgt(Vec2::ZERO).all() {
        Ok(v.as_dvec2())
    } else {
        Err(FieldError::bad(
            name,
            v,
            "every component must be finite and > 0",
        ))
    }
}

/// Signed distance of `q` (first quadrant) to the rectangle of half extents `h` at the
/// origin, and its gradient there (Quilez, "sdBox", exact).
fn box2_abs(q: DVec2, h: DVec2) -> (f64, DVec2) {
    let d = q - h;
    let out = d.max(DVec2::ZERO);
    if out.cmpgt(DVec2::ZERO).any() {
        (out.length(), unit2_or(out, DVec2::X))
    } else if d.x >= d.y {
        (d.x, DVec2::X)
    } else {
        (d.y, DVec2::Y)
    }
}

/// Componentwise sign with `+1` for zero.
fn sgn2(v: DVec2) -> DVec2 {
    DVec2::select(v.cmplt(DVec2::ZERO), DVec2::NEG_ONE, DVec2::ONE)
}

// ---------------------------------------------------------------- Circle

/// A disk of `radius` around `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    center: DVec2,
    radius: f64,
}

impl Circle {
    /// A circle; `center` finite, `radius` finite and > 0.
    pub fn new(center: Vec2, radius: f32) -> Result<Self, FieldError> {
        Ok(Self {
            center: finite2("center", center)?,
            radius: positive("radius", radius)?,
        })
    }
}

impl Sdf2 for Circle {
    fn sd(&self, q: DVec2) -> (f64, DVec2) {
        let v = q - self.center;
        (v.length() - self.radius, unit2_or(v, DVec2::X))
    }
    fn rect(&self) -> (DVec2, DVec2) {
        (self.center - self.radius, self.center + self.radius)
    }
}

// ---------------------------------------------------------------- Rectangle

/// An axis-aligned rectangle of half extents `half` around `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    center: DVec2,
    half: DVec2,
}

impl Rectangle {
    /// A rectangle; `half` components finite and > 0.
    pub fn new(center: Vec2, half: Vec2) -> Result<Self, FieldError> {
        Ok(Self {
            center: finite2("center", center)?,
            half: positive2("half", half)?,
        })
    }
}

impl Sdf2 for Rectangle {
    fn sd(&self, q: DVec2) -> (f64, DVec2) {
        let v = q - self.center;
        let (d, g) = box2_abs(v.abs(), self.half);
        (d, g * sgn2(v))
    }
    fn rect(&self) -> (DVec2, DVec2) {
        (self.center - self.half, self.center + self.half)
    }
}

// ---------------------------------------------------------------- RoundedRectangle

/// A rectangle of outer half extents `half` whose corners are rounded with `radius`: the
/// points within `radius` of the rectangle of half extents `half − radius` (exact, as the
/// offset of a convex set).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundedRectangle {
    center: DVec2,
    inner: DVec2,
    radius: f64,
}

impl RoundedRectangle {
    /// A rounded rectangle; `half` components finite and > 0, `0 ≤ radius ≤ min(half)`.
    pub fn new(center: Vec2, half: Vec2, radius: f32) -> Result<Self, FieldError> {
        let half = positive2("half", half)?;
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(FieldError::bad("radius", radius, "must be finite and >= 0"));
        }
        let radius = radius as f64;
        if radius > half.min_element() {
            return Err(FieldError::bad(
                "radius",
                radius,
                "must not exceed the smallest half extent",
            ));
        }
        Ok(Self {
            center: finite2("center", center)?,
            inner: half - radius,
            radius,
        })
    }
}

impl Sdf2 for RoundedRectangle {
    fn sd(&self, q: DVec2) -> (f64, DVec2) {
        let v = q - self.center;
        let (d, g) = box2_abs(v.abs(), self.inner);
        (d - self.radius, g * sgn2(v))
    }
    fn rect(&self) -> (DVec2, DVec2) {
        let h = self.inner + self.radius;
        (self.center - h, self.center + h)
    }
}

// ---------------------------------------------------------------- Polygon

/// The most vertices a polygon may have (each evaluation visits every edge).
pub const MAX_POLYGON_POINTS: usize = 1 << 20;

/// A polygon from its vertices (either orientation, closed implicitly), with the exact
/// distance to its edges signed by the even-odd rule (Quilez, "sdPolygon"): exact for every
/// simple polygon, convex or not. Each evaluation visits every edge.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    points: Arc<[DVec2]>,
    lo: DVec2,
    hi: DVec2,
    /// +1 when the vertices run counter-clockwise.
    orientation: f64,
}

impl Polygon {
    /// A polygon through `points`: at least 3 distinct, finite vertices (consecutive
    /// repeats, and a last vertex repeating the first, are dropped), enclosing a nonzero
    /// area, at most [`MAX_POLYGON_POINTS`].
    pub fn new(points: &[Vec2]) -> Result<Self, FieldError> {
        if points.len() > MAX_POLYGON_POINTS {
            return Err(FieldError::bad(
                "points",
                points.len(),
                "a polygon may have at most 2^20 vertices",
            ));
        }
        let mut v: Vec<DVec2> = Vec::with_capacity(points.len());
        for &p in points {
            let p = finite2("points", p)?;
            if v.last() != Some(&p) {
                v.push(p);
            }
        }
        while v.len() > 1 && v.first() == v.last() {
            v.pop();
        }
        if v.len() < 3 {
            return Err(FieldError::bad(
                "points",
                points.len(),
                "a polygon needs at least 3 distinct vertices",
            ));
        }
        let area2: f64 = (0..v.len())
            .map(|i| {
                let (a, b) = (v[i], v[(i + 1) % v.len()]);
                a.perp_dot(b)
            })
            .sum();
        let lo = v.iter().fold(DVec2::INFINITY, |m, &p| m.min(p));
        let hi = v.iter().fold(DVec2::NEG_INFINITY, |m, &p| m.max(p));
        let scale = (hi - lo).max_element();
        if area2.is_nan() || area2.abs() <= 1e-12 * scale * scale {
            return Err(FieldError::bad(
                "points",
                points.len(),
                "the polygon encloses no area (collinear vertices)",
            ));
        }
        Ok(Self {
            points: v.into(),
            lo,
            hi,
            orientation: area2.signum(),
        })
    }

    /// The regular polygon with `sides` (3 to 4096) corners on the circle of `radius`
    /// (the circumradius) around `center`, the first corner at `degrees` from the +x axis:
    /// `sides = 6, degrees = 0` is a hexagon with corners on the x axis and flat sides
    /// parallel to it.
    pub fn regular(
        center: Vec2,
        radius: f32,
        sides: u32,
        degrees: f32,
    ) -> Result<Self, FieldError> {
        if !(3..=4096).contains(&sides) {
            return Err(FieldError::bad("sides", sides, "must be 3 to 4096"));
        }
        let (c, r) = (finite2("center", center)?, positive("radius", radius)?);
        if !degrees.is_finite() {
            return Err(FieldError::bad("degrees", degrees, "must be finite"));
        }
        let a0 = (degrees as f64).to_radians();
        let pts: Vec<Vec2> = (0..sides)
            .map(|k| {
                let a = a0 + std::f64::consts::TAU * k as f64 / sides as f64;
                (c + r * DVec2::new(a.cos(), a.sin())).as_vec2()
            })
            .collect();
        Self::new(&pts)
    }

    /// The vertices (f64, repeats dropped).
    pub fn points(&self) -> &[DVec2] {
        &self.points
    }
}

impl Sdf2 for Polygon {
    fn sd(&self, q: DVec2) -> (f64, DVec2) {
        let v = &self.points;
        let n = v.len();
        let mut best = (f64::INFINITY, DVec2::ZERO, 0usize);
        let mut inside = false;
        let mut j = n - 1;
        for i in 0..n {
            let (a, b) = (v[i], v[j]);
            let e = b - a;
            let w = q - a;
            let t = (w.dot(e) / e.length_squared()).clamp(0.0, 1.0);
            let d = w - e * t;
            let dd = d.length_squared();
            if dd < best.0 {
                best = (dd, d, i);
            }
            // Even-odd crossing test of the edge against the horizontal ray from q.
            let c1 = q.y >= a.y;
            let c2 = q.y < b.y;
            let c3 = e.x * w.y > e.y * w.x;
            if (c1 && c2 && c3) || (!c1 && !c2 && !c3) {
                inside = !inside;
            }
            j = i;
        }
        let s = if inside { -1.0 } else { 1.0 };
        let (dd, d, i) = best;
        // The edge's outward normal where the point lies on it.
        let e = v[(i + n - 1) % n] - v[i];
        let normal = unit2_or(DVec2::new(-e.y, e.x) * self.orientation, DVec2::X);
        (s * dd.sqrt(), unit2_or(d * s, normal))
    }
    fn rect(&self) -> (DVec2, DVec2) {
        (self.lo, self.hi)
    }
}

// ---------------------------------------------------------------- Ellipse

/// An axis-aligned ellipse with semi-axes `radii` around `center`, with the exact distance
/// inside and outside (Eberly's method in f64, as [`crate::primitives::Ellipsoid`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    center: DVec2,
    radii: DVec2,
}

impl Ellipse {
    /// An ellipse; `radii` components finite and > 0 (equal radii give a circle).
    pub fn new(center: Vec2, radii: Vec2) -> Result<Self, FieldError> {
        Ok(Self {
            center: finite2("center", center)?,
            radii: positive2("radii", radii)?,
        })
    }
}

impl Sdf2 for Ellipse {
    fn sd(&self, q: DVec2) -> (f64, DVec2) {
        let v = q - self.center;
        let swap = self.radii.y > self.radii.x;
        let (e, y) = if swap {
            ([self.radii.y, self.radii.x], [v.y.abs(), v.x.abs()])
        } else {
            ([self.radii.x, self.radii.y], [v.x.abs(), v.y.abs()])
        };
        let (x, diff) = ellipse_closest(e, y);
        let inside = (y[0] / e[0]).powi(2) + (y[1] / e[1]).powi(2) < 1.0;
        let d = crate::primitives::robust_len(&diff);
        let normal = DVec2::new(x[0] / (e[0] * e[0]), x[1] / (e[1] * e[1]));
        let g = if d > 0.0 {
            DVec2::from_array(diff) * if inside { -1.0 } else { 1.0 }
        } else {
            normal
        };
        let g = if swap { DVec2::new(g.y, g.x) } else { g };
        (if inside { -d } else { d }, unit2_or(g, DVec2::X) * sgn2(v))
    }
    fn rect(&self) -> (DVec2, DVec2) {
        (self.center - self.radii, self.center + self.radii)
    }
}

// ---------------------------------------------------------------- Slot

/// A slot (stadium): the points within `radius` of the segment `a`–`b` (the 2D capsule;
/// `a == b` is a circle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    a: DVec2,
    b: DVec2,
    radius: f64,
}

impl Slot {
    /// A slot; endpoints finite (may coincide), `radius` finite and > 0.
    pub fn new(a: Vec2, b: Vec2, radius: f32) -> Result<Self, FieldError> {
        Ok(Self {
            a: finite2("a", a)?,
            b: finite2("b", b)?,
            radius: positive("radius", radius)?,
        })
    }
}

impl Sdf2 for Slot {
    fn sd(&self, q: DVec2) -> (f64, DVec2) {
        let (pa, ba) = (q - self.a, self.b - self.a);
        let bb = ba.length_squared();
        let t = if bb > 0.0 {
            (pa.dot(ba) / bb).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = pa - ba * t;
        let fallback = unit2_or(DVec2::new(-ba.y, ba.x), DVec2::X);
        (d.length() - self.radius, unit2_or(d, fallback))
    }
    fn rect(&self) -> (DVec2, DVec2) {
        (
            self.a.min(self.b) - self.radius,
            self.a.max(self.b) + self.radius,
        )
    }
}

field_from_sdf2!(Circle, Rectangle, RoundedRectangle, Polygon, Ellipse, Slot);

// ---------------------------------------------------------------- Profile

/// Any of the profiles, by value; implements [`Field`] by delegation.
#[derive(Clone, Debug, PartialEq)]
pub enum Profile {
    /// A [`Circle`].
    Circle(Circle),
    /// A [`Rectangle`].
    Rectangle(Rectangle),
    /// A [`RoundedRectangle`].
    RoundedRectangle(RoundedRectangle),
    /// A [`Polygon`].
    Polygon(Polygon),
    /// An [`Ellipse`].
    Ellipse(Ellipse),
    /// A [`Slot`].
    Slot(Slot),
}

macro_rules! profile_from {
    ($($t:ident),*) => {$(
        impl From<$t> for Profile {
            fn from(p: $t) -> Self {
                Profile::$t(p)
            }
        }
    )*};
}
profile_from!(Circle, Rectangle, RoundedRectangle, Polygon, Ellipse, Slot);

impl Profile {
    fn as_field(&self) -> &dyn Field {
        match self {
            Profile::Circle(p) => p,
            Profile::Rectangle(p) => p,
            Profile::RoundedRectangle(p) => p,
            Profile::Polygon(p) => p,
            Profile::Ellipse(p) => p,
            Profile::Slot(p) => p,
        }
    }

    /// The exact signed distance at the 2D point `q`, in f64 (before the final rounding).
    pub fn distance2(&self, q: DVec2) -> f64 {
        self.sdf2().sd(q).0
    }

    fn sdf2(&self) -> &dyn Sdf2 {
        match self {
            Profile::Circle(p) => p,
            Profile::Rectangle(p) => p,
            Profile::RoundedRectangle(p) => p,
            Profile::Polygon(p) => p,
            Profile::Ellipse(p) => p,
            Profile::Slot(p) => p,
        }
    }
}

impl Field for Profile {
    fn value(&self, p: Vec3) -> f32 {
        self.as_field().value(p)
    }
    fn bounds(&self) -> Aabb {
        self.as_field().bounds()
    }
    fn lipschitz(&self) -> f32 {
        1.0
    }
    fn is_exact(&self) -> bool {
        true
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.as_field().gradient(p)
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        self.as_field().lower_bound(p)
    }
    fn distance_box(&self) -> Option<crate::DistanceBox> {
        self.as_field().distance_box()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    /// A profile with an independent description: dense samples of its boundary (with the
    /// largest gap between neighbours) and an inside test.
    struct Case {
        name: &'static str,
        f: Profile,
        boundary: Vec<DVec2>,
        gap: f64,
        inside: Box<dyn Fn(DVec2) -> bool>,
    }

    /// Samples of the curve `c(t)`, `t ∈ [0, 1]`, of rough length `len`, about `h` apart;
    /// returns the samples and the largest gap.
    fn curve(c: impl Fn(f64) -> DVec2, len: f64, h: f64) -> (Vec<DVec2>, f64) {
        let n = (len / h).ceil().max(1.0) as usize;
        let pts: Vec<DVec2> = (0..=n).map(|k| c(k as f64 / n as f64)).collect();
        let gap = pts
            .windows(2)
            .map(|w| (w[1] - w[0]).length())
            .fold(0.0, f64::max);
        (pts, gap)
    }

    fn segment(a: DVec2, b: DVec2, h: f64) -> (Vec<DVec2>, f64) {
        curve(|t| a + (b - a) * t, (b - a).length(), h)
    }

    fn arc(c: DVec2, r: f64, a0: f64, a1: f64, h: f64) -> (Vec<DVec2>, f64) {
        curve(
            |t| {
                let a = a0 + (a1 - a0) * t;
                c + r * DVec2::new(a.cos(), a.sin())
            },
            r * (a1 - a0).abs(),
            h,
        )
    }

    fn join(parts: Vec<(Vec<DVec2>, f64)>) -> (Vec<DVec2>, f64) {
        let gap = parts.iter().map(|p| p.1).fold(0.0, f64::max);
        (parts.into_iter().flat_map(|p| p.0).collect(), gap)
    }

    /// Even-odd inside test by the winding angle (independent of the crossing test).
    fn winding_inside(poly: &[DVec2], q: DVec2) -> bool {
        let mut total = 0.0;
        for i in 0..poly.len() {
            let (a, b) = (poly[i] - q, poly[(i + 1) % poly.len()] - q);
            total += a.perp_dot(b).atan2(a.dot(b));
        }
        (total / TAU).round() as i64 % 2 != 0
    }

    fn polygon_edges(poly: &[DVec2], h: f64) -> (Vec<DVec2>, f64) {
        join(
            (0..poly.len())
                .map(|i| segment(poly[i], poly[(i + 1) % poly.len()], h))
                .collect(),
        )
    }

    /// A gear-like star: `n` teeth of depth `depth` on a circle of radius `r`.
    fn star(c: DVec2, r: f64, depth: f64, n: usize) -> Vec<DVec2> {
        (0..4 * n)
            .map(|k| {
                let a = TAU * k as f64 / (4 * n) as f64;
                let rr = if (k / 2) % 2 == 0 { r + depth } else { r };
                c + rr * DVec2::new(a.cos(), a.sin())
            })
            .collect()
    }

    /// The shapes at scale `s` (every length times `s`), centred near `c · s`.
    fn cases(s: f64, h: f64) -> Vec<Case> {
        let v = |x: f64, y: f64| DVec2::new(x, y) * s;
        let f2 = |p: DVec2| p.as_vec2();
        let mut out = vec![];
        {
            let (c, r) = (v(0.3, -0.2), 0.7 * s);
            let (b, gap) = arc(c, r, 0.0, TAU, h);
            out.push(Case {
                name: "circle",
                f: Circle::new(f2(c), r as f32).unwrap().into(),
                boundary: b,
                gap,
                inside: Box::new(move |q| (q - c).length() < r),
            });
        }
        {
            let (c, hh) = (v(-0.1, 0.2), v(0.8, 0.3));
            let corners = [
                c + DVec2::new(-hh.x, -hh.y),
                c + DVec2::new(hh.x, -hh.y),
                c + hh,
                c + DVec2::new(-hh.x, hh.y),
            ];
            let (b, gap) = polygon_edges(&corners, h);
            out.push(Case {
                name: "rectangle",
                f: Rectangle::new(f2(c), f2(hh)).unwrap().into(),
                boundary: b,
                gap,
                inside: Box::new(move |q| ((q - c).abs() - hh).max_element() < 0.0),
            });
        }
        {
            let (c, hh, r) = (v(0.2, 0.1), v(0.9, 0.5), 0.3 * s);
            let inner = hh - r;
            let mut parts = vec![];
            for k in 0..4 {
                let sx = [1.0, -1.0, -1.0, 1.0][k];
                let sy = [1.0, 1.0, -1.0, -1.0][k];
                let corner = c + DVec2::new(sx * inner.x, sy * inner.y);
                let a0 = FRAC_PI_2 * k as f64;
                parts.push(arc(corner, r, a0, a0 + FRAC_PI_2, h));
            }
            parts.push(segment(
                c + DVec2::new(inner.x, hh.y),
                c + DVec2::new(-inner.x, hh.y),
                h,
            ));
            parts.push(segment(
                c + DVec2::new(inner.x, -hh.y),
                c + DVec2::new(-inner.x, -hh.y),
                h,
            ));
            parts.push(segment(
                c + DVec2::new(hh.x, inner.y),
                c + DVec2::new(hh.x, -inner.y),
                h,
            ));
            parts.push(segment(
                c + DVec2::new(-hh.x, inner.y),
                c + DVec2::new(-hh.x, -inner.y),
                h,
            ));
            let (b, gap) = join(parts);
            out.push(Case {
                name: "rounded rectangle",
                f: RoundedRectangle::new(f2(c), f2(hh), r as f32)
                    .unwrap()
                    .into(),
                boundary: b,
                gap,
                inside: Box::new(move |q| {
                    let d = (q - c).abs() - inner;
                    d.max(DVec2::ZERO).length() + d.max_element().min(0.0) < r
                }),
            });
        }
        for (name, poly) in [
            (
                "L-shaped polygon",
                vec![
                    v(0.0, 0.0),
                    v(1.0, 0.0),
                    v(1.0, 0.3),
                    v(0.3, 0.3),
                    v(0.3, 1.0),
                    v(0.0, 1.0),
                ],
            ),
            ("star polygon", star(v(0.1, 0.0), 0.6 * s, 0.2 * s, 7)),
        ] {
            let pts: Vec<Vec2> = poly.iter().map(|&p| f2(p)).collect();
            let f = Polygon::new(&pts).unwrap();
            let exact: Vec<DVec2> = f.points().to_vec();
            let (b, gap) = polygon_edges(&exact, h);
            out.push(Case {
                name,
                f: f.into(),
                boundary: b,
                gap,
                inside: Box::new(move |q| winding_inside(&exact, q)),
            });
        }
        {
            let hex = Polygon::regular(f2(v(0.0, 0.1)), (0.6 * s) as f32, 6, 0.0).unwrap();
            let exact: Vec<DVec2> = hex.points().to_vec();
            let (b, gap) = polygon_edges(&exact, h);
            out.push(Case {
                name: "hexagon",
                f: hex.into(),
                boundary: b,
                gap,
                inside: Box::new(move |q| winding_inside(&exact, q)),
            });
        }
        for (name, radii) in [("ellipse", v(0.9, 0.35)), ("tall ellipse", v(0.25, 0.8))] {
            let c = v(-0.2, 0.1);
            let (b, gap) = curve(
                |t| c + DVec2::new(radii.x * (TAU * t).cos(), radii.y * (TAU * t).sin()),
                TAU * radii.max_element(),
                h,
            );
            out.push(Case {
                name,
                f: Ellipse::new(f2(c), f2(radii)).unwrap().into(),
                boundary: b,
                gap,
                inside: Box::new(move |q| {
                    let u = (q - c) / radii;
                    u.length_squared() < 1.0
                }),
            });
        }
        {
            let (a, b2, r) = (v(-0.5, -0.2), v(0.6, 0.4), 0.25 * s);
            let dir = (b2 - a).normalize();
            let n = DVec2::new(-dir.y, dir.x);
            let ang = n.y.atan2(n.x);
            let (bd, gap) = join(vec![
                segment(a + n * r, b2 + n * r, h),
                segment(a - n * r, b2 - n * r, h),
                arc(b2, r, ang - PI, ang, h),
                arc(a, r, ang, ang + PI, h),
            ]);
            out.push(Case {
                name: "slot",
                f: Slot::new(f2(a), f2(b2), r as f32).unwrap().into(),
                boundary: bd,
                gap,
                inside: Box::new(move |q| {
                    let (pa, ba) = (q - a, b2 - a);
                    let t = (pa.dot(ba) / ba.length_squared()).clamp(0.0, 1.0);
                    (pa - ba * t).length() < r
                }),
            });
        }
        out
    }

    /// Every profile against the brute-force distance to a dense sampling of its boundary
    /// and an independent inside test, at random points near, on and far from the shape,
    /// at unit, 1e-6 and 1e6 scale; values independent of z; gradients unit.
    #[test]
    fn profiles_are_exact_against_dense_boundary_samples() {
        let mut rng = SplitMix64::new(20);
        for s in [1.0, 1e-6, 1e6] {
            let h = 2e-3 * s;
            for c in cases(s, h) {
                let b = c.f.bounds();
                let (lo, hi) = (b.min.as_dvec3().truncate(), b.max.as_dvec3().truncate());
                assert!(b.min.z == f32::NEG_INFINITY && b.max.z == f32::INFINITY);
                let span = hi - lo;
                let mut pts: Vec<DVec2> = (0..400)
                    .map(|_| {
                        lo - 0.5 * span + 2.0 * span * DVec2::new(rng.next_f64(), rng.next_f64())
                    })
                    .collect();
                // Far away, and on the boundary itself.
                pts.extend(
                    (0..20)
                        .map(|k| lo + span * 1e3 * DVec2::new((k as f64).cos(), (k as f64).sin())),
                );
                let on: Vec<DVec2> = (0..40)
                    .map(|_| c.boundary[rng.below(c.boundary.len())])
                    .collect();
                for q in pts {
                    let q = q.as_vec2().as_dvec2();
                    let p = Vec3::new(q.x as f32, q.y as f32, rng.range(-5.0, 5.0) * s as f32);
                    let v = c.f.value(p) as f64;
                    let brute = c
                        .boundary
                        .iter()
                        .map(|&x| (x - q).length())
                        .fold(f64::INFINITY, f64::min);
                    let tol = 1e-6 * (s + q.abs().max_element());
                    assert!(
                        v.abs() <= brute + tol && v.abs() >= brute - c.gap - tol,
                        "{} at scale {s}: |{v}| vs brute {brute} (gap {}) at {q}",
                        c.name,
                        c.gap
                    );
                    if brute > c.gap + tol {
                        assert_eq!(
                            v < 0.0,
                            (c.inside)(q),
                            "{} at scale {s}: sign at {q}",
                            c.name
                        );
                    }
                    assert_eq!(c.f.value(Vec3::new(p.x, p.y, 0.0)), c.f.value(p));
                    let g = c.f.gradient(p);
                    assert!(
                        (g.length() - 1.0).abs() < 1e-5 && g.z == 0.0,
                        "{}: {g}",
                        c.name
                    );
                    assert!(
                        c.f.lower_bound(p) <= c.f.value(p),
                        "{}: lower bound",
                        c.name
                    );
                    if v <= 0.0 {
                        assert!(
                            b.contains(p),
                            "{}: inside point {q} outside the box",
                            c.name
                        );
                    }
                }
                for q in on {
                    let p = Vec3::new(q.x as f32, q.y as f32, 0.0);
                    let tol = 1e-6 * (s + q.abs().max_element());
                    assert!(
                        c.f.value(p).abs() as f64 <= tol,
                        "{} at scale {s}: {} on the boundary",
                        c.name,
                        c.f.value(p)
                    );
                }
                assert!(c.f.is_exact() && c.f.lipschitz() == 1.0);
            }
        }
    }

    /// Gradients point away from the nearest boundary point (finite differences agree away
    /// from corners).
    #[test]
    fn gradients_match_finite_differences() {
        let mut rng = SplitMix64::new(21);
        for c in cases(1.0, 1e-2) {
            let mut checked = 0;
            for _ in 0..300 {
                let p = rng.point_in(Vec3::new(-1.5, -1.5, 0.0), Vec3::new(1.5, 1.5, 0.0));
                let e = 1e-3f32;
                let fd = Vec3::new(
                    (c.f.value(p + e * Vec3::X) - c.f.value(p - e * Vec3::X)) / (2.0 * e),
                    (c.f.value(p + e * Vec3::Y) - c.f.value(p - e * Vec3::Y)) / (2.0 * e),
                    0.0,
                );
                if (fd.length() - 1.0).abs() < 1e-2 {
                    checked += 1;
                    assert!(
                        (c.f.gradient(p) - fd).length() < 2e-2,
                        "{}: {} vs {fd} at {p}",
                        c.name,
                        c.f.gradient(p)
                    );
                }
            }
            assert!(checked > 100, "{}: {checked}", c.name);
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let nan = f32::NAN;
        assert!(Circle::new(Vec2::ZERO, 0.0).is_err());
        assert!(Circle::new(Vec2::new(nan, 0.0), 1.0).is_err());
        assert!(Rectangle::new(Vec2::ZERO, Vec2::new(1.0, -1.0)).is_err());
        assert!(RoundedRectangle::new(Vec2::ZERO, Vec2::ONE, 1.5).is_err());
        assert!(Ellipse::new(Vec2::ZERO, Vec2::new(1.0, 0.0)).is_err());
        assert!(Slot::new(Vec2::ZERO, Vec2::ONE, -1.0).is_err());
        assert!(Polygon::new(&[Vec2::ZERO, Vec2::X]).is_err());
        assert!(Polygon::new(&[Vec2::ZERO, Vec2::X, Vec2::X, Vec2::ZERO]).is_err());
        assert!(Polygon::new(&[Vec2::ZERO, Vec2::X, 2.0 * Vec2::X]).is_err());
        assert!(Polygon::new(&[Vec2::ZERO, Vec2::X, Vec2::new(nan, 1.0)]).is_err());
        assert!(Polygon::regular(Vec2::ZERO, 1.0, 2, 0.0).is_err());
        // Repeats are dropped: the closed square with its first vertex repeated is a square.
        let sq =
            Polygon::new(&[Vec2::ZERO, Vec2::X, Vec2::X, Vec2::ONE, Vec2::Y, Vec2::ZERO]).unwrap();
        assert_eq!(sq.points().len(), 4);
        assert!((sq.value(Vec3::new(0.5, 0.5, 3.0)) + 0.5).abs() < 1e-7);
    }
}
