//! `isokit.view`: the live viewer of `isokit-viewer`, run in a child Python process (the
//! window needs its process's main thread) on a scene file the script rewrites.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Opens the viewer window on the scene file `path` and returns when it closes (the body of
/// the child process `isokit.view` starts). Arguments as `isokit view`'s flags.
#[pyfunction]
#[pyo3(signature = (path, width = 512, height = 512, backend = "auto", events = None,
    screenshot = None, exit_after_frames = None, exit_after_seconds = None))]
#[expect(clippy::too_many_arguments, reason = "the command's flags, one each")]
pub fn _view_main(
    py: Python<'_>,
    path: PathBuf,
    width: u32,
    height: u32,
    backend: &str,
    events: Option<PathBuf>,
    screenshot: Option<PathBuf>,
    exit_after_frames: Option<u64>,
    exit_after_seconds: Option<f64>,
) -> PyResult<()> {
    let backend = crate::render::backend_arg(backend)?;
    let opts = isokit_viewer::ViewOptions {
        input: path,
        backend,
        width,
        height,
        events,
        screenshot,
        exit_after_frames,
        exit_after_seconds,
        ..Default::default()
    };
    py.detach(|| isokit_viewer::run(opts))
        .map_err(|e| PyValueError::new_err(e.to_string()))
}
