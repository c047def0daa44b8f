//! Scene files: parsing (JSON and TOML alike), clear errors, pruned evaluation equal to the
//! full one, and lazy sampling equal to dense sampling in the band.

mod common;

use common::random_tree;
use glam::Vec3;
use isokit_field::{Field, rng::SplitMix64};
use isokit_scene::{SampleOptions, Scene, SceneFormat, parse};
use std::path::{Path, PathBuf};

/// A scratch folder removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!("isokit-scene-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Self(p)
    }
    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn json(text: &str) -> Scene {
    Scene::from_text(text, SceneFormat::Json, "t.json", Path::new(".")).unwrap()
}

fn json_err(text: &str, dir: &Path) -> String {
    Scene::from_text(text, SceneFormat::Json, "t.json", dir)
        .unwrap_err()
        .to_string()
}

fn random_points(n: usize, half: f32, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    (0..n)
        .map(|_| r.point_in(Vec3::splat(-half), Vec3::splat(half)))
        .collect()
}

const CSG_JSON: &str = r#"{
  "shape": {"union": [
    {"difference": [
      {"sphere": {"radius": 1.0}},
      {"box": {"half": [0.6, 0.6, 0.6], "center": [0.7, 0.7, 0.7]}},
      {"cylinder": {"a": [0, 0, -2], "b": [0, 0, 2], "radius": 0.3}}
    ]},
    {"smooth_union": {"radius": 0.2, "of": [
      {"torus": {"major": 0.8, "minor": 0.15, "center": [0, 0, -1.2]}},
      {"capsule": {"a": [-1.5, 0, -1.2], "b": [1.5, 0, -1.2], "radius": 0.1}}
    ]}},
    {"transform": {"translate": [2.0, 0, 0], "rotate": {"axis": [0, 1, 0], "degrees": 30},
                   "scale": 0.5, "of": {"offset": {"by": 0.1, "of": {"box": {"half": [1, 0.5, 0.5]}}}}}},
    {"morph": {"t": 0.3, "from": {"sphere": {"radius": 0.4, "center": [-2, 0, 0]}},
               "to": {"ellipsoid": {"radii": [0.5, 0.3, 0.2], "center": [-2, 0, 0]}}}},
    {"shell": {"thickness": 0.05, "of": {"sphere": {"radius": 0.5, "center": [0, 2, 0]}}}}
  ]},
  "camera": {"eye": [0, 0, 6], "fov": 40},
  "lights": [{"direction": [-1, -1, -1]}],
  "sampling": {"resolution": 128, "band": 0.1}
}"#;

const CSG_TOML: &str = r#"
[camera]
eye = [0, 0, 6]
fov = 40

[[lights]]
direction = [-1, -1, -1]

[sampling]
resolution = 128
band = 0.1

[shape]
union = [
  { difference = [
      { sphere = { radius = 1.0 } },
      { box = { half = [0.6, 0.6, 0.6], center = [0.7, 0.7, 0.7] } },
      { cylinder = { a = [0, 0, -2], b = [0, 0, 2], radius = 0.3 } },
  ] },
  { smooth_union = { radius = 0.2, of = [
      { torus = { major = 0.8, minor = 0.15, center = [0, 0, -1.2] } },
      { capsule = { a = [-1.5, 0, -1.2], b = [1.5, 0, -1.2], radius = 0.1 } },
  ] } },
  { transform = { translate = [2.0, 0, 0], rotate = { axis = [0, 1, 0], degrees = 30 },
                  scale = 0.5, of = { offset = { by = 0.1, of = { box = { half = [1, 0.5, 0.5] } } } } } },
  { morph = { t = 0.3, from = { sphere = { radius = 0.4, center = [-2, 0, 0] } },
              to = { ellipsoid = { radii = [0.5, 0.3, 0.2], center = [-2, 0, 0] } } } },
  { shell = { thickness = 0.05, of = { sphere = { radius = 0.5, center = [0, 2, 0] } } } },
]
"#;

#[test]
fn json_and_toml_read_the_same_scene() {
    let a = parse(CSG_JSON, SceneFormat::Json, "a.json").unwrap();
    let b = parse(CSG_TOML, SceneFormat::Toml, "a.toml").unwrap();
    assert_eq!(a, b);
    assert_eq!(a.camera.as_ref().unwrap().fov, 40.0);
    assert_eq!(a.lights.len(), 1);
}

