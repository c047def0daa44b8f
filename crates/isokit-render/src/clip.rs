//! Clipping a volume by a closed shape (Westermann and Ertl 1998, "Efficiently Using
//! Graphics Hardware in Volume Rendering Applications", Sec. 2.1).
//!
//! The paper finds, slice by slice, the pixels a closed clip object covers with stencil
//! operations. A ray caster has the sample positions at hand, so here the clip object is a
//! field `k` sampled on the volume's own lattice ([`Clip`]): a sample at `x` is kept where
//! `k(x) > 0` (or `< 0` with [`Clip::invert`]), `k` the trilinear interpolant of the clip's
//! samples. Any shape that has a distance field clips: a scene (planes, boxes, meshes
//! through their signed distance), another volume (resampled onto the lattice).
//!
//! - **Direct volume rendering** ([`crate::dvr::render_dvr_clipped`], both twins): each
//!   step is cut to its kept part, where `k` is taken linear between the step's ends; a
//!   post-classified step samples the kept part's middle, a pre-integrated one integrates
//!   the kept part from its own end values (the value linear along the step, as
//!   pre-integration assumes). No sample in the clipped region contributes.
//! - **Isosurfaces** ([`Clip::operand`]): the kept part of the solid is the intersection of
//!   the solid with `{k > 0}`, ray cast as the volume's second operand (002 Sec. 6.4.3,
//!   [`crate::Volume::with_operand`]) by both twins. Where the clip owns the hit (`id`
//!   [`crate::kernel::ID_SURFACE_B`]) the ray met the cut face of the solid, the *cap*: its
//!   normal is the clip's, and [`colour_caps`] shades it with the volume's value there, so
//!   the surface seen through the cut is not hollow.

use crate::shade::{Image, Light, Shading, shade_pixel_color};
use crate::{GBuffer, RenderError, Uniforms, kernel};
use glam::Vec3;
use isokit_field::{Field, Grid, filter::trilinear};
use rayon::prelude::*;

/// A clip field on a volume's lattice: samples are kept where it is positive (negative when
/// inverted).
#[derive(Clone, Debug)]
pub struct Clip {
    grid: Grid,
    invert: bool,
}

impl Clip {
    /// A clip from samples on the volume's lattice (same dimensions, origin and spacing).
    pub fn new(grid: Grid, onto: &Grid, invert: bool) -> Result<Self, RenderError> {
        same_lattice(&grid, onto)?;
        Self::checked(grid, invert)
    }

    /// Refuses a volume on another lattice than the clip's.
    pub(crate) fn fits(&self, volume: &Grid) -> Result<(), RenderError> {
        same_lattice(&self.grid, volume)
    }

    /// A clip field sampled from `field` at every node of `onto`'s lattice.
    pub fn from_field(field: &dyn Field, onto: &Grid, invert: bool) -> Result<Self, RenderError> {
        let mut grid = lattice_of(onto)?;
        isokit_field::sample_into(field, &mut grid);
        Self::checked(grid, invert)
    }

    /// A clip field given on its own lattice, resampled onto `onto`'s by trilinear
    /// interpolation (beyond the clip volume's box its boundary values continue).
    pub fn resampled(clip: &Grid, onto: &Grid, invert: bool) -> Result<Self, RenderError> {
        let mut grid = lattice_of(onto)?;
        let [nx, ny, _] = grid.dims();
        let (origin, h) = (grid.origin(), grid.spacing());
        grid.data_mut()
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slice)| {
                for (n, v) in slice.iter_mut().enumerate() {
                    let x = origin + h * Vec3::new((n % nx) as f32, (n / nx) as f32, k as f32);
                    *v = trilinear(clip, clip.to_grid(x));
                }
            });
        Self::checked(grid, invert)
    }

    fn checked(grid: Grid, invert: bool) -> Result<Self, RenderError> {
        if grid.data().iter().any(|v| !v.is_finite()) {
            return Err(RenderError::BadVolume {
                dims: grid.dims(),
                why: "the clip field has non-finite samples (NaN or infinite): it cannot say which side is kept",
            });
        }
        Ok(Self { grid, invert })
    }

    /// The clip field's samples (on the volume's lattice).
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// True when the negative side is kept.
    pub fn invert(&self) -> bool {
        self.invert
    }

    /// +1 when the positive side is kept, −1 when the negative one is.
    pub fn keep_sign(&self) -> f32 {
        if self.invert { -1.0 } else { 1.0 }
    }

    /// How far inside the kept region `x` (world) lies, in the clip field's units: `k(x)`
    /// times [`Clip::keep_sign`]; kept where positive.
    pub fn keep(&self, x: Vec3) -> f32 {
        self.keep_sign() * trilinear(&self.grid, self.grid.to_grid(x))
    }

    /// The second operand that clips a volume's isosurface `f = iso` (inside below `iso`
    /// when `inside_sign` is +1, above when −1) under [`crate::Combine::Intersection`]:
    /// samples `iso − inside_sign·keep`, whose residual `inside_sign·(b − iso)` is
    /// `−keep`, inside exactly where the clip keeps.
    ///
    /// ```
    /// use glam::Vec3;
    /// use isokit_field::{Grid, primitives::{Plane, Sphere}, sample_into};
    /// use isokit_render::{Combine, Layout, Volume, clip::Clip};
    ///
    /// let mut grid = Grid::new([20; 3], Vec3::splat(-1.0), 2.0 / 19.0).unwrap();
    /// sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut grid);
    /// // Keep x < 0: the plane's distance is positive on the side its normal points to.
    /// let plane = Plane::new(Vec3::NEG_X, 0.0).unwrap();
    /// let clip = Clip::from_field(&plane, &grid, false).unwrap();
    /// let volume = Volume::from_grid(grid, Layout::default()).unwrap()
    ///     .with_operand(clip.operand(0.0, 1.0), Combine::Intersection).unwrap();
    /// assert_eq!(volume.combine(), Some(Combine::Intersection));
    /// ```
    pub fn operand(&self, iso: f32, inside_sign: f32) -> Grid {
        let mut b = self.grid.clone();
        let s = inside_sign * self.keep_sign();
        for v in b.data_mut() {
            *v = iso - s * *v;
        }
        b
    }
}

