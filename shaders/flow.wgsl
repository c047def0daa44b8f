// Curvature-aligned flow (002 Sec. 6.4, Fig. 6.12): the line integral convolution of white
// noise along the screen-space direction field of the `flow` shading mode, one invocation
// per pixel over the whole image; the shading pass (shade.wgsl) then reads the result.
// Prepended by Rust (isokit_render::gpu::flow_shader): const WORKGROUP, ID_MISS, FLOW_STEPS.
// CPU twin: crates/isokit-render/src/flow/cpu.rs (flow_hash, flow_noise, flow_lic); the field
// itself is computed on the host by flow/cpu.rs's flow_field (bit-identical input).

// Rust: flow/gpu.rs FlowParams (16 bytes).
struct FlowParams {
    width: u32,
    height: u32,
    count: u32,   // width · height
    stride: u32,  // invocations per row of the dispatch grid
}

@group(0) @binding(0) var<uniform> F: FlowParams;
@group(0) @binding(1) var<storage, read> dirs: array<vec2<f32>>; // unit, pixel coordinates
@group(0) @binding(2) var<storage, read> keys: array<u32>;       // id, or ID_MISS: no flow
@group(0) @binding(3) var<storage, read_write> lic: array<f32>;

// flow/cpu.rs: flow_hash (lowbias32 of a mix of the coordinates; u32 arithmetic wraps).
fn flow_hash(x: u32, y: u32) -> u32 {
    var h = (x * 0x8da6b343u) ^ (y * 0xd8163841u);
    h ^= h >> 16u;
    h *= 0x7feb352du;
    h ^= h >> 15u;
    h *= 0x846ca68bu;
    h ^= h >> 16u;
    return h;
}

// flow/cpu.rs: flow_noise (16 bits: the sums below are exact).
fn flow_noise(x: u32, y: u32) -> f32 {
    return f32(flow_hash(x, y) >> 16u) * (1.0 / 65536.0);
}

// flow/cpu.rs: flow_lic. −1 where the pixel has no flow.
fn flow_lic(x: u32, y: u32) -> f32 {
    let key = keys[x + y * F.width];
    if (key == ID_MISS) {
        return -1.0;
    }
    let d0 = dirs[x + y * F.width];
    var sum = flow_noise(x, y);
    var n = 1u;
    for (var side = 0u; side < 2u; side++) {
        var sgn = 1.0;
        if (side == 1u) {
            sgn = -1.0;
        }
        var p = vec2<f32>(f32(x) + 0.5, f32(y) + 0.5);
        var d = sgn * d0;
        for (var k = 0u; k < FLOW_STEPS; k++) {
            p += d;
            let fp = floor(p);
            if (fp.x < 0.0 || fp.y < 0.0 || fp.x >= f32(F.width) || fp.y >= f32(F.height)) {
                break;
            }
            let ix = u32(fp.x);
            let iy = u32(fp.y);
            let j = ix + iy * F.width;
            if (keys[j] != key) {
                break;
            }
            sum += flow_noise(ix, iy);
            n += 1u;
            // Principal directions have no sign: keep the one that continues the line.
            var e = dirs[j];
            if (e.x * d.x + e.y * d.y < 0.0) {
                e = -e;
            }
            d = e;
        }
    }
    return sum / f32(n);
}

@compute @workgroup_size(WORKGROUP)
fn flow(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * F.stride;
    if (i >= F.count) {
        return;
    }
    lic[i] = flow_lic(i % F.width, i / F.width);
}
