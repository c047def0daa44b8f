//! End-to-end tests of the `isokit` program: real files through the real binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn isokit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isokit"))
        .args(args)
        .output()
        .expect("the isokit binary runs")
}

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// A fresh scratch folder per test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("isokit-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

/// A failure exits with 2 and prints exactly one line on stderr.
fn assert_clear_error(out: &Output, needle: &str) {
    assert_eq!(
        out.status.code(),
        Some(2),
        "stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected, got: {err}"
    );
    assert!(err.contains(needle), "'{needle}' not in: {err}");
}

#[test]
fn sample_writes_an_exact_sphere_distance() {
    let d = scratch("sample");
    let out = d.join("s.nrrd");
    let o = isokit(&[
        "sample",
        "sphere",
        "--radius",
        "1",
        "--res",
        "33",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = isokit::io::read_volume(&out).unwrap();
    let g = v.into_grid().unwrap();
    assert_eq!(g.dims(), [33, 33, 33]);
    for ([i, j, k], s) in g.iter() {
        let want = g.position(i, j, k).length() - 1.0;
        assert!((s - want).abs() < 1e-6, "{s} vs {want}");
    }
    let info = json(&isokit(&["info", out.to_str().unwrap(), "--json"]));
    assert_eq!(info["kind"], "volume");
    assert_eq!(info["dims"], serde_json::json!([33, 33, 33]));
    let lo = info["range"][0].as_f64().unwrap();
    assert!((lo + 1.0).abs() < 1e-6, "the centre sample is -1, got {lo}");
}

#[test]
fn sample_applies_transforms_and_needs_bounds_for_planes() {
    let d = scratch("transform");
    let out = d.join("t.npy");
    let o = isokit(&[
        "sample",
        "torus",
        "--major",
        "1",
        "--minor",
        "0.25",
        "--rotate",
        "1,0,0,90",
        "--translate",
        "0,0,2",
        "--res",
        "24",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = isokit::io::read_volume(&out).unwrap();
    // NPY keeps no geometry: the (nz, ny, nx) shape is all.
    assert!(g.dims.iter().all(|&n| n >= 2));
    let plane = isokit(&[
        "sample",
        "plane",
        "--res",
        "8",
        "-o",
        d.join("p.nrrd").to_str().unwrap(),
    ]);
    assert_clear_error(&plane, "--bounds");
    let plane = isokit(&[
        "sample",
        "plane",
        "--bounds",
        "-1,-1,-1,1,1,1",
        "--res",
        "8",
        "-o",
        d.join("p.nrrd").to_str().unwrap(),
    ]);
    assert!(plane.status.success());
}

#[test]
fn info_reports_the_shipped_meshes() {
    for (name, watertight, oriented) in [
        ("sphere.obj", true, true),
        ("torus.off", true, true),
        ("trefoil.ply", true, true),
        ("open_cube.obj", false, true),
    ] {
        let v = json(&isokit(&["info", &data(name), "--json"]));
        assert_eq!(v["kind"], "mesh", "{name}");
        assert_eq!(v["watertight"], watertight, "{name}");
        assert_eq!(v["consistently_oriented"], oriented, "{name}");
        assert!(v["triangles"].as_u64().unwrap() > 0);
    }
    let v = json(&isokit(&["info", &data("open_cube.obj"), "--json"]));
    assert_eq!(v["boundary_edges"], 4);
    let v = json(&isokit(&["info", &data("degenerate.off"), "--json"]));
    assert!(v["degenerate_triangles"].as_u64().unwrap() >= 2);
    let v = json(&isokit(&["info", &data("torus_cloud.ply"), "--json"]));
    assert_eq!(v["kind"], "points");
    assert_eq!(v["normals"], true);
    // The text report is readable too.
    let t = isokit(&["info", &data("torus.off")]);
    assert!(t.status.success());
    assert!(String::from_utf8_lossy(&t.stdout).contains("watertight"));
}

#[test]
fn convert_round_trips_meshes_clouds_and_volumes() {
    let d = scratch("convert");
    let stl = d.join("torus.stl");
    let back = d.join("back.obj");
    assert!(
        isokit(&["convert", &data("torus.off"), stl.to_str().unwrap()])
            .status
            .success()
    );
    assert!(
        isokit(&["convert", stl.to_str().unwrap(), back.to_str().unwrap()])
            .status
            .success()
    );
    let a = isokit::io::read_mesh(Path::new(&data("torus.off"))).unwrap();
    let b = isokit::io::read_mesh(&back).unwrap();
    assert_eq!(a.triangles.len(), b.triangles.len());
    assert_eq!(
        a.positions.len(),
        b.positions.len(),
        "STL welding restores shared vertices"
    );

    let xyz = d.join("cloud.xyz");
    assert!(
        isokit(&["convert", &data("torus_cloud.ply"), xyz.to_str().unwrap()])
            .status
            .success()
    );
    let c = isokit::io::read_points(&xyz).unwrap();
    assert_eq!(c.points.len(), 4000);
    assert!(c.normals.is_some());

    let nrrd = d.join("v.nrrd");
    let npy = d.join("v.npy");
    assert!(
        isokit(&["sample", "box", "--res", "10", "-o", nrrd.to_str().unwrap()])
            .status
            .success()
    );
    assert!(
        isokit(&["convert", nrrd.to_str().unwrap(), npy.to_str().unwrap()])
            .status
            .success()
    );
    let (a, b) = (
        isokit::io::read_volume(&nrrd).unwrap(),
        isokit::io::read_volume(&npy).unwrap(),
    );
    assert_eq!(a.dims, b.dims);
    assert_eq!(a.data, b.data);

    let bad = isokit(&[
        "convert",
        &data("torus.off"),
        d.join("x.nrrd").to_str().unwrap(),
    ]);
    assert_clear_error(&bad, "cannot convert");
}

#[test]
fn bad_input_gives_one_line_and_exit_code_2() {
    let d = scratch("errors");
    assert_clear_error(
        &isokit(&["info", d.join("missing.obj").to_str().unwrap()]),
        "missing.obj",
    );
    let garbage = d.join("garbage.ply");
    std::fs::write(
        &garbage,
        b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\n",
    )
    .unwrap();
    assert_clear_error(&isokit(&["info", garbage.to_str().unwrap()]), "garbage.ply");
    let empty = d.join("empty.stl");
    std::fs::write(&empty, b"").unwrap();
    assert_clear_error(&isokit(&["info", empty.to_str().unwrap()]), "empty.stl");
    let out = d.join("big.nrrd");
    assert_clear_error(
        &isokit(&[
            "sample",
            "sphere",
            "--res",
            "100000",
            "-o",
            out.to_str().unwrap(),
        ]),
        "too large",
    );
    assert!(!out.exists(), "a refused run writes nothing");
    assert_clear_error(
        &isokit(&[
            "sample",
            "sphere",
            "--radius",
            "-1",
            "-o",
            out.to_str().unwrap(),
        ]),
        "radius",
    );
    assert_clear_error(
        &isokit(&["sample", "sphere", "-o", d.join("x.vtk").to_str().unwrap()]),
        "unknown output format",
    );
    // A failed run keeps the previous output intact.
    std::fs::write(&out, b"previous").unwrap();
    let o = isokit(&[
        "sample",
        "sphere",
        "--res",
        "100000",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read(&out).unwrap(), b"previous");
}
