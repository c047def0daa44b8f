//! Helpers for GPU tests: skip with a printed reason where no adapter exists, fail instead
//! where the environment requires a GPU (`ISOKIT_REQUIRE_GPU=1`, set by `.ci/run`, whose
//! machines have Mesa's lavapipe); and the layout check of shared structs as a test assertion.
//!
//! Every GPU test reports its outcome through [`ran`] or [`skipped`] (the helpers below do it
//! for the tests that open a device through them). When `ISOKIT_GPU_TEST_LOG` names a file,
//! each outcome is appended to it as one line, `ran TEST` or `skipped TEST`, so a CI run can
//! count the GPU tests that really ran (tests run in many processes; each line is one
//! `O_APPEND` write).

use crate::{Gpu, GpuError, GpuOptions, ShaderSource, WgslStruct, check_wgsl_layout};
use std::io::Write;

/// Asserts that the struct `T` shares in `shader` has `T`'s layout member by member
/// ([`check_wgsl_layout`]).
///
/// # Panics
/// With the program's label and every difference found.
#[track_caller]
pub fn assert_wgsl_layout<T: WgslStruct>(shader: &ShaderSource) {
    if let Err(e) = check_wgsl_layout::<T>(shader.text()) {
        panic!("{}: {e}", shader.label());
    }
}

/// Whether `ISOKIT_REQUIRE_GPU` asks for GPU tests to fail rather than skip.
pub fn gpu_required() -> bool {
    std::env::var("ISOKIT_REQUIRE_GPU").is_ok_and(|v| v.trim() == "1")
}

/// Appends `what TEST` to the file named by `ISOKIT_GPU_TEST_LOG`, if any (best effort: a
/// log that cannot be written is reported on stderr, never a test failure by itself; CI
/// fails on a count of zero instead).
fn log(what: &str, test: &str) {
    if let Some(path) = std::env::var_os("ISOKIT_GPU_TEST_LOG") {
        if let Err(e) = log_to(std::path::Path::new(&path), what, test) {
            eprintln!("{test}: cannot append to ISOKIT_GPU_TEST_LOG {path:?}: {e}");
        }
    }
}

/// Appends the line `what test` to `path` in one write.
fn log_to(path: &std::path::Path, what: &str, test: &str) -> std::io::Result<()> {
    let line = format!("{what} {test}\n");
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)?
        .write_all(line.as_bytes())
}

/// Reports that the GPU test `test` runs on `device` (printed, and logged for the count).
pub fn ran(test: &str, device: &str) {
    eprintln!("{test}: running on {device}");
    log("ran", test);
}

/// Reports that the GPU test `test` is skipped because `reason`: printed and logged.
///
/// # Panics
/// Under `ISOKIT_REQUIRE_GPU=1`: a required GPU test fails instead of being skipped.
pub fn skipped(test: &str, reason: &str) {
    if gpu_required() {
        panic!("{test}: ISOKIT_REQUIRE_GPU=1 but no usable GPU adapter: {reason}");
    }
    eprintln!("{test}: SKIPPED (no GPU: {reason}; set ISOKIT_REQUIRE_GPU=1 to fail instead)");
    log("skipped", test);
}

/// A GPU test's verdict on an attempt to open a device (any device type, e.g. a renderer):
/// `Some(device)` after [`ran`] when it opened, `None` after [`skipped`] when it did not.
/// `describe` names the device for the log.
///
/// # Panics
/// As [`skipped`].
pub fn run_or_skip<T, E: std::fmt::Display>(
    test: &str,
    opened: Result<T, E>,
    describe: impl FnOnce(&T) -> String,
) -> Option<T> {
    match opened {
        Ok(d) => {
            ran(test, &describe(&d));
            Some(d)
        }
        Err(e) => {
            skipped(test, &e.to_string());
            None
        }
    }
}

/// What a GPU test should do given the outcome of opening a device: `Ok(Some(gpu))` run,
/// `Ok(None)` skip (the reason is returned for printing), `Err` fail.
pub fn decide(
    opened: Result<Gpu, GpuError>,
    required: bool,
) -> Result<Result<Gpu, String>, String> {
    match opened {
        Ok(gpu) => Ok(Ok(gpu)),
        Err(e) if required => Err(format!(
            "ISOKIT_REQUIRE_GPU=1 but no usable GPU adapter: {e}"
        )),
        Err(e) => Ok(Err(e.to_string())),
    }
}

/// Opens a device for the test `test`, or prints why the test is skipped and returns `None`.
///
/// # Panics
/// When no device can be opened and `ISOKIT_REQUIRE_GPU=1`: the test fails instead of being
/// skipped silently.
pub fn gpu_or_skip(test: &str) -> Option<Gpu> {
    gpu_or_skip_with(test, &GpuOptions::default())
}

/// [`gpu_or_skip`] with explicit options (e.g. extra features).
///
/// # Panics
/// As [`gpu_or_skip`].
pub fn gpu_or_skip_with(test: &str, opts: &GpuOptions) -> Option<Gpu> {
    match decide(Gpu::new(opts), gpu_required()) {
        Ok(Ok(gpu)) => {
            ran(test, &gpu.describe());
            Some(gpu)
        }
        Ok(Err(reason)) => {
            skipped(test, &reason);
            None
        }
        Err(msg) => panic!("{test}: {msg}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_adapter_skips_unless_required() {
        let none = || Err(GpuError::NoAdapter("test".into()));
        let skipped = decide(none(), false).unwrap();
        assert!(skipped.unwrap_err().contains("no GPU adapter"));
        let failed = decide(none(), true).unwrap_err();
        assert!(failed.contains("ISOKIT_REQUIRE_GPU=1"));
    }

    #[test]
    fn outcomes_are_logged_one_line_each() {
        // What `ran` and `skipped` append, exercised directly so that the test does not
        // depend on the process's ISOKIT_REQUIRE_GPU and ISOKIT_GPU_TEST_LOG.
        let dir = std::env::temp_dir().join(format!("isokit-gpu-log-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("log");
        log_to(&path, "ran", "a").unwrap();
        log_to(&path, "skipped", "b").unwrap();
        log_to(&path, "ran", "c").unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "ran a\nskipped b\nran c\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn gl_only_or_no_backend_is_a_clear_error() {
        // With no backend at all, the device request fails with NoAdapter, never a panic.
        let opts = GpuOptions {
            backends: wgpu::Backends::empty(),
            ..Default::default()
        };
        match Gpu::new(&opts) {
            Err(GpuError::NoAdapter(_)) => {}
            other => panic!("expected NoAdapter, got {other:?}"),
        }
    }
}
