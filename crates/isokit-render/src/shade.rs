//! Deferred shading (002 Sec. 6.4): every pixel's colour from its G-buffer sample alone,
//! with image-space cost. [`shade_pixel`] is the per-pixel function the GPU twin mirrors.
//!
//! | mode | what |
//! | --- | --- |
//! | `phong` | Blinn-Phong with the scene's lights |
//! | `tone` | Gooch cool-to-warm tone shading (GGSC98) |
//! | `normal` | the unit normal as colour, `0.5 + 0.5·n` |
//! | `curvature` | 2D transfer function of `(k1, k2)`: hue by shape index, saturation by curvedness |
//! | `mean`, `gaussian`, `k1`, `k2` | 1D diverging colour map (blue < 0 < red) of one measure |
//! | `ridges` | tone shading with ridge (`k1 ≫ 0`) and valley (`k2 ≪ 0`) regions coloured (KWTM03) |
//! | `silhouette` | tone shading with contours whose thickness follows the view curvature (KWTM03) |
//! | `accessibility` | tone shading darkened where both curvatures are strongly negative (approximate accessibility, Mil94) |
//! | `reflection` | reflection of a procedural environment (sky, ground, horizontal stripes: reflection lines) |
//! | `texture` | a solid texture (3D checkerboard of period 2/κ, world coordinates), diffusely lit |
//! | `flow` | curvature-aligned flow: tone shading modulated by a dense noise texture smeared along the direction of maximum principal curvature, in image space ([`flow_image`]) |
//!
//! Curvature maps are scaled by [`Shading::curvature_scale`] κ: a curvature of κ (radius
//! 1/κ) saturates the map. [`default_curvature_scale`] picks 20 / (volume diagonal).
//!
//! ## Curvature-aligned flow (002 Sec. 6.4, Fig. 6.12)
//! The one mode that is not per pixel: the steady state, for one frame, of image-based flow
//! advection (van Wijk 2003; Laramee et al. 2003), i.e. a line integral convolution (LIC)
//! of white noise along the principal direction of `k1` seen on the screen.
//! 1. **Field** ([`flow_field`], [`flow_direction`]): each pixel's `dir1` is projected onto
//!    the image plane (orthographic: `(dir1·right, −dir1·up)`; perspective: the derivative
//!    of the projection of the hit point moving along `dir1`) and normalized, in pixel
//!    coordinates (x right, y down). The field is undefined (the pixel gets no flow) where
//!    the ray missed, where the surface is umbilic ([`flow_umbilic`]: `|k1 − k2|` below
//!    `0.05·κ + 0.01·(|k1| + |k2|)`, so `dir1` is rounding noise; caps, of zero curvature,
//!    too) and where `dir1` points nearly along the view (projected length below
//!    [`FLOW_MIN_PROJECTED`]).
//! 2. **Noise** ([`flow_noise`]): a deterministic white noise, an integer hash of the pixel
//!    coordinates quantized to 16 bits (fixed to the screen).
//! 3. **Streamlines** ([`flow_lic`]): from the pixel's centre, [`FLOW_STEPS`] Euler steps of
//!    one pixel forward and as many backward; each step reads the field of the pixel it
//!    lands in (nearest-pixel sampling, `floor` of the position) and stops at the image's
//!    border and at a pixel whose flow key ([`FlowPixel::key`]: the id, or none) differs
//!    from the start's: misses, other object-map ids (caps, the other CSG operand) and
//!    umbilic pixels are never read (parts of one surface share an id, so a streamline may
//!    cross a depth discontinuity of the same surface, e.g. at a silhouette). Principal
//!    directions have no sign, so each step's direction is flipped when it points against
//!    the previous one; where the field is not orientable (around umbilics) seams remain,
//!    as 002 notes. The LIC value is the box-filtered mean of the noise over the pixels
//!    visited (the start included, at most `2·FLOW_STEPS + 1`).
//! 4. **Colour** ([`flow_modulate`]): the tone shading times
//!    `0.5 + clamp(0.5 + FLOW_CONTRAST·(lic − 0.5), 0, 1)`; pixels without flow keep the
//!    plain tone shading.
//!
//! [`shade_pixel`] alone gives the plain tone shading in this mode (which is also what the
//! splat shading, per pixel, shows for it). Multi-view G-buffers are refused: their
//! subpixels belong to different views, so there is no single image to advect in.
//! The GPU twin projects the field on the host with [`flow_field`] (the G-buffer is on
//! the host anyway), so both twins trace the same streamlines from bit-identical input.

