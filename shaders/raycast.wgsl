// Isosurface ray caster, one pass over the pending rays (002 Sec. 6.3, block-level ray
// casting with a 3D DDA; see the module docs of raycast/cpu.rs). One invocation is one ray: it
// runs to its hit (written to the G-buffer) or to an active block whose brick is not
// resident, where it asks for the brick, saves where to resume and appends itself to the
// next pass's list.
// Prepended by Rust (isokit_render::gpu): const WORKGROUP, ID_MISS, ID_SURFACE, ID_CAP,
// ID_SURFACE_B, FILTER_TRILINEAR, FILTER_TRICUBIC, FLAG_*, COMBINE_*, NOT_RESIDENT, HALF_RESOLUTION,
// RANGE_MARGIN, REFINE_TOLERANCE, SLOPE_MARGIN, CARRY_MARGIN, MIN_GRADIENT, F32_MAX; then raycast_common.wgsl
// and common/curvature.wgsl (curvature, used by surface_sample; any_orthonormal) and
// common/bspline.wgsl (the cubic B-spline weights).
// CPU twin: crates/isokit-render/src/raycast/cpu.rs, function by function in the same order.

// Rust: raycast/gpu.rs Params (32 bytes).
struct Params {
    count: u32,    // rays in this pass
    stride: u32,   // invocations per row of the dispatch grid
    fresh: u32,    // 1: the first pass, ray k is k; 0: ray k is lists[src + k], resumed
    src: u32,      // offset of this pass's list in `lists`
    dst: u32,      // offset of the next pass's list in `lists`
    ray_base: u32, // global index of this chunk's ray 0
    requests: u32, // offset of the per-brick request counters in `counters`
    used: u32,     // offset of the per-brick used flags in `counters`
}

