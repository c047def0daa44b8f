//! `isokit points CLOUD --res N -o out.nrrd`: a point cloud's approximate signed distance
//! (partition of unity of linear fields, far-field blend) sampled on a grid.

mod args;

pub use args::Args;

/// How the far-field weight judges the distance from the surface.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FarRuleArg {
    /// The height above the centroid of the nearest samples over the radius of their disc:
    /// stays on the surface in gaps of the sampling.
    Centroid,
    /// The spread of the distances to the nearest samples (002 Eq. 4.12–4.14): reads gaps of
    /// the sampling as distance from the surface.
    Spread,
}

use super::check_output;
use anyhow::{Context, Result, bail};
use isokit_io::{Volume, read_points};
use isokit_points::{NormalOptions, Solver, cloud_to_grid};

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &super::volume_args::VOLUME_OUTPUTS)?;
    a.out.check(&a.output)?;
    if let Some(w) = a.band
        && !(w.is_finite() && w > 0.0)
    {
        bail!("--band {w} must be finite and positive");
    }
    if !(a.brick.is_power_of_two() && (2..=256).contains(&a.brick)) {
        bail!(
            "--brick {}: the brick size must be a power of two from 2 to 256",
            a.brick
        );
    }
    let cloud = read_points(&a.cloud)?;
    let mut grid = a.lattice.grid(&a.cloud, cloud.bounds(), a.res)?;
    let (opts, noise) = a
        .options(&cloud)
        .with_context(|| a.cloud.display().to_string())?;
    let field = opts.field;
    let st = cloud_to_grid(&cloud, &mut grid, &opts, &super::progress::job())
        .with_context(|| a.cloud.display().to_string())?;
    if let Some(n) = noise {
        eprintln!(
            "noise estimate: deviation {:.3e} = {:.2} sample spacings ({}): k = {}, damping {} (--k and --damping override)",
            n.deviation,
            n.ratio(),
            if n.ratio() > isokit_points::noise::NOISY_RATIO {
                "noisy"
            } else {
                "clean"
            },
            field.k,
            field.damping
        );
    }
    match &st.normals {
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
    let b = &st.build;
    eprintln!(
        "field: {} samples ({} duplicates removed), {} weights, k = {}, far field {}",
        b.samples,
        b.duplicates_removed,
        field.weighting.name(),
        b.k,
        if field.far_field {
            format!(
                "on (weight: {}, {} samples; sign: {})",
                field.far_rule.name(),
                field.far_k.max(b.k).min(b.samples),
                field.sign.name()
            )
        } else {
            "off".to_string()
        }
    );
    if b.winding_seconds > 0.0 {
        eprintln!(
            "winding number: sample areas sum to {:.4}, {:.2} s",
            b.winding_area, b.winding_seconds
        );
    }
    if let Some(s) = b.solve {
        let damping = if field.solver == Solver::Lsqr {
            format!(" (damping {})", s.damping)
        } else {
            String::new()
        };
        let end = if s.reached_target {
            "grid precision"
        } else if s.converged {
            "converged"
        } else {
            "iteration limit"
        };
        eprintln!(
            "solve: {}{damping}, {} unknowns, {} non-zeros, {} iterations ({end}), relative residual {:.2e}, max |f| at the samples {:.2e}, {:.2} s",
            field.solver.name(),
            s.unknowns,
            s.nonzeros,
            s.iterations,
            s.relative_residual,
            s.max_sample_value,
            s.seconds
        );
    }
    eprintln!("build: {:.2} s", st.build_seconds);
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    let band = st.band.as_ref().map(|s| s.band);
    a.out.write(&a.output, &Volume::from(grid), band, None)?;
    let how = match st.band {
        Some(s) => format!(
            "band {}: {:.2}% of the dense samples evaluated ({} of {} bricks of {}^3 kept)",
            s.band,
            100.0 * s.evaluated_fraction,
            s.bricks_kept,
            s.bricks_total,
            s.brick
        ),
        None => "dense: 100% of the samples evaluated".to_string(),
    };
    let secs = st.sample_seconds;
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

/// `isokit info CLOUD`: the text and JSON (`kind` `"points"`) that describe a point cloud.
pub fn describe(path: &std::path::Path) -> Result<(String, serde_json::Value)> {
    use crate::cmd::info::{bounds_json, bounds_text};
    let c = isokit_io::read_points(path)?;
    let b = isokit_field::Aabb::from_points(&c.points);
    let non_finite = c.points.iter().filter(|p| !p.is_finite()).count();
    let normals = c.normals.is_some();
    let v = serde_json::json!({
        "kind": "points",
        "points": c.points.len(),
        "normals": normals,
        "non_finite_points": non_finite,
        "bounds": bounds_json(&b),
    });
    let t = format!(
        "{}: point cloud\n  points: {}\n  normals: {}\n  non-finite points: {}\n  bounds: {}",
        path.display(),
        c.points.len(),
        if normals { "yes" } else { "no" },
        non_finite,
        bounds_text(&b)
    );
    Ok((t, v))
}
