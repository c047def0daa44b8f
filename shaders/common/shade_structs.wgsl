// What deferred shading reads besides the G-buffer: its parameters and the lights, as the
// host uploads them. Shared by shade.wgsl and splat_shade.wgsl (which embeds ShadeParams in
// SplatShadeParams); each declares the variables `S` and `lights` itself.

// Rust: isokit-render shade/gpu.rs ShadeParams (80 bytes).
struct ShadeParams {
    color: vec3<f32>,
    mode: u32,
    background: vec4<f32>,
    ambient: f32,
    specular: f32,
    shininess: f32,
    curvature_scale: f32,
    contour_pixels: f32,
    lights: u32,       // number of lights (at least 1)
    pixel_angle: f32,  // 2 · half_height / height
    pixel_base: u32,   // first output pixel of this dispatch
    count: u32,        // output pixels in this dispatch
    stride: u32,       // invocations per row of the dispatch grid
    pad0: u32,
    pad1: u32,
}

// Rust: isokit-render shade/gpu.rs GpuLight (32 bytes). Directional lights arrive with their direction
// toward the light already computed (light_at's −normalize_or_zero(d)).
struct Light {
    dir: vec3<f32>,   // directional: unit direction toward the light; point: position
    point: u32,       // 1: a point light at `dir`; 0: directional; 2: neither (no light)
    color: vec3<f32>, // colour · intensity
    pad: f32,
}
