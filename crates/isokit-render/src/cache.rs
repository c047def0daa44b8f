//! The brick cache (002 Sec. 6.2.2): a pool of fixed-size slots holding bricks, a reference
//! index from brick to slot, least-recently-used eviction.

use crate::{RenderError, Volume};
use rayon::prelude::*;

/// Marks a brick that is not in the cache, in [`BrickCache::reference`].
pub const NOT_RESIDENT: u32 = u32::MAX;

/// Bit of a [`BrickCache::reference`] entry (other than [`NOT_RESIDENT`]) marking a brick
/// stored at half resolution (the downsampling policy, [`crate::CachePolicy::Downsample`]);
/// the other bits are its *half slot* `k`, whose samples start at
/// `k · Volume::half_slot_samples()` in the pool.
pub const HALF_RESOLUTION: u32 = 1 << 31;

/// Level of a brick in a downsampled assignment: not stored.
pub(crate) const LEVEL_NONE: u8 = 0;
/// Level of a brick in a downsampled assignment: full resolution.
pub(crate) const LEVEL_FULL: u8 = 1;
/// Level of a brick in a downsampled assignment: half resolution.
pub(crate) const LEVEL_HALF: u8 = 2;

/// Default memory budget of a cache made by [`BrickCache::for_volume`]: 1 GiB of samples.
pub const DEFAULT_CACHE_BYTES: usize = 1 << 30;

/// Counters of a [`BrickCache`], cumulative since it was made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    /// Bricks copied from the volume into a slot.
    pub loads: u64,
    /// Bricks dropped to make room.
    pub evictions: u64,
    /// Bricks a frame needed that were already resident when it started.
    pub hits: u64,
}

/// A brick cache: the CPU twin of the GPU's brick cache texture and reference texture.
///
/// - `pool`: `capacity` slots of [`Volume::slot_samples`] f32 each (slot `s` starts at
///   `s · slot_samples`): the brick's [`crate::Layout::brick_samples`] samples x fastest,
///   and for a volume with a second field ([`Volume::with_operand`]) that field's samples
///   of the brick after them (channel B at `s · slot_samples + brick_samples`); grown as
///   slots are first used.
/// - `reference`: one `u32` per brick of the volume (x fastest): its slot, or
///   [`NOT_RESIDENT`].
///
/// Bricks are loaded on demand by [`crate::render`] (first the bricks that hold the active
/// isovalue, nearest to the eye first, as far as the capacity allows; then those that rays
/// ask for) and evicted least recently used. A cache smaller than the set of active bricks
/// still renders the same image, in several passes (see [`crate::render`]), or with
/// [`crate::CachePolicy::Downsample`] holds some bricks at half resolution so that all fit
/// (a *downsampled assignment*, see [`BrickCache::half_slot_of`]). The cache belongs to one
/// volume; handed another one (see [`Volume::id`]) it empties itself.
///
/// A downsampled assignment lays the pool out as full-resolution slots `0 .. nf` (each
/// [`Volume::slot_samples`]), then half slots of [`Volume::half_slot_samples`] from the
/// first half-slot boundary after them; a half-resolution brick's reference entry is
/// [`HALF_RESOLUTION`] `|` its half slot. The pool never exceeds `capacity` full slots.
#[derive(Clone, Debug)]
pub struct BrickCache {
    /// Slots asked for; `capacity` is this bounded by the bound volume's brick count.
    requested: usize,
    capacity: usize,
    volume_id: u64,
    brick_samples: usize,
    pool: Vec<f32>,
    /// Brick held by each slot in use.
    slot_brick: Vec<u32>,
    /// Clock value of each slot's last use.
    last_used: Vec<u64>,
    reference: Vec<u32>,
    clock: u64,
    stats: CacheStats,
    /// False for the bookkeeping of a pool that lives elsewhere (the GPU renderer's): no
    /// samples are kept on the host.
    host_samples: bool,
    /// Per brick, its level in the current downsampled assignment ([`LEVEL_FULL`], …);
    /// empty when the cache holds bricks the ordinary way (slots and LRU).
    mixed: Vec<u8>,
    /// Per block, `[min, max]` of what the filters read of the stored samples under the
    /// downsampled assignment (the volume's own ranges for blocks of bricks not stored);
    /// second field in `mixed_rb`.
    mixed_ra: Vec<[f32; 2]>,
    mixed_rb: Vec<[f32; 2]>,
    /// Per block, the slope bounds of the stored samples under the downsampled assignment
    /// (as `mixed_ra` for the ranges); second field in `mixed_sb`.
    mixed_sa: Vec<[f32; 3]>,
    mixed_sb: Vec<[f32; 3]>,
    /// Bumped whenever what the pool stores changes other than brick by brick (a new
    /// volume, a downsampled assignment made or dropped): part of `block_info`'s key.
    generation: u64,
    /// What the kernel steps by per block ([`crate::kernel::TraceData::block_info`]) and
    /// the key it was computed for.
    block_info: Vec<[f32; 4]>,
    block_info_key: Option<BlockInfoKey>,
    /// The search filter the downsampled assignment's hanging samples are matched for.
    mixed_filter: crate::Filter,
    /// Per brick, its detail ([`Volume::brick_detail`]), NaN until computed.
    detail: Vec<f32>,
}

