//! Construction: options, top-down subdivision with culling and look-ahead, bottom-up
//! coalescing, and the finalize pass that gives hanging nodes their interpolated values.
//!
//! Both trees are built here on a hashed topology (the set of subdivided cells); the linked
//! tree converts the result, so both hold the same cells and the same node values.

use crate::domain::{Cell, Domain, octant};
use crate::interp::trilerp;
use crate::key::{CacheStats, DirectCache, KeyBuild, NodeKey};
use crate::{OctreeError, key::MAX_LEVEL};
use glam::{UVec3, Vec3};
use isokit_field::{Aabb, Field, Job, checked_len};
use rayon::prelude::*;
use std::collections::HashMap;
use std::time::Instant;

/// The set of subdivided cells, by key: one record per block of eight siblings (a cell
/// exists iff it is the root or its parent is in the set; a cell is a leaf iff it exists and
/// is not in the set).
pub(crate) type CellSet = HashMap<u64, (), KeyBuild>;
/// Node values by node key.
pub(crate) type NodeMap = HashMap<NodeKey, f32, KeyBuild>;

/// Largest look-ahead (extra levels of test points): `(2^(K+1) + 1)^3` points per cell.
pub const MAX_LOOKAHEAD: u32 = 4;

/// How cells that cannot hold the surface are recognised (and left unsubdivided).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Cull {
    /// `Lipschitz(1)` for exact distance fields ([`Field::is_exact`]), `SignChange`
    /// otherwise.
    #[default]
    Auto,
    /// The field is `L`-Lipschitz: a cell whose corner values all exceed `L` times half its
    /// diagonal plus the band in magnitude holds no point within the band of the surface
    /// (002 Sec. 3.4; every point of a cube is within half a diagonal of a corner).
    Lipschitz(f32),
    /// No bound: a cell is near the surface when its test points (corners, the children's
    /// corners and the look-ahead lattice) change sign or come within the band in value.
    SignChange,
}

/// Top-down subdivision or bottom-up coalescing (002 Sec. 3.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Construction {
    /// Subdivide from the root where the surface may pass and the error is too large.
    /// Evaluates the field only at the test points of the cells it visits.
    #[default]
    TopDown,
    /// Evaluate the whole finest grid, then coalesce eight siblings when their parent's
    /// trilinear reconstruction matches every finest sample inside it, or when all of them
    /// lie on one side of the surface beyond the band. Captures every feature the finest grid
    /// sees, at the cost of `(2^L + 1)^3` evaluations.
    BottomUp,
}

/// Knobs of the construction.
///
/// **The error bound.** `error` is split in halves: a cell near the surface is subdivided
/// while the trilinear reconstruction from its corners misses the field by more than
/// `error / 2` at any of its test points (cell centre, face centres, edge midpoints, and the
/// look-ahead lattice); and, with `refine_hanging`, a coarse leaf is subdivided while a
/// hanging node on its boundary that is a corner of a band leaf gets an interpolated value
/// more than `error / 2` from the field. So within band leaves below the maximum level the
/// reconstruction is within `error` of the field at every test point, and for fields that
/// are smooth at the cell's scale, everywhere in the cell. Leaves at the maximum level
/// carry whatever error that resolution gives. `error = 0` subdivides every cell the
/// surface may pass down to the maximum level (the thesis's construction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildOptions {
    /// Finest level (the root is level 0); at most [`MAX_LEVEL`] = 21.
    pub max_level: u32,
    /// Cells above this level are always subdivided.
    pub min_level: u32,
    /// Error bound in field units (world units for distance fields); see above.
    pub error: f32,
    /// Extra levels of test points per cell (look-ahead, for small features of general
    /// fields); at most [`MAX_LOOKAHEAD`].
    pub lookahead: u32,
    /// Half-width of the band around the surface where the error bound holds (world units
    /// for distance fields): cells that hold no point within it are not subdivided.
    pub band: f32,
    /// How cells away from the surface are recognised.
    pub cull: Cull,
    /// Top-down or bottom-up.
    pub construction: Construction,
    /// Subdivide coarse leaves whose hanging nodes' interpolated values miss the field by
    /// more than `error / 2` where they are corners of band leaves. `false` is the thesis's
    /// construction (hanging values interpolated, never refined).
    pub refine_hanging: bool,
    /// Largest number of cells; construction stops with [`OctreeError::TooManyCells`]
    /// beyond it (a tree costs roughly 20 to 60 bytes per cell while it is built).
    pub max_cells: usize,
}

