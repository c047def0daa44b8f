//! The per-pixel ray caster, written the way its WGSL twin will be written: plain functions
//! over [`Uniforms`] and flat buffers ([`TraceData`]), scalar f32 arithmetic, no allocation,
//! bounded loops. One invocation of [`trace_pixel`] is one GPU thread.
//!
//! ## Coordinates
//! Rays are cast in *grid coordinates* (sample `(i, j, k)` at `(i, j, k)`): the ray origin is
//! `(o_world − origin) / spacing`, the direction stays the unit world direction, so the ray
//! parameter `t` is in voxels and `t · spacing` is the world distance along the ray.
//!
//! ## The algorithm (002 Sec. 6.3, block-level ray casting)
//! 1. The ray is clipped to the box of the samples, `[0, n − 1]³` ([`ray_box`]).
//! 2. A 3D DDA walks the blocks the ray crosses, front to back. Each block's exit is
//!    computed from its index alone ([`block_exit`]), never accumulated, so a ray resumed
//!    at a block (after a cache miss) cuts exactly the same segments.
//! 3. A block whose `[min, max]` does not contain the isovalue is skipped ([`block_active`]).
//!    Otherwise its brick must be resident: if not, the ray records a request for it and
//!    stops; the host loads bricks and resumes it at that block ([`PixelResult::Suspended`]).
//! 4. The segment `[t_in, t_out]` is sampled at `m = ceil(len · r0)` equal steps, both ends
//!    included, so every segment is sampled on its own and no sample depends on other blocks
//!    ([`march_segment`]). An interval of the base rate with an end within `delta` of the
//!    isovalue is resampled `fine` times finer (002 Sec. 6.3.3; checking both ends catches a
//!    thin sheet whose crossing lies before the sample that comes near).
//! 5. A crossing from outside to inside between two samples is refined by a set number of
//!    bisection or secant (Illinois) steps, then linearly interpolated (Eq. 6.4) ([`refine`]).
//! 6. Gradient and Hessian at the hit give the normal and principal curvatures
//!    ([`surface_sample`]), written to the G-buffer ([`GSample`]).
//!
//! Samples are evaluated with their position clamped into the current block's box, so
//! every filter reads only the block's support, which its brick stores (apron 1 before and
//! 2 after) and its `[min, max]` covers.
//!
//! A brick stored at half resolution (reference entry [`HALF_RESOLUTION`] `|` half slot,
//! [`crate::CachePolicy::Downsample`]) is read the same way on its coarse lattice
//! ([`locate_half`]: spacing 2, `brick / 2 + 3` samples per axis, the same apron in coarse
//! samples) with the same filters; derivatives are scaled back to grid units.
//!
//! **Caps.** A ray whose first sample (where it enters the box) lies inside hits there: the
//! volume's box cuts the solid (CT data cut by the scan's field of view, or an isovalue at
//! the data's extreme). The normal is the face's; curvatures are 0; the id is [`ID_CAP`].

use glam::{IVec3, Mat3, Vec3};
use isokit_field::curvature::{DEFAULT_MIN_GRADIENT, Inside, curvature_with};
use isokit_field::filter::TwoFetch;
use std::sync::atomic::{AtomicU32, Ordering};

use crate::cache::{HALF_RESOLUTION, NOT_RESIDENT};

/// [`GSample::id`] of a pixel whose ray hit nothing.
pub const ID_MISS: u32 = 0;
/// [`GSample::id`] of a pixel whose ray hit the isosurface.
pub const ID_SURFACE: u32 = 1;
/// [`GSample::id`] of a pixel whose ray entered the volume inside the solid (a cap).
pub const ID_CAP: u32 = 2;
/// [`GSample::id`] of a pixel whose ray hit the isosurface of a combined volume
/// ([`crate::Volume::with_operand`]) where the second operand B owns the surface (the object
/// map of 002 Sec. 6.4.3); [`ID_SURFACE`] there means the first operand A (and a morph). A
/// surface hit either way: shading treats both alike, the G-buffer's `A` channel is 1.
pub const ID_SURFACE_B: u32 = 3;

/// True for the ids of isosurface hits: [`ID_SURFACE`] and [`ID_SURFACE_B`].
#[inline]
pub fn is_surface_id(id: u32) -> bool {
    id == ID_SURFACE || id == ID_SURFACE_B
}

/// [`Uniforms::combine`]: a single field.
pub const COMBINE_NONE: u32 = 0;
/// [`Uniforms::combine`]: union `min(a', b')` of the residuals.
pub const COMBINE_UNION: u32 = 1;
/// [`Uniforms::combine`]: intersection `max(a', b')`.
pub const COMBINE_INTERSECTION: u32 = 2;
/// [`Uniforms::combine`]: difference `max(a', −b')`.
pub const COMBINE_DIFFERENCE: u32 = 3;
/// [`Uniforms::combine`]: morph `(1 − t)·a' + t·b'`, `t` = [`Uniforms::morph_t`].
pub const COMBINE_MORPH: u32 = 4;

/// [`Uniforms::flags`] bit: skip blocks whose range excludes ρ.
pub const FLAG_SKIP_EMPTY: u32 = 1;
/// [`Uniforms::flags`] bit: report caps where a ray enters the volume inside the solid.
pub const FLAG_CAPS: u32 = 2;
/// [`Uniforms::flags`] bit: refine by the secant method (Illinois); bisection without it.
pub const FLAG_SECANT: u32 = 4;

/// [`Uniforms::filter`] value of the trilinear filter.
pub const FILTER_TRILINEAR: u32 = 0;
/// [`Uniforms::filter`] value of the tricubic B-spline filter (8-fetch scheme).
pub const FILTER_TRICUBIC: u32 = 1;

