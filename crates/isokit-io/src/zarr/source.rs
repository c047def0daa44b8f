//! Reading a store's samples on demand, chunk by chunk through a bounded cache of decoded
//! chunks, so that a field larger than memory can be ray cast (the renderer's brick cache
//! asks for the boxes of samples it uploads).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use glam::Vec3;
use zarrs::array::{Array, ArraySubset};
use zarrs::filesystem::FilesystemStore;

use super::{open_readable, subchunks, zerr};
use crate::IoError;
use crate::lattice::Lattice;

/// A decoded chunk: its samples (x fastest, the chunk's full shape), or `None` for a chunk
/// that is not stored (every sample the fill value).
type Decoded = Option<Arc<Vec<f32>>>;

/// The decoded chunks kept, with the clock of their last use.
#[derive(Default)]
struct Chunks {
    map: HashMap<[u64; 3], (Decoded, u64)>,
    clock: u64,
}

/// The samples of a Zarr store read on demand: chunks are decoded when first asked for and
/// kept in a cache of at most `cache_bytes` (least recently used dropped first). Reads never
/// fail: a chunk that cannot be read or decoded reads as NaN and [`ZarrSource::error`] says
/// why (check it after the work that read).
pub struct ZarrSource {
    path: PathBuf,
    array: Array<FilesystemStore>,
    lattice: Lattice,
    f64s: bool,
    fill: f32,
    /// The shape along x, y, z of what is decoded at once: a chunk, or a chunk inside a
    /// shard.
    chunk: [usize; 3],
    sharded: bool,
    capacity: usize,
    chunks: Mutex<Chunks>,
    loads: AtomicU64,
    error: Mutex<Option<String>>,
}

impl std::fmt::Debug for ZarrSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZarrSource")
            .field("path", &self.path)
            .field("dims", &self.lattice.dims)
            .field("chunk", &self.chunk)
            .field("capacity", &self.capacity)
            .finish()
    }
}

impl ZarrSource {
    /// Opens the store at `path` for reading on demand with a cache of decoded chunks of at
    /// most `cache_bytes` (at least one chunk). The store must be complete and hold float32
    /// or float64 samples (as [`super::read_zarr`]); nothing but its metadata is read here.
    pub fn open(path: &Path, cache_bytes: usize) -> Result<Self, IoError> {
        let r = open_readable(path)?;
        let shape = r
            .opened
            .array
            .chunk_shape(&[0, 0, 0])
            .map_err(|e| zerr(path, e))?;
        // A sharded store is read by the chunks inside its shards (decoded alone).
        let sharded = subchunks(&r.opened.array);
        let c: Vec<usize> = match sharded {
            Some(s) => s.iter().map(|&v| v as usize).collect(),
            None => shape.iter().map(|v| v.get() as usize).collect(),
        };
        let chunk = [c[2], c[1], c[0]];
        let per = chunk.iter().product::<usize>() * 4;
        Ok(Self {
            path: path.to_path_buf(),
            array: r.opened.array,
            lattice: r.lattice,
            f64s: r.f64s,
            fill: r.fill,
            chunk,
            sharded: sharded.is_some(),
            capacity: (cache_bytes / per.max(1)).max(1),
            chunks: Mutex::new(Chunks::default()),
            loads: AtomicU64::new(0),
            error: Mutex::new(None),
        })
    }

