//! `isokit render --shading flow`: the curvature-aligned flow mode from the command line
//! (a torus, whose LIC texture modulates the tone shading), and its refusal for a
//! multi-view display.

mod common;

use common::{assert_clear_error, isokit, isokit_ok, scratch};

const TORUS: &str = r#"{
  "shape": {"torus": {"major": 0.6, "minor": 0.25}},
  "camera": {"eye": [0.4, 1.6, 2.2], "fov": 40},
  "sampling": {"resolution": 48}
}"#;

#[test]
fn render_accepts_the_flow_mode() {
    let dir = scratch("flow-cli");
    let scene = dir.join("torus.json");
    std::fs::write(&scene, TORUS).unwrap();
    let run = |mode: &str| {
        let png = dir.join(format!("{mode}.png"));
        isokit_ok(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--shading",
            mode,
            "--backend",
            "cpu",
        ]);
        isokit::io::read_png(&png).unwrap()
    };
    let (w, h, flow) = run("flow");
    assert_eq!((w, h), (64, 48));
    let (_, _, tone) = run("tone");
    // The same background, a textured surface.
    assert_eq!(flow[..4], tone[..4]);
    let differ = flow
        .chunks(4)
        .zip(tone.chunks(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ > 300, "{differ} pixels differ from tone shading");
    // A multi-view G-buffer has no single image to advect in.
    let out = isokit(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        dir.join("mv.png").to_str().unwrap(),
        "--width",
        "32",
        "--height",
        "24",
        "--shading",
        "flow",
        "--views",
        "4",
        "--backend",
        "cpu",
    ]);
    assert_clear_error(&out, "multi-view");
}
