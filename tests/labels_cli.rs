//! `isokit mesh LABELS.nrrd --labels -o out.ply`: the PLY's faces carry `region_a` and
//! `region_b`, and the interfaces of three touching blocks have their exact areas.

mod common;

use common::{assert_clear_error, isokit, isokit_ok, scratch};
use glam::Vec3;
use isokit_field::Grid;
use std::collections::BTreeMap;
use std::path::Path;

/// Region 1 for i < 5, 2 for i ≥ 5 and j < 5, 3 for i ≥ 5 and j ≥ 5 over the samples
/// 1..=10 × 1..=8 × 1..=6 of a 12 × 10 × 8 volume of spacing 0.5; 0 around them.
fn write_blocks(path: &Path, bad: bool) {
    let mut g = Grid::new([12, 10, 8], Vec3::ZERO, 0.5).unwrap();
    for k in 1..=6 {
        for j in 1..=8 {
            for i in 1..=10 {
                g.set(
                    i,
                    j,
                    k,
                    if i < 5 {
                        1.0
                    } else if j < 5 {
                        2.0
                    } else {
                        3.0
                    },
                );
            }
        }
    }
    if bad {
        g.set(2, 2, 2, 0.25);
    }
    isokit::io::write_volume(path, &isokit::io::Volume::from(g)).unwrap();
}

/// Area per region pair, read from the binary PLY by its header.
fn areas(ply: &Path) -> BTreeMap<(i32, i32), f64> {
    let bytes = std::fs::read(ply).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(header.contains(
        "property list uchar int vertex_indices\nproperty int region_a\nproperty int region_b\n"
    ));
    let count = |what: &str| -> usize {
        let line = header.lines().find(|l| l.starts_with(what)).unwrap();
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let (nv, nf) = (count("element vertex"), count("element face"));
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let i32_at = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let vertex = |i: i32| {
        let o = end + 24 * i as usize;
        Vec3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8)).as_dvec3()
    };
    let faces = end + 24 * nv;
    assert_eq!(bytes.len(), faces + 21 * nf);
    let mut out = BTreeMap::new();
    for f in 0..nf {
        let o = faces + 21 * f;
        assert_eq!(bytes[o], 3);
        let [a, b, c] = [0, 1, 2].map(|k| vertex(i32_at(o + 1 + 4 * k)));
        let (ra, rb) = (i32_at(o + 13), i32_at(o + 17));
        assert!(ra < rb, "{ra} {rb}");
        *out.entry((ra, rb)).or_insert(0.0) += 0.5 * (b - a).cross(c - a).length();
    }
    out
}

#[test]
fn labels_mesh_into_a_ply_whose_faces_carry_their_regions() {
    let d = scratch("labels-cli");
    let vol = d.join("labels.nrrd");
    write_blocks(&vol, false);
    let ply = d.join("regions.ply");
    let v = vol.to_str().unwrap();
    let out = isokit_ok(&[
        "mesh",
        v,
        "--labels",
        "--smooth",
        "0",
        "-o",
        ply.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("between 6 region pairs"), "{err}");
    // In spacings² (0.25 each): halfway between the samples.
    let want = [
        ((0, 1), 160.0),
        ((0, 2), 108.0),
        ((0, 3), 108.0),
        ((1, 2), 24.0),
        ((1, 3), 24.0),
        ((2, 3), 36.0),
    ];
    let got = areas(&ply);
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (pair, a) in want {
        assert!(
            (got[&pair] / 0.25 - a).abs() < 1e-6 * a,
            "{pair:?}: {}",
            got[&pair]
        );
    }
    // The project's own reader (and any PLY reader) takes the mesh, skipping the regions.
    let mesh = isokit::io::read_mesh(&ply).unwrap();
    assert_eq!(mesh.triangles.len(), 2 * 460);
    // Smoothed (the default): the same pairs, the interfaces between blocks still flat
    // where they are away from the outside.
    isokit_ok(&["mesh", v, "--labels", "-o", ply.to_str().unwrap()]);
    assert_eq!(areas(&ply).len(), 6);
}

#[test]
fn labels_refuse_what_does_not_apply_and_labels_that_are_not_whole() {
    let d = scratch("labels-cli-errors");
    let vol = d.join("labels.nrrd");
    write_blocks(&vol, false);
    let v = vol.to_str().unwrap();
    let obj = d.join("out.obj");
    let ply = d.join("out.ply");
    let p = ply.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["mesh", v, "--labels", "-o", obj.to_str().unwrap()],
            ".ply",
        ),
        (
            vec!["mesh", v, "--labels", "--iso", "1", "-o", p],
            "--iso does not apply to --labels",
        ),
        (
            vec!["mesh", v, "--smooth", "3", "-o", p],
            "--smooth applies to --labels",
        ),
        (
            vec!["mesh", v, "--labels", "--smooth", "100000000", "-o", p],
            "must be at most 10000 relaxation passes",
        ),
    ] {
        assert_clear_error(&isokit(&args), needle);
    }
    write_blocks(&vol, true);
    assert_clear_error(
        &isokit(&["mesh", v, "--labels", "-o", p]),
        "labels must be whole numbers",
    );
    assert!(!ply.exists() && !obj.exists());
}

