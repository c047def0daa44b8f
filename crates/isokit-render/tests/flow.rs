//! The `flow` shading mode (curvature-aligned flow, 002 Sec. 6.4): the line integral
//! convolution on synthetic direction fields (exact box-filter properties along rows and
//! columns, the sign ambiguity, streamlines stopping at misses and other ids, umbilics),
//! and on a rendered cylinder (the texture runs around it: far smoother along the
//! circumferential screen direction than across it).
//!
//! On both twins ([`common::twin`]: the CPU twin and, where an adapter exists, the GPU
//! twin): the sign ambiguity and the umbilic fallback as shaded images (each twin's own
//! LIC), the refusal of multi-view G-buffers, and the cylinder (each twin's G-buffer).
//! CPU-only: the properties of the CPU twin's LIC functions (`flow_image`, `flow_lic`,
//! `flow_field`, `flow_direction`: the box filters, stopping streamlines, the projected
//! field; the host projects the field for both twins, and `gpu.rs` compares the GPU's LIC
//! pass with `flow_image` on rendered scenes) and the mode's name.

use glam::Vec3;
use isokit_field::Camera;
use isokit_render::kernel::{GSample, ID_CAP, ID_MISS, ID_SURFACE};
use isokit_render::shade::{
    FLOW_STEPS, FlowPixel, flow_field, flow_image, flow_lic, flow_modulate, flow_noise,
};
use isokit_render::{GBuffer, RenderOptions, Shading, ShadingMode, Uniforms, camera_uniforms};

mod common;
use common::twin::{Twin, raycast_tol, twins};
use common::*;

const L: i64 = FLOW_STEPS as i64;

/// An orthographic camera looking down −z (right = +x, up = +y), `w`×`h` pixels.
fn ortho_uniforms(w: u32, h: u32) -> Uniforms {
    let cam = orthographic(Vec3::Z * 3.0, Vec3::ZERO, 2.0, w, h);
    let u = camera_uniforms(&cam).unwrap();
    assert_eq!(u.right, [1.0, 0.0, 0.0]);
    assert_eq!(u.up, [0.0, 1.0, 0.0]);
    u
}

/// A surface sample facing the camera with principal direction `dir1` (`k1 = 1, k2 = 0`).
fn sample(dir1: Vec3) -> GSample {
    GSample {
        position: Vec3::ZERO,
        depth: 3.0,
        normal: Vec3::Z,
        k1: 1.0,
        k2: 0.0,
        dir1,
        id: ID_SURFACE,
    }
}

fn gbuffer(w: u32, h: u32, f: impl Fn(u32, u32) -> GSample) -> GBuffer {
    let px = (0..w * h).map(|i| f(i % w, i / w)).collect();
    GBuffer::new(w, h, px, vec![0; (w * h) as usize])
}

fn sh() -> Shading {
    Shading {
        mode: ShadingMode::Flow,
        ..Default::default()
    }
}

fn lic_of(g: &GBuffer) -> Vec<f32> {
    let u = ortho_uniforms(g.width(), g.height());
    flow_image(g, &u, &sh()).unwrap()
}