/// What [`BrickCache::block_info`] was computed for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BlockInfoKey {
    iso: u32,
    inside: u32,
    skip: u32,
    combine: u32,
    morph: u32,
    generation: u64,
}

/// Per block (x fastest, `dims` blocks per axis), the Chebyshev distance in blocks to the
/// nearest `active` block, at most 255 (0 for an active block; 255 also when none is
/// active): every block within distance `d − 1` of a block at distance `d` is inactive, so
/// a ray may cross that cube of `(2d − 1)³` blocks in one step. The exact chessboard
/// distance transform by two raster passes over the 26-neighbourhood.
pub(crate) fn skip_distances(active: &[bool], dims: [usize; 3]) -> Vec<u8> {
    let [nx, ny, nz] = dims;
    debug_assert_eq!(active.len(), nx * ny * nz);
    let mut d: Vec<u8> = active.iter().map(|&a| if a { 0 } else { 255 }).collect();
    let at = |x: usize, y: usize, z: usize| x + nx * (y + ny * z);
    let pass = |d: &mut Vec<u8>, forward: bool| {
        let idx = |i: usize, n: usize| if forward { i } else { n - 1 - i };
        let step: i64 = if forward { -1 } else { 1 };
        for zi in 0..nz {
            let z = idx(zi, nz);
            for yi in 0..ny {
                let y = idx(yi, ny);
                for xi in 0..nx {
                    let x = idx(xi, nx);
                    let mut best = d[at(x, y, z)];
                    if best == 0 {
                        continue;
                    }
                    // The 13 neighbours already visited in this raster order.
                    for (dz, dy, dx) in NEIGHBOURS_BEFORE {
                        let (qx, qy, qz) = (
                            x as i64 + step * dx,
                            y as i64 + step * dy,
                            z as i64 + step * dz,
                        );
                        if qx < 0
                            || qy < 0
                            || qz < 0
                            || qx >= nx as i64
                            || qy >= ny as i64
                            || qz >= nz as i64
                        {
                            continue;
                        }
                        let q = d[at(qx as usize, qy as usize, qz as usize)];
                        best = best.min(q.saturating_add(1));
                    }
                    d[at(x, y, z)] = best;
                }
            }
        }
    };
    pass(&mut d, true);
    pass(&mut d, false);
    d
}

/// The neighbours `(dz, dy, dx)` (each 0 or 1, scaled by the pass direction) that precede a
/// block in raster order x fastest: the previous slice, the previous row, the previous
/// block (for the backward pass negated: those that follow).
const NEIGHBOURS_BEFORE: [(i64, i64, i64); 13] = [
    (1, 1, 1),
    (1, 1, 0),
    (1, 1, -1),
    (1, 0, 1),
    (1, 0, 0),
    (1, 0, -1),
    (1, -1, 1),
    (1, -1, 0),
    (1, -1, -1),
    (0, 1, 1),
    (0, 1, 0),
    (0, 1, -1),
    (0, 0, 1),
];

/// Bricks filled per batch of a downsampled assignment (bounds the staging memory).
const FILL_BATCH: usize = 64;

