//! `isokit bench …`: in-process comparisons users can run on their own machine.

use anyhow::{Context, Result, bail};
use glam::DVec3;
use isokit_io::{TriMesh, generate, read_mesh};
use isokit_kdtree::tree::TreeStats;
use isokit_kdtree::{BuildParams, MeshOptions, MeshSdf, QueryStats, SignMode};
use rayon::prelude::*;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// The comparisons.
#[derive(clap::Subcommand, Debug)]
pub enum Bench {
    /// The kd-tree with overlapping siblings against the classic kd-tree (same leaf size,
    /// same mesh, same points): build time, queries per second, nodes visited and triangles
    /// tested per query, and a check that both give identical distances.
    Kdtree(KdtreeArgs),
    /// The hashed octree against the linked octree (002 Table 3.1): time for random cell
    /// accesses near the surface of a sphere and of a trefoil tube, levels 5 to 10, and
    /// bytes per cell of both.
    Octree(super::octree::BenchArgs),
    /// Warm frames of the CPU ray caster at 512² on a sphere sampled at 256³, the trefoil
    /// band and a CT-like density (sum of Gaussians): frame time, samples per ray, and the
    /// hit mask and depths against the fixed-rate reference at 8 samples per voxel.
    Render(super::bench_render::RenderBenchArgs),
}

/// Arguments of `isokit bench kdtree`.
#[derive(clap::Args, Debug)]
pub struct KdtreeArgs {
    /// Mesh to measure [default: a generated trefoil tube of 6144 triangles].
    pub mesh: Option<PathBuf>,
    /// Query points: half within 5% of the diagonal of the surface, half uniform in the
    /// bounds padded by 10%.
    #[arg(long, default_value_t = 200_000)]
    pub points: usize,
    /// Leaf size of both trees.
    #[arg(long, default_value_t = BuildParams::default().leaf_size, value_parser = super::mesh_args::leaf_size)]
    pub leaf_size: usize,
    /// Sibling overlap of the overlapping tree (fraction of a node's extent).
    #[arg(long, default_value_t = BuildParams::default().max_overlap, value_parser = super::mesh_args::max_overlap, allow_negative_numbers = true)]
    pub max_overlap: f32,
    /// Seed of the query points.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs a comparison.
pub fn run(b: Bench) -> Result<()> {
    match b {
        Bench::Kdtree(a) => kdtree(a),
        Bench::Octree(a) => super::octree::bench(a),
        Bench::Render(a) => super::bench_render::bench(a),
    }
}

struct Run {
    build: f64,
    query: f64,
    stats: QueryStats,
    tree: TreeStats,
    distances: Vec<f64>,
}

fn measure(mesh: &TriMesh, tree: BuildParams, points: &[DVec3]) -> Result<Run> {
    let opts = MeshOptions {
        tree,
        sign: SignMode::Unsigned,
        ..Default::default()
    };
    let t = Instant::now();
    let sdf = MeshSdf::new(mesh, opts)?;
    let build = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (distances, stats): (Vec<Vec<f64>>, Vec<QueryStats>) = points
        .par_chunks(4096)
        .map(|c| {
            let mut st = QueryStats::default();
            let d: Vec<f64> = c
                .iter()
                .map(|&p| sdf.query(p, &mut st).map_or(f64::NAN, |h| h.distance))
                .collect();
            (d, st)
        })
        .unzip();
    let query = t.elapsed().as_secs_f64();
    let mut total = QueryStats::default();
    for s in stats {
        total += s;
    }
    Ok(Run {
        build,
        query,
        stats: total,
        tree: sdf.tree().stats(),
        distances: distances.concat(),
    })
}

fn kdtree(a: KdtreeArgs) -> Result<()> {
    if a.points == 0 {
        bail!("--points must be at least 1");
    }
    let (name, mesh) = match &a.mesh {
        Some(p) => (p.display().to_string(), read_mesh(p)?),
        None => (
            "generated trefoil tube".to_string(),
            generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 192, 16),
        ),
    };
    let points: Vec<DVec3> = generate::query_points(&mesh, a.points, 0.05, a.seed)
        .into_iter()
        .map(|p| p.as_dvec3())
        .collect();
    let overlap = BuildParams {
        leaf_size: a.leaf_size,
        max_overlap: a.max_overlap,
        ..Default::default()
    };
    let classic = BuildParams {
        max_overlap: 0.0,
        ..overlap
    };
    let o = measure(&mesh, overlap, &points).context("overlapping tree")?;
    let c = measure(&mesh, classic, &points).context("classic tree")?;
    let identical = o
        .distances
        .iter()
        .zip(&c.distances)
        .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
    let n = points.len() as f64;
    let per = |r: &Run| {
        json!({
            "build_seconds": r.build,
            "query_seconds": r.query,
            "queries_per_second": n / r.query.max(1e-12),
            "nodes_visited_per_query": r.stats.nodes_visited as f64 / n,
            "triangles_tested_per_query": r.stats.prims_tested as f64 / n,
            "nodes": r.tree.nodes,
            "depth": r.tree.depth,
            "triangles_at_inner_nodes": r.tree.prims_at_inner_nodes,
            "overlapping_nodes": r.tree.overlapping_nodes,
            "bytes": r.tree.bytes,
        })
    };
    let v = json!({
        "mesh": name,
        "triangles": mesh.triangles.len(),
        "points": points.len(),
        "threads": rayon::current_num_threads(),
        "leaf_size": a.leaf_size,
        "max_overlap": a.max_overlap,
        "overlap": per(&o),
        "classic": per(&c),
        "speedup": c.query / o.query.max(1e-12),
        "identical_distances": identical,
    });
    if a.json {
        println!("{v}");
    } else {
        println!(
            "{name}: {} triangles, {} query points, {} threads",
            mesh.triangles.len(),
            points.len(),
            rayon::current_num_threads()
        );
        println!("{:>24} {:>12} {:>12}", "", "overlap", "classic");
        for (label, key) in [
            ("build s", "build_seconds"),
            ("queries/s", "queries_per_second"),
            ("nodes visited/query", "nodes_visited_per_query"),
            ("triangles tested/query", "triangles_tested_per_query"),
            ("nodes", "nodes"),
            ("triangles at inner nodes", "triangles_at_inner_nodes"),
            ("bytes", "bytes"),
        ] {
            let f = |r: &serde_json::Value| r[key].as_f64().unwrap_or(f64::NAN);
            println!(
                "{label:>24} {:>12.4} {:>12.4}",
                f(&v["overlap"]),
                f(&v["classic"])
            );
        }
        println!(
            "overlap tree answers {:.2}x faster; distances identical: {}",
            c.query / o.query.max(1e-12),
            if identical { "yes" } else { "NO" }
        );
    }
    if !identical {
        bail!("the two trees disagree: this is a bug");
    }
    Ok(())
}
