//! End-to-end tests of everyday rendering from the command line: errors that list the valid
//! choices, one default image size, notes only where a GPU would have been used, the camera
//! on the command line, antialiasing with coverage, the camera in the G-buffer's EXR
//! header, molecule selections and the warning about walls too thin for curvature.

mod common;

use common::{assert_clear_error, isokit, isokit_ok, json, scratch};
use isokit::render::ShadingMode;
use std::path::Path;

const SCENE: &str = r#"{
  "shape": {"difference": [
    {"sphere": {"radius": 0.8}},
    {"box": {"half": [0.4, 0.4, 0.9], "center": [0.5, 0.3, 0.0]}}
  ]},
  "shading": {"mode": "phong"},
  "sampling": {"resolution": 40}
}"#;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The PNG's pixels as linear RGB.
fn linear(path: &Path) -> (u32, u32, Vec<[f32; 3]>) {
    let (w, h, rgba) = isokit::io::read_png(path).unwrap();
    let px = rgba
        .chunks(4)
        .map(|c| {
            [
                isokit::io::srgb8_to_linear(c[0]),
                isokit::io::srgb8_to_linear(c[1]),
                isokit::io::srgb8_to_linear(c[2]),
            ]
        })
        .collect();
    (w, h, px)
}

// ---- Errors and help ----

/// `isokit render` of a scene file holding `text`, on the CPU.
fn render_scene_text(name: &str, text: &str) -> std::process::Output {
    let dir = scratch(name);
    let scene = write(&dir, "s.json", text);
    isokit(&[
        "render",
        &scene,
        "-o",
        s(&dir.join("o.png")),
        "--backend",
        "cpu",
    ])
}

#[test]
fn a_zero_light_direction_is_named_not_dumped() {
    let out = render_scene_text(
        "zero-light",
        r#"{"shape": {"sphere": {}}, "lights": [{"direction": [1, 0, 0]}, {"direction": [0, 0, 0]}]}"#,
    );
    assert_clear_error(&out, "light direction = [0, 0, 0] (lights[1])");
    let err = stderr(&out);
    assert!(err.contains("nonzero"), "{err}");
    assert!(
        !err.contains("Shading {") && !err.contains("Vec3("),
        "{err}"
    );
}

#[test]
fn a_misspelt_shading_mode_lists_every_mode_of_the_library() {
    let out = render_scene_text(
        "bad-mode",
        r#"{"shape": {"sphere": {}}, "shading": {"mode": "curvture"}}"#,
    );
    assert_clear_error(&out, "curvture");
    let err = stderr(&out);
    for (name, _) in ShadingMode::ALL {
        assert!(err.contains(name), "{name} missing from: {err}");
    }
}