/// Bytes per cell held while building (the cell set, node map and work lists), for the
/// memory budget.
const BYTES_PER_CELL: u128 = 64;

/// Default [`BuildOptions::max_cells`]: 50 million cells.
pub const DEFAULT_MAX_CELLS: usize = 50_000_000;

impl BuildOptions {
    /// Options for `max_level` levels: no minimum level, error 0 (refine every cell the
    /// surface may pass to the finest level), no look-ahead, band 0, automatic culling,
    /// top-down, hanging refinement on, at most [`DEFAULT_MAX_CELLS`] cells.
    pub fn new(max_level: u32) -> Self {
        Self {
            max_level,
            min_level: 0,
            error: 0.0,
            lookahead: 0,
            band: 0.0,
            cull: Cull::Auto,
            construction: Construction::TopDown,
            refine_hanging: true,
            max_cells: DEFAULT_MAX_CELLS,
        }
    }

    /// Checks the ranges (named errors).
    pub fn validate(&self) -> Result<(), OctreeError> {
        if self.max_level > MAX_LEVEL {
            return Err(OctreeError::bad(
                "max level",
                self.max_level,
                "at most 21 (cell keys are 64 bits)",
            ));
        }
        if self.min_level > self.max_level {
            return Err(OctreeError::bad(
                "min level",
                self.min_level,
                "must not exceed the max level",
            ));
        }
        if !(self.error.is_finite() && self.error >= 0.0) {
            return Err(OctreeError::bad(
                "error",
                self.error,
                "must be finite and non-negative",
            ));
        }
        if !(self.band.is_finite() && self.band >= 0.0) {
            return Err(OctreeError::bad(
                "band",
                self.band,
                "must be finite and non-negative",
            ));
        }
        if self.lookahead > MAX_LOOKAHEAD {
            return Err(OctreeError::bad(
                "lookahead",
                self.lookahead,
                "at most 4 levels ((2^5 + 1)^3 test points per cell)",
            ));
        }
        if let Cull::Lipschitz(l) = self.cull {
            if !(l.is_finite() && l > 0.0) {
                return Err(OctreeError::bad(
                    "lipschitz bound",
                    l,
                    "must be finite and positive",
                ));
            }
        }
        Ok(())
    }
}

/// What the construction did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Distinct points where the field was evaluated.
    pub evaluations: u64,
    /// `evaluations / (2^max_level + 1)^3`: the share of the dense finest grid sampled.
    pub dense_fraction: f64,
    /// Wall-clock seconds of the whole construction.
    pub seconds: f64,
    /// Finalize passes (1 + the number of hanging-node refinement rounds).
    pub passes: u32,
    /// Hanging nodes in the final tree.
    pub hanging_nodes: u64,
    /// Leaves per level (index = level).
    pub leaves_per_level: Vec<u64>,
    /// The direct-mapped cell cache during node classification (Sec. 3.4.2).
    pub cell_cache: CacheStats,
    /// The direct-mapped node cache while interpolating hanging nodes.
    pub node_cache: CacheStats,
}

/// The result of a construction: the topology and the node values.
pub(crate) struct Built {
    pub domain: Domain,
    pub subdivided: CellSet,
    pub nodes: NodeMap,
    pub stats: BuildStats,
    pub lipschitz: f32,
}

// ---------------------------------------------------------------------- topology queries

/// Whether `c` is subdivided.
#[inline]
pub(crate) fn is_sub(set: &CellSet, c: Cell, l: u32) -> bool {
    set.contains_key(&c.key(l))
}

