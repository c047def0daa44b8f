//! The ray caster's knobs (`isokit render`): filter, sampling rates, refinement, empty-space
//! skipping, the brick cache and its policy, curvature scale (the camera and projection are
//! in `camera_args`).

use super::args::InsideArg;
use anyhow::Result;
use isokit_render::{CachePolicy, Filter, RefineMethod, RenderOptions};

/// Refinement method.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refine {
    /// Halve the bracket.
    Bisection,
    /// Secant (Illinois).
    Secant,
}

/// What a brick cache too small for the active bricks does.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CachePolicyArg {
    /// Render the exact image in several passes.
    Passes,
    /// Store the least detailed bricks at half resolution so that all fit, one pass
    /// (Sigg 2006, Sec. 6.2.3; hanging samples matched, no cracks).
    Downsample,
}

/// The ray caster's knobs.
#[derive(clap::Args, Debug, Clone)]
pub struct RaycastArgs {
    /// Reconstruction filter of the intersection search: trilinear or tricubic.
    #[arg(long, default_value = "tricubic")]
    pub filter: String,
    /// Base sampling rate r0, samples per voxel.
    #[arg(long, default_value_t = 1.0)]
    pub r0: f32,
    /// Fine-rate factor n (r1 = n·r0 near the isovalue; 1 = off).
    #[arg(long, default_value_t = 8)]
    pub fine: u32,
    /// Fine-rate threshold in field units [default: one base step's change, L·h/r0].
    #[arg(long)]
    pub delta: Option<f32>,
    /// Refinement steps after a crossing.
    #[arg(long, default_value_t = 6)]
    pub refine: u32,
    /// Refinement method.
    #[arg(long, value_enum, default_value_t = Refine::Secant)]
    pub refine_method: Refine,
    /// Sample every block instead of skipping those without the isovalue (same image,
    /// slower: for comparison).
    #[arg(long)]
    pub no_skip: bool,
    /// Brick cache size in MiB (a cache smaller than the active bricks renders the same
    /// image in several passes) [default: 1024].
    #[arg(long)]
    pub cache_mb: Option<usize>,
    /// What a cache too small for the active bricks does: passes (the exact image, in
    /// several passes) or downsample (the least detailed bricks at half resolution, one
    /// pass; passes when even that does not fit).
    #[arg(long, value_enum, default_value_t = CachePolicyArg::Passes)]
    pub cache_policy: CachePolicyArg,
    /// Curvature that saturates the curvature maps, 1/world units [default: 20 / the
    /// volume's diagonal].
    #[arg(long)]
    pub curvature_scale: Option<f32>,
    /// Intersection search: sphere (sphere tracing by the reconstruction's slope bound per
    /// block, measured from the samples or --lipschitz) or fixed (the adaptive fixed-rate
    /// search, r0 and n).
    #[arg(long, default_value = "sphere")]
    pub search: String,
    /// A bound on |∇f| (field units per world unit) for sphere tracing instead of the
    /// bounds measured per block; blocks whose samples refute it use their measured bound.
    #[arg(long)]
    pub lipschitz: Option<f32>,
}

impl RaycastArgs {
    /// The library's options (isovalue and side from the caller), checked.
    pub fn options(&self, iso: f32, inside: InsideArg) -> Result<RenderOptions> {
        let filter: Filter = self.filter.parse().map_err(anyhow::Error::msg)?;
        let o = RenderOptions {
            iso,
            inside: inside.inside(),
            filter,
            r0: self.r0,
            fine: self.fine,
            delta: self.delta,
            refine_steps: self.refine,
            refine: match self.refine_method {
                Refine::Bisection => RefineMethod::Bisection,
                Refine::Secant => RefineMethod::Secant,
            },
            skip_empty: !self.no_skip,
            search: self.search.parse().map_err(anyhow::Error::msg)?,
            lipschitz: self.lipschitz,
            cache_policy: match self.cache_policy {
                CachePolicyArg::Passes => CachePolicy::Passes,
                CachePolicyArg::Downsample => CachePolicy::Downsample,
            },
            ..Default::default()
        };
        o.check()?;
        Ok(o)
    }

    /// The cache size in bytes, if given.
    pub fn cache_bytes(&self) -> Option<usize> {
        self.cache_mb.map(|mb| mb.saturating_mul(1 << 20))
    }
}
