//! `isokit.Shape`: a scene tree (an `isokit_scene::Node` with the scene file's settings),
//! built by the shape functions and operators, compiled once when first evaluated.

use crate::arrays::{self, Points};
use crate::errors::{io_err, scene_err, value_err};
use crate::field::Field;
use crate::render::{self, Frame, RenderArgs};
use crate::run::{guarded, run};
use crate::tree;
use glam::Vec3;
use isokit_field::{Aabb, Grid, Job, PointCloud, TriMesh};
use isokit_scene::node::VolumeNode;
use isokit_scene::primitives::{Param, PrimitiveKind};
use isokit_scene::{
    BandMethod, Filter, Inside, MeshOptions, Node, Normals, SampleOptions, Scene, SceneFile,
    SignMode, SourceCache, VolumeData, band_to_grid, mesh_scene,
};
use numpy::prelude::*;
use numpy::{PyReadonlyArray3, PyUntypedArray};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use rayon::prelude::*;
use std::path::Path;
use std::sync::{Arc, LazyLock, Mutex};

/// Built sources shared by every shape of the process (kd-trees, cloud solves, volumes), so
/// that `mesh | sphere` does not rebuild the mesh's tree. Cleared when it holds more than
/// [`CACHE_LIMIT`] sources.
static CACHE: LazyLock<Mutex<SourceCache>> = LazyLock::new(|| Mutex::new(SourceCache::default()));
const CACHE_LIMIT: usize = 32;

/// Points per chunk of an evaluation (progress and cancellation between chunks).
const CHUNK: usize = 1 << 16;

/// A shape: a tree of primitives, meshes, clouds, volumes and operations on them (the
/// tree a scene file holds). Build shapes with `isokit.sphere`, `isokit.mesh`, … and
/// combine them with `|` (union), `&` (intersection), `-` (difference), `~` (complement)
/// and the methods below; every operation returns a new shape.
///
/// Evaluate it with `shape(points)` and `shape.gradient(points)`, sample it with
/// `shape.sample()`, mesh it with `shape.mesh()`, render it with `shape.render()`, and
/// write it as a scene file with `shape.to_json()`. Signed distances are negative inside.
#[pyclass(frozen, module = "isokit", name = "Shape")]
pub struct Shape {
    pub(crate) file: SceneFile,
    compiled: Mutex<Option<Arc<Scene>>>,
}

impl Shape {
    /// A shape of just `node`.
    pub fn new(node: Node) -> Self {
        Self::with_file(SceneFile::new(node))
    }

    /// A shape with a whole scene file's settings.
    pub fn with_file(file: SceneFile) -> Self {
        Self {
            file,
            compiled: Mutex::new(None),
        }
    }

    /// The tree.
    pub fn node(&self) -> &Node {
        &self.file.shape
    }

    /// The compiled scene (compiled on first use; call without the GIL: meshes build their
    /// kd-trees here).
    pub fn scene(&self) -> PyResult<Arc<Scene>> {
        let mut slot = self.compiled.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = &*slot {
            return Ok(s.clone());
        }
        let scene = {
            let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
            if cache.len() > CACHE_LIMIT {
                cache.clear();
            }
            Scene::from_file_with(self.file.clone(), Path::new("."), &mut cache)
                .map_err(scene_err)?
        };
        let scene = Arc::new(scene);
        *slot = Some(scene.clone());
        Ok(scene)
    }

    fn combine(&self, other: &Shape, f: impl FnOnce(Node, Node) -> Node) -> Shape {
        Shape::new(f(self.node().clone(), other.node().clone()))
    }

    /// The options of a sampling from Python's arguments, over the scene's `sampling` table
    /// (a shape from `load_scene`), over the defaults (128 samples, a band of 4 samples,
    /// bricks of 4).
    pub fn sample_options(
        &self,
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<[[f32; 3]; 2]>,
        brick: Option<usize>,
    ) -> SampleOptions {
        let s = &self.file.sampling;
        let d = SampleOptions::default();
        SampleOptions {
            resolution: res.or(s.resolution).unwrap_or(d.resolution),
            band: band.or(s.band),
            brick: brick.or(s.brick).unwrap_or(d.brick),
            apron: 0,
            bounds: bounds.map(|[a, b]| Aabb::from_corners(Vec3::from(a), Vec3::from(b))),
            lattice: None,
        }
    }
}

