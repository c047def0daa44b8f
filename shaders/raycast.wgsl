// Isosurface ray caster, one pass over the pending rays (002 Sec. 6.3, block-level ray
// casting with a 3D DDA; see the module docs of raycast/cpu.rs). One invocation is one ray: it
// runs to its hit (written to the G-buffer) or to an active block whose brick is not
// resident, where it asks for the brick, saves where to resume and appends itself to the
// next pass's list.
// Prepended by Rust (isokit_render::gpu): const WORKGROUP, ID_MISS, ID_SURFACE, ID_CAP,
// ID_SURFACE_B, FILTER_TRILINEAR, FILTER_TRICUBIC, FLAG_*, COMBINE_*, NOT_RESIDENT, HALF_RESOLUTION,
// RANGE_MARGIN, MIN_GRADIENT, F32_MAX; then raycast_common.wgsl and common/curvature.wgsl
// (curvature, used by surface_sample; any_orthonormal).
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
    pad0: u32,
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

// Field evaluations of this invocation's ray (raycast/cpu.rs: the `samples` counters).
var<private> samples: u32;

fn residual(f: f32) -> f32 {
    return (f - U.iso) * U.inside_sign;
}

fn block_active(r: vec2<f32>) -> bool {
    if ((U.flags & FLAG_SKIP_EMPTY) == 0u) {
        return true;
    }
    let eps = RANGE_MARGIN * max(abs(r.x), abs(r.y));
    return r.x - eps <= U.iso && U.iso <= r.y + eps;
}

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

