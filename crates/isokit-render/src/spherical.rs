//! Volumes given on a spherical lattice (Westermann and Ertl 1998, "Efficiently Using
//! Graphics Hardware in Volume Rendering Applications", Sec. 2.2), rendered in world space
//! without resampling them to a Cartesian grid first.
//!
//! The paper assigns texture coordinates per pixel (SGI's pixel textures) because planar
//! slices map to curved surfaces in the lattice's parameter space. A ray caster does the
//! same per sample: each sample's world position `x` is mapped to the lattice's coordinates
//! and the samples are interpolated there.
//!
//! ## The lattice
//! Sample `(i, j, k)` of an `nr × nθ × nφ` array (r fastest) sits at radius
//! `r0 + i·Δr`, polar angle `θ0 + j·Δθ` (from +z) and azimuth `φ0 + k·Δφ` (from +x towards
//! +y), the ranges' ends included (`Δr = (r1 − r0)/(nr − 1)`, and so on), around the world
//! origin. For `x`: `r = |x|`, `θ = acos(z/r)`, `φ = atan2(y, x)`; the lattice coordinates
//! are `((r − r0)/Δr, (θ − θ0)/Δθ, ((φ − φ0) mod 360°)/Δφ)` and the value is the trilinear
//! interpolant of the samples at them ([`SphericalVolume::value`]).
//!
//! - **The seam**: when the azimuths go round the whole circle, either with the last sample
//!   one step before the first (`nφ·Δφ = 360°`, [`SphericalVolume::periodic`]: the cell from
//!   the last sample to the first is interpolated like any other) or with the last sample
//!   on the first (`φ1 − φ0 = 360°`: the two columns are one azimuth and take their mean),
//!   the field is continuous across azimuth `φ0`: no crack.
//! - **The poles**: where the polar range reaches a pole (`θ0 = 0°` or `θ1 = 180°`), the
//!   samples of that row all lie at one point per radius; they are replaced by their mean
//!   over the azimuths, so the interpolant is continuous through the pole (a row that
//!   differs along the azimuth would otherwise give a different value from every side).
//!   The same holds for the centre when `r0 = 0`.
//! - **The domain**: the shell `r0 ≤ r ≤ r1` within the polar and azimuthal ranges.
//!   Outside it there are no samples: [`SphericalVolume::keep`] measures how far inside the
//!   domain a point lies (world units, positive inside; each angular distance taken as an
//!   arc at the point's radius), and both renderers treat the domain as a clip: direct
//!   volume rendering cuts each step to its part inside ([`crate::dvr::render_dvr_spherical`]),
//!   and an isosurface is closed where it meets the domain's boundary, whose face is then
//!   shown ([`render_iso`]).
//!
//! Both renderers have their GPU twin (`shaders/dvr.wgsl`, entry points `dvr` and
//! `spherical_iso`, host code in `dvr/gpu.rs`).

use crate::kernel::{GSample, ID_CAP, ID_SURFACE};
use crate::{GBuffer, Inside, RenderError};
use glam::Vec3;
use isokit_field::{Aabb, Camera, Grid, Ray};
use rayon::prelude::*;

/// Degrees to radians.
const RAD: f32 = std::f32::consts::PI / 180.0;

/// Where the samples of a spherical volume lie: the first and last radius, polar angle and
/// azimuth (degrees) along the array's axes, r fastest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphericalLattice {
    /// Radii of the first and last sample (`0 ≤ r0 < r1`).
    pub r: [f32; 2],
    /// Polar angles from +z of the first and last sample, degrees (`0 ≤ θ0 < θ1 ≤ 180`).
    pub theta: [f32; 2],
    /// Azimuths from +x towards +y of the first and last sample, degrees
    /// (`φ0 < φ1 ≤ φ0 + 360`).
    pub phi: [f32; 2],
}

impl SphericalLattice {
    /// Checks the ranges (finite, increasing, within the sphere's angles).
    pub fn check(&self) -> Result<(), RenderError> {
        let all = [self.r, self.theta, self.phi].concat();
        if all.iter().any(|v| !v.is_finite()) {
            return Err(RenderError::bad(
                "spherical lattice",
                format!("{self:?}"),
                "its ranges must be finite",
            ));
        }
        let [r0, r1] = self.r;
        let [t0, t1] = self.theta;
        let [p0, p1] = self.phi;
        let why = if !(r0 >= 0.0 && r1 > r0) {
            "the radii must satisfy 0 <= r0 < r1"
        } else if !(t0 >= 0.0 && t1 > t0 && t1 <= 180.0) {
            "the polar angles must satisfy 0 <= theta0 < theta1 <= 180 (degrees from +z)"
        } else if !(p1 > p0 && p1 - p0 <= 360.0 * (1.0 + 1e-6)) {
            "the azimuths must satisfy phi0 < phi1 <= phi0 + 360 (degrees)"
        } else {
            return Ok(());
        };
        Err(RenderError::bad(
            "spherical lattice",
            format!("r {r0}..{r1}, theta {t0}..{t1}, phi {p0}..{p1}"),
            why,
        ))
    }
}

