//! The two backends of one conformance suite (STYLE.md, "Tests": the same analytic check for
//! the CPU and the GPU ray caster). A reference test runs its body once per [`Twin`]:
//!
//! ```ignore
//! for mut t in twins("sphere_hits_normals_and_curvature") {
//!     let f = t.render(&v, &cam, &opts).unwrap();
//!     let tol = t.tol(1e-3, 1e-3 + raycast_tol::Z_VOXEL);
//!     assert!(worst < tol, "{t}: …");
//! }
//! ```
//!
//! [`twins`] yields the CPU twin always and then the GPU twin where an adapter opens (on
//! lavapipe in CI), reporting the GPU case through `isokit_gpu::testing::ran` or `skipped` as
//! the GPU-against-CPU files do, so CI's count of GPU tests that ran includes these. The GPU
//! renderer is opened once per test binary (as [`isokit_render::gpu::GpuRenderer::open`]
//! does: with `FLOAT32_FILTERABLE` where the adapter offers it) and locked only while its
//! iteration runs, so the CPU iterations of other tests go on meanwhile.
//!
//! How the suites treat the GPU's documented differences ([`raycast_tol`], [`splat_tol`]:
//! the GPU twin agrees with the CPU twin to rounding, not bit for bit, see
//! `isokit_render::gpu` and `isokit_render::gpu::splat`):
//! - a bound on a measured quantity against an analytic reference (depth, position,
//!   normal, curvature) is the CPU's bound on the CPU and the CPU's bound plus the
//!   documented GPU–CPU agreement on the GPU (the triangle inequality), written out per
//!   twin with [`Twin::tol`];
//! - identities between two frames of the same twin (skipping on and off, small caches,
//!   both inside conventions, a subpixel and its view alone) are exact on both: the same
//!   kernel on the same device takes the same decisions in the same arithmetic;
//! - hit/miss decisions against a reference with a margin (rays a twentieth of a voxel
//!   inside or outside a silhouette) are exact on both: the margins are hundreds of times
//!   the documented depth differences; where a test counts pixels on a mask's edge, the GPU
//!   may have the documented [`raycast_tol::MASK_PX`] more per frame involved.

use glam::Vec3;
use isokit_field::Camera;
use isokit_gpu::{Gpu, GpuError, GpuOptions, testing, wgpu};
use isokit_render::gpu::{DEFAULT_MAX_RAYS_PER_DISPATCH, GpuRenderer};
use isokit_render::splat::{
    self, ShadeStats, ShadowMap, ShadowOptions, SplatFrame, SplatOptions, SplatScene, SplatShading,
};
use isokit_render::{
    BrickCache, DEFAULT_CACHE_BYTES, Frame, GBuffer, Image, MultiView, RenderError, RenderOptions,
    Shading, Uniforms, Volume,
};
use std::fmt;
use std::sync::{Mutex, MutexGuard, OnceLock};