use crate::kernel::{self, GSample, Uniforms};
use crate::{GBuffer, RenderError};
use glam::Vec3;
use isokit_field::Aabb;
use rayon::prelude::*;
use std::path::Path;

/// A shading mode (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadingMode {
    /// Blinn-Phong.
    #[default]
    Phong,
    /// Gooch tone shading.
    Tone,
    /// Normal as colour.
    Normal,
    /// 2D transfer function of the principal curvatures.
    Curvature,
    /// Mean curvature `(k1 + k2)/2`, diverging map.
    Mean,
    /// Gaussian curvature `k1·k2`, diverging map of `sign·sqrt(|K|)`.
    Gaussian,
    /// Largest principal curvature, diverging map.
    K1,
    /// Smallest principal curvature, diverging map.
    K2,
    /// Ridge and valley regions over tone shading.
    Ridges,
    /// Curvature-controlled contours over tone shading.
    Silhouette,
    /// Approximate accessibility over tone shading.
    Accessibility,
    /// Reflection of a procedural striped environment.
    Reflection,
    /// Solid 3D checkerboard texture.
    Texture,
    /// Curvature-aligned flow: tone shading modulated by a line integral convolution of
    /// white noise along the screen projection of the principal direction of `k1` (see the
    /// module docs); the direction's sign ambiguity is resolved step by step, seams remain
    /// where the field is not orientable; umbilic pixels keep the plain tone shading.
    /// Needs the whole G-buffer ([`shade()`]), not one pixel.
    Flow,
}

impl ShadingMode {
    /// Every mode with its name, as `FromStr` reads it.
    pub const ALL: [(&'static str, ShadingMode); 14] = [
        ("phong", Self::Phong),
        ("tone", Self::Tone),
        ("normal", Self::Normal),
        ("curvature", Self::Curvature),
        ("mean", Self::Mean),
        ("gaussian", Self::Gaussian),
        ("k1", Self::K1),
        ("k2", Self::K2),
        ("ridges", Self::Ridges),
        ("silhouette", Self::Silhouette),
        ("accessibility", Self::Accessibility),
        ("reflection", Self::Reflection),
        ("texture", Self::Texture),
        ("flow", Self::Flow),
    ];

    /// The mode's name.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, m)| *m == self)
            .map_or("phong", |(n, _)| n)
    }
}

impl std::str::FromStr for ShadingMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let l = s.to_ascii_lowercase();
        Self::ALL
            .iter()
            .find(|(n, _)| *n == l)
            .map(|(_, m)| *m)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|(n, _)| *n).collect();
                format!(
                    "unknown shading mode {s:?} (expected one of {})",
                    names.join(", ")
                )
            })
    }
}

/// A light: directional when `direction` is set (the direction the light travels), a point
/// light at `position` otherwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Direction of travel (directional light).
    pub direction: Option<Vec3>,
    /// Position (point light).
    pub position: Option<Vec3>,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Intensity factor.
    pub intensity: f32,
}

/// Shading parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Shading {
    /// The mode.
    pub mode: ShadingMode,
    /// Base colour, linear RGB.
    pub color: Vec3,
    /// Ambient term.
    pub ambient: f32,
    /// Specular strength.
    pub specular: f32,
    /// Specular exponent.
    pub shininess: f32,
    /// Lights; empty: a key light above-left of the camera.
    pub lights: Vec<Light>,
    /// Colour of pixels that hit nothing, linear RGBA.
    pub background: [f32; 4],
    /// Curvature κ that saturates the curvature maps (1/world units).
    pub curvature_scale: f32,
    /// Contour thickness in pixels (`silhouette`).
    pub contour_pixels: f32,
}

