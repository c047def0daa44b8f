//! The scene layer's own features: sources from memory, content hashes and dependencies,
//! the format version, round trips through JSON, the JSON Schema shipped in `docs/`, large
//! unions, prism bands and octree nodes.

use glam::Vec3;
use isokit_field::{Field, Grid, generate};
use isokit_scene::{
    BandMethod, Node, SampleOptions, Scene, SceneFile, SceneFormat, SignMode, json_schema, parse,
};
use std::path::{Path, PathBuf};

/// A scratch folder removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!("isokit-nodes-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Self(p)
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

fn json_err(text: &str) -> String {
    Scene::from_text(text, SceneFormat::Json, "t.json", Path::new("."))
        .unwrap_err()
        .to_string()
}

/// A mesh held in memory gives the same field as the same mesh read from a file; a grid in
/// memory the same as the file; any field can be a node.
#[test]
fn sources_from_memory_equal_sources_from_files() {
    let dir = Scratch::new("memory");
    let torus = generate::torus(0.8, 0.3, 48, 24);
    isokit_io::write_mesh(&dir.0.join("t.off"), &torus).unwrap();
    let from_file = Scene::from_file(SceneFile::new(Node::mesh("t.off")), &dir.0).unwrap();
    let in_memory = Scene::from_node(Node::mesh_data(torus.clone(), SignMode::Auto)).unwrap();
    let mut r = isokit_field::rng::SplitMix64::new(4);
    for _ in 0..200 {
        let p = r.point_in(Vec3::splat(-1.5), Vec3::splat(1.5));
        assert_eq!(from_file.value(p), in_memory.value(p), "at {p}");
    }
    assert_eq!(in_memory.sources()[0].kind, "mesh");
    assert_eq!(
        in_memory.sources()[0].triangles,
        Some(torus.triangles.len())
    );
    // A grid in memory and the same grid from a file.
    let mut g = Grid::new([24; 3], Vec3::splat(-1.2), 2.4 / 23.0).unwrap();
    isokit_field::sample_into(&from_file, &mut g);
    isokit_io::write_volume(&dir.0.join("t.nrrd"), &g.clone().into()).unwrap();
    let vf = Scene::from_file(SceneFile::new(Node::volume("t.nrrd")), &dir.0).unwrap();
    let vm = Scene::from_node(Node::grid(g, 0.0)).unwrap();
    for _ in 0..200 {
        let p = r.point_in(Vec3::splat(-1.5), Vec3::splat(1.5));
        assert_eq!(vf.value(p), vm.value(p), "at {p}");
    }
    // Any field.
    let ball = std::sync::Arc::new(isokit_field::primitives::Sphere::new(Vec3::ZERO, 0.5).unwrap());
    let f = Scene::from_node(Node::difference(vec![
        Node::sphere(1.0, [0.0; 3]),
        Node::field("ball", ball),
    ]))
    .unwrap();
    assert!((f.value(Vec3::ZERO) - 0.5).abs() < 1e-6);
    // A scene holding memory cannot become a scene file; the error names the node.
    let e = SceneFile::new(Node::union(vec![
        Node::sphere(1.0, [0.0; 3]),
        Node::mesh_data(torus, SignMode::Auto),
    ]))
    .to_json()
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("shape.union[1].mesh") && e.contains("memory"),
        "{e}"
    );
}

