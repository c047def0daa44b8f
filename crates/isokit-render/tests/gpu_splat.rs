//! The GPU twin of quadric splatting and of its shading against the CPU twin (on lavapipe
//! in CI): G-buffers, shadow maps and shaded images on several scenes (overlapping
//! spheres; a cylinder, a cone and an ellipsoid; a sphere cut by the near plane; an
//! orthographic camera; a few hundred random spheres; all kinds at random). On failure the
//! images and their differences are written to `$CARGO_TARGET_TMPDIR/gpu_splat/<test>/`.
//! Skips with a printed reason where no adapter exists, fails instead when
//! `ISOKIT_REQUIRE_GPU=1`.
//!
//! This is the claim that the twins agree, scene by scene; that each twin is right (against
//! analytic intersections, curvatures, shadows, outlines) is the claim of the conformance
//! suite `splat.rs`, whose reference checks run on both twins with the tolerances below
//! (`common::twin::splat_tol`, one definition for both).
//!
//! What "agree" means (why not bit for bit: see `isokit_render::gpu::splat`):
//! - **hit mask**: equal except at most [`MASK_PX`] pixels per scene, each on the edge of
//!   the CPU's mask (a ray grazing a silhouette, where the discriminant's rounding decides);
//! - where both hit: the same object except at most [`OBJECT_PX`] pixels (two surfaces
//!   within rounding of each other along the ray); where the objects agree the same id,
//!   `Z` within [`DEPTH_REL`] relative, normals within [`NORMAL_RAD`], `k1` and `k2`
//!   within [`K_REL`] of the pixel's largest `|k|`, `dir1` within [`DIR1_RAD`] (up to sign)
//!   where `k1 − k2` exceeds a tenth of it (elsewhere the direction is ill-conditioned);
//! - shadow maps: the same finite mask except [`MASK_PX`] texels, depths within
//!   [`DEPTH_REL`] relative where both are finite;
//! - shaded images (linear RGBA, Phong, shadows and outlines on): mean absolute difference
//!   per channel below [`IMAGE_MEAN`], and at most [`IMAGE_PX`] pixels with a channel
//!   differing by more than [`IMAGE_MAX`] (a shadow sample or outline weight flipped by
//!   rounding).
//!
//! Measured on lavapipe (Mesa 22.3.6, LLVM 15, Vulkan) over these scenes (each test prints
//! its measurements; run with `--nocapture`): hit masks, objects and ids identical; depths,
//! positions and normals bit for bit (lavapipe contracts no multiply-adds here); `k1`, `k2`
//! within 7.5e-7 of the largest `|k|` and `dir1` within 3.4e-6 rad (the curvature is f32 on
//! the GPU, f64 on the CPU); shadow maps bit for bit; shaded images within a mean of
//! 2.2e-8 and a largest channel difference of 3.6e-5 (bilinear fetches) or 6.9e-7 (2x2
//! loads). The tolerances above leave room for hardware GPUs, whose fused multiply-adds and
//! looser `sqrt`, division and trigonometry move grazing pixels and the last bits.

use glam::{DMat3, DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_field::{Camera, Projection};
use isokit_gpu::testing;
use isokit_gpu::{Gpu, GpuError, GpuOptions, wgpu};
use isokit_render::gpu::GpuRenderer;
use isokit_render::quadric::Quadric;
use isokit_render::splat::{
    self, OutlineOptions, ShadowMap, ShadowOptions, SplatFrame, SplatOptions, SplatScene,
    SplatShading,
};
use isokit_render::{GSample, Image};
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, OnceLock};

mod common;
// The tolerances, one definition shared with the conformance suite `splat.rs`.
use common::twin::splat_tol::{
    DEPTH_REL, DIR1_RAD, IMAGE_MAX, IMAGE_MEAN, IMAGE_PX, K_REL, MASK_PX, NORMAL_RAD, OBJECT_PX,
};

// ---------------------------------------------------------------------------------------
// Renderers: one opened as `GpuRenderer::open` does (bilinear outline fetches where the
// adapter has FLOAT32_FILTERABLE), one on a device without extra features (2x2 loads).
// ---------------------------------------------------------------------------------------

static PLAIN: OnceLock<Result<Mutex<GpuRenderer>, String>> = OnceLock::new();
static FILTERED: OnceLock<Option<Mutex<GpuRenderer>>> = OnceLock::new();

