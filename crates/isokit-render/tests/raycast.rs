//! The ray caster against analytic references, one conformance suite for both twins
//! ([`common::twin`]: each test body runs on the CPU twin and, where an adapter exists, on
//! the GPU twin): the sphere check (hit positions, normals, curvature), empty-space
//! skipping and the brick cache (no pixel changes), thin sheets, grazing rays and rays along
//! grid lines, both inside conventions, isovalues at the data's extremes, the G-buffer file,
//! refused input, shading modes, multi-view subpixels. Bounds against a reference are the
//! CPU's on the CPU and add the documented GPU–CPU agreement ([`raycast_tol`]) on the GPU;
//! identities between frames of one twin are exact on both.
//!
//! CPU-only, about the CPU twin's internals: the brick-pool filters against the grid's, the
//! pixel rays, the DDA's segments and the flat trace data (`kernel::` functions), the CPU
//! cache's own bookkeeping, and the G-buffer's equality.

use glam::Vec3;
use isokit_field::filter::{self, tricubic_bspline_gradient_fast};
use isokit_field::rng::SplitMix64;
use isokit_field::{Camera, Grid, Projection};
use isokit_render::kernel::{self, ID_CAP, ID_SURFACE, TraceData};
use isokit_render::{
    BrickCache, Filter, GBUFFER_CHANNELS, GBuffer, Inside, Layout, RenderError, RenderOptions,
    Shading, ShadingMode, Volume, render, uniforms,
};
use std::sync::atomic::AtomicU32;

mod common;
use common::twin::{Twin, raycast_tol, twins};
use common::*;

fn frame(v: &Volume, cam: &Camera, opts: &RenderOptions) -> isokit_render::Frame {
    let mut cache = BrickCache::for_volume(v);
    render(v, &mut cache, cam, opts).unwrap()
}

/// The brick-pool filters equal the foundation's filters on the dense grid, bit for bit
/// (values and tricubic derivatives) or to f32 rounding (trilinear derivatives, which the
/// foundation accumulates in f64). CPU-only: `kernel::` functions on the CPU's pool.
#[test]
fn brick_pool_filters_equal_the_grid_filters() {
    let mut rng = SplitMix64::new(7);
    let g = grid_of(45, |p| {
        (3.0 * p.x).sin() * p.y + p.z * p.z - 0.3 * p.x * p.y * p.z
    });
    let v = volume(g.clone());
    let s = v.layout().brick_samples();
    let mut pool = vec![0.0; v.brick_count() * s];
    for n in 0..v.brick_count() {
        v.fill_brick(n, &mut pool[n * s..(n + 1) * s]);
    }
    let cam = perspective(Vec3::Z * 4.0, 8, 8);
    let u = uniforms(&v, &cam, &RenderOptions::default()).unwrap();
    for _ in 0..2000 {
        let p = rng.point_in(Vec3::ZERO, Vec3::splat(43.999));
        let cell = (p / 8.0).floor().as_ivec3();
        let slot = kernel::brick_of_block(&u, cell) as u32;
        let l = kernel::locate(&u, slot, cell, p);
        assert_eq!(l.p, p);
        let tri = kernel::value_at(&u, &pool, kernel::FILTER_TRILINEAR, &l);
        assert_eq!(tri, filter::trilinear(&g, p), "{p}");
        let cub = kernel::value_at(&u, &pool, kernel::FILTER_TRICUBIC, &l);
        assert_eq!(cub, filter::tricubic_bspline_fast(&g, p), "{p}");
        let (val, grad, hess) = kernel::derivatives_at(&u, &pool, kernel::FILTER_TRICUBIC, &l);
        let want = filter::tricubic_bspline_derivatives_fast(&g, p);
        assert_eq!((val, grad, hess), (want.value, want.gradient, want.hessian));
        let (val, grad, hess) = kernel::derivatives_at(&u, &pool, kernel::FILTER_TRILINEAR, &l);
        let want = filter::trilinear_derivatives(&g, p);
        assert!((val - want.value).abs() < 1e-6);
        assert!(
            (grad - want.gradient).abs().max_element() < 1e-5,
            "{grad} {}",
            want.gradient
        );
        let dh = (hess - want.hessian).to_cols_array();
        assert!(dh.iter().all(|d| d.abs() < 1e-5), "{hess} {}", want.hessian);
    }
}

/// The kernel's pixel rays are the camera's rays. CPU-only: `kernel::pixel_ray` (both twins'
/// frames are checked against it above).
#[test]
fn pixel_rays_equal_the_cameras() {
    let v = volume(sphere_grid(16));
    for cam in [
        perspective(Vec3::new(1.0, 2.0, 3.0), 37, 21),
        orthographic(Vec3::new(1.0, 2.0, 3.0), Vec3::X, 1.7, 37, 21),
    ] {
        let u = uniforms(&v, &cam, &RenderOptions::default()).unwrap();
        for (px, py) in [(0, 0), (36, 20), (18, 10), (5, 17)] {
            let (o, d) = kernel::pixel_ray(&u, px, py);
            let r = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
            assert_eq!((o, d), (r.origin, r.dir));
        }
    }
}