impl Default for Shading {
    fn default() -> Self {
        Self {
            mode: ShadingMode::Phong,
            color: Vec3::splat(0.75),
            ambient: 0.1,
            specular: 0.3,
            shininess: 32.0,
            lights: Vec::new(),
            background: [0.8, 0.8, 0.8, 1.0],
            curvature_scale: 1.0,
            contour_pixels: 2.0,
        }
    }
}

impl Shading {
    /// The lights to shade with for the camera `u`: the given ones, or [`default_light`].
    pub fn lights_or_default(&self, u: &Uniforms) -> Vec<Light> {
        if self.lights.is_empty() {
            vec![default_light(u)]
        } else {
            self.lights.clone()
        }
    }

    /// Checks the parameters.
    pub fn check(&self) -> Result<(), RenderError> {
        let finite = self.color.is_finite()
            && self.ambient.is_finite()
            && self.specular.is_finite()
            && self.background.iter().all(|v| v.is_finite())
            && self.lights.iter().all(|l| {
                l.color.is_finite()
                    && l.intensity.is_finite()
                    && l.direction.is_none_or(|d| d.is_finite() && d != Vec3::ZERO)
                    && l.position.is_none_or(|p| p.is_finite())
            });
        if !finite {
            return Err(RenderError::bad(
                "shading",
                format!("{self:?}"),
                "colours, lights and terms must be finite; light directions nonzero",
            ));
        }
        if !(self.shininess.is_finite() && self.shininess >= 0.0) {
            return Err(RenderError::bad(
                "shininess",
                self.shininess,
                "must be finite and non-negative",
            ));
        }
        if !(self.curvature_scale.is_finite() && self.curvature_scale > 0.0) {
            return Err(RenderError::bad(
                "curvature scale",
                self.curvature_scale,
                "must be finite and positive",
            ));
        }
        if !(self.contour_pixels.is_finite() && self.contour_pixels >= 0.0) {
            return Err(RenderError::bad(
                "contour thickness",
                self.contour_pixels,
                "must be finite and non-negative",
            ));
        }
        Ok(())
    }
}

/// The curvature scale of the maps for a volume with these bounds: 20 / diagonal, so that
/// a sphere of a twentieth of the volume's diagonal in radius saturates them.
pub fn default_curvature_scale(bounds: Aabb) -> f32 {
    let d = bounds.diagonal();
    if d.is_finite() && d > 0.0 {
        20.0 / d
    } else {
        1.0
    }
}

/// A linear RGBA image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, row-major, linear RGBA.
    pub pixels: Vec<[f32; 4]>,
}

impl Image {
    /// 8-bit sRGB RGBA bytes (alpha linear).
    pub fn to_rgba8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| {
                [
                    isokit_io::linear_to_srgb8(p[0]),
                    isokit_io::linear_to_srgb8(p[1]),
                    isokit_io::linear_to_srgb8(p[2]),
                    (p[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
                ]
            })
            .collect()
    }

    /// Writes an sRGB PNG (atomically).
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        isokit_io::write_png(path, self.width, self.height, &self.to_rgba8())?;
        Ok(())
    }
}

/// The light directions (unit, from the surface toward the light) and colours at `p`.
fn light_at(l: &Light, p: Vec3) -> (Vec3, Vec3) {
    let dir = match (l.direction, l.position) {
        (Some(d), _) => -d.normalize_or_zero(),
        (None, Some(q)) => (q - p).normalize_or_zero(),
        (None, None) => Vec3::ZERO,
    };
    (dir, l.color * l.intensity)
}

