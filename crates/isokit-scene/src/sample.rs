//! Sampling a scene to a narrow band, lazily: only the bricks that can hold the band are
//! evaluated, and the tree is evaluated clamped to just above the band so bounding boxes
//! prune subtrees and meshes answer band-limited queries.

use crate::{Scene, SceneError};
use glam::Vec3;
use isokit_field::{Aabb, BrickGrid, Field, Grid, Job};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Knobs of [`Scene::sample`]; [`SampleOptions::from_scene`] reads them from the scene's
/// `sampling` table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleOptions {
    /// Samples along the longest side of the domain.
    pub resolution: usize,
    /// Band half-width in world units (default 4 voxels).
    pub band: Option<f32>,
    /// Brick size (a power of two, 2 to [`BrickGrid::MAX_BRICK`]).
    pub brick: usize,
    /// Apron samples stored around each brick (0 for meshing, 1 or more for filtering).
    pub apron: usize,
    /// The domain (default the scene's).
    pub bounds: Option<Aabb>,
    /// An exact lattice `(dims, origin, spacing)` to sample on instead of one covering the
    /// domain (another volume's, so that the two combine sample for sample); `resolution`
    /// and `bounds` are then not used.
    pub lattice: Option<([usize; 3], Vec3, f32)>,
    /// Sample only this block of the lattice (its samples equal those of the whole
    /// sampling bit for bit once clamped to `±band`, as a volume file holds them): what a
    /// distributed sampling computes per chunk. Not with [`Scene::sample_dense`].
    pub block: Option<Block>,
}

/// A block of a sampling's lattice: `dims` samples from index `first` (x, y, z).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Index of the block's first sample in the lattice.
    pub first: [usize; 3],
    /// Samples along x, y, z.
    pub dims: [usize; 3],
}

impl Default for SampleOptions {
    fn default() -> Self {
        Self {
            resolution: 128,
            band: None,
            brick: 4,
            apron: 0,
            bounds: None,
            lattice: None,
            block: None,
        }
    }
}

impl SampleOptions {
    /// The scene's `sampling` table over the defaults.
    pub fn from_scene(scene: &Scene) -> Self {
        let s = &scene.settings().sampling;
        let d = Self::default();
        Self {
            resolution: s.resolution.unwrap_or(d.resolution),
            band: s.band,
            brick: s.brick.unwrap_or(d.brick),
            ..d
        }
    }
}

/// What one source cost in one sampling.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SourceStats {
    /// Node path.
    pub node: String,
    /// Node kind.
    pub kind: &'static str,
    /// Evaluations of the source.
    pub queries: u64,
    /// `queries` over the dense grid's sample count (a dense evaluation queries every
    /// source once per sample).
    pub query_fraction: f64,
    /// Values read back from the source's lattice memo instead of evaluated (live editing,
    /// [`crate::SourceCache::memoizing`]); absent when 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub memo_hits: u64,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// What one sampling computed (the `--stats` object of `isokit scene`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SampleStats {
    /// Share of the dense grid's samples that were evaluated.
    pub dense_fraction: f64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Lattice dimensions.
    pub dims: [usize; 3],
    /// Position of sample (0, 0, 0).
    pub origin: [f32; 3],
    /// Sample spacing.
    pub spacing: f32,
    /// Band half-width.
    pub band: f32,
    /// Brick size.
    pub brick: usize,
    /// Samples of the dense grid.
    pub dense_samples: u64,
    /// Bricks kept.
    pub bricks_kept: usize,
    /// Bricks of the lattice.
    pub bricks_total: usize,
    /// Kept bricks taken unchanged from the scene's previous sampling
    /// ([`Scene::sample_again`]), none of their samples evaluated; 0 otherwise.
    /// `bricks_kept` counts them too.
    pub bricks_reused: usize,
    /// Per source.
    pub sources: Vec<SourceStats>,
    /// Meshes given a prism band, and where it was computed (`cpu` or `gpu`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub prism_bands: Vec<(String, &'static str)>,
}

impl SampleStats {
    /// As a JSON object.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_default()
    }
}

