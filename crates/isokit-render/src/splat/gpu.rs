//! The GPU twin of quadric splatting and of its shading (the twin of [`crate::splat`]): a
//! render pipeline (`shaders/splat.wgsl`) that splats the host's set-ups into a G-buffer or
//! a shadow map, and a compute pass (`shaders/splat_shade.wgsl`) that shades a
//! [`SplatFrame`] with per-object colours, soft shadows and outlines.
//!
//! ## Splatting
//! The set-ups ([`crate::splat::setups`], f64 on the host as for the CPU twin) go to a
//! storage buffer; one instance per set-up draws two triangles over its screen box, so one
//! fragment runs per pixel centre in the box (the pixels of [`crate::splat::pixel_range`];
//! the rasterizer's top-left rule differs from the box's closed bounds only for a centre
//! exactly on the box, which the box's padding keeps off every covered pixel). The fragment
//! shader is [`crate::splat::fragment`] and [`crate::quadric::intersect`] function by
//! function; misses are discarded; `frag_depth` is the hit's `t` divided by a far value
//! above every visible `t` (1.5 × the largest distance from the eye to a corner of the
//! scene's bounds), so the depth lies in [0, 1] and orders one pixel's fragments as `t`
//! does; the depth test `Less` over instances drawn in scene order keeps the nearest hit and
//! gives ties to the lower index, as on the CPU.
//!
//! **Render targets** (32 bytes per pixel, within WebGPU's default
//! `max_color_attachment_bytes_per_sample`, so no limit beyond the defaults is needed):
//! `Rgba32Float` `(N.xyz, Z)` and `Rgba32Uint` `(K1, K2, θ, object | id << 24)` with the
//! floats as their bits, θ the angle of `dir1` in the tangent basis of `N` (the basis of
//! the curvature, Duff et al.), or [`NO_DIR1`]; depth `Depth32Float`, cleared to 1. The
//! position is `o + Z d` on the host with the CPU's ray ([`crate::kernel::pixel_ray`]), as
//! [`crate::splat::resolve`] computes it. The principal curvatures come from
//! `common/curvature.wgsl`'s `curvature`, shared with `raycast.wgsl` (f32; the CPU's is f64
//! and rounds once); it reads `inside_sign`, which the splat's own copy of the uniforms sets to
//! +1 (the CPU's `curvature`, inside below).
//!
//! Set-ups that exceed the device's largest storage binding are drawn in chunks; the depth
//! and colour targets persist across chunks (`LoadOp::Load`), so chunks change no pixel
//! ([`GpuRenderer::splat_in_chunks`]). The G-buffer is read back in bands of rows (copies
//! with rows padded to 256 bytes).
//!
//! **Shadow map** ([`GpuRenderer::shadow_map`]): the same pipeline from the spot light's
//! camera ([`ShadowMap::prepare`]) with a second fragment entry writing the depth along the
//! light's axis to an `R32Float` target cleared to +∞; the shading pass reads it from a
//! storage buffer on the GPU (rows padded to 256 bytes).
//!
//! ## Shading
//! One invocation per pixel runs `common/shade_functions.wgsl`'s `shade_pixel` (shared with
//! `shade.wgsl`, with the object's colour in place of the uniform colour), [`crate::splat::shadow_factor`] with the
//! same jittered samples ([`crate::splat::hash_u32`]: WGSL's u32 arithmetic wraps), and
//! [`crate::splat::outline_weight`]. The four corner fetches of the outline filter are real
//! bilinear fetches (a clamp-to-edge linear sampler at the pixel corners) of an
//! `Rgba32Float` texture `(N.xyz, Z)` where the device has `FLOAT32_FILTERABLE`
//! ([`GpuRenderer::open`] asks for it where the adapter offers it; lavapipe does): a bilinear
//! fetch at a texel corner has weights ½, so it is the 2x2 mean up to rounding. On devices
//! without it (GL, or a [`Gpu`] opened without the feature) the four
//! means are computed from 2x2 loads of a storage buffer, exactly as
//! [`crate::splat::corner_fetches`] does. A 16-bit float texture (always filterable) was
//! not taken: `Z` in f16 rounds by up to 2.4e-4 relative, an eighth of the silhouette
//! ramp's start (2e-3), which would move outline weights by several per cent.
//!
//! ## What differs from the CPU twin
//! f32 on both sides in the same order, but the GPU may fuse multiply-adds, and its `sqrt`,
//! division, `atan2`, `sin`, `cos` round differently; the curvature is f32 (f64 on the CPU).
//! Measured on lavapipe (Vulkan) over the scenes of `tests/gpu_splat.rs`: the same hit
//! masks, objects and ids; depths, positions, normals and shadow maps bit for bit; principal
//! curvatures within 7.5e-7 relative, `dir1` within 3.4e-6 rad; shaded images (shadows and
//! outlines on) within 3.6e-5 per channel (bilinear fetches) or 6.9e-7 (2x2 loads).
//! [`SplatStats::hits`] counts fragments that hit with an atomic add in the fragment shader;
//! on adapters that cannot write storage from fragment shaders it stays 0. The vertex
//! shader reads the set-ups from a storage buffer, which GL adapters without vertex-stage
//! storage cannot do: pipeline creation then fails with [`RenderError::Gpu`].