// Where a waiting ray resumes (raycast/cpu.rs: Resume) and what it has cost so far.
struct RayState {
    cell: vec3<i32>,
    t: f32,
    first_block: u32,
    samples: u32,
    clear: f32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> U: Uniforms;
@group(0) @binding(1) var<uniform> P: Params;
@group(0) @binding(2) var<storage, read> pool: array<f32>;
@group(0) @binding(3) var<storage, read> reference: array<u32>;
@group(0) @binding(4) var<storage, read> block_range: array<vec2<f32>>;
// [0]: rays appended to the next list; then requests and used flags per brick.
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> lists: array<u32>;
@group(0) @binding(7) var<storage, read_write> states: array<RayState>;
@group(0) @binding(8) var<storage, read_write> gbuf: array<GPixel>;
// Per block: slope bounds along x, y, z per voxel and the Chebyshev distance in blocks to the
// nearest active block (raycast/cpu.rs: TraceData::block_info).
@group(0) @binding(9) var<storage, read> block_info: array<vec4<f32>>;

// Field evaluations of this invocation's ray (raycast/cpu.rs: the `samples` counters).
var<private> samples: u32;

fn residual(f: f32) -> f32 {
    return (f - U.iso) * U.inside_sign;
}

// rho within the block range widened by RANGE_MARGIN (raycast/cpu.rs: range_holds_iso).
fn range_holds_iso(range: vec2<f32>) -> bool {
    let eps = RANGE_MARGIN * max(abs(range.x), abs(range.y));
    return range.x - eps <= U.iso && U.iso <= range.y + eps;
}

// Which blocks are active (raycast/cpu.rs: block_active) the host decides: their skip
// distance in `block_info` is 0.

struct BoxHit {
    t0: f32,
    t1: f32,
    axis: u32,
    hit: bool,
}

// The ray clipped to [0, n − 1]³ and t >= 0; `axis` of the entry face, 3 when inside.
fn ray_box(o: vec3<f32>, d: vec3<f32>) -> BoxHit {
    var t0 = 0.0;
    var t1 = F32_MAX;
    var axis = 3u;
    for (var a = 0u; a < 3u; a++) {
        let hi = f32(U.dims[a] - 1u);
        if (d[a] == 0.0) {
            if (o[a] < 0.0 || o[a] > hi) {
                return BoxHit(0.0, 0.0, 3u, false);
            }
            continue;
        }
        let ta = (0.0 - o[a]) / d[a];
        let tb = (hi - o[a]) / d[a];
        let near = min(ta, tb);
        let far = max(ta, tb);
        if (near > t0) {
            t0 = near;
            axis = a;
        }
        t1 = min(t1, far);
    }
    return BoxHit(t0, t1, axis, t0 <= t1 && is_finite(t0));
}

struct Exit {
    t: f32,
    axis: u32,
}

// Where the ray crosses the plane x_a = m · block, from o and inv = 1 / d along the axis
// (raycast/cpu.rs: plane_t).
fn plane_t(m: i32, o: f32, inv: f32) -> f32 {
    return (f32(m) * f32(U.block) - o) * inv;
}

// Where the ray leaves block `cell`, from the block index alone (the lowest of tied axes)
// (raycast/cpu.rs: block_exit_inv).
fn block_exit(cell: vec3<i32>, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>) -> Exit {
    var t = F32_MAX;
    var axis = 0u;
    for (var a = 0u; a < 3u; a++) {
        if (d[a] != 0.0) {
            let ta = plane_t(cell[a] + select(0, 1, d[a] > 0.0), o[a], inv[a]);
            if (ta < t) {
                t = ta;
                axis = a;
            }
        }
    }
    return Exit(t, axis);
}

struct Jump {
    t: f32,
    axis: u32,
    next: vec3<i32>,
}

// Plane m of axis a crossed before the cube's exit (t, e) (raycast/cpu.rs: jump, `crossed`).
fn crossed(m: i32, a: u32, o: f32, inv: f32, t: f32, e: u32) -> bool {
    let tm = plane_t(m, o, inv);
    return tm < t || (tm == t && a < e);
}

// Across the inactive cube of blocks within k − 1 of `cell` (raycast/cpu.rs: jump).
fn jump(cell: vec3<i32>, k: i32, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, bd: vec3<i32>) -> Jump {
    let r = k - 1;
    let lo = max(cell - vec3<i32>(r), vec3<i32>(0));
    let hi = min(cell + vec3<i32>(r), bd - vec3<i32>(1));
    var t = F32_MAX;
    var e = 0u;
    for (var a = 0u; a < 3u; a++) {
        if (d[a] != 0.0) {
            let m = select(lo[a], hi[a] + 1, d[a] > 0.0);
            let ta = plane_t(m, o[a], inv[a]);
            if (ta < t) {
                t = ta;
                e = a;
            }
        }
    }
    var next = cell;
    let b = f32(U.block);
    for (var a = 0u; a < 3u; a++) {
        if (a == e) {
            next[a] = select(lo[a] - 1, hi[a] + 1, d[a] > 0.0);
            continue;
        }
        if (d[a] == 0.0) {
            continue;
        }
        let guess = i32((o[a] + t * d[a]) * (1.0 / b));
        if (d[a] > 0.0) {
            var g = clamp(guess, cell[a], hi[a]);
            while (g > cell[a] && !crossed(g, a, o[a], inv[a], t, e)) {
                g -= 1;
            }
            while (g < hi[a] && crossed(g + 1, a, o[a], inv[a], t, e)) {
                g += 1;
            }
            next[a] = g;
        } else {
            var g = clamp(guess, lo[a], cell[a]);
            while (g < cell[a] && !crossed(g + 1, a, o[a], inv[a], t, e)) {
                g += 1;
            }
            while (g > lo[a] && crossed(g, a, o[a], inv[a], t, e)) {
                g -= 1;
            }
            next[a] = g;
        }
    }
    return Jump(t, e, next);
}

fn block_index(cell: vec3<i32>) -> u32 {
    let c = vec3<u32>(cell);
    return c.x + U.block_dims.x * (c.y + U.block_dims.y * c.z);
}

fn brick_of_block(cell: vec3<i32>) -> u32 {
    let c = vec3<u32>(cell / i32(U.brick / U.block));
    return c.x + U.brick_dims.x * (c.y + U.brick_dims.y * c.z);
}

struct Located {
    base: u32,
    cell: vec3<i32>,
    frac: vec3<f32>,
    p: vec3<f32>,
    side: u32, // samples per axis of the stored brick (brick_side, or brick / 2 + 3)
    half: u32, // 1 for a brick stored at half resolution (coarse lattice, spacing 2)
}

// Grid position `p` in block `cell` (brick in `slot`), clamped to the block's box.
fn locate(slot: u32, cell: vec3<i32>, p: vec3<f32>) -> Located {
    let b = i32(U.block);
    let top = vec3<i32>(U.dims) - vec3<i32>(1);
    let lo = cell * b;
    let hi = min(lo + vec3<i32>(b), top);
    let q = clamp(p, vec3<f32>(lo), vec3<f32>(hi));
    if ((slot & HALF_RESOLUTION) != 0u) {
        return locate_half(slot, cell, lo, hi, q);
    }
    let c = clamp(vec3<i32>(q), lo, hi - vec3<i32>(1)); // q >= 0: truncation is the floor
    let first = cell / i32(U.brick / U.block) * i32(U.brick) - vec3<i32>(1);
    let side = U.brick_side;
    return Located(slot * channels() * side * side * side, c - first, q - vec3<f32>(c), q, side, 0u);
}

// `locate` in a brick stored at half resolution (raycast/cpu.rs: locate_half).
fn locate_half(slot: u32, cell: vec3<i32>, lo: vec3<i32>, hi: vec3<i32>, q: vec3<f32>) -> Located {
    let corner = cell / i32(U.brick / U.block) * i32(U.brick);
    let pc = (q - vec3<f32>(corner)) * 0.5;
    let clo = (lo - corner) / 2;
    let chi = (hi - corner + vec3<i32>(1)) / 2;
    let c = clamp(vec3<i32>(pc), clo, chi - vec3<i32>(1)); // pc >= 0
    let side = U.brick / 2u + 3u;
    let base = (slot & ~HALF_RESOLUTION) * channels() * side * side * side;
    return Located(base, c + vec3<i32>(1), pc - vec3<f32>(c), q, side, 1u);
}

// Fields per brick slot: 1, or 2 when a second field is combined (raycast/cpu.rs: channels).
fn channels() -> u32 {
    return select(2u, 1u, U.combine == COMBINE_NONE);
}

// The same point in channel B of its slot (raycast/cpu.rs: channel_b).
fn channel_b(l: Located) -> Located {
    let side = l.side;
    return Located(l.base + side * side * side, l.cell, l.frac, l.p, l.side, l.half);
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + t * (b - a);
}

// The emulated texture fetch: 8 loads and 7 lerps, x then y then z.
fn fetch(base: u32, side: u32, c: vec3<i32>, t: vec3<f32>) -> f32 {
    let i = base + u32(c.x) + side * (u32(c.y) + side * u32(c.z));
    let sy = side;
    let sz = side * side;
    let x00 = lerp(pool[i], pool[i + 1u], t.x);
    let x10 = lerp(pool[i + sy], pool[i + sy + 1u], t.x);
    let x01 = lerp(pool[i + sz], pool[i + sz + 1u], t.x);
    let x11 = lerp(pool[i + sy + sz], pool[i + sy + sz + 1u], t.x);
    return lerp(lerp(x00, x10, t.y), lerp(x01, x11, t.y), t.z);
}

// a · b summed as (x + z) + (y + w) (raycast/cpu.rs: dot4).
fn dot4(a: vec4<f32>, b: vec4<f32>) -> f32 {
    let p = a * b;
    return (p.x + p.z) + (p.y + p.w);
}

// First of the 4×4×4 samples around a located point (raycast/cpu.rs: taps_window).
fn taps_origin(l: Located) -> u32 {
    let side = l.side;
    return l.base + u32(l.cell.x - 1) + side * (u32(l.cell.y - 1) + side * u32(l.cell.z - 1));
}

// Row (j, k) of the neighbourhood: 4 samples along x (raycast/cpu.rs: taps_row).
fn taps_row(i0: u32, side: u32, j: u32, k: u32) -> vec4<f32> {
    let i = i0 + side * (j + side * k);
    return vec4<f32>(pool[i], pool[i + 1u], pool[i + 2u], pool[i + 3u]);
}

// The tricubic B-spline by its 64 taps (raycast/cpu.rs: tricubic_taps).
fn tricubic_taps(l: Located) -> f32 {
    let wx = bspline_weights(l.frac.x);
    let wy = bspline_weights(l.frac.y);
    let wz = bspline_weights(l.frac.z);
    let i0 = taps_origin(l);
    // Per slice k, then (s0 + s1) + (s2 + s3): the CPU twin's order (raycast/cpu.rs:
    // value_sum).
    var slice = array<vec4<f32>, 4>(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var k = 0u; k < 4u; k++) {
        for (var j = 0u; j < 4u; j++) {
            slice[k] += taps_row(i0, l.side, j, k) * (wy[j] * wz[k]);
        }
    }
    return dot4((slice[0] + slice[1]) + (slice[2] + slice[3]), wx);
}

struct GradHess {
    g: vec3<f32>,
    h: mat3x3<f32>,
}

// Gradient (and with `hessian` the Hessian) of the tricubic B-spline from the same 64 taps
// in one pass (raycast/cpu.rs: tricubic_taps_gradient, tricubic_taps_hessian).
fn tricubic_taps_derivatives(l: Located, hessian: bool) -> GradHess {
    let f = l.frac;
    let wx = bspline_weights(f.x);
    let wy = bspline_weights(f.y);
    let wz = bspline_weights(f.z);
    let dx = bspline_weights_d1(f.x);
    let dy = bspline_weights_d1(f.y);
    let dz = bspline_weights_d1(f.z);
    let i0 = taps_origin(l);
    var a0 = vec4<f32>(0.0);
    var a1 = vec4<f32>(0.0);
    var a2 = vec4<f32>(0.0);
    if (!hessian) {
        for (var k = 0u; k < 4u; k++) {
            for (var j = 0u; j < 4u; j++) {
                let row = taps_row(i0, l.side, j, k);
                a0 += row * (wy[j] * wz[k]);
                a1 += row * (dy[j] * wz[k]);
                a2 += row * (wy[j] * dz[k]);
            }
        }
        return GradHess(vec3<f32>(dot4(a0, dx), dot4(a1, wx), dot4(a2, wx)), mat3x3<f32>());
    }
    let ex = bspline_weights_d2(f.x);
    let ey = bspline_weights_d2(f.y);
    let ez = bspline_weights_d2(f.z);
    var a3 = vec4<f32>(0.0);
    var a4 = vec4<f32>(0.0);
    var a5 = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        for (var j = 0u; j < 4u; j++) {
            let row = taps_row(i0, l.side, j, k);
            a0 += row * (wy[j] * wz[k]);
            a1 += row * (dy[j] * wz[k]);
            a2 += row * (wy[j] * dz[k]);
            a3 += row * (ey[j] * wz[k]);
            a4 += row * (wy[j] * ez[k]);
            a5 += row * (dy[j] * dz[k]);
        }
    }
    let g = vec3<f32>(dot4(a0, dx), dot4(a1, wx), dot4(a2, wx));
    let hxy = dot4(a1, dx);
    let hxz = dot4(a2, dx);
    let hyz = dot4(a5, wx);
    let h = mat3x3<f32>(
        vec3<f32>(dot4(a0, ex), hxy, hxz),
        vec3<f32>(hxy, dot4(a3, wx), hyz),
        vec3<f32>(hxz, hyz, dot4(a4, wx)),
    );
    return GradHess(g, h);
}

