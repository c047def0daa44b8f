//! The CPU ray caster: options, the host side of the brick cache, and the passes over the
//! image (rayon over pixels) that call [`crate::kernel::trace_pixel`].

use crate::kernel::{
    self, COMBINE_NONE, FILTER_TRICUBIC, FILTER_TRILINEAR, FLAG_CAPS, FLAG_CURVATURE, FLAG_SECANT,
    FLAG_SKIP_EMPTY, FLAG_SPHERE, GSample, ID_CAP, PixelResult, Resume, TraceData, Uniforms,
};
use crate::raycast::reuse::{KeptFrame, Reuse};
use crate::{BrickCache, GBuffer, RenderError, StartRaster, Volume, check_image_size};
use glam::IVec3;
use isokit_field::curvature::Inside;
use isokit_field::{Camera, Projection};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

/// Reconstruction filter of the ray caster.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filter {
    /// Trilinear: interpolating, C0; one fetch per value. Its Hessian has a zero diagonal,
    /// so curvature from it is crude.
    Trilinear,
    /// Tricubic B-spline by the 8-fetch scheme: C2, approximating (it smooths: a sampled
    /// sphere shrinks by about `h²/(3R)`); the filter for normals and curvature.
    #[default]
    Tricubic,
}

impl Filter {
    fn code(self) -> u32 {
        match self {
            Filter::Trilinear => FILTER_TRILINEAR,
            Filter::Tricubic => FILTER_TRICUBIC,
        }
    }
}

impl std::str::FromStr for Filter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "trilinear" | "linear" => Ok(Self::Trilinear),
            "tricubic" | "cubic" | "cubic_bspline" | "bspline" => Ok(Self::Tricubic),
            _ => Err(format!(
                "unknown filter {s:?} (expected trilinear or tricubic)"
            )),
        }
    }
}

/// How a detected crossing is refined (002 Sec. 6.3.4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RefineMethod {
    /// Halve the bracket each step.
    Bisection,
    /// Secant (regula falsi, Eq. 6.4) with the Illinois modification, keeping the bracket.
    #[default]
    Secant,
}

/// How rays search for the first crossing inside an active block.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Search {
    /// Sphere tracing (Hart 1996) by the reconstruction's Lipschitz bound: from a sample
    /// with residual `r > 0` the ray advances by `r / L` (at least the fine step
    /// `1 / (r0 · fine)`), where `L` bounds the slope of the reconstructed field along the
    /// ray in the block: measured from the samples per block ([`RenderOptions::lipschitz`]
    /// `None`) or given. It never steps over a crossing where the bound holds, and finds
    /// every inside run at least one fine step long.
    #[default]
    Sphere,
    /// The adaptive fixed-rate search of 002 Sec. 6.3.3: `r0` samples per voxel, `fine`
    /// times more where either end of a base interval is within `delta` of the isovalue.
    Fixed,
}

impl std::str::FromStr for Search {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "sphere" | "sphere-trace" | "sphere_trace" => Ok(Self::Sphere),
            "fixed" | "fixed-rate" | "adaptive" => Ok(Self::Fixed),
            _ => Err(format!("unknown search {s:?} (expected sphere or fixed)")),
        }
    }
}

/// What to do when the bricks a frame needs do not all fit the brick cache.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CachePolicy {
    /// Render the exact image in several passes: rays wait at a missing brick, the host
    /// loads the bricks asked for and resumes them.
    #[default]
    Passes,
    /// 002 Sec. 6.2.3: store the bricks with the least detail ([`Volume::brick_detail`])
    /// at half resolution (every second sample, [`Volume::fill_brick_half`]) until all
    /// active bricks fit, and render in one pass; full-resolution bricks beside
    /// half-resolution ones get their hanging samples matched
    /// ([`Volume::fill_brick_matched`]) so the surface has no cracks. With a cache that
    /// holds every active brick it changes nothing; when even all at half resolution do
    /// not fit, it renders in passes.
    Downsample,
}

impl std::str::FromStr for CachePolicy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "passes" => Ok(Self::Passes),
            "downsample" => Ok(Self::Downsample),
            _ => Err(format!(
                "unknown cache policy {s:?} (expected passes or downsample)"
            )),
        }
    }
}

