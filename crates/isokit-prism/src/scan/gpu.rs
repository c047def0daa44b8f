//! The GPU path: compute scan conversion of slabs with wgpu, the host code of
//! `shaders/prism_scan.wgsl` (with `shaders/common/prism.wgsl`); the CPU twin is
//! `scan/cpu.rs` ([`crate::scan::scan_slab`]).
//!
//! ## Why compute, not the render pipeline
//! 002 Sec. 4.2.4 rasterizes each prism's slice polygon with the depth test keeping the
//! smallest `|d|`. Here a compute kernel walks each prism's rows and keeps the smallest
//! packed key `(|d| bits << 1) | sign` with `atomicMin`:
//! - **Order-independent and bit-comparable with the CPU twin.** The key makes ties
//!   deterministic (smaller `|d|`, then the positive value) whatever order the GPU runs the
//!   prisms in; a depth test keeps the first of equal depths in draw order, and writes depth
//!   normalized to `[0, 1]` (a 24-bit or 32-bit float depth of `|d| / d_max`), so equal
//!   distances are no longer equal and the sign of ties depends on submission order.
//! - **No per-slice geometry.** The paper's bottleneck was sending every prism's polygon
//!   for every slice (one draw per slice, 256–512 render passes). The kernel reads the
//!   prisms once and does one dispatch per slab of many slices; the slice polygon is the
//!   row span computed from the five planes, in the kernel.
//! - **Plain buffers.** The result is a `u32` storage buffer, read back without render-target
//!   formats, 256-byte row padding or the R32Float-blending limits of the GL backend, and the
//!   same code runs on Vulkan (lavapipe in CI) and GLES 3.1 (llvmpipe).
//!
//! The cost: no rasterizer hardware, and threads of a workgroup share one prism's rows, so a
//! small prism leaves threads idle. On lavapipe (a CPU) neither matters; on a real GPU, a
//! sorted work list of (prism, row-block) items is the next step if profiling asks for it.

use crate::placed::GpuPrism;
use crate::scan::UNWRITTEN;
use bytemuck::{Pod, Zeroable};
use isokit_gpu::{Gpu, GpuError, ShaderSource, wgpu};

/// Threads per workgroup (prepended to the WGSL as `WORKGROUP`).
pub const WORKGROUP: u32 = 64;

/// The scan kernel's WGSL, assembled: constants from Rust, `common/prism.wgsl`, the kernel.
pub fn scan_shader() -> ShaderSource {
    ShaderSource::new("prism_scan")
        .constant_u32("WORKGROUP", WORKGROUP)
        .piece(isokit_shaders::common::PRISM)
        .piece(isokit_shaders::PRISM_SCAN)
}

/// `Params` in `prism_scan.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Params {
    slab: [i32; 4],
    counts: [u32; 4],
}

isokit_gpu::wgsl_layout!(Params {
    slab: "vec4<i32>",
    counts: "vec4<u32>",
});

/// A GPU ready to scan prisms: the device and the compiled kernel.
#[derive(Debug)]
pub struct PrismGpu {
    gpu: Gpu,
    pipeline: wgpu::ComputePipeline,
}

impl PrismGpu {
    /// Compiles the kernel on `gpu`.
    pub fn new(gpu: Gpu) -> Result<Self, GpuError> {
        let src = scan_shader();
        let pipeline = gpu.compute_pipeline(src.label(), src.text(), "scan")?;
        Ok(Self { gpu, pipeline })
    }

    /// Opens the default device ([`isokit_gpu::GpuOptions::default`]) and compiles the
    /// kernel.
    pub fn open() -> Result<Self, GpuError> {
        Self::new(Gpu::new(&isokit_gpu::GpuOptions::default())?)
    }

    /// Resolves a backend request by the one policy of [`isokit_gpu::choose_backend`] and
    /// compiles the kernel on the device it opens. `None` means the CPU twin, with the reason
    /// when `auto` passed over the GPU (callers tell the user).
    pub fn choose(
        choice: isokit_gpu::BackendChoice,
    ) -> Result<(Option<Self>, Option<String>), GpuError> {
        let chosen = isokit_gpu::choose_backend(choice, &isokit_gpu::GpuOptions::default())?;
        Ok((chosen.gpu.map(Self::new).transpose()?, chosen.reason))
    }

