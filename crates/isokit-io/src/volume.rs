//! Volumes: the [`Volume`] type (possibly anisotropic spacing), format dispatch, conversion
//! to [`Grid`] and resampling.

use std::path::Path;

use glam::Vec3;
use isokit_field::{Aabb, FieldError, Grid, checked_len};

use crate::util::{extension, read_file};
use crate::{IoError, inr, lattice, nifti, npy, nrrd};

/// A dense node-centered volume as stored in files: sample `(i, j, k)` sits at
/// `origin + spacing * (i, j, k)` (component-wise) and is stored at `i + nx * (j + ny * k)`
/// (x fastest). Unlike [`Grid`] the spacing may differ between axes.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Samples along x, y, z.
    pub dims: [usize; 3],
    /// World position of sample (0, 0, 0).
    pub origin: Vec3,
    /// Distance between neighbouring samples along x, y, z.
    pub spacing: Vec3,
    /// Samples, x fastest; length `dims[0] * dims[1] * dims[2]`.
    pub data: Vec<f32>,
}

/// Relative tolerance within which three spacings count as one (see [`Volume::into_grid`]).
pub const ISOTROPY_TOL: f32 = 1e-4;

impl Volume {
    /// The volume holding a copy of a grid's samples. To convert without copying (half the
    /// peak memory), use `Volume::from(grid)`.
    pub fn from_grid(grid: &Grid) -> Self {
        Self {
            dims: grid.dims(),
            origin: grid.origin(),
            spacing: Vec3::splat(grid.spacing()),
            data: grid.data().to_vec(),
        }
    }

    /// True when the spacing is the same on all axes within [`ISOTROPY_TOL`] (relative), so
    /// that [`Volume::into_grid`] accepts it.
    pub fn is_uniform(&self) -> bool {
        let (lo, hi) = (self.spacing.min_element(), self.spacing.max_element());
        hi - lo <= ISOTROPY_TOL * hi
    }

    /// Checks that the fields agree: sizes against [`isokit_field::MAX_SAMPLES`], data
    /// length, finite positive spacing, finite origin.
    pub fn check(&self) -> Result<(), IoError> {
        let n = checked_len(self.dims)?;
        if self.data.len() != n {
            return Err(IoError::InvalidVolume(format!(
                "{} samples for dimensions {:?} (need {n})",
                self.data.len(),
                self.dims
            )));
        }
        if !(self.spacing.is_finite() && self.spacing.min_element() > 0.0) {
            return Err(IoError::InvalidVolume(format!(
                "spacing ({}, {}, {}) must be finite and positive",
                self.spacing.x, self.spacing.y, self.spacing.z
            )));
        }
        if !self.origin.is_finite() {
            return Err(IoError::InvalidVolume(format!(
                "origin ({}, {}, {}) must be finite",
                self.origin.x, self.origin.y, self.origin.z
            )));
        }
        Ok(())
    }

    /// The box spanned by the samples.
    pub fn bounds(&self) -> Aabb {
        let n = Vec3::new(
            self.dims[0].saturating_sub(1) as f32,
            self.dims[1].saturating_sub(1) as f32,
            self.dims[2].saturating_sub(1) as f32,
        );
        Aabb::new(self.origin, self.origin + n * self.spacing)
    }

    /// Smallest and largest finite sample, or `None` when no sample is finite.
    pub fn min_max(&self) -> Option<(f32, f32)> {
        isokit_field::finite_min_max(&self.data)
    }

    /// Converts to a [`Grid`] when the spacing is the same on all axes within
    /// [`ISOTROPY_TOL`] (relative); the grid takes the mean spacing. Otherwise
    /// [`IoError::Anisotropic`], which names the spacings: use
    /// [`Volume::resample_uniform`].
    pub fn into_grid(self) -> Result<Grid, IoError> {
        self.check()?;
        if !self.is_uniform() {
            return Err(IoError::Anisotropic {
                spacing: self.spacing.to_array(),
            });
        }
        let s = (self.spacing.x + self.spacing.y + self.spacing.z) / 3.0;
        Ok(Grid::from_data(self.dims, self.origin, s, self.data)?)
    }