/// The knobs of one rendering: what surface, how it is searched, how precisely.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// The isovalue ρ (default 0).
    pub iso: f32,
    /// Which side of ρ is inside (ERRATA 7): [`Inside::Below`] for distance fields,
    /// [`Inside::Above`] for densities.
    pub inside: Inside,
    /// Filter of the intersection search (default tricubic).
    pub filter: Filter,
    /// Filter of the gradient and Hessian at the hit (default tricubic).
    pub shading_filter: Filter,
    /// Base sampling rate r0 in samples per voxel (default 1; 0 < r0 <= 64).
    pub r0: f32,
    /// Fine-rate factor n, r1 = n · r0, used where the field comes within `delta` of ρ
    /// (default 8 as in 002; 1 turns adaptive sampling off; at most 64).
    pub fine: u32,
    /// The threshold of the fine rate in field units; `None`: `gradient_scale · spacing /
    /// r0`, the change of an L-Lipschitz field over one base step, which is twice what is
    /// needed for any interval where the field dips below ρ to be resampled finely.
    pub delta: Option<f32>,
    /// A bound on `|∇f|` in field units per world unit: 1 for distance fields (default);
    /// for densities an estimate ([`estimate_gradient_scale`]).
    pub gradient_scale: f32,
    /// Refinement steps after a crossing (default 6; at most 64).
    pub refine_steps: u32,
    /// Refinement method (default secant).
    pub refine: RefineMethod,
    /// Skip blocks whose range excludes ρ (default true). Off, every block is sampled:
    /// the image is the same, only slower.
    pub skip_empty: bool,
    /// Report caps where a ray enters the volume inside the solid (default true).
    pub caps: bool,
    /// What a cache too small for the active bricks does (default
    /// [`CachePolicy::Passes`]).
    pub cache_policy: CachePolicy,
    /// How rays search for the crossing in an active block (default [`Search::Sphere`]).
    pub search: Search,
    /// A bound on `|∇f|` in field units per world unit used by [`Search::Sphere`] instead
    /// of the bounds measured from the samples per block (`None`, the default). Blocks
    /// whose samples refute it (a difference between neighbouring samples steeper than
    /// `L · spacing`) use their measured bound instead.
    pub lipschitz: Option<f32>,
    /// Compute the Hessian and principal curvatures at each hit (default true). Off, the
    /// G-buffer holds positions, depths and normals only (curvatures 0, `dir1` any unit
    /// vector orthogonal to the normal): enough for Phong and the other modes that read no
    /// curvature, and cheaper.
    pub curvature: bool,
    /// Start each ray of the CPU twin where the projected boxes of the active blocks say it
    /// can first meet one ([`StartRaster`], default true). Off, rays walk from where they
    /// enter the volume, as the GPU twin's do: the image is the same bit for bit, only
    /// slower (a knob for measuring it).
    pub start_raster: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            iso: 0.0,
            inside: Inside::Below,
            filter: Filter::Tricubic,
            shading_filter: Filter::Tricubic,
            r0: 1.0,
            fine: 8,
            delta: None,
            gradient_scale: 1.0,
            refine_steps: 6,
            refine: RefineMethod::Secant,
            skip_empty: true,
            caps: true,
            cache_policy: CachePolicy::Passes,
            search: Search::Sphere,
            lipschitz: None,
            curvature: true,
            start_raster: true,
        }
    }
}

impl RenderOptions {
    /// Checks the ranges.
    pub fn check(&self) -> Result<(), RenderError> {
        if !self.iso.is_finite() {
            return Err(RenderError::bad("iso", self.iso, "must be finite"));
        }
        if !(self.r0.is_finite() && self.r0 > 0.0 && self.r0 <= 64.0) {
            return Err(RenderError::bad(
                "r0",
                self.r0,
                "the base sampling rate must lie in (0, 64] samples per voxel",
            ));
        }
        if !(1..=64).contains(&self.fine) {
            return Err(RenderError::bad(
                "fine",
                self.fine,
                "the fine-rate factor must be 1 to 64",
            ));
        }
        if self.refine_steps > 64 {
            return Err(RenderError::bad(
                "refine steps",
                self.refine_steps,
                "must be at most 64",
            ));
        }
        if let Some(d) = self.delta
            && !(d.is_finite() && d >= 0.0)
        {
            return Err(RenderError::bad(
                "delta",
                d,
                "must be finite and non-negative",
            ));
        }
        if let Some(l) = self.lipschitz
            && !(l.is_finite() && l > 0.0)
        {
            return Err(RenderError::bad(
                "lipschitz",
                l,
                "the bound on |∇f| must be finite and positive",
            ));
        }
        if !(self.gradient_scale.is_finite() && self.gradient_scale > 0.0) {
            return Err(RenderError::bad(
                "gradient scale",
                self.gradient_scale,
                "must be finite and positive",
            ));
        }
        Ok(())
    }

