//! `isokit sdf MESH --method kdtree --res N -o out.nrrd`: a mesh's signed distance on a grid.

use super::check_output;
use super::mesh_args::MeshKnobs;
use anyhow::{Context, Result, bail};
use isokit_io::{Volume, read_mesh, write_volume};
use isokit_kdtree::mesh::MeshSdf;
use isokit_kdtree::tree::QueryStats;
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
    if mesh.triangles.is_empty() {
        bail!("{}: the mesh has no triangles", a.mesh.display());
    }
    let mut grid = super::padded_grid(mesh.bounds(), a.res, a.padding)?;
    let sdf =
        MeshSdf::new(&mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());
    let t = Instant::now();
    let band = a.band.unwrap_or(f64::INFINITY);
    let stats = super::fill_slices(
        &mut grid,
        "sdf",
        |_, positions, values| {
            let mut st = QueryStats::default();
            // Neighbouring samples share their closest triangle more often than not.
            let mut hint = None;
            for (p, v) in positions.zip(values.iter_mut()) {
                let (d, t) = sdf.signed_distance_band_near(p, band, hint, &mut st);
                hint = t.or(hint);
                *v = d as f32;
            }
            st
        },
        |mut a, b| {
            a += b;
            a
        },
    );
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