impl BrickCache {
    /// A cache of `capacity` bricks for `volume` (at least 1). Nothing is allocated until
    /// bricks are loaded.
    pub fn new(volume: &Volume, capacity: usize) -> Result<Self, RenderError> {
        if capacity == 0 {
            return Err(RenderError::bad(
                "cache capacity",
                capacity,
                "must hold at least one brick",
            ));
        }
        Ok(Self {
            requested: capacity,
            capacity: capacity.min(volume.brick_count()),
            volume_id: volume.id(),
            brick_samples: volume.slot_samples(),
            pool: Vec::new(),
            slot_brick: Vec::new(),
            last_used: Vec::new(),
            reference: vec![NOT_RESIDENT; volume.brick_count()],
            clock: 0,
            stats: CacheStats::default(),
            host_samples: true,
            mixed: Vec::new(),
            mixed_ra: Vec::new(),
            mixed_rb: Vec::new(),
            mixed_sa: Vec::new(),
            mixed_sb: Vec::new(),
            generation: 0,
            block_info: Vec::new(),
            block_info_key: None,
            mixed_filter: crate::Filter::Tricubic,
            detail: vec![f32::NAN; volume.brick_count()],
        })
    }

    /// The bookkeeping of a cache whose samples live elsewhere (the GPU renderer's pool):
    /// slots, reference index and LRU as [`BrickCache::new`], but [`BrickCache::pool`] stays
    /// empty and the loaders copy the bricks themselves ([`BrickCache::load_slots`]).
    pub(crate) fn bookkeeping(volume: &Volume, capacity: usize) -> Result<Self, RenderError> {
        let mut c = Self::new(volume, capacity)?;
        c.host_samples = false;
        Ok(c)
    }

    /// A cache holding up to `bytes` of samples (at least one brick).
    pub fn with_bytes(volume: &Volume, bytes: usize) -> Result<Self, RenderError> {
        let per = volume.slot_samples() * size_of::<f32>();
        Self::new(volume, (bytes / per).max(1))
    }

    /// A cache for `volume` within [`DEFAULT_CACHE_BYTES`].
    pub fn for_volume(volume: &Volume) -> Self {
        let per = volume.slot_samples() * size_of::<f32>();
        let n = (DEFAULT_CACHE_BYTES / per).max(1);
        Self::new(volume, n).unwrap_or_else(|_| unreachable!("capacity is at least 1"))
    }

    /// Slots in the pool.
    pub fn capacity(&self) -> usize {
        self.capacity
    }
    /// Bricks now resident (at either resolution).
    pub fn resident(&self) -> usize {
        if self.mixed.is_empty() {
            self.slot_brick.len()
        } else {
            self.mixed.iter().filter(|&&l| l != LEVEL_NONE).count()
        }
    }
    /// Cumulative counters.
    pub fn stats(&self) -> CacheStats {
        self.stats
    }
    /// The pool of slots (see the type's docs).
    pub fn pool(&self) -> &[f32] {
        &self.pool
    }
    /// The reference index, one entry per brick (see the type's docs).
    pub fn reference(&self) -> &[u32] {
        &self.reference
    }
    /// Slot of brick `n`, if resident at full resolution.
    pub fn slot_of(&self, n: usize) -> Option<usize> {
        self.reference
            .get(n)
            .filter(|&&s| s & HALF_RESOLUTION == 0)
            .map(|&s| s as usize)
    }
    /// Half slot of brick `n`, if resident at half resolution (a downsampled assignment):
    /// its samples ([`Volume::fill_brick_half`]) start at `k · Volume::half_slot_samples()`
    /// in the pool.
    pub fn half_slot_of(&self, n: usize) -> Option<usize> {
        self.reference
            .get(n)
            .filter(|&&s| s != NOT_RESIDENT && s & HALF_RESOLUTION != 0)
            .map(|&s| (s & !HALF_RESOLUTION) as usize)
    }
    /// Bricks held at half resolution.
    pub fn downsampled(&self) -> usize {
        self.mixed.iter().filter(|&&l| l == LEVEL_HALF).count()
    }
    /// Bytes held by the pool and the index.
    pub fn memory_bytes(&self) -> usize {
        (self.pool.len() + self.reference.len()) * 4 + self.slot_brick.len() * 12
    }