/// The key light used when a scene gives none: from above-left behind the camera.
pub fn default_light(u: &Uniforms) -> Light {
    let (f, r, up) = (
        Vec3::from_array(u.forward),
        Vec3::from_array(u.right),
        Vec3::from_array(u.up),
    );
    Light {
        direction: Some((f - 0.6 * up + 0.4 * r).normalize()),
        position: None,
        color: Vec3::ONE,
        intensity: 1.0,
    }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Diverging colour map of `x` in `[-1, 1]`: blue, white, red (cool-warm).
pub fn diverging(x: f32) -> Vec3 {
    let x = if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) };
    let cold = Vec3::new(0.10, 0.22, 0.75);
    let mid = Vec3::splat(0.85);
    let warm = Vec3::new(0.75, 0.05, 0.05);
    if x < 0.0 {
        mid.lerp(cold, -x)
    } else {
        mid.lerp(warm, x)
    }
}

/// The 2D transfer function of the principal curvatures (`k1 >= k2`, scaled by κ): hue by
/// the shape index `S = (2/π)·atan2(k1 + k2, k1 − k2)` (−1 cup, −½ valley, 0 saddle,
/// ½ ridge, 1 cap: blue, cyan, green, yellow, red), mixed from grey by the curvedness
/// `sqrt((k1² + k2²)/2) / κ`.
pub fn curvature_color(k1: f32, k2: f32, scale: f32) -> Vec3 {
    let s = (k1 + k2).atan2(k1 - k2) * std::f32::consts::FRAC_2_PI;
    let stops = [
        Vec3::new(0.05, 0.15, 0.85),
        Vec3::new(0.05, 0.70, 0.80),
        Vec3::new(0.15, 0.70, 0.15),
        Vec3::new(0.90, 0.80, 0.05),
        Vec3::new(0.85, 0.10, 0.05),
    ];
    let x = ((s.clamp(-1.0, 1.0) + 1.0) * 2.0).min(3.999);
    let i = x.floor() as usize;
    let hue = stops[i].lerp(stops[i + 1], x - i as f32);
    let c = ((k1 * k1 + k2 * k2) * 0.5).sqrt() / scale;
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    Vec3::splat(0.8).lerp(hue, c)
}

/// The procedural environment of the `reflection` mode, seen along unit direction `r`
/// (world +y up): a sky over a dark ground with horizontal stripes, whose reflections draw
/// reflection lines that show the surface's smoothness (002 Fig. 6.15).
pub fn environment(r: Vec3) -> Vec3 {
    let e = r.y.clamp(-1.0, 1.0).asin();
    let sky = Vec3::new(0.55, 0.7, 0.95).lerp(Vec3::splat(0.95), smoothstep(0.0, 1.2, e));
    let ground = Vec3::new(0.25, 0.2, 0.15);
    let base = ground.lerp(sky, smoothstep(-0.03, 0.03, e));
    let stripe = smoothstep(-0.15, 0.15, (12.0 * e).sin());
    base * (0.35 + 0.65 * stripe)
}

/// Normal curvature of the surface along the view direction `v` projected to the tangent
/// plane: `k1 cos²θ + k2 sin²θ` (Euler), θ the angle to `dir1`; the mean curvature when `v`
/// is along the normal.
pub fn view_curvature(s: &GSample, v: Vec3) -> f32 {
    let vt = v - v.dot(s.normal) * s.normal;
    let len = vt.length();
    if len < 1e-6 {
        return 0.5 * (s.k1 + s.k2);
    }
    let c = vt.dot(s.dir1) / len;
    let c2 = (c * c).min(1.0);
    s.k1 * c2 + s.k2 * (1.0 - c2)
}

fn tone(s: &GSample, n: Vec3, v: Vec3, sh: &Shading, lights: &[Light], color: Vec3) -> Vec3 {
    let cool = Vec3::new(0.0, 0.0, 0.45) + 0.25 * color;
    let warm = Vec3::new(0.45, 0.4, 0.0) + 0.55 * color;
    let (l, lc) = lights
        .first()
        .map_or((Vec3::ZERO, Vec3::ONE), |l| light_at(l, s.position));
    let t = 0.5 * (1.0 + n.dot(l));
    let hv = (l - v).normalize_or_zero();
    let spec = sh.specular * n.dot(hv).max(0.0).powf(sh.shininess.max(1.0));
    cool.lerp(warm, t) + spec * lc
}