// The value the ray caster searches with (raycast/cpu.rs: sample_value).
fn sample_value(filter_code: u32, l: Located) -> f32 {
    if (filter_code == FILTER_TRILINEAR) {
        return fetch(l.base, l.side, l.cell, l.frac);
    }
    return tricubic_taps(l);
}

fn sample_at(i: u32, side: u32, dx: u32, dy: u32, dz: u32) -> f32 {
    return pool[i + dx + side * (dy + side * dz)];
}

// Gradient and (with `hessian`) Hessian in grid units; half-resolution bricks scaled back
// (raycast/cpu.rs: sample_gradient_hessian).
fn sample_gradient_hessian(filter_code: u32, l: Located, hessian: bool) -> GradHess {
    var gh: GradHess;
    if (filter_code == FILTER_TRILINEAR) {
        gh = trilinear_gradient_hessian(l);
    } else {
        gh = tricubic_taps_derivatives(l, hessian);
    }
    if (l.half != 0u) {
        return GradHess(gh.g * 0.5, gh.h * 0.25);
    }
    return gh;
}

// The trilinear interpolant's gradient and Hessian (zero diagonal) in the stored brick's
// units (raycast/cpu.rs: stored_gradient_hessian).
fn trilinear_gradient_hessian(l: Located) -> GradHess {
    let side = l.side;
    let i = l.base + u32(l.cell.x) + side * (u32(l.cell.y) + side * u32(l.cell.z));
    let t = l.frac;
    // Differences along each axis at the four edges, interpolated over the other two.
    let ex00 = sample_at(i, side, 1u, 0u, 0u) - sample_at(i, side, 0u, 0u, 0u);
    let ex10 = sample_at(i, side, 1u, 1u, 0u) - sample_at(i, side, 0u, 1u, 0u);
    let ex01 = sample_at(i, side, 1u, 0u, 1u) - sample_at(i, side, 0u, 0u, 1u);
    let ex11 = sample_at(i, side, 1u, 1u, 1u) - sample_at(i, side, 0u, 1u, 1u);
    let ey00 = sample_at(i, side, 0u, 1u, 0u) - sample_at(i, side, 0u, 0u, 0u);
    let ey10 = sample_at(i, side, 1u, 1u, 0u) - sample_at(i, side, 1u, 0u, 0u);
    let ey01 = sample_at(i, side, 0u, 1u, 1u) - sample_at(i, side, 0u, 0u, 1u);
    let ey11 = sample_at(i, side, 1u, 1u, 1u) - sample_at(i, side, 1u, 0u, 1u);
    let ez00 = sample_at(i, side, 0u, 0u, 1u) - sample_at(i, side, 0u, 0u, 0u);
    let ez10 = sample_at(i, side, 1u, 0u, 1u) - sample_at(i, side, 1u, 0u, 0u);
    let ez01 = sample_at(i, side, 0u, 1u, 1u) - sample_at(i, side, 0u, 1u, 0u);
    let ez11 = sample_at(i, side, 1u, 1u, 1u) - sample_at(i, side, 1u, 1u, 0u);
    let gx = lerp(lerp(ex00, ex10, t.y), lerp(ex01, ex11, t.y), t.z);
    let gy = lerp(lerp(ey00, ey10, t.x), lerp(ey01, ey11, t.x), t.z);
    let gz = lerp(lerp(ez00, ez10, t.x), lerp(ez01, ez11, t.x), t.y);
    let hxy = lerp(ex10 - ex00, ex11 - ex01, t.z);
    let hxz = lerp(ex01 - ex00, ex11 - ex10, t.y);
    let hyz = lerp(ey01 - ey00, ey11 - ey10, t.x);
    let h = mat3x3<f32>(
        vec3<f32>(0.0, hxy, hxz),
        vec3<f32>(hxy, 0.0, hyz),
        vec3<f32>(hxz, hyz, 0.0),
    );
    return GradHess(vec3<f32>(gx, gy, gz), h);
}

