//! The host side of the GPU ray caster: buffers, the pass loop, read-back (the twin of
//! `trace_frame` in `render.rs`).

use super::{GpuPixel, GpuRenderer, Resident, scoped};
use crate::gpu::dispatch_grid;
use crate::kernel::{GSample, Uniforms};
use crate::render::{Prefetch, frame_stats, load_requested, prefetch};
use crate::{CachePolicy, Frame, GBuffer, RenderError, Volume};
use bytemuck::{Pod, Zeroable};
use isokit_field::Camera;
use isokit_gpu::{Gpu, wgpu};
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

/// Size of `RayState` in `raycast.wgsl` (cell, t, first flag, samples, padding).
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
            bytemuck::cast_slice(&super::gpu_ranges(trace_ranges)),
        );
        res.ranges_modified = pre.ranges.is_some();
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