/// A vector argument: a number (all three components) or three numbers.
pub fn vec3_arg(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<[f32; 3]> {
    if let Ok(x) = obj.extract::<f64>() {
        return Ok([x as f32; 3]);
    }
    let v: Vec<f64> = obj
        .extract()
        .map_err(|_| PyTypeError::new_err(format!("{name} must be a number or three numbers")))?;
    match v.as_slice() {
        [x, y, z] => Ok([*x as f32, *y as f32, *z as f32]),
        _ => Err(PyValueError::new_err(format!(
            "{name} must have three components, got {}",
            v.len()
        ))),
    }
}

/// Bounds `((xmin, ymin, zmin), (xmax, ymax, zmax))`.
pub fn bounds_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<[[f32; 3]; 2]>> {
    let Some(obj) = obj else { return Ok(None) };
    if obj.is_none() {
        return Ok(None);
    }
    let seq: Vec<Bound<'_, PyAny>> = obj.extract().map_err(|_| {
        PyTypeError::new_err("bounds must be ((xmin, ymin, zmin), (xmax, ymax, zmax))")
    })?;
    match seq.as_slice() {
        [a, b] => {
            let (a, b) = (vec3_arg(a, "bounds[0]")?, vec3_arg(b, "bounds[1]")?);
            if a.iter().chain(&b).any(|x| !x.is_finite()) {
                return Err(PyValueError::new_err("bounds must be finite"));
            }
            if a.iter().zip(&b).any(|(lo, hi)| lo >= hi) {
                return Err(PyValueError::new_err(format!(
                    "bounds {a:?} .. {b:?}: each minimum must be below its maximum"
                )));
            }
            Ok(Some([a, b]))
        }
        _ => Err(PyValueError::new_err(
            "bounds must be ((xmin, ymin, zmin), (xmax, ymax, zmax))",
        )),
    }
}

fn finite(x: f64, name: &str) -> PyResult<f32> {
    let v = x as f32;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(PyValueError::new_err(format!(
            "{name} = {x} must be finite"
        )))
    }
}

fn parse_enum<T: serde::de::DeserializeOwned>(s: &str, name: &str, choices: &str) -> PyResult<T> {
    serde_json::from_value(serde_json::Value::String(s.to_owned()))
        .map_err(|_| PyValueError::new_err(format!("{name} = {s:?} is not one of {choices}")))
}

/// Evaluates `f` at the finite rows of `pts` in chunks (progress, cancellation); non-finite
/// rows give NaN.
fn evaluate<T: Copy + Send + Sync>(
    pts: &[Vec3],
    job: &Job,
    nan: T,
    f: &(dyn Fn(&[Vec3], &mut [T]) + Sync),
) -> PyResult<Vec<T>> {
    let mut out = vec![nan; pts.len()];
    let finite: Vec<usize> = (0..pts.len()).filter(|&i| pts[i].is_finite()).collect();
    let all = finite.len() == pts.len();
    let counter = job.counter("evaluate", pts.len() as u64);
    if all {
        for (p, o) in pts.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
            job.check()
                .map_err(|_| crate::errors::Cancelled::new_err("cancelled"))?;
            f(p, o);
            counter.advance(p.len() as u64);
        }
    } else {
        let sub: Vec<Vec3> = finite.iter().map(|&i| pts[i]).collect();
        let mut vals = vec![nan; sub.len()];
        for (p, o) in sub.chunks(CHUNK).zip(vals.chunks_mut(CHUNK)) {
            job.check()
                .map_err(|_| crate::errors::Cancelled::new_err("cancelled"))?;
            f(p, o);
            counter.advance(p.len() as u64);
        }
        for (&i, v) in finite.iter().zip(vals) {
            out[i] = v;
        }
    }
    Ok(out)
}

