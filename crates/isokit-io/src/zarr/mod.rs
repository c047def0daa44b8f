//! Zarr v3 stores of volumes and band fields (through the `zarrs` crate).
//!
//! A store is a directory `NAME.zarr` holding a group whose attributes carry the lattice
//! under the keys of the NPY sidecar ([`crate::lattice`]: `origin`, `spacing`, `dims`,
//! `axis_order`, `band`, `inside`, `sign`) and an `isokit` object saying whether the store is
//! complete. In it:
//! - `field`: the samples, `float32`, shape `(nz, ny, nx)` (x fastest, `dimension_names`
//!   `["z", "y", "x"]`), regular chunks of `chunk³` samples (default 64, a whole number of
//!   the samplers' bricks), the `bytes` codec (little endian) then gzip; its own attributes
//!   repeat the lattice, so the array opened alone still says where it lies;
//! - `x`, `y`, `z`: the world coordinates of the samples along each axis (`float64`), so
//!   that xarray opens the store as a dataset with world coordinates
//!   (`xr.open_zarr(path)["field"].sel(x=…, method="nearest")`).
//!
//! [`read_zarr`] also reads stores of other tools: a 3-D array at the root, or the group's
//! `field` array, or its only 3-D array.
//!
//! The fill value is `+band` for band fields (0 for fields without a band): a chunk wholly
//! outside the band holds nothing else and is not written, and readers (zarr-python, xarray,
//! this module) give its samples the fill value, which is the right value there. A chunk
//! wholly inside the band's negative side holds `-band` and is written, so an absent chunk
//! never means the wrong sign.
//!
//! A write goes to `NAME.zarr.partial` beside the target, which is renamed over the target
//! only when every chunk is written: an existing store is never left half-overwritten, and a
//! directory that is not a Zarr store is never replaced. While it runs, the partial store's
//! attributes say `"complete": false` and `.isokit-progress` lists the chunks done, so a
//! killed run's store says which chunks are missing ([`zarr_info`]) and [`read_zarr`]
//! refuses it.

use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use glam::Vec3;
use rayon::prelude::*;
use serde_json::{Value, json};
use zarrs::array::codec::GzipCodec;
use zarrs::array::{Array, ArrayBuilder, data_type};
use zarrs::filesystem::FilesystemStore;
use zarrs::group::{Group, GroupBuilder};

use crate::lattice::{Lattice, check_band};

mod source;
use crate::{IoError, Volume};
pub use source::ZarrSource;

/// The default chunk side: 64³ samples (1 MiB of f32), 8³ bricks of the default size.
pub const DEFAULT_CHUNK: usize = 64;

/// The largest chunk side accepted (256³ f32 = 64 MiB per chunk in memory).
pub const MAX_CHUNK: usize = 256;

/// The most chunks a store may have (a lattice of 16384³ in chunks of 64³ has 2^24).
pub const MAX_CHUNKS: u64 = 1 << 24;

/// The file in a partial store that lists the chunks done so far, one `z y x w` per line
/// (`w` 1 where a chunk file was written, 0 where the chunk holds only the fill value).
const PROGRESS: &str = ".isokit-progress";

/// How [`write_zarr`] lays out a store.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ZarrOptions {
    /// Chunk side in samples (1 to [`MAX_CHUNK`]).
    pub chunk: usize,
    /// Chunks per shard side: 1 writes every chunk as a file; `n > 1` groups `n³` chunks
    /// into one file (Zarr's sharding codec, an index of the chunks at its end), for stores
    /// of millions of chunks. A shard (`chunk · n` samples a side, at most [`MAX_CHUNK`]) is
    /// then the unit the writer samples and writes.
    pub shard: usize,
    /// Gzip level 0–9 (1, the fast level, by default; `None`: no compression).
    pub gzip: Option<u32>,
    /// What the samples were computed from (a hash of the scene and the sampling
    /// options), kept in the attributes: [`ZarrWriter::resume`] refuses a partial store
    /// started from something else.
    pub fingerprint: Option<u64>,
}

impl Default for ZarrOptions {
    fn default() -> Self {
        Self {
            chunk: DEFAULT_CHUNK,
            gzip: Some(1),
            shard: 1,
            fingerprint: None,
        }
    }
}

/// What [`write_zarr`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ZarrWritten {
    /// Chunks in the array's chunk grid.
    pub chunks: usize,
    /// Chunks written (the others hold only the fill value).
    pub written: usize,
}