    /// The fine-rate threshold used for `volume` (see [`RenderOptions::delta`]).
    pub fn delta_for(&self, volume: &Volume) -> f32 {
        self.delta
            .unwrap_or(self.gradient_scale * volume.spacing() / self.r0)
    }
}

/// An estimate of `|∇f|` near the isovalue for data that are not distance fields (CT-like
/// densities), in field units per world unit: the median over active blocks of
/// `(max − min) / (block diagonal)`. 1 when no block is active.
pub fn estimate_gradient_scale(volume: &Volume, iso: f32) -> f32 {
    let diag = (volume.layout().block + 3) as f32 * 3f32.sqrt() * volume.spacing();
    let mut g: Vec<f32> = volume
        .block_ranges()
        .iter()
        .filter(|r| r[0] <= iso && iso <= r[1] && r[1] > r[0])
        .map(|r| (r[1] - r[0]) / diag)
        .collect();
    if g.is_empty() {
        return 1.0;
    }
    let mid = g.len() / 2;
    let (_, m, _) = g.select_nth_unstable_by(mid, f32::total_cmp);
    if m.is_finite() && *m > 0.0 { *m } else { 1.0 }
}

/// The uniforms of a camera alone (no volume): the frame, the image and a single view; what
/// ray generation and shading read (the quadric splatter uses these).
pub fn camera_uniforms(camera: &Camera) -> Result<Uniforms, RenderError> {
    let (width, height) = check_image_size(camera.width().into(), camera.height().into())?;
    let forward = camera.forward();
    // As `Camera::look_at` builds its frame.
    let right = forward.cross(camera.up()).normalize_or_zero();
    let up = right.cross(forward);
    let (ortho, half_height) = match camera.projection() {
        Projection::Perspective { fov_y_degrees } => (0, (0.5 * fov_y_degrees.to_radians()).tan()),
        Projection::Orthographic { height } => (1, 0.5 * height),
    };
    Ok(Uniforms {
        eye: camera.eye().to_array(),
        ortho,
        right: right.to_array(),
        half_height,
        up: up.to_array(),
        aspect: camera.aspect(),
        forward: forward.to_array(),
        width,
        height,
        views: 1,
        view: 0,
        subpixels: 1,
        window_distance: (camera.target() - camera.eye()).length(),
        lens_pitch: 1.0,
        ..bytemuck::Zeroable::zeroed()
    })
}

/// The uniforms of one rendering of `volume` by `camera` with `opts`.
pub fn uniforms(
    volume: &Volume,
    camera: &Camera,
    opts: &RenderOptions,
) -> Result<Uniforms, RenderError> {
    opts.check()?;
    let layout = volume.layout();
    let u32s = |a: [usize; 3]| a.map(|v| v as u32);
    Ok(Uniforms {
        origin: volume.origin().to_array(),
        spacing: volume.spacing(),
        dims: u32s(volume.dims()),
        block: layout.block as u32,
        block_dims: u32s(volume.block_dims()),
        brick: layout.brick as u32,
        brick_dims: u32s(volume.brick_dims()),
        brick_side: layout.brick_side() as u32,
        iso: opts.iso,
        inside_sign: match opts.inside {
            Inside::Below => 1.0,
            Inside::Above => -1.0,
        },
        r0: opts.r0,
        fine: opts.fine,
        delta: match opts.search {
            Search::Fixed => opts.delta_for(volume),
            Search::Sphere => opts.lipschitz.map_or(0.0, |l| l * volume.spacing()),
        },
        refine_steps: opts.refine_steps,
        flags: if opts.skip_empty { FLAG_SKIP_EMPTY } else { 0 }
            | if opts.caps { FLAG_CAPS } else { 0 }
            | match opts.refine {
                RefineMethod::Bisection => 0,
                RefineMethod::Secant => FLAG_SECANT,
            }
            | match opts.search {
                Search::Fixed => 0,
                Search::Sphere => FLAG_SPHERE,
            }
            | if opts.curvature { FLAG_CURVATURE } else { 0 },
        filter: opts.filter.code(),
        shading_filter: opts.shading_filter.code(),
        combine: volume.combine().map_or(COMBINE_NONE, |c| c.code()),
        morph_t: volume.combine().map_or(0.0, |c| c.morph_t()),
        ..camera_uniforms(camera)?
    })
}

