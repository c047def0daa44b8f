//! The hashed octree (002 Ch. 3): cells found by hashing their level and position.

use crate::build::{self, BuildOptions, BuildStats, NodeStatus};
use crate::domain::{Cell, Domain};
use crate::interp::{trilerp, trilerp_gradient};
use crate::key::{CacheStats, DirectCache, KeyMap, NARROW_LEVELS, NodeKey};
use crate::{Octree, OctreeError};
use glam::{DVec3, IVec3, UVec3, Vec3};
use isokit_field::{Aabb, Field, Grid, Job};
use rayon::prelude::*;

/// An adaptively sampled field in a hashed octree.
///
/// Storage (see the crate docs for the accounting; keys are 32 bits for trees of at most
/// [`NARROW_LEVELS`] levels):
/// - **Cells**: a hash set of the keys of *subdivided* cells. A cell exists iff it is the
///   root or its parent is in the set, and it is a leaf iff it exists and is not in the set;
///   so one record stands for a block of eight siblings (the sibling rule of 002 Sec. 3.3.3,
///   and the blocking of Sec. 3.4.3 that the thesis did not use). Cells carry no data: their
///   corner nodes follow from their key.
/// - **Nodes**: a hash map from the node's finest-grid key to its value, each node stored
///   once however many cells share it.
///
/// Point location is a binary search over the levels (Sec. 3.3.1) whose first probe tests
/// the level holding most leaves (one probe for most points near the surface);
/// [`HashedOctree::locate_binary`] is the plain search. Neighbours come from key arithmetic,
/// node classification from the sibling rule. [`HashedOctree::accessor`] adds the small
/// direct-mapped cell and node caches of Sec. 3.4.2.
///
/// ```
/// use isokit_octree::{HashedOctree, BuildOptions, Octree};
/// use isokit_field::{primitives::Sphere, Aabb, Field};
/// use glam::Vec3;
/// let sphere = Sphere::new(Vec3::ZERO, 1.0).unwrap();
/// let mut opts = BuildOptions::new(6);
/// opts.error = 1e-2;
/// let tree = HashedOctree::build(&sphere, sphere.bounds().expanded(0.2), &opts).unwrap();
/// let p = Vec3::new(0.3, 0.9, 0.1);
/// assert!((tree.value(p) - sphere.value(p)).abs() < 1e-2);
/// assert!(tree.stats().dense_fraction < 0.5);
/// ```
#[derive(Clone, Debug)]
pub struct HashedOctree {
    domain: Domain,
    subdivided: KeyMap<u64, ()>,
    nodes: KeyMap<NodeKey, f32>,
    lipschitz: f32,
    hint: u32,
    stats: BuildStats,
}

impl HashedOctree {
    /// Builds the octree of `field` over the cube around `bounds` (centred, side = the
    /// longest extent). Errors: bad options or bounds, a non-finite field value, a dense grid
    /// too large for the bottom-up construction.
    pub fn build(
        field: &dyn Field,
        bounds: Aabb,
        opts: &BuildOptions,
    ) -> Result<Self, OctreeError> {
        Self::build_job(field, bounds, opts, &Job::new())
    }

