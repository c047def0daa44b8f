//! Hostile input through the real binary: the memory budget, bounded reads of referenced
//! files, nothing lost by the readers, clear errors, early refusals of unbounded work and
//! checked knobs. Each test reproduces an input that failed before its fix (an abort, a read
//! until memory ran out, a silent loss, a message naming the wrong thing, a slow refusal).

mod common;

use common::*;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `isokit` with `args` under `sh -c PREFIX`, killed after `limit`; returns the output
/// and the seconds it took, or panics naming the run when it did not finish in time.
fn run_limited(prefix: &str, args: &[&str], envs: &[(&str, &str)], limit: u64) -> (Output, f64) {
    let t0 = Instant::now();
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("{prefix} exec \"$@\""))
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_isokit"))
        .args(args)
        .envs(envs.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Both pipes drained while waiting: a child that writes more than a pipe holds would
    // otherwise block until the limit.
    let drain = |r: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut r) = r {
                let _ = r.read_to_end(&mut buf);
            }
            buf
        })
    };
    let stdout = drain(child.stdout.take().map(|r| Box::new(r) as _));
    let stderr = drain(child.stderr.take().map(|r| Box::new(r) as _));
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if t0.elapsed() > Duration::from_secs(limit) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("isokit {} ran past {limit} s", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let status = child.wait().unwrap();
    let out = Output {
        status,
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
    };
    (out, t0.elapsed().as_secs_f64())
}

fn write(d: &std::path::Path, name: &str, text: &str) -> String {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

// ------------------------------------------------------------------ the memory budget

/// 1200³ is under the 2³¹-sample limit, but its 6.9 GB grid was allocated at once and
/// aborted the process where memory is short (exit 134 and a backtrace). Under an address
/// space limit the default budget (a share of it) refuses it at once, in one line.
#[cfg(target_os = "linux")]
#[test]
fn a_dense_grid_over_the_budget_is_refused_before_sampling() {
    let d = scratch("budget-grid");
    let s = write(
        &d,
        "s.json",
        r#"{"shape":{"sphere":{"radius":0.5}},"sampling":{"resolution":1200}}"#,
    );
    let out = d.join("o.nrrd").display().to_string();
    let (o, secs) = run_limited("ulimit -v 3000000;", &["scene", &s, "-o", &out], &[], 60);
    assert_clear_error(&o, "the dense output grid of 1200 x 1200 x 1200 samples");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("6912000000 bytes") && err.contains("memory budget"),
        "{err}"
    );
    assert!(err.contains("lower the resolution"), "{err}");
    eprintln!("refused after {secs} s"); // not asserted: only run_limited's limit catches a hang
    // The flag and the variable set it too.
    for (args, envs) in [
        (vec!["--max-memory", "1G"], vec![]),
        (vec![], vec![("ISOKIT_MAX_MEMORY", "1G")]),
    ] {
        let mut all = vec!["scene", &s, "-o", &out];
        all.extend(args);
        let (o, _) = run_limited("", &all, &envs, 60);
        assert_clear_error(&o, "over the memory budget of 1.0 GiB");
    }
    let (o, _) = run_limited(
        "",
        &["scene", &s, "-o", &out],
        &[("ISOKIT_MAX_MEMORY", "lots")],
        60,
    );
    assert_clear_error(&o, "ISOKIT_MAX_MEMORY");
    let (o, _) = run_limited("", &["scene", &s, "-o", &out, "--max-memory", "0"], &[], 60);
    assert_clear_error(&o, "--max-memory");
    assert!(!std::path::Path::new(&out).exists());
}

