//! `isokit.Shape`: a scene tree (an `isokit_scene::Node` with the scene file's settings),
//! built by the shape functions and operators, compiled once when first evaluated.

use crate::arrays::{self, Points};
use crate::errors::{io_err, scene_err, value_err};
use crate::field::Field;
use crate::render::{self, Frame, RenderArgs};
use crate::run::{guarded, run};
use crate::tree;
use crate::vocab::{self, Of, build};
use glam::Vec3;
use isokit_field::{Aabb, Grid, Job, PointCloud, TriMesh};
use isokit_scene::node::VolumeNode;
use isokit_scene::primitives::{Param, PrimitiveKind};
use isokit_scene::{
    BandMethod, Filter, Inside, MeshOptions, Node, SampleOptions, Scene, SceneFile, SignMode,
    SourceCache, VolumeData, band_to_grid, mesh_scene,
};
use numpy::prelude::*;
use numpy::{PyReadonlyArray3, PyUntypedArray};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use rayon::prelude::*;
use std::collections::BTreeMap;
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
    /// Where the tree's numbers are `isokit.param`s: `(JSON pointer below the node, name)`,
    /// e.g. `("/sphere/radius", "r")`; `to_json` writes `"$r"` there.
    pub(crate) refs: Vec<(String, String)>,
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
            refs: Vec::new(),
            compiled: Mutex::new(None),
        }
    }

    /// A shape of `node` with its parameter table and references.
    pub fn from_parts(
        node: Node,
        params: BTreeMap<String, f64>,
        refs: Vec<(String, String)>,
    ) -> Self {
        let mut file = SceneFile::new(node);
        file.params = params;
        Self {
            file,
            refs,
            compiled: Mutex::new(None),
        }
    }

    /// The shape of `node`, an operation whose children from index `first` on are `kids`
    /// (and whose earlier children, if any, are those of `base`, the same kind of node): the
    /// parameters and references of both carried over. Checked (see [`vocab::check`]) when
    /// a 2D profile takes part, so that one where a solid is needed is refused now.
    pub fn derived(
        mut node: Node,
        base: Option<&Shape>,
        kids: &[&Shape],
        first: usize,
    ) -> PyResult<Shape> {
        let kind = node.kind();
        let mut params = BTreeMap::new();
        let mut refs = Vec::new();
        if let Some(b) = base {
            params = b.file.params.clone();
            refs = b.refs.clone();
        }
        let slots: Vec<tree::Slot> = tree::children_mut(&mut node)
            .into_iter()
            .map(|(s, _)| s)
            .collect();
        for (kid, slot) in kids.iter().zip(&slots[first.min(slots.len())..]) {
            vocab::merge_params(&mut params, &kid.file.params)?;
            let at = slot.pointer(kind);
            refs.extend(
                kid.refs
                    .iter()
                    .map(|(p, n)| (format!("{at}{p}"), n.clone())),
            );
        }
        // With a 2D operand: mixed dimensions are refused, and the wrappers that constrain
        // profiles (transforms about z only) are checked; CSG of profiles needs no check.
        let dims: Vec<u8> = base
            .iter()
            .chain(kids)
            .map(|s| vocab::dim(s.node()))
            .collect();
        let mixed = dims.windows(2).any(|w| w[0] != w[1]);
        let wrapped_2d =
            dims.contains(&2) && matches!(node.uncolored().0, Node::Transform(_) | Node::Octree(_));
        if mixed || wrapped_2d {
            vocab::check(&node)?;
        }
        Ok(Shape::from_parts(node, params, refs))
    }

    /// Refuses a 2D profile for `what` (meshing, sampling, rendering need a solid).
    fn solid(&self, what: &str) -> PyResult<()> {
        if vocab::dim(self.node()) == 2 {
            return Err(PyValueError::new_err(format!(
                "cannot {what} a 2D profile ({}): it is unbounded in z; extrude or revolve it \
                 first (profile.extrude(height), profile.revolve())",
                self.node().kind()
            )));
        }
        Ok(())
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

    fn combine(&self, other: &Shape, f: impl FnOnce(Node, Node) -> Node) -> PyResult<Shape> {
        Shape::derived(
            f(self.node().clone(), other.node().clone()),
            None,
            &[self, other],
            0,
        )
    }

    /// The vocabulary's node `kind` of this shape with `args` (see [`vocab::build`]).
    fn op(&self, kind: &str, args: &[(&str, Option<&Bound<'_, PyAny>>)]) -> PyResult<Shape> {
        build(kind, args, Of::One(self), None)
    }

    /// The vocabulary's blend `kind` of this shape and `other` with `args`.
    fn blend(
        &self,
        kind: &str,
        other: &Shape,
        args: &[(&str, Option<&Bound<'_, PyAny>>)],
    ) -> PyResult<Shape> {
        build(kind, args, Of::Many(vec![self, other]), None)
    }

    /// The stairs blend `kind` of this shape and `other`.
    fn stairs(
        &self,
        kind: &str,
        other: &Shape,
        radius: &Bound<'_, PyAny>,
        steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.blend(kind, other, &[("radius", Some(radius)), ("steps", steps)])
    }

    /// `f` of this shape's node, a one-child operation.
    fn wrap(&self, f: impl FnOnce(Node) -> Node) -> PyResult<Shape> {
        Shape::derived(f(self.node().clone()), None, &[self], 0)
    }

    /// The n-ary node `self`'s kind with `other` appended (`a | b | c` is one union).
    fn appended(
        &self,
        mut v: Vec<Node>,
        other: &Shape,
        f: fn(Vec<Node>) -> Node,
    ) -> PyResult<Shape> {
        v.push(other.node().clone());
        let last = v.len() - 1;
        Shape::derived(f(v), Some(self), &[other], last)
    }

    /// The block of `dims` samples from `first` of the lattice `opts` gives, clamped to
    /// `±band` (`_sample_block`, `_mesh_block`).
    fn block_grid(
        &self,
        mut opts: SampleOptions,
        first: [usize; 3],
        dims: [usize; 3],
        job: &Job,
    ) -> PyResult<Grid> {
        opts.block = Some(isokit_scene::Block { first, dims });
        let (g, _) = self
            .scene()?
            .sample_grid_job(&opts, job)
            .map_err(scene_err)?;
        Ok(g)
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
            block: None,
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

/// A rotation's axis: three numbers or `"x"`, `"y"`, `"z"`.
fn axis_arg(axis: &Bound<'_, PyAny>) -> PyResult<[f32; 3]> {
    Ok(match axis.extract::<String>() {
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
    })
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

/// A plain number argument (a `TypeError` naming it otherwise).
fn number(x: &Bound<'_, PyAny>, name: &str) -> PyResult<f64> {
    x.extract()
        .map_err(|_| PyTypeError::new_err(format!("{name} must be a number, got {}", x.get_type())))
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

/// `mesher="mc"|"dual"`.
pub(crate) fn parse_mesher(s: &str) -> PyResult<isokit_scene::Mesher> {
    parse_enum(s, "mesher", "\"mc\", \"dual\"")
}

/// `error=` of the mesh methods: adaptive dual contouring's bound, world units.
pub(crate) fn parse_error(
    mesher: isokit_scene::Mesher,
    error: Option<f64>,
) -> PyResult<Option<f64>> {
    match error {
        None => Ok(None),
        Some(_) if mesher != isokit_scene::Mesher::Dual => Err(PyValueError::new_err(
            "error= applies to mesher=\"dual\" (adaptive dual contouring)",
        )),
        Some(e) if !(e.is_finite() && e > 0.0) => Err(PyValueError::new_err(format!(
            "error = {e} must be a finite positive distance in world units"
        ))),
        Some(e) => Ok(Some(e)),
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
    fn __or__(&self, other: PyRef<'_, Shape>) -> PyResult<Shape> {
        match self.node() {
            Node::Union(v) if self.file.camera.is_none() => {
                self.appended(v.clone(), &other, Node::Union)
            }
            _ => self.combine(&other, |a, b| Node::union(vec![a, b])),
        }
    }

    /// `a & b`: the intersection (`max`; exact inside).
    fn __and__(&self, other: PyRef<'_, Shape>) -> PyResult<Shape> {
        match self.node() {
            Node::Intersection(v) => self.appended(v.clone(), &other, Node::Intersection),
            _ => self.combine(&other, |a, b| Node::intersection(vec![a, b])),
        }
    }

    /// `a - b`: the difference `max(a, -b)` (Sigg 2006, Table 2.1 corrected).
    fn __sub__(&self, other: PyRef<'_, Shape>) -> PyResult<Shape> {
        match self.node() {
            Node::Difference(v) => self.appended(v.clone(), &other, Node::Difference),
            _ => self.combine(&other, |a, b| Node::difference(vec![a, b])),
        }
    }

    /// `~a`: the complement `-a` (inside and outside swapped).
    fn __invert__(&self) -> PyResult<Shape> {
        self.wrap(Node::complement)
    }

    /// The union with `other`, blended over `radius` (a polynomial smooth minimum;
    /// `radius = 0` is the plain union).
    fn smooth_union(&self, other: PyRef<'_, Shape>, radius: &Bound<'_, PyAny>) -> PyResult<Shape> {
        if vocab::holds_param(radius) {
            return self.blend("smooth_union", &other, &[("radius", Some(radius))]);
        }
        let r = finite(number(radius, "radius")?, "radius")?;
        self.combine(&other, |a, b| Node::smooth_union(r, vec![a, b]))
    }

    /// The intersection with `other`, blended over `radius`.
    fn smooth_intersection(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
    ) -> PyResult<Shape> {
        if vocab::holds_param(radius) {
            return self.blend("smooth_intersection", &other, &[("radius", Some(radius))]);
        }
        let r = finite(number(radius, "radius")?, "radius")?;
        self.combine(&other, |a, b| Node::smooth_intersection(r, vec![a, b]))
    }

    /// This shape minus `other`, blended over `radius`.
    fn smooth_difference(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
    ) -> PyResult<Shape> {
        if vocab::holds_param(radius) {
            return self.blend("smooth_difference", &other, &[("radius", Some(radius))]);
        }
        let r = finite(number(radius, "radius")?, "radius")?;
        self.combine(&other, |a, b| Node::smooth_difference(r, vec![a, b]))
    }

    /// The surface moved outwards by `r` (`r < 0` moves it inwards): `f - r`.
    fn offset(&self, r: &Bound<'_, PyAny>) -> PyResult<Shape> {
        if vocab::holds_param(r) {
            return self.op("offset", &[("by", Some(r))]);
        }
        let r = finite(number(r, "r")?, "r")?;
        self.wrap(|n| n.offset(r))
    }

    /// A hollow shell of wall thickness `t` around the surface: `|f| - t/2`.
    fn shell(&self, t: &Bound<'_, PyAny>) -> PyResult<Shape> {
        if vocab::holds_param(t) {
            return self.op("shell", &[("thickness", Some(t))]);
        }
        let t = finite(number(t, "t")?, "t")?;
        self.wrap(|n| n.shell(t))
    }

    /// The linear morph `(1 - t)·self + t·other` (`t = 0` gives this shape, 1 the other).
    fn morph(&self, other: PyRef<'_, Shape>, t: f64) -> PyResult<Shape> {
        let t = finite(t, "t")?;
        self.combine(&other, |a, b| a.morph(b, t))
    }

    /// The shape moved by `offset` (three numbers), or by `(x, y, z)`.
    #[pyo3(signature = (x, y = None, z = None))]
    fn translate(
        &self,
        x: &Bound<'_, PyAny>,
        y: Option<&Bound<'_, PyAny>>,
        z: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        if [Some(x), y, z]
            .into_iter()
            .flatten()
            .any(vocab::holds_param)
        {
            let v = match (y, z) {
                (Some(y), Some(z)) => PyTuple::new(x.py(), [x, y, z])?.into_any(),
                _ => x.clone(),
            };
            return self.op("transform", &[("translate", Some(&v))]);
        }
        let t = match (
            y.map(|y| number(y, "y")).transpose()?,
            z.map(|z| number(z, "z")).transpose()?,
        ) {
            (None, None) => {
                if x.extract::<f64>().is_ok() {
                    return Err(PyTypeError::new_err(
                        "translate takes three numbers: translate(x, y, z) or translate((x, y, z))",
                    ));
                }
                vec3_arg(x, "offset")?
            }
            (Some(y), Some(z)) => [number(x, "x")? as f32, y as f32, z as f32],
            _ => {
                return Err(PyTypeError::new_err(
                    "translate takes three numbers: translate(x, y, z) or translate((x, y, z))",
                ));
            }
        };
        self.wrap(|n| n.translated(t))
    }

    /// The shape rotated by `degrees` about `axis` through the origin (right-handed); `axis`
    /// is three numbers or `"x"`, `"y"`, `"z"`.
    fn rotate(&self, axis: &Bound<'_, PyAny>, degrees: &Bound<'_, PyAny>) -> PyResult<Shape> {
        let named = axis.extract::<String>().ok();
        if vocab::holds_param(axis) || vocab::holds_param(degrees) {
            let rotate = PyDict::new(axis.py());
            match named {
                Some(_) => rotate.set_item("axis", axis_arg(axis)?)?,
                None => rotate.set_item("axis", axis)?,
            }
            rotate.set_item("degrees", degrees)?;
            return self.op("transform", &[("rotate", Some(rotate.as_any()))]);
        }
        let a = axis_arg(axis)?;
        let d = finite(number(degrees, "degrees")?, "degrees")?;
        self.wrap(|n| n.rotated(a, d))
    }

    /// The shape scaled by `s` about the origin (uniform scale only: distances stay exact;
    /// for one factor per axis, a distance bound, use `transform(scale=(sx, sy, sz))`).
    fn scale(&self, s: &Bound<'_, PyAny>) -> PyResult<Shape> {
        if s.is_instance_of::<vocab::Param>() {
            return self.op("transform", &[("scale", Some(s))]);
        }
        let s: f64 = s.extract().map_err(|_| {
            PyTypeError::new_err(
                "scale takes one number (a uniform scale keeps distances exact); for one \
                 factor per axis use transform(scale=(sx, sy, sz))",
            )
        })?;
        let s = finite(s, "s")?;
        self.wrap(|n| n.scaled(s))
    }

    /// The shape stored in a hashed octree (Sigg 2006, Ch. 3) of finest level `max_level`
    /// (1 to 12), read back by trilinear interpolation.
    #[pyo3(signature = (max_level = 8, error = None, min_level = None))]
    fn octree(&self, max_level: u8, error: Option<f32>, min_level: Option<u8>) -> PyResult<Shape> {
        self.wrap(|n| {
            let mut n = n.octree(max_level);
            if let Node::Octree(o) = &mut n {
                o.error = error;
                o.min_level = min_level;
            }
            n
        })
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
            let text = file.to_json().map_err(|e| {
                PyValueError::new_err(format!(
                    "{}: {}{}",
                    e.node,
                    e.message,
                    " (or call to_json(save_sources_to=DIR) to write the arrays to files)"
                ))
            })?;
            if self.refs.is_empty() {
                return Ok(text);
            }
            // The parameters' numbers written as their references.
            let mut v: serde_json::Value = serde_json::from_str(&text).map_err(value_err)?;
            for (at, name) in &self.refs {
                vocab::write_reference(&mut v, &format!("/shape{at}"), name)?;
            }
            let text = serde_json::to_string_pretty(&v).map_err(value_err)?;
            // The file must read back as this tree.
            let back = isokit_scene::parse(&text, isokit_scene::SceneFormat::Json, "to_json");
            if back.map(|b| b.shape) != Ok(file.shape) {
                return Err(pyo3::exceptions::PyRuntimeError::new_err(
                    "isokit: the scene file with parameter references does not read back as \
                     the shape (a bug; please report)",
                ));
            }
            Ok(text)
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
        self.solid("sample")?;
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

    /// The lattice `sample` would use with these arguments, without sampling: a dict with
    /// `dims` (nx, ny, nz), `origin`, `spacing`, `band` and `brick` (what `isokit.dask`
    /// splits into blocks).
    #[pyo3(signature = (res = None, band = None, bounds = None, brick = None))]
    fn _plan<'py>(
        &self,
        py: Python<'py>,
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<&Bound<'py, PyAny>>,
        brick: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        self.solid("sample")?;
        let opts = self.sample_options(res, band, bounds_arg(bounds)?, brick);
        let plan = self.scene()?.plan(&opts).map_err(scene_err)?;
        let d = PyDict::new(py);
        d.set_item("dims", plan.dims)?;
        d.set_item("origin", plan.origin.to_array())?;
        d.set_item("spacing", plan.spacing)?;
        d.set_item("band", plan.band)?;
        d.set_item("brick", plan.brick)?;
        Ok(d)
    }

    /// One block of the lazily sampled band, clamped to `±band`: the `dims` (nx, ny, nz)
    /// samples from index `first` of the lattice `sample` uses with the same arguments, as a
    /// float32 array of shape `(nz, ny, nx)`, equal bit for bit to that block of
    /// `sample(...).values`. The GIL is released while it samples.
    #[pyo3(signature = (first, dims, res = None, band = None, bounds = None, brick = None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn _sample_block<'py>(
        &self,
        py: Python<'py>,
        first: [usize; 3],
        dims: [usize; 3],
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<&Bound<'py, PyAny>>,
        brick: Option<usize>,
    ) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
        self.solid("sample")?;
        let opts = self.sample_options(res, band, bounds_arg(bounds)?, brick);
        let grid = run(py, None, "sample", |job| {
            self.block_grid(opts, first, dims, job)
        })?;
        let [nx, ny, nz] = grid.dims();
        let arr = numpy::ndarray::Array3::from_shape_vec((nz, ny, nx), grid.into_data())
            .map_err(value_err)?;
        Ok(numpy::PyArray3::from_owned_array(py, arr))
    }

    /// The mesh piece of one block of the lattice `sample` uses with these arguments
    /// (`isokit.dask.mesh`): the block owns the `owned` (nx, ny, nz) samples from `first`;
    /// its samples and the layer after are sampled (clamped to `±band`, as `sample` gives
    /// them) and its cells meshed by marching cubes (closed at the lattice's faces).
    /// Returns `(keys, positions, triangles)`: uint64 `(n,)` keys of the vertices in the
    /// whole lattice, float32 `(n, 3)` positions, uint32 `(m, 3)` triangles into them; the
    /// pieces of blocks tiling the lattice, welded by key, are `sample(...).mesh(iso)`.
    #[pyo3(signature = (first, owned, res = None, band = None, bounds = None, brick = None, iso = 0.0))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn _mesh_block<'py>(
        &self,
        py: Python<'py>,
        first: [usize; 3],
        owned: [usize; 3],
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<&Bound<'py, PyAny>>,
        brick: Option<usize>,
        iso: f32,
    ) -> PyResult<Bound<'py, PyTuple>> {
        self.solid("mesh")?;
        let opts = self.sample_options(res, band, bounds_arg(bounds)?, brick);
        let piece = run(py, None, "mesh", |job| {
            let scene = self.scene()?;
            let plan = scene.plan(&opts).map_err(scene_err)?;
            if (0..3).any(|a| {
                owned[a] == 0
                    || first[a]
                        .checked_add(owned[a])
                        .is_none_or(|end| end > plan.dims[a])
            }) {
                return Err(PyValueError::new_err(format!(
                    "the block of {owned:?} samples from {first:?} is not inside the lattice of {:?} samples",
                    plan.dims
                )));
            }
            let dims: [usize; 3] = std::array::from_fn(|a| {
                (first[a].saturating_add(owned[a]).saturating_add(1))
                    .min(plan.dims[a])
                    .saturating_sub(first[a])
                    .max(1)
            });
            let g = self.block_grid(opts, first, dims, job)?;
            let mo = isokit_levelset::meshing::MeshOptions {
                iso,
                close_boundary: true,
            };
            isokit_levelset::meshing::mesh_lattice_block(
                plan.dims,
                plan.origin,
                plan.spacing,
                first,
                owned,
                g.data(),
                &mo,
            )
            .map_err(value_err)
        })?;
        let n = piece.positions.len();
        let keys = numpy::PyArray1::from_vec(py, piece.keys);
        let pos: Vec<f32> = piece.positions.iter().flat_map(|p| p.to_array()).collect();
        let pos = numpy::PyArray1::from_vec(py, pos).reshape([n, 3])?;
        let m = piece.triangles.len();
        let tri: Vec<u32> = piece.triangles.into_iter().flatten().collect();
        let tri = numpy::PyArray1::from_vec(py, tri).reshape([m, 3])?;
        PyTuple::new(py, [keys.into_any(), pos.into_any(), tri.into_any()])
    }

    /// Pickling (Dask and multiprocessing send shapes to other processes): the shape travels
    /// as its scene file (`to_json`), so shapes holding arrays in memory are refused, naming
    /// the node; save them first (`to_json(save_sources_to=DIR)`, then `isokit.load_scene`).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let text = self.to_json(None, None)?;
        let f = py.import("isokit._isokit")?.getattr("_shape_from_json")?;
        Ok((f, (text,)))
    }

    /// The surface as a triangle mesh `(V, F)`: float64 `(n, 3)` vertices and int64 `(m, 3)`
    /// triangles (an `isokit.Mesh` named tuple with `.to_trimesh()` and `.stats`). Marching
    /// cubes with the asymptotic decider on the lazily sampled band: watertight and
    /// consistently oriented. `res`, `band`, `bounds` as for `sample`; `dense` evaluates the
    /// whole lattice (the baseline; the same mesh). `mesher`: `"mc"` (marching cubes, the
    /// default) or `"dual"` (dual contouring with Hermite data from the shape's exact field:
    /// sharp edges and corners; watertight, 2-manifold and oriented). `error` (`"dual"` only, world units): adaptive meshing, cells merged
    /// into octree nodes where one vertex lies within `error` of every crossing's tangent
    /// plane and of the exact surface, keeping the surface's topology (few large triangles
    /// where it is flat); `stats["merged_cells"]` counts the cells merged.
    #[pyo3(signature = (res = None, band = None, bounds = None, dense = false, mesher = "mc", progress = None, error = None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        res: Option<usize>,
        band: Option<f32>,
        bounds: Option<&Bound<'py, PyAny>>,
        dense: bool,
        mesher: &str,
        progress: Option<&Bound<'py, PyAny>>,
        error: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.solid("mesh")?;
        let mesher = parse_mesher(mesher)?;
        let opts = MeshOptions {
            sampling: self.sample_options(res, band, bounds_arg(bounds)?, None),
            dense,
            mesher,
            error: parse_error(mesher, error)?,
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
        self.solid("render")?;
        let args = RenderArgs::parse(
            width, height, shading, camera, backend, res, iso, projection, background,
        )?;
        render::render_shape(py, self, &args, progress)
    }

    /// 2 for a 2D profile (`isokit.circle`, `rectangle`, `polygon`, … and their CSG,
    /// offsets and transforms in the xy-plane), 3 for a solid. Profiles become solids by
    /// `extrude` and `revolve`; meshing, sampling and rendering need a solid.
    #[getter]
    fn dim(&self) -> u8 {
        vocab::dim(self.node())
    }

    /// The node's colour `(r, g, b)` (linear RGB in `[0, 1]`), or `None`.
    #[getter]
    fn color(&self) -> Option<(f32, f32, f32)> {
        self.node().uncolored().1.map(|[r, g, b]| (r, g, b))
    }

    /// The shape with the colour `color` = `(r, g, b)`, linear RGB each in `[0, 1]` (the
    /// scene files' `"color"` beside the node's kind): the renderer draws the surface it
    /// owns in it, and `isokit scene … -o part.ply` writes it per vertex. The field does
    /// not change. `isokit.sphere(0.5).with_color((0.8, 0.1, 0.1))`.
    fn with_color(&self, color: &Bound<'_, PyAny>) -> PyResult<Shape> {
        let c = vec3_arg(color, "color")?;
        if !c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
            return Err(PyValueError::new_err(format!(
                "color {c:?}: each component must be in [0, 1] (linear RGB)"
            )));
        }
        let (node, _) = self.node().uncolored();
        Shape::derived(node.clone().with_color(c), Some(self), &[], 0)
    }

    /// A scale per axis and/or a rotation and a translation: the scene files' `transform`
    /// node, applied as scale, then rotate, then translate. `scale`: one number (exact) or
    /// `(sx, sy, sz)` (a distance bound, `min(s)·f(p/s)`); `rotate`: `(axis, degrees)` or
    /// `{"axis": …, "degrees": …}`; `translate`: three numbers. Numbers may be
    /// `isokit.param`s.
    ///
    /// >>> isokit.sphere(1.0).transform(scale=(1, 2, 1))  # an ellipsoid-like bound
    #[pyo3(signature = (translate = None, rotate = None, scale = None))]
    fn transform(
        &self,
        py: Python<'_>,
        translate: Option<&Bound<'_, PyAny>>,
        rotate: Option<&Bound<'_, PyAny>>,
        scale: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        let rotate = match rotate {
            Some(r) if !r.is_none() && !r.is_instance_of::<PyDict>() => {
                let (axis, degrees): (Bound<'_, PyAny>, Bound<'_, PyAny>) =
                    r.extract().map_err(|_| {
                        PyTypeError::new_err(
                            "rotate must be (axis, degrees) or {\"axis\": …, \"degrees\": …}",
                        )
                    })?;
                let d = PyDict::new(py);
                d.set_item("axis", axis)?;
                d.set_item("degrees", degrees)?;
                Some(d.into_any())
            }
            r => r.cloned(),
        };
        self.op(
            "transform",
            &[
                ("translate", translate),
                ("rotate", rotate.as_ref()),
                ("scale", scale),
            ],
        )
    }

    /// The 2D profile extruded along z from `-height/2` to `height/2`, its cap edges rounded
    /// by `round` (default 0). Exact where the profile is.
    ///
    /// >>> isokit.circle(radius=1.0).extrude(height=0.5)
    #[pyo3(signature = (height, round = None))]
    fn extrude(
        &self,
        height: &Bound<'_, PyAny>,
        round: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.op("extrude", &[("height", Some(height)), ("round", round)])
    }

    /// The 2D profile revolved about the z axis: the profile's x is the distance from the
    /// axis less `offset` (default 0), its y is z. Exact where the profile is.
    ///
    /// >>> isokit.circle(radius=0.2).revolve(offset=1.0)  # a torus
    #[pyo3(signature = (offset = None))]
    fn revolve(&self, offset: Option<&Bound<'_, PyAny>>) -> PyResult<Shape> {
        self.op("revolve", &[("offset", offset)])
    }

    /// The reflection in the plane `normal · p = offset` (exact).
    ///
    /// >>> isokit.sphere(0.3, center=(1, 0, 0)).mirror(normal=(1, 0, 0))
    #[pyo3(signature = (normal, offset = None))]
    fn mirror(
        &self,
        normal: &Bound<'_, PyAny>,
        offset: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.op("mirror", &[("normal", Some(normal)), ("offset", offset)])
    }

    /// The solid turned so that its z axis points along `axis` (exact).
    ///
    /// >>> isokit.cylinder(a=(0, 0, -1), b=(0, 0, 1), radius=0.2).orient(axis=(1, 0, 0))
    fn orient(&self, axis: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("orient", &[("axis", Some(axis))])
    }

    /// A general invertible affine map, `matrix` its three rows `[a, b, c, t]`
    /// (`world_i = a·x + b·y + c·z + t`): `f(A⁻¹p)` times the smallest singular value of
    /// `A`, a distance bound.
    ///
    /// >>> isokit.sphere(1.0).affine(matrix=[[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]])
    fn affine(&self, matrix: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("affine", &[("matrix", Some(matrix))])
    }

    /// Infinite repetition with `period` per axis (0: that axis is not repeated); exact for
    /// a shape smaller than its cell.
    ///
    /// >>> isokit.sphere(0.2).repeat(period=(1, 1, 0))
    fn repeat(&self, period: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("repeat", &[("period", Some(period))])
    }

    /// A finite array of copies: `count` per axis (integers ≥ 1), copy `i` moved by
    /// `i · spacing`.
    ///
    /// >>> isokit.sphere(0.2).array(count=(3, 2, 1), spacing=(0.5, 0.5, 0))
    fn array(&self, count: &Bound<'_, PyAny>, spacing: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op(
            "array",
            &[("count", Some(count)), ("spacing", Some(spacing))],
        )
    }

    /// `count` copies turned by `360°/count` about `axis` through the origin (default z).
    ///
    /// >>> isokit.cylinder(a=(1, 0, -1), b=(1, 0, 1), radius=0.1).circular_array(count=6)
    #[pyo3(signature = (count, axis = None))]
    fn circular_array(
        &self,
        count: &Bound<'_, PyAny>,
        axis: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.op("circular_array", &[("count", Some(count)), ("axis", axis)])
    }

    /// A twist about `axis` (default z): the cross-section at height `z` turned by
    /// `rate · z` degrees. A distance bound (the map's stretch divided out).
    ///
    /// >>> isokit.box(half=(0.5, 0.2, 1)).twist(rate=45)
    #[pyo3(signature = (rate, axis = None))]
    fn twist(&self, rate: &Bound<'_, PyAny>, axis: Option<&Bound<'_, PyAny>>) -> PyResult<Shape> {
        self.op("twist", &[("rate", Some(rate)), ("axis", axis)])
    }

    /// A bend of the x axis into an arc, `rate` degrees per unit length (towards +y). A
    /// distance bound.
    ///
    /// >>> isokit.box(half=(1, 0.1, 0.1)).bend(rate=30)
    fn bend(&self, rate: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("bend", &[("rate", Some(rate))])
    }

    /// A taper along `axis` (default z): cross-sections scaled by `1 + rate · z`. A distance
    /// bound.
    ///
    /// >>> isokit.cylinder(a=(0, 0, -1), b=(0, 0, 1), radius=0.5).taper(rate=-0.3)
    #[pyo3(signature = (rate, axis = None))]
    fn taper(&self, rate: &Bound<'_, PyAny>, axis: Option<&Bound<'_, PyAny>>) -> PyResult<Shape> {
        self.op("taper", &[("rate", Some(rate)), ("axis", axis)])
    }

    /// The shape cut at the coordinate planes and its parts moved apart by `by` (three
    /// numbers ≥ 0): longer by `by` along each axis. Exact outside.
    ///
    /// >>> isokit.sphere(0.5).elongate(by=(1, 0, 0))  # a capsule along x
    fn elongate(&self, by: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("elongate", &[("by", Some(by))])
    }

    /// Rounding by `radius`: the surface moved out by it, `f − radius` (the same as
    /// `offset`, under the name fogleman's `sdf` and Quilez use).
    ///
    /// >>> isokit.box(half=0.5).round(radius=0.1)
    fn round(&self, radius: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("round", &[("radius", Some(radius))])
    }

    /// A shell of wall `thickness` around the surface, `|f| − thickness/2` (the same as
    /// `shell`, under Quilez's name).
    ///
    /// >>> isokit.sphere(1.0).onion(thickness=0.1)
    fn onion(&self, thickness: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.op("onion", &[("thickness", Some(thickness))])
    }

    /// The union with `other` with a 45° chamfer of size `radius` where they meet (hg_sdf).
    ///
    /// >>> isokit.box(0.5).chamfer_union(isokit.sphere(0.4, center=(0.5, 0, 0)), radius=0.1)
    fn chamfer_union(&self, other: PyRef<'_, Shape>, radius: &Bound<'_, PyAny>) -> PyResult<Shape> {
        self.blend("chamfer_union", &other, &[("radius", Some(radius))])
    }

    /// The intersection with `other`, chamfered by `radius` (hg_sdf).
    ///
    /// >>> isokit.box(0.5).chamfer_intersection(isokit.sphere(0.65), radius=0.05)
    fn chamfer_intersection(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
    ) -> PyResult<Shape> {
        self.blend("chamfer_intersection", &other, &[("radius", Some(radius))])
    }

    /// This shape minus `other`, chamfered by `radius` (hg_sdf).
    ///
    /// >>> isokit.box(0.5).chamfer_difference(isokit.cylinder(radius=0.2, a=(0, 0, -1), b=(0, 0, 1)), radius=0.05)
    fn chamfer_difference(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
    ) -> PyResult<Shape> {
        self.blend("chamfer_difference", &other, &[("radius", Some(radius))])
    }

    /// The union with `other` with `steps` stairs (default 4) over `radius` where they meet
    /// (hg_sdf).
    ///
    /// >>> isokit.box(0.5).stairs_union(isokit.sphere(0.4, center=(0.5, 0, 0)), radius=0.2, steps=3)
    #[pyo3(signature = (other, radius, steps = None))]
    fn stairs_union(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
        steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.stairs("stairs_union", &other, radius, steps)
    }

    /// The intersection with `other` with stairs (hg_sdf).
    ///
    /// >>> isokit.box(0.5).stairs_intersection(isokit.sphere(0.65), radius=0.1, steps=3)
    #[pyo3(signature = (other, radius, steps = None))]
    fn stairs_intersection(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
        steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.stairs("stairs_intersection", &other, radius, steps)
    }

    /// This shape minus `other` with stairs (hg_sdf).
    ///
    /// >>> isokit.box(0.5).stairs_difference(isokit.sphere(0.3, center=(0.5, 0.5, 0.5)), radius=0.1)
    #[pyo3(signature = (other, radius, steps = None))]
    fn stairs_difference(
        &self,
        other: PyRef<'_, Shape>,
        radius: &Bound<'_, PyAny>,
        steps: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Shape> {
        self.stairs("stairs_difference", &other, radius, steps)
    }

    /// A PNG of the shape (320×240, CPU), for Jupyter.
    /// (None for a 2D profile, which has no picture of its own.)
    fn _repr_png_<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<Bound<'py, pyo3::types::PyBytes>>> {
        if vocab::dim(self.node()) == 2 {
            return Ok(None);
        }
        let args = RenderArgs::parse(320, 240, None, None, "cpu", None, None, "perspective", None)?;
        let frame =
            render::render_shape(py, self, &args, Some(&pyo3::types::PyBool::new(py, false)))?;
        frame.png(py).map(Some)
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

/// A points node's knobs from the Python arguments.
fn set_cloud_options(node: &mut Node, k: Option<usize>, normals: &str, sign: &str) -> PyResult<()> {
    if let Node::Points(p) = node {
        p.k = k;
        p.normals = parse_enum(normals, "normals", "\"auto\", \"given\", \"estimate\"")?;
        p.sign = parse_enum(
            sign,
            "sign",
            "\"winding\", \"nearest\", \"winding_everywhere\"",
        )?;
    }
    Ok(())
}

/// `isokit._points_path(path, k, normals, sign)`.
#[pyfunction]
pub fn _points_path(
    path: std::path::PathBuf,
    k: Option<usize>,
    normals: &str,
    sign: &str,
) -> PyResult<Shape> {
    let mut node = Node::points(tree::absolute(&path.display().to_string(), Path::new(".")));
    set_cloud_options(&mut node, k, normals, sign)?;
    Ok(Shape::new(node))
}

/// `isokit._points_arrays(P, N, k, normals, sign)`.
#[pyfunction]
#[pyo3(signature = (p, n, k, normals, sign))]
pub fn _points_arrays(
    p: &Bound<'_, PyAny>,
    n: Option<&Bound<'_, PyAny>>,
    k: Option<usize>,
    normals: &str,
    sign: &str,
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
    set_cloud_options(&mut node, k, normals, sign)?;
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

/// The shapes of a call's `*shapes`, at least `min`.
fn collect_shapes<'py>(
    items: &Bound<'py, PyTuple>,
    what: &str,
    min: usize,
) -> PyResult<Vec<Bound<'py, Shape>>> {
    let out = items
        .iter()
        .map(|it| {
            it.cast::<Shape>().cloned().map_err(|_| {
                PyTypeError::new_err(format!("{what} takes shapes, got {}", it.get_type()))
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    if out.len() < min {
        return Err(PyValueError::new_err(format!(
            "{what} needs at least {min} shapes, got {}",
            out.len()
        )));
    }
    Ok(out)
}

/// The n-ary node `f(children)` of the shapes of a call.
fn nary(
    shapes: &Bound<'_, PyTuple>,
    what: &str,
    min: usize,
    f: impl FnOnce(Vec<Node>) -> Node,
) -> PyResult<Shape> {
    let shapes = collect_shapes(shapes, what, min)?;
    let kids: Vec<&Shape> = shapes.iter().map(|s| s.get()).collect();
    let node = f(kids.iter().map(|s| s.node().clone()).collect());
    Shape::derived(node, None, &kids, 0)
}

/// `isokit.union(*shapes)`: the union of all (one n-ary node: with many operands a
/// bounding-volume hierarchy prunes the evaluation).
#[pyfunction]
#[pyo3(signature = (*shapes))]
pub fn union(shapes: &Bound<'_, PyTuple>) -> PyResult<Shape> {
    nary(shapes, "union", 1, Node::union)
}

/// `isokit.intersection(*shapes)`: the intersection of all.
#[pyfunction]
#[pyo3(signature = (*shapes))]
pub fn intersection(shapes: &Bound<'_, PyTuple>) -> PyResult<Shape> {
    nary(shapes, "intersection", 1, Node::intersection)
}

/// `isokit.difference(a, *others)`: `a` minus all the others.
#[pyfunction]
#[pyo3(signature = (*shapes))]
pub fn difference(shapes: &Bound<'_, PyTuple>) -> PyResult<Shape> {
    nary(shapes, "difference", 2, Node::difference)
}

/// `isokit.smooth_union(*shapes, radius)`: the union of all, blended over `radius`.
#[pyfunction]
#[pyo3(signature = (*shapes, radius))]
pub fn smooth_union(shapes: &Bound<'_, PyTuple>, radius: &Bound<'_, PyAny>) -> PyResult<Shape> {
    if vocab::holds_param(radius) {
        let shapes = collect_shapes(shapes, "smooth_union", 1)?;
        let kids = shapes.iter().map(|s| s.get()).collect();
        return build(
            "smooth_union",
            &[("radius", Some(radius))],
            Of::Many(kids),
            None,
        );
    }
    let r = finite(number(radius, "radius")?, "radius")?;
    nary(shapes, "smooth_union", 1, |v| Node::smooth_union(r, v))
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
        // The parameters' references, kept for `to_json` (JSON files; a TOML file's shape
        // is written with the numbers).
        let refs = match format {
            isokit_scene::SceneFormat::Json => serde_json::from_str(&text)
                .map(|doc| vocab::references(&doc))
                .unwrap_or_default()
                .into_iter()
                .filter(|(_, n)| file.params.contains_key(n))
                .collect(),
            isokit_scene::SceneFormat::Toml => Vec::new(),
        };
        let dir = path.parent().unwrap_or(Path::new("."));
        tree::absolutize(&mut file.shape, dir)?;
        let mut shape = Shape::with_file(file);
        shape.refs = refs;
        Ok(shape)
    })
}

/// A shape from the text of its scene file (JSON, paths absolute): how a pickled shape is
/// rebuilt (`Shape.__reduce__`).
#[pyfunction]
pub fn _shape_from_json(text: &str) -> PyResult<Shape> {
    guarded(|| {
        let file = isokit_scene::parse(text, isokit_scene::SceneFormat::Json, "pickled shape")
            .map_err(scene_err)?;
        Ok(Shape::with_file(file))
    })
}