#[test]
fn scene_values_follow_the_corrected_csg_operators() {
    // Sphere minus box: max(f_sphere, -f_box) (ERRATA 1), checked against the primitives.
    let s = json(
        r#"{"shape": {"difference": [{"sphere": {"radius": 1}},
            {"box": {"half": [0.5, 0.5, 0.5], "center": [1, 0, 0]}}]}}"#,
    );
    let sphere = |p: Vec3| p.length() - 1.0;
    let cuboid = |p: Vec3| {
        let q = (p - Vec3::X).abs() - Vec3::splat(0.5);
        q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
    };
    for p in random_points(2000, 2.0, 1) {
        let want = sphere(p).max(-cuboid(p));
        assert!(
            (s.value(p) - want).abs() < 1e-5,
            "{p}: {} vs {want}",
            s.value(p)
        );
    }
}

#[test]
fn pruned_evaluation_equals_full_evaluation_within_the_cap() {
    let s = json(CSG_JSON);
    for cap in [0.05f32, 0.15, 0.5] {
        for p in random_points(4000, 3.0, 7) {
            let full = s.value(p).clamp(-cap, cap);
            let pruned = s.value_clamped(p, cap);
            assert!(
                (full - pruned).abs() <= 1e-6 * (1.0 + cap),
                "cap {cap} at {p}: full {full} pruned {pruned}"
            );
        }
    }
}

#[test]
fn lazy_sampling_matches_dense_in_the_band_and_computes_a_fraction() {
    for (name, text, most) in [
        ("csg", CSG_JSON, 0.35),
        (
            "sphere",
            r#"{"shape": {"sphere": {"radius": 1}}, "sampling": {"resolution": 128}}"#,
            0.4,
        ),
    ] {
        let s = json(text);
        let opts = SampleOptions::from_scene(&s);
        let (lazy, ls) = s.sample(&opts).unwrap();
        let (dense, ds) = s.sample_dense(&opts).unwrap();
        assert_eq!(ls.dims, ds.dims);
        let band = ls.band;
        let mut in_band = 0;
        for ([i, j, k], v) in dense.iter() {
            let w = lazy.get(i, j, k);
            if v.abs() < band {
                in_band += 1;
                assert!(
                    (w - v).abs() <= 1e-5,
                    "{name} ({i},{j},{k}): lazy {w} dense {v}"
                );
            } else {
                assert!(
                    w.abs() >= band * 0.999 && (w > 0.0) == (v > 0.0),
                    "{name}: {w} vs {v}"
                );
            }
        }
        assert!(in_band > 100);
        let dense_queries: u64 = ds.sources.iter().map(|s| s.queries).sum();
        let lazy_queries: u64 = ls.sources.iter().map(|s| s.queries).sum();
        println!(
            "{name}: dims {:?}, dense_fraction {:.4}, bricks {}/{}, source queries lazy {} dense {}",
            ls.dims,
            ls.dense_fraction,
            ls.bricks_kept,
            ls.bricks_total,
            lazy_queries,
            dense_queries
        );
        assert!(ls.dense_fraction < most, "{name}: {}", ls.dense_fraction);
        assert!(lazy_queries * 2 < dense_queries);
    }
}

#[test]
fn a_mesh_is_queried_only_near_its_box() {
    let dir = Scratch::new("mesh");
    let ico = isokit_io::generate::icosphere(Vec3::ZERO, 0.5, 3);
    isokit_io::write_mesh(&dir.0.join("ball.obj"), &ico).unwrap();
    let text = r#"{"shape": {"union": [
        {"sphere": {"radius": 0.3, "center": [-2, -2, -2]}},
        {"transform": {"translate": [2, 2, 2], "of": {"mesh": {"path": "ball.obj"}}}}
    ]}}"#;
    let s = Scene::from_text(text, SceneFormat::Json, "m.json", &dir.0).unwrap();
    let opts = SampleOptions {
        resolution: 128,
        ..Default::default()
    };
    let (lazy, st) = s.sample(&opts).unwrap();
    let mesh = st.sources.iter().find(|s| s.kind == "mesh").unwrap();
    let ball = st.sources.iter().find(|s| s.kind == "sphere").unwrap();
    println!(
        "dense_fraction {:.4}: mesh queries {} sphere queries {} of {} dense samples",
        st.dense_fraction, mesh.queries, ball.queries, st.dense_samples
    );
    assert!(mesh.query_fraction < 0.05, "{}", mesh.query_fraction);
    // The ball is there: its far pole reads zero.
    let (d, _) = s.sample_dense(&opts).unwrap();
    let mut worst = 0.0f32;
    for ([i, j, k], v) in d.iter() {
        if v.abs() < st.band {
            worst = worst.max((lazy.get(i, j, k) - v).abs());
        }
    }
    assert!(worst < 1e-5, "{worst}");
    assert!(s.value(Vec3::new(2.5, 2.0, 2.0)).abs() < 0.01);
}

