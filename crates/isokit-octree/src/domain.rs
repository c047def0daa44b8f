//! The cubic domain of an octree, its finest grid, and cells.

use crate::OctreeError;
use crate::key::{MAX_LEVEL, cell_key};
use glam::{DVec3, UVec3, Vec3};
use isokit_field::Aabb;

/// A cell: its level (0 = the root, the domain; `max_level` = the finest) and the position
/// of its lowest corner on the finest grid, aligned to its size `2^(max_level - level)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cell {
    /// Level: 0 for the root, `max_level` for the finest cells.
    pub level: u32,
    /// Lowest corner on the finest grid (each component a multiple of the cell's size).
    pub pos: UVec3,
}

/// Ordered by level, then z, y, x.
impl Ord for Cell {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        (self.level, self.pos.z, self.pos.y, self.pos.x).cmp(&(o.level, o.pos.z, o.pos.y, o.pos.x))
    }
}

impl PartialOrd for Cell {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Cell {
    /// The root cell.
    pub const ROOT: Cell = Cell {
        level: 0,
        pos: UVec3::ZERO,
    };

    /// Edge length in finest cells, `2^(max_level - level)` (the level must not exceed
    /// `max_level`, which must not exceed [`MAX_LEVEL`]; out of range gives a meaningless
    /// size, not a panic).
    #[inline]
    pub fn size(&self, max_level: u32) -> u32 {
        1u32.wrapping_shl(max_level.saturating_sub(self.level).min(31))
    }

    /// The hash key (see [`crate::key`]).
    #[inline]
    pub fn key(&self, max_level: u32) -> u64 {
        cell_key(
            self.level,
            self.pos >> max_level.saturating_sub(self.level).min(31),
        )
    }

    /// The `n`-th child (`n = x + 2y + 4z` of the octant). The cell must be above the finest
    /// level.
    #[inline]
    pub fn child(&self, n: usize, max_level: u32) -> Cell {
        let half = self.size(max_level) >> 1;
        Cell {
            level: self.level + 1,
            pos: self.pos + octant(n) * half,
        }
    }

    /// The parent (the root for the root).
    #[inline]
    pub fn parent(&self, max_level: u32) -> Cell {
        if self.level == 0 {
            return *self;
        }
        let mask = !(self.size(max_level).wrapping_shl(1).wrapping_sub(1));
        Cell {
            level: self.level - 1,
            pos: self.pos & UVec3::splat(mask),
        }
    }

    /// The ancestor at `level` (at most the cell's own level) containing this cell.
    #[inline]
    pub fn ancestor(&self, level: u32, max_level: u32) -> Cell {
        let shift = max_level.saturating_sub(level).min(31);
        let mask = !((1u32 << shift) - 1);
        Cell {
            level,
            pos: self.pos & UVec3::splat(mask),
        }
    }

    /// Finest-grid position of corner `n` (`n = x + 2y + 4z`).
    #[inline]
    pub fn corner(&self, n: usize, max_level: u32) -> UVec3 {
        self.pos + octant(n) * self.size(max_level)
    }

    /// Whether the finest-grid node `q` is one of the cell's corners.
    #[inline]
    pub fn has_corner(&self, q: UVec3, max_level: u32) -> bool {
        let s = self.size(max_level);
        let d = q.as_ivec3() - self.pos.as_ivec3();
        (d.x == 0 || d.x == s as i32)
            && (d.y == 0 || d.y == s as i32)
            && (d.z == 0 || d.z == s as i32)
    }
}

/// `(n & 1, n >> 1 & 1, n >> 2 & 1)`.
#[inline]
pub fn octant(n: usize) -> UVec3 {
    UVec3::new((n & 1) as u32, ((n >> 1) & 1) as u32, ((n >> 2) & 1) as u32)
}

/// The cubic domain of an octree and the mapping between world space and its finest grid:
/// `2^max_level` cells a side, nodes at `origin + h (x, y, z)` with `h = side / 2^max_level`.
/// The mapping works in f64, so positions keep their finest-grid resolution up to level 21.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain {
    origin: DVec3,
    side: f64,
    max_level: u32,
}

impl Domain {
    /// The cube centred on `bounds` whose side is the bounds' longest extent, split into
    /// `2^max_level` finest cells a side. Errors: empty or non-finite bounds, a zero-size
    /// box, `max_level` above [`MAX_LEVEL`].
    pub fn cube_around(bounds: Aabb, max_level: u32) -> Result<Self, OctreeError> {
        if max_level > MAX_LEVEL {
            return Err(OctreeError::bad(
                "max level",
                max_level,
                "at most 21 (cell keys are 64 bits)",
            ));
        }
        if bounds.is_empty() || !bounds.is_finite() {
            return Err(OctreeError::BadDomain(bounds));
        }
        let side = bounds.size().max_element() as f64;
        if !(side > 0.0 && side.is_finite()) {
            return Err(OctreeError::BadDomain(bounds));
        }
        let origin = bounds.center().as_dvec3() - DVec3::splat(0.5 * side);
        Ok(Self {
            origin,
            side,
            max_level,
        })
    }

