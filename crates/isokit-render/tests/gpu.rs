//! The GPU twin against the CPU twin (on lavapipe in CI): the same G-buffer within stated
//! tolerances on many scenes (a sphere in a 64³ grid, perspective and orthographic; the
//! trefoil knot's lazily sampled band; thin sheets; a cache too small for the active
//! bricks; both inside conventions with caps; a multi-view display; other filters and
//! refinements), and the same images. On failure the images and their differences are
//! written to a folder whose path the message gives. Skips with a printed reason where no
//! adapter exists, fails instead when `ISOKIT_REQUIRE_GPU=1`.
//!
//! This is the claim that the twins agree, scene by scene; that each twin is right is the
//! claim of the conformance suites (`raycast.rs`, `csg.rs`, `downsample.rs`, `flow.rs`),
//! whose reference checks run on both twins with the tolerances below
//! ([`common::twin::raycast_tol`], one definition for both).
//!
//! What "agree" means (why not bit for bit: see `isokit_render::gpu`):
//! - **hit mask**: equal, except at most `mask_px` pixels, each on the CPU mask's edge (a
//!   pixel with an 8-neighbour of the other status): a ray grazing the surface;
//! - where both hit, the same id, and for all but `outliers` pixels (again edge pixels,
//!   where the ray grazes and the two twins may bracket different crossings): depth `Z`
//!   and position `P` within `z_voxel` voxel, normals within `normal_deg`, `k1`, `k2`
//!   within `k_rel` of `max(|k|, k_floor)` (`k_floor` keeps flat regions, where curvature
//!   is rounding noise, from dividing by ~0);
//! - shaded images (Phong, 8-bit sRGB): mean absolute difference below `image_mean`;
//! - the same number of field evaluations on at least 99% of the rays (the twins take the
//!   same decisions: block skipping, fine sampling, brackets).

use glam::Vec3;
use isokit_field::{Camera, Projection};
use isokit_render::gpu::{GpuRenderer, raycast_shader, shade_shader};
use isokit_render::{
    BrickCache, DEFAULT_CACHE_BYTES, Filter, Frame, Image, Inside, Layout, MultiView, RefineMethod,
    RenderOptions, Shading, ShadingMode, Volume, render, render_multiview, render_view, shade,
};
use std::path::PathBuf;
use std::sync::MutexGuard;

mod common;
use common::twin::raycast_tol;
use common::*;

/// The test binary's GPU renderer ([`common::twin::gpu_renderer`]: opened once, the default
/// cache and dispatch sizes for each test, `ran`/`skipped` reported for CI's count).
fn renderer(test: &str) -> Option<MutexGuard<'static, GpuRenderer>> {
    common::twin::gpu_renderer(test)
}

// ---------------------------------------------------------------------------------------
// Scenes.
// ---------------------------------------------------------------------------------------

/// The trefoil knot mesh of `data/` as a lazily sampled band (its exact mesh distance).
fn trefoil_band(res: usize) -> Volume {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/trefoil.ply");
    Volume::from_brick_grid(mesh_band(&path, res).0, Layout::default()).unwrap()
}

// ---------------------------------------------------------------------------------------
// Comparison.
// ---------------------------------------------------------------------------------------

/// Tolerances of one comparison (see the module docs).
#[derive(Clone, Copy, Debug)]
struct Tol {
    mask_px: usize,
    outliers: usize,
    z_voxel: f32,
    normal_deg: f32,
    k_rel: f32,
    k_floor: f32,
    image_mean: f64,
}

/// The shared tolerances ([`raycast_tol`], with what was measured on lavapipe and
/// llvmpipe-GL over every scene below).
const TOL: Tol = Tol {
    mask_px: raycast_tol::MASK_PX,
    outliers: raycast_tol::OUTLIERS,
    z_voxel: raycast_tol::Z_VOXEL,
    normal_deg: raycast_tol::NORMAL_DEG,
    k_rel: raycast_tol::K_REL,
    k_floor: raycast_tol::K_FLOOR,
    image_mean: raycast_tol::IMAGE_MEAN,
};

