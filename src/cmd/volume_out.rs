//! How the sampling commands write their volumes: NRRD (compressed by `--compression`), NPY
//! with its lattice sidecar, or a Zarr v3 store in `--chunk`³ chunks.

use anyhow::{Result, bail};
use isokit_io::lattice::Lattice;
use isokit_io::zarr::{self, ZarrOptions};
use isokit_io::{NrrdEncoding, Volume, write_volume_with};
use std::path::Path;

/// The output names a sampling command accepts for volumes.
pub const VOLUME_OUTPUTS: [&str; 3] = [".nrrd", ".npy", ".zarr"];

/// How a volume is compressed where its format compresses (NRRD, Zarr).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Compression {
    /// Raw samples (NRRD `encoding: raw`; Zarr without a compressor).
    None,
    /// Gzip at the fast level (1): close to the default level's size in a fraction of its
    /// time.
    #[default]
    Fast,
    /// Gzip at the best level (9): a little smaller, several times slower.
    Best,
}

impl Compression {
    /// The gzip level, `None` for raw samples.
    pub fn gzip_level(self) -> Option<u32> {
        match self {
            Compression::None => None,
            Compression::Fast => Some(1),
            Compression::Best => Some(9),
        }
    }
}

/// How an output volume is written.
#[derive(clap::Args, Debug, Clone)]
pub struct VolumeOut {
    /// Compression of .nrrd and .zarr output (.npy is never compressed).
    #[arg(long, value_enum, default_value_t = Compression::Fast)]
    pub compression: Compression,
    /// Chunk side of .zarr output in samples (64: 8³ bricks of 8, 1 MiB of float32 a
    /// chunk).
    #[arg(long, default_value_t = zarr::DEFAULT_CHUNK, value_name = "N")]
    pub chunk: usize,
    /// .zarr output: group N³ chunks into one file (a shard; Zarr's sharding codec), for
    /// stores of very many chunks; 1 writes a file per chunk.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub shard: usize,
}

impl Default for VolumeOut {
    fn default() -> Self {
        Self {
            compression: Compression::Fast,
            chunk: zarr::DEFAULT_CHUNK,
            shard: 1,
        }
    }
}

impl VolumeOut {
    /// Refuses, before any work, what [`VolumeOut::write`] would refuse at the end: a chunk
    /// side out of range, or a .zarr output naming something that is not a Zarr store.
    pub fn check(&self, path: &Path) -> Result<()> {
        if !is_zarr(path) {
            return Ok(());
        }
        if !(1..=zarr::MAX_CHUNK).contains(&self.chunk) {
            bail!("--chunk {} must be 1 to {}", self.chunk, zarr::MAX_CHUNK);
        }
        if self.shard == 0 || self.chunk.saturating_mul(self.shard) > zarr::MAX_CHUNK {
            bail!(
                "--shard {} with --chunk {}: a shard is 1 or more chunks and at most {} samples a side",
                self.shard,
                self.chunk,
                zarr::MAX_CHUNK
            );
        }
        if path.exists() && !zarr::is_store(path) {
            bail!(
                "{}: exists and is not a Zarr store: not replaced (remove it or choose another name)",
                path.display()
            );
        }
        Ok(())
    }

    /// Writes `volume` to `path` with its lattice (NPY: the sidecar; Zarr: attributes) and
    /// the meaning of its samples: `band` (exact within it, ±band beyond) and the sign
    /// method of a mesh.
    pub fn write(
        &self,
        path: &Path,
        volume: &Volume,
        band: Option<f32>,
        sign: Option<&str>,
    ) -> Result<()> {
        let meta = Lattice {
            band,
            sign: sign.map(str::to_owned),
            ..Lattice::of(volume)
        };
        self.write_meta(path, volume, &meta)
    }

    /// Writes `volume` with the band, inside and sign of `meta`.
    pub fn write_meta(&self, path: &Path, volume: &Volume, meta: &Lattice) -> Result<()> {
        if is_zarr(path) {
            self.check(path)?;
            let opts = ZarrOptions {
                chunk: self.chunk,
                gzip: self.compression.gzip_level(),
                shard: self.shard,
                fingerprint: None,
            };
            zarr::write_zarr(path, volume, meta, opts)?;
            return Ok(());
        }
        let enc = match self.compression {
            Compression::None => NrrdEncoding::Raw,
            Compression::Fast => NrrdEncoding::Gzip,
            Compression::Best => NrrdEncoding::GzipBest,
        };
        Ok(write_volume_with(path, volume, meta, enc)?)
    }
}

/// True when `path` names a Zarr store (`.zarr`, any case).
pub fn is_zarr(path: &Path) -> bool {
    zarr::is_zarr_name(path)
}