    /// The device.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// The prisms uploaded once per grid.
    pub(crate) fn upload(&self, prisms: &[GpuPrism]) -> Result<wgpu::Buffer, GpuError> {
        let bytes = std::mem::size_of_val(prisms) as u64;
        if bytes > self.gpu.max_storage_bytes() {
            return Err(GpuError::TooLarge(format!(
                "{} prisms take {bytes} bytes, more than the device's {} per buffer",
                prisms.len(),
                self.gpu.max_storage_bytes()
            )));
        }
        Ok(self
            .gpu
            .upload("prisms", prisms, wgpu::BufferUsages::STORAGE))
    }

    /// The largest number of slices of `nx × ny` keys one slab may hold on this device
    /// (capped at 256 MiB of keys).
    pub fn max_slab_slices(&self, nx: usize, ny: usize) -> usize {
        let per = (nx * ny * 4) as u64;
        let cap = self.gpu.max_storage_bytes().min(256 << 20);
        ((cap / per.max(1)) as usize).max(1)
    }

    /// Scans slices `k0..=k1` with the prisms `active` and writes the keys into `out`
    /// (`nx × ny × (k1 − k0 + 1)` of them).
    #[expect(
        clippy::too_many_arguments,
        reason = "a slab's geometry and its buffers"
    )]
    pub(crate) fn scan_slab(
        &self,
        prisms: &wgpu::Buffer,
        active: &[u32],
        slab: (i32, i32),
        nx: usize,
        ny: usize,
        signed: bool,
        out: &mut [u32],
    ) -> Result<(), GpuError> {
        if active.is_empty() {
            out.fill(UNWRITTEN);
            return Ok(());
        }
        let n = out.len();
        let keys = self
            .gpu
            .buffer("prism keys", (n * 4) as u64, wgpu::BufferUsages::STORAGE);
        self.gpu.fill_u32(&keys, UNWRITTEN, n);
        let act = self
            .gpu
            .upload("active prisms", active, wgpu::BufferUsages::STORAGE);
        let max = self
            .gpu
            .limits()
            .max_compute_workgroups_per_dimension
            .max(1);
        let groups = active.len() as u32;
        let gx = groups.min(max);
        let gy = groups.div_ceil(gx);
        let params = Params {
            slab: [slab.0, slab.1, nx as i32, ny as i32],
            counts: [groups, u32::from(signed), gx, 0],
        };
        let pbuf = self
            .gpu
            .upload("prism params", &[params], wgpu::BufferUsages::UNIFORM);
        let bind =
            self.gpu
                .bind_buffers("prism scan", &self.pipeline, &[prisms, &act, &keys, &pbuf]);
        self.gpu
            .dispatch("prism scan", &self.pipeline, &bind, [gx, gy, 1])?;
        let back: Vec<u32> = self.gpu.read_buffer(&keys, 0, n)?;
        out.copy_from_slice(&back);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shader_validates_with_naga() {
        let src = scan_shader();
        src.validate().unwrap();
        // The common piece on its own, too (it is shared with future kernels).
        isokit_gpu::validate_wgsl("common/prism", isokit_shaders::common::PRISM).unwrap();
    }

    #[test]
    fn gpu_structs_match_their_rust_twins() {
        let src = scan_shader();
        assert_eq!(
            isokit_gpu::wgsl_struct_size(src.text(), "Prism"),
            Some(size_of::<GpuPrism>() as u32)
        );
        assert_eq!(
            isokit_gpu::wgsl_struct_size(src.text(), "Params"),
            Some(size_of::<Params>() as u32)
        );
    }

    #[test]
    fn gpu_structs_match_their_rust_twins_member_by_member() {
        let src = scan_shader();
        isokit_gpu::testing::assert_wgsl_layout::<GpuPrism>(&src);
        isokit_gpu::testing::assert_wgsl_layout::<Params>(&src);
        // Every file of the scan conversion is part of the program validated above.
        for (path, piece) in isokit_shaders::ALL {
            if path.contains("prism") {
                assert!(src.text().contains(piece), "{path}");
            }
        }
    }
}
