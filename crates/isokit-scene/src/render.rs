//! Rendering a scene or a volume to a frame (image, G-buffer, statistics) through one
//! [`Renderer`] that hides whether the CPU or the GPU twin runs.

use crate::file::{CameraSpec, LightSpec, ShadingSpec};
use crate::{SampleOptions, SampleStats, Scene, SceneError};
use glam::Vec3;
use isokit_field::{Aabb, Camera, Job, Projection};
use isokit_gpu::BackendChoice;
use isokit_render::gpu::GpuRenderer;
pub use isokit_render::setup::ProjectionKind;
use isokit_render::setup::camera_from;
use isokit_render::shade::default_curvature_scale;
use isokit_render::{
    BrickCache, GBuffer, Image, KeptFrame, Layout, Light, MultiView, RenderError, RenderOptions,
    Shading, ShadingMode, Uniforms, Volume, VolumeData, check_image_size, estimate_gradient_scale,
    supersample,
};
use serde::Serialize;
use std::time::Instant;

fn is_zero(n: &u64) -> bool {
    *n == 0
}

/// The scene's camera, or when it has none a camera framing `bounds` from the front upper
/// right (45° field of view). An orthographic camera with `ortho_height` shows that many
/// world units vertically; without, what the perspective view shows in the target's plane.
pub fn camera_for(
    spec: Option<&CameraSpec>,
    bounds: Aabb,
    kind: ProjectionKind,
    width: u32,
    height: u32,
) -> Result<Camera, RenderError> {
    match spec {
        Some(c) => {
            let (eye, target, up) = (Vec3::from(c.eye), Vec3::from(c.target), Vec3::from(c.up));
            match (kind, c.ortho_height) {
                (ProjectionKind::Orthographic, Some(h)) => {
                    if !(h.is_finite() && h > 0.0) {
                        return Err(RenderError::BadParameter {
                            name: "ortho_height",
                            value: h.to_string(),
                            why: "must be finite and positive (world units)",
                        });
                    }
                    let projection = Projection::Orthographic { height: h };
                    Ok(Camera::look_at(eye, target, up, projection, width, height)?)
                }
                _ => camera_from(eye, target, up, c.fov, kind, width, height),
            }
        }
        None => {
            let projection = match kind {
                ProjectionKind::Perspective => Projection::Perspective {
                    fov_y_degrees: 45.0,
                },
                ProjectionKind::Orthographic => Projection::Orthographic { height: 1.0 },
            };
            let from = Vec3::new(1.0, 0.7, 1.4);
            Ok(Camera::framing(bounds, from, projection, width, height)?)
        }
    }
}

/// Shading from a scene's `shading` table and `lights` (missing values take
/// [`Shading::default`]'s).
pub fn shading_for(
    spec: Option<&ShadingSpec>,
    lights: &[LightSpec],
) -> Result<Shading, RenderError> {
    let mut sh = Shading::default();
    if let Some(s) = spec {
        if let Some(m) = s.mode {
            sh.mode = m.0;
        }
        if let Some(c) = s.color {
            sh.color = Vec3::from(c);
        }
        if let Some(a) = s.ambient {
            sh.ambient = a;
        }
        if let Some(e) = s.shininess {
            sh.shininess = e;
        }
    }
    for (i, l) in lights.iter().enumerate() {
        if l.direction.is_none() && l.position.is_none() {
            return Err(RenderError::BadParameter {
                name: "lights",
                value: i.to_string(),
                why: "a light needs a direction (directional) or a position (point)",
            });
        }
        sh.lights.push(Light {
            direction: l.direction.map(Vec3::from),
            position: l.position.map(Vec3::from),
            color: Vec3::from(l.color),
            intensity: l.intensity,
        });
    }
    sh.check()?;
    Ok(sh)
}

/// What to render.
#[derive(Clone, Copy, Debug)]
pub enum RenderTarget<'a> {
    /// A compiled scene, sampled lazily to a band first (a distance field; its camera,
    /// lights and shading come from the scene unless the settings override them).
    Scene(&'a Scene),
    /// A volume on the ray caster's layout (a file's samples, possibly with a second
    /// operand for on-the-fly CSG); not known to be a distance field.
    Volume(&'a Volume),
    /// A compiled scene with its band already sampled (by [`Scene::sample_again`], with the
    /// options [`scene_options`] gives).
    Sampled(&'a Scene, &'a crate::Sampled),
}

impl<'a> RenderTarget<'a> {
    /// The scene, for scene targets.
    pub fn scene(self) -> Option<&'a Scene> {
        match self {
            RenderTarget::Scene(s) | RenderTarget::Sampled(s, _) => Some(s),
            RenderTarget::Volume(_) => None,
        }
    }
}