    /// Resamples onto a uniform grid of the given spacing with the same origin, by trilinear
    /// interpolation. Each axis gets `floor(extent / spacing) + 1` samples, so the new grid
    /// never reaches beyond the data. Refuses a spacing that is not finite and positive, or one so small
    /// that the grid would exceed [`isokit_field::MAX_SAMPLES`].
    pub fn resample_uniform(&self, spacing: f32) -> Result<Grid, IoError> {
        self.check()?;
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(FieldError::BadSpacing(spacing).into());
        }
        let dims: [usize; 3] = std::array::from_fn(|a| {
            let extent = (self.dims[a] - 1) as f64 * self.spacing[a] as f64;
            // A small tolerance keeps exact multiples (e.g. extent 10, spacing 0.5 → 21).
            let n = (extent / spacing as f64 * (1.0 + 1e-6)).floor() + 1.0;
            if n >= usize::MAX as f64 {
                usize::MAX
            } else {
                n as usize
            }
        });
        let mut g = Grid::new(dims, self.origin, spacing)?;
        let [nx, ny, nz] = self.dims;
        let at = |i: usize, j: usize, k: usize| self.data[i + nx * (j + ny * k)];
        let axis = |q: f32, n: usize| -> (usize, usize, f32) {
            let q = q.clamp(0.0, (n - 1) as f32);
            let i0 = (q.floor() as usize).min(n - 1);
            let i1 = (i0 + 1).min(n - 1);
            (i0, i1, q - i0 as f32)
        };
        let [gx, gy, _] = dims;
        let ratio = Vec3::splat(spacing) / self.spacing;
        for (n, out) in g.data_mut().iter_mut().enumerate() {
            let (i, j, k) = (n % gx, (n / gx) % gy, n / (gx * gy));
            let q = Vec3::new(i as f32, j as f32, k as f32) * ratio;
            let (x0, x1, tx) = axis(q.x, nx);
            let (y0, y1, ty) = axis(q.y, ny);
            let (z0, z1, tz) = axis(q.z, nz);
            let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
            let c00 = lerp(at(x0, y0, z0), at(x1, y0, z0), tx);
            let c10 = lerp(at(x0, y1, z0), at(x1, y1, z0), tx);
            let c01 = lerp(at(x0, y0, z1), at(x1, y0, z1), tx);
            let c11 = lerp(at(x0, y1, z1), at(x1, y1, z1), tx);
            *out = lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), tz);
        }
        Ok(g)
    }
}

/// Takes a grid's samples without copying them.
impl From<Grid> for Volume {
    fn from(grid: Grid) -> Self {
        let (dims, origin, spacing) = (grid.dims(), grid.origin(), grid.spacing());
        Self {
            dims,
            origin,
            spacing: Vec3::splat(spacing),
            data: grid.into_data(),
        }
    }
}

/// The volume file formats, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VolumeFormat {
    /// NRRD with attached data (`.nrrd`), or a detached data file it names.
    Nrrd,
    /// NRRD header with detached data (`.nhdr`).
    Nhdr,
    /// NumPy array (`.npy`), shape `(nz, ny, nx)`.
    Npy,
    /// NIfTI-1 single file (`.nii`).
    Nifti,
    /// Gzip-compressed NIfTI-1 (`.nii.gz`).
    NiftiGz,
    /// INRIMAGE-4 (`.inr`, or gzipped `.inr.gz`), the format of CGAL's sample images.
    Inr,
    /// A Zarr v3 store (a directory `.zarr`; the `zarr` module, with the `zarr` feature).
    Zarr,
}

impl VolumeFormat {
    /// The extensions [`VolumeFormat::from_path`] accepts, for messages.
    pub const EXTENSIONS: &'static str =
        ".nrrd, .nhdr, .npy, .nii, .nii.gz, .inr, .inr.gz or .zarr";

    /// The format named by a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        Ok(match extension(path).as_deref() {
            Some("nrrd") => VolumeFormat::Nrrd,
            Some("nhdr") => VolumeFormat::Nhdr,
            Some("npy") => VolumeFormat::Npy,
            Some("nii") => VolumeFormat::Nifti,
            Some("nii.gz") => VolumeFormat::NiftiGz,
            Some("inr" | "inr.gz") => VolumeFormat::Inr,
            Some("zarr") => VolumeFormat::Zarr,
            _ => {
                return Err(IoError::UnknownFormat {
                    path: path.to_path_buf(),
                    expected: Self::EXTENSIONS,
                });
            }
        })
    }
}

