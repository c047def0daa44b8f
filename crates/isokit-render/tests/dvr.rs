//! Direct volume rendering against references: the emission–absorption integral in f64 at a
//! fine step, the pre-integration claim of Engel et al. 2001 on a thin spike, the speed-ups
//! that must change no pixel, and the GPU twin against the CPU twin (on lavapipe in CI;
//! skipped with a printed reason where no adapter exists, failing when
//! `ISOKIT_REQUIRE_GPU=1`).

mod common;

use glam::{Vec3, Vec4};
use isokit_field::filter::trilinear;
use isokit_field::{Camera, Grid, Projection};
use isokit_render::dvr::{
    Classification, DvrGradient, DvrOptions, PreintegrationTable, PreintegrationTable3, TF_PRESETS,
    TableBuild, TfPoint, TransferFunction, render_dvr,
};

/// Two Gaussians and a linear ramp on a 24³ lattice over [-1, 1]³.
fn blobs() -> Grid {
    let n = 24;
    let h = 2.0 / (n - 1) as f32;
    let mut data = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = Vec3::new(i as f32, j as f32, k as f32) * h - Vec3::ONE;
                let g = |c: Vec3, s: f32| (-(p - c).length_squared() / (2.0 * s * s)).exp();
                data.push(
                    g(Vec3::new(0.3, 0.1, 0.0), 0.3)
                        + 0.7 * g(Vec3::new(-0.4, -0.2, 0.2), 0.2)
                        + 0.1 * (p.x + 1.0),
                );
            }
        }
    }
    Grid::from_data([n; 3], Vec3::splat(-1.0), h, data).unwrap()
}

/// The signed distance to a sphere of radius `r` at the origin, `n³` samples over [-1, 1]³.
fn sphere(n: usize, r: f32) -> Grid {
    let h = 2.0 / (n - 1) as f32;
    let values: Vec<f32> = (0..n * n * n)
        .map(|e| {
            let p = Vec3::new((e % n) as f32, ((e / n) % n) as f32, (e / (n * n)) as f32);
            (p * h - Vec3::ONE).length() - r
        })
        .collect();
    Grid::from_data([n; 3], Vec3::splat(-1.0), h, values).unwrap()
}

fn camera(w: u32) -> Camera {
    Camera::look_at(
        Vec3::new(1.2, 0.8, 3.2),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 45.0,
        },
        w,
        w,
    )
    .unwrap()
}

fn smooth_tf() -> TransferFunction {
    TransferFunction::from_json(
        r#"{"points": [[0.1, 0, 0, 0, 0], [0.4, 0.2, 0.4, 1.0, 3], [0.8, 1.0, 0.6, 0.2, 12], [1.2, 1, 1, 1, 20]]}"#,
    )
    .unwrap()
}

/// The transfer function evaluated in f64, independently of the crate's code.
fn tf64(tf: &TransferFunction, v: f64) -> ([f64; 3], f64) {
    let p = tf.points();
    let at = |q: &TfPoint| {
        (
            [
                q.emission.x as f64,
                q.emission.y as f64,
                q.emission.z as f64,
            ],
            q.sigma as f64,
        )
    };
    if v <= p[0].value as f64 {
        return at(&p[0]);
    }
    for w in p.windows(2) {
        let (a, b) = (w[0].value as f64, w[1].value as f64);
        if v < b {
            let t = (v - a) / (b - a);
            let (ca, sa) = at(&w[0]);
            let (cb, sb) = at(&w[1]);
            return (
                [0, 1, 2].map(|i| ca[i] + (cb[i] - ca[i]) * t),
                sa + (sb - sa) * t,
            );
        }
    }
    at(&p[p.len() - 1])
}