#[pymethods]
impl Shape {
    /// The kind of the root node (`"sphere"`, `"union"`, …).
    #[getter]
    fn kind(&self) -> &'static str {
        self.node().kind()
    }

    /// The shape's bounding box `((xmin, ymin, zmin), (xmax, ymax, zmax))`, or `None` when
    /// it is unbounded (a plane, a complement) or empty. Compiles the shape.
    #[getter]
    fn bounds(&self, py: Python<'_>) -> PyResult<Option<([f32; 3], [f32; 3])>> {
        let scene = run(
            py,
            Some(&pyo3::types::PyBool::new(py, false)),
            "compile",
            |_| self.scene(),
        )?;
        let b = isokit_field::Field::bounds(&*scene);
        Ok((b.is_finite() && !b.is_empty()).then(|| (b.min.to_array(), b.max.to_array())))
    }

    fn __repr__(&self) -> String {
        let json = serde_json::to_string(self.node()).unwrap_or_default();
        if self.node().first_in_memory("shape").is_none() && json.len() <= 120 {
            format!("isokit.Shape({json})")
        } else {
            let memory = if self.node().first_in_memory("shape").is_some() {
                ", with data in memory"
            } else {
                ""
            };
            format!("isokit.Shape(<{}{memory}>)", self.node().kind())
        }
    }

    /// `a | b`: the union (`min`; exact outside).
    fn __or__(&self, other: PyRef<'_, Shape>) -> Shape {
        match self.node() {
            Node::Union(v) if self.file.camera.is_none() => {
                let mut v = v.clone();
                v.push(other.node().clone());
                Shape::new(Node::Union(v))
            }
            _ => self.combine(&other, |a, b| Node::union(vec![a, b])),
        }
    }

    /// `a & b`: the intersection (`max`; exact inside).
    fn __and__(&self, other: PyRef<'_, Shape>) -> Shape {
        match self.node() {
            Node::Intersection(v) => {
                let mut v = v.clone();
                v.push(other.node().clone());
                Shape::new(Node::Intersection(v))
            }
            _ => self.combine(&other, |a, b| Node::intersection(vec![a, b])),
        }
    }

    /// `a - b`: the difference `max(a, -b)` (Sigg 2006, Table 2.1 corrected).
    fn __sub__(&self, other: PyRef<'_, Shape>) -> Shape {
        match self.node() {
            Node::Difference(v) => {
                let mut v = v.clone();
                v.push(other.node().clone());
                Shape::new(Node::Difference(v))
            }
            _ => self.combine(&other, |a, b| Node::difference(vec![a, b])),
        }
    }

    /// `~a`: the complement `-a` (inside and outside swapped).
    fn __invert__(&self) -> Shape {
        Shape::new(self.node().clone().complement())
    }

    /// The union with `other`, blended over `radius` (a polynomial smooth minimum;
    /// `radius = 0` is the plain union).
    fn smooth_union(&self, other: PyRef<'_, Shape>, radius: f64) -> PyResult<Shape> {
        let r = finite(radius, "radius")?;
        Ok(self.combine(&other, |a, b| Node::smooth_union(r, vec![a, b])))
    }

    /// The intersection with `other`, blended over `radius`.
    fn smooth_intersection(&self, other: PyRef<'_, Shape>, radius: f64) -> PyResult<Shape> {
        let r = finite(radius, "radius")?;
        Ok(self.combine(&other, |a, b| Node::smooth_intersection(r, vec![a, b])))
    }

    /// This shape minus `other`, blended over `radius`.
    fn smooth_difference(&self, other: PyRef<'_, Shape>, radius: f64) -> PyResult<Shape> {
        let r = finite(radius, "radius")?;
        Ok(self.combine(&other, |a, b| Node::smooth_difference(r, vec![a, b])))
    }

    /// The surface moved outwards by `r` (`r < 0` moves it inwards): `f - r`.
    fn offset(&self, r: f64) -> PyResult<Shape> {
        Ok(Shape::new(self.node().clone().offset(finite(r, "r")?)))
    }

    /// A hollow shell of wall thickness `t` around the surface: `|f| - t/2`.
    fn shell(&self, t: f64) -> PyResult<Shape> {
        Ok(Shape::new(self.node().clone().shell(finite(t, "t")?)))
    }

    /// The linear morph `(1 - t)·self + t·other` (`t = 0` gives this shape, 1 the other).
    fn morph(&self, other: PyRef<'_, Shape>, t: f64) -> PyResult<Shape> {
        let t = finite(t, "t")?;
        Ok(self.combine(&other, |a, b| a.morph(b, t)))
    }

    /// The shape moved by `offset` (three numbers), or by `(x, y, z)`.
    #[pyo3(signature = (x, y = None, z = None))]
    fn translate(&self, x: &Bound<'_, PyAny>, y: Option<f64>, z: Option<f64>) -> PyResult<Shape> {
        let t = match (y, z) {
            (None, None) => {
                if x.extract::<f64>().is_ok() {
                    return Err(PyTypeError::new_err(
                        "translate takes three numbers: translate(x, y, z) or translate((x, y, z))",
                    ));
                }
                vec3_arg(x, "offset")?
            }
            (Some(y), Some(z)) => [x.extract::<f64>()? as f32, y as f32, z as f32],
            _ => {
                return Err(PyTypeError::new_err(
                    "translate takes three numbers: translate(x, y, z) or translate((x, y, z))",
                ));
            }
        };
        Ok(Shape::new(self.node().clone().translated(t)))
    }

    /// The shape rotated by `degrees` about `axis` through the origin (right-handed); `axis`
    /// is three numbers or `"x"`, `"y"`, `"z"`.
    fn rotate(&self, axis: &Bound<'_, PyAny>, degrees: f64) -> PyResult<Shape> {
        let a = match axis.extract::<String>() {
            Ok(s) => match s.to_ascii_lowercase().as_str() {
                "x" => [1.0, 0.0, 0.0],
                "y" => [0.0, 1.0, 0.0],
                "z" => [0.0, 0.0, 1.0],
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "axis {s:?} is not one of \"x\", \"y\", \"z\" (or give three numbers)"
                    )));
                }
            },
            Err(_) => vec3_arg(axis, "axis")?,
        };
        Ok(Shape::new(
            self.node().clone().rotated(a, finite(degrees, "degrees")?),
        ))
    }

    /// The shape scaled by `s` about the origin (uniform scale only: distances stay exact).
    fn scale(&self, s: &Bound<'_, PyAny>) -> PyResult<Shape> {
        let s: f64 = s.extract().map_err(|_| {
            PyTypeError::new_err(
                "scale takes one number (uniform scale keeps distances exact; non-uniform \
                 scaling is not offered)",
            )
        })?;
        Ok(Shape::new(self.node().clone().scaled(finite(s, "s")?)))
    }

    /// The shape stored in a hashed octree (Sigg 2006, Ch. 3) of finest level `max_level`
    /// (1 to 12), read back by trilinear interpolation.
    #[pyo3(signature = (max_level = 8, error = None, min_level = None))]
    fn octree(&self, max_level: u8, error: Option<f32>, min_level: Option<u8>) -> Shape {
        let mut n = self.node().clone().octree(max_level);
        if let Node::Octree(o) = &mut n {
            o.error = error;
            o.min_level = min_level;
        }
        Shape::new(n)
    }

    /// The scene file (JSON) of this shape.
    ///
    /// A shape holding arrays in memory (`isokit.mesh((V, F))`, `isokit.points((P, N))`,
    /// `isokit.volume(array)`) is refused, naming the node, unless `save_sources_to` names a
    /// folder: each array is then written there (meshes and clouds as PLY, volumes as NRRD)
    /// and the file references it. Paths are absolute, or relative to `relative_to` (the
    /// folder the scene file will live in) for files below it.
    #[pyo3(signature = (save_sources_to = None, relative_to = None))]
    fn to_json(
        &self,
        save_sources_to: Option<std::path::PathBuf>,
        relative_to: Option<std::path::PathBuf>,
    ) -> PyResult<String> {
        guarded(|| {
            let mut file = self.file.clone();
            if let Some(dir) = &save_sources_to {
                tree::save_sources(&mut file.shape, dir)?;
            }
            if let Some(dir) = &relative_to {
                tree::relativize(&mut file.shape, dir)?;
            }
            file.to_json().map_err(|e| {
                PyValueError::new_err(format!(
                    "{}: {}{}",
                    e.node,
                    e.message,
                    " (or call to_json(save_sources_to=DIR) to write the arrays to files)"
                ))
            })
        })
    }

    /// Writes the scene file to `path` (`.json`): arrays held in memory are saved beside it
    /// and every path below its folder is written relative to it, so the folder can move.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        guarded(|| {
            let dir = path
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf();
            let text = self.to_json(Some(dir.clone()), Some(dir))?;
            isokit_io::atomic_write(&path, |w| w.write_all(text.as_bytes())).map_err(io_err)
        })
    }

    /// Signed distances at `points`, an `(n, 3)` float32 or float64 array of any memory
    /// order: an `(n,)` array in the same precision (computed in float32, the pipeline's
    /// precision). Rows holding NaN or infinity give NaN. Negative inside.
    #[pyo3(signature = (points, progress = None))]
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let pts = Points::extract(points, "points")?;
        let prec = pts.precision();
        let p = pts.to_vec3();
        let out = run(py, progress, "evaluate", |job| {
            let scene = self.scene()?;
            evaluate(&p, job, f32::NAN, &|pts, out| {
                isokit_field::Field::values(&*scene, pts, out)
            })
        })?;
        Ok(arrays::vector_f32(py, out, prec))
    }

    /// Gradients at `points` (as for `shape(points)`): an `(n, 3)` array, unit length where
    /// the field is an exact distance. NaN rows give NaN.
    #[pyo3(signature = (points, progress = None))]
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let pts = Points::extract(points, "points")?;
        let prec = pts.precision();
        let p = pts.to_vec3();
        let out = run(py, progress, "gradient", |job| {
            let scene = self.scene()?;
            evaluate(&p, job, Vec3::NAN, &|pts, out| {
                out.par_iter_mut().zip(pts.par_iter()).for_each(|(o, &q)| {
                    *o = isokit_field::Field::gradient(&*scene, q);
                });
            })
        })?;
        Ok(arrays::rows3_f32(py, &out, prec))
    }

    /// Samples the shape on a lattice and returns an `isokit.Field`.
    ///
    /// `res`: samples along the longest side of `bounds` (default: the scene's
    /// `sampling.resolution`, else 128). `bounds`: the domain (default: the shape's bounds
    /// padded by the band and two samples; required for unbounded shapes). `band`: the
    /// narrow band's half-width in world units (default 4 samples); values are exact within
    /// it and `±band` beyond. `method`: `"lazy"` (default) evaluates only the bricks that can hold
    /// the band (the field's `dense_fraction` says how much of the lattice that was);
    /// `"dense"` evaluates every sample in full (then `band` is None: exact everywhere).
    /// `brick`: brick size of the lazy sampler (a power of two).
    #[pyo3(signature = (res = None, band = None, bounds = None, method = "lazy", brick = None, progress = None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn sample(
        &self,
        py: Python<'_>,
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<&Bound<'_, PyAny>>,
        method: &str,
        brick: Option<usize>,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Field> {
        let dense = match method {
            "lazy" => false,
            "dense" => true,
            m => {
                return Err(PyValueError::new_err(format!(
                    "method = {m:?} is not one of \"lazy\", \"dense\""
                )));
            }
        };
        let opts = self.sample_options(res, band, bounds_arg(bounds)?, brick);
        let (grid, stats, band) = run(py, progress, "sample", |job| {
            let scene = self.scene()?;
            let plan = scene.plan(&opts).map_err(scene_err)?;
            isokit_field::checked_len(plan.dims).map_err(value_err)?;
            if dense {
                let (g, st) = scene.sample_dense(&opts).map_err(scene_err)?;
                Ok((g, st, None))
            } else {
                let (b, st) = scene.sample_job(&opts, job).map_err(scene_err)?;
                job.check()
                    .map_err(|_| crate::errors::Cancelled::new_err("cancelled"))?;
                let g = band_to_grid(&b, st.band).map_err(value_err)?;
                let band = st.band;
                Ok((g, st, Some(band)))
            }
        })?;
        let stats = crate::field::json_to_py(py, &stats.to_json())?;
        Field::from_grid(py, grid, band, Inside::Below, None, Some(stats))
    }

    /// The surface as a triangle mesh `(V, F)`: float64 `(n, 3)` vertices and int64 `(m, 3)`
    /// triangles (an `isokit.Mesh` named tuple with `.to_trimesh()` and `.stats`). Marching
    /// cubes with the asymptotic decider on the lazily sampled band: watertight and
    /// consistently oriented. `res`, `band`, `bounds` as for `sample`; `dense` evaluates the
    /// whole lattice (the baseline; the same mesh).
    #[pyo3(signature = (res = None, band = None, bounds = None, dense = false, progress = None))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<&Bound<'py, PyAny>>,
        dense: bool,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = MeshOptions {
            sampling: self.sample_options(res, band, bounds_arg(bounds)?, None),
            dense,
        };
        let (mesh, stats) = run(py, progress, "mesh", |job| {
            let scene = self.scene()?;
            let plan = scene.plan(&opts.sampling).map_err(scene_err)?;
            isokit_field::checked_len(plan.dims).map_err(value_err)?;
            let r = mesh_scene(&scene, &opts, job).map_err(scene_err)?;
            job.check()
                .map_err(|_| crate::errors::Cancelled::new_err("cancelled"))?;
            Ok(r)
        })?;
        let stats = serde_json::to_value(&stats).unwrap_or_default();
        mesh_tuple(py, &mesh, crate::field::json_to_py(py, &stats)?)
    }

    /// Renders the shape (ray casting its lazily sampled band) and returns an
    /// `isokit.Frame`. `shading`: a mode name (`"phong"`, `"curvature"`, `"normal"`, …;
    /// default the scene's, else Phong). `camera`: an `isokit.Camera` or the scene files'
    /// form `{"eye": …, "target": …, "up": …, "fov": …}` (default: the scene's, else one
    /// framing the shape). `backend`: `"auto"` (a hardware GPU when there is one, else the
    /// CPU), `"cpu"` or `"gpu"`. `res`: sampling resolution (default the scene's, 128).
    /// `iso`: the isovalue rendered. `projection`: `"perspective"` or `"orthographic"`.
    #[pyo3(signature = (width = 512, height = 512, shading = None, camera = None, backend = "auto", res = None, iso = None, projection = "perspective", background = None, progress = None))]
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
        res: Option<usize>,
        iso: Option<f32>,
        projection: &str,
        background: Option<&Bound<'_, PyAny>>,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Frame> {
        let args = RenderArgs::parse(
            width, height, shading, camera, backend, res, iso, projection, background,
        )?;
        render::render_shape(py, self, &args, progress)
    }

    /// A PNG of the shape (320×240, CPU), for Jupyter.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let args = RenderArgs::parse(320, 240, None, None, "cpu", None, None, "perspective", None)?;
        let frame =
            render::render_shape(py, self, &args, Some(&pyo3::types::PyBool::new(py, false)))?;
        frame.png(py)
    }
}

