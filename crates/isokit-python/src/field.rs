//! `isokit.Field`: a sampled field on a lattice (values as a NumPy array, origin, spacing,
//! band), with the level-set operations of `isokit-levelset`.

use crate::errors::{io_err, value_err};
use crate::render::{self, Frame, RenderArgs};
use crate::run::{guarded, run};
use crate::shape::{Shape, grid_from_array, vec3_arg};
use glam::Vec3;
use isokit_field::Grid;
use isokit_io::lattice::Lattice;
use isokit_levelset::evolve::{EvolveOptions, MorphOptions, Scheme, Speed};
use isokit_levelset::reinit::{Order, ReinitMethod, ReinitOptions};
use isokit_scene::node::VolumeNode;
use isokit_scene::{Filter, Inside, Node, VolumeData};
use numpy::ndarray::Array3;
use numpy::prelude::*;
use numpy::{PyArray3, PyReadonlyArray3};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;

/// A JSON value as the Python object `json.loads` makes of it.
pub fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(value_err)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A sampled field: `values[k, j, i]` is the sample at `origin + spacing * (i, j, k)`.
///
/// The values array has shape `(nz, ny, nx)` in C order (x fastest in memory; the NPY
/// sidecar's `axis_order "zyx"`). A band-sampled field holds exact values within `band` of
/// the surface and `±band` beyond. Negative inside (`inside == "below"`), unless made from
/// a density with `inside="above"`. Level-set operations (`reinit`, `evolve`, `offset`, …)
/// return new fields; the values array itself may be edited in place.
#[pyclass(frozen, module = "isokit", name = "Field")]
pub struct Field {
    values: Py<PyArray3<f32>>,
    origin: [f32; 3],
    spacing: f32,
    band: Option<f32>,
    inside: Inside,
    sign: Option<String>,
    stats: Option<Py<PyAny>>,
}

fn inside_name(i: Inside) -> &'static str {
    match i {
        Inside::Below => "below",
        Inside::Above => "above",
    }
}

fn reinit_method(s: &str) -> PyResult<ReinitMethod> {
    match s {
        "fast_marching" => Ok(ReinitMethod::FastMarching),
        "fast_sweeping" => Ok(ReinitMethod::FastSweeping),
        _ => Err(PyValueError::new_err(format!(
            "method = {s:?} is not one of \"fast_marching\", \"fast_sweeping\""
        ))),
    }
}

impl Field {
    /// A field holding `grid`'s samples (handed to NumPy without a copy).
    pub fn from_grid(
        py: Python<'_>,
        grid: Grid,
        band: Option<f32>,
        inside: Inside,
        sign: Option<String>,
        stats: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        let [nx, ny, nz] = grid.dims();
        let (origin, spacing) = (grid.origin().to_array(), grid.spacing());
        let arr = Array3::from_shape_vec((nz, ny, nx), grid.into_data()).map_err(value_err)?;
        Ok(Field {
            values: PyArray3::from_owned_array(py, arr).unbind(),
            origin,
            spacing,
            band,
            inside,
            sign,
            stats: stats.map(Bound::unbind),
        })
    }

    /// The samples as a grid (copied out of the array, whatever its memory order now).
    pub fn grid(&self, py: Python<'_>) -> PyResult<Grid> {
        let a: PyReadonlyArray3<'_, f32> = self.values.bind(py).readonly();
        let v = a.as_array();
        let dims = [v.shape()[2], v.shape()[1], v.shape()[0]];
        let data: Vec<f32> = v.iter().copied().collect();
        Grid::from_data(dims, Vec3::from(self.origin), self.spacing, data).map_err(value_err)
    }

    fn derived(
        &self,
        py: Python<'_>,
        grid: Grid,
        band: Option<f32>,
        stats: Option<serde_json::Value>,
    ) -> PyResult<Field> {
        let stats = stats.map(|s| json_to_py(py, &s)).transpose()?;
        Field::from_grid(py, grid, band, self.inside, self.sign.clone(), stats)
    }

    fn distance_field(&self, op: &str) -> PyResult<()> {
        if self.inside == Inside::Above {
            return Err(PyValueError::new_err(format!(
                "{op} needs a distance field (inside below its surface); this field has \
                 inside=\"above\": make one of -values first"
            )));
        }
        Ok(())
    }

