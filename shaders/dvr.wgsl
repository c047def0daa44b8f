// Direct volume rendering (002 Sec. 2.5.3; pre-integration after Engel, Kraus and Ertl 2001):
// emission and absorption along one ray per invocation through a 1D transfer function,
// post-classified or with pre-integrated segments, empty blocks skipped, early termination.
// Volumes on a Cartesian grid or on a spherical lattice (Westermann and Ertl 1998, Sec. 2.2:
// each sample's world position mapped to the lattice); the entry point spherical_iso finds
// the isosurface of a spherical volume.
// Prepended by Rust (isokit_render::dvr::gpu::dvr_shader): const WORKGROUP, SUB_STEPS,
// SHADE_MIN_OPACITY, SHADE_KA, SHADE_KD, SHADE_KS, SHININESS; then common/bspline.wgsl and
// common/transfer.wgsl (the transfer function, segments, shading) and common/slab.wgsl.
// CPU twin: crates/isokit-render/src/dvr/mod.rs (trace_ray and the functions it calls, named
// alike) and crates/isokit-render/src/spherical.rs (SphericalVolume's coords, keep, value,
// segment and trace_iso); the rays, the pre-integration table and the empty-block flags come
// from the host.

// Rust: dvr/gpu.rs DvrParams (176 bytes).
struct DvrParams {
    dims: vec3<u32>,
    count: u32,          // rays
    origin: vec3<f32>,   // world position of sample (0, 0, 0)
    spacing: f32,
    bmin: vec3<f32>,     // the volume's box
    step: f32,
    bmax: vec3<f32>,
    termination: f32,
    blocks: vec3<u32>,   // blocks per axis
    block: u32,          // cells per block edge; 0: no skipping
    n_tf: u32,           // transfer-function points
    preintegrated: u32,  // 1: pre-integrated segments from the table
    table_n: u32,
    stride: u32,         // invocations per row of the dispatch grid
    table_lo: f32,
    table_hi: f32,
    table_len: f32,
    shade: u32,          // Blinn-Phong shading by the gradient: 1 central differences, 2 tricubic
    clip_sign: f32,      // 0: no clip; +1 keep where the clip field is positive, -1 negative
    lattice: u32,        // 0: Cartesian (origin, spacing); 1: spherical (sph_*), dims (nr, ntheta, nphi)
    wrap: u32,           // spherical: 1 when the last azimuth cell wraps to the first sample
    wedge: u32,          // spherical: 1 when the azimuths cover a wedge only
    sph_lo: vec3<f32>,   // r0, theta0, phi0 (degrees)
    iso: f32,            // spherical_iso: the isovalue
    sph_hi: vec3<f32>,   // r1, theta1, phi1
    iso_sign: f32,       // spherical_iso: +1 inside below the isovalue, -1 above
    sph_step: vec3<f32>, // delta r, delta theta, delta phi
    sph_pad: f32,
}

@group(0) @binding(0) var<uniform> P: DvrParams;
@group(0) @binding(1) var<storage, read> volume: array<f32>;       // x fastest
@group(0) @binding(2) var<storage, read> tf: array<vec4<f32>>;     // per point: (value, sigma, 0, 0), (r, g, b, 0)
@group(0) @binding(3) var<storage, read> table: array<vec4<f32>>;  // front + n · back
@group(0) @binding(4) var<storage, read> empty: array<u32>;        // per block
@group(0) @binding(5) var<storage, read> rays: array<vec4<f32>>;   // per ray: origin, dir
@group(0) @binding(6) var<storage, read_write> out_rgba: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> out_extra: array<vec4<f32>>; // depth, samples, skipped, hit
@group(0) @binding(8) var<storage, read> clip: array<f32>;         // the clip field on the volume's lattice

// isokit_field::Grid::get_clamped.
fn sample_at(c: vec3<i32>) -> f32 {
    let hi = vec3<i32>(P.dims) - vec3<i32>(1);
    let q = clamp(c, vec3<i32>(0), hi);
    return volume[u32(q.x) + P.dims.x * (u32(q.y) + P.dims.y * u32(q.z))];
}

