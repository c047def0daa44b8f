//! The window thread: input, the camera, the panel, presenting frames, the events file.

use crate::events::{EventLog, Reason};
use crate::orbit::Orbit;
use crate::panel::{self, Action, Line};
use crate::watch::FileWatch;
use crate::worker::{self, CancelSlot, InputKind, Knobs, Reply, Request};
use crate::{ViewError, ViewOptions};
use isokit_render::ShadingMode;
use std::num::NonZeroU32;
use std::rc::Rc;
use std::sync::mpsc::{Sender, channel};
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, EventLoopProxy};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// Events the other threads send to the window thread.
pub(crate) enum UserEvent {
    Reply(Box<Reply>),
    Edit(Instant),
}

/// After the last camera input, how long to wait before asking for the final frame.
const SETTLE: Duration = Duration::from_millis(120);

struct Shown {
    pixels: Vec<u32>,
    width: u32,
    height: u32,
}

#[derive(Default)]
struct Live {
    frame_ms: f64,
    latency_ms: f64,
    evaluated: usize,
    reused: usize,
    dense_fraction: f64,
    bricks_loaded: u64,
    fps: f64,
    /// The resolution and band of the sampling shown.
    sampling: Option<(usize, f32)>,
    /// The shading mode of the frame shown.
    mode: Option<&'static str>,
    last_present: Option<Instant>,
}

type Surface = softbuffer::Surface<Rc<Window>, Rc<Window>>;

struct App {
    opts: ViewOptions,
    kind: InputKind,
    proxy: EventLoopProxy<UserEvent>,
    window: Option<(Rc<Window>, Surface)>,
    tx: Option<Sender<Request>>,
    slot: CancelSlot,
    watch: Option<FileWatch>,
    orbit: Option<Orbit>,
    home: Option<Orbit>,
    knobs: Knobs,
    size: (u32, u32),
    shown: Option<Shown>,
    last_final: Option<(Vec<u8>, u32, u32)>,
    error: Option<String>,
    notes: Vec<String>,
    device: String,
    live: Live,
    log: EventLog,
    finals: u64,
    start: Instant,
    buttons: (bool, bool),
    shift: bool,
    cursor: Option<PhysicalPosition<f64>>,
    settle_at: Option<Instant>,
    show_panel: bool,
    /// The panel widget the left button was pressed on (until it is released).
    pressed: Option<Action>,
    failure: Option<ViewError>,
}

/// Runs the window until it closes or an exit condition is met.
pub(crate) fn run(opts: ViewOptions) -> Result<(), ViewError> {
    let event_loop = EventLoop::<UserEvent>::with_user_event()
        .build()
        .map_err(|e| ViewError::Window(format!("{e} (is DISPLAY set? under CI use xvfb-run)")))?;
    let log = EventLog::open(opts.events.as_deref()).map_err(ViewError::Output)?;
    let proxy = event_loop.create_proxy();
    let resolution = opts.resolution;
    let mut app = App {
        kind: InputKind::of(&opts.input),
        size: (opts.width, opts.height),
        opts,
        proxy,
        window: None,
        tx: None,
        slot: CancelSlot::default(),
        watch: None,
        orbit: None,
        home: None,
        knobs: Knobs {
            resolution,
            ..Knobs::default()
        },
        shown: None,
        last_final: None,
        error: None,
        notes: Vec::new(),
        device: String::new(),
        live: Live::default(),
        log,
        finals: 0,
        start: Instant::now(),
        buttons: (false, false),
        shift: false,
        cursor: None,
        settle_at: None,
        show_panel: true,
        pressed: None,
        failure: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewError::Window(e.to_string()))?;
    app.finish()
}

impl App {
    fn finish(&mut self) -> Result<(), ViewError> {
        if let Some(f) = self.failure.take() {
            return Err(f);
        }
        if let Some(path) = &self.opts.screenshot {
            let Some((rgba, w, h)) = &self.last_final else {
                return Err(ViewError::Output(format!(
                    "--screenshot {}: no frame was finished",
                    path.display()
                )));
            };
            isokit_io::write_png(path, *w, *h, rgba)
                .map_err(|e| ViewError::Output(format!("--screenshot {}: {e}", path.display())))?;
        }
        if let Some(e) = self.log.failure() {
            return Err(ViewError::Output(format!("--events: {e}")));
        }
        Ok(())
    }