/// Content hashes change where an edit changed something and nowhere else; saving a
/// referenced file changes the hash of the nodes that read it; the dependencies list every
/// file read.
#[test]
fn content_hashes_follow_edits_and_files() {
    let dir = Scratch::new("hashes");
    let ico = generate::icosphere(Vec3::ZERO, 0.5, 2);
    isokit_io::write_mesh(&dir.0.join("m.obj"), &ico).unwrap();
    std::fs::write(
        dir.0.join("inc.json"),
        r#"{"shape": {"torus": {"major": 0.6, "minor": 0.1}}}"#,
    )
    .unwrap();
    let text = |r: f32| {
        format!(
            r#"{{"shape": {{"union": [{{"sphere": {{"radius": {r}, "center": [2, 0, 0]}}}},
                {{"mesh": {{"path": "m.obj"}}}}, {{"include": {{"path": "inc.json"}}}}]}}}}"#
        )
    };
    std::fs::write(dir.0.join("s.json"), text(0.5)).unwrap();
    let a = Scene::load(&dir.0.join("s.json")).unwrap();
    let deps: Vec<String> = a
        .dependencies()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(deps, ["s.json", "m.obj", "inc.json"]);
    let nodes: Vec<&str> = a.hashes().iter().map(|h| h.node.as_str()).collect();
    assert_eq!(nodes[0], "shape.union");
    assert!(nodes.contains(&"shape.union[1].mesh"), "{nodes:?}");
    // The same text gives the same hashes.
    let again = Scene::load(&dir.0.join("s.json")).unwrap();
    assert_eq!(a.hashes(), again.hashes());
    // An edit of the sphere's radius changes the root and the sphere only.
    std::fs::write(dir.0.join("s.json"), text(0.6)).unwrap();
    let b = Scene::load(&dir.0.join("s.json")).unwrap();
    let changed: Vec<&str> = a
        .hashes()
        .iter()
        .zip(b.hashes())
        .filter(|(x, y)| x.hash != y.hash)
        .map(|(x, _)| x.node.as_str())
        .collect();
    assert_eq!(changed, ["shape.union", "shape.union[0].sphere"]);
    // Saving the mesh file again (a new modification time and size) changes the mesh node.
    std::thread::sleep(std::time::Duration::from_millis(20));
    isokit_io::write_mesh(
        &dir.0.join("m.obj"),
        &generate::icosphere(Vec3::ZERO, 0.4, 2),
    )
    .unwrap();
    let c = Scene::load(&dir.0.join("s.json")).unwrap();
    let mesh_hash = |s: &Scene| {
        s.hashes()
            .iter()
            .find(|h| h.node == "shape.union[1].mesh")
            .unwrap()
            .hash
    };
    assert_ne!(mesh_hash(&b), mesh_hash(&c));
}

/// The scene format's version: 1 (or absent) is read, anything else refused with its path.
#[test]
fn the_version_key_is_checked() {
    json(r#"{"version": 1, "shape": {"sphere": {}}}"#);
    let e = json_err(r#"{"version": 2, "shape": {"sphere": {}}}"#);
    assert!(e.contains("version") && e.contains("not supported"), "{e}");
    // Primitives take the vocabulary's defaults: `{"sphere": {}}` is the unit sphere.
    let s = json(r#"{"shape": {"sphere": {}}}"#);
    assert!((s.value(Vec3::ZERO) + 1.0).abs() < 1e-6);
    // Options are enums: an unknown one lists the valid ones.
    let e = json_err(r#"{"shape": {"mesh": {"path": "x.obj", "sign": "both"}}}"#);
    assert!(
        e.contains("shape.mesh.sign") && e.contains("winding"),
        "{e}"
    );
}

/// Every shipped scene parses, writes back to JSON and reads again as the same scene.
#[test]
fn shipped_scenes_round_trip_through_json() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        let Some(format) = SceneFormat::from_path(&p) else {
            continue;
        };
        let text = std::fs::read_to_string(&p).unwrap();
        let a = parse(&text, format, &p.display().to_string()).unwrap();
        let back = a.to_json().unwrap();
        let b = parse(&back, SceneFormat::Json, "back.json").unwrap();
        assert_eq!(a, b, "{}", p.display());
        n += 1;
    }
    assert!(n >= 5, "{n} scenes");
}

/// `docs/scene.schema.json` is the schema generated from the types (regenerate with
/// `ISOKIT_BLESS=1 cargo test -p isokit-scene --test nodes`), and it describes the node
/// kinds and enums the library reads.
#[test]
fn the_shipped_json_schema_is_the_generated_one() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene.schema.json");
    let generated = serde_json::to_string_pretty(&json_schema()).unwrap() + "\n";
    if std::env::var("ISOKIT_BLESS").is_ok_and(|v| v == "1") {
        std::fs::write(&path, &generated).unwrap();
    }
    let shipped = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        shipped == generated,
        "docs/scene.schema.json is stale: run ISOKIT_BLESS=1 cargo test -p isokit-scene --test nodes"
    );
    // The node kinds of the schema (one `oneOf` entry per variant, its one required key)
    // are exactly `Node::KINDS`, the list `isokit scene --help` prints.
    let schema = json_schema();
    let mut kinds: Vec<String> = schema["$defs"]["Node"]["oneOf"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["required"][0].as_str().unwrap().to_owned())
        .collect();
    kinds.sort();
    let mut listed: Vec<String> = Node::KINDS.iter().map(|k| k.to_string()).collect();
    listed.sort();
    assert_eq!(kinds, listed);
    for word in [
        "pseudonormal",
        "prism_gpu",
        "catmull_rom",
        "curvature",
        "version",
    ] {
        assert!(generated.contains(word), "{word}");
    }
}