// A ray inside one resident block, with the block's constants of `locate` (raycast/cpu.rs:
// SegmentRay, SegmentRay::new).
struct SegmentRay {
    o: vec3<f32>,
    d: vec3<f32>,
    cell: vec3<i32>,
    slot: u32,
    lo: vec3<i32>,
    hi: vec3<i32>,
    first: vec3<i32>,
    t0: f32,
    p0: vec3<f32>, // o + t0 · d: samples at p0 + (t − t0) · d
}

fn segment_ray(o: vec3<f32>, d: vec3<f32>, cell: vec3<i32>, slot: u32, t0: f32) -> SegmentRay {
    let b = i32(U.block);
    let top = vec3<i32>(U.dims) - vec3<i32>(1);
    let lo = cell * b;
    let hi = min(lo + vec3<i32>(b), top);
    let first = cell / i32(U.brick / U.block) * i32(U.brick) - vec3<i32>(1);
    return SegmentRay(o, d, cell, slot, lo, hi, first, t0, o + t0 * d);
}

// `locate` of the ray's point at t from the block's constants (raycast/cpu.rs:
// SegmentRay::locate_at).
fn locate_at(ray: SegmentRay, t: f32) -> Located {
    let p = ray.p0 + (t - ray.t0) * ray.d;
    if ((ray.slot & HALF_RESOLUTION) != 0u) {
        return locate(ray.slot, ray.cell, p);
    }
    let q = clamp(p, vec3<f32>(ray.lo), vec3<f32>(ray.hi));
    let c = clamp(vec3<i32>(q), ray.lo, ray.hi - vec3<i32>(1));
    let side = U.brick_side;
    return Located(ray.slot * channels() * side * side * side, c - ray.first, q - vec3<f32>(c), q, side, 0u);
}

