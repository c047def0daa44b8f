//! `isokit scene SCENE -o field.zarr [--chunk N] [--resume]`: the band sampled one chunk of
//! the store at a time, so the whole field is never held in memory, and a killed run's
//! partial store finished by `--resume`.

use anyhow::Result;
use isokit_field::Job;
use isokit_io::lattice::Lattice;
use isokit_io::zarr::{ZarrOptions, ZarrWriter};
use isokit_scene::{Block, SampleOptions, SampleStats, Scene, SourceStats};
use std::path::Path;
use std::time::Instant;

/// Samples `scene` with `opts` into the store at `path`, chunk by chunk (each chunk one
/// block of the lattice, equal bit for bit to that block of a whole sampling), and returns
/// the statistics of the whole lattice. With `resume`, a partial store of the same lattice
/// and chunk side left by a killed run is continued: only its missing chunks are sampled.
pub fn write(
    scene: &Scene,
    opts: &SampleOptions,
    out: &super::volume_args::VolumeOut,
    path: &Path,
    resume: bool,
    job: &Job,
) -> Result<SampleStats> {
    let t0 = Instant::now();
    let plan = scene.plan(opts)?;
    let meta = Lattice {
        origin: plan.origin.to_array(),
        spacing: [plan.spacing; 3],
        dims: plan.dims,
        band: Some(plan.band),
        inside: isokit_field::curvature::Inside::Below,
        sign: None,
    };
    // What the samples come from: the scene's content (files by path, size and time) and
    // the brick size (the lattice itself is compared on its own).
    let mut h = std::collections::hash_map::DefaultHasher::new();
    std::hash::Hash::hash(
        &(scene.hashes().first().map(|n| n.hash), plan.brick),
        &mut h,
    );
    let zopts = ZarrOptions {
        chunk: out.chunk,
        gzip: out.compression.gzip_level(),
        shard: out.shard,
        fingerprint: Some(std::hash::Hasher::finish(&h)),
    };
    let partial = isokit_io::zarr::partial_path(path);
    let writer = if resume {
        ZarrWriter::resume(path, &meta, zopts)?
    } else {
        if partial.is_dir() {
            eprintln!(
                "note: starting afresh: removing {} that an earlier run left (--resume continues one)",
                partial.display()
            );
        }
        ZarrWriter::create(path, &meta, zopts)?
    };
    let pending = writer.pending();
    let total = writer.chunk_grid().iter().product::<usize>();
    if resume && pending.len() < total {
        eprintln!(
            "resuming {}: {} of {total} chunks left to sample",
            partial.display(),
            pending.len()
        );
    }
    let counter = job.counter("sampling chunks", pending.len() as u64);
    let mut sum = Sum::default();
    let result = pending.iter().try_for_each(|&idx| -> Result<()> {
        job.check()?;
        let (first, dims) = writer.chunk_block(idx);
        let block_opts = SampleOptions {
            block: Some(Block { first, dims }),
            ..*opts
        };
        let (grid, stats) = scene.sample_grid_job(&block_opts, &Job::default())?;
        writer.write_chunk(idx, grid.data())?;
        sum.add(&stats);
        counter.advance(1);
        Ok(())
    });
    if let Err(e) = result {
        // Nothing is left behind by a failed run (a killed one leaves the partial store).
        writer.abandon();
        return Err(e);
    }
    writer.finish()?;
    let dense = plan.dims.iter().map(|&d| d as f64).product::<f64>();
    Ok(SampleStats {
        dims: plan.dims,
        origin: plan.origin.to_array(),
        spacing: plan.spacing,
        band: plan.band,
        brick: plan.brick,
        dense_fraction: sum.evaluated / dense.max(1.0),
        dense_samples: dense as u64,
        bricks_kept: sum.kept,
        bricks_total: sum.total,
        bricks_reused: 0,
        seconds: t0.elapsed().as_secs_f64(),
        sources: sum
            .sources
            .into_iter()
            .map(|mut s| {
                s.query_fraction = s.queries as f64 / dense.max(1.0);
                s
            })
            .collect(),
        prism_bands: sum.prism_bands,
    })
}

/// The statistics of the blocks sampled so far.
#[derive(Default)]
struct Sum {
    evaluated: f64,
    kept: usize,
    total: usize,
    sources: Vec<SourceStats>,
    prism_bands: Vec<(String, &'static str)>,
}

impl Sum {
    fn add(&mut self, s: &SampleStats) {
        self.evaluated += s.dense_fraction * s.dense_samples as f64;
        self.kept += s.bricks_kept;
        self.total += s.bricks_total;
        if self.sources.is_empty() {
            self.sources = s.sources.clone();
            self.prism_bands = s.prism_bands.clone();
        } else {
            for (mine, theirs) in self.sources.iter_mut().zip(&s.sources) {
                mine.queries += theirs.queries;
                mine.memo_hits += theirs.memo_hits;
            }
        }
    }
}