/// Relative margin added to block ranges before they are compared with the isovalue, so
/// that rounding in the reconstruction (a few ulps of the samples' magnitude) can never
/// produce a crossing in a block judged empty.
pub const RANGE_MARGIN: f32 = 16.0 * f32::EPSILON;

/// Everything a trace pass reads that is the same for all pixels: the GPU uniform buffer.
///
/// `#[repr(C)]`, 16-byte rows (a `[f32; 3]` then a scalar, matching WGSL's
/// `vec3<f32>` + `f32` packing), 208 bytes; `Uniforms` in `shaders/raycast_common.wgsl`.
/// The on/off switches share one word ([`Uniforms::flags`]) so that the combination of two
/// fields ([`Uniforms::combine`], [`Uniforms::morph_t`]) fits the same 208 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Uniforms {
    /// Eye position (perspective) or image-plane centre (orthographic), world.
    pub eye: [f32; 3],
    /// 1 for orthographic projection, 0 for perspective.
    pub ortho: u32,
    /// Unit right vector of the image plane.
    pub right: [f32; 3],
    /// Half the view height at unit distance (perspective) or in world units (orthographic).
    pub half_height: f32,
    /// Unit up vector of the image plane.
    pub up: [f32; 3],
    /// Width over height.
    pub aspect: f32,
    /// Unit viewing direction.
    pub forward: [f32; 3],
    /// Image width in pixels.
    pub width: u32,
    /// World position of sample (0, 0, 0).
    pub origin: [f32; 3],
    /// Sample spacing, world units.
    pub spacing: f32,
    /// Samples along x, y, z.
    pub dims: [u32; 3],
    /// Block edge in cells.
    pub block: u32,
    /// Blocks along x, y, z.
    pub block_dims: [u32; 3],
    /// Brick edge in cells.
    pub brick: u32,
    /// Bricks along x, y, z.
    pub brick_dims: [u32; 3],
    /// Samples per axis of a stored brick (`brick + 3`).
    pub brick_side: u32,
    /// The isovalue ρ.
    pub iso: f32,
    /// +1 when the inside is below ρ (distance fields), −1 when above (densities).
    pub inside_sign: f32,
    /// Base sampling rate r0, samples per voxel.
    pub r0: f32,
    /// Fine-rate factor n (r1 = n · r0); 1 disables adaptive sampling.
    pub fine: u32,
    /// Resample finely where `|f − ρ| < delta` (field units).
    pub delta: f32,
    /// Refinement steps after a crossing is found.
    pub refine_steps: u32,
    /// Switches: [`FLAG_SKIP_EMPTY`] (skip blocks whose range excludes ρ; off, every block
    /// is sampled), [`FLAG_CAPS`] (report caps where a ray enters the volume inside the
    /// solid), [`FLAG_SECANT`] (refine by the secant method; off, bisection).
    pub flags: u32,
    /// Filter of the intersection search: [`FILTER_TRILINEAR`] or [`FILTER_TRICUBIC`].
    pub filter: u32,
    /// Filter of gradient and Hessian at the hit.
    pub shading_filter: u32,
    /// How a second field combines with the first per sample: [`COMBINE_NONE`] (a single
    /// field, one channel per brick slot), [`COMBINE_UNION`], [`COMBINE_INTERSECTION`],
    /// [`COMBINE_DIFFERENCE`], [`COMBINE_MORPH`] (two channels per slot).
    pub combine: u32,
    /// The morph parameter `t` of [`COMBINE_MORPH`].
    pub morph_t: f32,
    /// Image height in pixels.
    pub height: u32,
    /// Views of a multi-view display (001); 1 for an ordinary camera.
    pub views: u32,
    /// The view every ray uses, or −1: each subpixel's view from the lens formula
    /// ([`view_index`]).
    pub view: i32,
    /// Rays per pixel: 1, or 3 (red, green, blue subpixels) in the multi-view geometric pass.
    pub subpixels: u32,
    /// Distance between neighbouring views' eyes along `right`, world units.
    pub view_separation: f32,
    /// Distance from the eye to the plane of zero parallax (the display window).
    pub window_distance: f32,
    /// Subpixels under one lens (the period of the view pattern along a row).
    pub lens_pitch: f32,
    /// Horizontal shift of the lenses per pixel row, in pixels (slanted lenses).
    pub lens_slant: f32,
    /// Shift of the view pattern, in subpixels.
    pub lens_offset: f32,
}

// The WGSL twin, member by member (`Uniforms` in `shaders/raycast_common.wgsl`; checked by
// the GPU host code's unit tests).
isokit_gpu::wgsl_layout!(Uniforms {
    eye: "vec3<f32>",
    ortho: "u32",
    right: "vec3<f32>",
    half_height: "f32",
    up: "vec3<f32>",
    aspect: "f32",
    forward: "vec3<f32>",
    width: "u32",
    origin: "vec3<f32>",
    spacing: "f32",
    dims: "vec3<u32>",
    block: "u32",
    block_dims: "vec3<u32>",
    brick: "u32",
    brick_dims: "vec3<u32>",
    brick_side: "u32",
    iso: "f32",
    inside_sign: "f32",
    r0: "f32",
    fine: "u32",
    delta: "f32",
    refine_steps: "u32",
    flags: "u32",
    filter as "search_filter": "u32",
    shading_filter: "u32",
    combine: "u32",
    morph_t: "f32",
    height: "u32",
    views: "u32",
    view: "i32",
    subpixels: "u32",
    view_separation: "f32",
    window_distance: "f32",
    lens_pitch: "f32",
    lens_slant: "f32",
    lens_offset: "f32",
});

