//! `isokit render SCENE|VOLUME -o image.png [...]`: the isosurface ray cast into a G-buffer
//! and shaded; `--watch` renders again whenever the input or anything it references
//! changes. `isokit render A.nrrd --csg union|intersection|difference|morph --with B.nrrd
//! [--morph-t T]` combines two volumes on the same lattice per sample while ray casting
//! (002 Sec. 6.4.3): union min, intersection max, difference max(a, −b) of the residuals
//! (negative inside), or the linear morph; normals come from the operand that owns each
//! pixel, so CSG edges stay sharp.

use super::check_output;
use super::mesh::Inside as InsideArg;
use anyhow::{Context, Result, bail};
use isokit_field::Aabb;
use isokit_io::read_volume;
use isokit_levelset::scene::schema::{Node, SceneFile};
use isokit_levelset::scene::{SampleOptions, Scene, SceneFormat};
use isokit_render::gpu::{BackendChoice, GpuRenderer, select_backend};
use isokit_render::setup::{ProjectionKind, camera_for_scene, shading_for_scene};
use isokit_render::shade::default_curvature_scale;
use isokit_render::{
    BrickCache, CachePolicy, Combine, Filter, Frame, Image, Inside, Layout, MultiView,
    RefineMethod, RenderOptions, Shading, ShadingMode, Volume, check_image_size,
    estimate_gradient_scale, render, render_multiview, render_view, shade,
};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// Which implementation renders.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// `ISOKIT_BACKEND=cpu|gpu` when set; else a hardware GPU when one exists, the CPU
    /// (with a note) when none does or the only adapter is a software one (lavapipe).
    Auto,
    /// The CPU ray caster (rayon).
    Cpu,
    /// The GPU ray caster (wgpu); an error when no adapter exists.
    Gpu,
}

impl Backend {
    fn choice(self) -> BackendChoice {
        match self {
            Backend::Auto => BackendChoice::Auto,
            Backend::Cpu => BackendChoice::Cpu,
            Backend::Gpu => BackendChoice::Gpu,
        }
    }
}

/// Opens the renderer `backend` asks for: `Some` GPU renderer, or `None` for the CPU twin
/// (printing why when `auto` found no hardware GPU).
pub fn open_backend(backend: Backend) -> Result<Option<GpuRenderer>> {
    let selected = select_backend(backend.choice()).context("choosing the backend")?;
    if let Some(note) = &selected.note {
        eprintln!("{note}");
    }
    Ok(selected.gpu)
}

/// The name of the backend for messages and `--stats`.
pub fn backend_name(gpu: Option<&GpuRenderer>) -> String {
    match gpu {
        Some(g) => format!("GPU ({})", g.describe()),
        None => "CPU".to_string(),
    }
}

/// Refinement method.
/// What a brick cache too small for the active bricks does.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CachePolicyArg {
    /// Render the exact image in several passes.
    Passes,
    /// Store the least detailed bricks at half resolution so that all fit, one pass
    /// (002 Sec. 6.2.3; hanging samples matched, no cracks).
    Downsample,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refine {
    /// Halve the bracket.
    Bisection,
    /// Secant (Illinois).
    Secant,
}

