// The cubic B-spline weights of samples i − 1 .. i + 2 at fraction a of the cell and their
// first and second derivatives (ERRATA 2, 3), shared by raycast.wgsl (the ray caster's
// tricubic search, normals and curvature) and dvr.wgsl (the shading gradient).
// CPU twin: crates/isokit-render/src/raycast/cpu.rs (bspline4, bspline4_d1, bspline4_d2).

fn bspline_weights(a: f32) -> vec4<f32> {
    let sixth = 1.0 / 6.0;
    let b = 1.0 - a;
    let a2 = a * a;
    let a3 = a2 * a;
    return vec4<f32>(
        b * b * b * sixth,
        (3.0 * a3 - 6.0 * a2 + 4.0) * sixth,
        (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) * sixth,
        a3 * sixth,
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

fn bspline_weights_d2(a: f32) -> vec4<f32> {
    return vec4<f32>(1.0 - a, 3.0 * a - 2.0, 1.0 - 3.0 * a, a);
}
