// Rendering a tetrahedral grid through its cells (004 Sec. 4: isosurfaces and volume
// rendering of unstructured tetrahedral grids), one ray per invocation, no resampling to a
// regular grid. A ray enters the grid through the nearest boundary face that faces it (found
// in a bounding-volume hierarchy of the boundary faces), then walks from cell to cell across
// shared faces; in a cell the ray's barycentric coordinates are alpha + beta t, so the value
// is linear along it and the ray leaves through the face whose coordinate falls to 0 first.
// Entry tet_iso: the first crossing of the isovalue (exact: one division per cell). Entry
// tet_dvr: each cell's segment composited front to back, one entry of the 3D pre-integration
// table over (front value, back value, length) (Engel, Kraus and Ertl 2001 Sec. 4), or
// post-classified by its middle value, or integrated on its own.
// Prepended by Rust (isokit_render::tets::gpu::tets_shader): const WORKGROUP, SUB_STEPS,
// SHADE_MIN_OPACITY, SHADE_KA, SHADE_KD, SHADE_KS, SHININESS, NO_NEIGHBOUR; then
// common/transfer.wgsl and common/slab.wgsl.
// CPU twin: crates/isokit-render/src/tets/mod.rs (Walk::walk, Walk::entry, Walk::step_across,
// cross, TetCaster::trace and cross_cell) and tets/dvr.rs (TetVolume::trace), named alike;
// the rays, each cell's inverse edge matrix (in f64, rounded to f32), the point gradients, the
// hierarchy and the table come from the host.

// Rust: tets/gpu.rs TetParams (64 bytes).
struct TetParams {
    count: u32,        // rays
    stride: u32,       // invocations per row of the dispatch grid
    cells: u32,
    nodes: u32,        // nodes of the boundary faces' hierarchy (0: no boundary face)
    iso: f32,          // tet_iso: the isovalue times the inside sign (the values are signed alike)
    smooth_normals: u32, // tet_iso: 1 the point gradients interpolated, 0 the cell's gradient
    n_tf: u32,         // tet_dvr: transfer-function points
    mode: u32,         // tet_dvr: 0 post-classified, 1 the 3D table, 2 each segment integrated
    table_at: u32,     // tet_dvr: the table's first entry in `tf`
    table_n: u32,      // entries per value axis
    table_m: u32,      // entries along the length axis
    termination: f32,  // tet_dvr: opacity at which a ray stops
    table_lo: f32,
    table_hi: f32,
    table_len: f32,    // the table's longest segment (longer ones are cut into pieces)
    shade: u32,        // tet_dvr: 1 Blinn-Phong by the interpolated point gradients
}

@group(0) @binding(0) var<uniform> P: TetParams;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>; // per point: (x, y, z, value), (gradient, 0)
@group(0) @binding(2) var<storage, read> cells: array<vec4<u32>>;  // per cell: point indices, neighbours across faces 0..3
@group(0) @binding(3) var<storage, read> frames: array<vec4<f32>>; // per cell: (p0, flag: 1 degenerate, 2 a value not finite), the rows of the inverse edge matrix
@group(0) @binding(4) var<storage, read> nodes: array<vec4<f32>>;  // per node: (min, first child or face), (max, faces; 0 inner)
@group(0) @binding(5) var<storage, read> faces: array<vec2<u32>>;  // boundary faces (cell, face) in the hierarchy's order
@group(0) @binding(6) var<storage, read> rays: array<vec4<f32>>;   // per ray: origin, unit direction
@group(0) @binding(7) var<storage, read_write> out: array<vec4<f32>>; // two per ray
// tet_dvr only (the last binding, so tet_iso's layout is bindings 0 to 7):
@group(0) @binding(8) var<storage, read> tf: array<vec4<f32>>;     // the transfer function, then the 3D table

const FAR: f32 = 3.0e38;

// FACES in tets/mod.rs: the points of face k (opposite point k), counter-clockwise from
// outside for a positively oriented cell.
fn face_point(k: u32, i: u32) -> u32 {
    var faces = array<vec3<u32>, 4>(
        vec3<u32>(1u, 2u, 3u),
        vec3<u32>(0u, 3u, 2u),
        vec3<u32>(0u, 1u, 3u),
        vec3<u32>(0u, 2u, 1u),
    );
    return faces[k][i];
}

fn point_of(c: u32, k: u32) -> vec3<f32> {
    return points[2u * cells[2u * c][k]].xyz;
}

