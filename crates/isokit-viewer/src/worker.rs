//! The worker thread: compiles, samples and renders what the window asks for, always the
//! newest request (older ones still queued are merged into it), with the work of a load
//! cancellable from the window thread.

use crate::events::{FrameEvent, Reason};
use crate::orbit::Orbit;
use isokit_field::{Job, Projection};
use isokit_gpu::BackendChoice;
use isokit_render::{KeptFrame, Layout, ShadingMode, Volume};
use isokit_scene::{
    CameraSpec, Frame, Prepared, ProjectionKind, RenderSettings, RenderTarget, Renderer, Scene,
    SceneError, SceneFormat, SourceCache, camera_for,
};
use std::path::{Path, PathBuf};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A finished frame slower than this (trace and shade, milliseconds) makes an edit show a
/// half-size draft first.
const DRAFT_ABOVE_MS: f64 = 40.0;

/// A full sampling slower than this (milliseconds) makes the next edit show a coarse frame
/// first (a quarter of the resolution sampled, half the image).
const COARSE_ABOVE_MS: f64 = 50.0;

/// What the input file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum InputKind {
    Scene,
    Volume,
    Molecule,
}

impl InputKind {
    pub fn of(path: &Path) -> Self {
        if SceneFormat::from_path(path).is_some() {
            InputKind::Scene
        } else if isokit_molecule::MoleculeFormat::from_path(path).is_ok() {
            InputKind::Molecule
        } else {
            InputKind::Volume
        }
    }
}

/// The panel's settings.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Knobs {
    pub mode: Option<ShadingMode>,
    pub iso: Option<f32>,
    pub resolution: Option<usize>,
    /// The band half-width (world units) a scene is sampled with.
    pub band: Option<f32>,
}

/// A frame the window asks for.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Request {
    pub reason: Reason,
    /// When the file event or input happened (latencies run from it).
    pub t0: Instant,
    /// Compile the input again (a file changed).
    pub reload: bool,
    /// Sample again (resolution or band changed).
    pub resample: bool,
    /// The camera; `None`: the input's own.
    pub orbit: Option<Orbit>,
    pub knobs: Knobs,
    /// Render a draft at half size (while the camera moves); the window asks for the final
    /// frame when it stops.
    pub draft: bool,
    pub width: u32,
    pub height: u32,
}

impl Request {
    /// `self` followed by the newer `n`: the newest camera and settings, the oldest event
    /// time, and every reload or resample either asked for.
    fn then(self, n: Request) -> Request {
        let file = self.reload || n.reload;
        Request {
            reason: if file {
                self.reason.max(n.reason).max(Reason::Edit)
            } else {
                self.reason.max(n.reason)
            },
            t0: if self.reload && !n.reload {
                self.t0
            } else {
                self.t0.min(n.t0)
            },
            reload: file,
            resample: self.resample || n.resample,
            ..n
        }
    }
}

/// What the worker sends back.
pub(crate) enum Reply {
    /// A frame (0RGB pixels, row by row), with the request it answers.
    Frame {
        pixels: Vec<u32>,
        rgba: Vec<u8>,
        width: u32,
        height: u32,
        event: FrameEvent,
        t0: Instant,
        notes: Vec<String>,
        /// The sampling resolution and band of the volume shown, for scenes.
        sampling: Option<(usize, f32)>,
    },
    /// A load or render failed; the window keeps its last good frame.
    Error {
        file: String,
        node: String,
        message: String,
        reason: Reason,
    },
    /// The files the input depends on (watched from now on), and its own camera (`None`
    /// when it failed to load).
    Loaded {
        files: Vec<PathBuf>,
        camera: Option<Orbit>,
    },
    /// The renderer in use (for the panel).
    Device(String),
    /// A note on the finished frame just sent, found after it was sent (the thin-feature
    /// warning of curvature shadings: it evaluates the scene's tree).
    Note(String),
}

/// The work of the load in progress, which the window cancels when a newer edit arrives.
pub(crate) type CancelSlot = Arc<Mutex<Job>>;

