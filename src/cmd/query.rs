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
    /// Triangle mesh (.obj .gltf .glb .ply .stl .off), or a point cloud (.xyz, .ply without
    /// faces): then the distances are those of `isokit points` (approximate).
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

/// Indices of `points` sorted along a Morton (Z-order) curve over their bounds; non-finite
/// points go last.
fn morton_order(points: &[DVec3]) -> Vec<u32> {
    let finite = points.iter().filter(|p| p.is_finite());
    let lo = finite.clone().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = finite.fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    let scale = ((1u64 << 21) - 1) as f64 / (hi - lo).max_element().max(f64::MIN_POSITIVE);
    // Spreads the low 21 bits of v to every third bit.
    fn spread(v: u64) -> u64 {
        let mut x = v & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        (x | x << 2) & 0x1249_2492_4924_9249
    }
    let key = |p: &DVec3| {
        if !p.is_finite() {
            return u64::MAX;
        }
        let q = ((*p - lo) * scale).as_u64vec3();
        spread(q.x) | spread(q.y) << 1 | spread(q.z) << 2
    };
    let mut idx: Vec<u32> = (0..points.len() as u32).collect();
    idx.par_sort_unstable_by_key(|&i| key(&points[i as usize]));
    idx
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
    if isokit_io::detect_kind(&a.mesh)? == isokit_io::FileKind::PointCloud {
        return super::points::query_cloud(&a.mesh, &points, &a.output, a.closest.is_some());
    }
    let mesh = read_mesh(&a.mesh)?;
    let t0 = Instant::now();
    let sdf =
        MeshSdf::new(&mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
    let build = t0.elapsed().as_secs_f64();
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());

    // Visit the points in Morton order so that each query can start from its
    // predecessor's closest triangle (a tight initial bound); results go back in input order.
    let order = morton_order(&points);
    let progress = Progress::new("query", points.len() as u64);
    let t1 = Instant::now();
    const CHUNK: usize = 4096;
    let results: Vec<(Vec<Option<MeshHit>>, QueryStats)> = order
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut st = QueryStats::default();
            let mut hint = None;
            let hits = chunk
                .iter()
                .map(|&i| {
                    let p = points[i as usize];
                    let h = if p.is_finite() {
                        sdf.query_near(p, hint, &mut st)
                    } else {
                        None
                    };
                    hint = h.map(|h| h.triangle).or(hint);
                    h
                })
                .collect();
            progress.advance(chunk.len() as u64);
            (hits, st)
        })
        .collect();
    progress.finish();
    let secs = t1.elapsed().as_secs_f64();

    let mut stats = QueryStats::default();
    let mut dist = vec![f32::NAN; points.len()];
    let mut closest = if a.closest.is_some() {
        vec![f32::NAN; 3 * points.len()]
    } else {
        Vec::new()
    };
    for ((hits, st), idx) in results.into_iter().zip(order.chunks(CHUNK)) {
        stats += st;
        for (h, &i) in hits.into_iter().zip(idx) {
            let i = i as usize;
            if let Some(h) = h {
                dist[i] = h.distance as f32;
                if !closest.is_empty() {
                    closest[3 * i..3 * i + 3].copy_from_slice(&h.point.as_vec3().to_array());
                }
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