// isokit_kdtree::triangle: lexicographic order of two points.
fn lex_less(a: vec3<f32>, b: vec3<f32>) -> bool {
    if (a.x != b.x) {
        return a.x < b.x;
    }
    if (a.y != b.y) {
        return a.y < b.y;
    }
    return a.z < b.z;
}

// isokit_kdtree::triangle::edge_function: the edge's signed volume with the ray, in the
// canonical order of its points (exactly opposite for the two faces that share the edge).
fn edge_function(o: vec3<f32>, d: vec3<f32>, x: vec3<f32>, y: vec3<f32>) -> f32 {
    if (lex_less(y, x)) {
        return -dot(d, cross(y - o, x - y));
    }
    return dot(d, cross(x - o, y - x));
}

// isokit_kdtree::triangle::ray_triangle: the ray parameter of the hit in [0, t_max], or -1.
fn ray_triangle(o: vec3<f32>, d: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, t_max: f32) -> f32 {
    let wc = edge_function(o, d, a, b);
    let wa = edge_function(o, d, b, c);
    let wb = edge_function(o, d, c, a);
    let all_pos = wa >= 0.0 && wb >= 0.0 && wc >= 0.0;
    let all_neg = wa <= 0.0 && wb <= 0.0 && wc <= 0.0;
    if (!(all_pos || all_neg)) {
        return -1.0;
    }
    if (wa + wb + wc == 0.0) {
        return -1.0;
    }
    let n = cross(b - a, c - a);
    let dn = dot(d, n);
    if (!(abs(dn) > 8.0 * 1.1920929e-7 * length(d) * length(n))) {
        return -1.0;
    }
    let t = dot(a - o, n) / dn;
    if (!(t >= 0.0 && t <= t_max)) {
        return -1.0;
    }
    return t;
}

struct Entry {
    found: bool,
    cell: u32,
    t: f32,
}

// Walk::entry: the nearest boundary face beyond t_min through which the ray enters the grid
// (towards the face's cell).
fn entry(o: vec3<f32>, d: vec3<f32>, t_min: f32) -> Entry {
    var e = Entry(false, 0u, FAR);
    if (P.nodes == 0u) {
        return e;
    }
    var stack: array<u32, 64>;
    var sp = 1u;
    stack[0] = 0u;
    while (sp > 0u) {
        sp -= 1u;
        let n = stack[sp];
        let lo = nodes[2u * n];
        let hi = nodes[2u * n + 1u];
        let span = slab(o, d, lo.xyz, hi.xyz);
        if (span.x > span.y || span.y < t_min || span.x > e.t) {
            continue;
        }
        let first = bitcast<u32>(lo.w);
        let count = bitcast<u32>(hi.w);
        if (count == 0u) {
            if (sp + 2u <= 64u) {
                stack[sp] = first;
                stack[sp + 1u] = first + 1u;
                sp += 2u;
            }
            continue;
        }
        for (var i = first; i < first + count; i += 1u) {
            let f = faces[i];
            let k = f.y;
            let a = point_of(f.x, face_point(k, 0u));
            let b = point_of(f.x, face_point(k, 1u));
            let c = point_of(f.x, face_point(k, 2u));
            let nrm = cross(b - a, c - a);
            let inward = dot(point_of(f.x, k) - a, nrm);
            let towards = dot(d, nrm);
            if (inward * towards <= 0.0) {
                continue;
            }
            let t = ray_triangle(o, d, a, b, c, e.t);
            if (t > t_min && t < e.t) {
                e = Entry(true, f.x, t);
            }
        }
    }
    return e;
}

// Crossing in tets/mod.rs: the ray's barycentric coordinates alpha + beta t in a cell, from
// t_in to t_out, leaving through the face opposite point `exit`.
struct Crossing {
    ok: bool,
    cell: u32,
    alpha: vec4<f32>,
    beta: vec4<f32>,
    t_in: f32,
    t_out: f32,
    exit: u32,
    entered: bool,
}