/// The emission–absorption integral along every pixel's ray, in f64, midpoint rule at
/// `step`, exact exponential per step.
fn reference(grid: &Grid, cam: &Camera, tf: &TransferFunction, step: f64) -> Vec<Vec4> {
    let b = grid.bounds();
    let (w, h) = (cam.width(), cam.height());
    (0..w * h)
        .map(|pix| {
            let ray = cam.ray((pix % w) as f32 + 0.5, (pix / w) as f32 + 0.5);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
            for a in 0..3 {
                let (lo, hi) = (b.min[a] as f64, b.max[a] as f64);
                if d[a] == 0.0 {
                    if o[a] < lo || o[a] > hi {
                        t1 = -1.0;
                    }
                    continue;
                }
                let (x, y) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
                t0 = t0.max(x.min(y));
                t1 = t1.min(x.max(y));
            }
            let (mut c, mut trans) = ([0.0f64; 3], 1.0f64);
            let mut s = t0;
            while s < t1 {
                let e = (s + step).min(t1);
                let p = o + d * (0.5 * (s + e));
                let v = trilinear(grid, grid.to_grid(p.as_vec3())) as f64;
                let (col, sigma) = tf64(tf, v);
                let alpha = 1.0 - (-sigma * (e - s)).exp();
                for i in 0..3 {
                    c[i] += trans * alpha * col[i];
                }
                trans *= 1.0 - alpha;
                s = e;
            }
            Vec4::new(c[0] as f32, c[1] as f32, c[2] as f32, (1.0 - trans) as f32)
        })
        .collect()
}

fn mean_diff(a: &[Vec4], b: &[Vec4]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs().truncate().element_sum() / 3.0)
        .sum::<f32>()
        / a.len() as f32
}

#[test]
fn post_classification_at_a_fine_step_matches_the_f64_integral() {
    let grid = blobs();
    let cam = camera(12);
    let tf = smooth_tf();
    let step = grid.spacing() / 64.0;
    let want = reference(&grid, &cam, &tf, step as f64);
    let opts = DvrOptions {
        step: Some(step),
        termination: 1.0,
        ..DvrOptions::default()
    };
    let got = render_dvr(&grid, &cam, &tf, &opts).unwrap();
    let err = common::max_diff(&got.rgba, &want);
    eprintln!("post-classified at h/64 against the f64 reference: max error {err:.2e}");
    assert!(err < 1e-3, "{err}");
    // The scene is not trivial: some rays nearly opaque, some clear.
    assert!(want.iter().any(|p| p.w > 0.5) && want.iter().any(|p| p.w < 0.05));
}

#[test]
fn pre_integration_beats_post_classification_on_a_thin_spike_at_a_coarse_step() {
    // A ramp rising mostly along the view direction (a one-voxel step crosses 0.033 of the
    // value range), and a transfer function with a spike 0.02 wide in value.
    let n = 17;
    let h = 1.0 / (n - 1) as f32;
    let mut data = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                data.push((0.3 * i as f32 + 0.6 * j as f32 + k as f32) * h / 1.9);
            }
        }
    }
    let grid = Grid::from_data([n; 3], Vec3::ZERO, h, data).unwrap();
    let tf = TransferFunction::from_json(
        r#"{"points": [[0.49, 0, 0, 0, 0], [0.5, 1, 0.8, 0.3, 60], [0.51, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    let cam = Camera::look_at(
        Vec3::new(0.5, 0.5, 3.0),
        Vec3::splat(0.5),
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 30.0,
        },
        20,
        20,
    )
    .unwrap();
    let want = reference(&grid, &cam, &tf, (h / 64.0) as f64);
    let render = |classification| {
        render_dvr(
            &grid,
            &cam,
            &tf,
            &DvrOptions {
                step: Some(h),
                classification,
                termination: 1.0,
                table_size: 512,
                ..DvrOptions::default()
            },
        )
        .unwrap()
        .rgba
    };
    let post = mean_diff(&render(Classification::Post), &want);
    let pre = mean_diff(&render(Classification::Preintegrated), &want);
    let signal = want
        .iter()
        .map(|p| p.truncate().element_sum() / 3.0)
        .sum::<f32>()
        / want.len() as f32;
    eprintln!(
        "one-voxel step, thin spike: mean error post-classified {post:.2e}, pre-integrated {pre:.2e} (mean reference colour {signal:.2e})"
    );
    assert!(signal > 1e-2, "the spike must show: {signal}");
    assert!(pre < 0.5 * post, "pre {pre} post {post}");
}