    /// [`HashedOctree::build`] reporting its progress to `job` (stage `octree level K of
    /// L`, in cells of that level's frontier; `sampling the finest octree level`, in z
    /// slices, for the bottom-up construction) and stopping with
    /// [`OctreeError::Cancelled`] once the job is cancelled.
    ///
    /// ```
    /// use glam::Vec3;
    /// use isokit_field::{Aabb, Job, primitives::Sphere};
    /// use isokit_octree::{BuildOptions, HashedOctree, OctreeError};
    /// use std::sync::{Arc, Mutex};
    ///
    /// let sphere = Sphere::new(Vec3::ZERO, 0.6).unwrap();
    /// let bounds = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
    /// let stages = Arc::new(Mutex::new(Vec::new()));
    /// let seen = stages.clone();
    /// let job = Job::new().with_progress(move |stage, done, total| {
    ///     if done == total {
    ///         seen.lock().unwrap().push(stage.to_owned());
    ///     }
    /// });
    /// HashedOctree::build_job(&sphere, bounds, &BuildOptions::new(5), &job).unwrap();
    /// assert!(stages.lock().unwrap().contains(&"octree level 4 of 5".to_owned()));
    ///
    /// job.cancel();
    /// let err = HashedOctree::build_job(&sphere, bounds, &BuildOptions::new(5), &job);
    /// assert!(matches!(err, Err(OctreeError::Cancelled(_))));
    /// ```
    pub fn build_job(
        field: &dyn Field,
        bounds: Aabb,
        opts: &BuildOptions,
        job: &Job,
    ) -> Result<Self, OctreeError> {
        let b = build::build(field, bounds, opts, job)?;
        let hint = b
            .stats
            .leaves_per_level
            .iter()
            .enumerate()
            .max_by_key(|&(level, &n)| (n, level))
            .map_or(0, |(level, _)| level as u32);
        let narrow = b.domain.max_level() <= NARROW_LEVELS;
        let subdivided = KeyMap::from_pairs(narrow, b.subdivided.keys().map(|&k| (k, ())));
        drop(b.subdivided);
        let nodes = KeyMap::from_pairs(narrow, b.nodes.iter().map(|(k, &v)| (k.get(), v)));
        drop(b.nodes);
        Ok(Self {
            domain: b.domain,
            subdivided,
            nodes,
            lipschitz: b.lipschitz,
            hint,
            stats: b.stats,
        })
    }

    /// What the construction did.
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }

    /// Whether `cell` is subdivided (has children).
    #[inline]
    pub fn is_subdivided(&self, cell: Cell) -> bool {
        cell.level < self.domain.max_level() && self.sub(cell)
    }

    #[inline]
    fn sub(&self, c: Cell) -> bool {
        self.subdivided.contains(c.key(self.domain.max_level()))
    }

    /// Subdivided cells (one hash record each).
    pub fn subdivided_count(&self) -> usize {
        self.subdivided.len()
    }

    /// The leaf containing `p` by the plain binary search over levels (no first guess).
    pub fn locate_binary(&self, p: Vec3) -> Cell {
        let l = self.domain.max_level();
        let f = self.domain.finest_cell(self.domain.to_grid(p));
        build::locate_leaf(f, l, l, None, |c| self.sub(c))
    }

    #[inline]
    fn locate_finest(&self, f: UVec3) -> Cell {
        let l = self.domain.max_level();
        build::locate_leaf(f, l, l, Some(self.hint), |c| self.sub(c))
    }

    /// The value stored at the finest-grid node `q`, or None if `q` is not a node.
    pub fn node_value(&self, q: UVec3) -> Option<f32> {
        if q.cmpgt(UVec3::splat(self.domain.resolution())).any() {
            return None;
        }
        self.nodes
            .get(NodeKey::new(q, self.domain.max_level()).get())
    }

    /// Whether `q` is a node, and whether it hangs, through the cells alone (the sibling
    /// rule of 002 Sec. 3.3.3: one probe per distinct parent of the cells around `q`).
    pub fn node_status(&self, q: UVec3) -> NodeStatus {
        let l = self.domain.max_level();
        build::node_status(q, l, |c| self.sub(c))
    }

    /// A cursor with its own direct-mapped cell and node caches (002 Sec. 3.4.2), for runs
    /// of nearby queries. Not shared between threads: make one per thread.
    pub fn accessor(&self) -> Accessor<'_> {
        Accessor {
            tree: self,
            cells: DirectCache::default(),
            nodes: DirectCache::default(),
        }
    }

    /// Bytes of the cell set and the node map, split: `(cells, nodes)` (see
    /// [`crate::key::hashmap_bytes`]).
    pub fn memory_split(&self) -> (usize, usize) {
        (self.subdivided.bytes(), self.nodes.bytes())
    }

    /// Whether the maps use 32-bit keys (trees of at most [`NARROW_LEVELS`] levels).
    pub fn narrow_keys(&self) -> bool {
        matches!(self.nodes, KeyMap::Narrow(_))
    }

    fn corners_of(&self, cell: Cell) -> [f32; 8] {
        let l = self.domain.max_level();
        std::array::from_fn(|n| {
            self.nodes
                .get(NodeKey::new(cell.corner(n, l), l).get())
                .unwrap_or(f32::NAN)
        })
    }
}