/// The flat buffers one trace pass reads and writes (GPU: storage buffers and textures).
#[derive(Clone, Copy, Debug)]
pub struct TraceData<'a> {
    /// The brick pool: slots of `brick_side³` samples, x fastest ([`crate::BrickCache::pool`]).
    pub pool: &'a [f32],
    /// Slot per brick or [`NOT_RESIDENT`] ([`crate::BrickCache::reference`]).
    pub reference: &'a [u32],
    /// `[min, max]` per block ([`crate::Volume::block_ranges`]).
    pub block_range: &'a [[f32; 2]],
    /// Per brick: how many rays asked for it in this pass (atomic add).
    pub requests: &'a [AtomicU32],
    /// Per brick: set to 1 when a ray sampled it in this pass (for LRU).
    pub used: &'a [AtomicU32],
}

/// Where a suspended ray resumes: the block it waits for and the ray parameter where it
/// enters it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resume {
    /// Block coordinates.
    pub cell: [i32; 3],
    /// Ray parameter (voxels) at the block's entry.
    pub t: f32,
    /// True when no block has been processed yet (the cap test is still due).
    pub first: bool,
}

/// One pixel of the G-buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GSample {
    /// World position of the hit.
    pub position: Vec3,
    /// Distance from the ray origin to the hit along the ray, world units (for perspective
    /// the distance from the eye).
    pub depth: f32,
    /// Unit outward normal.
    pub normal: Vec3,
    /// Largest principal curvature (1/world units; positive where convex).
    pub k1: f32,
    /// Smallest principal curvature.
    pub k2: f32,
    /// Unit principal direction of `k1` (that of `k2` is `normal × dir1`).
    pub dir1: Vec3,
    /// [`ID_MISS`], [`ID_SURFACE`], [`ID_SURFACE_B`] (the second operand of a combined
    /// volume owns the hit) or [`ID_CAP`].
    pub id: u32,
}

impl GSample {
    /// True when the ray hit something (surface or cap): the G-buffer's `A` channel.
    pub fn is_hit(&self) -> bool {
        self.id != ID_MISS
    }
}

/// What one invocation of [`trace_pixel`] produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelResult {
    /// The pixel is finished.
    Done {
        /// Its G-buffer sample.
        sample: GSample,
        /// Field evaluations along the ray (search and refinement).
        samples: u32,
    },
    /// The ray reached an active block whose brick is not resident and asked for it.
    Suspended {
        /// Where to resume.
        resume: Resume,
        /// Field evaluations so far.
        samples: u32,
    },
}

#[inline]
fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// The ray of pixel `(px, py)` through its centre: world origin and unit direction. For a
/// single view it equals [`isokit_field::Camera::ray`] at `(px + 0.5, py + 0.5)`.
pub fn pixel_ray(u: &Uniforms, px: u32, py: u32) -> (Vec3, Vec3) {
    subpixel_ray(u, px, py, 0)
}

/// The view that subpixel `sub` (0 red, 1 green, 2 blue) of pixel `(px, py)` shows: the
/// fixed [`Uniforms::view`], or the lens formula of a slanted lenticular sheet (van Berkel;
/// 001 Fig. 3): `floor(views · frac((3·px + sub + 3·py·slant + offset) / pitch))`.
pub fn view_index(u: &Uniforms, px: u32, py: u32, sub: u32) -> u32 {
    if u.view >= 0 {
        return u.view as u32;
    }
    let x = ((3 * px + sub) as f32 + 3.0 * py as f32 * u.lens_slant + u.lens_offset) / u.lens_pitch;
    let f = x - x.floor();
    ((f * u.views as f32) as u32).min(u.views - 1)
}

/// The ray of subpixel `sub` of pixel `(px, py)`. With several views, the eye of the
/// subpixel's view sits `(v − (views − 1)/2) · view_separation` along `right`, and the ray
/// passes through the pixel's point on the display window at `window_distance` (an
/// off-axis frustum per view, 001 Fig. 2), so all views agree in the window plane.
pub fn subpixel_ray(u: &Uniforms, px: u32, py: u32, sub: u32) -> (Vec3, Vec3) {
    let h = u.half_height;
    let sx = (2.0 * (px as f32 + 0.5) / u.width as f32 - 1.0) * h * u.aspect;
    let sy = (1.0 - 2.0 * (py as f32 + 0.5) / u.height as f32) * h;
    let (right, up, forward) = (v3(u.right), v3(u.up), v3(u.forward));
    if u.ortho != 0 {
        return (v3(u.eye) + sx * right + sy * up, forward);
    }
    if u.views <= 1 {
        return (v3(u.eye), (forward + sx * right + sy * up).normalize());
    }
    let v = view_index(u, px, py, sub);
    let shift = (v as f32 - 0.5 * (u.views - 1) as f32) * u.view_separation;
    let window = u.window_distance * (forward + sx * right + sy * up);
    (
        v3(u.eye) + shift * right,
        (window - shift * right).normalize(),
    )
}

/// Signed distance from the isovalue in the inside convention: `(f − ρ) · inside_sign`,
/// negative inside, positive outside, NaN for NaN samples (which are neither).
#[inline]
pub fn residual(u: &Uniforms, f: f32) -> f32 {
    (f - u.iso) * u.inside_sign
}

/// True when a block with this `[min, max]` must be sampled: always when skipping is off,
/// else when ρ lies in the range widened by [`RANGE_MARGIN`].
#[inline]
pub fn block_active(u: &Uniforms, range: [f32; 2]) -> bool {
    if u.flags & FLAG_SKIP_EMPTY == 0 {
        return true;
    }
    let eps = RANGE_MARGIN * range[0].abs().max(range[1].abs());
    range[0] - eps <= u.iso && u.iso <= range[1] + eps
}