// Grid::get_clamped of the clip field.
fn clip_at(c: vec3<i32>) -> f32 {
    let hi = vec3<i32>(P.dims) - vec3<i32>(1);
    let q = clamp(c, vec3<i32>(0), hi);
    return clip[u32(q.x) + P.dims.x * (u32(q.y) + P.dims.y * u32(q.z))];
}

fn lerp1(a: f32, b: f32, t: f32) -> f32 {
    return a + t * (b - a);
}

const RAD: f32 = 0.017453292519943295;

// SphericalVolume::coords: radius, polar angle and azimuth from phi0 in [0, 360), degrees.
fn spherical_coords(x: vec3<f32>) -> vec3<f32> {
    let r = length(x);
    var theta = 0.0;
    if (r > 0.0) {
        theta = acos(clamp(x.z / r, -1.0, 1.0)) / RAD;
    }
    var phi = atan2(x.y, x.x) / RAD - P.sph_lo.z;
    phi = phi - 360.0 * floor(phi / 360.0);
    if (phi >= 360.0) {
        phi = 0.0;
    }
    return vec3<f32>(r, theta, phi);
}

// SphericalVolume::keep: how far inside the domain x lies (world units, positive inside).
fn spherical_keep(x: vec3<f32>) -> f32 {
    let c = spherical_coords(x);
    let r = c.x;
    let theta = c.y;
    let phi = c.z;
    var k = P.sph_hi.x - r;
    if (P.sph_lo.x > 0.0) {
        k = min(k, r - P.sph_lo.x);
    }
    if (P.sph_lo.y > 0.0) {
        k = min(k, (theta - P.sph_lo.y) * RAD * r);
    }
    if (P.sph_hi.y < 180.0) {
        k = min(k, (P.sph_hi.y - theta) * RAD * r);
    }
    if (P.wedge == 1u) {
        let span = P.sph_hi.z - P.sph_lo.z;
        let arc = r * sin(theta * RAD) * RAD;
        var inside = 0.0;
        if (phi <= span) {
            inside = min(phi, span - phi);
        } else {
            inside = -min(phi - span, 360.0 - phi);
        }
        k = min(k, inside * arc);
    }
    return k;
}

// SphericalVolume::at: r and theta clamped, phi wrapped (periodic) or clamped.
fn spherical_at(i: i32, j: i32, k: i32) -> f32 {
    let n = vec3<i32>(P.dims);
    var kk = clamp(k, 0, n.z - 1);
    if (P.wrap == 1u) {
        kk = ((k % n.z) + n.z) % n.z;
    }
    let ii = clamp(i, 0, n.x - 1);
    let jj = clamp(j, 0, n.y - 1);
    return volume[u32(ii) + P.dims.x * (u32(jj) + P.dims.y * u32(kk))];
}

// SphericalVolume::value: trilinear in the lattice's coordinates of x.
fn spherical_value(x: vec3<f32>) -> f32 {
    let c = spherical_coords(x);
    let nf = vec3<f32>(P.dims);
    let u = clamp((c.x - P.sph_lo.x) / P.sph_step.x, 0.0, nf.x - 1.0);
    let v = clamp((c.y - P.sph_lo.y) / P.sph_step.y, 0.0, nf.y - 1.0);
    var wmax = nf.z - 1.0;
    if (P.wrap == 1u) {
        wmax = nf.z;
    }
    let w = clamp(c.z / P.sph_step.z, 0.0, wmax);
    let f = floor(vec3<f32>(u, v, w));
    let a = vec3<f32>(u, v, w) - f;
    let i = i32(f.x);
    let j = i32(f.y);
    let k = i32(f.z);
    let r00 = lerp1(spherical_at(i, j, k), spherical_at(i + 1, j, k), a.x);
    let r10 = lerp1(spherical_at(i, j + 1, k), spherical_at(i + 1, j + 1, k), a.x);
    let r01 = lerp1(spherical_at(i, j, k + 1), spherical_at(i + 1, j, k + 1), a.x);
    let r11 = lerp1(spherical_at(i, j + 1, k + 1), spherical_at(i + 1, j + 1, k + 1), a.x);
    return lerp1(lerp1(r00, r10, a.y), lerp1(r01, r11, a.y), a.z);
}

// SphericalVolume::segment: where a ray is within the outer sphere; x > y when it misses.
fn sphere_segment(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    return sphere_chord(o, d, P.sph_hi.x);
}