/// How to render: image size, camera, shading, the ray caster's knobs.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The ray caster's knobs; `options.iso` is replaced by [`RenderSettings::iso`]'s
    /// resolution.
    pub options: RenderOptions,
    /// The isovalue; `None`: 0, or for a volume whose values do not reach 0 the middle of
    /// its range (with a note).
    pub iso: Option<f32>,
    /// The shading mode (default: the scene's, else Phong).
    pub mode: Option<ShadingMode>,
    /// Perspective or orthographic (same eye, target and field of view).
    pub projection: ProjectionKind,
    /// The camera (default: the scene's `camera`, else one framing the bounds).
    pub camera: Option<CameraSpec>,
    /// The curvature that saturates the curvature maps (default 20 / the diagonal).
    pub curvature_scale: Option<f32>,
    /// The background colour (linear RGBA; default the shading's).
    pub background: Option<[f32; 4]>,
    /// A multi-view autostereoscopic display (paper 001).
    pub multiview: Option<MultiView>,
    /// Replace the multi-view display's separation by the default, 1% of the distance from
    /// the eye to the target.
    pub default_separation: bool,
    /// The brick cache's size in bytes (default: [`isokit_render::DEFAULT_CACHE_BYTES`]).
    pub cache_bytes: Option<usize>,
    /// Scene sampling: samples along the longest side (default: the scene's `sampling`).
    pub resolution: Option<usize>,
    /// Rays per pixel for antialiasing (1, 4, 9, … 64: a `k × k` grid,
    /// [`isokit_render::supersample`]); 1 (the default) traces one ray per pixel.
    pub samples: u32,
    /// Compute the principal curvatures at the hits (the Hessian per pixel) only where the
    /// shading mode reads them ([`ShadingMode::uses_curvature`], following
    /// [`Prepared::set_mode`]) instead of as [`RenderOptions::curvature`] says: for frames
    /// whose G-buffer is not kept (default false).
    pub curvature_follows_mode: bool,
    /// Leave the thin-feature warning out of the frame's notes, for the caller to ask for
    /// it after showing the frame ([`Renderer::thin_note`]; default false).
    pub defer_thin_note: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            options: RenderOptions::default(),
            iso: None,
            mode: None,
            projection: ProjectionKind::Perspective,
            camera: None,
            curvature_scale: None,
            background: None,
            multiview: None,
            default_separation: false,
            cache_bytes: None,
            resolution: None,
            samples: 1,
            curvature_follows_mode: false,
            defer_thin_note: false,
        }
    }
}

/// What one frame did (the `--stats` object of `isokit render`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameStats {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The isovalue rendered.
    pub iso: f32,
    /// The shading mode.
    pub mode: &'static str,
    /// Rays that hit the isosurface.
    pub hits: u64,
    /// Rays that hit a cap (the volume's box inside the solid).
    pub caps: u64,
    /// Field evaluations along all rays.
    pub samples: u64,
    /// Mean field evaluations per ray.
    pub samples_per_ray: f64,
    /// Blocks that hold the isovalue.
    pub blocks_active: usize,
    /// Blocks of the volume.
    pub blocks_total: usize,
    /// Bricks that hold an active block.
    pub bricks_active: usize,
    /// Bricks of the volume.
    pub bricks_total: usize,
    /// Bricks loaded into the cache during the frame.
    pub bricks_loaded: u64,
    /// Brick slots of the cache.
    pub cache_capacity: usize,
    /// Passes over the pending pixels.
    pub passes: u32,
    /// Active bricks held at half resolution.
    pub bricks_downsampled: usize,
    /// Seconds to prepare (sample the scene, build blocks, camera, shading).
    pub prepare_seconds: f64,
    /// Seconds of ray casting.
    pub trace_seconds: f64,
    /// Rays whose pixel was taken from the frame kept before an edit
    /// ([`Renderer::render_prepared_keeping`]); absent from the JSON when none was.
    #[serde(skip_serializing_if = "is_zero")]
    pub rays_reused: u64,
    /// Trace seconds of further frames of the same camera with the brick cache kept (warm),
    /// where the caller rendered them (`isokit render --warm-frames`); empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warm_trace_seconds: Vec<f64>,
    /// Seconds of shading.
    pub shade_seconds: f64,
    /// `gpu` or `cpu`.
    pub backend: &'static str,
    /// The device (`GPU (adapter …)` or `CPU`).
    pub device: String,
    /// The scene's sampling, for scenes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampling: Option<SampleStats>,
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The shaded image (linear RGBA; `write_png` writes sRGB).
    pub image: Image,
    /// Per-pixel hits, positions, normals, curvatures.
    pub gbuffer: GBuffer,
    /// The uniforms the frame was traced with (the camera among them; with
    /// [`RenderSettings::samples`] above 1 those of the supersampled frame, `k` times wider
    /// and higher).
    pub uniforms: Uniforms,
    /// The camera (the centre view's, for multi-view frames).
    pub camera: Camera,
    /// Counters and timing.
    pub stats: FrameStats,
    /// Notes for the user (an isovalue chosen from the data, a band too narrow for the
    /// isovalue, no hit).
    pub notes: Vec<String>,
    /// The object map of a scene with coloured nodes (`"color"`): per pixel, row by row,
    /// the index in [`Scene::parts`] of the part whose surface the pixel shows (`None` for
    /// a miss or an uncoloured surface). Empty for volumes, for scenes without colours and
    /// for multi-view frames.
    pub parts: Vec<Option<u32>>,
}

