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

/// The largest chunk side accepted (512³ f32 = 512 MiB per chunk in memory).
pub const MAX_CHUNK: usize = 512;

/// The file in a partial store that lists the chunks done so far, one `z y x w` per line
/// (`w` 1 where a chunk file was written, 0 where the chunk holds only the fill value).
const PROGRESS: &str = ".isokit-progress";

/// How [`write_zarr`] lays out a store.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ZarrOptions {
    /// Chunk side in samples (1 to [`MAX_CHUNK`]).
    pub chunk: usize,
    /// Gzip level 0–9 (1, the fast level, by default; `None`: no compression).
    pub gzip: Option<u32>,
}

impl Default for ZarrOptions {
    fn default() -> Self {
        Self {
            chunk: DEFAULT_CHUNK,
            gzip: Some(1),
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
    /// For an incomplete store: the chunks `(z, y, x)` its writer had not finished.
    pub missing: Vec<[u64; 3]>,
}

fn zerr(path: &Path, e: impl std::fmt::Display) -> IoError {
    IoError::malformed(path, e.to_string())
}

/// `NAME.zarr` → `NAME.zarr.partial`, where a write goes before it is renamed.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".partial");
    PathBuf::from(s)
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
) -> serde_json::Map<String, Value> {
    let mut a = match meta.to_json() {
        Value::Object(m) => m,
        _ => serde_json::Map::new(),
    };
    let mut own = json!({ "complete": complete });
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
        let same_chunk = chunk.iter().all(|c| c.get() == opts.chunk as u64);
        if theirs != *meta || !same_chunk || o.at != "/field" {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "cannot resume {}: it was started with another lattice or chunk side (its lattice {}); run again without --resume",
                    partial.display(),
                    theirs.to_json()
                ),
            ));
        }
        let group = Group::open(o.array.storage(), "/").map_err(|e| zerr(&partial, e))?;
        let progress = partial.join(PROGRESS);
        let mut done = HashMap::new();
        if let Ok(text) = fs::read_to_string(&progress) {
            for line in text.lines() {
                let v: Vec<usize> = line.split(' ').filter_map(|t| t.parse().ok()).collect();
                if let [z, y, x, w] = v[..] {
                    done.insert([z, y, x], w == 1);
                }
            }
        }
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&progress)
            .map_err(|e| IoError::io(&progress, e))?;
        let [nx, ny, nz] = meta.dims;
        let c = opts.chunk;
        Ok(Self {
            path: path.to_path_buf(),
            partial,
            group,
            array: o.array,
            meta: meta.clone(),
            chunk: c,
            fill: meta.band.unwrap_or(0.0),
            grid: [nz.div_ceil(c), ny.div_ceil(c), nx.div_ceil(c)],
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
            .attributes(attributes(meta, false, None))
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
        let c = opts.chunk;
        let fill = meta.band.unwrap_or(0.0);
        let mut builder = ArrayBuilder::new(
            vec![nz as u64, ny as u64, nx as u64],
            vec![c as u64; 3],
            data_type::float32(),
            fill,
        );
        builder.dimension_names(["z", "y", "x"].into());
        if let Some(level) = opts.gzip {
            let codec = GzipCodec::new(level)
                .map_err(|e| IoError::invalid_input(partial, e.to_string()))?;
            builder.bytes_to_bytes_codecs(vec![Arc::new(codec)]);
        }
        let mut array_attrs = attributes(meta, true, None);
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
    pub fn chunk_block(&self, idx: [usize; 3]) -> ([usize; 3], [usize; 3]) {
        let c = self.chunk;
        let first = [idx[2] * c, idx[1] * c, idx[0] * c];
        let dims = std::array::from_fn(|a| c.min(self.meta.dims[a] - first[a]));
        (first, dims)
    }

    /// Writes chunk `idx` (z, y, x) from the samples of its block ([`ZarrWriter::chunk_block`],
    /// x fastest). A chunk holding only the fill value is recorded as done but not written.
    /// Safe to call from several threads for different chunks.
    pub fn write_chunk(&self, idx: [usize; 3], block: &[f32]) -> Result<(), IoError> {
        let (_, dims) = self.chunk_block(idx);
        if block.len() != dims.iter().product::<usize>() || (0..3).any(|a| idx[a] >= self.grid[a]) {
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
        }
        let mut done = self.done.lock().unwrap_or_else(|p| p.into_inner());
        let progress = self.partial.join(PROGRESS);
        writeln!(
            done.0,
            "{} {} {} {}",
            idx[0],
            idx[1],
            idx[2],
            u8::from(wrote)
        )
        .map_err(|e| IoError::io(&progress, e))?;
        done.1.insert(idx, wrote);
        Ok(())
    }

    /// Marks the store complete and renames it over the target (an existing store there is
    /// replaced). Every chunk must have been written.
    pub fn finish(mut self) -> Result<ZarrWritten, IoError> {
        let (chunks, written, missing) = {
            let done = self.done.lock().unwrap_or_else(|p| p.into_inner());
            let chunks = self.grid.iter().product::<usize>();
            (
                chunks,
                done.1.values().filter(|w| **w).count(),
                chunks - done.1.len(),
            )
        };
        if missing > 0 {
            return Err(IoError::invalid_input(
                &self.path,
                format!("{missing} of {chunks} chunks were not written"),
            ));
        }
        let w = ZarrWritten { chunks, written };
        *self.group.attributes_mut() = attributes(&self.meta, true, Some(w));
        self.group
            .store_metadata()
            .map_err(|e| zerr(&self.partial, e))?;
        let progress = self.partial.join(PROGRESS);
        fs::remove_file(&progress).map_err(|e| IoError::io(&progress, e))?;
        replace_dir(&self.partial, &self.path)?;
        Ok(w)
    }

    /// Removes the partial store (after an error: nothing is left behind).
    pub fn abandon(self) {
        let _ = fs::remove_dir_all(&self.partial);
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

/// Puts the finished store `from` at `to`: an existing store there is moved aside first and
/// removed after the rename, so `to` is always either the old store or the new one.
fn replace_dir(from: &Path, to: &Path) -> Result<(), IoError> {
    if !to.exists() {
        return fs::rename(from, to).map_err(|e| IoError::io(to, e));
    }
    let mut old = to.as_os_str().to_owned();
    old.push(format!(".old-{}", std::process::id()));
    let old = PathBuf::from(old);
    fs::rename(to, &old).map_err(|e| IoError::io(to, e))?;
    if let Err(e) = fs::rename(from, to) {
        let _ = fs::rename(&old, to);
        return Err(IoError::io(to, e));
    }
    fs::remove_dir_all(&old).map_err(|e| IoError::io(&old, e))
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
                // Arrays that cannot be opened (an unknown codec, say) are reported only
                // when nothing else is found.
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

/// Describes the store at `path` (or its partial store) without reading its samples.
pub fn zarr_info(path: &Path) -> Result<ZarrInfo, IoError> {
    let o = open(path)?;
    let (lattice, has_lattice) = lattice_of(&o, path)?;
    let array = &o.array;
    let g = array.chunk_grid_shape();
    let grid = [g[0], g[1], g[2]];
    let chunks = grid.iter().product::<u64>();
    let chunk_shape = array
        .chunk_shape(&[0, 0, 0])
        .map_err(|e| zerr(path, e))?
        .iter()
        .map(|v| v.get())
        .collect::<Vec<_>>();
    let complete = is_complete(&o);
    let mut present = 0;
    let mut done = std::collections::HashSet::new();
    if !complete {
        if let Ok(text) = fs::read_to_string(path.join(PROGRESS)) {
            for line in text.lines() {
                let v: Vec<u64> = line.split(' ').filter_map(|t| t.parse().ok()).collect();
                if let [z, y, x, _] = v[..] {
                    done.insert([z, y, x]);
                }
            }
        }
    }
    let mut missing = Vec::new();
    // Chunk files are counted from the grid (at most a few million chunks for any volume
    // this crate can hold).
    for z in 0..grid[0] {
        for y in 0..grid[1] {
            for x in 0..grid[2] {
                let key = array.chunk_key(&[z, y, x]);
                if path.join(key.as_str()).is_file() {
                    present += 1;
                }
                if !complete && !done.contains(&[z, y, x]) {
                    missing.push([z, y, x]);
                }
            }
        }
    }
    let meta = serde_json::to_value(array.metadata()).unwrap_or(Value::Null);
    let fill = meta.get("fill_value").and_then(Value::as_f64);
    let data_type = match meta.get("data_type") {
        Some(Value::String(s)) => s.clone(),
        _ => array.data_type().to_string(),
    };
    Ok(ZarrInfo {
        lattice,
        has_lattice,
        array: o.at.clone(),
        data_type,
        chunk_shape: [chunk_shape[0], chunk_shape[1], chunk_shape[2]],
        chunks,
        present,
        fill,
        complete,
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
    let fill = serde_json::to_value(opened.array.metadata())
        .ok()
        .and_then(|m| m.get("fill_value").and_then(Value::as_f64))
        .map_or(f32::NAN, |v| v as f32);
    Ok(Readable {
        opened,
        lattice,
        has_lattice,
        f64s,
        fill,
    })
}
