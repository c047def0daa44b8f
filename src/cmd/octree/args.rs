//! The arguments of `isokit octree`.

use crate::cmd::mesh_args::MeshKnobs;
use std::path::PathBuf;

/// Arguments of `isokit octree`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A mesh (.obj .gltf .glb .ply .stl .off: exact distance through the kd-tree), a volume
    /// (.nrrd .nhdr .npy .nii .nii.gz: its trilinear reconstruction, which is then also the
    /// reference for the error), a scene file (.json, .toml), or a primitive name with its
    /// default size (sphere, box, rounded-box, torus, capsule, cylinder, cone, ellipsoid; see
    /// `isokit sample --help`).
    pub input: String,
    /// Finest level (the root is level 0; 2^L cells a side), at most 21.
    #[arg(long)]
    pub max_level: u32,
    /// Cells above this level are always subdivided [default: min(2, max level)].
    #[arg(long)]
    pub min_level: Option<u32>,
    /// Error bound in world units: half for the cells' trilinear reconstruction at their test
    /// points, half for hanging nodes [default: a tenth of a finest cell].
    #[arg(long, allow_hyphen_values = true)]
    pub error: Option<f32>,
    /// Extra levels of test points per cell (for small features of general fields), 0 to 4.
    #[arg(long, default_value_t = 0)]
    pub lookahead: u32,
    /// Half-width of the band around the surface where the bound holds, in world units
    /// [default: two finest cells].
    #[arg(long)]
    pub band: Option<f32>,
    /// Half-width of the band where the test points lie [default: two finest cells].
    #[arg(long)]
    pub test_band: Option<f32>,
    /// Evaluate the whole finest grid and coalesce (guaranteed feature capture; refused when
    /// the dense grid is too large).
    #[arg(long)]
    pub bottom_up: bool,
    /// Leave hanging nodes interpolated without refining their coarse leaves (the thesis's
    /// construction; the bound then holds only where no hanging node is near).
    #[arg(long)]
    pub no_hanging_refinement: bool,
    /// Stop with an error beyond this many cells (a tree costs about 20 to 60 bytes per cell
    /// while it is built).
    #[arg(long, default_value_t = isokit_octree::DEFAULT_MAX_CELLS)]
    pub max_cells: usize,
    /// Margin around the input's bounds in world units [default: 10% of the diagonal for
    /// meshes and primitives, 0 for volumes].
    #[arg(long)]
    pub padding: Option<f32>,
    /// Export the tree sampled on a grid (.nrrd, or .npy with its lattice sidecar
    /// .npy.json: origin, spacing, dims [nx, ny, nz], axis_order "zyx"), or its surface as a
    /// mesh (.obj .ply .stl .off .glb .gltf; see --mesher) meshed at the export level.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Mesh output: `mc` (marching cubes of the tree's samples at the export level) or
    /// `dual` (dual contouring: the tree read node by node, never stored as a grid, with
    /// Hermite data from the input's exact field; sharp edges and corners) [default: mc].
    #[arg(long, value_enum)]
    pub mesher: Option<crate::cmd::mesher_args::MesherArg>,
    /// --mesher dual: adaptive meshing, cells merged where one vertex lies within E (world
    /// units) of every crossing's tangent plane and of the exact surface, as `isokit mesh
    /// --error` (named apart from --error, the tree's own bound) [default: one vertex per
    /// cell].
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    pub mesh_error: Option<f64>,
    #[command(flatten)]
    pub out: crate::cmd::volume_args::VolumeOut,
    /// Level of the exported grid or mesh (2^level + 1 samples a side) [default: min(max
    /// level, 8)].
    #[arg(long)]
    pub export_level: Option<u32>,
    /// Random test points within the band (independent of the construction).
    #[arg(long, default_value_t = 20_000)]
    pub test_points: usize,
    /// Seed of the test points.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub knobs: MeshKnobs,
}