/// The leaf containing the finest cell `f`, knowing that its ancestor at level `hi` is not
/// subdivided (`hi = max_level` always qualifies). Binary search over the levels `0..=hi`
/// (002 Sec. 3.3.1): subdivision is monotone along the ancestors (every ancestor of a
/// subdivided cell is subdivided). With `first = Some(h)`, the first probe tests whether the
/// leaf is at level `h` (its parent subdivided): one probe when the guess is right.
#[inline]
pub(crate) fn locate_leaf(
    f: UVec3,
    l: u32,
    hi: u32,
    first: Option<u32>,
    mut sub: impl FnMut(Cell) -> bool,
) -> Cell {
    let anc = |m: u32| Cell {
        level: m,
        pos: f & UVec3::splat(!((1u32 << (l - m)) - 1)),
    };
    // Answer D in [lo, hi]: sub(anc(m)) holds for m < D and fails from D on.
    let (mut lo, mut hi) = (0u32, hi);
    if let Some(h) = first {
        if h >= 1 && h <= hi {
            if sub(anc(h - 1)) {
                lo = h;
            } else {
                hi = h - 1;
            }
        }
    }
    while lo < hi {
        let mid = (lo + hi) / 2;
        if sub(anc(mid)) {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    anc(lo)
}

/// Where a node stands (found with the sibling rule of 002 Sec. 3.3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeStatus {
    /// No leaf has this point as a corner: not a node of the tree.
    Absent,
    /// A corner of every leaf that touches it: holds the field's own value.
    Regular,
    /// On a face or edge of a coarser leaf (the coarsest such leaf is given): holds that
    /// leaf's trilinear interpolation.
    Hanging {
        /// The coarsest leaf on whose boundary the node lies.
        leaf: Cell,
    },
}

/// Classifies the finest-grid point `q` with the sibling rule: with `2^t` the largest power
/// of two dividing all of `q`'s coordinates, the only cells that can have `q` as a corner
/// without having it as a corner of a larger ancestor are the (up to) eight cells of size
/// `2^t` around `q`. They exist iff their parents are subdivided, and siblings share a
/// parent, so one probe per distinct parent suffices: one when `q` is a parent's centre, two
/// on a face, four on an edge, eight only where `q` is a corner at the next level too.
pub(crate) fn node_status(q: UVec3, l: u32, mut sub: impl FnMut(Cell) -> bool) -> NodeStatus {
    let n = 1u32 << l;
    if q.cmpgt(UVec3::splat(n)).any() {
        return NodeStatus::Absent;
    }
    let t = q
        .to_array()
        .iter()
        .map(|&v| if v == 0 { 32 } else { v.trailing_zeros() })
        .min()
        .unwrap_or(32);
    if t >= l {
        return NodeStatus::Regular; // a corner of the root
    }
    let s = 1u32 << t;
    let level = l - t; // level of the cells of size s, at least 1
    let pmask = UVec3::splat(!((s << 1) - 1));
    let mut seen: [Option<UVec3>; 8] = [None; 8];
    let (mut any, mut coarse): (bool, Option<Cell>) = (false, None);
    for o in 0..8 {
        let off = octant(o);
        // Octant cell: below q on axes where off = 0, above where 1.
        let ok = (0..3).all(|a| {
            if off[a] == 0 {
                q[a] >= s
            } else {
                q[a] + s <= n
            }
        });
        if !ok {
            continue;
        }
        let pos = q + off * s - UVec3::splat(s);
        let ppos = pos & pmask;
        if seen.iter().flatten().any(|&p| p == ppos) {
            continue;
        }
        seen[o] = Some(ppos);
        let parent = Cell {
            level: level - 1,
            pos: ppos,
        };
        if sub(parent) {
            any = true;
        } else {
            let leaf = locate_leaf(pos, l, level - 1, None, &mut sub);
            if coarse.is_none_or(|c| leaf.level < c.level) {
                coarse = Some(leaf);
            }
        }
    }
    match (any, coarse) {
        (false, _) => NodeStatus::Absent,
        (true, None) => NodeStatus::Regular,
        (true, Some(leaf)) => NodeStatus::Hanging { leaf },
    }
}

/// All leaves, sorted by (level, position), from the keys of the subdivided cells and a test
/// of subdivision.
pub(crate) fn leaves_from(keys: &[u64], l: u32, sub: &(impl Fn(Cell) -> bool + Sync)) -> Vec<Cell> {
    if keys.is_empty() {
        return vec![Cell::ROOT];
    }
    let mut out: Vec<Cell> = keys
        .par_iter()
        .flat_map_iter(|&k| {
            let (level, idx) = crate::key::decode_cell_key(k);
            let p = Cell {
                level,
                pos: idx << (l - level),
            };
            (0..8).map(move |n| p.child(n, l)).filter(|c| !sub(*c))
        })
        .collect();
    out.par_sort_unstable();
    out
}

/// All leaves of a cell set.
pub(crate) fn leaves(set: &CellSet, l: u32) -> Vec<Cell> {
    let keys: Vec<u64> = set.keys().copied().collect();
    leaves_from(&keys, l, &|c| is_sub(set, c, l))
}

// ---------------------------------------------------------------------- samplers

/// Field values at finest-grid points.
pub(crate) trait Sampler: Sync {
    /// Makes sure every point in `keys` (node keys, any order, duplicates allowed) has a
    /// value. May reorder `keys`.
    fn ensure(&mut self, keys: &mut Vec<u64>) -> Result<(), OctreeError>;
    /// The value at `q` (which must have been ensured).
    fn get(&self, q: UVec3) -> f32;
    /// Distinct evaluations so far.
    fn evaluations(&self) -> u64;
}

/// Evaluates the field on demand and remembers every value.
struct FieldSampler<'a> {
    field: &'a dyn Field,
    domain: Domain,
    values: NodeMap,
}

