//! Sampling a block of the lattice (what a distributed sampling does per chunk): the block's
//! samples equal those of the whole sampling bit for bit once both are clamped to the band,
//! whether the block is aligned to the bricks or not, for analytic trees, a mesh and a cloud.

use isokit_field::Job;
use isokit_scene::{Block, SampleOptions, Scene, SceneFormat};
use std::path::Path;

fn scene(shape: &str) -> Scene {
    let text = format!(r#"{{"shape": {shape}}}"#);
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    Scene::from_text(&text, SceneFormat::Json, "blocks.json", &data).unwrap()
}

/// Samples the whole lattice and the given blocks; every block must equal the whole
/// sampling's samples there, bit for bit. Returns the number of samples compared.
fn blocks_equal_the_whole(s: &Scene, opts: &SampleOptions, blocks: &[Block]) -> usize {
    let job = Job::default();
    let (whole, _) = s.sample_grid_job(opts, &job).unwrap();
    let [nx, ny, _] = whole.dims();
    let mut compared = 0;
    for &b in blocks {
        let o = SampleOptions {
            block: Some(b),
            ..*opts
        };
        let (part, stats) = s.sample_grid_job(&o, &job).unwrap();
        assert_eq!(part.dims(), b.dims);
        assert_eq!(stats.dims, b.dims);
        for k in 0..b.dims[2] {
            for j in 0..b.dims[1] {
                for i in 0..b.dims[0] {
                    let w = whole.data()
                        [b.first[0] + i + nx * (b.first[1] + j + ny * (b.first[2] + k))];
                    let p = part.data()[i + b.dims[0] * (j + b.dims[1] * k)];
                    assert!(
                        w.to_bits() == p.to_bits(),
                        "block {b:?}: sample ({i}, {j}, {k}) is {p}, the whole sampling's {w}"
                    );
                    compared += 1;
                }
            }
        }
    }
    compared
}

/// Blocks tiling the lattice in `side`³ pieces, plus a few unaligned ones.
fn tiles(dims: [usize; 3], side: usize) -> Vec<Block> {
    let mut out = Vec::new();
    for z in (0..dims[2]).step_by(side) {
        for y in (0..dims[1]).step_by(side) {
            for x in (0..dims[0]).step_by(side) {
                let first = [x, y, z];
                out.push(Block {
                    first,
                    dims: std::array::from_fn(|a| side.min(dims[a] - first[a])),
                });
            }
        }
    }
    out.push(Block {
        first: [3, 5, 7],
        dims: [13, 9, 11],
    });
    out.push(Block {
        first: [1, 0, 2],
        dims: [dims[0] - 1, 6, 1],
    });
    out
}

#[test]
fn blocks_of_analytic_trees_equal_the_whole_sampling() {
    let s = scene(
        r#"{"smooth_union": {"radius": 0.2, "of": [
            {"difference": [{"box": {"half": [0.8, 0.5, 0.4]}}, {"sphere": {"radius": 0.45}}]},
            {"torus": {"major": 0.6, "minor": 0.15, "center": [0.5, 0.2, 0.3]}}]}}"#,
    );
    let opts = SampleOptions {
        resolution: 70,
        ..Default::default()
    };
    let dims = s.plan(&opts).unwrap().dims;
    let n = blocks_equal_the_whole(&s, &opts, &tiles(dims, 16));
    assert!(n > dims.iter().product::<usize>(), "{n} samples compared");
}

#[test]
fn blocks_of_a_mesh_and_a_cloud_equal_the_whole_sampling() {
    for shape in [
        r#"{"mesh": {"path": "torus.off"}}"#,
        r#"{"points": {"path": "torus_cloud.ply"}}"#,
    ] {
        let s = scene(shape);
        let opts = SampleOptions {
            resolution: 48,
            brick: 8,
            ..Default::default()
        };
        let dims = s.plan(&opts).unwrap().dims;
        blocks_equal_the_whole(&s, &opts, &tiles(dims, 24));
    }
}

#[test]
fn a_block_outside_the_lattice_or_a_dense_block_is_refused() {
    let s = scene(r#"{"sphere": {"radius": 0.5}}"#);
    let opts = SampleOptions {
        resolution: 20,
        ..Default::default()
    };
    let dims = s.plan(&opts).unwrap().dims;
    for b in [
        Block {
            first: [0, 0, 0],
            dims: [dims[0] + 1, 1, 1],
        },
        Block {
            first: [usize::MAX, 0, 0],
            dims: [2, 1, 1],
        },
        Block {
            first: [0, 0, 0],
            dims: [0, 1, 1],
        },
    ] {
        let o = SampleOptions {
            block: Some(b),
            ..opts
        };
        let e = s
            .sample_grid_job(&o, &Job::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("not inside the lattice"), "{e}");
    }
    let o = SampleOptions {
        block: Some(Block {
            first: [0, 0, 0],
            dims: [2, 2, 2],
        }),
        ..opts
    };
    assert!(s.sample_dense(&o).is_err());
}
