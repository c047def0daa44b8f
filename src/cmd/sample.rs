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

/// The primitives `isokit sample` knows (their options and defaults: [`SPECS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A sphere.
    Sphere,
    /// An axis-aligned box.
    Box,
    /// A box with rounded edges.
    RoundedBox,
    /// A torus around the z axis.
    Torus,
    /// A capsule (segment plus radius).
    Capsule,
    /// A capped cylinder.
    Cylinder,
    /// A capped cone.
    Cone,
    /// A plane (unbounded).
    Plane,
    /// An ellipsoid.
    Ellipsoid,
}

/// A shape option's value: a number or a vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Val {
    /// A number.
    F(f32),
    /// A vector "x,y,z".
    V(Vec3),
}

impl Val {
    fn f(self) -> f32 {
        match self {
            Val::F(x) => x,
            Val::V(v) => v.x,
        }
    }
    fn v(self) -> Vec3 {
        match self {
            Val::V(v) => v,
            Val::F(x) => Vec3::splat(x),
        }
    }
}

impl std::fmt::Display for Val {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Val::F(x) => write!(f, "{x}"),
            Val::V(v) => write!(f, "{},{},{}", v.x, v.y, v.z),
        }
    }
}

/// One shape: its command-line name and aliases, its options with their defaults (the only
/// copy of the defaults: `--help`, errors and [`primitive`] all read them here), and a note.
pub struct Spec {
    /// The shape.
    pub shape: Shape,
    /// Name on the command line.
    pub name: &'static str,
    /// Other accepted names (hidden).
    pub aliases: &'static [&'static str],
    /// Options (without `--`) and defaults, in help order.
    pub options: &'static [(&'static str, Val)],
    /// Shown after the options in `--help`.
    pub note: &'static str,
}

const O: Val = Val::V(Vec3::ZERO);

/// Every shape, its options and their defaults.
pub const SPECS: [Spec; 9] = [
    Spec {
        shape: Shape::Sphere,
        name: "sphere",
        aliases: &[],
        options: &[("center", O), ("radius", Val::F(1.0))],
        note: "",
    },
    Spec {
        shape: Shape::Box,
        name: "box",
        aliases: &["cuboid"],
        options: &[("center", O), ("half", Val::V(Vec3::new(1.0, 0.75, 0.5)))],
        note: "half extents",
    },
    Spec {
        shape: Shape::RoundedBox,
        name: "rounded-box",
        aliases: &["rounded_box"],
        options: &[
            ("center", O),
            ("half", Val::V(Vec3::new(1.0, 0.75, 0.5))),
            ("radius", Val::F(0.2)),
        ],
        note: "radius: edge rounding",
    },
    Spec {
        shape: Shape::Torus,
        name: "torus",
        aliases: &[],
        options: &[
            ("center", O),
            ("major", Val::F(0.75)),
            ("minor", Val::F(0.25)),
        ],
        note: "axis z",
    },
    Spec {
        shape: Shape::Capsule,
        name: "capsule",
        aliases: &[],
        options: &[
            ("a", Val::V(Vec3::new(0.0, 0.0, -0.5))),
            ("b", Val::V(Vec3::new(0.0, 0.0, 0.5))),
            ("radius", Val::F(0.5)),
        ],
        note: "segment a-b",
    },
    Spec {
        shape: Shape::Cylinder,
        name: "cylinder",
        aliases: &["capped-cylinder", "capped_cylinder"],
        options: &[
            ("a", Val::V(Vec3::new(0.0, 0.0, -0.75))),
            ("b", Val::V(Vec3::new(0.0, 0.0, 0.75))),
            ("radius", Val::F(0.5)),
        ],
        note: "axis a-b",
    },
    Spec {
        shape: Shape::Cone,
        name: "cone",
        aliases: &["capped-cone", "capped_cone"],
        options: &[
            ("a", Val::V(Vec3::new(0.0, 0.0, -0.75))),
            ("b", Val::V(Vec3::new(0.0, 0.0, 0.75))),
            ("ra", Val::F(0.75)),
            ("rb", Val::F(0.25)),
        ],
        note: "radius ra at a, rb at b",
    },
    Spec {
        shape: Shape::Plane,
        name: "plane",
        aliases: &[],
        options: &[("normal", Val::V(Vec3::Z)), ("offset", Val::F(0.0))],
        note: "n·p = offset; unbounded: needs --bounds",
    },
    Spec {
        shape: Shape::Ellipsoid,
        name: "ellipsoid",
        aliases: &[],
        options: &[("center", O), ("radii", Val::V(Vec3::new(1.0, 0.6, 0.4)))],
        note: "exact distance, Eberly's method",
    },
];

