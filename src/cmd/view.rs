//! `isokit view SCENE|VOLUME|MOLECULE`: a live window that renders the input again whenever
//! it or a file it depends on is saved (`isokit_viewer`).

use crate::cmd::args::Backend;
use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `isokit view`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A scene file (.json, .toml), a volume (.nrrd .nhdr .npy .nii .nii.gz) or a molecule
    /// (.pdb .cif .mmcif .ent).
    pub input: PathBuf,
    /// Backend: auto (a hardware GPU when one exists, else the CPU twin), cpu, gpu.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Window width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Window height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Scene sampling: samples along the longest side [default: `sampling.resolution`,
    /// else 128].
    #[arg(long)]
    pub res: Option<usize>,
    /// Write one JSON object per line for every frame and error to this file (replaced)
    /// (`{"event":"frame","reason":"edit","final":true,"latency_ms":…}`).
    #[arg(long, value_name = "FILE.jsonl")]
    pub events: Option<PathBuf>,
    /// On exit, write the last finished frame as PNG.
    #[arg(long, value_name = "PATH.png")]
    pub screenshot: Option<PathBuf>,
    /// Exit after this many finished (final) frames.
    #[arg(long, value_name = "N")]
    pub exit_after_frames: Option<u64>,
    /// Exit after this many seconds.
    #[arg(long, value_name = "S")]
    pub exit_after_seconds: Option<f64>,
    /// Merge file events closer together than this (one save writes several times); a
    /// quarter of it after an event that completes a save (closed after writing, renamed).
    #[arg(long, default_value_t = 16, value_name = "MS")]
    pub quiet_ms: u64,
    /// Sample every edit in full instead of reusing the bricks it cannot have changed, and
    /// trace every ray of its frame instead of taking those it cannot have changed from the
    /// frame before (the baseline the reuse is measured against).
    #[arg(long)]
    pub no_reuse: bool,
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    isokit_viewer::run(isokit_viewer::ViewOptions {
        input: a.input,
        backend: a.backend.choice(),
        width: a.width,
        height: a.height,
        resolution: a.res,
        events: a.events,
        screenshot: a.screenshot,
        exit_after_frames: a.exit_after_frames,
        exit_after_seconds: a.exit_after_seconds,
        quiet_ms: a.quiet_ms,
        reuse: !a.no_reuse,
    })?;
    Ok(())
}
