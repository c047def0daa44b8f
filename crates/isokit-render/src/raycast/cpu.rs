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

use glam::{IVec3, Mat3, Mat4, Vec3, Vec4};
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
/// [`Uniforms::flags`] bit: search active blocks by sphere tracing with the slope bounds of
/// [`TraceData::block_info`] ([`march_sphere`]); without it, the adaptive fixed-rate search
/// ([`march_segment`]).
pub const FLAG_SPHERE: u32 = 8;
/// [`Uniforms::flags`] bit: compute the Hessian and the principal curvatures at each hit;
/// without it, the gradient (the normal) only.
pub const FLAG_CURVATURE: u32 = 16;

/// Stop refining once an estimate lies this close to the surface, in voxels (its residual
/// over the first bracket's mean slope); the hit is then the linear interpolation in the
/// bracket that estimate closes, which is far closer. Well above f32 rounding of the
/// residual, so that both twins stop after the same step.
pub const REFINE_TOLERANCE: f32 = 3e-5;

/// Relative margin on a block's slope bound before sphere tracing divides by it, so that
/// rounding in the reconstruction cannot let a step land past a crossing.
pub const SLOPE_MARGIN: f32 = 1.0 / 1024.0;

/// Relative margin, per unit of the ray's coordinates, taken off a bound handed from one
/// block to the next ([`march_sphere`]): the two blocks place the same face point from their
/// own segment starts, a few ulps of `|o| + t` apart, so the next block's residual there may
/// be lower by `slope` times that.
pub const CARRY_MARGIN: f32 = 4.0 * f32::EPSILON;

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
    /// Fixed-rate search: resample finely where `|f − ρ| < delta` (field units). Sphere
    /// tracing ([`FLAG_SPHERE`]): a given bound on the field's slope per voxel (field
    /// units; `L · spacing` for a bound `L` on `|∇f|`), or 0 to step by the slope bounds
    /// measured per block.
    pub delta: f32,
    /// Refinement steps after a crossing is found.
    pub refine_steps: u32,
    /// Switches: [`FLAG_SKIP_EMPTY`] (skip blocks whose range excludes ρ; off, every block
    /// is sampled), [`FLAG_CAPS`] (report caps where a ray enters the volume inside the
    /// solid), [`FLAG_SECANT`] (refine by the secant method; off, bisection),
    /// [`FLAG_SPHERE`] (sphere tracing; off, the fixed-rate search), [`FLAG_CURVATURE`]
    /// (Hessian and curvatures at hits).
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
    /// Per block: the slope bounds of the field along x, y, z per voxel
    /// ([`crate::Volume::trace_slopes`]) and, as a whole number, the Chebyshev distance in
    /// blocks to the nearest active block (0 when active; a ray crosses the inactive cube
    /// of blocks within that distance minus one in one step, [`jump`]). Empty: no jumps,
    /// and the fixed-rate search even where [`FLAG_SPHERE`] asks for sphere tracing.
    pub block_info: &'a [[f32; 4]],
    /// Per brick: how many rays asked for it in this pass (atomic add).
    pub requests: &'a [AtomicU32],
    /// Per brick: set to 1 when a ray sampled it in this pass (for LRU).
    pub used: &'a [AtomicU32],
    /// Where each pixel's walk may start and where it may end ([`crate::StartRaster`]): CPU
    /// only; `None` walks from the box entry to its exit, as the WGSL twin does. The image is
    /// the same either way.
    pub start: Option<&'a crate::StartRaster>,
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
    /// A lower bound on the residual where the ray enters the block (0: none known), carried
    /// from the blocks before it ([`march_sphere`]).
    pub clear: f32,
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
    u.flags & FLAG_SKIP_EMPTY == 0 || range_holds_iso(u, range)
}

/// True when ρ lies in the range widened by [`RANGE_MARGIN`]: the block may hold the surface.
#[inline]
pub fn range_holds_iso(u: &Uniforms, range: [f32; 2]) -> bool {
    let eps = RANGE_MARGIN * range[0].abs().max(range[1].abs());
    range[0] - eps <= u.iso && u.iso <= range[1] + eps
}