struct Worker<F: Fn(Reply)> {
    input: PathBuf,
    kind: InputKind,
    renderer: Renderer,
    cache: SourceCache,
    /// The last full sampling of the scene, for the next edit to reuse bricks from.
    previous: Option<std::sync::Arc<isokit_scene::Sampled>>,
    reuse: bool,
    /// The resolution and band of the sampling being shown.
    sampling: Option<(usize, f32)>,
    /// Milliseconds the last load spent compiling and sampling, for its first frame's event.
    phases: (f64, f64),
    /// Trace and shade milliseconds of the last finished frame.
    last_frame_ms: f64,
    /// Milliseconds of the last full-resolution sampling.
    last_sample_ms: f64,
    /// The last finished frame of a scene, for the next edit's to take pixels from.
    kept: Option<KeptFrame>,
    send: F,
    slot: CancelSlot,
    rx: Receiver<Request>,
}

/// Runs the worker until the window's side of the channel closes.
pub(crate) fn run(
    input: PathBuf,
    backend: BackendChoice,
    reuse: bool,
    rx: Receiver<Request>,
    slot: CancelSlot,
    send: impl Fn(Reply),
) {
    let renderer = match Renderer::new(backend) {
        Ok(r) => r,
        Err(e) => {
            send(Reply::Error {
                file: String::new(),
                node: "backend".into(),
                message: format!("{e}; rendering on the CPU"),
                reason: Reason::Start,
            });
            Renderer::cpu()
        }
    };
    let device = match renderer.note() {
        Some(n) => format!("{} ({n})", renderer.device()),
        None => renderer.device(),
    };
    send(Reply::Device(device));
    let mut w = Worker {
        kind: InputKind::of(&input),
        input,
        renderer,
        cache: SourceCache::memoizing(),
        previous: None,
        reuse,
        sampling: None,
        phases: (0.0, 0.0),
        last_frame_ms: 0.0,
        last_sample_ms: 0.0,
        kept: None,
        send,
        slot,
        rx,
    };
    let mut pending: Option<Request> = None;
    loop {
        let req = match pending.take() {
            Some(r) => r,
            None => match w.rx.recv() {
                Ok(r) => r,
                Err(_) => return,
            },
        };
        let req = w.newest(req);
        pending = match w.kind {
            InputKind::Scene => w.scene(req),
            InputKind::Volume => w.volume(req),
            InputKind::Molecule => w.molecule(req),
        };
    }
}

/// sRGB bytes (RGBA) as the framebuffer's 0RGB words.
pub(crate) fn to_0rgb(rgba: &[u8]) -> Vec<u32> {
    rgba.chunks_exact(4)
        .map(|p| (u32::from(p[0]) << 16) | (u32::from(p[1]) << 8) | u32::from(p[2]))
        .collect()
}

/// A camera spec from an orbit.
fn spec(o: &Orbit) -> CameraSpec {
    CameraSpec {
        eye: o.eye().to_array(),
        target: o.target.to_array(),
        up: o.up.to_array(),
        fov: o.fov,
        ortho_height: None,
    }
}

fn orbit_of(c: &isokit_field::Camera) -> Orbit {
    let fov = match c.projection() {
        Projection::Perspective { fov_y_degrees } => fov_y_degrees,
        Projection::Orthographic { .. } => 45.0,
    };
    Orbit::new(c.eye(), c.target(), c.up(), fov)
}

fn size_of(req: &Request) -> (u32, u32) {
    if req.draft {
        ((req.width / 2).max(1), (req.height / 2).max(1))
    } else {
        (req.width, req.height)
    }
}

impl<F: Fn(Reply)> Worker<F> {
    /// `req` merged with every request queued behind it.
    fn newest(&self, mut req: Request) -> Request {
        while let Ok(n) = self.rx.try_recv() {
            req = req.then(n);
        }
        req
    }

    /// The next request when one is already queued that needs a reload (the current work
    /// is stale).
    fn stale(&self, req: &mut Option<Request>) -> bool {
        while let Ok(n) = self.rx.try_recv() {
            *req = Some(match req.take() {
                Some(r) => r.then(n),
                None => n,
            });
        }
        req.is_some_and(|r| r.reload || r.resample)
    }