/// What a store holds, read without its samples ([`zarr_info`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ZarrInfo {
    /// The lattice and meaning of the samples (origin 0 and spacing 1 when the store has
    /// no lattice attributes).
    pub lattice: Lattice,
    /// True when the attributes carry a lattice (`origin` and `spacing`).
    pub has_lattice: bool,
    /// The path of the samples' array in the store (`/field` for isokit's stores).
    pub array: String,
    /// Without sharding `None`; with it, the shape `(z, y, x)` of the chunks inside each
    /// shard (`chunk_shape` is then the shards').
    pub subchunk_shape: Option<[u64; 3]>,
    /// The array's data type, as Zarr names it.
    pub data_type: String,
    /// Chunk shape `(z, y, x)`.
    pub chunk_shape: [u64; 3],
    /// Chunks in the chunk grid.
    pub chunks: u64,
    /// Chunk files present.
    pub present: u64,
    /// The fill value, when it is a number.
    pub fill: Option<f64>,
    /// False for a store whose writer did not finish.
    pub complete: bool,
    /// For an incomplete store: how many chunks its writer had not finished.
    pub missing_chunks: u64,
    /// The first 20 of them, `(z, y, x)`.
    pub missing: Vec<[u64; 3]>,
}

fn zerr(path: &Path, e: impl std::fmt::Display) -> IoError {
    IoError::malformed(path, e.to_string())
}

/// `NAME.zarr` → `NAME.zarr.partial`, where a write goes before it is renamed.
pub fn partial_path(path: &Path) -> PathBuf {
    sibling(path, ".partial")
}

/// `path`'s file name with `suffix` appended, in the same folder (a trailing separator
/// of `path` ignored).
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.file_name().unwrap_or(path.as_os_str()).to_owned();
    name.push(suffix);
    match path.parent() {
        Some(dir) => dir.join(name),
        None => PathBuf::from(name),
    }
}

/// True when `path` names a Zarr store by its extension (`.zarr`, any case; a trailing
/// separator ignored), whether or not it exists.
pub fn is_zarr_name(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
}

/// True when `path` is a directory holding a Zarr v3 array or group (`zarr.json`) or a
/// Zarr v2 array (`.zarray`).
pub fn is_store(path: &Path) -> bool {
    path.join("zarr.json").is_file() || path.join(".zarray").is_file()
}

/// Writes `volume` as a Zarr v3 store at `path` (see the module docs) with the band, inside
/// and sign of `meta` (its geometry comes from `volume`). On an error the partial store is
/// removed and an existing store at `path` is left as it was.
pub fn write_zarr(
    path: &Path,
    volume: &Volume,
    meta: &Lattice,
    opts: ZarrOptions,
) -> Result<ZarrWritten, IoError> {
    volume
        .check()
        .map_err(|e| IoError::invalid_input(path, e.to_string()))?;
    let meta = Lattice::with_geometry_of(meta, volume);
    let writer = ZarrWriter::create(path, &meta, opts)?;
    let result = writer.pending().into_par_iter().try_for_each(|idx| {
        let (first, dims) = writer.chunk_block(idx);
        writer.write_chunk(idx, &block_of(volume, first, dims))
    });
    match result {
        Ok(()) => writer.finish(),
        Err(e) => {
            writer.abandon();
            Err(e)
        }
    }
}

/// The samples of the block of `dims` samples from `first` (x, y, z), x fastest.
fn block_of(volume: &Volume, first: [usize; 3], dims: [usize; 3]) -> Vec<f32> {
    let [nx, ny, _] = volume.dims;
    let mut out = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            let src = first[0] + nx * (first[1] + y + ny * (first[2] + z));
            out.extend_from_slice(&volume.data[src..src + dims[0]]);
        }
    }
    out
}

/// The attributes of a store: the lattice keys and the `isokit` object.
fn attributes(
    meta: &Lattice,
    complete: bool,
    w: Option<ZarrWritten>,
    fingerprint: Option<u64>,
) -> serde_json::Map<String, Value> {
    let mut a = match meta.to_json() {
        Value::Object(m) => m,
        _ => serde_json::Map::new(),
    };
    let mut own = json!({ "complete": complete });
    if let Some(f) = fingerprint {
        own["fingerprint"] = json!(format!("{f:016x}"));
    }
    if let Some(w) = w {
        own["chunks"] = json!(w.chunks);
        own["chunks_written"] = json!(w.written);
    }
    a.insert("isokit".into(), own);
    a
}

/// A store being written chunk by chunk, in `NAME.zarr.partial` until
/// [`ZarrWriter::finish`] renames it: what a sampler that never holds the whole field uses
/// (one block of the lattice per chunk), and what `--resume` continues.
pub struct ZarrWriter {
    path: PathBuf,
    partial: PathBuf,
    group: Group<FilesystemStore>,
    array: Array<FilesystemStore>,
    meta: Lattice,
    chunk: usize,
    fill: f32,
    /// Chunks along z, y, x.
    grid: [usize; 3],
    fingerprint: Option<u64>,
    /// The progress file and the chunks done (with whether a file was written).
    done: Mutex<(File, HashMap<[usize; 3], bool>)>,
}

