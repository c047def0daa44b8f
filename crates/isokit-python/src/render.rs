//! Rendering from Python: `Shape.render`, `Field.render`, `Molecule.render` → `isokit.Frame`.

use crate::errors::{io_err, scene_err, value_err};
use crate::run::{guarded, run};
use crate::shape::{Shape, vec3_arg};
use isokit_gpu::BackendChoice;
use isokit_render::{GBUFFER_CHANNELS, GBuffer, Image, Layout, ShadingMode, Volume};
use isokit_scene::{CameraSpec, ProjectionKind, RenderSettings, RenderTarget, Renderer};
use numpy::PyArray2;
use numpy::ndarray::{Array2, Array3};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{LazyLock, Mutex};

/// The largest image side accepted (pixels).
const MAX_SIDE: u32 = 16_384;
/// The most pixels of one image.
const MAX_PIXELS: u64 = 64 << 20;

/// Renderers opened so far, one per backend choice (opening a device takes a while).
static RENDERERS: LazyLock<Mutex<HashMap<&'static str, Renderer>>> =
    LazyLock::new(|| Mutex::new(HashMap::new()));

/// Runs `f` with the renderer for `choice`, opening it on first use.
pub(crate) fn with_renderer<T>(
    choice: BackendChoice,
    f: impl FnOnce(&mut Renderer) -> PyResult<T>,
) -> PyResult<T> {
    let mut map = RENDERERS.lock().unwrap_or_else(|e| e.into_inner());
    let r = match map.entry(choice.name()) {
        std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
        std::collections::hash_map::Entry::Vacant(e) => {
            e.insert(Renderer::new(choice).map_err(value_err)?)
        }
    };
    f(r)
}

/// The parsed arguments of a `render` call.
pub struct RenderArgs {
    /// The library's settings.
    pub settings: RenderSettings,
    /// The backend.
    pub backend: BackendChoice,
}

/// A camera from an `isokit.Camera` or a dict `{"eye", "target", "up", "fov"}`.
pub fn camera_arg(obj: &Bound<'_, PyAny>) -> PyResult<CameraSpec> {
    let get = |key: &str| -> PyResult<Option<Bound<'_, PyAny>>> {
        if let Ok(d) = obj.cast::<PyDict>() {
            for k in d.keys() {
                let k: String = k.extract()?;
                if !["eye", "target", "up", "fov"].contains(&k.as_str()) {
                    return Err(PyValueError::new_err(format!(
                        "camera has no key {k:?}; its keys are eye, target, up, fov"
                    )));
                }
            }
            d.get_item(key)
        } else {
            match obj.getattr(key) {
                Ok(v) => Ok(Some(v)),
                Err(_) => Ok(None),
            }
        }
    };
    let eye = get("eye")?.filter(|v| !v.is_none()).ok_or_else(|| {
        PyTypeError::new_err(
            "camera must be an isokit.Camera or a dict with at least \"eye\" (and \
                 \"target\", \"up\", \"fov\")",
        )
    })?;
    let vec = |key: &str, default: [f32; 3]| -> PyResult<[f32; 3]> {
        match get(key)? {
            Some(v) if !v.is_none() => vec3_arg(&v, &format!("camera {key}")),
            _ => Ok(default),
        }
    };
    let fov = match get("fov")? {
        Some(v) if !v.is_none() => v.extract::<f32>()?,
        _ => 45.0,
    };
    Ok(CameraSpec {
        eye: vec3_arg(&eye, "camera eye")?,
        target: vec("target", [0.0; 3])?,
        up: vec("up", [0.0, 1.0, 0.0])?,
        fov,
        ortho_height: None,
    })
}

/// A backend name as the renderer's choice, or a `ValueError`.
pub(crate) fn backend_arg(s: &str) -> PyResult<BackendChoice> {
    BackendChoice::parse(s).map_err(|_| {
        PyValueError::new_err(format!(
            "backend = {s:?} is not one of \"auto\", \"cpu\", \"gpu\""
        ))
    })
}

