//! `isokit render SCENE|VOLUME -o image.png [...]`: the isosurface ray cast into a G-buffer
//! and shaded (`isokit_scene::Renderer`); `--watch` renders again whenever the input or a
//! file it references changes. `--csg OP --with B.nrrd` combines two volumes per sample
//! while ray casting (Sigg 2006, Sec. 6.4.3).

use super::args::{CsgArgs, InsideArg, MultiViewArgs, RaycastArgs, shading_names};
use super::{check_output, read_grid};
use anyhow::{Context, Result, bail};
use isokit_field::Job;
use isokit_render::{Layout, Volume, check_image_size};
use isokit_scene::{RenderSettings, RenderTarget, Renderer, Scene, SceneFormat};
use std::path::{Path, PathBuf};

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
    /// Shading mode [default: the scene's `shading.mode`, else phong].
    #[arg(long, value_parser = shading_names())]
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
    #[arg(long, value_enum, default_value_t = super::args::Backend::Auto)]
    pub backend: super::args::Backend,
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
    #[command(flatten)]
    pub knobs: RaycastArgs,
    #[command(flatten)]
    pub multiview: MultiViewArgs,
    #[command(flatten)]
    pub csg: CsgArgs,
    /// Print what the rendering did as one JSON object on stdout.
    #[arg(long)]
    pub stats: bool,
}

fn is_scene(path: &Path) -> bool {
    SceneFormat::from_path(path).is_some()
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".png"])?;
    if let Some(g) = &a.gbuffer {
        check_output(g, &[".exr"])?;
    }
    let (width, height) = check_image_size(a.width, a.height)?;
    if a.csg.csg.is_some() {
        if is_scene(&a.input) {
            bail!(
                "--csg combines two volumes; {} is a scene (use its union/intersection/difference/morph nodes instead)",
                a.input.display()
            );
        }
        if a.csg.with.as_deref().is_some_and(is_scene) {
            bail!("--with must be a volume, not a scene");
        }
    }
    a.csg.combine()?;
    let (multiview, default_separation) = a.multiview.multiview()?;
    let mode = a
        .shading
        .as_deref()
        .map(super::args::shading_mode)
        .transpose()?;
    // Refuse bad knobs now rather than on every rendering of --watch.
    let settings = RenderSettings {
        width,
        height,
        options: a.knobs.options(a.iso.unwrap_or(0.0), a.inside)?,
        iso: a.iso,
        mode,
        projection: a.knobs.projection()?,
        curvature_scale: a.knobs.curvature_scale,
        multiview,
        default_separation,
        cache_bytes: a.knobs.cache_bytes(),
        resolution: a.res,
        ..RenderSettings::default()
    };
    // Opened once: --watch reuses the device, its compiled kernels and its brick cache.
    let mut renderer = super::args::open_renderer(a.backend)?;
    if !a.watch {
        return render_once(&a, &settings, &mut renderer).map(|_| ());
    }
    let limit = a.watch_renders.unwrap_or(u32::MAX);
    if limit == 0 {
        bail!("--watch-renders must be at least 1");
    }
    for n in 1.. {
        let t = std::time::Instant::now();
        let files = match render_once(&a, &settings, &mut renderer) {
            Ok(files) => {
                eprintln!("[watch] rendered in {:.2} s", t.elapsed().as_secs_f64());
                files
            }
            Err(e) => {
                eprintln!(
                    "[watch] error: {e:#}; keeping the last good image {}",
                    a.output.display()
                );
                isokit_scene::watch::files_of(&a.input)
            }
        };
        if n >= limit {
            break;
        }
        eprintln!("[watch] waiting for changes to {} file(s)", files.len());
        isokit_scene::watch::wait_for_change(&files, &Job::default())?;
    }
    Ok(())
}

