//! `isokit sample SHAPE --res N -o out.nrrd`: an analytic primitive's exact signed distance
//! sampled on a grid.

use super::{check_output, parse_vec3};
use anyhow::{Context, Result, bail};
use glam::Vec3;
use isokit_field::primitives::{
    CappedCone, CappedCylinder, Capsule, Cuboid, Ellipsoid, Plane, Primitive, RoundedBox, Sphere,
    Torus,
};
use isokit_field::transform::Transformed;
use isokit_field::{Aabb, Field, Grid, sample_into};
use isokit_io::{Volume, write_volume};
use std::path::PathBuf;
use std::time::Instant;

/// The primitives `isokit sample` knows.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// `--center`, `--radius` (default 1).
    Sphere,
    /// `--center`, `--half` (default 1,0.75,0.5).
    #[value(alias = "cuboid")]
    Box,
    /// `--center`, `--half`, `--radius` (edge rounding, default 0.2).
    #[value(name = "rounded-box", alias = "rounded_box")]
    RoundedBox,
    /// `--center`, `--major` (default 0.75), `--minor` (default 0.25); axis z.
    Torus,
    /// `--a`, `--b` (segment ends, default 0,0,±0.5), `--radius` (default 0.5).
    Capsule,
    /// `--a`, `--b` (axis ends, default 0,0,±0.75), `--radius` (default 0.5).
    #[value(alias = "capped-cylinder", alias = "capped_cylinder")]
    Cylinder,
    /// `--a`, `--b` (axis ends), `--ra`, `--rb` (end radii, default 0.75 and 0.25).
    #[value(alias = "capped-cone", alias = "capped_cone")]
    Cone,
    /// `--normal` (default 0,0,1), `--offset` (default 0); unbounded: give `--bounds`.
    Plane,
    /// `--center`, `--radii` (default 1,0.6,0.4). Exact distance (Eberly's method).
    Ellipsoid,
}

/// Arguments of `isokit sample`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The primitive.
    pub shape: Shape,
    /// Output volume (.nrrd, gzip-encoded, or .npy with shape (nz, ny, nx)).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples along the longest axis of the sampled box (others get the same spacing).
    #[arg(long, default_value_t = 64)]
    pub res: usize,
    /// Margin around the shape's bounds, in world units [default: 10% of the bounds' diagonal].
    #[arg(long, allow_hyphen_values = true)]
    pub pad: Option<f32>,
    /// Box to sample, "x0,y0,z0,x1,y1,z1" (required for the unbounded plane).
    #[arg(long, allow_hyphen_values = true)]
    pub bounds: Option<String>,
    /// Centre (sphere, box, rounded box, torus, ellipsoid), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub center: Option<Vec3>,
    /// Radius (sphere, capsule, cylinder) or edge rounding radius (rounded box).
    #[arg(long, allow_hyphen_values = true)]
    pub radius: Option<f32>,
    /// Half extents (box, rounded box), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub half: Option<Vec3>,
    /// Major radius (torus).
    #[arg(long, allow_hyphen_values = true)]
    pub major: Option<f32>,
    /// Minor (tube) radius (torus).
    #[arg(long, allow_hyphen_values = true)]
    pub minor: Option<f32>,
    /// First end point (capsule, cylinder, cone), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub a: Option<Vec3>,
    /// Second end point (capsule, cylinder, cone), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub b: Option<Vec3>,
    /// Radius at `a` (cone).
    #[arg(long, allow_hyphen_values = true)]
    pub ra: Option<f32>,
    /// Radius at `b` (cone).
    #[arg(long, allow_hyphen_values = true)]
    pub rb: Option<f32>,
    /// Normal (plane), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub normal: Option<Vec3>,
    /// Offset along the normal (plane: n·p = offset).
    #[arg(long, allow_hyphen_values = true)]
    pub offset: Option<f32>,
    /// Semi-axes (ellipsoid), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub radii: Option<Vec3>,
    /// Uniform scale applied to the shape (about the origin), before rotation.
    #[arg(long, allow_hyphen_values = true)]
    pub scale: Option<f32>,
    /// Rotation "axis_x,axis_y,axis_z,degrees" applied after scaling.
    #[arg(long, allow_hyphen_values = true)]
    pub rotate: Option<String>,
    /// Translation "x,y,z" applied last.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub translate: Option<Vec3>,
}