impl ZarrWriter {
    /// Starts a new store for the lattice `meta` (its dims, origin, spacing, band, inside,
    /// sign) at `path`: a partial store left by an earlier run is removed; `path` itself is
    /// not touched until [`ZarrWriter::finish`].
    pub fn create(path: &Path, meta: &Lattice, opts: ZarrOptions) -> Result<Self, IoError> {
        check_target(path, meta, opts)?;
        let partial = partial_path(path);
        if partial.exists() {
            fs::remove_dir_all(&partial).map_err(|e| IoError::io(&partial, e))?;
        }
        let made = Self::make(path, &partial, meta, opts);
        if made.is_err() {
            let _ = fs::remove_dir_all(&partial);
        }
        made
    }

    /// Continues the partial store a killed run left for `path`, which must have been
    /// started with the same lattice and chunk side; without one, starts afresh
    /// ([`ZarrWriter::create`]). [`ZarrWriter::pending`] then lists only the chunks not done.
    pub fn resume(path: &Path, meta: &Lattice, opts: ZarrOptions) -> Result<Self, IoError> {
        check_target(path, meta, opts)?;
        let partial = partial_path(path);
        if !partial.is_dir() {
            return Self::create(path, meta, opts);
        }
        let o = open(&partial)?;
        let (theirs, _) = lattice_of(&o, &partial)?;
        let chunk = o
            .array
            .chunk_shape(&[0, 0, 0])
            .map_err(|e| zerr(&partial, e))?;
        let same_chunk = chunk.iter().all(|c| c.get() == outer(opts) as u64)
            && subchunks(&o.array) == (opts.shard > 1).then_some([opts.chunk as u64; 3]);
        let print = o
            .attrs
            .get("isokit")
            .and_then(|i| i.get("fingerprint"))
            .cloned();
        let same_source = print == opts.fingerprint.map(|f| Value::String(format!("{f:016x}")));
        if theirs != *meta || !same_chunk || o.at != "/field" || !same_source {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "cannot resume {}: it was started with another lattice, chunk or shard side, or input (its lattice {}); run again without --resume",
                    partial.display(),
                    theirs.to_json()
                ),
            ));
        }
        let group = Group::open(o.array.storage(), "/").map_err(|e| zerr(&partial, e))?;
        let progress = partial.join(PROGRESS);
        let [nx, ny, nz] = meta.dims;
        let c = outer(opts);
        let grid = [nz.div_ceil(c), ny.div_ceil(c), nx.div_ceil(c)];
        let text = fs::read(&progress).unwrap_or_default();
        let done = read_progress(&text, grid.map(|g| g as u64))
            .into_iter()
            .map(|(k, w)| (k.map(|v| v as usize), w))
            .collect();
        // A line a kill cut short is dropped: the file is cut back to its last whole line.
        let whole = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let file = OpenOptions::new()
            .create(true)
            .write(true)
            .truncate(false)
            .open(&progress)
            .and_then(|mut f| {
                f.set_len(whole as u64)?;
                std::io::Seek::seek(&mut f, std::io::SeekFrom::End(0))?;
                Ok(f)
            })
            .map_err(|e| IoError::io(&progress, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            partial,
            group,
            array: o.array,
            meta: meta.clone(),
            chunk: c,
            fill: meta.band.unwrap_or(0.0),
            grid,
            fingerprint: opts.fingerprint,
            done: Mutex::new((file, done)),
        })
    }

    fn make(
        path: &Path,
        partial: &Path,
        meta: &Lattice,
        opts: ZarrOptions,
    ) -> Result<Self, IoError> {
        fs::create_dir_all(partial).map_err(|e| IoError::io(partial, e))?;
        let store = Arc::new(FilesystemStore::new(partial).map_err(|e| zerr(partial, e))?);
        let group = GroupBuilder::new()
            .attributes(attributes(meta, false, None, opts.fingerprint))
            .build(store.clone(), "/")
            .map_err(|e| zerr(partial, e))?;
        group.store_metadata().map_err(|e| zerr(partial, e))?;
        let [nx, ny, nz] = meta.dims;
        // The world coordinates of the samples along each axis, as xarray's coordinates.
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            let n = meta.dims[axis];
            let (o, h) = (f64::from(meta.origin[axis]), f64::from(meta.spacing[axis]));
            let coords: Vec<f64> = (0..n).map(|i| o + h * i as f64).collect();
            let a = ArrayBuilder::new(vec![n as u64], vec![n as u64], data_type::float64(), 0.0f64)
                .dimension_names([name].into())
                .build(store.clone(), &format!("/{name}"))
                .map_err(|e| zerr(partial, e))?;
            a.store_metadata().map_err(|e| zerr(partial, e))?;
            a.store_chunk(&[0], coords).map_err(|e| zerr(partial, e))?;
        }
        let c = outer(opts);
        let fill = meta.band.unwrap_or(0.0);
        let mut builder = ArrayBuilder::new(
            vec![nz as u64, ny as u64, nx as u64],
            vec![c as u64; 3],
            data_type::float32(),
            fill,
        );
        builder.dimension_names(["z", "y", "x"].into());
        if opts.shard > 1 {
            builder.subchunk_shape(vec![opts.chunk as u64; 3]);
        }
        if let Some(level) = opts.gzip {
            let codec = GzipCodec::new(level)
                .map_err(|e| IoError::invalid_input(partial, e.to_string()))?;
            builder.bytes_to_bytes_codecs(vec![Arc::new(codec)]);
        }
        let mut array_attrs = attributes(meta, true, None, None);
        array_attrs.remove("isokit");
        builder.attributes(array_attrs);
        let array = builder
            .build(store, "/field")
            .map_err(|e| zerr(partial, e))?;
        array.store_metadata().map_err(|e| zerr(partial, e))?;
        let progress = partial.join(PROGRESS);
        let file = File::create(&progress).map_err(|e| IoError::io(&progress, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            partial: partial.to_path_buf(),
            group,
            array,
            meta: meta.clone(),
            chunk: c,
            fill,
            grid: [nz.div_ceil(c), ny.div_ceil(c), nx.div_ceil(c)],
            fingerprint: opts.fingerprint,
            done: Mutex::new((file, HashMap::new())),
        })
    }

    /// Chunks along z, y, x.
    pub fn chunk_grid(&self) -> [usize; 3] {
        self.grid
    }

    /// The chunks `(z, y, x)` not written yet, in storage order.
    pub fn pending(&self) -> Vec<[usize; 3]> {
        let g = self.grid;
        let done = self.done.lock().unwrap_or_else(|p| p.into_inner());
        (0..g.iter().product::<usize>())
            .map(|n| [n / (g[1] * g[2]), (n / g[2]) % g[1], n % g[2]])
            .filter(|idx| !done.1.contains_key(idx))
            .collect()
    }

    /// The block of the lattice chunk `idx` (z, y, x) holds: its first sample and its
    /// samples along x, y, z (smaller than the chunk at the lattice's far ends).
    /// Empty (`dims` 0) for a chunk outside the grid.
    pub fn chunk_block(&self, idx: [usize; 3]) -> ([usize; 3], [usize; 3]) {
        let c = self.chunk;
        let first = [idx[2], idx[1], idx[0]].map(|i| i.saturating_mul(c));
        let dims = std::array::from_fn(|a| c.min(self.meta.dims[a].saturating_sub(first[a])));
        (first, dims)
    }

    /// Writes chunk `idx` (z, y, x) from the samples of its block ([`ZarrWriter::chunk_block`],
    /// x fastest). A chunk holding only the fill value is recorded as done but not written.
    /// Safe to call from several threads for different chunks.
    pub fn write_chunk(&self, idx: [usize; 3], block: &[f32]) -> Result<(), IoError> {
        let (_, dims) = self.chunk_block(idx);
        if (0..3).any(|a| idx[a] >= self.grid[a]) || block.len() != dims.iter().product::<usize>() {
            return Err(IoError::invalid_input(
                &self.partial,
                format!(
                    "chunk {idx:?}: {} samples for a block of {dims:?}",
                    block.len()
                ),
            ));
        }
        let fill = self.fill;
        let wrote = !block.iter().all(|v| v.to_bits() == fill.to_bits());
        if wrote {
            let c = self.chunk;
            let mut data = vec![fill; c * c * c];
            for z in 0..dims[2] {
                for y in 0..dims[1] {
                    let src = dims[0] * (y + dims[1] * z);
                    let dst = c * (y + c * z);
                    data[dst..dst + dims[0]].copy_from_slice(&block[src..src + dims[0]]);
                }
            }
            let key = idx.map(|v| v as u64);
            self.array
                .store_chunk(&key, data)
                .map_err(|e| zerr(&self.partial, e))?;
        } else {
            // A file an interrupted run left there would read instead of the fill value.
            self.array
                .erase_chunk(&idx.map(|v| v as u64))
                .map_err(|e| zerr(&self.partial, e))?;
        }
        let mut done = self.done.lock().unwrap_or_else(|p| p.into_inner());
        let progress = self.partial.join(PROGRESS);
        // One write per line, so a kill leaves at most one line cut short (dropped when read).
        let line = format!("{} {} {} {}\n", idx[0], idx[1], idx[2], u8::from(wrote));
        done.0
            .write_all(line.as_bytes())
            .map_err(|e| IoError::io(&progress, e))?;
        done.1.insert(idx, wrote);
        Ok(())
    }

    /// Marks the store complete and renames it over the target (an existing store there is
    /// replaced). Every chunk must have been written.
    pub fn finish(mut self) -> Result<ZarrWritten, IoError> {
        let missing = self.pending().len();
        let (chunks, written) = {
            let done = self.done.lock().unwrap_or_else(|p| p.into_inner());
            let chunks = self.grid.iter().product::<usize>();
            (chunks, done.1.values().filter(|w| **w).count())
        };
        if missing > 0 {
            return Err(IoError::invalid_input(
                &self.path,
                format!("{missing} of {chunks} chunks were not written"),
            ));
        }
        let w = ZarrWritten { chunks, written };
        *self.group.attributes_mut() = attributes(&self.meta, true, Some(w), self.fingerprint);
        self.group
            .store_metadata()
            .map_err(|e| zerr(&self.partial, e))?;
        replace_dir(&self.partial, &self.path)?;
        // The progress list goes once the store is in place (a complete store ignores it).
        let _ = fs::remove_file(self.path.join(PROGRESS));
        Ok(w)
    }

    /// Removes the partial store (after an error: nothing is left behind).
    pub fn abandon(self) {
        let _ = fs::remove_dir_all(&self.partial);
    }
}