    fn error(&self, e: &SceneError, reason: Reason) {
        (self.send)(Reply::Error {
            file: e.file.clone(),
            node: e.node.clone(),
            message: e.message.clone(),
            reason,
        });
    }

    fn new_job(&self) -> Job {
        let job = Job::new();
        *self.slot.lock().unwrap_or_else(|p| p.into_inner()) = job.clone();
        job
    }

    fn settings(&self, req: &Request, resolution: Option<usize>) -> RenderSettings {
        let (width, height) = size_of(req);
        RenderSettings {
            width,
            height,
            iso: req.knobs.iso,
            mode: req.knobs.mode,
            camera: req.orbit.as_ref().map(spec),
            resolution,
            // Frames are shown, not kept: the Hessian only for the modes that read it.
            curvature_follows_mode: true,
            // The frame first, the note after it (`Reply::Note`).
            defer_thin_note: true,
            ..RenderSettings::default()
        }
    }

    fn send_frame(&mut self, frame: &Frame, req: &Request, final_: bool, reused: Option<usize>) {
        let rgba = frame.image.to_rgba8();
        let pixels = to_0rgb(&rgba);
        let st = &frame.stats;
        if final_ {
            self.last_frame_ms = 1e3 * (st.trace_seconds + st.shade_seconds);
        }
        let ((load_ms, sample_ms), prepare_ms) = match reused {
            Some(_) => (self.phases, 1e3 * st.prepare_seconds),
            None => ((0.0, 0.0), 0.0),
        };
        let (evaluated, reused, dense) = match (&st.sampling, reused) {
            (Some(s), Some(r)) => (s.bricks_kept.saturating_sub(r), r, s.dense_fraction),
            _ => (0, 0, 0.0),
        };
        (self.send)(Reply::Frame {
            pixels,
            rgba,
            width: frame.image.width,
            height: frame.image.height,
            event: FrameEvent {
                reason: req.reason,
                final_,
                latency_ms: 0.0,
                frame_ms: 1e3 * (st.trace_seconds + st.shade_seconds),
                evaluated_bricks: evaluated,
                reused_bricks: reused,
                reused_rays: st.rays_reused,
                bricks_loaded: st.bricks_loaded,
                dense_fraction: dense,
                load_ms,
                sample_ms,
                prepare_ms,
                width: frame.image.width,
                height: frame.image.height,
                backend: st.backend,
                mode: st.mode,
                iso: Some(st.iso),
            },
            t0: req.t0,
            notes: frame.notes.clone(),
            sampling: self.sampling,
        });
    }

    /// Points `p` at `req`'s camera (at its size) and applies its shading knobs.
    fn aim(&self, p: &mut Prepared<'_>, req: &Request) -> Result<(), SceneError> {
        let (w, h) = size_of(req);
        let c = p.camera();
        let camera = match &req.orbit {
            Some(o) => Some(
                camera_for(
                    Some(&spec(o)),
                    p.volume().bounds(),
                    ProjectionKind::Perspective,
                    w,
                    h,
                )
                .map_err(|e| e.to_string()),
            ),
            // The input's own camera at this request's size (a draft is half the window).
            None if (c.width(), c.height()) != (w, h) => Some(
                isokit_field::Camera::look_at(c.eye(), c.target(), c.up(), c.projection(), w, h)
                    .map_err(|e| e.to_string()),
            ),
            None => None,
        };
        match camera {
            Some(Ok(c)) => p.set_camera(c),
            Some(Err(e)) => {
                let name = self.input.display().to_string();
                return Err(SceneError::new(&name, "camera", e));
            }
            None => {}
        }
        if let Some(m) = req.knobs.mode {
            p.set_mode(m);
        }
        if let Some(iso) = req.knobs.iso {
            p.set_iso(iso);
        }
        Ok(())
    }

    /// True when the finished frame of `req` can take the rays an edit left unchanged from
    /// the frame kept before it (the CPU twin, the same camera and knobs): it then comes
    /// sooner than a draft and the finished frame after it would.
    fn final_can_reuse(&mut self, p: &mut Prepared<'_>, req: &Request) -> bool {
        let Some(kept) = self.kept.take() else {
            return false;
        };
        let can = self.aim(p, req).is_ok() && self.renderer.can_reuse(p, &kept);
        self.kept = Some(kept);
        can
    }

