//! # isokit-render: isosurface ray casting and deferred shading
//!
//! Direct rendering of the isosurface `f = ρ` of a sampled field (dissertation 002 Ch. 6,
//! paper 000): rays find the surface, the hits and their differential geometry go to a
//! G-buffer, and every shading effect is computed from it per pixel.
//!
//! This crate holds the **CPU twin** (rayon) and the **GPU twin** ([`gpu::GpuRenderer`],
//! wgpu compute, WGSL from the `isokit-shaders` crate: `shaders/raycast*.wgsl`,
//! `shaders/shade.wgsl` and the pieces they share in `shaders/common/`). The CPU's
//! per-pixel logic ([`kernel`], [`shade::shade_pixel`]) is written over flat data — the
//! brick pool, the reference index, the block ranges, the [`Uniforms`] — and the WGSL
//! mirrors it function by function; both render the same [`GBuffer`] and image, the GPU's
//! to rounding. It does not open windows or sample fields: scenes are sampled by
//! `isokit-scene`, volumes read by `isokit-io`.
//!
//! ## Where the code of each shader is
//! Each kernel's CPU twin sits beside its host code, named after the shader (paths under
//! `src/`; every struct shared with the GPU has a member-by-member table next to its Rust
//! type, `isokit_gpu::wgsl_layout!`, checked against the WGSL in the host code's tests):
//!
//! | WGSL (`shaders/`) | CPU twin | GPU host code |
//! | --- | --- | --- |
//! | `raycast.wgsl`, `raycast_common.wgsl`, `common/curvature.wgsl` | `raycast/cpu.rs` ([`kernel`]); the passes in `raycast/render.rs` ([`render`]) | `raycast/gpu.rs` ([`gpu::GpuRenderer::render`]) |
//! | `shade.wgsl`, `common/shade_structs.wgsl`, `common/shade_functions.wgsl` | `shade/cpu.rs` ([`shade()`]) | `shade/gpu.rs` ([`gpu::GpuRenderer::shade`]) |
//! | `flow.wgsl` | `flow/cpu.rs` ([`shade::flow_image`]) | `flow/gpu.rs` |
//! | `splat.wgsl`, `splat_shade.wgsl` | `splat/cpu.rs` ([`splat`]), `quadric.rs` ([`quadric::intersect`]) | `splat/gpu.rs` ([`splat::gpu`], also [`gpu::splat`]) |
//! | `dvr.wgsl` | `dvr/mod.rs` ([`dvr::render_dvr`], [`dvr::render_dvr_spherical`]), `spherical.rs` ([`spherical::render_iso`]) | `dvr/gpu.rs` ([`gpu::GpuRenderer::render_dvr`], [`gpu::GpuRenderer::render_spherical_iso`]) |
//! | `tets.wgsl`, `common/transfer.wgsl`, `common/slab.wgsl` | `tets/mod.rs` ([`tets::TetCaster`]), `tets/dvr.rs` ([`tets::dvr::TetVolume`]) | `tets/gpu.rs` ([`gpu::GpuRenderer::render_tets`], [`gpu::GpuRenderer::render_tets_dvr`]) |
//! | `segmented.wgsl`, `common/slab.wgsl` | `segmented/mod.rs` ([`segmented::SegmentedCaster`]) | `segmented/gpu.rs` ([`gpu::GpuRenderer::render_segmented`], [`gpu::GpuRenderer::render_segmented_layers`]) |
//!
//! `dvr.wgsl` also takes `common/transfer.wgsl` and `common/slab.wgsl`.
//!
//! `gpu.rs` holds what the GPU host code shares (the device and pipelines, the constants
//! prepended from Rust, the backend choice).
//!
//! Choosing: [`render`] and [`shade()`] run everywhere; [`gpu::GpuRenderer`] needs a wgpu
//! adapter (Vulkan or GLES 3.1 with compute); [`gpu::select_backend`] resolves a user's
//! `cpu|gpu|auto` request.
//!
//! ## Pipeline
//! 1. [`Volume`]: the samples (a dense [`isokit_field::Grid`] or a lazily sampled band
//!    [`isokit_field::BrickGrid`]) with blocks (8³ cells, min/max for empty-space skipping)
//!    and bricks (32³ cells, the unit of the cache), 002 Sec. 6.2.
//! 2. [`BrickCache`]: a fixed number of brick slots, a reference index, on-demand loading
//!    and LRU eviction. A cache smaller than the active bricks renders the same image in
//!    several passes.
//! 3. [`render`]: per pixel, a 3D DDA over blocks, active blocks only; adaptive sampling
//!    (r0, r1 = n·r0 near ρ); bisection or secant refinement; normal and principal
//!    curvatures from the tricubic B-spline (or trilinear) gradient and Hessian
//!    ([`RenderOptions`]). Output: a [`GBuffer`] (also written as EXR).
//! 4. [`shade()`]: deferred shading ([`ShadingMode`]: Blinn-Phong, tone, curvature maps,
//!    ridges and valleys, curvature-controlled contours, accessibility, reflection lines,
//!    solid texture).
//! 5. Multi-view displays (paper 001, [`render_multiview`]): one geometric pass with one
//!    ray per subpixel from the eye of the view it shows, one shading pass; the individual
//!    views with [`render_view`].
//!
//! ```
//! use isokit_field::{Grid, sample_into, primitives::Sphere, Camera, Projection};
//! use isokit_render::{BrickCache, Layout, RenderOptions, Shading, Volume, render, shade};
//! use glam::Vec3;
//!
//! let mut grid = Grid::new([32; 3], Vec3::splat(-1.0), 2.0 / 31.0).unwrap();
//! sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
//! let volume = Volume::from_grid(grid, Layout::default()).unwrap();
//! let mut cache = BrickCache::for_volume(&volume);
//! let camera = Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y,
//!     Projection::Perspective { fov_y_degrees: 40.0 }, 24, 24).unwrap();
//! let frame = render(&volume, &mut cache, &camera, &RenderOptions::default()).unwrap();
//! let centre = frame.gbuffer.get(12, 12);
//! assert!(centre.is_hit() && (centre.position.z - 0.7).abs() < 0.01);
//! let image = shade(&frame.gbuffer, &frame.uniforms, &Shading::default()).unwrap();
//! assert_eq!(image.pixels.len(), 24 * 24);
//! ```
//!
//! ## Where this differs from 002
//! - **Segments**: block-level ray casting (Sec. 6.3.2), with segments cut by a 3D DDA
//!   instead of rasterized block faces: on wgpu a compute shader walks the blocks directly,
//!   no bounding geometry is rendered, segments never cross bricks (no per-sample reference
//!   lookup), and empty blocks are skipped entirely. Every segment is sampled on its own
//!   (both ends, `ceil(len·r0)` steps), so skipping changes no pixel.
//! - **Adaptive sampling**: an interval of the base rate is resampled at r1 when *either*
//!   end is within δ of ρ (002 switches after the near sample, which misses a sheet thinner
//!   than a base step lying just before it).
//! - **Too small a cache**: rays that reach a missing brick ask for it and wait; the host
//!   loads the bricks asked for and resumes them (several passes), the default. 002
//!   Sec. 6.2.3 downsamples low-detail bricks instead: [`CachePolicy::Downsample`], which
//!   changes the surface slightly and matches hanging samples (exact for the trilinear
//!   filter, to second order for the tricubic one), whereas passes keep the image exact
//!   and cost time only.
//! - **Caps**: a ray that enters the volume inside the solid hits the box there.
//! - **CSG and morphing** (Sec. 6.4.3, [`Volume::with_operand`]): both fields share each
//!   brick slot and are combined per sample with the corrected operators of ERRATA 1
//!   (union `min`, intersection `max`, difference `max(a, −b)`); block ranges for skipping
//!   come from interval arithmetic on both operands' ranges, and the object map (`id`
//!   [`kernel::ID_SURFACE_B`] where B owns the hit) takes the normal and curvatures from
//!   the owner's own derivatives, which keeps CSG edges sharp.
#![warn(missing_docs)]