use crate::gpu::{GpuRenderer, check_fits, constants, dispatch_grid, scoped};
use crate::kernel::{self, GSample, Uniforms};
use crate::quadric::{QuadricSetup, View};
use crate::raycast::gpu::GpuPixel;
use crate::shade::gpu::{GpuLight, ShadeParams, mode_code};
use crate::splat::{
    NO_OBJECT, ShadeStats, ShadowMap, ShadowOptions, ShadowParams, SplatFrame, SplatOptions,
    SplatScene, SplatShading, SplatStats, camera_uniforms, default_spot, miss_depth, pixel_range,
    setups, view_for,
};
use crate::{GBuffer, Image, RenderError, ShadingMode};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use isokit_field::Camera;
use isokit_gpu::{Gpu, GpuError, ShaderSource, wgpu};
use isokit_shaders::common::{CURVATURE, SHADE_FUNCTIONS, SHADE_STRUCTS};
use isokit_shaders::{RAYCAST_COMMON, SPLAT, SPLAT_SHADE};
use rayon::prelude::*;
use std::time::Instant;

/// The θ word of a G-buffer pixel without a principal direction (caps, near cuts, flat or
/// failed curvature): a NaN pattern no `atan2` returns.
pub const NO_DIR1: u32 = u32::MAX;

/// Bytes of one [`QuadricSetup`] on the GPU.
pub const SETUP_BYTES: usize = size_of::<QuadricSetup>();

/// Bits of the object index in the G-buffer's packed word (`object | id << 24`);
/// [`crate::splat::MAX_QUADRICS`] keeps every index below `1 << 24`.
const OBJECT_BITS: u32 = 24;
const _: () = assert!(crate::splat::MAX_QUADRICS <= 1 << OBJECT_BITS);

/// The splatter's WGSL, assembled: constants from Rust, `raycast_common.wgsl`,
/// `common/curvature.wgsl`, the hit counter (`count_hits`: an atomic add on binding 3; else
/// nothing), `splat.wgsl` (entry points `vs_splat`, `fs_gbuffer`, `fs_shadow`).
pub fn splat_shader(count_hits: bool) -> ShaderSource {
    let counter = if count_hits {
        "@group(0) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;\n\
         fn count_hit() { atomicAdd(&counters[0], 1u); }\n"
    } else {
        "fn count_hit() {}\n"
    };
    constants("splat")
        .constant_u32("NO_DIR1", NO_DIR1)
        .piece(RAYCAST_COMMON)
        .piece(CURVATURE)
        .piece(counter)
        .piece(SPLAT)
}

/// The splat shading kernel's WGSL, assembled: constants from Rust (with `MODE_*`),
/// `raycast_common.wgsl`, `common/shade_structs.wgsl`, `common/shade_functions.wgsl`,
/// `splat_shade.wgsl` (entry points `shade_splat_filtered`, `shade_splat_loads`).
pub fn splat_shade_shader() -> ShaderSource {
    let mut src = constants("splat_shade");
    for (name, mode) in ShadingMode::ALL {
        src = src.constant_u32(
            &format!("MODE_{}", name.to_ascii_uppercase()),
            mode_code(mode),
        );
    }
    src.piece(RAYCAST_COMMON)
        .piece(SHADE_STRUCTS)
        .piece(SHADE_FUNCTIONS)
        .piece(SPLAT_SHADE)
}

/// `SplatParams` in `splat.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct SplatParams {
    near: f32,
    far: f32,
    inf: f32,
    pad: f32,
}

isokit_gpu::wgsl_layout!(SplatParams {
    near: "f32",
    far: "f32",
    inf: "f32",
    pad: "f32",
});

/// `SplatShadeParams` in `splat_shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct SplatShadeParams {
    shade: ShadeParams,
    shadow: ShadowParams,
    outline_color: [f32; 3],
    outlines: u32,
    depth_ramp: [f32; 2],
    crease_ramp: [f32; 2],
    shadows: u32,
    colors: u32,
    shadow_stride: u32,
    pad: u32,
}

isokit_gpu::wgsl_layout!(SplatShadeParams {
    shade: "ShadeParams",
    shadow: "ShadowParams",
    outline_color: "vec3<f32>",
    outlines: "u32",
    depth_ramp: "vec2<f32>",
    crease_ramp: "vec2<f32>",
    shadows: "u32",
    colors: "u32",
    shadow_stride: "u32",
    pad: "u32",
});

/// The splatter's pipelines, compiled on first use.
#[derive(Debug)]
pub(crate) struct SplatPipelines {
    gbuffer: wgpu::RenderPipeline,
    shadow: wgpu::RenderPipeline,
    counts_hits: bool,
    shade_loads: wgpu::ComputePipeline,
    shade_filtered: Option<wgpu::ComputePipeline>,
    sampler: wgpu::Sampler,
}

const GBUFFER_FORMATS: [wgpu::TextureFormat; 2] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba32Uint,
];
const SHADOW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Runs `f` (creating a shader module or pipeline) under a validation error scope; an
/// error is a shader error named `label`.
fn shader_checked<T>(gpu: &Gpu, label: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
    let scope = gpu.device().push_error_scope(wgpu::ErrorFilter::Validation);
    let out = f();
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(GpuError::Shader {
            label: label.to_string(),
            message: e.to_string(),
        }),
        None => Ok(out),
    }
}

