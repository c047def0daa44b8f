//! The ray caster's knobs, swept: frames per second at 512x512 on 256³ fields (an analytic
//! sphere sampled densely; the trefoil knot tube and a mesh, each sampled lazily as a band
//! from its exact mesh distance), with and without empty-space skipping, trilinear and
//! tricubic, several base rates r0, fine factors n and refinement steps, and a cache too
//! small for the active bricks (rendered in passes, or with low-detail bricks downsampled). Each configuration's image is compared with a reference
//! traced at a very high sampling rate (r0 = 8, n = 8, 16 secant steps, tricubic): pixels
//! whose hit status differs, depth and normal errors where both hit, and the mean
//! difference of the Phong-shaded 8-bit images.
//!
//! GPU rows (when a wgpu adapter exists; `ISOKIT_BENCH_GPU=0` leaves them out): the GPU twin
//! with the default configuration and with a cache of 16 bricks, compared with the same
//! reference, and its agreement with the CPU twin's frame of the same configuration (hit
//! mask, depth). On a software adapter (lavapipe, llvmpipe) the rows are labelled so: their
//! times measure the CPU running the shader, not a GPU, and mean nothing for GPU speed.
//!
//! Run: `cargo bench -p isokit-render --bench raycast`. Knobs: `ISOKIT_BENCH_RES` (grid
//! resolution, default 256), `ISOKIT_BENCH_SIZE` (image side, default 512),
//! `ISOKIT_BENCH_RUNS` (best of, default 2). The mesh is `data/external/bunny00.off` when
//! `tools/fetch-data.sh` has fetched it, else `data/torus.off`. A plain harness (no
//! criterion) keeps the dependency tree lean.

#[path = "../tests/common/mod.rs"]
mod common;
use glam::Vec3;
use isokit_field::primitives::Sphere;
use isokit_field::{Aabb, Camera, Grid, Projection, sample_into};
use isokit_render::gpu::GpuRenderer;
use isokit_render::{
    BrickCache, CachePolicy, Filter, Frame, Layout, RefineMethod, RenderOptions, Shading, Volume,
    render, shade,
};
use std::path::Path;
use std::time::Instant;

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A field to render: the volume and the box of the shape (for the camera).
struct Case {
    name: String,
    volume: Volume,
    shape: Aabb,
    setup_seconds: f64,
}

fn sphere(res: usize) -> Case {
    let t = Instant::now();
    let h = 2.0 / (res - 1) as f32;
    let mut g = Grid::new([res; 3], Vec3::splat(-1.0), h).unwrap();
    sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut g);
    let volume = Volume::from_grid(g, Layout::default()).unwrap();
    Case {
        name: format!("sphere (dense {res}³)"),
        volume,
        shape: Aabb::new(Vec3::splat(-0.7), Vec3::splat(0.7)),
        setup_seconds: t.elapsed().as_secs_f64(),
    }
}

fn mesh(name: &str, path: &Path, res: usize) -> Case {
    let t = Instant::now();
    let (bricks, fraction) = common::mesh_band(path, res);
    let shape = isokit_field::Field::bounds(
        &isokit_kdtree::MeshSdf::new(&isokit_io::read_mesh(path).unwrap(), Default::default())
            .unwrap(),
    );
    let dims = bricks.dims();
    let volume = Volume::from_brick_grid(bricks, Layout::default()).unwrap();
    Case {
        name: format!(
            "{name} (band {}x{}x{}, {:.0}% evaluated)",
            dims[0],
            dims[1],
            dims[2],
            100.0 * fraction
        ),
        volume,
        shape,
        setup_seconds: t.elapsed().as_secs_f64(),
    }
}

/// The best of `runs` frames, each with a fresh cache (so loading counts) unless
/// `capacity` limits it.
fn time(
    case: &Case,
    cam: &Camera,
    opts: &RenderOptions,
    capacity: Option<usize>,
    runs: usize,
) -> (Frame, f64) {
    let mut best: Option<(Frame, f64)> = None;
    for _ in 0..runs {
        let mut cache = match capacity {
            Some(c) => BrickCache::new(&case.volume, c).unwrap(),
            None => BrickCache::for_volume(&case.volume),
        };
        let t = Instant::now();
        let f = render(&case.volume, &mut cache, cam, opts).unwrap();
        let s = t.elapsed().as_secs_f64();
        if best.as_ref().is_none_or(|b| s < b.1) {
            best = Some((f, s));
        }
    }
    best.unwrap()
}