/// A multi-view autostereoscopic display (paper 001): `views` eyes on a line along the
/// camera's right vector, `separation` apart and centred on the camera's eye, all looking
/// through the same window (the plane of the camera's target, zero parallax); behind a
/// slanted lenticular sheet each subpixel shows one view ([`kernel::view_index`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiView {
    /// Number of views, 2 to 64.
    pub views: u32,
    /// Distance between neighbouring eyes, world units.
    pub separation: f32,
    /// Subpixels under one lens (default: `views`, one view per subpixel along a row).
    pub pitch: f32,
    /// Horizontal shift of the lenses per pixel row, in pixels (0 for vertical lenses).
    pub slant: f32,
    /// Shift of the pattern, in subpixels.
    pub offset: f32,
}

impl MultiView {
    /// `views` views `separation` apart behind vertical lenses of `views` subpixels.
    pub fn new(views: u32, separation: f32) -> Self {
        Self {
            views,
            separation,
            pitch: views as f32,
            slant: 0.0,
            offset: 0.0,
        }
    }

    /// Checks the ranges.
    pub fn check(&self) -> Result<(), RenderError> {
        if !(2..=64).contains(&self.views) {
            return Err(RenderError::bad("views", self.views, "must be 2 to 64"));
        }
        if !(self.separation.is_finite() && self.separation >= 0.0) {
            return Err(RenderError::bad(
                "view separation",
                self.separation,
                "must be finite and non-negative",
            ));
        }
        if !(self.pitch.is_finite() && self.pitch > 0.0) {
            return Err(RenderError::bad(
                "lens pitch",
                self.pitch,
                "must be finite and positive",
            ));
        }
        if !(self.slant.is_finite() && self.offset.is_finite()) {
            return Err(RenderError::bad(
                "lens slant and offset",
                format!("{} {}", self.slant, self.offset),
                "must be finite",
            ));
        }
        Ok(())
    }

    /// The uniforms of the geometric pass (`view` `None`: one ray per subpixel) or of one
    /// view rendered alone.
    pub(crate) fn uniforms(
        &self,
        volume: &Volume,
        camera: &Camera,
        opts: &RenderOptions,
        view: Option<u32>,
    ) -> Result<Uniforms, RenderError> {
        self.check()?;
        if !matches!(camera.projection(), Projection::Perspective { .. }) {
            return Err(RenderError::bad(
                "projection",
                "orthographic",
                "multi-view rendering needs a perspective camera",
            ));
        }
        if let Some(v) = view
            && v >= self.views
        {
            return Err(RenderError::bad(
                "view",
                v,
                "must be below the number of views",
            ));
        }
        let mut u = uniforms(volume, camera, opts)?;
        let subpixels = if view.is_some() { 1 } else { 3 };
        if u64::from(u.width) * u64::from(u.height) * subpixels > crate::MAX_IMAGE_PIXELS {
            return Err(RenderError::ImageSize {
                width: u.width.into(),
                height: u.height.into(),
            });
        }
        u.views = self.views;
        u.view = view.map_or(-1, |v| v as i32);
        u.subpixels = subpixels as u32;
        u.view_separation = self.separation;
        u.lens_pitch = self.pitch;
        u.lens_slant = self.slant;
        u.lens_offset = self.offset;
        Ok(u)
    }
}

/// The geometric pass for a multi-view display (001): one ray per subpixel, each from the
/// eye of the view that subpixel shows, so its cost does not grow with the number of
/// views. The G-buffer is `3·width` wide: column `3x + c` is subpixel `c` of pixel `x`;
/// [`crate::shade()`] turns it into the interleaved image.
pub fn render_multiview(
    volume: &Volume,
    cache: &mut BrickCache,
    camera: &Camera,
    opts: &RenderOptions,
    mv: &MultiView,
) -> Result<Frame, RenderError> {
    let u = mv.uniforms(volume, camera, opts, None)?;
    trace_frame(volume, cache, camera, u, opts, None)
}

/// One view of a multi-view display rendered alone (every pixel from that view's eye): the
/// individual view images, and the reference the interleaved image is checked against.
pub fn render_view(
    volume: &Volume,
    cache: &mut BrickCache,
    camera: &Camera,
    opts: &RenderOptions,
    mv: &MultiView,
    view: u32,
) -> Result<Frame, RenderError> {
    let u = mv.uniforms(volume, camera, opts, Some(view))?;
    trace_frame(volume, cache, camera, u, opts, None)
}

