//! The kd-tree's knobs, swept: leaf size × maximum sibling overlap, on a generated trefoil
//! tube (6144 triangles) and an icosphere (20480), 100k query points (half near the
//! surface, half uniform in the padded bounds). Prints build time, queries per second,
//! nodes visited and triangles tested per query; `max_overlap = 0` is the classic tree.
//!
//! Run: `cargo bench -p isokit-kdtree --bench knobs`. A plain harness (no criterion) keeps
//! the dependency tree lean; each cell is the best of three runs.

use glam::{DVec3, Vec3};
use isokit_field::generate;
use isokit_kdtree::{BuildParams, MeshOptions, MeshSdf, QueryStats, SignMode};
use rayon::prelude::*;
use std::time::Instant;

fn main() {
    let meshes = [
        (
            "trefoil",
            generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 192, 16),
        ),
        ("icosphere", generate::icosphere(Vec3::ZERO, 1.0, 5)),
    ];
    println!(
        "| mesh | leaf | max_overlap | build ms | queries/s | nodes/query | triangles/query |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for (name, mesh) in &meshes {
        let pts: Vec<DVec3> = generate::query_points(mesh, 100_000, 0.05, 7)
            .into_iter()
            .map(|p| p.as_dvec3())
            .collect();
        for leaf in [2, 4, 8, 16, 32, 64] {
            for overlap in [0.0, 0.05, 0.1, 0.3, 1.0] {
                let tree = BuildParams {
                    leaf_size: leaf,
                    max_overlap: overlap,
                    ..Default::default()
                };
                let opts = MeshOptions {
                    tree,
                    sign: SignMode::Unsigned,
                    ..Default::default()
                };
                let mut best = (f64::INFINITY, f64::INFINITY, QueryStats::default());
                for _ in 0..3 {
                    let t = Instant::now();
                    let sdf = MeshSdf::new(mesh, opts).unwrap();
                    let build = t.elapsed().as_secs_f64();
                    let t = Instant::now();
                    let st = pts
                        .par_chunks(1024)
                        .map(|c| {
                            let mut st = QueryStats::default();
                            let mut hint = None;
                            for &p in c {
                                hint = sdf.query_near(p, hint, &mut st).map(|h| h.triangle);
                            }
                            st
                        })
                        .reduce(QueryStats::default, |mut a, b| {
                            a += b;
                            a
                        });
                    let q = t.elapsed().as_secs_f64();
                    if q < best.1 {
                        best = (build, q, st);
                    }
                }
                let n = pts.len() as f64;
                println!(
                    "| {name} | {leaf} | {overlap} | {:.1} | {:.0} | {:.1} | {:.1} |",
                    1e3 * best.0,
                    n / best.1,
                    best.2.nodes_visited as f64 / n,
                    best.2.prims_tested as f64 / n
                );
            }
        }
    }
}