    fn open(&mut self, el: &ActiveEventLoop) -> Result<(), String> {
        let title = format!("isokit view {}", self.opts.input.display());
        let attrs = Window::default_attributes()
            .with_title(title)
            .with_inner_size(PhysicalSize::new(self.opts.width, self.opts.height));
        let window = Rc::new(el.create_window(attrs).map_err(|e| e.to_string())?);
        let context = softbuffer::Context::new(window.clone()).map_err(|e| e.to_string())?;
        let surface = Surface::new(&context, window.clone()).map_err(|e| e.to_string())?;
        self.window = Some((window, surface));
        // The worker and the file events.
        let (tx, rx) = channel();
        let proxy = self.proxy.clone();
        let (input, backend, slot) = (
            self.opts.input.clone(),
            self.opts.backend,
            self.slot.clone(),
        );
        let reuse = self.opts.reuse;
        std::thread::Builder::new()
            .name("isokit-view-render".into())
            .spawn(move || {
                worker::run(input, backend, reuse, rx, slot, |r| {
                    let _ = proxy.send_event(UserEvent::Reply(Box::new(r)));
                })
            })
            .map_err(|e| e.to_string())?;
        self.tx = Some(tx);
        let proxy = self.proxy.clone();
        let quiet = Duration::from_millis(self.opts.quiet_ms);
        let mut watch = FileWatch::new(quiet, move |t| {
            let _ = proxy.send_event(UserEvent::Edit(t));
        })?;
        watch.set_files(std::slice::from_ref(&self.opts.input));
        self.watch = Some(watch);
        self.request(Reason::Start, Instant::now(), true, false, false);
        Ok(())
    }

    fn request(&mut self, reason: Reason, t0: Instant, reload: bool, resample: bool, draft: bool) {
        if reload || resample {
            // A newer edit cancels what is still running for an older one.
            self.slot.lock().unwrap_or_else(|p| p.into_inner()).cancel();
        }
        let req = Request {
            reason,
            t0,
            reload,
            resample,
            orbit: self.orbit,
            knobs: self.knobs,
            draft,
            width: self.size.0.max(1),
            height: self.size.1.max(1),
        };
        if let Some(tx) = &self.tx {
            let _ = tx.send(req);
        }
    }

    fn camera_moved(&mut self, draft: bool) {
        self.request(Reason::Camera, Instant::now(), false, false, draft);
        self.settle_at = draft.then(|| Instant::now() + SETTLE);
    }

    fn panel_lines(&self) -> Vec<Line> {
        let t = panel::TEXT;
        let mode = self.knobs.mode.map_or("scene's", ShadingMode::name);
        let iso = self
            .knobs
            .iso
            .map_or("default".into(), |v| format!("{v:.4}"));
        let mut lines = vec![
            Line::new(format!("{}", self.opts.input.display()), t).button("[hide H]", Action::Hide),
            Line::new(format!("shading  {mode:<10}"), t)
                .button("[<]", Action::Mode(-1))
                .button("[>]", Action::Mode(1))
                .text("  keys M N"),
            Line::new(format!("iso      {iso:<10}"), t)
                .button("[-]", Action::Iso(-1.0))
                .button("[+]", Action::Iso(1.0))
                .text("  keys K I"),
        ];
        if self.kind == InputKind::Scene {
            let (res, band) = match self.live.sampling {
                Some((r, b)) => (r.to_string(), format!("{b:.4}")),
                None => ("-".into(), "-".into()),
            };
            if let Some((_, b)) = self.live.sampling {
                let f = 0.5 * (self.knobs.iso.unwrap_or(0.0) / b + 1.0);
                lines.push(
                    Line::new(format!("{:<19}", format!("  -{b:.3}")), t)
                        .slider(24, f, Action::IsoAt)
                        .text(&format!(" +{b:.3}")),
                );
            }
            lines.push(
                Line::new(format!("sampling {res:<10}"), t)
                    .button("[-]", Action::Resolution(false))
                    .button("[+]", Action::Resolution(true))
                    .text("  keys - +"),
            );
            lines.push(
                Line::new(format!("band     {band:<10}"), t)
                    .button("[-]", Action::Band(false))
                    .button("[+]", Action::Band(true))
                    .text("  keys V B"),
            );
        }
        let l = &self.live;
        lines.extend([
            Line::new(format!("backend  {}", self.device), t),
            Line::new(
                format!(
                    "frame {:.1} ms  {:.1} fps  edit latency {:.0} ms",
                    l.frame_ms, l.fps, l.latency_ms
                ),
                t,
            ),
            Line::new(
                format!(
                    "bricks evaluated {} reused {}  grid evaluated {:.1}%  loaded {}",
                    l.evaluated,
                    l.reused,
                    100.0 * l.dense_fraction,
                    l.bricks_loaded
                ),
                t,
            ),
            Line::new("drag orbit, shift-drag pan, wheel zoom", t)
                .button("[reset view R]", Action::Reset)
                .button("[quit Q]", Action::Quit),
        ]);
        lines.extend(self.notes.iter().map(|n| Line::new(n.clone(), t)));
        if let Some(e) = &self.error {
            lines.push(Line::new(e.clone(), panel::ERROR));
        }
        lines
    }

