//! The host code of `shaders/shade.wgsl` (with `shaders/common/shade_structs.wgsl` and
//! `shaders/common/shade_functions.wgsl`): GPU deferred shading, the twin of
//! [`crate::shade()`], whose CPU side is `shade/cpu.rs`.
//!
//! The `flow` mode adds a pass before the chunked shading (`flow/gpu.rs`): the host projects
//! the direction field ([`crate::shade::flow_field`], the CPU twin's own function, so both
//! twins start from the same bits), uploads it whole (8 bytes of direction and 4 of key
//! per pixel; refused when it exceeds the largest storage binding), and `flow.wgsl`
//! writes the LIC value of every pixel into a buffer the shading pass reads.

use crate::flow::gpu::flow_pass;
use crate::gpu::{GpuRenderer, check_fits, constants, dispatch_grid, scoped};
use crate::kernel::Uniforms;
use crate::raycast::gpu::GpuPixel;
use crate::{GBuffer, Image, Light, RenderError, Shading, ShadingMode};
use bytemuck::{Pod, Zeroable};
use isokit_gpu::{ShaderSource, wgpu};
use isokit_shaders::common::{SHADE_FUNCTIONS, SHADE_STRUCTS};
use isokit_shaders::{RAYCAST_COMMON, SHADE};

/// `ShadeParams` in `common/shade_structs.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct ShadeParams {
    pub(crate) color: [f32; 3],
    pub(crate) mode: u32,
    pub(crate) background: [f32; 4],
    pub(crate) ambient: f32,
    pub(crate) specular: f32,
    pub(crate) shininess: f32,
    pub(crate) curvature_scale: f32,
    pub(crate) contour_pixels: f32,
    pub(crate) lights: u32,
    pub(crate) pixel_angle: f32,
    pub(crate) pixel_base: u32,
    pub(crate) count: u32,
    pub(crate) stride: u32,
    pub(crate) pad0: u32,
    pub(crate) pad1: u32,
}

isokit_gpu::wgsl_layout!(ShadeParams {
    color: "vec3<f32>",
    mode: "u32",
    background: "vec4<f32>",
    ambient: "f32",
    specular: "f32",
    shininess: "f32",
    curvature_scale: "f32",
    contour_pixels: "f32",
    lights: "u32",
    pixel_angle: "f32",
    pixel_base: "u32",
    count: "u32",
    stride: "u32",
    pad0: "u32",
    pad1: "u32",
});

impl ShadeParams {
    /// The parameters of one dispatch of a shading pass: `sh` with `lights` lights for the
    /// camera `u`, pixels `base..base + len`, `stride` invocations per row of workgroups.
    pub(crate) fn new(
        sh: &Shading,
        lights: usize,
        u: &Uniforms,
        base: usize,
        len: usize,
        stride: u32,
    ) -> Self {
        Self {
            color: sh.color.to_array(),
            mode: mode_code(sh.mode),
            background: sh.background,
            ambient: sh.ambient,
            specular: sh.specular,
            shininess: sh.shininess,
            curvature_scale: sh.curvature_scale,
            contour_pixels: sh.contour_pixels,
            lights: lights as u32,
            pixel_angle: 2.0 * u.half_height / u.height as f32,
            pixel_base: base as u32,
            count: len as u32,
            stride,
            pad0: 0,
            pad1: 0,
        }
    }
}

/// `Light` in `common/shade_structs.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct GpuLight {
    pub(crate) dir: [f32; 3],
    pub(crate) point: u32,
    pub(crate) color: [f32; 3],
    pub(crate) pad: f32,
}

isokit_gpu::wgsl_layout!(GpuLight as "Light" {
    dir: "vec3<f32>",
    point: "u32",
    color: "vec3<f32>",
    pad: "f32",
});

impl GpuLight {
    /// What `light_at` in `shade/cpu.rs` computes that does not depend on the pixel, computed
    /// here the same way: a directional light's direction toward the light and every
    /// light's colour times intensity.
    pub(crate) fn new(l: &Light) -> Self {
        let (dir, point) = match (l.direction, l.position) {
            (Some(d), _) => (-d.normalize_or_zero(), 0),
            (None, Some(q)) => (q, 1),
            (None, None) => (glam::Vec3::ZERO, 2),
        };
        Self {
            dir: dir.to_array(),
            point,
            color: (l.color * l.intensity).to_array(),
            pad: 0.0,
        }
    }
}