/// The mean noise over pixels `(x, y)` for `x` in `xs`, in f64.
fn mean_noise(xs: impl Iterator<Item = (u32, u32)>) -> f64 {
    let v: Vec<f64> = xs.map(|(x, y)| f64::from(flow_noise(x, y))).collect();
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn flow_is_a_mode_with_the_last_code() {
    assert_eq!("flow".parse::<ShadingMode>().unwrap(), ShadingMode::Flow);
    assert_eq!(ShadingMode::Flow.name(), "flow");
    assert_eq!(ShadingMode::ALL.last().unwrap().1, ShadingMode::Flow);
    assert_eq!(ShadingMode::ALL[12].0, "texture");
}

/// The field projects `dir1`: x on screen to the right, y up to −y (rows run down).
#[test]
fn the_field_is_the_screen_projection_of_dir1() {
    let u = ortho_uniforms(4, 2);
    let g = gbuffer(4, 2, |x, _| match x {
        0 => sample(Vec3::X),
        1 => sample(Vec3::new(0.6, 0.8, 0.0)),
        2 => sample(Vec3::Z), // along the view: undefined
        _ => GSample::default(),
    });
    let f = flow_field(&g, &u, &sh());
    assert_eq!(f[0].dir, [1.0, 0.0]);
    assert!((f[1].dir[0] - 0.6).abs() < 1e-6 && (f[1].dir[1] + 0.8).abs() < 1e-6);
    assert_eq!(f[0].key, ID_SURFACE);
    assert_eq!(f[2], FlowPixel::default());
    assert_eq!(f[3].key, ID_MISS);
}

/// A uniform horizontal field: each streamline is the row segment `[x − L, x + L]` (where
/// it fits), so LIC(x) − LIC(x + 1) = (noise(x − L) − noise(x + L + 1)) / (2L + 1), and
/// near the border the box is cut.
#[test]
fn horizontal_field_is_a_box_filter_along_rows() {
    let (w, h) = (64u32, 6u32);
    let lic = lic_of(&gbuffer(w, h, |_, _| sample(Vec3::X)));
    let at = |x: i64, y: u32| lic[(x as u32 + w * y) as usize];
    let n = (2 * L + 1) as f32;
    for y in 0..h {
        for x in L..(w as i64 - L - 1) {
            let d = at(x, y) - at(x + 1, y);
            let e = (flow_noise((x - L) as u32, y) - flow_noise((x + L + 1) as u32, y)) / n;
            assert!((d - e).abs() < 1e-6, "({x}, {y}): {d} vs {e}");
            let m = mean_noise(((x - L)..=(x + L)).map(|i| (i as u32, y)));
            assert!((f64::from(at(x, y)) - m).abs() < 1e-6);
        }
        // At the left border the box holds [0, L] only.
        let m = mean_noise((0..=L).map(|i| (i as u32, y)));
        assert!((f64::from(at(0, y)) - m).abs() < 1e-6);
    }
    // Not constant across rows: the streamlines do not mix rows.
    assert!((0..w).any(|x| lic[x as usize] != lic[(x + w) as usize]));
}

/// A uniform vertical field (`dir1` = up): the same along columns.
#[test]
fn vertical_field_is_a_box_filter_along_columns() {
    let (w, h) = (5u32, 60u32);
    let lic = lic_of(&gbuffer(w, h, |_, _| sample(Vec3::Y)));
    let at = |x: u32, y: i64| lic[(x + w * y as u32) as usize];
    let n = (2 * L + 1) as f32;
    for x in 0..w {
        for y in L..(h as i64 - L - 1) {
            let d = at(x, y) - at(x, y + 1);
            let e = (flow_noise(x, (y - L) as u32) - flow_noise(x, (y + L + 1) as u32)) / n;
            assert!((d - e).abs() < 1e-6, "({x}, {y}): {d} vs {e}");
        }
    }
}

/// Principal directions have no sign: a field whose sign flips from pixel to pixel (every
/// other pixel, or at random) gives exactly the image of the consistently signed field,
/// for axis-aligned and oblique directions. The LIC values are the CPU twin's
/// (`flow_image`, `flow_lic`); the shaded `flow` images, whose LIC each twin computes
/// itself (the GPU in `flow.wgsl`), are equal too, exactly on both twins.
#[test]
fn the_sign_of_dir1_does_not_matter() {
    let (w, h) = (48u32, 40u32);
    let u = ortho_uniforms(w, h);
    for t in twins("the_sign_of_dir1_does_not_matter") {
        for dir in [
            Vec3::X,
            Vec3::new(0.8, 0.6, 0.0),
            Vec3::new(-0.28, 0.96, 0.0),
        ] {
            let plain = gbuffer(w, h, |_, _| sample(dir));
            let checker = gbuffer(w, h, |x, y| {
                sample(if (x + y) % 2 == 0 { dir } else { -dir })
            });
            let random = gbuffer(w, h, |x, y| {
                let flip = isokit_render::shade::flow_hash(x + 1000, y) & 1 == 1;
                sample(if flip { -dir } else { dir })
            });
            if !t.is_gpu() {
                let (lp, lc, lr) = (lic_of(&plain), lic_of(&checker), lic_of(&random));
                // flow_image is flow_lic of every pixel of the field.
                let field = flow_field(&plain, &u, &sh());
                assert_eq!(lp[17 + w as usize * 9], flow_lic(&field, w, 17, 9));
                assert_eq!(lp, lc, "{dir}");
                assert_eq!(lp, lr, "{dir}");
                assert!(lp.iter().all(|v| (0.0..1.0).contains(v)));
            }
            let img = |g: &GBuffer| t.shade(g, &u, &sh()).unwrap().pixels;
            let ip = img(&plain);
            assert_eq!(ip, img(&checker), "{t}: {dir}");
            assert_eq!(ip, img(&random), "{t}: {dir}");
        }
    }
}

/// Streamlines stop at a miss and at a pixel of another id: a pixel beside a column of
/// misses (or of caps) averages only its own side of the row; a miss has no flow.
#[test]
fn streamlines_stop_at_misses_and_other_ids() {
    let (w, h) = (64u32, 3u32);
    let wall = 30u32;
    for other in [ID_MISS, ID_CAP] {
        let g = gbuffer(w, h, |x, _| {
            let mut s = sample(Vec3::X);
            if x == wall {
                s.id = other;
                if other == ID_MISS {
                    s = GSample::default();
                }
            }
            s
        });
        let lic = lic_of(&g);
        for y in 0..h {
            let left = f64::from(lic[(wall - 1 + w * y) as usize]);
            let m = mean_noise(((wall - 1 - FLOW_STEPS)..wall).map(|i| (i, y)));
            assert!((left - m).abs() < 1e-6, "id {other}: {left} vs {m}");
            let right = f64::from(lic[(wall + 1 + w * y) as usize]);
            let m = mean_noise(((wall + 1)..=(wall + 1 + FLOW_STEPS)).map(|i| (i, y)));
            assert!((right - m).abs() < 1e-6, "id {other}: {right} vs {m}");
            let wl = lic[(wall + w * y) as usize];
            if other == ID_MISS {
                assert_eq!(wl, -1.0);
            } else {
                // The cap column flows along itself only (its row neighbours differ).
                assert_eq!(f64::from(wl), mean_noise([(wall, y)].into_iter()));
            }
        }
    }
}

/// Where `|k1 − k2|` is tiny (umbilic) the image is plain tone shading; elsewhere the tone
/// shading times the LIC modulation; the background stays. On both twins, each shading
/// with its own LIC against the CPU's `flow_image` and `flow_modulate`: exact on the CPU;
/// on the GPU within 2.5 × [`raycast_tol::SHADE_LINEAR`] per linear channel (its `flow` and
/// `tone` images each agree with the CPU's within `SHADE_LINEAR`, and the modulation scales
/// the tone by at most 1.5); the umbilic fallback and the background exact on both.
#[test]
fn umbilics_fall_back_to_tone_shading() {
    let (w, h) = (40u32, 20u32);
    let g = gbuffer(w, h, |x, y| {
        let mut s = sample(Vec3::X);
        if x < 10 {
            s.k2 = s.k1 * (1.0 - 1e-3); // a near-umbilic
        }
        if y == 0 {
            s = GSample::default();
        }
        s
    });
    let u = ortho_uniforms(w, h);
    let lic = flow_image(&g, &u, &sh()).unwrap();
    for t in twins("umbilics_fall_back_to_tone_shading") {
        let tol = t.tol(0.0, 2.5 * raycast_tol::SHADE_LINEAR);
        let flow = t.shade(&g, &u, &sh()).unwrap();
        let tone = t
            .shade(
                &g,
                &u,
                &Shading {
                    mode: ShadingMode::Tone,
                    ..Default::default()
                },
            )
            .unwrap();
        for (i, &l) in lic.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            if y == 0 || x < 10 {
                assert_eq!(l, -1.0);
                assert_eq!(flow.pixels[i], tone.pixels[i], "{t}: ({x}, {y})");
            } else {
                assert!(l >= 0.0);
                let want = flow_modulate(tone.pixels[i], l);
                let e = (0..4)
                    .map(|c| (flow.pixels[i][c] - want[c]).abs())
                    .fold(0f32, f32::max);
                assert!(
                    e <= tol,
                    "{t}: ({x}, {y}): {:?} vs {want:?}",
                    flow.pixels[i]
                );
            }
        }
        assert_eq!(flow.pixels[0], Shading::default().background, "{t}");
        // The modulation spans darker and brighter than the tone shading.
        let ratio: Vec<f32> = (0..(w * h) as usize)
            .filter(|&i| lic[i] >= 0.0)
            .map(|i| flow.pixels[i][1] / tone.pixels[i][1])
            .collect();
        assert!(
            ratio.iter().any(|&r| r < 0.8) && ratio.iter().any(|&r| r > 1.2),
            "{t}"
        );
        let slack = 1e-6 + tol;
        assert!(
            ratio
                .iter()
                .all(|&r| (0.5 - slack..=1.5 + slack).contains(&r)),
            "{t}"
        );
    }
}

