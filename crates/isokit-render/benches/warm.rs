//! Warm frames of the CPU ray caster, for profiling: the brick cache filled by a first frame,
//! then frames from new cameras (an orbit in small steps), trace and shade timed apart.
//!
//! Run: `cargo bench -p isokit-render --bench warm`. Knobs: `ISOKIT_WARM_CASES` (comma list
//! of `sphere`, `trefoil`; default both), `ISOKIT_WARM_FRAMES` (default 5),
//! `ISOKIT_WARM_SIZE` (image side, default 512), `ISOKIT_WARM_RES` (default 256),
//! `ISOKIT_WARM_MODE` (`phong` or `curvature`, default phong), `ISOKIT_WARM_REF=1` to compare
//! with the r0 = 8 reference. Under `valgrind --tool=callgrind` set `ISOKIT_WARM_FRAMES=1`.

#[path = "../tests/common/mod.rs"]
mod common;
use glam::Vec3;
use isokit_field::primitives::Sphere;
use isokit_field::{Aabb, Camera, Grid, Projection, sample_into};
use isokit_render::{
    BrickCache, Frame, Layout, RenderOptions, Search, Shading, ShadingMode, Volume, render, shade,
};
use std::path::Path;
use std::time::Instant;

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn camera(shape: Aabb, size: u32, degrees: f32) -> Camera {
    let (s, c) = degrees.to_radians().sin_cos();
    let from = Vec3::new(c * 1.0 - s * 1.4, 0.7, s * 1.0 + c * 1.4);
    Camera::framing(
        shape,
        from,
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        size,
        size,
    )
    .unwrap()
}

fn compare(f: &Frame, r: &Frame, spacing: f32) -> (usize, f64, f64) {
    let (mut mask, mut n, mut dz, mut dz_max) = (0, 0usize, 0f64, 0f64);
    for (a, b) in f.gbuffer.pixels().iter().zip(r.gbuffer.pixels()) {
        if a.is_hit() != b.is_hit() {
            mask += 1;
        } else if a.is_hit() {
            n += 1;
            let e = f64::from((a.depth - b.depth).abs() / spacing);
            dz += e;
            dz_max = dz_max.max(e);
        }
    }
    (mask, dz / n.max(1) as f64, dz_max)
}

fn main() {
    let res = env_or("ISOKIT_WARM_RES", 256);
    let size = env_or("ISOKIT_WARM_SIZE", 512) as u32;
    let frames = env_or("ISOKIT_WARM_FRAMES", 5).max(1);
    let cases = std::env::var("ISOKIT_WARM_CASES").unwrap_or("sphere,trefoil".into());
    let curvature = std::env::var("ISOKIT_WARM_MODE").is_ok_and(|m| m == "curvature");
    let reference = std::env::var("ISOKIT_WARM_REF").is_ok_and(|v| v == "1");
    let search = std::env::var("ISOKIT_WARM_SEARCH").ok();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for case in cases.split(',') {
        let t = Instant::now();
        let (volume, shape) = match case {
            "sphere" => {
                let h = 2.0 / (res - 1) as f32;
                let mut g = Grid::new([res; 3], Vec3::splat(-1.0), h).unwrap();
                sample_into(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), &mut g);
                (
                    Volume::from_grid(g, Layout::default()).unwrap(),
                    Aabb::new(Vec3::splat(-0.7), Vec3::splat(0.7)),
                )
            }
            "trefoil" => {
                let path = root.join("data/trefoil.ply");
                let (bricks, _) = common::mesh_band(&path, res);
                let m = isokit_io::read_mesh(&path).unwrap();
                let shape = isokit_field::Field::bounds(
                    &isokit_kdtree::MeshSdf::new(&m, Default::default()).unwrap(),
                );
                (
                    Volume::from_brick_grid(bricks, Layout::default()).unwrap(),
                    shape,
                )
            }
            other => panic!("unknown case {other}"),
        };
        let setup = t.elapsed().as_secs_f64();
        if std::env::var("ISOKIT_WARM_SLOPES").is_ok() {
            let h = volume.spacing();
            let mut v: Vec<f32> = volume
                .block_ranges()
                .iter()
                .zip(volume.block_slopes())
                .filter(|(r, _)| r[0] <= 0.0 && 0.0 <= r[1])
                .map(|(_, s)| (s[0] + s[1] + s[2]) / h)
                .collect();
            v.sort_by(f32::total_cmp);
            let q = |f: f32| v[((v.len() - 1) as f32 * f) as usize];
            println!(
                "{case}: {} active blocks; sum of slopes / h: min {:.2} p10 {:.2} median {:.2} p90 {:.2} max {:.2}",
                v.len(),
                q(0.0),
                q(0.1),
                q(0.5),
                q(0.9),
                q(1.0)
            );
        }
        let mut opts = RenderOptions {
            curvature,
            ..RenderOptions::default()
        };
        match search.as_deref() {
            Some("fixed") => opts.search = Search::Fixed,
            Some("sphere") => opts.search = Search::Sphere,
            _ => {}
        }
        let sh = Shading {
            mode: if curvature {
                ShadingMode::Curvature
            } else {
                ShadingMode::Phong
            },
            ..Shading::default()
        };
        let mut cache = BrickCache::for_volume(&volume);
        let t = Instant::now();
        let first = render(&volume, &mut cache, &camera(shape, size, -2.0), &opts).unwrap();
        let first_s = t.elapsed().as_secs_f64();
        let (mut tr, mut shd) = (Vec::new(), Vec::new());
        let mut last = None;
        for k in 0..frames {
            let cam = camera(shape, size, k as f32 * 0.5);
            let t = Instant::now();
            let f = render(&volume, &mut cache, &cam, &opts).unwrap();
            tr.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            let img = shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            shd.push(t.elapsed().as_secs_f64() * 1e3);
            std::hint::black_box(img);
            if k == 0 {
                last = Some(f);
            }
        }
        let med = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let f = last.unwrap();
        println!(
            "{case}: setup {setup:.2} s, first frame {:.1} ms ({} bricks); warm trace {:.1} ms, shade {:.1} ms (median of {frames}); {:.2} samples/ray, {} hits",
            first_s * 1e3,
            first.stats.bricks_loaded,
            med(&mut tr),
            med(&mut shd),
            f.stats.samples_per_ray(),
            f.stats.hits
        );
        if reference {
            let r = render(
                &volume,
                &mut cache,
                &camera(shape, size, 0.0),
                &RenderOptions {
                    r0: 8.0,
                    fine: 8,
                    refine_steps: 16,
                    search: Search::Fixed,
                    curvature,
                    ..RenderOptions::default()
                },
            )
            .unwrap();
            let (mask, dz, dz_max) = compare(&f, &r, volume.spacing());
            println!(
                "  against r0 = 8: mask {mask} px, mean |dZ| {dz:.2e} voxel, max {dz_max:.2e}"
            );
        }
    }
}