    /// Empties the cache when it was made for another volume (or the volume's layout
    /// differs); counters are kept.
    pub(crate) fn bind(&mut self, volume: &Volume) {
        if self.volume_id == volume.id() {
            return;
        }
        if self.rebind(volume) {
            return;
        }
        self.volume_id = volume.id();
        self.brick_samples = volume.slot_samples();
        self.pool.clear();
        self.slot_brick.clear();
        self.last_used.clear();
        self.reference = vec![NOT_RESIDENT; volume.brick_count()];
        self.capacity = self.requested.min(volume.brick_count());
        self.mixed.clear();
        self.mixed_ra.clear();
        self.mixed_rb.clear();
        self.mixed_sa.clear();
        self.mixed_sb.clear();
        self.generation += 1;
        self.detail = vec![f32::NAN; volume.brick_count()];
    }

    /// Binds the cache to `volume` keeping what it holds, where `volume` was built after the
    /// bound one ([`Volume::new_after`]) and the samples live here: only the resident
    /// bricks that hold a changed block are filled again (a brick's stored samples are the
    /// union of its blocks' supports, so the others hold the same samples bit for bit). False
    /// (nothing done) otherwise: a downsampled assignment, another layout, a pool elsewhere.
    fn rebind(&mut self, volume: &Volume) -> bool {
        let Some(changed) = volume.changes_after(self.volume_id) else {
            return false;
        };
        if !self.host_samples
            || self.is_mixed()
            || self.brick_samples != volume.slot_samples()
            || self.reference.len() != volume.brick_count()
        {
            return false;
        }
        let [bx, by, _] = volume.block_dims();
        let per = volume.layout().blocks_per_brick();
        let mut stale = vec![false; volume.brick_count()];
        for n in (0..changed.len()).filter(|&n| changed[n]) {
            let c = [n % bx, (n / bx) % by, n / (bx * by)].map(|v| v / per);
            stale[volume.brick_index(c)] = true;
        }
        let b = self.brick_samples;
        for (slot, &brick) in self.slot_brick.iter().enumerate() {
            if stale[brick as usize] {
                volume.fill_brick(brick as usize, &mut self.pool[slot * b..(slot + 1) * b]);
                self.stats.loads += 1;
            }
        }
        self.volume_id = volume.id();
        // The slopes and ranges differ: what the kernel steps by is computed again.
        self.generation += 1;
        self.detail = vec![f32::NAN; volume.brick_count()];
        true
    }

    /// True while the cache holds a downsampled assignment.
    pub(crate) fn is_mixed(&self) -> bool {
        !self.mixed.is_empty()
    }

    /// Drops a downsampled assignment (every brick it held counts as evicted), leaving an
    /// empty cache for ordinary loading. False when there was none (nothing changes).
    pub(crate) fn clear_mixed(&mut self) -> bool {
        if self.mixed.is_empty() {
            return false;
        }
        self.stats.evictions += self.resident() as u64;
        self.mixed.clear();
        self.mixed_ra.clear();
        self.mixed_rb.clear();
        self.mixed_sa.clear();
        self.mixed_sb.clear();
        self.generation += 1;
        self.pool.clear();
        self.slot_brick.clear();
        self.last_used.clear();
        self.reference.fill(NOT_RESIDENT);
        true
    }

    /// The per-block ranges of the stored samples under the downsampled assignment (first
    /// field, second field or empty).
    pub(crate) fn mixed_ranges(&self) -> (&[[f32; 2]], &[[f32; 2]]) {
        (&self.mixed_ra, &self.mixed_rb)
    }

    /// The slope bounds of the field the ray caster searches under the downsampled
    /// assignment (as [`Volume::trace_slopes`], of the stored samples).
    pub(crate) fn mixed_slopes(&self, volume: &Volume) -> Vec<[f32; 3]> {
        match volume.combine() {
            None => self.mixed_sa.clone(),
            Some(c) => crate::volume::combined_slopes(c, &self.mixed_sa, &self.mixed_sb),
        }
    }