/// A target made ready to ray cast: the volume, camera, shading and options resolved.
pub struct Prepared<'a> {
    volume: std::borrow::Cow<'a, Volume>,
    scene: Option<&'a Scene>,
    camera: Camera,
    shading: Shading,
    options: RenderOptions,
    multiview: Option<MultiView>,
    cache_bytes: Option<usize>,
    sampling: Option<SampleStats>,
    notes: Vec<String>,
    prepare_seconds: f64,
    /// The side of the grid of rays per pixel (1: one ray).
    grid: u32,
    /// [`RenderSettings::curvature_follows_mode`].
    curvature_follows_mode: bool,
    /// [`RenderSettings::defer_thin_note`].
    defer_thin_note: bool,
}

impl Prepared<'_> {
    /// The volume that will be ray cast.
    pub fn volume(&self) -> &Volume {
        &self.volume
    }
    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }
    /// The shading.
    pub fn shading(&self) -> &Shading {
        &self.shading
    }
    /// The ray caster's options (the isovalue resolved).
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }
    /// The multi-view display, if any (its separation resolved).
    pub fn multiview(&self) -> Option<&MultiView> {
        self.multiview.as_ref()
    }
    /// The scene's sampling statistics (for scenes).
    pub fn sampling(&self) -> Option<&SampleStats> {
        self.sampling.as_ref()
    }
    /// Looks from another camera (its size is the next frame's), keeping the sampled volume:
    /// what a live viewer does while the user orbits.
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = camera;
    }
    /// Another shading mode for the next frame.
    pub fn set_mode(&mut self, mode: ShadingMode) {
        self.shading.mode = mode;
        if self.curvature_follows_mode {
            self.options.curvature = mode.uses_curvature();
        }
    }
    /// Another isovalue for the next frame (the volume is kept: for a scene, values beyond
    /// its sampled band are clamped, so an isovalue outside the band shows nothing).
    pub fn set_iso(&mut self, iso: f32) {
        self.options.iso = iso;
    }
}

/// The renderer: the GPU twin on a device, or the CPU twin; the same frames either way (to
/// rounding). Opened once and reused (a device, its compiled kernels and its brick cache).
pub struct Renderer {
    gpu: Option<GpuRenderer>,
    note: Option<String>,
    /// The CPU twin's brick cache of the volume rendered last, kept for the next frame of
    /// the same volume and cache size (as the GPU renderer keeps its own): frames after the
    /// first are warm.
    cpu_cache: Option<(u64, Option<usize>, Box<BrickCache>)>,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Renderer({})", self.device())
    }
}

impl Renderer {
    /// The renderer `choice` asks for (the one backend policy of `isokit-gpu`: `auto` takes a
    /// hardware GPU, else the CPU twin with a [`Renderer::note`]).
    pub fn new(choice: BackendChoice) -> Result<Self, RenderError> {
        let s = isokit_render::gpu::select_backend(choice)?;
        Ok(Self {
            gpu: s.gpu,
            note: s.note,
            cpu_cache: None,
        })
    }

    /// The CPU twin (no device is opened).
    pub fn cpu() -> Self {
        Self {
            gpu: None,
            note: None,
            cpu_cache: None,
        }
    }

