// Deferred shading of one G-buffer sample (002 Sec. 6.4): light_at … shade_pixel, shared by
// shade.wgsl (the ray caster's images) and splat_shade.wgsl (splat frames, with the object's
// colour). They read the module's `S` (ShadeParams: a uniform in shade.wgsl, a private copy
// with the object's colour in splat_shade.wgsl) and `lights` (array<Light>).
// Needs, anywhere in the module: const ID_*, MODE_* (from Rust); raycast_common.wgsl (GPixel,
// normalize_or_zero, signum); common/shade_structs.wgsl.
// CPU twin: crates/isokit-render/src/shade/cpu.rs (light_at … shade_pixel_color), in the
// same order.

struct LightAt {
    dir: vec3<f32>,
    color: vec3<f32>,
}

// Direction from the surface toward the light, and its colour (shade/cpu.rs: light_at).
fn light_at(l: Light, p: vec3<f32>) -> LightAt {
    if (l.point == 1u) {
        return LightAt(normalize_or_zero(l.dir - p), l.color);
    }
    if (l.point == 0u) {
        return LightAt(l.dir, l.color);
    }
    return LightAt(vec3<f32>(0.0), l.color);
}

fn smooth_step(a: f32, b: f32, x: f32) -> f32 {
    let t = clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// f32::powf with its special cases for a zero exponent and base.
fn powf(x: f32, y: f32) -> f32 {
    if (y == 0.0) {
        return 1.0;
    }
    if (x <= 0.0) {
        return 0.0;
    }
    return pow(x, y);
}

fn max_element(v: vec3<f32>) -> f32 {
    return max(max(v.x, v.y), v.z);
}

// glam's Vec3::lerp: a · (1 − t) + b · t.
fn lerp3(a: vec3<f32>, b: vec3<f32>, t: f32) -> vec3<f32> {
    return a * (1.0 - t) + b * t;
}

fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

fn diverging(x_in: f32) -> vec3<f32> {
    var x = 0.0;
    if (!is_nan(x_in)) {
        x = clamp(x_in, -1.0, 1.0);
    }
    let cold = vec3<f32>(0.10, 0.22, 0.75);
    let mid = vec3<f32>(0.85);
    let warm = vec3<f32>(0.75, 0.05, 0.05);
    if (x < 0.0) {
        return lerp3(mid, cold, -x);
    }
    return lerp3(mid, warm, x);
}

fn curvature_color(k1: f32, k2: f32, scale: f32) -> vec3<f32> {
    let s = atan2(k1 + k2, k1 - k2) * 0.63661977236758134; // 2/π
    var stops = array<vec3<f32>, 5>(
        vec3<f32>(0.05, 0.15, 0.85),
        vec3<f32>(0.05, 0.70, 0.80),
        vec3<f32>(0.15, 0.70, 0.15),
        vec3<f32>(0.90, 0.80, 0.05),
        vec3<f32>(0.85, 0.10, 0.05),
    );
    let x = min((clamp(s, -1.0, 1.0) + 1.0) * 2.0, 3.999);
    let i = u32(floor(x));
    let hue = lerp3(stops[i], stops[i + 1u], x - f32(i));
    var c = sqrt((k1 * k1 + k2 * k2) * 0.5) / scale;
    if (is_nan(c)) {
        c = 0.0;
    }
    c = clamp(c, 0.0, 1.0);
    return lerp3(vec3<f32>(0.8), hue, c);
}

fn environment(r: vec3<f32>) -> vec3<f32> {
    let e = asin(clamp(r.y, -1.0, 1.0));
    let sky = lerp3(vec3<f32>(0.55, 0.7, 0.95), vec3<f32>(0.95), smooth_step(0.0, 1.2, e));
    let ground = vec3<f32>(0.25, 0.2, 0.15);
    let base = lerp3(ground, sky, smooth_step(-0.03, 0.03, e));
    let stripe = smooth_step(-0.15, 0.15, sin(12.0 * e));
    return base * (0.35 + 0.65 * stripe);
}

fn view_curvature(s: GPixel, v: vec3<f32>) -> f32 {
    let vt = v - dot(v, s.normal) * s.normal;
    let len = sqrt(dot(vt, vt));
    if (len < 1e-6) {
        return 0.5 * (s.k1 + s.k2);
    }
    let c = dot(vt, s.dir1) / len;
    let c2 = min(c * c, 1.0);
    return s.k1 * c2 + s.k2 * (1.0 - c2);
}

fn tone(s: GPixel, n: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let cool = vec3<f32>(0.0, 0.0, 0.45) + 0.25 * S.color;
    let warm = vec3<f32>(0.45, 0.4, 0.0) + 0.55 * S.color;
    let la = light_at(lights[0], s.position);
    let t = 0.5 * (1.0 + dot(n, la.dir));
    let hv = normalize_or_zero(la.dir - v);
    let spec = S.specular * powf(max(dot(n, hv), 0.0), max(S.shininess, 1.0));
    return lerp3(cool, warm, t) + spec * la.color;
}

fn lambert(s: GPixel, n: vec3<f32>) -> f32 {
    var d = 0.0;
    for (var i = 0u; i < S.lights; i++) {
        let la = light_at(lights[i], s.position);
        d += max(dot(n, la.dir), 0.0) * max_element(la.color);
    }
    return S.ambient + (1.0 - S.ambient) * min(d, 1.0);
}

// The colour of one G-buffer sample seen along unit direction v (shade/cpu.rs: shade_pixel).
fn shade_pixel(s: GPixel, v: vec3<f32>, footprint: f32) -> vec4<f32> {
    if (s.id == ID_MISS) {
        return S.background;
    }
    let n = s.normal;
    let kappa = S.curvature_scale;
    var rgb = vec3<f32>(0.0);
    switch (S.mode) {
        case MODE_PHONG: {
            var c = S.ambient * S.color;
            for (var i = 0u; i < S.lights; i++) {
                let la = light_at(lights[i], s.position);
                let diff = max(dot(n, la.dir), 0.0);
                let hv = normalize_or_zero(la.dir - v);
                var spec = 0.0;
                if (diff > 0.0) {
                    spec = S.specular * powf(max(dot(n, hv), 0.0), S.shininess);
                }
                c += la.color * (S.color * diff + vec3<f32>(spec));
            }
            rgb = c;
        }
        case MODE_TONE: {
            rgb = tone(s, n, v);
        }
        case MODE_NORMAL: {
            rgb = 0.5 * n + vec3<f32>(0.5);
        }
        case MODE_CURVATURE: {
            rgb = curvature_color(s.k1, s.k2, kappa) * lambert(s, n);
        }
        case MODE_MEAN: {
            rgb = diverging(0.5 * (s.k1 + s.k2) / kappa) * lambert(s, n);
        }
        case MODE_GAUSSIAN: {
            let g = s.k1 * s.k2;
            rgb = diverging(signum(g) * sqrt(abs(g)) / kappa) * lambert(s, n);
        }
        case MODE_K1: {
            rgb = diverging(s.k1 / kappa) * lambert(s, n);
        }
        case MODE_K2: {
            rgb = diverging(s.k2 / kappa) * lambert(s, n);
        }
        case MODE_RIDGES: {
            let base = tone(s, n, v);
            let t = 0.5 * kappa;
            var ridge = 0.0;
            if (s.k1 > -s.k2) {
                ridge = smooth_step(t, 2.0 * t, s.k1);
            }
            var valley = 0.0;
            if (-s.k2 > s.k1) {
                valley = smooth_step(t, 2.0 * t, -s.k2);
            }
            rgb = lerp3(lerp3(base, vec3<f32>(0.6, 0.05, 0.02), ridge), vec3<f32>(0.02, 0.1, 0.55), valley);
        }
        case MODE_SILHOUETTE: {
            let base = tone(s, n, v);
            let tk = clamp(S.contour_pixels * footprint * view_curvature(s, v), 0.0, 1.0);
            let edge = sqrt(tk * (2.0 - tk));
            if ((s.id == ID_SURFACE || s.id == ID_SURFACE_B) && abs(dot(n, v)) <= edge) {
                rgb = vec3<f32>(0.02);
            } else {
                rgb = base;
            }
        }
        case MODE_ACCESSIBILITY: {
            let base = tone(s, n, v);
            rgb = base * (1.0 - 0.75 * smooth_step(0.0, kappa, -s.k1));
        }
        case MODE_REFLECTION: {
            let r = v - 2.0 * dot(v, n) * n;
            rgb = environment(r) * max(S.color, vec3<f32>(0.2)) / max(max_element(S.color), 0.2);
        }
        case MODE_TEXTURE: {
            let q = floor(s.position * (0.5 * kappa));
            let x = q.x + q.y + q.z;
            var r = x - 2.0 * trunc(x / 2.0);
            if (r < 0.0) {
                r += 2.0;
            }
            var albedo = S.color * 0.35;
            if (r >= 1.0) {
                albedo = S.color;
            }
            rgb = albedo * lambert(s, n);
        }
        // The per-pixel part of `flow`: the plain shading the LIC modulates (the entry point
        // `shade` does the rest).
        case MODE_FLOW: {
            rgb = tone(s, n, v);
        }
        default: {
            rgb = vec3<f32>(0.0);
        }
    }
    return vec4<f32>(rgb, 1.0);
}