impl Shape {
    /// The shape's row of [`SPECS`].
    pub fn spec(self) -> &'static Spec {
        SPECS
            .iter()
            .find(|s| s.shape == self)
            .expect("every shape has a spec")
    }

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        self.spec().name
    }

    /// "--center 0,0,0 --radius 1": the options with their defaults.
    pub fn usage(self) -> String {
        self.spec()
            .options
            .iter()
            .map(|(o, d)| format!("--{o} {d}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

impl clap::ValueEnum for Shape {
    fn value_variants<'a>() -> &'a [Self] {
        const ALL: [Shape; 9] = [
            Shape::Sphere,
            Shape::Box,
            Shape::RoundedBox,
            Shape::Torus,
            Shape::Capsule,
            Shape::Cylinder,
            Shape::Cone,
            Shape::Plane,
            Shape::Ellipsoid,
        ];
        &ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        let s = self.spec();
        let help = if s.note.is_empty() {
            self.usage()
        } else {
            format!("{} ({})", self.usage(), s.note)
        };
        Some(
            clap::builder::PossibleValue::new(s.name)
                .aliases(s.aliases.iter().copied())
                .help(help),
        )
    }
}

/// Arguments of `isokit sample`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The primitive; each takes only its own options (defaults shown), plus the
    /// transforms.
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
    /// Centre (sphere, box, rounded-box, torus, ellipsoid), "x,y,z".
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub center: Option<Vec3>,
    /// Radius (sphere, capsule, cylinder) or edge rounding radius (rounded-box).
    #[arg(long, allow_hyphen_values = true)]
    pub radius: Option<f32>,
    /// Half extents (box, rounded-box), "x,y,z".
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

/// The shape options given on the command line, by name (as in [`SPECS`]).
fn given(a: &Args, option: &str) -> Option<Val> {
    match option {
        "center" => a.center.map(Val::V),
        "radius" => a.radius.map(Val::F),
        "half" => a.half.map(Val::V),
        "major" => a.major.map(Val::F),
        "minor" => a.minor.map(Val::F),
        "a" => a.a.map(Val::V),
        "b" => a.b.map(Val::V),
        "ra" => a.ra.map(Val::F),
        "rb" => a.rb.map(Val::F),
        "normal" => a.normal.map(Val::V),
        "offset" => a.offset.map(Val::F),
        "radii" => a.radii.map(Val::V),
        _ => None,
    }
}

/// Every shape option (the union over [`SPECS`]).
const SHAPE_OPTIONS: [&str; 12] = [
    "center", "radius", "half", "major", "minor", "a", "b", "ra", "rb", "normal", "offset", "radii",
];

/// Builds the primitive from the arguments and the defaults of [`SPECS`]; an option the
/// shape does not take is an error naming the ones it does.
pub fn primitive(a: &Args) -> Result<Primitive> {
    let spec = a.shape.spec();
    let unused: Vec<String> = SHAPE_OPTIONS
        .iter()
        .filter(|o| given(a, o).is_some() && !spec.options.iter().any(|(s, _)| s == *o))
        .map(|o| format!("--{o}"))
        .collect();
    if !unused.is_empty() {
        let takes: Vec<String> = spec.options.iter().map(|(o, _)| format!("--{o}")).collect();
        bail!(
            "{} does not take {}; its options are {}",
            spec.name,
            unused.join(", "),
            takes.join(", ")
        );
    }
    let get = |o: &str| -> Val {
        given(a, o).unwrap_or_else(|| {
            spec.options
                .iter()
                .find(|(s, _)| *s == o)
                .map(|(_, d)| *d)
                .expect("every option read below is in the shape's spec")
        })
    };
    let (f, v) = (|o: &str| get(o).f(), |o: &str| get(o).v());
    let p: Primitive = match a.shape {
        Shape::Sphere => Sphere::new(v("center"), f("radius"))?.into(),
        Shape::Box => Cuboid::new(v("center"), v("half"))?.into(),
        Shape::RoundedBox => RoundedBox::new(v("center"), v("half"), f("radius"))?.into(),
        Shape::Torus => Torus::new(v("center"), f("major"), f("minor"))?.into(),
        Shape::Capsule => Capsule::new(v("a"), v("b"), f("radius"))?.into(),
        Shape::Cylinder => CappedCylinder::new(v("a"), v("b"), f("radius"))?.into(),
        Shape::Cone => CappedCone::new(v("a"), v("b"), f("ra"), f("rb"))?.into(),
        Shape::Plane => Plane::new(v("normal"), f("offset"))?.into(),
        Shape::Ellipsoid => Ellipsoid::new(v("center"), v("radii"))?.into(),
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
    let name = a.shape.name();
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
                    "a {name} is unbounded: give the box to sample with --bounds x0,y0,z0,x1,y1,z1"
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
    let (lo, hi) = grid.min_max().unwrap_or((f32::NAN, f32::NAN));
    let (dims, spacing, origin) = (grid.dims(), grid.spacing(), grid.origin());
    // The volume takes the grid's samples: no second copy at the size limit.
    write_volume(&a.output, &Volume::from(grid))?;
    eprintln!(
        "{name}: {} x {} x {} samples, spacing {spacing}, origin {:?}, range {lo} .. {hi}, sampled in {secs:.3} s -> {}",
        dims[0],
        dims[1],
        dims[2],
        origin.to_array(),
        a.output.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The README's table lists every shape with the defaults of [`SPECS`].
    #[test]
    fn readme_table_matches_the_specs() {
        let readme = include_str!("../../README.md");
        for spec in &SPECS {
            let row = format!("| `{}`", spec.name);
            let line = readme
                .lines()
                .find(|l| l.starts_with(&row))
                .unwrap_or_else(|| panic!("README has no row for {}", spec.name));
            let usage = spec.shape.usage();
            assert!(
                line.contains(&format!("`{usage}`")),
                "{line} lacks `{usage}`"
            );
        }
    }

    #[test]
    fn every_shape_builds_from_its_defaults() {
        use clap::Parser;
        #[derive(Parser)]
        struct T {
            #[command(flatten)]
            a: Args,
        }
        for spec in &SPECS {
            let t = T::try_parse_from(["t", spec.name, "-o", "x.nrrd"]).unwrap();
            assert_eq!(t.a.shape, spec.shape);
            primitive(&t.a).unwrap();
        }
    }
}