// cross: the ray's way through cell c from t_in; not ok for a degenerate cell or one the ray
// does not leave.
fn cross_cell(c: u32, o: vec3<f32>, d: vec3<f32>, t_in: f32, entered: bool) -> Crossing {
    var x: Crossing;
    x.ok = false;
    x.cell = c;
    x.t_in = t_in;
    x.entered = entered;
    let f0 = frames[4u * c];
    if (f0.w == 1.0) {
        return x;
    }
    let r0 = frames[4u * c + 1u].xyz;
    let r1 = frames[4u * c + 2u].xyz;
    let r2 = frames[4u * c + 3u].xyz;
    let q = o - f0.xyz;
    let a3 = vec3<f32>(dot(r0, q), dot(r1, q), dot(r2, q));
    let b3 = vec3<f32>(dot(r0, d), dot(r1, d), dot(r2, d));
    x.alpha = vec4<f32>(1.0 - (a3.x + a3.y + a3.z), a3);
    x.beta = vec4<f32>(-(b3.x + b3.y + b3.z), b3);
    var t_out = FAR;
    var exit = 4u;
    for (var k = 0u; k < 4u; k += 1u) {
        if (x.beta[k] < 0.0) {
            let t = -x.alpha[k] / x.beta[k];
            if (t < t_out) {
                t_out = t;
                exit = k;
            }
        }
    }
    if (exit == 4u) {
        return x;
    }
    x.t_out = max(t_out, t_in);
    x.exit = exit;
    x.ok = true;
    return x;
}

// Walk::step_across: the neighbour of the flat (or unleavable) cell c that the ray is inside
// of just beyond t_in, the one it stays in longest; NO_NEIGHBOUR where there is none. The
// tolerance is f32's (the CPU twin's is f64's, 1e-9).
fn step_across(c: u32, o: vec3<f32>, d: vec3<f32>, t_in: f32) -> u32 {
    let tol = 1e-6 * (1.0 + abs(t_in));
    let nb = cells[2u * c + 1u];
    var best = NO_NEIGHBOUR;
    var best_out = -FAR;
    for (var i = 0u; i < 4u; i += 1u) {
        let n = nb[i];
        if (n == NO_NEIGHBOUR) {
            continue;
        }
        let x = cross_cell(n, o, d, t_in, false);
        if (!x.ok) {
            continue;
        }
        var enter = -FAR;
        for (var k = 0u; k < 4u; k += 1u) {
            if (x.beta[k] > 0.0) {
                enter = max(enter, -x.alpha[k] / x.beta[k]);
            }
        }
        // >=: of equal exits the last, as the CPU twin's max_by keeps it.
        if (enter <= t_in + tol && x.t_out > t_in + tol && x.t_out >= best_out) {
            best = n;
            best_out = x.t_out;
        }
    }
    return best;
}

// Walk's state between two crossings.
struct Walker {
    o: vec3<f32>,
    d: vec3<f32>,
    t_min: f32,
    cell: u32,
    t_in: f32,
    entered: bool,
    in_grid: bool,
    done: bool,
    visited: u32,
}

fn walker(o: vec3<f32>, d: vec3<f32>) -> Walker {
    return Walker(o, d, 0.0, 0u, 0.0, false, false, false, 0u);
}

// Walk::walk, one crossing at a time: the next cell the ray crosses (not ok when the walk
// has ended). Where the walk leaves the grid it goes on from the next boundary face beyond;
// a flat cell is stepped across; the walk is bounded by the cell count against rounding
// loops.
fn next_crossing(w: ptr<function, Walker>) -> Crossing {
    var none: Crossing;
    none.ok = false;
    loop {
        if ((*w).done) {
            return none;
        }
        if (!(*w).in_grid) {
            let e = entry((*w).o, (*w).d, (*w).t_min);
            if (!e.found) {
                (*w).done = true;
                return none;
            }
            (*w).cell = e.cell;
            (*w).t_in = e.t;
            (*w).entered = true;
            (*w).in_grid = true;
        }
        (*w).visited += 1u;
        if ((*w).visited > 4u * P.cells + 64u) {
            (*w).done = true;
            return none;
        }
        let c = (*w).cell;
        let x = cross_cell(c, (*w).o, (*w).d, (*w).t_in, (*w).entered);
        if (!x.ok) {
            let n = step_across(c, (*w).o, (*w).d, (*w).t_in);
            if (n != NO_NEIGHBOUR) {
                (*w).cell = n;
            } else {
                (*w).t_min = (*w).t_in;
                (*w).in_grid = false;
            }
            continue;
        }
        (*w).t_min = x.t_out;
        let n = cells[2u * c + 1u][x.exit];
        if (n == NO_NEIGHBOUR) {
            (*w).in_grid = false;
        } else {
            (*w).cell = n;
            (*w).t_in = x.t_out;
            (*w).entered = false;
        }
        return x;
    }
    return none;
}

