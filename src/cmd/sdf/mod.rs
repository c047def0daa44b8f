//! `isokit sdf MESH --method kdtree|prism --res N [--band W] -o out.nrrd`: a mesh's signed
//! distance on a grid, per sample through the kd-tree or per triangle by prism scan
//! conversion (CPU or GPU).

mod args;
mod segmented;

pub use args::Args;
use args::{Backend, Method};

use super::check_output;
use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_io::{Volume, read_mesh};
use isokit_kdtree::mesh::MeshSdf;
use isokit_prism::{Engine, PrismGpu, PrismSdf};
use std::time::Instant;

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    if a.segmented {
        return segmented::run(&a);
    }
    if let Some((_, flag)) = a.segmented_knobs.given().into_iter().find(|g| g.0) {
        bail!("{flag} applies to --segmented");
    }
    check_output(&a.output, &super::volume_args::VOLUME_OUTPUTS)?;
    a.out.check(&a.output)?;
    if let Some(w) = a.band
        && !(w.is_finite() && w > 0.0)
    {
        bail!("--band {w} must be finite and positive");
    }
    if a.method == Method::Prism && a.band.is_none() {
        bail!("--method prism needs --band W (the half-width of the band it scan-converts)");
    }
    if a.method == Method::Kdtree && a.backend == Backend::Gpu {
        bail!("--method kdtree has no GPU kernel; use --method prism for --backend gpu");
    }
    let mesh = read_mesh(&a.mesh)?;
    if mesh.triangles.is_empty() {
        bail!("{}: the mesh has no triangles", a.mesh.display());
    }
    let grid = a
        .lattice
        .grid(&a.mesh, mesh.bounds(), a.res.unwrap_or(64))?;
    match a.method {
        Method::Kdtree => run_kdtree(&a, &mesh, grid),
        Method::Prism => run_prism(&a, &mesh, grid),
    }
}

fn run_kdtree(a: &Args, mesh: &isokit_io::TriMesh, mut grid: Grid) -> Result<()> {
    let sdf =
        MeshSdf::new(mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());
    let t = Instant::now();
    let job = super::progress::job();
    let (fill, lazy) = match a.band {
        Some(w) if !a.dense && !sdf.sign_is_local() => {
            eprintln!(
                "note: every sample is queried (not only the bricks near the surface): {} signs may flip away from the surface",
                sdf.sign_method().name()
            );
            (sdf.fill_grid(&mut grid, w, &job)?, String::new())
        }
        Some(w) if !a.dense => {
            let l = sdf.fill_band_lazy(&mut grid, w, 4, &job)?;
            let how = format!(
                ", lazy band: {} of {} bricks of 4^3 evaluated ({:.2}% of the samples)",
                l.bricks_kept,
                l.bricks_total,
                100.0 * l.evaluated_fraction
            );
            (l.fill, how)
        }
        w => (
            sdf.fill_grid(&mut grid, w.unwrap_or(f64::INFINITY), &job)?,
            String::new(),
        ),
    };
    let secs = t.elapsed().as_secs_f64();
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    let band = a.band.map(|b| b as f32);
    let sign = Some(sdf.sign_method().name());
    a.out.write(&a.output, &Volume::from(grid), band, sign)?;
    let in_band = a.band.map_or(String::new(), |_| {
        format!(
            ", {:.1}% of samples inside the band",
            100.0 * fill.band_samples as f64 / len as f64
        )
    });
    eprintln!(
        "{} x {} x {} samples, spacing {spacing} in {secs:.2} s ({:.0} samples/s, {:.1} triangles tested per sample{in_band}{lazy}) -> {}",
        dims[0],
        dims[1],
        dims[2],
        len as f64 / secs.max(1e-12),
        fill.stats.prims_tested as f64 / len as f64,
        a.output.display()
    );
    Ok(())
}

fn run_prism(a: &Args, mesh: &isokit_io::TriMesh, mut grid: Grid) -> Result<()> {
    let opts = a.prism_options(a.band.unwrap_or_default());
    let (gpu, note) =
        PrismGpu::choose(a.backend.choice()).context("--backend gpu (or ISOKIT_BACKEND=gpu)")?;
    if let Some(why) = note {
        eprintln!("note: backend auto: {why}; scanning on the CPU twin (same result)");
    }
    let sdf = PrismSdf::new(mesh, opts).with_context(|| a.mesh.display().to_string())?;
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());
    if let Some(w) = sdf.warning() {
        eprintln!("warning: {w}");
    }
    let r = sdf.report();
    eprintln!(
        "prisms: {} triangles ({} degenerate), {} vertices, {} saddles, {} with gaps in the paper's prisms, {} planes shifted{}, {} fat sides, built in {:.2} s",
        mesh.triangles.len(),
        r.degenerate_triangles,
        r.vertices,
        r.saddles,
        r.gaps,
        r.shifted_planes,
        if opts.repair { "" } else { " (gap repair off)" },
        r.fat_sides,
        sdf.build_seconds()
    );
    let engine = Engine::from(gpu.as_ref());
    let where_ = engine.describe();
    let t = Instant::now();
    let stats = sdf.fill_grid(&mut grid, &engine)?;
    let secs = t.elapsed().as_secs_f64();
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    let band = a.band.map(|b| b as f32);
    let sign = Some(sdf.sign_method().name());
    a.out.write(&a.output, &Volume::from(grid), band, sign)?;
    let evaluated = if stats.evaluated > 0 {
        format!(
            ", {:.2} distance evaluations per band sample",
            stats.evaluated as f64 / stats.band_samples.max(1) as f64
        )
    } else {
        String::new()
    };
    eprintln!(
        "{} x {} x {} samples, spacing {spacing} in {secs:.2} s on the {where_} ({:.0} band samples/s, {:.1}% of samples inside the band{evaluated}, {} winding numbers) -> {}",
        dims[0],
        dims[1],
        dims[2],
        stats.band_samples as f64 / secs.max(1e-12),
        100.0 * stats.band_samples as f64 / len as f64,
        stats.windings,
        a.output.display()
    );
    Ok(())
}
