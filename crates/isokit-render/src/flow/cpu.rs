//! The CPU twin of `shaders/flow.wgsl` ([`flow_hash`], [`flow_noise`], [`flow_lic`], in the
//! shader's order), the direction field both twins start from ([`flow_field`], computed on
//! the host for the GPU too) and the whole LIC image ([`flow_image`]). The mode is described
//! in [`crate::shade`]; these items are re-exported there.

use crate::kernel::{self, GSample, Uniforms};
use crate::shade::Shading;
use crate::shade::cpu::check_gbuffer;
use crate::{GBuffer, RenderError};
use glam::Vec3;
use rayon::prelude::*;

/// Streamline steps of one pixel each way of the `flow` mode (the LIC's half length L).
pub const FLOW_STEPS: u32 = 12;

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