fn size_arg(width: u32, height: u32) -> PyResult<()> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(PyValueError::new_err(format!(
            "image size {width}x{height}: each side must be 1 to {MAX_SIDE} pixels"
        )));
    }
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(PyValueError::new_err(format!(
            "image size {width}x{height} has more than {MAX_PIXELS} pixels"
        )));
    }
    Ok(())
}

impl RenderArgs {
    /// Checks and gathers the arguments.
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    pub fn parse(
        width: u32,
        height: u32,
        shading: Option<&str>,
        camera: Option<&Bound<'_, PyAny>>,
        backend: &str,
        res: Option<usize>,
        iso: Option<f32>,
        projection: &str,
        background: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        size_arg(width, height)?;
        let mode = shading
            .map(|s| s.parse::<ShadingMode>().map_err(PyValueError::new_err))
            .transpose()?;
        let camera = match camera {
            Some(c) if !c.is_none() => Some(camera_arg(c)?),
            _ => None,
        };
        let projection = match projection {
            "perspective" => ProjectionKind::Perspective,
            "orthographic" => ProjectionKind::Orthographic,
            p => {
                return Err(PyValueError::new_err(format!(
                    "projection = {p:?} is not one of \"perspective\", \"orthographic\""
                )));
            }
        };
        if let Some(i) = iso
            && !i.is_finite()
        {
            return Err(PyValueError::new_err(format!("iso = {i} must be finite")));
        }
        let background = match background {
            Some(b) if !b.is_none() => {
                let v: Vec<f32> = b.extract().map_err(|_| {
                    PyTypeError::new_err("background must be 3 or 4 numbers (linear RGB(A))")
                })?;
                match v.as_slice() {
                    [r, g, b] => Some([*r, *g, *b, 1.0]),
                    [r, g, b, a] => Some([*r, *g, *b, *a]),
                    _ => {
                        return Err(PyValueError::new_err(
                            "background must be 3 or 4 numbers (linear RGB(A))",
                        ));
                    }
                }
            }
            _ => None,
        };
        let settings = RenderSettings {
            width,
            height,
            iso,
            mode,
            projection,
            camera,
            background,
            resolution: res,
            ..RenderSettings::default()
        };
        Ok(Self {
            settings,
            backend: backend_arg(backend)?,
        })
    }
}

/// A rendered image with its G-buffer and statistics.
///
/// `frame.image` (and `np.asarray(frame)`) is the shaded image, an `(H, W, 4)` uint8 sRGB
/// array with row 0 at the top; `frame.gbuffer` a dict of float32 `(H, W)` arrays keyed by
/// the EXR channel names (`P.X P.Y P.Z` world position, `N.X N.Y N.Z` unit normal, `Z`
/// distance along the ray, `K1 K2` principal curvatures, `A` coverage; 0 where no ray hit).
#[pyclass(frozen, module = "isokit", name = "Frame")]
pub struct Frame {
    image: Image,
    gbuffer: Planes,
    stats: serde_json::Value,
    notes: Vec<String>,
}

/// What a frame holds beside its image: an isosurface's G-buffer, or a direct volume
/// rendering's planes (`R G B` premultiplied, `A` opacity, `Z` the depth where the opacity
/// passes 0.5).
enum Planes {
    Surface(GBuffer),
    Volume(Box<isokit_render::dvr::DvrImage>, isokit_field::Camera),
}

impl Frame {
    /// A frame of a surface: its shaded image, its G-buffer, what the rendering reported.
    pub(crate) fn from_surface(image: Image, gbuffer: GBuffer, stats: serde_json::Value) -> Self {
        Self {
            image,
            gbuffer: Planes::Surface(gbuffer),
            stats,
            notes: Vec::new(),
        }
    }

    /// A frame of a direct volume rendering seen through `camera`.
    pub(crate) fn from_volume(
        img: isokit_render::dvr::DvrImage,
        camera: isokit_field::Camera,
        stats: serde_json::Value,
    ) -> Self {
        Self {
            image: img.to_image(glam::Vec3::ZERO),
            gbuffer: Planes::Volume(Box::new(img), camera),
            stats,
            notes: Vec::new(),
        }
    }