fn module(gpu: &Gpu, src: &ShaderSource) -> Result<wgpu::ShaderModule, GpuError> {
    shader_checked(gpu, src.label(), || {
        gpu.device()
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(src.label()),
                source: wgpu::ShaderSource::Wgsl(src.text().into()),
            })
    })
}

fn render_pipeline(
    gpu: &Gpu,
    module: &wgpu::ShaderModule,
    label: &str,
    fragment: &str,
    formats: &[wgpu::TextureFormat],
) -> Result<wgpu::RenderPipeline, GpuError> {
    let targets: Vec<Option<wgpu::ColorTargetState>> =
        formats.iter().map(|&f| Some(f.into())).collect();
    shader_checked(gpu, label, || {
        gpu.device()
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: None,
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_splat"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some(fragment),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
    })
}

impl SplatPipelines {
    fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        // Refused in one line before any pipeline is made where the adapter cannot render
        // to the targets (GL adapters and Rgba32Float).
        gpu.check_render_formats(&GBUFFER_FORMATS, "the splatter's G-buffer")?;
        gpu.check_render_formats(&[SHADOW_FORMAT], "the splatter's shadow map")?;
        // The G-buffer pipeline counts hits with an atomic add in the fragment shader where
        // the adapter allows storage writes there; else the same shader without the count.
        let counting = module(gpu, &splat_shader(true)).and_then(|m| {
            render_pipeline(gpu, &m, "splat g-buffer", "fs_gbuffer", &GBUFFER_FORMATS)
        });
        let plain = module(gpu, &splat_shader(false))?;
        let (gbuffer, counts_hits) = match counting {
            Ok(p) => (p, true),
            Err(_) => (
                render_pipeline(
                    gpu,
                    &plain,
                    "splat g-buffer",
                    "fs_gbuffer",
                    &GBUFFER_FORMATS,
                )?,
                false,
            ),
        };
        let shadow = render_pipeline(
            gpu,
            &plain,
            "splat shadow map",
            "fs_shadow",
            &[SHADOW_FORMAT],
        )?;
        let s = splat_shade_shader();
        let shade_loads = gpu.compute_pipeline(s.label(), s.text(), "shade_splat_loads")?;
        let filterable = gpu
            .device()
            .features()
            .contains(wgpu::Features::FLOAT32_FILTERABLE);
        let shade_filtered = if filterable {
            Some(gpu.compute_pipeline(s.label(), s.text(), "shade_splat_filtered")?)
        } else {
            None
        };
        let sampler = gpu.device().create_sampler(&wgpu::SamplerDescriptor {
            label: Some("splat outline sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Ok(Self {
            gbuffer,
            shadow,
            counts_hits,
            shade_loads,
            shade_filtered,
            sampler,
        })
    }
}

/// Refuses an image the device's textures cannot hold.
fn check_texture(gpu: &Gpu, what: &str, width: u32, height: u32) -> Result<(), GpuError> {
    let max = gpu.limits().max_texture_dimension_2d;
    if width > max || height > max {
        return Err(GpuError::TooLarge(format!(
            "{what} of {width}x{height} pixels exceeds the device's largest texture ({max}x{max})"
        )));
    }
    Ok(())
}

fn target(
    gpu: &Gpu,
    label: &str,
    format: wgpu::TextureFormat,
    width: u32,
    height: u32,
) -> wgpu::Texture {
    gpu.device().create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// The far value that divides `t` into `frag_depth`: 1.5 × the largest distance from the
/// eye to a corner of the scene's bounds (every visible `t` is at most that distance, for
/// orthographic views too: `t` is then the depth along `forward`), kept finite.
fn far_depth(scene: &SplatScene, view: &View) -> f32 {
    let Some((lo, hi)) = scene.bounds() else {
        return 1.0;
    };
    let mut far = 0.0f64;
    for k in 0..8 {
        let c = glam::DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        far = far.max((c - view.eye).length());
    }
    (1.5 * far).clamp(f64::from(f32::MIN_POSITIVE), f64::from(f32::MAX)) as f32
}

/// One splat: the pipeline, its colour targets with their clear values, the depth target.
struct Pass<'a> {
    label: &'a str,
    pipeline: &'a wgpu::RenderPipeline,
    colors: &'a [(&'a wgpu::Texture, wgpu::Color)],
    depth: &'a wgpu::Texture,
    counters: Option<&'a wgpu::Buffer>,
}