    fn band_arg(&self, band: Option<f32>) -> PyResult<f32> {
        match band.or(self.band) {
            None => Ok(f32::INFINITY),
            Some(b) if b > 0.0 && !b.is_nan() => Ok(b),
            Some(b) => Err(PyValueError::new_err(format!(
                "band = {b} must be positive"
            ))),
        }
    }

    fn offsets(
        &self,
        py: Python<'_>,
        op: &str,
        radius: f32,
        band: Option<f32>,
        method: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.distance_field(op)?;
        let opts = isokit_levelset::offset::OffsetOptions {
            band: self.band_arg(band)?,
            method: reinit_method(method)?,
        };
        let mut grid = self.grid(py)?;
        use isokit_levelset::offset as o;
        let grid = run(py, progress, op, |_| {
            match op {
                "offset" => o::offset(&mut grid, radius, &opts),
                "dilate" => o::dilate(&mut grid, radius, &opts),
                "erode" => o::erode(&mut grid, radius, &opts),
                "opening" => o::opening(&mut grid, radius, &opts),
                _ => o::closing(&mut grid, radius, &opts),
            }
            .map_err(value_err)?;
            Ok(grid)
        })?;
        let band = opts.band.is_finite().then_some(opts.band);
        self.derived(py, grid, band, None)
    }
}

#[pymethods]
impl Field {
    /// A field from a `(nz, ny, nx)` array of samples (any float or integer dtype, stored as
    /// float32): sample `values[k, j, i]` sits at `origin + spacing * (i, j, k)`.
    #[new]
    #[pyo3(signature = (values, origin = None, spacing = None, band = None, inside = "below"))]
    fn py_new(
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        origin: Option<&Bound<'_, PyAny>>,
        spacing: Option<f32>,
        band: Option<f32>,
        inside: &str,
    ) -> PyResult<Field> {
        let origin = origin.map_or(Ok([0.0; 3]), |o| vec3_arg(o, "origin"))?;
        let grid = grid_from_array(values, origin, spacing.unwrap_or(1.0))?;
        let inside = match inside {
            "below" => Inside::Below,
            "above" => Inside::Above,
            s => {
                return Err(PyValueError::new_err(format!(
                    "inside = {s:?} is not one of \"below\", \"above\""
                )));
            }
        };
        if let Some(b) = band
            && !(b.is_finite() && b > 0.0)
        {
            return Err(PyValueError::new_err(format!(
                "band = {b} must be finite and positive"
            )));
        }
        Field::from_grid(py, grid, band, inside, None, None)
    }