/// The side of the unit a writer writes: a shard, or a chunk without sharding.
fn outer(opts: ZarrOptions) -> usize {
    opts.chunk.saturating_mul(opts.shard.max(1))
}

/// The shape `(z, y, x)` of the chunks inside a sharded array's shards (`None` without
/// sharding).
pub(crate) fn subchunks(array: &Array<FilesystemStore>) -> Option<[u64; 3]> {
    let meta = serde_json::to_value(array.metadata()).ok()?;
    let codec = meta.get("codecs")?.as_array()?.first()?;
    if codec.get("name")? != "sharding_indexed" {
        return None;
    }
    let s = codec.get("configuration")?.get("chunk_shape")?.as_array()?;
    match s[..] {
        [ref z, ref y, ref x] => Some([z.as_u64()?, y.as_u64()?, x.as_u64()?]),
        _ => None,
    }
}

/// Refuses a store that cannot be written: bad band, chunk side or gzip level, or a target
/// that exists and is not a Zarr store.
fn check_target(path: &Path, meta: &Lattice, opts: ZarrOptions) -> Result<(), IoError> {
    check_band(meta, path)?;
    isokit_field::checked_len(meta.dims)?;
    if !(1..=MAX_CHUNK).contains(&opts.chunk) {
        return Err(IoError::invalid_input(
            path,
            format!("chunk side {} must be 1 to {MAX_CHUNK}", opts.chunk),
        ));
    }
    if opts.shard == 0
        || opts.chunk.saturating_mul(opts.shard) > MAX_CHUNK
        || (opts.shard > 1 && opts.chunk < 4)
    {
        return Err(IoError::invalid_input(
            path,
            format!(
                "shards of {} chunks of {} samples a side: a shard is at most {MAX_CHUNK} samples a side, its chunks at least 4",
                opts.shard, opts.chunk
            ),
        ));
    }
    let chunks = meta
        .dims
        .iter()
        .map(|&d| d.div_ceil(outer(opts)) as u64)
        .product::<u64>();
    if chunks > MAX_CHUNKS {
        return Err(IoError::invalid_input(
            path,
            format!(
                "{chunks} chunks (or shards) of {}³ samples: at most {MAX_CHUNKS}; use larger chunks or shards",
                outer(opts)
            ),
        ));
    }
    if opts.gzip.is_some_and(|l| l > 9) {
        return Err(IoError::invalid_input(path, "gzip level must be 0 to 9"));
    }
    if path.exists() && !(path.is_dir() && is_store(path)) {
        return Err(IoError::invalid_input(
            path,
            "exists and is not a Zarr store: not replaced (remove it or choose another name)",
        ));
    }
    Ok(())
}

