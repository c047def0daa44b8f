//! `isokit points CLOUD --res N -o out.nrrd`: a point cloud's approximate signed distance
//! (partition of unity of linear fields, far-field blend) sampled on a grid.

use super::check_output;
use anyhow::{Context, Result, bail};
use isokit_field::BrickGrid;
use isokit_io::{Volume, read_points, write_volume};
use isokit_points::{NormalOptions, NormalSource, PointSdf, PointSdfOptions, Solver, Weighting};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Where the normals come from.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normals {
    /// The cloud's own normals (PLY nx ny nz, or XYZ with six columns).
    Given,
    /// Estimated: PCA over the k nearest, oriented over a minimum spanning tree.
    Estimate,
}

/// Weights of the partition of unity.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weights {
    /// (1 − r²/R²)³ with a sparse solve for interpolation (002 Eq. 4.10).
    PolyGauss,
    /// Shepard's inverse-square weights over the k nearest.
    Shepard,
    /// Truncated inverse-square weights of Nie04 (002 Eq. 4.9), `--nie04-neighbours` per
    /// support.
    Nie04,
}

/// Solver for the constants of the poly-gauss weights.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverArg {
    /// Damped least squares (LSQR), damping `--damping`: well posed on every cloud.
    Lsqr,
    /// The plain interpolation system by GMRES(50), Jacobi-preconditioned, stopped at
    /// `--max-iter`.
    Gmres,
    /// The plain interpolation system by BiCGSTAB, Jacobi-preconditioned.
    Bicgstab,
}

/// Arguments of `isokit points`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Point cloud (.ply or .xyz).
    pub cloud: PathBuf,
    /// Output volume (.nrrd or .npy).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples along the longest side of the padded bounds.
    #[arg(long, default_value_t = 64)]
    pub res: usize,
    /// Narrow band: evaluate only the bricks that may come within W of the surface and
    /// clamp the output to ±W (the sign is kept). Without it every sample is evaluated.
    #[arg(long)]
    pub band: Option<f32>,
    /// Brick edge in samples for `--band` (a power of two from 2 to 256). Small bricks
    /// follow the surface more closely (4: 34% of a 128-grid evaluated around a torus, 8:
    /// 53%), at one extra evaluation per brick.
    #[arg(long, default_value_t = 4)]
    pub brick: usize,
    /// Nearest samples per evaluation (partition of unity support).
    #[arg(long, default_value_t = 16)]
    pub k: usize,
    /// Nearest samples for the far-field statistics.
    #[arg(long, default_value_t = 64)]
    pub far_k: usize,
    /// Turn the far-field blend off (near field everywhere).
    #[arg(long)]
    pub no_far: bool,
    /// Where normals come from [default: given when the cloud has them, else estimate].
    #[arg(long, value_enum)]
    pub normals: Option<Normals>,
    /// Neighbours for normal estimation.
    #[arg(long, default_value_t = 16)]
    pub normal_k: usize,
    /// Partition-of-unity weights.
    #[arg(long, value_enum, default_value_t = Weights::PolyGauss)]
    pub weights: Weights,
    /// Neighbours inside each sample's support for `--weights nie04`.
    #[arg(long, default_value_t = 18)]
    pub nie04_neighbours: usize,
    /// Solver for the constants (poly-gauss weights only).
    #[arg(long, value_enum, default_value_t = SolverArg::Lsqr)]
    pub solver: SolverArg,
    /// Damping λ of the LSQR solve: small values interpolate the samples closely, large
    /// ones (1 and more, with a larger `--k`) average noisy samples.
    #[arg(long, default_value_t = isokit_points::DEFAULT_DAMPING)]
    pub damping: f64,
    /// Iteration limit of the solve.
    #[arg(long, default_value_t = PointSdfOptions::default().max_iter)]
    pub max_iter: usize,
    /// Margin around the cloud bounds in world units [default: 10% of the diagonal].
    #[arg(long)]
    pub padding: Option<f32>,
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".nrrd", ".npy"])?;
    if let Some(w) = a.band {
        if !(w.is_finite() && w > 0.0) {
            bail!("--band {w} must be finite and positive");
        }
    }
    if !(a.brick.is_power_of_two() && (2..=256).contains(&a.brick)) {
        bail!(
            "--brick {}: the brick size must be a power of two from 2 to 256",
            a.brick
        );
    }
    let cloud = read_points(&a.cloud)?;
    let mut grid = super::padded_grid(
        isokit_field::Aabb::from_points(&cloud.points),
        a.res,
        a.padding,
    )?;
    let source = match a.normals {
        Some(Normals::Given) => NormalSource::Given,
        Some(Normals::Estimate) => NormalSource::Estimate(NormalOptions {
            k: a.normal_k,
            ..NormalOptions::default()
        }),
        None if cloud.normals.is_some() => NormalSource::Given,
        None => NormalSource::Estimate(NormalOptions {
            k: a.normal_k,
            ..NormalOptions::default()
        }),
    };
    let opts = PointSdfOptions {
        k: a.k,
        far_k: a.far_k,
        far_field: !a.no_far,
        weighting: match a.weights {
            Weights::PolyGauss => Weighting::PolyGauss,
            Weights::Shepard => Weighting::Shepard,
            Weights::Nie04 => Weighting::Nie04 {
                neighbours: a.nie04_neighbours,
            },
        },
        solver: match a.solver {
            SolverArg::Lsqr => Solver::Lsqr,
            SolverArg::Gmres => Solver::Gmres,
            SolverArg::Bicgstab => Solver::Bicgstab,
        },
        damping: a.damping,
        max_iter: a.max_iter,
        ..PointSdfOptions::default()
    };
    let t = Instant::now();
    let (sdf, report) = PointSdf::from_cloud(&cloud, source, &opts)
        .with_context(|| a.cloud.display().to_string())?;
    let build = t.elapsed().as_secs_f64();
    match &report {
        Some(r) => eprintln!(
            "normals: estimated (k = {}): {} unreliable ({:.2}%, surface variation > {}), {} component(s), {} flipped by the orientation",
            r.k,
            r.unreliable.len(),
            100.0 * r.unreliable_fraction(),
            NormalOptions::default().max_variation,
            r.components,
            r.flipped
        ),
        None => eprintln!("normals: given"),
    }
    let st = sdf.stats();
    eprintln!(
        "field: {} samples ({} duplicates removed), {} weights, k = {}, far field {}",
        st.samples,
        st.duplicates_removed,
        opts.weighting.name(),
        st.k,
        if opts.far_field { "on" } else { "off" }
    );
    if let Some(s) = st.solve {
        let damping = if opts.solver == Solver::Lsqr {
            format!(" (damping {})", s.damping)
        } else {
            String::new()
        };
        eprintln!(
            "solve: {}{damping}, {} unknowns, {} non-zeros, {} iterations ({}), relative residual {:.2e}, max |f| at the samples {:.2e}, {:.2} s",
            opts.solver.name(),
            s.unknowns,
            s.nonzeros,
            s.iterations,
            if s.converged {
                "converged"
            } else {
                "iteration limit"
            },
            s.relative_residual,
            s.max_sample_value,
            s.seconds
        );
    }
    eprintln!("build: {build:.2} s");

    let t = Instant::now();
    let lazy = match a.band {
        // Lazy: one evaluation per brick decides (by the field's Lipschitz estimate) which
        // bricks may hold the band; the others read ±W.
        Some(w) => {
            let (dims, origin, spacing) = (grid.dims(), grid.origin(), grid.spacing());
            // Free the dense buffer while the bricks are sampled; `to_grid` makes a new one.
            drop(std::mem::replace(
                &mut grid,
                isokit_field::Grid::new([1, 1, 1], origin, spacing)?,
            ));
            let bricks = BrickGrid::sample_field(&sdf, dims, origin, spacing, a.brick, 0, w, w)?;
            let kept = bricks.brick_count();
            let total: usize = bricks.brick_dims().iter().product();
            let fraction = bricks.evaluated_fraction();
            grid = bricks.to_grid()?;
            // Kept bricks hold values beyond the band: clamp, so the file reads "field
            // within W, ±W beyond" everywhere, as the dense path with the same W would.
            isokit_scene::clamp_to_band(&mut grid, w);
            Some((w, fraction, kept, total))
        }
        None => {
            super::fill_slices(
                &mut grid,
                "points",
                |_, positions, values| {
                    for (p, v) in positions.zip(values.iter_mut()) {
                        *v = sdf.evaluate(p).value as f32;
                    }
                },
                |(), ()| (),
            );
            None
        }
    };
    let secs = t.elapsed().as_secs_f64();
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    write_volume(&a.output, &Volume::from(grid))?;
    let how = match lazy {
        Some((w, fraction, kept, total)) => format!(
            "band {w}: {:.2}% of the dense samples evaluated ({kept} of {total} bricks of {}^3 kept)",
            100.0 * fraction,
            a.brick
        ),
        None => "dense: 100% of the samples evaluated".to_string(),
    };
    eprintln!(
        "{} x {} x {} samples, spacing {spacing}, {how} in {secs:.2} s ({:.0} samples/s of the dense grid) -> {}",
        dims[0],
        dims[1],
        dims[2],
        len as f64 / secs.max(1e-12),
        a.output.display()
    );
    Ok(())
}