/// 002's check on an analytic sphere in a 64³ grid, on both twins: after refinement, hits lie
/// within 1e-3 voxel of the reconstructed surface; tricubic normals within 0.2° of the true
/// ones and k1, k2 within 2% of 1/R; the reconstructed surface within 0.03 voxel of the
/// sphere (the B-spline shrinks it by about h²/(3R)); `Z` the distance of `P` from the ray's
/// origin. These bounds are the CPU's; the GPU's add the documented GPU–CPU agreement
/// ([`raycast_tol`]: `Z` and `P` within 1e-4 voxel, normals 0.01°, curvature 1e-3 relative,
/// f32 curvature and fused multiply-adds). Without refinement the hits are worse than each
/// twin's bound: the check can fail.
#[test]
fn sphere_hits_normals_and_curvature() {
    use raycast_tol::{K_REL, NORMAL_DEG, Z_VOXEL};
    let g = sphere_grid(64);
    let h = g.spacing();
    let v = volume(g.clone());
    let cams = [
        perspective(Vec3::new(0.4, 0.9, 2.6), 64, 64),
        orthographic(Vec3::new(-2.0, 0.5, 1.0), Vec3::ZERO, 1.6, 64, 48),
    ];
    for mut t in twins("sphere_hits_normals_and_curvature") {
        let tol_iso = t.tol(1e-3, 1e-3 + Z_VOXEL);
        let tol_sphere = t.tol(0.03, 0.03 + Z_VOXEL);
        let tol_n = t.tol(0.2, 0.2 + NORMAL_DEG);
        // |k·R − 1| moves by R·|Δk| ≤ R·K_REL·|k| ≤ 1.02·K_REL (|k| within 2% of 1/R).
        let tol_k = t.tol(0.02, 0.02 + 1.02 * K_REL);
        // World units: `Z` and `P` each move by up to Z_VOXEL voxel on the GPU.
        let tol_z = t.tol(1e-4, 1e-4 + 2.0 * Z_VOXEL * h);
        for (ci, cam) in cams.iter().enumerate() {
            for refine in [
                isokit_render::RefineMethod::Secant,
                isokit_render::RefineMethod::Bisection,
            ] {
                let opts = RenderOptions {
                    refine,
                    refine_steps: if refine == isokit_render::RefineMethod::Secant {
                        6
                    } else {
                        12
                    },
                    ..Default::default()
                };
                let f = t.render(&v, cam, &opts).unwrap();
                assert!(
                    f.stats.hits > 1000,
                    "{t}, camera {ci}: {} hits",
                    f.stats.hits
                );
                let (mut worst_iso, mut worst_sphere, mut worst_n, mut worst_k) =
                    (0f32, 0f32, 0f32, 0f32);
                for s in f.gbuffer.pixels().iter().filter(|s| s.id == ID_SURFACE) {
                    let p = g.to_grid(s.position);
                    let val = filter::tricubic_bspline_fast(&g, p);
                    let grad = tricubic_bspline_gradient_fast(&g, p);
                    worst_iso = worst_iso.max(val.abs() / grad.length());
                    worst_sphere = worst_sphere.max((s.position.length() - R).abs() / h);
                    worst_n = worst_n.max(angle_degrees(s.normal, s.position));
                    for k in [s.k1, s.k2] {
                        worst_k = worst_k.max((k * R - 1.0).abs());
                    }
                    let z = (s.position - ray_origin(cam, s.position)).length();
                    assert!((s.depth - z).abs() < tol_z, "{t}: Z {} vs {z}", s.depth);
                }
                eprintln!(
                    "{t}, camera {ci} {refine:?}: iso {worst_iso:.2e} voxel, sphere {worst_sphere:.3} voxel, normal {worst_n:.4} deg, curvature {:.3}%",
                    100.0 * worst_k
                );
                assert!(
                    worst_iso < tol_iso,
                    "{t}: hit {worst_iso} voxel off the reconstructed surface"
                );
                assert!(
                    worst_sphere < tol_sphere,
                    "{t}: reconstructed surface {worst_sphere} voxel off the sphere"
                );
                assert!(worst_n < tol_n, "{t}: normal off by {worst_n} degrees");
                assert!(worst_k < tol_k, "{t}: curvature off by {worst_k}");
            }
        }
        // Without refinement (the linear interpolation of the detecting interval only) the
        // hits are measurably worse: the check above can fail.
        let opts = RenderOptions {
            refine_steps: 0,
            fine: 1,
            r0: 0.5,
            ..Default::default()
        };
        let f = t.render(&v, &cams[0], &opts).unwrap();
        let worst = f
            .gbuffer
            .pixels()
            .iter()
            .filter(|s| s.id == ID_SURFACE)
            .map(|s| {
                let p = g.to_grid(s.position);
                filter::tricubic_bspline_fast(&g, p).abs()
                    / tricubic_bspline_gradient_fast(&g, p).length()
            })
            .fold(0f32, f32::max);
        assert!(worst > tol_iso, "{t}: unrefined hits are {worst} voxel off");
    }
}

/// The origin of the camera ray through the pixel that sees `p` (the eye, or for an
/// orthographic camera the point of the image plane).
fn ray_origin(cam: &Camera, p: Vec3) -> Vec3 {
    match cam.projection() {
        Projection::Perspective { .. } => cam.eye(),
        Projection::Orthographic { .. } => {
            let f = cam.forward();
            p - (p - cam.eye()).dot(f) * f
        }
    }
}

