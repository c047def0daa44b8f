//! Warm frames of the ray caster (either twin) on three generated fields (`isokit bench render`): an
//! analytic sphere sampled densely, the trefoil knot tube sampled lazily as a band from its
//! exact mesh distance, and a CT-like density (a sum of Gaussians, inside above the
//! isovalue). Each scene is traced once to fill the brick cache, then from new cameras (a
//! small orbit); every row is compared with the quality reference, the adaptive fixed-rate
//! search at r0 = 8, n = 8 with 16 secant steps, on the first warm camera.

use glam::Vec3;
use isokit_field::primitives::Sphere;
use isokit_field::{Aabb, BrickGrid, Camera, Field, Grid, Projection, generate, sample_into};
use isokit_kdtree::MeshSdf;
use isokit_render::gpu::GpuRenderer;
use isokit_render::{
    BrickCache, Filter, Frame, Inside, Layout, RenderOptions, Search, Shading, ShadingMode, Volume,
    render, shade,
};
use std::time::Instant;

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct RenderBenchOptions {
    /// Image width in pixels (default 512).
    pub size: u32,
    /// Image height in pixels (`None`: square, `size`).
    pub height: Option<u32>,
    /// Trace and shade on the GPU twin ([`GpuRenderer`], G-buffer read back each frame)
    /// instead of the CPU twin (default false).
    pub gpu: bool,
    /// Samples along the longest side of each field (default 256).
    pub res: usize,
    /// Warm frames per row; the median is reported (default 5).
    pub frames: usize,
}

impl Default for RenderBenchOptions {
    fn default() -> Self {
        Self {
            size: 512,
            height: None,
            gpu: false,
            res: 256,
            frames: 5,
        }
    }
}

/// One scene in one mode.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderBenchRow {
    /// The scene's name.
    pub scene: String,
    /// `phong` (the default: tricubic search and normals, Phong, no Hessian), `curvature`
    /// (tricubic Hessian per pixel, curvature shading), `trilinear` (trilinear search,
    /// tricubic normals, Phong) or `fixed` (the adaptive fixed-rate search at r0 = 1, the
    /// former default, Phong).
    pub mode: String,
    /// Median warm frame (trace and shade), milliseconds.
    pub frame_ms: f64,
    /// Median warm trace, milliseconds.
    pub trace_ms: f64,
    /// Median shading, milliseconds.
    pub shade_ms: f64,
    /// The first frame (bricks loaded) of a fresh cache, milliseconds (trace only).
    pub first_frame_ms: f64,
    /// Field samples per ray of the first warm frame.
    pub samples_per_ray: f64,
    /// Pixels whose hit status differs from the reference's.
    pub mask_pixels: usize,
    /// Mean |ΔZ| against the reference where both hit, voxels.
    pub mean_dz_voxels: f64,
    /// Largest |ΔZ| against the reference where both hit, voxels.
    pub max_dz_voxels: f64,
}

/// The measurements of [`render_bench`].
#[derive(Clone, Debug, PartialEq)]
pub struct RenderBench {
    /// Scene names, in order.
    pub scenes: Vec<String>,
    /// Scene `i`'s median warm frame in the default mode (`phong`), milliseconds.
    pub frame_ms: Vec<f64>,
    /// Seconds to build each scene's volume.
    pub setup_seconds: Vec<f64>,
    /// One row per scene and mode.
    pub rows: Vec<RenderBenchRow>,
    /// Worker threads.
    pub threads: usize,
    /// The device traced on: `CPU twin` or the GPU adapter's description.
    pub device: String,
    /// True where the GPU adapter is a software rasterizer (lavapipe, llvmpipe, WARP).
    pub software: bool,
}

/// The modes measured per scene (name, search options, shading mode).
fn modes(base: RenderOptions) -> [(&'static str, RenderOptions, ShadingMode); 4] {
    let phong = RenderOptions {
        curvature: false,
        ..base
    };
    [
        ("phong", phong, ShadingMode::Phong),
        (
            "curvature",
            RenderOptions {
                curvature: true,
                ..base
            },
            ShadingMode::Curvature,
        ),
        (
            "trilinear",
            RenderOptions {
                filter: Filter::Trilinear,
                ..phong
            },
            ShadingMode::Phong,
        ),
        (
            "fixed",
            RenderOptions {
                search: Search::Fixed,
                ..phong
            },
            ShadingMode::Phong,
        ),
    ]
}

/// A generated scene: name, volume, the shape's box (for the cameras), the base options.
struct Case {
    name: &'static str,
    volume: Volume,
    shape: Aabb,
    opts: RenderOptions,
}

fn sphere(res: usize) -> Result<Case, String> {
    let h = 2.0 / (res - 1) as f32;
    let mut g = Grid::new([res; 3], Vec3::splat(-1.0), h).map_err(|e| e.to_string())?;
    sample_into(
        &Sphere::new(Vec3::ZERO, 0.7).map_err(|e| e.to_string())?,
        &mut g,
    );
    Ok(Case {
        name: "sphere",
        volume: Volume::from_grid(g, Layout::default()).map_err(|e| e.to_string())?,
        shape: Aabb::new(Vec3::splat(-0.7), Vec3::splat(0.7)),
        opts: RenderOptions::default(),
    })
}

/// The trefoil tube's exact distance clamped to the band (continuous, Lipschitz 1).
struct Clamped<'a>(&'a MeshSdf, f32);

