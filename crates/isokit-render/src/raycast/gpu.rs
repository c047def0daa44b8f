//! The host code of `shaders/raycast.wgsl` (with `shaders/raycast_common.wgsl` and
//! `shaders/common/curvature.wgsl`): the program's assembly, the G-buffer pixel and pass
//! parameters as the kernel reads them, the brick cache on the GPU, and the pass loop with
//! its read-back (the twin of `trace_frame` in `raycast/render.rs`). The CPU twin of the
//! kernel is `raycast/cpu.rs` ([`crate::kernel`]); the public side is [`crate::gpu`].

use super::render::{Prefetch, frame_stats, load_requested, prefetch};
use crate::gpu::{GpuRenderer, check_fits, constants, dispatch_grid, scoped};
use crate::kernel::{GSample, Uniforms};
use crate::{
    BrickCache, CachePolicy, CacheStats, Frame, GBuffer, MultiView, RenderError, RenderOptions,
    Volume,
};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use isokit_field::Camera;
use isokit_gpu::{Gpu, GpuError, ShaderSource, wgpu};
use isokit_shaders::common::{BSPLINE, CURVATURE};
use isokit_shaders::{RAYCAST, RAYCAST_COMMON};
use rayon::prelude::*;
use std::time::Instant;

/// `Params` in `raycast.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct Params {
    count: u32,
    stride: u32,
    fresh: u32,
    src: u32,
    dst: u32,
    ray_base: u32,
    requests: u32,
    used: u32,
}

isokit_gpu::wgsl_layout!(Params {
    count: "u32",
    stride: "u32",
    fresh: "u32",
    src: "u32",
    dst: "u32",
    ray_base: "u32",
    requests: "u32",
    used: "u32",
});

/// Size of `RayState` in `raycast.wgsl` (cell, t, first flag, samples, carried bound, padding).
pub(crate) const RAY_STATE_BYTES: usize = 32;

/// Bricks copied to the GPU per staging batch.
const UPLOAD_BATCH: usize = 32;

/// Copies the bricks `loaded` (`(slot, brick)` pairs) of `volume` into their slots of the
/// GPU pool, and the reference index after them.
fn upload_bricks(gpu: &Gpu, res: &Resident, volume: &Volume, loaded: &[(usize, usize)]) {
    let bs = res.brick_samples;
    for batch in loaded.chunks(UPLOAD_BATCH) {
        let mut staging = vec![0.0f32; batch.len() * bs];
        staging
            .par_chunks_mut(bs)
            .zip(batch.par_iter())
            .for_each(|(out, &(_, n))| volume.fill_brick(n, out));
        for (out, &(slot, _)) in staging.chunks(bs).zip(batch) {
            let offset = (slot * bs * size_of::<f32>()) as u64;
            gpu.write(&res.pool, offset, bytemuck::cast_slice(out));
        }
    }
    if !loaded.is_empty() {
        gpu.write(
            &res.reference,
            0,
            bytemuck::cast_slice(res.cache.reference()),
        );
    }
}