fn cell_values(c: u32) -> vec4<f32> {
    let idx = cells[2u * c];
    return vec4<f32>(points[2u * idx.x].w, points[2u * idx.y].w, points[2u * idx.z].w, points[2u * idx.w].w);
}

// Crossing::value: the linear interpolant of the point values v at ray parameter t.
fn value_at(x: Crossing, v: vec4<f32>, t: f32) -> f32 {
    var s = 0.0;
    for (var k = 0u; k < 4u; k += 1u) {
        s += (x.alpha[k] + x.beta[k] * t) * v[k];
    }
    return s;
}

// interpolated_gradient: the point gradients interpolated with the barycentric coordinates
// alpha + beta t.
fn interpolated_gradient(x: Crossing, t: f32) -> vec3<f32> {
    let idx = cells[2u * x.cell];
    var g = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k += 1u) {
        g += points[2u * idx[k] + 1u].xyz * clamp(x.alpha[k] + x.beta[k] * t, 0.0, 1.0);
    }
    return g;
}

// cell_gradient: the gradient of the linear interpolant, sum of v_k - v_0 times the rows of
// the inverse edge matrix.
fn cell_gradient(c: u32, v: vec4<f32>) -> vec3<f32> {
    return frames[4u * c + 1u].xyz * (v.y - v.x) + frames[4u * c + 2u].xyz * (v.z - v.x)
        + frames[4u * c + 3u].xyz * (v.w - v.x);
}

fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    if (l > 0.0) {
        return v / l;
    }
    return vec3<f32>(0.0);
}

fn ray_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * P.stride;
}

// TetCaster::trace: out[2 i] = (t, 1 when hit, cells visited, 0), out[2 i + 1] = (normal, 0).
@compute @workgroup_size(WORKGROUP)
fn tet_iso(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ray_index(id);
    if (i >= P.count) {
        return;
    }
    let o = rays[2u * i].xyz;
    let d = rays[2u * i + 1u].xyz;
    var w = walker(o, d);
    // Inside or not where the ray enters a cell, as the cell before saw it at its exit.
    var known = false;
    var inside = false;
    var hit = vec4<f32>(0.0);
    var normal = vec3<f32>(0.0);
    loop {
        let x = next_crossing(&w);
        if (!x.ok) {
            break;
        }
        if (x.entered) {
            known = false;
        }
        // A value that is not finite: no surface here, and the side unknown after it.
        if (frames[4u * x.cell].w == 2.0) {
            known = false;
            continue;
        }
        let v = cell_values(x.cell);
        let f_in = value_at(x, v, x.t_in) - P.iso;
        let f_out = value_at(x, v, x.t_out) - P.iso;
        var inside_in = f_in < 0.0;
        if (known) {
            inside_in = inside;
        }
        if (inside_in == (f_out < 0.0)) {
            known = true;
            inside = f_out < 0.0;
            continue;
        }
        var t = x.t_in;
        if ((f_in < 0.0) == inside_in) {
            t = clamp(x.t_in + f_in / (f_in - f_out) * (x.t_out - x.t_in), x.t_in, x.t_out);
        }
        let sm = interpolated_gradient(x, t);
        if (P.smooth_normals == 1u && dot(sm, sm) > 0.0) {
            normal = normalize(sm);
        } else {
            normal = normalize_or_zero(cell_gradient(x.cell, v));
        }
        hit = vec4<f32>(t, 1.0, 0.0, 0.0);
        break;
    }
    out[2u * i] = vec4<f32>(hit.x, hit.y, f32(w.visited), 0.0);
    out[2u * i + 1u] = vec4<f32>(normal, 0.0);
}

// PreintegrationTable3::lookup (table_cell for each axis).
fn table3_cell(x: f32, n: u32) -> vec2<f32> {
    let y = clamp(x, 0.0, f32(n - 1u));
    let i = min(u32(y), n - 2u);
    return vec2<f32>(f32(i), y - f32(i));
}

fn table3_entry(a: u32, b: u32, c: u32) -> vec4<f32> {
    return tf[P.table_at + a + P.table_n * (b + P.table_n * c)];
}