#[test]
fn render_help_lists_every_shading_mode_of_the_library() {
    let out = isokit_ok(&["render", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    let line = help
        .lines()
        .find(|l| l.contains("possible values") && l.contains("phong"))
        .expect("a list of shading modes");
    for (name, _) in ShadingMode::ALL {
        assert!(line.contains(name), "{name} missing from: {line}");
    }
}

#[test]
fn every_error_about_a_choice_lists_the_choices() {
    let dir = scratch("choices");
    let scene = write(&dir, "s.json", SCENE);
    let png = dir.join("o.png");
    let cases: [(&[&str], &[&str]); 5] = [
        (
            &["--projection", "fisheye"],
            &["perspective", "orthographic"],
        ),
        (&["--filter", "quintic"], &["trilinear", "tricubic"]),
        (&["--search", "binary"], &["sphere", "fixed"]),
        (&["--samples", "3"], &["1, 4, 9, 16"]),
        (&["--shading", "curvture"], &["phong", "flow", "texture"]),
    ];
    for (flags, choices) in cases {
        let mut args = vec!["render", &scene, "-o", s(&png), "--backend", "cpu"];
        args.extend_from_slice(flags);
        let out = isokit(&args);
        assert!(!out.status.success(), "{flags:?} was accepted");
        let err = stderr(&out);
        for c in choices {
            assert!(err.contains(c), "{flags:?}: {c} missing from: {err}");
        }
    }
}

#[test]
fn scene_nodes_take_the_defaults_of_isokit_sample() {
    let dir = scratch("defaults");
    let scene = write(
        &dir,
        "s.json",
        r#"{"shape": {"sphere": {}}, "sampling": {"resolution": 32}}"#,
    );
    let png = dir.join("o.png");
    let j = json(&isokit_ok(&[
        "render",
        &scene,
        "-o",
        s(&png),
        "--width",
        "48",
        "--height",
        "48",
        "--stats",
        "--backend",
        "cpu",
    ]));
    assert!(j["hits"].as_u64().unwrap() > 200, "{j}");
    // The same defaults as `isokit sample sphere` (radius 1 at the origin): the sampled
    // lattice spans the same box.
    let nrrd = dir.join("s.nrrd");
    isokit_ok(&["sample", "sphere", "-o", s(&nrrd), "--res", "32"]);
    let g = isokit::io::read_volume(&nrrd).unwrap();
    let lo = g.origin.to_array();
    assert!(lo.iter().all(|v| *v < -1.0 && *v > -2.0), "{lo:?}");
}

// ---- Small things ----

#[test]
fn a_missing_input_is_reported_without_a_word_about_adapters() {
    let dir = scratch("missing");
    let png = dir.join("o.png");
    for args in [
        vec!["render", "no/such/scene.json", "-o", s(&png)],
        vec!["render", "no/such/volume.nrrd", "-o", s(&png)],
        vec!["molecule", "no/such.pdb", "-o", s(&png)],
    ] {
        let out = isokit(&args);
        assert!(!out.status.success());
        let err = stderr(&out);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(
            !err.contains("note:") && !err.contains("adapter"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn the_software_adapter_note_is_printed_once_and_only_where_a_gpu_could_run() {
    let dir = scratch("note-once");
    let scene = write(&dir, "s.json", SCENE);
    let png = dir.join("o.png");
    let size = ["--width", "32", "--height", "24"];
    let mut args = vec!["render", &scene, "-o", s(&png), "--backend", "auto"];
    args.extend_from_slice(&size);
    let err = stderr(&isokit_ok(&args));
    assert!(err.matches("note: ").count() <= 1, "{err}");
    // Not before an error in the input either.
    let bad = write(
        &dir,
        "bad.json",
        r#"{"shape": {"sphere": {}}, "lights": [{"direction": [0, 0, 0]}]}"#,
    );
    let out = isokit(&["render", &bad, "-o", s(&png), "--backend", "auto"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(!err.contains("note: "), "{err}");
    // --backend cpu asks for no adapter and says nothing about them.
    let mut args = vec!["render", &scene, "-o", s(&png), "--backend", "cpu"];
    args.extend_from_slice(&size);
    let err = stderr(&isokit_ok(&args));
    assert!(!err.contains("note: ") && !err.contains("adapter"), "{err}");
    // Nor does a command that cannot use a GPU: sampling, or the kd-tree distance.
    let nrrd = dir.join("v.nrrd");
    let err = stderr(&isokit_ok(&[
        "sample",
        "sphere",
        "-o",
        s(&nrrd),
        "--res",
        "16",
    ]));
    assert!(!err.contains("adapter") && !err.contains("GPU"), "{err}");
}

#[test]
fn render_demo_and_molecule_share_one_default_image_size() {
    let dir = scratch("sizes");
    let scene = write(&dir, "s.json", SCENE);
    let (a, b, c) = (dir.join("a.png"), dir.join("b.png"), dir.join("c.png"));
    isokit_ok(&["render", &scene, "-o", s(&a), "--backend", "cpu"]);
    isokit_ok(&["demo", "-o", s(&b), "--scene", &scene, "--backend", "cpu"]);
    let mol = common::data("molecules/1a8o.pdb.gz");
    isokit_ok(&["molecule", &mol, "-o", s(&c), "--backend", "cpu"]);
    for p in [&a, &b, &c] {
        let (w, h, _) = isokit::io::read_png(p).unwrap();
        assert_eq!((w, h), (640, 480), "{}", p.display());
    }
}

fn molecule_atoms(path: &str, extra: &[&str]) -> u64 {
    let dir = scratch("mol-atoms");
    let png = dir.join("m.png");
    let mut args = vec![
        "molecule",
        path,
        "-o",
        s(&png),
        "--width",
        "64",
        "--height",
        "48",
        "--stats",
        "--backend",
        "cpu",
    ];
    args.extend_from_slice(extra);
    json(&isokit_ok(&args))["atoms"].as_u64().unwrap()
}

#[test]
fn molecule_hides_water_and_selects_chains() {
    let path = common::data("molecules/1a8o.pdb.gz");
    let mol = isokit::molecule::read_molecule(Path::new(&path)).unwrap();
    let waters = mol.atoms.iter().filter(|a| a.residue == "HOH").count() as u64;
    assert!(waters > 0);
    let all = molecule_atoms(&path, &[]);
    assert_eq!(all, mol.atoms.len() as u64);
    assert_eq!(molecule_atoms(&path, &["--no-water"]), all - waters);

    let path = common::data("molecules/7ddo.pdb.gz");
    let mol = isokit::molecule::read_molecule(Path::new(&path)).unwrap();
    let in_a = mol.atoms.iter().filter(|a| a.chain == "A").count() as u64;
    assert!(in_a > 0 && in_a < mol.atoms.len() as u64);
    assert_eq!(molecule_atoms(&path, &["--chains", "A"]), in_a);
    assert_eq!(
        molecule_atoms(&path, &["--chains", "A,C"]),
        mol.atoms
            .iter()
            .filter(|a| a.chain == "A" || a.chain == "C")
            .count() as u64
    );
    let dir = scratch("mol-chains");
    let out = isokit(&[
        "molecule",
        &path,
        "-o",
        s(&dir.join("m.png")),
        "--chains",
        "Z",
        "--backend",
        "cpu",
    ]);
    assert_clear_error(&out, "no chain \"Z\"");
    let err = stderr(&out);
    assert!(err.contains("\"A\"") && err.contains("\"C\""), "{err}");
}

/// `p` through the row-vector matrix `m` (OpenEXR's convention) to pixel coordinates.
fn to_pixel(m: &[f32; 16], p: [f32; 3], w: f32, h: f32) -> (f32, f32) {
    let mat = glam::Mat4::from_cols_array(m);
    let c = mat * glam::Vec4::new(p[0], p[1], p[2], 1.0);
    let (x, y) = (c.x / c.w, c.y / c.w);
    ((x + 1.0) * 0.5 * w, (1.0 - y) * 0.5 * h)
}

/// Every hit pixel's position projects through the header's `worldToNDC` into that pixel.
fn check_exr_camera(exr: &Path) {
    let img = isokit::io::read_exr(exr).unwrap();
    let cam = img.camera.expect("the header holds the camera");
    let (w, h) = (img.width, img.height);
    let (px, py, pz, a) = (
        img.channel("P.X").unwrap(),
        img.channel("P.Y").unwrap(),
        img.channel("P.Z").unwrap(),
        img.channel("A").unwrap(),
    );
    let mut hits = 0;
    for i in 0..w * h {
        if a[i] == 0.0 {
            continue;
        }
        hits += 1;
        let (x, y) = to_pixel(&cam.world_to_ndc, [px[i], py[i], pz[i]], w as f32, h as f32);
        let (cx, cy) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        assert!(
            (x - cx).abs() < 0.05 && (y - cy).abs() < 0.05,
            "pixel ({cx}, {cy}) projects to ({x}, {y})"
        );
        // worldToCamera puts the point in front of the camera (−z), at the G-buffer's depth
        // along the ray or less.
        let v = glam::Mat4::from_cols_array(&cam.world_to_camera)
            * glam::Vec4::new(px[i], py[i], pz[i], 1.0);
        assert!(v.z < 0.0, "{v}");
    }
    assert!(hits > 100, "{hits} hits");
}

/// `isokit COMMAND INPUT` to a 48×32 image and its G-buffer `NAME.exr` in `dir` on the
/// CPU, with `extra` flags; the G-buffer's path.
fn small_gbuffer(
    command: &str,
    input: &str,
    dir: &Path,
    name: &str,
    extra: &[&str],
) -> std::path::PathBuf {
    let (png, exr) = (
        dir.join(format!("{name}.png")),
        dir.join(format!("{name}.exr")),
    );
    let mut args = vec![
        command,
        input,
        "-o",
        s(&png),
        "--width",
        "48",
        "--height",
        "32",
        "--gbuffer",
        s(&exr),
        "--backend",
        "cpu",
    ];
    args.extend_from_slice(extra);
    isokit_ok(&args);
    exr
}

#[test]
fn the_gbuffer_exr_holds_the_camera() {
    let dir = scratch("exr-camera");
    let scene = write(&dir, "s.json", SCENE);
    check_exr_camera(&small_gbuffer(
        "render",
        &scene,
        &dir,
        "g",
        &["--eye", "1.5,1,2.5"],
    ));
    let mol = common::data("molecules/1a8o.pdb.gz");
    check_exr_camera(&small_gbuffer("molecule", &mol, &dir, "m", &[]));
}

// ---- The camera on the command line ----

#[test]
fn a_camera_on_the_command_line_equals_the_same_camera_in_the_scene_file() {
    let dir = scratch("camera");
    let plain = write(&dir, "plain.json", SCENE);
    let with_camera = SCENE.replacen(
        "\"shading\"",
        r#""camera": {"eye": [0.3, 2.2, 1.9], "target": [0.1, 0, 0], "up": [0, 0, -1], "fov": 35, "ortho_height": 1.3},
  "shading""#,
        1,
    );
    let framed = write(&dir, "framed.json", &with_camera);
    let flags = [
        "--eye",
        "0.3,2.2,1.9",
        "--target",
        "0.1,0,0",
        "--up",
        "0,0,-1",
        "--fov",
        "35",
    ];
    for projection in ["perspective", "orthographic"] {
        let (a, b, c) = (dir.join("a.png"), dir.join("b.png"), dir.join("c.png"));
        let common = [
            "--width",
            "64",
            "--height",
            "48",
            "--backend",
            "cpu",
            "--projection",
            projection,
        ];
        let mut args = vec!["render", &plain, "-o", s(&a)];
        args.extend_from_slice(&common);
        args.extend_from_slice(&flags);
        if projection == "orthographic" {
            args.extend_from_slice(&["--ortho-height", "1.3"]);
        }
        isokit_ok(&args);
        let mut args = vec!["render", &framed, "-o", s(&b)];
        args.extend_from_slice(&common);
        isokit_ok(&args);
        let mut args = vec!["render", &plain, "-o", s(&c)];
        args.extend_from_slice(&common);
        isokit_ok(&args);
        let (pa, pb, pc) = (
            isokit::io::read_png(&a).unwrap(),
            isokit::io::read_png(&b).unwrap(),
            isokit::io::read_png(&c).unwrap(),
        );
        assert!(
            pa == pb,
            "{projection}: the flags and the scene's camera differ"
        );
        assert!(pa != pc, "{projection}: the flags changed nothing");
    }
}

#[test]
fn a_volume_is_framed_from_the_command_line() {
    let dir = scratch("camera-volume");
    let nrrd = dir.join("v.nrrd");
    isokit_ok(&["sample", "torus", "-o", s(&nrrd), "--res", "40"]);
    let png = dir.join("v.png");
    let exr = dir.join("v.exr");
    let args = [
        "render",
        s(&nrrd),
        "-o",
        s(&png),
        "--width",
        "40",
        "--height",
        "40",
        "--backend",
        "cpu",
        "--eye",
        "0.001,0,3",
        "--up",
        "0,1,0",
        "--fov",
        "50",
        "--gbuffer",
        s(&exr),
        "--stats",
    ];
    let j = json(&isokit_ok(&args));
    assert!(j["hits"].as_u64().unwrap() > 200, "{j}");
    // Seen along its axis (z) the torus shows its hole: the centre pixel misses; the
    // header's view matrix puts the eye where --eye says.
    let img = isokit::io::read_exr(&exr).unwrap();
    let a = img.channel("A").unwrap();
    assert_eq!(a[20 * 40 + 20], 0.0, "the hole is in the middle");
    let v = glam::Mat4::from_cols_array(&img.camera.unwrap().world_to_camera);
    let eye = v.inverse().transform_point3(glam::Vec3::ZERO);
    assert!(
        (eye - glam::Vec3::new(0.001, 0.0, 3.0)).length() < 1e-4,
        "{eye}"
    );
    // Refused: flags that need --eye, a height without orthographic projection.
    let out = isokit(&["render", s(&nrrd), "-o", s(&png), "--target", "0,0,0"]);
    assert!(
        !out.status.success() && stderr(&out).contains("--eye"),
        "{}",
        stderr(&out)
    );
    let out = isokit(&[
        "render",
        s(&nrrd),
        "-o",
        s(&png),
        "--eye",
        "0,3,0",
        "--up",
        "0,1,0",
        "--backend",
        "cpu",
    ]);
    assert_clear_error(&out, "parallel");
    let out = isokit(&[
        "render",
        s(&nrrd),
        "-o",
        s(&png),
        "--eye",
        "0,0,3",
        "--ortho-height",
        "2",
        "--backend",
        "cpu",
    ]);
    assert_clear_error(&out, "--projection orthographic");
}

#[test]
fn molecule_takes_the_camera_from_the_command_line() {
    let dir = scratch("camera-molecule");
    let mol = common::data("molecules/1a8o.pdb.gz");
    let exr = small_gbuffer(
        "molecule",
        &mol,
        &dir,
        "m",
        &[
            "--eye",
            "0,0,90",
            "--target",
            "0,0,0",
            "--projection",
            "orthographic",
            "--ortho-height",
            "60",
        ],
    );
    let img = isokit::io::read_exr(&exr).unwrap();
    let cam = img.camera.unwrap();
    // Orthographic: worldToNDC scales y by 2 / height.
    let m = glam::Mat4::from_cols_array(&cam.world_to_ndc);
    let v = glam::Mat4::from_cols_array(&cam.world_to_camera);
    let proj = m * v.inverse();
    assert!((proj.y_axis.y - 2.0 / 60.0).abs() < 1e-5, "{proj}");
    assert!(proj.w_axis.w == 1.0 && proj.z_axis.w == 0.0, "{proj}");
}

// ---- Antialiasing ----

fn render_png(scene: &str, out: &Path, w: u32, h: u32, extra: &[&str]) {
    let (ws, hs) = (w.to_string(), h.to_string());
    let mut args = vec![
        "render",
        scene,
        "-o",
        s(out),
        "--width",
        &ws,
        "--height",
        &hs,
        "--backend",
        "cpu",
        "--eye",
        "1.6,1.1,2.3",
    ];
    args.extend_from_slice(extra);
    isokit_ok(&args);
}

#[test]
fn samples_4_is_closer_to_a_16x_supersampled_reference_and_edges_get_coverage() {
    let dir = scratch("antialias");
    let scene = write(&dir, "s.json", SCENE);
    let (w, h) = (48u32, 36u32);
    let reference = dir.join("ref.png");
    // Brute force: 16 rays per pixel as a 4× larger image, box-filtered here.
    render_png(&scene, &reference, 4 * w, 4 * h, &[]);
    let (_, _, big) = linear(&reference);
    let mut want = vec![[0.0f32; 3]; (w * h) as usize];
    for y in 0..4 * h {
        for x in 0..4 * w {
            let p = big[(y * 4 * w + x) as usize];
            let o = &mut want[((y / 4) * w + x / 4) as usize];
            for c in 0..3 {
                o[c] += p[c] / 16.0;
            }
        }
    }
    let error = |samples: &str| {
        let png = dir.join(format!("s{samples}.png"));
        let exr = dir.join(format!("s{samples}.exr"));
        render_png(
            &scene,
            &png,
            w,
            h,
            &["--samples", samples, "--gbuffer", s(&exr)],
        );
        let (_, _, got) = linear(&png);
        let e: f32 = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>())
            .sum();
        let img = isokit::io::read_exr(&exr).unwrap();
        let a = img.channel("A").unwrap().to_vec();
        (e / (w * h) as f32, a)
    };
    let (e1, a1) = error("1");
    let (e4, a4) = error("4");
    assert!(e4 < 0.6 * e1, "samples 4: {e4}, samples 1: {e1}");
    assert!(a1.iter().all(|&v| v == 0.0 || v == 1.0));
    let partial = a4.iter().filter(|&&v| v > 0.0 && v < 1.0).count();
    assert!(partial > 20, "{partial} pixels of fractional coverage");
    assert!(a4.iter().all(|&v| [0.0, 0.25, 0.5, 0.75, 1.0].contains(&v)));
}

// ---- Thin walls and curvature ----

fn shell_scene(thickness: f32) -> String {
    format!(
        r#"{{
  "shape": {{"difference": [
    {{"shell": {{"thickness": {thickness}, "of": {{"rounded_box": {{"half": [1.2, 0.2, 0.8], "radius": 0.05}}}}}}}},
    {{"box": {{"half": [0.8, 0.8, 0.8], "center": [0.8, 0.8, 0.8]}}}}
  ]}},
  "camera": {{"eye": [2.5, 2.0, 3.0], "target": [0, 0, 0], "fov": 40}},
  "sampling": {{"resolution": 160}}
}}"#
    )
}

#[test]
fn a_wall_too_thin_for_the_curvature_filter_is_warned_about_with_the_remedy() {
    let dir = scratch("thin");
    for (thickness, warned) in [(0.04, true), (0.12, false)] {
        let scene = write(&dir, &format!("s{thickness}.json"), &shell_scene(thickness));
        for mode in ["curvature", "ridges", "phong"] {
            let out = isokit_ok(&[
                "render",
                &scene,
                "-o",
                s(&dir.join("o.png")),
                "--width",
                "96",
                "--height",
                "72",
                "--backend",
                "cpu",
                "--shading",
                mode,
            ]);
            let err = stderr(&out);
            let want = warned && mode != "phong";
            assert_eq!(
                err.contains("crease of the distance field"),
                want,
                "{thickness} {mode}: {err}"
            );
            if want {
                assert!(err.contains("--res "), "{err}");
            }
        }
    }
}

/// The GPU twin traces the supersampled frame as the CPU twin does: the same coverage, the
/// same picture to rounding (skipped without an adapter, failed when `ISOKIT_REQUIRE_GPU=1`).
#[test]
fn samples_on_the_gpu_match_the_cpu() {
    if isokit::render::gpu::testing::run_or_skip(
        "samples_on_the_gpu_match_the_cpu",
        isokit::render::gpu::GpuRenderer::open().map(|g| g.describe()),
        |name| name.clone(),
    )
    .is_none()
    {
        return;
    }
    let dir = scratch("antialias-gpu");
    let scene = write(&dir, "s.json", SCENE);
    let run = |backend: &str| {
        let png = dir.join(format!("{backend}.png"));
        let exr = dir.join(format!("{backend}.exr"));
        isokit_ok(&[
            "render",
            &scene,
            "-o",
            s(&png),
            "--width",
            "40",
            "--height",
            "30",
            "--samples",
            "9",
            "--gbuffer",
            s(&exr),
            "--backend",
            backend,
            "--eye",
            "1.6,1.1,2.3",
        ]);
        let a = isokit::io::read_exr(&exr)
            .unwrap()
            .channel("A")
            .unwrap()
            .to_vec();
        (isokit::io::read_png(&png).unwrap().2, a)
    };
    let (cpu, ca) = run("cpu");
    let (gpu, ga) = run("gpu");
    let differ = ca.iter().zip(&ga).filter(|(a, b)| a != b).count();
    assert!(differ <= 2, "{differ} pixels of other coverage");
    let mean: f64 = cpu
        .chunks(4)
        .zip(gpu.chunks(4))
        .map(|(p, q)| (0..3).map(|c| f64::from(p[c].abs_diff(q[c]))).sum::<f64>())
        .sum::<f64>()
        / (3 * cpu.len() / 4) as f64;
    assert!(mean < 0.1, "mean |Δ| {mean} of 255");
}