    /// Pixels per font pixel of the panel, for the window's height.
    fn panel_scale(&self) -> usize {
        let h = self
            .window
            .as_ref()
            .map_or(self.size.1, |(w, _)| w.inner_size().height);
        if h >= 720 { 2 } else { 1 }
    }

    /// Draws the frame shown (scaled to the window, nearest sample) and the panel.
    fn present(&mut self) {
        let lines = if self.show_panel {
            self.panel_lines()
        } else {
            self.error
                .iter()
                .map(|e| Line::new(e.clone(), panel::ERROR))
                .collect()
        };
        let scale = self.panel_scale();
        let Some((window, surface)) = &mut self.window else {
            return;
        };
        let size = window.inner_size();
        let (Some(w), Some(h)) = (NonZeroU32::new(size.width), NonZeroU32::new(size.height)) else {
            return;
        };
        if surface.resize(w, h).is_err() {
            return;
        }
        let Ok(mut buf) = surface.buffer_mut() else {
            return;
        };
        let (ww, wh) = (size.width as usize, size.height as usize);
        match &self.shown {
            Some(s) => {
                let (fw, fh) = (s.width as usize, s.height as usize);
                for y in 0..wh {
                    let sy = (y * fh / wh).min(fh - 1);
                    for x in 0..ww {
                        let sx = (x * fw / ww).min(fw - 1);
                        buf[y * ww + x] = s.pixels[sy * fw + sx];
                    }
                }
            }
            None => buf.fill(0x0030_3030),
        }
        panel::draw(&mut buf, ww, wh, &lines, scale);
        let _ = buf.present();
    }