/// Position of grid point `g` in `cell`, in `[0, 1]^3`.
#[inline]
pub(crate) fn in_cell(g: DVec3, cell: Cell, l: u32) -> Vec3 {
    let s = cell.size(l) as f64;
    ((g - cell.pos.as_dvec3()) / s)
        .clamp(DVec3::ZERO, DVec3::ONE)
        .as_vec3()
}

impl Octree for HashedOctree {
    fn domain(&self) -> &Domain {
        &self.domain
    }

    fn locate(&self, p: Vec3) -> Cell {
        self.locate_finest(self.domain.finest_cell(self.domain.to_grid(p)))
    }

    fn contains(&self, cell: Cell) -> bool {
        let l = self.domain.max_level();
        crate::valid_cell(cell, l) && (cell.level == 0 || self.sub(cell.parent(l)))
    }

    fn is_leaf(&self, cell: Cell) -> bool {
        self.contains(cell) && !self.is_subdivided(cell)
    }

    fn corner_values(&self, cell: Cell) -> Option<[f32; 8]> {
        self.contains(cell).then(|| self.corners_of(cell))
    }

    fn neighbor(&self, cell: Cell, dir: IVec3) -> Option<Cell> {
        let l = self.domain.max_level();
        if !self.contains(cell) {
            return None;
        }
        let npos = crate::neighbor_pos(cell, dir, l)?;
        let n = Cell {
            level: cell.level,
            pos: npos,
        };
        if self.contains(n) {
            return Some(n);
        }
        // The parent of n is not subdivided: the coarser leaf covering it.
        Some(build::locate_leaf(npos, l, cell.level - 1, None, |c| {
            self.sub(c)
        }))
    }

    fn leaves(&self) -> Vec<Cell> {
        build::leaves_from(&self.subdivided.keys(), self.domain.max_level(), &|c| {
            self.sub(c)
        })
    }

    fn cell_count(&self) -> usize {
        8 * self.subdivided.len() + 1
    }

    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    fn memory_bytes(&self) -> usize {
        let (c, n) = self.memory_split();
        std::mem::size_of::<Self>() + c + n
    }

    fn build_stats(&self) -> &BuildStats {
        &self.stats
    }

    fn value_at_grid(&self, g: DVec3) -> f32 {
        let cell = self.locate_finest(self.domain.finest_cell(g));
        trilerp(
            &self.corners_of(cell),
            in_cell(g, cell, self.domain.max_level()),
        )
    }

    fn to_grid(&self, level: u32) -> Result<Grid, OctreeError> {
        // Rows through an accessor each: neighbouring samples share cells and nodes.
        crate::export_grid(self, level, |out, gs| {
            let mut a = self.accessor();
            for (v, &g) in out.iter_mut().zip(gs) {
                *v = a.value_at_grid(g);
            }
        })
    }
}

impl Field for HashedOctree {
    fn value(&self, p: Vec3) -> f32 {
        if p.is_nan() {
            return f32::NAN;
        }
        self.value_at_grid(self.domain.to_grid(p))
    }

    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        out.par_chunks_mut(1024)
            .zip(points.par_chunks(1024))
            .for_each(|(o, p)| {
                let mut a = self.accessor();
                for (o, &p) in o.iter_mut().zip(p) {
                    *o = a.value(p);
                }
            });
    }

    fn bounds(&self) -> Aabb {
        self.domain.bounds()
    }

    /// √3 times the source field's bound: each axis difference of the stored samples is
    /// within the source's bound (hanging values are interpolations of such samples).
    fn lipschitz(&self) -> f32 {
        self.lipschitz
    }

    /// The gradient of the trilinear reconstruction in the leaf containing `p`.
    fn gradient(&self, p: Vec3) -> Vec3 {
        let g = self.domain.to_grid(p);
        let cell = self.locate_finest(self.domain.finest_cell(g));
        let l = self.domain.max_level();
        let side = self.domain.cell_side(cell.level) as f32;
        trilerp_gradient(&self.corners_of(cell), in_cell(g, cell, l)) / side
    }
}

