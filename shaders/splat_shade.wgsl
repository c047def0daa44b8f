// Deferred shading of a splat frame (002 Sec. 7.3): per pixel the ray caster's shading with
// the object's colour, darkened toward the ambient term by the soft shadow (64 jittered
// percentage-closer samples, stopped after 8 when they agree), and blended with the outline
// colour (silhouettes and creases from four corner fetches per pixel).
// One invocation per output pixel. Two entry points that differ only in how the four corner
// fetches are made: `shade_splat_filtered` takes them as real bilinear fetches of an
// rgba32float texture (needs FLOAT32_FILTERABLE), `shade_splat_loads` as the means of 2x2
// loads from a storage buffer (exactly splat/cpu.rs: corner_fetches).
// Prepended by Rust (isokit_render::gpu::splat): const WORKGROUP, ID_*, F32_MAX, MODE_*;
// raycast_common.wgsl; common/shade_structs.wgsl (ShadeParams, Light) and
// common/shade_functions.wgsl (light_at … shade_pixel), which read the globals `S` and
// `lights` declared here.
// CPU twin: crates/isokit-render/src/splat/cpu.rs (shade_splat, shadow_factor, shadow_sample,
// hash_u32, corner_fetches, sobel4, outline_weight), in the same order of operations.

// Rust: isokit_render::splat::ShadowParams (64 bytes).
struct ShadowParams {
    eye: vec3<f32>,
    resolution: u32,
    right: vec3<f32>,
    half_height: f32,
    up: vec3<f32>,
    softness: f32,
    forward: vec3<f32>,
    bias: f32,
}

// Rust: splat/gpu.rs SplatShadeParams (192 bytes).
struct SplatShadeParams {
    shade: ShadeParams,        // mode, terms, background; `color` is the fallback colour
    shadow: ShadowParams,
    outline_color: vec3<f32>,
    outlines: u32,             // 1: blend outlines
    depth_ramp: vec2<f32>,     // OutlineOptions::depth
    crease_ramp: vec2<f32>,    // OutlineOptions::crease
    shadows: u32,              // 1: soft shadows from `shadow_map`
    colors: u32,               // number of object colours
    shadow_stride: u32,        // f32 per row of `shadow_map` (rows padded to 256 bytes)
    pad: u32,
}

@group(0) @binding(0) var<uniform> U: Uniforms;
@group(0) @binding(1) var<uniform> P: SplatShadeParams;
@group(0) @binding(2) var<storage, read> gbuf: array<GPixel>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read_write> image: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> objects: array<u32>;
@group(0) @binding(6) var<storage, read> colors: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> shadow_map: array<f32>;
@group(0) @binding(8) var<storage, read_write> shadow_samples: array<u32>;
// The outline images (N.xyz, Z) of the whole frame: a texture and a clamp-to-edge linear
// sampler (shade_splat_filtered), or a storage buffer (shade_splat_loads).
@group(0) @binding(9) var outline_tex: texture_2d<f32>;
@group(0) @binding(10) var outline_sampler: sampler;
@group(0) @binding(11) var<storage, read> outline_buf: array<vec4<f32>>;

// What common/shade_functions.wgsl reads as `S`: the uniform's ShadeParams with the pixel's
// object colour as `color`.
var<private> S: ShadeParams;