/// A union of 50,000 spheres evaluates through its hierarchy: the lazy band computes in
/// time proportional to the children near each sample (counted, not timed).
#[test]
fn a_union_of_fifty_thousand_spheres_is_evaluated_near_each_sample_only() {
    let mut r = isokit_field::rng::SplitMix64::new(9);
    let balls: Vec<Node> = (0..50_000)
        .map(|_| {
            let c = r.point_in(Vec3::splat(-10.0), Vec3::splat(10.0));
            Node::sphere(0.05, c.to_array())
        })
        .collect();
    let scene = Scene::from_node(Node::union(balls)).unwrap();
    let (band, stats) = scene
        .sample(&SampleOptions {
            resolution: 96,
            ..Default::default()
        })
        .unwrap();
    let queries: u64 = stats.sources.iter().map(|s| s.queries).sum();
    let evaluated = (stats.dense_fraction * stats.dense_samples as f64).max(1.0);
    let per_sample = queries as f64 / evaluated;
    println!(
        "50,000 spheres at 96: {} bricks kept, {:.1} children evaluated per sample",
        band.brick_count(),
        per_sample
    );
    assert!(
        per_sample < 20.0,
        "{per_sample} children per evaluated sample"
    );
}

/// A mesh with the prism method gives the kd-tree's band (to the prism's 1e-5 spacing
/// accuracy), also under a translation and a uniform scale; with a rotation it is read by
/// trilinear interpolation of the prism band (a documented approximation).
#[test]
fn prism_bands_equal_kdtree_bands() {
    let torus = generate::torus(0.8, 0.3, 48, 24);
    let mk = |method: BandMethod, wrap: &dyn Fn(Node) -> Node| {
        let node = match Node::mesh_data(torus.clone(), SignMode::Auto) {
            Node::Mesh(mut m) => {
                m.method = method;
                Node::Mesh(m)
            }
            _ => unreachable!(),
        };
        Scene::from_node(wrap(node)).unwrap()
    };
    let opts = SampleOptions {
        resolution: 48,
        ..Default::default()
    };
    for (name, wrap) in [
        ("plain", &(|n: Node| n) as &dyn Fn(Node) -> Node),
        ("moved and scaled", &|n: Node| {
            n.scaled(1.5).translated([0.3, -0.2, 0.1])
        }),
    ] {
        let kd = mk(BandMethod::Kdtree, wrap);
        let pr = mk(BandMethod::PrismCpu, wrap);
        let (a, sa) = kd.sample(&opts).unwrap();
        let (b, sb) = pr.sample(&opts).unwrap();
        assert_eq!(sb.prism_bands.len(), 1, "{name}");
        let (ga, gb) = (a.to_grid().unwrap(), b.to_grid().unwrap());
        let h = sa.spacing;
        let mut compared = 0;
        for (x, y) in ga.data().iter().zip(gb.data()) {
            if x.abs() < sa.band {
                compared += 1;
                assert!(
                    (x - y).abs() <= 1e-5 * h + 4.0 * f32::EPSILON * x.abs(),
                    "{name}: {x} vs {y}"
                );
            }
        }
        assert!(compared > 1000, "{name}: {compared}");
        assert_eq!(sa.bricks_kept, sb.bricks_kept, "{name}");
    }
}

/// An octree node stores its child adaptively: within the error bound near the surface, and
/// the child is queried only while the tree is built.
#[test]
fn an_octree_node_reconstructs_its_child() {
    let s = json(
        r#"{"shape": {"octree": {"max_level": 6, "error": 0.002,
            "of": {"torus": {"major": 0.7, "minor": 0.25}}}}}"#,
    );
    let exact = isokit_field::primitives::Torus::new(Vec3::ZERO, 0.7, 0.25).unwrap();
    let mut r = isokit_field::rng::SplitMix64::new(2);
    let mut worst = 0.0f32;
    for _ in 0..2000 {
        let p = r.point_in(Vec3::new(-1.0, -1.0, -0.3), Vec3::new(1.0, 1.0, 0.3));
        if exact.value(p).abs() < 0.02 {
            worst = worst.max((s.value(p) - exact.value(p)).abs());
        }
    }
    println!("octree level 6, error bound 0.002: worst {worst:.2e} near the surface");
    assert!(worst < 0.01, "{worst}");
    assert_eq!(s.sources().last().unwrap().kind, "octree");
}
