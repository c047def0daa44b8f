//! `isokit query MESH|CLOUD|SCENE --points P.npy -o D.npy`: signed distances at given
//! points (exact for meshes, `MeshSdf::query_points`).

use super::check_output;
use super::mesh_args::MeshKnobs;
use anyhow::{Context, Result, bail};
use glam::DVec3;
use isokit_field::Field;
use isokit_io::{read_mesh, read_npy, write_npy_f32};
use isokit_kdtree::mesh::MeshSdf;
use isokit_scene::{Scene, SceneFormat};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `isokit query`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Triangle mesh (.obj .gltf .glb .ply .stl .off); or a point cloud (.xyz, .ply without
    /// faces), then the distances are those of `isokit points` (approximate); or a scene
    /// file (.json, .toml), then they are the scene's field.
    pub mesh: PathBuf,
    /// Query points: an (n, 3) NPY array of f32 or f64 (C order).
    #[arg(long)]
    pub points: PathBuf,
    /// Output: n signed distances as f32 NPY (negative inside). NaN for non-finite points.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the closest points, (n, 3) f32 NPY (meshes only).
    #[arg(long)]
    pub closest: Option<PathBuf>,
    /// Print throughput, mean nodes visited and primitives tested, and the tree's shape.
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub knobs: MeshKnobs,
}

fn write_distances(path: &std::path::Path, dist: &[f32]) -> Result<()> {
    write_npy_f32(path, &[dist.len()], dist)?;
    let skipped = dist.iter().filter(|d| d.is_nan()).count();
    if skipped > 0 {
        eprintln!("warning: {skipped} query points were not finite; their distances are NaN");
    }
    Ok(())
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
    if SceneFormat::from_path(&a.mesh).is_some() {
        if a.closest.is_some() {
            bail!("--closest is for meshes: a scene's field has no closest point");
        }
        let scene = Scene::load(&a.mesh)?;
        let dist: Vec<f32> = points
            .par_iter()
            .map(|p| match p.is_finite() {
                true => scene.value(p.as_vec3()),
                false => f32::NAN,
            })
            .collect();
        return write_distances(&a.output, &dist);
    }
    if isokit_io::detect_kind(&a.mesh)? == isokit_io::FileKind::PointCloud {
        if a.closest.is_some() {
            bail!(
                "--closest is not available for point clouds: the field's zero set has no exact closest point"
            );
        }
        let cloud = isokit_io::read_points(&a.mesh)?;
        let q = isokit_points::query_cloud(&cloud, &points, &Default::default())
            .with_context(|| a.mesh.display().to_string())?;
        let normals = if q.normals_estimated {
            "estimated"
        } else {
            "given"
        };
        eprintln!(
            "cloud: {} samples, normals {normals}, built in {:.2} s",
            q.samples, q.build_seconds
        );
        return write_distances(&a.output, &q.distances);
    }
    let mesh = read_mesh(&a.mesh)?;
    let t0 = Instant::now();
    let sdf =
        MeshSdf::new(&mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
    let build = t0.elapsed().as_secs_f64();
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());
    let t1 = Instant::now();
    let q = sdf.query_points(&points, a.closest.is_some(), &super::progress::job())?;
    let secs = t1.elapsed().as_secs_f64();
    let dist: Vec<f32> = q.distances.iter().map(|&d| d as f32).collect();
    write_distances(&a.output, &dist)?;
    if let Some(c) = &a.closest {
        let flat: Vec<f32> = q
            .closest
            .iter()
            .flat_map(|p| p.as_vec3().to_array())
            .collect();
        write_npy_f32(c, &[dist.len(), 3], &flat)?;
    }
    if a.stats {
        let n = points.len().max(1) as f64;
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
            q.stats.nodes_visited as f64 / n,
            q.stats.prims_tested as f64 / n
        );
    }
    Ok(())
}