mod cache;
pub mod clip;
pub mod dvr;
mod error;
mod flow;
mod gbuffer;
pub mod gpu;
pub mod quadric;
mod raycast;
pub mod segmented;
pub mod setup;
pub mod shade;
pub mod spherical;
pub mod splat;
pub mod supersample;
pub mod tets;
mod volume;

/// The ray caster's per-pixel kernel, the CPU twin of `shaders/raycast.wgsl` (the module
/// `raycast/cpu.rs`).
pub use raycast::cpu as kernel;
pub use raycast::start::StartRaster;

pub use cache::{BrickCache, CacheStats, DEFAULT_CACHE_BYTES, HALF_RESOLUTION, NOT_RESIDENT};
pub use error::{BYTES_PER_PIXEL, MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, RenderError, check_image_size};
pub use gbuffer::{EXR_FAR, EXR_NEAR, GBUFFER_CHANNELS, GBuffer, exr_camera};
pub use isokit_field::curvature::Inside;
pub use kernel::{GSample, Uniforms};
pub use raycast::render::{
    CachePolicy, Filter, Frame, MultiView, RefineMethod, RenderOptions, RenderStats, Search,
    camera_uniforms, estimate_gradient_scale, render, render_multiview, render_reusing,
    render_view, uniforms,
};
pub use raycast::reuse::{KeptFrame, changed_blocks};
pub use shade::{Image, Light, Shading, ShadingMode, shade, shade_reusing};
pub use volume::{Combine, Layout, Volume, VolumeData};