fn lambert(s: &GSample, n: Vec3, sh: &Shading, lights: &[Light]) -> f32 {
    let d: f32 = lights
        .iter()
        .map(|l| {
            let (dir, c) = light_at(l, s.position);
            n.dot(dir).max(0.0) * c.max_element()
        })
        .sum();
    sh.ambient + (1.0 - sh.ambient) * d.min(1.0)
}

/// The colour of one G-buffer sample seen along the unit view direction `v` (from the eye
/// to the surface). `footprint` is the world size of one pixel at the sample's depth
/// (contour thickness); `lights` must not be empty for lit modes.
pub fn shade_pixel(
    s: &GSample,
    v: Vec3,
    footprint: f32,
    sh: &Shading,
    lights: &[Light],
) -> [f32; 4] {
    shade_pixel_color(s, v, footprint, sh, lights, sh.color)
}

/// [`shade_pixel`] with the base colour given per pixel instead of [`Shading::color`]
/// (objects of their own colour, e.g. atoms).
pub fn shade_pixel_color(
    s: &GSample,
    v: Vec3,
    footprint: f32,
    sh: &Shading,
    lights: &[Light],
    color: Vec3,
) -> [f32; 4] {
    if !s.is_hit() {
        return sh.background;
    }
    let n = s.normal;
    let kappa = sh.curvature_scale;
    let rgb = match sh.mode {
        ShadingMode::Phong => {
            let mut c = sh.ambient * color;
            for l in lights {
                let (dir, lc) = light_at(l, s.position);
                let diff = n.dot(dir).max(0.0);
                let hv = (dir - v).normalize_or_zero();
                let spec = if diff > 0.0 {
                    sh.specular * n.dot(hv).max(0.0).powf(sh.shininess)
                } else {
                    0.0
                };
                c += lc * (color * diff + Vec3::splat(spec));
            }
            c
        }
        ShadingMode::Tone => tone(s, n, v, sh, lights, color),
        ShadingMode::Normal => 0.5 * n + Vec3::splat(0.5),
        ShadingMode::Curvature => curvature_color(s.k1, s.k2, kappa) * lambert(s, n, sh, lights),
        ShadingMode::Mean => diverging(0.5 * (s.k1 + s.k2) / kappa) * lambert(s, n, sh, lights),
        ShadingMode::Gaussian => {
            let g = s.k1 * s.k2;
            diverging(g.signum() * g.abs().sqrt() / kappa) * lambert(s, n, sh, lights)
        }
        ShadingMode::K1 => diverging(s.k1 / kappa) * lambert(s, n, sh, lights),
        ShadingMode::K2 => diverging(s.k2 / kappa) * lambert(s, n, sh, lights),
        ShadingMode::Ridges => {
            let base = tone(s, n, v, sh, lights, color);
            let t = 0.5 * kappa;
            let ridge = if s.k1 > -s.k2 {
                smoothstep(t, 2.0 * t, s.k1)
            } else {
                0.0
            };
            let valley = if -s.k2 > s.k1 {
                smoothstep(t, 2.0 * t, -s.k2)
            } else {
                0.0
            };
            base.lerp(Vec3::new(0.6, 0.05, 0.02), ridge)
                .lerp(Vec3::new(0.02, 0.1, 0.55), valley)
        }
        ShadingMode::Silhouette => {
            let base = tone(s, n, v, sh, lights, color);
            // KWTM03: a contour where |n·v| <= sqrt(T κv (2 − T κv)), T the thickness in
            // world units and κv the curvature along the view; none where κv <= 0.
            let tk = (sh.contour_pixels * footprint * view_curvature(s, v)).clamp(0.0, 1.0);
            let edge = (tk * (2.0 - tk)).sqrt();
            if kernel::is_surface_id(s.id) && n.dot(v).abs() <= edge {
                Vec3::splat(0.02)
            } else {
                base
            }
        }
        ShadingMode::Accessibility => {
            let base = tone(s, n, v, sh, lights, color);
            base * (1.0 - 0.75 * smoothstep(0.0, kappa, -s.k1))
        }
        ShadingMode::Reflection => {
            let r = v - 2.0 * v.dot(n) * n;
            environment(r) * color.max(Vec3::splat(0.2)) / color.max_element().max(0.2)
        }
        ShadingMode::Texture => {
            let q = (s.position * (0.5 * kappa)).floor();
            let odd = (q.x + q.y + q.z).rem_euclid(2.0) >= 1.0;
            let albedo = if odd { color } else { color * 0.35 };
            albedo * lambert(s, n, sh, lights)
        }
        // The per-pixel part of `flow`: the plain shading the LIC modulates.
        ShadingMode::Flow => tone(s, n, v, sh, lights, color),
    };
    [rgb.x, rgb.y, rgb.z, 1.0]
}