// SphericalVolume::hole: where a ray is within the inner sphere (r0 > 0); x > y when it
// misses or there is none.
fn sphere_hole(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    if (P.lattice == 1u && P.sph_lo.x > 0.0) {
        return sphere_chord(o, d, P.sph_lo.x);
    }
    return vec2<f32>(1.0, 0.0);
}

// sphere_segment in spherical.rs: where a ray is within the sphere of radius r, from t = 0.
fn sphere_chord(o: vec3<f32>, d: vec3<f32>, r: f32) -> vec2<f32> {
    let b = dot(o, d);
    let c = dot(o, o) - r * r;
    let disc = b * b - c;
    if (!(disc > 0.0)) {
        return vec2<f32>(1.0, 0.0);
    }
    let q = sqrt(disc);
    return vec2<f32>(max(-b - q, 0.0), -b + q);
}

// isokit_field::filter::trilinear at world position x (split and fetch), or the spherical
// lattice's interpolant.
fn value_at(x: vec3<f32>) -> f32 {
    if (P.lattice == 1u) {
        return spherical_value(x);
    }
    let p = (x - P.origin) / P.spacing;
    let f = floor(p);
    let a = p - f;
    let hi = vec3<f32>(P.dims) + vec3<f32>(1.0);
    let c = vec3<i32>(min(max(f, vec3<f32>(-3.0)), hi));
    let x00 = lerp1(sample_at(c), sample_at(c + vec3<i32>(1, 0, 0)), a.x);
    let x10 = lerp1(sample_at(c + vec3<i32>(0, 1, 0)), sample_at(c + vec3<i32>(1, 1, 0)), a.x);
    let x01 = lerp1(sample_at(c + vec3<i32>(0, 0, 1)), sample_at(c + vec3<i32>(1, 0, 1)), a.x);
    let x11 = lerp1(sample_at(c + vec3<i32>(0, 1, 1)), sample_at(c + vec3<i32>(1, 1, 1)), a.x);
    return lerp1(lerp1(x00, x10, a.y), lerp1(x01, x11, a.y), a.z);
}

// Clip::keep: the clip field's trilinear value at world position x times the kept sign.
fn keep_at(x: vec3<f32>) -> f32 {
    let p = (x - P.origin) / P.spacing;
    let f = floor(p);
    let a = p - f;
    let hi = vec3<f32>(P.dims) + vec3<f32>(1.0);
    let c = vec3<i32>(min(max(f, vec3<f32>(-3.0)), hi));
    let x00 = lerp1(clip_at(c), clip_at(c + vec3<i32>(1, 0, 0)), a.x);
    let x10 = lerp1(clip_at(c + vec3<i32>(0, 1, 0)), clip_at(c + vec3<i32>(1, 1, 0)), a.x);
    let x01 = lerp1(clip_at(c + vec3<i32>(0, 0, 1)), clip_at(c + vec3<i32>(1, 0, 1)), a.x);
    let x11 = lerp1(clip_at(c + vec3<i32>(0, 1, 1)), clip_at(c + vec3<i32>(1, 1, 1)), a.x);
    return P.clip_sign * lerp1(lerp1(x00, x10, a.y), lerp1(x01, x11, a.y), a.z);
}

// kept_part: the kept fractions (a, b) of a step from the keep measure at its ends; a > b
// when nothing of it is kept.
fn kept_part(kf: f32, kb: f32) -> vec2<f32> {
    if (kf > 0.0 && kb > 0.0) {
        return vec2<f32>(0.0, 1.0);
    }
    if (!(kf > 0.0) && !(kb > 0.0)) {
        return vec2<f32>(1.0, 0.0);
    }
    if (kf > 0.0) {
        return vec2<f32>(0.0, min(kf / (kf - kb), 1.0));
    }
    let t = max(kf / (kf - kb), 0.0);
    if (t < 1.0) {
        return vec2<f32>(t, 1.0);
    }
    return vec2<f32>(1.0, 0.0);
}

// PreintegrationTable::lookup.
fn table_coord(v: f32) -> vec2<f32> {
    let n = P.table_n;
    let x = clamp((v - P.table_lo) / (P.table_hi - P.table_lo) * f32(n - 1u), 0.0, f32(n - 1u));
    let i = min(u32(x), n - 2u);
    return vec2<f32>(f32(i), x - f32(i));
}