#[test]
fn malformed_scenes_name_the_file_the_node_and_the_problem() {
    let dir = Scratch::new("errors");
    let d = &dir.0;
    let cases: [(&str, &[&str]); 12] = [
        (
            r#"{"shape": {"union": [{"sphere": {"radius": 1}}, {"sphre": {"radius": 1}}]}}"#,
            &["t.json", "shape.union[1]", "unknown variant `sphre`"],
        ),
        (
            r#"{"shape": {"difference": [{"sphere": {"radius": 1}}]}}"#,
            &["shape.difference", "at least 2 shapes, got 1"],
        ),
        (
            r#"{"shape": {"union": []}}"#,
            &["shape.union", "at least 1 shape"],
        ),
        (
            r#"{"shape": {"sphere": {"radius": -1}}}"#,
            &["shape.sphere", "radius"],
        ),
        (
            r#"{"shape": {"sphere": {"radius": 1, "centre": [0, 0, 0]}}}"#,
            &["shape.sphere", "unknown field `centre`"],
        ),
        (
            r#"{"shape": {"mesh": {"path": "missing.obj"}}}"#,
            &["shape.mesh", "no such file", "missing.obj"],
        ),
        (
            // A control character in a referenced name is shown escaped: one line.
            r#"{"shape": {"mesh": {"path": "new\nline.obj"}}}"#,
            &["shape.mesh", "no such file", r"new\nline.obj"],
        ),
        (
            // And in a key that is unknown.
            r#"{"shape": {"sph\nere": {"radius": 1}}}"#,
            &["shape", "unknown variant", r"sph\nere"],
        ),
        (
            r#"{"shape": {"sphere": {"radius": "big"}}}"#,
            &["shape.sphere.radius", "invalid type"],
        ),
        (
            r#"{"shape": {"sphere": {"radius": 1}"#,
            &["t.json", "invalid JSON"],
        ),
        (
            r#"{"camera": {"eye": [0, 0, 1]}}"#,
            &["missing field `shape`"],
        ),
        (
            r#"{"shape": {"transform": {"scale": 0, "of": {"sphere": {"radius": 1}}}}}"#,
            &["shape.transform.scale", "uniform"],
        ),
    ];
    for (text, want) in cases {
        let e = json_err(text, d);
        for w in want {
            assert!(e.contains(w), "error {e:?} lacks {w:?}");
        }
        assert!(!e.contains('\n'), "error {e:?} spans lines");
    }
    // Unbounded shapes need sampling bounds.
    let plane = json(r#"{"shape": {"plane": {"normal": [0, 0, 1]}}}"#);
    let e = plane
        .sample(&SampleOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unbounded") && e.contains("sampling.bounds"),
        "{e}"
    );
    // Absurd resolutions are refused before allocating.
    let s = json(r#"{"shape": {"sphere": {"radius": 1}}}"#);
    let e = s
        .sample(&SampleOptions {
            resolution: 1 << 28,
            ..Default::default()
        })
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("too large") || e.contains("not supported"),
        "{e}"
    );
}

#[test]
fn include_cycles_and_nested_errors_are_reported() {
    let dir = Scratch::new("include");
    dir.write(
        "a.json",
        r#"{"shape": {"union": [{"sphere": {"radius": 1}}, {"include": {"path": "b.toml"}}]}}"#,
    );
    dir.write("b.toml", "[shape.include]\npath = \"a.json\"\n");
    let e = Scene::load(&dir.0.join("a.json")).unwrap_err().to_string();
    assert!(
        e.contains("include cycle") && e.contains("a.json") && e.contains("b.toml"),
        "{e}"
    );
    // A working include, and an error inside the included file names that file.
    dir.write(
        "part.toml",
        "[shape.sphere]\nradius = 0.5\ncenter = [1, 0, 0]\n",
    );
    dir.write("bad.toml", "[shape.sphere]\nradius = 0.5\nfoo = 1\n");
    let s = Scene::load(&dir.write(
        "ok.json",
        r#"{"shape": {"union": [{"sphere": {"radius": 0.5}}, {"include": {"path": "part.toml"}}]}}"#,
    ))
    .unwrap();
    assert!(s.value(Vec3::new(1.0, 0.0, 0.0)) < -0.49);
    assert_eq!(s.sources().len(), 2);
    let e = Scene::load(&dir.write("c.json", r#"{"shape": {"include": {"path": "bad.toml"}}}"#))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.toml") && e.contains("unknown field `foo`"),
        "{e}"
    );
    // Unknown extension, missing scene file.
    let e = Scene::load(&dir.write("x.yaml", "shape: 1"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("expected .json or .toml"), "{e}");
    let e = Scene::load(&dir.0.join("nope.json"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("nope.json") && e.contains("cannot read"), "{e}");
}

#[test]
fn scenes_built_in_code_equal_scene_files() {
    use isokit_scene::{Node, SceneFile};
    let code = Node::difference(vec![
        Node::sphere(1.0, [0.0; 3]),
        Node::cuboid([0.5; 3], [0.0; 3])
            .rotated([0.0, 0.0, 1.0], 45.0)
            .translated([1.0, 0.0, 0.0]),
    ]);
    let text = r#"{"shape": {"difference": [{"sphere": {"radius": 1}},
        {"transform": {"translate": [1, 0, 0], "of":
            {"transform": {"rotate": {"axis": [0, 0, 1], "degrees": 45}, "of":
                {"box": {"half": [0.5, 0.5, 0.5]}}}}}}]}}"#;
    assert_eq!(parse(text, SceneFormat::Json, "t").unwrap().shape, code);
    let a = Scene::from_file(SceneFile::new(code), Path::new(".")).unwrap();
    let b = json(text);
    for p in random_points(500, 2.0, 3) {
        assert_eq!(a.value(p), b.value(p));
    }
}

#[test]
fn volume_and_point_cloud_sources() {
    let dir = Scratch::new("sources");
    // A sampled ball of radius 0.6 as a NRRD volume, and the same ball as a density
    // (inside above the isovalue).
    let ball = isokit_field::primitives::Sphere::new(Vec3::ZERO, 0.6).unwrap();
    let grid = isokit_field::sample_field(&ball, 48, 0.3).unwrap();
    isokit_io::write_volume(&dir.0.join("ball.nrrd"), &grid.clone().into()).unwrap();
    let mut density = grid.clone();
    density.data_mut().iter_mut().for_each(|v| *v = 10.0 - *v);
    isokit_io::write_volume(&dir.0.join("density.nrrd"), &density.into()).unwrap();
    for (file, extra) in [
        ("ball.nrrd", ""),
        ("density.nrrd", r#", "iso": 10, "inside": "above""#),
    ] {
        let text = format!(r#"{{"shape": {{"volume": {{"path": "{file}"{extra}}}}}}}"#);
        let s = Scene::from_text(&text, SceneFormat::Json, "v.json", &dir.0).unwrap();
        // Near the surface (away from the kink at the centre) trilinear reconstruction is
        // within about h²/(4r) of the exact distance (h = 0.038, r ≥ 0.45).
        for p in random_points(2000, 0.8, 5) {
            if ball.value(p).abs() < 0.15 {
                let d = (s.value(p) - ball.value(p)).abs();
                assert!(d < 1.5e-3, "{file} at {p}: {d}");
            }
        }
        // Beyond the volume the value grows with the distance to its box.
        let far = Vec3::new(5.0, 0.0, 0.0);
        assert!(s.value(far) > 3.0, "{file}: {}", s.value(far));
        let (band, st) = s
            .sample(&SampleOptions {
                resolution: 64,
                ..Default::default()
            })
            .unwrap();
        assert!(band.brick_count() > 0 && st.dense_fraction < 1.0);
    }
    // The shipped torus cloud (R = 1, r = 0.35) as a partition-of-unity field.
    let cloud = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let s = Scene::from_text(
        r#"{"shape": {"difference": [{"points": {"path": "torus_cloud.ply"}},
            {"sphere": {"radius": 0.3, "center": [1, 0, 0]}}]}}"#,
        SceneFormat::Json,
        "p.json",
        &cloud,
    )
    .unwrap();
    let torus =
        |p: Vec3| Vec3::new(Vec3::new(p.x, p.y, 0.0).length() - 1.0, p.z, 0.0).length() - 0.35;
    for p in random_points(300, 1.5, 9) {
        if p.distance(Vec3::X) > 0.5 && torus(p).abs() < 0.1 {
            assert!(
                (s.value(p) - torus(p)).abs() < 0.03,
                "{p}: {} vs {}",
                s.value(p),
                torus(p)
            );
        }
    }
    // The sphere bites into the tube: its centre is outside the difference.
    assert!(s.value(Vec3::X) > 0.2);
    // A bad parameter names the node.
    let e = Scene::from_text(
        r#"{"shape": {"points": {"path": "torus_cloud.ply", "normals": "guess"}}}"#,
        SceneFormat::Json,
        "p.json",
        &cloud,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("shape.points.normals") && e.contains("guess"),
        "{e}"
    );
}