/// How closely the GPU ray caster and its deferred shading agree with the CPU twin: the
/// tolerances of `tests/gpu.rs`, shared with the twin suites (`raycast.rs`, `csg.rs`,
/// `downsample.rs`, `flow.rs`).
///
/// Measured on lavapipe and llvmpipe-GL over the scenes of `tests/gpu.rs` (64³-class grids,
/// `t` up to ~100 voxels): hit masks and ids equal, no outlier, |ΔZ| and |ΔP| at most
/// 5.3e-5 voxel, normals 3.6e-4°, curvatures 6.1e-5 relative, the same field evaluations on
/// every ray, Phong images equal in 8 bits; shading the same G-buffer within 5e-7 per linear
/// channel (`reflection` 8e-3). The bounds leave room for other drivers' rounding.
pub mod raycast_tol {
    /// Pixels per frame whose hit status may differ, each on the CPU mask's edge (a ray
    /// grazing the surface).
    pub const MASK_PX: usize = 2;
    /// Pixels per frame, again on the mask's edge, where both hit but the values below may
    /// be exceeded (the two twins bracket different crossings of a grazing ray).
    pub const OUTLIERS: usize = 2;
    /// Depth `Z` and position `P`, in voxels.
    pub const Z_VOXEL: f32 = 1e-4;
    /// Normals, degrees.
    pub const NORMAL_DEG: f32 = 0.01;
    /// `k1`, `k2`, relative to `max(|k|, K_FLOOR)` (curvature in f32 on the GPU, f64 on the
    /// CPU).
    pub const K_REL: f32 = 1e-3;
    /// Keeps flat regions, where curvature is rounding noise, from dividing by ~0.
    pub const K_FLOOR: f32 = 1.0;
    /// Mean absolute difference of Phong images in 8-bit sRGB.
    pub const IMAGE_MEAN: f64 = 0.05;
    /// Shading the same G-buffer: every linear channel (all modes but `reflection`).
    pub const SHADE_LINEAR: f32 = 1e-5;
    /// Shading the same G-buffer in the `reflection` mode, whose striped environment goes
    /// through `asin` and `sin(12·e)` (Vulkan allows 2⁻¹¹ absolute error for `sin`).
    pub const SHADE_LINEAR_REFLECTION: f32 = 2e-2;
}

/// How closely the GPU splatter and its shading agree with the CPU twin: the tolerances of
/// `tests/gpu_splat.rs` (whose module docs give what was measured), shared with `splat.rs`.
pub mod splat_tol {
    /// Pixels whose hit status may differ per scene (grazing rays, where the discriminant's
    /// rounding decides), each on the CPU mask's edge.
    pub const MASK_PX: usize = 6;
    /// Pixels, where both hit, that may see different objects (two surfaces within rounding
    /// of each other along the ray).
    pub const OBJECT_PX: usize = 2;
    /// Depth `Z` relative; positions relative to `max(|P|, Z)`.
    pub const DEPTH_REL: f32 = 1e-5;
    /// Normals, radians.
    pub const NORMAL_RAD: f32 = 1e-3;
    /// `k1`, `k2`, relative to the pixel's largest `|k|` (f32 on the GPU, f64 on the CPU).
    pub const K_REL: f32 = 1e-3;
    /// Principal direction `dir1` up to sign, radians, where `k1 − k2` exceeds a tenth of
    /// the largest `|k|`.
    pub const DIR1_RAD: f32 = 1e-2;
    /// Mean absolute difference of shaded images per channel.
    pub const IMAGE_MEAN: f64 = 1e-3;
    /// Largest difference of a shaded channel on all but `IMAGE_PX` pixels.
    pub const IMAGE_MAX: f32 = 0.05;
    /// Shaded pixels that may differ by more than `IMAGE_MAX` (a shadow sample or an outline
    /// weight flipped by rounding; the bilinear fetches carry about 8 bits of weight).
    pub const IMAGE_PX: usize = 4;
}

static RENDERER: OnceLock<Result<Mutex<GpuRenderer>, String>> = OnceLock::new();

/// The test binary's GPU renderer, opened once as [`GpuRenderer::open`] opens it (the kernels
/// must compile: a failure there fails the test instead of skipping it), locked for `test`
/// with the default cache and dispatch sizes; reported through `testing::ran`, or
/// `testing::skipped` (which panics under `ISOKIT_REQUIRE_GPU=1`) where no adapter opens.
pub fn gpu_renderer(test: &str) -> Option<MutexGuard<'static, GpuRenderer>> {
    let slot = RENDERER.get_or_init(|| {
        let filterable = GpuOptions {
            features: wgpu::Features::FLOAT32_FILTERABLE,
            ..GpuOptions::default()
        };
        let gpu = match Gpu::new(&filterable) {
            Err(GpuError::MissingFeatures { .. }) => Gpu::new(&GpuOptions::default()),
            other => other,
        };
        gpu.map(|g| Mutex::new(GpuRenderer::new(g).expect("kernels compile")))
            .map_err(|e| e.to_string())
    });
    match slot {
        Ok(m) => {
            let mut r = m.lock().unwrap_or_else(|e| e.into_inner());
            testing::ran(test, &r.describe());
            r.set_cache_bytes(DEFAULT_CACHE_BYTES);
            r.set_max_rays_per_dispatch(DEFAULT_MAX_RAYS_PER_DISPATCH);
            Some(r)
        }
        Err(reason) => {
            testing::skipped(test, reason);
            None
        }
    }
}