/// Puts the finished store `from` at `to`. A directory cannot be renamed over a non-empty
/// one, so an existing store is first moved aside (to a fresh `NAME.old-PID-NANOS`), then
/// removed; the rename back is tried if the new store cannot be put in place. Between the
/// two renames (microseconds) `to` does not exist: a run killed exactly then leaves the old
/// store beside it and the new one complete in `NAME.partial`. A target that stopped being
/// a store meanwhile is not replaced.
fn replace_dir(from: &Path, to: &Path) -> Result<(), IoError> {
    if !to.exists() {
        return fs::rename(from, to).map_err(|e| IoError::io(to, e));
    }
    if !is_store(to) {
        return Err(IoError::invalid_input(
            to,
            "exists and is not a Zarr store: not replaced (remove it or choose another name)",
        ));
    }
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let old = sibling(to, &format!(".old-{}-{nanos}", std::process::id()));
    fs::rename(to, &old).map_err(|e| IoError::io(to, e))?;
    if let Err(e) = fs::rename(from, to) {
        let _ = fs::rename(&old, to);
        return Err(IoError::io(to, e));
    }
    // The new store is in place; an old copy that cannot be removed is only litter.
    let _ = fs::remove_dir_all(&old);
    Ok(())
}

/// The chunks a progress file lists as done, with whether a file was written: only whole
/// lines of four numbers, the chunk inside `grid` (z, y, x) and the flag 0 or 1 (a line a
/// kill cut short, or anything else, is ignored).
fn read_progress(text: &[u8], grid: [u64; 3]) -> HashMap<[u64; 3], bool> {
    let whole = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let text = String::from_utf8_lossy(&text[..whole]);
    let mut done = HashMap::new();
    for line in text.lines() {
        let v: Vec<Option<u64>> = line.split(' ').map(|t| t.parse().ok()).collect();
        if let [Some(z), Some(y), Some(x), Some(w)] = v[..]
            && z < grid[0]
            && y < grid[1]
            && x < grid[2]
            && w <= 1
        {
            done.insert([z, y, x], w == 1);
        }
    }
    done
}

