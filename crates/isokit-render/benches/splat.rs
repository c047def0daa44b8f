//! Quadric splatting (002 Ch. 7) on the CPU twin: **throughput**, the analogue of 002
//! Table 7.2. Quadrics per second for 100k small on-screen spheres, ellipsoids, cylinders
//! and cones (set-up + splat), and fragments per second for a few large spheres covering
//! most of a 1024x768 image (fragments / splat time, and the intersection kernel alone
//! without binning, depth test or G-buffer).
//!
//! Sections 2 and 3 of the same report (molecule frames, and spacefill atoms against
//! tessellated spheres on a z-buffer rasterizer) need molecules and live in
//! `crates/isokit-molecule/benches/splat.rs` (`cargo bench -p isokit-molecule --bench
//! splat`).
//!
//! Run: `cargo bench -p isokit-render --bench splat`: medians of 5 runs; `-- --quick`: 2
//! runs; `-- --full`: 7 runs. `ISOKIT_BENCH_RUNS` overrides the count. A plain harness (no
//! criterion) keeps the dependency tree lean.

use glam::{DMat3, DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_field::{Camera, Projection};
use isokit_render::kernel::Uniforms;
use isokit_render::quadric::{Quadric, QuadricSetup};
use isokit_render::splat::{self, SplatOptions, SplatScene};
use rayon::prelude::*;
use std::time::Instant;

const WIDTH: u32 = 1024;
const HEIGHT: u32 = 768;

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let nproc = std::thread::available_parallelism().map_or(1, usize::from);
    let mem = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemTotal"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|k| k.parse::<f64>().ok())
        })
        .map_or_else(String::new, |kb| format!(", {:.0} GiB", kb / 1048576.0));
    let date = std::process::Command::new("date")
        .arg("-u")
        .arg("+%Y-%m-%d %H:%M UTC")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    format!(
        "{nproc} × {cpu} (nproc {nproc}{mem}), rayon {} threads; {date}",
        rayon::current_num_threads()
    )
}

// ---------------------------------------------------------------------------------------
// 1. Throughput
// ---------------------------------------------------------------------------------------

/// The throughput camera: at (0, 0, 100) looking at the origin, 30° field of view.
fn throughput_camera() -> Camera {
    Camera::look_at(
        Vec3::new(0.0, 0.0, 100.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 30.0,
        },
        WIDTH,
        HEIGHT,
    )
    .unwrap()
}

/// World units per pixel at view depth `z` for [`throughput_camera`].
fn world_per_px(z: f64) -> f64 {
    z * 15f64.to_radians().tan() / (0.5 * f64::from(HEIGHT))
}

/// The world point at view depth `z` seen at continuous pixel `(x, y)`.
fn at_pixel(x: f64, y: f64, z: f64) -> DVec3 {
    let s = world_per_px(z);
    DVec3::new(
        (x - 0.5 * f64::from(WIDTH)) * s,
        (0.5 * f64::from(HEIGHT) - y) * s,
        100.0 - z,
    )
}

fn random_rotation(rng: &mut SplitMix64) -> DMat3 {
    let a = rng.unit_vector().as_dvec3();
    let b = a.any_orthonormal_vector();
    let th = rng.range(0.0, std::f32::consts::TAU) as f64;
    let u = b * th.cos() + a.cross(b) * th.sin();
    DMat3::from_cols(u, a.cross(u), a)
}

/// `n` primitives of one kind scattered uniformly over the image at view depths 90–110,
/// sized in pixels (`size`: the diameter of spheres and cylinders).
fn small_scene(kind: &str, n: usize, size: f64, seed: u64) -> SplatScene {
    let mut rng = SplitMix64::new(seed);
    let mut scene = SplatScene::default();
    for _ in 0..n {
        let x = rng.next_f64() * f64::from(WIDTH);
        let y = rng.next_f64() * f64::from(HEIGHT);
        let z = 90.0 + 20.0 * rng.next_f64();
        let c = at_pixel(x, y, z);
        let r = 0.5 * size * world_per_px(z);
        let q = match kind {
            "sphere" => Quadric::sphere(c, r),
            "ellipsoid" => Quadric::ellipsoid(
                c,
                DVec3::new(r, 0.5 * r, 0.75 * r),
                random_rotation(&mut rng),
            ),
            "cylinder" | "cone" => {
                let a = rng.unit_vector().as_dvec3() * (2.0 * r);
                if kind == "cylinder" {
                    Quadric::cylinder(c - a, c + a, r)
                } else {
                    Quadric::cone(c - a, r, c + a, 0.25 * r)
                }
            }
            _ => unreachable!(),
        }
        .unwrap();
        scene.push(q, Vec3::new(0.8, 0.6, 0.4));
    }
    scene
}

/// Large spheres of radius `r_px` pixels on a grid of `r_px`-spaced centres covering the
/// image, `layers` deep (each layer shifted and farther).
fn large_scene(r_px: f64, layers: usize) -> SplatScene {
    let mut scene = SplatScene::default();
    let (nx, ny) = (
        (f64::from(WIDTH) / (2.0 * r_px)).ceil() as usize,
        (f64::from(HEIGHT) / (2.0 * r_px)).ceil() as usize,
    );
    for l in 0..layers {
        let z = 60.0 + 10.0 * l as f64;
        let shift = 0.5 * r_px * l as f64 / layers.max(1) as f64;
        for j in 0..ny {
            for i in 0..nx {
                let x = (2 * i + 1) as f64 * r_px + shift;
                let y = (2 * j + 1) as f64 * r_px + shift;
                let q = Quadric::sphere(at_pixel(x, y, z), r_px * world_per_px(z)).unwrap();
                scene.push(q, Vec3::splat(0.7));
            }
        }
    }
    scene
}