/// What one rendering did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rays traced: one per pixel, or per subpixel for a multi-view display.
    pub rays: u64,
    /// Rays that hit the isosurface (either operand of a combined volume).
    pub hits: u64,
    /// Rays that hit a cap (the volume's box inside the solid).
    pub caps: u64,
    /// Field evaluations along all rays (search and refinement; not the derivatives).
    pub samples: u64,
    /// Blocks that hold the isovalue (all blocks when skipping is off).
    pub blocks_active: usize,
    /// Blocks of the volume.
    pub blocks_total: usize,
    /// Bricks that hold an active block.
    pub bricks_active: usize,
    /// Bricks of the volume.
    pub bricks_total: usize,
    /// Active bricks already resident when the frame started.
    pub cache_hits: u64,
    /// Bricks loaded during the frame.
    pub bricks_loaded: u64,
    /// Bricks evicted during the frame.
    pub evictions: u64,
    /// Passes over the pending pixels (1 when the cache held every brick rays needed).
    pub passes: u32,
    /// Active bricks held at half resolution ([`CachePolicy::Downsample`]).
    pub bricks_downsampled: usize,
    /// Active blocks whose samples refute the given bound [`RenderOptions::lipschitz`]
    /// (a difference of neighbouring samples steeper than `L · spacing`): sphere tracing
    /// steps by their measured bounds instead. 0 without a given bound.
    pub lipschitz_refuted: usize,
    /// Rays whose pixel was taken from a kept frame ([`render_reusing`]); their samples
    /// are counted as that frame traced them.
    pub rays_reused: u64,
    /// Wall-clock seconds of the frame (cache updates and tracing).
    pub seconds: f64,
}

impl RenderStats {
    /// Mean field evaluations per ray.
    pub fn samples_per_ray(&self) -> f64 {
        self.samples as f64 / self.rays.max(1) as f64
    }
}

/// A rendered frame: the G-buffer and what it cost.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Per-pixel hits, normals, curvature.
    pub gbuffer: GBuffer,
    /// Counters and timing.
    pub stats: RenderStats,
    /// The uniforms the frame was traced with (shading reads the camera from them).
    pub uniforms: Uniforms,
}

/// Ray casts `volume` from `camera` into a G-buffer.
///
/// 1. Blocks are culled against ρ; the bricks holding active blocks are the active set.
/// 2. Active bricks not resident are loaded nearest to the eye first, evicting only
///    inactive bricks (least recently used first), as far as the cache's capacity allows.
/// 3. Every pixel is traced (rayon). A ray that reaches an active brick which is not
///    resident asks for it and stops there.
/// 4. While rays wait: the bricks asked for are loaded, most requested first, evicting the
///    least recently used, and the waiting rays resume where they stopped. Because a ray
///    cuts and samples its segments the same way whether it ran through or was resumed, a
///    cache smaller than the active set renders exactly the same image, in more passes.
///
/// With [`CachePolicy::Downsample`] and more active bricks than slots, step 2 instead
/// stores some bricks at half resolution (least detail first) so that every active brick
/// is resident and step 3 is the only pass (see [`CachePolicy`]).
pub fn render(
    volume: &Volume,
    cache: &mut BrickCache,
    camera: &Camera,
    opts: &RenderOptions,
) -> Result<Frame, RenderError> {
    let u = uniforms(volume, camera, opts)?;
    trace_frame(volume, cache, camera, u, opts, None)
}

/// [`render`], taking from `kept` (the last frame, of an earlier version of the field) every
/// pixel whose ray meets no changed block and tracing only the others
/// ([`crate::KeptFrame`]): the same image bit for bit, faster after an edit that changed a
/// part of the field. With other uniforms (camera, size, isovalue, knobs) or another
/// lattice, and where either frame is traced from a downsampled assignment of the cache
/// ([`CachePolicy::Downsample`] with too small a cache), every pixel is traced; a cache too
/// small rendering in passes reuses as any other (the passes change no pixel).
/// [`RenderStats::rays_reused`] counts the pixels taken.
pub fn render_reusing(
    volume: &Volume,
    cache: &mut BrickCache,
    camera: &Camera,
    opts: &RenderOptions,
    kept: Option<&KeptFrame>,
) -> Result<Frame, RenderError> {
    let u = uniforms(volume, camera, opts)?;
    trace_frame(volume, cache, camera, u, opts, kept)
}

/// The host's first steps of a frame, shared by the CPU and GPU twins: which bricks hold an
/// active block (and how many blocks are active), and what the prefetch of those bricks
/// (nearest to the eye first, evicting only inactive ones) loaded.
pub(crate) struct Prefetch {
    /// Per brick: does it hold an active block?
    pub brick_active: Vec<bool>,
    /// Active blocks.
    pub blocks_active: usize,
    /// `(slot, brick)` pairs loaded by the prefetch.
    pub loaded: Vec<(usize, usize)>,
    /// Under a downsampled assignment: the block ranges to trace with (those of the stored
    /// samples, [`BrickCache`]'s mixed ranges combined as [`Volume::trace_ranges`]).
    pub ranges: Option<Vec<[f32; 2]>>,
    /// Active bricks at half resolution.
    pub downsampled: usize,
    /// True when the reference index changed other than through `loaded`.
    pub reference_changed: bool,
}