fn lock(m: &Mutex<GpuRenderer>) -> MutexGuard<'_, GpuRenderer> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The renderer on a device without extra features, opened once (the error, once).
fn plain_slot() -> &'static Result<Mutex<GpuRenderer>, String> {
    PLAIN.get_or_init(|| {
        Gpu::new(&GpuOptions::default())
            .map(|g| Mutex::new(GpuRenderer::new(g).expect("kernels compile")))
            .map_err(|e| e.to_string())
    })
}

/// The renderer on a device without extra features (outline fetches from 2x2 loads).
fn plain(test: &str) -> Option<MutexGuard<'static, GpuRenderer>> {
    match plain_slot() {
        Ok(m) => {
            let r = lock(m);
            testing::ran(test, &r.describe());
            Some(r)
        }
        Err(reason) => {
            testing::skipped(test, reason);
            None
        }
    }
}

/// The renderer with FLOAT32_FILTERABLE (bilinear outline fetches), or the plain one where
/// the adapter lacks the feature (printed).
fn renderer(test: &str) -> Option<MutexGuard<'static, GpuRenderer>> {
    if plain_slot().is_err() {
        return plain(test);
    }
    let slot = FILTERED.get_or_init(|| {
        let opts = GpuOptions {
            features: wgpu::Features::FLOAT32_FILTERABLE,
            ..GpuOptions::default()
        };
        match Gpu::new(&opts) {
            Ok(g) => Some(Mutex::new(GpuRenderer::new(g).expect("kernels compile"))),
            Err(GpuError::MissingFeatures { .. }) => {
                eprintln!("{test}: the adapter lacks FLOAT32_FILTERABLE: 2x2 loads only");
                None
            }
            Err(e) => panic!("{test}: {e}"),
        }
    });
    match slot {
        Some(m) => {
            let r = lock(m);
            testing::ran(test, &r.describe());
            Some(r)
        }
        None => plain(test),
    }
}

// ---------------------------------------------------------------------------------------
// Scenes.
// ---------------------------------------------------------------------------------------

fn camera(eye: Vec3, target: Vec3, w: u32, h: u32, fov: f32) -> Camera {
    Camera::look_at(
        eye,
        target,
        Vec3::Y,
        Projection::Perspective { fov_y_degrees: fov },
        w,
        h,
    )
    .unwrap()
}

fn overlapping_spheres() -> SplatScene {
    let mut s = SplatScene::default();
    let balls = [
        (DVec3::new(-0.4, 0.0, 0.0), 0.7, Vec3::new(0.9, 0.2, 0.2)),
        (DVec3::new(0.45, 0.1, 0.2), 0.6, Vec3::new(0.2, 0.8, 0.2)),
        (DVec3::new(0.0, 0.6, -0.3), 0.5, Vec3::new(0.2, 0.3, 0.9)),
        (DVec3::new(0.1, -0.5, 0.4), 0.4, Vec3::new(0.9, 0.8, 0.1)),
        // Two coincident-centre spheres: the bigger one hides the smaller.
        (DVec3::new(0.9, -0.4, -0.4), 0.3, Vec3::ONE),
        (DVec3::new(0.9, -0.4, -0.4), 0.2, Vec3::ZERO),
    ];
    for (c, r, col) in balls {
        s.push(Quadric::sphere(c, r).unwrap(), col);
    }
    s
}

fn cylinder_cone_ellipsoid() -> SplatScene {
    let mut s = SplatScene::default();
    s.push(
        Quadric::cylinder(DVec3::new(-1.2, -0.3, 0.0), DVec3::new(0.4, 0.5, -0.3), 0.3).unwrap(),
        Vec3::new(0.8, 0.3, 0.2),
    );
    s.push(
        Quadric::cone(
            DVec3::new(0.2, -0.8, 0.3),
            0.45,
            DVec3::new(0.9, 0.7, 0.1),
            0.1,
        )
        .unwrap(),
        Vec3::new(0.2, 0.7, 0.3),
    );
    s.push(
        Quadric::cone(
            DVec3::new(-0.6, 0.4, 0.5),
            0.0,
            DVec3::new(-0.3, 1.0, -0.2),
            0.3,
        )
        .unwrap(),
        Vec3::new(0.9, 0.9, 0.2),
    );
    s.push(
        Quadric::ellipsoid(
            DVec3::new(0.1, 0.1, -0.6),
            DVec3::new(0.9, 0.35, 0.5),
            DMat3::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, -0.2),
        )
        .unwrap(),
        Vec3::new(0.3, 0.4, 0.9),
    );
    s
}