impl Sampler for FieldSampler<'_> {
    fn ensure(&mut self, keys: &mut Vec<u64>) -> Result<(), OctreeError> {
        keys.par_sort_unstable();
        keys.dedup();
        keys.retain(|&k| !self.values.contains_key(&NodeKey::from_u64(k)));
        if keys.is_empty() {
            return Ok(());
        }
        let l = self.domain.max_level();
        let pts: Vec<Vec3> = keys
            .par_iter()
            .map(|&k| self.domain.position(NodeKey::from_u64(k).position(l)))
            .collect();
        let mut out = vec![0.0f32; pts.len()];
        self.field.values(&pts, &mut out);
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            return Err(OctreeError::NonFinite {
                x: pts[i].x,
                y: pts[i].y,
                z: pts[i].z,
                value: out[i],
            });
        }
        self.values.reserve(keys.len());
        for (&k, v) in keys.iter().zip(out) {
            self.values.insert(NodeKey::from_u64(k), v);
        }
        Ok(())
    }

    #[inline]
    fn get(&self, q: UVec3) -> f32 {
        let k = NodeKey::new(q, self.domain.max_level());
        self.values.get(&k).copied().unwrap_or(f32::NAN)
    }

    fn evaluations(&self) -> u64 {
        self.values.len() as u64
    }
}

/// The dense finest grid (bottom-up); its index is the node key.
struct GridSampler {
    data: Vec<f32>,
    l: u32,
}

impl Sampler for GridSampler {
    fn ensure(&mut self, _keys: &mut Vec<u64>) -> Result<(), OctreeError> {
        Ok(())
    }
    #[inline]
    fn get(&self, q: UVec3) -> f32 {
        self.data[NodeKey::new(q, self.l).get() as usize]
    }
    fn evaluations(&self) -> u64 {
        self.data.len() as u64
    }
}

// ---------------------------------------------------------------------- the builder

struct Ctx {
    domain: Domain,
    l: u32,
    min_level: u32,
    half_error: f32,
    lookahead: u32,
    band: f32,
    lip: Option<f32>,
    refine_hanging: bool,
    max_cells: usize,
}

/// Cells decided per batch (bounds the memory of the test-point lists).
const BATCH: usize = 1 << 15;

impl Ctx {
    /// Intervals per side of a cell's test lattice: 1 (corners only) at the finest level,
    /// else `2^(1 + min(K, L - level - 1))` (children's corners plus the look-ahead).
    fn lattice_n(&self, level: u32) -> u32 {
        if level >= self.l {
            1
        } else {
            1 << (1 + self.lookahead.min(self.l - level - 1))
        }
    }