/// The best of `runs` GPU frames, each with an empty cache of `capacity` bricks (or the
/// default), so that loading counts as it does for the CPU rows.
fn time_gpu(
    gpu: &mut GpuRenderer,
    case: &Case,
    cam: &Camera,
    opts: &RenderOptions,
    capacity: Option<usize>,
    runs: usize,
) -> (Frame, f64) {
    let mut best: Option<(Frame, f64)> = None;
    for _ in 0..runs {
        match capacity {
            Some(c) => gpu.set_cache_bricks(c).unwrap(),
            None => gpu.set_cache_bytes(isokit_render::DEFAULT_CACHE_BYTES),
        }
        let t = Instant::now();
        let f = gpu.render(&case.volume, cam, opts).unwrap();
        let s = t.elapsed().as_secs_f64();
        if best.as_ref().is_none_or(|b| s < b.1) {
            best = Some((f, s));
        }
    }
    best.unwrap()
}

/// Errors of `f` against the reference `r`: differing hit pixels, mean and max depth error
/// (voxels) and mean normal error (degrees) where both hit, mean 8-bit image difference.
fn compare(f: &Frame, r: &Frame, spacing: f32) -> (usize, f64, f64, f64, f64) {
    let (mut mask, mut n, mut dz, mut dz_max, mut dn) = (0, 0usize, 0f64, 0f64, 0f64);
    for (a, b) in f.gbuffer.pixels().iter().zip(r.gbuffer.pixels()) {
        if a.is_hit() != b.is_hit() {
            mask += 1;
        } else if a.is_hit() {
            n += 1;
            let e = f64::from((a.depth - b.depth).abs() / spacing);
            dz += e;
            dz_max = dz_max.max(e);
            // atan2(|a × b|, a · b) in f64: f32 acos cannot resolve less than ~0.02°.
            let (na, nb) = (a.normal.as_dvec3(), b.normal.as_dvec3());
            dn += na.cross(nb).length().atan2(na.dot(nb)).to_degrees();
        }
    }
    let sh = Shading::default();
    let ia = shade(&f.gbuffer, &f.uniforms, &sh).unwrap().to_rgba8();
    let ib = shade(&r.gbuffer, &r.uniforms, &sh).unwrap().to_rgba8();
    let rgb: f64 = ia
        .chunks(4)
        .zip(ib.chunks(4))
        .map(|(a, b)| (0..3).map(|c| f64::from(a[c].abs_diff(b[c]))).sum::<f64>() / 3.0)
        .sum::<f64>()
        / (ia.len() / 4) as f64;
    let n = n.max(1) as f64;
    (mask, dz / n, dz_max, dn / n, rgb)
}

