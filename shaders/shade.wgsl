// Deferred shading (002 Sec. 6.4): every pixel's colour from its G-buffer sample alone.
// One invocation per output pixel; for a multi-view G-buffer (3 subpixels per pixel) each
// channel comes from its own subpixel's sample, seen from that subpixel's view.
// Prepended by Rust (isokit_render::gpu): const WORKGROUP, ID_*, F32_MAX, MODE_* (the
// shading modes in the order of ShadingMode::ALL), FLOW_CONTRAST; then raycast_common.wgsl, common/shade_structs.wgsl (ShadeParams, Light)
// and common/shade_functions.wgsl (light_at … shade_pixel, which read `S` and `lights`).
// The `flow` mode's LIC image comes from the flow pass (flow.wgsl) in `flow`, one value per
// output pixel of the whole image (a 4-byte placeholder in the other modes).
// CPU twin: crates/isokit-render/src/shade/cpu.rs (shade: color_of and flow_modulate here,
// shade_pixel in the shared piece).

@group(0) @binding(0) var<uniform> U: Uniforms;
@group(0) @binding(1) var<uniform> S: ShadeParams;
@group(0) @binding(2) var<storage, read> gbuf: array<GPixel>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read_write> image: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> flow: array<f32>;

fn color_of(s: GPixel, px: u32, py: u32, sub: u32) -> vec4<f32> {
    let v = subpixel_ray(px, py, sub).d;
    var footprint = S.pixel_angle;
    if (U.ortho == 0u) {
        footprint = S.pixel_angle * s.depth;
    }
    return shade_pixel(s, v, footprint);
}

// shade/cpu.rs: flow_modulate. c where lic < 0 (no flow).
fn flow_modulate(c: vec4<f32>, lic: f32) -> vec4<f32> {
    if (lic < 0.0) {
        return c;
    }
    let m = 0.5 + clamp(0.5 + FLOW_CONTRAST * (lic - 0.5), 0.0, 1.0);
    return vec4<f32>(c.x * m, c.y * m, c.z * m, c.w);
}

@compute @workgroup_size(WORKGROUP)
fn shade(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * S.stride;
    if (k >= S.count) {
        return;
    }
    let i = S.pixel_base + k;
    let px = i % U.width;
    let py = i / U.width;
    if (U.subpixels <= 1u) {
        var c = color_of(gbuf[k], px, py, 0u);
        if (S.mode == MODE_FLOW) {
            c = flow_modulate(c, flow[i]);
        }
        image[k] = c;
        return;
    }
    var out = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    var any_hit = false;
    for (var c = 0u; c < 3u; c++) {
        let s = gbuf[3u * k + c];
        out[c] = color_of(s, px, py, c)[c];
        any_hit = any_hit || s.id != ID_MISS;
    }
    if (!any_hit) {
        out.w = S.background.w;
    }
    image[k] = out;
}