#[test]
fn random_trees_prune_exactly_and_sample_lazily_as_densely() {
    let dir = Scratch::new("random");
    // Extra leaves whose bounds and slopes are not those of exact distances: a volume of 100×
    // a ball's distance (Lipschitz 100), the shipped torus cloud, an open mesh signed by
    // pseudonormals.
    let ball = isokit_field::primitives::Sphere::new(Vec3::ZERO, 0.4).unwrap();
    let mut g = isokit_field::sample_field(&ball, 24, 0.2).unwrap();
    g.data_mut().iter_mut().for_each(|v| *v *= 100.0);
    isokit_io::write_volume(&dir.0.join("steep.nrrd"), &g.into()).unwrap();
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    for f in ["torus_cloud.ply", "open_cube.obj"] {
        std::fs::copy(data.join(f), dir.0.join(f)).unwrap();
    }
    let extra = [
        r#"{"volume": {"path": "steep.nrrd"}}"#,
        r#"{"transform": {"scale": 0.5, "of": {"points": {"path": "torus_cloud.ply"}}}}"#,
        r#"{"mesh": {"path": "open_cube.obj", "sign": "pseudonormal"}}"#,
    ];
    let mut r = SplitMix64::new(2026);
    for case in 0..24 {
        let leaves: &[&str] = if case % 3 == 0 { &extra } else { &[] };
        let tree = random_tree(&mut r, 3, leaves);
        let text = format!(
            r#"{{"shape": {tree}, "sampling": {{"bounds": [[-1.5, -1.5, -1.5], [1.5, 1.5, 1.5]], "resolution": 40, "band": 0.15}}}}"#
        );
        let s = Scene::from_text(&text, SceneFormat::Json, "r.json", &dir.0)
            .unwrap_or_else(|e| panic!("case {case}: {e}\n{text}"));
        // Pruned evaluation equals the full one, clamped.
        for cap in [0.05f32, 0.3] {
            for p in random_points(300, 1.6, case) {
                let full = s.value(p).clamp(-cap, cap);
                let pruned = s.value_clamped(p, cap);
                assert!(
                    (full - pruned).abs() <= 2e-5 * (1.0 + full.abs()),
                    "case {case} cap {cap} at {p}: full {full} pruned {pruned}\n{text}"
                );
            }
        }
        // Bounds hold every point where the value is at most δ, grown by δ.
        let b = s.bounds();
        for p in random_points(300, 1.6, case + 100) {
            let v = s.value(p);
            if v <= 0.0 {
                assert!(
                    b.contains(p),
                    "case {case}: {p} ({v}) outside {b:?}\n{text}"
                );
            }
        }
        // Lazy sampling equals dense sampling in the band, with the dense signs elsewhere.
        let opts = SampleOptions::from_scene(&s);
        let (lazy, ls) = s.sample(&opts).unwrap();
        let (dense, _) = s.sample_dense(&opts).unwrap();
        for ([i, j, k], v) in dense.iter() {
            let w = lazy.get(i, j, k);
            if v.abs() < ls.band {
                assert!(
                    (w - v).abs() <= 2e-5 * (1.0 + v.abs()),
                    "case {case} ({i},{j},{k}): lazy {w} dense {v}\n{text}"
                );
            } else if v.abs() > ls.band * 1.001 {
                assert_eq!(
                    w > 0.0,
                    v > 0.0,
                    "case {case} ({i},{j},{k}): lazy {w} dense {v}\n{text}"
                );
            }
        }
    }
}

