//! # isokit-viewer: a live window on a scene, a volume or a molecule
//!
//! `isokit view` keeps a window beside the user's editor and follows every save: file events
//! (inotify through `notify`, not polling) on the scene and every file it depends on, saves in
//! quick succession merged, a newer edit cancelling work still running for an older one, a
//! coarse frame first and the finished one after it, the last good picture kept (with the
//! one-line error drawn over it) while a save is broken. It is the watch → evaluate → render →
//! show pipeline of fidget's viewer and libfive Studio, as threads:
//!
//! - the window thread (winit) owns the camera, the panel and the presented pixels
//!   (softbuffer: a plain framebuffer, so the window works without any GPU adapter);
//! - a watcher thread turns file events into edits, merged over a short quiet period;
//! - a worker thread compiles the scene (keeping built kd-trees, clouds and volumes across
//!   edits in an [`isokit_scene::SourceCache`]), samples its band reusing the bricks an
//!   edit cannot have changed, and ray casts on the CPU twin or the GPU; on the CPU, the
//!   finished frame after an edit traces only the rays that can reach a changed block and
//!   takes the others from the frame before ([`isokit_render::render_reusing`]).
//!
//! Scripts and tests drive it headless with [`ViewOptions::events`] (one JSON object per
//! frame and per error), [`ViewOptions::screenshot`] and the exit conditions.
#![warn(missing_docs)]

mod app;
mod events;
mod orbit;
mod panel;
mod watch;
mod worker;

pub use events::Reason;
pub use orbit::Orbit;

use std::path::PathBuf;

/// What the window shows and how it is driven (the flags of `isokit view`).
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// A scene file (.json, .toml), a volume (.nrrd .nhdr .npy .nii .nii.gz .mrc .raw...)
    /// or a molecule (.pdb .cif .mmcif .ent).
    pub input: PathBuf,
    /// Which renderer: auto, cpu or gpu (the one backend policy of `isokit-gpu`).
    pub backend: isokit_gpu::BackendChoice,
    /// Window width in pixels.
    pub width: u32,
    /// Window height in pixels.
    pub height: u32,
    /// Scene sampling: samples along the longest side (default: the scene's).
    pub resolution: Option<usize>,
    /// Write one JSON object per line for every frame and error to this file (replaced at
    /// start).
    pub events: Option<PathBuf>,
    /// Write the last final frame as PNG on exit.
    pub screenshot: Option<PathBuf>,
    /// Exit after this many final frames.
    pub exit_after_frames: Option<u64>,
    /// Exit after this many seconds.
    pub exit_after_seconds: Option<f64>,
    /// How long file events must be quiet before an edit is rendered (merges the several
    /// writes of one save and saves in quick succession); a quarter of it after an event
    /// that completes a save (the file closed after writing, or renamed into place).
    pub quiet_ms: u64,
    /// Take the bricks an edit cannot have changed from the previous sampling (the default);
    /// `false` samples every edit in full and traces every ray of its frame (the baseline
    /// the reuse is measured against).
    pub reuse: bool,
}

impl Default for ViewOptions {
    fn default() -> Self {
        Self {
            input: PathBuf::new(),
            backend: isokit_gpu::BackendChoice::Auto,
            width: 512,
            height: 512,
            resolution: None,
            events: None,
            screenshot: None,
            exit_after_frames: None,
            exit_after_seconds: None,
            quiet_ms: 16,
            reuse: true,
        }
    }
}

/// Why the viewer could not run.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// No window can be opened (no display, or the display refused).
    #[error("cannot open a window: {0}")]
    Window(String),
    /// Bad options.
    #[error("{0}")]
    Options(String),
    /// Writing the events file or the screenshot failed.
    #[error("{0}")]
    Output(String),
}

/// Opens the window and runs until it is closed or an exit condition is met.
pub fn run(opts: ViewOptions) -> Result<(), ViewError> {
    if !opts.input.exists() {
        return Err(ViewError::Options(format!(
            "{}: no such file",
            opts.input.display()
        )));
    }
    if opts.width == 0 || opts.height == 0 || opts.width > 8192 || opts.height > 8192 {
        return Err(ViewError::Options(format!(
            "--width {} --height {}: each must be from 1 to 8192",
            opts.width, opts.height
        )));
    }
    if let Some(s) = opts.exit_after_seconds
        && !(s.is_finite() && s > 0.0)
    {
        return Err(ViewError::Options(format!(
            "--exit-after-seconds {s}: must be positive"
        )));
    }
    if opts.exit_after_frames == Some(0) {
        return Err(ViewError::Options(
            "--exit-after-frames must be at least 1".into(),
        ));
    }
    for (flag, p, ext) in [
        ("--screenshot", &opts.screenshot, "png"),
        ("--events", &opts.events, "jsonl"),
    ] {
        if let Some(p) = p {
            let ok = p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case(ext) || ext == "jsonl");
            if !ok {
                return Err(ViewError::Options(format!(
                    "{flag} {}: expected a .{ext} file",
                    p.display()
                )));
            }
        }
    }
    app::run(opts)
}