// Combines the residuals of the two fields (raycast/cpu.rs: combine); ties go to A.
fn combine(a: f32, b: f32) -> f32 {
    switch (U.combine) {
        case COMBINE_UNION: {
            return select(a, b, b < a);
        }
        case COMBINE_INTERSECTION: {
            return select(a, b, b > a);
        }
        case COMBINE_DIFFERENCE: {
            return select(a, -b, -b > a);
        }
        case COMBINE_MORPH: {
            return (1.0 - U.morph_t) * a + U.morph_t * b;
        }
        default: {
            return a;
        }
    }
}

// True when B attains the combination: the object map (raycast/cpu.rs: owner_is_b).
fn owner_is_b(a: f32, b: f32) -> bool {
    switch (U.combine) {
        case COMBINE_UNION: {
            return b < a;
        }
        case COMBINE_INTERSECTION: {
            return b > a;
        }
        case COMBINE_DIFFERENCE: {
            return -b > a;
        }
        default: {
            return false;
        }
    }
}

// The residual of the (combined) field (raycast/cpu.rs: combined_residual).
fn combined_residual(filter_code: u32, l: Located) -> f32 {
    let a = residual(sample_value(filter_code, l));
    if (U.combine == COMBINE_NONE) {
        return a;
    }
    let b = residual(sample_value(filter_code, channel_b(l)));
    return combine(a, b);
}

fn residual_at(ray: SegmentRay, t: f32) -> f32 {
    samples += 1u;
    let l = locate_at(ray, t);
    return combined_residual(U.search_filter, l);
}

// The bound on the residual's slope along the ray in a block, per voxel (raycast/cpu.rs:
// ray_slope): the measured one, or a given one (U.delta > 0) unless the samples refute it.
fn ray_slope(d: vec3<f32>, info: vec4<f32>) -> f32 {
    let a = abs(d);
    let measured = a.x * info.x + a.y * info.y + a.z * info.z;
    let given = U.delta;
    var slope = measured;
    if (given > 0.0 && max(max(info.x, info.y), info.z) <= given) {
        slope = given * (a.x + a.y + a.z);
    }
    return slope * (1.0 + SLOPE_MARGIN);
}

const SEG_EMPTY: u32 = 0u;
const SEG_CAP: u32 = 1u;
const SEG_CROSSING: u32 = 2u;

struct Segment {
    kind: u32,
    ta: f32,
    ra: f32,
    tb: f32,
    rb: f32,
}

// The first crossing from outside to inside in [t0, t1] (raycast/cpu.rs: march_segment).
fn march_segment(ray: SegmentRay, t0: f32, t1: f32, first_block: bool) -> Segment {
    var ta = t0;
    var ra = residual_at(ray, t0);
    if (ra < 0.0) {
        if (first_block) {
            return Segment(SEG_CAP, 0.0, 0.0, 0.0, 0.0);
        }
        // Inside at the entry of a later block: the crossing lies at its face
        // (raycast/cpu.rs: entry_crossing).
        if ((U.flags & FLAG_CAPS) != 0u) {
            return Segment(SEG_CROSSING, t0, 0.0, t0, ra);
        }
    }
    let len = t1 - t0;
    if (!(len > 0.0)) {
        return Segment(SEG_EMPTY, 0.0, 0.0, 0.0, 0.0);
    }
    let m = u32(max(ceil(len * U.r0), 1.0));
    let dt = len / f32(m);
    for (var k = 1u; k <= m; k++) {
        var tb = t1;
        if (k != m) {
            tb = t0 + f32(k) * dt;
        }
        let rb = residual_at(ray, tb);
        if (U.fine > 1u && (abs(ra) < U.delta || abs(rb) < U.delta)) {
            var tp = ta;
            var rp = ra;
            let h = (tb - ta) / f32(U.fine);
            for (var j = 1u; j <= U.fine; j++) {
                var tj = tb;
                var rj = rb;
                if (j != U.fine) {
                    tj = ta + f32(j) * h;
                    rj = residual_at(ray, tj);
                }
                if (rp >= 0.0 && rj < 0.0) {
                    return Segment(SEG_CROSSING, tp, rp, tj, rj);
                }
                tp = tj;
                rp = rj;
            }
        } else if (ra >= 0.0 && rb < 0.0) {
            return Segment(SEG_CROSSING, ta, ra, tb, rb);
        }
        ta = tb;
        ra = rb;
    }
    return Segment(SEG_EMPTY, 0.0, 0.0, 0.0, 0.0);
}

