//! # isokit-python: the `isokit` Python package's native module
//!
//! The pyo3 bindings behind `import isokit` (the pure-Python part of the package is in
//! `python/isokit/`). Every call goes through `isokit-scene`, the pipeline the command
//! uses, so a script and a scene file compute the same thing.
//!
//! - [`shape`], `isokit.Shape` (a scene tree with operators and methods), the source
//!   constructors and `load_scene`;
//! - [`field`], `isokit.Field` (a sampled lattice) and the level-set operations;
//! - [`render`], `isokit.Frame`, `isokit.Molecule`, rendering;
//! - [`sdf`], `isokit.signed_distance`;
//! - [`tets`], `isokit.read_tets` → `isokit.TetGrid`, and `isokit.mesh_labels`;
//! - [`run`], how work runs without the GIL, with Ctrl-C, progress and caught panics;
//! - [`errors`], the mapping of library errors to Python exceptions;
//! - [`vocab`], the modeling vocabulary (profiles, extrude, revolve, repetition,
//!   deformations, blends), `isokit.param` and colours;
//! - [`view`], the live viewer window behind `isokit.view`;
//! - [`arrays`], NumPy views in, NumPy arrays out.
//!
//! It is not a library for Rust code: use `isokit-scene` there.
#![warn(missing_docs)]

pub mod arrays;
pub mod errors;
pub mod field;
pub mod render;
pub mod run;
pub mod sdf;
pub mod shape;
pub mod tets;
pub mod tree;
pub mod view;
pub mod vocab;

use pyo3::prelude::*;

/// Python's `False`, the `progress` argument that reports nothing.
pub fn quiet(py: Python<'_>) -> Bound<'_, PyAny> {
    pyo3::types::PyBool::new(py, false).to_owned().into_any()
}

/// The native module `isokit._isokit`.
#[pymodule]
fn _isokit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<shape::Shape>()?;
    m.add_class::<field::Field>()?;
    m.add_class::<render::Frame>()?;
    m.add_class::<render::Molecule>()?;
    m.add_class::<vocab::Param>()?;
    m.add_class::<tets::TetGrid>()?;
    m.add("Cancelled", py.get_type::<errors::Cancelled>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add(
        "SHADING_MODES",
        isokit_render::ShadingMode::ALL
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>(),
    )?;
    m.add("GBUFFER_CHANNELS", isokit_render::GBUFFER_CHANNELS.to_vec())?;
    m.add_function(wrap_pyfunction!(shape::_primitive, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_shape_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_primitives, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_mesh_path, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_mesh_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_points_path, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_points_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_volume_path, m)?)?;
    m.add_function(wrap_pyfunction!(shape::_volume_array, m)?)?;
    m.add_function(wrap_pyfunction!(shape::union, m)?)?;
    m.add_function(wrap_pyfunction!(shape::intersection, m)?)?;
    m.add_function(wrap_pyfunction!(shape::difference, m)?)?;
    m.add_function(wrap_pyfunction!(shape::smooth_union, m)?)?;
    m.add_function(wrap_pyfunction!(shape::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(vocab::_node, m)?)?;
    m.add_function(wrap_pyfunction!(vocab::_profiles, m)?)?;
    m.add_function(wrap_pyfunction!(sdf::signed_distance, m)?)?;
    m.add_function(wrap_pyfunction!(field::morph_level_set, m)?)?;
    m.add_function(wrap_pyfunction!(render::molecule, m)?)?;
    m.add_function(wrap_pyfunction!(tets::read_tets, m)?)?;
    m.add_function(wrap_pyfunction!(tets::mesh_labels, m)?)?;
    m.add_function(wrap_pyfunction!(view::_view_main, m)?)?;
    Ok(())
}
