//! # isokit-kdtree: exact distances to triangle meshes
//!
//! The exact reference of isokit and the per-sample path of adaptive sampling:
//!
//! - [`tree::KdTree`]: the kd-tree with overlapping siblings of 002 Sec. 4.1 over anything
//!   with a bounding box. Each node keeps two planes (the left subtree's upper bound and
//!   the right subtree's lower bound), so siblings may overlap or leave a gap; primitives
//!   too big for either child stay at the node. `max_overlap = 0` gives the classic
//!   kd-tree it is measured against. Queries: nearest, k nearest, all within a radius,
//!   first ray hit, each with [`tree::QueryStats`].
//! - [`triangle`]: closest point on a triangle in f64 (feature and barycentrics; degenerate
//!   triangles reduce to segments or points), signed solid angle, ray–triangle.
//! - [`pseudonormal::Pseudonormals`]: angle-weighted pseudonormals (Bærentzen and Aanæs),
//!   the exact sign for watertight, consistently oriented meshes.
//! - [`mesh::MeshSdf`]: a mesh as an exact signed distance [`isokit_field::Field`], with the
//!   sign from pseudonormals or the hierarchical generalized winding number (Barill et al.
//!   2018) for open, non-manifold or self-intersecting meshes.
//!
//! Not here: sampling whole grids fast (the prism scan conversion of `isokit-sdt` does
//! narrow bands per triangle) and file formats (`isokit-io`).
//!
//! ## Precision
//! Vertices are f32 as loaded; every distance, closest point and solid angle is computed
//! in f64 from them, so distances are exact to f64 rounding (about 1e-15 relative) and
//! round once when returned as f32 through the `Field` trait.
#![warn(missing_docs)]

pub mod mesh;
pub mod pseudonormal;
pub mod tree;
pub mod triangle;

pub use mesh::{
    GridFill, LazyFill, MeshError, MeshHit, MeshOptions, MeshSdf, SignMethod, SignMode,
};
pub use tree::{BuildParams, KdTree, QueryStats};