/// What a comparison measured.
#[derive(Debug, Default)]
struct Report {
    rays: usize,
    hits: usize,
    mask_diff: usize,
    mask_off_edge: usize,
    id_diff: usize,
    outliers: usize,
    outliers_off_edge: usize,
    max_z: f32,
    max_p: f32,
    max_n: f32,
    max_k: f32,
    same_samples: usize,
    image_mean: f64,
}

/// True when pixel `(x, y)` of the CPU's hit mask has an 8-neighbour of the other status.
fn on_edge(cpu: &Frame, x: u32, y: u32) -> bool {
    let g = &cpu.gbuffer;
    let me = g.get(x, y).is_hit();
    for dy in -1i64..=1 {
        for dx in -1i64..=1 {
            let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
            if nx < 0 || ny < 0 || nx >= i64::from(g.width()) || ny >= i64::from(g.height()) {
                continue;
            }
            if g.get(nx as u32, ny as u32).is_hit() != me {
                return true;
            }
        }
    }
    false
}

fn mean_rgb8(a: &Image, b: &Image) -> f64 {
    let (a, b) = (a.to_rgba8(), b.to_rgba8());
    let sum: u64 = a
        .chunks(4)
        .zip(b.chunks(4))
        .map(|(p, q)| (0..3).map(|c| u64::from(p[c].abs_diff(q[c]))).sum::<u64>())
        .sum();
    sum as f64 / (3 * a.len() / 4) as f64
}

/// Mean |Δ| over RGB in 8 bits, the largest 8-bit channel difference, the largest linear one.
fn image_differences(c: &Image, g: &Image) -> (f64, u8, f32) {
    let (c8, g8) = (c.to_rgba8(), g.to_rgba8());
    let worst = c8
        .iter()
        .zip(&g8)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap_or(0);
    let linear = c
        .pixels
        .iter()
        .zip(&g.pixels)
        .map(|(a, b)| (0..4).map(|k| (a[k] - b[k]).abs()).fold(0f32, f32::max))
        .fold(0f32, f32::max);
    (mean_rgb8(c, g), worst, linear)
}

fn compare(cpu: &Frame, gpu: &Frame, spacing: f32, tol: &Tol, gpu_image: &Image) -> Report {
    let (a, b) = (&cpu.gbuffer, &gpu.gbuffer);
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    let mut r = Report {
        rays: a.pixels().len(),
        ..Report::default()
    };
    for y in 0..a.height() {
        for x in 0..a.width() {
            let (p, q) = (a.get(x, y), b.get(x, y));
            let i = (x + a.width() * y) as usize;
            r.same_samples += usize::from(a.samples()[i] == b.samples()[i]);
            if p.is_hit() != q.is_hit() {
                r.mask_diff += 1;
                r.mask_off_edge += usize::from(!on_edge(cpu, x, y));
                continue;
            }
            if !p.is_hit() {
                assert_eq!(q, &Default::default(), "a GPU miss must be all zeros");
                continue;
            }
            r.hits += 1;
            if p.id != q.id {
                r.id_diff += 1;
                continue;
            }
            let dz = (p.depth - q.depth).abs() / spacing;
            let dp = (p.position - q.position).length() / spacing;
            let dn = angle_degrees(p.normal, q.normal);
            let kf = |k: f32| k.abs().max(tol.k_floor);
            let dk = ((p.k1 - q.k1).abs() / kf(p.k1)).max((p.k2 - q.k2).abs() / kf(p.k2));
            let bad = !(dz <= tol.z_voxel
                && dp <= tol.z_voxel
                && dn <= tol.normal_deg
                && dk <= tol.k_rel);
            if bad {
                r.outliers += 1;
                r.outliers_off_edge += usize::from(!on_edge(cpu, x, y));
            } else {
                r.max_z = r.max_z.max(dz);
                r.max_p = r.max_p.max(dp);
                r.max_n = r.max_n.max(dn);
                r.max_k = r.max_k.max(dk);
            }
        }
    }
    let sh = Shading::default();
    let ia = shade(a, &cpu.uniforms, &sh).unwrap();
    r.image_mean = mean_rgb8(&ia, gpu_image);
    r
}

