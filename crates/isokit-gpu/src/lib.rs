//! # isokit-gpu
//!
//! The GPU plumbing every isokit kernel shares: one policy for finding an adapter and opening
//! a device (headless, wgpu 30), one error type, buffer upload and read-back, compute
//! pipelines built from WGSL under an error scope, WGSL assembly from pieces and validation
//! with naga for unit tests ([`ShaderSource`]), the member-by-member check of every struct
//! shared with WGSL against its `#[repr(C)]` Rust twin ([`layout`], [`wgsl_layout!`]), and the
//! test helper that skips a GPU test with a printed reason when no adapter exists (or fails
//! it when `ISOKIT_REQUIRE_GPU=1`).
//!
//! What it is not for: it holds no kernels of its own. The kernels (prism scan conversion,
//! the ray caster, quadric splatting) live in their crates, beside a CPU twin each; their
//! WGSL is in `shaders/` at the repository root, embedded by the `isokit-shaders` crate.
//!
//! ## Choosing a path
//! [`BackendChoice`] is the user's request (`--backend cpu|gpu|auto`, or the environment
//! variable `ISOKIT_BACKEND`); [`Gpu::new`] opens a device or says why it cannot
//! ([`GpuError::NoAdapter`], [`GpuError::NoCompute`], …). Callers with a CPU twin fall back to
//! it on `auto` and report the reason.
//!
//! ## Backends
//! Vulkan (on machines without a GPU: Mesa's lavapipe, Debian package
//! `mesa-vulkan-drivers`) and GLES 3.1 (Mesa's llvmpipe through EGL) are compiled in; DX12,
//! Metal and WebGPU are not, to keep the build lean. `WGPU_BACKEND=vulkan|gl` narrows the
//! choice (wgpu's own variable), `WGPU_ADAPTER_NAME` picks an adapter by name.
//!
//! ```no_run
//! use isokit_gpu::{Gpu, GpuOptions};
//! let gpu = Gpu::new(&GpuOptions::default()).unwrap();
//! let data = [1.0f32, 2.0, 3.0];
//! let buf = gpu.upload("example", &data, wgpu::BufferUsages::STORAGE);
//! let back: Vec<f32> = gpu.read_buffer(&buf, 0, 3).unwrap();
//! assert_eq!(back, data);
//! ```
#![warn(missing_docs)]

mod error;
pub mod layout;
pub mod shader;
pub mod testing;

pub use error::GpuError;
pub use layout::{
    GpuField, WgslMember, WgslStruct, WgslType, check_wgsl_layout, wgsl_struct_layout,
};
pub use shader::{ShaderSource, validate_wgsl, wgsl_struct_size};
pub use wgpu;

use std::sync::mpsc;

/// Which implementation a command should use: the user's request.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// The GPU when an adapter with compute shaders exists, else the CPU twin (with a note).
    #[default]
    Auto,
    /// The CPU twin (rayon), always available.
    Cpu,
    /// The GPU; an error when no adapter exists.
    Gpu,
}

impl BackendChoice {
    /// Lower-case name (`auto`, `cpu`, `gpu`).
    pub fn name(self) -> &'static str {
        match self {
            BackendChoice::Auto => "auto",
            BackendChoice::Cpu => "cpu",
            BackendChoice::Gpu => "gpu",
        }
    }

    /// Parses `auto`, `cpu` or `gpu` (case-insensitive).
    pub fn parse(s: &str) -> Result<Self, GpuError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" | "" => Ok(BackendChoice::Auto),
            "cpu" => Ok(BackendChoice::Cpu),
            "gpu" => Ok(BackendChoice::Gpu),
            _ => Err(GpuError::BadBackend(s.to_string())),
        }
    }

    /// The environment's request, `ISOKIT_BACKEND=cpu|gpu|auto`; `Auto` when unset.
    pub fn from_env() -> Result<Self, GpuError> {
        match std::env::var("ISOKIT_BACKEND") {
            Ok(v) => Self::parse(&v),
            Err(_) => Ok(BackendChoice::Auto),
        }
    }

    /// `self`, unless it is `Auto`, in which case the environment's request.
    pub fn or_env(self) -> Result<Self, GpuError> {
        match self {
            BackendChoice::Auto => Self::from_env(),
            other => Ok(other),
        }
    }
}

