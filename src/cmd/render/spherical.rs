//! `isokit render VOLUME --lattice spherical ...`: a volume on a spherical lattice rendered
//! in world space without resampling (`isokit_render::spherical`): its isosurface (the solid
//! closed by the lattice's domain) or, with `--mode dvr`, its volume rendering, on the GPU
//! twin or the CPU's as `--backend` says.

use super::Args;
use super::args::RenderMode;
use anyhow::{Context, Result, bail};
use glam::Vec3;
use isokit_field::Grid;
use isokit_render::dvr::{Classification, DvrOptions, TransferFunction, render_dvr_spherical};
use isokit_render::spherical::{IsoOptions, SphericalLattice, SphericalVolume, render_iso};
use isokit_render::{Shading, camera_uniforms, shade};
use serde_json::json;
use std::time::Instant;

/// Renders `a.input`, whose samples lie on `lattice`.
pub fn run(a: &Args, width: u32, height: u32, lattice: SphericalLattice) -> Result<()> {
    let extra = [
        (super::is_scene(&a.input), "a scene input"),
        (a.array.is_some(), "--array"),
        (
            a.volume.origin.is_some() || a.volume.spacing.is_some(),
            "--origin/--spacing",
        ),
    ];
    for &(given, flag) in super::tets::one_ray_flags(a)?.iter().chain(&extra) {
        if given {
            bail!("{flag} is not available for volumes on a spherical lattice");
        }
    }
    let v = isokit_io::read_volume(&a.input)?;
    let grid = Grid::from_data(v.dims, Vec3::ZERO, 1.0, v.data)
        .with_context(|| a.input.display().to_string())?;
    let vol = SphericalVolume::new(grid, lattice).with_context(|| a.input.display().to_string())?;
    let camera = a.camera.camera_for(vol.bounds(), width, height)?;
    let mut renderer = crate::cmd::args::open_renderer(a.backend)?;
    let backend = renderer.backend();
    let [nr, nt, np] = v.dims;
    let l = lattice;
    let what = format!(
        "{nr} x {nt} x {np} spherical volume (r {} .. {}, theta {} .. {}, phi {} .. {}{})",
        l.r[0],
        l.r[1],
        l.theta[0],
        l.theta[1],
        l.phi[0],
        l.phi[1],
        if vol.periodic() || !vol.wedge() {
            ", round"
        } else {
            ", a wedge"
        }
    );
    let t = Instant::now();
    let mut stats = if a.mode == RenderMode::Dvr {
        let (shade, tf_arg) = a.dvr_shading_and_tf()?;
        if a.iso.is_some() {
            bail!("--iso is for --mode isosurface; --mode dvr does not take it");
        }
        if a.gradient.as_deref() == Some("tricubic") {
            bail!("--gradient tricubic: a spherical lattice is shaded by central differences");
        }
        if a.gradient.is_some() && !shade {
            bail!("--gradient shades the samples: give it with --shading phong");
        }
        let tf = TransferFunction::load_for(tf_arg, vol.value_range(), vol.spacing())
            .with_context(|| format!("--tf {tf_arg}"))?;
        let opts = DvrOptions {
            step: a.step,
            classification: a.classification.map_or(Classification::Post, |c| c.into()),
            shade,
            table_size: a.table_size.unwrap_or(DvrOptions::default().table_size),
            table_build: super::dvr::table_build(a)?,
            ..DvrOptions::default()
        };
        let img = match renderer.gpu() {
            Some(gpu) => gpu.render_dvr_spherical(&vol, &camera, &tf, &opts)?,
            None => render_dvr_spherical(&vol, &camera, &tf, &opts)?,
        };
        let seconds = t.elapsed().as_secs_f64();
        img.to_image(Vec3::ZERO).write_png(&a.output)?;
        if let Some(g) = &a.gbuffer {
            img.write_exr(g, &camera)?;
        }
        eprintln!(
            "{what}: direct volume rendering ({}, step {}, {backend}), {} samples, {seconds:.2} s -> {}",
            img.classification.name(),
            img.step,
            img.samples,
            a.output.display()
        );
        img.stats(backend, seconds)
    } else {
        // --step is the isosurface search's step here.
        a.refuse_dvr_flags_except(&["--step"])?;
        let mode = super::tets::shading_without_curvature(
            a,
            "the isosurface of a spherical volume is found without curvatures",
        )?;
        let (lo, hi) = vol.value_range();
        let opts = IsoOptions {
            iso: a.iso.unwrap_or(super::tets::default_iso(lo, hi)),
            inside: a.inside.inside(),
            step: a.step,
        };
        let gb = match renderer.gpu() {
            Some(gpu) => gpu.render_spherical_iso(&vol, &camera, &opts)?,
            None => render_iso(&vol, &camera, &opts)?,
        };
        let trace = t.elapsed().as_secs_f64();
        let u = camera_uniforms(&camera)?;
        let image = shade(
            &gb,
            &u,
            &Shading {
                mode,
                ..Shading::default()
            },
        )?;
        image.write_png(&a.output)?;
        if let Some(g) = &a.gbuffer {
            gb.write_exr_with_camera(g, &camera)?;
        }
        let caps = gb
            .pixels()
            .iter()
            .filter(|p| p.id == isokit_render::kernel::ID_CAP)
            .count();
        let hits = gb.hit_count() - caps;
        let per_ray = gb.samples().iter().map(|&s| u64::from(s)).sum::<u64>() as f64
            / f64::from(width * height);
        eprintln!(
            "{what} at iso {}: {backend}, {width}x{height} {} image: {hits} surface + {caps} cap pixels, {per_ray:.1} samples/ray, {trace:.3} s -> {}",
            opts.iso,
            mode.name(),
            a.output.display()
        );
        json!({
            "mode": "isosurface",
            "backend": backend,
            "iso": opts.iso,
            "surface_pixels": hits,
            "cap_pixels": caps,
            "samples_per_ray": per_ray,
            "seconds": trace,
            "width": width,
            "height": height,
        })
    };
    if a.stats {
        stats["lattice"] = crate::cmd::lattice_args::lattice_json(&l);
        stats["lattice"]["periodic"] = vol.periodic().into();
        stats["output"] = a.output.display().to_string().into();
        println!("{stats}");
    }
    Ok(())
}