    /// The samples, a float32 array of shape `(nz, ny, nx)` (x fastest in memory): the
    /// field's own array, not a copy.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        self.values.bind(py).clone()
    }

    /// World position of sample `(0, 0, 0)`, `(x, y, z)`.
    #[getter]
    fn origin(&self) -> (f32, f32, f32) {
        (self.origin[0], self.origin[1], self.origin[2])
    }

    /// Distance between neighbouring samples (the same along every axis).
    #[getter]
    fn spacing(&self) -> f32 {
        self.spacing
    }

    /// Samples along x, y, z: `(nx, ny, nz)` (the array's shape reversed).
    #[getter]
    fn dims(&self, py: Python<'_>) -> (usize, usize, usize) {
        let s = self.values.bind(py).shape().to_vec();
        (s[2], s[1], s[0])
    }

    /// The narrow band's half-width (values are `±band` beyond it), or None.
    #[getter]
    fn band(&self) -> Option<f32> {
        self.band
    }

    /// `"below"` (a distance field, negative inside) or `"above"` (a density).
    #[getter]
    fn inside(&self) -> &'static str {
        inside_name(self.inside)
    }

    /// The box spanned by the samples, `((xmin, ymin, zmin), (xmax, ymax, zmax))`.
    #[getter]
    fn bounds(&self, py: Python<'_>) -> ([f32; 3], [f32; 3]) {
        let (nx, ny, nz) = self.dims(py);
        let o = Vec3::from(self.origin);
        let hi = o + self.spacing * Vec3::new((nx - 1) as f32, (ny - 1) as f32, (nz - 1) as f32);
        (self.origin, hi.to_array())
    }

    /// What the sampling (or the last operation) reported, as a dict; None when unknown.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        self.stats.as_ref().map(|s| s.bind(py).clone())
    }

    /// The share of the dense lattice's samples that the sampling evaluated (1.0 for a
    /// dense sampling; None for fields not sampled from a shape).
    #[getter]
    fn dense_fraction(&self, py: Python<'_>) -> PyResult<Option<f64>> {
        match &self.stats {
            Some(s) => match s.bind(py).get_item("dense_fraction") {
                Ok(v) => Ok(Some(v.extract()?)),
                Err(_) => Ok(None),
            },
            None => Ok(None),
        }
    }

    #[pyo3(signature = (dtype = None, copy = None))]
    fn __array__<'py>(
        &self,
        py: Python<'py>,
        dtype: Option<&Bound<'py, PyAny>>,
        copy: Option<bool>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let np = py.import("numpy")?;
        let v = self.values.bind(py).clone().into_any();
        let kwargs = pyo3::types::PyDict::new(py);
        if let Some(d) = dtype {
            kwargs.set_item("dtype", d)?;
        }
        if copy == Some(true) {
            kwargs.set_item("copy", true)?;
        }
        np.call_method("array", (v,), Some(&kwargs))
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let (nx, ny, nz) = self.dims(py);
        let band = self.band.map_or("None".to_owned(), |b| b.to_string());
        format!(
            "isokit.Field(dims=({nx}, {ny}, {nz}), origin={:?}, spacing={}, band={band}, inside={:?})",
            self.origin,
            self.spacing,
            self.inside()
        )
    }

    /// Writes the field: `.nrrd` (gzip-compressed float, origin and spacing in the header,
    /// band, inside and sign as key/value pairs)
    /// or `.npy` (float32, shape `(nz, ny, nx)`) with its lattice in the sidecar
    /// `<path>.json` (`origin`, `spacing`, `dims`, `axis_order`, `band`, `inside`, `sign`),
    /// which `isokit` reads back.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let grid = self.grid(py)?;
        let volume = isokit_io::Volume::from(grid);
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let lattice = Lattice {
            band: self.band,
            inside: match self.inside {
                Inside::Below => isokit_field::curvature::Inside::Below,
                Inside::Above => isokit_field::curvature::Inside::Above,
            },
            sign: self.sign.clone(),
            ..Lattice::of(&volume)
        };
        py.detach(|| {
            guarded(|| match ext.as_deref() {
                // One writer for the command line and Python: the NPY sidecar, or the
                // NRRD header's band/inside/sign key/values.
                Some("nrrd" | "npy") => isokit_io::write_volume_with(
                    &path,
                    &volume,
                    &lattice,
                    isokit_io::NrrdEncoding::Gzip,
                )
                .map_err(io_err),
                _ => Err(PyValueError::new_err(format!(
                    "{}: unrecognized extension; a field is saved as .nrrd or .npy",
                    path.display()
                ))),
            })
        })
    }

    /// The field as a shape (read by `filter`: `"trilinear"`, `"cubic_bspline"` or
    /// `"catmull_rom"`; surface at `iso`), to combine with other shapes.
    #[pyo3(signature = (filter = "trilinear", iso = 0.0))]
    fn to_shape(&self, py: Python<'_>, filter: &str, iso: f32) -> PyResult<Shape> {
        let filter: Filter = serde_json::from_value(serde_json::Value::String(filter.into()))
            .map_err(|_| {
                PyValueError::new_err(format!(
                    "filter = {filter:?} is not one of \"trilinear\", \"cubic_bspline\", \"catmull_rom\""
                ))
            })?;
        let grid = self.grid(py)?;
        Ok(Shape::new(Node::Volume(VolumeNode {
            path: None,
            filter,
            iso,
            inside: self.inside,
            data: Some(isokit_scene::Memory::volume(VolumeData::Grid(grid))),
        })))
    }

    /// Reinitializes the field to a signed distance to its zero set (Sigg 2006, Sec. 2.3.3
    /// and 2.4.3) and returns the new field. `band`: half-width of the result (default the
    /// field's band, else the whole grid); `method`: `"fast_marching"` or `"fast_sweeping"`;
    /// `order`: 1 or 2 (upwind differences); `tolerance` and `max_iterations`: fast
    /// sweeping's stopping rule. The stats say what it did.
    #[pyo3(signature = (band = None, method = "fast_marching", order = 2, tolerance = 1e-4, max_iterations = 32, progress = None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn reinit(
        &self,
        py: Python<'_>,
        band: Option<f32>,
        method: &str,
        order: u8,
        tolerance: f32,
        max_iterations: usize,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.distance_field("reinit")?;
        let opts = ReinitOptions {
            method: reinit_method(method)?,
            order: match order {
                1 => Order::First,
                2 => Order::Second,
                o => {
                    return Err(PyValueError::new_err(format!("order = {o} must be 1 or 2")));
                }
            },
            band: self.band_arg(band)?,
            tolerance,
            max_iterations,
        };
        let mut grid = self.grid(py)?;
        let (grid, st) = run(py, progress, "reinit", |_| {
            let st = isokit_levelset::reinit::reinitialize(&mut grid, &opts).map_err(value_err)?;
            Ok((grid, st))
        })?;
        let stats = serde_json::json!({
            "method": method,
            "interface_nodes": st.interface_nodes,
            "updated_nodes": st.updated_nodes,
            "clamped_nodes": st.clamped_nodes,
            "iterations": st.iterations,
            "last_change": st.last_change,
            "converged": st.converged,
        });
        let band = opts.band.is_finite().then_some(opts.band);
        self.derived(py, grid, band, Some(stats))
    }

    /// Evolves the surface for time `t` under the speed `speed` along its outward normal
    /// (Sigg 2006, Sec. 2.3; upwind level-set evolution on a narrow band) and returns the new
    /// field. `speed`: a number (`> 0` grows, `< 0` shrinks) or a shape whose value at each
    /// point is the speed there; `curvature`: adds mean-curvature flow `-curvature·κ`.
    /// `scheme`: `"upwind1"` or `"weno5"`; `cfl`, `band`, `reinit_every`, `reinit_method`,
    /// `extend_speed`, `final_reinit`, `max_steps`: the Rust API's `EvolveOptions`.
    #[pyo3(signature = (speed = None, t = 0.0, curvature = 0.0, scheme = "upwind1", cfl = 0.5, band = None, reinit_every = 0, reinit_method = "fast_marching", extend_speed = true, final_reinit = true, max_steps = 1_000_000, progress = None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn evolve(
        &self,
        py: Python<'_>,
        speed: Option<&Bound<'_, PyAny>>,
        t: f32,
        curvature: f32,
        scheme: &str,
        cfl: f32,
        band: Option<f32>,
        reinit_every: usize,
        reinit_method: &str,
        extend_speed: bool,
        final_reinit: bool,
        max_steps: usize,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.distance_field("evolve")?;
        let opts = EvolveOptions {
            cfl,
            band,
            reinit_every,
            reinit_method: self::reinit_method(reinit_method)?,
            scheme: match scheme {
                "upwind1" => Scheme::Upwind1,
                "weno5" => Scheme::Weno5,
                s => {
                    return Err(PyValueError::new_err(format!(
                        "scheme = {s:?} is not one of \"upwind1\", \"weno5\""
                    )));
                }
            },
            extend_speed,
            final_reinit,
            max_steps,
        };
        enum SpeedArg {
            Constant(f32),
            Shape(std::sync::Arc<isokit_scene::Scene>),
        }
        let speed = match speed {
            None => SpeedArg::Constant(0.0),
            Some(s) if s.is_none() => SpeedArg::Constant(0.0),
            Some(s) => {
                if let Ok(x) = s.extract::<f64>() {
                    SpeedArg::Constant(x as f32)
                } else if let Ok(sh) = s.cast::<Shape>() {
                    let sh = sh.get();
                    SpeedArg::Shape(run(py, Some(&crate::quiet(py)), "compile", |_| sh.scene())?)
                } else {
                    return Err(PyTypeError::new_err(
                        "speed must be a number or an isokit.Shape (the speed at each point)",
                    ));
                }
            }
        };
        let mut grid = self.grid(py)?;
        let (grid, st) = run(py, progress, "evolve", |_| {
            let base = match &speed {
                SpeedArg::Constant(c) => Speed::Constant(*c),
                SpeedArg::Shape(s) => Speed::Field(&**s),
            };
            let sp = if curvature != 0.0 {
                Speed::Sum(vec![base, Speed::MeanCurvature(curvature)])
            } else {
                base
            };
            let st =
                isokit_levelset::evolve::evolve(&mut grid, &sp, t, &opts).map_err(value_err)?;
            Ok((grid, st))
        })?;
        let stats = serde_json::json!({
            "steps": st.steps, "time": st.time, "reinits": st.reinits, "min_dt": st.min_dt,
            "max_dt": st.max_dt, "max_speed": st.max_speed, "band_nodes": st.band_nodes,
            "node_updates": st.node_updates,
        });
        self.derived(py, grid, self.band, Some(stats))
    }

    /// The surface moved by `distance` along its outward normal (`> 0` grows), then
    /// reinitialized (Sigg 2006, Sec. 2.3.3). `band`: half-width of the result (default the
    /// field's band, else the whole grid); `method`: the reinitialization.
    #[pyo3(signature = (distance, band = None, method = "fast_marching", progress = None))]
    fn offset(
        &self,
        py: Python<'_>,
        distance: f32,
        band: Option<f32>,
        method: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.offsets(py, "offset", distance, band, method, progress)
    }

    /// Dilation by `radius ≥ 0` (grows the shape; `offset(radius)`).
    #[pyo3(signature = (radius, band = None, method = "fast_marching", progress = None))]
    fn dilate(
        &self,
        py: Python<'_>,
        radius: f32,
        band: Option<f32>,
        method: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.offsets(py, "dilate", radius, band, method, progress)
    }

    /// Erosion by `radius ≥ 0` (shrinks the shape).
    #[pyo3(signature = (radius, band = None, method = "fast_marching", progress = None))]
    fn erode(
        &self,
        py: Python<'_>,
        radius: f32,
        band: Option<f32>,
        method: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.offsets(py, "erode", radius, band, method, progress)
    }

    /// Opening by `radius`: erosion then dilation, removing parts thinner than `2·radius`.
    #[pyo3(signature = (radius, band = None, method = "fast_marching", progress = None))]
    fn opening(
        &self,
        py: Python<'_>,
        radius: f32,
        band: Option<f32>,
        method: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.offsets(py, "opening", radius, band, method, progress)
    }

    /// Closing by `radius`: dilation then erosion, filling gaps narrower than `2·radius`.
    #[pyo3(signature = (radius, band = None, method = "fast_marching", progress = None))]
    fn closing(
        &self,
        py: Python<'_>,
        radius: f32,
        band: Option<f32>,
        method: &str,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        self.offsets(py, "closing", radius, band, method, progress)
    }

    /// The linear morph `(1 - t)·self + t·other`, sample by sample (the two fields must
    /// share their lattice).
    fn morph(&self, py: Python<'_>, other: PyRef<'_, Field>, t: f32) -> PyResult<Field> {
        let (a, b) = (self.grid(py)?, other.grid(py)?);
        let g = py.detach(|| {
            guarded(|| isokit_levelset::morph::morph_grids(&a, &b, t).map_err(value_err))
        })?;
        let band = match (self.band, other.band) {
            (Some(x), Some(y)) => Some(x.max(y)),
            _ => None,
        };
        self.derived(py, g, band, None)
    }

    /// The isosurface `f = iso` as a triangle mesh `(V, F)` (an `isokit.Mesh`), closed where
    /// it leaves the lattice unless `close_boundary=False`. `mesher`: `"mc"` (marching cubes
    /// with the asymptotic decider: watertight and 2-manifold) or `"dual"` (dual contouring,
    /// Hermite data from the samples' central differences: sharper edges and corners);
    /// `error` (`"dual"` only) merges cells adaptively as `Shape.mesh` does.
    /// `progress` as for the other long calls (stage `meshing`; dual contouring:
    /// `meshing (crossed edges)`, then `meshing (vertices)`; with `error`, then
    /// `meshing (merging cells)` and `meshing (checking merged polygons)`).
    #[pyo3(signature = (iso = 0.0, close_boundary = true, mesher = "mc", progress = None, error = None))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        iso: f32,
        close_boundary: bool,
        mesher: &str,
        progress: Option<&Bound<'_, PyAny>>,
        error: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mesher = crate::shape::parse_mesher(mesher)?;
        let error = crate::shape::parse_error(mesher, error)?;
        let mut grid = self.grid(py)?;
        let mut iso = iso;
        if self.inside == Inside::Above {
            // Marching cubes puts inside below the isovalue.
            grid.data_mut().iter_mut().for_each(|v| *v = -*v);
            iso = -iso;
        }
        let opts = isokit_levelset::meshing::MeshOptions {
            iso,
            close_boundary,
        };
        let mesh = run(py, progress, "mesh", |job| match mesher {
            isokit_scene::Mesher::Mc => {
                isokit_levelset::meshing::mesh_grid_job(&grid, &opts, job).map_err(value_err)
            }
            isokit_scene::Mesher::Dual => {
                let dual = isokit_levelset::dual::DualOptions {
                    iso,
                    close_boundary,
                    error,
                    ..Default::default()
                };
                isokit_levelset::dual::mesh_dual_grid_job(&grid, None, &dual, job)
                    .map(|(mesh, _)| mesh)
                    .map_err(value_err)
            }
        })?;
        crate::shape::mesh_tuple(py, &mesh, py.None().into_bound(py))
    }

    /// Renders the field's isosurface (as `Shape.render`; `iso` default 0, or the middle of
    /// the values' range when they do not reach 0).
    #[pyo3(signature = (width = 512, height = 512, shading = None, camera = None, backend = "auto", iso = None, projection = "perspective", background = None, progress = None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn render(
        &self,
        py: Python<'_>,
        width: u32,
        height: u32,
        shading: Option<&str>,
        camera: Option<&Bound<'_, PyAny>>,
        backend: &str,
        iso: Option<f32>,
        projection: &str,
        background: Option<&Bound<'_, PyAny>>,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Frame> {
        let args = RenderArgs::parse(
            width, height, shading, camera, backend, None, iso, projection, background,
        )?;
        let mut grid = self.grid(py)?;
        if self.inside == Inside::Above {
            grid.data_mut().iter_mut().for_each(|v| *v = -*v);
        }
        let mut args = args;
        if self.inside == Inside::Above {
            args.settings.iso = args.settings.iso.map(|i| -i);
        }
        render::render_grid(py, grid, &args, progress)
    }

    /// Renders the field directly, not an isosurface: emission and absorption along each
    /// ray through a transfer function (`isokit render --mode dvr`). `tf`: a preset name
    /// (`"ct-bone"`, `"ct-skin"`, `"mri-brain"`, `"distance-shell"`), the path of a JSON
    /// file, or a dict `{"points": [[value, r, g, b, sigma], ...]}` (linear-RGB emission,
    /// `sigma` the extinction per world unit). `classification`: `"post"` or
    /// `"preintegrated"`; `step` in world units (default one voxel); `shading`: `None`
    /// (emission only) or `"phong"` (by the gradient: `gradient="tricubic"`, the B-spline's,
    /// or `"central"`, central differences). `table_build`: `"integrated"` (each table entry
    /// integrated) or `"incremental"` (Lum et al. 2004's O(n²) build: faster, less exact).
    /// `camera`, `projection`, `backend` as for `render`. The frame's `gbuffer` holds `R G B` (premultiplied), `A` (opacity) and
    /// `Z` (where the opacity passes 0.5; infinite where it never does).
    #[pyo3(signature = (tf, width = 512, height = 512, classification = "post", step = None, shading = None, camera = None, backend = "auto", projection = "perspective", gradient = "tricubic", table_build = "integrated"))]
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
        step: Option<f32>,
        shading: Option<&str>,
        camera: Option<&Bound<'_, PyAny>>,
        backend: &str,
        projection: &str,
        gradient: &str,
        table_build: &str,
    ) -> PyResult<Frame> {
        use isokit_render::dvr::{DvrGradient, DvrOptions, TableBuild, TransferFunction};
        let grid = self.grid(py)?;
        let (tf, classification, shade) = render::volume_args(
            py,
            tf,
            |name| TransferFunction::load(name, &grid),
            classification,
            shading,
        )?;
        let gradient = match gradient {
            "tricubic" => DvrGradient::Tricubic,
            "central" => DvrGradient::Central,
            g => {
                return Err(PyValueError::new_err(format!(
                    "gradient = {g:?} is not one of \"tricubic\", \"central\""
                )));
            }
        };
        let table_build = match table_build {
            "integrated" => TableBuild::Integrated,
            "incremental" => TableBuild::Incremental,
            t => {
                return Err(PyValueError::new_err(format!(
                    "table_build = {t:?} is not one of \"integrated\", \"incremental\""
                )));
            }
        };
        let args = render::VolumeRenderArgs {
            size: (width, height),
            tf,
            options: DvrOptions {
                step,
                classification,
                shade,
                gradient,
                table_build,
                ..DvrOptions::default()
            },
            camera,
            projection,
            backend,
        };
        render::render_volume_grid(py, &grid, &args)
    }

    /// A PNG of the field's isosurface (320×240, CPU), for Jupyter.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let q = crate::quiet(py);
        let frame = self.render(
            py,
            320,
            240,
            None,
            None,
            "cpu",
            None,
            "perspective",
            None,
            Some(&q),
        )?;
        frame.png(py)
    }
}