/// The intersection kernel alone: every set-up against every pixel centre in its box, in
/// parallel over set-ups, no depth test or G-buffer. Returns fragments, hits and seconds.
fn kernel_only(set: &[QuadricSetup], u: &Uniforms, near: f32) -> (u64, u64, f64) {
    let t = Instant::now();
    let (f, h) = set
        .par_iter()
        .map(|s| {
            let r = splat::pixel_range(s, u.width, u.height);
            let (mut f, mut h) = (0u64, 0u64);
            for py in r[1]..r[3] {
                for px in r[0]..r[2] {
                    f += 1;
                    h += u64::from(
                        std::hint::black_box(splat::fragment(s, u, near, px, py)).is_some(),
                    );
                }
            }
            (f, h)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    (f, h, t.elapsed().as_secs_f64())
}

fn throughput(runs: usize) {
    let cam = throughput_camera();
    let cases: Vec<(String, SplatScene)> = vec![
        (
            "100k spheres, 2 px".into(),
            small_scene("sphere", 100_000, 2.0, 1),
        ),
        (
            "100k spheres, 8 px".into(),
            small_scene("sphere", 100_000, 8.0, 2),
        ),
        (
            "100k ellipsoids, 2 px".into(),
            small_scene("ellipsoid", 100_000, 2.0, 3),
        ),
        (
            "100k cylinders, 2 px × 4 px".into(),
            small_scene("cylinder", 100_000, 2.0, 4),
        ),
        (
            "100k cones, 2 px × 4 px".into(),
            small_scene("cone", 100_000, 2.0, 5),
        ),
        (
            "1 sphere, 2 px (the per-frame fixed cost)".into(),
            small_scene("sphere", 1, 2.0, 6),
        ),
        ("12 spheres, r = 128 px".into(), large_scene(128.0, 1)),
        (
            "48 spheres, r = 128 px, 4 layers".into(),
            large_scene(128.0, 4),
        ),
    ];
    println!("\n## 1. Throughput (1024x768, median of {runs})\n");
    println!(
        "*Fragments* are the pixel centres inside the quadrics' screen boxes; the default CPU splat evaluates only those its per-tile occlusion culling keeps (*evaluated*), `exhaustive` evaluates all (as the GPU twin does). Rates count quadrics over set-up + splat, fragments over the splat alone; *intersection only* is `splat::fragment` over every box pixel in parallel, nothing else.\n"
    );
    println!(
        "| primitives | quadrics drawn | fragments / quadric | set-up ms | splat ms | evaluated | hits / evaluated | quadrics/s (set-up + splat) | set-up only, quadrics/s | evaluated fragments/s | exhaustive: splat ms | exhaustive: quadrics/s | exhaustive: fragments/s | intersection only, fragments/s |"
    );
    println!(
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    let exhaustive = SplatOptions {
        exhaustive: true,
        ..SplatOptions::default()
    };
    for (name, scene) in &cases {
        let (mut su, mut sp, mut ex, mut exs, mut kf) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut last = None;
        let u = splat::camera_uniforms(&cam).unwrap();
        let view = splat::view_for(&u, scene, &SplatOptions::default()).unwrap();
        let set = splat::setups(scene, &view);
        let _ = splat::splat(scene, &cam, &SplatOptions::default()).unwrap(); // warm-up
        for _ in 0..runs {
            let f = splat::splat(scene, &cam, &SplatOptions::default()).unwrap();
            su.push(f.stats.setup_seconds);
            sp.push(f.stats.splat_seconds);
            last = Some(f.stats);
            let f = splat::splat(scene, &cam, &exhaustive).unwrap();
            exs.push(f.stats.setup_seconds);
            ex.push(f.stats.splat_seconds);
            let (frags, _, s) = kernel_only(&set, &u, view.near as f32);
            kf.push(frags as f64 / s);
        }
        let st = last.unwrap();
        let (su, sp, ex, exs) = (median(&su), median(&sp), median(&ex), median(&exs));
        let rate = |x: f64| {
            if st.quadrics >= 1000 {
                format!("{:.2} M", x / 1e6)
            } else {
                "–".into()
            }
        };
        println!(
            "| {name} | {} | {:.1} | {:.1} | {:.1} | {:.0}% | {:.2} | {} | {} | {:.1} M | {:.1} | {} | {:.1} M | {:.1} M |",
            st.drawn,
            st.fragments as f64 / st.drawn.max(1) as f64,
            1e3 * su,
            1e3 * sp,
            100.0 * st.evaluated as f64 / st.fragments.max(1) as f64,
            st.hits as f64 / st.evaluated.max(1) as f64,
            rate(st.quadrics as f64 / (su + sp)),
            rate(st.quadrics as f64 / su),
            st.evaluated as f64 / sp / 1e6,
            1e3 * ex,
            rate(st.quadrics as f64 / (exs + ex)),
            st.fragments as f64 / ex / 1e6,
            median(&kf) / 1e6,
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let full = args.iter().any(|a| a == "--full");
    let runs = env_or(
        "ISOKIT_BENCH_RUNS",
        if quick {
            2
        } else if full {
            7
        } else {
            5
        },
    )
    .max(1);
    println!("# isokit-render quadric splatting, CPU twin");
    println!();
    println!("Machine: {}", machine());
    println!(
        "Mode: {}",
        if quick {
            "--quick"
        } else if full {
            "--full"
        } else {
            "default"
        }
    );
    let t0 = Instant::now();
    throughput(runs);
    println!(
        "\nWall time of the whole run: {:.0} s",
        t0.elapsed().as_secs_f64()
    );
}