    /// What the kernel steps by per block for the frame `u` describes
    /// ([`crate::kernel::TraceData::block_info`]): the slope bounds of what the pool stores
    /// and the Chebyshev distance in blocks to the nearest block active under `u` for the
    /// block ranges `ranges` ([`skip_distances`]). Computed when the isovalue, the side,
    /// the switches, the combination or what the pool stores changed, else kept; the flag
    /// says whether it was computed now (the GPU uploads it then).
    pub(crate) fn block_info(
        &mut self,
        volume: &Volume,
        ranges: &[[f32; 2]],
        u: &crate::Uniforms,
    ) -> (&[[f32; 4]], bool) {
        let key = BlockInfoKey {
            iso: u.iso.to_bits(),
            inside: u.inside_sign.to_bits(),
            skip: u.flags & crate::kernel::FLAG_SKIP_EMPTY,
            combine: u.combine,
            morph: u.morph_t.to_bits(),
            generation: self.generation,
        };
        if self.block_info_key == Some(key) {
            return (&self.block_info, false);
        }
        let slopes = if self.is_mixed() {
            std::borrow::Cow::Owned(self.mixed_slopes(volume))
        } else {
            volume.trace_slopes()
        };
        let active: Vec<bool> = ranges
            .iter()
            .map(|&r| crate::kernel::block_active(u, r))
            .collect();
        let dist = skip_distances(&active, volume.block_dims());
        self.block_info = slopes
            .iter()
            .zip(dist)
            .map(|(s, d)| [s[0], s[1], s[2], f32::from(d)])
            .collect();
        self.block_info_key = Some(key);
        (&self.block_info, true)
    }

    /// What [`BrickCache::block_info`] computed last (empty before).
    pub(crate) fn current_block_info(&self) -> &[[f32; 4]] {
        &self.block_info
    }

    /// The detail of each brick in `bricks` ([`Volume::brick_detail`]), computed once per
    /// volume (in parallel) and kept.
    pub(crate) fn details(&mut self, volume: &Volume, bricks: &[usize]) -> Vec<f32> {
        let todo: Vec<usize> = bricks
            .iter()
            .copied()
            .filter(|&n| self.detail[n].is_nan())
            .collect();
        let got: Vec<f32> = todo.par_iter().map(|&n| volume.brick_detail(n)).collect();
        for (n, d) in todo.into_iter().zip(got) {
            self.detail[n] = d;
        }
        bricks.iter().map(|&n| self.detail[n]).collect()
    }

    /// Whether `full` bricks at full resolution and `half` at half resolution fit the pool
    /// (see the type's docs for the layout).
    pub(crate) fn mixed_fits(&self, volume: &Volume, full: usize, half: usize) -> bool {
        let (ss, hs) = (volume.slot_samples(), volume.half_slot_samples());
        ((full * ss).div_ceil(hs) + half) * hs <= self.capacity * ss
    }

