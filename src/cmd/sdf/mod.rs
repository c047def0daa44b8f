//! `isokit sdf MESH --method kdtree|prism --res N [--band W] -o out.nrrd`: a mesh's signed
//! distance on a grid, per sample through the kd-tree or per triangle by prism scan
//! conversion (CPU or GPU).

use super::check_output;
use super::mesh_args::MeshKnobs;
use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_gpu::BackendChoice;
use isokit_io::{Volume, read_mesh, write_volume};
use isokit_kdtree::mesh::MeshSdf;
use isokit_kdtree::tree::QueryStats;
use isokit_prism::{Engine, PrismGpu, PrismOptions, PrismSdf, SideRule};
use std::path::PathBuf;
use std::time::Instant;

/// How the grid is computed.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Per-sample exact closest point through the kd-tree.
    Kdtree,
    /// Per-triangle prism scan conversion of the narrow band (needs --band): exact inside the
    /// band, ±W outside it; much faster for narrow bands.
    Prism,
}

/// Where the prism scan runs.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// A hardware GPU when one exists, else the CPU (a software rasterizer such as lavapipe
    /// counts as no GPU here: the CPU twin is faster on the same cores). `ISOKIT_BACKEND`
    /// overrides.
    Auto,
    /// The CPU twin (rayon).
    Cpu,
    /// The GPU (wgpu compute); an error when no adapter exists.
    Gpu,
}

/// The prism's sides on the concave side of an edge.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sides {
    /// Perpendicular to the face: exact at any band width.
    Exact,
    /// The paper's bisectors: tighter, may leak where the band is wide compared with the
    /// triangles.
    Bisector,
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
    /// the right sign (the search exits early beyond W). Required by --method prism.
    #[arg(long)]
    pub band: Option<f64>,
    /// Margin around the mesh bounds in world units [default: 10% of the diagonal].
    #[arg(long)]
    pub padding: Option<f32>,
    /// Where --method prism runs.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// --method prism: sides of the prisms on concave edges.
    #[arg(long, value_enum, default_value_t = Sides::Exact)]
    pub prism_sides: Sides,
    /// --method prism: do not close the gaps at saddle vertices (to measure what the repair
    /// is for; leaves band samples wrong or at ±W).
    #[arg(long)]
    pub no_gap_repair: bool,
    #[command(flatten)]
    pub knobs: MeshKnobs,
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    check_output(&a.output, &[".nrrd", ".npy"])?;
    if let Some(w) = a.band
        && !(w.is_finite() && w > 0.0)
    {
        bail!("--band {w} must be finite and positive");
    }
    if a.method == Method::Prism && a.band.is_none() {
        bail!("--method prism needs --band W (the half-width of the band it scan-converts)");
    }
    if a.method == Method::Kdtree && a.backend == Backend::Gpu {
        bail!("--method kdtree has no GPU kernel; use --method prism for --backend gpu");
    }
    let mesh = read_mesh(&a.mesh)?;
    if mesh.triangles.is_empty() {
        bail!("{}: the mesh has no triangles", a.mesh.display());
    }
    let grid = super::padded_grid(mesh.bounds(), a.res, a.padding)?;
    match a.method {
        Method::Kdtree => run_kdtree(&a, &mesh, grid),
        Method::Prism => run_prism(&a, &mesh, grid),
    }
}

fn run_kdtree(a: &Args, mesh: &isokit_io::TriMesh, mut grid: Grid) -> Result<()> {
    let sdf =
        MeshSdf::new(mesh, a.knobs.options()).with_context(|| a.mesh.display().to_string())?;
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

/// Opens the GPU the user asked for (the one policy of `isokit_gpu::choose_backend`), or
/// says why the CPU runs.
fn choose_gpu(backend: Backend) -> Result<Option<PrismGpu>> {
    let choice = match backend {
        Backend::Cpu => BackendChoice::Cpu,
        Backend::Gpu => BackendChoice::Gpu,
        Backend::Auto => BackendChoice::Auto,
    };
    let chosen = isokit_gpu::choose_backend(choice, &Default::default())
        .context("--backend gpu (or ISOKIT_BACKEND=gpu)")?;
    if let Some(why) = &chosen.reason {
        eprintln!("note: backend auto: {why}; scanning on the CPU twin (same result)");
    }
    Ok(chosen.gpu.map(PrismGpu::new).transpose()?)
}

fn run_prism(a: &Args, mesh: &isokit_io::TriMesh, mut grid: Grid) -> Result<()> {
    let band = a.band.unwrap_or_default();
    let opts = PrismOptions {
        mesh: a.knobs.options(),
        repair: !a.no_gap_repair,
        sides: match a.prism_sides {
            Sides::Exact => SideRule::Exact,
            Sides::Bisector => SideRule::Bisector,
        },
        ..PrismOptions::with_band(band)
    };
    let gpu = choose_gpu(a.backend)?;
    let sdf = PrismSdf::new(mesh, opts).with_context(|| a.mesh.display().to_string())?;
    eprintln!("sign: {} ({})", sdf.sign_method().name(), sdf.sign_reason());
    if let Some(w) = sdf.warning() {
        eprintln!("warning: {w}");
    }
    let r = sdf.report();
    eprintln!(
        "prisms: {} triangles ({} degenerate), {} vertices, {} saddles, {} with gaps in the paper's prisms, {} planes shifted{}, {} fat sides, built in {:.2} s",
        mesh.triangles.len(),
        r.degenerate_triangles,
        r.vertices,
        r.saddles,
        r.gaps,
        r.shifted_planes,
        if opts.repair { "" } else { " (gap repair off)" },
        r.fat_sides,
        sdf.build_seconds()
    );
    let engine = match &gpu {
        Some(g) => Engine::Gpu(g),
        None => Engine::Cpu,
    };
    let where_ = match &gpu {
        Some(g) => format!("GPU {}", g.gpu().describe()),
        None => format!("CPU, {} threads", rayon::current_num_threads()),
    };
    let t = Instant::now();
    let stats = sdf.fill_grid(&mut grid, &engine)?;
    let secs = t.elapsed().as_secs_f64();
    let (dims, spacing, len) = (grid.dims(), grid.spacing(), grid.len());
    write_volume(&a.output, &Volume::from(grid))?;
    let evaluated = if stats.evaluated > 0 {
        format!(
            ", {:.2} distance evaluations per band sample",
            stats.evaluated as f64 / stats.band_samples.max(1) as f64
        )
    } else {
        String::new()
    };
    eprintln!(
        "{} x {} x {} samples, spacing {spacing} in {secs:.2} s on the {where_} ({:.0} band samples/s, {:.1}% of samples inside the band{evaluated}, {} winding numbers) -> {}",
        dims[0],
        dims[1],
        dims[2],
        stats.band_samples as f64 / secs.max(1e-12),
        100.0 * stats.band_samples as f64 / len as f64,
        stats.windings,
        a.output.display()
    );
    Ok(())
}