/// What a backend request resolved to: a device, or the CPU twin with the reason when
/// `auto` passed over the GPU.
#[derive(Debug)]
pub struct Chosen {
    /// The device, or `None` for the CPU twin.
    pub gpu: Option<Gpu>,
    /// Why the CPU twin runs although `auto` was asked for: no usable adapter, or only a
    /// software one (callers say it to the user, with what runs on the CPU).
    pub reason: Option<String>,
}

/// The one backend policy of isokit. `Cpu` is the CPU twin (no device is created); `Gpu`
/// opens a device on any adapter, software ones included, and fails without one; `Auto`
/// (after `ISOKIT_BACKEND`, see [`BackendChoice::or_env`]) takes a hardware GPU and
/// otherwise the CPU twin, with a note saying why.
///
/// `Auto` passes over software adapters (lavapipe, llvmpipe: [`wgpu::DeviceType::Cpu`])
/// because they run the kernels on the same CPU cores, several times slower than the rayon
/// twins (the demo scene at 640×480 on 2 cores: 7.1 s against 1.5–1.9 s). It decides
/// without creating a device where the answer is known: on Linux, a machine without any GPU
/// device node ([`hardware_gpu_possible`]) has only software adapters, and the CPU twin is
/// chosen without loading a driver (the Vulkan loader and EGL take 0.2–0.6 s to start even
/// for lavapipe alone); elsewhere it looks at the adapter before creating a device, so a
/// machine whose only adapter is a software one pays for the adapter query only.
pub fn choose_backend(choice: BackendChoice, opts: &GpuOptions) -> Result<Chosen, GpuError> {
    match choice.or_env()? {
        BackendChoice::Cpu => Ok(Chosen {
            gpu: None,
            reason: None,
        }),
        BackendChoice::Gpu => Ok(Chosen {
            gpu: Some(Gpu::new(opts)?),
            reason: None,
        }),
        BackendChoice::Auto => {
            let cpu = |why: String| Chosen {
                gpu: None,
                reason: Some(why),
            };
            if !hardware_gpu_possible(std::path::Path::new("/dev")) {
                return Ok(cpu(
                    "no usable GPU: this machine has no GPU device (no /dev/dri render node, /dev/nvidia* or /dev/dxg), so any adapter is a software one, slower than the CPU twin (--backend gpu uses it)"
                        .to_string(),
                ));
            }
            match Gpu::adapter(opts) {
                Ok(info) if info.device_type == wgpu::DeviceType::Cpu => Ok(cpu(format!(
                    "the only GPU adapter, {}, is a software one, slower than the CPU twin (--backend gpu uses it)",
                    adapter_name(&info)
                ))),
                Ok(_) => match Gpu::new(opts) {
                    Ok(g) => Ok(Chosen {
                        gpu: Some(g),
                        reason: None,
                    }),
                    Err(e) => Ok(cpu(format!("no usable GPU ({e})"))),
                },
                Err(e) => Ok(cpu(format!("no usable GPU ({e})"))),
            }
        }
    }
}

/// False when `dev` (the device folder, `/dev`) shows that no hardware GPU can be reached:
/// on Linux, every hardware Vulkan or GL driver opens a DRM node (`dri/renderD*`,
/// `dri/card*`), the NVIDIA driver `nvidia*`, WSL's `dxg`; without any of them only
/// software adapters (lavapipe, llvmpipe) exist. True on other systems and whenever `dev`
/// cannot be read (then the adapters are asked).
pub fn hardware_gpu_possible(dev: &std::path::Path) -> bool {
    if !cfg!(target_os = "linux") {
        return true;
    }
    let names = |dir: &std::path::Path| -> Option<Vec<String>> {
        let entries = std::fs::read_dir(dir).ok()?;
        Some(
            entries
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect(),
        )
    };
    let Some(top) = names(dev) else {
        return true;
    };
    if top.iter().any(|n| n.starts_with("nvidia") || n == "dxg") {
        return true;
    }
    names(&dev.join("dri")).is_some_and(|d| {
        d.iter()
            .any(|n| n.starts_with("renderD") || n.starts_with("card"))
    })
}

