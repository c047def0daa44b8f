//! `isokit demo`: the main job on the shipped data, each stage timed. The trefoil mesh
//! becomes an exact distance field, is smooth-unioned with a sphere, sampled lazily to a
//! band, ray cast and curvature-shaded to a PNG (on the CPU when no GPU adapter exists).

use super::check_output;
use anyhow::{Result, bail};
use isokit_render::check_image_size;
use isokit_scene::{RenderSettings, RenderTarget, Scene};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `isokit demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output image (.png).
    #[arg(short, long, default_value = "demo.png")]
    pub output: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = crate::cmd::args::DEFAULT_WIDTH)]
    pub width: u64,
    /// Image height in pixels.
    #[arg(long, default_value_t = crate::cmd::args::DEFAULT_HEIGHT)]
    pub height: u64,
    /// Scene to render [default: examples/scenes/demo.json of the checkout].
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Samples along the longest side [default: the scene's `sampling.resolution`].
    #[arg(long)]
    pub res: Option<usize>,
    /// Backend: auto (a hardware GPU when one exists, else the CPU), cpu, gpu.
    #[arg(long, value_enum, default_value_t = super::args::Backend::Auto)]
    pub backend: super::args::Backend,
}

const SCENE: &str = "examples/scenes/demo.json";

/// The demo scene: in the working folder, else in the checkout the binary was built from.
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

fn stage(name: &str, ms: f64, what: impl std::fmt::Display) {
    eprintln!("{name:<8} {ms:>8.1} ms  {what}");
}

fn since(t: Instant) -> f64 {
    1e3 * t.elapsed().as_secs_f64()
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".png"])?;
    let (width, height) = check_image_size(a.width, a.height)?;
    let path = match a.scene {
        Some(p) => p,
        None => find_scene()?,
    };
    let total = Instant::now();
    let t = Instant::now();
    let mut renderer = super::args::open_renderer(a.backend)?;
    stage("device", since(t), renderer.device());

    let t = Instant::now();
    let scene = Scene::load(&path)?;
    let kinds: Vec<&str> = scene.sources().iter().map(|s| s.kind).collect();
    stage(
        "load",
        since(t),
        format!("{} ({})", path.display(), kinds.join(" + ")),
    );

    let settings = RenderSettings {
        width,
        height,
        resolution: a.res,
        ..RenderSettings::default()
    };
    let p = renderer.prepare(
        RenderTarget::Scene(&scene),
        &settings,
        &super::progress::job(),
    )?;
    let frame = renderer.render_prepared(&p, scene.name())?;
    let st = &frame.stats;
    if let Some(s) = &st.sampling {
        stage(
            "sample",
            1e3 * s.seconds,
            format!(
                "{} x {} x {} lattice, band ±{}: {:.1}% of the dense samples evaluated, {} of {} bricks kept",
                s.dims[0],
                s.dims[1],
                s.dims[2],
                s.band,
                100.0 * s.dense_fraction,
                s.bricks_kept,
                s.bricks_total
            ),
        );
        let volume = p.volume();
        let active = volume
            .block_ranges()
            .iter()
            .filter(|r| r[0] <= 0.0 && 0.0 <= r[1])
            .count();
        stage(
            "blocks",
            1e3 * (st.prepare_seconds - s.seconds),
            format!(
                "{} blocks of 8³ with min/max ({} hold the surface), {} bricks of 32³",
                volume.block_ranges().len(),
                active,
                volume.brick_count()
            ),
        );
    }
    let device = if renderer.is_gpu() { "GPU" } else { "CPU" };
    stage(
        "trace",
        1e3 * st.trace_seconds,
        format!(
            "{}x{} rays ({device}, tricubic, r0 1, r1 8, 6 secant steps): {} hits, {:.1} samples/ray, {} bricks loaded, {} pass(es)",
            st.width, st.height, st.hits, st.samples_per_ray, st.bricks_loaded, st.passes
        ),
    );
    stage(
        "shade",
        1e3 * st.shade_seconds,
        format!("{} shading ({device})", st.mode),
    );
    let t = Instant::now();
    frame.image.write_png(&a.output)?;
    stage("write", since(t), a.output.display());
    eprintln!("total    {:>8.1} ms", since(total));
    Ok(())
}
