//! `isokit render GRID.vtu --mode dvr --tf TF -o image.png`: direct volume rendering through
//! the cells of a tetrahedral grid (`isokit_render::tets::dvr`, the GPU twin or the CPU's as
//! `--backend` says), each cell's segment of
//! a ray one entry of the 3D pre-integration table; written as `--mode dvr` of a volume is
//! (PNG over black, `--gbuffer` EXR with `R G B A Z`).

use super::Args;
use anyhow::{Context, Result};
use glam::Vec3;
use isokit_render::dvr::{Classification, TransferFunction};
use isokit_render::tets::dvr::{TetDvrOptions, TetVolume};
use std::time::Instant;

/// Renders `a.input` (a tetrahedral grid) in `dvr` mode.
pub fn run(a: &Args, width: u32, height: u32) -> Result<()> {
    super::tets::refuse_flags(
        a,
        &[
            (a.iso.is_some(), "--iso (for --mode isosurface)"),
            (a.step.is_some(), "--step (a ray's segments are its cells')"),
            (
                a.gradient.is_some(),
                "--gradient (cells are shaded by their point gradients)",
            ),
            (
                a.table_build.is_some(),
                "--table-build (grids take a 3D table)",
            ),
        ],
    )?;
    let (shade, tf_arg) = a.dvr_shading_and_tf()?;
    let grid = isokit_io::read_tets(&a.input, a.array.as_deref())?;
    let range = isokit_field::finite_min_max(grid.values()).unwrap_or((0.0, 1.0));
    let t = Instant::now();
    let volume = TetVolume::new(&grid);
    let prepare = t.elapsed().as_secs_f64();
    let tf = TransferFunction::load_for(tf_arg, range, volume.mean_edge())
        .with_context(|| format!("--tf {tf_arg}"))?;
    let camera = a.camera.camera_for(grid.bounds(), width, height)?;
    super::tets::warn_if_inside(&grid, &camera);
    let opts = TetDvrOptions {
        classification: a
            .classification
            .map_or(Classification::Preintegrated, |c| c.into()),
        shade,
        table_size: a.table_size.unwrap_or(TetDvrOptions::default().table_size),
        ..TetDvrOptions::default()
    };
    let mut renderer = crate::cmd::args::open_renderer(a.backend)?;
    let backend = renderer.backend();
    let t = Instant::now();
    let img = match renderer.gpu() {
        Some(gpu) => gpu.render_tets_dvr(&volume, &camera, &tf, &opts)?,
        None => volume.render(&camera, &tf, &opts, &crate::cmd::progress::job())?,
    };
    let seconds = t.elapsed().as_secs_f64();
    img.to_image(Vec3::ZERO).write_png(&a.output)?;
    if let Some(g) = &a.gbuffer {
        img.write_exr(g, &camera)?;
    }
    let per_ray = img.samples as f64 / f64::from(width * height);
    eprintln!(
        "{} cells, array {} (values {} .. {}): direct volume rendering through tetrahedra ({}, {backend}), {width}x{height}: {per_ray:.1} segments/ray; prepare {prepare:.2} s, render {seconds:.2} s -> {}",
        grid.tets().len(),
        grid.array(),
        range.0,
        range.1,
        img.classification.name(),
        a.output.display()
    );
    if a.stats {
        let mut v = img.stats(backend, seconds);
        // No fixed step and no blocks: a ray's segments are its cells'.
        if let Some(o) = v.as_object_mut() {
            o.remove("step");
            o.remove("skipped_blocks");
        }
        v["cells"] = grid.tets().len().into();
        v["segments_per_ray"] = per_ray.into();
        v["prepare_seconds"] = prepare.into();
        v["output"] = a.output.display().to_string().into();
        println!("{v}");
    }
    Ok(())
}
