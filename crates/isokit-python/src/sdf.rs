//! `isokit.signed_distance(V, F, P)`: exact signed distances, closest faces and closest
//! points of query points to a triangle mesh (the kd-tree of `isokit-kdtree`).

use crate::arrays::{self, Points, Precision};
use crate::errors::value_err;
use crate::run::run;
use isokit_kdtree::mesh::{MeshOptions, MeshSdf, SignMode};
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// `isokit.signed_distance(V, F, P, sign="auto")` → `(d, face_index, closest_points)`.
///
/// Exact distances from the points `P` (`(n, 3)`, float32 or float64, any memory order) to
/// the mesh of vertices `V` (`(nv, 3)`, float32 or float64, used as given in float64) and
/// triangles `F` (`(m, 3)`, any integer dtype): `d` `(n,)` and `closest_points` `(n, 3)` in
/// `P`'s precision, `face_index` `(n,)` int64 (the triangle holding the closest point; -1 for
/// NaN rows). **Negative inside**, as libigl's `signed_distance`; trimesh's
/// `proximity.signed_distance` and pysdf are positive inside: use `-d` to compare.
///
/// `sign`: `"auto"` (pseudonormals on a watertight, consistently oriented mesh, else the
/// generalized winding number), `"pseudonormal"`, `"winding"` or `"unsigned"`.
#[pyfunction]
#[pyo3(signature = (V, F, P, sign = "auto", progress = None))]
#[expect(
    non_snake_case,
    reason = "Python's names: the issue's and libigl's V, F, P"
)]
pub fn signed_distance<'py>(
    py: Python<'py>,
    V: &Bound<'py, PyAny>,
    F: &Bound<'py, PyAny>,
    P: &Bound<'py, PyAny>,
    sign: &str,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let sign = match sign {
        "auto" => SignMode::Auto,
        "pseudonormal" => SignMode::Pseudonormal,
        "winding" => SignMode::Winding,
        "unsigned" => SignMode::Unsigned,
        s => {
            return Err(PyValueError::new_err(format!(
                "sign = {s:?} is not one of \"auto\", \"pseudonormal\", \"winding\", \"unsigned\""
            )));
        }
    };
    let verts = Points::extract(V, "V")?;
    let pts = Points::extract(P, "P")?;
    let prec: Precision = pts.precision();
    let positions = verts.to_dvec3();
    let triangles = arrays::triangles(F, positions.len())?;
    if triangles.is_empty() {
        return Err(PyValueError::new_err(
            "the mesh has no triangles (F is empty)",
        ));
    }
    let query = pts.to_dvec3();
    let q = run(py, progress, "signed_distance", |job| {
        let opts = MeshOptions {
            sign,
            ..MeshOptions::default()
        };
        let sdf = MeshSdf::from_f64(&positions, &triangles, opts).map_err(value_err)?;
        sdf.query_points(&query, true, job)
            .map_err(|_| crate::errors::Cancelled::new_err("cancelled"))
    })?;
    let faces: Vec<i64> = q
        .triangles
        .iter()
        .map(|t| t.map_or(-1, i64::from))
        .collect();
    Ok((
        arrays::vector(py, q.distances, prec),
        PyArray1::from_vec(py, faces).into_any(),
        arrays::rows3_f64(py, &q.closest, prec),
    ))
}