/// An open store: its samples' array, the attributes that describe it (the group's where
/// the array is in a group, else the array's) and the array's path in the store.
pub(crate) struct Opened {
    pub(crate) array: Array<FilesystemStore>,
    attrs: serde_json::Map<String, Value>,
    at: String,
}

fn open(path: &Path) -> Result<Opened, IoError> {
    if !path.is_dir() {
        return Err(IoError::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "no such Zarr store (a directory)",
            ),
        ));
    }
    if !is_store(path) {
        return Err(IoError::malformed(
            path,
            "not a Zarr store: no zarr.json or .zarray in it",
        ));
    }
    let store = Arc::new(FilesystemStore::new(path).map_err(|e| zerr(path, e))?);
    let opened = match Array::open(store.clone(), "/") {
        Ok(array) => Opened {
            attrs: array.attributes().clone(),
            array,
            at: "/".into(),
        },
        Err(_) => {
            let group = Group::open(store.clone(), "/").map_err(|e| {
                zerr(
                    path,
                    format!("the root is neither an array nor a group: {e}"),
                )
            })?;
            let mut paths = group
                .child_array_paths()
                .map_err(|e| zerr(path, e))?
                .into_iter()
                .map(|p| p.as_str().to_owned())
                .collect::<Vec<_>>();
            paths.sort();
            let mut candidates = Vec::new();
            for p in &paths {
                // An array that cannot be opened (an unknown codec, say) stays a
                // candidate, so that its error is what is reported when it is the one.
                match Array::open(store.clone(), p) {
                    Ok(a) if a.dimensionality() == 3 => candidates.push((p.clone(), Ok(a))),
                    Ok(_) => {}
                    Err(e) => candidates.push((p.clone(), Err(e))),
                }
            }
            let pick = candidates
                .iter()
                .position(|(p, _)| p == "/field")
                .or((candidates.len() == 1).then_some(0));
            let Some(i) = pick else {
                return Err(IoError::malformed(
                    path,
                    format!(
                        "the group holds no array `field` and not exactly one 3-D array (arrays: {})",
                        if paths.is_empty() {
                            "none".into()
                        } else {
                            paths.join(", ")
                        }
                    ),
                ));
            };
            let (at, array) = candidates.swap_remove(i);
            let array = array.map_err(|e| zerr(path, format!("{at}: {e}")))?;
            let mut attrs = array.attributes().clone();
            attrs.extend(group.attributes().clone());
            Opened { array, attrs, at }
        }
    };
    if opened.array.dimensionality() != 3 {
        return Err(IoError::unsupported(
            path,
            format!(
                "{} dimensions: volumes have 3 (z, y, x)",
                opened.array.dimensionality()
            ),
        ));
    }
    Ok(opened)
}