// splat/cpu.rs: hash_u32 (u32 arithmetic wraps, as Rust's wrapping ops).
fn hash_u32(x: u32) -> u32 {
    let s = x * 747796405u + 2891336453u;
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// splat/cpu.rs: shadow_sample.
fn shadow_sample(k: u32, px: u32, py: u32) -> vec2<f32> {
    let ring = 7u - k / 8u;
    let angle = k % 8u;
    let key = k + 64u * ((px & 3u) + 4u * (py & 3u));
    let j1 = f32(hash_u32(key) >> 8u) / 16777216.0;
    let j2 = f32(hash_u32(key ^ 0x9e3779b9u) >> 8u) / 16777216.0;
    let r = sqrt((f32(ring) + j1) / 8.0);
    let th = 6.28318530717958647692 * (f32(angle) + j2) / 8.0;
    return vec2<f32>(r * cos(th), r * sin(th));
}

struct ShadowPoint {
    cx: f32,
    cy: f32,
    limit: f32,
}

// 1 when shadow-map sample k of the pixel sees the light (splat/cpu.rs: the closure `lit`).
fn lit(sp: ShadowPoint, k: u32, px: u32, py: u32) -> u32 {
    let res = f32(P.shadow.resolution);
    let o = shadow_sample(k, px, py);
    let x = sp.cx + o.x * P.shadow.softness;
    let y = sp.cy + o.y * P.shadow.softness;
    if (!(x >= 0.0 && y >= 0.0 && x < res && y < res)) {
        return 1u;
    }
    let i = u32(x) + P.shadow_stride * u32(y);
    return select(0u, 1u, shadow_map[i] >= sp.limit);
}

struct ShadowFactor {
    f: f32,
    samples: u32,
}

// splat/cpu.rs: shadow_factor.
fn shadow_factor(p: vec3<f32>, n: vec3<f32>, px: u32, py: u32) -> ShadowFactor {
    let sp = P.shadow;
    let d = p - sp.eye;
    let depth = dot(d, sp.forward);
    if (!(depth > 0.0)) {
        return ShadowFactor(1.0, 0u);
    }
    let res = f32(sp.resolution);
    // Normal offset: one and a half texels' world size along the normal.
    let texel = 2.0 * sp.half_height * depth / res;
    let q = p + n * (1.5 * texel);
    let dq = q - sp.eye;
    let depth_q = dot(dq, sp.forward);
    if (!(depth_q > 0.0)) {
        return ShadowFactor(1.0, 0u);
    }
    let sx = dot(dq, sp.right) / (depth_q * sp.half_height);
    let sy = dot(dq, sp.up) / (depth_q * sp.half_height);
    let at = ShadowPoint((sx + 1.0) * 0.5 * res, (1.0 - sy) * 0.5 * res, depth_q * (1.0 - sp.bias));
    var count = 0u;
    for (var k = 0u; k < 8u; k++) {
        count += lit(at, k, px, py);
    }
    if (count == 0u || count == 8u) {
        return ShadowFactor(f32(count) / 8.0, 8u);
    }
    for (var k = 8u; k < 64u; k++) {
        count += lit(at, k, px, py);
    }
    return ShadowFactor(f32(count) / 64.0, 64u);
}

// splat/cpu.rs: corner_fetches over the storage buffer: the mean of each 2x2 block at the
// corners (−−, +−, −+, ++), edge pixels repeated.
fn outline_at(x: i32, y: i32) -> vec4<f32> {
    let xx = clamp(x, 0, i32(U.width) - 1);
    let yy = clamp(y, 0, i32(U.height) - 1);
    return outline_buf[u32(xx) + U.width * u32(yy)];
}

fn corner_load(x: i32, y: i32, sx: i32, sy: i32) -> vec4<f32> {
    let a = outline_at(x, y);
    let b = outline_at(x + sx, y);
    let c = outline_at(x, y + sy);
    let d = outline_at(x + sx, y + sy);
    return 0.25 * (a + b + c + d);
}

// The same four corners as real bilinear fetches: the corner (x ± ½, y ± ½) of pixel
// (x, y) is texel-space point (x + ½ ± ½, y + ½ ± ½).
fn corner_filtered(x: u32, y: u32, sx: u32, sy: u32) -> vec4<f32> {
    let size = vec2<f32>(f32(U.width), f32(U.height));
    let uv = vec2<f32>(f32(x + sx), f32(y + sy)) / size;
    return textureSampleLevel(outline_tex, outline_sampler, uv, 0.0);
}

fn ramp(v: f32, r: vec2<f32>) -> f32 {
    return clamp((v - r.x) / max(r.y - r.x, 1e-12), 0.0, 1.0);
}

// splat/cpu.rs: outline_weight from the pixel's own (N, Z) and its four corner fetches
// (−−, +−, −+, ++), with sobel4 for the normals.
fn outline_weight(centre: vec4<f32>, mm: vec4<f32>, pm: vec4<f32>, mp: vec4<f32>, pp: vec4<f32>) -> f32 {
    let z = centre.w;
    let mean = 0.25 * (mm.w + pm.w + mp.w + pp.w);
    let zmin = min(min(min(min(z, mm.w), pm.w), mp.w), pp.w);
    let sil = abs(mean - z) / max(zmin, 1e-30);
    let gx = 4.0 * (pm.xyz + pp.xyz - mm.xyz - mp.xyz);
    let gy = 4.0 * (mp.xyz + pp.xyz - mm.xyz - pm.xyz);
    let crease = sqrt((gx.x * gx.x + gy.x * gy.x) + (gx.y * gx.y + gy.y * gy.y) + (gx.z * gx.z + gy.z * gy.z)) / 4.0;
    return max(ramp(sil, P.depth_ramp), ramp(crease, P.crease_ramp));
}

// splat/cpu.rs: shade_splat, one pixel, before the outline; returns the colour and writes the
// shadow samples taken.
fn shade_one(k: u32, px: u32, py: u32) -> vec4<f32> {
    S = P.shade;
    let s = gbuf[k];
    var samples = 0u;
    var c = S.background;
    if (s.id != ID_MISS) {
        let v = subpixel_ray(px, py, 0u).d;
        var footprint = S.pixel_angle;
        if (U.ortho == 0u) {
            footprint = S.pixel_angle * s.depth;
        }
        let obj = objects[k];
        if (obj < P.colors) {
            S.color = colors[obj].xyz;
        }
        c = shade_pixel(s, v, footprint);
        if (P.shadows != 0u) {
            let sf = shadow_factor(s.position, s.normal, px, py);
            samples = sf.samples;
            let amb = S.ambient * S.color;
            c = vec4<f32>(amb + sf.f * (c.xyz - amb), c.w);
        }
    }
    shadow_samples[k] = samples;
    return c;
}

fn blend_outline(c: vec4<f32>, w: f32) -> vec4<f32> {
    let rgb = c.xyz + w * (P.outline_color - c.xyz);
    return vec4<f32>(rgb, max(c.w, w));
}

@compute @workgroup_size(WORKGROUP)
fn shade_splat_filtered(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * P.shade.stride;
    if (k >= P.shade.count) {
        return;
    }
    let i = P.shade.pixel_base + k;
    let px = i % U.width;
    let py = i / U.width;
    var c = shade_one(k, px, py);
    if (P.outlines != 0u) {
        let centre = textureLoad(outline_tex, vec2<u32>(px, py), 0);
        let w = outline_weight(
            centre,
            corner_filtered(px, py, 0u, 0u),
            corner_filtered(px, py, 1u, 0u),
            corner_filtered(px, py, 0u, 1u),
            corner_filtered(px, py, 1u, 1u),
        );
        c = blend_outline(c, w);
    }
    image[k] = c;
}

@compute @workgroup_size(WORKGROUP)
fn shade_splat_loads(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * P.shade.stride;
    if (k >= P.shade.count) {
        return;
    }
    let i = P.shade.pixel_base + k;
    let px = i % U.width;
    let py = i / U.width;
    var c = shade_one(k, px, py);
    if (P.outlines != 0u) {
        let x = i32(px);
        let y = i32(py);
        let w = outline_weight(
            outline_at(x, y),
            corner_load(x, y, -1, -1),
            corner_load(x, y, 1, -1),
            corner_load(x, y, -1, 1),
            corner_load(x, y, 1, 1),
        );
        c = blend_outline(c, w);
    }
    image[k] = c;
}
