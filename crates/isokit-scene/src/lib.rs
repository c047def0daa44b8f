//! # isokit-scene: the one scene layer and pipeline of isokit
//!
//! What the command-line program, the Python package, the live viewer and cluster jobs all
//! call: typed scene nodes ([`Node`]) with constructors, sources from files or from memory,
//! JSON and TOML scene files as one serde view of the same types ([`parse`],
//! [`SceneFile::to_json`], a generated JSON Schema), compilation to the level-set crate's
//! field combinators ([`Scene`]), lazy sampling to a narrow band ([`Scene::sample`]), meshing
//! ([`mesh_scene`]) and rendering ([`Renderer`]), each long call with progress reports and
//! cancellation ([`Job`]).
//!
//! It is not where the mathematics lives: distances come from `isokit-field`,
//! `isokit-kdtree`, `isokit-points`, `isokit-prism` and `isokit-octree`, CSG from
//! `isokit-levelset`, ray casting from `isokit-render`, file formats from `isokit-io`. This
//! crate puts them together.
//!
//! ```
//! use isokit_scene::{Node, Scene, SampleOptions};
//! use isokit_field::Field;
//! use glam::Vec3;
//!
//! // A sphere with a box bitten out of it, built in code (the same tree a scene file holds).
//! let part = Node::difference(vec![
//!     Node::sphere(1.0, [0.0; 3]),
//!     Node::cuboid([0.5; 3], [1.0, 0.0, 0.0]),
//! ]);
//! let scene = Scene::from_node(part).unwrap();
//! // (0.6, 0, 0) is now outside, 0.1 from the box's face.
//! assert!((scene.value(Vec3::new(0.6, 0.0, 0.0)) - 0.1).abs() < 1e-6);
//!
//! // Sample the band lazily: bricks far from the surface are never evaluated.
//! let (band, stats) = scene
//!     .sample(&SampleOptions { resolution: 128, ..Default::default() })
//!     .unwrap();
//! assert!(stats.dense_fraction < 0.5);
//! assert!(band.brick_count() > 0);
//! ```
//!
//! ## Scene files
//! A scene is a table whose key `shape` holds the tree, with optional `version` (1),
//! `camera`, `lights`, `shading` and `sampling` tables. Paths inside a scene are relative to
//! the scene file. Errors name the file, the node path (`shape.difference[1].mesh`) and the
//! problem ([`SceneError`]). See [`node`] for the vocabulary and [`file`](mod@file) for the
//! settings.
//!
//! ## What is computed
//! [`Scene::sample`] never fills the dense grid: the sampler evaluates one point per brick
//! and keeps the bricks whose value, less the Lipschitz bound times the brick's
//! half-diagonal, comes within the band; the tree is evaluated with values clamped to a cap
//! just above that ([`isokit_field::Field::value_clamped`]), so bounding boxes prune subtrees
//! and sources (a union skips children whose bound is above the best value so far — through
//! a bounding-volume hierarchy when it has many — a difference skips subtrahends the point
//! lies well outside of, and meshes answer band-limited kd-tree queries or read their prism
//! band). [`SampleStats`] reports the share of the dense grid's samples that were computed
//! and how often each source was queried.
#![warn(missing_docs)]

pub mod bench;
pub mod file;
pub mod input;
mod memo;
mod mesh;
mod molecule;
pub mod node;
mod params;
pub mod primitives;
pub mod profiles;
mod render;
mod reuse;
mod sample;
mod scene;
pub mod segmented;
mod source;
mod vocab;
pub mod watch;

