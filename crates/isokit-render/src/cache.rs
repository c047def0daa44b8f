//! The brick cache (002 Sec. 6.2.2): a pool of fixed-size slots holding bricks, a reference
//! index from brick to slot, least-recently-used eviction.

use crate::{RenderError, Volume};

/// Marks a brick that is not in the cache, in [`BrickCache::reference`].
pub const NOT_RESIDENT: u32 = u32::MAX;

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
/// still renders the same image, in several passes (see [`crate::render`]). The cache
/// belongs to one volume; handed another one (see [`Volume::id`]) it empties itself.
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
}

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
    /// Bricks now resident.
    pub fn resident(&self) -> usize {
        self.slot_brick.len()
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
    /// Slot of brick `n`, if resident.
    pub fn slot_of(&self, n: usize) -> Option<usize> {
        self.reference
            .get(n)
            .filter(|&&s| s != NOT_RESIDENT)
            .map(|&s| s as usize)
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
        self.volume_id = volume.id();
        self.brick_samples = volume.slot_samples();
        self.pool.clear();
        self.slot_brick.clear();
        self.last_used.clear();
        self.reference = vec![NOT_RESIDENT; volume.brick_count()];
        self.capacity = self.requested.min(volume.brick_count());
    }

    /// Advances the clock (once per pass) and returns it.
    pub(crate) fn tick(&mut self) -> u64 {
        self.clock += 1;
        self.clock
    }

    /// Marks brick `n` (resident) as used now.
    pub(crate) fn touch(&mut self, n: usize) {
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