/// Streamline steps of one pixel each way of the `flow` mode (the LIC's half length L).
pub const FLOW_STEPS: u32 = 12;

/// Contrast gain of the `flow` mode's LIC value around its mean 0.5 (a mean of `2L + 1`
/// uniform samples has a standard deviation of about 0.058; the gain brings it to 0.29).
pub const FLOW_CONTRAST: f32 = 5.0;

/// Shortest projected length of the unit `dir1` (per unit of depth for perspective) for
/// which the `flow` mode's screen direction is defined.
pub const FLOW_MIN_PROJECTED: f32 = 1e-2;

/// One pixel of the `flow` mode's screen-space direction field ([`flow_field`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlowPixel {
    /// Unit direction in pixel coordinates (x right, y down), sign arbitrary; zero where
    /// `key` is [`kernel::ID_MISS`].
    pub dir: [f32; 2],
    /// The sample's id where the field is defined, [`kernel::ID_MISS`] where not (a miss, an
    /// umbilic, `dir1` along the view). Streamlines stay on pixels of their start's key.
    pub key: u32,
}

/// True when the principal directions of `s` are undefined for the `flow` mode: `|k1 − k2|`
/// at most `0.05·κ + 0.01·(|k1| + |k2|)` (κ the curvature scale), or not finite.
pub fn flow_umbilic(s: &GSample, kappa: f32) -> bool {
    let d = (s.k1 - s.k2).abs();
    !(d.is_finite() && d > 0.05 * kappa + 0.01 * (s.k1.abs() + s.k2.abs()))
}

/// The screen direction of `s.dir1` (a tangent at `s.position`) for the single-view camera
/// of `u`, unit, in pixel coordinates (x right, y down): orthographic
/// `(dir1·right, −dir1·up)`; perspective, with `q = position − eye`, `z = q·forward`,
/// `(sx, sy) = (q·right, q·up) / z` the point's image-plane coordinates and `t = dir1`,
/// `(t·right − sx·(t·forward), −(t·up − sy·(t·forward)))` (the derivative of the
/// projection times `z`). `None` where it is shorter than [`FLOW_MIN_PROJECTED`] (or not
/// finite, or the point is not in front of the eye).
pub fn flow_direction(u: &Uniforms, s: &GSample) -> Option<[f32; 2]> {
    let (r, up, f) = (
        Vec3::from_array(u.right),
        Vec3::from_array(u.up),
        Vec3::from_array(u.forward),
    );
    let t = s.dir1;
    let (dx, dy) = if u.ortho != 0 {
        (t.dot(r), -t.dot(up))
    } else {
        let q = s.position - Vec3::from_array(u.eye);
        let z = q.dot(f);
        if !(z.is_finite() && z > 0.0) {
            return None;
        }
        let (sx, sy) = (q.dot(r) / z, q.dot(up) / z);
        let tf = t.dot(f);
        (t.dot(r) - sx * tf, -(t.dot(up) - sy * tf))
    };
    let len = (dx * dx + dy * dy).sqrt();
    if !(len.is_finite() && len >= FLOW_MIN_PROJECTED) {
        return None;
    }
    Some([dx / len, dy / len])
}