/// Draws the set-ups `set` for uniforms `u` into the targets of `pass`, at most
/// `per_draw` set-ups per draw (and per storage binding); the targets are cleared first.
fn draw(
    gpu: &Gpu,
    pass: &Pass,
    set: &[QuadricSetup],
    u: &Uniforms,
    params: SplatParams,
    per_draw: usize,
) -> Result<(), RenderError> {
    let by_limit = (gpu.max_storage_bytes() / SETUP_BYTES as u64) as usize;
    if by_limit == 0 {
        return Err(GpuError::TooLarge(format!(
            "a quadric set-up of {SETUP_BYTES} bytes exceeds the device's largest storage buffer"
        ))
        .into());
    }
    let chunk = per_draw.min(by_limit).min(set.len()).max(1);
    check_fits(gpu, "the quadric set-ups", (chunk * SETUP_BYTES) as u64)?;
    // The curvature reads inside_sign: +1, the CPU's `curvature` (inside below).
    let gu = Uniforms {
        inside_sign: 1.0,
        ..*u
    };
    let storage = wgpu::BufferUsages::STORAGE;
    let (_ubuf, _pbuf, setup_buf, bind) = scoped(gpu, "allocating the splat buffers", || {
        let ubuf = gpu.upload("splat uniforms", &[gu], wgpu::BufferUsages::UNIFORM);
        let pbuf = gpu.upload("splat params", &[params], wgpu::BufferUsages::UNIFORM);
        let setup_buf = gpu.buffer("splat set-ups", (chunk * SETUP_BYTES) as u64, storage);
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: ubuf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: pbuf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: setup_buf.as_entire_binding(),
            },
        ];
        if let Some(c) = pass.counters {
            entries.push(wgpu::BindGroupEntry {
                binding: 3,
                resource: c.as_entire_binding(),
            });
        }
        let bind = gpu.device().create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(pass.label),
            layout: &pass.pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        (ubuf, pbuf, setup_buf, bind)
    })?;
    let views: Vec<wgpu::TextureView> = pass
        .colors
        .iter()
        .map(|(t, _)| t.create_view(&Default::default()))
        .collect();
    let depth_view = pass.depth.create_view(&Default::default());
    let mut first = true;
    let mut start = 0;
    while first || start < set.len() {
        let len = chunk.min(set.len() - start);
        gpu.write(
            &setup_buf,
            0,
            bytemuck::cast_slice(&set[start..start + len]),
        );
        scoped(gpu, pass.label, || {
            let mut enc = gpu
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some(pass.label),
                });
            {
                let attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = views
                    .iter()
                    .zip(pass.colors)
                    .map(|(v, (_, clear))| {
                        Some(wgpu::RenderPassColorAttachment {
                            view: v,
                            depth_slice: None,
                            resolve_target: None,
                            ops: wgpu::Operations {
                                load: if first {
                                    wgpu::LoadOp::Clear(*clear)
                                } else {
                                    wgpu::LoadOp::Load
                                },
                                store: wgpu::StoreOp::Store,
                            },
                        })
                    })
                    .collect();
                let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(pass.label),
                    color_attachments: &attachments,
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &depth_view,
                        depth_ops: Some(wgpu::Operations {
                            load: if first {
                                wgpu::LoadOp::Clear(1.0)
                            } else {
                                wgpu::LoadOp::Load
                            },
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                if len > 0 {
                    rp.set_pipeline(pass.pipeline);
                    rp.set_bind_group(0, &bind, &[]);
                    rp.draw(0..6, 0..len as u32);
                }
            }
            gpu.queue().submit([enc.finish()]);
        })?;
        first = false;
        start += len;
    }
    Ok(())
}

/// Reads a `width × height` texture with `texel` bytes per pixel back to the host, in bands
/// of rows (each copy's rows padded to 256 bytes), as `T` (4-byte aligned, e.g. `[f32; 4]`).
fn read_texture<T: Pod>(
    gpu: &Gpu,
    texture: &wgpu::Texture,
    width: u32,
    height: u32,
    texel: u32,
) -> Result<Vec<T>, RenderError> {
    let row = u64::from(width) * u64::from(texel);
    let padded = row.next_multiple_of(u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT));
    let cap = gpu.limits().max_buffer_size.min(1 << 28);
    let band = (cap / padded).clamp(1, u64::from(height)) as u32;
    if padded > gpu.limits().max_buffer_size {
        return Err(GpuError::TooLarge(format!(
            "a row of {padded} bytes exceeds the device's largest buffer"
        ))
        .into());
    }
    let buf = scoped(gpu, "allocating the read-back buffer", || {
        gpu.buffer(
            "splat read-back",
            padded * u64::from(band),
            wgpu::BufferUsages::empty(),
        )
    })?;
    let words_per_row = (padded / 4) as usize;
    let row_words = (row / 4) as usize;
    let mut out: Vec<T> = Vec::with_capacity(width as usize * height as usize);
    let mut y0 = 0;
    while y0 < height {
        let rows = band.min(height - y0);
        copy_rows(
            gpu,
            "reading the splat targets",
            texture,
            &buf,
            y0,
            width,
            rows,
            padded,
        )?;
        let words: Vec<u32> = gpu.read_buffer(&buf, 0, words_per_row * rows as usize)?;
        for r in words.chunks(words_per_row) {
            out.extend_from_slice(bytemuck::cast_slice(&r[..row_words]));
        }
        y0 += rows;
    }
    Ok(out)
}

/// Copies rows `y0 .. y0 + rows` (each `width` texels) of `texture` into `buffer`, rows
/// `padded` bytes apart (a multiple of 256).
#[allow(clippy::too_many_arguments)]
fn copy_rows(
    gpu: &Gpu,
    what: &str,
    texture: &wgpu::Texture,
    buffer: &wgpu::Buffer,
    y0: u32,
    width: u32,
    rows: u32,
    padded: u64,
) -> Result<(), GpuError> {
    scoped(gpu, what, || {
        let mut enc = gpu
            .device()
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(what) });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: y0, z: 0 },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d {
                width,
                height: rows,
                depth_or_array_layers: 1,
            },
        );
        gpu.queue().submit([enc.finish()]);
    })
}

