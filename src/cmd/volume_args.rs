//! The argument groups of volumes on the command line: where a sampling command's lattice
//! lies (`--bounds`, `--like VOLUME`, `--padding`), how a volume is written
//! (`--compression`, the NPY sidecar) and the lattice a reader gives an NPY file that has
//! no sidecar (`--origin`, `--spacing`).

use anyhow::{Context, Result, bail};
use glam::Vec3;
use isokit_field::{Aabb, Grid};
use isokit_io::lattice::{read_sidecar, sidecar_path};
use isokit_io::{Volume, VolumeFormat, read_volume};

pub use super::volume_out::{Compression, VOLUME_OUTPUTS, VolumeOut};
use std::path::{Path, PathBuf};

/// The layout of the volumes the commands write, for `--help`.
pub const LAYOUT: &str = "Output volume: .nrrd (float, gzip by --compression; band, inside and \
sign as key/value pairs), .npy (float32, shape (nz, ny, nx), x fastest) with its lattice in \
the sidecar <file>.npy.json: origin [x, y, z], spacing [x, y, z], dims [nx, ny, nz], \
axis_order \"zyx\", band, inside, sign; or a Zarr v3 store .zarr (a directory: float32 \
(nz, ny, nx) in --chunk³ chunks, gzip, the sidecar's keys as attributes; chunks holding only \
+band are not written).";

/// Where the sampled lattice lies.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct Placement {
    /// Box to sample, "x0,y0,z0,x1,y1,z1" (padded by --padding, default 0 then).
    #[arg(long, allow_hyphen_values = true, conflicts_with = "like")]
    pub bounds: Option<String>,
    /// Take another volume's lattice (origin, spacing, dims) whole, so that the two combine
    /// sample for sample (`render --csg`); --res, --bounds and --padding do not apply.
    #[arg(long, value_name = "VOLUME")]
    pub like: Option<PathBuf>,
}

/// [`Placement`] with a margin, for the commands that pad their input's bounds.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct LatticeArgs {
    #[command(flatten)]
    pub placement: Placement,
    /// Margin around the input's bounds (or --bounds) in world units [default: 10% of the
    /// bounds' diagonal; 0 with --bounds].
    #[arg(
        long,
        visible_alias = "pad",
        allow_hyphen_values = true,
        conflicts_with = "like"
    )]
    pub padding: Option<f32>,
}

/// Parses `--bounds x0,y0,z0,x1,y1,z1`.
pub fn parse_bounds(s: &str) -> Result<Aabb> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--bounds '{s}' is not a list of numbers"))?;
    if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
        bail!("--bounds '{s}' needs 6 finite numbers separated by commas");
    }
    Ok(Aabb::from_corners(
        Vec3::new(v[0], v[1], v[2]),
        Vec3::new(v[3], v[4], v[5]),
    ))
}

/// The lattice of `--like VOLUME`: dims, origin and (uniform) spacing.
pub fn like_lattice(path: &Path) -> Result<([usize; 3], Vec3, f32)> {
    let v = read_volume(path).with_context(|| format!("--like {}", path.display()))?;
    if !v.is_uniform() {
        bail!(
            "--like {}: its spacing {} differs between axes; a sampled lattice has one spacing",
            path.display(),
            v.spacing
        );
    }
    Ok((v.dims, v.origin, v.spacing.element_sum() / 3.0))
}

impl Placement {
    /// The box to sample when `--bounds` is given.
    pub fn bounds(&self) -> Result<Option<Aabb>> {
        self.bounds.as_deref().map(parse_bounds).transpose()
    }
}

impl LatticeArgs {
    /// The empty grid: `--like`'s lattice; else `--bounds` padded by `--padding` (default
    /// 0); else `input_bounds` (of the file `input`) padded by `--padding` (default 10% of
    /// the diagonal); `res` samples along the longest side. Sizes are checked before
    /// anything is allocated.
    pub fn grid(&self, input: &Path, input_bounds: Aabb, res: usize) -> Result<Grid> {
        if let Some(like) = &self.placement.like {
            let (dims, origin, spacing) = like_lattice(like)?;
            return Ok(Grid::new(dims, origin, spacing)?);
        }
        match self.placement.bounds()? {
            Some(b) => {
                let pad = self.padding.unwrap_or(0.0);
                if let Some(why) = Grid::padding_problem(b, res, pad) {
                    bail!("--padding {pad} {why}");
                }
                Ok(Grid::covering(b, res, pad)?)
            }
            None => super::padded_grid(input, input_bounds, res, self.padding),
        }
    }
}

/// The lattice a reader gives an NPY volume without a sidecar.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct VolumeIn {
    /// World position of sample (0, 0, 0), "x,y,z", for an .npy volume without its
    /// <file>.npy.json sidecar (overrides the file's lattice when given).
    #[arg(long, value_parser = super::parse_vec3, allow_hyphen_values = true)]
    pub origin: Option<Vec3>,
    /// Distance between samples, "x,y,z" or one number, for an .npy volume without its
    /// sidecar (overrides the file's lattice when given).
    #[arg(long, value_parser = super::parse_vec3)]
    pub spacing: Option<Vec3>,
}

impl VolumeIn {
    /// Reads a volume; an NPY file without a sidecar takes `--origin` and `--spacing` (or
    /// origin 0 and spacing 1, with a note saying so).
    pub fn read(&self, path: &Path) -> Result<Volume> {
        let mut v = read_volume(path)?;
        if self.origin.is_none()
            && self.spacing.is_none()
            && VolumeFormat::from_path(path).ok() == Some(VolumeFormat::Npy)
            && read_sidecar(path)?.is_none()
        {
            eprintln!(
                "note: {} has no lattice sidecar {}: taking origin 0 and spacing 1 (voxel units); give --origin x,y,z --spacing h",
                path.display(),
                sidecar_path(path).display()
            );
        }
        if let Some(o) = self.origin {
            v.origin = o;
        }
        if let Some(s) = self.spacing {
            v.spacing = s;
        }
        v.check()
            .with_context(|| format!("{}: --origin/--spacing", path.display()))?;
        Ok(v)
    }

    /// [`VolumeIn::read`] as a uniform grid (anisotropic volumes resampled, with a note).
    pub fn read_grid(&self, path: &Path) -> Result<Grid> {
        super::uniform_grid(self.read(path)?)
    }
}