/// Arguments of `isokit render`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A scene file (.json, .toml) or a volume (.nrrd .nhdr .npy .nii .nii.gz).
    pub input: PathBuf,
    /// Output image (.png).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u64,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u64,
    /// Shading: phong, tone, normal, curvature, mean, gaussian, k1, k2, ridges, silhouette,
    /// accessibility [default: the scene's `shading.mode`, else phong].
    #[arg(long)]
    pub shading: Option<String>,
    /// Isovalue [default: 0, or for a volume whose values do not reach 0 the middle of its
    /// range].
    #[arg(long)]
    pub iso: Option<f32>,
    /// Which side of the isovalue is inside.
    #[arg(long, value_enum, default_value_t = InsideArg::Below)]
    pub inside: InsideArg,
    /// Backend: auto (`ISOKIT_BACKEND=cpu|gpu` when set, else a hardware GPU when one
    /// exists and the CPU otherwise), cpu, gpu (any adapter, software ones included; an
    /// error without one).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Also write the G-buffer as OpenEXR (channels P.X P.Y P.Z N.X N.Y N.Z Z K1 K2 A).
    #[arg(long)]
    pub gbuffer: Option<PathBuf>,
    /// Render again whenever the input or a file it references changes (polling), keeping
    /// the last good image when a rendering fails. Stop with Ctrl-C.
    #[arg(long)]
    pub watch: bool,
    /// With --watch: stop after this many renderings (for scripts and tests).
    #[arg(long, hide = true)]
    pub watch_renders: Option<u32>,
    /// Scene sampling: samples along the longest side [default: `sampling.resolution`,
    /// else 128].
    #[arg(long)]
    pub res: Option<usize>,
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
    /// Print what the rendering did as one JSON object on stdout.
    #[arg(long)]
    pub stats: bool,
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

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".png"])?;
    if let Some(g) = &a.gbuffer {
        check_output(g, &[".exr"])?;
    }
    check_image_size(a.width, a.height)?;
    if a.csg.is_some() {
        if is_scene(&a.input) {
            bail!(
                "--csg combines two volumes; {} is a scene (use its union/intersection/difference/morph nodes instead)",
                a.input.display()
            );
        }
        if a.with.as_deref().is_some_and(is_scene) {
            bail!("--with must be a volume, not a scene");
        }
        combine_of(&a)?.check()?;
    }
    let filter: Filter = a.filter.parse().map_err(anyhow::Error::msg)?;
    let projection: ProjectionKind = a.projection.parse().map_err(anyhow::Error::msg)?;
    let mode: Option<ShadingMode> = a
        .shading
        .as_deref()
        .map(str::parse)
        .transpose()
        .map_err(anyhow::Error::msg)?;
    // Refuse bad knobs now rather than on every rendering of --watch.
    RenderOptions {
        iso: a.iso.unwrap_or(0.0),
        r0: a.r0,
        fine: a.fine,
        delta: a.delta,
        refine_steps: a.refine,
        ..Default::default()
    }
    .check()?;
    if let Some(n) = a.views {
        let mv = MultiView {
            pitch: a.lens_pitch.unwrap_or(n as f32),
            slant: a.lens_slant,
            ..MultiView::new(n, a.view_separation.unwrap_or(0.0))
        };
        mv.check()?;
    } else if a.views_out.is_some() {
        bail!("--views-out needs --views");
    }
    let settings = Settings {
        filter,
        projection,
        mode,
    };
    // Opened once: --watch reuses the device, its compiled kernels and its brick cache.
    let mut gpu = open_backend(a.backend)?;
    if !a.watch {
        return render_once(&a, &settings, gpu.as_mut()).map(|_| ());
    }
    watch(&a, &settings, gpu.as_mut())
}

struct Settings {
    filter: Filter,
    projection: ProjectionKind,
    mode: Option<ShadingMode>,
}

fn combine_of(a: &Args) -> Result<Combine> {
    if a.morph_t.is_some() && a.csg != Some(CsgOp::Morph) {
        bail!("--morph-t applies to --csg morph only");
    }
    Ok(match a.csg {
        Some(CsgOp::Union) | None => Combine::Union,
        Some(CsgOp::Intersection) => Combine::Intersection,
        Some(CsgOp::Difference) => Combine::Difference,
        Some(CsgOp::Morph) => Combine::Morph(a.morph_t.unwrap_or(0.5)),
    })
}

/// A volume file as a uniform grid (anisotropic volumes resampled).
fn read_grid(path: &Path) -> Result<isokit_field::Grid> {
    let v = read_volume(path)?;
    Ok(if v.is_uniform() {
        v.into_grid()?
    } else {
        let h = v.spacing.min_element();
        eprintln!(
            "note: resampling the anisotropic volume (spacing {}) to a uniform spacing {h}",
            v.spacing
        );
        v.resample_uniform(h)?
    })
}

fn is_scene(path: &Path) -> bool {
    SceneFormat::from_path(path).is_some()
}