    fn push_lattice(&self, c: Cell, out: &mut Vec<u64>) {
        let n = self.lattice_n(c.level);
        let step = c.size(self.l) / n;
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    let q = c.pos + UVec3::new(i, j, k) * step;
                    out.push(NodeKey::new(q, self.l).get());
                }
            }
        }
    }

    fn push_corners(&self, c: Cell, out: &mut Vec<u64>) {
        for n in 0..8 {
            out.push(NodeKey::new(c.corner(n, self.l), self.l).get());
        }
    }

    fn corners(&self, c: Cell, s: &impl Sampler) -> [f32; 8] {
        std::array::from_fn(|n| s.get(c.corner(n, self.l)))
    }

    /// Lipschitz culling from the corners alone (None without a bound).
    fn culled(&self, c: Cell, corners: &[f32; 8]) -> Option<bool> {
        self.lip.map(|lip| {
            let half_diag = (0.5 * 3f64.sqrt() * self.domain.cell_side(c.level)) as f32;
            let reach = lip * half_diag + self.band;
            corners.iter().all(|v| v.abs() > reach)
        })
    }

    /// (subdivide, band): whether the cell is subdivided and whether it may hold points
    /// within the band. Needs the corners and, below the finest level and for non-culled
    /// cells, the lattice.
    fn assess(&self, c: Cell, s: &impl Sampler) -> (bool, bool) {
        let corners = self.corners(c, s);
        let culled = self.culled(c, &corners);
        if culled == Some(true) {
            return (c.level < self.min_level, false);
        }
        let n = self.lattice_n(c.level);
        let step = c.size(self.l) / n;
        let inv = 1.0 / n as f32;
        let (mut err, mut pos, mut neg, mut min_abs) = (0.0f32, false, false, f32::INFINITY);
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    let v = s.get(c.pos + UVec3::new(i, j, k) * step);
                    let t = Vec3::new(i as f32, j as f32, k as f32) * inv;
                    err = err.max((trilerp(&corners, t) - v).abs());
                    pos |= v >= 0.0;
                    neg |= v <= 0.0;
                    min_abs = min_abs.min(v.abs());
                }
            }
        }
        let band = match culled {
            Some(_) => true,
            None => (pos && neg) || min_abs <= self.band,
        };
        let sub = c.level < self.min_level || (c.level < self.l && band && err > self.half_error);
        (sub, band)
    }

    /// Top-down subdivision of `frontier` (cells not yet decided) and their descendants.
    /// Progress is reported per level (stage `octree level K of L`, in cells of the level's
    /// frontier, followed by `pass` when it is not empty), and the job's cancellation is
    /// checked between batches.
    fn refine(
        &self,
        set: &mut CellSet,
        s: &mut impl Sampler,
        mut frontier: Vec<Cell>,
        job: &Job,
        pass: &str,
    ) -> Result<(), OctreeError> {
        // Cells split at the previous level, for the growth projection below.
        let mut previous: Option<(u32, usize)> = None;
        while !frontier.is_empty() {
            let level = frontier.iter().map(|c| c.level).min().unwrap_or(0);
            let mut next = Vec::new();
            let stage = format!("octree level {level} of {}{pass}", self.l);
            let counter = job.counter(&stage, frontier.len() as u64);
            for chunk in frontier.chunks(BATCH) {
                job.check()?;
                // Cells above the minimum level are subdivided without looking.
                let to_assess: Vec<Cell> = chunk
                    .iter()
                    .copied()
                    .filter(|c| c.level >= self.min_level && c.level < self.l)
                    .collect();
                // Corners first: culled cells need nothing more.
                let mut keys = Vec::with_capacity(to_assess.len() * 8);
                for &c in &to_assess {
                    self.push_corners(c, &mut keys);
                }
                s.ensure(&mut keys)?;
                let live: Vec<Cell> = to_assess
                    .par_iter()
                    .copied()
                    .filter(|&c| self.culled(c, &self.corners(c, s)) != Some(true))
                    .collect();
                keys.clear();
                for &c in &live {
                    self.push_lattice(c, &mut keys);
                }
                s.ensure(&mut keys)?;
                let split: Vec<Cell> = live
                    .par_iter()
                    .copied()
                    .filter(|&c| self.assess(c, s).0)
                    .collect();
                let forced = chunk.iter().copied().filter(|c| c.level < self.min_level);
                for c in forced.chain(split) {
                    set.insert(c.key(self.l), ());
                    if c.level + 1 < self.l {
                        next.extend((0..8).map(|n| c.child(n, self.l)));
                    }
                }
                if set.len().saturating_mul(8).saturating_add(1) > self.max_cells {
                    return Err(OctreeError::TooManyCells {
                        limit: self.max_cells,
                    });
                }
                isokit_field::memory::check(
                    &format!("the octree's {} cells and their nodes", set.len()),
                    set.len() as u128 * BYTES_PER_CELL,
                    "raise --error, lower --max-level, or raise the budget",
                )?;
                counter.advance(chunk.len() as u64);
            }
            // Refuse early what cannot fit: at the growth of the last two levels (a surface
            // quadruples its cells per level), the levels still to come would reach several
            // times the cell limit.
            let splits = next.len() / 8;
            if let Some((l0, p)) = previous
                && l0 + 1 == level
                && level >= 3
                && p > 0
            {
                let r = (splits as f64 / p as f64).min(8.0);
                let remaining = self.l.saturating_sub(level + 1) as i32;
                if r >= 2.0 && remaining > 0 {
                    let more = splits as f64 * (r.powi(remaining + 1) - r) / (r - 1.0);
                    if set.len() as f64 + more > 4.0 * self.max_cells as f64 {
                        return Err(OctreeError::TooManyCells {
                            limit: self.max_cells,
                        });
                    }
                }
            }
            previous = Some((level, splits));
            frontier = next;
        }
        Ok(())
    }

    /// Node values for the current topology; with `refine_hanging`, subdivides coarse
    /// leaves whose hanging nodes miss the field, until none do.
    fn finalize(
        &self,
        set: &mut CellSet,
        s: &mut impl Sampler,
        stats: &mut BuildStats,
        job: &Job,
    ) -> Result<NodeMap, OctreeError> {
        let l = self.l;
        loop {
            stats.passes += 1;
            // Node values: every leaf corner, with the field's value (evaluated now where a
            // corner was never a test point).
            let mut values = self.leaf_corners(set, s);
            let mut missing: Vec<u64> = values
                .iter()
                .filter(|(_, v)| v.is_nan())
                .map(|(k, _)| k.get())
                .collect();
            if !missing.is_empty() {
                s.ensure(&mut missing)?;
                for (k, v) in values.iter_mut() {
                    if v.is_nan() {
                        *v = s.get(k.position(l));
                    }
                }
            }
            let keys: Vec<u64> = values.keys().map(|k| k.get()).collect();
            // Classify every node (in parallel, a cell cache per chunk).
            let set_ref = &*set;
            let classified: Vec<(Vec<(u64, Cell)>, CacheStats)> = keys
                .par_chunks(4096)
                .map(|chunk| {
                    let mut cache = DirectCache::<bool>::default();
                    let mut hanging = Vec::new();
                    for &k in chunk {
                        let q = NodeKey::from_u64(k).position(l);
                        let st =
                            node_status(q, l, |c| cache.get_or(c.key(l), || is_sub(set_ref, c, l)));
                        if let NodeStatus::Hanging { leaf } = st {
                            hanging.push((k, leaf));
                        }
                    }
                    (hanging, cache.stats())
                })
                .collect();
            drop(keys);
            let mut hanging: Vec<(u64, Cell)> = Vec::new();
            for (h, st) in classified {
                hanging.extend(h);
                stats.cell_cache += st;
            }
            // Hanging nodes from the coarsest leaves down: a hanging node's leaf has only
            // corners that are regular or hang on strictly coarser leaves, so they are final
            // when it is computed.
            hanging.sort_unstable_by_key(|&(k, c)| (c.level, k));
            let mut node_cache = DirectCache::<f32>::default();
            for &(k, c) in &hanging {
                let corners: [f32; 8] = std::array::from_fn(|n| {
                    let ck = NodeKey::new(c.corner(n, l), l);
                    node_cache.get_or(ck.get(), || values.get(&ck).copied().unwrap_or(f32::NAN))
                });
                let q = NodeKey::from_u64(k).position(l);
                let t = (q - c.pos).as_vec3() / c.size(l) as f32;
                values.insert(NodeKey::from_u64(k), trilerp(&corners, t));
            }
            stats.node_cache += node_cache.stats();
            stats.hanging_nodes = hanging.len() as u64;
            if !self.refine_hanging {
                return Ok(values);
            }
            // Coarse leaves to subdivide: a hanging node that misses the field by more than
            // error / 2 and is a corner of a band leaf.
            let s_ref = &*s;
            let mut bad: Vec<Cell> = hanging
                .par_iter()
                .filter(|&&(k, c)| {
                    let q = NodeKey::from_u64(k).position(l);
                    c.level < l
                        && (values[&NodeKey::from_u64(k)] - s_ref.get(q)).abs() > self.half_error
                        && self.touches_band_leaf(q, set_ref, s_ref)
                })
                .map(|&(_, c)| c)
                .collect();
            if bad.is_empty() {
                return Ok(values);
            }
            bad.par_sort_unstable();
            bad.dedup();
            let mut frontier = Vec::new();
            if (set.len() + bad.len()).saturating_mul(8).saturating_add(1) > self.max_cells {
                return Err(OctreeError::TooManyCells {
                    limit: self.max_cells,
                });
            }
            for c in bad {
                set.insert(c.key(l), ());
                if c.level + 1 < l {
                    frontier.extend((0..8).map(|n| c.child(n, l)));
                }
            }
            self.refine(
                set,
                s,
                frontier,
                job,
                &format!(" (hanging nodes, pass {})", stats.passes),
            )?;
        }
    }

    /// A map holding every corner of every leaf with the sampler's value there (NaN where the
    /// sampler has none yet). Walks the subdivided cells: their leaf children's corners are
    /// among the 27 points of the parent's 3^3 lattice.
    fn leaf_corners(&self, set: &CellSet, s: &impl Sampler) -> NodeMap {
        let l = self.l;
        let mut values = NodeMap::with_capacity_and_hasher(3 * set.len() + 8, KeyBuild::default());
        let mut add = |q: UVec3| {
            values.entry(NodeKey::new(q, l)).or_insert_with(|| s.get(q));
        };
        if set.is_empty() {
            for n in 0..8 {
                add(Cell::ROOT.corner(n, l));
            }
            return values;
        }
        for &k in set.keys() {
            let (level, idx) = crate::key::decode_cell_key(k);
            let p = Cell {
                level,
                pos: idx << (l - level),
            };
            let half = p.size(l) >> 1;
            let mut mark = [false; 27];
            for n in 0..8 {
                let c = p.child(n, l);
                if is_sub(set, c, l) {
                    continue;
                }
                let o = octant(n);
                for m in 0..8 {
                    let v = o + octant(m);
                    mark[(v.x + 3 * v.y + 9 * v.z) as usize] = true;
                }
            }
            for (i, _) in mark.iter().enumerate().filter(|(_, m)| **m) {
                let v = UVec3::new(i as u32 % 3, (i as u32 / 3) % 3, i as u32 / 9);
                add(p.pos + v * half);
            }
        }
        values
    }

    /// Whether `q` is a corner of a leaf that may hold points within the band.
    fn touches_band_leaf(&self, q: UVec3, set: &CellSet, s: &impl Sampler) -> bool {
        let (l, n) = (self.l, 1u32 << self.l);
        (0..8).any(|o| {
            let off = octant(o);
            let ok = (0..3).all(|a| if off[a] == 0 { q[a] >= 1 } else { q[a] < n });
            if !ok {
                return false;
            }
            let f = q + off - UVec3::ONE;
            let leaf = locate_leaf(f, l, l, None, |c| is_sub(set, c, l));
            leaf.has_corner(q, l) && self.assess(leaf, s).1
        })
    }
}