    /// The image as PNG bytes.
    pub fn png<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = isokit_io::encode_png(
            self.image.width,
            self.image.height,
            &self.image.to_rgba8(),
            "frame",
        )
        .map_err(io_err)?;
        Ok(PyBytes::new(py, &bytes))
    }
}

#[pymethods]
impl Frame {
    /// The shaded image: `(H, W, 4)` uint8, sRGB, row 0 at the top.
    #[getter]
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        let a = Array3::from_shape_vec((h, w, 4), self.image.to_rgba8()).map_err(value_err)?;
        Ok(numpy::PyArray3::from_owned_array(py, a).into_any())
    }

    /// The shaded image in linear RGBA: `(H, W, 4)` float32.
    #[getter]
    fn linear<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        let flat: Vec<f32> = self.image.pixels.iter().flatten().copied().collect();
        let a = Array3::from_shape_vec((h, w, 4), flat).map_err(value_err)?;
        Ok(numpy::PyArray3::from_owned_array(py, a).into_any())
    }

    /// The G-buffer: a dict of float32 `(H, W)` arrays keyed by the EXR channel names.
    #[getter]
    fn gbuffer<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let (w, h, planes): (u32, u32, Vec<(&str, Vec<f32>)>) = match &self.gbuffer {
            Planes::Surface(g) => (
                g.width(),
                g.height(),
                GBUFFER_CHANNELS.iter().copied().zip(g.channels()).collect(),
            ),
            Planes::Volume(img, _) => (img.width, img.height, img.channels()),
        };
        for (name, plane) in planes {
            let a = Array2::from_shape_vec((h as usize, w as usize), plane).map_err(value_err)?;
            d.set_item(name, PyArray2::from_owned_array(py, a))?;
        }
        Ok(d)
    }

    /// Width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.image.width
    }

    /// Height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.image.height
    }

    /// Counters and timing (the `--stats` object of `isokit render`), as a dict.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::field::json_to_py(py, &self.stats)
    }

    /// Notes for the user (an isovalue chosen from the data, no ray hit, …).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    #[pyo3(signature = (dtype = None, copy = None))]
    fn __array__<'py>(
        &self,
        py: Python<'py>,
        dtype: Option<&Bound<'py, PyAny>>,
        copy: Option<bool>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let _ = copy;
        let img = self.image(py)?;
        match dtype {
            Some(d) if !d.is_none() => img.call_method1("astype", (d,)),
            _ => Ok(img),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "isokit.Frame({}x{}, {} notes)",
            self.image.width,
            self.image.height,
            self.notes.len()
        )
    }

    /// Writes the image as an sRGB PNG.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        guarded(|| self.image.write_png(Path::new(&path)).map_err(value_err))
    }

    /// Writes the G-buffer as OpenEXR (the channels of `gbuffer`).
    fn save_gbuffer(&self, path: PathBuf) -> PyResult<()> {
        guarded(|| match &self.gbuffer {
            Planes::Surface(g) => g.write_exr(Path::new(&path)).map_err(value_err),
            Planes::Volume(img, camera) => {
                img.write_exr(Path::new(&path), camera).map_err(value_err)
            }
        })
    }

    /// The image as PNG bytes, for Jupyter.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        self.png(py)
    }
}

