//! End-to-end tests of `isokit render` and `isokit demo`: scenes and volumes to PNG and
//! EXR, the GPU backend against the CPU's and the fallback without an adapter, refused
//! sizes, and `--watch` keeping the last good image.

mod common;

use common::{assert_clear_error, isokit, isokit_ok, json, scratch};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SCENE: &str = r#"{
  "shape": {"difference": [
    {"sphere": {"radius": 0.8}},
    {"box": {"half": [0.4, 0.4, 0.9], "center": [0.5, 0.3, 0.0]}}
  ]},
  "camera": {"eye": [1.5, 1.2, 2.5], "fov": 40},
  "shading": {"mode": "tone"},
  "sampling": {"resolution": 48}
}"#;

#[test]
fn render_a_scene_to_png_and_gbuffer() {
    let dir = scratch("render-scene");
    let scene = dir.join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let png = dir.join("out.png");
    let exr = dir.join("g.exr");
    let out = isokit_ok(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "40",
        "--gbuffer",
        exr.to_str().unwrap(),
        "--stats",
        "--backend",
        "cpu",
    ]);
    let j = json(&out);
    assert!(j["hits"].as_u64().unwrap() > 300, "{j}");
    assert_eq!(j["backend"], "cpu");
    assert_eq!(j["passes"], 1);
    let (w, h, _) = isokit::io::read_png(&png).unwrap();
    assert_eq!((w, h), (64, 40));
    let info = isokit::io::read_exr_info(&exr).unwrap();
    let mut names = info.channels.clone();
    names.sort();
    assert_eq!(
        names,
        [
            "A", "K1", "K2", "N.X", "N.Y", "N.Z", "P.X", "P.Y", "P.Z", "Z"
        ]
    );
    // A one-brick cache and no skipping render the same picture.
    let png2 = dir.join("out2.png");
    isokit_ok(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png2.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "40",
        "--cache-mb",
        "0",
        "--no-skip",
        "--backend",
        "cpu",
    ]);
    assert_eq!(
        isokit::io::read_png(&png).unwrap(),
        isokit::io::read_png(&png2).unwrap()
    );
}

#[test]
fn render_a_volume_with_the_inside_above() {
    let dir = scratch("render-volume");
    // A density: 1 − |p| over [-1, 1]³, the ball |p| < 0.6 is where it exceeds 0.4.
    let mut g = isokit::Grid::new([33; 3], glam::Vec3::splat(-1.0), 2.0 / 32.0).unwrap();
    for ([i, j, k], _) in g.clone().iter() {
        let p = g.position(i, j, k);
        g.set(i, j, k, 1.0 - p.length());
    }
    let vol = dir.join("d.nrrd");
    isokit::io::write_volume(&vol, &isokit::io::Volume::from(g)).unwrap();
    let png = dir.join("d.png");
    let run = |inside: &str| {
        json(&isokit_ok(&[
            "render",
            vol.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "32",
            "--iso",
            "0.4",
            "--inside",
            inside,
            "--shading",
            "curvature",
            "--stats",
        ]))
    };
    let above = run("above");
    assert!(above["hits"].as_u64().unwrap() > 50, "{above}");
    assert_eq!(above["caps"], 0);
    // With the inside below, the solid is the complement: the box's faces are caps.
    let below = run("below");
    assert_eq!(below["hits"], 0, "{below}");
    assert!(below["caps"].as_u64().unwrap() > 300, "{below}");
}

