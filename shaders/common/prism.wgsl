// Prism scan conversion: the prism record and the distance in a triangle's local frame.
// CPU twin: crates/isokit-prism/src/local.rs (distance2) and src/scan/cpu.rs (row_span,
// sample_key), written to be read side by side with this file.

// One triangle's bounding polyhedron on the grid (Rust: isokit_prism::GpuPrism, 320 bytes).
struct Prism {
    planes: array<vec4<f32>, 5>, // n.xyz · (q - base) >= w: three sides, two caps
    base: vec4<i32>,             // anchor lattice point; w = triangle index
    frac: vec4<f32>,             // local origin - base (grid units)
    axis_r: vec4<f32>,
    axis_s: vec4<f32>,
    axis_t: vec4<f32>,
    shape: vec4<f32>,            // a, b, h (grid units)
    inv: vec4<f32>,              // 1/(a^2+h^2), 1/(b^2+h^2)
    normals: array<vec4<f32>, 6>, // pseudonormals of AB, BC, CA, A, B, C (local frame)
    lo: vec4<i32>,               // bounding box, inclusive
    hi: vec4<i32>,
}

struct DistFeature {
    d2: f32,
    feature: u32, // 0 AB, 1 BC, 2 CA, 3 A, 4 B, 5 C, 6 face
}

// 002 Listing 4.1 with the corrected s' (see local.rs), branch-free.
fn prism_distance2(r: f32, s: f32, t: f32, a: f32, b: f32, h: f32, inv_a: f32, inv_b: f32) -> DistFeature {
    // Reflect to the half r >= 0.
    let left = r < 0.0;
    let rr = abs(r);
    let aa = select(a, b, left);
    let inv = select(inv_a, inv_b, left);
    // Second frame along the hypotenuse from C to (aa, 0).
    let r2 = (aa * rr - h * s + h * h) * inv;
    let s2 = (h * rr + aa * s - aa * h) * inv;
    let len2 = aa * aa + h * h;
    // Clamp the components of the vector to the closest point.
    let dr2 = max(max(-r2, r2 - 1.0), 0.0);
    let ds2 = max(s2, 0.0);
    let dr = max(rr - aa, 0.0);
    let below = s < 0.0 || inv <= 0.0;
    let d2 = select((dr2 * dr2 + ds2 * ds2) * len2, dr * dr + s * s, below) + t * t;
    // The closest feature (for the pseudonormal sign).
    let corner_ab = select(3u, 4u, left);
    let side = select(2u, 1u, left);
    let above = select(select(select(6u, side, s2 > 0.0), corner_ab, r2 > 1.0), 5u, r2 < 0.0);
    let feature = select(above, select(0u, corner_ab, rr > aa), below);
    return DistFeature(d2, feature);
}

// A point of feature `f` in the local frame (the face's is the origin).
fn feature_point(f: u32, a: f32, b: f32, h: f32) -> vec3<f32> {
    let c = vec3<f32>(0.0, h, 0.0);
    let pa = vec3<f32>(a, 0.0, 0.0);
    let pb = vec3<f32>(-b, 0.0, 0.0);
    let ab = select(select(vec3<f32>(0.0), pb, f == 4u), pa, f == 0u || f == 3u);
    return select(ab, c, f == 1u || f == 2u || f == 5u);
}

// The samples i of row (j, k) inside the prism, as [first, last] (empty when last < first).
fn row_span(p: Prism, j: i32, k: i32) -> vec2<i32> {
    let dj = f32(j - p.base.y);
    let dk = f32(k - p.base.z);
    let lo_box = f32(p.lo.x - p.base.x);
    let hi_box = f32(p.hi.x - p.base.x);
    var lo = lo_box;
    var hi = hi_box;
    for (var m = 0u; m < 5u; m++) {
        let pl = p.planes[m];
        let rhs = pl.w - pl.y * dj - pl.z * dk;
        if (pl.x > 0.0) {
            lo = max(lo, rhs / pl.x);
        } else if (pl.x < 0.0) {
            hi = min(hi, rhs / pl.x);
        } else if (rhs > 0.0) {
            hi = lo_box - 1.0;
        }
    }
    lo = min(lo, hi_box + 1.0);
    hi = max(hi, lo_box - 1.0);
    return vec2<i32>(i32(ceil(lo)) + p.base.x, i32(floor(hi)) + p.base.x);
}

// The packed value of sample (i, j, k) for prism p: |d| in grid units (its f32 bits, which
// order like the values) shifted left once, the sign in bit 0. The smallest key wins, so the
// smallest |d| wins and a tie goes to the positive value, in any order of writes.
fn sample_key(p: Prism, i: i32, j: i32, k: i32, signed: bool) -> u32 {
    let q = vec3<f32>(f32(i - p.base.x), f32(j - p.base.y), f32(k - p.base.z)) - p.frac.xyz;
    let r = dot(p.axis_r.xyz, q);
    let s = dot(p.axis_s.xyz, q);
    let t = dot(p.axis_t.xyz, q);
    let df = prism_distance2(r, s, t, p.shape.x, p.shape.y, p.shape.z, p.inv.x, p.inv.y);
    let slot = min(df.feature, 5u);
    let side_feature = dot(p.normals[slot].xyz, vec3<f32>(r, s, t) - feature_point(df.feature, p.shape.x, p.shape.y, p.shape.z));
    let side = select(side_feature, t, df.feature == 6u);
    let negative = signed && side < 0.0;
    return (bitcast<u32>(sqrt(df.d2)) << 1u) | select(0u, 1u, negative);
}
