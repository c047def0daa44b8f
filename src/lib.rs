//! # isokit
//!
//! A toolkit for distance-field and implicit-surface modeling: one pipeline from a
//! triangle mesh, a point cloud or an analytic shape to a sampled signed distance field.
//! This crate is the facade: it re-exports the workspace crates and ships the `isokit`
//! command-line program.
//!
//! | module | crate | what |
//! | --- | --- | --- |
//! | [`field`] | `isokit-field` | bounds, dense and brick grids, the [`Field`] trait, analytic primitives, filters, curvature, camera |
//! | [`io`] | `isokit-io` | meshes, point clouds, volumes, images; atomic writes |
//! | [`molecule`] | `isokit-molecule` | molecules: PDB and mmCIF readers, elements (radii, CPK colours), bond inference, ball-and-stick and space-filling quadric scenes |
//! | [`kdtree`] | `isokit-kdtree` | exact signed distance to triangle meshes: kd-tree with overlapping siblings, pseudonormal and winding-number signs |
//! | [`octree`] | `isokit-octree` | adaptively sampled fields in a hashed octree (and the linked octree it is measured against) |
//! | [`points`] | `isokit-points` | point cloud → signed distance: normal estimation, partition of unity of linear fields, sparse solve, far-field blend |
//! | [`levelset`] | `isokit-levelset` | CSG (with pruned evaluation), morph, offset, level-set evolution and reinitialization, watertight meshing |
//! | [`scene`] | `isokit-scene` | the scene layer and pipeline: typed nodes, scene files (JSON/TOML, JSON Schema), sources from files or memory, lazy band sampling, meshing, one `Renderer` for CPU and GPU |
//! | [`prism`] | `isokit-prism` | mesh → narrow-band signed distance by prism scan conversion, CPU (rayon) and GPU (wgpu compute), saddle-gap repair, dense or brick output |
//! | [`render`] | `isokit-render` | isosurface ray casting (blocks and bricks, empty-space skipping, adaptive sampling, refinement, tricubic curvature), G-buffer, deferred shading |
//!
//! ## Conventions
//! Signed distances are negative inside and positive outside. Grids are node-centered
//! (sample `(i, j, k)` at `origin + spacing * (i, j, k)`, x fastest) and hold f32.
//!
//! ## A first field
//! Build an analytic shape, move it, and sample it where the surface is:
//!
//! ```
//! use isokit::field::{primitives::Torus, transform::Transformed, BrickGrid, Field};
//! use glam::Vec3;
//!
//! let torus = Torus::new(Vec3::ZERO, 1.0, 0.25).unwrap();
//! let tilted = Transformed::new(torus)
//!     .rotate_axis_degrees(Vec3::X, 90.0).unwrap()
//!     .translate(Vec3::new(0.0, 0.0, 2.0)).unwrap();
//! // Exact distances survive rigid motion.
//! assert!((tilted.value(Vec3::new(1.25, 0.0, 2.0))).abs() < 1e-6);
//!
//! // A narrow band of half-width 0.05 around the surface, in bricks of 8 samples:
//! // only bricks near the surface are evaluated.
//! let b = tilted.bounds().expanded(0.5);
//! let h = 0.02;
//! let dims = (b.size() / h).ceil().as_uvec3().to_array().map(|n| n as usize + 1);
//! let band = BrickGrid::sample_field(&tilted, dims, b.min, h, 8, 1, 0.05, 0.05).unwrap();
//! assert!(band.evaluated_fraction() < 0.5);
//! ```
//!
//! ## Reading and writing files
//!
//! ```no_run
//! let mesh = isokit::io::read_mesh("data/torus.off".as_ref()).unwrap();
//! println!("{}", mesh.validate());
//! isokit::io::write_mesh("torus.stl".as_ref(), &mesh).unwrap();
//! ```
//!
//! ## Molecules
//! Atoms and bonds from a PDB or mmCIF file, as quadrics for the splatter:
//!
//! ```
//! use isokit::molecule::{
//!     MoleculeFormat, MoleculeOptions, framing_camera, molecule_scene, read_molecule_bytes,
//! };
//! use isokit::render::splat::{SplatOptions, splat};
//!
//! let water = b"\
//! HETATM    1  O   HOH A   1       0.000   0.000   0.000  1.00  0.00           O
//! HETATM    2  H1  HOH A   1       0.757   0.586   0.000  1.00  0.00           H
//! HETATM    3  H2  HOH A   1      -0.757   0.586   0.000  1.00  0.00           H
//! END
//! ";
//! let m = read_molecule_bytes(water, "water.pdb", MoleculeFormat::Pdb).unwrap();
//! assert_eq!(m.bonds.len(), 2); // inferred from covalent radii: two O–H, no H–H
//! let scene = molecule_scene(&m, &MoleculeOptions::default()).unwrap();
//! assert_eq!(scene.len(), 3 + 2 * 2); // ball-and-stick: 3 balls, 2 half-bonds per bond
//! let camera = framing_camera(&scene, 64, 48).unwrap();
//! let frame = splat(&scene, &camera, &SplatOptions::default()).unwrap();
//! assert!(frame.gbuffer.hit_count() > 0);
//! ```
#![warn(missing_docs)]

pub use isokit_field as field;
pub use isokit_io as io;
pub use isokit_kdtree as kdtree;
pub use isokit_levelset as levelset;
pub use isokit_molecule as molecule;
pub use isokit_octree as octree;
pub use isokit_points as points;
pub use isokit_prism as prism;
pub use isokit_render as render;
pub use isokit_scene as scene;

pub use isokit_field::{Aabb, BrickGrid, Field, Grid};

/// The README's Rust examples, compiled and run as doctests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
