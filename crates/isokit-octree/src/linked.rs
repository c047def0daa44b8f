//! The linked (pointer) octree: the baseline the hashed octree is measured against.

use crate::build::{BuildOptions, BuildStats};
use crate::domain::{Cell, Domain};
use crate::hashed::{HashedOctree, in_cell};
use crate::interp::{trilerp, trilerp_gradient};
use crate::key::{KeyBuild, NodeKey};
use crate::{Octree, OctreeError};
use glam::{DVec3, IVec3, UVec3, Vec3};
use isokit_field::{Aabb, Field};
use std::collections::HashMap;

/// Estimated allocator overhead per boxed block of children: glibc's malloc rounds a
/// 320-byte request plus its 8-byte header up to a 336-byte chunk.
pub const ALLOC_OVERHEAD: usize = 16;

/// One cell of the linked tree: a pointer to its block of eight children and the indices of
/// its eight corner nodes (every cell, inner or leaf, links its corners, as in 002 Sec. 3.1).
#[derive(Clone, Debug)]
struct LinkedCell {
    children: Option<Box<[LinkedCell; 8]>>,
    nodes: [u32; 8],
}

/// The same octree as [`HashedOctree`] with pointer children: each cell holds
/// `Option<Box<[LinkedCell; 8]>>` (the eight children allocated together, one pointer per
/// cell) and `[u32; 8]` indices of its corner nodes in a shared `Vec<f32>`, so nodes are
/// stored once as in the hashed tree. Cells are found by walking down from the root, one
/// level per step (002 Sec. 3.3.1); neighbours by walking down to the neighbour's position.
///
/// Differences from the thesis's linked tree (Sec. 3.2): no parent pointer (no operation
/// here walks up), and siblings share one allocation instead of eight pointers per cell.
/// Both make this baseline smaller than the thesis's 9 pointers per cell.
///
/// It is built by the same construction as the hashed tree (run on a hashed topology, then
/// converted), so both hold the same cells and node values and give identical values at
/// every point.
#[derive(Clone, Debug)]
pub struct LinkedOctree {
    domain: Domain,
    root: LinkedCell,
    values: Vec<f32>,
    cells: usize,
    blocks: usize,
    lipschitz: f32,
    stats: BuildStats,
}

impl LinkedOctree {
    /// Builds the octree of `field` over the cube around `bounds` (see
    /// [`HashedOctree::build`]).
    pub fn build(
        field: &dyn Field,
        bounds: Aabb,
        opts: &BuildOptions,
    ) -> Result<Self, OctreeError> {
        Ok(Self::from_hashed(&HashedOctree::build(
            field, bounds, opts,
        )?))
    }

    /// The linked form of a hashed octree: same cells, same node values.
    pub fn from_hashed(h: &HashedOctree) -> Self {
        let domain = *h.domain();
        let l = domain.max_level();
        let mut conv = Converter {
            h,
            l,
            index: HashMap::with_capacity_and_hasher(h.node_count(), KeyBuild::default()),
            values: Vec::with_capacity(h.node_count()),
            cells: 0,
            blocks: 0,
        };
        let root = conv.cell(Cell::ROOT);
        let Converter {
            mut values,
            cells,
            blocks,
            ..
        } = conv;
        values.shrink_to_fit();
        Self {
            domain,
            root,
            values,
            cells,
            blocks,
            lipschitz: h.lipschitz(),
            stats: h.stats().clone(),
        }
    }

    /// What the construction did.
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }

    /// The cell at `cell`'s position, walking down until its level or a leaf.
    #[inline]
    fn walk(&self, pos: UVec3, level: u32) -> (&LinkedCell, Cell) {
        let l = self.domain.max_level();
        let mut c = &self.root;
        let mut depth = 0;
        while depth < level {
            let Some(ch) = &c.children else { break };
            depth += 1;
            let s = l - depth;
            let n = ((pos.x >> s) & 1) | (((pos.y >> s) & 1) << 1) | (((pos.z >> s) & 1) << 2);
            c = &ch[n as usize];
        }
        let cell = Cell {
            level: depth,
            pos: pos & UVec3::splat(!((1u32 << (l - depth)) - 1)),
        };
        (c, cell)
    }

    #[inline]
    fn corners_of(&self, c: &LinkedCell) -> [f32; 8] {
        c.nodes.map(|i| self.values[i as usize])
    }
}

