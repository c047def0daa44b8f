//! `isokit sdf --method prism` end to end: the same grid as `--method kdtree` within 1e-5 of
//! the spacing, the GPU equal to the CPU, clear one-line errors, warnings for open meshes.

mod common;
use common::*;

fn grid(path: &std::path::Path) -> isokit::Grid {
    isokit::io::read_volume(path).unwrap().into_grid().unwrap()
}

fn sdf(mesh: &str, out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["sdf", mesh, "--res", "40", "--band", "0.15", "-o"];
    args.push(out.to_str().unwrap());
    args.extend_from_slice(extra);
    isokit_ok(&args)
}

#[test]
fn prism_grid_equals_the_kdtree_grid() {
    let d = scratch("prism-vs-kd");
    for name in ["torus.off", "trefoil.ply", "sphere.obj"] {
        let mesh = data(name);
        let kd = d.join(format!("{name}.kd.nrrd"));
        let pr = d.join(format!("{name}.prism.npy"));
        sdf(&mesh, &kd, &["--method", "kdtree"]);
        let out = sdf(&mesh, &pr, &["--method", "prism", "--backend", "cpu"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("saddles") && err.contains("band samples/s"),
            "{err}"
        );
        let (a, b) = (grid(&kd), grid(&pr));
        assert_eq!(a.dims(), b.dims());
        let h = a.spacing();
        let mut band = 0;
        for (x, y) in a.data().iter().zip(b.data()) {
            band += usize::from(x.abs() < 0.15);
            assert!(
                (x - y).abs() <= 1e-5 * h + 4.0 * f32::EPSILON * x.abs(),
                "{name}: kd-tree {x} vs prism {y}"
            );
        }
        assert!(band > 1000, "{name}: {band} band samples");
    }
}

#[test]
fn gpu_backend_equals_cpu_backend() {
    let Some(_gpu) = isokit_gpu::testing::gpu_or_skip("gpu_backend_equals_cpu_backend") else {
        return;
    };
    let d = scratch("prism-gpu");
    let mesh = data("trefoil.ply");
    let (c, g) = (d.join("cpu.nrrd"), d.join("gpu.nrrd"));
    sdf(&mesh, &c, &["--method", "prism", "--backend", "cpu"]);
    let out = sdf(&mesh, &g, &["--method", "prism", "--backend", "gpu"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("on the GPU"));
    let (a, b) = (grid(&c), grid(&g));
    for (x, y) in a.data().iter().zip(b.data()) {
        assert!((x - y).abs() <= 1e-5 * 0.15, "cpu {x} vs gpu {y}");
    }
}

#[test]
fn backend_choice_is_reported_and_env_forces_the_cpu() {
    let d = scratch("prism-backend");
    let mesh = data("sphere.obj");
    let out = d.join("s.nrrd");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args([
            "sdf", &mesh, "--method", "prism", "--res", "24", "--band", "0.1", "-o",
        ])
        .arg(&out)
        .env("ISOKIT_BACKEND", "cpu")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert!(err.contains("on the CPU"), "{err}");
    // No backend compiled in by that name: --backend gpu fails with one clear line.
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args([
            "sdf",
            &mesh,
            "--method",
            "prism",
            "--res",
            "24",
            "--band",
            "0.1",
            "--backend",
            "gpu",
            "-o",
        ])
        .arg(&out)
        .env("WGPU_BACKEND", "metal")
        .output()
        .unwrap();
    assert_clear_error(&run, "no GPU adapter");
    // auto without an adapter falls back to the CPU with a note.
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args([
            "sdf", &mesh, "--method", "prism", "--res", "24", "--band", "0.1", "-o",
        ])
        .arg(&out)
        .env("WGPU_BACKEND", "metal")
        .env_remove("ISOKIT_BACKEND")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        run.status.success() && err.contains("note: backend auto"),
        "{err}"
    );
}

#[test]
fn open_meshes_warn_and_still_match_the_kdtree() {
    let d = scratch("prism-open");
    let mesh = data("open_cube.obj");
    let (kd, pr) = (d.join("kd.nrrd"), d.join("pr.nrrd"));
    sdf(&mesh, &kd, &["--method", "kdtree"]);
    let out = sdf(&mesh, &pr, &["--method", "prism", "--backend", "cpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("warning:") && err.contains("winding"), "{err}");
    let (a, b) = (grid(&kd), grid(&pr));
    let h = a.spacing();
    for (x, y) in a.data().iter().zip(b.data()) {
        assert!(
            (x - y).abs() <= 1e-5 * h + 4.0 * f32::EPSILON * x.abs(),
            "{x} vs {y}"
        );
    }
}

#[test]
fn knobs_run_and_bad_arguments_are_one_line() {
    let d = scratch("prism-errors");
    let mesh = data("torus.off");
    let out = d.join("t.nrrd");
    let o = out.to_str().unwrap();
    sdf(
        &mesh,
        &out,
        &[
            "--method",
            "prism",
            "--backend",
            "cpu",
            "--prism-sides",
            "bisector",
        ],
    );
    let r = sdf(
        &mesh,
        &out,
        &["--method", "prism", "--backend", "cpu", "--no-gap-repair"],
    );
    assert!(String::from_utf8_lossy(&r.stderr).contains("gap repair off"));
    assert_clear_error(
        &isokit(&["sdf", &mesh, "--method", "prism", "-o", o]),
        "needs --band",
    );
    assert_clear_error(
        &isokit(&["sdf", &mesh, "--method", "prism", "--band=-1", "-o", o]),
        "--band",
    );
    assert_clear_error(
        &isokit(&[
            "sdf",
            &mesh,
            "--method",
            "kdtree",
            "--backend",
            "gpu",
            "-o",
            o,
        ]),
        "no GPU kernel",
    );
    assert_clear_error(
        &isokit(&[
            "sdf", &mesh, "--method", "prism", "--band", "0.1", "-o", "x.png",
        ]),
        "unknown output format",
    );
    assert_clear_error(
        &isokit(&[
            "sdf", &mesh, "--method", "prism", "--band", "0.1", "--res", "100000", "-o", o,
        ]),
        "too large",
    );
    let bad = d.join("bad.off");
    std::fs::write(&bad, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n").unwrap();
    let r = isokit(&[
        "sdf",
        bad.to_str().unwrap(),
        "--method",
        "prism",
        "--band",
        "0.1",
        "-o",
        o,
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&r.stderr)
            .trim_end()
            .lines()
            .count(),
        1
    );
}