fn main() {
    let res = env_or("ISOKIT_BENCH_RES", 256).max(16);
    let size = env_or("ISOKIT_BENCH_SIZE", 512).max(16) as u32;
    let runs = env_or("ISOKIT_BENCH_RUNS", 2).max(1);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let bunny = root.join("data/external/bunny00.off");
    let (mesh_name, mesh_path) = if bunny.is_file() {
        ("bunny", bunny)
    } else {
        ("torus mesh", root.join("data/torus.off"))
    };
    println!(
        "isokit-render ray caster, {size}x{size} pixels, CPU twin on {} threads, best of {runs}",
        rayon::current_num_threads()
    );
    let cases = [
        sphere(res),
        mesh("trefoil knot", &root.join("data/trefoil.ply"), res),
        mesh(mesh_name, &mesh_path, res),
    ];
    let mut gpu = if std::env::var("ISOKIT_BENCH_GPU").is_ok_and(|v| v == "0") {
        None
    } else {
        match GpuRenderer::open() {
            Ok(g) => {
                println!("GPU twin on {}", g.describe());
                Some(g)
            }
            Err(e) => {
                println!("no GPU rows: {e}");
                None
            }
        }
    };
    let gpu_label = match &gpu {
        Some(g) if g.is_software() => "GPU twin on a software adapter (CPU time, not GPU speed)",
        _ => "GPU twin",
    };
    let base = RenderOptions::default();
    let configs: Vec<(&str, RenderOptions, Option<usize>)> = vec![
        ("default: tricubic, r0 1, n 8, 6 secant", base, None),
        (
            "no skipping",
            RenderOptions {
                skip_empty: false,
                ..base
            },
            None,
        ),
        (
            "trilinear",
            RenderOptions {
                filter: Filter::Trilinear,
                ..base
            },
            None,
        ),
        (
            "trilinear search and shading",
            RenderOptions {
                filter: Filter::Trilinear,
                shading_filter: Filter::Trilinear,
                ..base
            },
            None,
        ),
        ("r0 0.5, n 8", RenderOptions { r0: 0.5, ..base }, None),
        ("r0 2, n 8", RenderOptions { r0: 2.0, ..base }, None),
        (
            "r0 1, n 1 (no adaptive)",
            RenderOptions { fine: 1, ..base },
            None,
        ),
        ("r0 1, n 4", RenderOptions { fine: 4, ..base }, None),
        (
            "r0 0.25, n 1",
            RenderOptions {
                r0: 0.25,
                fine: 1,
                ..base
            },
            None,
        ),
        (
            "0 refinement steps",
            RenderOptions {
                refine_steps: 0,
                ..base
            },
            None,
        ),
        (
            "2 refinement steps",
            RenderOptions {
                refine_steps: 2,
                ..base
            },
            None,
        ),
        (
            "6 bisection steps",
            RenderOptions {
                refine: RefineMethod::Bisection,
                ..base
            },
            None,
        ),
        ("cache of 16 bricks", base, Some(16)),
        ("cache of 48 bricks", base, Some(48)),
        (
            "cache of 48 bricks, downsample",
            RenderOptions {
                cache_policy: CachePolicy::Downsample,
                ..base
            },
            Some(48),
        ),
    ];
    let reference = RenderOptions {
        r0: 8.0,
        fine: 8,
        refine_steps: 16,
        ..base
    };
    for case in &cases {
        let cam = Camera::framing(
            case.shape,
            Vec3::new(1.0, 0.7, 1.4),
            Projection::Perspective {
                fov_y_degrees: 40.0,
            },
            size,
            size,
        )
        .unwrap();
        let h = case.volume.spacing();
        let (r, rt) = time(case, &cam, &reference, None, 1);
        println!(
            "\n### {} — set-up {:.2} s; {} of {} blocks and {} of {} bricks active; reference {:.2} s, {:.0} samples/ray\n",
            case.name,
            case.setup_seconds,
            r.stats.blocks_active,
            r.stats.blocks_total,
            r.stats.bricks_active,
            r.stats.bricks_total,
            rt,
            r.stats.samples_per_ray()
        );
        println!(
            "| configuration | ms/frame | fps | samples/ray | samples/hit pixel | passes | hit mask Δ px | mean \\|ΔZ\\| voxel | max \\|ΔZ\\| voxel | mean normal Δ ° | mean \\|ΔRGB\\| (8-bit) |"
        );
        println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
        for (name, opts, cap) in &configs {
            let (f, s) = time(case, &cam, opts, *cap, runs);
            let hit_samples: u64 = f
                .gbuffer
                .pixels()
                .iter()
                .zip(f.gbuffer.samples())
                .filter(|(p, _)| p.is_hit())
                .map(|(_, &s)| u64::from(s))
                .sum();
            let (mask, dz, dz_max, dn, rgb) = compare(&f, &r, h);
            println!(
                "| {name} | {:.0} | {:.2} | {:.1} | {:.1} | {} | {mask} | {dz:.2e} | {dz_max:.2e} | {dn:.3} | {rgb:.3} |",
                1e3 * s,
                1.0 / s,
                f.stats.samples_per_ray(),
                hit_samples as f64 / (f.stats.hits + f.stats.caps).max(1) as f64,
                f.stats.passes
            );
        }
        if let Some(g) = gpu.as_mut() {
            // Warm-up: the first dispatch compiles the kernel (lavapipe compiles lazily).
            let _ = g.render(&case.volume, &cam, &base);
            for (name, cap) in [("default", None), ("cache of 16 bricks", Some(16))] {
                let (f, s) = time_gpu(g, case, &cam, &base, cap, runs);
                let (mask, dz, dz_max, dn, rgb) = compare(&f, &r, h);
                let (cpu, _) = time(case, &cam, &base, cap, 1);
                let (cmask, _, cdz_max, cdn, _) = compare(&f, &cpu, h);
                println!(
                    "| {gpu_label}: {name} | {:.0} | {:.2} | {:.1} | – | {} | {mask} | {dz:.2e} | {dz_max:.2e} | {dn:.3} | {rgb:.3} |",
                    1e3 * s,
                    1.0 / s,
                    f.stats.samples_per_ray(),
                    f.stats.passes
                );
                println!(
                    "| ↳ GPU against the CPU twin's frame | | | | | | {cmask} | | {cdz_max:.2e} | {cdn:.2e} | |"
                );
            }
        }
    }
}