/// Refuses a clip field on another lattice than the volume's.
fn same_lattice(clip: &Grid, volume: &Grid) -> Result<(), RenderError> {
    let h = volume.spacing();
    if clip.dims() != volume.dims()
        || (clip.spacing() - h).abs() > 1e-5 * h
        || (clip.origin() - volume.origin()).abs().max_element() > 1e-4 * h
    {
        return Err(RenderError::BadVolume {
            dims: clip.dims(),
            why: "the clip field must be on the volume's lattice (Clip::resampled takes any)",
        });
    }
    Ok(())
}

/// An empty grid with `onto`'s lattice (within the memory budget).
fn lattice_of(onto: &Grid) -> Result<Grid, RenderError> {
    Ok(Grid::new(onto.dims(), onto.origin(), onto.spacing())?)
}

/// The colours of [`cap_color`] at 0, 0.25, 0.5, 0.75 and 1 (linear RGB; dark violet to
/// warm yellow, lightness rising monotonically, after the viridis and inferno maps).
const CAP_RAMP: [[f32; 3]; 5] = [
    [0.06, 0.02, 0.20],
    [0.30, 0.05, 0.35],
    [0.70, 0.15, 0.18],
    [0.95, 0.45, 0.05],
    [0.98, 0.85, 0.35],
];

/// The colour of a cap point whose volume value lies the fraction `t` (clamped to 0..1)
/// from the isovalue to the far end of the volume's range on the inside.
pub fn cap_color(t: f32) -> Vec3 {
    let x = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * 4.0;
    let i = (x as usize).min(3);
    Vec3::from(CAP_RAMP[i]).lerp(Vec3::from(CAP_RAMP[i + 1]), x - i as f32)
}

/// Shades the caps of a clipped isosurface (the pixels the clip owns, `id`
/// [`kernel::ID_SURFACE_B`]) with the volume's value there: the trilinear value of `volume`
/// at the hit mapped by [`cap_color`] over the inside's part of `range` (from the isovalue
/// to the range's end on the inside), lit by `shading` as any surface (CPU, after either
/// twin's shading; the other pixels keep theirs). Returns the number of cap pixels.
pub fn colour_caps(
    image: &mut Image,
    gbuffer: &GBuffer,
    u: &Uniforms,
    sh: &Shading,
    volume: &Grid,
    range: (f32, f32),
) -> usize {
    let lights: Vec<Light> = sh.lights_or_default(u);
    let pixel_angle = 2.0 * u.half_height / u.height as f32;
    let far = if u.inside_sign > 0.0 {
        range.0
    } else {
        range.1
    };
    let span = far - u.iso;
    image
        .pixels
        .par_iter_mut()
        .zip(gbuffer.pixels().par_iter())
        .enumerate()
        .filter(|(_, (_, s))| s.is_hit() && s.id == kernel::ID_SURFACE_B)
        .map(|(i, (out, s))| {
            let (px, py) = (i as u32 % u.width, i as u32 / u.width);
            let v = kernel::subpixel_ray(u, px, py, 0).1;
            let footprint = if u.ortho != 0 {
                pixel_angle
            } else {
                pixel_angle * s.depth
            };
            let value = trilinear(volume, volume.to_grid(s.position));
            let t = if span != 0.0 {
                (value - u.iso) / span
            } else {
                0.0
            };
            *out = shade_pixel_color(s, v, footprint, sh, &lights, cap_color(t));
        })
        .count()
}
