//! `isokit bench octree`: Sigg 2006's Table 3.1 on this machine (`isokit_octree::table_3_1`).

use anyhow::{Result, bail};
use glam::Vec3;
use isokit_field::{Field, TriMesh};
use isokit_kdtree::MeshSdf;
use serde_json::json;

/// Arguments of `isokit bench octree`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Random cell accesses per tree and variant (002 Table 3.1 used 50 million).
    #[arg(long, default_value_t = 2_000_000)]
    pub accesses: usize,
    /// First maximum level measured.
    #[arg(long, default_value_t = 5)]
    pub first_level: u32,
    /// Last maximum level measured (the trees grow about 4x per level).
    #[arg(long, default_value_t = 10)]
    pub last_level: u32,
    /// Seed of the access points.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Timing runs per variant; the fastest counts.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs `isokit bench octree`.
pub fn bench(a: BenchArgs) -> Result<()> {
    if a.accesses == 0 || a.repeat == 0 {
        bail!("--accesses and --repeat must be at least 1");
    }
    if a.first_level > a.last_level || a.last_level > 12 {
        bail!(
            "levels {}..={}: need first <= last <= 12",
            a.first_level,
            a.last_level
        );
    }
    let sphere = isokit_field::primitives::Sphere::new(Vec3::ZERO, 1.0)?;
    use isokit_field::generate::{trefoil, tube};
    let mesh = tube(|u| trefoil(u, 0.5), 0.18, 192, 16);
    let sdf = MeshSdf::new(&mesh, isokit_kdtree::MeshOptions::default())?;
    let datasets: Vec<(&str, &dyn Field, Option<&TriMesh>)> = vec![
        ("sphere", &sphere, None),
        ("trefoil tube (6144 triangles)", &sdf, Some(&mesh)),
    ];
    let rows = isokit_octree::table_3_1(
        &datasets,
        a.first_level..=a.last_level,
        a.accesses,
        a.repeat,
        a.seed,
        |r| {
            if !a.json {
                eprintln!(
                    "{} level {}: {} cells, locate hashed {:.3} s, linked {:.3} s ({:.2}x); {:.1} vs {:.1} bytes/cell",
                    r.dataset,
                    r.level,
                    r.cells,
                    r.hashed_seconds,
                    r.linked_seconds,
                    r.linked_seconds / r.hashed_seconds.max(1e-12),
                    r.hashed_bytes_per_cell,
                    r.linked_bytes_per_cell
                );
            }
        },
    )?;
    let rows: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            json!({
                "dataset": r.dataset, "level": r.level, "cells": r.cells, "nodes": r.nodes,
                "build_seconds": r.build_seconds, "convert_seconds": r.convert_seconds,
                "average_access_level_from_finest": r.average_access_level_from_finest,
                "hashed_seconds": r.hashed_seconds,
                "hashed_binary_seconds": r.hashed_binary_seconds,
                "hashed_cached_seconds": r.hashed_cached_seconds,
                "cell_cache_hit_rate": r.cell_cache_hit_rate,
                "linked_seconds": r.linked_seconds,
                "speedup": r.linked_seconds / r.hashed_seconds.max(1e-12),
                "speedup_binary": r.linked_seconds / r.hashed_binary_seconds.max(1e-12),
                "hashed_value_seconds": r.hashed_value_seconds,
                "linked_value_seconds": r.linked_value_seconds,
                "hashed_bytes_per_cell": r.hashed_bytes_per_cell,
                "linked_bytes_per_cell": r.linked_bytes_per_cell,
                "memory_ratio": r.hashed_bytes_per_cell / r.linked_bytes_per_cell,
            })
        })
        .collect();
    let col =
        |key: &str| -> Vec<serde_json::Value> { rows.iter().map(|r| r[key].clone()).collect() };
    let v = json!({
        "accesses": a.accesses,
        "repeat": a.repeat,
        "threads_timed": 1,
        "construction": "error 0, band 0, Lipschitz culling, hanging nodes interpolated (thesis)",
        "datasets": col("dataset"), "levels": col("level"), "cells": col("cells"),
        "hashed_seconds": col("hashed_seconds"),
        "hashed_binary_seconds": col("hashed_binary_seconds"),
        "hashed_cached_seconds": col("hashed_cached_seconds"),
        "linked_seconds": col("linked_seconds"), "speedup": col("speedup"),
        "hashed_value_seconds": col("hashed_value_seconds"),
        "linked_value_seconds": col("linked_value_seconds"),
        "hashed_bytes_per_cell": col("hashed_bytes_per_cell"),
        "linked_bytes_per_cell": col("linked_bytes_per_cell"),
        "memory_ratio": col("memory_ratio"),
        "rows": rows,
    });
    if a.json {
        println!("{v}");
        return Ok(());
    }
    println!(
        "{:<32} {:>5} {:>10} {:>10} {:>10} {:>8} {:>9} {:>9}",
        "dataset", "level", "cells", "hashed s", "linked s", "speedup", "hash B/c", "link B/c"
    );
    for r in v["rows"].as_array().into_iter().flatten() {
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        println!(
            "{:<32} {:>5} {:>10} {:>10.3} {:>10.3} {:>8.2} {:>9.1} {:>9.1}",
            r["dataset"].as_str().unwrap_or(""),
            r["level"],
            r["cells"],
            f("hashed_seconds"),
            f("linked_seconds"),
            f("speedup"),
            f("hashed_bytes_per_cell"),
            f("linked_bytes_per_cell"),
        );
    }
    println!(
        "{} random accesses near the surface per tree, one thread, fastest of {}",
        a.accesses, a.repeat
    );
    Ok(())
}