    /// Makes `levels` (one per brick) the cache's downsampled assignment unless it already
    /// is (with hanging samples matched for the same search `filter`): empties the cache,
    /// stores the full-resolution bricks (hanging samples matched,
    /// [`Volume::fill_brick_matched`]) and the half-resolution ones
    /// ([`Volume::fill_brick_half`]) and records the ranges of what is stored. `sink(offset,
    /// samples)` receives every brick's samples at its offset in the pool (the GPU's upload;
    /// a host cache also keeps them in [`BrickCache::pool`]). Returns false when nothing had
    /// to change (every brick a hit).
    pub(crate) fn load_mixed(
        &mut self,
        volume: &Volume,
        levels: Vec<u8>,
        filter: crate::Filter,
        mut sink: impl FnMut(usize, &[f32]),
    ) -> bool {
        if self.mixed == levels && self.mixed_filter == filter {
            self.stats.hits += self.resident() as u64;
            return false;
        }
        self.stats.evictions += self.resident() as u64;
        self.pool.clear();
        self.slot_brick.clear();
        self.last_used.clear();
        self.reference.fill(NOT_RESIDENT);
        let (ss, hs) = (volume.slot_samples(), volume.half_slot_samples());
        // Offsets: full slots first, then half slots from the next half-slot boundary.
        let full: Vec<usize> = (0..levels.len())
            .filter(|&n| levels[n] == LEVEL_FULL)
            .collect();
        let half: Vec<usize> = (0..levels.len())
            .filter(|&n| levels[n] == LEVEL_HALF)
            .collect();
        let k0 = (full.len() * ss).div_ceil(hs);
        let mut jobs: Vec<(usize, usize, bool)> = Vec::with_capacity(full.len() + half.len());
        for (s, &n) in full.iter().enumerate() {
            self.reference[n] = s as u32;
            jobs.push((s * ss, n, false));
        }
        for (k, &n) in half.iter().enumerate() {
            self.reference[n] = HALF_RESOLUTION | (k0 + k) as u32;
            jobs.push(((k0 + k) * hs, n, true));
        }
        let total = if half.is_empty() {
            full.len() * ss
        } else {
            (k0 + half.len()) * hs
        };
        if self.host_samples {
            self.pool.resize(total, 0.0);
        }
        self.mixed_ra = volume.block_ranges().to_vec();
        self.mixed_rb = volume
            .operand_block_ranges()
            .map_or_else(Vec::new, <[_]>::to_vec);
        self.mixed_sa = volume.block_slopes().to_vec();
        self.mixed_sb = volume
            .operand_block_slopes()
            .map_or_else(Vec::new, <[_]>::to_vec);
        self.generation += 1;
        let is_half = |n: usize| levels[n] == LEVEL_HALF;
        for batch in jobs.chunks(FILL_BATCH) {
            let filled: Vec<Vec<f32>> = batch
                .par_iter()
                .map(|&(_, n, h)| {
                    if h {
                        let mut out = vec![0.0; hs];
                        volume.fill_brick_half(n, &mut out);
                        out
                    } else {
                        let mut out = vec![0.0; ss];
                        volume.fill_brick_matched(n, is_half, filter, &mut out);
                        out
                    }
                })
                .collect();
            for (&(offset, n, h), data) in batch.iter().zip(&filled) {
                volume.stored_block_stats(
                    n,
                    h,
                    data,
                    &mut self.mixed_ra,
                    &mut self.mixed_sa,
                    &mut self.mixed_rb,
                    &mut self.mixed_sb,
                );
                if self.host_samples {
                    self.pool[offset..offset + data.len()].copy_from_slice(data);
                }
                sink(offset, data);
            }
        }
        self.stats.loads += jobs.len() as u64;
        self.mixed = levels;
        self.mixed_filter = filter;
        true
    }

    /// Advances the clock (once per pass) and returns it.
    pub(crate) fn tick(&mut self) -> u64 {
        self.clock += 1;
        self.clock
    }

    /// Marks brick `n` (resident) as used now.
    pub(crate) fn touch(&mut self, n: usize) {
        if self.is_mixed() {
            return;
        }
        if let Some(s) = self.slot_of(n) {
            self.last_used[s] = self.clock;
        }
    }

    pub(crate) fn count_hit(&mut self) {
        self.stats.hits += 1;
    }

    /// Loads `bricks` (not resident, in priority order) as far as the capacity allows,
    /// evicting the least recently used bricks that `keep` does not protect. Returns how
    /// many were loaded.
    #[cfg(test)]
    pub(crate) fn load(
        &mut self,
        volume: &Volume,
        bricks: &[usize],
        keep: impl Fn(usize) -> bool,
    ) -> usize {
        self.load_slots(volume, bricks, keep).len()
    }