// Sphere tracing of [t0, t1] by the block's slope bound: a sample clears r / slope of the ray
// and the next lies the fine step 1 / (r0 · fine) beyond; `clear` is a lower bound on the
// residual at t0 carried from the block before (0: none). An empty segment returns in `ra`
// the bound it leaves at t1 (raycast/cpu.rs: march_sphere).
fn march_sphere(ray: SegmentRay, t0: f32, t1: f32, first_block: bool, slope: f32, clear: f32) -> Segment {
    let min_step = 1.0 / (U.r0 * f32(U.fine));
    let ao = abs(ray.o);
    let face = slope * CARRY_MARGIN * (max(max(ao.x, ao.y), ao.z) + abs(t1));
    var t = t0;
    var r = 0.0;
    var carried = false;
    if (!first_block && clear > 0.0) {
        let lead = clear / slope;
        if (t0 + lead >= t1) {
            return Segment(SEG_EMPTY, 0.0, clear - slope * (t1 - t0) - face, 0.0, 0.0);
        }
        let tn = t0 + lead + min_step;
        let probe = select(t1, tn, tn < t1);
        let rn = residual_at(ray, probe);
        if (rn >= 0.0) {
            if (probe == t1) {
                return Segment(SEG_EMPTY, 0.0, rn - face, 0.0, 0.0);
            }
            t = tn;
            r = rn;
            carried = true;
        }
    }
    if (!carried) {
        r = residual_at(ray, t0);
        if (r < 0.0) {
            if (first_block) {
                return Segment(SEG_CAP, 0.0, 0.0, 0.0, 0.0);
            }
            // Inside at the entry of a later block: the crossing lies at its face
            // (raycast/cpu.rs: entry_crossing).
            if ((U.flags & FLAG_CAPS) != 0u) {
                return Segment(SEG_CROSSING, t0, 0.0, t0, r);
            }
        }
        let len = t1 - t0;
        if (!(len > 0.0)) {
            return Segment(SEG_EMPTY, 0.0, 0.0, 0.0, 0.0);
        }
    }
    let max_steps = u32(ceil((t1 - t0) / min_step)) + 1u;
    for (var n = 0u; n < max_steps; n++) {
        // What the sample clears; nothing for an inside or NaN residual.
        let sphere = r / slope;
        let cleared = select(0.0, sphere, sphere > 0.0);
        if (cleared > 0.0 && t + cleared >= t1) {
            return Segment(SEG_EMPTY, 0.0, r - slope * (t1 - t) - face, 0.0, 0.0);
        }
        let tf = t + cleared + min_step;
        let tn = select(t1, tf, tf < t1);
        let rn = residual_at(ray, tn);
        if (r >= 0.0 && rn < 0.0) {
            return Segment(SEG_CROSSING, t, r, tn, rn);
        }
        if (tn == t1) {
            return Segment(SEG_EMPTY, 0.0, select(0.0, rn - face, rn > 0.0), 0.0, 0.0);
        }
        t = tn;
        r = rn;
    }
    return Segment(SEG_EMPTY, 0.0, 0.0, 0.0, 0.0);
}

// Root of the linear interpolant (Eq. 6.4), or the midpoint when not a number.
fn secant(ta: f32, ra: f32, tb: f32, rb: f32) -> f32 {
    let t = ta + (tb - ta) * (ra / (ra - rb));
    if (is_finite(t)) {
        return clamp(t, min(ta, tb), max(ta, tb));
    }
    return 0.5 * (ta + tb);
}

// Bisection or Illinois secant steps keeping the bracket, then Eq. 6.4 (raycast/cpu.rs: refine).
fn refine(ray: SegmentRay, ta0: f32, ra0: f32, tb0: f32, rb0: f32) -> f32 {
    var ta = ta0;
    var ra = ra0;
    var tb = tb0;
    var rb = rb0;
    if (ta == tb) {
        // The empty bracket of a block entry (raycast/cpu.rs: entry_crossing).
        return ta;
    }
    var wa = ra;
    var wb = rb;
    var last = 0;
    var tol = REFINE_TOLERANCE * abs(ra - rb) / abs(tb - ta);
    if (!is_finite(tol)) {
        tol = 0.0;
    }
    for (var s = 0u; s < U.refine_steps; s++) {
        var tm: f32;
        if ((U.flags & FLAG_SECANT) == 0u) {
            tm = 0.5 * (ta + tb);
        } else {
            tm = secant(ta, wa, tb, wb);
        }
        let rm = residual_at(ray, tm);
        let close = abs(rm) <= tol;
        if (rm < 0.0) {
            tb = tm;
            rb = rm;
            wb = rm;
            if (last == 1) {
                wa *= 0.5;
            }
            last = 1;
        } else {
            ta = tm;
            ra = rm;
            wa = rm;
            if (last == -1) {
                wb *= 0.5;
            }
            last = -1;
        }
        if (close) {
            break;
        }
    }
    return secant(ta, ra, tb, rb);
}