fn parse_numbers(s: &str, n: usize, what: &str) -> Result<Vec<f32>> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--{what} '{s}' is not a list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("--{what} '{s}' needs {n} finite numbers separated by commas");
    }
    Ok(v)
}

/// Builds the primitive from the arguments (defaults from [`Primitive::example`]).
pub fn primitive(a: &Args) -> Result<Primitive> {
    let c = a.center.unwrap_or(Vec3::ZERO);
    let z = Vec3::Z;
    let p: Primitive = match a.shape {
        Shape::Sphere => Sphere::new(c, a.radius.unwrap_or(1.0))?.into(),
        Shape::Box => Cuboid::new(c, a.half.unwrap_or(Vec3::new(1.0, 0.75, 0.5)))?.into(),
        Shape::RoundedBox => RoundedBox::new(
            c,
            a.half.unwrap_or(Vec3::new(1.0, 0.75, 0.5)),
            a.radius.unwrap_or(0.2),
        )?
        .into(),
        Shape::Torus => Torus::new(c, a.major.unwrap_or(0.75), a.minor.unwrap_or(0.25))?.into(),
        Shape::Capsule => Capsule::new(
            a.a.unwrap_or(-0.5 * z),
            a.b.unwrap_or(0.5 * z),
            a.radius.unwrap_or(0.5),
        )?
        .into(),
        Shape::Cylinder => CappedCylinder::new(
            a.a.unwrap_or(-0.75 * z),
            a.b.unwrap_or(0.75 * z),
            a.radius.unwrap_or(0.5),
        )?
        .into(),
        Shape::Cone => CappedCone::new(
            a.a.unwrap_or(-0.75 * z),
            a.b.unwrap_or(0.75 * z),
            a.ra.unwrap_or(0.75),
            a.rb.unwrap_or(0.25),
        )?
        .into(),
        Shape::Plane => Plane::new(a.normal.unwrap_or(z), a.offset.unwrap_or(0.0))?.into(),
        Shape::Ellipsoid => Ellipsoid::new(c, a.radii.unwrap_or(Vec3::new(1.0, 0.6, 0.4)))?.into(),
    };
    Ok(p)
}

/// Wraps the primitive in the requested transform.
fn transformed(a: &Args, p: Primitive) -> Result<Transformed<Primitive>> {
    let mut t = Transformed::new(p);
    if let Some(s) = a.scale {
        t = t.scale(s)?;
    }
    if let Some(r) = &a.rotate {
        let v = parse_numbers(r, 4, "rotate")?;
        t = t.rotate_axis_degrees(Vec3::new(v[0], v[1], v[2]), v[3])?;
    }
    if let Some(v) = a.translate {
        t = t.translate(v)?;
    }
    Ok(t)
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".nrrd", ".npy"])?;
    let field = transformed(&a, primitive(&a)?)?;
    let (bounds, pad) = match &a.bounds {
        Some(s) => {
            let v = parse_numbers(s, 6, "bounds")?;
            let b = Aabb::from_corners(Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
            (b, a.pad.unwrap_or(0.0))
        }
        None => {
            let b = field.bounds();
            if !b.is_finite() {
                bail!(
                    "a {} is unbounded: give the box to sample with --bounds x0,y0,z0,x1,y1,z1",
                    field.inner().name()
                );
            }
            (b, a.pad.unwrap_or(0.1 * b.diagonal()))
        }
    };
    if !(pad.is_finite() && pad >= 0.0) {
        bail!("--pad {pad} must be finite and non-negative");
    }
    let start = Instant::now();
    let mut grid = Grid::covering(bounds, a.res, pad)?;
    sample_into(&field, &mut grid);
    let secs = start.elapsed().as_secs_f64();
    write_volume(&a.output, &Volume::from_grid(&grid))?;
    let (lo, hi) = grid.min_max().unwrap_or((f32::NAN, f32::NAN));
    eprintln!(
        "{}: {} x {} x {} samples, spacing {}, origin {:?}, range {lo} .. {hi}, sampled in {secs:.3} s -> {}",
        field.inner().name(),
        grid.dims()[0],
        grid.dims()[1],
        grid.dims()[2],
        grid.spacing(),
        grid.origin().to_array(),
        a.output.display()
    );
    Ok(())
}
