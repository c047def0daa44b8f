//! NumPy arrays in and out.
//!
//! Inputs are read in place through NumPy views (any memory order, no copy on the NumPy
//! side); points are float32 or float64 `(n, 3)` arrays, results come back in the input's
//! precision. Outputs hand their buffers to NumPy without a copy (`IntoPyArray`).

use glam::{DVec3, Vec3};
use numpy::ndarray::{Array2, ArrayView2};
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArray};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// The precision of an input array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// float32.
    F32,
    /// float64.
    F64,
}

/// `shape (4,), dtype int64` for messages.
fn describe(obj: &Bound<'_, PyAny>) -> String {
    match obj.cast::<PyUntypedArray>() {
        Ok(a) => format!("shape {:?}, dtype {}", a.shape(), a.dtype()),
        Err(_) => format!(
            "a {}",
            obj.get_type()
                .name()
                .map_or_else(|_| "?".to_owned(), |n| n.to_string())
        ),
    }
}

/// An `(n, 3)` float32 or float64 array, viewed in place.
pub enum Points<'py> {
    /// float32 input.
    F32(PyReadonlyArray2<'py, f32>),
    /// float64 input.
    F64(PyReadonlyArray2<'py, f64>),
}

impl<'py> Points<'py> {
    /// Reads argument `name` (any memory order).
    pub fn extract(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Self> {
        let p = if let Ok(a) = obj.extract::<PyReadonlyArray2<'py, f64>>() {
            Points::F64(a)
        } else if let Ok(a) = obj.extract::<PyReadonlyArray2<'py, f32>>() {
            Points::F32(a)
        } else {
            return Err(PyTypeError::new_err(format!(
                "{name} must be an (n, 3) array of float32 or float64, got {}",
                describe(obj)
            )));
        };
        let cols = match &p {
            Points::F32(a) => a.shape()[1],
            Points::F64(a) => a.shape()[1],
        };
        if cols != 3 {
            return Err(PyValueError::new_err(format!(
                "{name} must have shape (n, 3), got {}",
                describe(obj)
            )));
        }
        Ok(p)
    }

    /// float32 or float64.
    pub fn precision(&self) -> Precision {
        match self {
            Points::F32(_) => Precision::F32,
            Points::F64(_) => Precision::F64,
        }
    }

    /// The rows as f32 points (NaN rows stay NaN).
    pub fn to_vec3(&self) -> Vec<Vec3> {
        match self {
            Points::F32(a) => rows(a.as_array(), |r| Vec3::new(r[0], r[1], r[2])),
            Points::F64(a) => rows(a.as_array(), |r| {
                Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
            }),
        }
    }

    /// The rows as f64 points.
    pub fn to_dvec3(&self) -> Vec<DVec3> {
        match self {
            Points::F32(a) => rows(a.as_array(), |r| {
                DVec3::new(f64::from(r[0]), f64::from(r[1]), f64::from(r[2]))
            }),
            Points::F64(a) => rows(a.as_array(), |r| DVec3::new(r[0], r[1], r[2])),
        }
    }
}

fn rows<T: Copy, U>(a: ArrayView2<'_, T>, f: impl Fn([T; 3]) -> U) -> Vec<U> {
    a.outer_iter().map(|r| f([r[0], r[1], r[2]])).collect()
}

/// An `(n, 3)` integer array of triangle indices, checked against `vertices`.
pub fn triangles(obj: &Bound<'_, PyAny>, vertices: usize) -> PyResult<Vec<[u32; 3]>> {
    let np = obj.py().import("numpy")?;
    let arr = obj.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!(
            "F must be an (m, 3) integer array, got {}",
            describe(obj)
        ))
    })?;
    let kind: String = arr.dtype().getattr("kind")?.extract()?;
    if kind != "i" && kind != "u" {
        return Err(PyTypeError::new_err(format!(
            "F must be an (m, 3) integer array, got {}",
            describe(obj)
        )));
    }
    let as64 = np.call_method1("asarray", (obj, "int64"))?;
    let a: PyReadonlyArray2<'_, i64> = as64.extract().map_err(|_| {
        PyValueError::new_err(format!("F must have shape (m, 3), got {}", describe(obj)))
    })?;
    let v = a.as_array();
    if v.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "F must have shape (m, 3), got {}",
            describe(obj)
        )));
    }
    let mut out = Vec::with_capacity(v.shape()[0]);
    for (t, r) in v.outer_iter().enumerate() {
        let mut tri = [0u32; 3];
        for (o, &i) in tri.iter_mut().zip(r.iter()) {
            if i < 0 || i as u64 >= vertices as u64 {
                return Err(PyValueError::new_err(format!(
                    "F[{t}] refers to vertex {i}, but V has {vertices} vertices"
                )));
            }
            *o = i as u32;
        }
        out.push(tri);
    }
    Ok(out)
}

/// A 1-D result in the given precision.
pub fn vector<'py>(py: Python<'py>, v: Vec<f64>, p: Precision) -> Bound<'py, PyAny> {
    match p {
        Precision::F64 => PyArray1::from_vec(py, v).into_any(),
        Precision::F32 => {
            PyArray1::from_vec(py, v.into_iter().map(|x| x as f32).collect::<Vec<_>>()).into_any()
        }
    }
}

/// A 1-D f32 result in the given precision.
pub fn vector_f32<'py>(py: Python<'py>, v: Vec<f32>, p: Precision) -> Bound<'py, PyAny> {
    match p {
        Precision::F32 => PyArray1::from_vec(py, v).into_any(),
        Precision::F64 => {
            PyArray1::from_vec(py, v.into_iter().map(f64::from).collect::<Vec<_>>()).into_any()
        }
    }
}

/// An `(n, 3)` array of f64 rows in the given precision.
pub fn rows3_f64<'py>(py: Python<'py>, v: &[DVec3], p: Precision) -> Bound<'py, PyAny> {
    let n = v.len();
    match p {
        Precision::F64 => {
            let flat: Vec<f64> = v.iter().flat_map(|q| q.to_array()).collect();
            matrix(py, flat, n)
        }
        Precision::F32 => {
            let flat: Vec<f32> = v.iter().flat_map(|q| q.as_vec3().to_array()).collect();
            matrix(py, flat, n)
        }
    }
}

/// An `(n, 3)` array of f32 rows in the given precision.
pub fn rows3_f32<'py>(py: Python<'py>, v: &[Vec3], p: Precision) -> Bound<'py, PyAny> {
    let n = v.len();
    match p {
        Precision::F32 => matrix(py, v.iter().flat_map(|q| q.to_array()).collect(), n),
        Precision::F64 => matrix(
            py,
            v.iter().flat_map(|q| q.as_dvec3().to_array()).collect(),
            n,
        ),
    }
}

/// A flat row-major buffer as an `(n, 3)` array, without a copy.
pub fn matrix<T: numpy::Element>(py: Python<'_>, flat: Vec<T>, n: usize) -> Bound<'_, PyAny> {
    match Array2::from_shape_vec((n, 3), flat) {
        Ok(a) => PyArray2::from_owned_array(py, a).into_any(),
        // Lengths are ours; unreachable, but never a panic.
        Err(_) => PyArray2::<T>::zeros(py, [0, 3], false).into_any(),
    }
}