    /// Why the CPU twin renders although `auto` was asked for.
    pub fn note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// The GPU renderer, when one is open.
    pub fn gpu(&mut self) -> Option<&mut GpuRenderer> {
        self.gpu.as_mut()
    }

    /// True when the GPU twin renders.
    pub fn is_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    /// `gpu` or `cpu`.
    pub fn backend(&self) -> &'static str {
        if self.gpu.is_some() { "gpu" } else { "cpu" }
    }

    /// `GPU (adapter …)` or `CPU`.
    pub fn device(&self) -> String {
        match &self.gpu {
            Some(g) => format!("GPU ({})", g.describe()),
            None => "CPU".to_string(),
        }
    }

    /// The thin-feature warning of a frame of `p` (a curvature shading of a scene whose
    /// visible surface lies within the filter's reach of a crease), where
    /// [`RenderSettings::defer_thin_note`] left it out of the frame's notes: the live viewer
    /// shows the frame first and the note after it.
    pub fn thin_note(&self, p: &Prepared<'_>, frame: &Frame) -> Option<String> {
        thin_note_of(p, &frame.gbuffer)
    }

    /// Resolves a target for rendering: samples a scene's band (reporting progress to
    /// `job`), picks the isovalue, the camera and the shading.
    pub fn prepare<'a>(
        &self,
        target: RenderTarget<'a>,
        settings: &RenderSettings,
        job: &Job,
    ) -> Result<Prepared<'a>, SceneError> {
        self.prepare_after(target, settings, job, None)
    }

    /// [`Renderer::prepare`] for the frame after `kept` (live editing): a scene's volume is
    /// built after the kept one ([`Volume::new_after`]: only the blocks whose samples
    /// changed are scanned, and [`Renderer::render_prepared_keeping`] finds them there).
    pub fn prepare_after<'a>(
        &self,
        target: RenderTarget<'a>,
        settings: &RenderSettings,
        job: &Job,
        kept: Option<&KeptFrame>,
    ) -> Result<Prepared<'a>, SceneError> {
        let t0 = Instant::now();
        let err = |e: RenderError| SceneError::new(target_name(target), "", e.to_string());
        let mut notes = Vec::new();
        let (volume, sampling, specs) = match target {
            RenderTarget::Scene(_) | RenderTarget::Sampled(..) => {
                let (scene, band, stats) = match target {
                    RenderTarget::Sampled(scene, s) => (scene, s.grid.clone(), s.stats.clone()),
                    _ => {
                        let scene = target.scene().expect("a scene target");
                        let (band, stats) =
                            scene.sample_job(&scene_options(scene, settings), job)?;
                        (scene, band, stats)
                    }
                };
                if let Some(iso) = settings.iso
                    && iso.abs() >= stats.band
                {
                    notes.push(format!(
                        "warning: --iso {iso} lies outside the sampled band (±{}); raise sampling.band",
                        stats.band
                    ));
                }
                let volume = Volume::new_after(
                    VolumeData::Band(band),
                    Layout::default(),
                    kept.map(KeptFrame::volume),
                )
                .map_err(err)?;
                let f = scene.settings();
                (
                    std::borrow::Cow::Owned(volume),
                    Some(stats),
                    Some((f.camera.clone(), f.shading.clone(), f.lights.clone())),
                )
            }
            RenderTarget::Volume(v) => (std::borrow::Cow::Borrowed(v), None, None),
        };
        let iso = match (settings.iso, &specs, volume.value_range()) {
            (Some(v), _, _) => v,
            (None, None, Some((lo, hi))) if !(lo..=hi).contains(&0.0) => {
                let mid = 0.5 * (lo + hi);
                notes.push(format!(
                    "note: the values lie in [{lo}, {hi}]; using --iso {mid}"
                ));
                mid
            }
            _ => 0.0,
        };
        let mut options = RenderOptions {
            iso,
            ..settings.options
        };
        if specs.is_none() {
            // Not known to be a distance field: estimate |∇f| for the fine-rate threshold.
            options.gradient_scale = estimate_gradient_scale(&volume, iso);
        }
        options.check().map_err(err)?;
        let bounds = volume.bounds();
        let (w, h) = (settings.width, settings.height);
        let (scene_camera, scene_shading, lights) = specs.unwrap_or((None, None, Vec::new()));
        // A bad camera names where it came from: the scene's `camera` table, or the settings.
        let node = if settings.camera.is_none() && scene_camera.is_some() {
            "camera"
        } else {
            ""
        };
        let camera_spec = settings.camera.clone().or(scene_camera);
        let camera = camera_for(camera_spec.as_ref(), bounds, settings.projection, w, h)
            .map_err(|e| SceneError::new(target_name(target), node, format!("camera: {e}")))?;
        let mut shading = shading_for(scene_shading.as_ref(), &lights).map_err(err)?;
        if let Some(m) = settings.mode {
            shading.mode = m;
        }
        if let Some(b) = settings.background {
            shading.background = b;
        }
        shading.curvature_scale = settings
            .curvature_scale
            .unwrap_or_else(|| default_curvature_scale(bounds));
        shading.check().map_err(err)?;
        let multiview = settings.multiview.map(|mut mv| {
            if settings.default_separation {
                mv.separation = 0.01 * (camera.target() - camera.eye()).length();
            }
            mv
        });
        if let Some(mv) = &multiview {
            mv.check().map_err(err)?;
        }
        let grid = supersample::grid_side(settings.samples).map_err(err)?;
        if grid > 1 {
            if multiview.is_some() {
                return Err(SceneError::new(
                    target_name(target),
                    "",
                    "samples: antialiasing of multi-view frames is not supported (one ray per subpixel); use samples = 1",
                ));
            }
            check_image_size(u64::from(w * grid), u64::from(h * grid)).map_err(err)?;
        }
        if settings.curvature_follows_mode {
            options.curvature = shading.mode.uses_curvature();
        }
        Ok(Prepared {
            volume,
            scene: target.scene(),
            camera,
            shading,
            options,
            multiview,
            cache_bytes: settings.cache_bytes,
            sampling,
            notes,
            prepare_seconds: t0.elapsed().as_secs_f64(),
            grid,
            curvature_follows_mode: settings.curvature_follows_mode,
            defer_thin_note: settings.defer_thin_note,
        })
    }

    /// Renders a target: [`Renderer::prepare`] then [`Renderer::render_prepared`].
    pub fn render(
        &mut self,
        target: RenderTarget<'_>,
        settings: &RenderSettings,
        job: &Job,
    ) -> Result<Frame, SceneError> {
        let p = self.prepare(target, settings, job)?;
        self.render_prepared(&p, target_name(target))
    }

    /// Ray casts and shades a prepared target; `name` names it in errors.
    pub fn render_prepared(&mut self, p: &Prepared<'_>, name: &str) -> Result<Frame, SceneError> {
        self.render_view_of(p, None, name, None)
    }

    /// [`Renderer::render_prepared`] for live editing: on the CPU twin, the pixels of
    /// `kept` (the frame before an edit of the field) whose rays cannot reach a changed
    /// block are taken as they were and only the others traced
    /// ([`isokit_render::render_reusing`]: the same image bit for bit); then `kept` holds
    /// this frame. On the GPU, for multi-view targets and with supersampling, the frame is
    /// traced in full and `kept` emptied.
    pub fn render_prepared_keeping(
        &mut self,
        p: &Prepared<'_>,
        name: &str,
        kept: &mut Option<KeptFrame>,
    ) -> Result<Frame, SceneError> {
        self.render_view_of(p, None, name, Some(kept))
    }

    /// True when [`Renderer::render_prepared_keeping`] of `p` can take pixels from `kept`:
    /// the CPU twin, one ray per pixel, a single view, and the same uniforms (camera, image
    /// size, isovalue, knobs and lattice).
    pub fn can_reuse(&self, p: &Prepared<'_>, kept: &KeptFrame) -> bool {
        self.keeps_frames(p)
            && isokit_render::uniforms(&p.volume, &p.camera, &p.options)
                .is_ok_and(|u| u == *kept.uniforms())
    }

    /// Whether frames of `p` can be kept and taken from ([`KeptFrame`]): the CPU twin, a
    /// single view, one ray per pixel.
    fn keeps_frames(&self, p: &Prepared<'_>) -> bool {
        self.gpu.is_none() && p.multiview.is_none() && p.grid == 1
    }

    /// One view `k` of a prepared multi-view target, rendered alone.
    pub fn render_view(
        &mut self,
        p: &Prepared<'_>,
        k: u32,
        name: &str,
    ) -> Result<Frame, SceneError> {
        self.render_view_of(p, Some(k), name, None)
    }

    /// Every view of a prepared multi-view target, each rendered alone (what the display
    /// shows from each eye position), as shaded images in view order; empty when the target
    /// is not multi-view.
    pub fn render_views(&mut self, p: &Prepared<'_>, name: &str) -> Result<Vec<Image>, SceneError> {
        let Some(mv) = p.multiview() else {
            return Ok(Vec::new());
        };
        (0..mv.views)
            .map(|k| Ok(self.render_view(p, k, name)?.image))
            .collect()
    }

    fn render_view_of(
        &mut self,
        p: &Prepared<'_>,
        view: Option<u32>,
        name: &str,
        mut kept: Option<&mut Option<KeptFrame>>,
    ) -> Result<Frame, SceneError> {
        let err = |e: RenderError| SceneError::new(name, "", e.to_string());
        let key = (p.volume.id(), p.cache_bytes);
        let cache = match self.cpu_cache.take() {
            // The cache of the volume this one was built after keeps its unchanged bricks.
            Some((id, bytes, c))
                if bytes == key.1 && (id == key.0 || p.volume.built_after() == Some(id)) =>
            {
                c
            }
            _ => Box::new(match p.cache_bytes {
                Some(b) => BrickCache::with_bytes(&p.volume, b).map_err(err)?,
                None => BrickCache::for_volume(&p.volume),
            }),
        };
        // Whether this frame may take pixels from the kept one and be kept.
        let keeps = self.keeps_frames(p);
        let (_, _, cache) = self.cpu_cache.insert((key.0, key.1, cache));
        if let (Some(g), Some(b)) = (self.gpu.as_mut(), p.cache_bytes) {
            g.set_cache_bytes(b);
        }
        let (v, o) = (&*p.volume, &p.options);
        // Supersampling: the same camera over k times the pixels in each direction.
        let k = p.grid;
        let wide = (k > 1)
            .then(|| {
                let c = &p.camera;
                Camera::look_at(
                    c.eye(),
                    c.target(),
                    c.up(),
                    c.projection(),
                    c.width() * k,
                    c.height() * k,
                )
            })
            .transpose()
            .map_err(|e| err(e.into()))?;
        let c = wide.as_ref().unwrap_or(&p.camera);
        // The frame before an edit, where this frame may take pixels from it (CPU twin).
        let earlier = kept.as_deref().and_then(Option::as_ref).filter(|_| keeps);
        let frame = match (&p.multiview, view, self.gpu.as_mut()) {
            (Some(mv), Some(k), Some(g)) => g.render_view(v, c, o, mv, k),
            (Some(mv), Some(k), None) => isokit_render::render_view(v, cache, c, o, mv, k),
            (Some(mv), None, Some(g)) => g.render_multiview(v, c, o, mv),
            (Some(mv), None, None) => isokit_render::render_multiview(v, cache, c, o, mv),
            (None, _, Some(g)) => g.render(v, c, o),
            (None, _, None) => isokit_render::render_reusing(v, cache, c, o, earlier),
        }
        .map_err(err)?;
        let t1 = Instant::now();
        let image = match self.gpu.as_ref() {
            Some(g) => g.shade(&frame.gbuffer, &frame.uniforms, &p.shading),
            None => {
                isokit_render::shade_reusing(&frame.gbuffer, &frame.uniforms, &p.shading, earlier)
            }
        }
        .map_err(err)?;
        if let Some(slot) = kept.as_mut() {
            **slot = keeps.then(|| {
                let mut f = KeptFrame::new(v, &frame, slot.take());
                f.keep_image(&image, &p.shading);
                f
            });
        }
        let (image, parts) = match p.scene {
            Some(scene) if !scene.parts().is_empty() && frame.uniforms.subpixels <= 1 => {
                colour_parts(
                    scene,
                    &frame.gbuffer,
                    &frame.uniforms,
                    &p.shading,
                    p.volume.spacing(),
                    image,
                )
            }
            _ => (image, Vec::new()),
        };
        let (image, gbuffer, parts) = if k > 1 {
            let parts = resolve_parts(&parts, &frame.gbuffer, k);
            (
                supersample::resolve_image(&image, k),
                supersample::resolve_gbuffer(&frame.gbuffer, k),
                parts,
            )
        } else {
            (image, frame.gbuffer, parts)
        };
        let shade_seconds = t1.elapsed().as_secs_f64();
        let st = &frame.stats;
        let mut notes = p.notes.clone();
        if !p.defer_thin_note
            && let Some(n) = thin_note_of(p, &gbuffer)
        {
            notes.push(n);
        }
        if st.hits + st.caps == 0 {
            notes.push(format!(
                "warning: no ray hit the surface f = {}",
                p.options.iso
            ));
        }
        let cache_capacity = match self.gpu.as_ref() {
            Some(g) => g.cache_capacity().unwrap_or(0),
            None => cache.capacity(),
        };
        let stats = FrameStats {
            width: st.width / k,
            height: st.height / k,
            iso: p.options.iso,
            mode: p.shading.mode.name(),
            hits: st.hits,
            caps: st.caps,
            samples: st.samples,
            samples_per_ray: st.samples_per_ray(),
            blocks_active: st.blocks_active,
            blocks_total: st.blocks_total,
            bricks_active: st.bricks_active,
            bricks_total: st.bricks_total,
            bricks_loaded: st.bricks_loaded,
            cache_capacity,
            passes: st.passes,
            bricks_downsampled: st.bricks_downsampled,
            prepare_seconds: p.prepare_seconds,
            trace_seconds: st.seconds,
            rays_reused: st.rays_reused,
            warm_trace_seconds: Vec::new(),
            shade_seconds,
            backend: self.backend(),
            device: self.device(),
            sampling: p.sampling.clone(),
        };
        Ok(Frame {
            image,
            gbuffer,
            uniforms: frame.uniforms,
            camera: p.camera,
            stats,
            notes,
            parts,
        })
    }
}