/// Writes the CPU and GPU images and the mask and depth differences of a failed
/// comparison; returns the folder.
fn write_diff(name: &str, cpu: &Frame, gpu: &Frame, gpu_image: &Image, spacing: f32) -> PathBuf {
    let slug: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let dir = std::env::temp_dir().join("isokit-render-gpu").join(slug);
    std::fs::create_dir_all(&dir).unwrap();
    let sh = Shading::default();
    shade(&cpu.gbuffer, &cpu.uniforms, &sh)
        .unwrap()
        .write_png(&dir.join("cpu.png"))
        .unwrap();
    gpu_image.write_png(&dir.join("gpu.png")).unwrap();
    let (a, b) = (&cpu.gbuffer, &gpu.gbuffer);
    let (w, h) = (a.width(), a.height());
    let mut mask = Vec::new();
    let mut depth = Vec::new();
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        // White: both hit; red: CPU only; blue: GPU only; black: neither.
        let m = match (p.is_hit(), q.is_hit()) {
            (true, true) => [255, 255, 255, 255],
            (true, false) => [255, 0, 0, 255],
            (false, true) => [0, 0, 255, 255],
            (false, false) => [0, 0, 0, 255],
        };
        mask.extend(m);
        // Depth difference: 1e-4 voxel → dark, 1 voxel → bright (log scale).
        let d = if p.is_hit() && q.is_hit() {
            let e = ((p.depth - q.depth).abs() / spacing).max(1e-4);
            ((e.log10() + 4.0) / 4.0 * 255.0).clamp(0.0, 255.0) as u8
        } else {
            0
        };
        depth.extend([d, d, d, 255]);
    }
    isokit_io::write_png(&dir.join("mask.png"), w, h, &mask).unwrap();
    isokit_io::write_png(&dir.join("depth_diff.png"), w, h, &depth).unwrap();
    dir
}

/// Compares, prints the measurements, and on failure writes the diff images and panics
/// with their folder.
fn check(name: &str, cpu: &Frame, gpu: &Frame, gpu_image: &Image, spacing: f32, tol: &Tol) {
    let r = compare(cpu, gpu, spacing, tol, gpu_image);
    eprintln!(
        "{name}: {} rays, {} hits; mask Δ {} ({} off edge), id Δ {}, outliers {} ({} off edge); max |ΔZ| {:.2e} voxel, |ΔP| {:.2e} voxel, normal {:.2e}°, k rel {:.2e}; same sample counts {:.1}%; image mean |Δ| {:.4} (8-bit); CPU {} pass(es), GPU {}",
        r.rays,
        r.hits,
        r.mask_diff,
        r.mask_off_edge,
        r.id_diff,
        r.outliers,
        r.outliers_off_edge,
        r.max_z,
        r.max_p,
        r.max_n,
        r.max_k,
        100.0 * r.same_samples as f64 / r.rays as f64,
        r.image_mean,
        cpu.stats.passes,
        gpu.stats.passes
    );
    let ok = r.mask_diff <= tol.mask_px
        && r.mask_off_edge == 0
        && r.id_diff == 0
        && r.outliers <= tol.outliers
        && r.outliers_off_edge == 0
        && r.image_mean <= tol.image_mean
        && r.same_samples * 100 >= r.rays * 99
        && r.hits > 0;
    if !ok {
        let dir = write_diff(name, cpu, gpu, gpu_image, spacing);
        panic!(
            "{name}: GPU and CPU disagree beyond {tol:?}: {r:?}; images in {}",
            dir.display()
        );
    }
}

/// Renders `v` from `cam` with `opts` on both twins (caches of `cache` bricks, or the
/// default) and checks them.
fn both(
    gpu: &mut GpuRenderer,
    name: &str,
    v: &Volume,
    cam: &Camera,
    opts: &RenderOptions,
    cache: Option<usize>,
    tol: &Tol,
) -> (Frame, Frame) {
    let mut cc = match cache {
        Some(n) => BrickCache::new(v, n).unwrap(),
        None => BrickCache::for_volume(v),
    };
    if let Some(n) = cache {
        gpu.set_cache_bricks(n).unwrap();
    }
    let c = render(v, &mut cc, cam, opts).unwrap();
    let g = gpu.render(v, cam, opts).unwrap();
    let img = gpu
        .shade(&g.gbuffer, &g.uniforms, &Shading::default())
        .unwrap();
    check(name, &c, &g, &img, v.spacing(), tol);
    (c, g)
}