/// Reads a volume by extension. Samples of any stored type become f32.
///
/// - `.nrrd` / `.nhdr`: NRRD0001–5, 3 dimensions, types (u)int8/16/32/64, float, double
///   under all their spellings; encodings raw, gzip, ascii; either byte order;
///   `byte skip` and `line skip`; detached `data file` relative to the header. Geometry from
///   `space directions` (axis-aligned only; negative directions are flipped so that spacing
///   is positive) and `space origin`, or from `spacings` and `axis mins`; default spacing 1,
///   origin 0. Coordinates are taken in the file's space (RAS, LPS, …) without conversion.
/// - `.npy`: a 3-D array of shape `(nz, ny, nx)` in C order (so x is fastest in memory),
///   any numeric dtype. NumPy files carry no geometry: origin and spacing come from the
///   lattice sidecar `<file>.npy.json` when there is one ([`crate::lattice`]), else origin
///   is 0 and spacing 1.
/// - `.nii` / `.nii.gz`: NIfTI-1 of either byte order; datatypes uint8, int16, int32,
///   float32, float64, int8, uint16, uint32 (and int64/uint64); `scl_slope`/`scl_inter`
///   applied (slope 0 means none). Geometry from the sform when `sform_code > 0`, else from
///   the qform (quaternion, `pixdim`, `qfac`, `qoffset`) when `qform_code > 0`, else
///   `pixdim[1..3]` with origin 0. The matrix must be diagonal (axis-aligned; rotated
///   grids are refused as unsupported); negative directions are flipped as for NRRD, so
///   spacing is positive and the origin is the minimum corner. World coordinates are the
///   file's (RAS+ for NIfTI) without conversion. 4-D files are read when `dim[4..]` are
///   all 1.
/// - `.inr` / `.inr.gz`: INRIMAGE-4 (the [`crate::inr`] module says what is read): float and
///   fixed-point samples, either byte order, spacing `VX VY VZ`, origin `TX TY TZ`.
/// - `.zarr`: a Zarr v3 store, a directory (`zarr::read_zarr`, with the `zarr` feature;
///   refused without it): a float32 or float64 array of shape `(nz, ny, nx)` at its root, the lattice from its attributes (else origin
///   0, spacing 1); an incomplete store (a killed writer's) is refused.
///
/// Compressed data (NRRD `gzip`, `.nii.gz`, `.inr.gz`) is inflated only up to the size the header
/// claims, and that size is first checked against [`isokit_field::MAX_SAMPLES`] (8 GiB of
/// f32 at most): the buffer grows with the bytes actually inflated, so a small file
/// claiming a huge volume fails when its data runs out, never by allocating the claim.
/// There is no ratio limit between compressed and claimed sizes, since real volumes
/// (mostly background) compress very well.
pub fn read_volume(path: &Path) -> Result<Volume, IoError> {
    let format = VolumeFormat::from_path(path)?;
    if format == VolumeFormat::Zarr {
        #[cfg(feature = "zarr")]
        return Ok(crate::zarr::read_zarr(path)?.0);
        #[cfg(not(feature = "zarr"))]
        return Err(no_zarr(path));
    }
    let bytes = read_file(path)?;
    let mut volume = read_volume_from(&bytes, format, path)?;
    if format == VolumeFormat::Npy
        && let Some(lattice) = lattice::read_sidecar(path)?
    {
        lattice::apply(&mut volume, &lattice, path)?;
    }
    Ok(volume)
}

/// Reads a volume from bytes in memory; `name` is used in messages and as the location
/// that a detached NRRD data file is relative to.
pub fn read_volume_bytes(
    bytes: &[u8],
    format: VolumeFormat,
    name: &str,
) -> Result<Volume, IoError> {
    read_volume_from(bytes, format, Path::new(name))
}