/// `isokit.Mesh(V, F, stats)` from a triangle mesh.
pub fn mesh_tuple<'py>(
    py: Python<'py>,
    mesh: &TriMesh,
    stats: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let n = mesh.positions.len();
    let v: Vec<f64> = mesh
        .positions
        .iter()
        .flat_map(|p| p.as_dvec3().to_array())
        .collect();
    let f: Vec<i64> = mesh
        .triangles
        .iter()
        .flat_map(|t| t.map(i64::from))
        .collect();
    let v = arrays::matrix(py, v, n);
    let f = arrays::matrix(py, f, mesh.triangles.len());
    py.import("isokit._mesh")?
        .getattr("Mesh")?
        .call1((v, f, stats))
}

/// `isokit._primitive(kind, params)`: a primitive from its scene-file key and a dict of
/// parameters (missing ones take the vocabulary's defaults).
#[pyfunction]
pub fn _primitive(kind: &str, params: &Bound<'_, PyDict>) -> PyResult<Shape> {
    let k = PrimitiveKind::from_name(kind).ok_or_else(|| {
        let names: Vec<&str> = PrimitiveKind::ALL.iter().map(|k| k.key()).collect();
        PyValueError::new_err(format!(
            "unknown primitive {kind:?}; the primitives are {}",
            names.join(", ")
        ))
    })?;
    let mut node = k.default_node();
    for (name, value) in params.iter() {
        let name: String = name.extract()?;
        if value.is_none() {
            continue;
        }
        let p = if let Ok(x) = value.extract::<f64>() {
            Param::Number(finite(x, &name)?)
        } else {
            let v = vec3_arg(&value, &name)?;
            if v.iter().any(|x| !x.is_finite()) {
                return Err(PyValueError::new_err(format!("{name} must be finite")));
            }
            Param::Vector(v)
        };
        node.set(&name, p).map_err(PyTypeError::new_err)?;
    }
    // Invalid parameters (a negative radius) are errors now, not at the first evaluation.
    node.build()
        .map_err(|e| PyValueError::new_err(format!("{}: {e}", k.key())))?;
    Ok(Shape::new(node.into()))
}