// ---------------------------------------------------------------------------------------
// Tests.
// ---------------------------------------------------------------------------------------

#[test]
fn every_shader_validates_with_naga() {
    // Also unit-tested in the crate; here as the conformance suite's first check, without
    // an adapter.
    raycast_shader().validate().unwrap();
    shade_shader().validate().unwrap();
}

/// The sphere of the CPU conformance check (64³), perspective and orthographic, default
/// options and the other filters and refinements.
#[test]
fn sphere_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("sphere_gpu_equals_cpu") else {
        return;
    };
    let v = volume(sphere_grid(64));
    let persp = perspective(Vec3::new(0.4, 0.9, 2.6), 96, 96);
    let ortho = orthographic(Vec3::new(-1.4, 0.5, 2.2), Vec3::ZERO, 1.7, 80, 64);
    let base = RenderOptions::default();
    let cases = [
        ("sphere 64³ perspective", &persp, base),
        ("sphere 64³ orthographic", &ortho, base),
        (
            "sphere 64³ trilinear search and shading, bisection",
            &persp,
            RenderOptions {
                filter: Filter::Trilinear,
                shading_filter: Filter::Trilinear,
                refine: RefineMethod::Bisection,
                ..base
            },
        ),
        (
            "sphere 64³ r0 0.5, no adaptive sampling, no skipping, iso 0.1",
            &ortho,
            RenderOptions {
                r0: 0.5,
                fine: 1,
                skip_empty: false,
                iso: 0.1,
                ..base
            },
        ),
    ];
    for (name, cam, opts) in cases {
        let (c, g) = both(&mut gpu, name, &v, cam, &opts, None, &TOL);
        assert!(c.stats.hits > 1000, "{name}");
        assert_eq!(g.stats.passes, 1, "{name}");
        assert_eq!(g.stats.bricks_active, c.stats.bricks_active, "{name}");
    }
}

/// The trefoil knot's band (lazily sampled from its mesh), a thin tube with saddles.
#[test]
fn trefoil_band_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("trefoil_band_gpu_equals_cpu") else {
        return;
    };
    let v = trefoil_band(72);
    let b = v.bounds();
    let cam = Camera::framing(
        b,
        Vec3::new(1.0, 0.7, 1.4),
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        96,
        96,
    )
    .unwrap();
    let (c, _) = both(
        &mut gpu,
        "trefoil band 72",
        &v,
        &cam,
        &RenderOptions::default(),
        None,
        &TOL,
    );
    assert!(c.stats.hits > 800, "{}", c.stats.hits);
}

/// Sheets thinner than a voxel seen 25° off their normal (the CPU test's), trilinear and
/// tricubic: the adaptive sampling finds them on both twins.
#[test]
fn thin_sheets_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("thin_sheets_gpu_equals_cpu") else {
        return;
    };
    let n = Vec3::new(0.3, 0.2, 1.0).normalize();
    let view = (n + 0.47 * n.any_orthonormal_vector()).normalize();
    for (filter, thickness_voxels) in [(Filter::Trilinear, 0.8), (Filter::Tricubic, 1.1)] {
        let h = 2.0 / 63.0;
        let v = volume(grid_of(64, |p| p.dot(n).abs() - 0.5 * thickness_voxels * h));
        let cam = orthographic(view * 2.5, Vec3::ZERO, 0.8, 64, 64);
        let opts = RenderOptions {
            filter,
            ..Default::default()
        };
        let name = format!("thin sheet {thickness_voxels} voxel, {filter:?}");
        let (c, _) = both(&mut gpu, &name, &v, &cam, &opts, None, &TOL);
        assert!(c.stats.hits > 2000, "{name}");
    }
}