fn miss_pixel() -> GPixel {
    return GPixel(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, 0.0, 0.0, ID_MISS, 0u, vec3<f32>(0.0), 0.0);
}

struct Owned {
    g: vec3<f32>,
    h: mat3x3<f32>,
    id: u32,
}

// Gradient, Hessian (with FLAG_CURVATURE) and id of the operand owning a hit
// (raycast/cpu.rs: owner_gradient_hessian).
fn owner_gradient_hessian(l: Located) -> Owned {
    let hess = (U.flags & FLAG_CURVATURE) != 0u;
    if (U.combine == COMBINE_NONE) {
        let gh = sample_gradient_hessian(U.shading_filter, l, hess);
        return Owned(gh.g, gh.h, ID_SURFACE);
    }
    let lb = channel_b(l);
    if (U.combine == COMBINE_MORPH) {
        let ga = sample_gradient_hessian(U.shading_filter, l, hess);
        let gb = sample_gradient_hessian(U.shading_filter, lb, hess);
        let wa = 1.0 - U.morph_t;
        let wb = U.morph_t;
        return Owned(wa * ga.g + wb * gb.g, ga.h * wa + gb.h * wb, ID_SURFACE);
    }
    let a = residual(sample_value(U.search_filter, l));
    let b = residual(sample_value(U.search_filter, lb));
    if (!owner_is_b(a, b)) {
        let gh = sample_gradient_hessian(U.shading_filter, l, hess);
        return Owned(gh.g, gh.h, ID_SURFACE);
    }
    let gh = sample_gradient_hessian(U.shading_filter, lb, hess);
    if (U.combine == COMBINE_DIFFERENCE) {
        return Owned(-gh.g, gh.h * -1.0, ID_SURFACE_B);
    }
    return Owned(gh.g, gh.h, ID_SURFACE_B);
}

// The G-buffer sample at ray parameter t (raycast/cpu.rs: surface_sample); without
// FLAG_CURVATURE the normal only.
fn surface_sample(ray: SegmentRay, t: f32) -> GPixel {
    let l = locate_at(ray, t);
    let gh = owner_gradient_hessian(l);
    let inv = 1.0 / U.spacing;
    let position = U.origin + U.spacing * l.p;
    let depth = t * U.spacing;
    if ((U.flags & FLAG_CURVATURE) == 0u) {
        let gs = gh.g * inv * U.inside_sign;
        let len = sqrt(dot(gs, gs));
        if (is_finite3(gh.g) && is_finite(len) && len > MIN_GRADIENT) {
            let n = gs / len;
            return GPixel(position, depth, n, 1.0, 0.0, 0.0, gh.id, 0u, any_orthonormal(n), 0.0);
        }
        return GPixel(position, depth, -ray.d, 1.0, 0.0, 0.0, gh.id, 0u, any_orthonormal(ray.d), 0.0);
    }
    let c = curvature(gh.g * inv, gh.h * (inv * inv));
    if (c.ok) {
        return GPixel(position, depth, c.normal, 1.0, c.k1, c.k2, gh.id, 0u, c.dir1, 0.0);
    }
    return GPixel(position, depth, -ray.d, 1.0, 0.0, 0.0, gh.id, 0u, any_orthonormal(ray.d), 0.0);
}

fn cap_sample(o: vec3<f32>, d: vec3<f32>, t: f32, axis: u32) -> GPixel {
    var normal = -d;
    if (axis < 3u) {
        normal = vec3<f32>(0.0);
        normal[axis] = -signum(d[axis]);
    }
    let position = U.origin + U.spacing * (o + t * d);
    return GPixel(position, t * U.spacing, normal, 1.0, 0.0, 0.0, ID_CAP, 0u, any_orthonormal(normal), 0.0);
}

struct Traced {
    done: bool,
    pixel: GPixel,
    state: RayState,
}

fn finished(p: GPixel) -> Traced {
    return Traced(true, p, RayState(vec3<i32>(0), 0.0, 0u, 0u, 0.0, 0u));
}

