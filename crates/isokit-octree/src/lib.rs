//! # isokit-octree: adaptively sampled fields in a hashed octree
//!
//! 002 Ch. 3: an octree of cubic cells over a cubic domain, samples at the cell corners
//! (*nodes*, shared between cells and stored once), trilinear interpolation inside a cell,
//! and cells found by hashing their level and position instead of following pointers.
//!
//! - [`HashedOctree`]: the hashed tree. Point location by binary search over the levels,
//!   neighbours by key arithmetic, node classification by the sibling rule, and an
//!   [`Accessor`] with small direct-mapped cell and node caches.
//! - [`LinkedOctree`]: the same tree with pointer children, the baseline of 002 Table 3.1.
//! - [`BuildOptions`]: top-down subdivision (Lipschitz culling for distance fields,
//!   look-ahead for general fields, an error bound, minimum and maximum level) or bottom-up
//!   coalescing of the dense finest grid.
//! - The [`Octree`] trait: what both trees offer, including export to a dense [`Grid`] or a
//!   narrow-band [`BrickGrid`] at any level.
//!
//! ## Levels
//! Level 0 is the root (the whole domain); the finest level is `max_level` (at most 21), with
//! `2^max_level` cells a side. (The thesis counts the other way: its level 0 is the finest.)
//! Cells and nodes are addressed by integer positions on the finest grid ([`Cell`]).
//!
//! ## Hanging nodes and continuity
//! A node on a face or edge of a coarser neighbouring leaf (a *hanging* node) takes that
//! leaf's trilinear interpolation (002 Sec. 3.4.1), computed from the coarsest leaves down,
//! so the piecewise trilinear field is continuous across every face; a node that is a corner
//! of every leaf around it holds the field's own value. The construction can subdivide
//! coarse leaves until no hanging value near the surface misses the field by more than half
//! the error bound ([`BuildOptions::refine_hanging`]).
//!
//! ## Memory accounting
//! [`Octree::memory_bytes`] counts what the structures hold, from capacities:
//! - hashed: std's `HashMap` (hashbrown) allocates `buckets = capacity · 8/7` slots of
//!   `size_of::<(K, V)>()` bytes plus one control byte each (and 16 trailing control bytes);
//!   see [`key::hashmap_bytes`]. Buckets are a power of two, so the load after construction
//!   lies between 7/16 and 7/8 and bytes per record vary by up to 2x with the count. Keys are
//!   32 bits for trees of at most 10 levels (a cell record is 4 bytes, 5 per bucket; a node
//!   record 8 bytes, 9 per bucket) and 64 bits beyond (8 + 1 and 12 + 1). One cell record
//!   stands for eight sibling cells.
//! - linked: 40 bytes per cell (a child pointer and eight `u32` node indices), allocated in
//!   blocks of eight with an estimated 16 bytes of allocator header per block
//!   ([`ALLOC_OVERHEAD`]), plus 4 bytes per node value.
//!
//! Per cell means per cell of the tree, inner and leaf (both trees have the same cells).
//! ERRATA 8: the thesis's 36 / 25 bytes assume 32-bit pointers; the claim to compare is the
//! ratio. The thesis's records were per cell in both trees and both linked cells to their
//! nodes; here both trees block siblings (one allocation or one hash record per eight) and the
//! hashed tree derives node keys from the cell key instead of storing links.
//!
//! ## Precision
//! Positions are f32 and map to the finest grid in f64. At level 20 in a domain of side 2 a
//! finest cell is about 64 f32 ulps at coordinate 0.3, so values carry about 1e-7 absolute
//! rounding from the positions alone.
#![warn(missing_docs)]

mod build;
mod domain;
mod error;
mod hashed;
mod interp;
pub mod key;
mod linked;
mod measure;

pub use build::{
    BuildOptions, BuildStats, Construction, Cull, DEFAULT_MAX_CELLS, MAX_LOOKAHEAD, NodeStatus,
};
pub use domain::{Cell, Domain};
pub use error::OctreeError;
pub use hashed::{Accessor, HashedOctree};
pub use interp::{trilerp, trilerp_gradient};
pub use key::{CacheStats, MAX_LEVEL};
pub use linked::{ALLOC_OVERHEAD, LinkedOctree};
pub use measure::{AccessRow, BoundMiss, TreeErrors, bound_misses, errors, table_3_1, test_points};

use glam::{DVec3, IVec3, UVec3, Vec3};
use isokit_field::{BrickGrid, Field, Grid};
use rayon::prelude::*;

/// What both octrees offer. Points outside the domain are clamped to it.
pub trait Octree: Field {
    /// The cubic domain and its finest grid.
    fn domain(&self) -> &Domain;

    /// The leaf containing `p` (clamped to the domain; points on a face between cells belong
    /// to the upper cell, except on the domain's upper faces).
    fn locate(&self, p: Vec3) -> Cell;

    /// Whether the tree has this cell (inner or leaf).
    fn contains(&self, cell: Cell) -> bool;

    /// Whether the tree has this cell as a leaf.
    fn is_leaf(&self, cell: Cell) -> bool;

    /// The values at the cell's corners (`n = x + 2y + 4z`), None if the tree has no such
    /// cell.
    fn corner_values(&self, cell: Cell) -> Option<[f32; 8]>;