/// What was rendered, for the summary line.
struct Rendered {
    frame: Frame,
    prepare_seconds: f64,
    shade_seconds: f64,
}

/// Loads the input into a ray-castable volume; returns it with the scene (if any) and what
/// was prepared.
fn load(a: &Args) -> Result<(Volume, Option<Scene>, String)> {
    if is_scene(&a.input) {
        let scene = Scene::load(&a.input)?;
        let mut opts = SampleOptions::from_scene(&scene);
        if let Some(r) = a.res {
            opts.resolution = r;
        }
        let (band, stats) = scene.sample(&opts)?;
        if let Some(iso) = a.iso
            && iso.abs() >= stats.band
        {
            eprintln!(
                "warning: --iso {iso} lies outside the sampled band (±{}); raise sampling.band",
                stats.band
            );
        }
        let what = format!(
            "{} x {} x {} lattice, {:.1}% of the dense samples evaluated in {:.2} s",
            stats.dims[0],
            stats.dims[1],
            stats.dims[2],
            100.0 * stats.dense_fraction,
            stats.seconds
        );
        let volume = Volume::from_brick_grid(band, Layout::default())?;
        Ok((volume, Some(scene), what))
    } else {
        let grid = read_grid(&a.input)?;
        let mut what = format!(
            "{} x {} x {} volume",
            grid.dims()[0],
            grid.dims()[1],
            grid.dims()[2]
        );
        let mut volume = Volume::from_grid(grid, Layout::default())?;
        if let (Some(_), Some(with)) = (a.csg, &a.with) {
            let b = read_grid(with)?;
            let combine = combine_of(a)?;
            volume = volume
                .with_operand(b, combine)
                .with_context(|| format!("--with {}", with.display()))?;
            what = format!("{what}, {combine:?} with {}", with.display());
        }
        Ok((volume, None, what))
    }
}

