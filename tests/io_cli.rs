//! End-to-end tests of the files the commands write: NPY volumes keep their lattice in the
//! `.npy.json` sidecar, meshes go out as glTF/GLB (normals, colours) and PLY with normals,
//! NRRD compression is chosen by `--compression`, and `--like`/`--bounds` put several inputs
//! on one lattice.

mod common;

use common::{assert_clear_error, data, isokit, isokit_ok, json, scratch};
use serde_json::Value;
use std::path::Path;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn info(p: &Path) -> Value {
    json(&isokit_ok(&["info", s(p), "--json"]))
}

fn close(a: &Value, b: &Value, tol: f64) -> bool {
    let (a, b) = (a.as_array().unwrap(), b.as_array().unwrap());
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| (x.as_f64().unwrap() - y.as_f64().unwrap()).abs() <= tol)
}

#[test]
fn npy_outputs_carry_their_lattice_and_readers_use_it() {
    let d = scratch("npy-lattice");
    let (npy, nrrd) = (d.join("d.npy"), d.join("d.nrrd"));
    for out in [&npy, &nrrd] {
        isokit_ok(&[
            "sdf",
            &data("torus.off"),
            "--res",
            "24",
            "--band",
            "0.3",
            "-o",
            s(out),
        ]);
    }
    let side: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("d.npy.json")).unwrap()).unwrap();
    let vol = info(&nrrd);
    assert_eq!(side["dims"], vol["dims"]);
    assert!(close(&side["origin"], &vol["origin"], 1e-6), "{side} {vol}");
    assert!(
        close(&side["spacing"], &vol["spacing"], 1e-6),
        "{side} {vol}"
    );
    assert_eq!(side["axis_order"], "zyx");
    assert_eq!(side["inside"], "below");
    assert!(
        (side["band"].as_f64().unwrap() - 0.3).abs() < 1e-6,
        "{side}"
    );
    assert!(side["sign"].is_string(), "{side}");
    // `info` reads it: world coordinates, the band and the sign.
    let vi = info(&npy);
    assert_eq!(vi["sidecar"], true);
    assert_eq!(vi["origin"], vol["origin"]);
    assert_eq!(vi["sign"], side["sign"]);
    // `mesh` from the NPY gives the NRRD route's world-space mesh.
    let (m1, m2) = (d.join("a.obj"), d.join("b.obj"));
    isokit_ok(&["mesh", s(&npy), "-o", s(&m1)]);
    isokit_ok(&["mesh", s(&nrrd), "-o", s(&m2)]);
    assert_eq!(info(&m1)["bounds"], info(&m2)["bounds"]);
    // NRRD carries the same meaning as key/value pairs.
    let head = std::fs::read(&nrrd).unwrap();
    let head = String::from_utf8_lossy(&head[..400]);
    assert!(
        head.contains("band:=0.3") && head.contains("inside:=below"),
        "{head}"
    );
    // Every command that writes NPY writes the sidecar.
    let scene = d.join("s.json");
    std::fs::write(&scene, r#"{"shape": {"sphere": {"radius": 0.5}}}"#).unwrap();
    for args in [
        vec!["sample", "sphere", "--res", "16"],
        vec!["points", &data("torus_cloud.ply"), "--res", "16"],
        vec!["scene", s(&scene), "--res", "16"],
        vec!["convert", s(&nrrd)],
    ] {
        let out = d.join(format!("{}.npy", args[0]));
        let _ = std::fs::remove_file(d.join(format!("{}.npy.json", args[0])));
        let mut a = args.clone();
        if a[0] == "convert" {
            a.push(s(&out));
        } else {
            a.extend(["-o", s(&out)]);
        }
        isokit_ok(&a);
        let j = info(&out);
        assert_eq!(j["sidecar"], true, "{}: {j}", args[0]);
        assert_ne!(
            j["spacing"],
            serde_json::json!([1.0, 1.0, 1.0]),
            "{}",
            args[0]
        );
    }
    // A scene's volume source reads it too: its mesh lies where the NRRD route's does.
    let vs = d.join("v.json");
    std::fs::write(&vs, r#"{"shape": {"volume": {"path": "d.npy"}}}"#).unwrap();
    let m3 = d.join("v.obj");
    isokit_ok(&["scene", s(&vs), "--res", "24", "-o", s(&m3)]);
    let (b3, b2) = (info(&m3)["bounds"].clone(), info(&m2)["bounds"].clone());
    assert!(
        close(&b3["min"], &b2["min"], 0.1) && close(&b3["max"], &b2["max"], 0.1),
        "{b3} {b2}"
    );
    // Without the sidecar a reader says so, and takes --origin and --spacing.
    std::fs::remove_file(d.join("d.npy.json")).unwrap();
    let out = isokit_ok(&["mesh", s(&npy), "-o", s(&m1)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no lattice sidecar") && err.contains("--origin"),
        "{err}"
    );
    let o = vol["origin"].as_array().unwrap();
    let origin = format!("{},{},{}", o[0], o[1], o[2]);
    let spacing = vol["spacing"][0].to_string();
    isokit_ok(&[
        "mesh",
        s(&npy),
        "-o",
        s(&m1),
        "--origin",
        &origin,
        "--spacing",
        &spacing,
    ]);
    assert!(close(
        &info(&m1)["bounds"]["min"],
        &info(&m2)["bounds"]["min"],
        1e-5
    ));
}

#[test]
fn meshes_go_out_as_gltf_and_glb_with_normals_and_colours() {
    let d = scratch("gltf");
    let want = info(Path::new(&data("sphere.obj")));
    for ext in ["glb", "gltf"] {
        let out = d.join(format!("s.{ext}"));
        isokit_ok(&["convert", &data("sphere.obj"), s(&out)]);
        let j = info(&out);
        for k in ["vertices", "triangles", "bounds", "watertight"] {
            assert_eq!(j[k], want[k], "{ext} {k}: {j}");
        }
    }
    let glb = std::fs::read(d.join("s.glb")).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    let text = String::from_utf8_lossy(&glb);
    assert!(
        text.contains("\"NORMAL\"") && !text.contains("COLOR_0"),
        "{text:.300}"
    );
    // A coloured scene to GLB: COLOR_0; `mesh` writes GLB too.
    let scene = d.join("c.json");
    std::fs::write(
        &scene,
        r#"{"shape": {"union": [
            {"sphere": {"radius": 0.5, "center": [-0.6, 0, 0]}, "color": [1, 0, 0]},
            {"sphere": {"radius": 0.5, "center": [0.6, 0, 0]}, "color": [0, 0, 1]}]}}"#,
    )
    .unwrap();
    let (sg, sp) = (d.join("c.glb"), d.join("c.ply"));
    isokit_ok(&["scene", s(&scene), "--res", "24", "-o", s(&sg)]);
    isokit_ok(&["scene", s(&scene), "--res", "24", "-o", s(&sp)]);
    assert!(String::from_utf8_lossy(&std::fs::read(&sg).unwrap()).contains("COLOR_0"));
    assert_eq!(info(&sg)["triangles"], info(&sp)["triangles"]);
    // PLY carries vertex normals.
    let ply = std::fs::read(&sp).unwrap();
    assert!(String::from_utf8_lossy(&ply[..400]).contains("property float nx"));
    let vol = d.join("v.nrrd");
    isokit_ok(&["sample", "torus", "--res", "24", "-o", s(&vol)]);
    let (mg, mo) = (d.join("m.glb"), d.join("m.obj"));
    isokit_ok(&["mesh", s(&vol), "-o", s(&mg)]);
    isokit_ok(&["mesh", s(&vol), "-o", s(&mo)]);
    assert_eq!(info(&mg)["triangles"], info(&mo)["triangles"]);
    assert_eq!(info(&mg)["bounds"], info(&mo)["bounds"]);
}

