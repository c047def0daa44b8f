//! `isokit bench render`: warm frames of the CPU ray caster on generated fields
//! (`isokit_scene::bench::render_bench`).

use anyhow::{Result, anyhow};
use isokit_scene::bench::{RenderBenchOptions, RenderBenchRow, render_bench};
use serde_json::json;

/// Arguments of `isokit bench render`.
#[derive(clap::Args, Debug)]
pub struct RenderBenchArgs {
    /// Image width in pixels (and height, unless --height is given).
    #[arg(long, default_value_t = RenderBenchOptions::default().size)]
    pub size: u32,
    /// Image height in pixels [default: --size].
    #[arg(long)]
    pub height: Option<u32>,
    /// Trace and shade on the GPU twin (an error without an adapter).
    #[arg(long)]
    pub gpu: bool,
    /// Samples along the longest side of each field.
    #[arg(long, default_value_t = RenderBenchOptions::default().res)]
    pub res: usize,
    /// Warm frames per row (new cameras of a small orbit); the median counts.
    #[arg(long, default_value_t = RenderBenchOptions::default().frames)]
    pub frames: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

fn row_json(r: &RenderBenchRow) -> serde_json::Value {
    json!({
        "scene": r.scene,
        "mode": r.mode,
        "frame_ms": r.frame_ms,
        "trace_ms": r.trace_ms,
        "shade_ms": r.shade_ms,
        "first_frame_ms": r.first_frame_ms,
        "samples_per_ray": r.samples_per_ray,
        "mask_pixels": r.mask_pixels,
        "mean_dz_voxels": r.mean_dz_voxels,
        "max_dz_voxels": r.max_dz_voxels,
    })
}

/// Runs `isokit bench render`.
pub fn bench(a: RenderBenchArgs) -> Result<()> {
    let o = RenderBenchOptions {
        size: a.size,
        height: a.height,
        gpu: a.gpu,
        res: a.res,
        frames: a.frames,
    };
    if !a.json {
        println!(
            "{}x{} pixels, {} samples along the longest side, {} threads; reference: fixed-rate r0 = 8, n = 8, 16 secant steps",
            o.size,
            o.height.unwrap_or(o.size),
            o.res,
            rayon::current_num_threads()
        );
        println!(
            "{:<16} {:<10} {:>9} {:>9} {:>9} {:>10} {:>11} {:>5} {:>10}",
            "scene",
            "mode",
            "frame ms",
            "trace ms",
            "shade ms",
            "first ms",
            "samples/ray",
            "mask",
            "mean |dZ|"
        );
    }
    let quiet = a.json;
    let b = render_bench(&o, |r| {
        if !quiet {
            println!(
                "{:<16} {:<10} {:>9.1} {:>9.1} {:>9.1} {:>10.1} {:>11.2} {:>5} {:>10.2e}",
                r.scene,
                r.mode,
                r.frame_ms,
                r.trace_ms,
                r.shade_ms,
                r.first_frame_ms,
                r.samples_per_ray,
                r.mask_pixels,
                r.mean_dz_voxels
            );
        }
    })
    .map_err(|e| anyhow!(e))?;
    if a.json {
        let v = json!({
            "width": o.size,
            "height": o.height.unwrap_or(o.size),
            "device": b.device,
            "software": b.software,
            "res": o.res,
            "frames": o.frames,
            "threads": b.threads,
            "scenes": b.scenes,
            "frame_ms": b.frame_ms,
            "setup_seconds": b.setup_seconds,
            "rows": b.rows.iter().map(row_json).collect::<Vec<_>>(),
        });
        println!("{v}");
    }
    Ok(())
}
