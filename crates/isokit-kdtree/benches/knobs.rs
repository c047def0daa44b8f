//! The kd-tree's knobs, swept: leaf size × maximum sibling overlap, on a generated trefoil
//! tube (6144 triangles) and an icosphere (20480), 100k query points (half near the
//! surface, half uniform in the padded bounds). Prints build time, queries per second,
//! nodes visited and triangles tested per query; `max_overlap = 0` is the classic tree.
//!
//! Run: `cargo bench -p isokit-kdtree --bench knobs`. A plain harness (no criterion) keeps
//! the dependency tree lean; each cell is the best of three runs.

use glam::{DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_io::{TriMesh, generate};
use isokit_kdtree::{BuildParams, MeshOptions, MeshSdf, QueryStats, SignMode};
use rayon::prelude::*;
use std::time::Instant;

fn points(mesh: &TriMesh, n: usize) -> Vec<DVec3> {
    let mut r = SplitMix64::new(7);
    let b = mesh.bounds();
    let d = b.diagonal();
    (0..n)
        .map(|i| {
            if i % 2 == 0 {
                let t = mesh.triangles[r.below(mesh.triangles.len())];
                let v = mesh.positions[t[0] as usize];
                (v + r.unit_vector() * (0.05 * d * r.next_f32())).as_dvec3()
            } else {
                r.point_in(b.min - 0.1 * b.size(), b.max + 0.1 * b.size())
                    .as_dvec3()
            }
        })
        .collect()
}

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
        let pts = points(mesh, 100_000);
        for leaf in [2, 4, 8, 16] {
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