#[test]
fn nrrd_compression_is_chosen_and_every_level_reads_back() {
    let d = scratch("compression");
    let mut sizes = Vec::new();
    let reference = d.join("none.nrrd");
    for c in ["none", "fast", "best"] {
        let out = d.join(format!("{c}.nrrd"));
        isokit_ok(&[
            "sample",
            "torus",
            "--res",
            "40",
            "--compression",
            c,
            "-o",
            s(&out),
        ]);
        let bytes = std::fs::read(&out).unwrap();
        let enc = if c == "none" {
            "encoding: raw"
        } else {
            "encoding: gzip"
        };
        assert!(String::from_utf8_lossy(&bytes[..300]).contains(enc), "{c}");
        sizes.push(bytes.len());
        let a = isokit::io::read_volume(&out).unwrap();
        let b = isokit::io::read_volume(&reference).unwrap();
        assert_eq!(a, b, "{c}");
    }
    assert!(sizes[1] < sizes[0] && sizes[2] <= sizes[1], "{sizes:?}");
    assert_clear_error(
        &isokit(&[
            "sample",
            "torus",
            "--compression",
            "max",
            "-o",
            s(&reference),
        ]),
        "--compression",
    );
}

#[test]
fn like_puts_two_meshes_on_one_lattice_for_render_csg() {
    let d = scratch("like");
    let (a, b, c) = (d.join("a.nrrd"), d.join("b.nrrd"), d.join("c.nrrd"));
    isokit_ok(&["sdf", &data("torus.off"), "--res", "32", "-o", s(&a)]);
    isokit_ok(&["sdf", &data("sphere.obj"), "--res", "32", "-o", s(&c)]);
    isokit_ok(&["sdf", &data("sphere.obj"), "--like", s(&a), "-o", s(&b)]);
    let png = d.join("u.png");
    let render = |with: &Path| {
        isokit(&[
            "render",
            s(&a),
            "-o",
            s(&png),
            "--width",
            "32",
            "--height",
            "32",
            "--csg",
            "union",
            "--with",
            s(with),
            "--backend",
            "cpu",
            "--stats",
        ])
    };
    // Each on its own lattice: refused; through --like: combined.
    assert_clear_error(&render(&c), "same lattice");
    let j = json(&render(&b));
    assert!(j["hits"].as_u64().unwrap() > 0, "{j}");
    // Every sampling command takes --like (and the lattice whole).
    let want = info(&a);
    let scene = d.join("s.json");
    std::fs::write(&scene, r#"{"shape": {"sphere": {"radius": 0.5}}}"#).unwrap();
    for args in [
        vec!["sample", "sphere"],
        vec!["points", &data("torus_cloud.ply")],
        vec!["scene", s(&scene)],
    ] {
        let out = d.join(format!("{}.nrrd", args[0]));
        let mut v = args.clone();
        v.extend(["--like", s(&a), "-o", s(&out)]);
        isokit_ok(&v);
        let j = info(&out);
        assert_eq!(j["dims"], want["dims"], "{}", args[0]);
        assert!(
            close(&j["origin"], &want["origin"], 1e-6),
            "{}: {j}",
            args[0]
        );
        assert!(
            close(&j["spacing"], &want["spacing"], 1e-7),
            "{}: {j}",
            args[0]
        );
    }
    // --bounds on sdf; --pad and --padding are one flag.
    let (p1, p2) = (d.join("p1.nrrd"), d.join("p2.nrrd"));
    isokit_ok(&[
        "sdf",
        &data("sphere.obj"),
        "--bounds",
        "-2,-2,-2,2,2,2",
        "--res",
        "9",
        "-o",
        s(&p1),
    ]);
    let j = info(&p1);
    assert_eq!(
        j["bounds"]["min"],
        serde_json::json!([-2.0, -2.0, -2.0]),
        "{j}"
    );
    isokit_ok(&[
        "sample",
        "sphere",
        "--res",
        "9",
        "--pad",
        "0.5",
        "-o",
        s(&p1),
    ]);
    isokit_ok(&[
        "sample",
        "sphere",
        "--res",
        "9",
        "--padding",
        "0.5",
        "-o",
        s(&p2),
    ]);
    assert_eq!(info(&p1)["bounds"], info(&p2)["bounds"]);
    assert_clear_error(
        &isokit(&[
            "sdf",
            &data("sphere.obj"),
            "--like",
            s(&a),
            "--bounds",
            "0,0,0,1,1,1",
            "-o",
            s(&p1),
        ]),
        "--like",
    );
}

#[test]
fn kdtree_band_is_lazy_by_bricks_and_equals_the_dense_band() {
    let d = scratch("lazy-kdtree");
    let (lazy, dense) = (d.join("lazy.npy"), d.join("dense.npy"));
    let torus = data("torus.off");
    let run = |out: &Path, extra: &[&str]| {
        let mut a = vec![
            "sdf",
            &torus,
            "--method",
            "kdtree",
            "--band",
            "0.15",
            "--res",
            "48",
            "-o",
            s(out),
        ];
        a.extend(extra);
        String::from_utf8_lossy(&isokit_ok(&a).stderr).into_owned()
    };
    let said = run(&lazy, &[]);
    let dense_said = run(&dense, &["--dense"]);
    assert!(said.contains("lazy band"), "{said}");
    // Both count the samples inside the band alike (the clamped ±W is outside it).
    let share = |t: &str| {
        let end = t.find("% of samples inside the band").unwrap();
        t[..end].rsplit(' ').next().unwrap().parse::<f64>().unwrap()
    };
    assert_eq!(share(&said), share(&dense_said), "{said}\n{dense_said}");
    assert!(share(&said) < 50.0, "{said}");
    let (a, b) = (
        isokit::io::read_volume(&lazy).unwrap(),
        isokit::io::read_volume(&dense).unwrap(),
    );
    assert_eq!((a.dims, a.origin, a.spacing), (b.dims, b.origin, b.spacing));
    let inside = b.data.iter().filter(|v| v.abs() < 0.15).count();
    assert!(inside > 1000, "{inside} samples within the band");
    let worst = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-5, "lazy and dense differ by {worst}");
}

