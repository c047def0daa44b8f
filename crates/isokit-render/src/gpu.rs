//! The GPU twin of the ray caster and of deferred shading (wgpu compute, WGSL in
//! `shaders/raycast_common.wgsl`, `shaders/common/curvature.wgsl`, `shaders/raycast.wgsl`,
//! `shaders/common/shade_structs.wgsl`, `shaders/common/shade_functions.wgsl`,
//! `shaders/shade.wgsl` and, for the `flow` mode's LIC pass, `shaders/flow.wgsl`), and of
//! quadric splatting ([`splat`]).
//!
//! The host code of each kernel sits beside its CPU twin, named after its shader
//! (`crates/isokit-render/src/`): `raycast/gpu.rs` (`raycast.wgsl`; CPU twin
//! `raycast/cpu.rs`, public as [`crate::kernel`]), `shade/gpu.rs` (`shade.wgsl`;
//! `shade/cpu.rs`), `flow/gpu.rs` (`flow.wgsl`; `flow/cpu.rs`), `dvr/gpu.rs` (`dvr.wgsl`;
//! `dvr/mod.rs`), `tets/gpu.rs` (`tets.wgsl`; `tets/mod.rs`, `tets/dvr.rs`),
//! `segmented/gpu.rs` (`segmented.wgsl`; `segmented/mod.rs`), `splat/gpu.rs`
//! (`splat.wgsl`, `splat_shade.wgsl`; `splat/cpu.rs`). This module holds what they share:
//! the device and its pipelines ([`GpuRenderer`]), the constants generated from Rust, the
//! backend choice ([`select_backend`]).
//!
//! [`GpuRenderer`] renders the same [`GBuffer`] as [`crate::render`] and shades it as
//! [`crate::shade()`] does: the kernels mirror [`crate::kernel`] and
//! [`crate::shade::shade_pixel`] function by function, over the same flat data.
//!
//! ## Data on the GPU
//! - the [`Uniforms`] as a uniform buffer (208 bytes);
//! - the brick pool as a storage buffer of f32, slot `s` at `s · channels · brick_side³`, x
//!   fastest, a second field's channel after the first (as [`crate::BrickCache::pool`]): the filters' fetches are 8 loads and 7 lerps each, so no
//!   float-filterable 3D texture is needed and the values equal the CPU's up to the
//!   rounding of the arithmetic (no 16-bit storage, no texture filtering precision);
//! - the reference index (`u32` per brick, slot, [`crate::HALF_RESOLUTION`] `|` half slot,
//!   or [`crate::NOT_RESIDENT`]) and the block
//!   ranges (`vec2<f32>` per block, [`Volume::trace_ranges`]: for a volume with a second
//!   field they depend on ρ and the inside sign and are sent with every frame; blocks
//!   without finite samples are sent as `[f32::MAX, −f32::MAX]`, which no isovalue lies
//!   in, instead of `[+∞, −∞]`);
//! - counters (rays that wait, requests and used flags per brick), the lists of waiting
//!   rays, their resume state, and the G-buffer: 64 bytes per ray, the four `rgba32f` rows
//!   `(P.xyz, Z), (N.xyz, A), (K1, K2, id, samples), (dir1.xyz, 0)`.
//!
//! ## The passes
//! The host runs the same loop as the CPU twin (`raycast/render.rs`): the active bricks are
//! prefetched nearest first into the pool; a pass traces every pending ray; a ray that
//! reaches an active brick that is not resident asks for it (atomic add), saves where to
//! resume and appends itself to the next pass's list; the host reads back the counters,
//! loads the bricks asked for (most requested first, LRU eviction) and runs the next pass
//! over the waiting rays only, until none waits. Images larger than
//! [`GpuRenderer::max_rays_per_dispatch`] are traced in chunks of rays, each with its own
//! passes.
//!
//! ## What differs from the CPU twin
//! The arithmetic is f32 on both sides and written in the same order, but the GPU compiler
//! may contract `a·b + c` into fused multiply-adds and its `sqrt`, division, `atan2`, `sin`
//! and `cos` may round differently, and the curvature (f64 on the CPU, [`curvature_with`])
//! is computed in f32. The results therefore agree to rounding, not bit for bit. Measured
//! on lavapipe (Vulkan) and llvmpipe (GL) over the scenes of `tests/gpu.rs` (spheres,
//! the trefoil band, thin sheets, small caches, both inside conventions, multi-view): the
//! same hit masks, ids and field-evaluation counts on every ray; hit depths and positions
//! within 5.3e-5 voxel, normals within 3.6e-4°, principal curvatures within 6.1e-5
//! relative; Phong images equal in 8 bits. Shading the same G-buffer agrees within 5e-7
//! per linear channel, except the `reflection` mode (8e-3: its environment goes through
//! `asin` and `sin`, which GPUs compute with looser error bounds).
//!
//! [`curvature_with`]: isokit_field::curvature::curvature_with
//! [`GBuffer`]: crate::GBuffer
//! [`Uniforms`]: crate::Uniforms
//! [`Volume::trace_ranges`]: crate::Volume::trace_ranges