/// An `Rgba32Float` texture holding `data` (`width × height`, row-major), as a view.
fn upload_rgba32f(
    gpu: &Gpu,
    label: &str,
    data: &[[f32; 4]],
    width: u32,
    height: u32,
) -> wgpu::TextureView {
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: 1,
    };
    let tex = gpu.device().create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    gpu.queue().write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytemuck::cast_slice(data),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(16 * width),
            rows_per_image: None,
        },
        size,
    );
    tex.create_view(&Default::default())
}

/// The tangent basis `(u, v)` of a unit normal that `curvature` uses (Duff et al.), in f32
/// as `tangent_u`/`tangent_v` in `splat.wgsl`.
fn tangent_basis(n: Vec3) -> (Vec3, Vec3) {
    let sgn = if n.z.is_sign_negative() { -1.0 } else { 1.0 };
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x),
        Vec3::new(b, sgn + n.y * n.y * a, -n.y),
    )
}

/// The G-buffer sample and object of one pixel from its two target texels.
fn unpack(u: &Uniforms, px: u32, py: u32, nz: [f32; 4], kid: [u32; 4]) -> (GSample, u32) {
    let id = kid[3] >> OBJECT_BITS;
    if id == 0 {
        return (GSample::default(), NO_OBJECT);
    }
    let (o, d) = kernel::pixel_ray(u, px, py);
    let normal = Vec3::new(nz[0], nz[1], nz[2]);
    let dir1 = if kid[2] == NO_DIR1 {
        Vec3::ZERO
    } else {
        let th = f32::from_bits(kid[2]);
        let (tu, tv) = tangent_basis(normal);
        (tu * th.cos() + tv * th.sin()).normalize()
    };
    let s = GSample {
        position: o + nz[3] * d,
        depth: nz[3],
        normal,
        k1: f32::from_bits(kid[0]),
        k2: f32::from_bits(kid[1]),
        dir1,
        id,
    };
    (s, kid[3] & ((1 << OBJECT_BITS) - 1))
}

/// A shadow map rendered on the GPU and left there: the map's parameters (depth empty), the
/// storage buffer of depths and its row stride in f32.
struct GpuShadow {
    map: ShadowMap,
    depth: wgpu::Buffer,
    stride: u32,
}

impl GpuRenderer {
    fn splat_pipelines(&self) -> Result<&SplatPipelines, RenderError> {
        if let Some(p) = self.splat.get() {
            return Ok(p);
        }
        let p = SplatPipelines::new(&self.gpu)?;
        let _ = self.splat.set(p);
        Ok(self
            .splat
            .get()
            .unwrap_or_else(|| unreachable!("set above")))
    }

    /// True when the splat shading takes its outline fetches as real bilinear texture
    /// fetches (the device has `FLOAT32_FILTERABLE`), false when it averages 2x2 loads.
    pub fn splat_fetches_filtered(&self) -> Result<bool, RenderError> {
        Ok(self.splat_pipelines()?.shade_filtered.is_some())
    }

    /// Splats a scene for a camera into a G-buffer on the GPU: the GPU twin of
    /// [`crate::splat::splat`] (see the module docs for how they differ).
    pub fn splat(
        &self,
        scene: &SplatScene,
        camera: &Camera,
        opts: &SplatOptions,
    ) -> Result<SplatFrame, RenderError> {
        self.splat_in_chunks(scene, camera, opts, usize::MAX)
    }

    /// [`GpuRenderer::splat`] drawing at most `quadrics_per_draw` set-ups per draw (at least
    /// 1; the device's largest storage binding bounds it too). The depth and colour targets
    /// persist across draws, so the result is the same for every bound.
    pub fn splat_in_chunks(
        &self,
        scene: &SplatScene,
        camera: &Camera,
        opts: &SplatOptions,
        quadrics_per_draw: usize,
    ) -> Result<SplatFrame, RenderError> {
        scene.check()?;
        let u = camera_uniforms(camera)?;
        let view = view_for(&u, scene, opts)?;
        self.splat_view(scene, &u, view, quadrics_per_draw.max(1))
    }

