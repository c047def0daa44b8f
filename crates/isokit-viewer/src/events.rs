//! The events file: one JSON object per line for every frame presented and every error.

use serde_json::{Value, json};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Why a frame was rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Reason {
    /// The camera moved (mouse, keys, reset).
    Camera,
    /// A panel setting changed (shading mode, isovalue, resolution, band).
    Panel,
    /// A watched file changed.
    Edit,
    /// The first frame.
    Start,
}

impl Reason {
    /// The name written to the events file.
    pub fn name(self) -> &'static str {
        match self {
            Reason::Camera => "camera",
            Reason::Panel => "panel",
            Reason::Edit => "edit",
            Reason::Start => "start",
        }
    }
}

/// One frame's line of the events file.
#[derive(Clone, Debug)]
pub(crate) struct FrameEvent {
    pub reason: Reason,
    pub final_: bool,
    pub latency_ms: f64,
    pub frame_ms: f64,
    pub evaluated_bricks: usize,
    pub reused_bricks: usize,
    /// Rays of a finished frame whose pixels were taken from the frame before the edit
    /// (the others were traced).
    pub reused_rays: u64,
    pub bricks_loaded: u64,
    pub dense_fraction: f64,
    /// For the frame that follows a (re)load: milliseconds compiling the scene, sampling its
    /// band and preparing the renderer's volume; 0 for frames of an earlier sampling (a
    /// half-size draft and the finished frame after it both carry their sampling's).
    pub load_ms: f64,
    pub sample_ms: f64,
    pub prepare_ms: f64,
    pub width: u32,
    pub height: u32,
    pub backend: &'static str,
    /// The shading mode rendered.
    pub mode: &'static str,
    /// The isovalue rendered; `None` (JSON `null`) for molecules, whose splatted quadrics
    /// have none.
    pub iso: Option<f32>,
}

/// Appends events to a file, a line at a time (flushed, so a killed viewer leaves whole
/// lines).
pub(crate) struct EventLog {
    out: Option<BufWriter<File>>,
    failed: Option<String>,
}

impl EventLog {
    pub fn open(path: Option<&Path>) -> Result<Self, String> {
        let out = match path {
            Some(p) => Some(BufWriter::new(
                File::create(p).map_err(|e| format!("--events {}: {e}", p.display()))?,
            )),
            None => None,
        };
        Ok(Self { out, failed: None })
    }

    /// The first write error, if any (reported on exit).
    pub fn failure(&self) -> Option<&str> {
        self.failed.as_deref()
    }

    fn write(&mut self, v: Value) {
        if let Some(out) = &mut self.out {
            let r = writeln!(out, "{v}").and_then(|_| out.flush());
            if let Err(e) = r {
                self.failed.get_or_insert(e.to_string());
            }
        }
    }

    pub fn frame(&mut self, f: &FrameEvent) {
        self.write(json!({
            "event": "frame",
            "reason": f.reason.name(),
            "final": f.final_,
            "latency_ms": f.latency_ms,
            "frame_ms": f.frame_ms,
            "evaluated_bricks": f.evaluated_bricks,
            "reused_bricks": f.reused_bricks,
            "reused_rays": f.reused_rays,
            "bricks_loaded": f.bricks_loaded,
            "dense_fraction": f.dense_fraction,
            "load_ms": f.load_ms,
            "sample_ms": f.sample_ms,
            "prepare_ms": f.prepare_ms,
            "width": f.width,
            "height": f.height,
            "backend": f.backend,
            "mode": f.mode,
            "iso": f.iso,
            "ok": true,
        }));
    }

    pub fn error(&mut self, file: &str, node: &str, message: &str, reason: Reason) {
        self.write(json!({
            "event": "error",
            "reason": reason.name(),
            "file": file,
            "node": node,
            "message": message,
            "ok": false,
        }));
    }
}
