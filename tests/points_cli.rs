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
        assert!(err.contains("solve: GMRES"), "{err}");
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