    /// Renders `p` for `req` from its camera; errors are reported.
    /// `reused`: when the frame's volume was just sampled, how many of its bricks were
    /// taken from the previous sampling; `None` for a frame of an earlier sampling.
    /// Finished frames of scenes are kept for the next edit's, which traces again only the
    /// rays the edit can change ([`Renderer::render_prepared_keeping`]).
    fn render(
        &mut self,
        p: &mut Prepared<'_>,
        req: &Request,
        final_: bool,
        reused: Option<usize>,
    ) -> bool {
        if let Err(e) = self.aim(p, req) {
            self.error(&e, req.reason);
            return false;
        }
        let name = self.input.display().to_string();
        let rendered = if final_ && !req.draft && self.kind == InputKind::Scene && self.reuse {
            let mut kept = self.kept.take();
            let r = self.renderer.render_prepared_keeping(p, &name, &mut kept);
            self.kept = kept;
            r
        } else {
            self.renderer.render_prepared(p, &name)
        };
        match rendered {
            Ok(frame) => {
                self.send_frame(&frame, req, final_, reused);
                if final_ && let Some(n) = self.renderer.thin_note(p, &frame) {
                    (self.send)(Reply::Note(n));
                }
                true
            }
            Err(e) => {
                self.error(&e, req.reason);
                false
            }
        }
    }

    /// Serves camera and shading requests from one prepared target until a request needs
    /// a reload or a resample; returns that request.
    fn serve(&mut self, p: &mut Prepared<'_>) -> Option<Request> {
        loop {
            let req = self.newest(self.rx.recv().ok()?);
            if req.reload || req.resample {
                return Some(req);
            }
            self.render(p, &req, !req.draft, None);
        }
    }

    fn scene(&mut self, req: Request) -> Option<Request> {
        let job = self.new_job();
        let t_load = Instant::now();
        let scene = match Scene::load_with(&self.input, &mut self.cache) {
            Ok(s) => s,
            Err(e) => {
                self.error(&e, req.reason);
                (self.send)(Reply::Loaded {
                    files: isokit_scene::watch::files_of(&self.input),
                    camera: None,
                });
                return None;
            }
        };
        let full = req
            .knobs
            .resolution
            .or(scene.settings().sampling.resolution);
        let base = full.unwrap_or(isokit_scene::SampleOptions::default().resolution);
        let s = self.settings(&req, full);
        let mut opts = isokit_scene::scene_options(&scene, &s);
        if req.knobs.band.is_some() {
            opts.band = req.knobs.band;
        }
        let load_ms = 1e3 * t_load.elapsed().as_secs_f64();
        self.phases = (load_ms, 0.0);
        let reusable = self.previous.as_ref().is_some_and(|p| *p.options() == opts);
        let mut pending = None;
        // A coarse frame first (a quarter of the resolution, half the image) when nothing
        // can be reused or the last sampling was slow, unless only the camera or shading
        // changed.
        let slow = !reusable || self.last_sample_ms > COARSE_ABOVE_MS;
        let coarse = slow && req.reason >= Reason::Edit && base >= 64 && !req.draft;
        if coarse {
            let coarse_req = Request { draft: true, ..req };
            let cs = self.settings(&coarse_req, Some((base / 4).max(24)));
            match self
                .renderer
                .prepare(RenderTarget::Scene(&scene), &cs, &job)
            {
                Ok(mut p) => {
                    // Files only: the scene's camera frames the full lattice (below).
                    self.loaded(&scene, &p, false);
                    let full_sampling = self.sampling.take();
                    self.render(&mut p, &coarse_req, false, Some(0));
                    self.sampling = full_sampling;
                }
                Err(_) if job.is_cancelled() => return self.newest_after_cancel(req),
                Err(e) => {
                    self.error(&e, req.reason);
                    return None;
                }
            }
            if self.stale(&mut pending) {
                return pending;
            }
        }
        let sampled = match scene.sample_again(&opts, self.previous.as_deref(), &job) {
            Ok(x) => std::sync::Arc::new(x),
            Err(_) if job.is_cancelled() => return self.newest_after_cancel(req),
            Err(e) => {
                self.error(&e, req.reason);
                return None;
            }
        };
        let reused = sampled.stats.bricks_reused;
        self.phases = (load_ms, 1e3 * sampled.stats.seconds);
        // Only a sampling that could reuse says what the next edit's will cost.
        self.last_sample_ms = if reusable {
            1e3 * sampled.stats.seconds
        } else {
            0.0
        };
        self.sampling = Some((opts.resolution, sampled.stats.band));
        if self.reuse {
            // Shared, not copied: the renderer's volume is built from it below.
            self.previous = Some(sampled.clone());
        }
        let mut p = match self.renderer.prepare_after(
            RenderTarget::Sampled(&scene, &sampled),
            &s,
            &job,
            self.kept.as_ref(),
        ) {
            Ok(p) => p,
            Err(_) if job.is_cancelled() => return self.newest_after_cancel(req),
            Err(e) => {
                self.error(&e, req.reason);
                return None;
            }
        };
        self.loaded(&scene, &p, true);
        if self.stale(&mut pending) {
            return pending;
        }
        // A draft first (half the image) when a finished frame takes longer than the frame
        // budget, no coarse frame was shown and the finished frame cannot take the rays the
        // edit left unchanged from the last one: the edit's first pixels come sooner, the
        // finished frame right after.
        if !coarse
            && req.reason >= Reason::Edit
            && !req.draft
            && self.last_frame_ms > DRAFT_ABOVE_MS
            && !self.final_can_reuse(&mut p, &req)
        {
            let draft = Request { draft: true, ..req };
            self.render(&mut p, &draft, false, Some(reused));
            if self.stale(&mut pending) {
                return pending;
            }
        }
        let ok = self.render(&mut p, &req, true, Some(reused));
        if let Some(r) = pending.take() {
            if r.reload || r.resample {
                return Some(r);
            }
            self.render(&mut p, &r, !r.draft, None);
        }
        if !ok {
            return None;
        }
        self.serve(&mut p)
    }

