//! `isokit scene SCENE -o out.nrrd|npy|zarr|obj|ply|stl|off [--res N] [--band W]
//! [--mesher mc|dual [--error E]] [--stats]`: a scene file evaluated lazily to a band field or a mesh.

use super::{MESH_OUTPUTS, check_output, is_mesh_output};
use anyhow::{Result, bail};
use glam::Vec3;
use isokit_io::{Volume, write_mesh, write_mesh_colored};
use isokit_scene::{MeshOptions, SampleOptions, Scene, clamp_to_band, mesh_scene, vertex_colors};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `isokit scene`.
#[derive(clap::Args, Debug)]
#[command(after_help = super::volume_args::LAYOUT)]
pub struct Args {
    /// Scene file (.json or .toml).
    pub scene: PathBuf,
    /// Output: a volume (.nrrd, .npy with its lattice sidecar, a .zarr store sampled chunk by
    /// chunk; see below) or a mesh (.obj, .ply, .stl, .off, .glb, .gltf; PLY and glTF carry
    /// the nodes' colours).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples along the longest side of the domain [default: the scene's
    /// `sampling.resolution`, else 128].
    #[arg(long)]
    pub res: Option<usize>,
    /// Band half-width in world units: values are exact within it, ±W (right sign) beyond
    /// [default: `sampling.band`, else 4 voxels].
    #[arg(long)]
    pub band: Option<f32>,
    /// Brick size, a power of two from 2 to 256 [default: `sampling.brick`, else 4].
    #[arg(long)]
    pub brick: Option<usize>,
    /// Evaluate every sample of the dense grid instead (the baseline lazy evaluation is
    /// measured against).
    #[arg(long)]
    pub dense: bool,
    /// Mesh outputs: the mesher.
    #[command(flatten)]
    pub mesher: super::mesher_args::MesherOpts,
    /// Print what the evaluation computed as one JSON object on stdout (`dense_fraction`,
    /// `seconds`, per-source query counts, …).
    #[arg(long)]
    pub stats: bool,
    /// .zarr output: finish a killed run's <output>.partial (its missing chunks only).
    #[arg(long)]
    pub resume: bool,
    /// The domain: --bounds (instead of the scene's box padded by the band) or another
    /// volume's lattice.
    #[command(flatten)]
    pub placement: super::volume_args::Placement,
    #[command(flatten)]
    pub out: super::volume_args::VolumeOut,
}

/// The node kinds a scene file can hold, for `--help` (from the library's list).
pub fn node_kinds_help() -> String {
    format!(
        "Node kinds: {}.\nThe JSON Schema of scene files: docs/scene.schema.json.",
        isokit_scene::Node::KINDS.join(", ")
    )
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    let all: Vec<&str> = super::volume_args::VOLUME_OUTPUTS
        .iter()
        .chain(&MESH_OUTPUTS)
        .copied()
        .collect();
    check_output(&a.output, &all)?;
    a.out.check(&a.output)?;
    let to_mesh = is_mesh_output(&a.output);
    let to_store = super::volume_out::is_zarr(&a.output);
    if a.resume && (a.dense || !to_store) {
        bail!("--resume continues a lazily sampled .zarr output");
    }
    let error = a.mesher.error()?;
    if !to_mesh && a.mesher.mesher.is_some() {
        bail!(
            "--mesher applies to mesh outputs ({}) only",
            MESH_OUTPUTS.join(" ")
        );
    }
    let t0 = Instant::now();
    let scene = Scene::load(&a.scene)?;
    let load_seconds = t0.elapsed().as_secs_f64();
    let mut opts = SampleOptions::from_scene(&scene);
    if let Some(r) = a.res {
        opts.resolution = r;
    }
    if let Some(b) = a.band {
        if !(b.is_finite() && b > 0.0) {
            bail!("--band {b} must be finite and positive");
        }
        opts.band = Some(b);
    }
    if let Some(b) = a.brick {
        opts.brick = b;
    }
    if let Some(b) = a.placement.bounds()? {
        opts.bounds = Some(b);
    }
    if let Some(like) = &a.placement.like {
        opts.lattice = Some(super::volume_args::like_lattice(like)?);
    }
    let t1 = Instant::now();
    let job = super::progress::job();
    let mut mesh_stats = None;
    let (stats, triangles) = if to_mesh {
        let mo = MeshOptions {
            sampling: opts,
            dense: a.dense,
            mesher: a.mesher.kind().into(),
            error,
        };
        let (mesh, st) = mesh_scene(&scene, &mo, &job)?;
        match vertex_colors(&scene, &mesh, st.sampling.spacing) {
            Some(colors) => write_mesh_colored(&a.output, &mesh, &colors)?,
            None => write_mesh(&a.output, &mesh)?,
        }
        super::mesher_args::print_scene_dual_stats(&st);
        let out = (st.sampling.clone(), Some(st.triangles));
        mesh_stats = Some(st);
        out
    } else if to_store && !a.dense {
        let stats = super::scene_store::write(&scene, &opts, &a.out, &a.output, a.resume, &job)?;
        (stats, None)
    } else if a.dense {
        let (mut grid, stats) = scene.sample_dense(&opts)?;
        clamp_to_band(&mut grid, stats.band);
        a.out
            .write(&a.output, &Volume::from(grid), Some(stats.band), None)?;
        (stats, None)
    } else {
        // Kept bricks hold exact values a little beyond the band: clamped, so the file
        // reads "exact within W, ±W beyond" everywhere.
        let (grid, stats) = scene.sample_grid_job(&opts, &job)?;
        a.out
            .write(&a.output, &Volume::from(grid), Some(stats.band), None)?;
        (stats, None)
    };
    let total = t1.elapsed().as_secs_f64();
    if triangles == Some(0) {
        eprintln!("warning: the surface does not cross the sampled domain; the mesh is empty");
    }
    // The most queried sources first; a union of thousands of primitives names six.
    let mut sources: Vec<_> = stats.sources.iter().collect();
    sources.sort_by(|a, b| b.query_fraction.total_cmp(&a.query_fraction));
    let mut queried: Vec<String> = sources
        .iter()
        .take(6)
        .map(|s| format!("{} {:.2}%", s.node, 100.0 * s.query_fraction))
        .collect();
    if sources.len() > 6 {
        queried.push(format!("{} more", sources.len() - 6));
    }
    eprintln!(
        "{} x {} x {} lattice, spacing {}, band {}: {:.2}% of the dense samples evaluated in {:.2} s{} (sources queried: {}) -> {}",
        stats.dims[0],
        stats.dims[1],
        stats.dims[2],
        stats.spacing,
        stats.band,
        100.0 * stats.dense_fraction,
        stats.seconds,
        triangles.map_or(String::new(), |t| format!(", {t} triangles")),
        queried.join(", "),
        a.output.display()
    );
    if a.stats {
        let mut j = stats.to_json();
        j["load_seconds"] = load_seconds.into();
        j["total_seconds"] = total.into();
        j["lazy"] = (!a.dense).into();
        j["output"] = a.output.display().to_string().into();
        if let Some(st) = &mesh_stats {
            j["triangles"] = st.triangles.into();
            j["mesher"] = serde_json::to_value(st.mesher)?;
            super::mesher_args::add_dual_counts(&mut j, st)?;
        }
        // The sampled lattice's extent (the shape's box padded by the band).
        let hi = Vec3::from(stats.origin)
            + stats.spacing * Vec3::from_array(stats.dims.map(|d| d.saturating_sub(1) as f32));
        j["domain"] = serde_json::json!([stats.origin, hi.to_array()]);
        println!("{j}");
    }
    Ok(())
}