/// Renders a shape.
pub fn render_shape(
    py: Python<'_>,
    shape: &Shape,
    args: &RenderArgs,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Frame> {
    let frame = run(py, progress, "render", |job| {
        let scene = shape.scene()?;
        with_renderer(args.backend, |r| {
            r.render(RenderTarget::Scene(&scene), &args.settings, job)
                .map_err(scene_err)
        })
    })?;
    Ok(Frame {
        stats: serde_json::to_value(&frame.stats).unwrap_or_default(),
        image: frame.image,
        gbuffer: Planes::Surface(frame.gbuffer),
        notes: frame.notes,
    })
}

/// Renders a sampled grid (inside below its isovalue).
pub fn render_grid(
    py: Python<'_>,
    grid: isokit_field::Grid,
    args: &RenderArgs,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Frame> {
    let frame = run(py, progress, "render", |job| {
        let volume = Volume::from_grid(grid, Layout::default()).map_err(value_err)?;
        with_renderer(args.backend, |r| {
            r.render(RenderTarget::Volume(&volume), &args.settings, job)
                .map_err(scene_err)
        })
    })?;
    Ok(Frame {
        stats: serde_json::to_value(&frame.stats).unwrap_or_default(),
        image: frame.image,
        gbuffer: Planes::Surface(frame.gbuffer),
        notes: frame.notes,
    })
}

/// A molecule read from a PDB or mmCIF file (gzipped or not): `isokit.molecule(path)`.
#[pyclass(frozen, module = "isokit", name = "Molecule")]
pub struct Molecule {
    mol: isokit_molecule::Molecule,
    path: String,
}

#[pymethods]
impl Molecule {
    /// The number of atoms (first model, first alternate location).
    #[getter]
    fn atoms(&self) -> usize {
        self.mol.atoms.len()
    }

    /// The number of bonds (CONECT records and covalent radii).
    #[getter]
    fn bonds(&self) -> usize {
        self.mol.bonds.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "isokit.Molecule({:?}, atoms={}, bonds={})",
            self.path,
            self.mol.atoms.len(),
            self.mol.bonds.len()
        )
    }

    /// Splats the molecule as quadrics (Sigg 2006, Ch. 7) and returns an `isokit.Frame`.
    /// `style`: `"balls"` (ball-and-stick) or `"spacefill"`; `shading`: a mode name;
    /// `shadows`: soft shadows from a spot light behind the camera; `outlines`: silhouettes
    /// and creases; `camera`: as for `Shape.render` (default: framing the molecule).
    #[pyo3(signature = (width = 512, height = 512, style = "balls", shading = "phong", shadows = false, outlines = false, camera = None, backend = "auto"))]
    #[expect(
        clippy::too_many_arguments,
        reason = "one argument per Python keyword argument"
    )]
    fn render(
        &self,
        py: Python<'_>,
        width: u32,
        height: u32,
        style: &str,
        shading: &str,
        shadows: bool,
        outlines: bool,
        camera: Option<&Bound<'_, PyAny>>,
        backend: &str,
    ) -> PyResult<Frame> {
        size_arg(width, height)?;
        let mode = shading
            .parse::<ShadingMode>()
            .map_err(PyValueError::new_err)?;
        let style: isokit_molecule::MoleculeStyle = style
            .parse()
            .map_err(|e: String| PyValueError::new_err(e))?;
        let backend = backend_arg(backend)?;
        let camera = match camera {
            Some(c) if !c.is_none() => Some(camera_arg(c)?),
            _ => None,
        };
        let frame = run(py, Some(&crate::quiet(py)), "molecule", |_| {
            let mut settings = isokit_scene::MoleculeSettings {
                width,
                height,
                mode,
                shadows: shadows.then(Default::default),
                outlines,
                ..Default::default()
            };
            settings.model.style = style;
            if let Some(spec) = &camera {
                let c = isokit_scene::camera_for(
                    Some(spec),
                    isokit_field::Aabb::EMPTY,
                    ProjectionKind::Perspective,
                    width,
                    height,
                )
                .map_err(value_err)?;
                settings.camera = Some(c);
            }
            with_renderer(backend, |r| {
                r.render_molecule(&self.mol, &settings).map_err(value_err)
            })
        })?;
        Ok(Frame {
            stats: serde_json::to_value(&frame.stats).unwrap_or_default(),
            image: frame.image,
            gbuffer: Planes::Surface(frame.frame.gbuffer),
            notes: Vec::new(),
        })
    }

    /// A PNG of the molecule (320×240, CPU), for Jupyter.
    fn _repr_png_<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        self.render(py, 320, 240, "balls", "phong", false, false, None, "cpu")?
            .png(py)
    }
}

/// `isokit.molecule(path)`: reads a PDB (`.pdb`, `.ent`) or mmCIF (`.cif`, `.mmcif`)
/// structure, gzipped or not.
#[pyfunction]
pub fn molecule(py: Python<'_>, path: PathBuf) -> PyResult<Molecule> {
    let mol = py.detach(|| guarded(|| isokit_molecule::read_molecule(&path).map_err(io_err)))?;
    Ok(Molecule {
        mol,
        path: path.display().to_string(),
    })
}

