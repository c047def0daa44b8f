//! End-to-end tests of the `isokit` program: real files through the real binary.

mod common;

use common::*;
use std::path::Path;

#[test]
fn sample_writes_an_exact_sphere_distance() {
    let d = scratch("sample");
    let out = d.join("s.nrrd");
    isokit_ok(&[
        "sample",
        "sphere",
        "--radius",
        "1",
        "--res",
        "33",
        "-o",
        out.to_str().unwrap(),
    ]);
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
    let out = d.join("t.nrrd");
    isokit_ok(&[
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
    let g = isokit::io::read_volume(&out).unwrap().into_grid().unwrap();
    // The torus (axis z, R = 1, r = 0.25) turned 90° about x has its axis along y, then
    // moves to centre (0, 0, 2): its distance is |(|(x, z − 2)| − 1, y)| − 0.25.
    let exact = |p: glam::Vec3| {
        let q = p - glam::Vec3::new(0.0, 0.0, 2.0);
        let ring = (q.x * q.x + q.z * q.z).sqrt() - 1.0;
        (ring * ring + q.y * q.y).sqrt() - 0.25
    };
    let h = g.spacing();
    // (1.25, 0, 2) is on the surface: the nearest sample is within one spacing of it.
    let target = glam::Vec3::new(1.25, 0.0, 2.0);
    let c = g.to_grid(target).round();
    let (i, j, k) = (c.x as usize, c.y as usize, c.z as usize);
    assert!(g.position(i, j, k).distance(target) <= 0.5 * 3f32.sqrt() * h);
    assert!(
        g.get(i, j, k).abs() <= h,
        "{} vs spacing {h}",
        g.get(i, j, k)
    );
    // Every sample, near and far, is the exact distance at its position.
    for ([i, j, k], v) in g.iter() {
        let want = exact(g.position(i, j, k));
        assert!((v - want).abs() < 1e-5, "{v} vs {want} at {i},{j},{k}");
    }
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
        assert_eq!(v["non_manifold_vertices"], 0, "{name}");
        assert!(v["triangles"].as_u64().unwrap() > 0);
    }
    let v = json(&isokit(&["info", &data("open_cube.obj"), "--json"]));
    assert_eq!(v["boundary_edges"], 4);
    let v = json(&isokit(&["info", &data("degenerate.off"), "--json"]));
    for (key, want) in [
        ("degenerate_triangles", 2),
        ("duplicate_triangles", 1),
        ("duplicate_vertices", 1),
        ("unreferenced_vertices", 1),
        ("non_finite_vertices", 0),
        ("components", 2),
        ("euler_characteristic", 3),
    ] {
        assert_eq!(v[key], want, "degenerate.off: {key}");
    }
    assert_eq!(v["watertight"], false);
    let v = json(&isokit(&["info", &data("torus_cloud.ply"), "--json"]));
    assert_eq!(v["kind"], "points");
    assert_eq!(v["normals"], true);
    // The text report is readable too.
    let t = isokit(&["info", &data("torus.off")]);
    assert!(t.status.success());
    assert!(String::from_utf8_lossy(&t.stdout).contains("watertight"));
    // Self-intersections, on request: none in a closed mesh; one pair in two crossing
    // triangles.
    for name in ["sphere.obj", "trefoil.ply"] {
        let v = json(&isokit(&[
            "info",
            &data(name),
            "--json",
            "--self-intersections",
        ]));
        assert_eq!(v["self_intersections"], 0, "{name}");
    }
    let d = scratch("info-crossing");
    let crossing = d.join("crossing.obj");
    std::fs::write(
        &crossing,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 -1\nv 0.2 0.2 1\nv 0.9 0.9 0\nf 1 2 3\nf 4 5 6\n",
    )
    .unwrap();
    let c = crossing.to_str().unwrap();
    let v = json(&isokit(&["info", c, "--json", "--self-intersections"]));
    assert_eq!(v["self_intersections"], 1);
    assert!(
        json(&isokit(&["info", c, "--json"]))
            .get("self_intersections")
            .is_none()
    );
    let t = isokit(&["info", c, "--self-intersections"]);
    assert!(String::from_utf8_lossy(&t.stdout).contains("self-intersections: 1 pairs"));
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
fn info_reads_the_header_of_an_exr() {
    let d = scratch("exr");
    let p = d.join("g.exr");
    let z = vec![0.5f32; 5 * 3];
    isokit::io::write_exr(&p, 5, 3, &[("Z", &z), ("N.X", &z)]).unwrap();
    let v = json(&isokit(&["info", p.to_str().unwrap(), "--json"]));
    assert_eq!(v["kind"], "image");
    assert_eq!(v["format"], "exr");
    assert_eq!(
        (v["width"].as_u64(), v["height"].as_u64()),
        (Some(5), Some(3))
    );
    let mut names: Vec<&str> = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["N.X", "Z"]);
    let t = isokit(&["info", p.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&t.stdout).contains("OpenEXR"));
}

/// Command-line usage errors are one line too (not clap's multi-line report), name the
/// problem and point at the subcommand's help; `--help` itself succeeds.
#[test]
fn usage_errors_are_one_line_with_a_hint() {
    let d = scratch("usage");
    let out = d.join("u.nrrd");
    let o = out.to_str().unwrap();
    for (args, needles) in [
        (
            vec!["sample", "teapot", "-o", o],
            vec!["invalid value 'teapot'", "sphere", "ellipsoid"],
        ),
        (
            vec!["sample", "sphere", "--center", "1,2", "-o", o],
            vec!["--center", "'1,2' is not a vector"],
        ),
        (
            vec!["sample", "sphere", "--res", "x", "-o", o],
            vec!["invalid value 'x' for '--res <RES>'"],
        ),
        (vec!["sample", "sphere"], vec!["--output"]),
        (
            vec!["sample", "sphere", "--bogus", "-o", o],
            vec!["--bogus"],
        ),
    ] {
        let r = isokit(&args);
        assert_clear_error(&r, "(see isokit sample --help)");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(err.starts_with("isokit: error: "), "{err}");
        assert!(!err.contains("error: error"), "{err}");
        for n in needles {
            assert!(err.contains(n), "'{n}' not in: {err}");
        }
    }
    assert_clear_error(&isokit(&["frobnicate"]), "(see isokit --help)");
    assert_clear_error(&isokit(&[]), "isokit: error: ");
    let help = isokit(&["sample", "--help"]);
    assert_eq!(help.status.code(), Some(0));
    let text = String::from_utf8_lossy(&help.stdout);
    // The shapes' options and defaults come from one table.
    assert!(
        text.contains("--center 0,0,0 --major 0.75 --minor 0.25"),
        "{text}"
    );
    assert!(isokit(&["--version"]).status.success());
    assert!(!out.exists());
}

/// An option the shape does not take is an error naming the ones it does, in the
/// command-line names.
#[test]
fn sample_refuses_options_the_shape_does_not_take() {
    let d = scratch("unused");
    let out = d.join("u.nrrd");
    let r = isokit(&[
        "sample",
        "torus",
        "--radius",
        "2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_clear_error(
        &r,
        "torus does not take --radius; its options are --center, --major, --minor",
    );
    let r = isokit(&["sample", "cuboid", "--ra", "1", "-o", out.to_str().unwrap()]);
    assert_clear_error(
        &r,
        "box does not take --ra; its options are --center, --half",
    );
    assert!(!out.exists());
}

#[test]
fn bad_input_gives_one_line_and_exit_code_2() {
    let d = scratch("errors");
    // The operating system's reason appears once: "isokit: error: PATH: REASON".
    let missing = d.join("missing.obj");
    let reason = std::fs::read(&missing).unwrap_err().to_string();
    let o = isokit(&["info", missing.to_str().unwrap()]);
    assert_clear_error(&o, "missing.obj");
    assert_eq!(
        String::from_utf8_lossy(&o.stderr).trim_end(),
        format!("isokit: error: {}: {reason}", missing.display())
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
    // A run refused before it starts keeps the previous output intact.
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

/// A run that fails *while writing* its output keeps the previous output intact: a file-size
/// limit (`ulimit -f`) stops the write part-way, after the temporary output was opened and
/// partly written (the kernel either kills the process with SIGXFSZ or fails the write with
/// EFBIG). A writer that wrote to the output path directly fails this test.
#[cfg(unix)]
#[test]
fn a_run_failing_while_writing_keeps_the_previous_output() {
    let d = scratch("failing-write");
    // A mesh output needs a volume input: sample one first, without the limit.
    let vol = d.join("in.nrrd");
    let torus = data("torus.off");
    isokit_ok(&["sdf", &torus, "--res", "64", "-o", vol.to_str().unwrap()]);
    let vol = vol.display().to_string();
    for (name, args) in [
        ("big.nrrd", ["sample", "sphere", "--res", "96"]),
        ("big.npy", ["sample", "torus", "--res", "96"]),
        ("big.obj", ["mesh", &vol, "--iso", "0"]),
    ] {
        let out = d.join(name);
        std::fs::write(&out, b"previous").unwrap();
        // 16 blocks of 512 bytes (dash) or 1024 bytes (bash): far below each output's size.
        let o = std::process::Command::new("sh")
            .arg("-c")
            .arg("ulimit -f 16; exec \"$@\"")
            .arg("sh")
            .arg(env!("CARGO_BIN_EXE_isokit"))
            .args(args)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success(),
            "{name}: the limit did not stop the run: {stderr}"
        );
        assert_eq!(
            std::fs::read(&out).unwrap(),
            b"previous",
            "{name}: the previous output was touched"
        );
        // It failed after the output was opened: either it was killed with a partial
        // temporary file beside the output, or the write failed and said so.
        let partial = std::fs::read_dir(&*d)
            .unwrap()
            .filter_map(Result::ok)
            .any(|e| {
                e.file_name()
                    .to_string_lossy()
                    .starts_with(&format!(".{name}.isokit-"))
            });
        assert!(
            partial || stderr.contains("File too large"),
            "{name}: neither a partial temporary file nor a write error: {stderr}"
        );
    }
}

/// A run killed with SIGKILL while writing leaves its temporary file (nothing can remove
/// it), keeps the previous output, and the next run writing the same output removes the
/// orphan.
#[cfg(target_os = "linux")]
#[test]
fn a_killed_write_leaves_no_orphan_after_the_next_run() {
    let d = scratch("killed-write");
    for (name, args) in [
        ("big.nrrd", ["sample", "sphere", "--res", "320"]),
        ("big.npy", ["sample", "torus", "--res", "320"]),
    ] {
        let out = d.join(name);
        std::fs::write(&out, b"previous").unwrap();
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_isokit"))
            .args(args)
            .arg("-o")
            .arg(&out)
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let temporaries = || -> Vec<std::path::PathBuf> {
            std::fs::read_dir(&*d)
                .unwrap()
                .filter_map(Result::ok)
                .filter(|e| {
                    e.file_name()
                        .to_string_lossy()
                        .starts_with(&format!(".{name}."))
                })
                .map(|e| e.path())
                .collect()
        };
        let t0 = std::time::Instant::now();
        while temporaries().is_empty() {
            assert!(
                t0.elapsed().as_secs() < 120,
                "{name}: no temporary file appeared"
            );
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        child.kill().unwrap(); // SIGKILL
        let status = child.wait().unwrap();
        let left = temporaries();
        assert_eq!(std::fs::read(&out).unwrap(), b"previous", "{name}");
        assert!(
            !status.success() && left.len() == 1,
            "{name}: the kill came too late ({status}, {left:?})"
        );
        // The next run writing the same output succeeds and removes the orphan.
        isokit_ok(&[args[0], args[1], "--res", "16", "-o", out.to_str().unwrap()]);
        assert_ne!(std::fs::read(&out).unwrap(), b"previous");
        assert!(temporaries().is_empty(), "{name}: {:?}", temporaries());
    }
}

#[test]
fn query_gives_exact_signed_distances_and_closest_points() {
    let d = scratch("query");
    let mesh_path = data("sphere.obj");
    let mesh = isokit::io::read_mesh(Path::new(&mesh_path)).unwrap();
    let mut r = isokit::field::rng::SplitMix64::new(5);
    let pts: Vec<glam::Vec3> = (0..500)
        .map(|_| r.point_in(glam::Vec3::splat(-1.5), glam::Vec3::splat(1.5)))
        .collect();
    let flat: Vec<f32> = pts.iter().flat_map(|p| p.to_array()).collect();
    let (p, o, c) = (d.join("p.npy"), d.join("d.npy"), d.join("c.npy"));
    isokit::io::write_npy_f32(&p, &[pts.len(), 3], &flat).unwrap();
    let out = isokit(&[
        "query",
        &mesh_path,
        "--points",
        p.to_str().unwrap(),
        "-o",
        o.to_str().unwrap(),
        "--closest",
        c.to_str().unwrap(),
        "--stats",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("sign: pseudonormal"), "{err}");
    assert!(
        err.contains("queries/s") && err.contains("nodes visited"),
        "{err}"
    );
    let dist = isokit::io::read_npy(&o).unwrap();
    let cl = isokit::io::read_npy(&c).unwrap();
    assert_eq!(dist.shape, vec![500]);
    assert_eq!(cl.shape, vec![500, 3]);
    for (i, q) in pts.iter().enumerate() {
        let want = isokit::kdtree::mesh::brute_force_distance(&mesh, q.as_dvec3());
        let got = dist.data[i];
        assert!(
            (got.abs() - want).abs() <= 1e-6 * want.max(1e-3),
            "{got} vs {want}"
        );
        // The icosphere lies within 0.005 inside the unit sphere.
        if (q.length() - 1.0).abs() > 0.01 {
            assert_eq!(got < 0.0, q.length() < 1.0, "sign at {q}: {got}");
        }
        let cp = glam::DVec3::new(cl.data[3 * i], cl.data[3 * i + 1], cl.data[3 * i + 2]);
        assert!(((cp - q.as_dvec3()).length() - want).abs() < 1e-5);
    }
    // Bad shapes of the point array are clear errors.
    isokit::io::write_npy_f32(&p, &[10, 2], &[0.0; 20]).unwrap();
    let bad = isokit(&[
        "query",
        &mesh_path,
        "--points",
        p.to_str().unwrap(),
        "-o",
        o.to_str().unwrap(),
    ]);
    assert_clear_error(&bad, "(n, 3)");
}

#[test]
fn sdf_grid_is_exact_and_the_band_clamps_with_the_right_sign() {
    let d = scratch("sdf");
    let mesh_path = data("torus.off");
    let mesh = isokit::io::read_mesh(Path::new(&mesh_path)).unwrap();
    let full = d.join("full.nrrd");
    let band = d.join("band.nrrd");
    isokit_ok(&[
        "sdf",
        &mesh_path,
        "--method",
        "kdtree",
        "--res",
        "20",
        "-o",
        full.to_str().unwrap(),
    ]);
    isokit_ok(&[
        "sdf",
        &mesh_path,
        "--res",
        "20",
        "--band",
        "0.1",
        "--padding",
        "0.3",
        "-o",
        band.to_str().unwrap(),
    ]);
    let g = isokit::io::read_volume(&full).unwrap().into_grid().unwrap();
    assert_eq!(g.dims().iter().max(), Some(&20));
    for ([i, j, k], v) in g.iter() {
        let p = g.position(i, j, k).as_dvec3();
        let want = isokit::kdtree::mesh::brute_force_distance(&mesh, p);
        // The tool places samples in f64, `position` in f32: allow that rounding.
        assert!(((v.abs() as f64) - want).abs() <= 1e-6, "{v} vs {want}");
        // Inside the tube of the torus (R = 1, r = 0.35) means negative.
        let tube = ((p.x * p.x + p.y * p.y).sqrt() - 1.0).hypot(p.z);
        if (tube - 0.35).abs() > 0.02 {
            assert_eq!(v < 0.0, tube < 0.35, "sign at {p}");
        }
    }
    let b = isokit::io::read_volume(&band).unwrap().into_grid().unwrap();
    let mut clamped = 0;
    for ([i, j, k], v) in b.iter() {
        let p = b.position(i, j, k).as_dvec3();
        let want = isokit::kdtree::mesh::brute_force_distance(&mesh, p);
        if want < 0.1 {
            assert!(((v.abs() as f64) - want).abs() <= 1e-6, "{v} vs {want}");
        } else {
            clamped += 1;
            assert_eq!(v.abs(), 0.1);
            let tube = ((p.x * p.x + p.y * p.y).sqrt() - 1.0).hypot(p.z);
            assert_eq!(v < 0.0, tube < 0.35, "band sign at {p}");
        }
    }
    assert!(clamped > 0);
}

const OCTREE_KEYS: [&str; 7] = [
    "cells",
    "nodes",
    "bytes_per_cell",
    "build_seconds",
    "max_error",
    "rms_error",
    "dense_fraction",
];

#[test]
fn octree_of_a_primitive_a_mesh_and_a_volume() {
    let d = scratch("octree");
    // A primitive: the error at independent points near the surface stays within the bound.
    let v = json(&isokit(&["octree", "sphere", "--max-level", "6", "--json"]));
    for k in OCTREE_KEYS {
        assert!(v[k].is_number(), "{k} missing: {v}");
    }
    let f = |k: &str| v[k].as_f64().unwrap();
    assert!(f("cells") > 8.0 && f("nodes") > 8.0 && f("bytes_per_cell") > 0.0);
    assert!(
        f("dense_fraction") > 0.0 && f("dense_fraction") < 0.5,
        "{v}"
    );
    assert!(
        f("max_error") > 0.0 && f("max_error") <= f("error_bound"),
        "{v}"
    );
    assert!(f("rms_error") <= f("max_error"));
    assert_eq!(v["test_points"], 20_000);
    assert_eq!(v["exact_reference"], true);
    // A mesh, exported on a grid of the default level min(L, 8).
    let out = d.join("torus.nrrd");
    let v = json(&isokit(&[
        "octree",
        &data("torus.off"),
        "--max-level",
        "5",
        "--error",
        "0.01",
        "--json",
        "-o",
        out.to_str().unwrap(),
    ]));
    for k in OCTREE_KEYS {
        assert!(v[k].is_number(), "{k} missing: {v}");
    }
    assert!(v["what"].as_str().unwrap().contains("pseudonormal"), "{v}");
    let g = isokit::io::read_volume(&out).unwrap().into_grid().unwrap();
    assert_eq!(g.dims(), [33, 33, 33]);
    let (lo, hi) = g.min_max().unwrap();
    assert!(lo < -0.3 && hi > 0.5, "{lo} {hi}");
    // A volume: its trilinear field is both the input and the reference.
    let vol = d.join("ball.nrrd");
    isokit_ok(&[
        "sample",
        "sphere",
        "--res",
        "33",
        "-o",
        vol.to_str().unwrap(),
    ]);
    let v = json(&isokit(&[
        "octree",
        vol.to_str().unwrap(),
        "--max-level",
        "5",
        "--test-points",
        "2000",
        "--json",
    ]));
    assert_eq!(v["exact_reference"], false);
    assert!(v["reference"].as_str().unwrap().contains("trilinear"));
    assert!(
        v["max_error"].as_f64().unwrap() <= v["error_bound"].as_f64().unwrap(),
        "{v}"
    );
    // Text output names the figures.
    let o = isokit(&["octree", "torus", "--max-level", "4"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for w in [
        "cells",
        "nodes",
        "bytes per cell",
        "built in",
        "max",
        "rms",
        "dense",
    ] {
        assert!(text.contains(w), "'{w}' not in {text}");
    }
}

/// `-o out.obj`: the tree's surface. Dual contouring reads the tree node by node with the
/// exact field's Hermite data; adaptive, a box is its 12 triangles with its 8 corners.
#[test]
fn octree_meshes_its_surface() {
    let d = scratch("octree-mesh");
    let p = |name: &str| d.join(name).to_str().unwrap().to_owned();
    let v = json(&isokit(&[
        "octree",
        "box",
        "--max-level",
        "6",
        "-o",
        &p("box.obj"),
        "--mesher",
        "dual",
        "--mesh-error",
        "0.001",
        "--json",
    ]));
    assert_eq!(
        (v["mesher"].as_str(), v["mesh_level"].as_u64()),
        (Some("dual"), Some(6))
    );
    assert!(v["merged_cells"].as_u64().unwrap() > 0, "{v}");
    let m = isokit::io::read_mesh(Path::new(&p("box.obj"))).unwrap();
    let r = m.validate();
    assert!(r.watertight && r.consistently_oriented, "{r}");
    assert_eq!(m.triangles.len(), 12, "{r}");
    // `isokit octree box`'s default box: centre 0, half sizes 1, 0.75, 0.5.
    for n in 0..8 {
        let c = glam::Vec3::new(
            if n & 1 == 1 { 1.0 } else { -1.0 },
            if n & 2 == 2 { 0.75 } else { -0.75 },
            if n & 4 == 4 { 0.5 } else { -0.5 },
        );
        let near = m
            .positions
            .iter()
            .map(|q| q.distance(c))
            .fold(f32::INFINITY, f32::min);
        assert!(near < 1e-4, "corner {c}: nearest vertex {near}");
    }
    // Marching cubes of the tree equals marching cubes of its exported grid.
    isokit_ok(&["octree", "sphere", "--max-level", "5", "-o", &p("tree.obj")]);
    isokit_ok(&[
        "octree",
        "sphere",
        "--max-level",
        "5",
        "-o",
        &p("tree.nrrd"),
    ]);
    isokit_ok(&["mesh", &p("tree.nrrd"), "-o", &p("grid.obj")]);
    let (a, b) = (
        isokit::io::read_mesh(Path::new(&p("tree.obj"))).unwrap(),
        isokit::io::read_mesh(Path::new(&p("grid.obj"))).unwrap(),
    );
    assert!(a.validate().watertight);
    assert_eq!(
        (a.positions.len(), a.triangles.len()),
        (b.positions.len(), b.triangles.len())
    );
    // Uniform dual contouring through the tree: closed.
    isokit_ok(&[
        "octree",
        "torus",
        "--max-level",
        "5",
        "-o",
        &p("torus.obj"),
        "--mesher",
        "dual",
    ]);
    let t = isokit::io::read_mesh(Path::new(&p("torus.obj")))
        .unwrap()
        .validate();
    assert!(t.watertight && t.genus() == Some(1), "{t}");
    // The mesher's flags need a mesh output, and --mesh-error needs dual.
    let small_box =
        |more: &[&str]| isokit(&[&["octree", "box", "--max-level", "4"], more].concat());
    // Either mesher named with a grid output is refused (not ignored).
    for mesher in ["dual", "mc"] {
        assert_clear_error(
            &small_box(&["-o", &p("x.nrrd"), "--mesher", mesher]),
            "mesh output",
        );
    }
    assert_clear_error(
        &small_box(&["-o", &p("x.obj"), "--mesh-error", "0.1"]),
        "--mesh-error applies to --mesher dual",
    );
    // A negative bound written as a separate argument reaches the check (not the parser).
    assert_clear_error(
        &small_box(&["-o", &p("x.obj"), "--error", "-1"]),
        "must be finite and non-negative",
    );
    // A mesh level beyond a grid's size is refused before the tree is built.
    for level in ["11", "21"] {
        assert_clear_error(
            &isokit(&[
                "octree",
                "box",
                "--max-level",
                "21",
                "--export-level",
                level,
                "-o",
                &p("x.obj"),
            ]),
            "use --export-level 10 or less",
        );
    }
}

#[test]
fn octree_refuses_bad_input_with_one_line() {
    assert_clear_error(
        &isokit(&["octree", "no-such-input", "--max-level", "4"]),
        "not a primitive name",
    );
    assert_clear_error(
        &isokit(&["octree", "sphere", "--max-level", "22"]),
        "--max-level 22",
    );
    assert_clear_error(
        &isokit(&["octree", "plane", "--max-level", "4"]),
        "unbounded",
    );
    assert_clear_error(
        &isokit(&["octree", "sphere", "--max-level", "4", "--min-level", "5"]),
        "min level",
    );
    assert_clear_error(
        &isokit(&["octree", "sphere", "--max-level", "4", "--error", "-1"]),
        "error",
    );
    assert_clear_error(
        &isokit(&["octree", "sphere", "--max-level", "4", "-o", "x.txt"]),
        "unknown output format",
    );
    assert_clear_error(
        &isokit(&["octree", "sphere", "--max-level", "21", "--bottom-up"]),
        "too large",
    );
    assert_clear_error(
        &isokit(&[
            "octree",
            "sphere",
            "--max-level",
            "9",
            "--max-cells",
            "1000",
        ]),
        "more than 1000 cells",
    );
    assert_clear_error(&isokit(&["octree", "sphere"]), "isokit octree --help");
}

/// `isokit bench render --json` at a tiny size: the documented keys, one row per scene and
/// mode, and the default mode's hit mask equal to the r0 = 8 reference's on every scene.
#[test]
fn bench_render_reports_warm_frames_per_scene_and_mode() {
    let v = json(&isokit(&[
        "bench", "render", "--json", "--size", "48", "--res", "40", "--frames", "1",
    ]));
    let scenes = v["scenes"]
        .as_array()
        .unwrap_or_else(|| panic!("scenes: {v}"));
    assert_eq!(scenes.len(), 3, "{v}");
    let frame_ms = v["frame_ms"].as_array().unwrap();
    assert_eq!(frame_ms.len(), 3);
    assert!(frame_ms.iter().all(|x| x.as_f64().unwrap() > 0.0), "{v}");
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3 * 4, "three scenes, four modes: {v}");
    for r in rows {
        for k in [
            "scene",
            "mode",
            "frame_ms",
            "samples_per_ray",
            "mask_pixels",
            "mean_dz_voxels",
        ] {
            assert!(!r[k].is_null(), "{k} in {r}");
        }
        assert!(r["samples_per_ray"].as_f64().unwrap() > 0.0, "{r}");
        if r["mode"] == "phong" {
            assert_eq!(
                r["mask_pixels"], 0,
                "default mode against the reference: {r}"
            );
            assert!(r["mean_dz_voxels"].as_f64().unwrap() < 1e-2, "{r}");
        }
    }
    for (i, s) in scenes.iter().enumerate() {
        let default = rows
            .iter()
            .find(|r| &r["scene"] == s && r["mode"] == "phong")
            .unwrap_or_else(|| panic!("no default row for {s}"));
        assert_eq!(
            default["frame_ms"], frame_ms[i],
            "frame_ms[{i}] is {s}'s default row"
        );
    }
}

#[test]
fn bench_octree_reports_both_trees_per_level() {
    let v = json(&isokit(&[
        "bench",
        "octree",
        "--json",
        "--accesses",
        "3000",
        "--first-level",
        "3",
        "--last-level",
        "5",
        "--repeat",
        "1",
    ]));
    let levels = v["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 6, "two datasets x three levels: {v}");
    assert_eq!(levels[0], 3);
    assert_eq!(v["datasets"].as_array().unwrap().len(), 6);
    for k in [
        "hashed_seconds",
        "linked_seconds",
        "hashed_bytes_per_cell",
        "linked_bytes_per_cell",
    ] {
        let col = v[k].as_array().unwrap_or_else(|| panic!("{k}: {v}"));
        assert_eq!(col.len(), 6, "{k}");
        assert!(
            col.iter().all(|x| x.as_f64().unwrap() > 0.0),
            "{k}: {col:?}"
        );
    }
    // The hashed tree is smaller per cell.
    for (h, l) in v["hashed_bytes_per_cell"]
        .as_array()
        .unwrap()
        .iter()
        .zip(v["linked_bytes_per_cell"].as_array().unwrap())
    {
        assert!(h.as_f64().unwrap() < l.as_f64().unwrap());
    }
    assert_eq!(v["accesses"], 3000);
}

#[test]
fn a_reader_that_closes_the_pipe_early_ends_the_command_quietly() {
    // `isokit info FILE | head -1`: the reader goes before the command prints. Rust ignores
    // SIGPIPE, so printing fails; the command ends with the status a shell gives a Unix
    // tool ended by SIGPIPE (141), not with a panic.
    let mut closed = 0;
    for _ in 0..3 {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_isokit"))
            .args(["info", &data("trefoil.ply")])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
        match out.status.code() {
            Some(141) => closed += 1,
            Some(0) => {} // it printed before the pipe closed
            other => panic!("status {other:?}: {err}"),
        }
    }
    assert!(
        closed > 0,
        "the pipe never closed before the command printed"
    );
}