/// Shades `gbuffer` on the GPU (see [`GpuRenderer::shade`]).
pub(crate) fn shade(
    r: &GpuRenderer,
    gbuffer: &GBuffer,
    u: &Uniforms,
    sh: &Shading,
) -> Result<Image, RenderError> {
    sh.check()?;
    crate::shade::check_gbuffer(gbuffer, u)?;
    let subs = u.subpixels.max(1);
    let gpu = &r.gpu;
    let lights: Vec<GpuLight> = sh.lights_or_default(u).iter().map(GpuLight::new).collect();
    let storage = wgpu::BufferUsages::STORAGE;
    let total = u.width as usize * u.height as usize;
    let per_pixel = (size_of::<GpuPixel>() * subs as usize) as u64;
    let chunk = ((gpu.max_storage_bytes() / per_pixel) as usize)
        .min(r.max_rays_per_dispatch())
        .min(total)
        .max(1);
    check_fits(
        gpu,
        "the lights",
        std::mem::size_of_val(lights.as_slice()) as u64,
    )?;
    // The LIC image of the `flow` mode, else a placeholder for its binding.
    let flow = if sh.mode == ShadingMode::Flow {
        flow_pass(r, gbuffer, u, sh)?
    } else {
        scoped(gpu, "allocating the shading buffers", || {
            gpu.buffer("shade flow placeholder", 4, storage)
        })?
    };
    // The uniforms and lights are only read through the bind group.
    let (_ubuf, pbuf, gbuf, _lbuf, image, bind) =
        scoped(gpu, "allocating the shading buffers", || {
            let ubuf = gpu.upload("shade uniforms", &[*u], wgpu::BufferUsages::UNIFORM);
            let pbuf = gpu.buffer(
                "shade params",
                size_of::<ShadeParams>() as u64,
                wgpu::BufferUsages::UNIFORM,
            );
            let gbuf = gpu.buffer("shade g-buffer", chunk as u64 * per_pixel, storage);
            let lbuf = gpu.upload("shade lights", &lights, storage);
            let image = gpu.buffer("shade image", 16 * chunk as u64, storage);
            let bind = gpu.bind_buffers(
                "shade",
                &r.shade,
                &[&ubuf, &pbuf, &gbuf, &lbuf, &image, &flow],
            );
            (ubuf, pbuf, gbuf, lbuf, image, bind)
        })?;
    let mut pixels = Vec::with_capacity(total);
    for base in (0..total).step_by(chunk) {
        let len = chunk.min(total - base);
        let s = subs as usize;
        let up: Vec<GpuPixel> = gbuffer.pixels()[base * s..(base + len) * s]
            .iter()
            .map(GpuPixel::from_sample)
            .collect();
        gpu.write(&gbuf, 0, bytemuck::cast_slice(&up));
        let (groups, stride) = dispatch_grid(gpu, len);
        let params = ShadeParams::new(sh, lights.len(), u, base, len, stride);
        gpu.write(&pbuf, 0, bytemuck::bytes_of(&params));
        gpu.dispatch("shade", &r.shade, &bind, groups)?;
        let out: Vec<[f32; 4]> = gpu.read_buffer(&image, 0, len)?;
        pixels.extend(out);
    }
    Ok(Image {
        width: u.width,
        height: u.height,
        pixels,
    })
}

/// The shading kernel's WGSL, assembled: constants from Rust (with `MODE_*`, the shading
/// modes in the order of [`ShadingMode::ALL`]), `raycast_common.wgsl`,
/// `common/shade_structs.wgsl`, `common/shade_functions.wgsl`, `shade.wgsl` (entry point
/// `shade`).
pub fn shade_shader() -> ShaderSource {
    let mut src = constants("shade");
    for (name, mode) in ShadingMode::ALL {
        src = src.constant_u32(
            &format!("MODE_{}", name.to_ascii_uppercase()),
            mode_code(mode),
        );
    }
    src.constant_f32("FLOW_CONTRAST", crate::shade::FLOW_CONTRAST)
        .piece(RAYCAST_COMMON)
        .piece(SHADE_STRUCTS)
        .piece(SHADE_FUNCTIONS)
        .piece(SHADE)
}

/// The code of a shading mode in the kernel: its index in [`ShadingMode::ALL`].
pub(crate) fn mode_code(mode: ShadingMode) -> u32 {
    ShadingMode::ALL
        .iter()
        .position(|(_, m)| *m == mode)
        .unwrap_or(0) as u32
}

impl GpuRenderer {
    /// Shades a G-buffer traced with uniforms `u` into an image on the GPU: the GPU twin of
    /// [`crate::shade()`] (any G-buffer, from either twin).
    pub fn shade(
        &self,
        gbuffer: &GBuffer,
        u: &Uniforms,
        sh: &Shading,
    ) -> Result<Image, RenderError> {
        shade(self, gbuffer, u, sh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_shaders::common::SHADE_FUNCTIONS;

    #[test]
    fn shade_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<ShadeParams>();
    }

    #[test]
    fn lights_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<GpuLight>();
    }

    #[test]
    fn shading_mode_codes_follow_the_list() {
        let src = shade_shader();
        assert!(src.text().contains("const MODE_PHONG: u32 = 0u;"));
        assert!(src.text().contains("const MODE_TEXTURE: u32 = 12u;"));
        assert!(src.text().contains("const MODE_FLOW: u32 = 13u;"));
        // Every mode has a case in the kernel (`shade_pixel`, in the shared piece).
        for (name, _) in ShadingMode::ALL {
            let case = format!("case MODE_{}:", name.to_ascii_uppercase());
            assert!(SHADE_FUNCTIONS.contains(&case), "{case}");
        }
    }
}