/// The `flow` mode's direction field of a single-view G-buffer (see the module docs), in
/// parallel. The GPU twin uploads this field.
pub fn flow_field(gbuffer: &GBuffer, u: &Uniforms, sh: &Shading) -> Vec<FlowPixel> {
    gbuffer
        .pixels()
        .par_iter()
        .map(|s| {
            if !s.is_hit() || flow_umbilic(s, sh.curvature_scale) {
                return FlowPixel::default();
            }
            match flow_direction(u, s) {
                Some(dir) => FlowPixel { dir, key: s.id },
                None => FlowPixel::default(),
            }
        })
        .collect()
}

/// The integer hash of the `flow` mode's noise (the `lowbias32` finalizer of a mix of the
/// coordinates); `flow_hash` in `shaders/flow.wgsl`.
pub fn flow_hash(x: u32, y: u32) -> u32 {
    let mut h = x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    h
}

/// The white noise of pixel `(x, y)` in `[0, 1)`: the hash's top 16 bits over 2¹⁶ (so that
/// sums of up to 2⁸ of them are exact in f32, on the CPU and the GPU alike).
pub fn flow_noise(x: u32, y: u32) -> f32 {
    (flow_hash(x, y) >> 16) as f32 * (1.0 / 65536.0)
}

/// The LIC value of pixel `(x, y)` of a `width`-wide direction field (see the module docs):
/// the mean noise over the pixels visited by the streamline through the pixel, `FLOW_STEPS`
/// steps each way; −1 where the pixel has no flow. `flow_lic` in `shaders/flow.wgsl`.
pub fn flow_lic(field: &[FlowPixel], width: u32, x: u32, y: u32) -> f32 {
    let height = (field.len() / width.max(1) as usize) as u32;
    let start = field[(x + y * width) as usize];
    if start.key == kernel::ID_MISS {
        return -1.0;
    }
    let mut sum = flow_noise(x, y);
    let mut n = 1u32;
    for sign in [1.0f32, -1.0] {
        let (mut px, mut py) = (x as f32 + 0.5, y as f32 + 0.5);
        let (mut dx, mut dy) = (sign * start.dir[0], sign * start.dir[1]);
        for _ in 0..FLOW_STEPS {
            px += dx;
            py += dy;
            let (fx, fy) = (px.floor(), py.floor());
            if fx < 0.0 || fy < 0.0 || fx >= width as f32 || fy >= height as f32 {
                break;
            }
            let (ix, iy) = (fx as u32, fy as u32);
            let f = field[(ix + iy * width) as usize];
            if f.key != start.key {
                break;
            }
            sum += flow_noise(ix, iy);
            n += 1;
            // Principal directions have no sign: keep the one that continues the line.
            let (mut ex, mut ey) = (f.dir[0], f.dir[1]);
            if ex * dx + ey * dy < 0.0 {
                ex = -ex;
                ey = -ey;
            }
            dx = ex;
            dy = ey;
        }
    }
    sum / n as f32
}

/// Multi-view G-buffers have no single image to advect in.
pub(crate) fn check_flow(u: &Uniforms) -> Result<(), RenderError> {
    if u.subpixels > 1 {
        return Err(RenderError::bad(
            "shading mode",
            "flow",
            "needs a single-view G-buffer: the subpixels of a multi-view one belong to different views",
        ));
    }
    Ok(())
}