/// A scalar volume on a [`SphericalLattice`] (see the [module](self) docs).
#[derive(Clone, Debug)]
pub struct SphericalVolume {
    /// The samples, `nr × nθ × nφ` (pole rows replaced by their means).
    grid: Grid,
    lattice: SphericalLattice,
    /// Δr, Δθ, Δφ (world units, degrees, degrees).
    delta: Vec3,
    /// The azimuths go round with the last cell wrapping to the first sample.
    periodic: bool,
    /// The azimuths cover a wedge only (the domain ends at φ0 and φ1).
    wedge: bool,
}

impl SphericalVolume {
    /// A volume from its samples (`dims` `[nr, nθ, nφ]`, each at least 2; the grid's origin
    /// and spacing are not used) and where they lie. Non-finite samples are refused.
    pub fn new(samples: Grid, lattice: SphericalLattice) -> Result<Self, RenderError> {
        lattice.check()?;
        let [nr, nt, np] = samples.dims();
        if nr < 2 || nt < 2 || np < 2 {
            return Err(RenderError::BadVolume {
                dims: samples.dims(),
                why: "a spherical lattice needs at least 2 samples along r, theta and phi",
            });
        }
        if samples.data().iter().any(|v| !v.is_finite()) {
            return Err(RenderError::BadVolume {
                dims: samples.dims(),
                why: "has non-finite samples (NaN or infinite), which a spherical volume does not take",
            });
        }
        let span = |a: [f32; 2], n: usize| (a[1] - a[0]) / (n - 1) as f32;
        let delta = Vec3::new(
            span(lattice.r, nr),
            span(lattice.theta, nt),
            span(lattice.phi, np),
        );
        let phi_span = lattice.phi[1] - lattice.phi[0];
        let periodic = ((np as f32 * delta.z) - 360.0).abs() <= 1e-3 * delta.z;
        let full = periodic || (phi_span - 360.0).abs() <= 1e-3 * delta.z;
        let mut grid = samples;
        // Samples that lie at one point take one value, their mean: the last azimuth column
        // when it repeats the first (φ1 − φ0 = 360°), the pole rows (one point per radius)
        // and, for r0 = 0, the centre.
        let mut merge = |points: &[(usize, usize, usize)]| {
            let mean = points
                .iter()
                .map(|&(i, j, k)| f64::from(grid.get(i, j, k)))
                .sum::<f64>()
                / points.len() as f64;
            for &(i, j, k) in points {
                grid.set(i, j, k, mean as f32);
            }
        };
        if full && !periodic {
            for j in 0..nt {
                for i in 0..nr {
                    merge(&[(i, j, 0), (i, j, np - 1)]);
                }
            }
        }
        for (at_pole, j) in [
            (lattice.theta[0] == 0.0, 0),
            (lattice.theta[1] == 180.0, nt - 1),
        ] {
            if at_pole {
                for i in 0..nr {
                    merge(&(0..np).map(|k| (i, j, k)).collect::<Vec<_>>());
                }
            }
        }
        if lattice.r[0] == 0.0 {
            let centre: Vec<_> = (0..np)
                .flat_map(|k| (0..nt).map(move |j| (0, j, k)))
                .collect();
            merge(&centre);
        }
        Ok(Self {
            grid,
            lattice,
            delta,
            periodic,
            wedge: !full,
        })
    }

    /// The samples, `[nr, nθ, nφ]` (those at one point replaced by their mean: a repeated
    /// last azimuth, the pole rows, the centre).
    pub fn samples(&self) -> &Grid {
        &self.grid
    }

    /// Where the samples lie.
    pub fn lattice(&self) -> SphericalLattice {
        self.lattice
    }

    /// True when the azimuths go round the circle with the last cell wrapping from the last
    /// sample to the first (`nφ·Δφ = 360°`).
    pub fn periodic(&self) -> bool {
        self.periodic
    }

    /// True when the azimuths cover only a wedge, so the domain ends at `φ0` and `φ1`.
    pub fn wedge(&self) -> bool {
        self.wedge
    }

    /// `(Δr, Δθ, Δφ)`: world units, degrees, degrees.
    pub fn delta(&self) -> Vec3 {
        self.delta
    }

