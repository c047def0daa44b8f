//! The CPU twin of `shaders/shade.wgsl` with `shaders/common/shade_functions.wgsl`: the
//! per-pixel shading ([`shade_pixel_color`] and its helpers, in the shader's order) and the
//! passes over a G-buffer ([`shade()`]). The settings and the mode table are documented in
//! [`crate::shade`].

use crate::flow::cpu::flow_image;
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

    /// True for the modes that show the principal curvatures (or directions) of the
    /// G-buffer: `curvature`, `mean`, `gaussian`, `k1`, `k2`, `ridges`, `silhouette`,
    /// `accessibility`, `flow`.
    pub fn uses_curvature(self) -> bool {
        !matches!(
            self,
            Self::Phong | Self::Tone | Self::Normal | Self::Reflection | Self::Texture
        )
    }

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
        let v3 = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
        if !self.color.is_finite() {
            return Err(RenderError::bad("color", v3(self.color), "must be finite"));
        }
        for (name, v) in [("ambient", self.ambient), ("specular", self.specular)] {
            if !v.is_finite() {
                return Err(RenderError::bad(name, v, "must be finite"));
            }
        }
        if !self.background.iter().all(|v| v.is_finite()) {
            return Err(RenderError::bad(
                "background",
                format!("{:?}", self.background),
                "must be finite",
            ));
        }
        for (i, l) in self.lights.iter().enumerate() {
            if let Some(d) = l.direction
                && !(d.is_finite() && d != Vec3::ZERO)
            {
                return Err(RenderError::bad(
                    "light direction",
                    format!("{} (lights[{i}])", v3(d)),
                    "must be finite and nonzero: the direction the light travels, e.g. [0, -1, 0] for light from above",
                ));
            }
            if let Some(p) = l.position
                && !p.is_finite()
            {
                return Err(RenderError::bad(
                    "light position",
                    format!("{} (lights[{i}])", v3(p)),
                    "must be finite",
                ));
            }
            if !(l.color.is_finite() && l.intensity.is_finite()) {
                return Err(RenderError::bad(
                    "light color and intensity",
                    format!("{} and {} (lights[{i}])", v3(l.color), l.intensity),
                    "must be finite",
                ));
            }
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
        const ROWS: usize = 4096;
        let mut out = vec![0u8; 4 * self.pixels.len()];
        out.par_chunks_mut(4 * ROWS)
            .zip(self.pixels.par_chunks(ROWS))
            .for_each(|(out, pixels)| {
                for (o, p) in out.chunks_exact_mut(4).zip(pixels) {
                    o.copy_from_slice(&[
                        isokit_io::linear_to_srgb8(p[0]),
                        isokit_io::linear_to_srgb8(p[1]),
                        isokit_io::linear_to_srgb8(p[2]),
                        (p[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
                    ]);
                }
            });
        out
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

/// Contrast gain of the `flow` mode's LIC value around its mean 0.5 (a mean of `2L + 1`
/// uniform samples has a standard deviation of about 0.058; the gain brings it to 0.29).
pub const FLOW_CONTRAST: f32 = 5.0;

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

/// [`shade`], taking from `kept` (the frame before an edit, [`crate::render_reusing`]) the
/// colour of every pixel whose G-buffer sample is the kept one's bit for bit, where that
/// frame had the same uniforms and shading: a pixel's colour depends on nothing else
/// (every mode but [`ShadingMode::Flow`], whose line integrals read the neighbours).
pub fn shade_reusing(
    gbuffer: &GBuffer,
    u: &Uniforms,
    sh: &Shading,
    kept: Option<&crate::KeptFrame>,
) -> Result<Image, RenderError> {
    let prior = kept
        .filter(|_| sh.mode != ShadingMode::Flow && u.subpixels <= 1)
        .and_then(|k| k.image_for(u, sh))
        .filter(|(p, _)| p.len() == gbuffer.pixels().len());
    let Some((before, image)) = prior else {
        return shade(gbuffer, u, sh);
    };
    sh.check()?;
    check_gbuffer(gbuffer, u)?;
    let lights = sh.lights_or_default(u);
    let pixels = gbuffer
        .pixels()
        .par_iter()
        .zip(before)
        .zip(&image.pixels)
        .enumerate()
        .map(|(i, ((s, b), &c))| {
            if same_bits(s, b) {
                return c;
            }
            colour_of(u, s, i as u32 % u.width, i as u32 / u.width, 0, sh, &lights)
        })
        .collect();
    Ok(Image {
        width: u.width,
        height: u.height,
        pixels,
    })
}

/// The colour of ray `(px, py, sub)` of a frame with uniforms `u` (all but
/// [`ShadingMode::Flow`]'s modulation): [`shade_pixel`] with the ray's direction and the
/// pixel's footprint at the hit.
fn colour_of(
    u: &Uniforms,
    s: &GSample,
    px: u32,
    py: u32,
    sub: u32,
    sh: &Shading,
    lights: &[Light],
) -> [f32; 4] {
    if !s.is_hit() {
        // As `shade_pixel` colours it, without the ray it does not read.
        return sh.background;
    }
    let pixel_angle = 2.0 * u.half_height / u.height as f32;
    let v = kernel::subpixel_ray(u, px, py, sub).1;
    let footprint = if u.ortho != 0 {
        pixel_angle
    } else {
        pixel_angle * s.depth
    };
    shade_pixel(s, v, footprint, sh, lights)
}

/// True when two G-buffer samples are the same bit for bit.
fn same_bits(a: &GSample, b: &GSample) -> bool {
    let f = |s: &GSample| {
        [
            s.position.x,
            s.position.y,
            s.position.z,
            s.depth,
            s.normal.x,
            s.normal.y,
            s.normal.z,
            s.k1,
            s.k2,
            s.dir1.x,
            s.dir1.y,
            s.dir1.z,
        ]
        .map(f32::to_bits)
    };
    a.id == b.id && f(a) == f(b)
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
    let color = |s: &GSample, px: u32, py: u32, sub: u32| colour_of(u, s, px, py, sub, sh, &lights);
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