/// `isokit._primitives()`: the vocabulary, `[(key, [(name, default), …], note), …]`, with
/// vectors as tuples.
#[pyfunction]
pub fn _primitives(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for &k in PrimitiveKind::ALL {
        let params = PyList::empty(py);
        for (name, p) in k.params() {
            // The shortest decimal that is the f32 (0.2, not 0.20000000298023224).
            let short = |x: f32| x.to_string().parse::<f64>().unwrap_or(f64::from(x));
            let v: Bound<'_, PyAny> = match p {
                Param::Number(x) => short(x).into_pyobject(py)?.into_any(),
                Param::Vector(v) => PyTuple::new(py, v.map(short))?.into_any(),
            };
            params.append((name, v))?;
        }
        out.append((k.key(), params, k.note()))?;
    }
    Ok(out)
}

/// `isokit._mesh_path(path, sign, method)`.
#[pyfunction]
pub fn _mesh_path(path: std::path::PathBuf, sign: &str, method: &str) -> PyResult<Shape> {
    let mut node = Node::mesh(tree::absolute(&path.display().to_string(), Path::new(".")));
    if let Node::Mesh(m) = &mut node {
        m.sign = parse_enum(
            sign,
            "sign",
            "\"auto\", \"pseudonormal\", \"winding\", \"unsigned\"",
        )?;
        m.method = parse_enum::<BandMethod>(
            method,
            "method",
            "\"kdtree\", \"prism\", \"prism_cpu\", \"prism_gpu\"",
        )?;
    }
    Ok(Shape::new(node))
}

