// Isosurface ray caster: what the trace and shade kernels share. The uniforms, the G-buffer
// pixel, the rays of pixels and subpixels (multi-view), and float helpers.
// Prepended by Rust (isokit_render::gpu): the constants ID_*, FILTER_*, FLAG_*, COMBINE_*,
// F32_MAX.
// Each kernel declares `U` (var<uniform> Uniforms) at group 0, binding 0.
// CPU twin: crates/isokit-render/src/raycast/cpu.rs (Uniforms, subpixel_ray, view_index),
// written to be read side by side with this file.

// Rust: isokit_render::Uniforms (#[repr(C)], 208 bytes, 13 rows of 16).
struct Uniforms {
    eye: vec3<f32>,
    ortho: u32,
    right: vec3<f32>,
    half_height: f32,
    up: vec3<f32>,
    aspect: f32,
    forward: vec3<f32>,
    width: u32,
    origin: vec3<f32>,
    spacing: f32,
    dims: vec3<u32>,
    block: u32,
    block_dims: vec3<u32>,
    brick: u32,
    brick_dims: vec3<u32>,
    brick_side: u32,
    iso: f32,
    inside_sign: f32,
    r0: f32,
    fine: u32,
    delta: f32,
    refine_steps: u32,
    flags: u32, // FLAG_SKIP_EMPTY | FLAG_CAPS | FLAG_SECANT
    search_filter: u32, // Rust: filter (a reserved word in WGSL)
    shading_filter: u32,
    combine: u32, // COMBINE_*: how channel B combines with A
    morph_t: f32,
    height: u32,
    views: u32,
    view: i32,
    subpixels: u32,
    view_separation: f32,
    window_distance: f32,
    lens_pitch: f32,
    lens_slant: f32,
    lens_offset: f32,
}

// One G-buffer pixel, the four rgba32f rows of the GPU layout (Rust: raycast/gpu.rs GpuPixel, 64 bytes):
// (P.xyz, Z), (N.xyz, A), (K1, K2, id, samples), (dir1.xyz, 0). A miss is all zeros.
struct GPixel {
    position: vec3<f32>,
    depth: f32,
    normal: vec3<f32>,
    hit: f32,
    k1: f32,
    k2: f32,
    id: u32,
    samples: u32,
    dir1: vec3<f32>,
    pad: f32,
}

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
}

// glam's normalize: v · (1 / |v|).
fn normalize3(v: vec3<f32>) -> vec3<f32> {
    return v * (1.0 / sqrt(dot(v, v)));
}

// glam's normalize_or_zero.
fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / sqrt(dot(v, v));
    if (is_finite(rcp) && rcp > 0.0) {
        return v * rcp;
    }
    return vec3<f32>(0.0);
}

// f32::is_finite by the exponent bits (immune to a compiler's no-NaN assumptions).
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite3(v: vec3<f32>) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

// f32::signum: ±1 by the sign bit (so −0 gives −1).
fn signum(x: f32) -> f32 {
    return select(1.0, -1.0, (bitcast<u32>(x) & 0x80000000u) != 0u);
}

// The view that subpixel `sub` of pixel (px, py) shows (raycast/cpu.rs: view_index).
fn view_index(px: u32, py: u32, sub: u32) -> u32 {
    if (U.view >= 0) {
        return u32(U.view);
    }
    let x = (f32(3u * px + sub) + 3.0 * f32(py) * U.lens_slant + U.lens_offset) / U.lens_pitch;
    let f = x - floor(x);
    return min(u32(f * f32(U.views)), U.views - 1u);
}

// The ray of subpixel `sub` of pixel (px, py): world origin, unit direction
// (raycast/cpu.rs: subpixel_ray).
fn subpixel_ray(px: u32, py: u32, sub: u32) -> Ray {
    let h = U.half_height;
    let sx = (2.0 * (f32(px) + 0.5) / f32(U.width) - 1.0) * h * U.aspect;
    let sy = (1.0 - 2.0 * (f32(py) + 0.5) / f32(U.height)) * h;
    if (U.ortho != 0u) {
        return Ray(U.eye + sx * U.right + sy * U.up, U.forward);
    }
    if (U.views <= 1u) {
        return Ray(U.eye, normalize3(U.forward + sx * U.right + sy * U.up));
    }
    let v = view_index(px, py, sub);
    let shift = (f32(v) - 0.5 * f32(U.views - 1u)) * U.view_separation;
    let window = U.window_distance * (U.forward + sx * U.right + sy * U.up);
    return Ray(U.eye + shift * U.right, normalize3(window - shift * U.right));
}
