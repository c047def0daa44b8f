//! Options shared by the commands that turn a mesh into distances.

use isokit_kdtree::mesh::{MeshOptions, SignMode};
use isokit_kdtree::tree::BuildParams;

/// Sign choice on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Sign {
    /// Pseudonormals for watertight, oriented meshes; winding number otherwise.
    #[default]
    Auto,
    /// Angle-weighted pseudonormals.
    Pseudonormal,
    /// Generalized winding number (hierarchical).
    Winding,
    /// Unsigned distance.
    Unsigned,
}

/// Sign and kd-tree knobs.
#[derive(clap::Args, Debug, Clone)]
pub struct MeshKnobs {
    /// How to decide inside and outside.
    #[arg(long, value_enum, default_value_t = Sign::Auto)]
    pub sign: Sign,
    /// kd-tree leaf size (1 to 65536).
    #[arg(long, default_value_t = BuildParams::default().leaf_size, value_parser = leaf_size, allow_negative_numbers = true)]
    pub leaf_size: usize,
    /// Largest sibling overlap as a fraction of a node's extent, 0 to 1 (0: classic kd-tree).
    #[arg(long, default_value_t = BuildParams::default().max_overlap, value_parser = max_overlap, allow_negative_numbers = true)]
    pub max_overlap: f32,
    /// Winding-number accuracy (expansion used beyond beta × node radius).
    #[arg(long, default_value_t = 2.0)]
    pub beta: f64,
}

/// `--leaf-size`, checked by [`BuildParams::check_leaf_size`].
pub fn leaf_size(s: &str) -> Result<usize, String> {
    BuildParams::check_leaf_size(s.parse().map_err(|e| format!("{s:?}: {e}"))?)
}

/// `--max-overlap`, checked by [`BuildParams::check_max_overlap`].
pub fn max_overlap(s: &str) -> Result<f32, String> {
    BuildParams::check_max_overlap(s.parse().map_err(|e| format!("{s:?}: {e}"))?)
}

impl MeshKnobs {
    /// The library options.
    pub fn options(&self) -> MeshOptions {
        MeshOptions {
            sign: match self.sign {
                Sign::Auto => SignMode::Auto,
                Sign::Pseudonormal => SignMode::Pseudonormal,
                Sign::Winding => SignMode::Winding,
                Sign::Unsigned => SignMode::Unsigned,
            },
            tree: BuildParams {
                leaf_size: self.leaf_size,
                max_overlap: self.max_overlap,
                ..BuildParams::default()
            },
            winding_beta: self.beta,
        }
    }
}
