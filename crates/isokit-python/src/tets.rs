//! Tetrahedral grids and label volumes from Python: `isokit.read_tets` → `isokit.TetGrid`
//! (marching tetrahedra, ray casting and volume rendering through the cells, as `isokit mesh`
//! and `isokit render` do for `.vtk`/`.vtu`), and `isokit.mesh_labels` (surface nets on a
//! label volume, each triangle with the two regions it separates).

use crate::errors::{io_err, value_err};
use crate::render::{Frame, RenderArgs, with_renderer};
use crate::run::{guarded, run};
use crate::shape::{grid_from_array, mesh_tuple, vec3_arg};
use isokit_field::curvature::Inside;
use isokit_render::dvr::TransferFunction;
use isokit_render::tets::dvr::{TetDvrOptions, TetVolume};
use isokit_render::tets::{TetCaster, TetNormals};
use isokit_render::{Shading, ShadingMode, camera_uniforms, shade};
use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A tetrahedral grid with one scalar per point (`isokit.read_tets`).
#[pyclass(name = "TetGrid", module = "isokit", frozen)]
pub struct TetGrid {
    grid: isokit_field::TetGrid,
}

/// `isokit.read_tets(path, array=None)`: a tetrahedral grid from a VTK legacy `.vtk` (ASCII
/// or binary) or VTK XML `.vtu` file (raw, base64 or zlib-compressed appended data), with
/// the point array `array` (default: the first with one component). Only tetrahedral cells
/// are taken; another cell type is refused with its name.
#[pyfunction]
#[pyo3(signature = (path, array = None))]
pub fn read_tets(py: Python<'_>, path: PathBuf, array: Option<&str>) -> PyResult<TetGrid> {
    let grid = py.detach(|| guarded(|| isokit_io::read_tets(&path, array).map_err(io_err)))?;
    Ok(TetGrid { grid })
}

/// `"below"` or `"above"`.
fn inside_arg(inside: &str) -> PyResult<Inside> {
    match inside {
        "below" => Ok(Inside::Below),
        "above" => Ok(Inside::Above),
        other => Err(PyValueError::new_err(format!(
            "inside = {other:?} is not one of \"below\", \"above\""
        ))),
    }
}

impl TetGrid {
    /// The camera `args` ask for, framing the grid's bounds by default.
    fn camera(&self, args: &RenderArgs) -> PyResult<isokit_field::Camera> {
        let s = &args.settings;
        isokit_scene::camera_for(
            s.camera.as_ref(),
            self.grid.bounds(),
            s.projection,
            s.width,
            s.height,
        )
        .map_err(value_err)
    }

    /// `iso`, or 0 where the values reach it, else the middle of their range.
    fn iso(&self, iso: Option<f32>) -> PyResult<f32> {
        let Some((lo, hi)) = isokit_field::finite_min_max(self.grid.values()) else {
            return Err(PyValueError::new_err(format!(
                "no finite value in array {}",
                self.grid.array()
            )));
        };
        Ok(iso.unwrap_or(if lo <= 0.0 && 0.0 <= hi {
            0.0
        } else {
            0.5 * (lo + hi)
        }))
    }
}

