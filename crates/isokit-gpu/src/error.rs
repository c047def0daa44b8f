//! The one error type of the GPU plumbing.

/// What can go wrong between the program and the GPU.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
pub enum GpuError {
    /// No adapter could be found (no driver, no device, or the backends were narrowed away).
    #[error(
        "no GPU adapter: {} (install a Vulkan driver, e.g. Debian's mesa-vulkan-drivers, or use --backend cpu)",
        one_line(.0)
    )]
    NoAdapter(String),
    /// The adapter cannot run compute shaders (e.g. GL below ES 3.1).
    #[error("GPU adapter {0} cannot run compute shaders")]
    NoCompute(String),
    /// The adapter lacks features the kernel needs.
    #[error("GPU adapter {adapter} lacks the features {features}")]
    MissingFeatures {
        /// The adapter.
        adapter: String,
        /// The missing features, printed.
        features: String,
    },
    /// Opening the device failed.
    #[error("could not open the GPU device: {}", one_line(.0))]
    Device(String),
    /// A shader failed to compile or a pipeline failed to build.
    #[error("shader {label}: {}", one_line(message))]
    Shader {
        /// The shader's label.
        label: String,
        /// wgpu's or naga's message.
        message: String,
    },
    /// Mapping a buffer for read-back failed.
    #[error("GPU read-back failed: {}", one_line(.0))]
    Map(String),
    /// A validation or internal error raised by wgpu while recording or submitting work.
    #[error("GPU error: {}", one_line(.0))]
    Wgpu(String),
    /// The work does not fit the device's limits (buffer size, dispatch size).
    #[error("too large for the GPU: {}", one_line(.0))]
    TooLarge(String),
    /// `--backend` or `ISOKIT_BACKEND` holds an unknown value.
    #[error("unknown backend '{0}': use cpu, gpu or auto")]
    BadBackend(String),
}

/// wgpu's and naga's messages span lines (a validation error, its causes, the source
/// excerpt): joined with "; " so that every error prints as one line.
pub(crate) fn one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}