fn render_once(a: &Args, s: &Settings, mut gpu: Option<&mut GpuRenderer>) -> Result<Rendered> {
    let t0 = Instant::now();
    // Scene and volume errors already name the file.
    let (volume, scene, what) = load(a)?;
    let iso = match (a.iso, &scene, volume.value_range()) {
        (Some(v), _, _) => v,
        (None, None, Some((lo, hi))) if !(lo..=hi).contains(&0.0) => {
            let mid = 0.5 * (lo + hi);
            eprintln!("note: the values lie in [{lo}, {hi}]; using --iso {mid}");
            mid
        }
        _ => 0.0,
    };
    let inside = match a.inside {
        InsideArg::Below => Inside::Below,
        InsideArg::Above => Inside::Above,
    };
    let mut opts = RenderOptions {
        iso,
        inside,
        filter: s.filter,
        r0: a.r0,
        fine: a.fine,
        delta: a.delta,
        refine_steps: a.refine,
        refine: match a.refine_method {
            Refine::Bisection => RefineMethod::Bisection,
            Refine::Secant => RefineMethod::Secant,
        },
        skip_empty: !a.no_skip,
        cache_policy: match a.cache_policy {
            CachePolicyArg::Passes => CachePolicy::Passes,
            CachePolicyArg::Downsample => CachePolicy::Downsample,
        },
        ..Default::default()
    };
    if scene.is_none() {
        // Not known to be a distance field: estimate |∇f| for the fine-rate threshold.
        opts.gradient_scale = estimate_gradient_scale(&volume, iso);
    }
    opts.check()?;
    let (w, h) = check_image_size(a.width, a.height)?;
    let bounds: Aabb = volume.bounds();
    let (camera, mut shading) = match &scene {
        Some(sc) => {
            let f: &SceneFile = sc.settings();
            (
                camera_for_scene(f.camera.as_ref(), bounds, s.projection, w, h)?,
                shading_for_scene(f.shading.as_ref(), &f.lights)?,
            )
        }
        None => (
            camera_for_scene(None, bounds, s.projection, w, h)?,
            Shading::default(),
        ),
    };
    if let Some(m) = s.mode {
        shading.mode = m;
    }
    shading.curvature_scale = a
        .curvature_scale
        .unwrap_or_else(|| default_curvature_scale(bounds));
    shading.check()?;
    let mut cache = match a.cache_mb {
        Some(mb) => BrickCache::with_bytes(&volume, mb.saturating_mul(1 << 20))?,
        None => BrickCache::for_volume(&volume),
    };
    if let (Some(g), Some(mb)) = (gpu.as_deref_mut(), a.cache_mb) {
        g.set_cache_bytes(mb.saturating_mul(1 << 20));
    }
    let multiview = a.views.map(|n| MultiView {
        pitch: a.lens_pitch.unwrap_or(n as f32),
        slant: a.lens_slant,
        ..MultiView::new(
            n,
            a.view_separation
                .unwrap_or(0.01 * (camera.target() - camera.eye()).length()),
        )
    });
    let prepare_seconds = t0.elapsed().as_secs_f64();
    let frame = match (&multiview, gpu.as_deref_mut()) {
        (Some(mv), Some(g)) => g.render_multiview(&volume, &camera, &opts, mv)?,
        (Some(mv), None) => render_multiview(&volume, &mut cache, &camera, &opts, mv)?,
        (None, Some(g)) => g.render(&volume, &camera, &opts)?,
        (None, None) => render(&volume, &mut cache, &camera, &opts)?,
    };
    let shade_with = |f: &Frame, g: Option<&GpuRenderer>| -> Result<Image> {
        Ok(match g {
            Some(g) => g.shade(&f.gbuffer, &f.uniforms, &shading)?,
            None => shade(&f.gbuffer, &f.uniforms, &shading)?,
        })
    };
    let t1 = Instant::now();
    let image: Image = shade_with(&frame, gpu.as_deref())?;
    let shade_seconds = t1.elapsed().as_secs_f64();
    image.write_png(&a.output)?;
    if let (Some(mv), Some(dir)) = (&multiview, &a.views_out) {
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
        for k in 0..mv.views {
            let f = match gpu.as_deref_mut() {
                Some(g) => g.render_view(&volume, &camera, &opts, mv, k)?,
                None => render_view(&volume, &mut cache, &camera, &opts, mv, k)?,
            };
            shade_with(&f, gpu.as_deref())?.write_png(&dir.join(format!("view_{k:02}.png")))?;
        }
    }
    if let Some(g) = &a.gbuffer {
        frame.gbuffer.write_exr(g)?;
    }
    let st = &frame.stats;
    let backend = backend_name(gpu.as_deref());
    let capacity = match gpu.as_deref() {
        Some(g) => g.cache_capacity().unwrap_or(0),
        None => cache.capacity(),
    };
    eprintln!(
        "{what}; {backend}: {}x{}{} {} image: {} surface + {} cap pixels, {:.1} samples/ray, {}/{} blocks and {}/{} bricks active, {} pass(es), {} bricks loaded; prepare {:.2} s, trace {:.3} s, shade {:.3} s -> {}{}",
        frame.uniforms.width,
        st.height,
        multiview.map_or(String::new(), |m| format!(" {}-view", m.views)),
        shading.mode.name(),
        st.hits,
        st.caps,
        st.samples_per_ray(),
        st.blocks_active,
        st.blocks_total,
        st.bricks_active,
        st.bricks_total,
        st.passes,
        st.bricks_loaded,
        prepare_seconds,
        st.seconds,
        shade_seconds,
        a.output.display(),
        a.gbuffer
            .as_ref()
            .map_or(String::new(), |g| format!(", {}", g.display()))
    );
    if st.hits + st.caps == 0 {
        eprintln!("warning: no ray hit the surface f = {iso}");
    }
    if a.stats {
        let j = serde_json::json!({
            "width": st.width,
            "height": st.height,
            "iso": iso,
            "hits": st.hits,
            "caps": st.caps,
            "samples": st.samples,
            "samples_per_ray": st.samples_per_ray(),
            "blocks_active": st.blocks_active,
            "blocks_total": st.blocks_total,
            "bricks_active": st.bricks_active,
            "bricks_total": st.bricks_total,
            "bricks_loaded": st.bricks_loaded,
            "cache_capacity": capacity,
            "passes": st.passes,
            "bricks_downsampled": st.bricks_downsampled,
            "prepare_seconds": prepare_seconds,
            "trace_seconds": st.seconds,
            "shade_seconds": shade_seconds,
            "backend": if gpu.is_some() { "gpu" } else { "cpu" },
            "device": backend,
            "output": a.output.display().to_string(),
        });
        println!("{j}");
    }
    Ok(Rendered {
        frame,
        prepare_seconds,
        shade_seconds,
    })
}