fn read_volume_from(bytes: &[u8], format: VolumeFormat, path: &Path) -> Result<Volume, IoError> {
    match format {
        VolumeFormat::Nrrd | VolumeFormat::Nhdr => nrrd::read_nrrd(bytes, path),
        VolumeFormat::Npy => npy::read_npy_volume(bytes, path),
        VolumeFormat::Nifti | VolumeFormat::NiftiGz => nifti::read_nifti(bytes, path),
        VolumeFormat::Inr => inr::read_inr(bytes, path),
        VolumeFormat::Zarr => Err(IoError::unsupported(
            path,
            "a Zarr store is a directory: read it by its path (read_volume)",
        )),
    }
}

/// Writes a volume atomically by extension: `.nrrd` (gzip-encoded float at the fast level,
/// see [`write_nrrd`]) or `.npy` (f32, shape `(nz, ny, nx)`; origin and spacing are lost: use
/// [`write_volume_with`] or [`crate::lattice::write_npy_volume`] to keep them in the
/// sidecar).
pub fn write_volume(path: &Path, volume: &Volume) -> Result<(), IoError> {
    match extension(path).as_deref() {
        Some("nrrd") => nrrd::write_nrrd(path, volume, NrrdEncoding::Gzip, None),
        Some("npy") => {
            volume
                .check()
                .map_err(|e| IoError::invalid_input(path, e.to_string()))?;
            let [nx, ny, nz] = volume.dims;
            npy::write_npy_f32(path, &[nz, ny, nx], &volume.data)
        }
        _ => Err(unknown_output(path)),
    }
}

/// Writes a volume atomically by extension with its lattice kept:
/// - `.npy`: f32 of shape `(nz, ny, nx)` and the sidecar `<path>.json`
///   ([`crate::lattice::write_npy_volume`]); `encoding` does not apply (NPY is raw);
/// - `.nrrd`: `encoding`, with the band, inside and sign of `meta` as the key/value pairs
///   `band:=`, `inside:=`, `sign:=` (the sidecar's names).
///
/// Origin, spacing and dims always come from `volume` (those of `meta` are ignored).
pub fn write_volume_with(
    path: &Path,
    volume: &Volume,
    meta: &lattice::Lattice,
    encoding: NrrdEncoding,
) -> Result<(), IoError> {
    lattice::check_band(meta, path)?;
    match extension(path).as_deref() {
        Some("nrrd") => nrrd::write_nrrd(path, volume, encoding, Some(meta)),
        Some("npy") => lattice::write_npy_volume(path, volume, meta),
        #[cfg(feature = "zarr")]
        Some("zarr") => {
            crate::zarr::write_zarr(path, volume, meta, crate::zarr::ZarrOptions::default())
                .map(|_| ())
        }
        #[cfg(not(feature = "zarr"))]
        Some("zarr") => Err(no_zarr(path)),
        _ => Err(unknown_output(path)),
    }
}

/// The refusal of a `.zarr` path in a build without the `zarr` feature.
#[cfg(not(feature = "zarr"))]
fn no_zarr(path: &Path) -> IoError {
    IoError::unsupported(
        path,
        "this build of isokit-io reads and writes no Zarr stores (the `zarr` feature is off)",
    )
}

fn unknown_output(path: &Path) -> IoError {
    IoError::UnknownFormat {
        path: path.to_path_buf(),
        expected: ".nrrd, .npy or .zarr (volumes are written in these)",
    }
}

/// How [`write_nrrd`] encodes the samples (the `--compression none|fast|best` of the
/// command line).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NrrdEncoding {
    /// Little-endian f32, uncompressed.
    Raw,
    /// Little-endian f32, gzip-compressed at the fast level (1; the default): about as
    /// small as the default level 6 on distance fields at a fraction of its time.
    #[default]
    Gzip,
    /// Little-endian f32, gzip-compressed at the best level (9): slowest.
    GzipBest,
}

/// Writes a `NRRD0004` file atomically: `type: float`, `space dimension: 3`,
/// `space directions` (diagonal) and `space origin`, little-endian, with the given encoding
/// (gzip as a single member).
pub fn write_nrrd(path: &Path, volume: &Volume, encoding: NrrdEncoding) -> Result<(), IoError> {
    nrrd::write_nrrd(path, volume, encoding, None)
}

/// Writes an uncompressed (`encoding: raw`) NRRD file atomically.
pub fn write_nrrd_raw(path: &Path, volume: &Volume) -> Result<(), IoError> {
    nrrd::write_nrrd(path, volume, NrrdEncoding::Raw, None)
}