pub use file::{
    CameraSpec, LightSpec, SamplingSpec, SceneFile, SceneFormat, ShadingName, ShadingSpec, VERSION,
    json_schema, parse, parse_with_params,
};
pub use isokit_field::{Cancelled, Job};
pub use mesh::{MeshOptions, MeshStats, Mesher, mesh_scene, vertex_colors};
pub use molecule::{MoleculeFrame, MoleculeSettings, MoleculeStats, molecule_camera};
pub use node::{
    BandMethod, CloudSign, Filter, Inside, Memory, Node, Normals, SignMode, VolumeData,
};
pub use render::{
    Frame, FrameStats, Prepared, ProjectionKind, RenderSettings, RenderTarget, Renderer,
    camera_for, scene_options, shading_for,
};
pub use reuse::{Changed, Sampled, changed_boxes};
pub use sample::{
    Block, Plan, SampleOptions, SampleStats, SourceStats, band_to_grid, clamp_to_band,
};
pub use scene::{ColoredPart, MAX_DEPTH, MAX_NODES, NodeHash, Pass, Scene, SourceInfo};

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

/// A scene that cannot be read or built: which file, which node, what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
/// Its message is one line: control characters that a file put in a key or a name are shown
/// escaped ([`isokit_io::shown_text`]).
#[error("{}", isokit_io::shown_text(&if node.is_empty() {
    format!("{file}: {message}")
} else {
    format!("{file}: {node}: {message}")
}))]
pub struct SceneError {
    /// The scene file (or the name given to [`Scene::from_text`]).
    pub file: String,
    /// Path of the node in the file, e.g. `shape.union[1].sphere.radius`; empty for
    /// problems with the file as a whole.
    pub node: String,
    /// The problem.
    pub message: String,
}

impl SceneError {
    /// An error in `file` at `node`.
    pub fn new(file: &str, node: &str, message: impl Into<String>) -> Self {
        Self {
            file: file.to_owned(),
            node: node.to_owned(),
            message: message.into(),
        }
    }
}

/// Built sources kept across compilations (a live viewer recompiles a scene on every save):
/// meshes read and their kd-trees, point-cloud solves and volumes, each keyed by its file's
/// path, size and modification time (or its in-memory content) and its options, so an edit
/// elsewhere in the scene does not rebuild them.
#[derive(Default)]
pub struct SourceCache {
    pub(crate) meshes: HashMap<(PathBuf, u64), Arc<isokit_field::TriMesh>>,
    pub(crate) mesh_sdfs: HashMap<(u64, SignMode), Arc<isokit_kdtree::mesh::MeshSdf>>,
    pub(crate) clouds:
        HashMap<(u64, Option<usize>, Normals, CloudSign), Arc<isokit_points::PointSdf>>,
    pub(crate) volumes: HashMap<(u64, Filter, u32, Inside), Arc<source::VolumeField>>,
    /// Whether meshes and clouds keep their values at lattice nodes across compilations
    /// ([`SourceCache::memoizing`]).
    pub(crate) memoize: bool,
    pub(crate) memos: Arc<std::sync::Mutex<memo::MemoStore>>,
}

impl std::fmt::Debug for SourceCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SourceCache")
            .field("meshes", &self.mesh_sdfs.len())
            .field("clouds", &self.clouds.len())
            .field("volumes", &self.volumes.len())
            .finish()
    }
}

impl SourceCache {
    /// A cache that also keeps, per mesh and point-cloud source, the values it took at the
    /// nodes of the lattices it was sampled on (while its file, options and frame are
    /// unchanged; at most two lattices each): [`Scene::sample_again`] reads them back in
    /// the bricks an edit elsewhere samples again, so that only the edited part of the tree
    /// is evaluated there. The values are the ones the source gives, so the sampling is
    /// the same bit for bit. Meshes with a prism band (built per sampling) and sources
    /// under rotations or warps are not memoized. Costs 4 bytes per lattice node in the
    /// chunks of 8³ nodes that hold a value within the sampler's cap of the source's
    /// surface, plus 3/64 byte per node of the lattice, per source and kept lattice; for
    /// live editing (`isokit view`), not for one-shot runs.
    pub fn memoizing() -> Self {
        Self {
            memoize: true,
            ..Self::default()
        }
    }

    /// The number of built sources held (kd-trees, cloud solves, volumes).
    pub fn len(&self) -> usize {
        self.mesh_sdfs.len() + self.clouds.len() + self.volumes.len()
    }

    /// True when nothing is cached.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        *self = Self {
            memoize: self.memoize,
            ..Self::default()
        };
    }
}