/// The LIC image of the `flow` mode ([`flow_lic`] of every pixel of [`flow_field`], in
/// parallel), row-major; −1 where a pixel has no flow. Refuses multi-view G-buffers.
pub fn flow_image(gbuffer: &GBuffer, u: &Uniforms, sh: &Shading) -> Result<Vec<f32>, RenderError> {
    sh.check()?;
    check_flow(u)?;
    check_gbuffer(gbuffer, u)?;
    let field = flow_field(gbuffer, u, sh);
    let w = u.width;
    Ok((0..w * u.height)
        .into_par_iter()
        .map(|i| flow_lic(&field, w, i % w, i / w))
        .collect())
}

/// The `flow` mode's colour: `c` (the tone shading) times
/// `0.5 + clamp(0.5 + FLOW_CONTRAST·(lic − 0.5), 0, 1)`; `c` itself where `lic < 0` (no
/// flow). `flow_modulate` in `shaders/shade.wgsl`.
pub fn flow_modulate(c: [f32; 4], lic: f32) -> [f32; 4] {
    if lic < 0.0 {
        return c;
    }
    let m = 0.5 + (0.5 + FLOW_CONTRAST * (lic - 0.5)).clamp(0.0, 1.0);
    [c[0] * m, c[1] * m, c[2] * m, c[3]]
}

/// Checks that a G-buffer is the size the uniforms it is shaded with make (one sample per
/// pixel, or per subpixel of a multi-view display): both twins' shading start with it.
pub(crate) fn check_gbuffer(gbuffer: &GBuffer, u: &Uniforms) -> Result<(), RenderError> {
    let subs = u.subpixels.max(1);
    if gbuffer.width() != u.width * subs || gbuffer.height() != u.height {
        return Err(RenderError::bad(
            "G-buffer",
            format!("{}x{}", gbuffer.width(), gbuffer.height()),
            "does not match the uniforms it is shaded with",
        ));
    }
    Ok(())
}

/// Shades a G-buffer traced with uniforms `u` (the camera) into an image, in parallel. For
/// a multi-view G-buffer ([`crate::render_multiview`], 3 subpixels per pixel) each channel
/// of a pixel comes from its own subpixel's sample, seen from that subpixel's view. The
/// `flow` mode computes the LIC image of the whole G-buffer first ([`flow_image`]) and
/// refuses multi-view G-buffers.
pub fn shade(gbuffer: &GBuffer, u: &Uniforms, sh: &Shading) -> Result<Image, RenderError> {
    sh.check()?;
    check_gbuffer(gbuffer, u)?;
    let subs = u.subpixels.max(1);
    let lights = sh.lights_or_default(u);
    let lic = if sh.mode == ShadingMode::Flow {
        Some(flow_image(gbuffer, u, sh)?)
    } else {
        None
    };
    let pixel_angle = 2.0 * u.half_height / u.height as f32;
    let color = |s: &GSample, px: u32, py: u32, sub: u32| {
        let v = kernel::subpixel_ray(u, px, py, sub).1;
        let footprint = if u.ortho != 0 {
            pixel_angle
        } else {
            pixel_angle * s.depth
        };
        shade_pixel(s, v, footprint, sh, &lights)
    };
    let px_of = |i: usize| (i as u32 % u.width, i as u32 / u.width);
    let pixels = if subs == 1 {
        gbuffer
            .pixels()
            .par_iter()
            .enumerate()
            .map(|(i, s)| {
                let (px, py) = px_of(i);
                let c = color(s, px, py, 0);
                match &lic {
                    Some(l) => flow_modulate(c, l[i]),
                    None => c,
                }
            })
            .collect()
    } else {
        gbuffer
            .pixels()
            .par_chunks(subs as usize)
            .enumerate()
            .map(|(i, s)| {
                let (px, py) = px_of(i);
                let mut out = [0.0, 0.0, 0.0, 1.0];
                for (c, o) in out.iter_mut().take(3).enumerate() {
                    *o = color(&s[c], px, py, c as u32)[c];
                }
                if s.iter().all(|x| !x.is_hit()) {
                    out[3] = sh.background[3];
                }
                out
            })
            .collect()
    };
    Ok(Image {
        width: u.width,
        height: u.height,
        pixels,
    })
}
