// Quadric splatting (002 Ch. 7), the render pipeline: one instance per quadric set-up, two
// triangles over its screen box, one fragment per pixel centre in the box running the
// ray–quadric intersection; the depth test keeps the nearest hit (`Less`, instances drawn in
// scene order: ties go to the lower index, as on the CPU).
// Prepended by Rust (isokit_render::gpu::splat): const ID_*, MIN_GRADIENT, F32_MAX, NO_DIR1;
// raycast_common.wgsl (Uniforms, subpixel_ray, normalize_or_zero, is_finite, signum);
// common/curvature.wgsl (any_orthonormal, hypot, Curvature, curvature); and
// `count_hit` (an atomic add on binding 3, or nothing where fragment shaders cannot write
// storage).
// CPU twin: crates/isokit-render/src/quadric.rs (intersect and its helpers) and
// crates/isokit-render/src/splat/cpu.rs (fragment, resolve, ShadowMap::render), function by
// function in the same order of operations.

// Rust: isokit_render::quadric::QuadricSetup (#[repr(C)], 144 bytes).
struct QuadricSetup {
    inv: array<vec4<f32>, 3>, // columns of the linear part of T⁻¹, w 0
    eye_p: vec4<f32>,  // T⁻¹ eye, w 1
    diag: vec4<f32>,   // D
    hess_a: vec4<f32>, // world Hessian (xx, yy, zz, xy)
    hess_b: vec4<f32>, // world Hessian (xz, yz, 0, 0)
    bbox: vec4<f32>,   // screen box (x_min, y_min, x_max, y_max), pixels, top-left origin
    clip: vec2<f32>,   // parameter slab z_lo, z_hi
    kind: u32,         // 0 ellipsoid, 1 cylinder, 2 cone
    object: u32,       // index in the scene
}

// Rust: splat/gpu.rs SplatParams (16 bytes).
struct SplatParams {
    near: f32, // near plane along forward (View::near as f32)
    far: f32,  // frag_depth = t / far, far above every visible t
    inf: f32,  // +infinity, from the host (WGSL has no infinite literal)
    pad: f32,
}

@group(0) @binding(0) var<uniform> U: Uniforms;
@group(0) @binding(1) var<uniform> P: SplatParams;
@group(0) @binding(2) var<storage, read> setups: array<QuadricSetup>;

const HIT_SURFACE: u32 = 0u;
const HIT_CAP: u32 = 1u;
const HIT_NEAR_CUT: u32 = 2u;

// quadric.rs: QuadricHit (`ok` false for None).
struct QuadricHit {
    t: f32,
    normal: vec3<f32>,
    gradient: vec3<f32>,
    kind: u32,
    ok: bool,
}

fn no_hit() -> QuadricHit {
    return QuadricHit(0.0, vec3<f32>(0.0), vec3<f32>(0.0), HIT_SURFACE, false);
}

struct Roots {
    r1: f32,
    r2: f32,
    ok: bool,
}

// quadric.rs: solve_quadratic, a t² + 2 b t + c = 0.
fn solve_quadratic(a: f32, b: f32, c: f32) -> Roots {
    let disc = b * b - a * c;
    if (disc < 0.0) {
        return Roots(0.0, 0.0, false);
    }
    let q = -(b + signum(b) * sqrt(disc));
    if (a == 0.0) {
        if (b == 0.0) {
            return Roots(0.0, 0.0, false);
        }
        let r = -c / (2.0 * b);
        return Roots(r, r, true);
    }
    let r1 = q / a;
    var r2 = r1;
    if (q != 0.0) {
        r2 = c / q;
    }
    return Roots(min(r1, r2), max(r1, r2), true);
}

// quadric.rs: quad_form.
fn quad_form(d: vec4<f32>, x: vec4<f32>, y: vec4<f32>) -> f32 {
    return d.x * x.x * y.x + d.y * x.y * y.y + d.z * x.z * y.z + d.w * x.w * y.w;
}

// The linear part of T⁻¹ applied to a world vector (quadric.rs: the closure `m`).
fn to_param(s: QuadricSetup, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        s.inv[0].x * v.x + s.inv[1].x * v.y + s.inv[2].x * v.z,
        s.inv[0].y * v.x + s.inv[1].y * v.y + s.inv[2].y * v.z,
        s.inv[0].z * v.x + s.inv[1].z * v.y + s.inv[2].z * v.z,
    );
}

// quadric.rs: surface_gradient, T⁻ᵀ (D x) restricted to xyz.
fn surface_gradient(s: QuadricSetup, x: vec3<f32>) -> vec3<f32> {
    let g = vec3<f32>(s.diag.x * x.x, s.diag.y * x.y, s.diag.z * x.z);
    return vec3<f32>(
        s.inv[0].x * g.x + s.inv[0].y * g.y + s.inv[0].z * g.z,
        s.inv[1].x * g.x + s.inv[1].y * g.y + s.inv[1].z * g.z,
        s.inv[2].x * g.x + s.inv[2].y * g.y + s.inv[2].z * g.z,
    );
}