/// The Lipschitz bound used for culling, or None for sign-change culling.
fn lipschitz_of(cull: Cull, field: &dyn Field) -> Option<f32> {
    match cull {
        Cull::Auto => field.is_exact().then_some(1.0),
        Cull::Lipschitz(l) => Some(l),
        Cull::SignChange => None,
    }
}

/// Builds the topology and node values of an octree of `field` over the cube around
/// `bounds`, reporting progress to `job` and stopping when it is cancelled.
pub(crate) fn build(
    field: &dyn Field,
    bounds: Aabb,
    opts: &BuildOptions,
    job: &Job,
) -> Result<Built, OctreeError> {
    let t0 = Instant::now();
    opts.validate()?;
    let domain = Domain::cube_around(bounds, opts.max_level)?;
    let l = opts.max_level;
    let ctx = Ctx {
        domain,
        l,
        min_level: opts.min_level,
        half_error: 0.5 * opts.error,
        lookahead: opts.lookahead,
        band: opts.band,
        lip: lipschitz_of(opts.cull, field),
        refine_hanging: opts.refine_hanging,
        max_cells: opts.max_cells,
    };
    let mut stats = BuildStats::default();
    let mut set = CellSet::default();
    let (nodes, evaluations) = match opts.construction {
        Construction::TopDown => {
            let mut s = FieldSampler {
                field,
                domain,
                values: NodeMap::default(),
            };
            ctx.refine(&mut set, &mut s, vec![Cell::ROOT], job, "")?;
            let nodes = ctx.finalize(&mut set, &mut s, &mut stats, job)?;
            (nodes, s.evaluations())
        }
        Construction::BottomUp => {
            let mut s = sample_dense(field, &domain, job)?;
            coalesce(&ctx, &s, &mut set);
            if set.len().saturating_mul(8).saturating_add(1) > ctx.max_cells {
                return Err(OctreeError::TooManyCells {
                    limit: ctx.max_cells,
                });
            }
            let nodes = ctx.finalize(&mut set, &mut s, &mut stats, job)?;
            (nodes, s.evaluations())
        }
    };
    set.shrink_to_fit();
    let mut nodes = nodes;
    nodes.shrink_to_fit();
    let mut per_level = vec![0u64; l as usize + 1];
    for c in leaves(&set, l) {
        per_level[c.level as usize] += 1;
    }
    stats.leaves_per_level = per_level;
    stats.evaluations = evaluations;
    let dense = ((1u64 << l) + 1) as f64;
    stats.dense_fraction = evaluations as f64 / (dense * dense * dense);
    stats.seconds = t0.elapsed().as_secs_f64();
    Ok(Built {
        domain,
        subdivided: set,
        nodes,
        stats,
        lipschitz: 3f32.sqrt() * field.lipschitz().max(0.0),
    })
}