fn table_entry(a: u32, b: u32) -> vec4<f32> {
    return table[a + P.table_n * b];
}

fn table_lookup(vf: f32, vb: f32) -> vec4<f32> {
    let cf = table_coord(vf);
    let cb = table_coord(vb);
    let i = u32(cf.x);
    let j = u32(cb.x);
    let r0 = mix(table_entry(i, j), table_entry(i + 1u, j), cf.y);
    let r1 = mix(table_entry(i, j + 1u), table_entry(i + 1u, j + 1u), cf.y);
    return mix(r0, r1, cb.y);
}

// Blocks::empty_at: the empty block holding grid point g (its lower corner, in blocks), or
// a negative x when the block there is not empty.
fn empty_block(g: vec3<f32>) -> vec3<f32> {
    let cf = min(vec3<u32>(min(max(g, vec3<f32>(0.0)), vec3<f32>(1e9))) / P.block, P.blocks - vec3<u32>(1u));
    let e = cf.x + P.blocks.x * (cf.y + P.blocks.y * cf.z);
    if (empty[e] == 0u) {
        return vec3<f32>(-1.0);
    }
    return vec3<f32>(cf);
}

// gradient: central differences one spacing apart of the interpolated value.
fn gradient(x: vec3<f32>) -> vec3<f32> {
    let h = P.spacing;
    let dx = value_at(x + vec3<f32>(1.0, 0.0, 0.0) * h) - value_at(x - vec3<f32>(1.0, 0.0, 0.0) * h);
    let dy = value_at(x + vec3<f32>(0.0, 1.0, 0.0) * h) - value_at(x - vec3<f32>(0.0, 1.0, 0.0) * h);
    let dz = value_at(x + vec3<f32>(0.0, 0.0, 1.0) * h) - value_at(x - vec3<f32>(0.0, 0.0, 1.0) * h);
    return vec3<f32>(dx, dy, dz) / (2.0 * h);
}

// dvr::tricubic_gradient: the tricubic B-spline gradient at world point x, the 64 taps
// summed in the CPU twin's order.
fn tricubic_gradient(x: vec3<f32>) -> vec3<f32> {
    let p = (x - P.origin) / P.spacing;
    let f = floor(p);
    let a = p - f;
    let hi = vec3<f32>(P.dims) + vec3<f32>(1.0);
    let c = vec3<i32>(min(max(f, vec3<f32>(-3.0)), hi));
    var wx = bspline_weights(a.x);
    var wy = bspline_weights(a.y);
    var wz = bspline_weights(a.z);
    var dx = bspline_weights_d1(a.x);
    var dy = bspline_weights_d1(a.y);
    var dz = bspline_weights_d1(a.z);
    var g = vec3<f32>(0.0);
    for (var k = 0; k < 4; k += 1) {
        for (var j = 0; j < 4; j += 1) {
            for (var i = 0; i < 4; i += 1) {
                let v = sample_at(c + vec3<i32>(i - 1, j - 1, k - 1));
                g.x += dx[i] * wy[j] * wz[k] * v;
                g.y += wx[i] * dy[j] * wz[k] * v;
                g.z += wx[i] * wy[j] * dz[k] * v;
            }
        }
    }
    return g / P.spacing;
}

// Source::keep: the spherical domain's or the clip's keep measure (one of them at most).
fn keep_of(x: vec3<f32>) -> f32 {
    if (P.lattice == 1u) {
        return spherical_keep(x);
    }
    return keep_at(x);
}