/// `isokit._mesh_arrays(V, F, sign, method)`.
#[pyfunction]
pub fn _mesh_arrays(
    v: &Bound<'_, PyAny>,
    f: &Bound<'_, PyAny>,
    sign: &str,
    method: &str,
) -> PyResult<Shape> {
    let sign: SignMode = parse_enum(
        sign,
        "sign",
        "\"auto\", \"pseudonormal\", \"winding\", \"unsigned\"",
    )?;
    let method: BandMethod = parse_enum(
        method,
        "method",
        "\"kdtree\", \"prism\", \"prism_cpu\", \"prism_gpu\"",
    )?;
    let v = Points::extract(v, "V")?;
    let positions = v.to_vec3();
    let triangles = arrays::triangles(f, positions.len())?;
    if triangles.is_empty() {
        return Err(PyValueError::new_err(
            "the mesh has no triangles (F is empty)",
        ));
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "V[{i}] is not finite (NaN or infinite vertices are not allowed)"
        )));
    }
    let mut node = Node::mesh_data(
        TriMesh {
            positions,
            triangles,
        },
        sign,
    );
    if let Node::Mesh(m) = &mut node {
        m.method = method;
    }
    Ok(Shape::new(node))
}

fn parse_normals(s: &str) -> PyResult<Normals> {
    parse_enum(s, "normals", "\"auto\", \"given\", \"estimate\"")
}