impl Field for Clamped<'_> {
    fn value(&self, p: Vec3) -> f32 {
        isokit_field::value_clamped(self.0, p, self.1)
    }
    fn bounds(&self) -> Aabb {
        Field::bounds(self.0)
    }
}

/// The trefoil knot tube (6144 triangles) as a band of 4 voxels, bricks of 4 samples, as
/// `isokit scene` samples a mesh by default.
fn trefoil(res: usize) -> Result<Case, String> {
    let mesh = generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 192, 16);
    let sdf = MeshSdf::new(&mesh, Default::default()).map_err(|e| e.to_string())?;
    let shape = Field::bounds(&sdf);
    let h0 = shape.size().max_element() / (res - 1) as f32;
    let band = 4.0 * h0;
    let (dims, origin, h) =
        Grid::covering_geometry(shape, res, band + 2.0 * h0).map_err(|e| e.to_string())?;
    let reach = 0.5 * 4.0 * h * 3f32.sqrt();
    let cap = (band + reach) * 1.001 + h;
    let bricks = BrickGrid::sample_field(&Clamped(&sdf, cap), dims, origin, h, 4, 0, band, band)
        .map_err(|e| e.to_string())?;
    Ok(Case {
        name: "trefoil band",
        volume: Volume::from_brick_grid(bricks, Layout::default()).map_err(|e| e.to_string())?,
        shape,
        opts: RenderOptions::default(),
    })
}

/// A CT-like density: 14 Gaussian blobs of different widths (fixed seeds), inside where the
/// density exceeds 0.5.
struct Blobs(Vec<(Vec3, f32, f32)>);

impl Field for Blobs {
    fn value(&self, p: Vec3) -> f32 {
        self.0
            .iter()
            .map(|&(c, s, a)| a * (-(p - c).length_squared() / (2.0 * s * s)).exp())
            .sum()
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    }
}