#[test]
fn skipping_and_early_termination_change_no_pixel_beyond_their_tolerance() {
    let grid = blobs();
    let cam = camera(24);
    let tf = smooth_tf();
    for classification in [Classification::Post, Classification::Preintegrated] {
        let with = |block, termination| {
            render_dvr(
                &grid,
                &cam,
                &tf,
                &DvrOptions {
                    classification,
                    block,
                    termination,
                    ..DvrOptions::default()
                },
            )
            .unwrap()
        };
        let plain = with(0, 1.0);
        let skip = with(4, 1.0);
        let both = with(4, 0.99);
        assert!(skip.skipped_blocks > 0 && skip.samples < plain.samples);
        assert!(both.samples < skip.samples);
        let (d_skip, d_term) = (
            common::max_diff(&skip.rgba, &plain.rgba),
            common::max_diff(&both.rgba, &plain.rgba),
        );
        eprintln!(
            "{classification:?}: skipping {} blocks, max change {d_skip:.1e}; terminating at 0.99, max change {d_term:.1e}; samples {} -> {} -> {}",
            skip.skipped_blocks, plain.samples, skip.samples, both.samples
        );
        assert!(d_skip < 1e-5, "{d_skip}");
        // What termination leaves out is at most 1 - 0.99 of the brightest emission (1).
        assert!(d_term <= 0.01 + 1e-5, "{d_term}");
        // Depth: where the opacity passes 0.5, only on rays that are that opaque.
        for (p, z) in plain.rgba.iter().zip(&plain.depth) {
            assert_eq!(p.w >= 0.5, z.is_finite(), "{p} {z}");
        }
    }
}

#[test]
fn transfer_functions_and_knobs_are_checked() {
    for name in TF_PRESETS {
        let tf = TransferFunction::preset(name, (0.0, 1.0), 0.01).unwrap();
        assert!(tf.points().iter().any(|p| p.sigma > 0.0), "{name}");
    }
    assert!(TransferFunction::preset("ct-bones", (0.0, 1.0), 0.01).is_err());
    let many = format!(
        r#"{{"points": [{}]}}"#,
        vec!["[0, 1, 1, 1, 1]"; 5000].join(", ")
    );
    assert!(TransferFunction::from_json(&many).is_err());
    for bad in [
        "",
        "{}",
        r#"{"points": []}"#,
        r#"{"points": [[0, 1, 1, 1]]}"#,
        r#"{"points": [[0, 1, 1, 1, -1]]}"#,
        r#"{"points": [[0, 1, 1, 1, "x"]]}"#,
        r#"{"points": [[1e39, 1, 1, 1, 1]]}"#,
    ] {
        let e = TransferFunction::from_json(bad).unwrap_err().to_string();
        assert!(e.contains("transfer function"), "{bad}: {e}");
    }
    // Unsorted points are sorted; a step (two points at one value) is kept.
    let tf = TransferFunction::from_json(
        r#"{"points": [[1, 1, 1, 1, 2], [0, 0, 0, 0, 0], [0.5, 0, 0, 0, 0], [0.5, 1, 0, 0, 3]]}"#,
    )
    .unwrap();
    assert_eq!(tf.eval(0.49).1, 0.0);
    assert_eq!(tf.eval(0.5).1, 3.0);
    assert_eq!(tf.max_sigma(0.0, 0.4), 0.0);
    assert_eq!(tf.max_sigma(0.0, 0.6), 3.0);
    let grid = blobs();
    let cam = camera(4);
    for step in [0.0, -1.0, f32::NAN, 1e-9] {
        let o = DvrOptions {
            step: Some(step),
            ..DvrOptions::default()
        };
        assert!(render_dvr(&grid, &cam, &tf, &o).is_err(), "{step}");
    }
}

