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
    /// kd-tree leaf size.
    #[arg(long, default_value_t = BuildParams::default().leaf_size)]
    pub leaf_size: usize,
    /// Largest sibling overlap as a fraction of a node's extent (0: classic kd-tree).
    #[arg(long, default_value_t = BuildParams::default().max_overlap)]
    pub max_overlap: f32,
    /// Winding-number accuracy (expansion used beyond beta × node radius).
    #[arg(long, default_value_t = 2.0)]
    pub beta: f64,
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