#[pymethods]
impl TetGrid {
    /// The points, a float32 `(n, 3)` array.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let flat: Vec<f32> = self
            .grid
            .points()
            .iter()
            .flat_map(|p| p.to_array())
            .collect();
        crate::arrays::matrix(py, flat, self.grid.points().len())
    }

    /// The cells, an int64 `(m, 4)` array of point indices.
    #[getter]
    fn cells<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let flat: Vec<i64> = self
            .grid
            .tets()
            .iter()
            .flat_map(|t| t.map(i64::from))
            .collect();
        match Array2::from_shape_vec((self.grid.tets().len(), 4), flat) {
            Ok(a) => PyArray2::from_owned_array(py, a).into_any(),
            Err(_) => PyArray2::<i64>::zeros(py, [0, 4], false).into_any(),
        }
    }

    /// The point values, a float32 `(n,)` array.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        PyArray1::from_slice(py, self.grid.values())
    }

    /// The name of the point array read.
    #[getter]
    fn array(&self) -> String {
        self.grid.array().to_string()
    }

    /// What `isokit info` reports of the grid: `cells`, `points`, `inverted` and
    /// `degenerate` cells, the values' `range`.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let r = self.grid.report();
        let d = PyDict::new(py);
        d.set_item("cells", self.grid.tets().len())?;
        d.set_item("points", self.grid.points().len())?;
        d.set_item("inverted", r.inverted)?;
        d.set_item("degenerate", r.degenerate)?;
        d.set_item("range", isokit_field::finite_min_max(self.grid.values()))?;
        Ok(d)
    }

    /// The isosurface by marching tetrahedra (`iso` default 0, or the middle of the range
    /// where the values do not reach 0), as an `isokit.Mesh`, the triangles facing the
    /// `inside`'s other side.
    #[pyo3(signature = (iso = None, inside = "below"))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        iso: Option<f32>,
        inside: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let iso = self.iso(iso)?;
        let above = inside_arg(inside)? == Inside::Above;
        let mesh = py.detach(|| {
            guarded(|| {
                if above {
                    // Marching tetrahedra put the inside below the isovalue.
                    let values = self.grid.values().iter().map(|v| -v).collect();
                    let flipped = isokit_field::TetGrid::new(
                        self.grid.points().to_vec(),
                        self.grid.tets().to_vec(),
                        values,
                        self.grid.array(),
                    )
                    .map_err(value_err)?;
                    isokit_levelset::tets::mesh_tets(&flipped, -iso).map_err(value_err)
                } else {
                    isokit_levelset::tets::mesh_tets(&self.grid, iso).map_err(value_err)
                }
            })
        })?;
        mesh_tuple(py, &mesh, py.None().into_bound(py))
    }

    /// The isosurface ray cast through the cells (no resampling; `isokit render GRID.vtu`),
    /// shaded (`phong`, `tone`, `normal` or `reflection`: the surface is piecewise planar,
    /// without curvature), as an `isokit.Frame`.
    #[pyo3(signature = (iso = None, inside = "below", width = 512, height = 512, shading = None, camera = None, backend = "auto", projection = "perspective"))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn render(
        &self,
        py: Python<'_>,
        iso: Option<f32>,
        inside: &str,
        width: u32,
        height: u32,
        shading: Option<&str>,
        camera: Option<&Bound<'_, PyAny>>,
        backend: &str,
        projection: &str,
    ) -> PyResult<Frame> {
        let iso = self.iso(iso)?;
        let inside = inside_arg(inside)?;
        let args = RenderArgs::parse(
            width, height, shading, camera, backend, None, None, projection, None,
        )?;
        let mode = args.settings.mode.unwrap_or(ShadingMode::Phong);
        if mode.uses_curvature() {
            return Err(PyValueError::new_err(format!(
                "shading = {:?}: the isosurface of a tetrahedral grid is piecewise planar and has no curvature; use phong, tone, normal or reflection",
                mode.name()
            )));
        }
        let camera = self.camera(&args)?;
        let u = camera_uniforms(&camera).map_err(value_err)?;
        let t = std::time::Instant::now();
        let (gb, backend) = py.detach(|| {
            guarded(|| {
                let caster = TetCaster::new(&self.grid, iso, inside, TetNormals::Smooth)
                    .map_err(value_err)?;
                with_renderer(args.backend, |r| {
                    let backend = r.backend();
                    let gb = match r.gpu() {
                        Some(g) => g.render_tets(&caster, &u),
                        None => caster.render(&u, &isokit_field::Job::new()),
                    };
                    Ok((gb.map_err(value_err)?, backend))
                })
            })
        })?;
        let seconds = t.elapsed().as_secs_f64();
        let sh = Shading {
            mode,
            ..Shading::default()
        };
        let image = shade(&gb, &u, &sh).map_err(value_err)?;
        let hits = gb.pixels().iter().filter(|p| p.is_hit()).count();
        let stats = serde_json::json!({
            "device": backend,
            "cells": self.grid.tets().len(),
            "iso": iso,
            "hits": hits,
            "seconds": seconds,
        });
        Ok(Frame::from_surface(image, gb, stats))
    }

    /// Direct volume rendering through the cells (`isokit render GRID.vtu --mode dvr`): each
    /// cell's segment of a ray one entry of the 3D pre-integration table (`table_size`
    /// values per axis; 0 integrates each segment alone), or post-classified; `tf` a preset
    /// name, a JSON file's path or a dict `{"points": [[value, r, g, b, sigma], ...]}`.
    #[pyo3(signature = (tf, width = 512, height = 512, classification = "preintegrated", shading = None, camera = None, backend = "auto", projection = "perspective", table_size = 128))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn render_volume(
        &self,
        py: Python<'_>,
        tf: &Bound<'_, PyAny>,
        width: u32,
        height: u32,
        classification: &str,
        shading: Option<&str>,
        camera: Option<&Bound<'_, PyAny>>,
        backend: &str,
        projection: &str,
        table_size: usize,
    ) -> PyResult<Frame> {
        let volume = py.detach(|| guarded(|| Ok(TetVolume::new(&self.grid))))?;
        let range = isokit_field::finite_min_max(self.grid.values()).unwrap_or((0.0, 1.0));
        let (tf, classification, shade) = crate::render::volume_args(
            py,
            tf,
            |name| TransferFunction::load_for(name, range, volume.mean_edge()),
            classification,
            shading,
        )?;
        let args = RenderArgs::parse(
            width, height, None, camera, backend, None, None, projection, None,
        )?;
        let camera = self.camera(&args)?;
        let opts = TetDvrOptions {
            classification,
            shade,
            table_size,
            ..TetDvrOptions::default()
        };
        let t = std::time::Instant::now();
        let (img, backend) = py.detach(|| {
            guarded(|| {
                with_renderer(args.backend, |r| {
                    let backend = r.backend();
                    let img = match r.gpu() {
                        Some(g) => g.render_tets_dvr(&volume, &camera, &tf, &opts),
                        None => volume.render(&camera, &tf, &opts, &isokit_field::Job::new()),
                    };
                    Ok((img.map_err(value_err)?, backend))
                })
            })
        })?;
        let stats = img.stats(backend, t.elapsed().as_secs_f64());
        Ok(Frame::from_volume(img, camera, stats))
    }

    fn __repr__(&self) -> String {
        format!(
            "isokit.TetGrid({} cells, {} points, array {:?})",
            self.grid.tets().len(),
            self.grid.points().len(),
            self.grid.array()
        )
    }
}

