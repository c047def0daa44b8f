// Prism scan conversion of one slab of z-slices (002 Sec. 4.2.3), compute version.
// One workgroup per active prism; its threads share the prism's rows (j, k) in the slab and
// walk each row's span, keeping the smallest packed key per sample with atomicMin.
// Prepended by Rust: const WORKGROUP: u32; the contents of common/prism.wgsl.
// CPU twin: crates/isokit-prism/src/scan/cpu.rs (scan_slab); host code: src/scan/gpu.rs.

// Rust: scan/gpu.rs Params (32 bytes).
struct Params {
    slab: vec4<i32>,   // first slice, last slice, nx, ny
    counts: vec4<u32>, // active prisms, signed (0/1), workgroups along x, unused
}

@group(0) @binding(0) var<storage, read> prisms: array<Prism>;
@group(0) @binding(1) var<storage, read> work: array<u32>;
@group(0) @binding(2) var<storage, read_write> keys: array<atomic<u32>>;
@group(0) @binding(3) var<uniform> params: Params;

@compute @workgroup_size(WORKGROUP)
fn scan(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let g = wg.x + wg.y * params.counts.z;
    if (g >= params.counts.x) {
        return;
    }
    let p = prisms[work[g]];
    let k0 = max(p.lo.z, params.slab.x);
    let k1 = min(p.hi.z, params.slab.y);
    let nj = p.hi.y - p.lo.y + 1;
    let nk = k1 - k0 + 1;
    if (nj <= 0 || nk <= 0) {
        return;
    }
    let nx = u32(params.slab.z);
    let ny = u32(params.slab.w);
    let signed = params.counts.y != 0u;
    let rows = u32(nj) * u32(nk);
    for (var row = lid; row < rows; row += WORKGROUP) {
        let j = p.lo.y + i32(row % u32(nj));
        let k = k0 + i32(row / u32(nj));
        let span = row_span(p, j, k);
        let row_base = nx * (u32(j) + ny * u32(k - params.slab.x));
        for (var i = span.x; i <= span.y; i++) {
            atomicMin(&keys[row_base + u32(i)], sample_key(p, i, j, k, signed));
        }
    }
}