fn table3_lookup(vf: f32, vb: f32, len: f32) -> vec4<f32> {
    let scale = f32(P.table_n - 1u) / (P.table_hi - P.table_lo);
    let ci = table3_cell((vf - P.table_lo) * scale, P.table_n);
    let cj = table3_cell((vb - P.table_lo) * scale, P.table_n);
    let ck = table3_cell(len / P.table_len * f32(P.table_m - 1u), P.table_m);
    let i = u32(ci.x);
    let j = u32(cj.x);
    let k = u32(ck.x);
    var planes: array<vec4<f32>, 2>;
    for (var m = 0u; m < 2u; m += 1u) {
        let r0 = mix(table3_entry(i, j, k + m), table3_entry(i + 1u, j, k + m), ci.y);
        let r1 = mix(table3_entry(i, j + 1u, k + m), table3_entry(i + 1u, j + 1u, k + m), ci.y);
        planes[m] = mix(r0, r1, cj.y);
    }
    return mix(planes[0], planes[1], ck.y);
}

// TetVolume::trace: out[2 i] = premultiplied colour and opacity, out[2 i + 1] = (depth where
// the opacity passes 0.5, segments, 0, 1 when it does).
@compute @workgroup_size(WORKGROUP)
fn tet_dvr(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ray_index(id);
    if (i >= P.count) {
        return;
    }
    let o = rays[2u * i].xyz;
    let d = rays[2u * i + 1u].xyz;
    var w = walker(o, d);
    var c = vec3<f32>(0.0);
    var trans = 1.0;
    var depth = 0.0;
    var passed = 0.0;
    var segments = 0u;
    var max_len = FAR;
    if (P.mode == 1u) {
        max_len = P.table_len;
    }
    var stop = false;
    loop {
        if (stop) {
            break;
        }
        let x = next_crossing(&w);
        if (!x.ok) {
            break;
        }
        let v = cell_values(x.cell);
        let len = x.t_out - x.t_in;
        if (frames[4u * x.cell].w == 2.0 || !(len > 0.0)) {
            continue;
        }
        segments += 1u;
        let v_in = value_at(x, v, x.t_in);
        let v_out = value_at(x, v, x.t_out);
        // The gradient at the segment's middle, for a shaded image only.
        var g = vec3<f32>(0.0);
        if (P.shade == 1u) {
            g = interpolated_gradient(x, 0.5 * (x.t_in + x.t_out));
        }
        var pieces = 1u;
        if (len > max_len) {
            pieces = u32(min(ceil(len / max_len), 1e6));
        }
        let piece = len / f32(pieces);
        for (var k = 0u; k < pieces; k += 1u) {
            let vf = v_in + (v_out - v_in) * (f32(k) / f32(pieces));
            let vb = v_in + (v_out - v_in) * (f32(k + 1u) / f32(pieces));
            var seg: vec4<f32>;
            var sigma = -1.0;
            if (P.mode == 0u) {
                let e = tf_eval(0.5 * (vf + vb));
                sigma = e.w;
                let a = 1.0 - exp(-sigma * piece);
                seg = vec4<f32>(e.xyz * a, a);
            } else if (P.mode == 1u) {
                seg = table3_lookup(vf, vb, piece);
            } else {
                seg = segment(vf, vb, piece);
            }
            if (P.shade == 1u && seg.w > SHADE_MIN_OPACITY) {
                seg = shade_sample(seg, g, d);
            }
            c += trans * seg.xyz;
            let before = trans;
            trans *= 1.0 - seg.w;
            if (before > 0.5 && trans <= 0.5) {
                let alpha = 1.0 - 0.5 / before;
                var into = 0.0;
                if (P.mode == 1u) {
                    // Bisection on the table's own entries.
                    var lo = 0.0;
                    var hi = 1.0;
                    for (var it = 0u; it < 24u; it += 1u) {
                        let m = 0.5 * (lo + hi);
                        if (table3_lookup(vf, vf + (vb - vf) * m, piece * m).w >= alpha) {
                            hi = m;
                        } else {
                            lo = m;
                        }
                    }
                    into = hi * piece;
                } else {
                    into = opacity_at(P.mode == 0u, sigma, vf, vb, piece, alpha);
                }
                depth = x.t_in + f32(k) * piece + into;
                passed = 1.0;
            }
            if (1.0 - trans >= P.termination) {
                stop = true;
                break;
            }
        }
    }
    out[2u * i] = vec4<f32>(c, 1.0 - trans);
    out[2u * i + 1u] = vec4<f32>(depth, f32(segments), 0.0, passed);
}