/// `isokit._points_path(path, k, normals)`.
#[pyfunction]
pub fn _points_path(path: std::path::PathBuf, k: Option<usize>, normals: &str) -> PyResult<Shape> {
    let mut node = Node::points(tree::absolute(&path.display().to_string(), Path::new(".")));
    if let Node::Points(p) = &mut node {
        p.k = k;
        p.normals = parse_normals(normals)?;
    }
    Ok(Shape::new(node))
}

/// `isokit._points_arrays(P, N, k, normals)`.
#[pyfunction]
#[pyo3(signature = (p, n, k, normals))]
pub fn _points_arrays(
    p: &Bound<'_, PyAny>,
    n: Option<&Bound<'_, PyAny>>,
    k: Option<usize>,
    normals: &str,
) -> PyResult<Shape> {
    let pts = Points::extract(p, "P")?.to_vec3();
    if pts.is_empty() {
        return Err(PyValueError::new_err(
            "the cloud has no points (P is empty)",
        ));
    }
    if let Some(i) = pts.iter().position(|p| !p.is_finite()) {
        return Err(PyValueError::new_err(format!("P[{i}] is not finite")));
    }
    let normals_arr = match n {
        Some(n) if !n.is_none() => {
            let nn = Points::extract(n, "N")?.to_vec3();
            if nn.len() != pts.len() {
                return Err(PyValueError::new_err(format!(
                    "N has {} rows but P has {}",
                    nn.len(),
                    pts.len()
                )));
            }
            Some(nn)
        }
        _ => None,
    };
    let mut node = Node::points_data(PointCloud {
        points: pts,
        normals: normals_arr,
    });
    if let Node::Points(pn) = &mut node {
        pn.k = k;
        pn.normals = parse_normals(normals)?;
    }
    Ok(Shape::new(node))
}

fn volume_options(iso: f32, inside: &str, filter: &str) -> PyResult<(f32, Inside, Filter)> {
    if !iso.is_finite() {
        return Err(PyValueError::new_err(format!("iso = {iso} must be finite")));
    }
    Ok((
        iso,
        parse_enum(inside, "inside", "\"below\", \"above\"")?,
        parse_enum(
            filter,
            "filter",
            "\"trilinear\", \"cubic_bspline\", \"catmull_rom\"",
        )?,
    ))
}

/// `isokit._volume_path(path, iso, inside, filter)`.
#[pyfunction]
pub fn _volume_path(
    path: std::path::PathBuf,
    iso: f32,
    inside: &str,
    filter: &str,
) -> PyResult<Shape> {
    let (iso, inside, filter) = volume_options(iso, inside, filter)?;
    Ok(Shape::new(Node::Volume(VolumeNode {
        path: Some(tree::absolute(&path.display().to_string(), Path::new("."))),
        filter,
        iso,
        inside,
        data: None,
    })))
}

/// A dense grid from a `(nz, ny, nx)` array (any float or integer dtype, any memory order).
pub fn grid_from_array(
    values: &Bound<'_, PyAny>,
    origin: [f32; 3],
    spacing: f32,
) -> PyResult<Grid> {
    let arr = values.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err("values must be a 3-D NumPy array of shape (nz, ny, nx)")
    })?;
    if arr.ndim() != 3 {
        return Err(PyValueError::new_err(format!(
            "values must be 3-D with shape (nz, ny, nx), got shape {:?}",
            arr.shape()
        )));
    }
    let kind: String = arr.dtype().getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(PyTypeError::new_err(format!(
            "values must be a float or integer array, got dtype {}",
            arr.dtype()
        )));
    }
    let f32s = values
        .py()
        .import("numpy")?
        .call_method1("asarray", (values, "float32"))?;
    let a: PyReadonlyArray3<'_, f32> = f32s.extract()?;
    let view = a.as_array();
    let [nz, ny, nx] = [view.shape()[0], view.shape()[1], view.shape()[2]];
    if nx < 2 || ny < 2 || nz < 2 {
        return Err(PyValueError::new_err(format!(
            "values must have at least 2 samples along each axis, got shape ({nz}, {ny}, {nx})"
        )));
    }
    // Iterating the view in logical order gives x fastest, whatever the memory order.
    let data: Vec<f32> = view.iter().copied().collect();
    Grid::from_data([nx, ny, nz], Vec3::from(origin), spacing, data).map_err(value_err)
}

