//! # isokit-field: the core of isokit
//!
//! Bounds ([`Aabb`]), dense node-centered grids ([`Grid`]) and sparse brick grids
//! ([`BrickGrid`]), the [`Field`] trait that every distance source implements, analytic
//! primitives with exact signed distances ([`primitives`]), rigid transforms and uniform
//! scale that keep distances exact ([`transform`]), reconstruction filters on grids
//! ([`filter`]: trilinear, tricubic B-spline value/gradient/Hessian by direct 64-tap
//! convolution and by the 8-fetch scheme, Catmull-Rom), differential geometry of level
//! sets ([`curvature`]) and a [`Camera`]; the plain geometry the other crates exchange:
//! triangle meshes ([`TriMesh`], with a validation report), point clouds ([`PointCloud`])
//! and tetrahedral grids with point scalars ([`TetGrid`], with a report on its cells), and
//! small generated ones for tests ([`generate`]).
//!
//! It is not the place for file formats, CSG or rendering: those live in the other isokit
//! crates and build on these types.
//!
//! ## Conventions
//! - Sign: negative inside, positive outside.
//! - Grids are node-centered: sample `(i, j, k)` is at `origin + spacing * (i, j, k)`, x fastest.
//! - Samples are f32; analytic primitives evaluate in f64 and round once.
//!
//! ## Choosing a grid
//! [`Grid`] is dense and simple: use it for small volumes and as the exchange format with
//! files. [`BrickGrid`] stores only the bricks near the surface (with an apron for filtering
//! and per-brick min/max for skipping): use it for narrow bands and for rendering.
#![warn(missing_docs)]

mod aabb;
mod brick;
mod camera;
mod cloud;
pub mod curvature;
mod error;
mod field;
pub mod filter;
pub mod generate;
mod grid;
mod job;
pub mod memory;
pub mod mesh;
pub mod morton;
pub mod primitives;
pub mod profile;
pub mod rng;
pub mod segmentation;
pub mod tet;
pub mod transform;

pub use aabb::Aabb;
pub use brick::{BrickGrid, BrickInfo, Reuse};
pub use camera::{Camera, Projection, Ray};
pub use cloud::PointCloud;
pub use error::FieldError;
pub use field::{
    DistanceBox, Field, box_lower_bound, fill_slices, finite_difference_hessian, sample_field,
    sample_into, sample_into_job, value_clamped,
};
pub use grid::{Grid, MAX_AXIS, MAX_SAMPLES, check_grid_budget, checked_len, finite_min_max};
pub use job::{Cancelled, Counter, Job, ProgressFn};
pub use mesh::{DEGENERATE_REL_TOL, MeshReport, TriMesh};
pub use tet::{TetFaces, TetGrid, TetReport, TetSplit};