/// A multi-view G-buffer is refused with a clear error, by both twins.
#[test]
fn multiview_is_refused() {
    let mut u = ortho_uniforms(4, 4);
    u.subpixels = 3;
    let g = gbuffer(12, 4, |_, _| sample(Vec3::X));
    for t in twins("multiview_is_refused") {
        let e = t.shade(&g, &u, &sh()).unwrap_err().to_string();
        assert!(e.contains("flow") && e.contains("multi-view"), "{t}: {e}");
    }
}

/// A cylinder of radius 0.5 about the y axis (48³ samples over [−1, 1]³).
fn cylinder() -> isokit_render::Volume {
    volume(grid_of(48, |p| (p.x * p.x + p.z * p.z).sqrt() - 0.5))
}

/// On a cylinder seen from the side, `dir1` runs around it, horizontally on the screen (up
/// to the perspective's ellipses): returns the mean `|dir.x|` of the field, the mean
/// squared LIC difference between each pixel and the one a pixel along its own screen
/// direction and the one a pixel across it (a box of 2L + 1 samples gives a ratio of about
/// 2L + 1 = 25 on straight streamlines), and the flowing and hit pixel counts. The twin `t`
/// renders the G-buffer; the LIC is the CPU twin's `flow_image` of it.
fn anisotropy(t: &mut Twin, cam: &Camera) -> (f64, f64, f64, usize, usize) {
    let v = cylinder();
    let f = t.render(&v, cam, &RenderOptions::default()).unwrap();
    let lic = flow_image(&f.gbuffer, &f.uniforms, &sh()).unwrap();
    let field = flow_field(&f.gbuffer, &f.uniforms, &sh());
    let (w, h) = (f.uniforms.width as i64, f.uniforms.height as i64);
    let at = |x: f32, y: f32| {
        let (x, y) = (x.floor() as i64, y.floor() as i64);
        if x < 0 || y < 0 || x >= w || y >= h {
            return -1.0;
        }
        lic[(x + w * y) as usize]
    };
    let (mut horizontal, mut along, mut across, mut n) = (0.0, 0.0, 0.0, 0usize);
    for (i, p) in field.iter().enumerate() {
        let a = lic[i];
        if a < 0.0 {
            continue;
        }
        horizontal += f64::from(p.dir[0].abs());
        let (cx, cy) = ((i as i64 % w) as f32 + 0.5, (i as i64 / w) as f32 + 0.5);
        let [dx, dy] = p.dir;
        let (b, c) = (at(cx + dx, cy + dy), at(cx - dy, cy + dx));
        if b < 0.0 || c < 0.0 {
            continue;
        }
        along += f64::from(a - b).powi(2);
        across += f64::from(a - c).powi(2);
        n += 1;
    }
    let flowing = lic.iter().filter(|&&l| l >= 0.0).count();
    (
        horizontal / flowing as f64,
        along / n as f64,
        across / n as f64,
        flowing,
        f.gbuffer.hit_count(),
    )
}