    /// The same cube with a different number of levels.
    pub fn with_max_level(&self, max_level: u32) -> Result<Self, OctreeError> {
        if max_level > MAX_LEVEL {
            return Err(OctreeError::bad(
                "max level",
                max_level,
                "at most 21 (cell keys are 64 bits)",
            ));
        }
        Ok(Self { max_level, ..*self })
    }

    /// Finest level.
    pub fn max_level(&self) -> u32 {
        self.max_level
    }

    /// Lowest corner.
    pub fn origin(&self) -> Vec3 {
        self.origin.as_vec3()
    }

    /// Edge length.
    pub fn side(&self) -> f32 {
        self.side as f32
    }

    /// The cube as a box.
    pub fn bounds(&self) -> Aabb {
        Aabb::new(
            self.origin.as_vec3(),
            (self.origin + DVec3::splat(self.side)).as_vec3(),
        )
    }

    /// Finest cells per side, `2^max_level`.
    pub fn resolution(&self) -> u32 {
        1 << self.max_level
    }

    /// Edge length of a finest cell.
    pub fn finest_spacing(&self) -> f64 {
        self.side / (1u64 << self.max_level) as f64
    }

    /// Edge length of a cell at `level`.
    pub fn cell_side(&self, level: u32) -> f64 {
        self.side / (1u64 << level) as f64
    }

    /// World position of the finest-grid node `q`.
    #[inline]
    pub fn position(&self, q: UVec3) -> Vec3 {
        (self.origin + q.as_dvec3() * self.finest_spacing()).as_vec3()
    }

    /// `p` in finest-grid units, clamped to the domain (`[0, 2^max_level]` per axis). NaN
    /// components become 0.
    #[inline]
    pub fn to_grid(&self, p: Vec3) -> DVec3 {
        let g = (p.as_dvec3() - self.origin) / self.finest_spacing();
        let n = self.resolution() as f64;
        let c = |v: f64| if v.is_nan() { 0.0 } else { v.clamp(0.0, n) };
        DVec3::new(c(g.x), c(g.y), c(g.z))
    }

    /// The finest cell containing grid point `g` (from [`Domain::to_grid`]): its floor,
    /// with the domain's upper faces belonging to the last cell.
    #[inline]
    pub fn finest_cell(&self, g: DVec3) -> UVec3 {
        let top = self.resolution() - 1;
        UVec3::new(
            (g.x as u32).min(top),
            (g.y as u32).min(top),
            (g.z as u32).min(top),
        )
    }

    /// A cell's box in world space.
    pub fn cell_bounds(&self, c: Cell) -> Aabb {
        let s = c.size(self.max_level);
        Aabb::new(self.position(c.pos), self.position(c.pos + UVec3::splat(s)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_navigate_by_arithmetic() {
        let l = 5;
        let c = Cell {
            level: 3,
            pos: UVec3::new(8, 4, 28),
        };
        assert_eq!(c.size(l), 4);
        assert_eq!(
            c.parent(l),
            Cell {
                level: 2,
                pos: UVec3::new(8, 0, 24)
            }
        );
        assert_eq!(c.ancestor(0, l), Cell::ROOT);
        for n in 0..8 {
            assert_eq!(c.child(n, l).parent(l), c);
            assert!(c.has_corner(c.corner(n, l), l));
        }
        assert!(!c.has_corner(c.pos + UVec3::new(2, 0, 0), l));
        assert_ne!(c.key(l), c.parent(l).key(l));
    }

    #[test]
    fn domain_is_a_cube_around_the_bounds() {
        let d = Domain::cube_around(
            Aabb::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.5)),
            4,
        )
        .unwrap();
        assert_eq!(d.side(), 2.0);
        assert_eq!(d.origin(), Vec3::new(-1.0, -0.5, -0.75));
        assert_eq!(d.position(UVec3::splat(16)), Vec3::new(1.0, 1.5, 1.25));
        assert_eq!(d.finest_cell(d.to_grid(Vec3::splat(9.0))), UVec3::splat(15));
        assert_eq!(d.finest_cell(d.to_grid(Vec3::splat(-9.0))), UVec3::ZERO);
        assert!(Domain::cube_around(Aabb::EMPTY, 4).is_err());
        assert!(Domain::cube_around(Aabb::new(Vec3::ZERO, Vec3::ZERO), 4).is_err());
        assert!(Domain::cube_around(Aabb::new(Vec3::ZERO, Vec3::ONE), 22).is_err());
    }
}