/// Caches of one and of three bricks: the GPU runs several passes (rays wait, the host
/// loads what they asked for) and renders the CPU's image; the pass counts match.
#[test]
fn small_caches_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("small_caches_gpu_equals_cpu") else {
        return;
    };
    let v = volume(two_spheres());
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 64, 64);
    let opts = RenderOptions::default();
    let (full, _) = both(
        &mut gpu,
        "two spheres, full cache",
        &v,
        &cam,
        &opts,
        None,
        &TOL,
    );
    for bricks in [1, 3] {
        let name = format!("two spheres, cache of {bricks} brick(s)");
        let (c, g) = both(&mut gpu, &name, &v, &cam, &opts, Some(bricks), &TOL);
        assert!(g.stats.passes > 1, "{name}: {} passes", g.stats.passes);
        assert_eq!(g.stats.passes, c.stats.passes, "{name}");
        assert_eq!(g.stats.bricks_loaded, c.stats.bricks_loaded, "{name}");
        // The CPU's small cache renders its full-cache image exactly.
        assert_eq!(c.gbuffer, full.gbuffer, "{name}");
    }
}

/// ERRATA 7 on the GPU: negated data with the inside above the isovalue give the image of
/// the inside below; with the inside below they show the complement, as caps on the box.
#[test]
fn both_inside_conventions_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("both_inside_conventions_gpu_equals_cpu") else {
        return;
    };
    let g = sphere_grid(48);
    let mut neg = g.clone();
    neg.data_mut().iter_mut().for_each(|x| *x = -*x);
    let (v, vn) = (volume(g), volume(neg));
    let cam = perspective(Vec3::new(0.5, 0.6, 2.7), 64, 64);
    let below = RenderOptions {
        iso: 0.1,
        ..Default::default()
    };
    let above = RenderOptions {
        iso: -0.1,
        inside: Inside::Above,
        ..Default::default()
    };
    let caps = RenderOptions {
        iso: -0.1,
        ..Default::default()
    };
    let (_, gb) = both(&mut gpu, "inside below", &v, &cam, &below, None, &TOL);
    let (_, ga) = both(
        &mut gpu,
        "inside above, negated",
        &vn,
        &cam,
        &above,
        None,
        &TOL,
    );
    let (c, g) = both(
        &mut gpu,
        "caps: the complement",
        &vn,
        &cam,
        &caps,
        None,
        &TOL,
    );
    assert!(c.stats.caps > 1000 && g.stats.caps == c.stats.caps);
    // The GPU's two conventions agree with each other as the CPU's do (exactly: the
    // residuals are the same numbers).
    assert_eq!(gb.gbuffer, ga.gbuffer);
}

/// 001 on the GPU: the multi-view geometric pass (3 subpixels per pixel, each from its own
/// view's eye) and one view alone equal the CPU's; the shaded interleaved image too.
#[test]
fn multiview_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("multiview_gpu_equals_cpu") else {
        return;
    };
    let v = volume(two_spheres());
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 40, 32);
    let opts = RenderOptions::default();
    let mv = MultiView {
        slant: 1.0 / 3.0,
        ..MultiView::new(8, 0.06)
    };
    let mut cache = BrickCache::for_volume(&v);
    let c = render_multiview(&v, &mut cache, &cam, &opts, &mv).unwrap();
    let g = gpu.render_multiview(&v, &cam, &opts, &mv).unwrap();
    assert_eq!((g.gbuffer.width(), g.gbuffer.height()), (120, 32));
    let sh = Shading::default();
    let gi = gpu.shade(&g.gbuffer, &g.uniforms, &sh).unwrap();
    let ci = shade(&c.gbuffer, &c.uniforms, &sh).unwrap();
    assert_eq!((gi.width, gi.height), (40, 32));
    let mean = mean_rgb8(&ci, &gi);
    eprintln!("multi-view interleaved image: mean |Δ| {mean:.4} (8-bit)");
    assert!(mean <= TOL.image_mean, "{mean}");
    // G-buffers per subpixel: shade them as single-view frames for the comparison.
    let as_single = |f: &Frame| Frame {
        gbuffer: f.gbuffer.clone(),
        stats: f.stats,
        uniforms: isokit_render::Uniforms {
            width: f.gbuffer.width(),
            subpixels: 1,
            views: 1,
            view: 0,
            ..f.uniforms
        },
    };
    let (cs, gs) = (as_single(&c), as_single(&g));
    let gsi = gpu.shade(&gs.gbuffer, &gs.uniforms, &sh).unwrap();
    check("multi-view, 8 views", &cs, &gs, &gsi, v.spacing(), &TOL);
    let c3 = render_view(&v, &mut cache, &cam, &opts, &mv, 3).unwrap();
    let g3 = gpu.render_view(&v, &cam, &opts, &mv, 3).unwrap();
    let g3i = gpu.shade(&g3.gbuffer, &g3.uniforms, &sh).unwrap();
    check(
        "multi-view, view 3 alone",
        &c3,
        &g3,
        &g3i,
        v.spacing(),
        &TOL,
    );
}