/// The flow runs around a rendered cylinder, on the G-buffer of both twins (the GPU's
/// principal directions in f32): nearly every hit pixel flows, the field is nearly
/// horizontal, the LIC far smoother along the flow than across it. The bounds are the same
/// on both twins: they are coarse (the mean `|dir.x|` bound 1e-3 below 1 at its tightest)
/// against the splatter's documented `dir1` agreement of 1e-2 rad, whose cosine is within
/// 5e-5 of 1.
#[test]
fn flow_runs_around_a_cylinder() {
    let ortho = orthographic(Vec3::Z * 3.0, Vec3::ZERO, 1.6, 64, 64);
    let persp = perspective(Vec3::new(0.0, 0.3, 3.0), 64, 64);
    // Measured: orthographic ratio 37.6 (straight rows), perspective 5.9 (slanted, curved
    // streamlines sampled at the nearest pixel share fewer pixels with their neighbours').
    let cases = [
        ("orthographic", ortho, 0.999, 20.0),
        ("perspective", persp, 0.9, 4.0),
    ];
    for mut t in twins("flow_runs_around_a_cylinder") {
        for (name, cam, horizontal, ratio) in &cases {
            let (hx, along, across, flowing, hits) = anisotropy(&mut t, cam);
            eprintln!(
                "{t}, {name}: {flowing} of {hits} hit pixels flow, mean |dir.x| {hx:.4}; mean squared LIC difference a pixel along the flow {along:.2e}, across it {across:.2e} (ratio {:.1})",
                across / along
            );
            assert!(flowing * 10 >= hits * 9, "{t}, {name}: {flowing} of {hits}");
            assert!(hx > *horizontal, "{t}, {name}: {hx}");
            assert!(across > ratio * along, "{t}, {name}: {along} vs {across}");
        }
    }
}

