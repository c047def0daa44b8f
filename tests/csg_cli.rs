//! End-to-end tests of `isokit render A --csg OP --with B`: on-the-fly CSG of two volumes
//! to PNG, and refused inputs (another lattice, a scene) with one-line errors.

mod common;

use common::{assert_clear_error, isokit, isokit_ok, json, scratch};

/// A sphere's signed distance on an `n³` lattice over `[-1, 1]³` (spacing `2/(n − 1)`).
fn sphere(path: &std::path::Path, n: usize, c: glam::Vec3, r: f32) {
    let mut g = isokit::Grid::new([n; 3], glam::Vec3::splat(-1.0), 2.0 / (n - 1) as f32).unwrap();
    for ([i, j, k], _) in g.clone().iter() {
        let p = g.position(i, j, k);
        g.set(i, j, k, (p - c).length() - r);
    }
    isokit::io::write_volume(path, &isokit::io::Volume::from(g)).unwrap();
}

#[test]
fn csg_difference_renders_and_other_lattices_are_refused() {
    let dir = scratch("csg-cli");
    let (a, b, c) = (dir.join("a.nrrd"), dir.join("b.nrrd"), dir.join("c.nrrd"));
    sphere(&a, 33, glam::Vec3::ZERO, 0.6);
    sphere(&b, 33, glam::Vec3::new(0.3, 0.3, 0.6), 0.45);
    sphere(&c, 25, glam::Vec3::ZERO, 0.4);
    let png = dir.join("diff.png");
    let run = |op: &str, with: &std::path::Path| {
        isokit(&[
            "render",
            a.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "48",
            "--height",
            "40",
            "--csg",
            op,
            "--with",
            with.to_str().unwrap(),
            "--stats",
            "--backend",
            "cpu",
        ])
    };
    let out = run("difference", &b);
    let j = json(&out);
    assert!(out.status.success());
    let (w, h, _) = isokit::io::read_png(&png).unwrap();
    assert_eq!((w, h), (48, 40));
    // The sphere alone covers more pixels than with the bite taken out.
    let alone = json(&isokit_ok(&[
        "render",
        a.to_str().unwrap(),
        "-o",
        dir.join("a.png").to_str().unwrap(),
        "--width",
        "48",
        "--height",
        "40",
        "--stats",
        "--backend",
        "cpu",
    ]));
    let hits = |j: &serde_json::Value| j["hits"].as_u64().unwrap();
    assert!(hits(&j) > 50 && hits(&j) <= hits(&alone), "{j} {alone}");
    let (_, _, cut) = isokit::io::read_png(&png).unwrap();
    let (_, _, whole) = isokit::io::read_png(&dir.join("a.png")).unwrap();
    assert_ne!(cut, whole, "the difference must show the bite");
    assert_clear_error(&run("union", &c), "same lattice");
    // A scene with --csg is refused.
    let scene = dir.join("s.json");
    std::fs::write(&scene, r#"{"shape": {"sphere": {"radius": 0.5}}}"#).unwrap();
    let out = isokit(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--csg",
        "union",
        "--with",
        b.to_str().unwrap(),
    ]);
    assert_clear_error(&out, "--csg combines two volumes");
    // --morph-t belongs to --csg morph.
    let out = isokit(&[
        "render",
        a.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--csg",
        "union",
        "--with",
        b.to_str().unwrap(),
        "--morph-t",
        "0.3",
    ]);
    assert_clear_error(&out, "--morph-t applies to --csg morph only");
}