/// The CPU twin's state: a brick cache kept across frames (as the GPU renderer keeps its
/// own), made for the volume rendered with the size last set.
#[derive(Debug)]
pub struct CpuTwin {
    cache: Option<(u64, Box<BrickCache>)>,
    size: CacheSize,
}

#[derive(Clone, Copy, Debug)]
enum CacheSize {
    Bytes(usize),
    Bricks(usize),
}

impl Default for CpuTwin {
    fn default() -> Self {
        Self {
            cache: None,
            size: CacheSize::Bytes(DEFAULT_CACHE_BYTES),
        }
    }
}

impl CpuTwin {
    /// The cache for `v`: kept while the volume stays the same, else made anew (as the GPU
    /// renderer drops its cache for another volume).
    fn cache(&mut self, v: &Volume) -> Result<&mut BrickCache, RenderError> {
        if self.cache.as_ref().is_none_or(|(id, _)| *id != v.id()) {
            let c = match self.size {
                CacheSize::Bytes(b) => BrickCache::with_bytes(v, b)?,
                CacheSize::Bricks(n) => BrickCache::new(v, n)?,
            };
            self.cache = Some((v.id(), Box::new(c)));
        }
        Ok(&mut *self.cache.as_mut().unwrap_or_else(|| unreachable!()).1)
    }
}

/// One backend of the renderer: the CPU twin or the GPU twin.
pub enum Twin {
    /// `isokit_render::render`, `shade`, `splat::…` (rayon).
    Cpu(CpuTwin),
    /// [`GpuRenderer`]'s methods, the renderer locked for the test.
    Gpu(MutexGuard<'static, GpuRenderer>),
}

impl fmt::Display for Twin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.is_gpu() {
            "GPU twin"
        } else {
            "CPU twin"
        })
    }
}

/// The CPU twin, then the GPU twin where an adapter opens (locked when the iteration reaches
/// it, reported for `test` through `isokit_gpu::testing`).
pub fn twins(test: &str) -> impl Iterator<Item = Twin> {
    let test = test.to_owned();
    std::iter::once(Twin::Cpu(CpuTwin::default()))
        .chain(std::iter::once_with(move || gpu_renderer(&test).map(Twin::Gpu)).flatten())
}

impl Twin {
    /// True for the GPU twin.
    pub fn is_gpu(&self) -> bool {
        matches!(self, Twin::Gpu(_))
    }

    /// The CPU twin's brick cache of the volume last rendered, for assertions about the CPU's
    /// own bookkeeping (`None` on the GPU twin, whose bookkeeping is private, and before the
    /// first frame).
    pub fn cpu_cache(&self) -> Option<&BrickCache> {
        match self {
            Twin::Cpu(c) => c.cache.as_ref().map(|(_, c)| &**c),
            Twin::Gpu(_) => None,
        }
    }

    /// `cpu` on the CPU twin, `gpu` on the GPU twin: a tolerance written out per twin.
    pub fn tol<T>(&self, cpu: T, gpu: T) -> T {
        if self.is_gpu() { gpu } else { cpu }
    }

    /// Ray casts `v` ([`isokit_render::render`] or [`GpuRenderer::render`]); the brick cache
    /// persists across frames of the same volume.
    pub fn render(
        &mut self,
        v: &Volume,
        cam: &Camera,
        opts: &RenderOptions,
    ) -> Result<Frame, RenderError> {
        match self {
            Twin::Cpu(c) => isokit_render::render(v, c.cache(v)?, cam, opts),
            Twin::Gpu(g) => g.render(v, cam, opts),
        }
    }

