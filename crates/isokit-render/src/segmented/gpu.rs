//! The host code of `shaders/segmented.wgsl`: the GPU twin of ray casting a segmented
//! distance field ([`GpuRenderer::render_segmented`]; CPU twin [`SegmentedCaster::render`]).
//!
//! The field goes up as a storage buffer of f32 (x fastest), the vertex generation diagram
//! (when the caster uses it) as its three layers of `t`, the rays (one origin and unit
//! direction per pixel) as the CPU twin makes them. Both twins compute in f32 in the same
//! order, so they differ only where the GPU's compiler fuses multiply-adds or rounds a
//! division differently.

use super::{SegmentedCaster, SegmentedHit, SegmentedImage, check_layers, layer_images};
use crate::RenderError;
use crate::gpu::{GpuRenderer, WORKGROUP, check_fits, dispatch_grid, scoped};
use crate::kernel::{Uniforms, pixel_ray};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use isokit_gpu::{ShaderSource, wgpu};

/// `SegParams` in `segmented.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct SegParams {
    pub(crate) dims: [u32; 3],
    pub(crate) count: u32,
    pub(crate) origin: [f32; 3],
    pub(crate) spacing: f32,
    pub(crate) delta: f32,
    pub(crate) period: f32,
    pub(crate) diagram: u32,
    pub(crate) levels: u32,
    pub(crate) n: u32,
    pub(crate) stride: u32,
    pub(crate) layers: u32,
    pub(crate) pad: u32,
}

isokit_gpu::wgsl_layout!(SegParams {
    dims: "vec3<u32>",
    count: "u32",
    origin: "vec3<f32>",
    spacing: "f32",
    delta: "f32",
    period: "f32",
    diagram: "u32",
    levels: "u32",
    n: "u32",
    stride: "u32",
    layers: "u32",
    pad: "u32",
});

/// The segmented ray caster's kernel, assembled: `WORKGROUP` from Rust,
/// `common/slab.wgsl`, `segmented.wgsl` (entry point `segmented`).
pub fn segmented_shader() -> ShaderSource {
    ShaderSource::new("segmented")
        .constant_u32("WORKGROUP", WORKGROUP)
        .piece(isokit_shaders::common::SLAB)
        .piece(isokit_shaders::SEGMENTED)
}

impl GpuRenderer {
    /// [`SegmentedCaster::render`] on the GPU: the same G-buffer and region pairs to f32
    /// rounding.
    pub fn render_segmented(
        &self,
        caster: &SegmentedCaster<'_>,
        u: &Uniforms,
    ) -> Result<SegmentedImage, RenderError> {
        let mut layers = self.render_segmented_layers(caster, u, 1)?;
        Ok(layers.remove(0))
    }

    /// [`SegmentedCaster::render_layers`] on the GPU.
    pub fn render_segmented_layers(
        &self,
        caster: &SegmentedCaster<'_>,
        u: &Uniforms,
        layers: usize,
    ) -> Result<Vec<SegmentedImage>, RenderError> {
        let (w, h) = crate::check_image_size(u64::from(u.width), u64::from(u.height))?;
        check_layers(layers)?;
        let gpu = &self.gpu;
        let grid = caster.grid;
        let count = (w * h) as usize;
        check_fits(gpu, "the segmented field", 4 * grid.data().len() as u64)?;
        check_fits(gpu, "the rays", 32 * count as u64)?;
        check_fits(gpu, "the output", 48 * (count * layers) as u64)?;
        let rays: Vec<(Vec3, Vec3)> = (0..w * h)
            .map(|pix| {
                let (o, d) = pixel_ray(u, pix % w, pix / w);
                (o, d.normalize_or_zero())
            })
            .collect();
        let ray_data: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|(o, d)| [o.extend(0.0).to_array(), d.extend(0.0).to_array()])
            .collect();
        let (groups, stride) = dispatch_grid(gpu, count);
        let (table, levels, n): (&[f32], usize, usize) = match &caster.diagram {
            Some(d) => (&d.t, d.levels, d.n),
            None => (&[-1.0], 2, 1),
        };
        check_fits(gpu, "the vertex generation diagram", 4 * table.len() as u64)?;
        let params = SegParams {
            dims: grid.dims().map(|d| d as u32),
            count: count as u32,
            origin: grid.origin().to_array(),
            spacing: grid.spacing(),
            delta: caster.seg.delta(),
            period: caster.seg.period(),
            diagram: u32::from(caster.diagram.is_some()),
            levels: levels as u32,
            n: n as u32,
            stride,
            layers: layers as u32,
            ..SegParams::default()
        };
        let pipeline = match self.segmented.get() {
            Some(pl) => pl,
            None => {
                let s = segmented_shader();
                let pl = gpu.compute_pipeline(s.label(), s.text(), "segmented")?;
                self.segmented.get_or_init(|| pl)
            }
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let (_inputs, out, bind) = scoped(gpu, "allocating the segmented buffers", || {
            let inputs = [
                gpu.upload("segmented params", &[params], wgpu::BufferUsages::UNIFORM),
                gpu.upload("segmented field", grid.data(), storage),
                gpu.upload("segmented diagram", table, storage),
                gpu.upload("segmented rays", &ray_data, storage),
            ];
            let out = gpu.buffer("segmented output", 48 * (count * layers) as u64, storage);
            let [a, b, c, d] = &inputs;
            let bind = gpu.bind_buffers("segmented", pipeline, &[a, b, c, d, &out]);
            (inputs, out, bind)
        })?;
        gpu.dispatch("segmented", pipeline, &bind, groups)?;
        let out: Vec<[f32; 4]> = gpu.read_buffer(&out, 0, 3 * count * layers)?;
        Ok(layer_images(w, h, layers, |ray, k| {
            let r = &out[3 * (ray * layers + k)..];
            let samples = if k == 0 {
                out[3 * ray * layers][2] as u32
            } else {
                0
            };
            let hit = (r[0][1] > 0.5).then(|| SegmentedHit {
                t: r[0][0],
                position: Vec3::new(r[0][3], r[1][3], r[2][2]),
                normal: Vec3::new(r[1][0], r[1][1], r[1][2]),
                regions: [r[2][0] as i32, r[2][1] as i32],
            });
            (hit, samples)
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seg_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<SegParams>();
    }
}
