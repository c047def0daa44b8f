// The transfer function on the GPU (002 Sec. 2.5.3; pre-integration after Engel, Kraus and
// Ertl 2001): evaluation, one segment integrated through its pieces, the distance into a
// segment at which its opacity reaches a level, and the two-sided Blinn-Phong shading of a
// composited sample. A piece of dvr.wgsl and tets.wgsl.
// Needs from its kernel: `tf` (a storage array of vec4<f32>, two per control point:
// (value, sigma, 0, 0), (r, g, b, 0)), the uniform `P` with the member `n_tf` (the control
// points), and the constants SUB_STEPS, SHADE_KA, SHADE_KD, SHADE_KS, SHININESS.
// CPU twin: crates/isokit-render/src/dvr/mod.rs (TransferFunction::eval,
// TransferFunction::segment, Within::opacity_at, shade_sample).

fn tf_value(i: u32) -> f32 {
    return tf[2u * i].x;
}

fn tf_sigma(i: u32) -> f32 {
    return tf[2u * i].y;
}

fn tf_emission(i: u32) -> vec3<f32> {
    return tf[2u * i + 1u].xyz;
}

// TransferFunction::eval: emission (xyz) and extinction (w) at v.
fn tf_eval(v: f32) -> vec4<f32> {
    var i = 0u;
    while (i < P.n_tf && tf_value(i) <= v) {
        i += 1u;
    }
    if (i == 0u) {
        return vec4<f32>(tf_emission(0u), tf_sigma(0u));
    }
    if (i == P.n_tf) {
        return vec4<f32>(tf_emission(i - 1u), tf_sigma(i - 1u));
    }
    let t = (v - tf_value(i - 1u)) / (tf_value(i) - tf_value(i - 1u));
    let e = mix(tf_emission(i - 1u), tf_emission(i), t);
    return vec4<f32>(e, tf_sigma(i - 1u) + (tf_sigma(i) - tf_sigma(i - 1u)) * t);
}

// One window [w0, w1] of TransferFunction::segment, composited onto (c, trans).
fn segment_window(vf: f32, vb: f32, len: f32, w0: f32, w1: f32, acc: vec4<f32>) -> vec4<f32> {
    var c = acc.xyz;
    var trans = acc.w;
    let n = SUB_STEPS;
    for (var k = 0u; k < n; k += 1u) {
        let t0 = w0 + (w1 - w0) * f32(k) / f32(n);
        let t1 = w0 + (w1 - w0) * f32(k + 1u) / f32(n);
        let depth = 0.5 * (tf_eval(vf + (vb - vf) * t0).w + tf_eval(vf + (vb - vf) * t1).w)
            * (t1 - t0) * len;
        if (depth <= 0.0) {
            continue;
        }
        let alpha = 1.0 - exp(-depth);
        c += trans * alpha * tf_eval(vf + (vb - vf) * (0.5 * (t0 + t1))).xyz;
        trans *= 1.0 - alpha;
    }
    return vec4<f32>(c, trans);
}

// TransferFunction::segment: premultiplied colour and opacity of a segment of length len
// along which the value goes linearly from vf to vb, through the transfer function's
// pieces in ascending order of the segment parameter.
fn segment(vf: f32, vb: f32, len: f32) -> vec4<f32> {
    var acc = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    var prev = 0.0;
    if (vb != vf) {
        for (var m = 0u; m < P.n_tf; m += 1u) {
            // Control points in ascending order of t: ascending values when vb > vf.
            var q = m;
            if (vb < vf) {
                q = P.n_tf - 1u - m;
            }
            let t = (tf_value(q) - vf) / (vb - vf);
            if (t > 0.0 && t < 1.0) {
                acc = segment_window(vf, vb, len, prev, t, acc);
                prev = t;
            }
        }
    }
    acc = segment_window(vf, vb, len, prev, 1.0, acc);
    return vec4<f32>(acc.xyz, 1.0 - acc.w);
}

// Within::opacity_at: the distance into a step of length len at which its opacity reaches
// alpha; sigma >= 0 for a post-classified step, else the pre-integrated one from vf to vb.
fn opacity_at(post: bool, sigma: f32, vf: f32, vb: f32, len: f32, alpha: f32) -> f32 {
    if (post) {
        if (sigma > 0.0) {
            return min(-log(1.0 - alpha) / sigma, len);
        }
        return len;
    }
    var lo = 0.0;
    var hi = 1.0;
    for (var it = 0u; it < 24u; it += 1u) {
        let t = 0.5 * (lo + hi);
        if (segment(vf, vf + (vb - vf) * t, len * t).w >= alpha) {
            hi = t;
        } else {
            lo = t;
        }
    }
    return hi * len;
}

// shade_sample: two-sided Blinn-Phong by a headlight.
fn shade_sample(seg: vec4<f32>, g: vec3<f32>, dir: vec3<f32>) -> vec4<f32> {
    let len = length(g);
    if (!(len > 1e-20)) {
        return seg;
    }
    let ndl = abs(dot(g, dir) / len);
    var spec = ndl;
    var p = 1u;
    while (p < SHININESS) {
        spec *= spec;
        p *= 2u;
    }
    return vec4<f32>(seg.xyz * (SHADE_KA + SHADE_KD * ndl) + vec3<f32>(SHADE_KS * spec * seg.w), seg.w);
}