fn trace_ray(o: vec3<f32>, d: vec3<f32>, ray_index: u32) {
    var tt = slab(o, d, P.bmin, P.bmax);
    if (P.lattice == 1u) {
        tt = sphere_segment(o, d);
    }
    let t0 = tt.x;
    let t1 = tt.y;
    if (!(t0 < t1)) {
        out_rgba[ray_index] = vec4<f32>(0.0);
        out_extra[ray_index] = vec4<f32>(0.0, 0.0, 0.0, 0.0);
        return;
    }
    let step = P.step;
    let h = P.spacing;
    var c = vec3<f32>(0.0);
    var trans = 1.0;
    var depth = 0.0;
    var hit = 0.0;
    var samples = 0u;
    var skipped = 0u;
    let n = u32(max(ceil((t1 - t0) / step), 1.0));
    var k = 0u;
    var front = 0.0;
    var have_front = false;
    let pre = P.preintegrated == 1u;
    let hole = sphere_hole(o, d);
    // The keep measure at the end of the last step, which starts the next one (like front,
    // forgotten when steps are passed over).
    var keep_front = 0.0;
    var have_keep = false;
    while (k < n) {
        let s0 = t0 + f32(k) * step;
        if (hole.x < hole.y && s0 >= hole.x && s0 < hole.y) {
            // Steps wholly in the hole keep nothing: on to the step that holds its end.
            let next = u32(max(floor((hole.y - t0) / step), 0.0));
            if (next > k) {
                k = next;
                have_front = false;
                have_keep = false;
                continue;
            }
        }
        if (P.block > 0u) {
            var probe = s0;
            if (!pre) {
                probe = min(s0 + step * 0.5, t1);
            }
            let g = ((o + probe * d) - P.origin) / P.spacing;
            let cell = empty_block(g);
            if (cell.x >= 0.0) {
                let lo = cell * f32(P.block);
                let hi = lo + vec3<f32>(f32(P.block));
                let go = (o - P.origin) / P.spacing;
                let ex = slab(go, d / h, lo, hi);
                if (ex.x < ex.y) {
                    let next = u32(max(floor((ex.y - t0) / step), 0.0));
                    if (next > k) {
                        k = next;
                        have_front = false;
                        have_keep = false;
                        skipped += 1u;
                        continue;
                    }
                }
            }
        }
        let s1 = min(s0 + step, t1);
        var part = vec2<f32>(0.0, 1.0);
        if (P.clip_sign != 0.0 || P.lattice == 1u) {
            var kf = keep_front;
            if (!have_keep) {
                kf = keep_of(o + s0 * d);
            }
            let kb = keep_of(o + s1 * d);
            keep_front = kb;
            have_keep = true;
            part = kept_part(kf, kb);
            if (!(part.x < part.y)) {
                have_front = false;
                k += 1u;
                continue;
            }
        }
        let a = s0 + part.x * (s1 - s0);
        let b = s0 + part.y * (s1 - s0);
        let len = b - a;
        let clipped = part.x != 0.0 || part.y != 1.0;
        var seg: vec4<f32>;
        var sigma = 0.0;
        var vf = 0.0;
        var vb = 0.0;
        if (!pre) {
            samples += 1u;
            let ev = tf_eval(value_at(o + (0.5 * (a + b)) * d));
            sigma = ev.w;
            let alpha = 1.0 - exp(-sigma * len);
            seg = vec4<f32>(ev.xyz * alpha, alpha);
        } else {
            if (have_front) {
                vf = front;
            } else {
                samples += 1u;
                vf = value_at(o + s0 * d);
            }
            vb = value_at(o + s1 * d);
            samples += 1u;
            front = vb;
            have_front = true;
            if (clipped) {
                let va = vf + (vb - vf) * part.x;
                let vz = vf + (vb - vf) * part.y;
                vf = va;
                vb = vz;
                seg = segment(vf, vb, len);
            } else if (abs(len - P.table_len) <= 1e-6 * P.table_len) {
                seg = table_lookup(vf, vb);
            } else {
                seg = segment(vf, vb, len);
            }
        }
        if (P.shade != 0u && seg.w > SHADE_MIN_OPACITY) {
            let xm = o + (0.5 * (a + b)) * d;
            var g: vec3<f32>;
            if (P.shade == 2u) {
                g = tricubic_gradient(xm);
            } else {
                g = gradient(xm);
            }
            seg = shade_sample(seg, g, d);
        }
        c += trans * seg.xyz;
        let before = trans;
        trans *= 1.0 - seg.w;
        if (before > 0.5 && trans <= 0.5) {
            depth = a + opacity_at(!pre, sigma, vf, vb, len, 1.0 - 0.5 / before);
            hit = 1.0;
        }
        if (1.0 - trans >= P.termination) {
            break;
        }
        k += 1u;
    }
    out_rgba[ray_index] = vec4<f32>(c, 1.0 - trans);
    out_extra[ray_index] = vec4<f32>(depth, f32(samples), f32(skipped), hit);
}