/// The lattice one sampling uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    /// Dimensions.
    pub dims: [usize; 3],
    /// Position of sample (0, 0, 0).
    pub origin: Vec3,
    /// Spacing.
    pub spacing: f32,
    /// Band half-width.
    pub band: f32,
    /// Brick size.
    pub brick: usize,
}

impl Scene {
    /// Samples the band lazily into a [`BrickGrid`] (see the module docs) and reports what
    /// it cost.
    pub fn sample(&self, opts: &SampleOptions) -> Result<(BrickGrid, SampleStats), SceneError> {
        self.sample_job(opts, &Job::default())
    }

    /// [`Scene::sample`] with progress reports and cancellation.
    pub fn sample_job(
        &self,
        opts: &SampleOptions,
        job: &Job,
    ) -> Result<(BrickGrid, SampleStats), SceneError> {
        let s = self.sample_kept(opts, job)?;
        Ok((s.grid, s.stats))
    }

    /// [`Scene::sample_job`] made dense: the band clamped to `±band` on the whole lattice
    /// ([`band_to_grid`]), what a volume file of the scene holds. The dense grid is checked
    /// against the memory budget ([`isokit_field::memory`]) before anything is sampled.
    pub fn sample_grid_job(
        &self,
        opts: &SampleOptions,
        job: &Job,
    ) -> Result<(Grid, SampleStats), SceneError> {
        let dims = self.sampled_dims(opts)?;
        let [nx, ny, nz] = dims;
        isokit_field::memory::check(
            &format!("the dense output grid of {nx} x {ny} x {nz} samples"),
            isokit_field::memory::grid_bytes(dims),
            "lower the resolution (sampling.resolution or --res), or write a mesh (.obj, .ply, .stl, .off) instead, or raise the budget",
        )
        .map_err(|e| SceneError::new(self.name(), "sampling", e.to_string()))?;
        let (bricks, stats) = self.sample_job(opts, job)?;
        let grid = band_to_grid(&bricks, stats.band)
            .map_err(|e| SceneError::new(self.name(), "sampling", e.to_string()))?;
        Ok((grid, stats))
    }