/// `isokit.mesh_labels(labels, spacing=1.0, origin=0.0, smooth=16, progress=None)`: the
/// surface between the regions of a label volume (a 3-D integer or float array of shape
/// `(nz, ny, nx)`, whole numbers, 0 outside) by surface nets, as `isokit mesh --labels`
/// makes it: non-manifold where three or more regions meet, relaxed `smooth` times. An
/// `isokit.Mesh` whose `stats["regions"]` is an int32 `(m, 2)` array: the two regions each
/// triangle separates (the lower first; the normal points towards it).
#[pyfunction]
#[pyo3(signature = (labels, spacing = None, origin = None, smooth = 16, progress = None))]
pub fn mesh_labels<'py>(
    py: Python<'py>,
    labels: &Bound<'py, PyAny>,
    spacing: Option<&Bound<'py, PyAny>>,
    origin: Option<&Bound<'py, PyAny>>,
    smooth: usize,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let spacing = spacing.map_or(Ok([1.0; 3]), |s| vec3_arg(s, "spacing"))?;
    let origin = origin.map_or(Ok([0.0; 3]), |o| vec3_arg(o, "origin"))?;
    let grid = grid_from_array(labels, origin, 1.0)?;
    let opts = isokit_levelset::labels::LabelOptions {
        smoothing: smooth,
        ..Default::default()
    };
    let m = run(py, progress, "labels", |job| {
        isokit_levelset::labels::label_surface_spaced(
            grid.dims(),
            origin.into(),
            spacing.into(),
            grid.data(),
            &opts,
            job,
        )
        .map_err(value_err)
    })?;
    let flat: Vec<i32> = m.regions.iter().flatten().copied().collect();
    let regions = match Array2::from_shape_vec((m.regions.len(), 2), flat) {
        Ok(a) => PyArray2::from_owned_array(py, a).into_any(),
        Err(_) => PyArray2::<i32>::zeros(py, [0, 2], false).into_any(),
    };
    let stats = PyDict::new(py);
    stats.set_item("regions", regions)?;
    mesh_tuple(py, &m.mesh, stats.into_any())
}