/// Files whose change triggers a new rendering: the input, and for a scene every file its
/// tree references (meshes, clouds, volumes, included scenes and what they reference).
fn watched_files(input: &Path) -> Vec<PathBuf> {
    let mut out = vec![input.to_path_buf()];
    if is_scene(input) {
        collect_scene(input, &mut out, 0);
    }
    out
}

fn collect_scene(path: &Path, out: &mut Vec<PathBuf>, depth: usize) {
    let Some(format) = SceneFormat::from_path(path) else {
        return;
    };
    let Ok(text) = std::fs::read_to_string(path) else {
        return;
    };
    let name = path.display().to_string();
    let Ok(file) = isokit_levelset::scene::parse(&text, format, &name) else {
        return;
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut stack = vec![&file.shape];
    while let Some(node) = stack.pop() {
        match node {
            Node::Mesh { path, .. } | Node::Points { path, .. } | Node::Volume { path, .. } => {
                out.push(dir.join(path));
            }
            Node::Include { path } => {
                let p = dir.join(path);
                let seen = out.contains(&p);
                out.push(p.clone());
                // Cycles are the scene loader's error to report; stop at a depth anyway.
                if !seen && depth < 16 {
                    collect_scene(&p, out, depth + 1);
                }
            }
            Node::Union(v) | Node::Intersection(v) | Node::Difference(v) => stack.extend(v),
            Node::Complement(n) => stack.push(n),
            Node::SmoothUnion(s) | Node::SmoothIntersection(s) | Node::SmoothDifference(s) => {
                stack.extend(&s.of)
            }
            Node::Offset { of, .. } | Node::Shell { of, .. } => stack.push(of),
            Node::Morph { from, to, .. } => stack.extend([from.as_ref(), to.as_ref()]),
            Node::Transform(t) => stack.push(&t.of),
            _ => {}
        }
    }
}

/// Modification time and size of each file (`None` for a missing file).
fn stamp(files: &[PathBuf]) -> Vec<Option<(SystemTime, u64)>> {
    files
        .iter()
        .map(|f| {
            std::fs::metadata(f)
                .ok()
                .and_then(|m| Some((m.modified().ok()?, m.len())))
        })
        .collect()
}

fn watch(a: &Args, s: &Settings, mut gpu: Option<&mut GpuRenderer>) -> Result<()> {
    let limit = a.watch_renders.unwrap_or(u32::MAX);
    if limit == 0 {
        bail!("--watch-renders must be at least 1");
    }
    let mut renders = 0u32;
    loop {
        let files = watched_files(&a.input);
        let before = stamp(&files);
        match render_once(a, s, gpu.as_deref_mut()) {
            Ok(r) => eprintln!(
                "[watch] rendered in {:.2} s",
                r.prepare_seconds + r.frame.stats.seconds + r.shade_seconds
            ),
            Err(e) => eprintln!(
                "[watch] error: {e:#}; keeping the last good image {}",
                a.output.display()
            ),
        }
        renders += 1;
        if renders >= limit {
            return Ok(());
        }
        eprintln!("[watch] waiting for changes to {} file(s)", files.len());
        // Poll until something changed, then let the writer finish.
        loop {
            std::thread::sleep(Duration::from_millis(200));
            if stamp(&files) != before {
                std::thread::sleep(Duration::from_millis(100));
                break;
            }
        }
    }
}