/// Tracing in chunks of rays (each with its own passes) changes no pixel, with a full cache
/// and with a one-brick cache.
#[test]
fn chunked_dispatch_changes_no_pixel() {
    let Some(mut gpu) = renderer("chunked_dispatch_changes_no_pixel") else {
        return;
    };
    let v = volume(two_spheres());
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 48, 40);
    let opts = RenderOptions::default();
    let whole = gpu.render(&v, &cam, &opts).unwrap();
    for cache in [None, Some(1)] {
        if let Some(n) = cache {
            gpu.set_cache_bricks(n).unwrap();
        }
        gpu.set_max_rays_per_dispatch(333);
        let parts = gpu.render(&v, &cam, &opts).unwrap();
        assert_eq!(parts.gbuffer, whole.gbuffer, "cache {cache:?}");
        assert!(parts.stats.passes >= 6, "{}", parts.stats.passes);
    }
}

/// GPU shading of the same G-buffer (the CPU's) in every mode equals CPU shading to
/// rounding: every linear channel within 1e-5 (measured: 5e-7), except `reflection`, whose
/// striped environment goes through `asin` and `sin(12·e)` and inherits the GPU's looser
/// transcendentals (Vulkan allows 2⁻¹¹ absolute error for `sin`): within 2e-2 (measured:
/// 8e-3); in 8-bit sRGB a mean below 0.02 of a step and no channel more than 2 steps off;
/// the background and alpha exact.
#[test]
fn gpu_shading_equals_cpu_shading() {
    let Some(gpu) = renderer("gpu_shading_equals_cpu_shading") else {
        return;
    };
    let v = volume(two_spheres());
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 64, 48);
    let mut cache = BrickCache::for_volume(&v);
    let f = render(&v, &mut cache, &cam, &RenderOptions::default()).unwrap();
    let point = isokit_render::Light {
        direction: None,
        position: Some(Vec3::new(1.0, 2.0, 2.0)),
        color: Vec3::new(1.0, 0.9, 0.8),
        intensity: 0.7,
    };
    let directional = isokit_render::Light {
        direction: Some(Vec3::new(-0.3, -1.0, -0.2)),
        position: None,
        color: Vec3::ONE,
        intensity: 0.6,
    };
    for lights in [vec![], vec![directional, point]] {
        for (name, mode) in ShadingMode::ALL {
            let sh = Shading {
                mode,
                lights: lights.clone(),
                curvature_scale: 3.0,
                ..Default::default()
            };
            let c = shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            let g = gpu.shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            let (mean, worst, linear) = image_differences(&c, &g);
            eprintln!(
                "shading {name} ({} lights): mean |Δ| {mean:.5}, max {worst} (8-bit), max linear {linear:.2e}",
                lights.len()
            );
            let bound = if mode == ShadingMode::Reflection {
                raycast_tol::SHADE_LINEAR_REFLECTION
            } else {
                raycast_tol::SHADE_LINEAR
            };
            assert!(
                linear <= bound && mean < 0.02 && worst <= 2,
                "{name}: linear {linear} (bound {bound}), 8-bit mean {mean}, max {worst}"
            );
            for (p, q) in f.gbuffer.pixels().iter().zip(&g.pixels) {
                if !p.is_hit() {
                    assert_eq!(*q, sh.background);
                } else {
                    assert_eq!(q[3], 1.0);
                }
            }
        }
    }
}