/// Two spheres with empty space around and between them: skipping changes no pixel and no
/// shaded colour (exact on both twins: the same kernel with the skip flag set or not), and
/// saves more than half the field evaluations.
#[test]
fn skipping_empty_space_changes_no_pixel() {
    let v = volume(two_spheres());
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 64, 64);
    for mut t in twins("skipping_empty_space_changes_no_pixel") {
        for filter in [Filter::Tricubic, Filter::Trilinear] {
            for iso in [0.0, 0.08] {
                let on = RenderOptions {
                    filter,
                    iso,
                    ..Default::default()
                };
                let off = RenderOptions {
                    skip_empty: false,
                    ..on
                };
                let a = t.render(&v, &cam, &on).unwrap();
                let b = t.render(&v, &cam, &off).unwrap();
                assert!(a.stats.hits > 300, "{t}: {} hits", a.stats.hits);
                assert_eq!(
                    a.gbuffer.pixels(),
                    b.gbuffer.pixels(),
                    "{t}: {filter:?} iso {iso}"
                );
                assert!(
                    a.stats.samples * 2 < b.stats.samples,
                    "{t}: skipping saved too little: {} vs {} samples",
                    a.stats.samples,
                    b.stats.samples
                );
                assert!(a.stats.blocks_active < a.stats.blocks_total / 4, "{t}");
                assert_eq!(b.stats.blocks_active, b.stats.blocks_total, "{t}");
                let sh = Shading {
                    mode: ShadingMode::Curvature,
                    ..Default::default()
                };
                let ia = t.shade(&a.gbuffer, &a.uniforms, &sh).unwrap().to_rgba8();
                let ib = t.shade(&b.gbuffer, &b.uniforms, &sh).unwrap().to_rgba8();
                assert_eq!(ia, ib, "{t}");
            }
        }
    }
}

/// A cache of one brick, or of a few, renders the same image as one that holds them all,
/// in several passes (exact on both twins); bricks behind others need not be loaded at all.
/// That the CPU's cache never holds more than its capacity is the CPU's bookkeeping
/// (CPU-only); the GPU's pool has at most that many slots.
#[test]
fn a_small_cache_renders_the_same_image() {
    let g = two_spheres();
    let layout = Layout {
        block: 8,
        brick: 16,
    };
    let v = Volume::from_grid(g, layout).unwrap();
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 48, 48);
    let opts = RenderOptions::default();
    for mut t in twins("a_small_cache_renders_the_same_image") {
        let want = t.render(&v, &cam, &opts).unwrap();
        assert_eq!(want.stats.passes, 1, "{t}");
        assert_eq!(
            want.stats.bricks_loaded as usize, want.stats.bricks_active,
            "{t}"
        );
        for capacity in [1, 3, 7] {
            t.set_cache_bricks(capacity).unwrap();
            let got = t.render(&v, &cam, &opts).unwrap();
            assert!(got.stats.bricks_active > capacity, "{t}");
            assert!(got.stats.passes > 1, "{t}: capacity {capacity}");
            assert_eq!(got.gbuffer, want.gbuffer, "{t}: capacity {capacity}");
            match &t {
                Twin::Cpu(_) => assert!(t.cpu_cache().unwrap().resident() <= capacity),
                Twin::Gpu(g) => assert!(g.cache_capacity().unwrap() <= capacity),
            }
            eprintln!(
                "{t}, capacity {capacity}: {} passes, {} loads, {} evictions ({} active bricks)",
                got.stats.passes,
                got.stats.bricks_loaded,
                got.stats.evictions,
                got.stats.bricks_active
            );
        }
    }
}

/// LRU across frames, on both twins (each keeps its cache across frames of one volume): the
/// same view reloads nothing; a new isovalue loads only the bricks it adds; another volume
/// starts over. A [`BrickCache`] handed another volume starting over by itself is the CPU's
/// bookkeeping (CPU-only).
#[test]
fn the_cache_keeps_bricks_across_frames() {
    let lay = Layout {
        block: 8,
        brick: 16,
    };
    let v = Volume::from_grid(two_spheres(), lay).unwrap();
    let other = Volume::from_grid(two_spheres(), lay).unwrap();
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 32, 32);
    for mut t in twins("the_cache_keeps_bricks_across_frames") {
        let a = t.render(&v, &cam, &RenderOptions::default()).unwrap();
        assert!(a.stats.bricks_loaded > 0 && a.stats.cache_hits == 0, "{t}");
        let b = t.render(&v, &cam, &RenderOptions::default()).unwrap();
        assert_eq!(b.stats.bricks_loaded, 0, "{t}");
        assert_eq!(b.stats.cache_hits as usize, b.stats.bricks_active, "{t}");
        assert_eq!(a.gbuffer, b.gbuffer, "{t}");
        let grown = RenderOptions {
            iso: 0.2,
            ..Default::default()
        };
        let c = t.render(&v, &cam, &grown).unwrap();
        assert!(c.stats.cache_hits > 0, "{t}");
        assert_eq!(
            (c.stats.cache_hits + c.stats.bricks_loaded) as usize,
            c.stats.bricks_active,
            "{t}"
        );
        let d = t.render(&other, &cam, &RenderOptions::default()).unwrap();
        assert_eq!(d.stats.cache_hits, 0, "{t}");
        assert_eq!(d.gbuffer, a.gbuffer, "{t}");
    }
    // CPU-only: one BrickCache handed another volume.
    let mut cache = BrickCache::for_volume(&v);
    let a = render(&v, &mut cache, &cam, &RenderOptions::default()).unwrap();
    let d = render(&other, &mut cache, &cam, &RenderOptions::default()).unwrap();
    assert_eq!(d.stats.cache_hits, 0);
    assert_eq!(d.gbuffer, a.gbuffer);
}