    /// A length that stands for one voxel: the smallest of `Δr` and the angular steps as
    /// arcs at the middle radius (the default step of both renderers, and the spacing of
    /// the central differences that give gradients).
    pub fn spacing(&self) -> f32 {
        let [r0, r1] = self.lattice.r;
        let mid = 0.5 * (r0 + r1);
        self.delta
            .x
            .min(mid * self.delta.y * RAD)
            .min(mid * self.delta.z * RAD)
    }

    /// The box around the outer sphere.
    pub fn bounds(&self) -> Aabb {
        let r = self.lattice.r[1];
        Aabb::new(Vec3::splat(-r), Vec3::splat(r))
    }

    /// Where a ray (unit direction) is within the outer sphere, from `t = 0` on; `None`
    /// when it misses (the twin of `sphere_segment` in `dvr.wgsl`).
    pub fn segment(&self, ray: Ray) -> Option<(f32, f32)> {
        sphere_segment(ray, self.lattice.r[1])
    }

    /// Where a ray is within the inner sphere (`r0 > 0`), which holds no sample: both
    /// renderers pass over the steps wholly inside it (the twin of `sphere_hole` in
    /// `dvr.wgsl`).
    pub fn hole(&self, ray: Ray) -> Option<(f32, f32)> {
        let r0 = self.lattice.r[0];
        if r0 > 0.0 {
            sphere_segment(ray, r0)
        } else {
            None
        }
    }

    /// The samples' smallest and largest value.
    pub fn value_range(&self) -> (f32, f32) {
        crate::dvr::value_range(&self.grid)
    }

    /// `(r, θ, φ')` of `x`: radius, polar angle and azimuth from `φ0` in `[0, 360)`, degrees
    /// (the twin of `spherical_coords` in `dvr.wgsl`).
    pub fn coords(&self, x: Vec3) -> Vec3 {
        let r = x.length();
        let theta = if r > 0.0 {
            (x.z / r).clamp(-1.0, 1.0).acos() / RAD
        } else {
            0.0
        };
        let phi = x.y.atan2(x.x) / RAD - self.lattice.phi[0];
        let phi = phi - 360.0 * (phi / 360.0).floor();
        // Rounding may give exactly 360 for a tiny negative angle.
        let phi = if phi >= 360.0 { 0.0 } else { phi };
        Vec3::new(r, theta, phi)
    }

    /// How far inside the domain `x` lies, world units (positive inside): the least of the
    /// distances to the two spheres and, where the ranges do not cover the sphere, the arcs
    /// to the polar cones and the azimuthal half-planes at `x`'s radius (the twin of
    /// `spherical_keep` in `dvr.wgsl`).
    pub fn keep(&self, x: Vec3) -> f32 {
        let c = self.coords(x);
        let (r, theta, phi) = (c.x, c.y, c.z);
        let [r0, r1] = self.lattice.r;
        let [t0, t1] = self.lattice.theta;
        let mut k = r1 - r;
        if r0 > 0.0 {
            k = k.min(r - r0);
        }
        if t0 > 0.0 {
            k = k.min((theta - t0) * RAD * r);
        }
        if t1 < 180.0 {
            k = k.min((t1 - theta) * RAD * r);
        }
        if self.wedge {
            let span = self.lattice.phi[1] - self.lattice.phi[0];
            let arc = r * (theta * RAD).sin() * RAD;
            let inside = if phi <= span {
                phi.min(span - phi)
            } else {
                -(phi - span).min(360.0 - phi)
            };
            k = k.min(inside * arc);
        }
        k
    }

    /// The sample at `(i, j, k)` with `i`, `j` clamped and `k` wrapped round the circle when
    /// [`SphericalVolume::periodic`], clamped otherwise.
    fn at(&self, i: i64, j: i64, k: i64) -> f32 {
        let [nr, nt, np] = self.grid.dims().map(|n| n as i64);
        let k = if self.periodic {
            k.rem_euclid(np)
        } else {
            k.clamp(0, np - 1)
        };
        self.grid.get(
            i.clamp(0, nr - 1) as usize,
            j.clamp(0, nt - 1) as usize,
            k as usize,
        )
    }

