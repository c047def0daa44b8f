// The normal and principal curvatures of an implicit surface from its gradient and Hessian,
// in f32 (002 Sec. 6.3.4): what the ray caster's hits (raycast.wgsl: surface_sample) and the
// splatter's fragments (splat.wgsl: fs_gbuffer) share.
// Needs, anywhere in the module: const MIN_GRADIENT (from Rust); raycast_common.wgsl
// (is_finite, is_finite3, signum, normalize3); `U` (var<uniform> Uniforms), of which it
// reads inside_sign.
// CPU twin: isokit_field::curvature::curvature_with (in f64) and glam's
// Vec3::any_orthonormal_vector.

// glam's Vec3::any_orthonormal_vector (Pixar's basis).
fn any_orthonormal(n: vec3<f32>) -> vec3<f32> {
    let sgn = signum(n.z);
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, sgn + n.y * n.y * a, -n.y);
}

fn hypot(x: f32, y: f32) -> f32 {
    let m = max(abs(x), abs(y));
    if (m == 0.0) {
        return 0.0;
    }
    let a = x / m;
    let b = y / m;
    return m * sqrt(a * a + b * b);
}

struct Curvature {
    normal: vec3<f32>,
    k1: f32,
    k2: f32,
    dir1: vec3<f32>,
    ok: bool,
}

// isokit_field::curvature::curvature_with in f32 (the CPU twin works in f64): the shape
// operator in the tangent basis of Duff et al., Eq. 6.6, closed-form eigenvalues and the
// eigenvector of k1.
fn curvature(g_in: vec3<f32>, h_in: mat3x3<f32>) -> Curvature {
    let none = Curvature(vec3<f32>(0.0), 0.0, 0.0, vec3<f32>(0.0), false);
    if (!(is_finite3(g_in) && is_finite3(h_in[0]) && is_finite3(h_in[1]) && is_finite3(h_in[2]))) {
        return none;
    }
    let s = U.inside_sign;
    let g = g_in * s;
    let hs = h_in * s;
    let h = (hs + transpose(hs)) * 0.5;
    let len = hypot(hypot(g.x, g.y), g.z);
    if (!(len > MIN_GRADIENT)) {
        return none;
    }
    let n = g / len;
    // Tangent basis (u, v) with u × v = n.
    let sgn = signum(n.z);
    let a = -1.0 / (sgn + n.z);
    let b = n.x * n.y * a;
    let u = vec3<f32>(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x);
    let v = vec3<f32>(b, sgn + n.y * n.y * a, -n.y);
    let hu = h * u;
    let hv = h * v;
    let a11 = dot(u, hu) / len;
    let a22 = dot(v, hv) / len;
    let a12 = 0.5 * (dot(u, hv) + dot(v, hu)) / len;
    let t = a11 + a22;
    let disc = hypot(a11 - a22, 2.0 * a12);
    let k1 = 0.5 * (t + disc);
    let k2 = 0.5 * (t - disc);
    let theta = 0.5 * atan2(2.0 * a12, a11 - a22);
    let dir1 = normalize3(u * cos(theta) + v * sin(theta));
    let ok = is_finite(k1) && is_finite(k2) && is_finite(t) && is_finite(k1 * k2) && is_finite3(dir1);
    return Curvature(n, k1, k2, dir1, ok);
}
