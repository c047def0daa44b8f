//! End-to-end tests of `isokit render --clip SCENE|VOLUME [--clip-invert]`: a plane scene
//! and a clip volume on another lattice cut a sphere's volume in both render modes, and what
//! `--clip` does not go with is refused in one line.

mod common;

use common::{assert_clear_error, data, isokit, isokit_ok, json, scratch};
use glam::Vec3;
use isokit::field::Grid;
use std::path::Path;

/// A sphere of radius 0.6 as a signed distance on 32³ over [-1, 1]³.
fn ball(dir: &Path) -> String {
    let n = 32;
    let h = 2.0 / (n - 1) as f32;
    let values: Vec<f32> = (0..n * n * n)
        .map(|e| {
            let p = Vec3::new((e % n) as f32, ((e / n) % n) as f32, (e / (n * n)) as f32);
            (p * h - Vec3::ONE).length() - 0.6
        })
        .collect();
    let grid = Grid::from_data([n; 3], Vec3::splat(-1.0), h, values).unwrap();
    let vol = dir.join("ball.nrrd");
    isokit::io::write_nrrd_raw(&vol, &isokit::io::Volume::from_grid(&grid)).unwrap();
    vol.to_str().unwrap().to_string()
}

/// The plane z = 0.3 as a scene whose inside is z ≥ 0.3: the clip keeps z < 0.3.
const PLANE: &str = r#"{"shape": {"plane": {"normal": [0, 0, -1], "offset": -0.3}}}"#;

fn render(vol: &str, out: &Path, extra: &[&str]) -> serde_json::Value {
    let o = out.to_str().unwrap();
    let mut args = vec![
        "render", vol, "--width", "24", "--height", "24", "--eye", "0,0,4", "-o", o, "--stats",
    ];
    args.extend(extra);
    json(&isokit_ok(&args))
}

/// The centre pixel's opacity of a `--gbuffer` written by `--mode dvr`.
fn centre_opacity(exr: &Path) -> f32 {
    let g = isokit::io::read_exr(exr).unwrap();
    g.channel("A").unwrap()[12 * 24 + 12]
}

