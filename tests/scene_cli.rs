//! End-to-end tests of `isokit scene` and `isokit mesh` through the real binary.

mod common;

use common::*;

fn example(name: &str) -> String {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

#[test]
fn example_scenes_mesh_watertight_and_report_stats() {
    let d = scratch("examples");
    for (scene, genus) in [("part.json", 5), ("part.toml", 5), ("trefoil_cut.json", -1)] {
        let out = d.join(format!("{scene}.obj"));
        let o = isokit_ok(&[
            "scene",
            &example(scene),
            "-o",
            out.to_str().unwrap(),
            "--res",
            "64",
            "--stats",
        ]);
        let j = json(&o);
        let fraction = j["dense_fraction"].as_f64().unwrap();
        assert!(fraction > 0.0 && fraction < 1.0, "{scene}: {fraction}");
        assert!(j["seconds"].as_f64().unwrap() >= 0.0);
        assert!(j["triangles"].as_u64().unwrap() > 1000);
        assert!(!j["sources"].as_array().unwrap().is_empty());
        let mesh = isokit::io::read_mesh(&out).unwrap();
        let r = mesh.validate();
        assert!(r.watertight && r.consistently_oriented, "{scene}: {r}");
        if genus >= 0 {
            assert_eq!(r.genus(), Some(genus), "{scene}");
        }
    }
}

/// The vocabulary's example parts (a bolt flange from a circular array of holes, a revolved
/// vase with a twisted shell, an extruded gear profile) mesh watertight with their genus.
#[test]
fn vocabulary_example_parts_mesh_watertight() {
    let d = scratch("vocab_examples");
    for (scene, genus) in [("flange.json", 7), ("vase.json", 0), ("gear.json", 1)] {
        let out = d.join(format!("{scene}.obj"));
        let o = isokit_ok(&[
            "scene",
            &example(scene),
            "-o",
            out.to_str().unwrap(),
            "--res",
            "64",
            "--stats",
        ]);
        let j = json(&o);
        assert!(j["triangles"].as_u64().unwrap() > 1000, "{scene}");
        let mesh = isokit::io::read_mesh(&out).unwrap();
        let r = mesh.validate();
        assert!(r.watertight && r.consistently_oriented, "{scene}: {r}");
        assert_eq!(r.genus(), Some(genus), "{scene}");
    }
}

#[test]
fn scene_to_volume_then_mesh_round_trip() {
    let d = scratch("volume");
    let scene = d.join("s.toml");
    std::fs::write(
        &scene,
        "[shape]\ndifference = [{ sphere = { radius = 1.0 } }, \
         { sphere = { radius = 0.5, center = [1, 0, 0] } }]\n",
    )
    .unwrap();
    let vol = d.join("s.nrrd");
    isokit_ok(&[
        "scene",
        scene.to_str().unwrap(),
        "-o",
        vol.to_str().unwrap(),
        "--res",
        "48",
        "--band",
        "0.2",
    ]);
    let v = isokit::io::read_volume(&vol).unwrap().into_grid().unwrap();
    // Band values clamp at ±0.2 with the right sign: the centre is deep inside.
    let (lo, hi) = v.min_max().unwrap();
    assert!(lo == -0.2 && hi == 0.2, "{lo} {hi}");
    let [nx, ny, nz] = v.dims();
    assert!(v.get(nx / 2 - 4, ny / 2, nz / 2) < 0.0);
    let obj = d.join("s.obj");
    let o = isokit_ok(&["mesh", vol.to_str().unwrap(), "-o", obj.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("watertight true"), "{err}");
    let mesh = isokit::io::read_mesh(&obj).unwrap();
    // Sphere of radius 1 minus a ball of radius 0.5 centred on its surface.
    let exact = 4.0 / 3.0 * std::f64::consts::PI - lens_volume(1.0, 0.5, 1.0);
    let vol_mesh = isokit::levelset::meshing::mesh_volume(&mesh);
    assert!(
        (vol_mesh - exact).abs() < 0.01 * exact,
        "{vol_mesh} vs {exact}"
    );
}

/// Volume of the intersection of balls of radii `r1`, `r2` with centres `d` apart.
fn lens_volume(r1: f64, r2: f64, d: f64) -> f64 {
    std::f64::consts::PI
        * (r1 + r2 - d).powi(2)
        * (d * d + 2.0 * d * r2 - 3.0 * r2 * r2 + 2.0 * d * r1 + 6.0 * r1 * r2 - 3.0 * r1 * r1)
        / (12.0 * d)
}

#[test]
fn scene_and_mesh_errors_are_one_clear_line() {
    let d = scratch("errors");
    let bad = d.join("bad.json");
    std::fs::write(
        &bad,
        r#"{"shape": {"union": [{"sphere": {"radius": 1}}, {"cube": {}}]}}"#,
    )
    .unwrap();
    let out = d.join("o.obj");
    let o = isokit(&["scene", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_clear_error(&o, "shape.union[1]");
    assert_clear_error(&o, "unknown variant `cube`");
    assert!(!out.exists());
    let o = isokit(&["scene", &example("part.json"), "-o", "x.vtk"]);
    assert_clear_error(&o, "unknown output format");
    let o = isokit(&[
        "scene",
        &example("part.json"),
        "-o",
        out.to_str().unwrap(),
        "--res",
        "1000000000",
    ]);
    assert_clear_error(&o, "too large");
    let o = isokit(&["mesh", &data("torus.off"), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let o = isokit(&["mesh", "missing.nrrd", "-o", out.to_str().unwrap()]);
    assert_clear_error(&o, "missing.nrrd");
}

/// A scene with coloured nodes meshed to PLY carries each part's colour on its vertices
/// (8-bit sRGB): the flange's bolt holes in theirs, its body in its own.
#[test]
fn coloured_parts_reach_the_ply_vertices() {
    let d = scratch("vocab_colours");
    let out = d.join("flange.ply");
    isokit_ok(&[
        "scene",
        &example("flange.json"),
        "-o",
        out.to_str().unwrap(),
        "--res",
        "48",
    ]);
    let bytes = std::fs::read(&out).unwrap();
    let end = b"end_header\n";
    let at = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let header = String::from_utf8_lossy(&bytes[..at]);
    assert!(header.contains("property uchar red\nproperty uchar green\nproperty uchar blue\n"));
    let n: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .unwrap()
        .parse()
        .unwrap();
    let srgb = |x: f32| {
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    let holes = [0.85f32, 0.35, 0.1].map(srgb);
    let body = [0.72f32, 0.72, 0.76].map(srgb);
    let (mut in_holes, mut in_body) = (0, 0);
    // x y z, the vertex normal nx ny nz (f32 each), then red green blue.
    assert!(header.contains("property float nx\nproperty float ny\nproperty float nz\n"));
    let stride = 27;
    for i in 0..n {
        let rec = &bytes[at + stride * i..at + stride * (i + 1)];
        let rgb = [rec[24], rec[25], rec[26]];
        if rgb == holes {
            in_holes += 1;
            // A hole's wall is within a bolt radius (and a voxel) of the bolt circle.
            let x = f32::from_le_bytes(rec[0..4].try_into().unwrap());
            let y = f32::from_le_bytes(rec[4..8].try_into().unwrap());
            let r = x.hypot(y);
            assert!((r - 0.7).abs() < 0.08 + 0.1, "hole vertex at radius {r}");
        } else if rgb == body {
            in_body += 1;
        }
    }
    assert!(
        in_holes > 50 && in_body > 500,
        "holes {in_holes}, body {in_body} of {n}"
    );
    let mesh = isokit::io::read_mesh(&out).unwrap();
    assert_eq!(mesh.positions.len(), n);
    assert!(mesh.validate().watertight);
}

/// `--mesher dual` on the shipped scenes: closed, oriented meshes with the genus (or the
/// components) of the marching-cubes ones, the mesher named in the statistics, no triangle
/// crossing another or facing the wrong way — the CSG parts at resolution 64, the scenes
/// with faceted mesh operands and thin blends at their own; on a volume output it is
/// refused, and `isokit mesh --mesher dual` meshes a volume.
#[test]
fn mesher_dual_meshes_the_shipped_scenes() {
    let d = scratch("mesher_dual");
    // Scene, resolution, genus, components.
    let scenes = [
        ("part.json", Some("64"), Some(5), 1),
        ("flange.json", Some("64"), Some(7), 1),
        ("gear.json", Some("64"), Some(1), 1),
        ("demo.json", None, Some(3), 1),
        ("trefoil_cut.json", None, None, 3),
        ("vase.json", None, Some(0), 1),
        // Thin twisted walls: 8 triangles faced the wrong way here while vertices on sharp
        // features kept their places where their quads only folded.
        ("vase.json", Some("128"), Some(0), 1),
    ];
    for (scene, res, genus, components) in scenes {
        let out = d.join(format!("{scene}.{}.dual.obj", res.unwrap_or("own")));
        let path = example(scene);
        let mut args = vec!["scene", &path, "-o", out.to_str().unwrap()];
        if let Some(r) = res {
            args.extend(["--res", r]);
        }
        args.extend(["--mesher", "dual", "--stats"]);
        let o = isokit_ok(&args);
        let j = json(&o);
        assert_eq!(j["mesher"], "dual", "{scene}");
        assert!(j["clamped_vertices"].as_u64().is_some(), "{scene}");
        assert_eq!(j["folded_triangles"], 0, "{scene}");
        let mesh = isokit::io::read_mesh(&out).unwrap();
        let r = mesh.validate();
        assert!(r.watertight && r.consistently_oriented, "{scene}: {r}");
        assert_eq!(r.degenerate_triangles, 0, "{scene}: {r}");
        assert_eq!(r.components, components, "{scene}");
        if genus.is_some() {
            assert_eq!(r.genus(), genus, "{scene}");
        }
        let x = isokit_levelset::intersect::self_intersections(&mesh);
        assert!(
            x.pairs.is_empty(),
            "{scene}: {} self-intersecting pairs",
            x.pairs.len()
        );
    }
    let vol = d.join("part.nrrd");
    let o = isokit(&[
        "scene",
        &example("part.json"),
        "-o",
        vol.to_str().unwrap(),
        "--mesher",
        "dual",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--mesher"), "{e}");
    isokit_ok(&[
        "scene",
        &example("part.json"),
        "-o",
        vol.to_str().unwrap(),
        "--res",
        "48",
    ]);
    let out = d.join("part_volume.dual.obj");
    isokit_ok(&[
        "mesh",
        vol.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--mesher",
        "dual",
    ]);
    let r = isokit::io::read_mesh(&out).unwrap().validate();
    assert!(r.watertight && r.consistently_oriented, "{r}");
}

/// `--mesher dual --error E`: the shipped part meshed adaptively has the genus of the uniform
/// mesh, far fewer triangles, no self-intersection, and every vertex within E of its exact
/// surface where cells merged; `--error` without `--mesher dual`, or not positive, is refused.
#[test]
fn mesher_dual_error_merges_cells() {
    let d = scratch("mesher_dual_error");
    let uniform = d.join("part.obj");
    let adaptive = d.join("part_adaptive.obj");
    let scene = example("part.json");
    let run = |out: &std::path::Path, extra: &[&str]| {
        let mut a = vec!["scene", &scene, "-o", out.to_str().unwrap(), "--res", "96"];
        a.extend_from_slice(&["--mesher", "dual", "--stats"]);
        a.extend_from_slice(extra);
        json(&isokit_ok(&a))
    };
    let ju = run(&uniform, &[]);
    assert!(ju.get("merged_cells").is_none());
    let spacing = ju["spacing"].as_f64().unwrap();
    let e = format!("{}", 0.1 * spacing);
    let ja = run(&adaptive, &["--error", &e]);
    assert!(ja["merged_cells"].as_u64().unwrap() > 0);
    let (mu, ma) = (
        isokit::io::read_mesh(&uniform).unwrap(),
        isokit::io::read_mesh(&adaptive).unwrap(),
    );
    let r = ma.validate();
    assert!(r.watertight && r.consistently_oriented, "{r}");
    assert_eq!(r.non_manifold_edges, 0, "{r}");
    assert_eq!(r.genus(), mu.validate().genus());
    assert!(
        ma.triangles.len() * 3 < mu.triangles.len(),
        "{} against {} triangles",
        ma.triangles.len(),
        mu.triangles.len()
    );
    assert_eq!(ja["triangles"].as_u64(), Some(ma.triangles.len() as u64));
    let x = isokit_levelset::intersect::self_intersections(&ma);
    assert!(x.pairs.is_empty(), "{} pairs", x.pairs.len());
    for bad in [
        vec!["--error", "0.01"],
        vec!["--mesher", "dual", "--error", "0"],
        vec!["--mesher", "dual", "--error", "nan"],
        // A negative value after a space is the value, refused as such (not an option).
        vec!["--mesher", "dual", "--error", "-0.01"],
    ] {
        let mut a = vec!["scene", &scene, "-o", adaptive.to_str().unwrap()];
        a.extend_from_slice(&bad);
        let o = isokit(&a);
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        let msg = String::from_utf8_lossy(&o.stderr);
        assert!(msg.contains("--error"), "{bad:?}: {msg}");
        if bad.len() == 4 {
            assert!(msg.contains("positive"), "{bad:?}: {msg}");
        }
    }
    // Either mesher named with a volume output is refused, not ignored.
    let volume = adaptive.with_extension("nrrd");
    for mesher in ["mc", "dual"] {
        let o = isokit(&[
            "scene",
            &scene,
            "-o",
            volume.to_str().unwrap(),
            "--mesher",
            mesher,
        ]);
        assert_clear_error(&o, "--mesher applies to mesh outputs");
        assert!(!volume.exists(), "{mesher}");
    }
}