/// Three square patches of side 2 meeting along the line x = 0.02, z = 0.01 (a T): the
/// floor's halves (normal +z; 2 and 3 above, 1 below) and a wall on x = 0.02 above the
/// floor (normal +x; 3 in front, 2 behind), as an ASCII PLY with `region_front` and
/// `region_back`.
fn write_tee(path: &Path, with_regions: bool) {
    let (x0, z0) = (0.02f32, 0.01f32);
    let quads: [([[f32; 3]; 4], i32, i32); 3] = [
        (
            [
                [-1.0, -1.0, z0],
                [x0, -1.0, z0],
                [x0, 1.0, z0],
                [-1.0, 1.0, z0],
            ],
            2,
            1,
        ),
        (
            [
                [x0, -1.0, z0],
                [1.0, -1.0, z0],
                [1.0, 1.0, z0],
                [x0, 1.0, z0],
            ],
            3,
            1,
        ),
        (
            [
                [x0, -1.0, z0],
                [x0, 1.0, z0],
                [x0, 1.0, 2.0],
                [x0, -1.0, 2.0],
            ],
            3,
            2,
        ),
    ];
    let props = if with_regions {
        "property int region_front\nproperty int region_back\n"
    } else {
        ""
    };
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex 12\nproperty float x\nproperty float y\nproperty float z\nelement face 3\nproperty list uchar int vertex_indices\n{props}end_header\n"
    );
    for (q, _, _) in &quads {
        for p in q {
            s += &format!("{} {} {}\n", p[0], p[1], p[2]);
        }
    }
    for (i, (_, f, b)) in quads.iter().enumerate() {
        let v = 4 * i;
        s += &format!("4 {} {} {} {}", v, v + 1, v + 2, v + 3);
        if with_regions {
            s += &format!(" {f} {b}");
        }
        s += "\n";
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn segmented_patches_mesh_into_their_junction_with_the_areas_of_the_patches() {
    let d = scratch("segmented-cli");
    let (tee, out) = (d.join("tee.ply"), d.join("regions.ply"));
    write_tee(&tee, true);
    let o = isokit_ok(&[
        "mesh",
        tee.to_str().unwrap(),
        "--segmented",
        "--res",
        "48",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("between 3 region pairs"), "{err}");
    let got = areas(&out);
    // The patches' areas: 2 x 1.02, 2 x 0.98, 2 x 1.99 (measured: −0.3%, +0.0%, −0.2%, the
    // open rims located from the distances and the junction's vertices placed on the line;
    // −1.1%, +1.3%, −1.3% with those vertices up to half a spacing off it).
    for (pair, want) in [((1, 2), 2.04), ((1, 3), 1.96), ((2, 3), 3.98)] {
        let rel = got[&pair] / want - 1.0;
        eprintln!("{pair:?}: {rel:+.3}");
        assert!(rel.abs() < 0.03, "{pair:?}: {}", got[&pair]);
    }
    write_tee(&tee, false);
    assert_clear_error(
        &isokit(&[
            "mesh",
            tee.to_str().unwrap(),
            "--segmented",
            "-o",
            out.to_str().unwrap(),
        ]),
        "no scalar property region_front",
    );
    assert_clear_error(
        &isokit(&[
            "mesh",
            tee.to_str().unwrap(),
            "--segmented",
            "--smooth",
            "2",
            "-o",
            out.to_str().unwrap(),
        ]),
        "--smooth does not apply to --segmented",
    );
}

#[test]
fn segmented_patches_render_each_surface_with_its_region_pair() {
    let d = scratch("segmented-render");
    let (tee, png, exr) = (d.join("tee.ply"), d.join("tee.png"), d.join("tee.exr"));
    write_tee(&tee, true);
    let (mut stats, mut hits) = (Vec::new(), Vec::new());
    for diagram in [None, Some("256")] {
        let mut args = vec![
            "render",
            tee.to_str().unwrap(),
            "--segmented",
            "--res",
            "40",
            "--width",
            "96",
            "--height",
            "72",
            "--eye",
            "2.5,-3,2.5",
            "-o",
            png.to_str().unwrap(),
            "--gbuffer",
            exr.to_str().unwrap(),
            "--stats",
            "-q",
        ];
        if let Some(n) = diagram {
            args.extend_from_slice(&["--diagram", n]);
        }
        let o = isokit_ok(&args);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["regions"], serde_json::json!([1, 2, 3]), "{v}");
        let pairs: BTreeMap<(i64, i64), u64> = v["pairs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                let r = &p["regions"];
                (
                    (r[0].as_i64().unwrap(), r[1].as_i64().unwrap()),
                    p["pixels"].as_u64().unwrap(),
                )
            })
            .collect();
        // The three patches' pairs, each seen by many pixels.
        let keys: Vec<_> = pairs.keys().copied().collect();
        assert_eq!(keys, vec![(1, 2), (1, 3), (2, 3)], "{v}");
        assert!(pairs.values().all(|&n| n > 50), "{pairs:?}");
        // The EXR's region channels hold the same pairs, on the right planes: the wall at
        // x = 0.02 between 2 and 3, the floor at z = 0.01 under 1|2 and 1|3.
        let e = isokit::io::read_exr(&exr).unwrap();
        let ch = |n: &str| e.channel(n).unwrap().to_vec();
        let (ra, rb) = (ch("region_a"), ch("region_b"));
        let (px, py, pz) = (ch("P.X"), ch("P.Y"), ch("P.Z"));
        let h = 2.4 * 1.2 / 39.0; // the padded box's longest side over the samples
        let (mut wall, mut floor) = (0.0f32, 0.0f32);
        for i in 0..ra.len() {
            let (a, b) = (ra[i] as i64, rb[i] as i64);
            if a < 0 {
                continue;
            }
            let (x, y, z) = (px[i], py[i], pz[i]);
            // Away from the junction line and the patches' open rims.
            if (x - 0.02).hypot(z - 0.01) < 2.0 * h || x.abs().max(y.abs()) > 0.9 || z > 1.9 {
                continue;
            }
            if (a, b) == (2, 3) {
                wall = wall.max((x - 0.02).abs() / h);
            } else {
                floor = floor.max((z - 0.01).abs() / h);
            }
        }
        eprintln!(
            "diagram {diagram:?}: {pairs:?}; off the wall {wall:.2e}, off the floor {floor:.2e} spacing"
        );
        assert!(wall < 0.1 && floor < 0.1, "{wall} {floor}");
        stats.push(pairs);
        hits.push((ra.clone(), px.clone(), py.clone(), pz.clone()));
    }
    // The diagram and Eq. 5-7 see the same surfaces, up to pixels at the patches' open rims
    // (the diagram takes Eq. 7's bound an entry wider; measured: 1146 and 1241 pixels
    // of 2|3, the wall, whose rims are long in this view).
    let h = 2.4 * 1.2 / 39.0;
    let mut differ = 0;
    for i in 0..hits[0].0.len() {
        if (hits[0].0[i] < 0.0) != (hits[1].0[i] < 0.0) {
            differ += 1;
            let k = usize::from(hits[0].0[i] < 0.0);
            let (x, y, z) = (hits[k].1[i], hits[k].2[i], hits[k].3[i]);
            let to_rim = (1.0 - x.abs()).min(1.0 - y.abs()).min((2.0 - z).abs());
            assert!(
                to_rim < 2.0 * h,
                "({x}, {y}, {z}) differs {to_rim} from a rim"
            );
        }
    }
    eprintln!("{differ} pixels differ, all within 2 spacings of a rim");
    for (k, n) in &stats[0] {
        let m = stats[1][k];
        assert!(n.abs_diff(m) <= n / 8, "{k:?}: {n} {m}");
    }
    let t = tee.to_str().unwrap();
    // The GPU twin, where an adapter exists: the same pairs on the same pixels.
    let gpu = isokit_gpu::testing::gpu_or_skip("segmented_patches_render (the gpu twin)");
    if gpu.is_some() {
        let mut pairs = Vec::new();
        for backend in ["cpu", "gpu"] {
            isokit_ok(&[
                "render",
                t,
                "--segmented",
                "--res",
                "40",
                "--width",
                "96",
                "--height",
                "72",
                "--eye",
                "2.5,-3,2.5",
                "-o",
                png.to_str().unwrap(),
                "--gbuffer",
                exr.to_str().unwrap(),
                "--backend",
                backend,
                "-q",
            ]);
            let e = isokit::io::read_exr(&exr).unwrap();
            let ch = |n: &str| e.channel(n).unwrap().to_vec();
            pairs.push((ch("region_a"), ch("region_b")));
        }
        assert!(pairs[0] == pairs[1], "the twins' region pairs differ");
        assert!(pairs[0].0.iter().any(|&a| a >= 0.0));
    }
    for (extra, needle) in [
        (
            &["--iso", "0"][..],
            "--iso (the surfaces lie between regions)",
        ),
        (&["--shading", "curvature"], "without curvature"),
        (&["--diagram", "1"], "vertex generation diagram"),
    ] {
        let mut args = vec!["render", t, "--segmented", "-o", png.to_str().unwrap()];
        args.extend_from_slice(extra);
        assert_clear_error(&isokit(&args), needle);
    }
    assert_clear_error(
        &isokit(&["render", t, "--diagram", "64", "-o", png.to_str().unwrap()]),
        "--segmented",
    );
}