/// The longest run along the ray `o + t·d` (grid coordinates, `t` in `[t0, t1]`) where
/// the dense grid's reconstruction lies inside (below 0), sampled every 1/64 voxel: the
/// reference for what a ray may or must find.
fn inside_chord(g: &Grid, filter: Filter, o: Vec3, d: Vec3, t0: f32, t1: f32) -> f32 {
    let (mut best, mut run) = (0f32, 0f32);
    let steps = ((t1 - t0) * 64.0).ceil() as usize;
    for k in 0..=steps {
        let p = o + (t0 + k as f32 / 64.0) * d;
        let v = match filter {
            Filter::Trilinear => filter::trilinear(g, p),
            Filter::Tricubic => filter::tricubic_bspline_fast(g, p),
        };
        if v < 0.0 {
            run += 1.0 / 64.0;
            best = best.max(run);
        } else {
            run = 0.0;
        }
    }
    best
}

/// Sheets less than a voxel thick along the rays (0.8 and 1.1 voxels, seen 25° off their
/// normal; the trilinear one has holes in its reconstruction), on both twins: every ray
/// along which the reconstruction is inside for a quarter voxel or more (two fine steps)
/// finds it, and no ray finds it where the reconstruction never goes inside (exact on both:
/// the margin, a quarter voxel of chord, is thousands of times the GPU's documented depth
/// agreement, and the twins take the same sampling decisions); hits lie within the sheet
/// (on the GPU plus [`raycast_tol::Z_VOXEL`]). With the base rate only, at half a sample
/// per voxel, rays miss it.
#[test]
fn thin_sheets_are_not_missed() {
    let n = Vec3::new(0.3, 0.2, 1.0).normalize();
    let view = (n + 0.47 * n.any_orthonormal_vector()).normalize();
    assert!((angle_degrees(view, n) - 25.0).abs() < 1.0);
    for mut t in twins("thin_sheets_are_not_missed") {
        for (filter, thickness_voxels) in [(Filter::Trilinear, 0.8), (Filter::Tricubic, 1.1)] {
            let h = 2.0 / 63.0;
            let g = grid_of(64, |p| p.dot(n).abs() - 0.5 * thickness_voxels * h);
            let v = volume(g.clone());
            let cam = orthographic(view * 2.5, Vec3::ZERO, 0.8, 40, 40);
            let within = t.tol(
                thickness_voxels * h,
                (thickness_voxels + raycast_tol::Z_VOXEL) * h,
            );
            let run = |t: &mut Twin, opts: &RenderOptions| {
                let f = t.render(&v, &cam, opts).unwrap();
                let u = f.uniforms;
                let (mut required, mut missed, mut spurious) = (0, 0, 0);
                let mut chords = (f32::INFINITY, 0f32);
                for py in 0..40 {
                    for px in 0..40 {
                        let (ow, d) = kernel::pixel_ray(&u, px, py);
                        let o = g.to_grid(ow);
                        // The reconstruction can be inside only within a few voxels of the
                        // plane (at signed distance `a + t·b` voxels along the ray).
                        let (a, b) = (n.dot(ow) / h, n.dot(d));
                        let reach = 0.5 * thickness_voxels + 3.0;
                        let (t0, t1) = ((-reach - a) / b, (reach - a) / b);
                        let chord = inside_chord(&g, filter, o, d, t0.min(t1), t0.max(t1));
                        let s = f.gbuffer.get(px, py);
                        chords = (chords.0.min(chord), chords.1.max(chord));
                        if chord >= 0.25 {
                            required += 1;
                            missed += usize::from(!s.is_hit());
                        }
                        if s.is_hit() {
                            spurious += usize::from(chord == 0.0);
                            assert!(s.position.dot(n).abs() < within, "{t}");
                        }
                    }
                }
                eprintln!(
                    "{t}, {filter:?}: inside chords {:.2} to {:.2} voxels",
                    chords.0, chords.1
                );
                (required, missed, spurious)
            };
            let opts = RenderOptions {
                filter,
                ..Default::default()
            };
            let (required, missed, spurious) = run(&mut t, &opts);
            eprintln!(
                "{t}, {filter:?}: {required} rays must hit, {missed} missed, {spurious} spurious"
            );
            assert!(
                required > 1000,
                "{t}, {filter:?}: only {required} rays cross the sheet"
            );
            assert_eq!((missed, spurious), (0, 0), "{t}, {filter:?}");
            let coarse = RenderOptions {
                filter,
                fine: 1,
                r0: 0.5,
                ..Default::default()
            };
            let (_, missed, _) = run(&mut t, &coarse);
            eprintln!("{t}, {filter:?}, base rate only: {missed} missed");
            assert!(
                missed > 50,
                "{t}, {filter:?}: coarse sampling missed only {missed}"
            );
        }
    }
}