struct Converter<'a> {
    h: &'a HashedOctree,
    l: u32,
    index: HashMap<NodeKey, u32, KeyBuild>,
    values: Vec<f32>,
    cells: usize,
    blocks: usize,
}

impl Converter<'_> {
    fn cell(&mut self, c: Cell) -> LinkedCell {
        self.cells += 1;
        let nodes = std::array::from_fn(|n| {
            let q = c.corner(n, self.l);
            let k = NodeKey::new(q, self.l);
            if let Some(&i) = self.index.get(&k) {
                return i;
            }
            let i = self.values.len() as u32;
            self.values.push(self.h.node_value(q).unwrap_or(f32::NAN));
            self.index.insert(k, i);
            i
        });
        let children = self.h.is_subdivided(c).then(|| {
            self.blocks += 1;
            Box::new(std::array::from_fn(|n| self.cell(c.child(n, self.l))))
        });
        LinkedCell { children, nodes }
    }
}

impl Octree for LinkedOctree {
    fn domain(&self) -> &Domain {
        &self.domain
    }

    fn locate(&self, p: Vec3) -> Cell {
        let f = self.domain.finest_cell(self.domain.to_grid(p));
        self.walk(f, self.domain.max_level()).1
    }

    fn contains(&self, cell: Cell) -> bool {
        crate::valid_cell(cell, self.domain.max_level())
            && self.walk(cell.pos, cell.level).1.level == cell.level
    }

    fn is_leaf(&self, cell: Cell) -> bool {
        if !crate::valid_cell(cell, self.domain.max_level()) {
            return false;
        }
        let (c, found) = self.walk(cell.pos, cell.level);
        found.level == cell.level && c.children.is_none()
    }

    fn corner_values(&self, cell: Cell) -> Option<[f32; 8]> {
        if !crate::valid_cell(cell, self.domain.max_level()) {
            return None;
        }
        let (c, found) = self.walk(cell.pos, cell.level);
        (found.level == cell.level).then(|| self.corners_of(c))
    }

    fn neighbor(&self, cell: Cell, dir: IVec3) -> Option<Cell> {
        if !self.contains(cell) {
            return None;
        }
        let npos = crate::neighbor_pos(cell, dir, self.domain.max_level())?;
        Some(self.walk(npos, cell.level).1)
    }

    fn leaves(&self) -> Vec<Cell> {
        let l = self.domain.max_level();
        let mut out = Vec::new();
        let mut stack = vec![(&self.root, Cell::ROOT)];
        while let Some((c, cell)) = stack.pop() {
            match &c.children {
                None => out.push(cell),
                Some(ch) => {
                    for (n, child) in ch.iter().enumerate() {
                        stack.push((child, cell.child(n, l)));
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }

    fn cell_count(&self) -> usize {
        self.cells
    }

    fn node_count(&self) -> usize {
        self.values.len()
    }

    /// The struct, the boxed blocks of eight cells plus [`ALLOC_OVERHEAD`] each, and the
    /// node values' capacity.
    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.blocks * (8 * std::mem::size_of::<LinkedCell>() + ALLOC_OVERHEAD)
            + self.values.capacity() * std::mem::size_of::<f32>()
    }

    fn build_stats(&self) -> &BuildStats {
        &self.stats
    }

    fn value_at_grid(&self, g: DVec3) -> f32 {
        let l = self.domain.max_level();
        let (c, cell) = self.walk(self.domain.finest_cell(g), l);
        trilerp(&self.corners_of(c), in_cell(g, cell, l))
    }
}

impl Field for LinkedOctree {
    fn value(&self, p: Vec3) -> f32 {
        if p.is_nan() {
            return f32::NAN;
        }
        self.value_at_grid(self.domain.to_grid(p))
    }

    fn bounds(&self) -> Aabb {
        self.domain.bounds()
    }

    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let l = self.domain.max_level();
        let g = self.domain.to_grid(p);
        let (c, cell) = self.walk(self.domain.finest_cell(g), l);
        let side = self.domain.cell_side(cell.level) as f32;
        trilerp_gradient(&self.corners_of(c), in_cell(g, cell, l)) / side
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linked_cell_is_a_pointer_and_eight_indices() {
        assert_eq!(std::mem::size_of::<LinkedCell>(), 40);
    }
}