/// Two triangles over x, y in [-1, 1] on the plane z = s x, region 1 below and 2 above.
fn write_tilted(path: &Path, s: f32) {
    let corners = [[-1.0f32, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let mut t = String::from(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nproperty int region_front\nproperty int region_back\nend_header\n",
    );
    for [x, y] in corners {
        t += &format!("{x} {y} {}\n", s * x);
    }
    t += "3 0 1 2 2 1\n3 0 2 3 2 1\n";
    std::fs::write(path, t).unwrap();
}

#[test]
fn segmented_fields_are_written_read_and_morphed() {
    let d = scratch("segmented-files");
    let p = |n: &str| d.join(n).to_str().unwrap().to_owned();
    write_tilted(&d.join("a.ply"), 0.3);
    write_tilted(&d.join("b.ply"), -0.3);
    // The same box, so the same lattice; δ of 8 spacings, more than the planes are apart.
    for n in ["a", "b"] {
        isokit_ok(&[
            "sdf",
            &p(&format!("{n}.ply")),
            "--segmented",
            "--res",
            "40",
            "--seg-delta",
            "8",
            "--seg-period",
            "16",
            "-o",
            &p(&format!("{n}.nrrd")),
        ]);
    }
    // Read back: the same surface as sampling the patches directly.
    isokit_ok(&["mesh", &p("a.nrrd"), "--segmented", "-o", &p("a_file.ply")]);
    isokit_ok(&[
        "mesh",
        &p("a.ply"),
        "--segmented",
        "--res",
        "40",
        "--seg-delta",
        "8",
        "--seg-period",
        "16",
        "-o",
        &p("a_direct.ply"),
    ]);
    assert_eq!(areas(&d.join("a_file.ply")), areas(&d.join("a_direct.ply")));
    // Halfway between z = 0.3 x and z = -0.3 x: the plane z = 0 (003 Sec. 5.2, the blend of
    // the signed distances to the two planes), in the mesh and in the rendering.
    isokit_ok(&[
        "mesh",
        &p("a.nrrd"),
        "--segmented",
        "--seg-morph",
        &p("b.nrrd"),
        "-o",
        &p("half.ply"),
    ]);
    let m = isokit_io::read_mesh(&d.join("half.ply")).unwrap();
    let inner: Vec<f32> = m
        .positions
        .iter()
        .filter(|v| v.x.abs().max(v.y.abs()) < 0.8)
        .map(|v| v.z.abs())
        .collect();
    let worst = inner.iter().copied().fold(0.0f32, f32::max);
    eprintln!(
        "morph: {} inner vertices, worst |z| {worst:.2e}",
        inner.len()
    );
    assert!(inner.len() > 500 && worst < 1e-3, "{worst}");
    isokit_ok(&[
        "render",
        &p("a.nrrd"),
        "--segmented",
        "--seg-morph",
        &p("b.nrrd"),
        "--seg-morph-t",
        "0.5",
        "--eye",
        "1.5,-2.5,2.5",
        "--width",
        "64",
        "--height",
        "64",
        "-o",
        &p("half.png"),
        "--gbuffer",
        &p("half.exr"),
    ]);
    let e = isokit::io::read_exr(&d.join("half.exr")).unwrap();
    let ch = |n: &str| e.channel(n).unwrap().to_vec();
    let (ra, px, py, pz) = (ch("region_a"), ch("P.X"), ch("P.Y"), ch("P.Z"));
    let (mut n, mut worst) = (0, 0.0f32);
    for i in 0..ra.len() {
        if ra[i] >= 0.0 && px[i].abs().max(py[i].abs()) < 0.8 {
            n += 1;
            worst = worst.max(pz[i].abs());
        }
    }
    eprintln!("morph rendered: {n} inner hits, worst |z| {worst:.2e}");
    assert!(n > 500 && worst < 1e-3, "{n} {worst}");
    // What does not go together is refused.
    isokit_ok(&[
        "sdf",
        &p("b.ply"),
        "--segmented",
        "--res",
        "40",
        "-o",
        &p("c.nrrd"),
    ]);
    for (args, needle) in [
        (
            vec![
                "mesh",
                &p("a.nrrd"),
                "--segmented",
                "--seg-morph",
                &p("c.nrrd"),
                "-o",
                &p("x.ply"),
            ],
            "differ from the input's",
        ),
        (
            vec![
                "mesh",
                &p("a.nrrd"),
                "--segmented",
                "--seg-morph-t",
                "0.3",
                "-o",
                &p("x.ply"),
            ],
            "--seg-morph-t needs --seg-morph",
        ),
        (
            vec![
                "mesh",
                &p("a.nrrd"),
                "--segmented",
                "--seg-delta",
                "3",
                "-o",
                &p("x.ply"),
            ],
            "--seg-delta applies to surface patches",
        ),
        (
            vec!["mesh", &p("a.nrrd"), "--seg-delta", "3", "-o", &p("x.ply")],
            "--seg-delta applies to --segmented",
        ),
        (
            vec!["sdf", &p("a.nrrd"), "--segmented", "-o", &p("x.nrrd")],
            "a PLY whose faces carry region_front",
        ),
        (
            vec![
                "sdf",
                &p("a.ply"),
                "--segmented",
                "--seg-delta",
                "9",
                "-o",
                &p("x.nrrd"),
            ],
            "needs 0 < delta < period",
        ),
        (
            vec!["sdf", &p("a.ply"), "--segmented", "-o", &p("x.npy")],
            "use one of .nrrd",
        ),
        (
            vec![
                "sdf",
                &p("a.ply"),
                "--segmented",
                "--band",
                "0.1",
                "-o",
                &p("x.nrrd"),
            ],
            "--band does not apply to --segmented",
        ),
        (
            vec![
                "sdf",
                &p("a.ply"),
                "--segmented",
                "--sign",
                "winding",
                "-o",
                &p("x.nrrd"),
            ],
            "--sign does not apply to --segmented",
        ),
        (
            vec![
                "render",
                &p("a.nrrd"),
                "--seg-morph",
                &p("b.nrrd"),
                "-o",
                &p("x.png"),
            ],
            "--seg-morph applies to --segmented",
        ),
        (
            vec![
                "render",
                &p("a.nrrd"),
                "--segmented",
                "--layers",
                "3",
                "--opacity",
                "1",
                "-o",
                &p("x.png"),
            ],
            "give --opacity below 1",
        ),
        (
            vec![
                "render",
                &p("a.nrrd"),
                "--segmented",
                "--mode",
                "dvr",
                "-o",
                &p("x.png"),
            ],
            "--mode dvr is not available for --segmented",
        ),
        (
            vec![
                "mesh",
                &p("a.nrrd"),
                "--labels",
                "--seg-delta",
                "2",
                "-o",
                &p("x.ply"),
            ],
            "--seg-delta does not apply to --labels",
        ),
    ] {
        assert_clear_error(&isokit(&args), needle);
    }
    // A plain volume is not a segmented field.
    let plain = d.join("plain.nrrd");
    let g = Grid::new([4, 4, 4], Vec3::ZERO, 0.5).unwrap();
    isokit_io::write_nrrd(
        &plain,
        &isokit_io::Volume::from(g),
        isokit_io::NrrdEncoding::Raw,
    )
    .unwrap();
    assert_clear_error(
        &isokit(&[
            "render",
            plain.to_str().unwrap(),
            "--segmented",
            "-o",
            &p("x.png"),
        ]),
        "not a segmented field",
    );
    // At the default δ (4 spacings) the planes are too far apart near x = ±1: a warning.
    isokit_ok(&[
        "sdf",
        &p("a.ply"),
        "--segmented",
        "--res",
        "40",
        "-o",
        &p("a4.nrrd"),
    ]);
    let o = isokit_ok(&[
        "mesh",
        &p("a4.nrrd"),
        "--segmented",
        "--seg-morph",
        &p("c.nrrd"),
        "-o",
        &p("near.ply"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("the blend there is not exact"), "{err}");
    // A segmented field without --segmented, and a tetrahedral grid with it.
    for args in [
        vec!["render", &p("a.nrrd"), "-o", &p("x.png")],
        vec!["mesh", &p("a.nrrd"), "-o", &p("x.ply")],
    ] {
        assert_clear_error(
            &isokit(&args),
            "is a segmented field (its header says field:=segmented): add --segmented",
        );
    }
    let torus = common::data("tets/torus.vtu");
    assert_clear_error(
        &isokit(&["render", &torus, "--segmented", "-o", &p("x.png")]),
        "is a tetrahedral grid",
    );
    // A field whose samples decode to a region beyond 4095 is refused, not indexed.
    let mut g = isokit_io::read_volume(&d.join("a.nrrd"))
        .unwrap()
        .into_grid()
        .unwrap();
    let kv = isokit_io::read_nrrd_key_values(&d.join("a.nrrd")).unwrap();
    let period: f32 = kv
        .iter()
        .find(|(k, _)| k == "period")
        .unwrap()
        .1
        .parse()
        .unwrap();
    g.set(3, 3, 3, 5000.0 * period + 0.01);
    let pairs: Vec<(&str, &str)> = kv.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    let big = d.join("big.nrrd");
    isokit_io::write_nrrd_key_values(
        &big,
        &isokit_io::Volume::from(g),
        isokit_io::NrrdEncoding::Raw,
        &pairs,
    )
    .unwrap();
    assert_clear_error(
        &isokit(&[
            "render",
            big.to_str().unwrap(),
            "--segmented",
            "-o",
            &p("x.png"),
        ]),
        "decodes to a region beyond 4095",
    );
    assert!(!d.join("x.png").exists() && !d.join("x.ply").exists() && !d.join("x.nrrd").exists());
}

#[test]
fn a_label_volume_becomes_a_segmented_field_to_render_and_mesh() {
    let d = scratch("segmented-labels");
    let vol = d.join("blocks.nrrd");
    write_blocks(&vol, false);
    let (v, png, exr) = (vol.to_str().unwrap(), d.join("b.png"), d.join("b.exr"));
    // From above: the top faces of the three blocks, against region 0, at z = 3.25.
    isokit_ok(&[
        "render",
        v,
        "--segmented",
        "--from-labels",
        "--eye",
        "2.8,2.2,12",
        "--target",
        "2.8,2.2,0",
        "--up",
        "0,1,0",
        "--width",
        "80",
        "--height",
        "80",
        "-o",
        png.to_str().unwrap(),
        "--gbuffer",
        exr.to_str().unwrap(),
    ]);
    let e = isokit::io::read_exr(&exr).unwrap();
    let ch = |n: &str| e.channel(n).unwrap().to_vec();
    let (ra, rb) = (ch("region_a"), ch("region_b"));
    let (px, py, pz) = (ch("P.X"), ch("P.Y"), ch("P.Z"));
    // The reference: the label interfaces as `isokit mesh --labels` makes them (relaxed
    // 16 times, as --from-labels meshes them before sampling their distance).
    let reference = d.join("ref.ply");
    isokit_ok(&["mesh", v, "--labels", "-o", reference.to_str().unwrap()]);
    let m = isokit_io::read_mesh(&reference).unwrap();
    let sdf = isokit_kdtree::mesh::MeshSdf::new(&m, Default::default()).unwrap();
    let mut stats = Default::default();
    let (mut n, mut worst) = (0, 0.0f64);
    for i in 0..ra.len() {
        let (x, y) = (px[i], py[i]);
        // Away from the top face's edges and from the junctions with the inner interfaces.
        let inner = x > 1.0 && x < 4.5 && y > 1.0 && y < 3.5;
        if ra[i] < 0.0 || !inner || (x - 2.25).abs() < 0.5 || (x > 2.25 && (y - 2.25).abs() < 0.5) {
            continue;
        }
        n += 1;
        let want = if x < 2.25 {
            1.0
        } else if y < 2.25 {
            2.0
        } else {
            3.0
        };
        assert_eq!((ra[i], rb[i]), (0.0, want), "at ({x}, {y})");
        let p = glam::DVec3::new(f64::from(x), f64::from(y), f64::from(pz[i]));
        let off = sdf.query(p, &mut stats).unwrap().distance.abs() / 0.5;
        worst = worst.max(off);
    }
    eprintln!("labels: {n} top-face hits, worst {worst:.3} spacing off the label surface");
    assert!(n > 300 && worst < 0.1, "{n} {worst}");
    // Translucent: the inner interfaces are found behind the outer faces and composited.
    let o = isokit_ok(&[
        "render",
        v,
        "--segmented",
        "--from-labels",
        "--opacity",
        "0.5",
        "--layers",
        "4",
        "--eye",
        "9,-6,7",
        "--target",
        "2.8,2.2,1.7",
        "--width",
        "80",
        "--height",
        "80",
        "--stats",
        "-q",
        "-o",
        png.to_str().unwrap(),
    ]);
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let layer_hits: Vec<u64> = s["layer_hits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    eprintln!("translucent: hits per layer {layer_hits:?}");
    // Every ray through the blocks leaves them again, and many cross an inner interface.
    assert_eq!(layer_hits.len(), 4);
    assert_eq!(layer_hits[0], layer_hits[1], "{s}");
    assert!(layer_hits[2] > layer_hits[0] / 4, "{s}");
    for (extra, needle) in [
        (&["--opacity", "0"][..], "must be above 0"),
        (&["--opacity", "0.5", "--layers", "17"], "from 1 to 16"),
    ] {
        let mut args = vec![
            v,
            "--segmented",
            "--from-labels",
            "-o",
            png.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let mut all = vec!["render"];
        all.extend(args);
        assert_clear_error(&isokit(&all), needle);
    }
    // Meshed through the same field: the six interfaces, the three inside ones too.
    let ply = d.join("b.ply");
    let o = isokit_ok(&[
        "mesh",
        v,
        "--segmented",
        "--from-labels",
        "-o",
        ply.to_str().unwrap(),
    ]);
    let pairs: Vec<(i32, i32)> = areas(&ply).keys().copied().collect();
    assert_eq!(
        pairs,
        vec![(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)],
        "{o:?}"
    );
    // Labels that are not whole, and --from-labels on patches, are refused.
    write_blocks(&vol, true);
    assert_clear_error(
        &isokit(&[
            "render",
            v,
            "--segmented",
            "--from-labels",
            "-o",
            png.to_str().unwrap(),
        ]),
        "whole labels from 0 to 4095",
    );
    let tee = d.join("tee.ply");
    write_tee(&tee, true);
    assert_clear_error(
        &isokit(&[
            "render",
            tee.to_str().unwrap(),
            "--segmented",
            "--from-labels",
            "-o",
            png.to_str().unwrap(),
        ]),
        "not surface patches",
    );
}
