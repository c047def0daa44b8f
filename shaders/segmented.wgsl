// Ray casting a segmented distance field (003 Sec. 4): the surfaces between the regions of a
// field sampled as f = min(d, delta) + D r (003 Eq. 4), one ray per invocation. Samples along
// the ray, half a spacing apart (jumping where the distances say no surface is near), take
// their lattice point's value by nearest-neighbour lookup (003 Sec. 4.2); where two consecutive samples' points differ, 003 Eq. 5-7 (or the vertex
// generation diagram, a table from the host) say whether and where the surface crosses the
// lattice edge between them; the hit is where the ray meets the plane through that crossing
// with the normal there. Entry point segmented.
// Prepended by Rust (isokit_render::segmented::gpu::segmented_shader): const WORKGROUP; then
// common/slab.wgsl.
// CPU twin: crates/isokit-render/src/segmented/mod.rs (SegmentedCaster::trace, nearest,
// normal; Segmentation::decode, reach and crossing of isokit_levelset::segmented;
// VertexDiagram::lookup), named alike; the rays and the diagram come from the host.

// Rust: segmented/gpu.rs SegParams (64 bytes).
struct SegParams {
    dims: vec3<u32>,
    count: u32,         // rays
    origin: vec3<f32>,
    spacing: f32,
    delta: f32,         // 003 Eq. 4's distance clamp
    period: f32,        // 003 Eq. 4's region period D
    diagram: u32,       // 1: crossings from the diagram, 0: Eq. 5-7
    levels: u32,        // diagram entries per period
    n: u32,             // diagram entries per axis (levels times regions)
    stride: u32,        // invocations per row of the dispatch grid
    layers: u32,        // surfaces per ray (the march goes on past each hit)
    pad: u32,
}

@group(0) @binding(0) var<uniform> P: SegParams;
@group(0) @binding(1) var<storage, read> field: array<f32>;      // x fastest
@group(0) @binding(2) var<storage, read> table: array<f32>;      // the diagram: t of Eq. 6 or -1, three layers
@group(0) @binding(3) var<storage, read> rays: array<vec4<f32>>; // per ray: origin, unit direction
@group(0) @binding(4) var<storage, read_write> out: array<vec4<f32>>; // three per ray

// Grid::get_clamped.
fn value_at(c: vec3<i32>) -> f32 {
    let hi = vec3<i32>(P.dims) - vec3<i32>(1);
    let q = clamp(c, vec3<i32>(0), hi);
    return field[u32(q.x) + P.dims.x * (u32(q.y) + P.dims.y * u32(q.z))];
}

struct Decoded {
    ok: bool,
    region: i32,
    d: f32,
}

// Segmentation::decode: the region and the clamped distance of a sample.
fn decode(f: f32) -> Decoded {
    if (!(f >= 0.0 && f <= 3.4028235e38)) {
        return Decoded(false, 0, 0.0);
    }
    let r = floor(f / P.period);
    let d = clamp(f - r * P.period, 0.0, P.delta);
    return Decoded(true, i32(r), d);
}

// Segmentation::reach: the largest d_u + d_v of Eq. 7 between samples w apart.
fn reach(w: f32, r: i32) -> f32 {
    return w * (1.0 + 1e-4) + 4.0 * 1.1920929e-7 * P.period * (f32(r) + 1.0);
}

struct Cross {
    ok: bool,
    i: i32,
    j: i32,
    t: f32,
}

// Segmentation::crossing: 003 Eq. 5-7 between u and v, w apart.
fn crossing(u: f32, v: f32, w: f32) -> Cross {
    let a = decode(u);
    let b = decode(v);
    if (!a.ok || !b.ok || a.region == b.region || a.d + b.d > reach(w, max(a.region, b.region))) {
        return Cross(false, 0, 0, 0.0);
    }
    let sum = a.d + b.d;
    var t = 0.5;
    if (sum > 0.0) {
        t = a.d / sum;
    }
    return Cross(true, a.region, b.region, t);
}

// VertexDiagram::lookup: the nearest entry of the layer for points differing on `axes` axes.
fn diagram_lookup(u: f32, v: f32, axes: u32) -> Cross {
    let fa = floor(u / P.period * f32(P.levels));
    let fb = floor(v / P.period * f32(P.levels));
    if (!(fa >= 0.0 && fa < f32(P.n) && fb >= 0.0 && fb < f32(P.n))) {
        return Cross(false, 0, 0, 0.0);
    }
    let a = u32(fa);
    let b = u32(fb);
    let layer = clamp(axes, 1u, 3u) - 1u;
    let t = table[a + P.n * (b + P.n * layer)];
    if (!(t >= 0.0)) {
        return Cross(false, 0, 0, 0.0);
    }
    return Cross(true, i32(a / P.levels), i32(b / P.levels), t);
}

// SegmentedCaster::nearest: the lattice point nearest x, clamped into the grid.
fn nearest(x: vec3<f32>) -> vec3<i32> {
    let g = floor((x - P.origin) / P.spacing + vec3<f32>(0.5));
    let hi = vec3<i32>(P.dims) - vec3<i32>(1);
    return clamp(vec3<i32>(g), vec3<i32>(0), hi);
}

fn point_of(c: vec3<i32>) -> vec3<f32> {
    return P.origin + vec3<f32>(c) * P.spacing;
}