fn ground_and_balls() -> SplatScene {
    let mut s = SplatScene::default();
    s.push(
        Quadric::ellipsoid(
            DVec3::new(0.0, -1.0, 0.0),
            DVec3::new(3.0, 0.05, 3.0),
            DMat3::IDENTITY,
        )
        .unwrap(),
        Vec3::splat(0.8),
    );
    s.push(
        Quadric::sphere(DVec3::ZERO, 0.5).unwrap(),
        Vec3::new(0.8, 0.1, 0.1),
    );
    s.push(
        Quadric::cylinder(DVec3::new(0.9, -0.95, 0.3), DVec3::new(0.9, 0.2, 0.3), 0.2).unwrap(),
        Vec3::new(0.1, 0.5, 0.8),
    );
    s
}

fn random_spheres(n: usize, seed: u64) -> SplatScene {
    let mut rng = SplitMix64::new(seed);
    let mut s = SplatScene::default();
    for _ in 0..n {
        let c = DVec3::new(
            rng.next_f64() - 0.5,
            rng.next_f64() - 0.5,
            rng.next_f64() - 0.5,
        ) * 3.0;
        let r = 0.05 + 0.2 * rng.next_f64();
        let col = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        s.push(Quadric::sphere(c, r).unwrap(), col);
    }
    s
}

fn random_quadrics(n: usize, seed: u64) -> SplatScene {
    let mut rng = SplitMix64::new(seed);
    let mut s = SplatScene::default();
    for _ in 0..n {
        let mut r = || rng.next_f64();
        let c = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 2.5;
        let dir = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize_or(DVec3::X);
        let len = 0.1 + 0.4 * r();
        let q = match (r() * 4.0) as u32 {
            0 => Quadric::sphere(c, 0.1 + 0.3 * r()).unwrap(),
            1 => {
                let rot = DMat3::from_axis_angle(dir, r() * 6.0);
                let radii = DVec3::new(0.1 + 0.3 * r(), 0.1 + 0.3 * r(), 0.1 + 0.3 * r());
                Quadric::ellipsoid(c, radii, rot).unwrap()
            }
            2 => Quadric::cylinder(c - dir * len, c + dir * len, 0.05 + 0.2 * r()).unwrap(),
            _ => {
                let r0 = if r() < 0.5 { 0.0 } else { 0.1 * r() };
                Quadric::cone(c - dir * len, r0, c + dir * len, 0.1 + 0.2 * r()).unwrap()
            }
        };
        let col = Vec3::new(r() as f32, r() as f32, r() as f32);
        s.push(q, col);
    }
    s
}

// ---------------------------------------------------------------------------------------
// Comparisons.
// ---------------------------------------------------------------------------------------

/// Accurate angle between two vectors (atan2 of |a × b| and a · b).
fn angle(a: Vec3, b: Vec3) -> f32 {
    a.cross(b).length().atan2(a.dot(b))
}

#[derive(Debug, Default)]
struct GDiff {
    both: usize,
    mask: usize,
    mask_off_edge: usize,
    object: usize,
    id: usize,
    depth_rel: f32,
    position_rel: f32,
    normal_rad: f32,
    k_rel: f32,
    dir1_rad: f32,
    dir1_checked: usize,
}