/// Traces every ray `u` describes on the GPU.
pub(crate) fn trace_frame(
    r: &mut GpuRenderer,
    volume: &Volume,
    camera: &Camera,
    u: Uniforms,
    policy: CachePolicy,
) -> Result<Frame, RenderError> {
    let t0 = Instant::now();
    let chunk_max = r.max_rays_per_dispatch();
    r.bind(volume)?;
    // Disjoint borrows: the device and kernel stay shared while the cache changes.
    let GpuRenderer {
        gpu,
        trace: pipeline,
        resident,
        ..
    } = r;
    let res = resident
        .as_mut()
        .unwrap_or_else(|| unreachable!("bound above"));
    let before = res.cache.stats();
    let total = u.width as usize * u.subpixels as usize * u.height as usize;
    let n_bricks = volume.brick_count();
    let ranges = volume.trace_ranges(u.iso, u.inside_sign);
    let pool = &res.pool;
    let pre: Prefetch = prefetch(
        volume,
        &ranges,
        &mut res.cache,
        camera,
        &u,
        policy,
        |offset, samples| {
            gpu.write(
                pool,
                (offset * size_of::<f32>()) as u64,
                bytemuck::cast_slice(samples),
            )
        },
    );
    if volume.combine().is_some() || pre.ranges.is_some() || res.ranges_modified {
        // The combined ranges depend on ρ and the inside sign, a downsampled assignment's
        // on what it stores: sent with every frame (and the volume's own restored after).
        let trace_ranges: &[[f32; 2]] = pre.ranges.as_deref().unwrap_or(&ranges);
        gpu.write(
            &res.block_range,
            0,
            bytemuck::cast_slice(&gpu_ranges(trace_ranges)),
        );
        res.ranges_modified = pre.ranges.is_some();
    }
    {
        // Slope bounds and skip distances, sent when they change (the cache keeps them).
        let ranges_now: &[[f32; 2]] = pre.ranges.as_deref().unwrap_or(&ranges);
        let (info, changed) = res.cache.block_info(volume, ranges_now, &u);
        if changed || !res.block_info_valid {
            gpu.write(
                &res.block_info,
                0,
                bytemuck::cast_slice(&gpu_block_info(info)),
            );
            res.block_info_valid = true;
        }
    }
    if pre.reference_changed && pre.loaded.is_empty() {
        gpu.write(
            &res.reference,
            0,
            bytemuck::cast_slice(res.cache.reference()),
        );
    }
    upload_bricks(gpu, res, volume, &pre.loaded);

    let chunk = total.min(chunk_max);
    let storage = wgpu::BufferUsages::STORAGE;
    let n_counters = 1 + 2 * n_bricks;
    let pbuf_size = size_of::<Params>() as u64;
    // The uniforms, lists and states are only read through the bind group.
    let (_ubuf, pbuf, counters, _lists, _states, gbuf, bind) =
        scoped(gpu, "allocating the ray buffers", || {
            let ubuf = gpu.upload("raycast uniforms", &[u], wgpu::BufferUsages::UNIFORM);
            let pbuf = gpu.buffer("raycast params", pbuf_size, wgpu::BufferUsages::UNIFORM);
            let counters = gpu.buffer("raycast counters", 4 * n_counters as u64, storage);
            let lists = gpu.buffer("raycast lists", 8 * chunk as u64, storage);
            let states = gpu.buffer(
                "raycast ray states",
                (RAY_STATE_BYTES * chunk) as u64,
                storage,
            );
            let gbuf = gpu.buffer(
                "raycast g-buffer",
                (size_of::<GpuPixel>() * chunk) as u64,
                storage,
            );
            let bind = gpu.bind_buffers(
                "raycast",
                pipeline,
                &[
                    &ubuf,
                    &pbuf,
                    &res.pool,
                    &res.reference,
                    &res.block_range,
                    &counters,
                    &lists,
                    &states,
                    &gbuf,
                    &res.block_info,
                ],
            );
            (ubuf, pbuf, counters, lists, states, gbuf, bind)
        })?;
    let mut pixels = vec![GSample::default(); total];
    let mut samples = vec![0u32; total];
    let mut passes = 0u32;
    let zeros = vec![0u32; n_counters];
    for base in (0..total).step_by(chunk) {
        let len = chunk.min(total - base);
        let (mut src, mut dst) = (0u32, chunk as u32);
        let mut count = len;
        let mut fresh = true;
        loop {
            passes += 1;
            gpu.write(&counters, 0, bytemuck::cast_slice(&zeros));
            let (groups, stride) = dispatch_grid(gpu, count);
            let params = Params {
                count: count as u32,
                stride,
                fresh: u32::from(fresh),
                src,
                dst,
                ray_base: base as u32,
                requests: 1,
                used: 1 + n_bricks as u32,
            };
            gpu.write(&pbuf, 0, bytemuck::bytes_of(&params));
            gpu.dispatch("raycast", pipeline, &bind, groups)?;
            let back: Vec<u32> = gpu.read_buffer(&counters, 0, n_counters)?;
            for (n, &flag) in back[1 + n_bricks..].iter().enumerate() {
                if flag != 0 {
                    res.cache.touch(n);
                }
            }
            let waiting = back[0] as usize;
            if waiting == 0 {
                break;
            }
            let loaded = load_requested(
                volume,
                &mut res.cache,
                back[1..1 + n_bricks].iter().copied(),
            )?;
            upload_bricks(gpu, res, volume, &loaded);
            count = waiting;
            fresh = false;
            std::mem::swap(&mut src, &mut dst);
        }
        let out: Vec<GpuPixel> = gpu.read_buffer(&gbuf, 0, len)?;
        for (i, p) in out.iter().enumerate() {
            pixels[base + i] = p.sample();
            samples[base + i] = p.samples();
        }
    }
    let stats = frame_stats(
        volume,
        &u,
        &pixels,
        &samples,
        &pre,
        before,
        res.cache.stats(),
        passes,
        t0.elapsed().as_secs_f64(),
    );
    let w = u.width * u.subpixels;
    Ok(Frame {
        gbuffer: GBuffer::new(w, u.height, pixels, samples),
        stats,
        uniforms: u,
    })
}

/// The trace kernel's WGSL, assembled: constants from Rust, `raycast_common.wgsl`,
/// `common/curvature.wgsl`, `raycast.wgsl` (entry point `trace`).
pub fn raycast_shader() -> ShaderSource {
    constants("raycast")
        .piece(RAYCAST_COMMON)
        .piece(CURVATURE)
        .piece(BSPLINE)
        .piece(RAYCAST)
}

