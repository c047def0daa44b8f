//! Argument groups shared by several commands: the backend, the ray caster's knobs, the
//! multi-view display, on-the-fly CSG. Every list of choices comes from the library.

use anyhow::{Result, bail};
use isokit_gpu::BackendChoice;
use isokit_render::{
    CachePolicy, Combine, Filter, MultiView, RefineMethod, RenderOptions, ShadingMode,
};
use isokit_scene::ProjectionKind;
use std::path::PathBuf;

/// Which implementation runs.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// `ISOKIT_BACKEND=cpu|gpu` when set; else a hardware GPU when one exists, the CPU
    /// (with a note) when none does or the only adapter is a software one (lavapipe).
    Auto,
    /// The CPU twin (rayon).
    Cpu,
    /// The GPU twin (wgpu), on any adapter, software ones included; an error without one.
    Gpu,
}

impl Backend {
    /// The library's request.
    pub fn choice(self) -> BackendChoice {
        match self {
            Backend::Auto => BackendChoice::Auto,
            Backend::Cpu => BackendChoice::Cpu,
            Backend::Gpu => BackendChoice::Gpu,
        }
    }
}

/// The renderer a backend request opens, printing the note when `auto` chose the CPU.
pub fn open_renderer(backend: Backend) -> Result<isokit_scene::Renderer> {
    let r = isokit_scene::Renderer::new(backend.choice())?;
    if let Some(note) = r.note() {
        eprintln!("{note}");
    }
    Ok(r)
}

/// Parses shading mode names with the library's error (which lists the modes), and shows
/// the library's list of modes in `--help`.
#[derive(Clone, Copy, Debug)]
pub struct ShadingNames;

impl clap::builder::TypedValueParser for ShadingNames {
    type Value = String;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<String, clap::Error> {
        let s = value.to_string_lossy();
        match s.parse::<ShadingMode>() {
            Ok(_) => Ok(s.into_owned()),
            Err(msg) => {
                let name = arg.map_or("--shading".to_owned(), |a| a.to_string());
                Err(clap::Error::raw(
                    clap::error::ErrorKind::InvalidValue,
                    format!("{name}: {msg}\n"),
                )
                .with_cmd(cmd))
            }
        }
    }

    fn possible_values(
        &self,
    ) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        Some(Box::new(
            ShadingMode::ALL
                .iter()
                .map(|(n, _)| clap::builder::PossibleValue::new(*n)),
        ))
    }
}

/// The shading modes' names, from the library's list.
pub fn shading_names() -> ShadingNames {
    ShadingNames
}

/// Parses a shading mode name (one of [`ShadingMode::ALL`]).
pub fn shading_mode(name: &str) -> Result<ShadingMode> {
    name.parse().map_err(anyhow::Error::msg)
}

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

/// Which side of the isovalue is inside.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum InsideArg {
    /// Below the isovalue (distance fields).
    #[default]
    Below,
    /// Above the isovalue (densities such as CT).
    Above,
}

impl InsideArg {
    /// The library's side.
    pub fn inside(self) -> isokit_render::Inside {
        match self {
            InsideArg::Below => isokit_render::Inside::Below,
            InsideArg::Above => isokit_render::Inside::Above,
        }
    }
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
    /// Projection: perspective or orthographic (same eye, target and field of view).
    #[arg(long, default_value = "perspective")]
    pub projection: String,
    /// Curvature that saturates the curvature maps, 1/world units [default: 20 / the
    /// volume's diagonal].
    #[arg(long)]
    pub curvature_scale: Option<f32>,
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
            cache_policy: match self.cache_policy {
                CachePolicyArg::Passes => CachePolicy::Passes,
                CachePolicyArg::Downsample => CachePolicy::Downsample,
            },
            ..Default::default()
        };
        o.check()?;
        Ok(o)
    }

    /// The projection.
    pub fn projection(&self) -> Result<ProjectionKind> {
        self.projection.parse().map_err(anyhow::Error::msg)
    }

    /// The cache size in bytes, if given.
    pub fn cache_bytes(&self) -> Option<usize> {
        self.cache_mb.map(|mb| mb.saturating_mul(1 << 20))
    }
}

/// A multi-view autostereoscopic display (paper 001).
#[derive(clap::Args, Debug, Clone)]
pub struct MultiViewArgs {
    /// Render for a multi-view autostereoscopic display with this many views (2 to 64):
    /// one ray per subpixel from the eye of the view it shows (paper 001). With --gbuffer
    /// the G-buffer is per subpixel (3·width wide).
    #[arg(long)]
    pub views: Option<u32>,
    /// Distance between neighbouring views' eyes, world units [default: 1% of the distance
    /// from the eye to the target].
    #[arg(long)]
    pub view_separation: Option<f32>,
    /// Subpixels under one lens [default: the number of views].
    #[arg(long)]
    pub lens_pitch: Option<f32>,
    /// Horizontal shift of the lenses per pixel row, in pixels (slanted lenses).
    #[arg(long, default_value_t = 0.0)]
    pub lens_slant: f32,
    /// With --views: also write each view rendered alone to this folder (view_00.png, …).
    #[arg(long)]
    pub views_out: Option<PathBuf>,
}

impl MultiViewArgs {
    /// The display, checked, and whether its separation is to be the default (1% of the
    /// distance from the eye to the target, resolved with the camera).
    pub fn multiview(&self) -> Result<(Option<MultiView>, bool)> {
        let Some(n) = self.views else {
            if self.views_out.is_some() {
                bail!("--views-out needs --views");
            }
            return Ok((None, false));
        };
        let mv = MultiView {
            pitch: self.lens_pitch.unwrap_or(n as f32),
            slant: self.lens_slant,
            ..MultiView::new(n, self.view_separation.unwrap_or(0.0))
        };
        mv.check()?;
        Ok((Some(mv), self.view_separation.is_none()))
    }
}

/// The operation of `--csg`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsgOp {
    /// A ∪ B.
    Union,
    /// A ∩ B.
    Intersection,
    /// A − B.
    Difference,
    /// (1 − t)·A + t·B.
    Morph,
}

/// On-the-fly CSG of two volumes.
#[derive(clap::Args, Debug, Clone)]
pub struct CsgArgs {
    /// Combine the input volume A with a second volume B (--with, same dimensions, origin
    /// and spacing) per sample while ray casting: union (min), intersection (max),
    /// difference A − B (max(a, −b)), or morph ((1 − t)·a + t·b). Volumes only.
    #[arg(long, value_enum, requires = "with")]
    pub csg: Option<CsgOp>,
    /// The second volume of --csg.
    #[arg(long, requires = "csg")]
    pub with: Option<PathBuf>,
    /// The morph parameter t in [0, 1] of --csg morph [default: 0.5].
    #[arg(long)]
    pub morph_t: Option<f32>,
}

impl CsgArgs {
    /// The combination, checked (`--morph-t` only with `morph`).
    pub fn combine(&self) -> Result<Option<Combine>> {
        if self.morph_t.is_some() && self.csg != Some(CsgOp::Morph) {
            bail!("--morph-t applies to --csg morph only");
        }
        let c = match self.csg {
            None => return Ok(None),
            Some(CsgOp::Union) => Combine::Union,
            Some(CsgOp::Intersection) => Combine::Intersection,
            Some(CsgOp::Difference) => Combine::Difference,
            Some(CsgOp::Morph) => Combine::Morph(self.morph_t.unwrap_or(0.5)),
        };
        c.check()?;
        Ok(Some(c))
    }
}