#[test]
fn octree_says_when_the_max_level_misses_the_error_bound() {
    let run = |level: &str, error: &str| {
        let out = isokit_ok(&[
            "octree",
            "sphere",
            "--max-level",
            level,
            "--error",
            error,
            "--json",
        ]);
        json(&out)
    };
    let tight = run("3", "0.0005");
    let missed = tight["bound_missed_cells"].as_u64().unwrap();
    assert!(missed > 0, "{tight}");
    assert!(tight["max_error"].as_f64().unwrap() > 0.0005);
    let need = tight["level_for_bound"].as_u64().unwrap();
    assert!(need > 3, "{tight}");
    // The suggested level misses in fewer places.
    let finer = run(&need.to_string(), "0.0005");
    assert!(
        finer["bound_missed_cells_at_max_level"].as_u64().unwrap()
            < tight["bound_missed_cells_at_max_level"].as_u64().unwrap(),
        "{finer} {tight}"
    );
    let loose = run("3", "0.5");
    assert_eq!(loose["bound_missed_cells"], 0, "{loose}");
    assert!(loose["level_for_bound"].is_null());
    let text = isokit_ok(&["octree", "sphere", "--max-level", "3", "--error", "0.0005"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("bound missed") && text.contains("--max-level"),
        "{text}"
    );
}