/// The downsampled assignment of a frame (one level per brick) when the active bricks do
/// not fit the cache at full resolution but do with the least detailed ones at half
/// resolution; `None` when they fit as they are, or not even all at half resolution.
fn plan_downsample(
    volume: &Volume,
    cache: &mut BrickCache,
    brick_active: &[bool],
) -> Option<Vec<u8>> {
    use crate::cache::{LEVEL_FULL, LEVEL_HALF, LEVEL_NONE};
    let active: Vec<usize> = (0..brick_active.len())
        .filter(|&n| brick_active[n])
        .collect();
    if active.len() <= cache.capacity() {
        return None;
    }
    let a = active.len();
    let nh = (0..=a).find(|&nh| cache.mixed_fits(volume, a - nh, nh))?;
    let detail = cache.details(volume, &active);
    let mut order: Vec<(f32, usize)> = detail.into_iter().zip(active.iter().copied()).collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut levels = vec![LEVEL_NONE; brick_active.len()];
    for (i, &(_, n)) in order.iter().enumerate() {
        levels[n] = if i < nh { LEVEL_HALF } else { LEVEL_FULL };
    }
    Some(levels)
}

/// Steps 1–2 of [`render`] (see there).
///
/// With [`CachePolicy::Downsample`], a downsampled assignment when one is needed (see
/// [`plan_downsample`]); `sink` receives the samples the cache stores for it (the GPU's
/// upload). Otherwise a downsampled assignment left from an earlier frame is dropped first.
pub(crate) fn prefetch(
    volume: &Volume,
    ranges: &[[f32; 2]],
    cache: &mut BrickCache,
    camera: &Camera,
    u: &Uniforms,
    policy: CachePolicy,
    sink: impl FnMut(usize, &[f32]),
) -> Prefetch {
    let n_bricks = volume.brick_count();
    // 1. Active blocks and bricks.
    let [bx, by, _] = volume.block_dims();
    let mut brick_active = vec![false; n_bricks];
    let mut blocks_active = 0;
    for (n, &r) in ranges.iter().enumerate() {
        if kernel::block_active(u, r) {
            blocks_active += 1;
            let c = IVec3::new(
                (n % bx) as i32,
                ((n / bx) % by) as i32,
                (n / (bx * by)) as i32,
            );
            brick_active[kernel::brick_of_block(u, c)] = true;
        }
    }
    cache.tick();
    if policy == CachePolicy::Downsample
        && let Some(levels) = plan_downsample(volume, cache, &brick_active)
    {
        let downsampled = levels
            .iter()
            .filter(|&&l| l == crate::cache::LEVEL_HALF)
            .count();
        let filter = if u.filter == FILTER_TRILINEAR {
            Filter::Trilinear
        } else {
            Filter::Tricubic
        };
        let changed = cache.load_mixed(volume, levels, filter, sink);
        let (ra, rb) = cache.mixed_ranges();
        return Prefetch {
            brick_active,
            blocks_active,
            loaded: Vec::new(),
            ranges: Some(volume.trace_ranges_of(ra, rb, u.iso, u.inside_sign)),
            downsampled,
            reference_changed: changed,
        };
    }
    let reference_changed = cache.clear_mixed();
    // 2. Hits and prefetch, nearest first.
    let eye = camera.eye();
    let forward = camera.forward();
    let mut wanted: Vec<(f32, usize)> = Vec::new();
    for n in (0..n_bricks).filter(|&n| brick_active[n]) {
        if cache.slot_of(n).is_some() {
            cache.count_hit();
            cache.touch(n);
        } else {
            let c = volume.brick_bounds(n).center();
            let depth = match camera.projection() {
                Projection::Perspective { .. } => (c - eye).length(),
                Projection::Orthographic { .. } => (c - eye).dot(forward),
            };
            wanted.push((depth, n));
        }
    }
    wanted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let order: Vec<usize> = wanted.iter().map(|&(_, n)| n).collect();
    let loaded = cache.load_slots(volume, &order, |n| brick_active[n]);
    Prefetch {
        brick_active,
        blocks_active,
        loaded,
        ranges: None,
        downsampled: 0,
        reference_changed,
    }
}