/// Rays passing the sphere's silhouette at a fraction of a voxel, on both twins: those inside
/// the sphere by more than 0.05 voxel hit, those outside by more than 0.05 voxel miss (exact
/// on both: the margin is 500 times the GPU's documented depth agreement). With a coarse
/// base rate and no fine sampling, some are wrong.
#[test]
fn grazing_rays_at_the_silhouette() {
    // The sphere's equator between block faces along z (at voxels 32 and 40), at voxel
    // 34.5, so that block ends do not sample it by chance.
    let c = Vec3::new(0.0, 0.0, -1.0 + 34.5 * 2.0 / 63.0);
    let g = grid_of(64, |p| (p - c).length() - R);
    let h = g.spacing();
    let v = volume(g);
    // A strip of 201 pixels across the silhouette at x = R, 2 voxels wide.
    let (w, span) = (201u32, 2.0 * h);
    let target = c + Vec3::new(R, 0.0, 0.0);
    let cam = orthographic(target + Vec3::Z * 3.0, target, span / w as f32, w, 1);
    for mut t in twins("grazing_rays_at_the_silhouette") {
        for (opts, must_pass) in [
            (RenderOptions::default(), true),
            (
                RenderOptions {
                    filter: Filter::Trilinear,
                    ..Default::default()
                },
                true,
            ),
            (
                RenderOptions {
                    fine: 1,
                    r0: 0.125,
                    ..Default::default()
                },
                false,
            ),
        ] {
            let f = t.render(&v, &cam, &opts).unwrap();
            let u = f.uniforms;
            let mut wrong = 0;
            for px in 0..w {
                let (o, _) = kernel::pixel_ray(&u, px, 0);
                let rho = (o - c).truncate().length();
                let s = f.gbuffer.get(px, 0);
                if rho < R - 0.05 * h && !s.is_hit() || rho > R + 0.05 * h && s.is_hit() {
                    wrong += 1;
                }
            }
            if must_pass {
                assert_eq!(wrong, 0, "{t}: {opts:?}");
            } else {
                assert!(wrong >= 5, "{t}: coarse sampling got only {wrong} wrong");
            }
        }
    }
}

/// Rays along grid lines and block faces (axis-aligned, through sample positions), on both
/// twins: those well inside the silhouette hit the sphere within 0.03 voxel with normals
/// within 0.2° (on the GPU plus [`raycast_tol::Z_VOXEL`] and [`raycast_tol::NORMAL_DEG`]),
/// those well outside miss.
#[test]
fn rays_along_grid_lines() {
    // 65 samples over [-1, 1]: spacing 1/32, a node (and a block face) at 0.
    let g = grid_of(65, |p| p.length() - R);
    let h = g.spacing();
    let v = volume(g);
    // Pixel centres 2 voxels apart, the middle one on the axis.
    let cam = orthographic(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 33.0 * 2.0 * h, 33, 33);
    for mut t in twins("rays_along_grid_lines") {
        let tol_r = t.tol(0.03, 0.03 + raycast_tol::Z_VOXEL) * h;
        let tol_n = t.tol(0.2, 0.2 + raycast_tol::NORMAL_DEG);
        let f = t.render(&v, &cam, &RenderOptions::default()).unwrap();
        let u = f.uniforms;
        for py in 0..33 {
            for px in 0..33 {
                let (o, d) = kernel::pixel_ray(&u, px, py);
                assert_eq!(d, -Vec3::Z);
                let on_node = (o.truncate() / h).round() * h;
                assert!((o.truncate() - on_node).length() < 1e-6);
                let s = f.gbuffer.get(px, py);
                let rho = o.truncate().length();
                if rho < R - 0.1 * h {
                    assert!(s.id == ID_SURFACE, "{t}: pixel {px},{py}");
                    assert!((s.position.length() - R).abs() < tol_r, "{t}: {px},{py}");
                    assert!(angle_degrees(s.normal, s.position) < tol_n, "{t}");
                } else if rho > R + 0.1 * h {
                    assert!(!s.is_hit(), "{t}: pixel {px},{py}");
                }
            }
        }
    }
}

/// ERRATA 7: the inside side is a parameter. Negated data with the inside above the
/// isovalue give exactly the original image (on both twins: the residuals are the same
/// numbers); with the inside below they show the solid's complement, here as caps on the
/// volume's box.
#[test]
fn both_inside_conventions() {
    let g = sphere_grid(48);
    let mut neg = g.clone();
    neg.data_mut().iter_mut().for_each(|x| *x = -*x);
    let (v, vn) = (volume(g), volume(neg));
    let cam = perspective(Vec3::new(0.5, 0.6, 2.7), 40, 40);
    for mut t in twins("both_inside_conventions") {
        for iso in [0.0, 0.1] {
            let below = t
                .render(
                    &v,
                    &cam,
                    &RenderOptions {
                        iso,
                        ..Default::default()
                    },
                )
                .unwrap();
            let above = t
                .render(
                    &vn,
                    &cam,
                    &RenderOptions {
                        iso: -iso,
                        inside: Inside::Above,
                        ..Default::default()
                    },
                )
                .unwrap();
            assert!(below.stats.hits > 300, "{t}");
            assert_eq!(below.gbuffer, above.gbuffer, "{t}: iso {iso}");
            let wrong = t
                .render(
                    &vn,
                    &cam,
                    &RenderOptions {
                        iso: -iso,
                        ..Default::default()
                    },
                )
                .unwrap();
            let c = wrong.gbuffer.get(20, 20);
            assert_eq!(c.id, ID_CAP, "{t}");
            assert!(c.depth < below.gbuffer.get(20, 20).depth, "{t}");
            assert_eq!(wrong.stats.hits, 0, "{t}");
        }
    }
}