/// Options of [`Gpu::new`].
#[derive(Clone, Debug)]
pub struct GpuOptions {
    /// Backends to try (default Vulkan and GL, narrowed by `WGPU_BACKEND`).
    pub backends: wgpu::Backends,
    /// Power preference (default high performance: the discrete GPU when there are several).
    pub power: wgpu::PowerPreference,
    /// Extra features the kernel needs; the device request fails with
    /// [`GpuError::MissingFeatures`] when the adapter lacks them.
    pub features: wgpu::Features,
    /// Label of the device, shown by graphics debuggers.
    pub label: &'static str,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self {
            backends: (wgpu::Backends::VULKAN | wgpu::Backends::GL).with_env(),
            power: wgpu::PowerPreference::HighPerformance,
            features: wgpu::Features::empty(),
            label: "isokit",
        }
    }
}

/// An open GPU device with its queue, and what was learnt about the adapter.
#[derive(Debug)]
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    adapter: wgpu::Adapter,
}

impl Gpu {
    /// Finds an adapter and opens a device, headless. Errors: no adapter
    /// ([`GpuError::NoAdapter`]), no compute shaders (GL below 3.1:
    /// [`GpuError::NoCompute`]), missing features, or the device request failing.
    pub fn new(opts: &GpuOptions) -> Result<Self, GpuError> {
        let adapter = Self::request_adapter(opts)?;
        let info = adapter.get_info();
        let down = adapter.get_downlevel_capabilities();
        if !down.flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) {
            return Err(GpuError::NoCompute(adapter_name(&info)));
        }
        let missing = opts.features - adapter.features();
        if !missing.is_empty() {
            return Err(GpuError::MissingFeatures {
                adapter: adapter_name(&info),
                features: format!("{missing:?}"),
            });
        }
        // Everything the adapter offers: the largest buffers and dispatches it allows.
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some(opts.label),
            required_features: opts.features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(Self {
            device,
            queue,
            info,
            limits,
            adapter,
        })
    }

    /// Refuses, before anything is drawn, render-target formats the adapter cannot render to
    /// (GL adapters such as llvmpipe cannot render to `Rgba32Float`), naming the adapter,
    /// the formats and `what` needs them.
    pub fn check_render_formats(
        &self,
        formats: &[wgpu::TextureFormat],
        what: &str,
    ) -> Result<(), GpuError> {
        let missing: Vec<String> = formats
            .iter()
            .filter(|f| {
                !self
                    .adapter
                    .get_texture_format_features(**f)
                    .allowed_usages
                    .contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
            })
            .map(|f| format!("{f:?}"))
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(GpuError::MissingFeatures {
            adapter: adapter_name(&self.info),
            features: format!(
                "render targets of {} ({what}); use --backend cpu",
                missing.join(" and ")
            ),
        })
    }

    /// What the adapter [`Gpu::new`] would open says about itself, without creating a
    /// device.
    pub fn adapter(opts: &GpuOptions) -> Result<wgpu::AdapterInfo, GpuError> {
        Ok(Self::request_adapter(opts)?.get_info())
    }

    fn request_adapter(opts: &GpuOptions) -> Result<wgpu::Adapter, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = opts.backends;
        let instance = wgpu::Instance::new(desc);
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: opts.power,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))
    }

    /// True for a software adapter (lavapipe, llvmpipe): one that runs on the CPU.
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// What the adapter says about itself.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// The device's limits (the adapter's, all requested).
    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    /// One line naming the adapter, its backend and driver, e.g.
    /// `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, llvmpipe Mesa 22.3.6)`.
    pub fn describe(&self) -> String {
        adapter_name(&self.info)
    }

    /// The largest storage buffer a kernel may bind, in bytes.
    pub fn max_storage_bytes(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// A buffer holding `data`, with `usage` plus `COPY_SRC` and `COPY_DST`. Empty data
    /// gets a 4-byte buffer (bindings cannot be empty).
    pub fn upload<T: bytemuck::Pod>(
        &self,
        label: &str,
        data: &[T],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = (bytes.len() as u64).max(4).next_multiple_of(4);
        let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: usage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        self.write(&buf, 0, bytes);
        buf
    }

    /// An uninitialized (zeroed by wgpu) buffer of `size` bytes (rounded up to a multiple of
    /// 4, at least 4) with `usage` plus `COPY_SRC` and `COPY_DST`.
    pub fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4).next_multiple_of(4),
            usage: usage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// Writes `bytes` into `buffer` at `offset` (queued; takes effect before the next
    /// submission). Lengths that are not a multiple of 4 are padded with zeros.
    pub fn write(&self, buffer: &wgpu::Buffer, offset: u64, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        if bytes.len().is_multiple_of(4) {
            self.queue.write_buffer(buffer, offset, bytes);
        } else {
            let mut padded = bytes.to_vec();
            padded.resize(bytes.len().next_multiple_of(4), 0);
            self.queue.write_buffer(buffer, offset, &padded);
        }
    }

    /// Fills `buffer` with the 32-bit word `word`, `words` of them from the start (a kernel's
    /// "clear to +infinity").
    pub fn fill_u32(&self, buffer: &wgpu::Buffer, word: u32, words: usize) {
        let v = vec![word; words];
        self.write(buffer, 0, bytemuck::cast_slice(&v));
    }

    /// Copies `len` elements of `T` from `buffer` (starting `offset` bytes in) back to the
    /// host: a staging copy, a map, and a blocking wait. Reports any error wgpu raised in the
    /// meantime.
    pub fn read_buffer<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        offset: u64,
        len: usize,
    ) -> Result<Vec<T>, GpuError> {
        let bytes = (len * size_of::<T>()) as u64;
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let padded = bytes.next_multiple_of(4);
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("isokit read-back"),
            size: padded,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("isokit read-back"),
            });
        enc.copy_buffer_to_buffer(buffer, offset, &staging, 0, padded);
        self.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Wgpu(e.to_string()));
        }
        let (tx, rx) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|_| GpuError::Map("the map callback never ran".into()))?
            .map_err(|e| GpuError::Map(e.to_string()))?;
        let out = {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| GpuError::Map(e.to_string()))?;
            bytemuck::pod_collect_to_vec(&view[..bytes as usize])
        };
        staging.unmap();
        Ok(out)
    }

    /// Blocks until all submitted work has finished.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Wgpu(e.to_string()))
    }

    /// A compute pipeline from WGSL `source` (entry point `entry`), with the layout deduced
    /// from the shader. Shader compilation and pipeline errors are returned, not raised.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Shader {
                label: label.to_string(),
                message: e.to_string(),
            }),
            None => Ok(pipeline),
        }
    }

    /// A bind group for group 0 of `pipeline`, binding `buffers[i]` whole at binding `i`.
    pub fn bind_buffers(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let layout = pipeline.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &layout,
            entries: &entries,
        })
    }

    /// Runs `pipeline` with `bind_group` as group 0 over `groups` workgroups (x, y, z) and
    /// submits it; errors raised by wgpu during recording or submission are returned. Does
    /// not wait for the GPU (a later [`Gpu::read_buffer`] does).
    pub fn dispatch(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        bind_group: &wgpu::BindGroup,
        groups: [u32; 3],
    ) -> Result<(), GpuError> {
        let max = self.limits.max_compute_workgroups_per_dimension;
        if groups.iter().any(|&g| g > max) {
            return Err(GpuError::TooLarge(format!(
                "{label}: {groups:?} workgroups exceed the device limit of {max} per dimension"
            )));
        }
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        }
        self.queue.submit([enc.finish()]);
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Wgpu(e.to_string())),
            None => Ok(()),
        }
    }
}

