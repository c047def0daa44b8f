//! End-to-end test of `isokit render --cache-policy downsample`: with a cache too small for
//! the active bricks, the least detailed bricks are stored at half resolution and the image
//! is rendered in one pass (002 Sec. 6.2.3); `passes` (the default) renders the exact
//! image in several.

mod common;

use common::{isokit, isokit_ok, json, scratch};

#[test]
fn cache_policy_downsample_renders_in_one_pass() {
    let dir = scratch("downsample-cli");
    // A sphere across the face between two bricks (48³ samples: bricks of 32 cells, the
    // face at x ≈ 0.36): two active bricks, a cache of one (--cache-mb 0).
    let vol = dir.join("s.nrrd");
    let n = 48;
    let mut g = isokit::Grid::new([n; 3], glam::Vec3::splat(-1.0), 2.0 / (n - 1) as f32).unwrap();
    for ([i, j, k], _) in g.clone().iter() {
        let p = g.position(i, j, k);
        g.set(
            i,
            j,
            k,
            (p - glam::Vec3::new(0.36, -0.45, -0.45)).length() - 0.45,
        );
    }
    isokit::io::write_volume(&vol, &isokit::io::Volume::from(g)).unwrap();
    let run = |policy: &str| {
        let png = dir.join(format!("{policy}.png"));
        let out = isokit_ok(&[
            "render",
            vol.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "64",
            "--cache-mb",
            "0",
            "--cache-policy",
            policy,
            "--stats",
            "--backend",
            "cpu",
        ]);
        let (w, h, _) = isokit::io::read_png(&png).unwrap();
        assert_eq!((w, h), (64, 64));
        json(&out)
    };
    let passes = run("passes");
    let down = run("downsample");
    assert_eq!(passes["cache_capacity"], 1, "{passes}");
    assert!(passes["bricks_active"].as_u64().unwrap() >= 2, "{passes}");
    assert!(passes["passes"].as_u64().unwrap() > 1, "{passes}");
    assert_eq!(passes["bricks_downsampled"], 0, "{passes}");
    assert_eq!(down["passes"], 1, "{down}");
    assert!(down["bricks_downsampled"].as_u64().unwrap() >= 1, "{down}");
    let (hp, hd) = (
        passes["hits"].as_u64().unwrap() as f64,
        down["hits"].as_u64().unwrap() as f64,
    );
    assert!(hp > 50.0 && (hp - hd).abs() <= 0.03 * hp, "{passes} {down}");
    // An unknown policy is refused.
    let bad = isokit(&[
        "render",
        vol.to_str().unwrap(),
        "-o",
        dir.join("x.png").to_str().unwrap(),
        "--cache-policy",
        "half",
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("cache-policy"));
}
