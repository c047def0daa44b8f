//! # isokit-levelset
//!
//! Level-set modeling on distance fields (002 Ch. 2 and Sec. 6.4):
//!
//! - [`csg`]: union, intersection, difference and complement with the corrected operators
//!   of ERRATA 1 (negative inside), smooth variants with a blend radius, plain offsets; on
//!   [`isokit_field::Field`]s and on sampled grids.
//! - [`offset`]: offsets that re-distance the result, opening and closing, on grids.
//! - [`morph`]: linear interpolation of two distance fields ([`evolve`] has the level-set
//!   morph that moves one surface into the other).
//! - [`evolve`]: level-set evolution with an upwind (Godunov) scheme on a narrow band.
//! - [`reinit`]: reinitialization to a signed distance by fast marching and fast sweeping.
//! - [`meshing`]: watertight, 2-manifold isosurface meshes for export (marching cubes).
//! - [`dual`]: dual contouring with Hermite data, sharp edges and corners from exact fields.
//! - [`tets`]: marching tetrahedra on unstructured tetrahedral grids, exact in each cell.
//! - [`labels`]: the non-manifold surface between the regions of a label volume (surface
//!   nets on labels), each face carrying its two regions.
//! - [`segmented`]: segmented distance fields (003): surfaces with boundaries and junctions
//!   in one volume, their meshes and their morph.
//! - [`intersect`]: exact self-intersection test of a triangle mesh (Shewchuk's predicates).
//! - [`weld`]: merging coincident vertices, as mesh tools do on load, to check meshes by it.
//! - [`profile`]: solids from 2D profiles (extrude, revolve), exact for exact profiles.
//! - [`deform`]: twist, bend, taper and elongate, each with its distance bound derived.
//! - [`repeat`]: infinite repetition, finite arrays and circular arrays, exact for shapes
//!   smaller than their cells.
//!
//! Every combinator answers the questions lazy evaluation asks (a lower bound from boxes,
//! the value clamped to a cap; see [`isokit_field::Field::value_clamped`]), so a tree of
//! them is evaluated only where it matters. Scene files that describe such trees, and their
//! sources (meshes, clouds, volumes), are the `isokit-scene` crate's: this crate has no file
//! formats.

pub mod csg;
pub mod deform;
pub mod dual;
pub mod evolve;
pub mod intersect;
pub mod labels;
pub mod meshing;
pub mod morph;
pub mod offset;
pub mod profile;
pub mod reinit;
pub mod repeat;
pub mod segmented;
pub mod tets;
pub mod weld;
