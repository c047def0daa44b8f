//! Tetrahedral grids written by VTK and meshio (`data/tets/`, made by
//! `tools/tet_fixtures.py`) through `isokit info` and `isokit mesh`, against what VTK itself
//! reports for the same grid in `data/tets/reference.json`: the counts and range of the
//! grid, and the isosurface of `vtkContourFilter` (points, triangles, area, volume).

mod common;

use common::{assert_clear_error, data, isokit, isokit_ok, json, scratch};
use isokit_levelset::meshing::{mesh_area, mesh_volume};
use serde_json::Value;
use std::path::Path;

fn reference() -> Value {
    let text = std::fs::read_to_string(data("tets/reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn grids() -> Vec<String> {
    let files = reference()["files"].as_array().unwrap().clone();
    let grids: Vec<String> = files
        .iter()
        .map(|f| f.as_str().unwrap())
        .filter(|f| f.ends_with(".vtk") || f.ends_with(".vtu"))
        .map(|f| data(&format!("tets/{f}")))
        .collect();
    assert_eq!(grids.len(), 5, "{grids:?}");
    grids
}

fn near(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs()
}

#[test]
fn info_reports_the_grid_as_vtk_does_in_every_encoding() {
    let r = reference();
    for g in grids() {
        let v = json(&isokit_ok(&["info", &g, "--json"]));
        assert_eq!(v["kind"], "tets", "{g}");
        assert_eq!(v["cells"], r["cells"], "{g}");
        assert_eq!(v["points"], r["points"], "{g}");
        assert_eq!(v["array"], "distance", "{g}");
        for k in 0..2 {
            let (a, b) = (
                v["range"][k].as_f64().unwrap(),
                r["range"][k].as_f64().unwrap(),
            );
            assert!((a - b).abs() < 1e-7, "{g}: range {a} vs {b}");
        }
        // A tetrahedralized 8 × 8 × 8 box of cubes: two triangles per boundary square.
        assert_eq!(v["boundary_faces"], 2 * 6 * 64, "{g}");
        for k in [
            "inverted_cells",
            "degenerate_cells",
            "over_shared_faces",
            "unused_points",
        ] {
            assert_eq!(v[k], 0, "{g}: {k}");
        }
    }
    // Another scalar by name; a vector array is not a scalar.
    let g = data("tets/torus.vtu");
    let v = json(&isokit_ok(&["info", &g, "--json", "--array", "height"]));
    assert_eq!(v["array"], "height");
    assert!(v["range"][0].as_f64().unwrap() < -1.0);
    let out = isokit(&["info", &g, "--array", "position"]);
    assert_clear_error(&out, "no point array named \"position\" with one component");
}

#[test]
fn the_isosurface_is_vtks_contour_closed_and_facing_out() {
    let c = reference()["contour"].clone();
    let d = scratch("tets-mesh");
    for g in grids() {
        let out = d.join("surface.ply");
        let o = out.to_str().unwrap();
        isokit_ok(&["mesh", &g, "-o", o, "-q"]);
        let mesh = isokit_io::read_mesh(Path::new(o)).unwrap();
        // Both cut each crossing edge once and merge the corners: the same counts.
        assert_eq!(
            mesh.positions.len() as u64,
            c["points"].as_u64().unwrap(),
            "{g}"
        );
        assert_eq!(
            mesh.triangles.len() as u64,
            c["triangles"].as_u64().unwrap(),
            "{g}"
        );
        // The same corners, and (measured) the same diagonals through the quadrilaterals:
        // area and volume agree to 2e-9 and 1.2e-8 relative, f32 corners allow 1e-6.
        let (area, volume) = (mesh_area(&mesh), mesh_volume(&mesh));
        assert!(
            near(area, c["area"].as_f64().unwrap(), 1e-6),
            "{g}: area {area} vs {c}"
        );
        assert!(
            near(volume, c["volume"].as_f64().unwrap(), 1e-6),
            "{g}: volume {volume} vs {c}"
        );
        let rep = mesh.validate();
        assert!(rep.is_clean(), "{g}: {rep}");
        assert_eq!(rep.genus(), Some(1), "{g}: {rep}");
    }
    // The other side inside: the same surface facing in.
    let g = data("tets/torus.vtu");
    let out = d.join("inward.obj");
    let o = out.to_str().unwrap();
    isokit_ok(&["mesh", &g, "-o", o, "-q", "--inside", "above"]);
    let volume = mesh_volume(&isokit_io::read_mesh(Path::new(o)).unwrap());
    assert!(
        near(-volume, c["volume"].as_f64().unwrap(), 1e-6),
        "{volume}"
    );
}

#[test]
fn knobs_that_do_not_apply_are_refused_and_nothing_is_written() {
    let d = scratch("tets-refused");
    let g = data("tets/torus.vtu");
    let out = d.join("x.obj");
    let o = out.to_str().unwrap();
    for extra in [&["--open"][..], &["--mesher", "dual"], &["--array", "nope"]] {
        let mut args = vec!["mesh", g.as_str(), "-o", o];
        args.extend_from_slice(extra);
        let r = isokit(&args);
        assert!(!r.status.success(), "{extra:?}");
        assert!(!out.exists(), "{extra:?}");
    }
    assert_clear_error(
        &isokit(&["mesh", &g, "-o", o, "--open"]),
        "--open and --mesher apply to volumes",
    );
    // `--array` on a volume.
    let vol = d.join("v.nrrd");
    isokit_ok(&[
        "sdf",
        &data("sphere.obj"),
        "-o",
        vol.to_str().unwrap(),
        "--res",
        "8",
        "-q",
    ]);
    assert_clear_error(
        &isokit(&[
            "mesh",
            vol.to_str().unwrap(),
            "-o",
            o,
            "--array",
            "distance",
        ]),
        "--array applies to tetrahedral grids",
    );
}

#[test]
fn render_ray_casts_the_grid_and_refuses_what_it_cannot_do() {
    let d = scratch("tets-render");
    let g = data("tets/torus.vtu");
    let png = d.join("torus.png");
    let exr = d.join("torus.exr");
    let p = png.to_str().unwrap();
    let out = isokit_ok(&[
        "render",
        &g,
        "-o",
        p,
        "--gbuffer",
        exr.to_str().unwrap(),
        "--width",
        "96",
        "--height",
        "72",
        "--stats",
        "-q",
    ]);
    let v = json(&out);
    assert_eq!(v["cells"], 2560);
    assert_eq!(v["boundary_faces"], 768);
    let hits = v["hits"].as_u64().unwrap();
    // The camera frames the grid's box, the torus fills part of it (measured: 473).
    assert!(hits > 300, "{v}");
    assert!(png.exists() && exr.exists());
    // The other side inside: the same surface, the same pixels.
    let out = isokit_ok(&[
        "render", &g, "-o", p, "--width", "96", "--height", "72", "--stats", "-q", "--inside",
        "above",
    ]);
    assert_eq!(json(&out)["hits"].as_u64(), Some(hits));
    for (extra, needle) in [
        (&["--shading", "curvature"][..], "has no curvature"),
        (
            &["--samples", "4"],
            "--samples is not available for tetrahedral grids",
        ),
        (&["--mode", "dvr"], "--mode dvr needs --tf"),
        (&["--step", "0.1"], "--step applies to --mode dvr"),
        (&["--tf", "distance-shell"], "--tf applies to --mode dvr"),
    ] {
        let mut args = vec!["render", g.as_str(), "-o", p];
        args.extend_from_slice(extra);
        assert_clear_error(&isokit(&args), needle);
    }
}

#[test]
fn dvr_renders_through_the_cells_with_its_channels_consistent() {
    let d = scratch("tets-dvr");
    let g = data("tets/torus.vtu");
    // White emission, extinction rising with the distance inside the torus.
    let tf = d.join("tf.json");
    std::fs::write(
        &tf,
        r#"{"points": [[-0.25, 1, 1, 1, 12], [0, 1, 1, 1, 3], [0.05, 1, 1, 1, 0]]}"#,
    )
    .unwrap();
    let (png, exr) = (d.join("dvr.png"), d.join("dvr.exr"));
    let mut means = vec![];
    for classification in ["preintegrated", "post"] {
        let out = isokit_ok(&[
            "render",
            &g,
            "--mode",
            "dvr",
            "--tf",
            tf.to_str().unwrap(),
            "--classification",
            classification,
            "-o",
            png.to_str().unwrap(),
            "--gbuffer",
            exr.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--stats",
            "-q",
        ]);
        let v = json(&out);
        assert_eq!(v["mode"], "dvr");
        assert_eq!(v["classification"], classification);
        assert_eq!(v["cells"], 2560);
        assert!(v["segments_per_ray"].as_f64().unwrap() > 1.0, "{v}");
        let img = isokit::io::read_exr(&exr).unwrap();
        let (r, a, z) = (
            img.channel("R").unwrap(),
            img.channel("A").unwrap(),
            img.channel("Z").unwrap(),
        );
        // White emission: the premultiplied red is the opacity; the depth is where the
        // opacity passes 0.5, so it is finite exactly where the opacity ends above 0.5.
        let (mut opaque, mut sum) = (0, 0.0f64);
        for i in 0..a.len() {
            assert!(
                (r[i] - a[i]).abs() < 1e-4,
                "{classification} {i}: {} {}",
                r[i],
                a[i]
            );
            assert_eq!(
                z[i].is_finite(),
                a[i] > 0.5,
                "{classification} {i}: {}",
                a[i]
            );
            opaque += usize::from(a[i] > 0.5);
            sum += f64::from(a[i]);
        }
        assert!(opaque > 100, "{classification}: {opaque}");
        means.push(sum / a.len() as f64);
    }
    // Each segment integrated on its own (--table-size 0) against the table: close.
    let out = isokit_ok(&[
        "render",
        &g,
        "--mode",
        "dvr",
        "--tf",
        tf.to_str().unwrap(),
        "--table-size",
        "0",
        "-o",
        png.to_str().unwrap(),
        "--gbuffer",
        exr.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
        "-q",
    ]);
    assert!(out.status.success());
    let a = isokit::io::read_exr(&exr).unwrap();
    let exact = a.channel("A").unwrap();
    let mean = exact.iter().map(|&x| f64::from(x)).sum::<f64>() / exact.len() as f64;
    eprintln!("mean opacity integrated per segment: {mean}");
    assert!((mean - means[0]).abs() < 0.01 * mean, "{mean} {means:?}");
    // A smooth transfer function: post-classification per cell is close (measured: mean
    // opacity 0.0604 pre-integrated, 0.0596 post).
    eprintln!("mean opacity: pre-integrated, post: {means:?}");
    assert!((means[0] - means[1]).abs() < 0.05 * means[0], "{means:?}");
    for (extra, needle) in [
        (
            &["--step", "0.1"][..],
            "--step (a ray's segments are its cells')",
        ),
        (&["--iso", "0"], "--iso (for --mode isosurface)"),
        (&["--shading", "tone"], "--mode dvr shades with phong"),
    ] {
        let mut args = vec![
            "render",
            g.as_str(),
            "--mode",
            "dvr",
            "--tf",
            "distance-shell",
            "-o",
            png.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        assert_clear_error(&isokit(&args), needle);
    }
}

#[test]
fn the_gpu_backend_renders_both_modes_as_the_cpu_does() {
    let Some(_gpu) =
        isokit_gpu::testing::gpu_or_skip("the_gpu_backend_renders_both_modes_as_the_cpu_does")
    else {
        return;
    };
    let d = scratch("tets-gpu");
    let g = data("tets/torus.vtu");
    for mode in [
        &["--mode", "isosurface"][..],
        &["--mode", "dvr", "--tf", "distance-shell"],
    ] {
        let mut channels = Vec::new();
        for backend in ["cpu", "gpu"] {
            let exr = d.join(format!("{backend}.exr"));
            let png = d.join(format!("{backend}.png"));
            let mut args = vec![
                "render",
                g.as_str(),
                "-o",
                png.to_str().unwrap(),
                "--gbuffer",
                exr.to_str().unwrap(),
                "--width",
                "64",
                "--height",
                "48",
                "--backend",
                backend,
                "--stats",
                "-q",
            ];
            args.extend_from_slice(mode);
            let out = isokit_ok(&args);
            let v = json(&out);
            let device = v.get("device").or_else(|| v.get("backend")).cloned();
            assert_eq!(device, Some(Value::from(backend)), "{v}");
            let e = isokit::io::read_exr(&exr).unwrap();
            channels.push(
                e.channel(if mode[1] == "dvr" { "A" } else { "Z" })
                    .unwrap()
                    .to_vec(),
            );
        }
        let (cpu, gpu) = (&channels[0], &channels[1]);
        let (mut masks, mut worst) = (0, 0.0f32);
        for (a, b) in cpu.iter().zip(gpu) {
            if a.is_finite() != b.is_finite() {
                masks += 1;
            } else if a.is_finite() {
                worst = worst.max((a - b).abs());
            }
        }
        eprintln!(
            "{mode:?}: cpu and gpu differ by {worst:.1e} where both are finite, {masks} masks"
        );
        assert!(masks == 0 && worst < 1e-4, "{mode:?}: {worst} {masks}");
        assert!(cpu.iter().any(|z| z.is_finite() && *z > 0.0));
    }
}