/// The ray `o + t·d` (grid coordinates) clipped to the samples' box `[0, n − 1]³` and to
/// `t >= 0`: `(t_enter, t_exit, axis)` where `axis` is the axis of the face it enters through
/// (3 when it starts inside the box), or `None` when it misses.
pub fn ray_box(u: &Uniforms, o: Vec3, d: Vec3) -> Option<(f32, f32, u32)> {
    let (o, d) = (o.to_array(), d.to_array());
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

/// The ray parameter where the ray crosses the plane `x_a = m · block` of axis `a`, from
/// the ray's origin `o` and inverse direction `inv = 1 / d` along that axis (`d` not 0):
/// `(m · block − o) · inv`, the one expression every block face is computed by, so that
/// faces reached by different walks agree bit for bit (and monotone in `m`).
#[inline]
pub fn plane_t(u: &Uniforms, m: i32, o: f32, inv: f32) -> f32 {
    (m as f32 * u.block as f32 - o) * inv
}

/// `1 / d` per axis, as [`plane_t`] takes it (infinite where `d` is 0: those axes are never
/// crossed and never read).
#[inline]
pub fn inverse_direction(d: Vec3) -> Vec3 {
    Vec3::ONE / d
}

/// Where the ray leaves block `cell`: the smallest `t` at which it crosses one of the block's
/// exit faces, and that face's axis (the lowest of tied axes). Computed from the block index
/// alone.
#[inline]
pub fn block_exit(u: &Uniforms, cell: IVec3, o: Vec3, d: Vec3) -> (f32, usize) {
    block_exit_inv(u, cell, o, d, inverse_direction(d))
}

/// [`block_exit`] with the inverse direction given (computed once per ray).
#[inline]
pub fn block_exit_inv(u: &Uniforms, cell: IVec3, o: Vec3, d: Vec3, inv: Vec3) -> (f32, usize) {
    first_face(exit_faces(u, cell, o, d, inv))
}

/// The [`plane_t`] of block `cell`'s exit face on each axis, infinite on axes the ray
/// does not cross (`d` 0): what [`first_face`] chooses from. A walk keeps them and, on a
/// step along one axis, recomputes that axis's alone ([`exit_face`]).
#[inline]
pub fn exit_faces(u: &Uniforms, cell: IVec3, o: Vec3, d: Vec3, inv: Vec3) -> [f32; 3] {
    [0, 1, 2].map(|a| exit_face(u, cell[a], o[a], d[a], inv[a]))
}

/// One axis of [`exit_faces`]: the plane the ray leaves block coordinate `c` through.
#[inline]
pub fn exit_face(u: &Uniforms, c: i32, o: f32, d: f32, inv: f32) -> f32 {
    if d != 0.0 {
        plane_t(u, c + i32::from(d > 0.0), o, inv)
    } else {
        f32::INFINITY
    }
}

/// The first of the exit faces ([`exit_faces`]): its time and axis, the lowest of tied
/// axes (axis 0 where none is crossed).
#[inline]
pub fn first_face(faces: [f32; 3]) -> (f32, usize) {
    let mut t = f32::INFINITY;
    let mut axis = 0;
    for (a, &ta) in faces.iter().enumerate() {
        if ta < t {
            t = ta;
            axis = a;
        }
    }
    (t, axis)
}

/// One step of the block walk over many inactive blocks at once: from block `cell`, whose
/// Chebyshev distance to the nearest active block is `k ≥ 2`, across the cube of blocks
/// within `k − 1` of it (clamped to the `bd` blocks), all inactive. Returns where the ray
/// leaves the cube (`t`, the exit axis) and the block it enters there — the block the
/// walk by [`block_exit`] reaches at that face, bit for bit: per axis, the planes it has
/// crossed are those whose [`plane_t`] lies before `t` (or at it, for a lower axis than the
/// exit's, as [`block_exit`] breaks ties). The entered block may lie outside the volume.
#[inline]
pub fn jump(
    u: &Uniforms,
    cell: IVec3,
    k: i32,
    o: Vec3,
    d: Vec3,
    inv: Vec3,
    bd: IVec3,
) -> (f32, usize, IVec3) {
    let r = k - 1;
    let (c, o, d, inv, bd) = (
        cell.to_array(),
        o.to_array(),
        d.to_array(),
        inv.to_array(),
        bd.to_array(),
    );
    let lo = c.map(|v| (v - r).max(0));
    let hi = [0, 1, 2].map(|a| (c[a] + r).min(bd[a] - 1));
    let mut t = f32::INFINITY;
    let mut e = 0;
    for a in 0..3 {
        if d[a] != 0.0 {
            let m = if d[a] > 0.0 { hi[a] + 1 } else { lo[a] };
            let ta = plane_t(u, m, o[a], inv[a]);
            if ta < t {
                t = ta;
                e = a;
            }
        }
    }
    let mut next = c;
    // Blocks are a power of two of voxels: the reciprocal is exact.
    let rb = 1.0 / u.block as f32;
    for a in 0..3 {
        if a == e {
            next[a] = if d[a] > 0.0 { hi[a] + 1 } else { lo[a] - 1 };
            continue;
        }
        if d[a] == 0.0 {
            continue;
        }
        let crossed = |m: i32| {
            let tm = plane_t(u, m, o[a], inv[a]);
            tm < t || (tm == t && a < e)
        };
        // A first guess from the position, then corrected by the planes' own times.
        let guess = ((o[a] + t * d[a]) * rb) as i32;
        next[a] = if d[a] > 0.0 {
            // Crossing plane m enters block m: the last crossed plane in (cell, hi].
            last_crossed_rising(guess.clamp(c[a], hi[a]), c[a], hi[a], &crossed)
        } else {
            // Crossing plane m enters block m − 1: planes cell, cell − 1, …, lo + 1.
            last_crossed_falling(guess.clamp(lo[a], c[a]), lo[a], c[a], &crossed)
        };
    }
    (t, e, IVec3::from_array(next))
}

/// From the guess `g` in `[lo, hi]`, the block a ray moving up an axis is in, where
/// `crossed(m)` says whether it has crossed plane `m` (entering block `m`; true up to some
/// plane, false after): down while `g > lo` and plane `g` is not crossed, then up while
/// `g < hi` and plane `g + 1` is. The guess is almost always right or one block off, so
/// one step each way is tried inline and longer runs go to [`settle_rising`] (as plain
/// loops the compiler vectorises these sixteen planes at a time, several times the cost of
/// the one or two planes they usually test).
#[inline]
fn last_crossed_rising(g: i32, lo: i32, hi: i32, crossed: &impl Fn(i32) -> bool) -> i32 {
    if g > lo && !crossed(g) {
        // Plane g + 1 is not crossed either: only further down can the answer lie.
        let g = g - 1;
        if g > lo && !crossed(g) {
            return settle_rising(g, lo, hi, crossed);
        }
        return g;
    }
    if g < hi && crossed(g + 1) {
        let g = g + 1;
        if g < hi && crossed(g + 1) {
            return settle_rising(g, lo, hi, crossed);
        }
        return g;
    }
    g
}

/// The loops of [`last_crossed_rising`], for its rare long runs.
#[cold]
#[inline(never)]
fn settle_rising(mut g: i32, lo: i32, hi: i32, crossed: &impl Fn(i32) -> bool) -> i32 {
    while g > lo && !crossed(g) {
        g -= 1;
    }
    while g < hi && crossed(g + 1) {
        g += 1;
    }
    g
}

/// [`last_crossed_rising`] for a ray moving down an axis: crossing plane `m` enters
/// block `m − 1` (`crossed` true from some plane down): up while `g < hi` and plane
/// `g + 1` is not crossed, then down while `g > lo` and plane `g` is. The same search on
/// the mirrored axis (`g → −g`, plane `m → 1 − m`).
#[inline]
fn last_crossed_falling(g: i32, lo: i32, hi: i32, crossed: &impl Fn(i32) -> bool) -> i32 {
    -last_crossed_rising(-g, -hi, -lo, &|m: i32| crossed(1 - m))
}

/// The block the walk by [`block_exit`] is in at ray parameter `t` (inside the volume's
/// box): per axis, the block entered by the last plane `x_a = m · block` whose [`plane_t`]
/// lies before `t`, found from the position's block and corrected by the planes' own times
/// (as [`jump`] finds the block it enters). Where `t` is no plane's time this is the block of
/// the walk bit for bit, whatever path the walk took to it.
#[inline]
pub fn cell_at(u: &Uniforms, t: f32, o: Vec3, d: Vec3, inv: Vec3, bd: IVec3) -> IVec3 {
    let rb = 1.0 / u.block as f32;
    let mut c = [0i32; 3];
    let (o, d, inv, bd) = (o.to_array(), d.to_array(), inv.to_array(), bd.to_array());
    for (a, ca) in c.iter_mut().enumerate() {
        let top = bd[a] - 1;
        // Inside the box the position is >= 0 up to rounding: the cast truncates.
        let mut g = (((o[a] + t * d[a]) * rb).max(0.0) as i32).clamp(0, top);
        if d[a] != 0.0 {
            let crossed = |m: i32| plane_t(u, m, o[a], inv[a]) < t;
            g = if d[a] > 0.0 {
                // Crossing plane m enters block m.
                last_crossed_rising(g, 0, top, &crossed)
            } else {
                // Crossing plane m enters block m − 1.
                last_crossed_falling(g, 0, top, &crossed)
            };
        }
        *ca = g;
    }
    IVec3::from_array(c)
}

/// Whether the walk samples block `idx`: its skip distance is 0 where `block_info` holds one
/// ([`TraceData::block_info`], computed by [`block_active`] for these ranges), else
/// [`block_active`] of its range.
#[inline]
pub fn block_is_active(
    u: &Uniforms,
    block_info: &[[f32; 4]],
    block_range: &[[f32; 2]],
    idx: usize,
) -> bool {
    match block_info.get(idx) {
        Some(i) => i[3] == 0.0,
        None => block_active(u, block_range[idx]),
    }
}

/// True when a block with this `[min, max]` lies inside the solid throughout: a ray whose
/// first block it is hits a cap there.
#[inline]
pub fn range_inside(u: &Uniforms, range: [f32; 2]) -> bool {
    residual(u, range[0]) < 0.0 && residual(u, range[1]) < 0.0
}

/// Linear index of block `cell`.
#[inline]
pub fn block_index(u: &Uniforms, cell: IVec3) -> usize {
    let [bx, by, _] = u.block_dims;
    cell.x as usize + bx as usize * (cell.y as usize + by as usize * cell.z as usize)
}

/// `log2(brick / block)`: both are powers of two, so a block's brick coordinate is its own
/// shifted right by this (block coordinates inside the volume are never negative).
#[inline]
pub fn blocks_per_brick_log2(u: &Uniforms) -> i32 {
    (u.brick.trailing_zeros() - u.block.trailing_zeros()) as i32
}

/// Linear index of the brick holding block `cell`.
#[inline]
pub fn brick_of_block(u: &Uniforms, cell: IVec3) -> usize {
    let c = cell >> blocks_per_brick_log2(u);
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
    // q >= 0: truncation is the floor (and needs no libm call on baseline x86-64).
    let c = q.as_ivec3().clamp(lo, hi - IVec3::ONE);
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
    // pc >= 0 (q lies in the block, past the brick's corner): truncation is the floor.
    let c = pc.as_ivec3().clamp(clo, chi - IVec3::ONE);
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
pub fn gradient_hessian_at(_u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> (Vec3, Mat3) {
    let (g, h) = stored_gradient_hessian(pool, filter, l);
    if l.half {
        return (g * 0.5, h * 0.25);
    }
    (g, h)
}

/// Gradient and Hessian in the stored brick's own units (see [`gradient_hessian_at`]).
fn stored_gradient_hessian(pool: &[f32], filter: u32, l: &Located) -> (Vec3, Mat3) {
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

/// The cubic B-spline weights of the samples `i − 1, i, i + 1, i + 2` at fraction `a`
/// ([`isokit_field::filter::bspline_weights`], ERRATA 2).
#[inline]
pub fn bspline4(a: f32) -> [f32; 4] {
    const SIXTH: f32 = 1.0 / 6.0;
    let b = 1.0 - a;
    let a2 = a * a;
    let a3 = a2 * a;
    [
        b * b * b * SIXTH,
        (3.0 * a3 - 6.0 * a2 + 4.0) * SIXTH,
        (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) * SIXTH,
        a3 * SIXTH,
    ]
}

/// [`bspline4`] of the three axes at once: lane `a` of the fraction `f` gives the weights of
/// axis `a`, evaluated per lane with [`bspline4`]'s operations in its order (the same weights
/// bit for bit), then transposed to one vector of four tap weights per axis, `(wx, wy, wz)`.
#[inline]
pub fn bspline4_xyz(f: Vec4) -> (Vec4, Vec4, Vec4) {
    const SIXTH: f32 = 1.0 / 6.0;
    let s = Vec4::splat;
    let b = Vec4::ONE - f;
    let a2 = f * f;
    let a3 = a2 * f;
    let w = Mat4::from_cols(
        b * b * b * SIXTH,
        (s(3.0) * a3 - s(6.0) * a2 + s(4.0)) * SIXTH,
        (s(-3.0) * a3 + s(3.0) * a2 + s(3.0) * f + s(1.0)) * SIXTH,
        a3 * SIXTH,
    )
    .transpose();
    (w.x_axis, w.y_axis, w.z_axis)
}

/// [`bspline4_d1`] of the three axes at once, as [`bspline4_xyz`] evaluates [`bspline4`]:
/// per lane in its order, then transposed to `(dx, dy, dz)`.
#[inline]
pub fn bspline4_d1_xyz(f: Vec4) -> (Vec4, Vec4, Vec4) {
    let s = Vec4::splat;
    let b = Vec4::ONE - f;
    let a2 = f * f;
    let w = Mat4::from_cols(
        s(-0.5) * b * b,
        s(0.5) * (s(3.0) * a2 - s(4.0) * f),
        s(0.5) * (s(-3.0) * a2 + s(2.0) * f + s(1.0)),
        s(0.5) * a2,
    )
    .transpose();
    (w.x_axis, w.y_axis, w.z_axis)
}

/// Their first derivatives ([`isokit_field::filter::bspline_weights_d1`], ERRATA 3).
#[inline]
pub fn bspline4_d1(a: f32) -> [f32; 4] {
    let b = 1.0 - a;
    let a2 = a * a;
    [
        -0.5 * b * b,
        0.5 * (3.0 * a2 - 4.0 * a),
        0.5 * (-3.0 * a2 + 2.0 * a + 1.0),
        0.5 * a2,
    ]
}

/// Their second derivatives ([`isokit_field::filter::bspline_weights_d2`]).
#[inline]
pub fn bspline4_d2(a: f32) -> [f32; 4] {
    [1.0 - a, 3.0 * a - 2.0, 1.0 - 3.0 * a, a]
}

/// `a · b` summed as `(x + z) + (y + w)`: one order on every platform (and in the WGSL
/// twin), the order SSE2 sums in.
#[inline]
pub fn dot4(a: Vec4, b: Vec4) -> f32 {
    let p = a * b;
    (p.x + p.z) + (p.y + p.w)
}

/// The 4×4×4 samples around a located point (from its cell minus one along each axis) as
/// one slice of the pool: row `(j, k)` (4 samples along x) starts at `side · (j + side · k)`.
#[inline]
fn taps_window<'p>(pool: &'p [f32], l: &Located) -> &'p [f32] {
    let side = l.side;
    let i0 = l.base
        + (l.cell.x - 1) as usize
        + side * ((l.cell.y - 1) as usize + side * (l.cell.z - 1) as usize);
    &pool[i0..i0 + 3 * side * side + 3 * side + 4]
}

/// Row `(j, k)` of a [`taps_window`]: one 4-wide load.
#[inline]
fn taps_row(w: &[f32], side: usize, j: usize, k: usize) -> Vec4 {
    let o = side * (j + side * k);
    let r: &[f32; 4] = w[o..o + 4]
        .try_into()
        .unwrap_or_else(|_| unreachable!("a range of 4"));
    Vec4::from_array(*r)
}

/// The stored side of the default layout's bricks (32 cells and the apron of 3;
/// [`crate::Layout::brick_side`]).
const DEFAULT_SIDE: usize = 35;

/// The length of a [`taps_window`] in a brick of the default side.
const DEFAULT_WINDOW: usize = 3 * DEFAULT_SIDE * DEFAULT_SIDE + 3 * DEFAULT_SIDE + 4;

/// A [`taps_window`] of the default side as an array, so that its rows load with constant
/// offsets and no bounds checks (a third fewer instructions per sample than [`taps_row`]).
#[inline]
fn default_window(w: &[f32]) -> &[f32; DEFAULT_WINDOW] {
    match w.try_into() {
        Ok(w) => w,
        Err(_) => unreachable!("a window of the default side"),
    }
}

/// Row `(j, k)` of a [`default_window`].
#[inline(always)]
fn default_row(w: &[f32; DEFAULT_WINDOW], j: usize, k: usize) -> Vec4 {
    let o = DEFAULT_SIDE * (j + DEFAULT_SIDE * k);
    Vec4::new(w[o], w[o + 1], w[o + 2], w[o + 3])
}

/// The value's sum over the 16 rows `row(j, k)`: each weighted by `wy[j] · wz[k]`, summed
/// as vectors per slice `k` (`j` in order, from zero), the four slices as `(s0 + s1) +
/// (s2 + s3)`, then dotted with `wx`. One order for every brick side and in the WGSL twin;
/// four short chains of additions instead of one of sixteen, which the processor overlaps.
#[inline(always)]
fn value_sum(row: impl Fn(usize, usize) -> Vec4, wx: Vec4, wy: Vec4, wz: Vec4) -> f32 {
    let mut slice = [Vec4::ZERO; 4];
    for (k, acc) in slice.iter_mut().enumerate() {
        for j in 0..4 {
            *acc += row(j, k) * (wy[j] * wz[k]);
        }
    }
    dot4((slice[0] + slice[1]) + (slice[2] + slice[3]), wx)
}

/// The tricubic B-spline at a located point by its 64 taps: the 16 rows of 4 samples
/// (contiguous in the pool: one 4-wide load each) weighted by `wy · wz` and summed as
/// vectors per z-slice, the slices added as `(s0 + s1) + (s2 + s3)`, then dotted with `wx`.
/// The same field as the 8-fetch [`value_at`] (both are exact evaluations of the B-spline)
/// to f32 rounding, at a quarter of the loads; the search and the shading use it.
#[inline]
pub fn tricubic_taps(pool: &[f32], l: &Located) -> f32 {
    let (wx, wy, wz) = bspline4_xyz(l.frac.extend(0.0));
    let w = taps_window(pool, l);
    if l.side == DEFAULT_SIDE {
        return taps_value_default_side(w, wx, wy, wz);
    }
    value_sum(|j, k| taps_row(w, l.side, j, k), wx, wy, wz)
}

/// [`tricubic_taps`]'s sum for bricks of the default side ([`default_window`]).
#[inline(never)]
fn taps_value_default_side(w: &[f32], wx: Vec4, wy: Vec4, wz: Vec4) -> f32 {
    let w = default_window(w);
    value_sum(|j, k| default_row(w, j, k), wx, wy, wz)
}

/// The value's and the gradient's sums over the 16 rows `row(j, k)` (`k` outer, `j` inner,
/// each in one chain from zero): three row sums, weighted `wy·wz`, `wy'·wz`, `wy·wz'`, dotted
/// with `wx` or `wx'`. Its value equals [`value_sum`]'s to rounding (the shading reads only
/// the gradient).
#[inline(always)]
fn gradient_sum(row: impl Fn(usize, usize) -> Vec4, w: [Vec4; 3], dw: [Vec4; 3]) -> (f32, Vec3) {
    let ([wx, wy, wz], [dx, dy, dz]) = (w, dw);
    let (mut a0, mut a1, mut a2) = (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO);
    for k in 0..4 {
        for j in 0..4 {
            let row = row(j, k);
            a0 += row * (wy[j] * wz[k]);
            a1 += row * (dy[j] * wz[k]);
            a2 += row * (wy[j] * dz[k]);
        }
    }
    (
        dot4(a0, wx),
        Vec3::new(dot4(a0, dx), dot4(a1, wx), dot4(a2, wx)),
    )
}

/// Value and gradient (stored units) of the tricubic B-spline from the same 64 taps in one
/// pass: three row sums, weighted `wy·wz`, `wy'·wz`, `wy·wz'`.
#[inline]
pub fn tricubic_taps_gradient(pool: &[f32], l: &Located) -> (f32, Vec3) {
    let f = l.frac.extend(0.0);
    let (wx, wy, wz) = bspline4_xyz(f);
    let (dx, dy, dz) = bspline4_d1_xyz(f);
    let (w3, d3) = ([wx, wy, wz], [dx, dy, dz]);
    let w = taps_window(pool, l);
    if l.side == DEFAULT_SIDE {
        let w = default_window(w);
        return gradient_sum(|j, k| default_row(w, j, k), w3, d3);
    }
    gradient_sum(|j, k| taps_row(w, l.side, j, k), w3, d3)
}

/// Value, gradient and Hessian (stored units) of the tricubic B-spline from the same 64
/// taps in one pass: six row sums (`wy·wz`, `wy'·wz`, `wy·wz'`, `wy''·wz`, `wy·wz''`,
/// `wy'·wz'`) dotted with `wx`, `wx'` or `wx''`.
#[inline]
pub fn tricubic_taps_hessian(pool: &[f32], l: &Located) -> (f32, Vec3, Mat3) {
    let f = l.frac;
    let (wy, wz) = (bspline4(f.y), bspline4(f.z));
    let (dy, dz) = (bspline4_d1(f.y), bspline4_d1(f.z));
    let (ey, ez) = (bspline4_d2(f.y), bspline4_d2(f.z));
    let wx = Vec4::from_array(bspline4(f.x));
    let dx = Vec4::from_array(bspline4_d1(f.x));
    let ex = Vec4::from_array(bspline4_d2(f.x));
    let w = taps_window(pool, l);
    let mut a = [Vec4::ZERO; 6];
    for k in 0..4 {
        for j in 0..4 {
            let row = taps_row(w, l.side, j, k);
            a[0] += row * (wy[j] * wz[k]);
            a[1] += row * (dy[j] * wz[k]);
            a[2] += row * (wy[j] * dz[k]);
            a[3] += row * (ey[j] * wz[k]);
            a[4] += row * (wy[j] * ez[k]);
            a[5] += row * (dy[j] * dz[k]);
        }
    }
    let g = Vec3::new(dot4(a[0], dx), dot4(a[1], wx), dot4(a[2], wx));
    let (hxy, hxz, hyz) = (dot4(a[1], dx), dot4(a[2], dx), dot4(a[5], wx));
    let h = Mat3::from_cols(
        Vec3::new(dot4(a[0], ex), hxy, hxz),
        Vec3::new(hxy, dot4(a[3], wx), hyz),
        Vec3::new(hxz, hyz, dot4(a[4], wx)),
    );
    (dot4(a[0], wx), g, h)
}

/// The reconstructed value the ray caster searches with: trilinear (one fetch) or the
/// tricubic B-spline by its 64 taps ([`tricubic_taps`]).
#[inline]
pub fn sample_value(pool: &[f32], filter: u32, l: &Located) -> f32 {
    if filter == FILTER_TRILINEAR {
        return fetch(pool, l.side, l.base, l.cell, l.frac);
    }
    tricubic_taps(pool, l)
}

/// Gradient, and with `hessian` the Hessian (else zero), in grid units, as shading reads
/// them: tricubic from the 64 taps in one pass ([`tricubic_taps_gradient`],
/// [`tricubic_taps_hessian`]); trilinear as [`gradient_hessian_at`]. Half-resolution bricks
/// are scaled back to grid units (gradient · 1/2, Hessian · 1/4).
#[inline]
pub fn sample_gradient_hessian(
    pool: &[f32],
    filter: u32,
    l: &Located,
    hessian: bool,
) -> (Vec3, Mat3) {
    let (g, h) = if filter == FILTER_TRILINEAR {
        stored_gradient_hessian(pool, filter, l)
    } else if hessian {
        let (_, g, h) = tricubic_taps_hessian(pool, l);
        (g, h)
    } else {
        (tricubic_taps_gradient(pool, l).1, Mat3::ZERO)
    };
    if l.half {
        return (g * 0.5, h * 0.25);
    }
    (g, h)
}

/// A ray inside one resident block: what [`march_segment`] and [`refine`] sample, with
/// what [`locate`] derives from the block alone computed once ([`SegmentRay::new`]).
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
    /// Where the segment starts: samples lie at `p0 + (t − t0)·d`, so that the rounding
    /// of the far ray origin is shared by the segment's samples instead of jittering each
    /// (the residual is then smooth in `t` to f32 precision near the block).
    pub t0: f32,
    /// `o + t0·d`.
    pub p0: Vec3,
    /// How the segment samples: the common case's fused sampler ([`TapsRay`]), else
    /// [`SegmentRay::locate_at`] from the block's box.
    sampler: Sampler,
}

/// How a [`SegmentRay`] samples.
#[derive(Clone, Copy, Debug)]
enum Sampler {
    /// [`TapsRay`], where it applies.
    Taps(TapsRay),
    /// [`locate`] from the block's constants: its first and last sample corners (its box,
    /// clamped to the grid) and the grid coordinates of the stored brick's first sample.
    Located {
        /// The box's first corner.
        lo: IVec3,
        /// The box's last corner.
        hi: IVec3,
        /// The stored brick's first sample.
        first: IVec3,
    },
}

/// What every [`SegmentRay`] of a frame shares ([`SegmentRay::in_block`]): made once per
/// ray by the walk, instead of once per block it visits.
#[derive(Clone, Copy, Debug)]
pub struct SegmentFrame {
    /// Whether full-resolution slots take [`TapsRay`]: one field, the tricubic filter,
    /// bricks of the default side, on x86 (there `maxps`/`minps` give the second operand
    /// for a NaN, as the scalar clamp does; other targets' vector max and min keep the NaN,
    /// so they take the general path).
    fused: bool,
    /// The block edge in voxels.
    block: i32,
    /// `log2(brick / block)` ([`blocks_per_brick_log2`]).
    per_brick_log2: i32,
    /// The brick edge in voxels.
    brick: i32,
    /// The last sample per axis: `dims − 1`.
    top: IVec3,
    /// [`SegmentFrame::top`] as floats, with a fourth lane of 0.
    top4: Vec4,
    /// [`SegmentFrame::block`] in the first three lanes, 0 in the fourth.
    block4: Vec4,
    /// `block / brick` in the first three lanes, 0 in the fourth.
    per_brick4: Vec4,
    /// [`SegmentFrame::brick`] as a float.
    brick_f: f32,
    /// Samples per axis of a stored brick.
    side: usize,
}

impl SegmentFrame {
    /// The constants of frame `u`.
    #[inline]
    pub fn new(u: &Uniforms) -> Self {
        let side = u.brick_side as usize;
        let top = IVec3::new(u.dims[0] as i32, u.dims[1] as i32, u.dims[2] as i32) - 1;
        let b = u.block as f32;
        let per_brick = u.block as f32 / u.brick as f32;
        Self {
            fused: cfg!(any(target_arch = "x86_64", target_arch = "x86"))
                && u.combine == COMBINE_NONE
                && u.filter != FILTER_TRILINEAR
                && side == DEFAULT_SIDE,
            block: u.block as i32,
            per_brick_log2: blocks_per_brick_log2(u),
            brick: u.brick as i32,
            top,
            top4: top.as_vec3().extend(0.0),
            block4: Vec4::new(b, b, b, 0.0),
            per_brick4: Vec4::new(per_brick, per_brick, per_brick, 0.0),
            brick_f: u.brick as f32,
            side,
        }
    }
}

/// What [`SegmentRay`] samples with in the common case (one field, the tricubic filter, a
/// brick of the default side at full resolution): [`SegmentRay::locate_at`] and
/// [`tricubic_taps`] fused, with the block's constants prepared as vectors. The point, the
/// clamp, the cell and the fraction are computed four lanes at a time with the same
/// operations as the scalar path, so every sample is the same bit for bit.
#[derive(Clone, Copy, Debug)]
struct TapsRay {
    /// [`SegmentRay::p0`] and the direction, with a fourth lane of 0.
    p0: Vec4,
    /// See [`TapsRay::p0`].
    d: Vec4,
    /// The block's box as floats (its first and last sample corners).
    lo: Vec4,
    /// See [`TapsRay::lo`].
    hi: Vec4,
    /// The last cell a sample may use: `hi − 1`.
    last: Vec4,
    /// The grid coordinates of the taps window's first sample relative to its cell:
    /// the stored brick's first sample plus one.
    window: Vec4,
    /// Index of the slot's first sample in the pool.
    base: usize,
}

impl TapsRay {
    /// The tricubic value at `p0 + (t − t0)·d`. Kept out of line: a leaf that needs no
    /// saved registers.
    #[inline(never)]
    fn value(&self, pool: &[f32], t0: f32, t: f32) -> f32 {
        const S: f32 = DEFAULT_SIDE as f32;
        let p = self.p0 + Vec4::splat(t - t0) * self.d;
        let q = p.max(self.lo).min(self.hi);
        // q >= 0 (x86's `maxps` replaced a NaN lane by `lo` above): the floor is the truncation
        // [`locate`] takes, and the cell index is clamped from above only, as the lower
        // clamp cannot bind.
        let c = q.floor().min(self.last);
        // Whole numbers below 2^24 in every product and sum: exact in any order.
        let i0 = self.base + (c - self.window).dot(Vec4::new(1.0, S, S * S, 0.0)) as i32 as usize;
        let (wx, wy, wz) = bspline4_xyz(q - c);
        let w = default_window(&pool[i0..i0 + DEFAULT_WINDOW]);
        value_sum(|j, k| default_row(w, j, k), wx, wy, wz)
    }
}

impl SegmentRay {
    /// The ray `o + t·d` in block `cell`, whose brick sits in `slot`, its segment starting
    /// at `t0`.
    #[inline]
    pub fn new(u: &Uniforms, o: Vec3, d: Vec3, cell: IVec3, slot: u32, t0: f32) -> Self {
        Self::in_block(&SegmentFrame::new(u), o, d, cell, slot, t0)
    }

    /// [`SegmentRay::new`] with the frame's constants computed once.
    #[inline]
    pub fn in_block(f: &SegmentFrame, o: Vec3, d: Vec3, cell: IVec3, slot: u32, t0: f32) -> Self {
        let p0 = o + t0 * d;
        let sampler = if f.fused && slot & HALF_RESOLUTION == 0 {
            // The box and the brick's corner as floats: whole numbers below 2^24, exact as
            // the integers they stand for (block coordinates are never negative, and the
            // quotient by the power of two bricks per block is exact).
            let c = Vec4::new(cell.x as f32, cell.y as f32, cell.z as f32, 0.0);
            let lo = c * f.block4;
            let hi = (lo + f.block4).min(f.top4);
            Sampler::Taps(TapsRay {
                p0: p0.extend(0.0),
                d: d.extend(0.0),
                lo,
                hi,
                last: hi - Vec4::new(1.0, 1.0, 1.0, 0.0),
                window: (c * f.per_brick4).floor() * f.brick_f,
                base: slot as usize * f.side * f.side * f.side,
            })
        } else {
            let lo = cell * f.block;
            Sampler::Located {
                lo,
                hi: (lo + IVec3::splat(f.block)).min(f.top),
                first: (cell >> f.per_brick_log2) * f.brick - IVec3::ONE,
            }
        };
        Self {
            o,
            d,
            cell,
            slot,
            t0,
            p0,
            sampler,
        }
    }

    /// The block's box (first and last sample corners) and the stored brick's first sample.
    #[inline]
    fn block_box(&self) -> (IVec3, IVec3, IVec3) {
        match self.sampler {
            Sampler::Located { lo, hi, first } => (lo, hi, first),
            Sampler::Taps(t) => (
                t.lo.truncate().as_ivec3(),
                t.hi.truncate().as_ivec3(),
                t.window.truncate().as_ivec3() - IVec3::ONE,
            ),
        }
    }

    /// The ray's point at `t`: `p0 + (t − t0)·d`.
    #[inline]
    pub fn point(&self, t: f32) -> Vec3 {
        self.p0 + (t - self.t0) * self.d
    }

    /// [`locate`] of [`SegmentRay::point`] at `t`, bit for bit, from the block's constants.
    #[inline]
    pub fn locate_at(&self, u: &Uniforms, t: f32) -> Located {
        let p = self.point(t);
        if self.slot & HALF_RESOLUTION != 0 {
            return locate(u, self.slot, self.cell, p);
        }
        let (lo, hi, first) = self.block_box();
        let q = p.clamp(lo.as_vec3(), hi.as_vec3());
        let c = q.as_ivec3().clamp(lo, hi - IVec3::ONE);
        let side = u.brick_side as usize;
        Located {
            base: self.slot as usize * channels(u) * side * side * side,
            cell: c - first,
            frac: q - c.as_vec3(),
            p: q,
            side,
            half: false,
        }
    }

    #[inline]
    fn residual_at(&self, u: &Uniforms, pool: &[f32], t: f32, samples: &mut u32) -> f32 {
        *samples += 1;
        match &self.sampler {
            Sampler::Taps(taps) => residual(u, taps.value(pool, self.t0, t)),
            Sampler::Located { .. } => self.residual_located(u, pool, t),
        }
    }

    /// [`combined_residual`] at [`SegmentRay::locate_at`]: every case but [`TapsRay`]'s.
    #[inline(never)]
    fn residual_located(&self, u: &Uniforms, pool: &[f32], t: f32) -> f32 {
        let l = self.locate_at(u, t);
        combined_residual(u, pool, u.filter, &l)
    }
}

/// The bound on the slope of the residual along the ray in a block, per voxel, that
/// [`march_sphere`] steps by: `Σ |d_i| · slope_i` of the block's measured bounds
/// ([`TraceData::block_info`]), or for a given bound `g` ([`Uniforms::delta`] > 0)
/// `g · Σ |d_i|` unless the block's samples refute it (a neighbouring difference steeper
/// than `g`: no field with that bound has such samples), then the measured one. Both times
/// `1 +` [`SLOPE_MARGIN`].
#[inline]
pub fn ray_slope(u: &Uniforms, d: Vec3, info: [f32; 4]) -> f32 {
    let a = d.abs();
    let measured = a.x * info[0] + a.y * info[1] + a.z * info[2];
    let given = u.delta;
    let slope = if given > 0.0 && info[0].max(info[1]).max(info[2]) <= given {
        given * (a.x + a.y + a.z)
    } else {
        measured
    };
    slope * (1.0 + SLOPE_MARGIN)
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
/// field, or [`combine`] of both fields' residuals (each reconstructed with `filter`,
/// [`sample_value`]). The combined field's value is `ρ + s·residual`; the ray caster only
/// needs the residual.
#[inline]
pub fn combined_residual(u: &Uniforms, pool: &[f32], filter: u32, l: &Located) -> f32 {
    let a = residual(u, sample_value(pool, filter, l));
    if u.combine == COMBINE_NONE {
        return a;
    }
    let b = residual(u, sample_value(pool, filter, &channel_b(u, l)));
    combine(u, a, b)
}

/// Gradient and Hessian of the (combined) field at a hit, in grid units, and the id of the
/// operand that owns it: the single field's ([`ID_SURFACE`]); for union, intersection and
/// difference those of the operand attaining the combination at the point (by the search
/// filter's values), B's negated for a difference (its complement), with
/// [`ID_SURFACE_B`] when B owns it; for a morph `(1 − t)·A + t·B` of both ([`ID_SURFACE`]).
/// The Hessian only with [`FLAG_CURVATURE`] (zero without) ([`sample_gradient_hessian`]).
pub fn owner_gradient_hessian(u: &Uniforms, pool: &[f32], l: &Located) -> (Vec3, Mat3, u32) {
    let hess = u.flags & FLAG_CURVATURE != 0;
    let derivs = |l: &Located| sample_gradient_hessian(pool, u.shading_filter, l, hess);
    if u.combine == COMBINE_NONE {
        let (g, h) = derivs(l);
        return (g, h, ID_SURFACE);
    }
    let lb = channel_b(u, l);
    if u.combine == COMBINE_MORPH {
        let (ga, ha) = derivs(l);
        let (gb, hb) = derivs(&lb);
        let (wa, wb) = (1.0 - u.morph_t, u.morph_t);
        return (wa * ga + wb * gb, ha * wa + hb * wb, ID_SURFACE);
    }
    let a = residual(u, sample_value(pool, u.filter, l));
    let b = residual(u, sample_value(pool, u.filter, &lb));
    if !owner_is_b(u, a, b) {
        let (g, h) = derivs(l);
        return (g, h, ID_SURFACE);
    }
    let (g, h) = derivs(&lb);
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

/// A block whose first sample (at `t0`, residual `r < 0`) lies inside although it is not
/// the ray's first: with caps on, every earlier sample of the ray was outside (an inside
/// first sample would have been a cap), so the crossing lies at the face the ray entered by,
/// between the previous block's last sample and this one. The two blocks evaluate the face
/// from different cells (fraction 1 of the last cell against 0 of the next) and positions,
/// so their residuals can disagree in sign by rounding where the surface meets the face;
/// without this rule such a ray would step on inside the solid and miss it. The crossing is
/// returned as the empty bracket `[t0, t0]` ([`refine`] keeps it). With caps off a ray may
/// have started inside, and no crossing is claimed.
#[inline]
pub fn entry_crossing(u: &Uniforms, t0: f32, r: f32) -> Option<Segment> {
    (u.flags & FLAG_CAPS != 0).then_some(Segment::Crossing {
        ta: t0,
        ra: 0.0,
        tb: t0,
        rb: r,
    })
}

/// The first sample of a block's segment `[t0, t1]`, shared by both searches: the segment
/// ends there as a cap (`first` and inside), as a crossing at the block's face (inside after
/// an outside sample in the previous block) or as empty (no length); otherwise the
/// residual at `t0` and the segment's length.
#[inline]
fn segment_start(
    u: &Uniforms,
    pool: &[f32],
    ray: &SegmentRay,
    t0: f32,
    t1: f32,
    first: bool,
    samples: &mut u32,
) -> Result<(f32, f32), Segment> {
    let r = ray.residual_at(u, pool, t0, samples);
    if r < 0.0 {
        if first {
            return Err(Segment::Cap);
        }
        if let Some(entry) = entry_crossing(u, t0, r) {
            return Err(entry);
        }
    }
    let len = t1 - t0;
    if len.is_nan() || len <= 0.0 {
        return Err(Segment::Empty);
    }
    Ok((r, len))
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
    let (mut ra, len) = match segment_start(u, pool, ray, t0, t1, first, samples) {
        Ok(start) => start,
        Err(end) => return end,
    };
    // At most a block's diagonal (√3 · 32 voxels) times r0 (at most 64): fits in u32.
    let m = ceil_u32(len * u.r0).max(1);
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

/// Sphere tracing (Hart 1996) of the segment `[t0, t1]` of a block for the first crossing
/// from outside to inside, by the reconstruction's Lipschitz bound: a sample with residual
/// `r ≥ 0` clears `r / slope` of the ray after it (`slope` from [`ray_slope`]: no crossing
/// lies there where the bound holds), and the next sample lies the fine step
/// `min_step = 1 / (r0 · fine)` beyond what is cleared. Every inside run of at least
/// `min_step` then holds a sample, as in the fine rate of [`march_segment`]: it starts past
/// the cleared part, within `min_step` before the next sample. Where the cleared part
/// reaches `t1` the segment ends without a sample there; where the next sample would lie
/// past `t1`, it lies at `t1`. `first` asks for the cap test on the first sample, as
/// [`march_segment`].
///
/// `clear` is a lower bound on the residual at `t0` carried from the block before (0: none):
/// the search then starts from what it clears instead of a sample at `t0`, falling back to
/// that sample where the first one lies inside (the crossing needs an outside end).
/// Returns, with [`Segment::Empty`], the bound the segment leaves at `t1` for the next block:
/// `r − slope · (t1 − t)` after the last sample `(t, r)` where the cleared part reaches
/// `t1`, the residual itself where `t1` was sampled, else 0; less [`CARRY_MARGIN`]'s share.
#[expect(
    clippy::too_many_arguments,
    reason = "the segment, its bounds and the counter, as the shader passes them"
)]
pub fn march_sphere(
    u: &Uniforms,
    pool: &[f32],
    ray: &SegmentRay,
    t0: f32,
    t1: f32,
    first: bool,
    slope: f32,
    clear: f32,
    samples: &mut u32,
) -> (Segment, f32) {
    let min_step = 1.0 / (u.r0 * u.fine as f32);
    // What a bound handed on loses to the next block's placing of the face point.
    let face = slope * CARRY_MARGIN * (ray.o.abs().max_element() + t1.abs());
    let mut carried = None;
    if !first && clear > 0.0 {
        let lead = clear / slope;
        if t0 + lead >= t1 {
            return (Segment::Empty, clear - slope * (t1 - t0) - face);
        }
        let tn = t0 + lead + min_step;
        let probe = if tn < t1 { tn } else { t1 };
        let rn = ray.residual_at(u, pool, probe, samples);
        if rn >= 0.0 {
            if probe == t1 {
                return (Segment::Empty, rn - face);
            }
            carried = Some((tn, rn));
        }
    }
    let (mut t, mut r) = match carried {
        Some(start) => start,
        None => match segment_start(u, pool, ray, t0, t1, first, samples) {
            Ok((r, _)) => (t0, r),
            Err(end) => return (end, 0.0),
        },
    };
    // Every step is at least `min_step` long (a bound on the loop, as in the shader).
    let max_steps = ceil_u32((t1 - t0) / min_step) + 1;
    for _ in 0..max_steps {
        // What the sample clears; nothing for an inside or NaN residual (NaN fails `>`).
        let sphere = r / slope;
        let cleared = if sphere > 0.0 { sphere } else { 0.0 };
        if cleared > 0.0 && t + cleared >= t1 {
            // The bound keeps the rest of the segment outside.
            return (Segment::Empty, r - slope * (t1 - t) - face);
        }
        let tn = t + cleared + min_step;
        let tn = if tn < t1 { tn } else { t1 };
        let rn = ray.residual_at(u, pool, tn, samples);
        if r >= 0.0 && rn < 0.0 {
            let crossing = Segment::Crossing {
                ta: t,
                ra: r,
                tb: tn,
                rb: rn,
            };
            return (crossing, 0.0);
        }
        if tn == t1 {
            return (Segment::Empty, if rn > 0.0 { rn - face } else { 0.0 });
        }
        (t, r) = (tn, rn);
    }
    (Segment::Empty, 0.0)
}

/// `x.ceil() as u32` for every `x` (NaN and below 0 give 0, above `u32::MAX` saturate),
/// without the library call that `ceil` is on baseline x86-64.
#[inline]
pub fn ceil_u32(x: f32) -> u32 {
    let c = x as u32;
    c.saturating_add(u32::from((c as f32) < x))
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

/// Refines a crossing (`ra >= 0 > rb`) with up to `refine_steps` steps of bisection or of
/// the secant method (Illinois: an end kept twice has its residual halved for the next
/// estimate), keeping the bracket, stopping early once an estimate lies within
/// [`REFINE_TOLERANCE`] voxel of the surface, and returns the linear interpolation in the
/// final bracket (002 Sec. 6.3.4).
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
    if ta == tb {
        // The empty bracket of a block entry ([`entry_crossing`]).
        return ta;
    }
    let (mut wa, mut wb) = (ra, rb);
    let mut last = 0i32;
    // Residual per voxel of the first bracket: |rm| / slope estimates the distance to the
    // crossing in voxels ([`REFINE_TOLERANCE`]).
    let tol = REFINE_TOLERANCE * (ra - rb).abs() / (tb - ta).abs();
    let tol = if tol.is_finite() { tol } else { 0.0 };
    for _ in 0..u.refine_steps {
        let tm = if u.flags & FLAG_SECANT == 0 {
            0.5 * (ta + tb)
        } else {
            secant(ta, wa, tb, wb)
        };
        let rm = ray.residual_at(u, pool, tm, samples);
        let close = rm.abs() <= tol;
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
        if close {
            break;
        }
    }
    secant(ta, ra, tb, rb)
}

/// The G-buffer sample at ray parameter `t` in a resident block: position, depth, and from
/// the shading filter's gradient and Hessian (converted to world units) the outward normal,
/// principal curvatures and direction (without [`FLAG_CURVATURE`] the normal only:
/// curvatures 0, `dir1` any unit vector orthogonal to the normal). Flat gradients give the
/// normal `−d` and zero curvature. With two fields, the owner's derivatives and id
/// ([`owner_gradient_hessian`]).
pub fn surface_sample(u: &Uniforms, pool: &[f32], ray: &SegmentRay, t: f32) -> GSample {
    let l = ray.locate_at(u, t);
    let (g, h, id) = owner_gradient_hessian(u, pool, &l);
    let inv = 1.0 / u.spacing;
    let inside = if u.inside_sign > 0.0 {
        Inside::Below
    } else {
        Inside::Above
    };
    let position = v3(u.origin) + u.spacing * l.p;
    let depth = t * u.spacing;
    if u.flags & FLAG_CURVATURE == 0 {
        // The normal as `curvature_with` makes it (f64), curvatures left at 0.
        let gs = (g * inv).as_dvec3() * f64::from(u.inside_sign);
        let len = gs.length();
        if g.is_finite() && len > f64::from(DEFAULT_MIN_GRADIENT) {
            let normal = (gs / len).as_vec3();
            return GSample {
                position,
                depth,
                normal,
                dir1: normal.any_orthonormal_vector(),
                id,
                ..GSample::default()
            };
        }
        return GSample {
            position,
            depth,
            normal: -ray.d,
            dir1: ray.d.any_orthonormal_vector(),
            id,
            ..GSample::default()
        };
    }
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
    let caps_on = u.flags & FLAG_CAPS != 0;
    // The smallest parameter at which this ray can reach an active block, and the largest
    // at which it can still be in one (CPU only).
    let (near, misses_final) = match (resume, data.start) {
        (None, Some(s)) => (s.near(px, py), s.misses_final()),
        _ => (f32::NEG_INFINITY, false),
    };
    let far = data.start.map_or(f32::INFINITY, |s| s.far(px, py));
    if near == f32::INFINITY && misses_final {
        return miss(samples);
    }
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
    // A lower bound on the residual at `t_in` (0: none), carried from one searched block to
    // the next ([`march_sphere`]). None after a block whose range excludes ρ, whether or not
    // it was skipped, so that skipping, where the walk starts ([`crate::StartRaster`]) and
    // jumps ([`jump`], over such blocks only) change no sample.
    let mut clear = resume.map_or(0.0, |r| r.clear);
    let mut after_excluded = false;
    let (mut cell, mut t_in, mut first) = match resume {
        Some(r) => (IVec3::from_array(r.cell), r.t, r.first),
        None => {
            let p = o + t_enter * d;
            // The truncation is the floor where it matters: below 0 both clamp to 0.
            let c = (p / u.block as f32).as_ivec3();
            (c.clamp(IVec3::ZERO, bd - 1), t_enter, true)
        }
    };
    let inv = inverse_direction(d);
    if near > t_in {
        // Nothing active before `near`: the entry block's cap test (as the walk's first step
        // over an inactive block makes it), then the walk starts in the block at `near`.
        let idx = block_index(u, cell);
        if !block_is_active(u, data.block_info, data.block_range, idx) {
            if first && caps_on && range_inside(u, data.block_range[idx]) {
                return PixelResult::Done {
                    sample: cap_sample(u, o, d, t_in, entry_axis),
                    samples,
                };
            }
            if near >= t_exit {
                return miss(samples);
            }
            let c = cell_at(u, near, o, d, inv, bd);
            if !block_is_active(u, data.block_info, data.block_range, block_index(u, c)) {
                (cell, t_in, first) = (c, near, false);
            }
        }
    }
    let step = IVec3::new(
        if d.x > 0.0 { 1 } else { -1 },
        if d.y > 0.0 { 1 } else { -1 },
        if d.z > 0.0 { 1 } else { -1 },
    );
    let sphere = u.flags & FLAG_SPHERE != 0 && !data.block_info.is_empty();
    // Each step moves one block coordinate monotonically: at most the sum of the dims.
    let max_steps = u.block_dims.iter().sum::<u32>() + 3;
    let skip_on = u.flags & FLAG_SKIP_EMPTY != 0;
    let frame = SegmentFrame::new(u);
    // The current block's exit faces, one per axis, updated as the walk steps.
    let mut faces = exit_faces(u, cell, o, d, inv);
    for _ in 0..max_steps {
        let idx = block_index(u, cell);
        // The skip distance is 0 exactly where `block_active` holds (it was computed by it,
        // for these ranges); without it, the ranges decide.
        let info = data.block_info.get(idx).copied();
        let active = match info {
            Some(i) => i[3] == 0.0,
            None => block_active(u, data.block_range[idx]),
        };
        let (t_out, axis) = first_face(faces);
        if active {
            if after_excluded {
                clear = 0.0;
            }
            let t1 = t_out.min(t_exit);
            let brick = brick_of_block(u, cell);
            let slot = data.reference[brick];
            if slot == NOT_RESIDENT {
                data.requests[brick].fetch_add(1, Ordering::Relaxed);
                return PixelResult::Suspended {
                    resume: Resume {
                        cell: cell.to_array(),
                        t: t_in,
                        first,
                        clear,
                    },
                    samples,
                };
            }
            // Read before writing: both threads store into the same few cache lines.
            if data.used[brick].load(Ordering::Relaxed) == 0 {
                data.used[brick].store(1, Ordering::Relaxed);
            }
            let ray = SegmentRay::in_block(&frame, o, d, cell, slot, t_in);
            let caps = first && u.flags & FLAG_CAPS != 0;
            // A segment of zero length (the ray crosses a block edge or corner) holds no
            // crossing; only the cap test needs its sample.
            let seg = if !(t1 > t_in || caps) {
                // The bound at `t_in` holds at `t1` too.
                Segment::Empty
            } else if let (true, Some(info)) = (sphere, info) {
                let slope = ray_slope(u, d, info);
                let t1 = t1.max(t_in);
                let (seg, left) = march_sphere(
                    u,
                    data.pool,
                    &ray,
                    t_in,
                    t1,
                    caps,
                    slope,
                    clear,
                    &mut samples,
                );
                clear = left;
                seg
            } else {
                clear = 0.0;
                march_segment(u, data.pool, &ray, t_in, t1.max(t_in), caps, &mut samples)
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
        } else if first && u.flags & FLAG_CAPS != 0 && range_inside(u, data.block_range[idx]) {
            // A skipped block entirely inside: its first sample would be inside too.
            return PixelResult::Done {
                sample: cap_sample(u, o, d, t_in, entry_axis),
                samples,
            };
        }
        first = false;
        let k = info.map_or(0, |i| i[3] as i32);
        // Where empty blocks are skipped, a block is active exactly where its range holds ρ
        // ([`block_active`]; a skip distance k ≥ 2 is an inactive block's).
        after_excluded = if skip_on {
            !active
        } else {
            k >= 2 || !range_holds_iso(u, data.block_range[idx])
        };
        let (t_out, axis, next) = if k >= 2 {
            // Every block within k − 1 of this one is inactive: cross them at once.
            jump(u, cell, k, o, d, inv, bd)
        } else {
            let mut next = cell;
            next[axis] += step[axis];
            (t_out, axis, next)
        };
        let t1 = t_out.min(t_exit);
        // Past `far` no active block lies on the ray (and only the first block is tested
        // for a cap): a miss.
        if t1 >= t_exit || t1 > far {
            break;
        }
        if next[axis] < 0 || next[axis] >= bd[axis] {
            break;
        }
        if k >= 2 {
            faces = exit_faces(u, next, o, d, inv);
        } else {
            faces[axis] = exit_face(u, next[axis], o[axis], d[axis], inv[axis]);
        }
        cell = next;
        t_in = t1.max(t_in);
    }
    miss(samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The specialised tricubic sum is the default layout's and sums as the general one.
    #[test]
    fn the_default_side_specialisation_matches_the_general_sum() {
        assert_eq!(DEFAULT_SIDE, crate::Layout::default().brick_side());
        let side = DEFAULT_SIDE;
        let pool: Vec<f32> = (0..side * side * side)
            .map(|i| ((i * 7919) % 1013) as f32 * 0.01 - 3.0)
            .collect();
        for (c, f) in [
            (IVec3::new(1, 1, 1), Vec3::new(0.25, 0.5, 0.75)),
            (IVec3::new(17, 3, 30), Vec3::new(0.9, 0.01, 0.5)),
            (IVec3::new(32, 32, 32), Vec3::ONE),
        ] {
            let l = Located {
                base: 0,
                cell: c,
                frac: f,
                p: Vec3::ZERO,
                side,
                half: false,
            };
            let (wy, wz) = (bspline4(f.y), bspline4(f.z));
            let wx = Vec4::from_array(bspline4(f.x));
            let w = taps_window(&pool, &l);
            let mut slice = [Vec4::ZERO; 4];
            for (k, &zk) in wz.iter().enumerate() {
                for (j, &yj) in wy.iter().enumerate() {
                    slice[k] += taps_row(w, side, j, k) * (yj * zk);
                }
            }
            let acc = (slice[0] + slice[1]) + (slice[2] + slice[3]);
            assert_eq!(tricubic_taps(&pool, &l).to_bits(), dot4(acc, wx).to_bits());
        }
    }

    /// The three axes' weights evaluated as vectors are [`bspline4`]'s and
    /// [`bspline4_d1`]'s bit for bit, at fractions across the cell and at its ends.
    #[test]
    fn the_weights_of_three_axes_at_once_are_the_scalar_weights() {
        let mut state = 0x5eed_u32;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut fracs = vec![
            [0.0, 1.0, 0.5],
            [1.0, 0.0, f32::EPSILON],
            [0.999_999_9, 1e-30, 0.25],
        ];
        fracs.extend((0..2000).map(|_| [next(), next(), next()]));
        for f in fracs {
            let v = Vec4::new(f[0], f[1], f[2], 0.0);
            let (w, d) = (bspline4_xyz(v), bspline4_d1_xyz(v));
            for (a, &fa) in f.iter().enumerate() {
                let (wa, da) = ([w.0, w.1, w.2][a], [d.0, d.1, d.2][a]);
                let bits = |x: Vec4| x.to_array().map(f32::to_bits);
                assert_eq!(bits(wa), bspline4(fa).map(f32::to_bits), "weights at {fa}");
                assert_eq!(
                    bits(da),
                    bspline4_d1(fa).map(f32::to_bits),
                    "derivatives at {fa}"
                );
            }
        }
    }

    /// The fused sample of a segment in the common case ([`TapsRay`], x86 only) is the
    /// residual of [`SegmentRay::locate_at`] and [`combined_residual`] bit for bit: inside
    /// blocks, clamped onto their faces from beyond them, in the grid's last (shorter) block,
    /// in another slot, and for NaN parameters.
    #[test]
    #[cfg(any(target_arch = "x86_64", target_arch = "x86"))]
    fn the_fused_sample_is_locate_and_taps_bit_for_bit() {
        let side = DEFAULT_SIDE;
        let mut u: Uniforms = bytemuck::Zeroable::zeroed();
        u.dims = [70, 70, 70];
        u.block = 8;
        u.brick = 32;
        u.brick_side = side as u32;
        u.filter = FILTER_TRICUBIC;
        u.combine = COMBINE_NONE;
        u.iso = 0.25;
        u.inside_sign = -1.0;
        let pool: Vec<f32> = (0..2 * side * side * side)
            .map(|i| ((i * 7919) % 1013) as f32 * 0.01 - 3.0)
            .collect();
        let mut state = 0x1234_5678_u32;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        for (cell, slot) in [
            (IVec3::new(0, 0, 0), 0),
            (IVec3::new(1, 2, 3), 1),
            (IVec3::new(3, 0, 2), 0),
            (IVec3::new(8, 8, 8), 1),
            (IVec3::new(4, 7, 8), 0),
        ] {
            let center = (cell * 8).as_vec3() + 4.0;
            for _ in 0..200 {
                let d = (Vec3::new(next(), next(), next()) - 0.5).normalize_or(Vec3::X);
                let o = center - 30.0 * d + (Vec3::new(next(), next(), next()) - 0.5) * 8.0;
                let t0 = 20.0 + 8.0 * next();
                let ray = SegmentRay::new(&u, o, d, cell, slot, t0);
                let Sampler::Taps(taps) = ray.sampler else {
                    panic!("the common case takes the fused sample");
                };
                let mut ts: Vec<f32> = (0..12).map(|_| t0 + 24.0 * next() - 4.0).collect();
                ts.extend([t0, f32::NAN]);
                for t in ts {
                    // `locate` from the point alone: independent of the segment's box.
                    let l = locate(&u, slot, cell, ray.point(t));
                    assert_eq!(ray.locate_at(&u, t), l, "block {cell} at t {t}");
                    let want = combined_residual(&u, &pool, u.filter, &l);
                    let got = residual(&u, taps.value(&pool, ray.t0, t));
                    assert_eq!(got.to_bits(), want.to_bits(), "block {cell} at t {t}");
                }
            }
        }
        // Not taken where it does not apply: the trilinear filter, a second field, a brick at
        // half resolution.
        let trilinear = Uniforms {
            filter: FILTER_TRILINEAR,
            ..u
        };
        let combined = Uniforms {
            combine: COMBINE_UNION,
            ..u
        };
        let (o, d) = (Vec3::ZERO, Vec3::X);
        assert!(matches!(
            SegmentRay::new(&trilinear, o, d, IVec3::ZERO, 0, 0.0).sampler,
            Sampler::Located { .. }
        ));
        assert!(matches!(
            SegmentRay::new(&combined, o, d, IVec3::ZERO, 0, 0.0).sampler,
            Sampler::Located { .. }
        ));
        let half = HALF_RESOLUTION | 1;
        assert!(matches!(
            SegmentRay::new(&u, o, d, IVec3::ZERO, half, 0.0).sampler,
            Sampler::Located { .. }
        ));
    }

    /// The fused sampler's vectors, computed in floats, are the integer box of the general
    /// path as floats, bit for bit in every lane, for every block of a volume and every
    /// block size.
    #[test]
    #[cfg(any(target_arch = "x86_64", target_arch = "x86"))]
    fn the_fused_box_is_the_integer_box() {
        for block in [2u32, 4, 8, 16, 32] {
            let mut u: Uniforms = bytemuck::Zeroable::zeroed();
            u.combine = COMBINE_NONE;
            u.block = block;
            u.brick = 32;
            u.brick_side = DEFAULT_SIDE as u32;
            u.dims = [301, 256, 97];
            u.filter = FILTER_TRICUBIC;
            let fused = SegmentFrame::new(&u);
            assert!(fused.fused);
            let general = SegmentFrame {
                fused: false,
                ..fused
            };
            let n = u.dims.map(|d| d.div_ceil(block) as i32);
            for z in 0..n[2] {
                for y in 0..n[1] {
                    for x in 0..n[0] {
                        let cell = IVec3::new(x, y, z);
                        let f = SegmentRay::in_block(&fused, Vec3::ZERO, Vec3::X, cell, 3, 0.0);
                        let g = SegmentRay::in_block(&general, Vec3::ZERO, Vec3::X, cell, 3, 0.0);
                        let Sampler::Taps(taps) = f.sampler else {
                            panic!("the common case takes the fused sample");
                        };
                        let (lo, hi, first) = g.block_box();
                        // The vectors as the integer box makes them, every lane bit for bit.
                        let bits = |v: Vec4| v.to_array().map(f32::to_bits);
                        let want = |v: IVec3| bits(v.as_vec3().extend(0.0));
                        let at = format!("block {cell}, edge {block}");
                        assert_eq!(bits(taps.lo), want(lo), "{at}");
                        assert_eq!(bits(taps.hi), want(hi), "{at}");
                        assert_eq!(bits(taps.last), want(hi - IVec3::ONE), "{at}");
                        assert_eq!(bits(taps.window), want(first + IVec3::ONE), "{at}");
                        assert_eq!(f.block_box(), (lo, hi, first), "{at}");
                    }
                }
            }
        }
    }

    /// The planes' search with its one-step fast path is the two plain loops it replaces,
    /// for every guess and threshold in a range, near and far (the out-of-line loops).
    #[test]
    fn the_crossed_plane_search_is_the_plain_loops() {
        for lo in -2..3 {
            for hi in lo..lo + 12 {
                for threshold in lo - 3..hi + 4 {
                    for g in lo..=hi {
                        // Rising: planes up to `threshold` are crossed.
                        let crossed = |m: i32| m <= threshold;
                        let mut want = g;
                        while want > lo && !crossed(want) {
                            want -= 1;
                        }
                        while want < hi && crossed(want + 1) {
                            want += 1;
                        }
                        assert_eq!(last_crossed_rising(g, lo, hi, &crossed), want);
                        // Falling: planes from `threshold` down are crossed.
                        let crossed = |m: i32| m >= threshold;
                        let mut want = g;
                        while want < hi && !crossed(want + 1) {
                            want += 1;
                        }
                        while want > lo && crossed(want) {
                            want -= 1;
                        }
                        assert_eq!(last_crossed_falling(g, lo, hi, &crossed), want);
                    }
                }
            }
        }
    }

    /// [`ceil_u32`] is `ceil` and the saturating cast, at the edges and across a range.
    #[test]
    fn the_integer_ceiling_is_ceil_and_the_cast() {
        let mut xs = vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            0.0,
            -0.5,
            -1.0,
            f32::MIN_POSITIVE,
            1.0,
            1.0 + f32::EPSILON,
            16_777_215.5,
            16_777_216.0,
            4_294_967_040.0,
            4_294_967_296.0,
            1e20,
        ];
        xs.extend((0..100_000).map(|i| i as f32 * 0.0137 - 20.0));
        xs.extend((0..2000).map(|i| f32::from_bits(0x3f80_0000 + i * 997)));
        for x in xs {
            assert_eq!(ceil_u32(x), x.ceil() as u32, "at {x}");
        }
    }
}
