//! `isokit sdf MESH --method kdtree --res N -o out.nrrd`: a mesh's signed distance on a grid.

use super::check_output;
use super::mesh_args::MeshKnobs;
use super::progress::Progress;
use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_io::{Volume, read_mesh, write_volume};
use isokit_kdtree::mesh::MeshSdf;
use isokit_kdtree::tree::QueryStats;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// How the grid is computed.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Per-sample exact closest point through the kd-tree.
    Kdtree,
}

/// Arguments of `isokit sdf`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Triangle mesh (.obj .gltf .glb .ply .stl .off).
    pub mesh: PathBuf,
    /// Output volume (.nrrd or .npy).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Algorithm.
    #[arg(long, value_enum, default_value_t = Method::Kdtree)]
    pub method: Method,
    /// Samples along the longest side of the padded bounds.
    #[arg(long, default_value_t = 64)]
    pub res: usize,
    /// Narrow band: only samples within W of the surface are exact; the rest hold ±W with
    /// the right sign (the search exits early beyond W).
    #[arg(long)]
    pub band: Option<f64>,
    /// Margin around the mesh bounds in world units [default: 10% of the diagonal].
    #[arg(long)]
    pub padding: Option<f32>,
    #[command(flatten)]
    pub knobs: MeshKnobs,
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".nrrd", ".npy"])?;
    if let Some(w) = a.band {
        if !(w.is_finite() && w > 0.0) {
            bail!("--band {w} must be finite and positive");
        }
    }
    let mesh = read_mesh(&a.mesh)?;
    let sdf =
        MeshSdf::new(&mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());
    let bounds = sdf.tree().bounds();
    let pad = a.padding.unwrap_or(0.1 * bounds.diagonal());
    if !(pad.is_finite() && pad >= 0.0) {
        bail!("--padding {pad} must be finite and non-negative");
    }
    let mut grid = Grid::covering(bounds, a.res, pad)?;
    let [nx, ny, _] = grid.dims();
    let (origin, h) = (grid.origin().as_dvec3(), grid.spacing() as f64);
    let progress = Progress::new("sdf", grid.len() as u64);
    let t = Instant::now();
    let band = a.band.unwrap_or(f64::INFINITY);
    let stats = grid
        .data_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .map(|(k, slice)| {
            let mut st = QueryStats::default();
            // Neighbouring samples share their closest triangle more often than not.
            let mut hint = None;
            for (n, v) in slice.iter_mut().enumerate() {
                let p = origin + h * glam::DVec3::new((n % nx) as f64, (n / nx) as f64, k as f64);
                let (d, t) = sdf.signed_distance_band_near(p, band, hint, &mut st);
                hint = t.or(hint);
                *v = d as f32;
            }
            progress.advance(slice.len() as u64);
            st
        })
        .reduce(QueryStats::default, |mut a, b| {
            a += b;
            a
        });
    progress.finish();
    let secs = t.elapsed().as_secs_f64();
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    let inside_band = a.band.map(|_| {
        grid.data()
            .iter()
            .filter(|v| (v.abs() as f64) < band)
            .count()
    });
    write_volume(&a.output, &Volume::from(grid))?;
    let in_band = inside_band.map_or(String::new(), |n| {
        format!(
            ", {:.1}% of samples inside the band",
            100.0 * n as f64 / len as f64
        )
    });
    eprintln!(
        "{} x {} x {} samples, spacing {spacing} in {secs:.2} s ({:.0} samples/s, {:.1} triangles tested per sample{in_band}) -> {}",
        dims[0],
        dims[1],
        dims[2],
        len as f64 / secs.max(1e-12),
        stats.prims_tested as f64 / len as f64,
        a.output.display()
    );
    Ok(())
}