fn compare_gbuffers(cpu: &SplatFrame, gpu: &SplatFrame) -> GDiff {
    let (a, b) = (&cpu.gbuffer, &gpu.gbuffer);
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    let (w, h) = (a.width(), a.height());
    let mut d = GDiff::default();
    let on_edge = |x: u32, y: u32| {
        let hit = a.get(x, y).is_hit();
        (-1i64..=1).any(|dy| {
            (-1i64..=1).any(|dx| {
                let (xx, yy) = (i64::from(x) + dx, i64::from(y) + dy);
                xx >= 0
                    && yy >= 0
                    && xx < i64::from(w)
                    && yy < i64::from(h)
                    && a.get(xx as u32, yy as u32).is_hit() != hit
            })
        })
    };
    for y in 0..h {
        for x in 0..w {
            let i = (x + w * y) as usize;
            let (p, q): (&GSample, &GSample) = (a.get(x, y), b.get(x, y));
            if p.is_hit() != q.is_hit() {
                d.mask += 1;
                if !on_edge(x, y) {
                    d.mask_off_edge += 1;
                }
                continue;
            }
            if !p.is_hit() {
                assert_eq!(gpu.objects[i], splat::NO_OBJECT);
                continue;
            }
            d.both += 1;
            if cpu.objects[i] != gpu.objects[i] {
                d.object += 1;
                continue;
            }
            if p.id != q.id {
                d.id += 1;
                continue;
            }
            d.depth_rel = d
                .depth_rel
                .max((p.depth - q.depth).abs() / p.depth.abs().max(1e-30));
            let scale = p.position.length().max(p.depth);
            d.position_rel = d.position_rel.max(p.position.distance(q.position) / scale);
            d.normal_rad = d.normal_rad.max(angle(p.normal, q.normal));
            let kmax = p.k1.abs().max(p.k2.abs());
            if kmax > 0.0 {
                let e = (p.k1 - q.k1).abs().max((p.k2 - q.k2).abs()) / kmax;
                d.k_rel = d.k_rel.max(e);
                if p.k1 - p.k2 > 0.1 * kmax {
                    d.dir1_checked += 1;
                    let e = angle(p.dir1, q.dir1).min(angle(p.dir1, -q.dir1));
                    d.dir1_rad = d.dir1_rad.max(e);
                }
            } else {
                d.k_rel = d.k_rel.max(q.k1.abs().max(q.k2.abs()));
            }
        }
    }
    d
}

