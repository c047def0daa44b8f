//! Solids from 2D profiles: [`Extrude`] (along z, with optional rounded cap edges) and
//! [`Revolve`] (about the z axis, with an offset).
//!
//! A profile is a field that does not depend on `z` (`isokit_field::profile`, and any CSG
//! of profiles): its value at `(x, y, 0)` is a 2D signed distance. Both operations evaluate
//! the profile in the plane `z = 0` at a point computed from `p` (Quilez, "distance
//! functions": extrusion and revolution) and are exact when the profile is exact (the
//! revolution also needs the profile on the positive side of the axis).

use crate::csg::CsgError;
use glam::{DVec2, Vec3};
use isokit_field::{Aabb, DistanceBox, Field, value_clamped};

fn bad(name: &'static str, value: f32, why: &'static str) -> CsgError {
    CsgError::BadParameter { name, value, why }
}

/// `min(max(w.x, w.y), 0) + |max(w, 0)|`: the signed distance to the negative quadrant,
/// 1-Lipschitz in `w` (Quilez's extrusion and 2D box).
#[inline]
fn quadrant(w: DVec2) -> f64 {
    w.x.max(w.y).min(0.0) + w.max(DVec2::ZERO).length()
}

/// The xy-rectangle of a box and a profile's slack, when the profile has a distance box.
fn profile_rect(profile: &dyn Field) -> Option<(Aabb, f32)> {
    let d = profile.distance_box()?;
    if d.aabb.is_empty() {
        return None;
    }
    Some((d.aabb, d.slack))
}

// ---------------------------------------------------------------- extrude

/// A profile extruded along z from `−height/2` to `height/2`, its cap edges optionally
/// rounded with radius `round`:
///
/// `quadrant(d + round, |z| − height/2 + round) − round`, `d` the profile's value at
/// `(x, y, 0)` (Quilez, "opExtrusion"; with `round` the profile is eroded and the extrusion
/// dilated by it, which rounds the rim where the wall meets a cap and leaves the wall where
/// it is).
///
/// Exact when the profile is exact and `round = 0` (the distance to a right prism is the
/// quadrant distance in the coordinates (profile distance, height)); with `round > 0` a
/// bound (exact for convex profiles). Lipschitz: the profile's, at least 1 (the map
/// `p ↦ (d, z)` has the profile's slope in xy and 1 along z, orthogonally). Bounds: the
/// profile's rectangle times `[−height/2, height/2]`.
#[derive(Clone, Debug)]
pub struct Extrude<F> {
    profile: F,
    half: f64,
    round: f64,
    bounds: Aabb,
}

impl<F: Field> Extrude<F> {
    /// `profile` extruded to `height` (finite, > 0) with cap edges rounded by `round`
    /// (`0 ≤ round ≤ height/2`; 0 for sharp edges).
    pub fn new(profile: F, height: f32, round: f32) -> Result<Self, CsgError> {
        if !(height.is_finite() && height > 0.0) {
            return Err(bad("height", height, "must be finite and > 0"));
        }
        if !(round.is_finite() && round >= 0.0 && round <= 0.5 * height) {
            return Err(bad(
                "round",
                round,
                "must be finite, >= 0 and at most height/2",
            ));
        }
        let b = profile.bounds();
        let half = 0.5 * height as f64;
        let bounds = Aabb::new(
            Vec3::new(b.min.x, b.min.y, -(half as f32)),
            Vec3::new(b.max.x, b.max.y, half as f32),
        );
        Ok(Self {
            profile,
            half,
            round: round as f64,
            bounds,
        })
    }

    /// The profile.
    pub fn profile(&self) -> &F {
        &self.profile
    }

    #[inline]
    fn combine(&self, d: f32, z: f32) -> f32 {
        let r = self.round;
        let w = DVec2::new(d as f64 + r, (z as f64).abs() - self.half + r);
        (quadrant(w) - r) as f32
    }
}

impl<F: Field> Field for Extrude<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.combine(self.profile.value(Vec3::new(p.x, p.y, 0.0)), p.z)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.profile.lipschitz().max(1.0)
    }
    fn is_exact(&self) -> bool {
        self.round == 0.0 && self.profile.is_exact()
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let q = Vec3::new(p.x, p.y, 0.0);
        let r = self.round;
        let d = self.profile.value(q) as f64;
        let w = DVec2::new(d + r, (p.z as f64).abs() - self.half + r);
        let g = if w.x > 0.0 || w.y > 0.0 {
            let o = w.max(DVec2::ZERO);
            o / o.length()
        } else if w.x >= w.y {
            DVec2::X
        } else {
            DVec2::Y
        };
        let gp = self.profile.gradient(q);
        let sz = if p.z < 0.0 { -1.0 } else { 1.0 };
        Vec3::new(gp.x * g.x as f32, gp.y * g.x as f32, sz * g.y as f32)
    }
    /// The profile's distance box (its slack kept) times the slab: the value is at least the
    /// quadrant distance of (box distance in xy − slack, height), which is the distance to
    /// the extruded box less the slack (rounding only raises the value).
    fn distance_box(&self) -> Option<DistanceBox> {
        let (r, slack) = profile_rect(&self.profile)?;
        let h = self.half as f32;
        Some(DistanceBox {
            aabb: Aabb::new(
                Vec3::new(r.min.x, r.min.y, -h),
                Vec3::new(r.max.x, r.max.y, h),
            ),
            slack,
        })
    }
    /// `max(lower bound of the profile, |z| − height/2)` and the distance box's bound: the
    /// quadrant distance is at least the larger coordinate.
    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = self.profile.lower_bound(Vec3::new(p.x, p.y, 0.0));
        let lb = if lb.is_nan() { f32::NEG_INFINITY } else { lb };
        let slab = ((p.z as f64).abs() - self.half) as f32;
        let boxed = self
            .distance_box()
            .map_or(f32::NEG_INFINITY, |d| d.lower_bound(p));
        lb.max(slab).max(boxed)
    }
    /// The profile clamped to `cap + round`: the quadrant distance is non-decreasing in the
    /// profile's value and at least it, so a clamped profile value gives the clamped result.
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        let inner = cap + self.round as f32;
        let d = value_clamped(&self.profile, Vec3::new(p.x, p.y, 0.0), inner);
        self.combine(d, p.z).clamp(-cap, cap)
    }
}