/// The arguments of a direct volume rendering (`Field.render_volume`).
pub struct VolumeRenderArgs<'a> {
    /// Image size.
    pub size: (u32, u32),
    /// The transfer function.
    pub tf: isokit_render::dvr::TransferFunction,
    /// Step, classification, shading.
    pub options: isokit_render::dvr::DvrOptions,
    /// The camera given, if any, and the projection.
    pub camera: Option<&'a Bound<'a, PyAny>>,
    /// `"perspective"` or `"orthographic"`.
    pub projection: &'a str,
    /// `"auto"`, `"cpu"` or `"gpu"`.
    pub backend: &'a str,
}

/// Renders `grid` directly with a transfer function (`isokit_render::dvr`, the GPU twin
/// or the CPU's as `backend` says).
pub fn render_volume_grid(
    py: Python<'_>,
    grid: &isokit_field::Grid,
    a: &VolumeRenderArgs<'_>,
) -> PyResult<Frame> {
    let args = RenderArgs::parse(
        a.size.0,
        a.size.1,
        None,
        a.camera,
        a.backend,
        None,
        None,
        a.projection,
        None,
    )?;
    let s = &args.settings;
    let camera = isokit_scene::camera_for(
        s.camera.as_ref(),
        grid.bounds(),
        s.projection,
        s.width,
        s.height,
    )
    .map_err(value_err)?;
    let t = std::time::Instant::now();
    let (tf, opts, choice) = (&a.tf, &a.options, args.backend);
    let (img, backend) = py.detach(|| {
        guarded(|| {
            with_renderer(choice, |r| {
                let backend = r.backend();
                let img = match r.gpu() {
                    Some(g) => g.render_dvr(grid, &camera, tf, opts),
                    None => isokit_render::dvr::render_dvr(grid, &camera, tf, opts),
                };
                Ok((img.map_err(value_err)?, backend))
            })
        })
    })?;
    let seconds = t.elapsed().as_secs_f64();
    let stats = img.stats(backend, seconds);
    Ok(Frame::from_volume(img, camera, stats))
}

/// The parsed arguments every volume rendering takes: the transfer function (a dict
/// `{"points": [...]}`, or a preset name or JSON file's path that `load` resolves),
/// `classification` (`"post"` or `"preintegrated"`) and `shading` (`"phong"` or None).
pub(crate) fn volume_args(
    py: Python<'_>,
    tf: &Bound<'_, PyAny>,
    load: impl FnOnce(&str) -> Result<isokit_render::dvr::TransferFunction, isokit_render::RenderError>,
    classification: &str,
    shading: Option<&str>,
) -> PyResult<(
    isokit_render::dvr::TransferFunction,
    isokit_render::dvr::Classification,
    bool,
)> {
    use isokit_render::dvr::{Classification, TransferFunction};
    let tf = if tf.cast::<PyDict>().is_ok() {
        let text: String = py.import("json")?.call_method1("dumps", (tf,))?.extract()?;
        TransferFunction::from_json(&text)
    } else {
        let path: PathBuf = tf.extract().map_err(|_| {
            PyTypeError::new_err(
                "tf must be a preset name, a JSON file's path or a dict {\"points\": [...]}",
            )
        })?;
        load(&path.to_string_lossy())
    }
    .map_err(value_err)?;
    let classification = match classification {
        "post" => Classification::Post,
        "preintegrated" => Classification::Preintegrated,
        c => {
            return Err(PyValueError::new_err(format!(
                "classification = {c:?} is not one of \"post\", \"preintegrated\""
            )));
        }
    };
    let shade = match shading {
        None => false,
        Some("phong") => true,
        Some(m) => {
            return Err(PyValueError::new_err(format!(
                "shading = {m:?}: a volume rendering shades with \"phong\" or not at all (None)"
            )));
        }
    };
    Ok((tf, classification, shade))
}