    /// The trilinear interpolant of the samples at `x`'s lattice coordinates (clamped to the
    /// lattice's ends along r and θ, and along φ for a wedge) (the twin of
    /// `spherical_value` in `dvr.wgsl`).
    pub fn value(&self, x: Vec3) -> f32 {
        let c = self.coords(x);
        let [r0, _] = self.lattice.r;
        let [t0, _] = self.lattice.theta;
        let [nr, nt, np] = self.grid.dims().map(|n| n as f32);
        let u = ((c.x - r0) / self.delta.x).clamp(0.0, nr - 1.0);
        let v = ((c.y - t0) / self.delta.y).clamp(0.0, nt - 1.0);
        // Periodic: w up to nφ, where the cell from the last sample wraps to the first.
        let w = (c.z / self.delta.z).clamp(0.0, if self.periodic { np } else { np - 1.0 });
        let (i, j, k) = (u.floor(), v.floor(), w.floor());
        let (a, b, g) = (u - i, v - j, w - k);
        let (i, j, k) = (i as i64, j as i64, k as i64);
        let lerp = |p: f32, q: f32, t: f32| p + t * (q - p);
        let row = |j: i64, k: i64| lerp(self.at(i, j, k), self.at(i + 1, j, k), a);
        let plane = |k: i64| lerp(row(j, k), row(j + 1, k), b);
        lerp(plane(k), plane(k + 1), g)
    }
}

/// Knobs of [`render_iso`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsoOptions {
    /// The isovalue.
    pub iso: f32,
    /// Which side of the isovalue is the solid.
    pub inside: Inside,
    /// The search's step along the ray, world units (`None`: half of
    /// [`SphericalVolume::spacing`]). Features thinner than a step may be missed.
    pub step: Option<f32>,
}

impl Default for IsoOptions {
    fn default() -> Self {
        Self {
            iso: 0.0,
            inside: Inside::Below,
            step: None,
        }
    }
}

/// The checked search step and the sign of the solid (`+1`: inside below the isovalue).
pub(crate) fn iso_knobs(
    vol: &SphericalVolume,
    opts: &IsoOptions,
) -> Result<(f32, f32), RenderError> {
    let step = opts.step.unwrap_or(0.5 * vol.spacing());
    if !(step.is_finite() && step > 0.0) {
        return Err(RenderError::bad(
            "step",
            step,
            "must be positive and finite",
        ));
    }
    if 2.0 * vol.lattice.r[1] / step > 1e7 {
        return Err(RenderError::bad(
            "step",
            step,
            "gives more than 10 million samples per ray; take a longer step",
        ));
    }
    if !opts.iso.is_finite() {
        return Err(RenderError::bad("isovalue", opts.iso, "must be finite"));
    }
    let sign = match opts.inside {
        Inside::Below => 1.0,
        Inside::Above => -1.0,
    };
    Ok((step, sign))
}

/// What one ray of [`render_iso`] found: the distance to the surface, its unit outward
/// normal, whether the domain's boundary owns it, and the samples taken.
pub(crate) type IsoHit = (Option<(f32, Vec3, bool)>, u32);

impl SphericalVolume {
    /// The solid's residual at `x`: `max(s·(f − iso), −keep)`, negative inside the part of
    /// the solid within the domain (`s` +1 when the inside lies below the isovalue). Also
    /// says whether the domain's term is the larger (the twin of `spherical_solid`).
    fn solid(&self, x: Vec3, iso: f32, sign: f32) -> (f32, bool) {
        let a = sign * (self.value(x) - iso);
        let b = -self.keep(x);
        if b > a { (b, true) } else { (a, false) }
    }

    /// The unit outward normal at `x` of the term that owns it: the field's gradient
    /// (times the inside's sign) or the domain's outward direction, by central differences
    /// half a spacing apart.
    fn normal(&self, x: Vec3, sign: f32, domain: bool) -> Vec3 {
        let h = 0.5 * self.spacing();
        let f = |p: Vec3| {
            if domain {
                -self.keep(p)
            } else {
                sign * self.value(p)
            }
        };
        let g = crate::dvr::gradient(&f, x, h);
        let l = g.length();
        if l > 0.0 { g / l } else { Vec3::ZERO }
    }