/// Step 4 of [`render`], shared by the twins: after a pass in which rays waited, the bricks
/// they asked for (`requests[n]` rays asked for brick `n`) are loaded, most requested first,
/// evicting the least recently used. Returns the `(slot, brick)` pairs loaded; an error when
/// none could be.
pub(crate) fn load_requested(
    volume: &Volume,
    cache: &mut BrickCache,
    requests: impl Iterator<Item = u32>,
) -> Result<Vec<(usize, usize)>, RenderError> {
    if cache.is_mixed() {
        // Every active brick is resident under a downsampled assignment: no ray waits.
        return Err(RenderError::bad(
            "cache capacity",
            cache.capacity(),
            "a ray waited for a brick under a downsampled assignment",
        ));
    }
    let mut asked: Vec<(u32, usize)> = requests
        .enumerate()
        .filter_map(|(n, c)| (c > 0).then_some((c, n)))
        .collect();
    asked.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let order: Vec<usize> = asked.iter().map(|&(_, n)| n).collect();
    cache.tick();
    // Every resident brick may go: rays only move forward, and those still waiting
    // wait for the ones asked for. Capacity >= 1, so at least one loads.
    let loaded = cache.load_slots(volume, &order, |_| false);
    if loaded.is_empty() {
        return Err(RenderError::bad(
            "cache capacity",
            cache.capacity(),
            "no brick could be loaded",
        ));
    }
    Ok(loaded)
}

/// Active blocks whose samples refute a given Lipschitz bound ([`kernel::ray_slope`]).
pub(crate) fn lipschitz_refuted(u: &Uniforms, ranges: &[[f32; 2]], info: &[[f32; 4]]) -> usize {
    if u.flags & FLAG_SPHERE == 0 || u.delta <= 0.0 {
        return 0;
    }
    ranges
        .iter()
        .zip(info)
        .filter(|(r, i)| kernel::block_active(u, **r) && i[0].max(i[1]).max(i[2]) > u.delta)
        .count()
}

/// The counters of a finished frame (shared by the twins).
#[expect(
    clippy::too_many_arguments,
    reason = "the frame's parts, as both twins hold them"
)]
pub(crate) fn frame_stats(
    volume: &Volume,
    u: &Uniforms,
    pixels: &[GSample],
    samples: &[u32],
    pre: &Prefetch,
    before: crate::CacheStats,
    after: crate::CacheStats,
    passes: u32,
    seconds: f64,
) -> RenderStats {
    RenderStats {
        width: u.width,
        height: u.height,
        rays: pixels.len() as u64,
        hits: pixels
            .iter()
            .filter(|p| kernel::is_surface_id(p.id))
            .count() as u64,
        caps: pixels.iter().filter(|p| p.id == ID_CAP).count() as u64,
        samples: samples.iter().map(|&s| u64::from(s)).sum(),
        blocks_active: pre.blocks_active,
        blocks_total: volume.block_ranges().len(),
        bricks_active: pre.brick_active.iter().filter(|&&a| a).count(),
        bricks_total: volume.brick_count(),
        cache_hits: after.hits - before.hits,
        bricks_loaded: after.loads - before.loads,
        evictions: after.evictions - before.evictions,
        passes,
        bricks_downsampled: pre.downsampled,
        lipschitz_refuted: 0,
        rays_reused: 0,
        seconds,
    }
}