    /// Samples every node of the same lattice [`Scene::sample`] uses, in full (no
    /// clamping, no pruning): the baseline lazy sampling is measured against.
    pub fn sample_dense(&self, opts: &SampleOptions) -> Result<(Grid, SampleStats), SceneError> {
        if opts.block.is_some() {
            return Err(SceneError::new(
                self.name(),
                "sampling",
                "a dense sampling covers the whole lattice: sample blocks lazily",
            ));
        }
        let t0 = Instant::now();
        self.reset_counts();
        let plan = self.plan(opts)?;
        let mut grid = Grid::new(plan.dims, plan.origin, plan.spacing)
            .map_err(|e| SceneError::new(self.name(), "sampling", e.to_string()))?;
        let [nx, ny, _] = plan.dims;
        let (o, h) = (plan.origin, plan.spacing);
        grid.data_mut()
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slice)| {
                for (n, v) in slice.iter_mut().enumerate() {
                    let ijk = Vec3::new((n % nx) as f32, (n / nx) as f32, k as f32);
                    *v = self.value(o + h * ijk);
                }
            });
        let dense = grid.len() as f64;
        let bricks = plan.dims.map(|d| d.div_ceil(plan.brick)).iter().product();
        let stats = self.stats(&plan, 1.0, dense, bricks, bricks, t0);
        Ok((grid, stats))
    }

    /// Computes the prism band of every mesh with the prism method on the lattice of
    /// `plan` (in each mesh's frame), wide enough for values clamped to `cap`.
    pub(crate) fn prepare_prism_bands(
        &self,
        plan: &Plan,
        cap: f32,
    ) -> Result<Vec<(String, &'static str)>, SceneError> {
        let mut out = Vec::new();
        if self.prism_meshes.is_empty() {
            return Ok(out);
        }
        let needs_gpu = self.prism_meshes.iter().any(|m| m.field.wants_gpu());
        let chosen = if needs_gpu {
            let choice = if self.prism_meshes.iter().any(|m| m.field.forces_gpu()) {
                isokit_gpu::BackendChoice::Gpu
            } else {
                isokit_gpu::BackendChoice::Auto
            };
            isokit_prism::PrismGpu::choose(choice)
                .map_err(|e| SceneError::new(self.name(), "sampling", format!("prism band: {e}")))?
                .0
        } else {
            None
        };
        for m in &self.prism_meshes {
            let origin = m.frame.to_local(plan.origin.as_dvec3()).as_vec3();
            let spacing = (f64::from(plan.spacing) / m.frame.scale) as f32;
            let band = (f64::from(cap) / m.frame.scale) as f32;
            let used = m
                .field
                .prepare(origin, spacing, band, chosen.as_ref())
                .map_err(|e| SceneError::new(self.name(), &m.node, e))?;
            if let Some(u) = used {
                out.push((m.node.clone(), u));
            }
        }
        Ok(out)
    }

    pub(crate) fn stats(
        &self,
        plan: &Plan,
        fraction: f64,
        dense: f64,
        kept: usize,
        total: usize,
        t0: Instant,
    ) -> SampleStats {
        SampleStats {
            dims: plan.dims,
            origin: plan.origin.to_array(),
            spacing: plan.spacing,
            band: plan.band,
            brick: plan.brick,
            dense_fraction: fraction,
            dense_samples: dense as u64,
            bricks_kept: kept,
            bricks_total: total,
            bricks_reused: 0,
            seconds: t0.elapsed().as_secs_f64(),
            sources: self
                .sources()
                .iter()
                .map(|s| SourceStats {
                    node: s.node.clone(),
                    kind: s.kind,
                    queries: s.queries(),
                    query_fraction: s.queries() as f64 / dense.max(1.0),
                    memo_hits: s.memo_hits(),
                })
                .collect(),
            prism_bands: Vec::new(),
        }
    }

    /// The lattice [`Scene::sample`] would use with `opts` (checked, nothing allocated).
    pub fn plan(&self, opts: &SampleOptions) -> Result<Plan, SceneError> {
        let err = |node: &str, m: String| SceneError::new(self.name(), node, m);
        if let Some((dims, origin, spacing)) = opts.lattice {
            return self.plan_on(opts, dims, origin, spacing);
        }
        let domain = opts.bounds.unwrap_or_else(|| self.domain());
        if domain.is_empty() {
            return Err(err(
                "shape",
                "the shape is empty (its bounding box holds nothing)".into(),
            ));
        }
        if !domain.is_finite() {
            return Err(err(
                "shape",
                "the shape is unbounded: give sampling.bounds = [[xmin, ymin, zmin], [xmax, ymax, zmax]]"
                    .into(),
            ));
        }
        let res = opts.resolution;
        if !(2..=isokit_field::MAX_AXIS).contains(&res) {
            return Err(err(
                "sampling.resolution",
                format!("{res} must be at least 2 samples along the longest side"),
            ));
        }
        BrickGrid::check_brick(opts.brick)
            .map_err(|e| err("sampling.brick", format!("{}: {e}", opts.brick)))?;
        let h0 = domain.size().max_element() / (res - 1).max(1) as f32;
        let explicit = opts.bounds.is_some() || self.settings().sampling.bounds.is_some();
        let band = match opts.band {
            Some(b) if b.is_finite() && b > 0.0 => b,
            Some(b) => {
                return Err(err(
                    "sampling.band",
                    format!("{b} must be finite and positive"),
                ));
            }
            None if h0 > 0.0 && h0.is_finite() => 4.0 * h0,
            None => {
                return Err(err(
                    "sampling",
                    "the domain has no extent (a single point): give sampling.bounds or a band"
                        .into(),
                ));
            }
        };
        let pad = if explicit { 0.0 } else { band + 2.0 * h0 };
        if let Some(why) = Grid::padding_problem(domain, res, pad) {
            return Err(err(
                "sampling.band",
                format!("{band} (the band, or --band, pads the domain by its width) {why}"),
            ));
        }
        if domain.expanded(pad).size().max_element() <= 0.0 {
            return Err(err(
                "sampling.bounds",
                "the domain has no extent: the corners must differ".into(),
            ));
        }
        let (dims, origin, spacing) = Grid::covering_geometry(domain, res, pad)
            .map_err(|e| err("sampling", e.to_string()))?;
        Ok(Plan {
            dims,
            origin,
            spacing,
            band,
            brick: opts.brick,
        })
    }
}

