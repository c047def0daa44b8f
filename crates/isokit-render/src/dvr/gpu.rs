//! The host code of `shaders/dvr.wgsl`: direct volume rendering on the GPU
//! ([`GpuRenderer::render_dvr`]); the CPU twin is `dvr/mod.rs` ([`super::render_dvr`]).
//!
//! The host prepares what both twins share (`prepare` in the parent module: the checked
//! step, the pre-integration table, the empty-block flags) and the rays (one origin and
//! direction per pixel, from the camera exactly as the CPU twin makes them); the kernel
//! traces each ray as `trace_ray` does. The volume goes to the GPU as a storage buffer of f32
//! (x fastest), the transfer function as two `vec4<f32>` per control point. The GPU computes
//! in f32 where the CPU twin integrates partial segments in f64, and its compiler may fuse
//! multiply-adds, so the two agree to rounding (`tests/dvr.rs` measures it), not bit for bit.

use super::{DvrImage, DvrOptions, RayResult, TransferFunction, prepare};
use crate::RenderError;
use crate::clip::Clip;
use crate::gpu::{GpuRenderer, WORKGROUP, check_fits, dispatch_grid, scoped};
use bytemuck::{Pod, Zeroable};
use glam::Vec4;
use isokit_field::{Camera, Grid};
use isokit_gpu::{ShaderSource, wgpu};

/// Sub-steps per linear piece of the transfer function in a pre-integrated segment (both
/// twins; prepended to the WGSL as `SUB_STEPS`).
pub const SUB_STEPS: u32 = 4;

/// `DvrParams` in `dvr.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct DvrParams {
    pub(crate) dims: [u32; 3],
    pub(crate) count: u32,
    pub(crate) origin: [f32; 3],
    pub(crate) spacing: f32,
    pub(crate) bmin: [f32; 3],
    pub(crate) step: f32,
    pub(crate) bmax: [f32; 3],
    pub(crate) termination: f32,
    pub(crate) blocks: [u32; 3],
    pub(crate) block: u32,
    pub(crate) n_tf: u32,
    pub(crate) preintegrated: u32,
    pub(crate) table_n: u32,
    pub(crate) stride: u32,
    pub(crate) table_lo: f32,
    pub(crate) table_hi: f32,
    pub(crate) table_len: f32,
    pub(crate) shade: u32,
    pub(crate) clip_sign: f32,
    pub(crate) clip_pad0: f32,
    pub(crate) clip_pad1: f32,
    pub(crate) clip_pad2: f32,
}

isokit_gpu::wgsl_layout!(DvrParams {
    dims: "vec3<u32>",
    count: "u32",
    origin: "vec3<f32>",
    spacing: "f32",
    bmin: "vec3<f32>",
    step: "f32",
    bmax: "vec3<f32>",
    termination: "f32",
    blocks: "vec3<u32>",
    block: "u32",
    n_tf: "u32",
    preintegrated: "u32",
    table_n: "u32",
    stride: "u32",
    table_lo: "f32",
    table_hi: "f32",
    table_len: "f32",
    shade: "u32",
    clip_sign: "f32",
    clip_pad0: "f32",
    clip_pad1: "f32",
    clip_pad2: "f32",
});

/// The direct volume rendering kernel, assembled: `WORKGROUP`, `SUB_STEPS` and the shading
/// constants from Rust,
/// `dvr.wgsl` (entry point `dvr`).
pub fn dvr_shader() -> ShaderSource {
    let (ka, kd, ks, shininess) = super::SHADE_WEIGHTS;
    ShaderSource::new("dvr")
        .constant_u32("WORKGROUP", WORKGROUP)
        .constant_u32("SUB_STEPS", SUB_STEPS)
        .constant_f32("SHADE_MIN_OPACITY", super::SHADE_MIN_OPACITY)
        .constant_f32("SHADE_KA", ka)
        .constant_f32("SHADE_KD", kd)
        .constant_f32("SHADE_KS", ks)
        .constant_u32("SHININESS", shininess)
        .piece(isokit_shaders::DVR)
}

impl GpuRenderer {
    /// [`super::render_dvr`] on the GPU: the same image to rounding. Volumes with
    /// non-finite samples are refused (WGSL gives NaN and infinity no defined meaning; the
    /// CPU twin renders them as clear).
    pub fn render_dvr(
        &self,
        grid: &Grid,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &DvrOptions,
    ) -> Result<DvrImage, RenderError> {
        self.render_dvr_clipped(grid, camera, tf, opts, None)
    }