/// One G-buffer pixel as the kernels store it (`GPixel` in `raycast_common.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub(crate) struct GpuPixel {
    position: [f32; 3],
    depth: f32,
    normal: [f32; 3],
    hit: f32,
    k1: f32,
    k2: f32,
    id: u32,
    samples: u32,
    dir1: [f32; 3],
    pad: f32,
}

isokit_gpu::wgsl_layout!(GpuPixel as "GPixel" {
    position: "vec3<f32>",
    depth: "f32",
    normal: "vec3<f32>",
    hit: "f32",
    k1: "f32",
    k2: "f32",
    id: "u32",
    samples: "u32",
    dir1: "vec3<f32>",
    pad: "f32",
});

impl GpuPixel {
    pub(crate) fn from_sample(s: &GSample) -> Self {
        Self {
            position: s.position.to_array(),
            depth: s.depth,
            normal: s.normal.to_array(),
            hit: if s.is_hit() { 1.0 } else { 0.0 },
            k1: s.k1,
            k2: s.k2,
            id: s.id,
            samples: 0,
            dir1: s.dir1.to_array(),
            pad: 0.0,
        }
    }

    pub(crate) fn sample(&self) -> GSample {
        GSample {
            position: Vec3::from_array(self.position),
            depth: self.depth,
            normal: Vec3::from_array(self.normal),
            k1: self.k1,
            k2: self.k2,
            dir1: Vec3::from_array(self.dir1),
            id: self.id,
        }
    }

    pub(crate) fn samples(&self) -> u32 {
        self.samples
    }
}

/// The brick cache of the bound volume, on the GPU: the bookkeeping on the host (slots,
/// reference index, LRU), the samples only in the GPU's pool.
#[derive(Debug)]
pub(crate) struct Resident {
    pub(crate) volume_id: u64,
    pub(crate) cache: BrickCache,
    pub(crate) pool: wgpu::Buffer,
    pub(crate) reference: wgpu::Buffer,
    pub(crate) block_range: wgpu::Buffer,
    pub(crate) brick_samples: usize,
    /// True while `block_range` holds a downsampled assignment's ranges instead of the
    /// volume's own (restored by the next frame that does not use them).
    pub(crate) ranges_modified: bool,
    /// Per block: slope bounds and skip distance ([`crate::kernel::TraceData::block_info`]).
    pub(crate) block_info: wgpu::Buffer,
    /// True once `block_info` holds what the cache computed last.
    pub(crate) block_info_valid: bool,
}

impl GpuRenderer {
    /// Limits the brick cache to `bricks` slots (at least 1); drops the bricks held. A cache
    /// smaller than the active bricks renders the same image in several passes.
    pub fn set_cache_bricks(&mut self, bricks: usize) -> Result<(), RenderError> {
        if bricks == 0 {
            return Err(RenderError::bad(
                "cache capacity",
                bricks,
                "must hold at least one brick",
            ));
        }
        self.cache_bricks = Some(bricks);
        self.resident = None;
        Ok(())
    }

    /// Limits the brick cache to `bytes` of samples (at least one brick); drops the bricks
    /// held.
    pub fn set_cache_bytes(&mut self, bytes: usize) {
        self.cache_bricks = None;
        self.cache_bytes = bytes;
        self.resident = None;
    }

    /// Counters of the brick cache of the volume last rendered (`None` before the first
    /// frame).
    pub fn cache_stats(&self) -> Option<CacheStats> {
        self.resident.as_ref().map(|r| r.cache.stats())
    }

    /// Slots of the brick cache of the volume last rendered (`None` before the first frame).
    pub fn cache_capacity(&self) -> Option<usize> {
        self.resident.as_ref().map(|r| r.cache.capacity())
    }

    /// Ray casts `volume` from `camera` into a G-buffer: the GPU twin of [`crate::render`].
    pub fn render(
        &mut self,
        volume: &Volume,
        camera: &Camera,
        opts: &RenderOptions,
    ) -> Result<Frame, RenderError> {
        let u = crate::uniforms(volume, camera, opts)?;
        trace_frame(self, volume, camera, u, opts.cache_policy)
    }

    /// The geometric pass for a multi-view display: the GPU twin of
    /// [`crate::render_multiview`].
    pub fn render_multiview(
        &mut self,
        volume: &Volume,
        camera: &Camera,
        opts: &RenderOptions,
        mv: &MultiView,
    ) -> Result<Frame, RenderError> {
        let u = mv.uniforms(volume, camera, opts, None)?;
        trace_frame(self, volume, camera, u, opts.cache_policy)
    }