pub use crate::flow::gpu::flow_shader;
pub use crate::raycast::gpu::raycast_shader;
pub use crate::segmented::gpu::segmented_shader;
pub use crate::shade::gpu::shade_shader;
/// The GPU twin of quadric splatting (the same module as [`crate::splat::gpu`]).
pub use crate::splat::gpu as splat;
pub use crate::tets::gpu::tets_shader;

use crate::kernel::{
    COMBINE_DIFFERENCE, COMBINE_INTERSECTION, COMBINE_MORPH, COMBINE_NONE, COMBINE_UNION,
    FILTER_TRICUBIC, FILTER_TRILINEAR, FLAG_CAPS, FLAG_SECANT, FLAG_SKIP_EMPTY, ID_CAP, ID_MISS,
    ID_SURFACE, ID_SURFACE_B, RANGE_MARGIN,
};
use crate::raycast::gpu::{GpuPixel, Resident};
use crate::{DEFAULT_CACHE_BYTES, NOT_RESIDENT, RenderError};
use isokit_field::curvature::DEFAULT_MIN_GRADIENT;
pub use isokit_gpu::{BackendChoice, Gpu, GpuError, GpuOptions, testing};
use isokit_gpu::{ShaderSource, wgpu};

/// Threads per workgroup of both kernels (prepended to the WGSL as `WORKGROUP`).
pub const WORKGROUP: u32 = 64;

/// Rays traced per dispatch unless [`GpuRenderer::set_max_rays_per_dispatch`] says otherwise
/// (and the device's buffer limits allow): 2²⁰, 64 MiB of G-buffer.
pub const DEFAULT_MAX_RAYS_PER_DISPATCH: usize = 1 << 20;

/// Runs `f` (buffer allocations, bind groups) under out-of-memory and validation error
/// scopes, so that what wgpu reports comes back as an error instead of reaching its default
/// handler, which panics.
pub(crate) fn scoped<T>(gpu: &Gpu, what: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
    let oom = gpu
        .device()
        .push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let invalid = gpu.device().push_error_scope(wgpu::ErrorFilter::Validation);
    let out = f();
    let invalid = pollster::block_on(invalid.pop());
    let oom = pollster::block_on(oom.pop());
    match (oom, invalid) {
        (Some(e), _) => Err(GpuError::TooLarge(format!("{what}: {e}"))),
        (None, Some(e)) => Err(GpuError::Wgpu(format!("{what}: {e}"))),
        (None, None) => Ok(out),
    }
}

/// The workgroup grid of a dispatch over `count` items (x up to the device's limit, the rest
/// along y) and the invocations per row of workgroups (the `stride` the shaders read).
pub(crate) fn dispatch_grid(gpu: &Gpu, count: usize) -> ([u32; 3], u32) {
    let max = gpu.limits().max_compute_workgroups_per_dimension.max(1) as usize;
    let groups = count.div_ceil(WORKGROUP as usize).max(1);
    let gx = groups.min(max);
    let gy = groups.div_ceil(gx);
    ([gx as u32, gy as u32, 1], gx as u32 * WORKGROUP)
}

/// Checks that a buffer of `bytes` fits the device's largest storage binding.
pub(crate) fn check_fits(gpu: &Gpu, what: &str, bytes: u64) -> Result<(), GpuError> {
    let limit = gpu.max_storage_bytes();
    if bytes > limit {
        return Err(GpuError::TooLarge(format!(
            "{what} takes {bytes} bytes, more than the device's largest storage buffer ({limit} bytes)"
        )));
    }
    Ok(())
}