/// Traces every ray `u` describes (`width · height · subpixels`).
fn trace_frame(
    volume: &Volume,
    cache: &mut BrickCache,
    camera: &Camera,
    u: Uniforms,
    opts: &RenderOptions,
    kept: Option<&KeptFrame>,
) -> Result<Frame, RenderError> {
    let t0 = Instant::now();
    let policy = opts.cache_policy;
    // Counted from before the binding: bricks a cache kept across an edit fills again
    // there ([`BrickCache`]'s rebinding) are this frame's loads.
    let before = cache.stats();
    cache.bind(volume);
    let (w, h) = (u.width as usize * u.subpixels as usize, u.height as usize);
    let n_bricks = volume.brick_count();
    let ranges = volume.trace_ranges(u.iso, u.inside_sign);
    let pre = prefetch(volume, &ranges, cache, camera, &u, policy, |_, _| {});
    let ranges: &[[f32; 2]] = pre.ranges.as_deref().unwrap_or(&ranges);
    // Slope bounds and skip distances: kept by the cache while the isovalue and what it
    // stores stay the same.
    cache.block_info(volume, ranges, &u);
    let refuted = lipschitz_refuted(&u, ranges, cache.current_block_info());
    // Pixels of the kept frame, where its samples stay resident: a downsampled assignment
    // traces other samples.
    let reuse = kept
        .filter(|_| pre.ranges.is_none())
        .and_then(|k| Reuse::new(k, volume, &u));
    let start = opts
        .start_raster
        .then(|| StartRaster::build(&u, ranges, cache.current_block_info()))
        .flatten();

    // 3–4. Passes. The first traces every ray, each writing its own pixel; later ones the
    // rays that waited for a brick.
    let n = w * h;
    let mut pixels = vec![GSample::default(); n];
    let mut samples = vec![0u32; n];
    let requests: Vec<AtomicU32> = (0..n_bricks).map(|_| AtomicU32::new(0)).collect();
    let used: Vec<AtomicU32> = (0..n_bricks).map(|_| AtomicU32::new(0)).collect();
    let waiting = std::sync::Mutex::new(Vec::new());
    let mut passes = 1u32;
    let reused: u64 = {
        let data = TraceData {
            pool: cache.pool(),
            reference: cache.reference(),
            block_range: ranges,
            block_info: cache.current_block_info(),
            requests: &requests,
            used: &used,
            start: start.as_ref(),
        };
        // Runs of rays per task; each counts the pixels it took from the kept frame.
        const RUN: usize = 64;
        pixels
            .par_chunks_mut(RUN)
            .zip(samples.par_chunks_mut(RUN))
            .enumerate()
            .map(|(run, (pixels, samples))| {
                let mut taken = 0u64;
                for (k, (pixel, count)) in pixels.iter_mut().zip(samples).enumerate() {
                    let i = (run * RUN + k) as u32;
                    let (p, sub) = (i / u.subpixels, i % u.subpixels);
                    let (px, py) = (p % u.width, p / u.width);
                    let kept = reuse.as_ref().and_then(|r| r.pixel(&u, i as usize, px, py));
                    (*pixel, *count) = match kept {
                        Some(k) => {
                            taken += 1;
                            k
                        }
                        None => match kernel::trace_pixel(&u, &data, px, py, sub, None) {
                            PixelResult::Done { sample, samples } => (sample, samples),
                            PixelResult::Suspended { resume, samples } => {
                                let mut list = waiting.lock().unwrap_or_else(|e| e.into_inner());
                                list.push((i, Some(resume)));
                                (GSample::default(), samples)
                            }
                        },
                    };
                }
                taken
            })
            .sum()
    };
    let mut pending: Vec<(u32, Option<Resume>)> =
        waiting.into_inner().unwrap_or_else(|e| e.into_inner());
    pending.sort_unstable_by_key(|&(i, _)| i);
    loop {
        for (n, flag) in used.iter().enumerate() {
            if flag.swap(0, Ordering::Relaxed) != 0 {
                cache.touch(n);
            }
        }
        if pending.is_empty() {
            break;
        }
        load_requested(
            volume,
            cache,
            requests.iter().map(|r| r.swap(0, Ordering::Relaxed)),
        )?;
        passes += 1;
        let data = TraceData {
            pool: cache.pool(),
            reference: cache.reference(),
            block_range: ranges,
            block_info: cache.current_block_info(),
            requests: &requests,
            used: &used,
            start: start.as_ref(),
        };
        let results: Vec<(u32, PixelResult)> = pending
            .par_iter()
            .with_min_len(64)
            .map(|&(i, r)| {
                let (p, sub) = (i / u.subpixels, i % u.subpixels);
                let (px, py) = (p % u.width, p / u.width);
                (i, kernel::trace_pixel(&u, &data, px, py, sub, r))
            })
            .collect();
        pending.clear();
        for (i, r) in results {
            let idx = i as usize;
            match r {
                PixelResult::Done { sample, samples: s } => {
                    pixels[idx] = sample;
                    samples[idx] += s;
                }
                PixelResult::Suspended { resume, samples: s } => {
                    samples[idx] += s;
                    pending.push((i, Some(resume)));
                }
            }
        }
    }
    let stats = frame_stats(
        volume,
        &u,
        &pixels,
        &samples,
        &pre,
        before,
        cache.stats(),
        passes,
        t0.elapsed().as_secs_f64(),
    );
    let stats = RenderStats {
        lipschitz_refuted: refuted,
        rays_reused: reused,
        ..stats
    };
    Ok(Frame {
        gbuffer: GBuffer::new(w as u32, u.height, pixels, samples),
        stats,
        uniforms: u,
    })
}
