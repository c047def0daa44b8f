//! `isokit render SCENE|VOLUME -o image.png [...]`: the isosurface ray cast into a G-buffer
//! and shaded (`isokit_scene::Renderer`); `--watch` renders again whenever the input or a
//! file it references changes. `--csg OP --with B.nrrd` combines two volumes per sample
//! (Sigg 2006, Sec. 6.4.3); `--clip SCENE|VOLUME` cuts a volume open (`volume.rs`). `--mode dvr` renders a volume with a transfer function
//! (`dvr.rs`); tetrahedral grids are ray cast through their cells (`tets.rs`, `tets_dvr.rs`);
//! volumes on a spherical lattice are rendered without resampling (`spherical.rs`); surface
//! patches with regions through their segmented distance field (`segmented.rs`).

mod args;
mod dvr;
mod segmented;
mod segmented_args;
mod spherical;
mod summary;
mod tets;
mod tets_dvr;
mod volume;

pub use args::Args;

use super::check_output;
use anyhow::{Context, Result, bail};
use isokit_field::Job;
use isokit_render::{Image, check_image_size};
use isokit_scene::{Prepared, RenderSettings, RenderTarget, Renderer, Scene, SceneFormat};
use std::path::{Path, PathBuf};

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
    if segmented_args::segmented(&a)? {
        return segmented::run(&a, width, height);
    } else if super::tets::is_tets(&a.input) {
        return tets::run(&a, width, height);
    }
    if let Some(lattice) = a.lattice.spherical(&a.input)? {
        return spherical::run(&a, width, height, lattice);
    }
    if a.mode == args::RenderMode::Dvr {
        return dvr::run(&a, width, height);
    }
    a.refuse_dvr_flags_except(&[])?;
    a.check_inputs(is_scene)?;
    volume::check_clip(&a)?;
    let (multiview, default_separation) = a.multiview.multiview()?;
    isokit_render::supersample::grid_side(a.samples)?;
    if a.samples > 1 && multiview.is_some() {
        bail!(
            "--samples {} with --views: antialiasing of multi-view frames is not supported",
            a.samples
        );
    }
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
        projection: a.camera.projection()?,
        camera: a.camera.spec()?,
        curvature_scale: a.knobs.curvature_scale,
        multiview,
        default_separation,
        cache_bytes: a.knobs.cache_bytes(),
        resolution: a.res,
        samples: a.samples,
        curvature_follows_mode: a.gbuffer.is_none(), // a kept G-buffer keeps its curvatures
        ..RenderSettings::default()
    };
    // Opened once, at the first rendering (after the input was read, so that a missing
    // file is reported without a word about adapters): --watch reuses the device, its
    // compiled kernels and its brick cache.
    let mut renderer = None;
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
fn render_once(
    a: &Args,
    s: &RenderSettings,
    renderer: &mut Option<Renderer>,
) -> Result<Vec<PathBuf>> {
    let name = a.input.display().to_string();
    let (frame, prepared_views, files, what, clip_caps) = if is_scene(&a.input) {
        let scene = Scene::load(&a.input)?;
        let files = scene.dependencies().to_vec();
        let p = Renderer::cpu().prepare(RenderTarget::Scene(&scene), s, &super::progress::job())?;
        let renderer = open(renderer, a)?;
        let mut frame = renderer.render_prepared(&p, &name)?;
        frame.stats.warm_trace_seconds = warm(a, renderer, &p, &name)?;
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
        (frame, views, files, what, None)
    } else {
        let (volume, files, what, caps) = volume::load(a, s)?;
        let p = Renderer::cpu().prepare(RenderTarget::Volume(&volume), s, &Job::default())?;
        let renderer = open(renderer, a)?;
        let mut frame = renderer.render_prepared(&p, &name)?;
        let clip_caps = caps.as_ref().map(|c| c.colour(&mut frame, p.shading()));
        frame.stats.warm_trace_seconds = warm(a, renderer, &p, &name)?;
        let views = views(a, renderer, &p, &name)?;
        volume::check_store(&volume)?;
        (frame, views, files, what, clip_caps)
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
        frame.gbuffer.write_exr_with_camera(g, &frame.camera)?;
    }
    summary::print(a, s, &frame, &what, clip_caps)?;
    Ok(files)
}

/// The renderer, opened once at the first call, after the input was read and prepared.
fn open<'r>(slot: &'r mut Option<Renderer>, a: &Args) -> Result<&'r mut Renderer> {
    if slot.is_none() {
        *slot = Some(super::args::open_renderer(a.backend)?);
    }
    slot.as_mut().context("renderer")
}

/// With `--warm-frames N`: the trace seconds of N more frames of the same camera, the
/// brick cache kept from the first (warm).
fn warm(a: &Args, renderer: &mut Renderer, p: &Prepared<'_>, name: &str) -> Result<Vec<f64>> {
    (0..a.warm_frames)
        .map(|_| Ok(renderer.render_prepared(p, name)?.stats.trace_seconds))
        .collect()
}

/// With `--views-out`: each view of the multi-view display rendered alone.
fn views(a: &Args, renderer: &mut Renderer, p: &Prepared<'_>, name: &str) -> Result<Vec<Image>> {
    let Some(dir) = &a.multiview.views_out else {
        return Ok(Vec::new());
    };
    std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    Ok(renderer.render_views(p, name)?)
}