/// The constants the ray caster's and the splatter's kernels share, generated from Rust (the single source of truth).
pub(crate) fn constants(label: &str) -> ShaderSource {
    ShaderSource::new(label)
        .constant_u32("WORKGROUP", WORKGROUP)
        .constant_u32("ID_MISS", ID_MISS)
        .constant_u32("ID_SURFACE", ID_SURFACE)
        .constant_u32("ID_CAP", ID_CAP)
        .constant_u32("ID_SURFACE_B", ID_SURFACE_B)
        .constant_u32("FILTER_TRILINEAR", FILTER_TRILINEAR)
        .constant_u32("FILTER_TRICUBIC", FILTER_TRICUBIC)
        .constant_u32("FLAG_SKIP_EMPTY", FLAG_SKIP_EMPTY)
        .constant_u32("FLAG_CAPS", FLAG_CAPS)
        .constant_u32("FLAG_SECANT", FLAG_SECANT)
        .constant_u32("FLAG_SPHERE", crate::kernel::FLAG_SPHERE)
        .constant_u32("FLAG_CURVATURE", crate::kernel::FLAG_CURVATURE)
        .constant_u32("COMBINE_NONE", COMBINE_NONE)
        .constant_u32("COMBINE_UNION", COMBINE_UNION)
        .constant_u32("COMBINE_INTERSECTION", COMBINE_INTERSECTION)
        .constant_u32("COMBINE_DIFFERENCE", COMBINE_DIFFERENCE)
        .constant_u32("COMBINE_MORPH", COMBINE_MORPH)
        .constant_u32("NOT_RESIDENT", NOT_RESIDENT)
        .constant_u32("HALF_RESOLUTION", crate::HALF_RESOLUTION)
        .constant_f32("RANGE_MARGIN", RANGE_MARGIN)
        .constant_f32("REFINE_TOLERANCE", crate::kernel::REFINE_TOLERANCE)
        .constant_f32("SLOPE_MARGIN", crate::kernel::SLOPE_MARGIN)
        .constant_f32("CARRY_MARGIN", crate::kernel::CARRY_MARGIN)
        .constant_f32("MIN_GRADIENT", DEFAULT_MIN_GRADIENT)
        .constant_f32("F32_MAX", f32::MAX)
}

