// Where a ray meets an axis-aligned box, in f32 without infinities or NaN (WGSL gives them no
// defined meaning): a piece of dvr.wgsl (the volume's box, empty blocks), tets.wgsl (the
// boxes of the boundary faces' hierarchy) and segmented.wgsl. Needs nothing from its kernel.
// CPU twin: crates/isokit-render/src/dvr/mod.rs (slab).

// slab: where a ray enters and leaves a box; x > y when it misses.
fn safe_inv(x: f32) -> f32 {
    if (abs(x) < 1e-30) {
        return 1.0 / select(1e-30, -1e-30, x < 0.0);
    }
    return 1.0 / x;
}

fn slab(o: vec3<f32>, d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let inv = vec3<f32>(safe_inv(d.x), safe_inv(d.y), safe_inv(d.z));
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let n = min(a, b);
    let f = max(a, b);
    let t0 = max(max(max(n.x, n.y), n.z), 0.0);
    let t1 = min(min(f.x, f.y), f.z);
    return vec2<f32>(t0, t1);
}