impl Scene {
    /// The dimensions of what a sampling with `opts` gives: the block's, else the lattice's
    /// (checked against the lattice).
    pub fn sampled_dims(&self, opts: &SampleOptions) -> Result<[usize; 3], SceneError> {
        let plan = self.plan(opts)?;
        match opts.block {
            None => Ok(plan.dims),
            Some(b) => {
                let inside = (0..3).all(|a| {
                    b.dims[a] >= 1
                        && b.first[a]
                            .checked_add(b.dims[a])
                            .is_some_and(|end| end <= plan.dims[a])
                });
                if !inside {
                    return Err(SceneError::new(
                        self.name(),
                        "sampling",
                        format!(
                            "the block of {:?} samples from {:?} is not inside the lattice of {:?} samples",
                            b.dims, b.first, plan.dims
                        ),
                    ));
                }
                Ok(b.dims)
            }
        }
    }

    /// The plan of [`Scene::plan`] on a given lattice.
    fn plan_on(
        &self,
        opts: &SampleOptions,
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
    ) -> Result<Plan, SceneError> {
        let err = |m: String| SceneError::new(self.name(), "sampling", m);
        isokit_field::checked_len(dims).map_err(|e| err(e.to_string()))?;
        if dims.iter().any(|&d| d < 2) || !(spacing.is_finite() && spacing > 0.0) {
            return Err(err(format!(
                "the lattice {dims:?} with spacing {spacing} needs 2 samples a side and a positive spacing"
            )));
        }
        if !origin.is_finite() {
            return Err(err(format!("the lattice's origin {origin} is not finite")));
        }
        BrickGrid::check_brick(opts.brick).map_err(|e| {
            SceneError::new(
                self.name(),
                "sampling.brick",
                format!("{}: {e}", opts.brick),
            )
        })?;
        let band = opts.band.unwrap_or(4.0 * spacing);
        if !(band.is_finite() && band > 0.0) {
            return Err(SceneError::new(
                self.name(),
                "sampling.band",
                format!("{band} must be finite and positive"),
            ));
        }
        Ok(Plan {
            dims,
            origin,
            spacing,
            band,
            brick: opts.brick,
        })
    }
}

/// The scene clamped to `±cap`: what the lazy sampler evaluates.
pub(crate) struct Clamped<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) cap: f32,
}

impl Field for Clamped<'_> {
    /// The root's own clamped evaluation, without the root's lower-bound test first
    /// ([`isokit_field::value_clamped`]): the sampler evaluates points near the surface,
    /// where that test never prunes and costs a walk of the whole tree, while the
    /// operands still test their own bounds. Both give `cap` where the bound is above it
    /// (the clamped value is then `cap`), so the samples are the same.
    fn value(&self, p: Vec3) -> f32 {
        if !p.is_finite() {
            return f32::NAN;
        }
        self.scene.field().value_clamped(p, self.cap)
    }
    fn bounds(&self) -> Aabb {
        self.scene.bounds()
    }
    fn lipschitz(&self) -> f32 {
        self.scene.lipschitz()
    }
}

/// A band field as a dense grid clamped to `±band`: lazily sampled bricks hold exact values
/// a little beyond the band, and the files read "exact within W, ±W beyond" everywhere.
pub fn band_to_grid(bricks: &BrickGrid, band: f32) -> Result<Grid, isokit_field::FieldError> {
    let mut grid = bricks.to_grid()?;
    clamp_to_band(&mut grid, band);
    Ok(grid)
}

/// Clamps a grid's samples to `±band` ([`Grid::clamp_to_band`]).
pub fn clamp_to_band(grid: &mut Grid, band: f32) {
    grid.clamp_to_band(band);
}