fn adapter_name(info: &wgpu::AdapterInfo) -> String {
    let driver = [info.driver.as_str(), info.driver_info.as_str()]
        .iter()
        .filter(|s| !s.is_empty())
        .copied()
        .collect::<Vec<_>>()
        .join(" ");
    format!(
        "{} ({:?}, {:?}{}{})",
        info.name,
        info.backend,
        info.device_type,
        if driver.is_empty() { "" } else { ", " },
        driver
    )
}

/// Whether any adapter with compute shaders can be opened with the default options (opens
/// one to find out; cheap enough for a command's start-up, not for a loop).
pub fn adapter_available() -> Result<(), GpuError> {
    Gpu::new(&GpuOptions::default()).map(|_| ())
}

#[cfg(test)]
mod tests {
    #[test]
    #[cfg(target_os = "linux")]
    fn a_device_folder_without_gpu_nodes_rules_hardware_out() {
        let root = std::env::temp_dir().join(format!("isokit-gpu-dev-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(root.join("dri")).unwrap();
        std::fs::write(root.join("null"), b"").unwrap();
        assert!(!super::hardware_gpu_possible(&root));
        std::fs::write(root.join("dri/renderD128"), b"").unwrap();
        assert!(super::hardware_gpu_possible(&root));
        std::fs::remove_file(root.join("dri/renderD128")).unwrap();
        std::fs::write(root.join("nvidia0"), b"").unwrap();
        assert!(super::hardware_gpu_possible(&root));
        // An unreadable folder leaves the decision to the adapters.
        assert!(super::hardware_gpu_possible(&root.join("missing")));
        std::fs::remove_dir_all(&root).unwrap();
    }

    use super::*;

    #[test]
    fn backend_choice_parses() {
        assert_eq!(BackendChoice::parse("GPU").unwrap(), BackendChoice::Gpu);
        assert_eq!(BackendChoice::parse("cpu").unwrap(), BackendChoice::Cpu);
        assert_eq!(BackendChoice::parse("auto").unwrap(), BackendChoice::Auto);
        assert!(matches!(
            BackendChoice::parse("tpu"),
            Err(GpuError::BadBackend(_))
        ));
        assert_eq!(BackendChoice::Cpu.or_env().unwrap(), BackendChoice::Cpu);
    }

    #[test]
    fn upload_and_read_back_round_trip() {
        let Some(gpu) = testing::gpu_or_skip("upload_and_read_back_round_trip") else {
            return;
        };
        let data: Vec<u32> = (0..1000u32).map(|i| i.wrapping_mul(2654435761)).collect();
        let buf = gpu.upload("test", &data, wgpu::BufferUsages::STORAGE);
        assert_eq!(gpu.read_buffer::<u32>(&buf, 0, data.len()).unwrap(), data);
        // A sub-range from an offset.
        assert_eq!(gpu.read_buffer::<u32>(&buf, 40, 5).unwrap(), data[10..15]);
        // Odd byte counts are padded on the way up and trimmed on the way back.
        let bytes = [1u8, 2, 3, 4, 5];
        let b2 = gpu.upload("odd", &bytes, wgpu::BufferUsages::STORAGE);
        assert_eq!(gpu.read_buffer::<u8>(&b2, 0, 5).unwrap(), bytes);
        assert!(!gpu.describe().is_empty());
    }

    #[test]
    fn kernel_runs_and_bad_shader_is_an_error() {
        let Some(gpu) = testing::gpu_or_skip("kernel_runs_and_bad_shader_is_an_error") else {
            return;
        };
        let src = "@group(0) @binding(0) var<storage, read_write> v: array<u32>;\n\
                   @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n\
                   if (id.x < arrayLength(&v)) { v[id.x] = v[id.x] * 3u + 1u; } }";
        validate_wgsl("inline", src).unwrap();
        let p = gpu.compute_pipeline("triple", src, "main").unwrap();
        let data: Vec<u32> = (0..200).collect();
        let buf = gpu.upload("v", &data, wgpu::BufferUsages::STORAGE);
        let bg = gpu.bind_buffers("v", &p, &[&buf]);
        gpu.dispatch("triple", &p, &bg, [4, 1, 1]).unwrap();
        let out = gpu.read_buffer::<u32>(&buf, 0, 200).unwrap();
        assert!(out.iter().zip(&data).all(|(o, d)| *o == d * 3 + 1));
        let err = gpu.compute_pipeline("broken", "fn main( {", "main");
        assert!(matches!(err, Err(GpuError::Shader { .. })), "{err:?}");
        assert!(matches!(
            gpu.dispatch("huge", &p, &bg, [u32::MAX, 1, 1]),
            Err(GpuError::TooLarge(_))
        ));
    }
}