    /// Samples along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.lattice.dims
    }

    /// Position of sample (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        Vec3::from(self.lattice.origin)
    }

    /// Distance between samples along x, y, z.
    pub fn spacing(&self) -> Vec3 {
        Vec3::from(self.lattice.spacing)
    }

    /// The lattice and meaning of the samples (the store's attributes).
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// Chunks decoded so far (a chunk dropped from the cache and asked for again counts
    /// again).
    pub fn loads(&self) -> u64 {
        self.loads.load(Ordering::Relaxed)
    }

    /// Decoded chunks the cache holds at most.
    pub fn cache_chunks(&self) -> usize {
        self.capacity
    }

    /// The first failure to read a chunk, if any (its samples read as NaN).
    pub fn error(&self) -> Option<String> {
        self.error.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    fn decode(&self, key: [u64; 3]) -> Decoded {
        self.loads.fetch_add(1, Ordering::Relaxed);
        if self.sharded {
            return self.decode_subchunk(key);
        }
        let got = if self.f64s {
            self.array
                .retrieve_chunk_if_exists::<Vec<f64>>(&key)
                .map(|o| o.map(|v| v.into_iter().map(|x| x as f32).collect::<Vec<f32>>()))
        } else {
            self.array.retrieve_chunk_if_exists::<Vec<f32>>(&key)
        };
        match got {
            Ok(v) => v.map(Arc::new),
            Err(e) => {
                let mut slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
                slot.get_or_insert_with(|| format!("{}: chunk {key:?}: {e}", self.path.display()));
                Some(Arc::new(vec![f32::NAN; self.chunk.iter().product()]))
            }
        }
    }

    /// A chunk inside a shard, as the samples of its region (the sharding codec decodes only
    /// that chunk), padded to the chunk's shape with the fill value.
    fn decode_subchunk(&self, key: [u64; 3]) -> Decoded {
        let [cx, cy, cz] = self.chunk;
        let [nx, ny, nz] = self.lattice.dims;
        let lo = [
            key[0] as usize * cz,
            key[1] as usize * cy,
            key[2] as usize * cx,
        ];
        let hi = [
            (lo[0] + cz).min(nz),
            (lo[1] + cy).min(ny),
            (lo[2] + cx).min(nx),
        ];
        let subset = ArraySubset::new_with_ranges(&[
            lo[0] as u64..hi[0] as u64,
            lo[1] as u64..hi[1] as u64,
            lo[2] as u64..hi[2] as u64,
        ]);
        let got = if self.f64s {
            self.array
                .retrieve_array_subset::<Vec<f64>>(&subset)
                .map(|v| v.into_iter().map(|x| x as f32).collect::<Vec<f32>>())
        } else {
            self.array.retrieve_array_subset::<Vec<f32>>(&subset)
        };
        let mut out = vec![self.fill; cx * cy * cz];
        match got {
            Ok(v) => {
                let w = [hi[2] - lo[2], hi[1] - lo[1], hi[0] - lo[0]];
                for z in 0..w[2] {
                    for y in 0..w[1] {
                        let src = w[0] * (y + w[1] * z);
                        let dst = cx * (y + cy * z);
                        out[dst..dst + w[0]].copy_from_slice(&v[src..src + w[0]]);
                    }
                }
            }
            Err(e) => {
                let mut slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
                slot.get_or_insert_with(|| format!("{}: chunk {key:?}: {e}", self.path.display()));
                out.fill(f32::NAN);
            }
        }
        Some(Arc::new(out))
    }

    /// Chunk `key` (z, y, x), decoded or from the cache.
    fn chunk(&self, key: [u64; 3]) -> Decoded {
        {
            let mut c = self.chunks.lock().unwrap_or_else(|p| p.into_inner());
            c.clock += 1;
            let now = c.clock;
            if let Some((d, used)) = c.map.get_mut(&key) {
                *used = now;
                return d.clone();
            }
        }
        // Decoded outside the lock: other threads read other chunks meanwhile (two may
        // decode the same chunk at once; both results are the same).
        let d = self.decode(key);
        let mut c = self.chunks.lock().unwrap_or_else(|p| p.into_inner());
        while c.map.len() >= self.capacity {
            let Some(oldest) = c.map.iter().min_by_key(|(_, (_, u))| *u).map(|(k, _)| *k) else {
                break;
            };
            c.map.remove(&oldest);
        }
        let now = c.clock;
        c.map.insert(key, (d.clone(), now));
        d
    }

    /// Samples `(x0 + i, y, z)` for `i` in `0..out.len()`; every index must lie inside the
    /// lattice (the caller clamps).
    pub fn read_row(&self, x0: usize, y: usize, z: usize, out: &mut [f32]) {
        let [cx, cy, cz] = self.chunk;
        let key_yz = [(z / cz) as u64, (y / cy) as u64];
        let (ly, lz) = (y % cy, z % cz);
        let mut x = x0;
        let end = x0 + out.len();
        while x < end {
            let kx = x / cx;
            let stop = ((kx + 1) * cx).min(end);
            let dst = &mut out[x - x0..stop - x0];
            match self.chunk([key_yz[0], key_yz[1], kx as u64]) {
                Some(data) => {
                    let at = (x - kx * cx) + cx * (ly + cy * lz);
                    dst.copy_from_slice(&data[at..at + dst.len()]);
                }
                None => dst.fill(self.fill),
            }
            x = stop;
        }
    }

    /// The smallest and largest finite sample and the number of non-finite ones, read chunk
    /// by chunk (each decoded once, outside the cache; absent chunks count as their fill
    /// value), so a store of any size is summarized in the memory of one chunk.
    pub fn summary(&self) -> (Option<(f32, f32)>, u64) {
        let [cx, cy, cz] = self.chunk;
        let [nx, ny, nz] = self.lattice.dims;
        let (mut lo, mut hi, mut bad) = (f32::INFINITY, f32::NEG_INFINITY, 0u64);
        let mut see = |v: f32, n: u64| {
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            } else {
                bad += n;
            }
        };
        for kz in 0..nz.div_ceil(cz) {
            for ky in 0..ny.div_ceil(cy) {
                for kx in 0..nx.div_ceil(cx) {
                    let (wx, wy, wz) = (
                        cx.min(nx - kx * cx),
                        cy.min(ny - ky * cy),
                        cz.min(nz - kz * cz),
                    );
                    match self.decode([kz as u64, ky as u64, kx as u64]) {
                        None => see(self.fill, (wx * wy * wz) as u64),
                        Some(d) => {
                            for z in 0..wz {
                                for y in 0..wy {
                                    let at = cx * (y + cy * z);
                                    for &v in &d[at..at + wx] {
                                        see(v, 1);
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        ((lo <= hi).then_some((lo, hi)), bad)
    }

    /// One sample (inside the lattice).
    pub fn get(&self, x: usize, y: usize, z: usize) -> f32 {
        let mut v = [0.0];
        self.read_row(x, y, z, &mut v);
        v[0]
    }
}