/// `--warm-frames N`: N more frames of the same camera with the brick cache kept, listed in
/// `--stats` as `warm_trace_seconds`; the image is the first frame's.
#[test]
fn render_reports_warm_frames() {
    let dir = scratch("render-warm");
    let mut g = isokit::Grid::new([33; 3], glam::Vec3::splat(-1.0), 2.0 / 32.0).unwrap();
    for ([i, j, k], _) in g.clone().iter() {
        let p = g.position(i, j, k);
        g.set(i, j, k, p.length() - 0.6);
    }
    let vol = dir.join("s.nrrd");
    isokit::io::write_volume(&vol, &isokit::io::Volume::from(g)).unwrap();
    let png = dir.join("s.png");
    let run = |warm: &str| {
        json(&isokit_ok(&[
            "render",
            vol.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "32",
            "--backend",
            "cpu",
            "--stats",
            "--warm-frames",
            warm,
        ]))
    };
    let cold = run("0");
    assert!(cold.get("warm_trace_seconds").is_none(), "{cold}");
    let warm = run("3");
    let w = warm["warm_trace_seconds"].as_array().unwrap();
    assert_eq!(w.len(), 3, "{warm}");
    assert!(w.iter().all(|x| x.as_f64().unwrap() > 0.0), "{warm}");
    assert_eq!(warm["hits"], cold["hits"]);
    // --search fixed (the adaptive fixed-rate search) hits the same pixels with more
    // samples per ray; --lipschitz 1 (honest for this distance field) the same.
    let with = |extra: &[&str]| {
        let mut args = vec![
            "render",
            vol.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "32",
            "--backend",
            "cpu",
            "--stats",
        ];
        args.extend_from_slice(extra);
        json(&isokit_ok(&args))
    };
    let fixed = with(&["--search", "fixed"]);
    assert_eq!(fixed["hits"], cold["hits"]);
    let spr = |j: &serde_json::Value| j["samples_per_ray"].as_f64().unwrap();
    assert!(spr(&fixed) > spr(&cold), "{fixed} {cold}");
    let given = with(&["--lipschitz", "1"]);
    assert_eq!(given["hits"], cold["hits"]);
    assert!(
        !isokit(&[
            "render",
            vol.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--search",
            "zigzag"
        ])
        .status
        .success()
    );
}

/// Mean absolute difference of two 8-bit RGBA images' colour channels.
fn mean_rgb8(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let sum: u64 = a
        .chunks(4)
        .zip(b.chunks(4))
        .map(|(p, q)| (0..3).map(|c| u64::from(p[c].abs_diff(q[c]))).sum::<u64>())
        .sum();
    sum as f64 / (3 * a.len() / 4) as f64
}

/// `--backend gpu` renders on the GPU (lavapipe in CI) the image and G-buffer the CPU
/// renders: the same hit count and a mean colour difference below 0.05 of an 8-bit step.
/// Without an adapter the GPU part is skipped with a note (or fails when
/// `ISOKIT_REQUIRE_GPU=1`).
#[test]
fn gpu_backend_renders_like_the_cpu() {
    let Some(software) = isokit::render::gpu::testing::run_or_skip(
        "gpu_backend_renders_like_the_cpu",
        isokit::render::gpu::GpuRenderer::open().map(|g| (g.is_software(), g.describe())),
        |(_, name)| name.clone(),
    )
    .map(|(software, _)| software) else {
        return;
    };
    let dir = scratch("render-gpu");
    let scene = dir.join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let run = |backend: &str, extra: &[&str]| {
        let png = dir.join(format!("{backend}.png"));
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "48",
            "--height",
            "40",
            "--backend",
            backend,
            "--stats",
        ];
        args.extend(extra);
        let j = json(&isokit_ok(&args));
        (j, isokit::io::read_png(&png).unwrap())
    };
    let (cj, (_, _, cpx)) = run("cpu", &[]);
    let (gj, (w, h, gpx)) = run("gpu", &[]);
    // `auto` takes a hardware GPU, and passes over a software one (lavapipe) with a note.
    let (aj, _) = run("auto", &[]);
    assert_eq!(aj["backend"], if software { "cpu" } else { "gpu" }, "{aj}");
    assert_eq!((w, h), (48, 40));
    assert_eq!(cj["backend"], "cpu");
    assert_eq!(gj["backend"], "gpu", "{gj}");
    assert!(gj["device"].as_str().unwrap().starts_with("GPU"), "{gj}");
    let (ch, gh) = (cj["hits"].as_i64().unwrap(), gj["hits"].as_i64().unwrap());
    assert!(ch > 300 && (ch - gh).abs() <= 2, "{ch} {gh}");
    let mean = mean_rgb8(&cpx, &gpx);
    assert!(mean < 0.05, "mean |Δ| {mean}");
    // A one-brick cache on the GPU: several passes, the same picture.
    let (sj, (_, _, spx)) = run("gpu", &["--cache-mb", "0", "--shading", "curvature"]);
    assert!(sj["passes"].as_u64().unwrap() > 1, "{sj}");
    assert_eq!(sj["cache_capacity"], 1);
    let (_, (_, _, cspx)) = run("cpu", &["--shading", "curvature"]);
    assert!(mean_rgb8(&cspx, &spx) < 0.05);
    // A multi-view display and its views, on the GPU.
    let views = dir.join("views");
    let (mj, (mw, mh, mpx)) = run(
        "gpu",
        &[
            "--views",
            "4",
            "--lens-slant",
            "0.333",
            "--views-out",
            views.to_str().unwrap(),
        ],
    );
    assert_eq!(
        (mw, mh, &mj["backend"]),
        (48, 40, &serde_json::json!("gpu"))
    );
    let (_, (_, _, cmpx)) = run("cpu", &["--views", "4", "--lens-slant", "0.333"]);
    assert!(mean_rgb8(&cmpx, &mpx) < 0.05);
    for k in 0..4 {
        let (w, h, _) = isokit::io::read_png(&views.join(format!("view_{k:02}.png"))).unwrap();
        assert_eq!((w, h), (48, 40));
    }
}