    fn splat_view(
        &self,
        scene: &SplatScene,
        u: &Uniforms,
        view: View,
        per_draw: usize,
    ) -> Result<SplatFrame, RenderError> {
        let gpu = &self.gpu;
        let p = self.splat_pipelines()?;
        let (w, h) = (u.width, u.height);
        check_texture(gpu, "the image", w, h)?;
        let t0 = Instant::now();
        let set = setups(scene, &view);
        let setup_seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let (nz_tex, kid_tex, depth_tex, counters) =
            scoped(gpu, "allocating the g-buffer", || {
                (
                    target(gpu, "splat (N, Z)", GBUFFER_FORMATS[0], w, h),
                    target(gpu, "splat (K, θ, id)", GBUFFER_FORMATS[1], w, h),
                    target(gpu, "splat depth", DEPTH_FORMAT, w, h),
                    gpu.buffer("splat counters", 4, wgpu::BufferUsages::STORAGE),
                )
            })?;
        let params = SplatParams {
            near: view.near as f32,
            far: far_depth(scene, &view),
            inf: f32::INFINITY,
            pad: 0.0,
        };
        let clear = wgpu::Color::TRANSPARENT;
        draw(
            gpu,
            &Pass {
                label: "splat g-buffer",
                pipeline: &p.gbuffer,
                colors: &[(&nz_tex, clear), (&kid_tex, clear)],
                depth: &depth_tex,
                counters: p.counts_hits.then_some(&counters),
            },
            &set,
            u,
            params,
            per_draw,
        )?;
        let nz: Vec<[f32; 4]> = read_texture(gpu, &nz_tex, w, h, 16)?;
        let kid: Vec<[u32; 4]> = read_texture(gpu, &kid_tex, w, h, 16)?;
        let hits = if p.counts_hits {
            gpu.read_buffer::<u32>(&counters, 0, 1)?[0]
        } else {
            0
        };
        let (pixels, objects): (Vec<GSample>, Vec<u32>) = nz
            .par_iter()
            .zip(kid.par_iter())
            .enumerate()
            .map(|(i, (a, b))| unpack(u, i as u32 % w, i as u32 / w, *a, *b))
            .unzip();
        let fragments = set
            .iter()
            .map(|s| {
                let r = pixel_range(s, w, h);
                u64::from(r[2].saturating_sub(r[0])) * u64::from(r[3].saturating_sub(r[1]))
            })
            .sum();
        let n = pixels.len();
        Ok(SplatFrame {
            gbuffer: GBuffer::new(w, h, pixels, vec![0; n]),
            objects,
            uniforms: *u,
            view,
            stats: SplatStats {
                quadrics: scene.len(),
                drawn: set.len(),
                fragments,
                evaluated: fragments,
                hits: u64::from(hits),
                setup_seconds,
                splat_seconds: t1.elapsed().as_secs_f64(),
            },
        })
    }

    /// Renders the shadow map of a spot light at `light` on the GPU: the GPU twin of
    /// [`ShadowMap::render`] (depths along the light's axis, +∞ where no solid is seen).
    pub fn shadow_map(
        &self,
        scene: &SplatScene,
        light: Vec3,
        opts: &ShadowOptions,
    ) -> Result<ShadowMap, RenderError> {
        let s = self.render_shadow(scene, light, opts)?;
        let res = s.map.params.resolution as usize;
        let stride = s.stride as usize;
        let all: Vec<f32> = self.gpu.read_buffer(&s.depth, 0, stride * res)?;
        let mut map = s.map;
        map.depth = all
            .chunks(stride)
            .flat_map(|r| r[..res].iter().copied())
            .collect();
        Ok(map)
    }