/// The ray `o + t·d` (grid coordinates) clipped to the samples' box `[0, n − 1]³` and to
/// `t >= 0`: `(t_enter, t_exit, axis)` where `axis` is the axis of the face it enters through
/// (3 when it starts inside the box), or `None` when it misses.
pub fn ray_box(u: &Uniforms, o: Vec3, d: Vec3) -> Option<(f32, f32, u32)> {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    let mut axis = 3u32;
    for a in 0..3 {
        let hi = (u.dims[a] - 1) as f32;
        if d[a] == 0.0 {
            if o[a] < 0.0 || o[a] > hi {
                return None;
            }
            continue;
        }
        let (ta, tb) = ((0.0 - o[a]) / d[a], (hi - o[a]) / d[a]);
        let (near, far) = (ta.min(tb), ta.max(tb));
        if near > t0 {
            t0 = near;
            axis = a as u32;
        }
        t1 = t1.min(far);
    }
    (t0 <= t1 && t0.is_finite()).then_some((t0, t1, axis))
}

/// Where the ray leaves block `cell`: the smallest `t` at which it crosses one of the block's
/// exit faces, and that face's axis. Computed from the block index alone.
#[inline]
pub fn block_exit(u: &Uniforms, cell: IVec3, o: Vec3, d: Vec3) -> (f32, usize) {
    let b = u.block as f32;
    let mut t = f32::INFINITY;
    let mut axis = 0;
    for a in 0..3 {
        if d[a] != 0.0 {
            let edge = (cell[a] + i32::from(d[a] > 0.0)) as f32 * b;
            let ta = (edge - o[a]) / d[a];
            if ta < t {
                t = ta;
                axis = a;
            }
        }
    }
    (t, axis)
}

/// Linear index of block `cell`.
#[inline]
pub fn block_index(u: &Uniforms, cell: IVec3) -> usize {
    let [bx, by, _] = u.block_dims;
    cell.x as usize + bx as usize * (cell.y as usize + by as usize * cell.z as usize)
}

/// Linear index of the brick holding block `cell`.
#[inline]
pub fn brick_of_block(u: &Uniforms, cell: IVec3) -> usize {
    let c = cell / (u.brick / u.block) as i32;
    let [bx, by, _] = u.brick_dims;
    c.x as usize + bx as usize * (c.y as usize + by as usize * c.z as usize)
}

/// A sample position resolved to its brick slot: the slot's first index in the pool, the
/// cell within the stored brick and the position in that cell (`[0, 1]³`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Located {
    /// Index of the slot's first sample in the pool.
    pub base: usize,
    /// Cell in the stored brick's local sample coordinates.
    pub cell: IVec3,
    /// Position inside the cell.
    pub frac: Vec3,
    /// The (clamped) position in grid coordinates.
    pub p: Vec3,
    /// Samples per axis of the stored brick: `brick_side`, or `brick / 2 + 3` for a brick
    /// stored at half resolution.
    pub side: usize,
    /// True for a brick stored at half resolution: `cell` and `frac` are on its coarse
    /// lattice (spacing 2), derivatives are scaled back to grid units.
    pub half: bool,
}

/// Resolves grid position `p` in block `cell` whose brick sits in `slot`: `p` is clamped to
/// the block's box and the cell index to the block's cells (so a point on the far face
/// uses the last cell at fraction 1), which keeps every filter tap inside the brick.
#[inline]
pub fn locate(u: &Uniforms, slot: u32, cell: IVec3, p: Vec3) -> Located {
    let b = u.block as i32;
    let top = IVec3::new(u.dims[0] as i32, u.dims[1] as i32, u.dims[2] as i32) - 1;
    let lo = cell * b;
    let hi = (lo + IVec3::splat(b)).min(top);
    let q = p.clamp(lo.as_vec3(), hi.as_vec3());
    // The cell and fraction in grid coordinates (exact, as the dense filters split them),
    // then the cell relative to the brick's first stored sample.
    if slot & HALF_RESOLUTION != 0 {
        return locate_half(u, slot, cell, lo, hi, q);
    }
    let c = q.floor().as_ivec3().clamp(lo, hi - IVec3::ONE);
    let first = cell / (u.brick / u.block) as i32 * u.brick as i32 - IVec3::ONE;
    let side = u.brick_side as usize;
    Located {
        base: slot as usize * channels(u) * side * side * side,
        cell: c - first,
        frac: q - c.as_vec3(),
        p: q,
        side,
        half: false,
    }
}

/// [`locate`] in a brick stored at half resolution (`slot` is [`HALF_RESOLUTION`] `|` its
/// half slot): the clamped position `q` in coarse coordinates relative to the brick's
/// corner, `(q − corner) / 2`; the coarse cell clamped to the block's coarse cells
/// `[(lo − corner) / 2, ceil((hi − corner) / 2))` (a block of an odd number of cells at the
/// grid's end ends inside its last coarse cell); the stored coarse brick starts one coarse
/// sample before the corner.
#[inline]
pub fn locate_half(u: &Uniforms, slot: u32, cell: IVec3, lo: IVec3, hi: IVec3, q: Vec3) -> Located {
    let corner = cell / (u.brick / u.block) as i32 * u.brick as i32;
    let pc = (q - corner.as_vec3()) * 0.5;
    let clo = (lo - corner) / 2;
    let chi = (hi - corner + IVec3::ONE) / 2;
    let c = pc.floor().as_ivec3().clamp(clo, chi - IVec3::ONE);
    let side = (u.brick / 2 + 3) as usize;
    Located {
        base: (slot & !HALF_RESOLUTION) as usize * channels(u) * side * side * side,
        cell: c + IVec3::ONE,
        frac: pc - c.as_vec3(),
        p: q,
        side,
        half: true,
    }
}