fn density(res: usize) -> Result<Case, String> {
    let mut state = 0x2026_u64;
    let mut next = move || {
        // SplitMix64.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let blobs = (0..14)
        .map(|_| {
            let c = Vec3::new(next(), next(), next()) * 1.1 - 0.55;
            (c, 0.08 + 0.14 * next(), 0.7 + 0.6 * next())
        })
        .collect();
    let field = Blobs(blobs);
    let h = 2.0 / (res - 1) as f32;
    let mut g = Grid::new([res; 3], Vec3::splat(-1.0), h).map_err(|e| e.to_string())?;
    sample_into(&field, &mut g);
    let volume = Volume::from_grid(g, Layout::default()).map_err(|e| e.to_string())?;
    let iso = 0.5;
    let opts = RenderOptions {
        iso,
        inside: Inside::Above,
        gradient_scale: isokit_render::estimate_gradient_scale(&volume, iso),
        ..RenderOptions::default()
    };
    Ok(Case {
        name: "CT-like density",
        volume,
        shape: Aabb::new(Vec3::splat(-0.8), Vec3::splat(0.8)),
        opts,
    })
}

/// A camera of the orbit around `shape`, `degrees` about the vertical axis, `w × h` pixels.
fn camera(shape: Aabb, (w, h): (u32, u32), degrees: f32) -> Result<Camera, String> {
    let (s, c) = degrees.to_radians().sin_cos();
    let from = Vec3::new(c - s * 1.4, 0.7, s + c * 1.4);
    let projection = Projection::Perspective {
        fov_y_degrees: 40.0,
    };
    Camera::framing(shape, from, projection, w, h).map_err(|e| e.to_string())
}

/// Hit-mask pixels that differ, and mean and largest |ΔZ| in voxels where both hit.
fn compare(f: &Frame, r: &Frame, spacing: f32) -> (usize, f64, f64) {
    let (mut mask, mut n, mut dz, mut dz_max) = (0, 0usize, 0f64, 0f64);
    for (a, b) in f.gbuffer.pixels().iter().zip(r.gbuffer.pixels()) {
        if a.is_hit() != b.is_hit() {
            mask += 1;
        } else if a.is_hit() {
            n += 1;
            let e = f64::from((a.depth - b.depth).abs() / spacing);
            dz += e;
            dz_max = dz_max.max(e);
        }
    }
    (mask, dz / n.max(1) as f64, dz_max)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The twin a row is traced and shaded on.
enum Twin<'a> {
    Cpu(Box<BrickCache>),
    Gpu(&'a mut GpuRenderer),
}

impl Twin<'_> {
    fn render(&mut self, v: &Volume, cam: &Camera, opts: &RenderOptions) -> Result<Frame, String> {
        match self {
            Twin::Cpu(c) => render(v, c, cam, opts),
            Twin::Gpu(g) => g.render(v, cam, opts),
        }
        .map_err(|e| e.to_string())
    }

    fn shade(&self, f: &Frame, sh: &Shading) -> Result<isokit_render::Image, String> {
        match self {
            Twin::Cpu(_) => shade(&f.gbuffer, &f.uniforms, sh),
            Twin::Gpu(g) => g.shade(&f.gbuffer, &f.uniforms, sh),
        }
        .map_err(|e| e.to_string())
    }
}

/// One scene in one mode: a first frame with a fresh cache, `frames` warm frames from new
/// cameras (trace and shade timed apart), the reference on the first warm camera.
fn row(
    case: &Case,
    mode: &str,
    opts: &RenderOptions,
    sm: ShadingMode,
    o: &RenderBenchOptions,
    gpu: Option<&mut GpuRenderer>,
) -> Result<RenderBenchRow, String> {
    let sh = Shading {
        mode: sm,
        ..Shading::default()
    };
    let v = &case.volume;
    let px = (o.size, o.height.unwrap_or(o.size));
    let mut twin = match gpu {
        Some(g) => Twin::Gpu(g),
        None => Twin::Cpu(Box::new(BrickCache::for_volume(v))),
    };
    let t = Instant::now();
    twin.render(v, &camera(case.shape, px, -2.0)?, opts)?;
    let first_frame_ms = ms(t);
    let (mut tr, mut shd, mut first) = (Vec::new(), Vec::new(), None);
    for k in 0..o.frames.max(1) {
        let cam = camera(case.shape, px, k as f32 * 0.5)?;
        let t = Instant::now();
        let f = twin.render(v, &cam, opts)?;
        tr.push(ms(t));
        let t = Instant::now();
        std::hint::black_box(twin.shade(&f, &sh)?);
        shd.push(ms(t));
        first.get_or_insert(f);
    }
    let f = first.unwrap_or_else(|| unreachable!("at least one frame"));
    let reference = RenderOptions {
        search: Search::Fixed,
        filter: Filter::Tricubic,
        r0: 8.0,
        fine: 8,
        refine_steps: 16,
        ..*opts
    };
    let r = twin.render(v, &camera(case.shape, px, 0.0)?, &reference)?;
    let (mask_pixels, mean_dz_voxels, max_dz_voxels) = compare(&f, &r, v.spacing());
    let frame: Vec<f64> = tr.iter().zip(&shd).map(|(a, b)| a + b).collect();
    Ok(RenderBenchRow {
        scene: case.name.to_string(),
        mode: mode.to_string(),
        frame_ms: median(frame),
        trace_ms: median(tr),
        shade_ms: median(shd),
        first_frame_ms,
        samples_per_ray: f.stats.samples_per_ray(),
        mask_pixels,
        mean_dz_voxels,
        max_dz_voxels,
    })
}

/// Measures warm frames of the ray caster (the CPU twin, or the GPU twin with
/// [`RenderBenchOptions::gpu`]) on the sphere, the trefoil band and the CT-like density in
/// every mode (see [`RenderBenchRow::mode`]); `progress` hears each row.
pub fn render_bench(
    o: &RenderBenchOptions,
    mut progress: impl FnMut(&RenderBenchRow),
) -> Result<RenderBench, String> {
    if o.size == 0 || o.height == Some(0) || o.res < 8 {
        return Err("the image size must be at least 1 and the resolution at least 8".into());
    }
    let mut gpu = if o.gpu {
        Some(GpuRenderer::open().map_err(|e| e.to_string())?)
    } else {
        None
    };
    let mut out = RenderBench {
        scenes: Vec::new(),
        frame_ms: Vec::new(),
        setup_seconds: Vec::new(),
        rows: Vec::new(),
        threads: rayon::current_num_threads(),
        device: gpu
            .as_ref()
            .map_or("CPU twin".into(), GpuRenderer::describe),
        software: gpu.as_ref().is_some_and(GpuRenderer::is_software),
    };
    let builders: [fn(usize) -> Result<Case, String>; 3] = [sphere, trefoil, density];
    for build in builders {
        let t = Instant::now();
        let case = build(o.res)?;
        out.setup_seconds.push(t.elapsed().as_secs_f64());
        out.scenes.push(case.name.to_string());
        for (i, (mode, opts, sm)) in modes(case.opts).iter().enumerate() {
            let r = row(&case, mode, opts, *sm, o, gpu.as_mut())?;
            progress(&r);
            if i == 0 {
                out.frame_ms.push(r.frame_ms);
            }
            out.rows.push(r);
        }
    }
    Ok(out)
}