/// An isovalue at the data's minimum leaves nothing inside (with the inside below): no
/// hit. At the maximum everything but the extreme samples is inside: every ray that meets
/// the box hits it as a cap. With the inside above, the other way round. No NaN anywhere.
/// On both twins, exact (the counts compare frames of the same twin).
#[test]
fn isovalues_at_the_data_extremes() {
    let g = sphere_grid(40);
    let (lo, hi) = g.min_max().unwrap();
    let v = volume(g);
    let cam = perspective(Vec3::new(1.5, 1.1, 2.9), 40, 40);
    for mut t in twins("isovalues_at_the_data_extremes") {
        let box_pixels = {
            let f = t
                .render(
                    &v,
                    &cam,
                    &RenderOptions {
                        iso: hi,
                        ..Default::default()
                    },
                )
                .unwrap();
            f.gbuffer.pixels().iter().filter(|s| s.is_hit()).count()
        };
        assert!(box_pixels > 800, "{t}: {box_pixels}");
        for (iso, inside, empty) in [
            (lo, Inside::Below, true),
            (hi, Inside::Below, false),
            (lo, Inside::Above, false),
            (hi, Inside::Above, true),
        ] {
            for skip_empty in [true, false] {
                let opts = RenderOptions {
                    iso,
                    inside,
                    skip_empty,
                    ..Default::default()
                };
                let f = t.render(&v, &cam, &opts).unwrap();
                for s in f.gbuffer.pixels() {
                    assert!(
                        s.position.is_finite() && s.normal.is_finite() && s.depth.is_finite(),
                        "{t}"
                    );
                    assert!(s.k1.is_finite() && s.k2.is_finite(), "{t}");
                }
                if empty {
                    assert_eq!(f.gbuffer.hit_count(), 0, "{t}: {iso} {inside:?}");
                } else {
                    assert_eq!(f.stats.caps as usize, box_pixels, "{t}: {iso} {inside:?}");
                    assert_eq!(f.stats.hits, 0, "{t}");
                }
            }
        }
    }
}