    /// One ray: steps of `step` from where the ray enters the outer sphere until the
    /// solid's residual is no longer positive, then 24 bisections of the last step (the
    /// twin of `trace_iso` in `dvr.wgsl`).
    pub(crate) fn trace_iso(&self, ray: Ray, iso: f32, sign: f32, step: f32) -> IsoHit {
        let Some((t0, t1)) = self.segment(ray) else {
            return (None, 0);
        };
        let n = ((t1 - t0) / step).ceil().max(1.0) as u32;
        let mut samples = 1u32;
        let mut found = (!positive(self.solid(ray.at(t0), iso, sign).0)).then_some((t0, t0));
        let mut ta = t0;
        let mut k = 1;
        let hole = self.hole(ray);
        while found.is_none() && k <= n {
            let t = (t0 + k as f32 * step).min(t1);
            if let Some((a, b)) = hole
                && t > a
                && t < b
            {
                // The residual is positive all through the hole: on to the first sample
                // beyond it, bracketed from the sample before.
                let next = ((b - t0) / step).ceil() as u32;
                if next > k {
                    k = next;
                    ta = (t0 + (k - 1) as f32 * step).min(t1);
                    continue;
                }
            }
            samples += 1;
            if !positive(self.solid(ray.at(t), iso, sign).0) {
                found = Some((ta, t));
            }
            ta = t;
            k += 1;
        }
        let Some((mut lo, mut hi)) = found else {
            return (None, samples);
        };
        for _ in 0..24 {
            if lo == hi {
                break;
            }
            let mid = 0.5 * (lo + hi);
            let (f, _) = self.solid(ray.at(mid), iso, sign);
            samples += 1;
            if f > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let x = ray.at(hi);
        let (_, domain) = self.solid(x, iso, sign);
        (Some((hi, self.normal(x, sign, domain), domain)), samples)
    }
}

/// Where a ray (unit direction) is within the sphere of radius `r` around the origin, from
/// `t = 0` on (the twin of `sphere_chord` in `dvr.wgsl`).
fn sphere_segment(ray: Ray, r: f32) -> Option<(f32, f32)> {
    let b = ray.origin.dot(ray.dir);
    let c = ray.origin.length_squared() - r * r;
    let disc = b * b - c;
    if !positive(disc) {
        return None;
    }
    let q = disc.sqrt();
    let (t0, t1) = ((-b - q).max(0.0), -b + q);
    (t0 < t1).then_some((t0, t1))
}

/// `x > 0` (false for NaN): outside the solid, or a ray that meets a sphere.
fn positive(x: f32) -> bool {
    x > 0.0
}

/// The G-buffer sample of a hit at distance `t` along `ray`.
pub(crate) fn iso_sample(ray: Ray, hit: Option<(f32, Vec3, bool)>) -> GSample {
    let Some((t, n, domain)) = hit else {
        return GSample::default();
    };
    GSample {
        position: ray.at(t),
        depth: t,
        normal: n,
        dir1: n.any_orthonormal_vector(),
        id: if domain { ID_CAP } else { ID_SURFACE },
        ..GSample::default()
    }
}

/// The isosurface of `vol` seen by `camera`, as a G-buffer for [`crate::shade()`] (one ray
/// per pixel, the CPU twin of [`crate::gpu::GpuRenderer::render_spherical_iso`]). The
/// solid is closed where it meets the domain's boundary: those pixels are caps (`id`
/// [`ID_CAP`]), as the Cartesian caster's volume faces are. Normals come from central
/// differences (no curvature).
///
/// ```
/// use glam::Vec3;
/// use isokit_field::{Camera, Grid, Projection};
/// use isokit_render::spherical::{IsoOptions, SphericalLattice, SphericalVolume, render_iso};
///
/// // A shell from r 0.2 to 1.0 holding r − 0.6: the sphere of radius 0.6.
/// let (nr, nt, np) = (9, 10, 16);
/// let data = (0..nr * nt * np).map(|n| 0.2 + 0.1 * (n % nr) as f32 - 0.6).collect();
/// let grid = Grid::from_data([nr, nt, np], Vec3::ZERO, 1.0, data).unwrap();
/// let lattice = SphericalLattice { r: [0.2, 1.0], theta: [0.0, 180.0], phi: [0.0, 337.5] };
/// let vol = SphericalVolume::new(grid, lattice).unwrap();
/// assert!(vol.periodic());
/// let cam = Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y,
///     Projection::Perspective { fov_y_degrees: 40.0 }, 16, 16).unwrap();
/// let gb = render_iso(&vol, &cam, &IsoOptions::default()).unwrap();
/// let centre = gb.get(8, 8);
/// assert!(centre.is_hit() && (centre.position.length() - 0.6).abs() < 1e-3);
/// ```
pub fn render_iso(
    vol: &SphericalVolume,
    camera: &Camera,
    opts: &IsoOptions,
) -> Result<GBuffer, RenderError> {
    let (w, h) = crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
    let (step, sign) = iso_knobs(vol, opts)?;
    let (pixels, samples): (Vec<GSample>, Vec<u32>) = (0..w * h)
        .into_par_iter()
        .map(|pix| {
            let ray = crate::dvr::pixel_ray(camera, pix);
            let (hit, n) = vol.trace_iso(ray, opts.iso, sign, step);
            (iso_sample(ray, hit), n)
        })
        .unzip();
    Ok(GBuffer::new(w, h, pixels, samples))
}