// Traces the ray of subpixel `sub` of pixel (px, py) from its start or from `resume`
// (raycast/cpu.rs: trace_pixel).
fn trace_pixel(px: u32, py: u32, sub: u32, resumed: bool, resume: RayState) -> Traced {
    let r = subpixel_ray(px, py, sub);
    let d = r.d;
    let o = (r.o - U.origin) / U.spacing;
    let bx = ray_box(o, d);
    if (!bx.hit) {
        return finished(miss_pixel());
    }
    let t_exit = bx.t1;
    let bd = vec3<i32>(U.block_dims);
    var cell: vec3<i32>;
    var t_in: f32;
    var first_block: bool;
    // A lower bound on the residual at t_in (raycast/cpu.rs: trace_pixel).
    var clear = 0.0;
    var after_excluded = false;
    if (resumed) {
        cell = resume.cell;
        t_in = resume.t;
        first_block = resume.first_block != 0u;
        clear = resume.clear;
    } else {
        let p = o + bx.t0 * d;
        let c = vec3<i32>(floor(p / f32(U.block)));
        cell = clamp(c, vec3<i32>(0), bd - vec3<i32>(1));
        t_in = bx.t0;
        first_block = true;
    }
    let dir_step = vec3<i32>(select(-1, 1, d.x > 0.0), select(-1, 1, d.y > 0.0), select(-1, 1, d.z > 0.0));
    let sphere = (U.flags & FLAG_SPHERE) != 0u;
    let inv = vec3<f32>(1.0) / d;
    let max_steps = U.block_dims.x + U.block_dims.y + U.block_dims.z + 3u;
    for (var n = 0u; n < max_steps; n++) {
        let idx = block_index(cell);
        // Skip distance 0 exactly where block_active holds (raycast/cpu.rs: trace_pixel).
        let info = block_info[idx];
        var bexit = Exit(0.0, 0u);
        var have_exit = false;
        if (info.w == 0.0) {
            if (after_excluded) {
                clear = 0.0;
            }
            bexit = block_exit(cell, o, d, inv);
            have_exit = true;
            let t1 = min(bexit.t, t_exit);
            let brick = brick_of_block(cell);
            let slot = reference[brick];
            if (slot == NOT_RESIDENT) {
                atomicAdd(&counters[P.requests + brick], 1u);
                let state = RayState(cell, t_in, select(0u, 1u, first_block), 0u, clear, 0u);
                return Traced(false, miss_pixel(), state);
            }
            atomicStore(&counters[P.used + brick], 1u);
            let ray = segment_ray(o, d, cell, slot, t_in);
            let caps = first_block && (U.flags & FLAG_CAPS) != 0u;
            var seg = Segment(SEG_EMPTY, 0.0, 0.0, 0.0, 0.0);
            if (t1 > t_in || caps) {
                if (sphere) {
                    let slope = ray_slope(d, info);
                    seg = march_sphere(ray, t_in, max(t1, t_in), caps, slope, clear);
                    clear = seg.ra;
                } else {
                    clear = 0.0;
                    seg = march_segment(ray, t_in, max(t1, t_in), caps);
                }
            }
            if (seg.kind == SEG_CAP) {
                return finished(cap_sample(o, d, t_in, bx.axis));
            }
            if (seg.kind == SEG_CROSSING) {
                let t = refine(ray, seg.ta, seg.ra, seg.tb, seg.rb);
                return finished(surface_sample(ray, t));
            }
        } else if (first_block && (U.flags & FLAG_CAPS) != 0u) {
            let range = block_range[idx];
            if (residual(range.x) < 0.0 && residual(range.y) < 0.0) {
                return finished(cap_sample(o, d, t_in, bx.axis));
            }
        }
        first_block = false;
        let k = i32(info.w);
        after_excluded = k >= 2 || !range_holds_iso(block_range[idx]);
        var t_out: f32;
        var axis: u32;
        var next = cell;
        if (k >= 2) {
            // Every block within k − 1 of this one is inactive: cross them at once.
            let j = jump(cell, k, o, d, inv, bd);
            t_out = j.t;
            axis = j.axis;
            next = j.next;
        } else {
            if (!have_exit) {
                bexit = block_exit(cell, o, d, inv);
            }
            t_out = bexit.t;
            axis = bexit.axis;
            next[axis] += dir_step[axis];
        }
        let t1 = min(t_out, t_exit);
        if (t1 >= t_exit) {
            break;
        }
        cell = next;
        if (cell[axis] < 0 || cell[axis] >= bd[axis]) {
            break;
        }
        t_in = max(t1, t_in);
    }
    return finished(miss_pixel());
}

@compute @workgroup_size(WORKGROUP)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x + gid.y * P.stride;
    if (k >= P.count) {
        return;
    }
    var ray = k;
    var resume = RayState(vec3<i32>(0), 0.0, 1u, 0u, 0.0, 0u);
    let resumed = P.fresh == 0u;
    if (resumed) {
        ray = lists[P.src + k];
        resume = states[ray];
    }
    samples = resume.samples;
    let g = P.ray_base + ray;
    let pixel = g / U.subpixels;
    let sub = g % U.subpixels;
    let out = trace_pixel(pixel % U.width, pixel / U.width, sub, resumed, resume);
    if (out.done) {
        var p = out.pixel;
        p.samples = samples;
        gbuf[ray] = p;
    } else {
        var s = out.state;
        s.samples = samples;
        states[ray] = s;
        let at = atomicAdd(&counters[0], 1u);
        lists[P.dst + at] = ray;
    }
}