#[test]
fn an_opaque_step_at_zero_puts_the_depth_on_the_surface_between_samples() {
    // Pre-integration of a distance field (Sigg et al., segmented distance fields, 003
    // Sec. 4): with the transfer function a step at 0, opaque inside, the segment that
    // crosses 0 is tabulated, so the surface is found between samples without a search.
    let n = 32;
    let h = 2.0 / (n - 1) as f32;
    let r = 0.6;
    let grid = sphere(n, r);
    let sigma = 400.0 / h;
    let tf = TransferFunction::from_json(&format!(
        r#"{{"points": [[0, 1, 1, 1, {sigma}], [0, 0, 0, 0, 0]]}}"#
    ))
    .unwrap();
    let cam = Camera::look_at(
        Vec3::new(0.3, 0.2, 3.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 30.0,
        },
        24,
        24,
    )
    .unwrap();
    // The exact distance to the sphere along each ray (and where the opacity passes 0.5
    // after that: ln 2 / sigma further).
    let exact: Vec<Option<f32>> = (0..24 * 24)
        .map(|pix| {
            let ray = cam.ray((pix % 24) as f32 + 0.5, (pix / 24) as f32 + 0.5);
            let b = ray.origin.dot(ray.dir);
            let c = ray.origin.length_squared() - r * r;
            let disc = b * b - c;
            // Rays that graze the silhouette (impact parameter above 0.87 r) cross the
            // shell of values near 0 over several steps, where neither model is linear.
            (disc > 0.25 * r * r).then(|| -b - disc.sqrt() + std::f32::consts::LN_2 / sigma)
        })
        .collect();
    let mut worst = Vec::new();
    for classification in [Classification::Post, Classification::Preintegrated] {
        let img = render_dvr(
            &grid,
            &cam,
            &tf,
            &DvrOptions {
                classification,
                table_size: 1024,
                ..DvrOptions::default()
            },
        )
        .unwrap();
        let mut err = 0.0f32;
        for (z, e) in img.depth.iter().zip(&exact) {
            if let Some(e) = e
                && z.is_finite()
            {
                err = err.max((z - e).abs() / h);
            }
        }
        let hits = img.depth.iter().filter(|z| z.is_finite()).count();
        let want = exact.iter().filter(|e| e.is_some()).count();
        eprintln!(
            "{classification:?} at one-voxel steps: depth within {err:.3} voxel of the sphere ({hits} rays opaque, {want} hit it)"
        );
        assert!(hits as f32 > 0.9 * want as f32, "{hits} of {want}");
        worst.push(err);
    }
    // Post-classification finds the surface only to within a step; pre-integration to the
    // trilinear interpolant's accuracy.
    assert!(worst[1] < 0.1, "{worst:?}");
    assert!(worst[0] > 2.0 * worst[1], "{worst:?}");
}

#[test]
fn the_gpu_twin_renders_what_the_cpu_twin_renders() {
    let Some(r) = common::twin::gpu_renderer("dvr::the_gpu_twin_renders_what_the_cpu_twin_renders")
    else {
        return;
    };
    let grid = blobs();
    let cam = camera(32);
    let tf = smooth_tf();
    let h = grid.spacing();
    for classification in [Classification::Post, Classification::Preintegrated] {
        for (block, shade, gradient) in [
            (0, false, DvrGradient::Tricubic),
            (4, true, DvrGradient::Tricubic),
            (4, true, DvrGradient::Central),
        ] {
            // A step that does not divide the rays' lengths: partial last segments too.
            let opts = DvrOptions {
                step: Some(0.7 * h),
                classification,
                block,
                shade,
                gradient,
                ..DvrOptions::default()
            };
            let cpu = render_dvr(&grid, &cam, &tf, &opts).unwrap();
            let gpu = r.render_dvr(&grid, &cam, &tf, &opts).unwrap();
            let (d, mask, dz) = common::dvr_difference(&cpu, &gpu, h);
            eprintln!(
                "{classification:?}, block {block}, shaded {shade} ({gradient:?}): max colour/opacity difference {d:.1e}, depth {dz:.1e} voxel, {mask} depth masks differ, samples {} / {}, skipped {} / {}",
                cpu.samples, gpu.samples, cpu.skipped_blocks, gpu.skipped_blocks
            );
            assert!(d < 1e-4, "{d}");
            assert!(dz < 1e-3 && mask <= 2, "{dz} {mask}");
            let rel = (cpu.samples as f64 - gpu.samples as f64).abs() / cpu.samples as f64;
            assert!(rel < 1e-3, "{} {}", cpu.samples, gpu.samples);
            assert!(cpu.rgba.iter().any(|p| p.w > 0.5));
        }
    }
    // The GPU twin refuses what WGSL cannot hold: non-finite samples.
    let mut bad = blobs();
    bad.set(3, 3, 3, f32::NAN);
    let e = r
        .render_dvr(&bad, &cam, &tf, &DvrOptions::default())
        .unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
}