/// The lattice of an open array: its attributes, or origin 0 and spacing 1 when it has none
/// (then `false`).
fn lattice_of(o: &Opened, path: &Path) -> Result<(Lattice, bool), IoError> {
    let s = o.array.shape();
    let too_big = || IoError::unsupported(path, format!("shape {s:?} is too large"));
    let dims = [
        usize::try_from(s[2]).map_err(|_| too_big())?,
        usize::try_from(s[1]).map_err(|_| too_big())?,
        usize::try_from(s[0]).map_err(|_| too_big())?,
    ];
    let attrs = &o.attrs;
    if attrs.contains_key("origin") && attrs.contains_key("spacing") {
        let mut obj = attrs.clone();
        obj.entry("dims").or_insert_with(|| json!(dims));
        let lattice = Lattice::from_json(&Value::Object(obj).to_string(), &path.join("zarr.json"))?;
        if lattice.dims != dims {
            return Err(IoError::malformed(
                path,
                format!(
                    "attribute dims {:?} do not match the array's shape {s:?} (z, y, x)",
                    lattice.dims
                ),
            ));
        }
        return Ok((lattice, true));
    }
    let v = Volume {
        dims,
        origin: Vec3::ZERO,
        spacing: Vec3::ONE,
        data: Vec::new(),
    };
    Ok((Lattice::of(&v), false))
}

fn is_complete(o: &Opened) -> bool {
    o.attrs
        .get("isokit")
        .and_then(|o| o.get("complete"))
        .and_then(Value::as_bool)
        .unwrap_or(true)
}

/// The chunk shape and the chunk grid `(z, y, x)` of an open array: a regular grid (other
/// grids are refused), chunks of at most `MAX_CHUNK³` samples, at most [`MAX_CHUNKS`]
/// chunks, and a lattice within [`isokit_field::MAX_SAMPLES`].
fn chunk_layout(o: &Opened, path: &Path) -> Result<([u64; 3], [u64; 3]), IoError> {
    let meta = serde_json::to_value(o.array.metadata()).unwrap_or(Value::Null);
    if let Some(name) = meta.get("chunk_grid").and_then(|g| g.get("name")) {
        if name != "regular" {
            return Err(IoError::unsupported(
                path,
                format!("chunk grid {name}: only regular chunk grids are read"),
            ));
        }
    }
    let s = o.array.shape();
    let too_big = || IoError::unsupported(path, format!("shape {s:?} is too large"));
    let dims = [s[2], s[1], s[0]].map(|v| usize::try_from(v).unwrap_or(usize::MAX));
    isokit_field::checked_len(dims).map_err(|_| too_big())?;
    let shape = o.array.chunk_shape(&[0, 0, 0]).map_err(|e| zerr(path, e))?;
    let c: Vec<u64> = shape.iter().map(|v| v.get()).collect();
    // A chunk (a shard, when sharded) of at most MAX_CHUNK³ samples; the chunks inside a
    // shard at least 4 samples a side, dividing it.
    let volume = |s: &[u64]| s.iter().try_fold(1u64, |a, &v| a.checked_mul(v));
    let limit = (MAX_CHUNK as u64).pow(3);
    if c.len() != 3 || volume(&c).is_none_or(|p| p > limit) {
        return Err(IoError::unsupported(
            path,
            format!("chunks of {c:?} samples: at most {limit} samples a chunk are read"),
        ));
    }
    if let Some(s) = subchunks(&o.array)
        && (0..3).any(|a| s[a] < 4.min(c[a]) || s[a] == 0 || !c[a].is_multiple_of(s[a]))
    {
        return Err(IoError::unsupported(
            path,
            format!(
                "shards of {c:?} samples in chunks of {s:?}: the chunks must divide the shard and be 4 or more samples a side"
            ),
        ));
    }
    let g = o.array.chunk_grid_shape();
    let grid = [g[0], g[1], g[2]];
    let count = grid.iter().try_fold(1u64, |a, &v| a.checked_mul(v));
    if count.is_none_or(|n| n > MAX_CHUNKS) {
        return Err(IoError::unsupported(
            path,
            format!("a grid of {grid:?} chunks: at most {MAX_CHUNKS} chunks are read"),
        ));
    }
    Ok(([c[0], c[1], c[2]], grid))
}

/// The array's fill value as f32 (NaN when it is not a float32 or float64 value).
fn fill_of(array: &Array<FilesystemStore>) -> f32 {
    let b = array.fill_value().as_ne_bytes();
    match b.len() {
        4 => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
        8 => f64::from_ne_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]) as f32,
        _ => f32::NAN,
    }
}