// ---------------------------------------------------------------- revolve

/// A profile revolved about the z axis: the profile's `x` is the distance from the axis less
/// `offset`, its `y` is `z`: value `d(√(x² + y²) − offset, z)` (Quilez, "opRevolution").
///
/// Exact when the profile is exact and lies on the positive side (`x ≥ −offset` over its
/// bounds): the nearest point of a solid of revolution lies in the point's own meridian
/// half-plane. Where the profile crosses the axis the part beyond it is cut off, and the
/// value is a bound (a point of the profile across the axis is nearer in the meridian plane
/// than in space). A profile whose boundary runs *along* the axis (an edge at
/// `x = −offset`, as a closed vase's outline drawn to the axis has) is neither: the value is
/// `−ρ` beside the axis and 0 on it, a seam inside the solid that a mesher takes for surface;
/// draw such a profile across the axis instead (to `x < −offset`), which is a bound and has
/// no seam. Lipschitz: the profile's (`(ρ, z)` is a 1-Lipschitz map). Bounds: the
/// square of the largest radius times the profile's `y` range.
#[derive(Clone, Debug)]
pub struct Revolve<F> {
    profile: F,
    offset: f64,
    bounds: Aabb,
    exact: bool,
}

impl<F: Field> Revolve<F> {
    /// `profile` revolved about z with `offset` (finite) added to its `x`.
    pub fn new(profile: F, offset: f32) -> Result<Self, CsgError> {
        if !offset.is_finite() {
            return Err(bad("offset", offset, "must be finite"));
        }
        let b = profile.bounds();
        let (x0, x1) = (
            b.min.x as f64 + offset as f64,
            b.max.x as f64 + offset as f64,
        );
        if b.is_empty() || x1 < 0.0 {
            return Err(bad(
                "offset",
                offset,
                "leaves the whole profile across the axis (nothing to revolve)",
            ));
        }
        let bounds = if x1.is_finite() {
            let r = (x1 * (1.0 + 4.0 * f64::EPSILON)) as f32;
            let r = if (r as f64) < x1 { r.next_up() } else { r };
            Aabb::new(Vec3::new(-r, -r, b.min.y), Vec3::new(r, r, b.max.y))
        } else {
            Aabb::new(
                Vec3::new(f32::NEG_INFINITY, f32::NEG_INFINITY, b.min.y),
                Vec3::new(f32::INFINITY, f32::INFINITY, b.max.y),
            )
        };
        Ok(Self {
            exact: profile.is_exact() && x0 >= 0.0,
            profile,
            offset: offset as f64,
            bounds,
        })
    }

    /// The profile.
    pub fn profile(&self) -> &F {
        &self.profile
    }

    /// The profile's point for `p`: `(ρ − offset, z, 0)` (and ρ).
    #[inline]
    fn meridian(&self, p: Vec3) -> (Vec3, f64) {
        let rho = (p.x as f64).hypot(p.y as f64);
        (Vec3::new((rho - self.offset) as f32, p.z, 0.0), rho)
    }
}

impl<F: Field> Field for Revolve<F> {
    fn value(&self, p: Vec3) -> f32 {
        self.profile.value(self.meridian(p).0)
    }
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn lipschitz(&self) -> f32 {
        self.profile.lipschitz()
    }
    fn is_exact(&self) -> bool {
        self.exact
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let (q, rho) = self.meridian(p);
        let g = self.profile.gradient(q);
        let (cx, cy) = if rho > 0.0 {
            ((p.x as f64 / rho) as f32, (p.y as f64 / rho) as f32)
        } else {
            (1.0, 0.0)
        };
        Vec3::new(g.x * cx, g.x * cy, g.y)
    }
    /// The square of the profile's distance-box radius times its `y` range, the slack
    /// kept: outside it the meridian point lies at least as far from the profile's box.
    fn distance_box(&self) -> Option<DistanceBox> {
        let (r, slack) = profile_rect(&self.profile)?;
        let x1 = r.max.x as f64 + self.offset;
        if x1.is_nan() || x1 < 0.0 {
            return None;
        }
        let rr = (x1 * (1.0 + 4.0 * f64::EPSILON)) as f32;
        Some(DistanceBox {
            aabb: Aabb::new(Vec3::new(-rr, -rr, r.min.y), Vec3::new(rr, rr, r.max.y)),
            slack,
        })
    }
    fn lower_bound(&self, p: Vec3) -> f32 {
        let lb = self.profile.lower_bound(self.meridian(p).0);
        if lb.is_nan() { f32::NEG_INFINITY } else { lb }
    }
    fn value_clamped(&self, p: Vec3, cap: f32) -> f32 {
        value_clamped(&self.profile, self.meridian(p).0, cap)
    }
}
