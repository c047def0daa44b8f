//! Keys of cells and nodes, the hash function, the direct-mapped caches of 002 Sec. 3.4.2 and
//! the memory accounting of hash maps.
//!
//! ## Cell keys
//! A cell at level `d` (the root is level 0, the finest level is the tree's `max_level`)
//! has an integer index `(i, j, k)` in `[0, 2^d)^3` at its own level: its position on the
//! finest grid, shifted right by its size exponent `max_level - d`. The key is
//!
//! ```text
//! key = 1 << 3d  |  i << 2d  |  j << d  |  k
//! ```
//!
//! The leading 1 (a sentinel bit) encodes the level: `d = (63 - leading_zeros) / 3`. The key
//! takes `3d + 1` bits, so a `u64` holds every level up to [`MAX_LEVEL`] = 21 without
//! overflow (level 21 uses all 64 bits; the last cell of level 21 has the key `u64::MAX`).
//! No key is 0. The thesis (Sec. 3.2) stores 32 bits per coordinate plus a level byte (13
//! bytes); 8 bytes suffice here because positions are stored at the cell's own level.
//!
//! ## Node keys
//! Nodes (cell corners) sit on the finest grid, `(x, y, z)` in `[0, 2^L]^3`, and are keyed by
//! their linear index `x + (2^L + 1) (y + (2^L + 1) z)`, which is below
//! `(2^21 + 1)^3 < 2^64` for every supported level. [`NodeKey`] stores it as two `u32` so that
//! a node record `(NodeKey, f32)` takes 12 bytes instead of the 16 a `(u64, f32)` would.
//!
//! ## Hashing
//! [`KeyHasher`] is a folded multiply (the 128-bit product of the key and an odd 64-bit
//! constant, high half XOR low half): one multiplication per key, and every key bit reaches
//! the low bits that `std::collections::HashMap` (hashbrown) uses as the bucket index and the
//! top 7 bits it uses as the tag. Thesis Sec. 3.3.1 uses "a few shifts, additions and XORs".

use glam::UVec3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};

/// Deepest supported level: cell keys use `3 * level + 1` bits of a `u64`.
pub const MAX_LEVEL: u32 = 21;

/// The key of the cell at `level` with index `index` at its own level (each component below
/// `2^level`). See the module docs.
#[inline]
pub fn cell_key(level: u32, index: UVec3) -> u64 {
    debug_assert!(level <= MAX_LEVEL);
    (1u64 << (3 * level))
        | ((index.x as u64) << (2 * level))
        | ((index.y as u64) << level)
        | index.z as u64
}

/// Level and own-level index of a cell key made by [`cell_key`].
#[inline]
pub fn decode_cell_key(key: u64) -> (u32, UVec3) {
    let level = (63 - key.leading_zeros()) / 3;
    let mask = (1u64 << level) - 1;
    let index = UVec3::new(
        ((key >> (2 * level)) & mask) as u32,
        ((key >> level) & mask) as u32,
        (key & mask) as u32,
    );
    (level, index)
}

/// The key of a node at finest-grid position `q` (each component at most `2^max_level`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct NodeKey([u32; 2]);

impl NodeKey {
    /// Linear index `x + (2^L + 1) (y + (2^L + 1) z)` of `q` on the finest node grid of a tree
    /// of `max_level` L.
    #[inline]
    pub fn new(q: UVec3, max_level: u32) -> Self {
        let n = (1u64 << max_level) + 1;
        Self::from_u64(q.x as u64 + n * (q.y as u64 + n * q.z as u64))
    }

    /// From the linear index.
    #[inline]
    pub fn from_u64(v: u64) -> Self {
        Self([v as u32, (v >> 32) as u32])
    }

    /// The linear index.
    #[inline]
    pub fn get(self) -> u64 {
        self.0[0] as u64 | ((self.0[1] as u64) << 32)
    }

    /// The finest-grid position, inverse of [`NodeKey::new`].
    #[inline]
    pub fn position(self, max_level: u32) -> UVec3 {
        let n = (1u64 << max_level) + 1;
        let v = self.get();
        UVec3::new((v % n) as u32, ((v / n) % n) as u32, (v / (n * n)) as u32)
    }
}