#[test]
fn shading_by_the_gradient_lights_what_faces_the_eye() {
    // A glowing shell just inside a sphere's surface, seen from the front: its normal faces
    // the eye at the centre of the image and turns away towards the rim.
    let n = 40;
    let h = 2.0 / (n - 1) as f32;
    let grid = sphere(n, 0.7);
    let tf = TransferFunction::preset("distance-shell", (-0.7, 1.0), h).unwrap();
    let cam = Camera::look_at(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { height: 1.8 },
        33,
        33,
    )
    .unwrap();
    let render = |shade| {
        let o = DvrOptions {
            shade,
            ..DvrOptions::default()
        };
        render_dvr(&grid, &cam, &tf, &o).unwrap().rgba
    };
    let (flat, lit) = (render(false), render(true));
    // The centre, and a pixel 0.6 from the axis (the normal there 59° from the view).
    let (centre, side) = (16 * 33 + 16, 16 * 33 + 16 + 11);
    let gain = |i: usize| lit[i].x / flat[i].x;
    eprintln!(
        "shading gain: centre {:.2}, 0.6 off axis {:.2} (opacity {:.2}, {:.2})",
        gain(centre),
        gain(side),
        lit[centre].w,
        lit[side].w
    );
    assert!(flat[centre].w > 0.1 && flat[side].w > 0.1);
    // Unlit the side (a longer path through the shell) is brighter; lit, the centre gains
    // the most: diffuse 1 and the specular highlight against cos 59° and almost none.
    assert!(
        gain(centre) > 1.0 && gain(side) < 0.8,
        "{} {}",
        gain(centre),
        gain(side)
    );
    // Opacity is not shaded.
    assert!(lit.iter().zip(&flat).all(|(a, b)| a.w == b.w));
}

#[test]
fn the_tricubic_gradient_turns_smoothly_on_coarse_data() {
    // A sphere's distance on a coarse 14³ lattice, the shading normal followed along a
    // circle on the surface in steps of 1e-3. Central differences of the trilinear
    // interpolant turn with kinks at the cell faces (their second differences spike); the
    // tricubic B-spline's gradient is C1 and turns smoothly.
    let n = 14;
    let h = 2.0 / (n - 1) as f32;
    let grid = sphere(n, 0.7);
    let central = |x: Vec3| {
        let v = |p: Vec3| trilinear(&grid, grid.to_grid(p));
        let d = |e: Vec3| v(x + e * h) - v(x - e * h);
        Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z))
    };
    let tricubic = |x: Vec3| isokit_render::dvr::tricubic_gradient(&grid, x);
    let path: Vec<Vec3> = (0..1400)
        .map(|i| {
            let t = 0.3 + i as f32 * 1e-3 / 0.7;
            Vec3::new(t.cos(), t.sin() * 0.8, t.sin() * 0.6) * 0.7
        })
        .collect();
    let kinks = |g: &dyn Fn(Vec3) -> Vec3| {
        let normals: Vec<Vec3> = path.iter().map(|&x| g(x).normalize()).collect();
        let worst_angle = path
            .iter()
            .zip(&normals)
            .map(|(x, m)| m.dot(x.normalize()).clamp(-1.0, 1.0).acos().to_degrees())
            .fold(0.0f32, f32::max);
        let second = normals
            .windows(3)
            .map(|w| (w[0] - 2.0 * w[1] + w[2]).length())
            .fold(0.0f32, f32::max);
        (second, worst_angle)
    };
    let (c, t) = (kinks(&central), kinks(&tricubic));
    eprintln!(
        "normal along a circle, largest second difference / angle to the sphere's: central {:.1e} / {:.2} degrees, tricubic {:.1e} / {:.2} degrees",
        c.0, c.1, t.0, t.1
    );
    assert!(t.0 < 0.1 * c.0 && t.1 < 0.5 * c.1, "{t:?} {c:?}");
}