    fn render_shadow(
        &self,
        scene: &SplatScene,
        light: Vec3,
        opts: &ShadowOptions,
    ) -> Result<GpuShadow, RenderError> {
        scene.check()?;
        let gpu = &self.gpu;
        let p = self.splat_pipelines()?;
        let (u, view, map) = ShadowMap::prepare(scene, light, opts)?;
        let res = u.width;
        check_texture(gpu, "the shadow map", res, res)?;
        let set = setups(scene, &view);
        let padded =
            (u64::from(res) * 4).next_multiple_of(u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT));
        check_fits(gpu, "the shadow map", padded * u64::from(res))?;
        let (color, depth_tex, depth) = scoped(gpu, "allocating the shadow map", || {
            (
                target(gpu, "shadow map", SHADOW_FORMAT, res, res),
                target(gpu, "shadow map depth", DEPTH_FORMAT, res, res),
                gpu.buffer(
                    "shadow map depths",
                    padded * u64::from(res),
                    wgpu::BufferUsages::STORAGE,
                ),
            )
        })?;
        let params = SplatParams {
            near: view.near as f32,
            far: far_depth(scene, &view),
            inf: f32::INFINITY,
            pad: 0.0,
        };
        let clear = wgpu::Color {
            r: f64::INFINITY,
            g: 0.0,
            b: 0.0,
            a: 0.0,
        };
        draw(
            gpu,
            &Pass {
                label: "splat shadow map",
                pipeline: &p.shadow,
                colors: &[(&color, clear)],
                depth: &depth_tex,
                counters: None,
            },
            &set,
            &u,
            params,
            usize::MAX,
        )?;
        copy_rows(
            gpu,
            "copying the shadow map",
            &color,
            &depth,
            0,
            res,
            res,
            padded,
        )?;
        Ok(GpuShadow {
            map,
            depth,
            stride: (padded / 4) as u32,
        })
    }

    /// Deferred shading of a splat frame on the GPU: the GPU twin of
    /// [`crate::splat::shade_splat`] (per-object colour, soft shadows from a shadow map
    /// rendered on the GPU, outlines). The frame may come from either twin.
    pub fn shade_splat(
        &self,
        frame: &SplatFrame,
        scene: &SplatScene,
        opts: &SplatShading,
    ) -> Result<(Image, ShadeStats), RenderError> {
        let sh = &opts.shading;
        sh.check()?;
        scene.check()?;
        frame.check()?;
        let u = &frame.uniforms;
        let (w, h) = (u.width, u.height);
        let g = &frame.gbuffer;
        let total = w as usize * h as usize;
        let gpu = &self.gpu;
        let p = self.splat_pipelines()?;
        let mut stats = ShadeStats::default();
        let t0 = Instant::now();
        let shadow = match &opts.shadows {
            Some(so) if !scene.is_empty() => {
                let pos = so.light.unwrap_or_else(|| default_spot(u, scene));
                let s = self.render_shadow(scene, pos, so)?;
                gpu.wait()?;
                Some(s)
            }
            _ => None,
        };
        stats.shadow_map_seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let lights: Vec<GpuLight> = match &shadow {
            Some(s) => vec![GpuLight::new(&s.map.light)],
            None => sh.lights_or_default(u).iter().map(GpuLight::new).collect(),
        };
        // At least one entry: a binding of `array<vec4<f32>>` cannot be smaller than 16 bytes
        // (the count passed to the kernel stays the scene's).
        let mut colors: Vec<[f32; 4]> = scene
            .colors
            .iter()
            .map(|c| c.extend(0.0).to_array())
            .collect();
        let n_colors = colors.len() as u32;
        if colors.is_empty() {
            colors.push([0.0; 4]);
        }
        check_fits(
            gpu,
            "the lights",
            std::mem::size_of_val(lights.as_slice()) as u64,
        )?;
        check_fits(
            gpu,
            "the object colours",
            std::mem::size_of_val(colors.as_slice()) as u64,
        )?;
        // The outline images (N.xyz, Z), misses at the far depth with zero normals.
        let filtered = p.shade_filtered.is_some();
        let outline: Vec<[f32; 4]> = if opts.outlines.is_some() {
            let far = miss_depth(g);
            g.pixels()
                .par_iter()
                .map(|s| {
                    if s.is_hit() {
                        [s.normal.x, s.normal.y, s.normal.z, s.depth]
                    } else {
                        [0.0, 0.0, 0.0, far]
                    }
                })
                .collect()
        } else {
            vec![[0.0; 4]]
        };
        let (ow, oh) = if opts.outlines.is_some() {
            (w, h)
        } else {
            (1, 1)
        };
        if filtered {
            check_texture(gpu, "the outline image", ow, oh)?;
        } else {
            check_fits(
                gpu,
                "the outline image",
                std::mem::size_of_val(outline.as_slice()) as u64,
            )?;
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let chunk = ((gpu.max_storage_bytes() / size_of::<GpuPixel>() as u64) as usize)
            .min(self.max_rays_per_dispatch())
            .min(total)
            .max(1);
        let shadow_buf;
        let (shadow_map, shadow_stride) = match &shadow {
            Some(s) => (&s.depth, s.stride),
            None => {
                shadow_buf = gpu.buffer("no shadow map", 4, storage);
                (&shadow_buf, 0)
            }
        };
        let pipeline = p.shade_filtered.as_ref().unwrap_or(&p.shade_loads);
        let (_ubuf, pbuf, gbuf, _lbuf, image, objects, _cbuf, samples, _outline, bind) =
            scoped(gpu, "allocating the splat shading buffers", || {
                let ubuf = gpu.upload("splat shade uniforms", &[*u], wgpu::BufferUsages::UNIFORM);
                let pbuf = gpu.buffer(
                    "splat shade params",
                    size_of::<SplatShadeParams>() as u64,
                    wgpu::BufferUsages::UNIFORM,
                );
                let gbuf = gpu.buffer(
                    "splat shade g-buffer",
                    (chunk * size_of::<GpuPixel>()) as u64,
                    storage,
                );
                let lbuf = gpu.upload("splat shade lights", &lights, storage);
                let image = gpu.buffer("splat shade image", 16 * chunk as u64, storage);
                let objects = gpu.buffer("splat shade objects", 4 * chunk as u64, storage);
                let cbuf = gpu.upload("splat shade colours", &colors, storage);
                let samples = gpu.buffer("splat shade samples", 4 * chunk as u64, storage);
                let mut entries: Vec<wgpu::BindGroupEntry> = [
                    &ubuf, &pbuf, &gbuf, &lbuf, &image, &objects, &cbuf, shadow_map, &samples,
                ]
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: b.as_entire_binding(),
                })
                .collect();
                let outline_res = if filtered {
                    Outline::Texture(upload_rgba32f(gpu, "splat outline image", &outline, ow, oh))
                } else {
                    Outline::Buffer(gpu.upload("splat outline image", &outline, storage))
                };
                match &outline_res {
                    Outline::Texture(view) => {
                        entries.push(wgpu::BindGroupEntry {
                            binding: 9,
                            resource: wgpu::BindingResource::TextureView(view),
                        });
                        entries.push(wgpu::BindGroupEntry {
                            binding: 10,
                            resource: wgpu::BindingResource::Sampler(&p.sampler),
                        });
                    }
                    Outline::Buffer(b) => entries.push(wgpu::BindGroupEntry {
                        binding: 11,
                        resource: b.as_entire_binding(),
                    }),
                }
                let bind = gpu.device().create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("splat shade"),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &entries,
                });
                (
                    ubuf,
                    pbuf,
                    gbuf,
                    lbuf,
                    image,
                    objects,
                    cbuf,
                    samples,
                    outline_res,
                    bind,
                )
            })?;
        let outline_opts = opts.outlines.unwrap_or_default();
        let mut pixels = Vec::with_capacity(total);
        for base in (0..total).step_by(chunk) {
            let len = chunk.min(total - base);
            let up: Vec<GpuPixel> = g.pixels()[base..base + len]
                .iter()
                .map(GpuPixel::from_sample)
                .collect();
            gpu.write(&gbuf, 0, bytemuck::cast_slice(&up));
            gpu.write(
                &objects,
                0,
                bytemuck::cast_slice(&frame.objects[base..base + len]),
            );
            let (groups, stride) = dispatch_grid(gpu, len);
            let params = SplatShadeParams {
                shade: ShadeParams::new(sh, lights.len(), u, base, len, stride),
                shadow: shadow.as_ref().map(|s| s.map.params).unwrap_or_default(),
                outline_color: outline_opts.color.to_array(),
                outlines: u32::from(opts.outlines.is_some()),
                depth_ramp: outline_opts.depth,
                crease_ramp: outline_opts.crease,
                shadows: u32::from(shadow.is_some()),
                colors: n_colors,
                shadow_stride,
                pad: 0,
            };
            gpu.write(&pbuf, 0, bytemuck::bytes_of(&params));
            gpu.dispatch("splat shade", pipeline, &bind, groups)?;
            let out: Vec<[f32; 4]> = gpu.read_buffer(&image, 0, len)?;
            let taken: Vec<u32> = gpu.read_buffer(&samples, 0, len)?;
            pixels.extend(out);
            for k in taken {
                stats.count_pixel(k);
            }
        }
        stats.shade_seconds = t1.elapsed().as_secs_f64();
        Ok((
            Image {
                width: w,
                height: h,
                pixels,
            },
            stats,
        ))
    }
}