/// Every node of the finest grid (refused beyond [`isokit_field::MAX_SAMPLES`]).
fn sample_dense(field: &dyn Field, domain: &Domain, job: &Job) -> Result<GridSampler, OctreeError> {
    let l = domain.max_level();
    let n = (1usize << l) + 1;
    let len = checked_len([n, n, n])?;
    let mut data = vec![0.0f32; len];
    let counter = job.counter("sampling the finest octree level", n as u64);
    data.par_chunks_mut(n * n)
        .enumerate()
        .for_each(|(k, slice)| {
            if job.is_cancelled() {
                return;
            }
            for (m, v) in slice.iter_mut().enumerate() {
                let q = UVec3::new((m % n) as u32, (m / n) as u32, k as u32);
                *v = field.value(domain.position(q));
            }
            counter.advance(1);
        });
    job.check()?;
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        let q = NodeKey::from_u64(i as u64).position(l);
        let p = domain.position(q);
        return Err(OctreeError::NonFinite {
            x: p.x,
            y: p.y,
            z: p.z,
            value: data[i],
        });
    }
    Ok(GridSampler { data, l })
}

/// Bottom-up: from the finest level up, a cell whose eight children are all leaves becomes a
/// leaf when every finest sample inside it (boundary included) is on one side of the surface
/// beyond the band, or within `error / 2` of its trilinear reconstruction.
fn coalesce(ctx: &Ctx, s: &GridSampler, set: &mut CellSet) {
    let l = ctx.l;
    if l == 0 {
        return;
    }
    // flags[level]: whether each cell of that level (x fastest, own-level index) coalesces
    // into a leaf; computed from level L - 1 up (the finest cells are all leaves).
    let mut flags: Vec<Vec<bool>> = vec![Vec::new(); l as usize];
    for level in (0..l).rev() {
        let m = 1usize << level;
        let below = flags.get(level as usize + 1);
        let coalesces: Vec<bool> = (0..m * m * m)
            .into_par_iter()
            .map(|i| {
                let idx = UVec3::new((i % m) as u32, ((i / m) % m) as u32, (i / (m * m)) as u32);
                if level < ctx.min_level {
                    return false;
                }
                if let Some(below) = below {
                    let m2 = m * 2;
                    let all = (0..8).all(|n| {
                        let ci = idx * 2 + octant(n);
                        below[ci.x as usize + m2 * (ci.y as usize + m2 * ci.z as usize)]
                    });
                    if !all {
                        return false;
                    }
                }
                let c = Cell {
                    level,
                    pos: idx << (l - level),
                };
                coalescible(ctx, s, c)
            })
            .collect();
        flags[level as usize] = coalesces;
    }
    // Subdivided: every existing cell above the finest level that did not coalesce.
    let mut frontier = vec![Cell::ROOT];
    while let Some(c) = frontier.pop() {
        if c.level >= l {
            continue;
        }
        let m = 1usize << c.level;
        let idx = c.pos >> (l - c.level);
        if flags[c.level as usize][idx.x as usize + m * (idx.y as usize + m * idx.z as usize)] {
            continue;
        }
        set.insert(c.key(l), ());
        frontier.extend((0..8).map(|n| c.child(n, l)));
    }
}

fn coalescible(ctx: &Ctx, s: &GridSampler, c: Cell) -> bool {
    let l = ctx.l;
    let size = c.size(l);
    let corners = ctx.corners(c, s);
    let inv = 1.0 / size as f32;
    let (mut far, mut fits) = (true, true);
    let first_sign = corners[0] > 0.0;
    for k in 0..=size {
        for j in 0..=size {
            for i in 0..=size {
                let v = s.get(c.pos + UVec3::new(i, j, k));
                if far && ((v > 0.0) != first_sign || v.abs() <= ctx.band || v == 0.0) {
                    far = false;
                }
                if fits {
                    let t = Vec3::new(i as f32, j as f32, k as f32) * inv;
                    if (trilerp(&corners, t) - v).abs() > ctx.half_error {
                        fits = false;
                    }
                }
                if !far && !fits {
                    return false;
                }
            }
        }
    }
    true
}