/// The `flow` mode (curvature-aligned LIC, its own pass over the whole image) on the GPU
/// equals the CPU's on the same G-buffer: a cylinder (orthographic and perspective) and a
/// torus (saddles, umbilic-free but with non-orientable seams), in one dispatch and in
/// chunks of 333 pixels (the shading pass then reads the LIC image at an offset). The host
/// projects the field for both twins, so the streamlines are the same; what remains is the
/// division of the LIC mean and the shading's rounding: every linear channel within 1e-5,
/// 8-bit sRGB equal but for at most 2 steps, the background exact. A multi-view G-buffer
/// is refused, as on the CPU.
#[test]
fn gpu_flow_equals_cpu_flow() {
    let Some(mut gpu) = renderer("gpu_flow_equals_cpu_flow") else {
        return;
    };
    let cylinder = volume(grid_of(48, |p| (p.x * p.x + p.z * p.z).sqrt() - 0.5));
    let torus = volume(grid_of(64, |p| {
        let q = ((p.x * p.x + p.z * p.z).sqrt() - 0.55, p.y);
        (q.0 * q.0 + q.1 * q.1).sqrt() - 0.25
    }));
    let scenes = [
        (
            "cylinder orthographic",
            &cylinder,
            orthographic(Vec3::Z * 3.0, Vec3::ZERO, 1.6, 64, 56),
        ),
        (
            "cylinder perspective",
            &cylinder,
            perspective(Vec3::new(0.0, 0.3, 3.0), 64, 56),
        ),
        (
            "torus perspective",
            &torus,
            perspective(Vec3::new(0.4, 1.6, 2.2), 72, 60),
        ),
    ];
    for (name, v, cam) in scenes {
        let mut cache = BrickCache::for_volume(v);
        let f = render(v, &mut cache, &cam, &RenderOptions::default()).unwrap();
        let sh = Shading {
            mode: ShadingMode::Flow,
            curvature_scale: 3.0,
            ..Default::default()
        };
        let c = shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
        let lic = isokit_render::shade::flow_image(&f.gbuffer, &f.uniforms, &sh).unwrap();
        let flowing = lic.iter().filter(|&&l| l >= 0.0).count();
        assert!(flowing * 2 > f.gbuffer.hit_count(), "{name}: {flowing}");
        for chunk in [None, Some(333)] {
            gpu.set_max_rays_per_dispatch(
                chunk.unwrap_or(isokit_render::gpu::DEFAULT_MAX_RAYS_PER_DISPATCH),
            );
            let g = gpu.shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            let (mean, worst, linear) = image_differences(&c, &g);
            eprintln!(
                "flow, {name}, chunk {chunk:?}: {flowing} of {} hit pixels flow; mean |Δ| {mean:.5}, max {worst} (8-bit), max linear {linear:.2e}",
                f.gbuffer.hit_count()
            );
            assert!(
                linear <= raycast_tol::SHADE_LINEAR && mean < 0.02 && worst <= 2,
                "{name}: linear {linear}, 8-bit mean {mean}, max {worst}"
            );
            for (p, q) in f.gbuffer.pixels().iter().zip(&g.pixels) {
                if !p.is_hit() {
                    assert_eq!(*q, sh.background);
                }
            }
        }
    }
    // Multi-view: refused with the CPU's error.
    let mv = MultiView::new(4, 0.05);
    let cam = perspective(Vec3::new(0.0, 0.3, 3.0), 16, 12);
    let m = render_multiview(
        &cylinder,
        &mut BrickCache::for_volume(&cylinder),
        &cam,
        &RenderOptions::default(),
        &mv,
    )
    .unwrap();
    let sh = Shading {
        mode: ShadingMode::Flow,
        ..Default::default()
    };
    let e = gpu
        .shade(&m.gbuffer, &m.uniforms, &sh)
        .unwrap_err()
        .to_string();
    assert!(e.contains("flow") && e.contains("multi-view"), "{e}");
    assert!(shade(&m.gbuffer, &m.uniforms, &sh).is_err());
}