/// Describes the store at `path` (or its partial store) without reading its samples.
pub fn zarr_info(path: &Path) -> Result<ZarrInfo, IoError> {
    let o = open(path)?;
    let (lattice, has_lattice) = lattice_of(&o, path)?;
    let (chunk_shape, grid) = chunk_layout(&o, path)?;
    let array = &o.array;
    let chunks = grid.iter().product::<u64>();
    let complete = is_complete(&o);
    let done = if complete {
        HashMap::new()
    } else {
        read_progress(&fs::read(path.join(PROGRESS)).unwrap_or_default(), grid)
    };
    let (mut present, mut missing_chunks, mut missing) = (0, 0, Vec::new());
    // Chunk files are looked up over the grid (at most MAX_CHUNKS); 20 missing ones named.
    for z in 0..grid[0] {
        for y in 0..grid[1] {
            for x in 0..grid[2] {
                let key = array.chunk_key(&[z, y, x]);
                if path.join(key.as_str()).is_file() {
                    present += 1;
                }
                if !complete && !done.contains_key(&[z, y, x]) {
                    missing_chunks += 1;
                    if missing.len() < 20 {
                        missing.push([z, y, x]);
                    }
                }
            }
        }
    }
    let meta = serde_json::to_value(array.metadata()).unwrap_or(Value::Null);
    let fill = Some(f64::from(fill_of(array))).filter(|f| !f.is_nan());
    let data_type = match meta.get("data_type") {
        Some(Value::String(s)) => s.clone(),
        _ => array.data_type().to_string(),
    };
    Ok(ZarrInfo {
        lattice,
        has_lattice,
        array: o.at.clone(),
        subchunk_shape: subchunks(array),
        data_type,
        chunk_shape,
        chunks,
        present,
        fill,
        complete,
        missing_chunks,
        missing,
    })
}

/// Reads the array of the store at `path` as a volume with its lattice (origin 0 and spacing
/// 1 when its attributes carry none; the returned flag says so). `float32` and `float64`
/// arrays are read; the size is checked against the memory budget before anything is
/// allocated; an incomplete store (its writer did not finish) is refused.
pub fn read_zarr(path: &Path) -> Result<(Volume, Lattice, bool), IoError> {
    let r = open_readable(path)?;
    let (array, lattice) = (&r.opened.array, &r.lattice);
    let dims = lattice.dims;
    let n = isokit_field::checked_len(dims)?;
    let f64s = r.f64s;
    isokit_field::memory::check(
        &format!(
            "the {} x {} x {} samples of the store",
            dims[0], dims[1], dims[2]
        ),
        n as u128 * if f64s { 12 } else { 4 },
        "read a smaller store, or raise the budget",
    )?;
    let all = array.subset_all();
    let data: Vec<f32> = if f64s {
        let d: Vec<f64> = array
            .retrieve_array_subset(&all)
            .map_err(|e| zerr(path, e))?;
        d.into_iter().map(|v| v as f32).collect()
    } else {
        array
            .retrieve_array_subset(&all)
            .map_err(|e| zerr(path, e))?
    };
    let volume = Volume {
        dims,
        origin: Vec3::from(lattice.origin),
        spacing: Vec3::from(lattice.spacing),
        data,
    };
    Ok((volume, r.lattice, r.has_lattice))
}

/// An open store whose samples can be read: complete, float32 or float64, its lattice
/// valid.
pub(crate) struct Readable {
    pub(crate) opened: Opened,
    pub(crate) lattice: Lattice,
    pub(crate) has_lattice: bool,
    pub(crate) f64s: bool,
    pub(crate) fill: f32,
}

pub(crate) fn open_readable(path: &Path) -> Result<Readable, IoError> {
    let opened = open(path)?;
    let (lattice, has_lattice) = lattice_of(&opened, path)?;
    if !is_complete(&opened) {
        return Err(IoError::malformed(
            path,
            "the store is incomplete (its writer did not finish): `isokit info` lists the missing chunks",
        ));
    }
    let dt = opened.array.data_type();
    let f64s = *dt == data_type::float64();
    if !f64s && *dt != data_type::float32() {
        return Err(IoError::unsupported(
            path,
            format!("data type {dt}: float32 and float64 arrays are read"),
        ));
    }
    let probe = Volume {
        dims: [1; 3],
        origin: Vec3::from(lattice.origin),
        spacing: Vec3::from(lattice.spacing),
        data: vec![0.0],
    };
    probe
        .check()
        .map_err(|e| IoError::malformed(path, format!("the lattice is invalid: {e}")))?;
    isokit_field::checked_len(lattice.dims)?;
    chunk_layout(&opened, path)?;
    let fill = fill_of(&opened.array);
    Ok(Readable {
        opened,
        lattice,
        has_lattice,
        f64s,
        fill,
    })
}
