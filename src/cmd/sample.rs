//! `isokit sample SHAPE --res N -o out.nrrd`: an analytic primitive's exact signed distance
//! sampled on a grid. The shapes, their options and defaults are the scene files' (one
//! vocabulary: `isokit_scene::primitives`).

use super::{check_output, parse_vec3};
use anyhow::{Context, Result, bail};
use glam::Vec3;
use isokit_field::{Field, sample_into_job};
use isokit_io::Volume;
use isokit_scene::primitives::PrimitiveKind;
use isokit_scene::{Node, Scene};
use std::path::PathBuf;
use std::time::Instant;

/// The primitive on the command line: the scene files' vocabulary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shape(pub PrimitiveKind);

impl clap::ValueEnum for Shape {
    fn value_variants<'a>() -> &'a [Self] {
        static ALL: std::sync::OnceLock<Vec<Shape>> = std::sync::OnceLock::new();
        ALL.get_or_init(|| PrimitiveKind::ALL.iter().map(|&k| Shape(k)).collect())
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        let k = self.0;
        let help = if k.note().is_empty() {
            k.usage()
        } else {
            format!("{} ({})", k.usage(), k.note())
        };
        let aliases = std::iter::once(k.key())
            .filter(move |a| *a != k.cli_name())
            .chain(k.aliases().iter().copied());
        Some(
            clap::builder::PossibleValue::new(k.cli_name())
                .aliases(aliases)
                .help(help),
        )
    }
}

/// Arguments of `isokit sample`.
#[derive(clap::Args, Debug)]
#[command(after_help = super::volume_args::LAYOUT)]
pub struct Args {
    /// The primitive; each takes only its own options (defaults shown), plus the
    /// transforms.
    pub shape: Shape,
    /// Output volume (.nrrd, or .npy with its lattice sidecar .npy.json; see below).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples along the longest axis of the sampled box (others get the same spacing).
    #[arg(long, default_value_t = 64)]
    pub res: usize,
    /// Where the lattice lies (--bounds is required for the unbounded plane).
    #[command(flatten)]
    pub lattice: super::volume_args::LatticeArgs,
    #[command(flatten)]
    pub out: super::volume_args::VolumeOut,
    #[command(flatten)]
    pub options: super::sample_options::ShapeOptions,
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

/// The shape's node: the vocabulary's defaults with the options given; an option the shape
/// does not take is an error naming the ones it does.
pub fn shape_node(
    shape: PrimitiveKind,
    options: &super::sample_options::ShapeOptions,
) -> Result<Node> {
    Ok(shape.node_with(&options.given())?.into())
}

/// The shape node wrapped in the requested transform.
fn transformed(a: &Args, node: Node) -> Result<Node> {
    let rotate = match &a.rotate {
        Some(r) => {
            let v = parse_numbers(r, 4, "rotate")?;
            Some(isokit_scene::node::Rotation {
                axis: [v[0], v[1], v[2]],
                degrees: v[3],
            })
        }
        None => None,
    };
    Ok(node.transformed(a.scale, rotate, a.translate.map(|t| t.to_array())))
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &super::volume_args::VOLUME_OUTPUTS)?;
    a.out.check(&a.output)?;
    let shape = a.shape.0;
    let scene = Scene::from_node(transformed(&a, shape_node(shape, &a.options)?)?)?;
    let name = shape.cli_name();
    let p = &a.lattice.placement;
    if p.bounds.is_none() && p.like.is_none() && !scene.bounds().is_finite() {
        bail!("a {name} is unbounded: give the box to sample with --bounds x0,y0,z0,x1,y1,z1");
    }
    let mut grid = a
        .lattice
        .grid(std::path::Path::new(name), scene.bounds(), a.res)?;
    let start = Instant::now();
    sample_into_job(scene.field(), &mut grid, &super::progress::job())?;
    let secs = start.elapsed().as_secs_f64();
    let (lo, hi) = grid.min_max().unwrap_or((f32::NAN, f32::NAN));
    let (dims, spacing, origin) = (grid.dims(), grid.spacing(), grid.origin());
    // The volume takes the grid's samples: no second copy at the size limit.
    a.out.write(&a.output, &Volume::from(grid), None, None)?;
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

    /// The README's table lists every shape with the vocabulary's defaults.
    #[test]
    fn readme_table_matches_the_vocabulary() {
        let readme = include_str!("../../README.md");
        for &k in PrimitiveKind::ALL {
            let row = format!("| `{}`", k.cli_name());
            let line = readme
                .lines()
                .find(|l| l.starts_with(&row))
                .unwrap_or_else(|| panic!("README has no row for {}", k.cli_name()));
            let usage = k.usage();
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
        for &k in PrimitiveKind::ALL {
            let t = T::try_parse_from(["t", k.cli_name(), "-o", "x.nrrd"]).unwrap();
            assert_eq!(t.a.shape.0, k);
            shape_node(k, &t.a.options).unwrap();
        }
    }
}
