//! The arguments of `isokit sdf` and the library settings they make.

use crate::cmd::mesh_args::MeshKnobs;
use crate::cmd::volume_args::{LatticeArgs, VolumeOut};
use isokit_gpu::BackendChoice;
use isokit_prism::{PrismOptions, SideRule};
use std::path::PathBuf;

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
#[command(after_help = crate::cmd::volume_args::LAYOUT)]
pub struct Args {
    /// Triangle mesh (.obj .gltf .glb .ply .stl .off), or with --segmented surface patches
    /// (.ply).
    pub mesh: PathBuf,
    /// Output volume (.nrrd or .npy with its lattice sidecar .npy.json; see below).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Algorithm.
    #[arg(long, value_enum, default_value_t = Method::Kdtree)]
    pub method: Method,
    /// Samples along the longest side of the padded bounds [default: 64].
    #[arg(long)]
    pub res: Option<usize>,
    /// Narrow band: only samples within W of the surface are exact; the rest hold ±W with
    /// the right sign (the search exits early beyond W). Required by --method prism.
    #[arg(long)]
    pub band: Option<f64>,
    /// --method kdtree --band W: query every sample of the grid (with the early exit beyond
    /// W) instead of only the bricks of 4^3 samples that may come within W of the surface
    /// (the same values; the baseline the lazy band is measured against).
    #[arg(long)]
    pub dense: bool,
    #[command(flatten)]
    pub lattice: LatticeArgs,
    #[command(flatten)]
    pub out: VolumeOut,
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
    /// The input is a PLY of surface patches whose faces carry `region_front` and
    /// `region_back`: write their segmented distance field (003 Eq. 4) as an NRRD whose
    /// header holds `field:=segmented`, `delta:=` and `period:=` (world units).
    #[arg(long)]
    pub segmented: bool,
    #[command(flatten)]
    pub segmented_knobs: crate::cmd::segmented_field::SegmentedKnobs,
}

impl Backend {
    /// The library's request.
    pub fn choice(self) -> BackendChoice {
        match self {
            Backend::Cpu => BackendChoice::Cpu,
            Backend::Gpu => BackendChoice::Gpu,
            Backend::Auto => BackendChoice::Auto,
        }
    }
}

impl Args {
    /// The prism scan's options for band half-width `band`.
    pub fn prism_options(&self, band: f64) -> PrismOptions {
        PrismOptions {
            mesh: self.knobs.options(),
            repair: !self.no_gap_repair,
            sides: match self.prism_sides {
                Sides::Exact => SideRule::Exact,
                Sides::Bisector => SideRule::Bisector,
            },
            ..PrismOptions::with_band(band)
        }
    }
}