/// Every stage that holds big buffers checks the budget first: a dense sample, the brick
/// sampler's kept bricks, an image and its G-buffer, a molecule scene.
#[test]
fn each_stage_refuses_what_does_not_fit() {
    let d = scratch("budget-stages");
    let out = |n: &str| d.join(n).display().to_string();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["sample", "sphere", "--res", "1000", "-o", &out("a.nrrd")]
                .into_iter()
                .map(String::from)
                .collect(),
            "a dense grid of 1000 x 1000 x 1000 samples",
        ),
        (
            vec![
                "render",
                &write(&d, "r.json", r#"{"shape":{"sphere":{}}}"#),
                "-o",
                &out("r.png"),
                "--width",
                "8000",
                "--height",
                "8000",
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            "the G-buffer and image of 8000x8000 pixels",
        ),
        (
            vec![
                "scene",
                &write(&d, "m.json", r#"{"shape":{"sphere":{}}}"#),
                "--res",
                "1200",
                "-o",
                &out("m.obj"),
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            "bricks",
        ),
        (
            vec![
                "molecule",
                &data("molecules/7ddo.pdb.gz"),
                "-o",
                &out("m.png"),
                "--width",
                "64",
                "--height",
                "64",
                "--max-memory",
                "2M",
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            "the scene of",
        ),
    ];
    for (mut args, needle) in cases {
        if !args.iter().any(|a| a == "--max-memory") {
            args.extend(["--max-memory".into(), "256M".into()]);
        }
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let (o, secs) = run_limited("", &a, &[], 60);
        assert_clear_error(&o, needle);
        assert_clear_error(&o, "memory budget");
        eprintln!("{needle}: refused after {secs} s"); // not asserted: only run_limited's limit catches a hang
    }
}

/// White noise crosses the isovalue on about half of all lattice edges: its mesh is many
/// times the size of the volume. Both meshers count what they hold against the budget while
/// meshing and refuse in one line, leaving no output behind.
#[test]
fn a_noise_volume_whose_mesh_exceeds_the_budget_is_refused() {
    let d = scratch("budget-mesh");
    let n = 64;
    let mut rng = isokit_field::rng::SplitMix64::new(7);
    let noise: Vec<f32> = (0..n * n * n).map(|_| rng.next_f32() - 0.5).collect();
    let vol = d.join("noise.npy");
    isokit_io::write_npy_f32(&vol, &[n, n, n], &noise).unwrap();
    let vol = vol.display().to_string();
    let out = d.join("m.obj").display().to_string();
    for mesher in ["mc", "dual"] {
        let args = [
            "mesh",
            &vol,
            "-o",
            &out,
            "--mesher",
            mesher,
            "--max-memory",
            "8M",
        ];
        let (o, _) = run_limited("", &args, &[], 60);
        assert_clear_error(&o, "memory budget of 8.0 MiB");
        assert!(!std::path::Path::new(&out).exists(), "{mesher}");
        // The same volume meshes within the default budget.
        let ok = isokit(&["mesh", &vol, "-o", &out, "--mesher", mesher]);
        assert!(
            ok.status.success(),
            "{mesher}: {}",
            String::from_utf8_lossy(&ok.stderr)
        );
        std::fs::remove_file(&out).unwrap();
    }
}

// ------------------------------------------------------------------ bounded reads

/// A glTF buffer on `/dev/zero` and a detached NRRD on `/dev/urandom` were read until memory
/// ran out; now a referenced file must be a regular file, and only the declared bytes are
/// read from it.
#[cfg(target_os = "linux")]
#[test]
fn referenced_data_files_are_read_to_their_declared_size_only() {
    let d = scratch("bounded-reads");
    let gltf = write(
        &d,
        "z.gltf",
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"/dev/zero","byteLength":100}],
            "bufferViews":[{"buffer":0,"byteLength":36}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
            "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]}"#,
    );
    let nhdr = write(
        &d,
        "u.nhdr",
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 8 8 8\nencoding: raw\nendian: little\ndata file: /dev/urandom\n",
    );
    for input in [&gltf, &nhdr] {
        for cmd in ["info", "octree"] {
            let mut args = vec![cmd, input.as_str()];
            if cmd == "octree" {
                args.extend(["--max-level", "3"]);
            }
            let (o, secs) = run_limited("ulimit -v 4000000;", &args, &[], 30);
            assert_clear_error(&o, "is not a regular file");
            eprintln!("{cmd} {input}: {secs} s"); // not asserted: only run_limited's limit catches a hang
        }
    }
    // A regular data file longer than declared: the declared bytes are used, the rest is
    // not read; a shorter one is refused.
    let raw: Vec<u8> = (0..8 * 8 * 8 + 1000)
        .flat_map(|i| (i as f32 - 256.0).to_le_bytes())
        .collect();
    std::fs::write(d.join("long.raw"), &raw).unwrap();
    std::fs::write(d.join("short.raw"), &raw[..100]).unwrap();
    let long = write(
        &d,
        "long.nhdr",
        &std::fs::read_to_string(&nhdr)
            .unwrap()
            .replace("/dev/urandom", "long.raw"),
    );
    let info = json(&isokit(&["info", &long, "--json"]));
    assert_eq!(info["dims"], serde_json::json!([8, 8, 8]));
    assert_eq!(info["range"][1].as_f64(), Some(255.0));
    let short = write(
        &d,
        "short.nhdr",
        &std::fs::read_to_string(&nhdr)
            .unwrap()
            .replace("/dev/urandom", "short.raw"),
    );
    assert_clear_error(&isokit(&["info", &short]), "fewer than the 2048 declared");
}

// ------------------------------------------------------------------ no silent loss

/// A vertex no face uses is kept and counted; an OBJ of `v` lines only is a point cloud.
#[test]
fn obj_vertices_are_never_dropped() {
    let d = scratch("obj-loss");
    let four = write(
        &d,
        "four.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\n",
    );
    let info = json(&isokit(&["info", &four, "--json"]));
    assert_eq!(info["vertices"], 4, "{info}");
    assert_eq!(info["unreferenced_vertices"], 1, "{info}");
    let mut text = String::new();
    for i in 0..20_000 {
        text.push_str(&format!("v {i} {} 0.5\n", i % 7));
    }
    let vonly = write(&d, "vonly.obj", &text);
    let info = json(&isokit(&["info", &vonly, "--json"]));
    assert_eq!(info["kind"], "points", "{info}");
    assert_eq!(info["points"], 20_000, "{info}");
    let xyz = d.join("v.xyz");
    isokit_ok(&["convert", &vonly, xyz.to_str().unwrap()]);
    let back = isokit::io::read_points(&xyz).unwrap();
    assert_eq!(back.points.len(), 20_000);
    assert_eq!(
        back.points[19_999],
        glam::Vec3::new(19_999.0, 19_999.0 % 7.0, 0.5)
    );
    // A non-UTF-8 file name still has an extension.
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let odd = d.join(std::ffi::OsStr::from_bytes(b"\xff\xfe.obj"));
        std::fs::copy(&four, &odd).unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_isokit"))
            .arg("info")
            .arg(&odd)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
}

// ------------------------------------------------------------------ checked knobs

/// Knobs outside their meaning were accepted: a negative, NaN or huge sibling overlap, a
/// leaf size of 0, a padding or band that leaves the shape between two samples.
#[test]
fn knobs_outside_their_range_are_refused_naming_the_flag() {
    let d = scratch("knobs");
    let mesh = data("sphere.obj");
    let out = d.join("o.npy").display().to_string();
    for v in ["-1", "NaN", "100", "1e30"] {
        let o = isokit(&["sdf", &mesh, "--res", "8", "-o", &out, "--max-overlap", v]);
        assert_clear_error(&o, "--max-overlap");
    }
    assert_clear_error(
        &isokit(&["sdf", &mesh, "--res", "8", "-o", &out, "--leaf-size", "0"]),
        "--leaf-size",
    );
    assert_clear_error(
        &isokit(&[
            "sample", "sphere", "--res", "16", "--pad", "1e30", "-o", &out,
        ]),
        "--pad",
    );
    let s = write(&d, "s.json", r#"{"shape":{"sphere":{}}}"#);
    assert_clear_error(
        &isokit(&["scene", &s, "--res", "16", "--band", "1e30", "-o", &out]),
        "--band",
    );
    assert!(!std::path::Path::new(&out).exists());
}

/// A valid 100-deep `transform` chain nests 200 brackets, past serde_json's limit of 128: it
/// loads. A million nested brackets are refused without overflowing the stack.
#[test]
fn deep_scenes_load_and_absurd_nesting_is_refused() {
    let d = scratch("deep");
    let mut node = r#"{"sphere":{"radius":0.5}}"#.to_string();
    for _ in 0..100 {
        node = format!(r#"{{"transform":{{"translate":[0.001,0,0],"of":{node}}}}}"#);
    }
    let s = write(&d, "deep.json", &format!(r#"{{"shape":{node}}}"#));
    let out = d.join("o.nrrd").display().to_string();
    isokit_ok(&["scene", &s, "--res", "12", "-o", &out]);
    let mut toml_node = String::from("[shape");
    for _ in 0..100 {
        toml_node.push_str(".transform.of");
    }
    let t = write(
        &d,
        "deep.toml",
        &format!("{toml_node}.sphere]\nradius = 0.5\n"),
    );
    isokit_ok(&["scene", &t, "--res", "12", "-o", &out]);
    let brackets = write(
        &d,
        "b.json",
        &("[".repeat(1_000_000) + &"]".repeat(1_000_000)),
    );
    assert_clear_error(
        &isokit(&["scene", &brackets, "-o", &out]),
        "nesting deeper than",
    );
    let dotted = write(
        &d,
        "b.toml",
        &format!("{} = 1\n", vec!["a"; 200_000].join(".")),
    );
    assert_clear_error(
        &isokit(&["scene", &dotted, "-o", &out]),
        "nesting deeper than",
    );
}

// ------------------------------------------------------------------ errors that name the input

/// A coordinate near f32's limit was blamed on `--padding inf`, which nobody passed; NaN
/// vertices printed a debug struct; NaN volumes in `octree` named no file; a scene's bad
/// camera named no node.
#[test]
fn errors_name_the_file_or_flag_the_user_gave() {
    let d = scratch("names");
    let out = d.join("o.npy").display().to_string();
    let huge = write(
        &d,
        "huge.obj",
        "v 0 0 0\nv 3e38 0 0\nv 0 -3e38 1\nf 1 2 3\n",
    );
    let o = isokit(&["sdf", &huge, "--res", "8", "-o", &out]);
    assert_clear_error(&o, "huge.obj");
    assert!(!String::from_utf8_lossy(&o.stderr).contains("--padding"));
    let nan = write(&d, "nan.obj", "v nan 0 0\nv 0 nan 0\nv 0 0 nan\nf 1 2 3\n");
    let o = isokit(&["sdf", &nan, "--res", "8", "-o", &out]);
    assert_clear_error(&o, "nan.obj");
    assert!(!String::from_utf8_lossy(&o.stderr).contains("Aabb"));
    // A volume with NaN samples, and one without a surface, for the octree.
    let mut head =
        String::from("NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 4\nencoding: ascii\n\n");
    let nan_vol = write(&d, "nan.nrrd", &(head.clone() + &"nan ".repeat(64)));
    assert_clear_error(
        &isokit(&["octree", &nan_vol, "--max-level", "3"]),
        "nan.nrrd: 64 of its 64 samples are not finite",
    );
    head.push_str(&"1 ".repeat(64));
    let flat = write(&d, "flat.nrrd", &head);
    let (o, secs) = run_limited("", &["octree", &flat, "--max-level", "6"], &[], 60);
    assert_clear_error(&o, "flat.nrrd: holds no surface");
    eprintln!("{secs} s"); // not asserted: only run_limited's limit catches a hang
    let cam = write(
        &d,
        "cam.json",
        r#"{"shape":{"sphere":{}},"camera":{"eye":[0,0,0],"target":[0,0,0]}}"#,
    );
    let png = d.join("c.png").display().to_string();
    assert_clear_error(
        &isokit(&["render", &cam, "-o", &png, "--width", "8", "--height", "8"]),
        "cam.json: camera:",
    );
}

// ------------------------------------------------------------------ bounded work

/// `octree sphere --max-level 21` (the documented maximum) was refused only after 44 s and
/// 1.7 GB, when the cell limit was reached; the growth of the first levels predicts it.
#[test]
fn an_octree_that_cannot_fit_is_refused_early() {
    let (o, secs) = run_limited(
        "",
        &[
            "octree",
            "sphere",
            "--max-level",
            "21",
            "--max-memory",
            "4G",
        ],
        &[],
        120,
    );
    assert_clear_error(&o, "the octree would have more than");
    eprintln!("refused after {secs} s"); // not asserted: only run_limited's limit catches a hang
}

/// A union of 50,000 spheres evaluates a handful of children per sample (a hierarchy over
/// their bounds), not 50,000: counted, not timed.
#[test]
fn a_union_of_fifty_thousand_spheres_visits_few_children() {
    let d = scratch("big-union");
    let mut r = isokit::field::rng::SplitMix64::new(7);
    let spheres: Vec<String> = (0..50_000)
        .map(|_| {
            let c = r.point_in(glam::Vec3::splat(-1.0), glam::Vec3::splat(1.0));
            format!(
                r#"{{"sphere":{{"center":[{},{},{}],"radius":0.01}}}}"#,
                c.x, c.y, c.z
            )
        })
        .collect();
    let s = write(
        &d,
        "u.json",
        &format!(r#"{{"shape":{{"union":[{}]}}}}"#, spheres.join(",")),
    );
    let out = d.join("u.nrrd").display().to_string();
    let (o, secs) = run_limited(
        "",
        &["scene", &s, "--res", "48", "-o", &out, "--stats"],
        &[],
        300,
    );
    let st = json(&o);
    let queries: u64 = st["sources"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["queries"].as_u64().unwrap())
        .sum();
    let evaluated = st["dense_fraction"].as_f64().unwrap() * st["dense_samples"].as_f64().unwrap();
    let per_sample = queries as f64 / evaluated;
    eprintln!("50,000 spheres: {per_sample:.1} children per evaluated sample, {secs:.1} s");
    assert!(per_sample < 64.0, "{per_sample} children per sample");
}

// ------------------------------------------------------------------ GPU adapters

/// On a GL adapter (llvmpipe) the splatter's `Rgba32Float` target is not renderable: wgpu's
/// validation error filled seven lines. It is refused in one line before drawing (or, where
/// the adapter can render to it, the molecule renders).
#[test]
fn a_gl_adapter_without_float_targets_fails_in_one_line() {
    let d = scratch("gl-splat");
    let png = d.join("m.png").display().to_string();
    let (o, _) = run_limited(
        "",
        &[
            "molecule",
            &data("molecules/1a8o.pdb.gz"),
            "-o",
            &png,
            "--backend",
            "gpu",
            "--width",
            "64",
            "--height",
            "64",
        ],
        &[("WGPU_BACKEND", "gl"), ("XDG_RUNTIME_DIR", "/tmp")],
        300,
    );
    if !o.status.success() {
        assert_clear_error(&o, "GPU");
    }
}

/// One OBJ polygon of 400,000 vertices was fanned into slivers sharing a vertex, which no
/// spatial index separates: `sdf` tested most triangles per sample and ran past 20 s. Large
/// polygons are strips now: counted, not timed.
#[test]
fn a_huge_polygon_does_not_make_every_query_test_every_triangle() {
    let d = scratch("fan");
    let n = 400_000;
    let mut text = String::with_capacity(n * 30);
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        text.push_str(&format!("v {} {} 0\n", a.cos(), a.sin()));
    }
    text.push('f');
    for i in 1..=n {
        text.push_str(&format!(" {i}"));
    }
    text.push('\n');
    let fan = write(&d, "fan.obj", &text);
    let out = d.join("fan.npy").display().to_string();
    let (o, secs) = run_limited(
        "",
        &[
            "sdf",
            &fan,
            "--res",
            "24",
            "--sign",
            "pseudonormal",
            "-o",
            &out,
        ],
        &[],
        120,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    let tested: f64 = err
        .split(" triangles tested per sample")
        .next()
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no count in: {err}"));
    eprintln!("400,000-gon: {tested} triangles tested per sample, {secs:.1} s");
    assert!(tested < 2000.0, "{tested} triangles tested per sample");
}

/// 20,000 atoms at one point with shadows ran past 20 s on the CPU splatter (every quadric
/// evaluated at every pixel, twice with the shadow map); refused at once with the reason.
#[test]
fn coincident_atoms_are_refused_at_once() {
    let d = scratch("atoms");
    let mut text = String::new();
    for i in 0..20_000 {
        text.push_str(&format!(
            "HETATM{:5}  O   HOH A{:4}       0.000   0.000   0.000  1.00 20.00           O\n",
            i % 100_000,
            i % 10_000
        ));
    }
    let pdb = write(&d, "pile.pdb", &text);
    let png = d.join("p.png").display().to_string();
    let (o, secs) = run_limited(
        "",
        &[
            "molecule",
            &pdb,
            "-o",
            &png,
            "--shadows",
            "--backend",
            "cpu",
        ],
        &[],
        120,
    );
    assert_clear_error(&o, "coincident quadrics");
    eprintln!("20,000 coincident atoms refused after {secs:.1} s");
}
