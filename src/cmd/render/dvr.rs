//! `isokit render VOLUME --mode dvr`: direct volume rendering with a transfer function
//! (`isokit_render::dvr`, the GPU twin or the CPU's as `--backend` says), written as a PNG
//! over black and, with `--gbuffer`, an
//! EXR of the premultiplied colour `R G B`, the opacity `A` and `Z`, the distance along the
//! ray where the opacity first passes 0.5.

use super::Args;
use super::args::RenderMode;
use anyhow::{Context, Result, bail};
use glam::Vec3;
use isokit_render::dvr::{Classification, DvrOptions, TransferFunction, render_dvr_clipped};

/// How `--mode dvr` classifies samples.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClassificationArg {
    /// Sample, then classify.
    #[default]
    Post,
    /// Pre-integrated segments (Engel et al. 2001): thin features of the transfer function
    /// between samples still show.
    Preintegrated,
}

impl From<ClassificationArg> for isokit_render::dvr::Classification {
    fn from(c: ClassificationArg) -> Self {
        match c {
            ClassificationArg::Post => Self::Post,
            ClassificationArg::Preintegrated => Self::Preintegrated,
        }
    }
}

/// `--table-build` (default integrated), refused unless the classification is
/// pre-integrated.
pub(super) fn table_build(a: &Args) -> Result<isokit_render::dvr::TableBuild> {
    let pre = a.classification == Some(ClassificationArg::Preintegrated);
    Ok(match a.table_build.as_deref() {
        Some(_) if !pre => {
            bail!("--table-build builds the table of --classification preintegrated")
        }
        Some("incremental") => isokit_render::dvr::TableBuild::Incremental,
        _ => isokit_render::dvr::TableBuild::Integrated,
    })
}

/// Renders `a.input` (a volume) in `dvr` mode.
pub fn run(a: &Args, width: u32, height: u32) -> Result<()> {
    debug_assert_eq!(a.mode, RenderMode::Dvr);
    if super::is_scene(&a.input) {
        bail!(
            "--mode dvr renders volumes; sample the scene to one first (isokit scene {} -o volume.nrrd)",
            a.input.display()
        );
    }
    for (given, flag) in [
        (a.watch, "--watch"),
        (a.csg.csg.is_some(), "--csg"),
        (a.samples > 1, "--samples"),
        (a.multiview.multiview()?.0.is_some(), "--views"),
        (a.iso.is_some(), "--iso"),
        (a.array.is_some(), "--array"),
    ] {
        if given {
            bail!("{flag} is for --mode isosurface; --mode dvr does not take it");
        }
    }
    let (shade, tf_arg) = a.dvr_shading_and_tf()?;
    let gradient = match a.gradient.as_deref() {
        None | Some("tricubic") => isokit_render::dvr::DvrGradient::Tricubic,
        Some(_) => isokit_render::dvr::DvrGradient::Central,
    };
    if a.gradient.is_some() && !shade {
        bail!("--gradient shades the samples: give it with --shading phong");
    }
    let grid = a.volume.read_grid(&a.input)?;
    let tf = TransferFunction::load(tf_arg, &grid).with_context(|| format!("--tf {tf_arg}"))?;
    let camera = a.camera.camera_for(grid.bounds(), width, height)?;
    let clip = a.clip.load(&grid, &a.volume)?;
    let opts = DvrOptions {
        step: a.step,
        classification: a.classification.map_or(Classification::Post, |c| c.into()),
        shade,
        gradient,
        table_size: a.table_size.unwrap_or(DvrOptions::default().table_size),
        table_build: table_build(a)?,
        ..DvrOptions::default()
    };
    let mut renderer = crate::cmd::args::open_renderer(a.backend)?;
    let backend = renderer.backend();
    let t = std::time::Instant::now();
    let img = match renderer.gpu() {
        Some(gpu) => gpu.render_dvr_clipped(&grid, &camera, &tf, &opts, clip.as_ref())?,
        None => render_dvr_clipped(&grid, &camera, &tf, &opts, clip.as_ref())?,
    };
    let seconds = t.elapsed().as_secs_f64();
    img.to_image(Vec3::ZERO).write_png(&a.output)?;
    if let Some(g) = &a.gbuffer {
        img.write_exr(g, &camera)?;
    }
    let d = grid.dims();
    let (lo, hi) = isokit_render::dvr::value_range(&grid);
    eprintln!(
        "{} x {} x {} volume, values {lo} .. {hi}{}: direct volume rendering ({}, step {}, {backend}), {} samples, {} empty blocks skipped, {seconds:.2} s -> {}",
        d[0],
        d[1],
        d[2],
        clip_note(a),
        img.classification.name(),
        img.step,
        img.samples,
        img.skipped_blocks,
        a.output.display()
    );
    if a.stats {
        let mut v = img.stats(backend, seconds);
        if let Some(c) = a.clip.file() {
            v["clip"] = c.display().to_string().into();
            v["clip_invert"] = a.clip.clip_invert.into();
        }
        v["output"] = a.output.display().to_string().into();
        println!("{v}");
    }
    Ok(())
}

/// `", clipped by FILE"` (`"… inverted"`) for the summary line, or nothing.
pub(super) fn clip_note(a: &Args) -> String {
    match a.clip.file() {
        Some(c) if a.clip.clip_invert => format!(", clipped by {} (inverted)", c.display()),
        Some(c) => format!(", clipped by {}", c.display()),
        None => String::new(),
    }
}
