//! `isokit demo`: renders the bundled demo scene (`examples/scenes/demo.json`: the trefoil
//! knot mesh from `data/` turned into a distance field and blended with a sphere,
//! curvature-shaded) to `demo.png` on a hardware GPU when one exists (else on the CPU
//! twin), printing each stage and how long it took.

use super::check_output;
use super::render::{Backend, backend_name, open_backend};
use anyhow::{Result, bail};
use isokit_levelset::scene::{SampleOptions, Scene};
use isokit_render::setup::{ProjectionKind, camera_for_scene, shading_for_scene};
use isokit_render::shade::default_curvature_scale;
use isokit_render::{BrickCache, Layout, RenderOptions, Volume, check_image_size, render, shade};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `isokit demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output image (.png).
    #[arg(short, long, default_value = "demo.png")]
    pub output: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u64,
    /// Image height in pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u64,
    /// The scene to render [default: examples/scenes/demo.json of this checkout].
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Sampling resolution (samples along the longest side) [default: the scene's].
    #[arg(long)]
    pub res: Option<usize>,
    /// Backend: auto (`ISOKIT_BACKEND=cpu|gpu` when set, else a hardware GPU when one
    /// exists and the CPU otherwise), cpu, gpu (any adapter, software ones included; an
    /// error without one).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
}

const SCENE: &str = "examples/scenes/demo.json";

/// The demo scene: in the current folder's checkout, else in the one this program was
/// built from.
fn find_scene() -> Result<PathBuf> {
    let here = Path::new(SCENE);
    if here.is_file() {
        return Ok(here.to_path_buf());
    }
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join(SCENE);
    if built.is_file() {
        return Ok(built);
    }
    bail!("cannot find the demo scene {SCENE}: run from the isokit checkout or give --scene")
}

fn stage(name: &str, t: Instant, what: impl std::fmt::Display) {
    eprintln!(
        "{name:<8} {:>8.1} ms  {what}",
        1e3 * t.elapsed().as_secs_f64()
    );
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".png"])?;
    let (w, h) = check_image_size(a.width, a.height)?;
    let path = match a.scene {
        Some(p) => p,
        None => find_scene()?,
    };
    let total = Instant::now();

    let t = Instant::now();
    let mut gpu = open_backend(a.backend)?;
    stage("device", t, backend_name(gpu.as_ref()));

    let t = Instant::now();
    let scene = Scene::load(&path)?;
    let kinds: Vec<&str> = scene.sources().iter().map(|s| s.kind).collect();
    stage(
        "load",
        t,
        format!("{} ({})", path.display(), kinds.join(" + ")),
    );

    let t = Instant::now();
    let mut opts = SampleOptions::from_scene(&scene);
    if let Some(r) = a.res {
        opts.resolution = r;
    }
    let (band, stats) = scene.sample(&opts)?;
    stage(
        "sample",
        t,
        format!(
            "{} x {} x {} lattice, band ±{}: {:.1}% of the dense samples evaluated, {} of {} bricks kept",
            stats.dims[0],
            stats.dims[1],
            stats.dims[2],
            stats.band,
            100.0 * stats.dense_fraction,
            stats.bricks_kept,
            stats.bricks_total
        ),
    );

    let t = Instant::now();
    let volume = Volume::from_brick_grid(band, Layout::default())?;
    let active = volume
        .block_ranges()
        .iter()
        .filter(|r| r[0] <= 0.0 && 0.0 <= r[1])
        .count();
    stage(
        "blocks",
        t,
        format!(
            "{} blocks of 8³ with min/max ({} hold the surface), {} bricks of 32³",
            volume.block_ranges().len(),
            active,
            volume.brick_count()
        ),
    );

    let settings = scene.settings();
    let camera = camera_for_scene(
        settings.camera.as_ref(),
        volume.bounds(),
        ProjectionKind::Perspective,
        w,
        h,
    )?;
    let mut shading = shading_for_scene(settings.shading.as_ref(), &settings.lights)?;
    shading.curvature_scale = default_curvature_scale(volume.bounds());
    let t = Instant::now();
    let opts = RenderOptions::default();
    let frame = match gpu.as_mut() {
        Some(g) => g.render(&volume, &camera, &opts)?,
        None => render(
            &volume,
            &mut BrickCache::for_volume(&volume),
            &camera,
            &opts,
        )?,
    };
    let st = &frame.stats;
    stage(
        "trace",
        t,
        format!(
            "{}x{} rays ({}, tricubic, r0 1, r1 8, 6 secant steps): {} hits, {:.1} samples/ray, {} bricks loaded, {} pass(es)",
            st.width,
            st.height,
            if gpu.is_some() { "GPU" } else { "CPU" },
            st.hits,
            st.samples_per_ray(),
            st.bricks_loaded,
            st.passes
        ),
    );

    let t = Instant::now();
    let image = match gpu.as_ref() {
        Some(g) => g.shade(&frame.gbuffer, &frame.uniforms, &shading)?,
        None => shade(&frame.gbuffer, &frame.uniforms, &shading)?,
    };
    stage(
        "shade",
        t,
        format!(
            "{} shading ({})",
            shading.mode.name(),
            if gpu.is_some() { "GPU" } else { "CPU" }
        ),
    );

    let t = Instant::now();
    image.write_png(&a.output)?;
    stage("write", t, a.output.display());
    eprintln!("total    {:>8.1} ms", 1e3 * total.elapsed().as_secs_f64());
    Ok(())
}