// quadric.rs: cap_normal.
fn cap_normal(s: QuadricSetup, sign: f32) -> vec3<f32> {
    return vec3<f32>(s.inv[0].z, s.inv[1].z, s.inv[2].z) * sign;
}

// quadric.rs: setup_hessian.
fn setup_hessian(s: QuadricSetup) -> mat3x3<f32> {
    let a = s.hess_a;
    let b = s.hess_b;
    return mat3x3<f32>(
        vec3<f32>(a.x, a.w, b.x),
        vec3<f32>(a.w, a.y, b.y),
        vec3<f32>(b.x, b.y, a.z),
    );
}

// q(t') = A t'² + 2 B t' + C (quadric.rs: the closure `q`).
fn q_at(qa: f32, qb: f32, qc: f32, t: f32) -> f32 {
    return (qa * t + 2.0 * qb) * t + qc;
}

// quadric.rs: intersect. `ortho_offset` is o − eye (zero for perspective rays).
fn intersect(s: QuadricSetup, ortho_offset: vec3<f32>, d: vec3<f32>, t_near: f32) -> QuadricHit {
    let off = to_param(s, ortho_offset);
    let bd = to_param(s, d);
    let b = vec4<f32>(bd, 0.0);
    var a = vec4<f32>(s.eye_p.x + off.x, s.eye_p.y + off.y, s.eye_p.z + off.z, 1.0);
    // Move the origin to the point nearest to the parameter-space centre (t = shift).
    let bb = b.x * b.x + b.y * b.y + b.z * b.z;
    if (!(bb > 0.0)) {
        return no_hit();
    }
    let shift = -(a.x * b.x + a.y * b.y + a.z * b.z) / bb;
    a.x += shift * b.x;
    a.y += shift * b.y;
    a.z += shift * b.z;
    // Slab interval in t' = t − shift.
    var s0 = -P.inf;
    var s1 = P.inf;
    if (s.kind != 0u) {
        if (b.z != 0.0) {
            let u0 = (s.clip.x - a.z) / b.z;
            let u1 = (s.clip.y - a.z) / b.z;
            s0 = min(u0, u1);
            s1 = max(u0, u1);
        } else if (a.z < s.clip.x || a.z > s.clip.y) {
            return no_hit();
        }
    }
    let qa = quad_form(s.diag, b, b);
    let qb = quad_form(s.diag, a, b);
    let qc = quad_form(s.diag, a, a);
    // A ray parallel to a cylinder's axis has no roots but may still pass through the caps
    // (the CPU's NaN roots: every comparison with them is false).
    let roots = solve_quadratic(qa, qb, qc);
    let r1 = roots.r1;
    let r2 = roots.r2;
    var entry = 0.0;
    var entry_cap = false;
    if (is_finite(s0) && q_at(qa, qb, qc, s0) <= 0.0) {
        entry = s0;
        entry_cap = true;
    } else if (roots.ok && r1 > s0 && r1 <= s1 && qa * r1 + qb <= 0.0) {
        entry = r1;
    } else if (roots.ok && r2 > s0 && r2 <= s1 && qa * r2 + qb <= 0.0) {
        entry = r2;
    } else {
        return no_hit();
    }
    var exit = entry;
    if (is_finite(s1) && q_at(qa, qb, qc, s1) <= 0.0) {
        exit = s1;
    } else if (roots.ok && r2 >= entry && r2 < s1 && qa * r2 + qb >= 0.0) {
        exit = r2;
    } else if (roots.ok && r1 >= entry && r1 < s1 && qa * r1 + qb >= 0.0) {
        exit = r1;
    }
    let t_entry = entry + shift;
    let t_exit = exit + shift;
    if (t_entry >= t_near) {
        var normal = vec3<f32>(0.0);
        var gradient = vec3<f32>(0.0);
        var kind = HIT_SURFACE;
        if (entry_cap) {
            // The slab face the ray enters: parameter normal ∓z.
            var sign = 1.0;
            if (b.z > 0.0) {
                sign = -1.0;
            }
            normal = cap_normal(s, sign);
            kind = HIT_CAP;
        } else {
            let x = vec3<f32>(a.x + entry * b.x, a.y + entry * b.y, a.z + entry * b.z);
            let g = 2.0 * surface_gradient(s, x);
            normal = g;
            gradient = g;
        }
        return QuadricHit(t_entry, normalize_or_zero(normal), gradient, kind, true);
    }
    if (t_exit >= t_near) {
        return QuadricHit(t_near, vec3<f32>(0.0), vec3<f32>(0.0), HIT_NEAR_CUT, true);
    }
    return no_hit();
}

// splat/cpu.rs: fragment. The ray of pixel (px, py) against one quadric.
fn fragment(s: QuadricSetup, ray: Ray) -> QuadricHit {
    var offset = vec3<f32>(0.0);
    var t_near = P.near;
    if (U.ortho != 0u) {
        offset = ray.o - U.eye;
    } else {
        t_near = P.near / dot(ray.d, U.forward);
    }
    return intersect(s, offset, ray.d, t_near);
}

