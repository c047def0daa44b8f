//! `isokit points CLOUD --res N -o out.nrrd`: a point cloud's approximate signed distance
//! (partition of unity of linear fields, far-field blend) sampled on a grid.

use super::check_output;
use anyhow::{Context, Result, bail};
use isokit_io::{Volume, read_points, write_volume};
use isokit_points::{NormalOptions, NormalSource, PointSdf, PointSdfOptions, Weighting};
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
    /// Truncated inverse-square weights of Nie04 (002 Eq. 4.9), 18 neighbours per support.
    Nie04,
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
    /// Clamp the output to ±W (the sign is kept); every sample is still evaluated.
    #[arg(long)]
    pub band: Option<f32>,
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
            Weights::Nie04 => Weighting::Nie04 { neighbours: 18 },
        },
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
        eprintln!(
            "solve: GMRES, {} unknowns, {} non-zeros, {} iterations, relative residual {:.2e}, max |f| at the samples {:.2e}, {:.2} s",
            s.unknowns,
            s.nonzeros,
            s.iterations,
            s.relative_residual,
            s.max_sample_value,
            s.seconds
        );
    }
    eprintln!("build: {build:.2} s");

    let t = Instant::now();
    let band = a.band.unwrap_or(f32::INFINITY);
    super::fill_slices(
        &mut grid,
        "points",
        |_, positions, values| {
            for (p, v) in positions.zip(values.iter_mut()) {
                *v = (sdf.evaluate(p).value as f32).clamp(-band, band);
            }
        },
        |(), ()| (),
    );
    let secs = t.elapsed().as_secs_f64();
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    write_volume(&a.output, &Volume::from(grid))?;
    eprintln!(
        "{} x {} x {} samples, spacing {spacing} in {secs:.2} s ({:.0} samples/s) -> {}",
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