/// `isokit query CLOUD --points P.npy -o D.npy`: the field of a point cloud (default options,
/// normals given when the cloud has them, else estimated) at the query points; NaN for
/// non-finite points.
pub fn query_cloud(
    cloud_path: &std::path::Path,
    points: &[glam::DVec3],
    output: &std::path::Path,
    closest: bool,
) -> Result<()> {
    if closest {
        bail!(
            "--closest is not available for point clouds: the field's zero set has no exact closest point"
        );
    }
    let cloud = read_points(cloud_path)?;
    let source = if cloud.normals.is_some() {
        NormalSource::Given
    } else {
        NormalSource::Estimate(NormalOptions::default())
    };
    let t = Instant::now();
    let (sdf, report) = PointSdf::from_cloud(&cloud, source, &PointSdfOptions::default())
        .with_context(|| cloud_path.display().to_string())?;
    eprintln!(
        "cloud: {} samples, normals {}, built in {:.2} s",
        sdf.stats().samples,
        if report.is_some() {
            "estimated"
        } else {
            "given"
        },
        t.elapsed().as_secs_f64()
    );
    let dist: Vec<f32> = points
        .par_iter()
        .map(|p| {
            if p.is_finite() {
                sdf.evaluate(*p).value as f32
            } else {
                f32::NAN
            }
        })
        .collect();
    isokit_io::write_npy_f32(output, &[dist.len()], &dist)?;
    let skipped = dist.iter().filter(|d| d.is_nan()).count();
    if skipped > 0 {
        eprintln!("warning: {skipped} query points were not finite; their distances are NaN");
    }
    Ok(())
}