/// Perspective: the field is the direction in which the projection of the hit point moves
/// along `dir1` (a finite difference of the pixel coordinates, in f64).
#[test]
fn perspective_direction_is_the_projected_tangent() {
    let cam = perspective(Vec3::new(0.4, 0.7, 2.5), 80, 60);
    let u = camera_uniforms(&cam).unwrap();
    let (r, up, f, eye) = (
        Vec3::from_array(u.right).as_dvec3(),
        Vec3::from_array(u.up).as_dvec3(),
        Vec3::from_array(u.forward).as_dvec3(),
        Vec3::from_array(u.eye).as_dvec3(),
    );
    let h = f64::from(u.half_height);
    let pixel = |p: glam::DVec3| {
        let q = p - eye;
        let (sx, sy) = (q.dot(r) / q.dot(f), q.dot(up) / q.dot(f));
        let x = (sx / (h * f64::from(u.aspect)) + 1.0) * 0.5 * f64::from(u.width);
        let y = (1.0 - sy / h) * 0.5 * f64::from(u.height);
        glam::DVec2::new(x, y)
    };
    for (p, t) in [
        (Vec3::new(0.3, -0.2, 0.1), Vec3::new(0.0, 0.6, 0.8)),
        (Vec3::new(-0.5, 0.4, -0.3), Vec3::new(0.48, 0.6, 0.64)),
        (Vec3::new(0.1, 0.1, 0.5), Vec3::X),
    ] {
        let s = GSample {
            position: p,
            dir1: t,
            ..sample(t)
        };
        let d = isokit_render::shade::flow_direction(&u, &s).unwrap();
        let e = 1e-6;
        let fd = (pixel(p.as_dvec3() + e * t.as_dvec3()) - pixel(p.as_dvec3() - e * t.as_dvec3()))
            .normalize();
        assert!(
            (f64::from(d[0]) - fd.x).abs() < 1e-4 && (f64::from(d[1]) - fd.y).abs() < 1e-4,
            "{d:?} vs {fd}"
        );
    }
}