/// Without a usable adapter (simulated by narrowing wgpu to a backend this build lacks),
/// `auto` renders on the CPU and says why, `--backend gpu` is a clear error; the
/// environment's `ISOKIT_BACKEND` is honoured and checked.
#[test]
fn backend_choice_without_an_adapter() {
    let dir = scratch("render-no-gpu");
    let scene = dir.join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let png = dir.join("out.png");
    let run = |backend: &str, env: &[(&str, &str)]| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_isokit"));
        cmd.args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "16",
            "--backend",
            backend,
            "--stats",
        ])
        .env_remove("ISOKIT_BACKEND")
        .env("WGPU_BACKEND", "dx12");
        for (k, v) in env {
            cmd.env(k, v);
        }
        cmd.output().unwrap()
    };
    let out = run("auto", &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("note: no usable GPU"), "{err}");
    assert!(err.contains("rendering on the CPU twin"), "{err}");
    assert_eq!(json(&out)["backend"], "cpu");
    assert!(png.is_file());
    let out = run("gpu", &[]);
    assert_clear_error(&out, "no GPU adapter");
    let out = run("auto", &[("ISOKIT_BACKEND", "cpu")]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("note: no usable GPU"));
    assert_eq!(json(&out)["backend"], "cpu");
    let out = run("auto", &[("ISOKIT_BACKEND", "gpu")]);
    assert_clear_error(&out, "no GPU adapter");
    let out = run("auto", &[("ISOKIT_BACKEND", "quantum")]);
    assert_clear_error(&out, "unknown backend 'quantum'");
    // --backend cpu wins over the environment.
    let out = run("cpu", &[("ISOKIT_BACKEND", "gpu")]);
    assert_eq!(json(&out)["backend"], "cpu");
}