/// `isokit._volume_array(values, origin, spacing, iso, inside, filter)`.
#[pyfunction]
pub fn _volume_array(
    values: &Bound<'_, PyAny>,
    origin: &Bound<'_, PyAny>,
    spacing: &Bound<'_, PyAny>,
    iso: f32,
    inside: &str,
    filter: &str,
) -> PyResult<Shape> {
    let (iso, inside, filter) = volume_options(iso, inside, filter)?;
    let origin = vec3_arg(origin, "origin")?;
    let sp = vec3_arg(spacing, "spacing")?;
    if (sp[0] - sp[1]).abs() > 1e-4 * sp[0].abs() || (sp[0] - sp[2]).abs() > 1e-4 * sp[0].abs() {
        return Err(PyValueError::new_err(format!(
            "spacing {sp:?} differs between axes; isokit grids have one spacing"
        )));
    }
    let grid = grid_from_array(values, origin, sp[0])?;
    if let Some(i) = grid.data().iter().position(|v| v.is_nan()) {
        return Err(PyValueError::new_err(format!(
            "values hold NaN (first at flat index {i})"
        )));
    }
    Ok(Shape::new(Node::Volume(VolumeNode {
        path: None,
        filter,
        iso,
        inside,
        data: Some(isokit_scene::Memory::volume(VolumeData::Grid(grid))),
    })))
}

fn collect_shapes(items: &Bound<'_, PyTuple>, what: &str, min: usize) -> PyResult<Vec<Node>> {
    let mut out = Vec::new();
    for it in items.iter() {
        let s = it.cast::<Shape>().map_err(|_| {
            PyTypeError::new_err(format!("{what} takes shapes, got {}", it.get_type()))
        })?;
        out.push(s.get().node().clone());
    }
    if out.len() < min {
        return Err(PyValueError::new_err(format!(
            "{what} needs at least {min} shapes, got {}",
            out.len()
        )));
    }
    Ok(out)
}

/// `isokit.union(*shapes)`: the union of all (one n-ary node: with many operands a
/// bounding-volume hierarchy prunes the evaluation).
#[pyfunction]
#[pyo3(signature = (*shapes))]
pub fn union(shapes: &Bound<'_, PyTuple>) -> PyResult<Shape> {
    Ok(Shape::new(Node::union(collect_shapes(shapes, "union", 1)?)))
}

/// `isokit.intersection(*shapes)`: the intersection of all.
#[pyfunction]
#[pyo3(signature = (*shapes))]
pub fn intersection(shapes: &Bound<'_, PyTuple>) -> PyResult<Shape> {
    Ok(Shape::new(Node::intersection(collect_shapes(
        shapes,
        "intersection",
        1,
    )?)))
}

/// `isokit.difference(a, *others)`: `a` minus all the others.
#[pyfunction]
#[pyo3(signature = (*shapes))]
pub fn difference(shapes: &Bound<'_, PyTuple>) -> PyResult<Shape> {
    Ok(Shape::new(Node::difference(collect_shapes(
        shapes,
        "difference",
        2,
    )?)))
}

/// `isokit.smooth_union(*shapes, radius)`: the union of all, blended over `radius`.
#[pyfunction]
#[pyo3(signature = (*shapes, radius))]
pub fn smooth_union(shapes: &Bound<'_, PyTuple>, radius: f64) -> PyResult<Shape> {
    let r = finite(radius, "radius")?;
    Ok(Shape::new(Node::smooth_union(
        r,
        collect_shapes(shapes, "smooth_union", 1)?,
    )))
}

/// `isokit.load_scene(path)`: a scene file (JSON or TOML) as a shape, with its camera,
/// lights, shading and sampling (used by `render` and `sample` unless overridden). Paths in
/// the file are relative to it.
#[pyfunction]
pub fn load_scene(path: std::path::PathBuf) -> PyResult<Shape> {
    guarded(|| {
        let name = path.display().to_string();
        let format = isokit_scene::SceneFormat::from_path(&path).ok_or_else(|| {
            PyValueError::new_err(format!(
                "{name}: unknown scene format (expected .json or .toml)"
            ))
        })?;
        let text =
            std::fs::read_to_string(&path).map_err(|e| io_err(isokit_io::IoError::io(&path, e)))?;
        let mut file = isokit_scene::parse(&text, format, &name).map_err(scene_err)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        tree::absolutize(&mut file.shape, dir)?;
        Ok(Shape::with_file(file))
    })
}