#[test]
fn review_cases_blends_morph_endpoints_and_limits() {
    // Three equal spheres blended with a large radius: the fold lowers the value by up to
    // 2·k/4, and the bounds must hold the bulge (surface at r = 2.5625 on the axis).
    let s = json(
        r#"{"shape": {"smooth_union": {"radius": 4, "of": [
            {"sphere": {"radius": 1}}, {"sphere": {"radius": 1}}, {"sphere": {"radius": 1}}]}}}"#,
    );
    let on_axis = Vec3::new(2.5625, 0.0, 0.0);
    assert!(s.value(on_axis).abs() < 1e-4, "{}", s.value(on_axis));
    assert!(s.bounds().contains(on_axis));
    // A morph at t = 0 inside a union is not pruned away (0 · −∞ in its bound).
    let s = json(
        r#"{"shape": {"union": [
            {"morph": {"t": 0, "from": {"sphere": {"radius": 0.5}}, "to": {"sphere": {"radius": 0.7}}}},
            {"sphere": {"radius": 0.5, "center": [5, 0, 0]}}]}}"#,
    );
    assert_eq!(s.value_clamped(Vec3::ZERO, 0.1), -0.1);
    // Include chains that double at every level are refused, not expanded.
    let dir = Scratch::new("limits");
    dir.write("l0.json", r#"{"shape": {"sphere": {"radius": 1}}}"#);
    for i in 1..24 {
        dir.write(
            &format!("l{i}.json"),
            &format!(
                r#"{{"shape": {{"union": [{{"include": {{"path": "l{0}.json"}}}}, {{"include": {{"path": "l{0}.json"}}}}]}}}}"#,
                i - 1
            ),
        );
    }
    let e = Scene::load(&dir.0.join("l23.json"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("more than 100000 nodes"), "{e}");
    // Deep nesting across includes is refused before the stack runs out.
    let deep = format!(
        r#"{{"shape": {}{{"sphere": {{"radius": 1}}}}{}}}"#,
        r#"{"complement": "#.repeat(100),
        "}".repeat(100)
    );
    for i in 0..4 {
        let next = if i == 3 {
            String::new()
        } else {
            format!("d{}.json", i + 1)
        };
        let text = if next.is_empty() {
            deep.clone()
        } else {
            deep.replace(
                r#"{"sphere": {"radius": 1}}"#,
                &format!(r#"{{"include": {{"path": "{next}"}}}}"#),
            )
        };
        dir.write(&format!("d{i}.json"), &text);
    }
    let e = Scene::load(&dir.0.join("d0.json")).unwrap_err().to_string();
    assert!(e.contains("nested more than 256 levels"), "{e}");
    // TOML nan, a directory as a path, a domain without extent.
    let e = Scene::load(&dir.write("n.toml", "[shape.sphere]\nradius = nan\n"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("shape.sphere.radius") && e.contains("finite"),
        "{e}"
    );
    std::fs::create_dir_all(dir.0.join("sub.obj")).unwrap();
    let e = json_err(r#"{"shape": {"mesh": {"path": "sub.obj"}}}"#, &dir.0);
    assert!(e.contains("is a directory"), "{e}");
    let s = json(
        r#"{"shape": {"sphere": {"radius": 1}}, "sampling": {"bounds": [[0, 0, 0], [0, 0, 0]]}}"#,
    );
    let e = s
        .sample(&SampleOptions::from_scene(&s))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no extent"), "{e}");
}