#[test]
fn a_plane_scene_and_a_clip_volume_cut_the_volume_in_both_modes() {
    let dir = scratch("clip-cli");
    let vol = ball(&dir);
    let plane = dir.join("plane.json");
    std::fs::write(&plane, PLANE).unwrap();
    let tf = dir.join("tf.json");
    std::fs::write(
        &tf,
        r#"{"points": [[-0.05, 1, 0.5, 0.2, 3], [-0.04, 1, 0.5, 0.2, 3], [0, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    let (tf, p) = (tf.to_str().unwrap(), plane.to_str().unwrap());
    let exr = dir.join("g.exr");
    let e = exr.to_str().unwrap();
    let dvr = ["--mode", "dvr", "--tf", tf, "--gbuffer", e];
    let open_png = dir.join("open.png");
    render(&vol, &open_png, &dvr);
    let whole = centre_opacity(&exr);
    // The centre ray crosses the sphere from z = 0.6 to −0.6, σ = 3 where the distance is
    // below −0.04 and ramping to 0 at the surface (worth 0.02 of full σ at each end): whole
    // 1.2 − 0.04 at full σ; kept z < 0.3, 0.9 − 0.02; inverted, 0.3 − 0.02.
    let opacity = |len: f32| 1.0 - (-3.0 * len).exp();
    let mut args = dvr.to_vec();
    args.extend(["--clip", p]);
    let s = render(&vol, &dir.join("kept.png"), &args);
    assert_eq!(s["clip"], p);
    let kept = centre_opacity(&exr);
    args.push("--clip-invert");
    let s = render(&vol, &dir.join("inverted.png"), &args);
    assert_eq!(s["clip_invert"], true);
    let inverted = centre_opacity(&exr);
    eprintln!("centre opacity: whole {whole}, kept z < 0.3 {kept}, inverted {inverted}");
    assert!((whole - opacity(1.16)).abs() < 0.03, "{whole}");
    assert!((kept - opacity(0.88)).abs() < 0.03, "{kept}");
    assert!((inverted - opacity(0.28)).abs() < 0.03, "{inverted}");

    // The same plane as a clip volume on a coarser lattice of its own (resampled).
    let m = 12;
    let h = 2.4 / (m - 1) as f32;
    let values: Vec<f32> = (0..m * m * m)
        .map(|e| 0.3 - ((e / (m * m)) as f32 * h - 1.2))
        .collect();
    let clip = Grid::from_data([m; 3], Vec3::splat(-1.2), h, values).unwrap();
    let clip_vol = dir.join("clip.nrrd");
    isokit::io::write_nrrd_raw(&clip_vol, &isokit::io::Volume::from_grid(&clip)).unwrap();
    let mut args = dvr.to_vec();
    args.extend(["--clip", clip_vol.to_str().unwrap()]);
    render(&vol, &dir.join("kept_volume.png"), &args);
    let by_volume = centre_opacity(&exr);
    assert!((by_volume - kept).abs() < 1e-3, "{by_volume} {kept}");

    // The isosurface cut open: seen from +z the centre shows the cut face at z = 0.3,
    // shaded as a cap; inverted, the sphere's own cap of z > 0.3 at z = 0.6.
    let iso_exr = dir.join("iso.exr");
    let ie = iso_exr.to_str().unwrap();
    let s = render(&vol, &dir.join("iso.png"), &["--clip", p, "--gbuffer", ie]);
    assert!(s["clip_caps"].as_u64().unwrap() > 20, "{s}");
    let z = |exr: &Path| isokit::io::read_exr(exr).unwrap().channel("P.Z").unwrap()[12 * 24 + 12];
    assert!((z(&iso_exr) - 0.3).abs() < 0.01, "{}", z(&iso_exr));
    let s = render(
        &vol,
        &dir.join("iso_inv.png"),
        &["--clip", p, "--clip-invert", "--gbuffer", ie],
    );
    assert_eq!(s["clip_caps"], 0, "{s}");
    assert!((z(&iso_exr) - 0.6).abs() < 0.02, "{}", z(&iso_exr));
    let (_, _, cut) = isokit::io::read_png(&dir.join("iso.png")).unwrap();
    let (_, _, plain) = isokit::io::read_png(&dir.join("iso_inv.png")).unwrap();
    assert_ne!(cut, plain);
}

#[test]
fn what_clip_does_not_go_with_is_refused_in_one_line() {
    let dir = scratch("clip-cli-refused");
    let vol = ball(&dir);
    let plane = dir.join("plane.json");
    std::fs::write(&plane, PLANE).unwrap();
    let p = plane.to_str().unwrap();
    let png = dir.join("x.png");
    let o = png.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["render", vol.as_str(), "-o", o];
        args.extend(extra);
        isokit(&args)
    };
    assert_clear_error(&run(&["--clip-invert"]), "--clip");
    assert_clear_error(&run(&["--clip", "missing.json"]), "missing.json");
    assert_clear_error(
        &run(&["--clip", p, "--csg", "union", "--with", &vol]),
        "--csg",
    );
    assert_clear_error(&run(&["--clip", p, "--samples", "4"]), "--samples");
    assert_clear_error(
        &isokit(&["render", p, "--clip", p, "-o", o]),
        "cut it with an intersection or difference node",
    );
    let tets = data("tets/torus.vtu");
    assert_clear_error(&isokit(&["render", &tets, "--clip", p, "-o", o]), "--clip");
    // A clip volume with a NaN cannot say which side is kept.
    let mut bad = Grid::filled([4; 3], Vec3::splat(-1.0), 0.7, 1.0).unwrap();
    bad.set(1, 1, 1, f32::NAN);
    let bad_vol = dir.join("bad.nrrd");
    isokit::io::write_nrrd_raw(&bad_vol, &isokit::io::Volume::from_grid(&bad)).unwrap();
    assert_clear_error(&run(&["--clip", bad_vol.to_str().unwrap()]), "non-finite");
    assert!(!png.exists(), "a refused run wrote its output");
}