impl Hash for NodeKey {
    #[inline]
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64(self.get());
    }
}

const MUL: u64 = 0x9E37_79B9_7F4A_7C15;

#[inline]
fn fold_mul(x: u64) -> u64 {
    let p = (x as u128) * (MUL as u128);
    (p as u64) ^ ((p >> 64) as u64)
}

/// The hash of a `u64` key (what [`KeyHasher`] gives for one `write_u64`).
#[inline]
pub fn hash_u64(key: u64) -> u64 {
    fold_mul(key)
}

/// A folded-multiply hasher for integer keys (see the module docs). Not for untrusted keys:
/// it is not collision resistant, which is fine for octree positions.
#[derive(Clone, Copy, Debug, Default)]
pub struct KeyHasher(u64);

impl Hasher for KeyHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write_u64(&mut self, x: u64) {
        self.0 = fold_mul(self.0 ^ x);
    }
    #[inline]
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut b = [0u8; 8];
            b[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(b));
        }
    }
}

/// The `BuildHasher` of the octree's maps.
pub type KeyBuild = BuildHasherDefault<KeyHasher>;

/// Estimated heap bytes of a `std::collections::HashMap`, from its capacity.
///
/// std's map is hashbrown's SwissTable: `buckets` is a power of two and the capacity is
/// `buckets - 1` below 8 buckets, `buckets / 8 * 7` from 8 on, so the bucket count follows
/// from [`HashMap::capacity`]. Each bucket holds one `(K, V)` slot (padding included, as
/// `size_of::<(K, V)>()` says) and one control byte, plus 16 trailing control bytes (one SSE2
/// group). Allocator headers (one allocation per map) are not counted.
pub fn hashmap_bytes<K, V, S>(m: &HashMap<K, V, S>) -> usize {
    let cap = m.capacity();
    if cap == 0 {
        return 0;
    }
    let buckets = if cap < 7 { cap + 1 } else { cap / 7 * 8 };
    buckets * (std::mem::size_of::<(K, V)>() + 1) + 16
}

/// A key type of the wide maps, made from the `u64` key.
pub trait WideKey: Copy + Eq + Hash {
    /// From the `u64` key.
    fn from_u64(v: u64) -> Self;
    /// Back to the `u64` key.
    fn to_u64(self) -> u64;
}

impl WideKey for u64 {
    #[inline]
    fn from_u64(v: u64) -> Self {
        v
    }
    #[inline]
    fn to_u64(self) -> u64 {
        self
    }
}

impl WideKey for NodeKey {
    #[inline]
    fn from_u64(v: u64) -> Self {
        NodeKey::from_u64(v)
    }
    #[inline]
    fn to_u64(self) -> u64 {
        self.get()
    }
}

/// Deepest level whose cell and node keys all fit in 32 bits: cell keys take `3L + 1 = 31`
/// bits and node keys are below `(2^10 + 1)^3 < 2^32`.
pub const NARROW_LEVELS: u32 = 10;

/// A hash map from `u64` keys, stored with `u32` keys when every key fits (trees of at most
/// [`NARROW_LEVELS`] levels) and as `W` otherwise. The narrow form makes a cell record 4
/// bytes instead of 8 and a node record 8 bytes instead of 12.
#[derive(Clone, Debug)]
pub enum KeyMap<W, V> {
    /// `u32` keys.
    Narrow(HashMap<u32, V, KeyBuild>),
    /// Full-width keys.
    Wide(HashMap<W, V, KeyBuild>),
}

impl<W: WideKey, V: Copy> KeyMap<W, V> {
    /// The map of `pairs`, narrow when `narrow` (every key must then be below 2^32).
    pub fn from_pairs(narrow: bool, pairs: impl ExactSizeIterator<Item = (u64, V)>) -> Self {
        let n = pairs.len();
        if narrow {
            let mut m = HashMap::with_capacity_and_hasher(n, KeyBuild::default());
            for (k, v) in pairs {
                debug_assert!(k <= u32::MAX as u64);
                m.insert(k as u32, v);
            }
            KeyMap::Narrow(m)
        } else {
            let mut m = HashMap::with_capacity_and_hasher(n, KeyBuild::default());
            for (k, v) in pairs {
                m.insert(W::from_u64(k), v);
            }
            KeyMap::Wide(m)
        }
    }