@compute @workgroup_size(WORKGROUP)
fn dvr(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * P.stride;
    if (i >= P.count) {
        return;
    }
    trace_ray(rays[2u * i].xyz, rays[2u * i + 1u].xyz, i);
}

// SphericalVolume::solid: the solid's residual max(sign (f - iso), -keep) and 1 where the
// domain's term is the larger.
fn spherical_solid(x: vec3<f32>) -> vec2<f32> {
    let a = P.iso_sign * (spherical_value(x) - P.iso);
    let b = -spherical_keep(x);
    if (b > a) {
        return vec2<f32>(b, 1.0);
    }
    return vec2<f32>(a, 0.0);
}

// SphericalVolume::normal: the owner's outward gradient by central differences half a
// spacing apart (dvr::gradient), normalized (zero where it vanishes).
fn spherical_term(x: vec3<f32>, domain: bool) -> f32 {
    if (domain) {
        return -spherical_keep(x);
    }
    return P.iso_sign * spherical_value(x);
}

fn spherical_normal(x: vec3<f32>, domain: bool) -> vec3<f32> {
    let h = 0.5 * P.spacing;
    let ex = vec3<f32>(1.0, 0.0, 0.0) * h;
    let ey = vec3<f32>(0.0, 1.0, 0.0) * h;
    let ez = vec3<f32>(0.0, 0.0, 1.0) * h;
    let g = vec3<f32>(
        spherical_term(x + ex, domain) - spherical_term(x - ex, domain),
        spherical_term(x + ey, domain) - spherical_term(x - ey, domain),
        spherical_term(x + ez, domain) - spherical_term(x - ez, domain),
    ) / (2.0 * h);
    let l = length(g);
    if (!(l > 0.0)) {
        return vec3<f32>(0.0);
    }
    return g / l;
}

// SphericalVolume::trace_iso: steps from where the ray enters the outer sphere until the
// solid's residual is no longer positive, then 24 bisections. Writes (normal, domain) and
// (t, samples, 0, hit).
@compute @workgroup_size(WORKGROUP)
fn spherical_iso(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * P.stride;
    if (i >= P.count) {
        return;
    }
    // The bindings this entry point does not read, used so that both entry points share
    // one bind group layout.
    _ = tf[0];
    _ = table[0];
    _ = empty[0];
    _ = clip[0];
    let o = rays[2u * i].xyz;
    let d = rays[2u * i + 1u].xyz;
    let tt = sphere_segment(o, d);
    let t0 = tt.x;
    let t1 = tt.y;
    out_rgba[i] = vec4<f32>(0.0);
    out_extra[i] = vec4<f32>(0.0);
    if (!(t0 < t1)) {
        return;
    }
    let n = u32(max(ceil((t1 - t0) / P.step), 1.0));
    var samples = 1u;
    var found = !(spherical_solid(o + t0 * d).x > 0.0);
    var lo = t0;
    var hi = t0;
    var ta = t0;
    var k = 1u;
    let hole = sphere_hole(o, d);
    while (!found && k <= n) {
        let t = min(t0 + f32(k) * P.step, t1);
        if (hole.x < hole.y && t > hole.x && t < hole.y) {
            // The residual is positive all through the hole: on to the first sample beyond
            // it, bracketed from the sample before.
            let next = u32(ceil((hole.y - t0) / P.step));
            if (next > k) {
                k = next;
                ta = min(t0 + f32(k - 1u) * P.step, t1);
                continue;
            }
        }
        samples += 1u;
        if (!(spherical_solid(o + t * d).x > 0.0)) {
            found = true;
            lo = ta;
            hi = t;
        }
        ta = t;
        k += 1u;
    }
    if (!found) {
        out_extra[i] = vec4<f32>(0.0, f32(samples), 0.0, 0.0);
        return;
    }
    for (var it = 0u; it < 24u; it += 1u) {
        if (lo == hi) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        samples += 1u;
        if (spherical_solid(o + mid * d).x > 0.0) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let x = o + hi * d;
    let domain = spherical_solid(x).y > 0.5;
    out_rgba[i] = vec4<f32>(spherical_normal(x, domain), select(0.0, 1.0, domain));
    out_extra[i] = vec4<f32>(hi, f32(samples), 0.0, 1.0);
}