// The pair's signed distance at a lattice point: +d in the front region, -d in the back.
fn signed_at(p: vec3<i32>, back: i32) -> f32 {
    let s = decode(value_at(p));
    if (!s.ok) {
        return 0.0;
    }
    if (s.region == back) {
        return -s.d;
    }
    return s.d;
}

fn corner_weight(a: i32, f: f32) -> f32 {
    if (a == 1) {
        return f;
    }
    return 1.0 - f;
}

fn corner_slope(a: i32) -> f32 {
    if (a == 1) {
        return 1.0;
    }
    return -1.0;
}

// SegmentedCaster::normal: the gradient of the pair's signed distance, trilinear in the cell
// around x, facing against d.
fn normal_at(x: vec3<f32>, back: i32, d: vec3<f32>) -> vec3<f32> {
    let g = (x - P.origin) / P.spacing;
    let hi = max(vec3<i32>(P.dims) - vec3<i32>(2), vec3<i32>(0));
    let c = clamp(vec3<i32>(floor(g)), vec3<i32>(0), hi);
    let f = clamp(g - vec3<f32>(c), vec3<f32>(0.0), vec3<f32>(1.0));
    var grad = vec3<f32>(0.0);
    for (var k = 0; k < 2; k += 1) {
        for (var j = 0; j < 2; j += 1) {
            for (var i = 0; i < 2; i += 1) {
                let s = signed_at(c + vec3<i32>(i, j, k), back);
                grad += s * vec3<f32>(
                    corner_slope(i) * corner_weight(j, f.y) * corner_weight(k, f.z),
                    corner_weight(i, f.x) * corner_slope(j) * corner_weight(k, f.z),
                    corner_weight(i, f.x) * corner_weight(j, f.y) * corner_slope(k),
                );
            }
        }
    }
    let len = length(grad);
    var n = -d;
    if (len > 0.0) {
        n = grad * (1.0 / len);
    }
    if (dot(n, d) > 0.0) {
        n = -n;
    }
    return n;
}

// SegmentedCaster::trace_layers: per ray and layer k, at s = 3 (i layers + k):
// out[s] = (t, 1 when hit, samples (layer 0 only), position.x), out[s + 1] = (normal,
// position.y), out[s + 2] = (front region, back region, position.z, 0).
@compute @workgroup_size(WORKGROUP)
fn segmented(@builtin(global_invocation_id) id: vec3<u32>) {
    let ray = id.x + id.y * P.stride;
    if (ray >= P.count) {
        return;
    }
    let o = rays[2u * ray].xyz;
    let d = rays[2u * ray + 1u].xyz;
    let bmin = P.origin;
    let bmax = P.origin + vec3<f32>(P.dims - vec3<u32>(1u)) * P.spacing;
    let span = slab(o, d, bmin, bmax);
    let first = 3u * ray * P.layers;
    for (var k = 0u; k < P.layers; k += 1u) {
        out[first + 3u * k] = vec4<f32>(0.0);
        out[first + 3u * k + 1u] = vec4<f32>(0.0);
        out[first + 3u * k + 2u] = vec4<f32>(0.0);
    }
    var samples = 0u;
    if (span.x < span.y) {
        // From the entry point oe, s along the ray from there (as the CPU twin).
        let t0 = span.x;
        let len = span.y - span.x;
        let oe = o + t0 * d;
        let step = 0.5 * P.spacing;
        var s = 0.0;
        var cu = nearest(oe);
        var u = value_at(cu);
        samples = 1u;
        var found = 0u;
        while (s < len) {
            // Empty space: jump by the sample's distance less 1.87 spacings, untested.
            let here = decode(u);
            var dist = 0.0;
            if (here.ok) {
                dist = here.d;
            }
            let jump = dist - 1.87 * P.spacing;
            if (jump > step) {
                s = min(s + jump, len);
                cu = nearest(oe + s * d);
                u = value_at(cu);
                samples += 1u;
                continue;
            }
            s = min(s + step, len);
            let cv = nearest(oe + s * d);
            let v = value_at(cv);
            samples += 1u;
            if (any(cv != cu)) {
                let pu = point_of(cu);
                let pv = point_of(cv);
                var c: Cross;
                if (P.diagram == 1u) {
                    let diff = abs(cv - cu);
                    let axes = u32(diff.x > 0) + u32(diff.y > 0) + u32(diff.z > 0);
                    c = diagram_lookup(u, v, axes);
                } else {
                    c = crossing(u, v, distance(pu, pv));
                }
                if (c.ok) {
                    let x = pu + c.t * (pv - pu);
                    let n = normal_at(x, c.j, d);
                    let dn = abs(dot(d, n));
                    var sh = dot(x - oe, d);
                    if (dn > 0.1) {
                        let reach_s = 0.87 * P.spacing / dn;
                        sh = clamp(dot(x - oe, n) / dot(d, n), s - step - reach_s, s + reach_s);
                    }
                    sh = clamp(sh, 0.0, len);
                    let slot = first + 3u * found;
                    let pos = oe + sh * d;
                    out[slot] = vec4<f32>(t0 + sh, 1.0, 0.0, pos.x);
                    out[slot + 1u] = vec4<f32>(n, pos.y);
                    out[slot + 2u] = vec4<f32>(f32(c.i), f32(c.j), pos.z, 0.0);
                    found += 1u;
                    if (found >= P.layers) {
                        break;
                    }
                }
            }
            cu = cv;
            u = v;
        }
    }
    out[first].z = f32(samples);
}