    fn on_reply(&mut self, el: &ActiveEventLoop, r: Reply) {
        match r {
            Reply::Frame {
                pixels,
                rgba,
                width,
                height,
                mut event,
                t0,
                notes,
                sampling,
            } => {
                if event.final_ && sampling.is_some() {
                    self.live.sampling = sampling;
                }
                self.shown = Some(Shown {
                    pixels,
                    width,
                    height,
                });
                if event.final_ {
                    self.last_final = Some((rgba, width, height));
                    self.error = None;
                    self.notes = notes;
                }
                self.present();
                let now = Instant::now();
                event.latency_ms = 1e3 * now.duration_since(t0).as_secs_f64();
                let l = &mut self.live;
                if let Some(prev) = l.last_present {
                    let dt = now.duration_since(prev).as_secs_f64();
                    if dt > 0.0 {
                        l.fps = 1.0 / dt;
                    }
                }
                l.last_present = Some(now);
                l.frame_ms = event.frame_ms;
                l.mode = Some(event.mode);
                if event.reason >= Reason::Edit || event.reason == Reason::Panel {
                    l.latency_ms = event.latency_ms;
                }
                if event.evaluated_bricks + event.reused_bricks > 0 {
                    l.evaluated = event.evaluated_bricks;
                    l.reused = event.reused_bricks;
                    l.dense_fraction = event.dense_fraction;
                }
                l.bricks_loaded = event.bricks_loaded;
                self.log.frame(&event);
                if event.final_ {
                    self.finals += 1;
                    if self
                        .opts
                        .exit_after_frames
                        .is_some_and(|n| self.finals >= n)
                    {
                        el.exit();
                    }
                }
            }
            Reply::Error {
                file,
                node,
                message,
                reason,
            } => {
                let mut line = String::new();
                for part in [file.as_str(), node.as_str()] {
                    if !part.is_empty() {
                        line.push_str(part);
                        line.push_str(": ");
                    }
                }
                line.push_str(&message);
                self.error = Some(line.lines().next().unwrap_or_default().to_string());
                self.log.error(&file, &node, &message, reason);
                self.present();
            }
            Reply::Loaded { files, camera } => {
                if let Some(w) = &mut self.watch {
                    w.set_files(&files);
                }
                if camera.is_some() {
                    self.home = camera;
                    if self.orbit.is_none() {
                        self.orbit = camera;
                    }
                }
            }
            Reply::Device(d) => self.device = d,
            Reply::Note(n) => {
                self.notes.push(n);
                self.present();
            }
        }
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) {
        let action = match key {
            Key::Named(NamedKey::Escape) => Action::Quit,
            Key::Character(c) => match c.as_str() {
                "q" | "Q" => Action::Quit,
                "h" | "H" => Action::Hide,
                "m" | "M" => Action::Mode(1),
                "n" | "N" => Action::Mode(-1),
                "i" | "I" => Action::Iso(1.0),
                "k" | "K" => Action::Iso(-1.0),
                "b" | "B" => Action::Band(true),
                "v" | "V" => Action::Band(false),
                "+" | "=" => Action::Resolution(true),
                "-" => Action::Resolution(false),
                "r" | "R" => Action::Reset,
                _ => return,
            },
            _ => return,
        };
        self.act(el, action, 0.0);
    }

    /// Does what a key or a click on the panel asks for; `fraction`: where along a slider
    /// it was clicked.
    fn act(&mut self, el: &ActiveEventLoop, action: Action, fraction: f32) {
        let modes = ShadingMode::ALL;
        let scene = self.kind == InputKind::Scene;
        match action {
            Action::Quit => el.exit(),
            Action::Hide => {
                self.show_panel = !self.show_panel;
                self.present();
            }
            Action::Mode(d) => {
                // From the mode set, else the one shown (the input's own).
                let i = match self.knobs.mode {
                    Some(m) => modes.iter().position(|(_, x)| *x == m),
                    None => self
                        .live
                        .mode
                        .and_then(|n| modes.iter().position(|(_, x)| x.name() == n)),
                }
                .map_or(0, |i| i as isize + d);
                self.knobs.mode = Some(modes[i.rem_euclid(modes.len() as isize) as usize].1);
                self.request(Reason::Panel, Instant::now(), false, false, false);
            }
            Action::Iso(d) => {
                let step = self.orbit.map_or(0.01, |o| 0.002 * o.offset.length());
                self.knobs.iso = Some(self.knobs.iso.unwrap_or(0.0) + d * step);
                self.request(Reason::Panel, Instant::now(), false, false, false);
            }
            Action::IsoAt => {
                if let Some((_, band)) = self.live.sampling {
                    self.knobs.iso = Some(band * (2.0 * fraction.clamp(0.0, 1.0) - 1.0));
                    self.request(Reason::Panel, Instant::now(), false, false, false);
                }
            }
            Action::Band(wider) if scene => {
                if let Some((_, band)) = self.live.sampling {
                    self.knobs.band = Some(band * if wider { 2.0 } else { 0.5 });
                    self.request(Reason::Panel, Instant::now(), false, true, false);
                }
            }
            Action::Resolution(finer) if scene => {
                let r = self
                    .knobs
                    .resolution
                    .or(self.live.sampling.map(|s| s.0))
                    .unwrap_or(128);
                let r = if finer {
                    (r * 2).min(1024)
                } else {
                    (r / 2).max(16)
                };
                self.knobs.resolution = Some(r);
                self.request(Reason::Panel, Instant::now(), false, true, false);
            }
            Action::Band(_) | Action::Resolution(_) => {}
            Action::Reset => {
                self.orbit = self.home;
                self.camera_moved(false);
            }
        }
    }