/// The GPU ray caster and shader: a device, the two compiled kernels, and the brick cache
/// of the last volume rendered (kept across frames, as the CPU's [`crate::BrickCache`]).
///
/// ```no_run
/// use isokit_field::{Grid, sample_into, primitives::Sphere, Camera, Projection};
/// use isokit_render::gpu::GpuRenderer;
/// use isokit_render::{Layout, RenderOptions, Shading, Volume};
/// use glam::Vec3;
///
/// let mut grid = Grid::new([32; 3], Vec3::splat(-1.0), 2.0 / 31.0).unwrap();
/// sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
/// let volume = Volume::from_grid(grid, Layout::default()).unwrap();
/// let camera = Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y,
///     Projection::Perspective { fov_y_degrees: 40.0 }, 24, 24).unwrap();
/// let mut gpu = GpuRenderer::open().unwrap();
/// let frame = gpu.render(&volume, &camera, &RenderOptions::default()).unwrap();
/// let image = gpu.shade(&frame.gbuffer, &frame.uniforms, &Shading::default()).unwrap();
/// assert_eq!(image.pixels.len(), 24 * 24);
/// ```
#[derive(Debug)]
pub struct GpuRenderer {
    pub(crate) gpu: Gpu,
    /// `raycast.wgsl` (host code in `raycast/gpu.rs`).
    pub(crate) trace: wgpu::ComputePipeline,
    /// `shade.wgsl` (host code in `shade/gpu.rs`).
    pub(crate) shade: wgpu::ComputePipeline,
    /// The `flow` mode's LIC pass, `flow.wgsl` (host code in `flow/gpu.rs`).
    pub(crate) flow: wgpu::ComputePipeline,
    /// Brick slots asked for (the pool is bounded by the device's limits, too).
    pub(crate) cache_bricks: Option<usize>,
    pub(crate) cache_bytes: usize,
    pub(crate) max_rays: usize,
    pub(crate) resident: Option<Resident>,
    /// The splatter's pipelines (`splat.wgsl`, `splat_shade.wgsl`; host code in
    /// `splat/gpu.rs`), compiled on first use.
    pub(crate) splat: std::sync::OnceLock<splat::SplatPipelines>,
    /// Direct volume rendering, `dvr.wgsl` (host code in `dvr/gpu.rs`), compiled on first
    /// use.
    pub(crate) dvr: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The isosurface of a spherical volume, `dvr.wgsl`'s `spherical_iso` (host code in
    /// `dvr/gpu.rs`), compiled on first use.
    pub(crate) spherical_iso: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The isosurface of a tetrahedral grid, `tets.wgsl`'s `tet_iso` (host code in
    /// `tets/gpu.rs`), compiled on first use.
    pub(crate) tet_iso: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// Volume rendering through a tetrahedral grid's cells, `tets.wgsl`'s `tet_dvr`,
    /// compiled on first use.
    pub(crate) tet_dvr: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The surfaces of a segmented field, `segmented.wgsl` (host code in
    /// `segmented/gpu.rs`), compiled on first use.
    pub(crate) segmented: std::sync::OnceLock<wgpu::ComputePipeline>,
}

impl GpuRenderer {
    /// Compiles both kernels on `gpu`. The brick cache holds up to [`DEFAULT_CACHE_BYTES`]
    /// of samples (less where the device's largest storage buffer is smaller).
    pub fn new(gpu: Gpu) -> Result<Self, RenderError> {
        let t = raycast_shader();
        let trace = gpu.compute_pipeline(t.label(), t.text(), "trace")?;
        let s = shade_shader();
        let shade = gpu.compute_pipeline(s.label(), s.text(), "shade")?;
        let f = flow_shader();
        let flow = gpu.compute_pipeline(f.label(), f.text(), "flow")?;
        Ok(Self {
            gpu,
            trace,
            shade,
            flow,
            cache_bricks: None,
            cache_bytes: DEFAULT_CACHE_BYTES,
            max_rays: DEFAULT_MAX_RAYS_PER_DISPATCH,
            resident: None,
            splat: std::sync::OnceLock::new(),
            dvr: std::sync::OnceLock::new(),
            spherical_iso: std::sync::OnceLock::new(),
            tet_iso: std::sync::OnceLock::new(),
            tet_dvr: std::sync::OnceLock::new(),
            segmented: std::sync::OnceLock::new(),
        })
    }

    /// Opens the default device ([`GpuOptions::default`], with
    /// [`wgpu::Features::FLOAT32_FILTERABLE`] where the adapter offers it, for the splat
    /// shading's bilinear fetches) and compiles the kernels.
    pub fn open() -> Result<Self, RenderError> {
        let filterable = GpuOptions {
            features: wgpu::Features::FLOAT32_FILTERABLE,
            ..GpuOptions::default()
        };
        let gpu = match Gpu::new(&filterable) {
            Err(GpuError::MissingFeatures { .. }) => Gpu::new(&GpuOptions::default())?,
            other => other?,
        };
        Self::new(gpu)
    }

    /// The device.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// One line naming the adapter, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, …)`.
    pub fn describe(&self) -> String {
        self.gpu.describe()
    }

    /// True when the adapter is a software rasterizer running on the CPU (lavapipe,
    /// llvmpipe): correct, but its timings say nothing about a GPU.
    pub fn is_software(&self) -> bool {
        self.gpu.is_software()
    }

    /// Rays traced per dispatch at most (default [`DEFAULT_MAX_RAYS_PER_DISPATCH`], at least
    /// 1): larger images are traced in chunks, each with its own passes (which
    /// [`crate::RenderStats::passes`] adds up). Bounds the G-buffer and ray-state buffers (104
    /// bytes per ray) and the length of one dispatch; changes no pixel.
    pub fn set_max_rays_per_dispatch(&mut self, rays: usize) {
        self.max_rays = rays.max(1);
    }

