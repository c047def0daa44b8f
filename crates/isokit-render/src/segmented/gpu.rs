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
        check_fits(gpu, "the segmented field", 4 * grid.data().len() as u64)?;
        let rays: Vec<(Vec3, Vec3)> = (0..w * h)
            .map(|pix| {
                let (o, d) = pixel_ray(u, pix % w, pix / w);
                (o, d.normalize_or_zero())
            })
            .collect();
        let (table, levels, n): (&[f32], usize, usize) = match &caster.diagram {
            Some(d) => (&d.t, d.levels, d.n),
            None => (&[-1.0], 2, 1),
        };
        check_fits(gpu, "the vertex generation diagram", 4 * table.len() as u64)?;
        let params = SegParams {
            dims: grid.dims().map(|d| d as u32),
            origin: grid.origin().to_array(),
            spacing: grid.spacing(),
            delta: caster.seg.delta(),
            period: caster.seg.period(),
            diagram: u32::from(caster.diagram.is_some()),
            levels: levels as u32,
            n: n as u32,
            layers: layers as u32,
            ..SegParams::default()
        };
        // In chunks of rays whose output (48 bytes a layer) fits the device.
        let fit = (gpu.max_storage_bytes() / (48 * layers as u64)).max(1) as usize;
        let chunk = self.max_rays.min(fit).max(1);
        let mut out: Vec<[f32; 4]> = Vec::with_capacity(3 * rays.len() * layers);
        for part in rays.chunks(chunk) {
            out.extend(self.dispatch_segmented(part, params, grid.data(), table)?);
        }
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

impl GpuRenderer {
    /// Uploads the field, the diagram and `rays`, runs `segmented` once per ray with
    /// `params` completed, and reads back its three `vec4<f32>` per ray and layer.
    fn dispatch_segmented(
        &self,
        rays: &[(Vec3, Vec3)],
        mut params: SegParams,
        field: &[f32],
        table: &[f32],
    ) -> Result<Vec<[f32; 4]>, RenderError> {
        let gpu = &self.gpu;
        let (count, layers) = (rays.len(), params.layers as usize);
        let ray_data: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|(o, d)| [o.extend(0.0).to_array(), d.extend(0.0).to_array()])
            .collect();
        check_fits(gpu, "the ray buffer", 32 * count as u64)?;
        check_fits(gpu, "the output buffer", 48 * (count * layers) as u64)?;
        let (groups, stride) = dispatch_grid(gpu, count);
        params.count = count as u32;
        params.stride = stride;
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
                gpu.upload("segmented field", field, storage),
                gpu.upload("segmented diagram", table, storage),
                gpu.upload("segmented rays", &ray_data, storage),
            ];
            let out = gpu.buffer("segmented output", 48 * (count * layers) as u64, storage);
            let [a, b, c, d] = &inputs;
            let bind = gpu.bind_buffers("segmented", pipeline, &[a, b, c, d, &out]);
            (inputs, out, bind)
        })?;
        gpu.dispatch("segmented", pipeline, &bind, groups)?;
        Ok(gpu.read_buffer(&out, 0, 3 * count * layers)?)
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