/// A cursor over a [`HashedOctree`] with direct-mapped cell and node caches (002 Sec.
/// 3.4.2): the cell cache remembers whether a cell is subdivided, the node cache a node's
/// value. Each lookup that hits skips one hash-map probe.
#[derive(Debug)]
pub struct Accessor<'a> {
    tree: &'a HashedOctree,
    cells: DirectCache<bool>,
    nodes: DirectCache<f32>,
}

impl Accessor<'_> {
    #[inline]
    fn sub(&mut self, c: Cell) -> bool {
        let l = self.tree.domain.max_level();
        let set = &self.tree.subdivided;
        let k = c.key(l);
        self.cells.get_or(k, || set.contains(k))
    }

    #[inline]
    fn locate_finest(&mut self, f: UVec3) -> Cell {
        let (l, hint) = (self.tree.domain.max_level(), self.tree.hint);
        build::locate_leaf(f, l, l, Some(hint), |c| self.sub(c))
    }

    /// The leaf containing `p` (clamped to the domain).
    pub fn locate(&mut self, p: Vec3) -> Cell {
        let d = self.tree.domain;
        self.locate_finest(d.finest_cell(d.to_grid(p)))
    }

    /// The value at node `q`, or None if `q` is not a node.
    pub fn node_value(&mut self, q: UVec3) -> Option<f32> {
        let l = self.tree.domain.max_level();
        if q.cmpgt(UVec3::splat(self.tree.domain.resolution())).any() {
            return None;
        }
        let k = NodeKey::new(q, l);
        let nodes = &self.tree.nodes;
        let v = self
            .nodes
            .get_or(k.get(), || nodes.get(k.get()).unwrap_or(f32::NAN));
        (!v.is_nan()).then_some(v)
    }

    /// [`HashedOctree::node_status`] through the cell cache.
    pub fn node_status(&mut self, q: UVec3) -> NodeStatus {
        let l = self.tree.domain.max_level();
        build::node_status(q, l, |c| self.sub(c))
    }

    fn corners(&mut self, cell: Cell) -> [f32; 8] {
        let l = self.tree.domain.max_level();
        std::array::from_fn(|n| self.node_value(cell.corner(n, l)).unwrap_or(f32::NAN))
    }

    fn value_at_grid(&mut self, g: DVec3) -> f32 {
        let cell = self.locate_finest(self.tree.domain.finest_cell(g));
        let c = self.corners(cell);
        trilerp(&c, in_cell(g, cell, self.tree.domain.max_level()))
    }

    /// The field value at `p`, as [`Field::value`] gives it.
    pub fn value(&mut self, p: Vec3) -> f32 {
        if p.is_nan() {
            return f32::NAN;
        }
        self.value_at_grid(self.tree.domain.to_grid(p))
    }

    /// The gradient at `p`, as [`Field::gradient`] gives it.
    pub fn gradient(&mut self, p: Vec3) -> Vec3 {
        let d = self.tree.domain;
        let g = d.to_grid(p);
        let cell = self.locate_finest(d.finest_cell(g));
        let c = self.corners(cell);
        trilerp_gradient(&c, in_cell(g, cell, d.max_level())) / d.cell_side(cell.level) as f32
    }

    /// Hits and misses of the cell cache.
    pub fn cell_stats(&self) -> CacheStats {
        self.cells.stats()
    }

    /// Hits and misses of the node cache.
    pub fn node_stats(&self) -> CacheStats {
        self.nodes.stats()
    }
}