/// The object map of a frame and the image with each coloured part's pixels shaded in its
/// colour (CPU, after either twin's shading: the other pixels keep theirs). A hit belongs
/// to the part whose surface passes within two voxels of it ([`Scene::part_at`]: the band's
/// trilinear surface lies within a voxel of the exact one).
fn colour_parts(
    scene: &Scene,
    gbuffer: &GBuffer,
    u: &Uniforms,
    sh: &Shading,
    spacing: f32,
    mut image: Image,
) -> (Image, Vec<Option<u32>>) {
    use rayon::prelude::*;
    let tolerance = 2.0 * spacing;
    let lights = sh.lights_or_default(u);
    let pixel_angle = 2.0 * u.half_height / u.height as f32;
    let parts: Vec<Option<u32>> = gbuffer
        .pixels()
        .par_iter()
        .map(|s| {
            if !s.is_hit() {
                return None;
            }
            scene.part_at(s.position, tolerance).map(|i| i as u32)
        })
        .collect();
    if sh.mode != ShadingMode::Flow {
        let colors: Vec<Vec3> = scene.parts().iter().map(|c| Vec3::from(c.color)).collect();
        image
            .pixels
            .par_iter_mut()
            .zip(gbuffer.pixels().par_iter().zip(parts.par_iter()))
            .enumerate()
            .for_each(|(i, (out, (s, part)))| {
                if let Some(k) = part {
                    let (px, py) = (i as u32 % u.width, i as u32 / u.width);
                    let v = isokit_render::kernel::subpixel_ray(u, px, py, 0).1;
                    let footprint = if u.ortho != 0 {
                        pixel_angle
                    } else {
                        pixel_angle * s.depth
                    };
                    *out = isokit_render::shade::shade_pixel_color(
                        s,
                        v,
                        footprint,
                        sh,
                        &lights,
                        colors[*k as usize],
                    );
                }
            });
    }
    (image, parts)
}