    /// The value of key `k`.
    #[inline]
    pub fn get(&self, k: u64) -> Option<V> {
        match self {
            KeyMap::Narrow(m) => {
                if k > u32::MAX as u64 {
                    return None;
                }
                m.get(&(k as u32)).copied()
            }
            KeyMap::Wide(m) => m.get(&W::from_u64(k)).copied(),
        }
    }

    /// Whether key `k` is present.
    #[inline]
    pub fn contains(&self, k: u64) -> bool {
        self.get(k).is_some()
    }

    /// Entries.
    pub fn len(&self) -> usize {
        match self {
            KeyMap::Narrow(m) => m.len(),
            KeyMap::Wide(m) => m.len(),
        }
    }

    /// Whether there are no entries.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every key.
    pub fn keys(&self) -> Vec<u64> {
        match self {
            KeyMap::Narrow(m) => m.keys().map(|&k| k as u64).collect(),
            KeyMap::Wide(m) => m.keys().map(|k| k.to_u64()).collect(),
        }
    }

    /// Estimated heap bytes ([`hashmap_bytes`]).
    pub fn bytes(&self) -> usize {
        match self {
            KeyMap::Narrow(m) => hashmap_bytes(m),
            KeyMap::Wide(m) => hashmap_bytes(m),
        }
    }
}

/// Hits and misses of a cache.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    /// Lookups answered by the cache.
    pub hits: u64,
    /// Lookups that went to the hash map.
    pub misses: u64,
}

impl CacheStats {
    /// `hits / (hits + misses)`, 0 when there were no lookups.
    pub fn hit_rate(&self) -> f64 {
        let n = self.hits + self.misses;
        if n == 0 {
            0.0
        } else {
            self.hits as f64 / n as f64
        }
    }
}

impl std::ops::AddAssign for CacheStats {
    fn add_assign(&mut self, o: Self) {
        self.hits += o.hits;
        self.misses += o.misses;
    }
}

/// Lines of the direct-mapped caches (the thesis used 100).
pub const CACHE_LINES: usize = 128;

/// A direct-mapped cache (002 Sec. 3.4.2): the line is chosen by the key's hash (its top 7
/// bits, where the hash map uses the low bits: "another divisor"), and a new key evicts
/// whatever held its line.
#[derive(Clone, Debug)]
pub struct DirectCache<V: Copy> {
    lines: Box<[Option<(u64, V)>]>,
    stats: CacheStats,
}

impl<V: Copy> Default for DirectCache<V> {
    fn default() -> Self {
        Self {
            lines: vec![None; CACHE_LINES].into_boxed_slice(),
            stats: CacheStats::default(),
        }
    }
}

impl<V: Copy> DirectCache<V> {
    /// The cached value of `key`, or `miss(key)` stored in its line.
    #[inline]
    pub fn get_or(&mut self, key: u64, miss: impl FnOnce() -> V) -> V {
        let line = (hash_u64(key) >> (64 - CACHE_LINES.trailing_zeros())) as usize;
        if let Some((k, v)) = self.lines[line] {
            if k == key {
                self.stats.hits += 1;
                return v;
            }
        }
        self.stats.misses += 1;
        let v = miss();
        self.lines[line] = Some((key, v));
        v
    }