    /// Rays one dispatch traces: the setting, bounded by the device's largest storage
    /// buffer (64 bytes of G-buffer per ray).
    pub fn max_rays_per_dispatch(&self) -> usize {
        let by_limit = (self.gpu.max_storage_bytes() / size_of::<GpuPixel>() as u64) as usize;
        self.max_rays.min(by_limit).max(1)
    }
}

/// What `--backend` (or `ISOKIT_BACKEND`) resolved to.
#[derive(Debug)]
pub struct Selected {
    /// The GPU renderer, or `None` for the CPU twin.
    pub gpu: Option<GpuRenderer>,
    /// Why the CPU twin renders although `auto` was asked for (no usable adapter, or only
    /// a software one): a line for the user.
    pub note: Option<String>,
}

/// Resolves a backend request by [`isokit_gpu::choose_backend`] (the one policy: `auto`
/// takes a hardware GPU, else the CPU twin with a note) and compiles the kernels on the
/// device it chose.
pub fn select_backend(choice: BackendChoice) -> Result<Selected, RenderError> {
    let chosen = isokit_gpu::choose_backend(choice, &GpuOptions::default())?;
    Ok(Selected {
        gpu: chosen.gpu.map(GpuRenderer::new).transpose()?,
        note: chosen
            .reason
            .map(|why| format!("note: {why}; rendering on the CPU twin (same algorithm)")),
    })
}

/// Every program the renderer builds, in every variant, for the tests.
#[cfg(test)]
pub(crate) fn every_shader() -> Vec<ShaderSource> {
    vec![
        raycast_shader(),
        shade_shader(),
        flow_shader(),
        splat::splat_shader(true),
        splat::splat_shader(false),
        splat::splat_shade_shader(),
        crate::dvr::gpu::dvr_shader(),
        crate::tets::gpu::tets_shader(),
        crate::segmented::gpu::segmented_shader(),
    ]
}

/// Checks `T` member by member against its WGSL twin in every program that declares it
/// (and that at least one does).
#[cfg(test)]
#[track_caller]
pub(crate) fn check_layout_everywhere<T: isokit_gpu::WgslStruct>() {
    let mut found = 0;
    for src in every_shader() {
        if isokit_gpu::wgsl_struct_size(src.text(), T::WGSL_NAME).is_some() {
            isokit_gpu::testing::assert_wgsl_layout::<T>(&src);
            found += 1;
        }
    }
    assert!(found > 0, "no program declares struct {}", T::WGSL_NAME);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::Uniforms;

    #[test]
    fn every_shader_validates_with_naga() {
        raycast_shader().validate().unwrap();
        shade_shader().validate().unwrap();
        flow_shader().validate().unwrap();
        for src in every_shader() {
            src.validate().unwrap();
        }
    }

    #[test]
    fn every_file_of_the_renderer_is_in_a_validated_program() {
        // Every WGSL file except the prism scan conversion's (validated by isokit-prism) is
        // a piece of at least one program validated above.
        let programs = every_shader();
        for (path, src) in isokit_shaders::ALL {
            if path.contains("prism") {
                continue;
            }
            assert!(
                programs.iter().any(|p| p.text().contains(src)),
                "{path} is part of no program"
            );
        }
    }

    #[test]
    fn gpu_structs_match_their_rust_twins() {
        let t = raycast_shader();
        let size = |src: &ShaderSource, name| isokit_gpu::wgsl_struct_size(src.text(), name);
        assert_eq!(size(&t, "Uniforms"), Some(size_of::<Uniforms>() as u32));
        assert_eq!(size_of::<Uniforms>(), 208);
        assert!(t.text().contains("morph_t: f32"));
        assert_eq!(size(&t, "GPixel"), Some(size_of::<GpuPixel>() as u32));
        assert_eq!(size_of::<GpuPixel>(), 64);
        assert_eq!(
            size(&t, "Params"),
            Some(size_of::<crate::raycast::gpu::Params>() as u32)
        );
        assert_eq!(
            size(&t, "RayState"),
            Some(crate::raycast::gpu::RAY_STATE_BYTES as u32)
        );
        let s = shade_shader();
        assert_eq!(
            size(&s, "ShadeParams"),
            Some(size_of::<crate::shade::gpu::ShadeParams>() as u32)
        );
        assert_eq!(
            size(&s, "Light"),
            Some(size_of::<crate::shade::gpu::GpuLight>() as u32)
        );
        assert_eq!(
            size(&flow_shader(), "FlowParams"),
            Some(size_of::<crate::flow::gpu::FlowParams>() as u32)
        );
    }
}