    /// [`BrickCache::load`], returning the `(slot, brick)` pairs it filled, in order. A
    /// cache made by [`BrickCache::bookkeeping`] only assigns the slots: the caller copies
    /// the bricks into its own pool.
    pub(crate) fn load_slots(
        &mut self,
        volume: &Volume,
        bricks: &[usize],
        keep: impl Fn(usize) -> bool,
    ) -> Vec<(usize, usize)> {
        let mut loaded = Vec::new();
        // Eviction candidates, popped least recently used first (ties: lower slot).
        let mut victims: Vec<usize> = (0..self.slot_brick.len())
            .filter(|&s| !keep(self.slot_brick[s] as usize))
            .collect();
        victims.sort_by_key(|&s| std::cmp::Reverse((self.last_used[s], s)));
        for &n in bricks {
            debug_assert!(self.slot_of(n).is_none());
            let slot = if self.slot_brick.len() < self.capacity {
                self.slot_brick.push(n as u32);
                self.last_used.push(self.clock);
                if self.host_samples {
                    self.pool
                        .resize(self.slot_brick.len() * self.brick_samples, 0.0);
                }
                self.slot_brick.len() - 1
            } else if let Some(s) = victims.pop() {
                let old = self.slot_brick[s] as usize;
                self.reference[old] = NOT_RESIDENT;
                self.slot_brick[s] = n as u32;
                self.last_used[s] = self.clock;
                self.stats.evictions += 1;
                s
            } else {
                break;
            };
            if self.host_samples {
                let b = self.brick_samples;
                volume.fill_brick(n, &mut self.pool[slot * b..(slot + 1) * b]);
            }
            self.reference[n] = slot as u32;
            self.stats.loads += 1;
            loaded.push((slot, n));
        }
        loaded
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Layout;
    use glam::Vec3;
    use isokit_field::Grid;

    fn volume() -> Volume {
        let g = Grid::new([17, 17, 9], Vec3::ZERO, 1.0).unwrap();
        Volume::from_grid(g, Layout { block: 4, brick: 8 }).unwrap()
    }

    #[test]
    fn evicts_the_least_recently_used_brick() {
        let v = volume();
        assert_eq!(v.brick_count(), 4);
        let mut c = BrickCache::new(&v, 2).unwrap();
        c.tick();
        assert_eq!(c.load(&v, &[0, 1], |_| false), 2);
        c.tick();
        c.touch(0); // brick 1 is now the least recently used
        assert_eq!(c.load(&v, &[2], |_| false), 1);
        assert!(c.slot_of(0).is_some() && c.slot_of(1).is_none() && c.slot_of(2).is_some());
        // Protected bricks are never evicted: nothing can make room.
        assert_eq!(c.load(&v, &[3], |_| true), 0);
        assert_eq!(
            c.stats(),
            CacheStats {
                loads: 3,
                evictions: 1,
                hits: 0
            }
        );
        assert_eq!(
            c.pool().len(),
            2 * Layout { block: 4, brick: 8 }.brick_samples()
        );
        assert!(BrickCache::new(&v, 0).is_err());
    }

    #[test]
    fn skip_distances_are_the_chessboard_distance() {
        let mut rng = isokit_field::rng::SplitMix64::new(11);
        for dims in [[7, 5, 6], [1, 9, 3], [12, 1, 1]] {
            let n = dims[0] * dims[1] * dims[2];
            for density in [0.02, 0.1, 0.0] {
                let active: Vec<bool> = (0..n).map(|_| rng.next_f64() < density).collect();
                let d = skip_distances(&active, dims);
                let c = |m: usize| {
                    [
                        (m % dims[0]) as i64,
                        ((m / dims[0]) % dims[1]) as i64,
                        (m / (dims[0] * dims[1])) as i64,
                    ]
                };
                for (m, &got) in d.iter().enumerate() {
                    let want = (0..n)
                        .filter(|&a| active[a])
                        .map(|a| {
                            let (p, q) = (c(m), c(a));
                            (0..3).map(|i| (p[i] - q[i]).abs()).max().unwrap()
                        })
                        .min()
                        .map_or(255, |v| v.min(255) as u8);
                    assert_eq!(got, want, "{dims:?} block {m}");
                }
            }
        }
    }

    #[test]
    fn a_cache_handed_another_volume_empties_itself() {
        let (a, b) = (volume(), volume());
        let mut c = BrickCache::new(&a, 4).unwrap();
        c.load(&a, &[0, 3], |_| false);
        assert_eq!(c.resident(), 2);
        c.bind(&a);
        assert_eq!(c.resident(), 2);
        c.bind(&b);
        assert_eq!(c.resident(), 0);
        assert!(c.reference().iter().all(|&r| r == NOT_RESIDENT));
        // The capacity asked for survives a smaller volume.
        let g = Grid::new([5, 5, 5], Vec3::ZERO, 1.0).unwrap();
        let small = Volume::from_grid(g, Layout { block: 4, brick: 4 }).unwrap();
        c.bind(&small);
        assert_eq!(c.capacity(), 1);
        c.bind(&a);
        assert_eq!(c.capacity(), 4);
    }
}