fn slug(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("gpu_splat")
        .join(slug(name));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes the hit masks of a failed G-buffer comparison; returns the folder.
fn write_mask_diff(name: &str, cpu: &SplatFrame, gpu: &SplatFrame) -> PathBuf {
    let dir = out_dir(name);
    let (a, b) = (&cpu.gbuffer, &gpu.gbuffer);
    let mut mask = Vec::new();
    for (i, (p, q)) in a.pixels().iter().zip(b.pixels()).enumerate() {
        // White: both hit the same object; yellow: different objects; red: CPU only;
        // blue: GPU only; black: neither.
        let m = match (p.is_hit(), q.is_hit()) {
            (true, true) if cpu.objects[i] == gpu.objects[i] => [255, 255, 255, 255],
            (true, true) => [255, 255, 0, 255],
            (true, false) => [255, 0, 0, 255],
            (false, true) => [0, 0, 255, 255],
            (false, false) => [0, 0, 0, 255],
        };
        mask.extend(m);
    }
    isokit_io::write_png(&dir.join("mask.png"), a.width(), a.height(), &mask).unwrap();
    dir
}

/// Splats `scene` on both twins and checks the G-buffers.
fn check_splat(
    r: &GpuRenderer,
    name: &str,
    scene: &SplatScene,
    cam: &Camera,
    opts: &SplatOptions,
) -> (SplatFrame, SplatFrame) {
    // The CPU evaluates every fragment here, as the GPU does, so the counts compare.
    let exhaustive = SplatOptions {
        exhaustive: true,
        ..*opts
    };
    let cpu = splat::splat(scene, cam, &exhaustive).unwrap();
    let gpu = r.splat(scene, cam, opts).unwrap();
    let d = compare_gbuffers(&cpu, &gpu);
    eprintln!("{name}: {d:?}");
    eprintln!("{name}: cpu {:?}\n{name}: gpu {:?}", cpu.stats, gpu.stats);
    assert_eq!(cpu.stats.drawn, gpu.stats.drawn);
    assert_eq!(cpu.stats.fragments, gpu.stats.fragments);
    // The GPU counts its hits in the fragment shader (lavapipe can; an adapter without
    // storage writes from fragment shaders reports 0).
    assert!(
        gpu.stats.hits == cpu.stats.hits || (gpu.stats.hits == 0 && !r.is_software()),
        "hits: cpu {} gpu {}",
        cpu.stats.hits,
        gpu.stats.hits
    );
    assert_eq!(cpu.view, gpu.view);
    assert_eq!(cpu.uniforms, gpu.uniforms);
    let ok = d.mask <= MASK_PX
        && d.mask_off_edge == 0
        && d.object <= OBJECT_PX
        && d.id == 0
        && d.depth_rel <= DEPTH_REL
        && d.position_rel <= DEPTH_REL
        && d.normal_rad <= NORMAL_RAD
        && d.k_rel <= K_REL
        && d.dir1_rad <= DIR1_RAD;
    if !ok {
        let dir = write_mask_diff(name, &cpu, &gpu);
        panic!(
            "{name}: the twins differ: {d:?}; masks in {}",
            dir.display()
        );
    }
    assert!(d.both > 100, "{name}: only {} pixels hit", d.both);
    (cpu, gpu)
}

fn to_rgba8(img: &Image) -> Vec<u8> {
    img.to_rgba8()
}

/// Compares two shaded images; on failure writes both and their difference.
fn check_images(name: &str, cpu: &Image, gpu: &Image) {
    assert_eq!((cpu.width, cpu.height), (gpu.width, gpu.height));
    let mut sum = 0.0f64;
    let mut max = 0.0f32;
    let mut over = 0;
    let mut diff = Vec::with_capacity(cpu.pixels.len() * 4);
    for (p, q) in cpu.pixels.iter().zip(&gpu.pixels) {
        let e = (0..4).map(|c| (p[c] - q[c]).abs()).fold(0.0f32, f32::max);
        sum += (0..4).map(|c| f64::from((p[c] - q[c]).abs())).sum::<f64>();
        max = max.max(e);
        over += usize::from(e > IMAGE_MAX);
        let v = ((e / IMAGE_MAX).sqrt() * 255.0).min(255.0) as u8;
        diff.extend([v, v, v, 255]);
    }
    let mean = sum / (4 * cpu.pixels.len()) as f64;
    eprintln!("{name}: image mean |Δ| {mean:.3e}, max {max:.3e}, {over} pixels over {IMAGE_MAX}");
    if !(mean < IMAGE_MEAN && over <= IMAGE_PX) {
        let dir = out_dir(name);
        isokit_io::write_png(&dir.join("cpu.png"), cpu.width, cpu.height, &to_rgba8(cpu)).unwrap();
        isokit_io::write_png(&dir.join("gpu.png"), gpu.width, gpu.height, &to_rgba8(gpu)).unwrap();
        isokit_io::write_png(&dir.join("diff.png"), cpu.width, cpu.height, &diff).unwrap();
        panic!(
            "{name}: shaded images differ: mean {mean:.3e}, max {max:.3e}, {over} pixels over {IMAGE_MAX}; images in {}",
            dir.display()
        );
    }
}

fn check_shadow_maps(name: &str, cpu: &ShadowMap, gpu: &ShadowMap) {
    assert_eq!(cpu.params, gpu.params);
    assert_eq!(cpu.light, gpu.light);
    assert_eq!(cpu.depth.len(), gpu.depth.len());
    let mut mask = 0;
    let mut finite = 0;
    let mut rel = 0.0f32;
    for (a, b) in cpu.depth.iter().zip(&gpu.depth) {
        assert!(!a.is_nan() && !b.is_nan());
        match (a.is_finite(), b.is_finite()) {
            (true, true) => {
                finite += 1;
                rel = rel.max((a - b).abs() / a.abs());
            }
            (false, false) => assert_eq!(a, b),
            _ => mask += 1,
        }
    }
    eprintln!(
        "{name}: shadow map: {finite} texels hit, {mask} differ in mask, depth rel {rel:.3e}"
    );
    assert!(
        mask <= MASK_PX && rel <= DEPTH_REL,
        "{name}: shadow maps differ"
    );
    assert!(finite > 100, "{name}: {finite}");
}

fn shading() -> SplatShading {
    SplatShading {
        shadows: Some(ShadowOptions {
            resolution: 512,
            softness: 3.0,
            light: None,
        }),
        outlines: Some(OutlineOptions::default()),
        ..Default::default()
    }
}

/// Shades the CPU's frame on both twins and compares.
fn check_shading(
    r: &GpuRenderer,
    name: &str,
    frame: &SplatFrame,
    scene: &SplatScene,
    opts: &SplatShading,
) {
    let (ci, cs) = splat::shade_splat(frame, scene, opts).unwrap();
    let (gi, gs) = r.shade_splat(frame, scene, opts).unwrap();
    eprintln!("{name}: cpu {cs:?}\n{name}: gpu {gs:?}");
    check_images(name, &ci, &gi);
    // The same decisions on (nearly) every pixel: samples taken.
    let tol = 64 * IMAGE_PX as u64;
    assert!(
        cs.shadow_samples.abs_diff(gs.shadow_samples) <= tol,
        "{cs:?} {gs:?}"
    );
    assert!(
        cs.penumbra_pixels.abs_diff(gs.penumbra_pixels) <= IMAGE_PX as u64,
        "{cs:?} {gs:?}"
    );
}

// ---------------------------------------------------------------------------------------
// Tests.
// ---------------------------------------------------------------------------------------

#[test]
fn overlapping_spheres_match_the_cpu() {
    let name = "overlapping_spheres_match_the_cpu";
    let Some(r) = renderer(name) else { return };
    let scene = overlapping_spheres();
    let cam = camera(Vec3::new(0.5, 0.8, 4.0), Vec3::ZERO, 160, 120, 40.0);
    let (cpu, _) = check_splat(&r, name, &scene, &cam, &SplatOptions::default());
    check_shading(&r, name, &cpu, &scene, &shading());
}

#[test]
fn cylinder_cone_and_ellipsoid_match_the_cpu() {
    let name = "cylinder_cone_and_ellipsoid_match_the_cpu";
    let Some(r) = renderer(name) else { return };
    let scene = cylinder_cone_ellipsoid();
    let cam = camera(Vec3::new(-0.8, 1.2, 3.5), Vec3::ZERO, 160, 128, 45.0);
    let (cpu, _) = check_splat(&r, name, &scene, &cam, &SplatOptions::default());
    check_shading(&r, name, &cpu, &scene, &shading());
}

#[test]
fn a_sphere_cut_by_the_near_plane_matches_the_cpu() {
    let name = "a_sphere_cut_by_the_near_plane_matches_the_cpu";
    let Some(r) = renderer(name) else { return };
    let mut scene = SplatScene::default();
    scene.push(
        Quadric::sphere(DVec3::ZERO, 1.0).unwrap(),
        Vec3::new(0.8, 0.5, 0.2),
    );
    scene.push(
        Quadric::sphere(DVec3::new(0.8, 0.3, -1.5), 0.7).unwrap(),
        Vec3::new(0.2, 0.5, 0.8),
    );
    let cam = camera(Vec3::new(0.3, 0.2, 3.0), Vec3::ZERO, 128, 96, 50.0);
    let opts = SplatOptions {
        near: Some(2.6),
        ..Default::default()
    };
    let (cpu, gpu) = check_splat(&r, name, &scene, &cam, &opts);
    let cuts = cpu
        .gbuffer
        .pixels()
        .iter()
        .filter(|p| p.is_hit() && p.k1 == 0.0)
        .count();
    assert!(cuts > 500, "{cuts} pixels on the cut");
    assert_eq!(
        cuts,
        gpu.gbuffer
            .pixels()
            .iter()
            .filter(|p| p.is_hit() && p.k1 == 0.0)
            .count()
    );
    check_shading(&r, name, &cpu, &scene, &shading());
}

#[test]
fn an_orthographic_camera_matches_the_cpu() {
    let name = "an_orthographic_camera_matches_the_cpu";
    let Some(r) = renderer(name) else { return };
    let scene = cylinder_cone_ellipsoid();
    let cam = Camera::look_at(
        Vec3::new(1.0, 2.0, 5.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { height: 3.0 },
        144,
        112,
    )
    .unwrap();
    let (cpu, _) = check_splat(&r, name, &scene, &cam, &SplatOptions::default());
    check_shading(&r, name, &cpu, &scene, &shading());
    // The near plane of an orthographic view, through the scene.
    let opts = SplatOptions {
        near: Some(5.3),
        ..Default::default()
    };
    check_splat(&r, &format!("{name} (near cut)"), &scene, &cam, &opts);
}

#[test]
fn hundreds_of_random_spheres_match_the_cpu_in_any_chunks() {
    let name = "hundreds_of_random_spheres_match_the_cpu_in_any_chunks";
    let Some(r) = renderer(name) else { return };
    let scene = random_spheres(400, 17);
    let cam = camera(Vec3::new(0.4, 1.5, 6.0), Vec3::ZERO, 200, 150, 45.0);
    let (cpu, gpu) = check_splat(&r, name, &scene, &cam, &SplatOptions::default());
    // Drawn in chunks of 7 set-ups, the depth buffer persisting: the same frame.
    let chunked = r
        .splat_in_chunks(&scene, &cam, &SplatOptions::default(), 7)
        .unwrap();
    assert_eq!(chunked.gbuffer, gpu.gbuffer);
    assert_eq!(chunked.objects, gpu.objects);
    assert_eq!(chunked.stats.hits, gpu.stats.hits);
    check_shading(&r, name, &cpu, &scene, &shading());
}

#[test]
fn random_quadrics_of_every_kind_match_the_cpu() {
    let name = "random_quadrics_of_every_kind_match_the_cpu";
    let Some(r) = renderer(name) else { return };
    let scene = random_quadrics(120, 5);
    let cam = camera(Vec3::new(-1.0, 1.0, 5.0), Vec3::ZERO, 200, 150, 45.0);
    let (cpu, _) = check_splat(&r, name, &scene, &cam, &SplatOptions::default());
    check_shading(&r, name, &cpu, &scene, &shading());
}

#[test]
fn shadow_maps_match_the_cpu() {
    let name = "shadow_maps_match_the_cpu";
    let Some(r) = renderer(name) else { return };
    for (label, scene, light) in [
        ("ground", ground_and_balls(), Vec3::new(0.5, 6.0, 1.0)),
        ("spheres", random_spheres(200, 3), Vec3::new(5.0, 4.0, 3.0)),
        (
            "quadrics",
            random_quadrics(60, 9),
            Vec3::new(-3.0, 5.0, 4.0),
        ),
    ] {
        for res in [256, 300] {
            let opts = ShadowOptions {
                resolution: res,
                softness: 3.0,
                light: Some(light),
            };
            let cpu = ShadowMap::render(&scene, light, &opts).unwrap();
            let gpu = r.shadow_map(&scene, light, &opts).unwrap();
            check_shadow_maps(&format!("{name} {label} {res}"), &cpu, &gpu);
        }
    }
    // Bad options are refused as on the CPU.
    let scene = ground_and_balls();
    let bad = ShadowOptions {
        resolution: 8,
        ..Default::default()
    };
    assert!(
        r.shadow_map(&scene, Vec3::new(0.0, 6.0, 0.0), &bad)
            .is_err()
    );
    assert!(
        r.shadow_map(&scene, Vec3::ZERO, &ShadowOptions::default())
            .is_err()
    );
}

#[test]
fn soft_shadows_and_outlines_match_the_cpu_with_both_fetch_routes() {
    let name = "soft_shadows_and_outlines_match_the_cpu_with_both_fetch_routes";
    let scene = ground_and_balls();
    let cam = camera(
        Vec3::new(0.0, 2.0, 5.0),
        Vec3::new(0.0, -0.5, 0.0),
        192,
        144,
        45.0,
    );
    let cpu = splat::splat(&scene, &cam, &SplatOptions::default()).unwrap();
    let opts = SplatShading {
        shadows: Some(ShadowOptions {
            resolution: 512,
            softness: 3.0,
            light: Some(Vec3::new(0.5, 6.0, 1.0)),
        }),
        outlines: Some(OutlineOptions::default()),
        ..Default::default()
    };
    {
        let Some(r) = plain(name) else { return };
        assert!(!r.splat_fetches_filtered().unwrap());
        check_shading(&r, &format!("{name} (loads)"), &cpu, &scene, &opts);
        // Shadows only, outlines only, neither, and other modes.
        for (label, o) in [
            (
                "shadows",
                SplatShading {
                    outlines: None,
                    ..opts.clone()
                },
            ),
            (
                "outlines",
                SplatShading {
                    shadows: None,
                    ..opts.clone()
                },
            ),
            ("plain", SplatShading::default()),
        ] {
            check_shading(&r, &format!("{name} (loads, {label})"), &cpu, &scene, &o);
        }
    }
    let Some(mut r) = renderer(name) else { return };
    eprintln!(
        "{name}: filtered fetches: {}",
        r.splat_fetches_filtered().unwrap()
    );
    check_shading(&r, &format!("{name} (filtered)"), &cpu, &scene, &opts);
    // Shaded in chunks of 1000 pixels: the same image (outlines read the whole frame).
    let whole = r.shade_splat(&cpu, &scene, &opts).unwrap().0;
    r.set_max_rays_per_dispatch(1000);
    let chunked = r.shade_splat(&cpu, &scene, &opts);
    r.set_max_rays_per_dispatch(isokit_render::gpu::DEFAULT_MAX_RAYS_PER_DISPATCH);
    assert_eq!(chunked.unwrap().0.pixels, whole.pixels);
    let mut tone = opts.clone();
    tone.shading.mode = isokit_render::ShadingMode::Curvature;
    check_shading(&r, &format!("{name} (curvature)"), &cpu, &scene, &tone);
    // A frame from the GPU twin shades as the CPU's.
    let gpu = r.splat(&scene, &cam, &SplatOptions::default()).unwrap();
    check_shading(&r, &format!("{name} (gpu frame)"), &gpu, &scene, &opts);
}

#[test]
fn empty_scenes_and_bad_input_are_handled() {
    let name = "empty_scenes_and_bad_input_are_handled";
    let Some(r) = renderer(name) else { return };
    let cam = camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 24, 16, 40.0);
    let empty = SplatScene::default();
    let frame = r.splat(&empty, &cam, &SplatOptions::default()).unwrap();
    assert_eq!(
        frame.gbuffer,
        splat::splat(&empty, &cam, &SplatOptions::default())
            .unwrap()
            .gbuffer
    );
    assert_eq!(frame.gbuffer.hit_count(), 0);
    let (img, _) = r.shade_splat(&frame, &empty, &shading()).unwrap();
    let (cimg, _) = splat::shade_splat(&frame, &empty, &shading()).unwrap();
    assert_eq!(img.pixels, cimg.pixels);
    // Mismatched colours and a negative near plane are refused.
    let mut scene = overlapping_spheres();
    scene.colors.pop();
    assert!(r.splat(&scene, &cam, &SplatOptions::default()).is_err());
    let scene = overlapping_spheres();
    assert!(
        r.splat(
            &scene,
            &cam,
            &SplatOptions {
                near: Some(-1.0),
                ..Default::default()
            }
        )
        .is_err()
    );
    // A frame whose objects do not match its size is refused.
    let mut bad = r.splat(&scene, &cam, &SplatOptions::default()).unwrap();
    bad.objects.pop();
    assert!(
        r.shade_splat(&bad, &scene, &SplatShading::default())
            .is_err()
    );
    // Everything behind the eye: nothing drawn.
    let mut behind = SplatScene::default();
    behind.push(
        Quadric::sphere(DVec3::new(0.0, 0.0, 9.0), 1.0).unwrap(),
        Vec3::ONE,
    );
    let f = r.splat(&behind, &cam, &SplatOptions::default()).unwrap();
    assert_eq!((f.stats.drawn, f.gbuffer.hit_count()), (0, 0));
}

#[test]
fn far_small_and_huge_scenes_match_the_cpu() {
    let name = "far_small_and_huge_scenes_match_the_cpu";
    let Some(r) = renderer(name) else { return };
    // A sphere 1000 radii away seen through a narrow field of view.
    let mut far = SplatScene::default();
    far.push(Quadric::sphere(DVec3::ZERO, 1.0).unwrap(), Vec3::ONE);
    let cam = camera(Vec3::new(0.0, 0.0, 1000.0), Vec3::ZERO, 64, 64, 0.2);
    check_splat(
        &r,
        &format!("{name} (far)"),
        &far,
        &cam,
        &SplatOptions::default(),
    );
    // The mixed scene scaled by 1e-4 and by 1e5 (camera with it).
    for s in [1e-4f64, 1e5] {
        let mut scene = SplatScene::default();
        for (q, c) in cylinder_cone_ellipsoid()
            .quadrics
            .iter()
            .zip(cylinder_cone_ellipsoid().colors)
        {
            let t = q.variance_matrix();
            let (u, v, w, o) = (t.x_axis, t.y_axis, t.z_axis, t.w_axis);
            let sc = |a: glam::DVec4| a.truncate() * s;
            scene.push(
                Quadric::from_axes(q.kind(), sc(u), sc(v), sc(w), sc(o), q.z_lo()).unwrap(),
                c,
            );
        }
        let eye = Vec3::new(-0.8, 1.2, 3.5) * s as f32;
        let cam = camera(eye, Vec3::ZERO, 120, 96, 45.0);
        let label = format!("{name} (scale {s:e})");
        let (cpu, _) = check_splat(&r, &label, &scene, &cam, &SplatOptions::default());
        check_shading(&r, &label, &cpu, &scene, &shading());
    }
}