/// On-the-fly CSG and morphing (two fields per brick slot, combined per sample, the object
/// map): the GPU twin equals the CPU twin for every operation, with the full cache and with
/// one too small for the active bricks.
#[test]
fn csg_gpu_equals_cpu() {
    let Some(mut gpu) = renderer("csg_gpu_equals_cpu") else {
        return;
    };
    let cam = perspective(Vec3::new(0.9, 0.7, 2.6), 64, 48);
    let ops = [
        isokit_render::Combine::Union,
        isokit_render::Combine::Intersection,
        isokit_render::Combine::Difference,
        isokit_render::Combine::Morph(0.4),
    ];
    for op in ops {
        gpu.set_cache_bytes(DEFAULT_CACHE_BYTES);
        let (a, b) = csg_pair();
        let v = volume(a).with_operand(b, op).unwrap();
        let opts = RenderOptions::default();
        let (c, g) = both(
            &mut gpu,
            &format!("csg {op:?}"),
            &v,
            &cam,
            &opts,
            None,
            &TOL,
        );
        let owners = |f: &Frame| {
            f.gbuffer
                .pixels()
                .iter()
                .filter(|s| s.id == isokit_render::kernel::ID_SURFACE_B)
                .count()
        };
        assert_eq!(owners(&c), owners(&g), "{op:?}");
        both(
            &mut gpu,
            &format!("csg {op:?}, 2 bricks"),
            &v,
            &cam,
            &opts,
            Some(2),
            &TOL,
        );
    }
}

/// The downsampling cache policy (002 Sec. 6.2.3): a cache of about half the active bricks
/// stores the least detailed ones at half resolution, hanging samples matched; the GPU reads
/// the same pool layout with the same arithmetic and renders the CPU's image in one pass,
/// for both search filters. A passes frame after it, on the same small cache, is exact
/// again (the volume's own block ranges restored).
#[test]
fn downsample_gpu_equals_cpu() {
    use isokit_render::CachePolicy;
    let Some(mut gpu) = renderer("downsample_gpu_equals_cpu") else {
        return;
    };
    let layout = Layout {
        block: 4,
        brick: 16,
    };
    let v = Volume::from_grid(sphere_grid(65), layout).unwrap();
    let cam = perspective(Vec3::new(0.4, 0.9, 2.6), 80, 80);
    let mut big = BrickCache::for_volume(&v);
    let exact = render(&v, &mut big, &cam, &RenderOptions::default()).unwrap();
    let cap = exact.stats.bricks_active / 2;
    for filter in [Filter::Tricubic, Filter::Trilinear] {
        let opts = RenderOptions {
            filter,
            cache_policy: CachePolicy::Downsample,
            ..Default::default()
        };
        let name = format!("sphere 65³, bricks of 16, cache {cap}, downsample, {filter:?}");
        let (c, g) = both(&mut gpu, &name, &v, &cam, &opts, Some(cap), &TOL);
        assert_eq!(g.stats.passes, 1, "{name}");
        assert!(c.stats.bricks_downsampled > 0, "{name}");
        assert_eq!(
            g.stats.bricks_downsampled, c.stats.bricks_downsampled,
            "{name}"
        );
        // Passes on the same (GPU) cache afterwards: exact.
        let p = RenderOptions {
            filter,
            ..Default::default()
        };
        let back = gpu.render(&v, &cam, &p).unwrap();
        let mut small = BrickCache::new(&v, cap).unwrap();
        let cpu = render(&v, &mut small, &cam, &p).unwrap();
        let img = gpu
            .shade(&back.gbuffer, &back.uniforms, &Shading::default())
            .unwrap();
        check(
            &format!("{name}, then passes"),
            &cpu,
            &back,
            &img,
            v.spacing(),
            &TOL,
        );
        assert!(back.stats.passes > 1 && back.stats.bricks_downsampled == 0);
    }
}
