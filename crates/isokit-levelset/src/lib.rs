//! # isokit-levelset
//!
//! Level-set modeling on distance fields (002 Ch. 2 and Sec. 6.4):
//!
//! - [`csg`]: union, intersection, difference and complement with the corrected operators
//!   of ERRATA 1 (negative inside), smooth variants with a blend radius, offsets, opening
//!   and closing; on [`isokit_field::Field`]s and on sampled grids.
//! - [`morph`]: linear interpolation of two distance fields and a level-set morph.
//! - [`evolve`]: level-set evolution with an upwind (Godunov) scheme on a narrow band.
//! - [`reinit`]: reinitialization to a signed distance by fast marching and fast sweeping.
//! - [`meshing`]: watertight, 2-manifold isosurface meshes for export.
//! - [`scene`]: scene files (JSON or TOML) describing CSG trees, evaluated lazily into a
//!   [`isokit_field::BrickGrid`] of the band.

pub mod csg;
pub mod evolve;
pub mod meshing;
pub mod morph;
pub mod reinit;
pub mod scene;