/// Renders once and writes the outputs; returns the files the rendering read.
fn render_once(a: &Args, s: &RenderSettings, renderer: &mut Renderer) -> Result<Vec<PathBuf>> {
    let name = a.input.display().to_string();
    let (frame, prepared_views, files, what) = if is_scene(&a.input) {
        let scene = Scene::load(&a.input)?;
        let files = scene.dependencies().to_vec();
        let p = renderer.prepare(RenderTarget::Scene(&scene), s, &Job::default())?;
        let frame = renderer.render_prepared(&p, &name)?;
        let views = views(a, renderer, &p, &name)?;
        let st = frame
            .stats
            .sampling
            .as_ref()
            .context("scene sampling stats")?;
        let what = format!(
            "{} x {} x {} lattice, {:.1}% of the dense samples evaluated in {:.2} s",
            st.dims[0],
            st.dims[1],
            st.dims[2],
            100.0 * st.dense_fraction,
            st.seconds
        );
        (frame, views, files, what)
    } else {
        let grid = read_grid(&a.input)?;
        let d = grid.dims();
        let mut what = format!("{} x {} x {} volume", d[0], d[1], d[2]);
        let mut volume = Volume::from_grid(grid, Layout::default())?;
        let mut files = vec![a.input.clone()];
        if let (Some(c), Some(with)) = (a.csg.combine()?, &a.csg.with) {
            volume = volume
                .with_operand(read_grid(with)?, c)
                .with_context(|| format!("--with {}", with.display()))?;
            what = format!("{what}, {c:?} with {}", with.display());
            files.push(with.clone());
        }
        let p = renderer.prepare(RenderTarget::Volume(&volume), s, &Job::default())?;
        let frame = renderer.render_prepared(&p, &name)?;
        let views = views(a, renderer, &p, &name)?;
        (frame, views, files, what)
    };
    for n in &frame.notes {
        eprintln!("{n}");
    }
    frame.image.write_png(&a.output)?;
    for (k, image) in prepared_views.iter().enumerate() {
        if let Some(dir) = &a.multiview.views_out {
            image.write_png(&dir.join(format!("view_{k:02}.png")))?;
        }
    }
    if let Some(g) = &a.gbuffer {
        frame.gbuffer.write_exr(g)?;
    }
    let st = &frame.stats;
    eprintln!(
        "{what}; {}: {}x{}{} {} image: {} surface + {} cap pixels, {:.1} samples/ray, {}/{} blocks and {}/{} bricks active, {} pass(es), {} bricks loaded; prepare {:.2} s, trace {:.3} s, shade {:.3} s -> {}{}",
        st.device,
        frame.uniforms.width,
        st.height,
        s.multiview
            .map_or(String::new(), |m| format!(" {}-view", m.views)),
        st.mode,
        st.hits,
        st.caps,
        st.samples_per_ray,
        st.blocks_active,
        st.blocks_total,
        st.bricks_active,
        st.bricks_total,
        st.passes,
        st.bricks_loaded,
        st.prepare_seconds,
        st.trace_seconds,
        st.shade_seconds,
        a.output.display(),
        a.gbuffer
            .as_ref()
            .map_or(String::new(), |g| format!(", {}", g.display()))
    );
    if a.stats {
        let mut j = serde_json::to_value(st)?;
        if let Some(o) = j.as_object_mut() {
            o.remove("sampling");
            o.insert("output".into(), a.output.display().to_string().into());
        }
        println!("{j}");
    }
    Ok(files)
}

/// With `--views-out`: each view of the multi-view display rendered alone.
fn views(
    a: &Args,
    renderer: &mut Renderer,
    p: &isokit_scene::Prepared<'_>,
    name: &str,
) -> Result<Vec<isokit_render::Image>> {
    let (Some(mv), Some(dir)) = (p.multiview(), &a.multiview.views_out) else {
        return Ok(Vec::new());
    };
    std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    (0..mv.views)
        .map(|k| Ok(renderer.render_view(p, k, name)?.image))
        .collect()
}