    /// Reports the files `scene` depends on and, with `camera`, its own camera (what [R]
    /// resets to; it frames `p`'s lattice when the scene has none), whatever the window
    /// looks from now.
    fn loaded(&self, scene: &Scene, p: &Prepared<'_>, camera: bool) {
        let c = p.camera();
        let camera = camera_for(
            scene.settings().camera.as_ref(),
            p.volume().bounds(),
            ProjectionKind::Perspective,
            c.width(),
            c.height(),
        )
        .ok()
        .filter(|_| camera)
        .map(|c| orbit_of(&c));
        let mut files = scene.dependencies().to_vec();
        if files.is_empty() {
            files.push(self.input.clone());
        }
        (self.send)(Reply::Loaded { files, camera });
    }

    /// After a cancelled load: the request that cancelled it (waiting for it if it is not
    /// queued yet).
    fn newest_after_cancel(&self, req: Request) -> Option<Request> {
        let next = match self.rx.try_recv() {
            Ok(n) => n,
            Err(_) => self.rx.recv().ok()?,
        };
        Some(self.newest(req.then(next)))
    }

    /// A volume file read whole, as a uniform grid (anisotropic ones resampled).
    fn dense_volume(&self) -> Result<Volume, String> {
        isokit_io::read_volume(&self.input)
            .map_err(|e| e.to_string())
            .and_then(|v| {
                if v.is_uniform() {
                    v.into_grid().map_err(|e| e.to_string())
                } else {
                    let h = v.spacing.min_element();
                    v.resample_uniform(h).map_err(|e| e.to_string())
                }
            })
            .and_then(|g| Volume::from_grid(g, Layout::default()).map_err(|e| e.to_string()))
    }

