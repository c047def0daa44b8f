//! Axis-aligned bounding boxes.

use glam::Vec3;

/// An axis-aligned box `[min, max]` in world units.
///
/// A box with `min > max` on any axis is *empty*; [`Aabb::EMPTY`] is the identity of
/// [`Aabb::union`]. Infinite extents are allowed (an unbounded field such as a plane
/// reports [`Aabb::INFINITE`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

/// `[x0, y0, z0] .. [x1, y1, z1]`, or `empty` (for messages).
impl std::fmt::Display for Aabb {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_empty() {
            return write!(f, "empty");
        }
        let v = |v: glam::Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
        write!(f, "{} .. {}", v(self.min), v(self.max))
    }
}

impl Aabb {
    /// The empty box: contains nothing, and `EMPTY.union(b) == b`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The whole space.
    pub const INFINITE: Aabb = Aabb {
        min: Vec3::splat(f32::NEG_INFINITY),
        max: Vec3::splat(f32::INFINITY),
    };

    /// A box from its two corners (taken as given; see [`Aabb::from_corners`] to sort them).
    pub const fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The box spanned by two arbitrary corners.
    pub fn from_corners(a: Vec3, b: Vec3) -> Self {
        Self::new(a.min(b), a.max(b))
    }

    /// A box centred at `center` with half extents `half`.
    pub fn from_center_half(center: Vec3, half: Vec3) -> Self {
        Self::new(center - half.abs(), center + half.abs())
    }

    /// The smallest box holding every point (empty for no points). Non-finite points are skipped.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        points
            .into_iter()
            .filter(|p| p.is_finite())
            .fold(Self::EMPTY, |b, p| b.including(*p))
    }

    /// True when the box contains no point.
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// True when both corners are finite.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// Size along each axis (`max - min`; negative for empty boxes).
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Length of the diagonal (0 for empty boxes).
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            self.size().length()
        }
    }

    /// The box grown to contain `p`.
    pub fn including(&self, p: Vec3) -> Self {
        Self::new(self.min.min(p), self.max.max(p))
    }

    /// Smallest box containing both.
    pub fn union(&self, other: &Aabb) -> Self {
        Self::new(self.min.min(other.min), self.max.max(other.max))
    }

    /// The common part (possibly empty).
    pub fn intersection(&self, other: &Aabb) -> Self {
        Self::new(self.min.max(other.min), self.max.min(other.max))
    }

    /// The box grown by `d` on every side (shrunk for negative `d`).
    pub fn expanded(&self, d: f32) -> Self {
        Self::new(self.min - Vec3::splat(d), self.max + Vec3::splat(d))
    }

    /// True when `p` lies inside or on the boundary.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// True when the two boxes share at least a boundary point.
    pub fn overlaps(&self, other: &Aabb) -> bool {
        !self.intersection(other).is_empty()
    }

    /// Euclidean distance from `p` to the box (0 inside).
    pub fn distance(&self, p: Vec3) -> f32 {
        (self.min - p).max(p - self.max).max(Vec3::ZERO).length()
    }

    /// The exact signed distance from `p` to the box, negative inside (Quilez, "sdBox"):
    /// outside it equals [`Aabb::distance`] (the same f32 expression), inside it is minus the
    /// distance to the nearest face. Infinite extents are allowed (an axis unbounded on both
    /// sides never limits the box); [`f32::NEG_INFINITY`] for [`Aabb::INFINITE`], `+∞` for an
    /// empty box.
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        if self.is_empty() {
            return f32::INFINITY;
        }
        let q = (self.min - p).max(p - self.max);
        if q.cmpgt(Vec3::ZERO).any() {
            q.max(Vec3::ZERO).length()
        } else {
            q.max_element()
        }
    }

    /// The eight corners, x fastest.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { a.x } else { b.x },
                if i & 2 == 0 { a.y } else { b.y },
                if i & 4 == 0 { a.z } else { b.z },
            )
        })
    }

    /// Parameter interval `[t0, t1]` where the ray `origin + t * dir` is inside the box,
    /// or `None` when it misses. `t0` may be negative when the origin is inside.
    /// Rays along a face plane count as hitting (slab test with the NaN cases resolved).
    pub fn ray_interval(&self, origin: Vec3, dir: Vec3) -> Option<(f32, f32)> {
        let mut t0 = f32::NEG_INFINITY;
        let mut t1 = f32::INFINITY;
        for a in 0..3 {
            let (o, d, lo, hi) = (origin[a], dir[a], self.min[a], self.max[a]);
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d;
            let (mut ta, mut tb) = ((lo - o) * inv, (hi - o) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_is_union_identity() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.union(&b), b);
        assert!(!b.is_empty());
        assert_eq!(Aabb::EMPTY.diagonal(), 0.0);
    }

    #[test]
    fn distance_and_contains() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert!(b.contains(Vec3::splat(0.5)));
        assert!(b.contains(Vec3::ONE));
        assert!(!b.contains(Vec3::new(1.5, 0.5, 0.5)));
        assert_eq!(b.distance(Vec3::new(2.0, 0.5, 0.5)), 1.0);
        assert!((b.distance(Vec3::new(2.0, 2.0, 0.5)) - 2f32.sqrt()).abs() < 1e-6);
        assert_eq!(b.distance(Vec3::splat(0.3)), 0.0);
    }

    #[test]
    fn ray_interval_cases() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let (t0, t1) = b.ray_interval(Vec3::new(-1.0, 0.5, 0.5), Vec3::X).unwrap();
        assert_eq!((t0, t1), (1.0, 2.0));
        // Along a face plane: a grazing ray still counts.
        assert!(b.ray_interval(Vec3::new(-1.0, 0.0, 0.0), Vec3::X).is_some());
        // Parallel and outside.
        assert!(b.ray_interval(Vec3::new(-1.0, 2.0, 0.5), Vec3::X).is_none());
        // Origin inside gives t0 < 0.
        let (t0, _) = b.ray_interval(Vec3::splat(0.5), Vec3::Z).unwrap();
        assert!(t0 < 0.0);
    }

    #[test]
    fn from_points_skips_nan() {
        let pts = [Vec3::ZERO, Vec3::NAN, Vec3::new(1.0, 2.0, 3.0)];
        let b = Aabb::from_points(&pts);
        assert_eq!(b, Aabb::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)));
        assert_eq!(b.corners()[7], Vec3::new(1.0, 2.0, 3.0));
    }
}