    /// One view of a multi-view display rendered alone: the GPU twin of
    /// [`crate::render_view`].
    pub fn render_view(
        &mut self,
        volume: &Volume,
        camera: &Camera,
        opts: &RenderOptions,
        mv: &MultiView,
        view: u32,
    ) -> Result<Frame, RenderError> {
        let u = mv.uniforms(volume, camera, opts, Some(view))?;
        trace_frame(self, volume, camera, u, opts.cache_policy)
    }

    /// Makes the brick cache for `volume` (and allocates its buffers) when the volume
    /// changed.
    fn bind(&mut self, volume: &Volume) -> Result<(), RenderError> {
        if self
            .resident
            .as_ref()
            .is_none_or(|r| r.volume_id != volume.id())
        {
            self.resident = None;
            let brick_samples = volume.slot_samples();
            let brick_bytes = (brick_samples * size_of::<f32>()) as u64;
            let limit = self.gpu.max_storage_bytes();
            let fit = (limit / brick_bytes) as usize;
            if fit == 0 {
                return Err(GpuError::TooLarge(format!(
                    "a brick of {brick_bytes} bytes exceeds the device's largest storage buffer ({limit} bytes); use smaller bricks"
                ))
                .into());
            }
            let asked = self
                .cache_bricks
                .unwrap_or(self.cache_bytes / brick_bytes as usize)
                .max(1);
            let capacity = asked.min(fit).min(volume.brick_count());
            let cache = BrickCache::bookkeeping(volume, capacity)?;
            let ranges = gpu_ranges(volume.block_ranges());
            check_fits(
                &self.gpu,
                "the block ranges",
                std::mem::size_of_val(ranges.as_slice()) as u64,
            )?;
            // The counters of a pass: one, then two per brick.
            check_fits(
                &self.gpu,
                "the brick counters",
                4 * (1 + 2 * volume.brick_count() as u64),
            )?;
            let storage = wgpu::BufferUsages::STORAGE;
            let gpu = &self.gpu;
            let info_bytes = 16 * volume.block_ranges().len() as u64;
            check_fits(&self.gpu, "the block slopes and distances", info_bytes)?;
            let (pool, reference, block_range, block_info) =
                scoped(gpu, "allocating the brick cache", || {
                    (
                        gpu.buffer("brick pool", capacity as u64 * brick_bytes, storage),
                        gpu.upload("brick reference", cache.reference(), storage),
                        gpu.upload("block ranges", &ranges, storage),
                        gpu.buffer("block slopes and distances", info_bytes, storage),
                    )
                })?;
            self.resident = Some(Resident {
                volume_id: volume.id(),
                cache,
                pool,
                reference,
                block_range,
                brick_samples,
                ranges_modified: false,
                block_info,
                block_info_valid: false,
            });
        }
        Ok(())
    }
}

/// Slope bounds and skip distances as the kernel reads them: infinite slopes (a block
/// with a non-finite sample) as `f32::MAX`, which WGSL can hold.
pub(crate) fn gpu_block_info(info: &[[f32; 4]]) -> Vec<[f32; 4]> {
    info.iter()
        .map(|i| i.map(|v| if v.is_finite() { v } else { f32::MAX }))
        .collect()
}

/// Block ranges as the kernel reads them: `[f32::MAX, −f32::MAX]` for a block without
/// finite samples.
pub(crate) fn gpu_ranges(ranges: &[[f32; 2]]) -> Vec<[f32; 2]> {
    ranges
        .iter()
        .map(|r| {
            if r[0] <= r[1] {
                *r
            } else {
                [f32::MAX, -f32::MAX]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::ID_SURFACE;
    use glam::Vec3;

    #[test]
    fn uniforms_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<Uniforms>();
    }

    #[test]
    fn pixel_matches_its_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<GpuPixel>();
    }

    #[test]
    fn params_match_their_wgsl_twin_member_by_member() {
        crate::gpu::check_layout_everywhere::<Params>();
    }

    #[test]
    fn pixels_round_trip() {
        let s = GSample {
            position: Vec3::new(1.0, 2.0, 3.0),
            depth: 4.0,
            normal: Vec3::Y,
            k1: 0.5,
            k2: -0.25,
            dir1: Vec3::X,
            id: ID_SURFACE,
        };
        assert_eq!(GpuPixel::from_sample(&s).sample(), s);
        let px = GpuPixel::from_sample(&s);
        let bytes: &[u8] = bytemuck::bytes_of(&px);
        // (P.xyz, Z), (N.xyz, A), (K1, K2, id, samples), (dir1.xyz, 0).
        let f = |i: usize| f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap());
        assert_eq!([f(3), f(7), f(8), f(9)], [4.0, 1.0, 0.5, -0.25]);
    }
}