#[test]
fn absurd_and_bad_arguments_are_refused_clearly() {
    let dir = scratch("render-bad");
    let scene = dir.join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let png = dir.join("out.png");
    let s = scene.to_str().unwrap();
    let p = png.to_str().unwrap();
    let out = isokit(&[
        "render",
        s,
        "-o",
        p,
        "--width",
        "100000000",
        "--height",
        "100000000",
    ]);
    assert_clear_error(&out, "image size 100000000x100000000");
    let out = isokit(&["render", s, "-o", p, "--width", "0"]);
    assert_clear_error(&out, "image size");
    let out = isokit(&["render", s, "-o", p, "--shading", "sparkly"]);
    assert_clear_error(&out, "unknown shading mode");
    let out = isokit(&[
        "render", s, "-o", p, "--r0", "0", "--width", "8", "--height", "8",
    ]);
    assert_clear_error(&out, "r0");
    let out = isokit(&["render", s, "-o", dir.join("x.jpg").to_str().unwrap()]);
    assert_clear_error(&out, "unknown output format");
    std::fs::write(&scene, "{\"shape\": {\"sphere\": {\"radius\": -1}}}").unwrap();
    let out = isokit(&["render", s, "-o", p, "--width", "8", "--height", "8"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!png.exists());
}

/// `--watch` renders again when the scene changes, keeps the last good image when the
/// scene is broken, and picks up the repaired scene.
#[test]
fn watch_keeps_the_last_good_image() {
    let dir = scratch("render-watch");
    let scene = dir.join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let png = dir.join("w.png");
    let mut child = Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "32",
            "--watch",
            "--watch-renders",
            "3",
        ])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let stderr = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let wait_for = |needle: &str| {
        let t = Instant::now();
        loop {
            let line = rx
                .recv_timeout(Duration::from_secs(120).saturating_sub(t.elapsed()))
                .unwrap_or_else(|_| panic!("no line with {needle:?}"));
            if line.contains(needle) {
                return line;
            }
        }
    };
    wait_for("[watch] waiting");
    let first = std::fs::read(&png).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    std::fs::write(&scene, "{\"shape\": {\"sphere\": {\"radius\": \"big\"}}}").unwrap();
    let err = wait_for("[watch] error");
    assert!(err.contains("keeping the last good image"), "{err}");
    assert_eq!(std::fs::read(&png).unwrap(), first);
    wait_for("[watch] waiting");
    std::fs::write(&scene, SCENE.replace("0.8", "0.6")).unwrap();
    wait_for("[watch] rendered");
    assert!(child.wait().unwrap().success());
    assert_ne!(std::fs::read(&png).unwrap(), first);
}

#[test]
fn demo_renders_the_bundled_scene() {
    let dir = scratch("demo");
    let png = dir.join("demo.png");
    let out = isokit_ok(&[
        "demo",
        "-o",
        png.to_str().unwrap(),
        "--width",
        "48",
        "--height",
        "36",
        "--res",
        "64",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    for stage in [
        "load", "sample", "blocks", "trace", "shade", "write", "total",
    ] {
        assert!(err.lines().any(|l| l.starts_with(stage)), "{stage}: {err}");
    }
    let (w, h, px) = isokit::io::read_png(&png).unwrap();
    assert_eq!((w, h), (48, 36));
    // Not just background: the knot and sphere cover part of the image.
    let bg = &px[0..4];
    let covered = px.chunks(4).filter(|p| p != &bg).count();
    assert!(covered > 200, "{covered} pixels differ from the background");
}

#[test]
fn render_for_a_multiview_display() {
    let dir = scratch("render-views");
    let scene = dir.join("s.json");
    std::fs::write(&scene, SCENE).unwrap();
    let png = dir.join("mv.png");
    let views = dir.join("views");
    let j = json(&isokit_ok(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--width",
        "20",
        "--height",
        "12",
        "--views",
        "4",
        "--lens-slant",
        "0.333",
        "--views-out",
        views.to_str().unwrap(),
        "--stats",
    ]));
    assert_eq!(j["width"], 20);
    let (w, h, _) = isokit::io::read_png(&png).unwrap();
    assert_eq!((w, h), (20, 12));
    for k in 0..4 {
        let (w, h, _) = isokit::io::read_png(&views.join(format!("view_{k:02}.png"))).unwrap();
        assert_eq!((w, h), (20, 12));
    }
    let out = isokit(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--views",
        "1",
    ]);
    assert_clear_error(&out, "views");
}