/// The outline images on the GPU: a filterable texture or a storage buffer.
enum Outline {
    Texture(wgpu::TextureView),
    Buffer(wgpu::Buffer),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setups_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<QuadricSetup>();
    }

    #[test]
    fn splat_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<SplatParams>();
    }

    #[test]
    fn shadow_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<ShadowParams>();
    }

    #[test]
    fn splat_shade_params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<SplatShadeParams>();
    }

    #[test]
    fn splat_shaders_validate_with_naga() {
        splat_shader(true).validate().unwrap();
        splat_shader(false).validate().unwrap();
        splat_shade_shader().validate().unwrap();
    }

    #[test]
    fn reused_sections_are_found() {
        // The pieces shared with the ray caster's kernels are files of their own, joined by
        // the loader (no text is cut out of another kernel).
        assert!(CURVATURE.contains("fn curvature("));
        assert!(CURVATURE.contains("fn hypot("));
        assert!(SHADE_STRUCTS.contains("struct ShadeParams"));
        assert!(SHADE_STRUCTS.contains("struct Light"));
        assert!(!SHADE_STRUCTS.contains("@group"));
        assert!(SHADE_FUNCTIONS.contains("fn shade_pixel("));
        assert!(!SHADE_FUNCTIONS.contains("@group"));
        // Each kernel gets each piece once.
        for (src, piece) in [
            (splat_shader(true), CURVATURE),
            (splat_shader(false), CURVATURE),
            (splat_shade_shader(), SHADE_STRUCTS),
            (splat_shade_shader(), SHADE_FUNCTIONS),
        ] {
            assert_eq!(src.text().matches(piece).count(), 1);
        }
    }

    #[test]
    fn splat_structs_match_their_rust_twins() {
        let s = splat_shader(true);
        let size = |src: &ShaderSource, name| isokit_gpu::wgsl_struct_size(src.text(), name);
        assert_eq!(size(&s, "QuadricSetup"), Some(SETUP_BYTES as u32));
        assert_eq!(SETUP_BYTES, 144);
        assert_eq!(
            size(&s, "SplatParams"),
            Some(size_of::<SplatParams>() as u32)
        );
        assert_eq!(size(&s, "Uniforms"), Some(size_of::<Uniforms>() as u32));
        let t = splat_shade_shader();
        assert_eq!(
            size(&t, "ShadeParams"),
            Some(size_of::<ShadeParams>() as u32)
        );
        assert_eq!(
            size(&t, "ShadowParams"),
            Some(size_of::<ShadowParams>() as u32)
        );
        assert_eq!(
            size(&t, "SplatShadeParams"),
            Some(size_of::<SplatShadeParams>() as u32)
        );
        assert_eq!(size_of::<SplatShadeParams>(), 192);
        assert_eq!(size(&t, "Light"), Some(size_of::<GpuLight>() as u32));
        assert_eq!(size(&t, "GPixel"), Some(size_of::<GpuPixel>() as u32));
    }

    #[test]
    fn tangent_basis_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.6, 0.0, -0.8),
            Vec3::new(0.0, 0.8, 0.6),
        ] {
            let (u, v) = tangent_basis(n);
            assert!((u.length() - 1.0).abs() < 1e-6 && (v.length() - 1.0).abs() < 1e-6);
            assert!(u.cross(v).distance(n) < 1e-6, "{n}");
        }
    }
}