    /// The multi-view geometric pass ([`isokit_render::render_multiview`]).
    pub fn render_multiview(
        &mut self,
        v: &Volume,
        cam: &Camera,
        opts: &RenderOptions,
        mv: &MultiView,
    ) -> Result<Frame, RenderError> {
        match self {
            Twin::Cpu(c) => isokit_render::render_multiview(v, c.cache(v)?, cam, opts, mv),
            Twin::Gpu(g) => g.render_multiview(v, cam, opts, mv),
        }
    }

    /// One view of a multi-view display alone ([`isokit_render::render_view`]).
    pub fn render_view(
        &mut self,
        v: &Volume,
        cam: &Camera,
        opts: &RenderOptions,
        mv: &MultiView,
        view: u32,
    ) -> Result<Frame, RenderError> {
        match self {
            Twin::Cpu(c) => isokit_render::render_view(v, c.cache(v)?, cam, opts, mv, view),
            Twin::Gpu(g) => g.render_view(v, cam, opts, mv, view),
        }
    }

    /// Deferred shading ([`isokit_render::shade()`] or [`GpuRenderer::shade`]).
    pub fn shade(&self, g: &GBuffer, u: &Uniforms, sh: &Shading) -> Result<Image, RenderError> {
        match self {
            Twin::Cpu(_) => isokit_render::shade(g, u, sh),
            Twin::Gpu(r) => r.shade(g, u, sh),
        }
    }

    /// Limits the brick cache to `bricks` slots (at least 1); drops the bricks held
    /// ([`BrickCache::new`], [`GpuRenderer::set_cache_bricks`]).
    pub fn set_cache_bricks(&mut self, bricks: usize) -> Result<(), RenderError> {
        match self {
            Twin::Cpu(c) => {
                if bricks == 0 {
                    return Err(RenderError::BadParameter {
                        name: "cache capacity",
                        value: "0".into(),
                        why: "must hold at least one brick",
                    });
                }
                c.size = CacheSize::Bricks(bricks);
                c.cache = None;
                Ok(())
            }
            Twin::Gpu(g) => g.set_cache_bricks(bricks),
        }
    }

    /// Limits the brick cache to `bytes` of samples; drops the bricks held
    /// ([`BrickCache::with_bytes`], [`GpuRenderer::set_cache_bytes`]).
    pub fn set_cache_bytes(&mut self, bytes: usize) {
        match self {
            Twin::Cpu(c) => {
                c.size = CacheSize::Bytes(bytes);
                c.cache = None;
            }
            Twin::Gpu(g) => g.set_cache_bytes(bytes),
        }
    }

    /// Splats a scene ([`splat::splat`] or [`GpuRenderer::splat`]).
    pub fn splat(
        &self,
        scene: &SplatScene,
        cam: &Camera,
        opts: &SplatOptions,
    ) -> Result<SplatFrame, RenderError> {
        match self {
            Twin::Cpu(_) => splat::splat(scene, cam, opts),
            Twin::Gpu(g) => g.splat(scene, cam, opts),
        }
    }

    /// Shades a splat frame ([`splat::shade_splat`] or [`GpuRenderer::shade_splat`]).
    pub fn shade_splat(
        &self,
        frame: &SplatFrame,
        scene: &SplatScene,
        opts: &SplatShading,
    ) -> Result<(Image, ShadeStats), RenderError> {
        match self {
            Twin::Cpu(_) => splat::shade_splat(frame, scene, opts),
            Twin::Gpu(g) => g.shade_splat(frame, scene, opts),
        }
    }

    /// The shadow map of a spot light at `light` ([`ShadowMap::render`] or
    /// [`GpuRenderer::shadow_map`]).
    pub fn shadow_map(
        &self,
        scene: &SplatScene,
        light: Vec3,
        opts: &ShadowOptions,
    ) -> Result<ShadowMap, RenderError> {
        match self {
            Twin::Cpu(_) => ShadowMap::render(scene, light, opts),
            Twin::Gpu(g) => g.shadow_map(scene, light, opts),
        }
    }
}