// The tangent basis (u, v) of a unit normal that common/curvature.wgsl's `curvature` uses (Duff et
// al.); the host rebuilds dir1 from its angle in this basis (splat/gpu.rs: tangent_basis).
fn tangent_u(n: vec3<f32>) -> vec3<f32> {
    let sgn = signum(n.z);
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
}

fn tangent_v(n: vec3<f32>) -> vec3<f32> {
    let sgn = signum(n.z);
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, sgn + n.y * n.y * a, -n.y);
}

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) @interpolate(flat) quadric: u32,
}

// Two triangles over the set-up's box: pixel (x, y) → clip (2x/W − 1, 1 − 2y/H).
@vertex
fn vs_splat(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VOut {
    let b = setups[ii].bbox;
    // Corners (x0, y0) (x1, y0) (x0, y1), (x0, y1) (x1, y0) (x1, y1).
    let right = vi == 1u || vi == 4u || vi == 5u;
    let bottom = vi == 2u || vi == 3u || vi == 5u;
    // One pixel beyond the box, so that the rasterizer's sub-pixel precision can never drop
    // a covered pixel; `in_box` then keeps exactly the CPU's pixels (splat/cpu.rs: pixel_range).
    let x = select(b.x - 1.0, b.z + 1.0, right);
    let y = select(b.y - 1.0, b.w + 1.0, bottom);
    let ndc = vec2<f32>(2.0 * x / f32(U.width) - 1.0, 1.0 - 2.0 * y / f32(U.height));
    return VOut(vec4<f32>(ndc, 0.0, 1.0), ii);
}

// The G-buffer sample of a hit, in two colour targets (32 bytes per pixel, the WebGPU
// default limit): (N.xyz, Z) as rgba32float and (K1, K2, θ, object | id << 24) as rgba32uint
// (float bits), θ the angle of dir1 in the tangent basis of N, or NO_DIR1 where there is no
// principal direction. Position comes from the ray and Z on the host (splat/cpu.rs: resolve).
struct GOut {
    @location(0) nz: vec4<f32>,
    @location(1) kid: vec4<u32>,
    @builtin(frag_depth) depth: f32,
}

// splat/cpu.rs: pixel_range — the pixels whose centres lie in the box, the same f32 operations.
fn in_box(b: vec4<f32>, px: u32, py: u32) -> bool {
    let size = vec2<f32>(f32(U.width), f32(U.height));
    let lo = clamp(ceil(b.xy - 0.5), vec2<f32>(0.0), size);
    let hi = clamp(floor(b.zw - 0.5) + 1.0, vec2<f32>(0.0), size);
    let p = vec2<f32>(f32(px), f32(py));
    return all(p >= lo) && all(p < hi);
}

@fragment
fn fs_gbuffer(in: VOut) -> GOut {
    let px = u32(in.pos.x);
    let py = u32(in.pos.y);
    let s = setups[in.quadric];
    if (!in_box(s.bbox, px, py)) {
        discard;
    }
    let ray = subpixel_ray(px, py, 0u);
    let hit = fragment(s, ray);
    if (!hit.ok) {
        discard;
    }
    count_hit();
    // splat/cpu.rs: resolve.
    var normal = hit.normal;
    var id = ID_CAP;
    var k1 = 0.0;
    var k2 = 0.0;
    var theta = NO_DIR1;
    if (hit.kind == HIT_NEAR_CUT) {
        normal = -U.forward;
    } else if (hit.kind == HIT_SURFACE) {
        id = ID_SURFACE;
        let c = curvature(hit.gradient, setup_hessian(s));
        if (c.ok) {
            k1 = c.k1;
            k2 = c.k2;
            theta = bitcast<u32>(atan2(dot(c.dir1, tangent_v(normal)), dot(c.dir1, tangent_u(normal))));
        }
    }
    var out: GOut;
    out.nz = vec4<f32>(normal, hit.t);
    out.kid = vec4<u32>(bitcast<u32>(k1), bitcast<u32>(k2), theta, s.object | (id << 24u));
    out.depth = hit.t / P.far;
    return out;
}

// The shadow map (splat/cpu.rs: ShadowMap::render): depth along the light's axis.
struct ShadowOut {
    @location(0) depth_along: f32,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_shadow(in: VOut) -> ShadowOut {
    let px = u32(in.pos.x);
    let py = u32(in.pos.y);
    if (!in_box(setups[in.quadric].bbox, px, py)) {
        discard;
    }
    let ray = subpixel_ray(px, py, 0u);
    let hit = fragment(setups[in.quadric], ray);
    if (!hit.ok) {
        discard;
    }
    var out: ShadowOut;
    out.depth_along = hit.t * dot(ray.d, U.forward);
    out.depth = hit.t / P.far;
    return out;
}