#[test]
fn the_tricubic_gradient_is_the_sampled_fields() {
    // The renderer's f32 gradient against isokit_field's direct 64-tap convolution in f64.
    let grid = blobs();
    let (mut worst, mut largest) = (0.0f32, 0.0f32);
    for k in 0..200 {
        let t = k as f32 * 0.618_034;
        let x = Vec3::new((3.1 * t).sin(), (1.7 * t).cos(), (2.3 * t).sin() * 0.9) * 1.05;
        let want = isokit_field::filter::tricubic_bspline_gradient(&grid, grid.to_grid(x))
            / grid.spacing();
        let got = isokit_render::dvr::tricubic_gradient(&grid, x);
        worst = worst.max((got - want).length());
        largest = largest.max(want.length());
    }
    eprintln!(
        "tricubic gradient against the f64 convolution: worst {worst:.1e} (largest gradient {largest:.2})"
    );
    assert!(worst < 1e-5 * largest, "{worst} {largest}");
}

#[test]
fn the_incremental_table_approximates_the_integrated_segments() {
    // Lum, Wilson and Ma 2004's O(n²) construction against segments integrated in f64 at
    // 256 sub-steps per piece, on the smooth transfer function (benches/dvr_table.rs has
    // the sizes and times: about 8× the integrated table's error, 8–13× faster).
    let tf = smooth_tf();
    let (lo, hi, len, n) = (0.0f32, 1.2f32, 0.05f32, 128usize);
    let v = |i: usize| lo + (hi - lo) * i as f32 / (n - 1) as f32;
    let inc = PreintegrationTable::incremental(&tf, lo, hi, n, len).unwrap();
    let int = PreintegrationTable::new(&tf, lo, hi, n, len).unwrap();
    let (mut worst_inc, mut worst_int) = (0.0f32, 0.0f32);
    for f in (0..n).step_by(3) {
        for b in (0..n).step_by(5) {
            let want = tf.segment(v(f), v(b), len, 256);
            worst_inc = worst_inc.max((inc.lookup(v(f), v(b)) - want).abs().max_element());
            worst_int = worst_int.max((int.lookup(v(f), v(b)) - want).abs().max_element());
        }
    }
    eprintln!(
        "table entries' worst error: incremental {worst_inc:.2e}, integrated {worst_int:.2e}"
    );
    assert!(
        worst_inc < 0.03 && worst_int < 4e-3,
        "{worst_inc} {worst_int}"
    );
    // Constant segments are exact in both; some entries are opaque, some clear.
    let c = tf.segment(v(90), v(90), len, 256);
    assert!((inc.lookup(v(90), v(90)) - c).abs().max_element() < 1e-5);
    assert!(inc.lookup(v(127), v(127)).w > 0.5 && inc.lookup(v(0), v(10)).w == 0.0);
    // Rendering with it changes the image a little, not much.
    let grid = blobs();
    let cam = camera(24);
    let o = |table_build| DvrOptions {
        classification: Classification::Preintegrated,
        table_build,
        ..DvrOptions::default()
    };
    let a = render_dvr(&grid, &cam, &tf, &o(TableBuild::Integrated)).unwrap();
    let b = render_dvr(&grid, &cam, &tf, &o(TableBuild::Incremental)).unwrap();
    let d = common::max_diff(&a.rgba, &b.rgba);
    eprintln!("the image with the incremental table: max difference {d:.2e}");
    assert!(d > 0.0 && d < 0.03, "{d}");
}

#[test]
fn the_3d_table_gives_segments_of_any_length() {
    let tf = smooth_tf();
    let table = PreintegrationTable3::new(&tf, 0.0, 1.3, 128, 64, 0.5).unwrap();
    let mut rng = isokit_field::rng::SplitMix64::new(3);
    let mut worst = 0.0f32;
    for _ in 0..2000 {
        let (vf, vb, len) = (
            rng.range(0.0, 1.3),
            rng.range(0.0, 1.3),
            rng.range(0.0, 0.5),
        );
        let exact = tf.segment(vf, vb, len, 4);
        worst = worst.max((table.lookup(vf, vb, len) - exact).abs().max_element());
    }
    eprintln!("3D pre-integration table 128 x 128 x 64: max error {worst:.1e} over 2000 segments");
    assert!(worst < 0.01, "{worst}");
    assert_eq!(table.lookup(0.5, 0.9, 0.0), Vec4::ZERO);
    assert!(PreintegrationTable3::new(&tf, 0.0, 1.0, 2000, 2000, 1.0).is_err());
    assert!(PreintegrationTable3::new(&tf, 0.0, 1.0, 16, 16, 0.0).is_err());
}
