//! A modeling script: builds a CSG part in code, checks it against the same part written as
//! a scene file (`examples/scenes/part.json`), samples its narrow band lazily and writes a
//! watertight mesh.
//!
//! Run: `cargo run --release --example csg_scene [OUT.obj]` (default `part.obj`).

use anyhow::{Result, ensure};
use isokit::field::{Field, rng::SplitMix64};
use isokit::levelset::meshing::{MeshOptions, mesh_brick_grid};
use isokit::scene::{Node, SceneFile};
use isokit::scene::{SampleOptions, Scene};
use std::path::{Path, PathBuf};

/// The part: a rounded plate with a boss blended on by a smooth union, drilled through the
/// boss and at the four corners.
fn part() -> Node {
    let plate = Node::rounded_box([1.2, 0.2, 0.8], 0.05, [0.0; 3]);
    let boss = Node::cylinder([0.0, 0.0, 0.0], [0.0, 0.7, 0.0], 0.4);
    let mut cuts = vec![
        Node::smooth_union(0.15, vec![plate, boss]),
        Node::cylinder([0.0, -1.0, 0.0], [0.0, 1.0, 0.0], 0.2),
    ];
    for (x, z) in [(-0.8, 0.4), (0.8, 0.4), (-0.8, -0.4), (0.8, -0.4)] {
        cuts.push(Node::cylinder([x, -1.0, z], [x, 1.0, z], 0.12));
    }
    Node::difference(cuts)
}

fn main() -> Result<()> {
    let out = std::env::args()
        .nth(1)
        .map_or_else(|| PathBuf::from("part.obj"), PathBuf::from);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));

    let in_code = Scene::from_file(SceneFile::new(part()), root)?;
    let from_file = Scene::load(&root.join("examples/scenes/part.json"))?;
    // The two descriptions are the same tree: equal values everywhere.
    let mut rng = SplitMix64::new(1);
    let b = in_code.bounds().expanded(0.2);
    for _ in 0..10_000 {
        let p = rng.point_in(b.min, b.max);
        ensure!(
            in_code.value(p) == from_file.value(p),
            "the scenes differ at {p}"
        );
    }

    let opts = SampleOptions::from_scene(&from_file);
    let (band, stats) = in_code.sample(&opts)?;
    let mesh = mesh_brick_grid(&band, &MeshOptions::default())?;
    isokit::io::write_mesh(&out, &mesh)?;
    let report = mesh.validate();
    println!(
        "{:?} lattice: {:.1}% of the dense samples evaluated in {:.2} s; {} triangles, watertight {}, genus {:?} -> {}",
        stats.dims,
        100.0 * stats.dense_fraction,
        stats.seconds,
        mesh.triangles.len(),
        report.watertight,
        report.genus(),
        out.display()
    );
    Ok(())
}