/// The radius of the tricubic B-spline reconstruction kernel in voxels (its support is 4
/// voxels wide).
const BSPLINE_RADIUS_VOXELS: f32 = 2.0;

/// The most hit pixels [`thin_feature_note`] probes.
const THIN_PROBES: usize = 1024;

/// The fraction of probed surface pixels near a crease above which [`thin_feature_note`]
/// warns (sharp edges alone stay below it: their creases reach only a strip of pixels along
/// each edge).
const THIN_FRACTION: f64 = 0.2;

/// [`thin_feature_note`] where it applies: scenes in a curvature shading, tricubic.
fn thin_note_of(p: &Prepared<'_>, gbuffer: &GBuffer) -> Option<String> {
    let (scene, sampling) = (p.scene?, p.sampling.as_ref()?);
    if !p.shading.mode.uses_curvature() || p.options.filter != isokit_render::Filter::Tricubic {
        return None;
    }
    thin_feature_note(scene, gbuffer, p.volume.spacing(), sampling, p.shading.mode)
}

/// A warning when much of the visible surface of a scene lies within the reach of the
/// tricubic filter (2 voxels) of a crease of its distance field — the medial surface of a
/// wall or gap thinner than 4 voxels, where the field's gradient flips. The B-spline
/// averages across the crease, so the Hessian, and with it the principal curvatures, mix
/// in where the crease passes between the lattice's samples, and the curvature shadings
/// show the grid (002 Sec. 2.2.3: the distance between the shocks of a distance function
/// and its surface should exceed the radius of the reconstruction kernel). `None` when the
/// surface keeps clear.
///
/// Probes up to [`THIN_PROBES`] hit pixels: at a hit `p` with outward normal `n`, an exact
/// distance field without a crease within `r` has `f(p + r·n) = r` and `f(p − r·n) = −r`;
/// a crease at distance `s < r` on either side brings that side's value to `2s − r`
/// (measured in units of the field's slope at the surface on that side, a quarter voxel
/// deep, for fields that are not exact distances).
fn thin_feature_note(
    scene: &Scene,
    g: &GBuffer,
    spacing: f32,
    sampling: &SampleStats,
    mode: ShadingMode,
) -> Option<String> {
    let r = BSPLINE_RADIUS_VOXELS * spacing;
    let hits: Vec<&isokit_render::GSample> = g
        .pixels()
        .iter()
        .filter(|s| s.is_hit() && isokit_render::kernel::is_surface_id(s.id))
        .collect();
    if hits.is_empty() || !(r.is_finite() && r > 0.0) {
        return None;
    }
    let step = hits.len().div_ceil(THIN_PROBES);
    let probes: Vec<&isokit_render::GSample> = hits.iter().step_by(step).copied().collect();
    use rayon::prelude::*;
    let mut creases: Vec<f32> = probes
        .par_iter()
        .filter_map(|s| {
            let f = |t: f32| scene.value_clamped(s.position + t * s.normal, 2.0 * r);
            // Each side's reach in units of its own slope near the surface (fields that are
            // not exact distances, e.g. twisted ones, change at other rates than 1).
            let (d, f0) = (0.25 * spacing, f(0.0));
            let side = |sign: f32| {
                let slope = sign * (f(sign * d) - f0) / d;
                if slope > 0.0 {
                    sign * (f(sign * r) - f0) / slope
                } else {
                    -r
                }
            };
            let reach = side(1.0).min(side(-1.0));
            // The crease's distance from the surface; a margin of a tenth of the radius
            // for the band's sampling and the hit's refinement.
            (reach < 0.8 * r).then_some(0.5 * (r + reach.max(-r)))
        })
        .collect();
    let fraction = creases.len() as f64 / probes.len() as f64;
    if fraction < THIN_FRACTION {
        return None;
    }
    creases.sort_by(f32::total_cmp);
    let crease = creases[creases.len() / 2].max(0.05 * r);
    let longest = sampling.dims.iter().copied().max().unwrap_or(0);
    let needed = (longest as f32 * r / crease).ceil() as usize;
    Some(format!(
        "warning: {:.0}% of the visible surface lies within 2 voxels (the reach of the tricubic filter) of a crease of the distance field, a wall or gap about {:.3} thick ({:.1} voxels); the curvature there is unreliable and the {} shading shows the sampling grid. Remedy: sample finer, at least --res {needed} (sampling.resolution; the wall must span 4 voxels), or use a mode without curvature (phong, tone)",
        100.0 * fraction,
        2.0 * crease,
        2.0 * crease / spacing,
        mode.name(),
    ))
}

/// The object map of a supersampled frame at the output size: per pixel the part of the hit
/// ray nearest its centre (the sample [`supersample::resolve_gbuffer`] keeps).
fn resolve_parts(parts: &[Option<u32>], g: &GBuffer, k: u32) -> Vec<Option<u32>> {
    if parts.is_empty() {
        return Vec::new();
    }
    let (w, h) = (g.width() / k, g.height() / k);
    (0..w * h)
        .map(|i| {
            supersample::nearest_hit(g, k, i % w, i / w)
                .0
                .and_then(|j| parts[j])
        })
        .collect()
}

fn target_name(t: RenderTarget<'_>) -> &str {
    t.scene().map_or("<volume>", Scene::name)
}

/// The sampling options a scene target is sampled with: the scene's, with the settings'
/// resolution.
pub fn scene_options(scene: &Scene, settings: &RenderSettings) -> SampleOptions {
    let mut opts = SampleOptions::from_scene(scene);
    if let Some(r) = settings.resolution {
        opts.resolution = r;
    }
    opts
}