// Where the ray leaves block `cell`, from the block index alone.
fn block_exit(cell: vec3<i32>, o: vec3<f32>, d: vec3<f32>) -> Exit {
    let b = f32(U.block);
    var t = F32_MAX;
    var axis = 0u;
    for (var a = 0u; a < 3u; a++) {
        if (d[a] != 0.0) {
            let edge = f32(cell[a] + select(0, 1, d[a] > 0.0)) * b;
            let ta = (edge - o[a]) / d[a];
            if (ta < t) {
                t = ta;
                axis = a;
            }
        }
    }
    return Exit(t, axis);
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
    let c = clamp(vec3<i32>(floor(q)), lo, hi - vec3<i32>(1));
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
    let c = clamp(vec3<i32>(floor(pc)), clo, chi - vec3<i32>(1));
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

// isokit_field::filter::{bspline_weights, bspline_weights_d1, TwoFetch}.
fn bspline_weights(a: f32) -> vec4<f32> {
    let b = 1.0 - a;
    let a2 = a * a;
    let a3 = a2 * a;
    return vec4<f32>(
        b * b * b / 6.0,
        (3.0 * a3 - 6.0 * a2 + 4.0) / 6.0,
        (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) / 6.0,
        a3 / 6.0,
    );
}

fn bspline_weights_d1(a: f32) -> vec4<f32> {
    let b = 1.0 - a;
    let a2 = a * a;
    return vec4<f32>(
        -0.5 * b * b,
        0.5 * (3.0 * a2 - 4.0 * a),
        0.5 * (-3.0 * a2 + 2.0 * a + 1.0),
        0.5 * a2,
    );
}

// Per-axis taps of the 8-fetch scheme: cells c + cell[i], positions t[i], weights w[i].
struct Taps {
    cell: vec3<i32>,
    t: vec3<f32>,
    w: vec3<f32>,
    n: u32,
}

// Two fetches at i − 1 + t0 and i + 1 + t1 (TwoFetch::from_weights).
fn taps_two(w: vec4<f32>) -> Taps {
    let g0 = w.x + w.y;
    let g1 = w.z + w.w;
    return Taps(vec3<i32>(-1, 1, 0), vec3<f32>(w.y / g0, w.w / g1, 0.0), vec3<f32>(g0, g1, 0.0), 2u);
}

// Second derivative: x − 1, x, x + 1 weighted (1, −2, 1).
fn taps_three(a: f32) -> Taps {
    return Taps(vec3<i32>(-1, 0, 1), vec3<f32>(a), vec3<f32>(1.0, -2.0, 1.0), 3u);
}

fn fetch_sum(l: Located, x: Taps, y: Taps, z: Taps) -> f32 {
    var sx = 0.0;
    for (var ix = 0u; ix < x.n; ix++) {
        var sy = 0.0;
        for (var iy = 0u; iy < y.n; iy++) {
            var sz = 0.0;
            for (var iz = 0u; iz < z.n; iz++) {
                let c = l.cell + vec3<i32>(x.cell[ix], y.cell[iy], z.cell[iz]);
                let t = vec3<f32>(x.t[ix], y.t[iy], z.t[iz]);
                sz += z.w[iz] * fetch(l.base, l.side, c, t);
            }
            sy += y.w[iy] * sz;
        }
        sx += x.w[ix] * sy;
    }
    return sx;
}

fn value_at(filter_code: u32, l: Located) -> f32 {
    if (filter_code == FILTER_TRILINEAR) {
        return fetch(l.base, l.side, l.cell, l.frac);
    }
    let bx = taps_two(bspline_weights(l.frac.x));
    let by = taps_two(bspline_weights(l.frac.y));
    let bz = taps_two(bspline_weights(l.frac.z));
    return fetch_sum(l, bx, by, bz);
}

struct GradHess {
    g: vec3<f32>,
    h: mat3x3<f32>,
}

fn sample_at(i: u32, side: u32, dx: u32, dy: u32, dz: u32) -> f32 {
    return pool[i + dx + side * (dy + side * dz)];
}

// For a brick stored at half resolution the coarse derivatives are scaled back to grid
// units (raycast/cpu.rs: gradient_hessian_at).
fn gradient_hessian_at(filter_code: u32, l: Located) -> GradHess {
    let gh = stored_gradient_hessian(filter_code, l);
    if (l.half != 0u) {
        return GradHess(gh.g * 0.5, gh.h * 0.25);
    }
    return gh;
}

fn stored_gradient_hessian(filter_code: u32, l: Located) -> GradHess {
    let side = l.side;
    if (filter_code == FILTER_TRILINEAR) {
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
    let b = array<Taps, 3>(
        taps_two(bspline_weights(l.frac.x)),
        taps_two(bspline_weights(l.frac.y)),
        taps_two(bspline_weights(l.frac.z)),
    );
    let d = array<Taps, 3>(
        taps_two(bspline_weights_d1(l.frac.x)),
        taps_two(bspline_weights_d1(l.frac.y)),
        taps_two(bspline_weights_d1(l.frac.z)),
    );
    let g = vec3<f32>(
        fetch_sum(l, d[0], b[1], b[2]),
        fetch_sum(l, b[0], d[1], b[2]),
        fetch_sum(l, b[0], b[1], d[2]),
    );
    let hxx = fetch_sum(l, taps_three(l.frac.x), b[1], b[2]);
    let hyy = fetch_sum(l, b[0], taps_three(l.frac.y), b[2]);
    let hzz = fetch_sum(l, b[0], b[1], taps_three(l.frac.z));
    let hxy = fetch_sum(l, d[0], d[1], b[2]);
    let hxz = fetch_sum(l, d[0], b[1], d[2]);
    let hyz = fetch_sum(l, b[0], d[1], d[2]);
    let h = mat3x3<f32>(
        vec3<f32>(hxx, hxy, hxz),
        vec3<f32>(hxy, hyy, hyz),
        vec3<f32>(hxz, hyz, hzz),
    );
    return GradHess(g, h);
}

// A ray inside one resident block (raycast/cpu.rs: SegmentRay).
struct SegmentRay {
    o: vec3<f32>,
    d: vec3<f32>,
    cell: vec3<i32>,
    slot: u32,
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
    let a = residual(value_at(filter_code, l));
    if (U.combine == COMBINE_NONE) {
        return a;
    }
    let b = residual(value_at(filter_code, channel_b(l)));
    return combine(a, b);
}

fn residual_at(ray: SegmentRay, t: f32) -> f32 {
    samples += 1u;
    let l = locate(ray.slot, ray.cell, ray.o + t * ray.d);
    return combined_residual(U.search_filter, l);
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
    if (first_block && ra < 0.0) {
        return Segment(SEG_CAP, 0.0, 0.0, 0.0, 0.0);
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
    var wa = ra;
    var wb = rb;
    var last = 0;
    for (var s = 0u; s < U.refine_steps; s++) {
        var tm: f32;
        if ((U.flags & FLAG_SECANT) == 0u) {
            tm = 0.5 * (ta + tb);
        } else {
            tm = secant(ta, wa, tb, wb);
        }
        let rm = residual_at(ray, tm);
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

// Gradient, Hessian and id of the operand owning a hit (raycast/cpu.rs: owner_gradient_hessian).
fn owner_gradient_hessian(l: Located) -> Owned {
    if (U.combine == COMBINE_NONE) {
        let gh = gradient_hessian_at(U.shading_filter, l);
        return Owned(gh.g, gh.h, ID_SURFACE);
    }
    let lb = channel_b(l);
    if (U.combine == COMBINE_MORPH) {
        let ga = gradient_hessian_at(U.shading_filter, l);
        let gb = gradient_hessian_at(U.shading_filter, lb);
        let wa = 1.0 - U.morph_t;
        let wb = U.morph_t;
        return Owned(wa * ga.g + wb * gb.g, ga.h * wa + gb.h * wb, ID_SURFACE);
    }
    let a = residual(value_at(U.search_filter, l));
    let b = residual(value_at(U.search_filter, lb));
    if (!owner_is_b(a, b)) {
        let gh = gradient_hessian_at(U.shading_filter, l);
        return Owned(gh.g, gh.h, ID_SURFACE);
    }
    let gh = gradient_hessian_at(U.shading_filter, lb);
    if (U.combine == COMBINE_DIFFERENCE) {
        return Owned(-gh.g, gh.h * -1.0, ID_SURFACE_B);
    }
    return Owned(gh.g, gh.h, ID_SURFACE_B);
}

// The G-buffer sample at ray parameter t (raycast/cpu.rs: surface_sample).
fn surface_sample(ray: SegmentRay, t: f32) -> GPixel {
    let l = locate(ray.slot, ray.cell, ray.o + t * ray.d);
    let gh = owner_gradient_hessian(l);
    let inv = 1.0 / U.spacing;
    let position = U.origin + U.spacing * l.p;
    let depth = t * U.spacing;
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
    return Traced(true, p, RayState(vec3<i32>(0), 0.0, 0u, 0u, 0u, 0u));
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
    if (resumed) {
        cell = resume.cell;
        t_in = resume.t;
        first_block = resume.first_block != 0u;
    } else {
        let p = o + bx.t0 * d;
        let c = vec3<i32>(floor(p / f32(U.block)));
        cell = clamp(c, vec3<i32>(0), bd - vec3<i32>(1));
        t_in = bx.t0;
        first_block = true;
    }
    let dir_step = vec3<i32>(select(-1, 1, d.x > 0.0), select(-1, 1, d.y > 0.0), select(-1, 1, d.z > 0.0));
    let max_steps = U.block_dims.x + U.block_dims.y + U.block_dims.z + 3u;
    for (var n = 0u; n < max_steps; n++) {
        let ex = block_exit(cell, o, d);
        let t1 = min(ex.t, t_exit);
        let range = block_range[block_index(cell)];
        if (block_active(range)) {
            let brick = brick_of_block(cell);
            let slot = reference[brick];
            if (slot == NOT_RESIDENT) {
                atomicAdd(&counters[P.requests + brick], 1u);
                let state = RayState(cell, t_in, select(0u, 1u, first_block), 0u, 0u, 0u);
                return Traced(false, miss_pixel(), state);
            }
            atomicStore(&counters[P.used + brick], 1u);
            let ray = SegmentRay(o, d, cell, slot);
            let caps = first_block && (U.flags & FLAG_CAPS) != 0u;
            var seg = Segment(SEG_EMPTY, 0.0, 0.0, 0.0, 0.0);
            if (t1 > t_in || caps) {
                seg = march_segment(ray, t_in, max(t1, t_in), caps);
            }
            if (seg.kind == SEG_CAP) {
                return finished(cap_sample(o, d, t_in, bx.axis));
            }
            if (seg.kind == SEG_CROSSING) {
                let t = refine(ray, seg.ta, seg.ra, seg.tb, seg.rb);
                return finished(surface_sample(ray, t));
            }
        } else if (first_block && (U.flags & FLAG_CAPS) != 0u && residual(range.x) < 0.0 && residual(range.y) < 0.0) {
            return finished(cap_sample(o, d, t_in, bx.axis));
        }
        first_block = false;
        if (t1 >= t_exit) {
            break;
        }
        cell[ex.axis] += dir_step[ex.axis];
        if (cell[ex.axis] < 0 || cell[ex.axis] >= bd[ex.axis]) {
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
    var resume = RayState(vec3<i32>(0), 0.0, 1u, 0u, 0u, 0u);
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