    /// The panel widget under the cursor, if the panel is shown.
    fn widget_at_cursor(&self) -> Option<(Action, f32)> {
        let c = self.cursor?;
        if !self.show_panel {
            return None;
        }
        panel::hit(&self.panel_lines(), self.panel_scale(), c.x, c.y)
    }
}

impl ApplicationHandler<UserEvent> for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.window.is_none()
            && let Err(e) = self.open(el)
        {
            self.failure = Some(ViewError::Window(e));
            el.exit();
        }
    }

    fn user_event(&mut self, el: &ActiveEventLoop, ev: UserEvent) {
        match ev {
            UserEvent::Reply(r) => self.on_reply(el, *r),
            UserEvent::Edit(t) => self.request(Reason::Edit, t, true, false, false),
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, ev: WindowEvent) {
        match ev {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::RedrawRequested => self.present(),
            WindowEvent::Resized(s) => {
                if (s.width, s.height) != self.size && s.width > 0 && s.height > 0 {
                    self.size = (s.width, s.height);
                    self.camera_moved(false);
                }
                self.present();
            }
            WindowEvent::ModifiersChanged(m) => self.shift = m.state().shift_key(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(el, &event.logical_key);
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                // A press on a panel widget is a click (or a slider drag), not an orbit.
                if button == MouseButton::Left && down {
                    if let Some((action, f)) = self.widget_at_cursor() {
                        self.pressed = Some(action);
                        self.act(el, action, f);
                        return;
                    }
                }
                if button == MouseButton::Left && !down && self.pressed.take().is_some() {
                    self.buttons.0 = false;
                    return;
                }
                match button {
                    MouseButton::Left => self.buttons.0 = down,
                    MouseButton::Right | MouseButton::Middle => self.buttons.1 = down,
                    _ => {}
                }
                if !down {
                    self.camera_moved(false);
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let prev = self.cursor.replace(position);
                if self.pressed == Some(Action::IsoAt) {
                    let lines = self.panel_lines();
                    if let Some(f) = panel::slider_fraction(&lines, self.panel_scale(), position.x)
                    {
                        self.act(el, Action::IsoAt, f);
                    }
                    return;
                }
                if self.pressed.is_some() {
                    return;
                }
                let (Some(prev), Some(o)) = (prev, self.orbit.as_mut()) else {
                    return;
                };
                let (dx, dy) = ((position.x - prev.x) as f32, (position.y - prev.y) as f32);
                let h = self.size.1.max(1) as f32;
                if self.buttons.1 || (self.buttons.0 && self.shift) {
                    o.pan(dx / h, dy / h);
                } else if self.buttons.0 {
                    o.rotate(3.0 * dx / h, 3.0 * dy / h);
                } else {
                    return;
                }
                self.camera_moved(true);
            }
            // A release after the window lost the focus (to another window, a desktop
            // switch) may never arrive: the drag or the press on a widget ends here. (A drag
            // that leaves the window keeps its grab and its release.)
            WindowEvent::Focused(false) => {
                let dragging = self.buttons.0 || self.buttons.1;
                self.pressed = None;
                self.buttons = (false, false);
                self.cursor = None;
                if dragging {
                    self.camera_moved(false);
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let clicks = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                if let Some(o) = self.orbit.as_mut() {
                    o.zoom(0.9f32.powf(clicks));
                    self.camera_moved(true);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        let now = Instant::now();
        if let Some(t) = self.settle_at
            && now >= t
        {
            self.camera_moved(false);
        }
        let deadline = self
            .opts
            .exit_after_seconds
            .map(|s| self.start + Duration::from_secs_f64(s));
        if deadline.is_some_and(|d| now >= d) {
            el.exit();
            return;
        }
        match [self.settle_at, deadline].into_iter().flatten().min() {
            Some(t) => el.set_control_flow(ControlFlow::WaitUntil(t)),
            None => el.set_control_flow(ControlFlow::Wait),
        }
    }
}
