//! The isosurface of a distance field found two ways, on the same field and camera: the ray
//! caster (search and refinement, 002 Ch. 6) and pre-integrated volume rendering with an
//! opaque step at 0 in the transfer function (003 Sec. 4: the tabulated segment places the
//! surface between samples with no search). For each: the time of a frame and the depth's
//! error against the analytic sphere (for volume rendering, where the opacity passes 0.5,
//! less the ln 2 / σ that an exact step puts beyond the surface), in voxels.
//!
//! Run: `cargo bench -p isokit-render --bench dvr_surface`. Knobs: `ISOKIT_DS_RES` (samples
//! per side, default 256), `ISOKIT_DS_SIZE` (image side, default 512), `ISOKIT_DS_RUNS`
//! (best of, default 3). CPU twins only.

use glam::Vec3;
use isokit_field::primitives::Sphere;
use isokit_field::{Camera, Grid, Projection, sample_into};
use isokit_render::dvr::{
    Classification, DvrOptions, PreintegrationTable, TransferFunction, render_dvr,
};
use isokit_render::{BrickCache, Layout, RenderOptions, Volume, render};
use std::time::Instant;

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// The best of `runs` timings of `f`, seconds, and its last result.
fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = None;
    let mut t_best = f64::INFINITY;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let r = f();
        t_best = t_best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (t_best, out.unwrap())
}

/// Mean and largest |depth − exact| in voxels over the rays that hit the sphere with an
/// impact parameter below 0.87 r (grazing rays cross the values near 0 over many steps).
fn errors(depths: &[Option<f32>], exact: &[Option<f32>], h: f32) -> (f64, f64, usize) {
    let (mut sum, mut worst, mut n, mut missed) = (0.0f64, 0.0f64, 0usize, 0usize);
    for (z, e) in depths.iter().zip(exact) {
        match (z, e) {
            (Some(z), Some(e)) => {
                let d = f64::from((z - e).abs() / h);
                sum += d;
                worst = worst.max(d);
                n += 1;
            }
            (None, Some(_)) => missed += 1,
            _ => {}
        }
    }
    (sum / n.max(1) as f64, worst, missed)
}

fn main() {
    let res = env_or("ISOKIT_DS_RES", 256);
    let size = env_or("ISOKIT_DS_SIZE", 512) as u32;
    let runs = env_or("ISOKIT_DS_RUNS", 3);
    let r = 0.6f32;
    let h = 2.0 / (res - 1) as f32;
    let mut grid = Grid::new([res; 3], Vec3::splat(-1.0), h).unwrap();
    sample_into(&Sphere::new(Vec3::ZERO, r).unwrap(), &mut grid);
    let cam = Camera::look_at(
        Vec3::new(0.5, 0.4, 2.4),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        size,
        size,
    )
    .unwrap();
    let sigma = 400.0 / h;
    let shift = std::f32::consts::LN_2 / sigma;
    let exact: Vec<Option<f32>> = (0..size * size)
        .map(|pix| {
            let ray = cam.ray((pix % size) as f32 + 0.5, (pix / size) as f32 + 0.5);
            let b = ray.origin.dot(ray.dir);
            let disc = b * b - (ray.origin.length_squared() - r * r);
            (disc > 0.25 * r * r).then(|| -b - disc.sqrt())
        })
        .collect();
    println!(
        "sphere r {r} sampled at {res}^3, {size}^2 pixels, {} rays hit it away from the silhouette; best of {runs}",
        exact.iter().flatten().count()
    );
    println!("| method | frame ms | mean depth error (voxel) | worst (voxel) | rays missed |");
    println!("| --- | ---: | ---: | ---: | ---: |");

    // The ray caster, warm (the cache filled by a first frame), default options.
    let volume = Volume::from_grid(grid.clone(), Layout::default()).unwrap();
    let mut cache = BrickCache::for_volume(&volume);
    let opts = RenderOptions::default();
    render(&volume, &mut cache, &cam, &opts).unwrap();
    let (t, frame) = best(runs, || render(&volume, &mut cache, &cam, &opts).unwrap());
    let depths: Vec<Option<f32>> = frame
        .gbuffer
        .pixels()
        .iter()
        .map(|p| p.is_hit().then_some(p.depth))
        .collect();
    let (mean, worst, missed) = errors(&depths, &exact, h);
    println!(
        "| ray caster (tricubic search, warm) | {:.1} | {mean:.2e} | {worst:.2e} | {missed} |",
        1e3 * t
    );

    // Volume rendering with an opaque step at 0: pre-integrated and post-classified.
    let tf = TransferFunction::from_json(&format!(
        r#"{{"points": [[0, 1, 1, 1, {sigma}], [0, 0, 0, 0, 0]]}}"#
    ))
    .unwrap();
    for (name, classification, step) in [
        ("pre-integrated, 1 voxel", Classification::Preintegrated, h),
        (
            "pre-integrated, 2 voxels",
            Classification::Preintegrated,
            2.0 * h,
        ),
        ("post-classified, 1 voxel", Classification::Post, h),
        ("post-classified, 1/8 voxel", Classification::Post, h / 8.0),
    ] {
        let o = DvrOptions {
            classification,
            step: Some(step),
            table_size: 1024,
            ..DvrOptions::default()
        };
        // Each call builds the table; its time is measured alone and taken off (a viewer
        // keeps the table across frames).
        let table = if classification == Classification::Preintegrated {
            let (lo, hi) = isokit_render::dvr::value_range(&grid);
            best(runs, || {
                PreintegrationTable::new(&tf, lo, hi, 1024, step).unwrap()
            })
            .0
        } else {
            0.0
        };
        let (t, img) = best(runs, || render_dvr(&grid, &cam, &tf, &o).unwrap());
        let t = t - table;
        let depths: Vec<Option<f32>> = img
            .depth
            .iter()
            .map(|z| z.is_finite().then_some(z - shift))
            .collect();
        let (mean, worst, missed) = errors(&depths, &exact, h);
        let note = if table > 0.0 {
            format!(" (+ {:.0} ms for the 1024² table)", 1e3 * table)
        } else {
            String::new()
        };
        println!(
            "| DVR {name} | {:.1}{note} | {mean:.2e} | {worst:.2e} | {missed} |",
            1e3 * t
        );
    }
}