#[test]
fn direct_volume_rendering_of_a_volume_to_png_and_an_rgbaz_gbuffer() {
    let dir = scratch("render-dvr");
    // A sphere's signed distance on a 32³ lattice, inside glowing.
    let n = 32;
    let h = 2.0 / (n - 1) as f32;
    let values: Vec<f32> = (0..n * n * n)
        .map(|e| {
            let p = glam::Vec3::new((e % n) as f32, ((e / n) % n) as f32, (e / (n * n)) as f32);
            (p * h - glam::Vec3::ONE).length() - 0.6
        })
        .collect();
    let grid = isokit::field::Grid::from_data([n; 3], glam::Vec3::splat(-1.0), h, values).unwrap();
    let vol = dir.join("ball.nrrd");
    isokit::io::write_nrrd_raw(&vol, &isokit::io::Volume::from_grid(&grid)).unwrap();
    let tf = dir.join("tf.json");
    std::fs::write(
        &tf,
        r#"{"points": [[-0.05, 1, 0.5, 0.2, 3], [0, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    for (classification, shading) in [("post", "emission"), ("preintegrated", "phong")] {
        let png = dir.join(format!("{classification}.png"));
        let exr = dir.join(format!("{classification}.exr"));
        let mut args = vec![
            "render",
            vol.to_str().unwrap(),
            "--mode",
            "dvr",
            "--tf",
            tf.to_str().unwrap(),
            "--classification",
            classification,
            "--width",
            "24",
            "--height",
            "24",
            "--eye",
            "0,0,4",
            "-o",
            png.to_str().unwrap(),
            "--gbuffer",
            exr.to_str().unwrap(),
            "--stats",
        ];
        if shading == "phong" {
            // With the incremental table: the same centre opacity to the tolerance below.
            args.extend(["--shading", "phong", "--table-build", "incremental"]);
        }
        let stats = json(&isokit_ok(&args));
        assert_eq!(stats["mode"], "dvr");
        assert_eq!(stats["classification"], classification);
        assert_eq!(stats["shading"], shading);
        let gradient = if shading == "phong" { "tricubic" } else { "" };
        assert_eq!(stats["gradient"].as_str().unwrap_or(""), gradient);
        assert!(png.is_file());
        let g = isokit::io::read_exr(&exr).unwrap();
        let (a, z) = (g.channel("A").unwrap(), g.channel("Z").unwrap());
        for c in ["R", "G", "B"] {
            assert!(g.channel(c).is_some(), "{c}");
        }
        // The centre's ray crosses 1.2 of the sphere at sigma 3: opacity 1 - exp(-3.6)
        // (to the step's and the lattice's accuracy); the corner's misses it.
        let centre = 12 * 24 + 12;
        assert!(
            (a[centre] - (1.0 - (-3.6f32).exp())).abs() < 0.03,
            "{}",
            a[centre]
        );
        assert!(a[0] == 0.0 && z[0].is_infinite());
        // Opacity passes 0.5 about 0.23 inside the sphere's front at z = 0.6: from the eye
        // at 4, near 3.4 + 0.23.
        assert!((z[centre] - 3.63).abs() < 0.1, "{}", z[centre]);
    }
    // What --mode dvr needs and refuses, in one line each.
    for (extra, want) in [
        (vec![], "needs --tf"),
        (
            vec!["--tf", "no-such-preset"],
            "neither a file nor a preset",
        ),
        (vec!["--tf", "ct-bone", "--step", "0"], "step = 0"),
        (
            vec!["--tf", "ct-bone", "--shading", "tone"],
            "shades with phong",
        ),
        (
            vec![
                "--tf",
                "ct-bone",
                "--classification",
                "preintegrated",
                "--table-size",
                "1",
            ],
            "pre-integration table size",
        ),
        (
            vec!["--tf", "ct-bone", "--gradient", "central"],
            "with --shading phong",
        ),
        (
            vec!["--tf", "ct-bone", "--table-build", "incremental"],
            "--classification preintegrated",
        ),
    ] {
        let mut args = vec![
            "render",
            vol.to_str().unwrap(),
            "--mode",
            "dvr",
            "-o",
            "x.png",
        ];
        args.extend(extra);
        assert_clear_error(&isokit(&args), want);
    }
    // The flags of --mode dvr are refused in the isosurface mode, not ignored.
    for flag in [
        &["--tf", "ct-bone"][..],
        &["--table-size", "64"],
        &["--step", "0.1"],
        &["--gradient", "central"],
        &["--table-build", "incremental"],
    ] {
        let mut args = vec!["render", vol.to_str().unwrap(), "-o", "x.png"];
        args.extend_from_slice(flag);
        assert_clear_error(&isokit(&args), "applies to --mode dvr");
    }
}