/// The G-buffer file of either twin's frame has the named channels, `A` marks the hits and
/// `Z` is positive exactly there, and it reads back as the frame's samples.
#[test]
fn gbuffer_exr_has_the_named_channels() {
    let v = volume(sphere_grid(24));
    for mut t in twins("gbuffer_exr_has_the_named_channels") {
        let f = t
            .render(
                &v,
                &perspective(Vec3::Z * 3.0, 20, 12),
                &RenderOptions::default(),
            )
            .unwrap();
        let dir = std::env::temp_dir().join(format!(
            "isokit-render-exr-{}-{}",
            std::process::id(),
            t.tol("cpu", "gpu")
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("g.exr");
        f.gbuffer.write_exr(&path).unwrap();
        let info = isokit_io::read_exr_info(&path).unwrap();
        assert_eq!((info.width, info.height), (20, 12));
        let mut got = info.channels.clone();
        got.sort();
        let mut want: Vec<String> = GBUFFER_CHANNELS.iter().map(|s| s.to_string()).collect();
        want.sort();
        assert_eq!(got, want);
        let planes = f.gbuffer.channels();
        let a = &planes[9];
        assert_eq!(
            a.iter().filter(|&&x| x == 1.0).count(),
            f.gbuffer.hit_count(),
            "{t}"
        );
        let z = &planes[6];
        assert!(
            z.iter().zip(a).all(|(z, a)| (*z > 0.0) == (*a > 0.0)),
            "{t}"
        );
        // The pixels read back from the file are the in-memory samples, channel by channel.
        let back = isokit_io::read_exr(&path).unwrap();
        f.gbuffer.matches_exr(&back).unwrap();
        // The check can fail: one changed value in memory is found.
        let mut pixels = f.gbuffer.pixels().to_vec();
        let hit = pixels.iter().position(|p| p.is_hit()).unwrap();
        pixels[hit].k2 += 1.0;
        let changed = isokit_render::GBuffer::new(20, 12, pixels, f.gbuffer.samples().to_vec());
        let e = changed.matches_exr(&back).unwrap_err();
        assert!(e.contains("channel K2"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// Absurd image sizes and options are refused by both twins, never a panic; so are a cache
/// of no brick ([`BrickCache::new`] on the CPU, [`GpuRenderer::set_cache_bricks`] on the
/// GPU), shading a G-buffer that does not match its uniforms and a negative curvature
/// scale. (An orthographic or single-view multi-view display: in
/// [`multiview_subpixels_equal_their_views`].)
///
/// [`GpuRenderer::set_cache_bricks`]: isokit_render::gpu::GpuRenderer::set_cache_bricks
#[test]
fn absurd_sizes_and_options_are_refused() {
    let v = volume(sphere_grid(16));
    for mut t in twins("absurd_sizes_and_options_are_refused") {
        let cam = perspective(Vec3::Z * 3.0, 100_000, 100_000);
        let e = t.render(&v, &cam, &RenderOptions::default()).unwrap_err();
        assert!(matches!(e, RenderError::ImageSize { .. }), "{t}: {e}");
        let cam = perspective(Vec3::Z * 3.0, 8, 8);
        for opts in [
            RenderOptions {
                r0: 0.0,
                ..Default::default()
            },
            RenderOptions {
                r0: f32::NAN,
                ..Default::default()
            },
            RenderOptions {
                fine: 0,
                ..Default::default()
            },
            RenderOptions {
                refine_steps: 1000,
                ..Default::default()
            },
            RenderOptions {
                iso: f32::INFINITY,
                ..Default::default()
            },
            RenderOptions {
                delta: Some(-1.0),
                ..Default::default()
            },
            RenderOptions {
                gradient_scale: 0.0,
                ..Default::default()
            },
        ] {
            assert!(t.render(&v, &cam, &opts).is_err(), "{t}: {opts:?}");
        }
        match &mut t {
            Twin::Cpu(_) => assert!(BrickCache::new(&v, 0).is_err()),
            Twin::Gpu(g) => assert!(g.set_cache_bricks(0).is_err()),
        }
        // Shading refuses a G-buffer that does not match its uniforms, and bad settings.
        let v24 = volume(sphere_grid(24));
        let cam = perspective(Vec3::Z * 3.0, 16, 16);
        let f = t.render(&v24, &cam, &RenderOptions::default()).unwrap();
        let mut u = f.uniforms;
        u.width = 17;
        assert!(t.shade(&f.gbuffer, &u, &Shading::default()).is_err(), "{t}");
        let sh = Shading {
            curvature_scale: -1.0,
            ..Default::default()
        };
        assert!(t.shade(&f.gbuffer, &f.uniforms, &sh).is_err(), "{t}");
    }
}

/// The DDA's segments tile each ray's part in the volume without gaps or overlaps, in
/// order, each inside its block; checked through a walk that mirrors `trace_pixel`'s.
/// CPU-only: `kernel::` functions.
#[test]
fn dda_segments_tile_the_ray() {
    let v = Volume::from_grid(grid_of(37, |p| p.x), Layout { block: 4, brick: 8 }).unwrap();
    let u = uniforms(
        &v,
        &perspective(Vec3::Z * 3.0, 4, 4),
        &RenderOptions::default(),
    )
    .unwrap();
    let mut rng = SplitMix64::new(3);
    for trial in 0..3000 {
        let o = rng.point_in(Vec3::splat(-20.0), Vec3::splat(56.0));
        let mut d = rng.unit_vector();
        if trial % 5 == 0 {
            d = Vec3::new(d.x, 0.0, 0.0).normalize_or(Vec3::X); // along an axis
        }
        let Some((t0, t1, _)) = kernel::ray_box(&u, o, d) else {
            continue;
        };
        let bd = glam::IVec3::new(9, 9, 9);
        let mut cell = ((o + t0 * d) / 4.0)
            .floor()
            .as_ivec3()
            .clamp(glam::IVec3::ZERO, bd - 1);
        let mut t_in = t0;
        let mut covered = 0.0f32;
        loop {
            let (t_out, axis) = kernel::block_exit(&u, cell, o, d);
            let te = t_out.min(t1);
            if te > t_in {
                let mid = o + 0.5 * (t_in + te) * d;
                let lo = cell.as_vec3() * 4.0 - 1e-3;
                let hi = lo + 4.0 + 2e-3;
                assert!(
                    mid.cmpge(lo).all() && mid.cmple(hi).all(),
                    "{mid} not in {cell}"
                );
                covered += te - t_in;
            }
            if te >= t1 {
                break;
            }
            cell[axis] += if d[axis] > 0.0 { 1 } else { -1 };
            if cell[axis] < 0 || cell[axis] >= 9 {
                break;
            }
            t_in = te.max(t_in);
        }
        assert!(
            (covered - (t1 - t0)).abs() < 1e-3 * (1.0 + t1 - t0),
            "{covered} vs {}",
            t1 - t0
        );
    }
}

/// Shading on both twins (each shading its own frame): every mode gives finite colours and
/// the background where nothing was hit; the lit side is brighter; the curvature maps read a
/// sphere as convex; contours appear near the silhouette only and grow with the thickness.
/// The colour thresholds are the same on both twins: they are coarse (a twentieth of the
/// range and more) against the GPU's documented shading agreement of 1e-5 per linear
/// channel ([`raycast_tol::SHADE_LINEAR`]; `reflection`, looser, is only checked finite).
#[test]
fn shading_modes() {
    let v = volume(sphere_grid(40));
    let cam = perspective(Vec3::Z * 3.0, 32, 32);
    for mut t in twins("shading_modes") {
        let f = t.render(&v, &cam, &RenderOptions::default()).unwrap();
        let centre = 16 + 32 * 16;
        for (name, mode) in ShadingMode::ALL {
            let sh = Shading {
                mode,
                curvature_scale: 2.0,
                ..Default::default()
            };
            let img = t.shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            assert_eq!(img.pixels[0], sh.background, "{t}: {name}");
            assert!(
                img.pixels.iter().flatten().all(|c| c.is_finite()),
                "{t}: {name}"
            );
            let c = img.pixels[centre];
            match mode {
                ShadingMode::Normal => {
                    assert!(c[2] > 0.95 && (c[0] - 0.5).abs() < 0.05, "{t}: {c:?}")
                }
                ShadingMode::Mean | ShadingMode::K1 | ShadingMode::K2 | ShadingMode::Gaussian => {
                    assert!(
                        c[0] > c[2],
                        "{t}: {name}: a convex sphere maps warm, got {c:?}"
                    )
                }
                ShadingMode::Curvature => {
                    assert!(c[0] > c[1] && c[0] > c[2], "{t}: {name}: {c:?}")
                }
                _ => {}
            }
        }
        // Phong with the default key light (above left): the upper left is brighter.
        let img = t
            .shade(&f.gbuffer, &f.uniforms, &Shading::default())
            .unwrap();
        let lum = |x: usize, y: usize| img.pixels[x + 32 * y][1];
        assert!(lum(11, 11) > lum(21, 21), "{t}");
        // Contours appear near the silhouette only, and grow with the thickness.
        let dark = |px: f32| {
            let sh = Shading {
                mode: ShadingMode::Silhouette,
                contour_pixels: px,
                ..Default::default()
            };
            let img = t.shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            assert!(img.pixels[centre][0] > 0.1, "{t}");
            img.pixels.iter().filter(|c| c[0] < 0.05).count()
        };
        let (thin, thick) = (dark(1.0), dark(3.0));
        assert!(thin > 0 && thick > thin, "{t}: {thin} {thick}");
    }
    assert!(
        Shading {
            curvature_scale: 0.0,
            ..Default::default()
        }
        .check()
        .is_err()
    );
}

/// A G-buffer compares equal only to itself: the equality the tests above rely on sees a
/// one-ulp change. CPU-only: about `GBuffer`'s equality, whichever twin made it.
#[test]
fn gbuffer_equality_is_exact() {
    let v = volume(sphere_grid(24));
    let f = frame(
        &v,
        &perspective(Vec3::Z * 3.0, 8, 8),
        &RenderOptions::default(),
    );
    let mut px = f.gbuffer.pixels().to_vec();
    let i = px.iter().position(|s| s.is_hit()).unwrap();
    px[i].depth = f32::from_bits(px[i].depth.to_bits() + 1);
    let other = GBuffer::new(8, 8, px, f.gbuffer.samples().to_vec());
    assert_ne!(other, f.gbuffer);
}

/// A ray that reaches a brick which is not resident asks for it once (the request buffer
/// the GPU twin mirrors) and waits at its first block; the uniforms keep their WGSL size.
/// CPU-only: `kernel::trace_pixel` on the CPU's trace data.
#[test]
fn trace_data_is_flat() {
    let v = volume(sphere_grid(16));
    let cache = BrickCache::for_volume(&v);
    let req: Vec<AtomicU32> = (0..v.brick_count()).map(|_| AtomicU32::new(0)).collect();
    let used: Vec<AtomicU32> = (0..v.brick_count()).map(|_| AtomicU32::new(0)).collect();
    let data = TraceData {
        pool: cache.pool(),
        reference: cache.reference(),
        block_range: v.block_ranges(),
        block_info: &[],
        requests: &req,
        used: &used,
        start: None,
    };
    let u = uniforms(
        &v,
        &perspective(Vec3::Z * 3.0, 8, 8),
        &RenderOptions::default(),
    )
    .unwrap();
    // Nothing resident: the centre ray asks for its brick and waits.
    match kernel::trace_pixel(&u, &data, 4, 4, 0, None) {
        kernel::PixelResult::Suspended { resume, .. } => assert!(resume.first),
        r => panic!("{r:?}"),
    }
    assert_eq!(
        req.iter()
            .map(|r| r.load(std::sync::atomic::Ordering::Relaxed))
            .sum::<u32>(),
        1
    );
    assert_eq!(std::mem::size_of::<isokit_render::Uniforms>(), 208);
}

/// 001, on both twins: in the multi-view geometric pass every subpixel equals that view
/// rendered alone, in the G-buffer and in the shaded channel (exact on both: the same
/// subpixel ray in the same kernel); the views differ (parallax); and the work, one ray per
/// subpixel, does not grow with the number of views. An orthographic camera and a single
/// view are refused.
#[test]
fn multiview_subpixels_equal_their_views() {
    use isokit_render::MultiView;
    let v = volume(two_spheres());
    let cam = perspective(Vec3::new(0.3, 0.8, 2.8), 24, 16);
    let opts = RenderOptions::default();
    let sh = Shading::default();
    for mut t in twins("multiview_subpixels_equal_their_views") {
        let mut rays = Vec::new();
        for (views, slant) in [(5, 0.0), (8, 1.0 / 3.0), (16, 0.25)] {
            let mv = MultiView {
                slant,
                ..MultiView::new(views, 0.06)
            };
            let f = t.render_multiview(&v, &cam, &opts, &mv).unwrap();
            assert_eq!((f.gbuffer.width(), f.gbuffer.height()), (72, 16), "{t}");
            let img = t.shade(&f.gbuffer, &f.uniforms, &sh).unwrap();
            let alone: Vec<_> = (0..views)
                .map(|k| {
                    let fr = t.render_view(&v, &cam, &opts, &mv, k).unwrap();
                    let im = t.shade(&fr.gbuffer, &fr.uniforms, &sh).unwrap();
                    (fr, im)
                })
                .collect();
            let mut seen = vec![false; views as usize];
            for y in 0..16 {
                for x in 0..24 {
                    for c in 0..3 {
                        let k = kernel::view_index(&f.uniforms, x, y, c) as usize;
                        seen[k] = true;
                        let (fr, im) = &alone[k];
                        assert_eq!(
                            f.gbuffer.get(3 * x + c, y),
                            fr.gbuffer.get(x, y),
                            "{t}: {views} views, ({x}, {y}) subpixel {c}"
                        );
                        let i = (x + 24 * y) as usize;
                        assert_eq!(img.pixels[i][c as usize], im.pixels[i][c as usize], "{t}");
                    }
                }
            }
            assert!(seen.iter().all(|&s| s), "{t}: {views} views: not all used");
            assert_ne!(
                alone[0].0.gbuffer,
                alone[views as usize - 1].0.gbuffer,
                "{t}"
            );
            rays.push(f.gbuffer.pixels().len());
        }
        assert!(rays.iter().all(|&r| r == 3 * 24 * 16), "{t}");
        let ortho = orthographic(Vec3::Z * 3.0, Vec3::ZERO, 2.0, 8, 8);
        assert!(
            t.render_multiview(&v, &ortho, &opts, &MultiView::new(4, 0.1))
                .is_err(),
            "{t}"
        );
        assert!(
            t.render_multiview(&v, &cam, &opts, &MultiView::new(1, 0.1))
                .is_err(),
            "{t}"
        );
    }
}