    /// The neighbour of `cell` at offset `dir` (in cells of its size, e.g. `(1, 0, 0)` or
    /// `(-1, 1, 0)`): the cell of the same size there if the tree has it (it may be
    /// subdivided), else the coarser leaf covering that place; None outside the domain or if
    /// the tree has no `cell`.
    fn neighbor(&self, cell: Cell, dir: IVec3) -> Option<Cell>;

    /// Every leaf, sorted by (level, position).
    fn leaves(&self) -> Vec<Cell>;

    /// Cells, inner and leaf.
    fn cell_count(&self) -> usize;

    /// Distinct nodes.
    fn node_count(&self) -> usize;

    /// Heap and struct bytes, from capacities (see the crate docs).
    fn memory_bytes(&self) -> usize;

    /// What the construction did.
    fn build_stats(&self) -> &BuildStats;

    /// The value at `g` in finest-grid units (clamped to the domain).
    fn value_at_grid(&self, g: DVec3) -> f32;

    /// [`Octree::memory_bytes`] per cell.
    fn bytes_per_cell(&self) -> f64 {
        self.memory_bytes() as f64 / self.cell_count().max(1) as f64
    }

    /// The trilinear interpolation of `cell`'s corners at `p` (clamped to the cell), None if
    /// the tree has no such cell. On a face shared by two leaves both give the same value.
    fn cell_value(&self, cell: Cell, p: Vec3) -> Option<f32> {
        let c = self.corner_values(cell)?;
        let g = self.domain().to_grid(p);
        Some(trilerp(
            &c,
            hashed::in_cell(g, cell, self.domain().max_level()),
        ))
    }

    /// The field sampled on the nodes of `level` (`2^level + 1` samples a side over the
    /// domain), refused when larger than [`isokit_field::MAX_SAMPLES`] or when `level` is
    /// finer than the tree.
    fn to_grid(&self, level: u32) -> Result<Grid, OctreeError> {
        export_grid(self, level, |out, gs| {
            for (v, &g) in out.iter_mut().zip(gs) {
                *v = self.value_at_grid(g);
            }
        })
    }

    /// The band `|f| <= band` sampled at `level` into a [`BrickGrid`] (bricks of `brick`
    /// samples with an `apron`, background `+band`), lazily: bricks whose centre value rules
    /// out the band by the Lipschitz bound are skipped.
    fn to_brick_grid(
        &self,
        level: u32,
        brick: usize,
        apron: usize,
        band: f32,
    ) -> Result<BrickGrid, OctreeError>
    where
        Self: Sized,
    {
        let d = self.domain();
        if level > d.max_level() {
            return Err(OctreeError::bad(
                "export level",
                level,
                "must not exceed the tree's max level",
            ));
        }
        if !(band.is_finite() && band > 0.0) {
            return Err(OctreeError::bad(
                "band",
                band,
                "must be finite and positive",
            ));
        }
        let n = (1usize << level) + 1;
        Ok(BrickGrid::sample_field(
            self,
            [n, n, n],
            d.origin(),
            d.cell_side(level) as f32,
            brick,
            apron,
            band,
            band,
        )?)
    }
}

/// Whether `cell` is a possible cell of a tree of `max_level` levels.
pub(crate) fn valid_cell(cell: Cell, l: u32) -> bool {
    if cell.level > l {
        return false;
    }
    let s = 1u64 << (l - cell.level);
    let n = 1u64 << l;
    cell.pos
        .to_array()
        .iter()
        .all(|&v| (v as u64).is_multiple_of(s) && v as u64 + s <= n)
}

/// The position of `cell` moved by `dir` cells of its size, None outside the domain.
pub(crate) fn neighbor_pos(cell: Cell, dir: IVec3, l: u32) -> Option<UVec3> {
    let s = 1i64 << (l - cell.level);
    let n = 1i64 << l;
    let mut out = [0u32; 3];
    for a in 0..3 {
        let v = cell.pos[a] as i64 + dir[a] as i64 * s;
        if v < 0 || v + s > n {
            return None;
        }
        out[a] = v as u32;
    }
    Some(UVec3::from_array(out))
}

/// A grid of `2^level + 1` samples a side, filled row by row: `row(out, g)` writes the values
/// at the finest-grid points `g`.
pub(crate) fn export_grid<T: Octree + ?Sized>(
    t: &T,
    level: u32,
    row: impl Fn(&mut [f32], &[DVec3]) + Sync,
) -> Result<Grid, OctreeError> {
    let d = t.domain();
    let l = d.max_level();
    if level > l {
        return Err(OctreeError::bad(
            "export level",
            level,
            "must not exceed the tree's max level",
        ));
    }
    let n = (1usize << level) + 1;
    let mut grid = Grid::new([n, n, n], d.origin(), d.cell_side(level) as f32)?;
    let shift = l - level;
    grid.data_mut()
        .par_chunks_mut(n)
        .enumerate()
        .for_each(|(r, out)| {
            let (j, k) = ((r % n) as u32, (r / n) as u32);
            let gs: Vec<DVec3> = (0..n as u32)
                .map(|i| (UVec3::new(i, j, k) << shift).as_dvec3())
                .collect();
            row(out, &gs);
        });
    Ok(grid)
}