    fn volume(&mut self, req: Request) -> Option<Request> {
        let name = self.input.display().to_string();
        let zarr = isokit_io::zarr::is_zarr_name(&self.input);
        // A Zarr store is read on demand (fields larger than memory), through a cache of
        // 256 MiB of decoded chunks.
        let read = if zarr {
            isokit_io::zarr::ZarrSource::open(&self.input, 256 << 20)
                .map_err(|e| e.to_string())
                .and_then(|s| {
                    Volume::from_store(std::sync::Arc::new(s), Layout::default())
                        .map_err(|e| e.to_string())
                })
        } else {
            self.dense_volume()
        };
        let volume = match read {
            Ok(v) => v,
            Err(m) => {
                self.error(&SceneError::new(&name, "", m), req.reason);
                (self.send)(Reply::Loaded {
                    files: vec![self.input.clone()],
                    camera: None,
                });
                return None;
            }
        };
        let s = self.settings(&req, None);
        let mut p = match self
            .renderer
            .prepare(RenderTarget::Volume(&volume), &s, &Job::new())
        {
            Ok(p) => p,
            Err(e) => {
                self.error(&e, req.reason);
                return None;
            }
        };
        let own = camera_for(None, p.volume().bounds(), ProjectionKind::Perspective, 1, 1);
        (self.send)(Reply::Loaded {
            files: vec![self.input.clone()],
            camera: own.ok().map(|c| orbit_of(&c)),
        });
        if !self.render(&mut p, &req, true, None) {
            return None;
        }
        // A store read on demand whose chunk could not be decoded shows it as holes (NaN):
        // say why.
        if let Some(e) = volume.store_error() {
            self.error(&SceneError::new(&name, "", e), req.reason);
        }
        self.serve(&mut p)
    }

    fn molecule(&mut self, req: Request) -> Option<Request> {
        let name = self.input.display().to_string();
        let mol = match isokit_molecule::read_molecule(&self.input) {
            Ok(m) => m,
            Err(e) => {
                self.error(&SceneError::new(&name, "", e.to_string()), req.reason);
                (self.send)(Reply::Loaded {
                    files: vec![self.input.clone()],
                    camera: None,
                });
                return None;
            }
        };
        let mut req = req;
        let mut first = true;
        loop {
            let (w, h) = size_of(&req);
            let camera = match &req.orbit {
                Some(o) => camera_for(
                    Some(&spec(o)),
                    isokit_field::Aabb::EMPTY,
                    ProjectionKind::Perspective,
                    w,
                    h,
                )
                .ok(),
                None => None,
            };
            let settings = isokit_scene::MoleculeSettings {
                width: w,
                height: h,
                mode: req.knobs.mode.unwrap_or(ShadingMode::Phong),
                camera,
                ..Default::default()
            };
            let t = Instant::now();
            match self.renderer.render_molecule(&mol, &settings) {
                Ok(f) => {
                    if first {
                        let camera = isokit_molecule::molecule_scene(&mol, &settings.model)
                            .and_then(|sc| isokit_molecule::framing_camera(&sc, w, h))
                            .ok()
                            .map(|c| orbit_of(&c));
                        (self.send)(Reply::Loaded {
                            files: vec![self.input.clone()],
                            camera,
                        });
                        first = false;
                    }
                    let rgba = f.image.to_rgba8();
                    let pixels = to_0rgb(&rgba);
                    (self.send)(Reply::Frame {
                        pixels,
                        rgba,
                        width: w,
                        height: h,
                        event: FrameEvent {
                            reason: req.reason,
                            final_: !req.draft,
                            latency_ms: 0.0,
                            frame_ms: 1e3 * t.elapsed().as_secs_f64(),
                            evaluated_bricks: 0,
                            reused_bricks: 0,
                            reused_rays: 0,
                            bricks_loaded: 0,
                            dense_fraction: 0.0,
                            load_ms: 0.0,
                            sample_ms: 0.0,
                            prepare_ms: 0.0,
                            width: w,
                            height: h,
                            backend: self.renderer.backend(),
                            mode: settings.mode.name(),
                            iso: None,
                        },
                        t0: req.t0,
                        notes: Vec::new(),
                        sampling: None,
                    });
                }
                Err(e) => {
                    self.error(&SceneError::new(&name, "", e.to_string()), req.reason);
                    return None;
                }
            }
            let next = self.newest(self.rx.recv().ok()?);
            if next.reload {
                return Some(next);
            }
            req = next;
        }
    }
}
