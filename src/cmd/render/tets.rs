//! `isokit render GRID.vtu -o image.png`: the isosurface of a tetrahedral grid ray cast
//! through its cells (`isokit_render::tets`, the GPU twin or the CPU's as `--backend` says),
//! shaded like any other G-buffer.

use super::Args;
use super::args::RenderMode;
use anyhow::{Result, bail};
use isokit_render::tets::{TetCaster, TetNormals};
use isokit_render::{Shading, ShadingMode, camera_uniforms, shade};
use serde_json::json;
use std::time::Instant;

/// Refuses the flags tetrahedral grids do not take (`extra`: those of one mode).
pub(super) fn refuse_flags(a: &Args, extra: &[(bool, &str)]) -> Result<()> {
    for &(given, flag) in one_ray_flags(a)?.iter().chain(extra) {
        if given {
            bail!(
                "{flag} is not available for tetrahedral grids (rendered through their cells, one ray per pixel)"
            );
        }
    }
    Ok(())
}

/// The flags of the ray caster's volumes that inputs rendered with one ray per pixel and
/// without its bricks (tetrahedral grids, spherical lattices) do not take, with whether
/// each was given.
pub(super) fn one_ray_flags(a: &Args) -> Result<[(bool, &'static str); 7]> {
    Ok([
        (a.watch, "--watch"),
        (a.csg.csg.is_some(), "--csg"),
        (a.clip.clip.is_some(), "--clip"),
        (a.samples > 1, "--samples"),
        (a.multiview.multiview()?.0.is_some(), "--views"),
        (a.res.is_some(), "--res"),
        (a.warm_frames > 0, "--warm-frames"),
    ])
}

/// Renders `a.input` (a tetrahedral grid).
pub fn run(a: &Args, width: u32, height: u32) -> Result<()> {
    if a.mode == RenderMode::Dvr {
        return super::tets_dvr::run(a, width, height);
    }
    a.refuse_dvr_flags_except(&[])?;
    refuse_flags(a, &[])?;
    let mode = shading_without_curvature(
        a,
        "the isosurface of a tetrahedral grid is piecewise planar and has no curvature",
    )?;
    let grid = isokit_io::read_tets(&a.input, a.array.as_deref())?;
    let Some((lo, hi)) = isokit_field::finite_min_max(grid.values()) else {
        bail!(
            "{}: no finite value in array {}",
            a.input.display(),
            grid.array()
        );
    };
    let iso = a.iso.unwrap_or(default_iso(lo, hi));
    let camera = a.camera.camera_for(grid.bounds(), width, height)?;
    warn_if_inside(&grid, &camera);
    let u = camera_uniforms(&camera)?;
    let mut renderer = crate::cmd::args::open_renderer(a.backend)?;
    let backend = renderer.backend();
    let t = Instant::now();
    let caster = TetCaster::new(&grid, iso, a.inside.inside(), TetNormals::Smooth)?;
    let prepare = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let gb = match renderer.gpu() {
        Some(gpu) => gpu.render_tets(&caster, &u)?,
        None => caster.render(&u, &crate::cmd::progress::job())?,
    };
    let trace = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let sh = Shading {
        mode,
        ..Shading::default()
    };
    let image = shade(&gb, &u, &sh)?;
    let shade_s = t.elapsed().as_secs_f64();
    image.write_png(&a.output)?;
    if let Some(g) = &a.gbuffer {
        gb.write_exr_with_camera(g, &camera)?;
    }
    let hits = gb.pixels().iter().filter(|p| p.is_hit()).count();
    let visited: u64 = gb.samples().iter().map(|&s| u64::from(s)).sum();
    let per_ray = visited as f64 / f64::from(width * height);
    eprintln!(
        "{} cells, {} boundary faces, array {} at iso {iso}: ray cast through tetrahedra ({backend}), {width}x{height} {} image: {hits} surface pixels, {per_ray:.1} cells/ray; prepare {prepare:.2} s, trace {trace:.3} s, shade {shade_s:.3} s -> {}",
        grid.tets().len(),
        caster.boundary_faces(),
        grid.array(),
        mode.name(),
        a.output.display()
    );
    if a.stats {
        let v = json!({
            "device": backend,
            "cells": grid.tets().len(),
            "boundary_faces": caster.boundary_faces(),
            "iso": iso,
            "width": width,
            "height": height,
            "hits": hits,
            "cells_per_ray": per_ray,
            "prepare_seconds": prepare,
            "trace_seconds": trace,
            "shade_seconds": shade_s,
            "output": a.output.display().to_string(),
        });
        println!("{v}");
    }
    Ok(())
}

/// `--shading` (default phong) for a surface found without curvatures (`why` says why the
/// curvature modes are refused).
pub(super) fn shading_without_curvature(a: &Args, why: &str) -> Result<ShadingMode> {
    let mode = match a.shading.as_deref() {
        None => ShadingMode::Phong,
        Some(name) => crate::cmd::args::shading_mode(name)?,
    };
    if mode.uses_curvature() {
        bail!(
            "--shading {}: {why}; use phong, tone, normal or reflection",
            mode.name()
        );
    }
    Ok(mode)
}

/// The isovalue when none is given: 0 where the values reach it, else their middle.
pub(super) fn default_iso(lo: f32, hi: f32) -> f32 {
    if lo <= 0.0 && 0.0 <= hi {
        0.0
    } else {
        0.5 * (lo + hi)
    }
}

/// Rays start at the first boundary face they meet: an eye inside the grid's box may see
/// nothing of the cells around it.
pub(super) fn warn_if_inside(grid: &isokit_field::TetGrid, camera: &isokit_field::Camera) {
    let (b, e) = (grid.bounds(), camera.eye());
    if (0..3).all(|i| e[i] > b.min[i] && e[i] < b.max[i]) {
        eprintln!(
            "warning: the camera is inside the grid's bounds; rays start at the first boundary face they meet, so the cells around the eye are not drawn (put --eye outside the grid)"
        );
    }
}