    /// Hits and misses so far.
    pub fn stats(&self) -> CacheStats {
        self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::rng::SplitMix64;

    #[test]
    fn cell_keys_round_trip_at_every_level_without_overflow() {
        let mut r = SplitMix64::new(5);
        for level in 0..=MAX_LEVEL {
            let top = (1u64 << level) - 1;
            let mut cases = vec![UVec3::ZERO, UVec3::splat(top as u32)];
            for _ in 0..50 {
                cases.push(UVec3::new(
                    (r.next_u64() & top) as u32,
                    (r.next_u64() & top) as u32,
                    (r.next_u64() & top) as u32,
                ));
            }
            for idx in cases {
                let k = cell_key(level, idx);
                assert_ne!(k, 0);
                assert_eq!(decode_cell_key(k), (level, idx), "level {level} {idx}");
            }
        }
        assert_eq!(cell_key(21, UVec3::splat((1 << 21) - 1)), u64::MAX);
        assert_eq!(cell_key(0, UVec3::ZERO), 1);
    }

    #[test]
    fn node_keys_round_trip_at_level_21() {
        let n = 1u32 << 21;
        for q in [
            UVec3::ZERO,
            UVec3::splat(n),
            UVec3::new(n, 0, n - 1),
            UVec3::new(3, n, 7),
        ] {
            let k = NodeKey::new(q, 21);
            assert_eq!(k.position(21), q);
        }
        // Distinct positions, distinct keys (spot check along the axes' ends).
        let a = NodeKey::new(UVec3::new(n, 0, 0), 21);
        let b = NodeKey::new(UVec3::new(0, 1, 0), 21);
        assert_ne!(a, b);
        assert_eq!(std::mem::size_of::<(NodeKey, f32)>(), 12);
    }

    #[test]
    fn hash_spreads_grid_keys_over_buckets() {
        // Keys of a dense 64^3 block of level-10 cells into 2^16 buckets by the low bits: the
        // fullest bucket must stay close to the mean (4), as for a random function.
        let mut counts = vec![0u32; 1 << 16];
        for x in 0..64u32 {
            for y in 0..64 {
                for z in 0..64 {
                    let h = hash_u64(cell_key(10, UVec3::new(x + 300, y, z + 17)));
                    counts[(h & 0xFFFF) as usize] += 1;
                }
            }
        }
        let max = *counts.iter().max().unwrap();
        assert!(max <= 20, "fullest bucket {max}");
        // The top 7 bits (cache line, hashbrown tag) are spread too.
        let mut top = [0u32; 128];
        for x in 0..4096u64 {
            top[(hash_u64(cell_key(12, UVec3::new(x as u32, 5, 9))) >> 57) as usize] += 1;
        }
        assert!(top.iter().all(|&c| (10..=60).contains(&c)), "{top:?}");
    }

    #[test]
    fn memory_estimate_follows_capacity() {
        let mut m: HashMap<u64, (), KeyBuild> = HashMap::default();
        assert_eq!(hashmap_bytes(&m), 0);
        for k in 0..1000u64 {
            m.insert(k, ());
        }
        let cap = m.capacity();
        assert!(cap >= 1000);
        let bytes = hashmap_bytes(&m);
        // 1000 entries need 2048 buckets (capacity 1792) of 8 + 1 bytes.
        assert_eq!(bytes, 2048 * 9 + 16, "capacity {cap}");
    }

    #[test]
    fn narrow_and_wide_maps_agree() {
        let pairs: Vec<(u64, f32)> = (0..500u64)
            .map(|k| (k * 7919 % 100_003, k as f32))
            .collect();
        let n = KeyMap::<NodeKey, f32>::from_pairs(true, pairs.iter().copied());
        let w = KeyMap::<NodeKey, f32>::from_pairs(false, pairs.iter().copied());
        for k in 0..100_010u64 {
            assert_eq!(n.get(k), w.get(k));
        }
        assert_eq!(n.get(u32::MAX as u64 + 5), None);
        assert_eq!((n.len(), w.len()), (500, 500));
        // Same buckets, 8-byte against 12-byte records.
        assert_eq!(n.bytes() - 16, (w.bytes() - 16) / 13 * 9);
        let mut keys = n.keys();
        keys.sort_unstable();
        let mut want: Vec<u64> = pairs.iter().map(|p| p.0).collect();
        want.sort_unstable();
        assert_eq!(keys, want);
    }

    #[test]
    fn direct_cache_counts_hits_and_evicts() {
        let mut c = DirectCache::<f32>::default();
        assert_eq!(c.get_or(7, || 1.0), 1.0);
        assert_eq!(c.get_or(7, || 2.0), 1.0);
        assert_eq!(c.stats(), CacheStats { hits: 1, misses: 1 });
        // Some other key lands on 7's line and evicts it.
        let line = |k: u64| hash_u64(k) >> 57;
        let other = (8..).find(|&k| line(k) == line(7)).unwrap();
        c.get_or(other, || 3.0);
        assert_eq!(c.get_or(7, || 4.0), 4.0);
        assert_eq!(c.stats().misses, 3);
    }
}
