//! `isokit query MESH --points P.npy -o D.npy`: exact signed distances at given points.

use super::check_output;
use super::mesh_args::MeshKnobs;
use super::progress::Progress;
use anyhow::{Context, Result, bail};
use glam::DVec3;
use isokit_io::{read_mesh, read_npy, write_npy_f32};
use isokit_kdtree::mesh::{MeshHit, MeshSdf};
use isokit_kdtree::tree::QueryStats;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `isokit query`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Triangle mesh (.obj .gltf .glb .ply .stl .off).
    pub mesh: PathBuf,
    /// Query points: an (n, 3) NPY array of f32 or f64 (C order).
    #[arg(long)]
    pub points: PathBuf,
    /// Output: n signed distances as f32 NPY (negative inside). NaN for non-finite points.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the closest points, (n, 3) f32 NPY.
    #[arg(long)]
    pub closest: Option<PathBuf>,
    /// Print throughput, mean nodes visited and primitives tested, and the tree's shape.
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub knobs: MeshKnobs,
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".npy"])?;
    if let Some(c) = &a.closest {
        check_output(c, &[".npy"])?;
    }
    let arr = read_npy(&a.points)?;
    if arr.shape.len() != 2 || arr.shape[1] != 3 {
        bail!(
            "{}: query points must be an (n, 3) array, got shape {:?}",
            a.points.display(),
            arr.shape
        );
    }
    let points: Vec<DVec3> = arr
        .data
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect();
    let mesh = read_mesh(&a.mesh)?;
    let t0 = Instant::now();
    let sdf =
        MeshSdf::new(&mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
    let build = t0.elapsed().as_secs_f64();
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());

    let progress = Progress::new("query", points.len() as u64);
    let t1 = Instant::now();
    const CHUNK: usize = 4096;
    let results: Vec<(Vec<Option<MeshHit>>, QueryStats)> = points
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut st = QueryStats::default();
            let hits = chunk
                .iter()
                .map(|&p| {
                    if p.is_finite() {
                        sdf.query(p, &mut st)
                    } else {
                        None
                    }
                })
                .collect();
            progress.advance(chunk.len() as u64);
            (hits, st)
        })
        .collect();
    progress.finish();
    let secs = t1.elapsed().as_secs_f64();

    let mut stats = QueryStats::default();
    let mut dist = Vec::with_capacity(points.len());
    let mut closest = Vec::with_capacity(if a.closest.is_some() {
        3 * points.len()
    } else {
        0
    });
    for (hits, st) in results {
        stats += st;
        for h in hits {
            dist.push(h.map_or(f32::NAN, |h| h.distance as f32));
            if a.closest.is_some() {
                let c = h.map_or(DVec3::NAN, |h| h.point).as_vec3();
                closest.extend_from_slice(&c.to_array());
            }
        }
    }
    let skipped = dist.iter().filter(|d| d.is_nan()).count();
    write_npy_f32(&a.output, &[dist.len()], &dist)?;
    if let Some(c) = &a.closest {
        write_npy_f32(c, &[dist.len(), 3], &closest)?;
    }
    if skipped > 0 {
        eprintln!("warning: {skipped} query points were not finite; their distances are NaN");
    }
    let n = points.len().max(1) as f64;
    if a.stats {
        let ts = sdf.tree().stats();
        eprintln!(
            "{} triangles, tree built in {build:.3} s ({} nodes, depth {}, {} primitives at inner nodes, {} overlapping nodes, {} bytes)",
            sdf.triangles().len(),
            ts.nodes,
            ts.depth,
            ts.prims_at_inner_nodes,
            ts.overlapping_nodes,
            ts.bytes
        );
        eprintln!(
            "{} queries in {secs:.3} s: {:.0} queries/s, {:.1} nodes visited and {:.1} triangles tested per query",
            points.len(),
            points.len() as f64 / secs.max(1e-12),
            stats.nodes_visited as f64 / n,
            stats.prims_tested as f64 / n
        );
    }
    Ok(())
}
