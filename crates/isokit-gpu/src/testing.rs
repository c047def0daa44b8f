//! Helpers for GPU tests: skip with a printed reason where no adapter exists, fail instead
//! where the environment requires a GPU (`ISOKIT_REQUIRE_GPU=1`, set by CI, whose machines
//! have Mesa's lavapipe); and the layout check of shared structs as a test assertion.

use crate::{Gpu, GpuError, GpuOptions, ShaderSource, WgslStruct, check_wgsl_layout};

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
            eprintln!("{test}: running on {}", gpu.describe());
            Some(gpu)
        }
        Ok(Err(reason)) => {
            eprintln!(
                "{test}: SKIPPED (no GPU: {reason}; set ISOKIT_REQUIRE_GPU=1 to fail instead)"
            );
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