/// `isokit.morph_level_set(source, target, …)`: morphs the field `source` into `target`
/// by level-set evolution (Breen and Whitaker 2001) until its surface lies within
/// `tolerance` of the target's; returns `(field, stats)`. The knobs are the Rust API's
/// `MorphOptions` (`max_speed`, `width`, `tolerance`, `t_max`, `check_every`,
/// `stall_checks`, `reinit_target`) and the evolution's `scheme`, `cfl`, `band`.
#[pyfunction]
#[pyo3(signature = (source, target, max_speed = 1.0, width = None, tolerance = None, t_max = None, check_every = 5, stall_checks = 10, reinit_target = true, scheme = "upwind1", cfl = 0.5, band = None, progress = None))]
#[expect(
    clippy::too_many_arguments,
    reason = "one argument per Python keyword argument"
)]
pub fn morph_level_set<'py>(
    py: Python<'py>,
    source: PyRef<'py, Field>,
    target: PyRef<'py, Field>,
    max_speed: f32,
    width: Option<f32>,
    tolerance: Option<f32>,
    t_max: Option<f32>,
    check_every: usize,
    stall_checks: usize,
    reinit_target: bool,
    scheme: &str,
    cfl: f32,
    band: Option<f32>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Field, Bound<'py, PyAny>)> {
    source.distance_field("morph_level_set")?;
    target.distance_field("morph_level_set")?;
    let opts = MorphOptions {
        max_speed,
        width,
        tolerance,
        t_max,
        check_every,
        stall_checks,
        reinit_target,
        evolve: EvolveOptions {
            cfl,
            band,
            scheme: match scheme {
                "upwind1" => Scheme::Upwind1,
                "weno5" => Scheme::Weno5,
                s => {
                    return Err(PyValueError::new_err(format!(
                        "scheme = {s:?} is not one of \"upwind1\", \"weno5\""
                    )));
                }
            },
            ..EvolveOptions::default()
        },
    };
    let (a, b) = (source.grid(py)?, target.grid(py)?);
    // The morph has no cancellation point of its own: it runs to its end (progress reports
    // count its steps).
    let (g, st) = run(py, progress, "morph", |job| {
        isokit_levelset::evolve::morph_level_set_with(&a, &b, &opts, &mut |f| {
            job.report("step", f.step as u64, 0);
        })
        .map_err(value_err)
    })?;
    let stats = serde_json::json!({
        "deviation": st.deviation, "converged": st.converged, "steps": st.evolve.steps,
        "time": st.evolve.time, "reinits": st.evolve.reinits,
    });
    let field = source.derived(py, g, source.band, None)?;
    Ok((field, json_to_py(py, &stats)?))
}
