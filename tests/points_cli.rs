//! End-to-end tests of `isokit points`: the shipped torus cloud through the real binary.

mod common;

use common::*;

/// Exact signed distance of the shipped torus (R = 1, r = 0.35, z axis).
fn torus(p: glam::Vec3) -> f32 {
    let q = glam::Vec2::new(glam::Vec2::new(p.x, p.y).length() - 1.0, p.z);
    q.length() - 0.35
}

#[test]
fn torus_cloud_to_volume_given_and_estimated_normals() {
    let d = scratch("torus");
    for normals in ["given", "estimate"] {
        let out = d.join(format!("t_{normals}.nrrd"));
        let o = isokit(&[
            "points",
            &data("torus_cloud.ply"),
            "--res",
            "48",
            "--normals",
            normals,
            "-o",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(err.contains("solve: LSQR"), "{err}");
        assert!(err.contains("(converged)"), "{err}");
        if normals == "estimate" {
            assert!(err.contains("normals: estimated"), "{err}");
        }
        let grid = isokit_io::read_volume(&out).unwrap().into_grid().unwrap();
        // Near the surface the samples follow the exact distance.
        let mut worst = 0.0f32;
        for ([i, j, k], v) in grid.iter() {
            let e = torus(grid.position(i, j, k));
            if e.abs() < 0.05 {
                worst = worst.max((v - e).abs());
            }
        }
        assert!(worst < 0.03, "{normals}: {worst}");
    }
}

/// `--band W` evaluates only bricks near the surface, yet writes the same file as the dense
/// path clamped to ±W; and it reports the fraction evaluated.
#[test]
fn band_is_lazy_and_equals_the_clamped_dense_field() {
    let d = scratch("band");
    let (dense, band) = (d.join("dense.nrrd"), d.join("band.nrrd"));
    let base = [
        "points",
        &data("torus_cloud.ply"),
        "--res",
        "64",
        "--brick",
        "4",
    ];
    isokit_ok(&[&base[..], &["-o", dense.to_str().unwrap()]].concat());
    let w = 0.06f32;
    let o = isokit_ok(&[&base[..], &["--band", "0.06", "-o", band.to_str().unwrap()]].concat());
    let err = String::from_utf8_lossy(&o.stderr);
    let pct: f64 = err
        .split("band 0.06: ")
        .nth(1)
        .and_then(|s| s.split('%').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no evaluated fraction in: {err}"));
    println!("{err}");
    // 59% measured: the torus fills much of its own bounds at this resolution.
    assert!(pct > 0.0 && pct < 70.0, "{pct}% evaluated");
    let a = isokit_io::read_volume(&dense).unwrap().into_grid().unwrap();
    let b = isokit_io::read_volume(&band).unwrap().into_grid().unwrap();
    assert_eq!(a.dims(), b.dims());
    assert_eq!(a.origin(), b.origin());
    let (mut inside, mut worst) = (0, 0.0f32);
    for (x, y) in a.data().iter().zip(b.data()) {
        let want = x.clamp(-w, w);
        worst = worst.max((want - y).abs());
        inside += usize::from(x.abs() < w);
    }
    // The lazy path evaluates at f32 positions, the dense one at f64 ones.
    assert!(worst < 1e-5, "lazy and dense differ by {worst}");
    assert!(inside > 1000, "{inside} samples within the band");
    // The .npy output of the band path too.
    let npy = d.join("band.npy");
    isokit_ok(&[&base[..], &["--band", "0.06", "-o", npy.to_str().unwrap()]].concat());
    assert_eq!(isokit_io::read_npy(&npy).unwrap().data.len(), a.len());
}

/// The comparison variants and solvers are reachable from the command line.
#[test]
fn variants_and_solvers() {
    let d = scratch("variants");
    let out = d.join("v.npy");
    for extra in [
        &["--weights", "shepard"][..],
        &["--weights", "nie04", "--nie04-neighbours", "12"],
        &["--solver", "gmres", "--max-iter", "30"],
        &["--solver", "bicgstab"],
        &["--damping", "1", "--k", "32"],
        &["--no-far"],
    ] {
        let o = isokit_ok(
            &[
                &["points", &data("torus_cloud.ply"), "--res", "24"][..],
                extra,
                &["-o", out.to_str().unwrap()],
            ]
            .concat(),
        );
        let err = String::from_utf8_lossy(&o.stderr);
        let v = isokit_io::read_npy(&out).unwrap().data;
        assert!(v.iter().all(|x| x.is_finite()), "{extra:?}");
        assert!(
            v.iter().any(|&x| x < 0.0) && v.iter().any(|&x| x > 0.0),
            "{extra:?}"
        );
        if extra[0] == "--weights" {
            assert!(!err.contains("solve:"), "{err}");
        }
        if extra[0] == "--solver" {
            assert!(
                err.contains(&format!("solve: {}", extra[1].to_uppercase()))
                    || err.contains("BiCGSTAB"),
                "{err}"
            );
        }
    }
}

#[test]
fn clear_errors() {
    let d = scratch("errors");
    let bad = d.join("nan.xyz");
    std::fs::write(&bad, "0 0 0\n1 0 0\nnan 0 0\n0 1 0\n").unwrap();
    let o = isokit(&[
        "points",
        bad.to_str().unwrap(),
        "-o",
        d.join("x.npy").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("not finite") || err.contains("nan"), "{err}");

    let plain = d.join("plain.xyz");
    std::fs::write(&plain, "0 0 0\n1 0 0\n0 1 0\n1 1 0\n").unwrap();
    let o = isokit(&[
        "points",
        plain.to_str().unwrap(),
        "--normals",
        "given",
        "-o",
        d.join("x.npy").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("no normals"), "{err}");

    let out = d.join("x.npy");
    for (extra, needle) in [
        (&["--damping=-1"][..], "damping"),
        (&["--band", "0"], "--band"),
        (&["--band", "0.1", "--brick", "3"], "brick size"),
        (
            &["--weights", "nie04", "--nie04-neighbours", "0"],
            "neighbours",
        ),
        (&["--k", "0"], "k must be"),
    ] {
        let o = isokit(
            &[
                &["points", &data("torus_cloud.ply"), "--res", "16"][..],
                extra,
                &["-o", out.to_str().unwrap()],
            ]
            .concat(),
        );
        assert_clear_error(&o, needle);
    }
}

#[test]
fn query_a_cloud() {
    let d = scratch("query");
    let q = d.join("q.npy");
    let pts: [f32; 9] = [1.35, 0.0, 0.0, 1.45, 0.0, 0.0, 0.0, 0.0, 0.0];
    isokit_io::write_npy_f32(&q, &[3, 3], &pts).unwrap();
    let out = d.join("d.npy");
    isokit_ok(&[
        "query",
        &data("torus_cloud.ply"),
        "--points",
        q.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let got = isokit_io::read_npy(&out).unwrap().data;
    for (g, e) in got.iter().zip([0.0, 0.1, 0.65]) {
        assert!((g - e).abs() < 0.02, "{got:?}");
    }
    let o = isokit(&[
        "query",
        &data("torus_cloud.ply"),
        "--points",
        q.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--closest",
        d.join("c.npy").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not available for point clouds"));
}

/// `--sign`: beside a box's sharp edges the closest sample's side is wrong several grid
/// spacings away (`--sign nearest`, the old rule); the default winding-number sign agrees
/// with the exact sign everywhere beyond 3 spacings.
#[test]
fn sign_rules_on_a_sharp_box() {
    let d = scratch("sign");
    let half = glam::Vec3::new(0.7, 0.5, 0.4);
    // Area-uniform samples on the six faces, with their exact normals.
    let mut rng = isokit_field::rng::SplitMix64::new(21);
    let areas = [half.y * half.z, half.x * half.z, half.x * half.y];
    let total: f32 = areas.iter().sum();
    let (mut points, mut normals) = (Vec::new(), Vec::new());
    for _ in 0..30_000 {
        let r = rng.next_f32() * total;
        let axis = if r < areas[0] {
            0
        } else if r < areas[0] + areas[1] {
            1
        } else {
            2
        };
        let mut p = rng.point_in(-half, half);
        let s = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
        p[axis] = s * half[axis];
        let mut n = glam::Vec3::ZERO;
        n[axis] = s;
        points.push(p);
        normals.push(n);
    }
    let cloud = d.join("box.ply");
    let pc = isokit_field::PointCloud {
        points,
        normals: Some(normals),
    };
    isokit_io::write_points(&cloud, &pc).unwrap();
    let exact = |p: glam::Vec3| {
        let q = p.abs() - half;
        q.max(glam::Vec3::ZERO).length() + q.max_element().min(0.0)
    };
    let mut wrong = Vec::new();
    // The last spelled as in scene files (an alias of `winding-everywhere`).
    for sign in [
        None,
        Some("nearest"),
        Some("winding"),
        Some("winding_everywhere"),
    ] {
        let out = d.join(format!("box_{}.nrrd", sign.unwrap_or("default")));
        let mut args = vec![
            "points",
            cloud.to_str().unwrap(),
            "--res",
            "64",
            "-o",
            out.to_str().unwrap(),
        ];
        if let Some(s) = sign {
            args.extend(["--sign", s]);
        }
        let o = isokit(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        let name = sign.unwrap_or("winding").replace('_', "-");
        assert!(err.contains(&format!("sign: {name})")), "{err}");
        assert_eq!(
            err.contains("winding number: sample areas"),
            name != "nearest"
        );
        let grid = isokit_io::read_volume(&out).unwrap().into_grid().unwrap();
        let h = grid.spacing();
        let bad = grid
            .iter()
            .filter(|&([i, j, k], v)| {
                let e = exact(grid.position(i, j, k));
                e.abs() > 3.0 * h && (v < 0.0) != (e < 0.0)
            })
            .count();
        eprintln!("sharp box, sign {name}: {bad} wrong signs beyond 3 spacings");
        wrong.push(bad);
    }
    assert!(
        wrong[1] > 0,
        "the nearest-sample rule was expected to fail here"
    );
    assert_eq!((wrong[0], wrong[2], wrong[3]), (0, 0, 0));
    let o = isokit(&[
        "points",
        cloud.to_str().unwrap(),
        "--sign",
        "majority",
        "-o",
        "x.nrrd",
    ]);
    assert!(!o.status.success());
}