    /// [`super::render_dvr_clipped`] on the GPU: the clip field goes up as a second
    /// storage buffer on the volume's lattice and every step is cut as the CPU twin cuts it.
    pub fn render_dvr_clipped(
        &self,
        grid: &Grid,
        camera: &Camera,
        tf: &TransferFunction,
        opts: &DvrOptions,
        clip: Option<&Clip>,
    ) -> Result<DvrImage, RenderError> {
        let (width, height) =
            crate::check_image_size(camera.width() as u64, camera.height() as u64)?;
        if grid.data().iter().any(|v| !v.is_finite()) {
            return Err(RenderError::BadVolume {
                dims: grid.dims(),
                why: "has non-finite samples, which the GPU twin of direct volume rendering does not take (render it on the CPU)",
            });
        }
        let p = prepare(grid, tf, opts)?;
        if let Some(c) = clip {
            c.fits(grid)?;
        }
        let gpu = &self.gpu;
        let count = width as usize * height as usize;
        check_fits(gpu, "the volume", 4 * grid.data().len() as u64)?;
        let clip_data: &[f32] = clip.map_or(&[0.0], |c| c.grid().data());
        check_fits(gpu, "the clip field", 4 * clip_data.len() as u64)?;
        check_fits(gpu, "the rays", 32 * count as u64)?;
        let pipeline = match self.dvr.get() {
            Some(pl) => pl,
            None => {
                let s = dvr_shader();
                let pl = gpu.compute_pipeline(s.label(), s.text(), "dvr")?;
                self.dvr.get_or_init(|| pl)
            }
        };
        let rays: Vec<[f32; 4]> = (0..count)
            .flat_map(|pix| {
                let r = camera.ray(
                    (pix % width as usize) as f32 + 0.5,
                    (pix / width as usize) as f32 + 0.5,
                );
                [
                    r.origin.extend(0.0).to_array(),
                    r.dir.extend(0.0).to_array(),
                ]
            })
            .collect();
        let points: Vec<[f32; 4]> = tf
            .points()
            .iter()
            .flat_map(|q| {
                [
                    [q.value, q.sigma, 0.0, 0.0],
                    q.emission.extend(0.0).to_array(),
                ]
            })
            .collect();
        let (table, table_n, table_lo, table_hi, table_len) = match &p.table {
            Some(t) => (
                t.entries.iter().map(|e| e.to_array()).collect(),
                t.n as u32,
                t.lo,
                t.hi,
                t.len(),
            ),
            None => (vec![[0.0f32; 4]], 2, 0.0, 1.0, 1.0),
        };
        let (empty, blocks, block): (Vec<u32>, [u32; 3], u32) = match &p.blocks {
            Some(b) => (
                b.empty.iter().map(|&e| u32::from(e)).collect(),
                b.counts.map(|c| c as u32),
                b.b as u32,
            ),
            None => (vec![0], [1; 3], 0),
        };
        let (groups, stride) = dispatch_grid(gpu, count);
        let bounds = grid.bounds();
        let params = DvrParams {
            dims: grid.dims().map(|d| d as u32),
            count: count as u32,
            origin: grid.origin().to_array(),
            spacing: grid.spacing(),
            bmin: bounds.min.to_array(),
            step: p.step,
            bmax: bounds.max.to_array(),
            termination: p.termination,
            blocks,
            block,
            n_tf: tf.points().len() as u32,
            preintegrated: u32::from(p.table.is_some()),
            table_n,
            stride,
            table_lo,
            table_hi,
            table_len,
            shade: u32::from(p.shade),
            clip_sign: clip.map_or(0.0, Clip::keep_sign),
            ..DvrParams::default()
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let (_inputs, rgba, extra, bind) = scoped(gpu, "allocating the dvr buffers", || {
            let inputs = [
                gpu.upload("dvr params", &[params], wgpu::BufferUsages::UNIFORM),
                gpu.upload("dvr volume", grid.data(), storage),
                gpu.upload("dvr transfer function", &points, storage),
                gpu.upload("dvr table", &table, storage),
                gpu.upload("dvr empty blocks", &empty, storage),
                gpu.upload("dvr rays", &rays, storage),
                gpu.upload("dvr clip", clip_data, storage),
            ];
            let rgba = gpu.buffer("dvr rgba", 16 * count as u64, storage);
            let extra = gpu.buffer("dvr depth", 16 * count as u64, storage);
            let [a, b, c, d, e, f, k] = &inputs;
            let bind = gpu.bind_buffers("dvr", pipeline, &[a, b, c, d, e, f, &rgba, &extra, k]);
            (inputs, rgba, extra, bind)
        })?;
        gpu.dispatch("dvr", pipeline, &bind, groups)?;
        let rgba: Vec<[f32; 4]> = gpu.read_buffer(&rgba, 0, count)?;
        let extra: Vec<[f32; 4]> = gpu.read_buffer(&extra, 0, count)?;
        let rays: Vec<RayResult> = rgba
            .iter()
            .zip(&extra)
            .map(|(c, x)| {
                let depth = if x[3] > 0.5 { x[0] } else { f32::INFINITY };
                (Vec4::from_array(*c), depth, x[1] as u32, x[2] as u32)
            })
            .collect();
        Ok(DvrImage::from_rays(width, height, &p, &rays))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dvr_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<DvrParams>();
    }
}