/// Fields per brick slot: 1, or 2 when a second field is combined (channel B follows A).
#[inline]
pub fn channels(u: &Uniforms) -> usize {
    if u.combine == COMBINE_NONE { 1 } else { 2 }
}

/// The same point in channel B of its slot (the second field).
#[inline]
pub fn channel_b(_u: &Uniforms, l: &Located) -> Located {
    let side = l.side;
    Located {
        base: l.base + side * side * side,
        ..*l
    }
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// The emulated texture fetch: trilinear interpolation in cell `c` of the slot at `base`,
/// position `t` in `[0, 1]³`. WGSL twin: 8 `textureLoad`s (or storage-buffer reads) and 7
/// `mix`, in this order (x, then y, then z), as in [`isokit_field::filter`]'s fetch.
#[inline]
pub fn fetch(pool: &[f32], side: usize, base: usize, c: IVec3, t: Vec3) -> f32 {
    let i = base + c.x as usize + side * (c.y as usize + side * c.z as usize);
    let (sy, sz) = (side, side * side);
    let x00 = lerp(pool[i], pool[i + 1], t.x);
    let x10 = lerp(pool[i + sy], pool[i + sy + 1], t.x);
    let x01 = lerp(pool[i + sz], pool[i + sz + 1], t.x);
    let x11 = lerp(pool[i + sy + sz], pool[i + sy + sz + 1], t.x);
    lerp(lerp(x00, x10, t.y), lerp(x01, x11, t.y), t.z)
}

/// `N` linear fetches along one axis (cells `c + cell[n]`, positions `t[n]`, weights
/// `w[n]`): the per-axis taps of the 8-fetch scheme (`N = 2`; 3 for a second derivative).
#[derive(Clone, Copy, Debug)]
struct Taps<const N: usize> {
    cell: [i32; N],
    t: [f32; N],
    w: [f32; N],
}

impl Taps<2> {
    /// Two fetches at `i − 1 + t0` and `i + 1 + t1`, weights `g0, g1` (ERRATA 4 and 5).
    #[inline]
    fn two(f: TwoFetch) -> Self {
        Self {
            cell: [-1, 1],
            t: [f.t0, f.t1],
            w: [f.g0, f.g1],
        }
    }
}

impl Taps<3> {
    /// Second derivative: fetches at `x − 1, x, x + 1` weighted `(1, −2, 1)` (Listing 5.4).
    #[inline]
    fn three(a: f32) -> Self {
        Self {
            cell: [-1, 0, 1],
            t: [a; 3],
            w: [1.0, -2.0, 1.0],
        }
    }
}

/// `Σx wx Σy wy Σz wz fetch(c + (cx, cy, cz), (tx, ty, tz))`, accumulated in this order
/// (as [`isokit_field::filter`] does, so the results agree bit for bit).
#[inline]
fn fetch_sum<const X: usize, const Y: usize, const Z: usize>(
    pool: &[f32],
    side: usize,
    l: &Located,
    x: &Taps<X>,
    y: &Taps<Y>,
    z: &Taps<Z>,
) -> f32 {
    let mut sx = 0.0f32;
    for ix in 0..X {
        let mut sy = 0.0f32;
        for iy in 0..Y {
            let mut sz = 0.0f32;
            for iz in 0..Z {
                let c = l.cell + IVec3::new(x.cell[ix], y.cell[iy], z.cell[iz]);
                let t = Vec3::new(x.t[ix], y.t[iy], z.t[iz]);
                sz += z.w[iz] * fetch(pool, side, l.base, c, t);
            }
            sy += y.w[iy] * sz;
        }
        sx += x.w[ix] * sy;
    }
    sx
}

/// The reconstructed value at a located point: trilinear (one fetch) or tricubic B-spline
/// (8 fetches). Bit-for-bit the value of [`isokit_field::filter::trilinear`] and
/// [`isokit_field::filter::tricubic_bspline_fast`] on the dense grid.
#[inline]
pub fn value_at(_u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> f32 {
    let side = l.side;
    if filter == FILTER_TRILINEAR {
        return fetch(pool, side, l.base, l.cell, l.frac);
    }
    let b = [l.frac.x, l.frac.y, l.frac.z].map(|a| Taps::two(TwoFetch::bspline(a)));
    fetch_sum(pool, side, l, &b[0], &b[1], &b[2])
}

/// Value, gradient and Hessian at a located point, in grid units. Tricubic: the 8-fetch
/// scheme of [`isokit_field::filter::tricubic_bspline_derivatives_fast`] (8 + 24 + 60
/// fetches). Trilinear: the interpolant of the cell (8 samples), whose Hessian has a zero
/// diagonal.
pub fn derivatives_at(u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> (f32, Vec3, Mat3) {
    let (g, h) = gradient_hessian_at(u, pool, filter, l);
    (value_at(u, pool, filter, l), g, h)
}

/// Gradient and Hessian at a located point, in grid units (see [`derivatives_at`]); what
/// shading needs (84 fetches for the tricubic filter).
/// For a brick stored at half resolution the coarse lattice's derivatives are scaled back
/// to grid units (gradient · 1/2, Hessian · 1/4).
pub fn gradient_hessian_at(u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> (Vec3, Mat3) {
    let (g, h) = stored_gradient_hessian(u, pool, filter, l);
    if l.half {
        return (g * 0.5, h * 0.25);
    }
    (g, h)
}

/// Gradient and Hessian in the stored brick's own units (see [`gradient_hessian_at`]).
fn stored_gradient_hessian(_u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> (Vec3, Mat3) {
    let side = l.side;
    if filter == FILTER_TRILINEAR {
        let i = l.base + l.cell.x as usize + side * (l.cell.y as usize + side * l.cell.z as usize);
        let s = |dx: usize, dy: usize, dz: usize| pool[i + dx + side * (dy + side * dz)];
        let t = l.frac;
        // Differences along each axis, interpolated over the other two.
        let ex = |dy, dz| s(1, dy, dz) - s(0, dy, dz);
        let ey = |dx, dz| s(dx, 1, dz) - s(dx, 0, dz);
        let ez = |dx, dy| s(dx, dy, 1) - s(dx, dy, 0);
        let gx = lerp(
            lerp(ex(0, 0), ex(1, 0), t.y),
            lerp(ex(0, 1), ex(1, 1), t.y),
            t.z,
        );
        let gy = lerp(
            lerp(ey(0, 0), ey(1, 0), t.x),
            lerp(ey(0, 1), ey(1, 1), t.x),
            t.z,
        );
        let gz = lerp(
            lerp(ez(0, 0), ez(1, 0), t.x),
            lerp(ez(0, 1), ez(1, 1), t.x),
            t.y,
        );
        let hxy = lerp(ex(1, 0) - ex(0, 0), ex(1, 1) - ex(0, 1), t.z);
        let hxz = lerp(ex(0, 1) - ex(0, 0), ex(1, 1) - ex(1, 0), t.y);
        let hyz = lerp(ey(0, 1) - ey(0, 0), ey(1, 1) - ey(1, 0), t.x);
        let h = Mat3::from_cols(
            Vec3::new(0.0, hxy, hxz),
            Vec3::new(hxy, 0.0, hyz),
            Vec3::new(hxz, hyz, 0.0),
        );
        return (Vec3::new(gx, gy, gz), h);
    }
    let a = [l.frac.x, l.frac.y, l.frac.z];
    let b = a.map(|a| Taps::two(TwoFetch::bspline(a)));
    let d = a.map(|a| Taps::two(TwoFetch::bspline_d1(a)));
    let s = a.map(Taps::three);
    let g = Vec3::new(
        fetch_sum(pool, side, l, &d[0], &b[1], &b[2]),
        fetch_sum(pool, side, l, &b[0], &d[1], &b[2]),
        fetch_sum(pool, side, l, &b[0], &b[1], &d[2]),
    );
    let hxx = fetch_sum(pool, side, l, &s[0], &b[1], &b[2]);
    let hyy = fetch_sum(pool, side, l, &b[0], &s[1], &b[2]);
    let hzz = fetch_sum(pool, side, l, &b[0], &b[1], &s[2]);
    let hxy = fetch_sum(pool, side, l, &d[0], &d[1], &b[2]);
    let hxz = fetch_sum(pool, side, l, &d[0], &b[1], &d[2]);
    let hyz = fetch_sum(pool, side, l, &b[0], &d[1], &d[2]);
    let h = Mat3::from_cols(
        Vec3::new(hxx, hxy, hxz),
        Vec3::new(hxy, hyy, hyz),
        Vec3::new(hxz, hyz, hzz),
    );
    (g, h)
}

/// A ray inside one resident block: what [`march_segment`] and [`refine`] sample.
#[derive(Clone, Copy, Debug)]
pub struct SegmentRay {
    /// Ray origin, grid coordinates.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// The block.
    pub cell: IVec3,
    /// Its brick's slot.
    pub slot: u32,
}

impl SegmentRay {
    #[inline]
    fn residual_at(&self, u: &Uniforms, pool: &[f32], t: f32, samples: &mut u32) -> f32 {
        *samples += 1;
        let l = locate(u, self.slot, self.cell, self.o + t * self.d);
        combined_residual(u, pool, u.filter, &l)
    }
}

/// Combines the residuals `a' = s(a − ρ)` and `b'` of the two fields (see
/// [`crate::Combine`]): union `min`, intersection `max`, difference `max(a', −b')`, morph
/// `(1 − t)·a' + t·b'`. Ties go to A; the comparisons are written out (`b' < a'`) as in
/// the WGSL twin, so a NaN in B yields A's residual, a NaN in A a NaN.
#[inline]
pub fn combine(u: &Uniforms, a: f32, b: f32) -> f32 {
    match u.combine {
        COMBINE_UNION => {
            if b < a {
                b
            } else {
                a
            }
        }
        COMBINE_INTERSECTION => {
            if b > a {
                b
            } else {
                a
            }
        }
        COMBINE_DIFFERENCE => {
            if -b > a {
                -b
            } else {
                a
            }
        }
        COMBINE_MORPH => (1.0 - u.morph_t) * a + u.morph_t * b,
        _ => a,
    }
}

/// True when B attains the combination of `a'` and `b'` ([`combine`]): the object map.
/// Never for a single field or a morph.
#[inline]
pub fn owner_is_b(u: &Uniforms, a: f32, b: f32) -> bool {
    match u.combine {
        COMBINE_UNION => b < a,
        COMBINE_INTERSECTION => b > a,
        COMBINE_DIFFERENCE => -b > a,
        _ => false,
    }
}

/// The residual of the (combined) field at a located point: `s(f − ρ)` of the single
/// field, or [`combine`] of both fields' residuals (each reconstructed with `filter`). The
/// combined field's value is `ρ + s·residual`; the ray caster only needs the residual.
#[inline]
pub fn combined_residual(u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> f32 {
    let a = residual(u, value_at(u, pool, filter, l));
    if u.combine == COMBINE_NONE {
        return a;
    }
    let b = residual(u, value_at(u, pool, filter, &channel_b(u, l)));
    combine(u, a, b)
}

/// Gradient and Hessian of the (combined) field at a hit, in grid units, and the id of the
/// operand that owns it: the single field's ([`ID_SURFACE`]); for union, intersection and
/// difference those of the operand attaining the combination at the point (by the search
/// filter's values), B's negated for a difference (its complement), with
/// [`ID_SURFACE_B`] when B owns it; for a morph `(1 − t)·A + t·B` of both ([`ID_SURFACE`]).
pub fn owner_gradient_hessian(u: &Uniforms, pool: &[f32], l: &Located) -> (Vec3, Mat3, u32) {
    if u.combine == COMBINE_NONE {
        let (g, h) = gradient_hessian_at(u, pool, u.shading_filter, l);
        return (g, h, ID_SURFACE);
    }
    let lb = channel_b(u, l);
    if u.combine == COMBINE_MORPH {
        let (ga, ha) = gradient_hessian_at(u, pool, u.shading_filter, l);
        let (gb, hb) = gradient_hessian_at(u, pool, u.shading_filter, &lb);
        let (wa, wb) = (1.0 - u.morph_t, u.morph_t);
        return (wa * ga + wb * gb, ha * wa + hb * wb, ID_SURFACE);
    }
    let a = residual(u, value_at(u, pool, u.filter, l));
    let b = residual(u, value_at(u, pool, u.filter, &lb));
    if !owner_is_b(u, a, b) {
        let (g, h) = gradient_hessian_at(u, pool, u.shading_filter, l);
        return (g, h, ID_SURFACE);
    }
    let (g, h) = gradient_hessian_at(u, pool, u.shading_filter, &lb);
    if u.combine == COMBINE_DIFFERENCE {
        (-g, -h, ID_SURFACE_B)
    } else {
        (g, h, ID_SURFACE_B)
    }
}

/// What [`march_segment`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Segment {
    /// No crossing.
    Empty,
    /// The first sample lies inside and it was the ray's first: a cap at the segment start.
    Cap,
    /// A crossing between `ta` (residual `ra >= 0`) and `tb` (`rb < 0`).
    Crossing {
        /// Outside end.
        ta: f32,
        /// Its residual.
        ra: f32,
        /// Inside end.
        tb: f32,
        /// Its residual.
        rb: f32,
    },
}

/// Samples the segment `[t0, t1]` of a block for the first crossing from outside to inside
/// (see the module docs, step 4). `first` asks for the cap test on the first sample.
pub fn march_segment(
    u: &Uniforms,
    pool: &[f32],
    ray: &SegmentRay,
    t0: f32,
    t1: f32,
    first: bool,
    samples: &mut u32,
) -> Segment {
    let mut ta = t0;
    let mut ra = ray.residual_at(u, pool, t0, samples);
    if first && ra < 0.0 {
        return Segment::Cap;
    }
    let len = t1 - t0;
    if len.is_nan() || len <= 0.0 {
        return Segment::Empty;
    }
    // At most a block's diagonal (√3 · 32 voxels) times r0 (at most 64): fits in u32.
    let m = (len * u.r0).ceil().max(1.0) as u32;
    let step = len / m as f32;
    for k in 1..=m {
        let tb = if k == m { t1 } else { t0 + k as f32 * step };
        let rb = ray.residual_at(u, pool, tb, samples);
        if u.fine > 1 && (ra.abs() < u.delta || rb.abs() < u.delta) {
            let (mut tp, mut rp) = (ta, ra);
            let h = (tb - ta) / u.fine as f32;
            for j in 1..=u.fine {
                let (tj, rj) = if j == u.fine {
                    (tb, rb)
                } else {
                    let t = ta + j as f32 * h;
                    (t, ray.residual_at(u, pool, t, samples))
                };
                if rp >= 0.0 && rj < 0.0 {
                    return Segment::Crossing {
                        ta: tp,
                        ra: rp,
                        tb: tj,
                        rb: rj,
                    };
                }
                (tp, rp) = (tj, rj);
            }
        } else if ra >= 0.0 && rb < 0.0 {
            return Segment::Crossing { ta, ra, tb, rb };
        }
        (ta, ra) = (tb, rb);
    }
    Segment::Empty
}

/// The root of the linear interpolant between `(ta, ra)` and `(tb, rb)` (Eq. 6.4), or the
/// midpoint when that is not a number in `[ta, tb]`.
#[inline]
pub fn secant(ta: f32, ra: f32, tb: f32, rb: f32) -> f32 {
    let t = ta + (tb - ta) * (ra / (ra - rb));
    if t.is_finite() {
        t.clamp(ta.min(tb), ta.max(tb))
    } else {
        0.5 * (ta + tb)
    }
}

/// Refines a crossing (`ra >= 0 > rb`) with `refine_steps` steps of bisection or of the
/// secant method (Illinois: an end kept twice has its residual halved for the next
/// estimate), keeping the bracket, and returns the linear interpolation in the final
/// bracket (002 Sec. 6.3.4).
#[expect(
    clippy::too_many_arguments,
    reason = "the bracket ends and the ray, as the shader passes them"
)]
pub fn refine(
    u: &Uniforms,
    pool: &[f32],
    ray: &SegmentRay,
    mut ta: f32,
    mut ra: f32,
    mut tb: f32,
    mut rb: f32,
    samples: &mut u32,
) -> f32 {
    let (mut wa, mut wb) = (ra, rb);
    let mut last = 0i32;
    for _ in 0..u.refine_steps {
        let tm = if u.flags & FLAG_SECANT == 0 {
            0.5 * (ta + tb)
        } else {
            secant(ta, wa, tb, wb)
        };
        let rm = ray.residual_at(u, pool, tm, samples);
        if rm < 0.0 {
            (tb, rb, wb) = (tm, rm, rm);
            if last == 1 {
                wa *= 0.5;
            }
            last = 1;
        } else {
            (ta, ra, wa) = (tm, rm, rm);
            if last == -1 {
                wb *= 0.5;
            }
            last = -1;
        }
    }
    secant(ta, ra, tb, rb)
}

/// The G-buffer sample at ray parameter `t` in a resident block: position, depth, and from
/// the shading filter's gradient and Hessian (converted to world units) the outward normal,
/// principal curvatures and direction. Flat gradients give the normal `−d` and zero
/// curvature. With two fields, the owner's derivatives and id
/// ([`owner_gradient_hessian`]).
pub fn surface_sample(u: &Uniforms, pool: &[f32], ray: &SegmentRay, t: f32) -> GSample {
    let l = locate(u, ray.slot, ray.cell, ray.o + t * ray.d);
    let (g, h, id) = owner_gradient_hessian(u, pool, &l);
    let inv = 1.0 / u.spacing;
    let inside = if u.inside_sign > 0.0 {
        Inside::Below
    } else {
        Inside::Above
    };
    let position = v3(u.origin) + u.spacing * l.p;
    let depth = t * u.spacing;
    match curvature_with(g * inv, h * (inv * inv), inside, DEFAULT_MIN_GRADIENT) {
        Some(c) => GSample {
            position,
            depth,
            normal: c.normal,
            k1: c.k1,
            k2: c.k2,
            dir1: c.dir1,
            id,
        },
        None => GSample {
            position,
            depth,
            normal: -ray.d,
            dir1: ray.d.any_orthonormal_vector(),
            id,
            ..GSample::default()
        },
    }
}

fn cap_sample(u: &Uniforms, o: Vec3, d: Vec3, t: f32, axis: u32) -> GSample {
    let normal = if axis < 3 {
        let mut n = Vec3::ZERO;
        n[axis as usize] = -d[axis as usize].signum();
        n
    } else {
        -d
    };
    GSample {
        position: v3(u.origin) + u.spacing * (o + t * d),
        depth: t * u.spacing,
        normal,
        dir1: normal.any_orthonormal_vector(),
        id: ID_CAP,
        ..GSample::default()
    }
}

/// Traces the ray of subpixel `sub` of pixel `(px, py)` (`sub` is 0 unless
/// [`Uniforms::subpixels`] is 3), from its start or from `resume` (see the module docs).
pub fn trace_pixel(
    u: &Uniforms,
    data: &TraceData<'_>,
    px: u32,
    py: u32,
    sub: u32,
    resume: Option<Resume>,
) -> PixelResult {
    let mut samples = 0u32;
    let miss = |samples| PixelResult::Done {
        sample: GSample::default(),
        samples,
    };
    let (ro, d) = subpixel_ray(u, px, py, sub);
    let o = (ro - v3(u.origin)) / u.spacing;
    let Some((t_enter, t_exit, entry_axis)) = ray_box(u, o, d) else {
        return miss(samples);
    };
    let bd = IVec3::new(
        u.block_dims[0] as i32,
        u.block_dims[1] as i32,
        u.block_dims[2] as i32,
    );
    let (mut cell, mut t_in, mut first) = match resume {
        Some(r) => (IVec3::from_array(r.cell), r.t, r.first),
        None => {
            let p = o + t_enter * d;
            let c = (p / u.block as f32).floor().as_ivec3();
            (c.clamp(IVec3::ZERO, bd - 1), t_enter, true)
        }
    };
    let step = IVec3::new(
        if d.x > 0.0 { 1 } else { -1 },
        if d.y > 0.0 { 1 } else { -1 },
        if d.z > 0.0 { 1 } else { -1 },
    );
    // Each step moves one block coordinate monotonically: at most the sum of the dims.
    let max_steps = u.block_dims.iter().sum::<u32>() + 3;
    for _ in 0..max_steps {
        let (t_out, axis) = block_exit(u, cell, o, d);
        let t1 = t_out.min(t_exit);
        let range = data.block_range[block_index(u, cell)];
        if block_active(u, range) {
            let brick = brick_of_block(u, cell);
            let slot = data.reference[brick];
            if slot == NOT_RESIDENT {
                data.requests[brick].fetch_add(1, Ordering::Relaxed);
                return PixelResult::Suspended {
                    resume: Resume {
                        cell: cell.to_array(),
                        t: t_in,
                        first,
                    },
                    samples,
                };
            }
            data.used[brick].store(1, Ordering::Relaxed);
            let ray = SegmentRay { o, d, cell, slot };
            let caps = first && u.flags & FLAG_CAPS != 0;
            // A segment of zero length (the ray crosses a block edge or corner) holds no
            // crossing; only the cap test needs its sample.
            let seg = if t1 > t_in || caps {
                march_segment(u, data.pool, &ray, t_in, t1.max(t_in), caps, &mut samples)
            } else {
                Segment::Empty
            };
            match seg {
                Segment::Empty => {}
                Segment::Cap => {
                    return PixelResult::Done {
                        sample: cap_sample(u, o, d, t_in, entry_axis),
                        samples,
                    };
                }
                Segment::Crossing { ta, ra, tb, rb } => {
                    let t = refine(u, data.pool, &ray, ta, ra, tb, rb, &mut samples);
                    return PixelResult::Done {
                        sample: surface_sample(u, data.pool, &ray, t),
                        samples,
                    };
                }
            }
        } else if first
            && u.flags & FLAG_CAPS != 0
            && residual(u, range[0]) < 0.0
            && residual(u, range[1]) < 0.0
        {
            // A skipped block entirely inside: its first sample would be inside too.
            return PixelResult::Done {
                sample: cap_sample(u, o, d, t_in, entry_axis),
                samples,
            };
        }
        first = false;
        if t1 >= t_exit {
            break;
        }
        cell[axis] += step[axis];
        if cell[axis] < 0 || cell[axis] >= bd[axis] {
            break;
        }
        t_in = t1.max(t_in);
    }
    miss(samples)
}
