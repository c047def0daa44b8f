//! The host code of `shaders/flow.wgsl`: the `flow` shading mode's LIC pass on the GPU, run
//! by the shading pass (`shade/gpu.rs`) before it shades; the CPU twin is `flow/cpu.rs`.

use crate::flow::cpu::{check_flow, flow_field};
use crate::gpu::{GpuRenderer, WORKGROUP, check_fits, dispatch_grid, scoped};
use crate::kernel::{ID_MISS, Uniforms};
use crate::{GBuffer, RenderError, Shading};
use bytemuck::{Pod, Zeroable};
use isokit_gpu::{ShaderSource, wgpu};
use isokit_shaders::FLOW;

/// `FlowParams` in `flow.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct FlowParams {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) count: u32,
    pub(crate) stride: u32,
}

isokit_gpu::wgsl_layout!(FlowParams {
    width: "u32",
    height: "u32",
    count: "u32",
    stride: "u32",
});

/// Runs the `flow` mode's LIC pass over the whole (single-view) G-buffer; returns the
/// buffer of one f32 per pixel that the shading pass binds.
pub(crate) fn flow_pass(
    r: &GpuRenderer,
    gbuffer: &GBuffer,
    u: &Uniforms,
    sh: &Shading,
) -> Result<wgpu::Buffer, RenderError> {
    check_flow(u)?;
    let gpu = &r.gpu;
    let total = u.width as usize * u.height as usize;
    check_fits(gpu, "the flow direction field", 8 * total as u64)?;
    let field = flow_field(gbuffer, u, sh);
    let dirs: Vec<[f32; 2]> = field.iter().map(|f| f.dir).collect();
    let keys: Vec<u32> = field.iter().map(|f| f.key).collect();
    drop(field);
    let (flow_groups, stride) = dispatch_grid(gpu, total);
    let params = FlowParams {
        width: u.width,
        height: u.height,
        count: total as u32,
        stride,
    };
    let storage = wgpu::BufferUsages::STORAGE;
    // The parameters and the field are only read through the bind group.
    let (_pbuf, _dbuf, _kbuf, lic, bind) = scoped(gpu, "allocating the flow buffers", || {
        let pbuf = gpu.upload("flow params", &[params], wgpu::BufferUsages::UNIFORM);
        let dbuf = gpu.upload("flow directions", &dirs, storage);
        let kbuf = gpu.upload("flow keys", &keys, storage);
        let lic = gpu.buffer("flow lic", 4 * total as u64, storage);
        let bind = gpu.bind_buffers("flow", &r.flow, &[&pbuf, &dbuf, &kbuf, &lic]);
        (pbuf, dbuf, kbuf, lic, bind)
    })?;
    gpu.dispatch("flow", &r.flow, &bind, flow_groups)?;
    Ok(lic)
}

/// The `flow` shading mode's LIC kernel, assembled: `WORKGROUP`, `ID_MISS`, `FLOW_STEPS`
/// from Rust, `flow.wgsl` (entry point `flow`).
pub fn flow_shader() -> ShaderSource {
    ShaderSource::new("flow")
        .constant_u32("WORKGROUP", WORKGROUP)
        .constant_u32("ID_MISS", ID_MISS)
        .constant_u32("FLOW_STEPS", crate::flow::cpu::FLOW_STEPS)
        .piece(FLOW)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flow_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<FlowParams>();
    }
}
