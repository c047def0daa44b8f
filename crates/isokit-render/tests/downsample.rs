//! The downsampling cache policy (002 Sec. 6.2.3, [`CachePolicy::Downsample`]): with a
//! cache too small for the active bricks, the least detailed bricks are stored at half
//! resolution so that all fit and the frame renders in one pass, with hanging samples
//! matched so that the surface has no cracks.
//!
//! What is checked:
//! - a cache large enough: the policy changes nothing (bit for bit);
//! - a cache of about half the active bricks (sphere and torus crossing many brick faces,
//!   both filters): one pass, some bricks downsampled, every pixel that hits in the exact
//!   (passes) image hits in the downsampled one and depths agree within [`DEPTH_VOXELS`];
//!   a later frame with the passes policy on the same cache is exact again;
//! - hanging samples: on every face shared by a full- and a half-resolution brick, the
//!   full brick's stored samples equal the half brick's trilinear reconstruction exactly,
//!   and the kernel's trilinear reconstructions from both sides agree to rounding, while
//!   without matching they differ; the tricubic filter's residual mismatch is bounded;
//! - the low-detail rule: a field flat in one half and detailed in the other downsamples
//!   the flat bricks first;
//! - a cache too small even at half resolution falls back to passes (exact).
//!
//! The tests that render against the exact image run on both twins ([`common::twin`]: the
//! CPU twin and, where an adapter exists, the GPU twin, each against its own exact frame);
//! the GPU's allowances are the documented GPU–CPU agreement ([`raycast_tol`]). CPU-only:
//! the hanging-sample and low-detail checks, which read the CPU cache's pool and slots
//! (`kernel::` functions, [`BrickCache`] bookkeeping), and the policy's names.

use glam::{IVec3, Vec3};
use isokit_render::kernel::{self, FILTER_TRICUBIC, FILTER_TRILINEAR};
use isokit_render::{
    BrickCache, CachePolicy, DEFAULT_CACHE_BYTES, Filter, Frame, Layout, RenderOptions, Volume,
    render, uniforms,
};

mod common;
use common::twin::{raycast_tol, twins};
use common::*;

/// Depth tolerance between the downsampled and the exact image, in voxels (a voxel or two:
/// the half-resolution reconstruction moves a curved surface by up to about `(2h)²·κ/8`
/// for trilinear and `(2h)²·κ/6` for the B-spline's smoothing; see the measured numbers).
const DEPTH_VOXELS: f32 = 1.5;

/// Bricks of 16 cells, blocks of 4: a 65³ grid has 4³ bricks, many of them crossed by the
/// surfaces below.
const LAYOUT: Layout = Layout {
    block: 4,
    brick: 16,
};

fn vol(g: isokit_field::Grid) -> Volume {
    Volume::from_grid(g, LAYOUT).unwrap()
}

fn torus_grid(n: usize) -> isokit_field::Grid {
    grid_of(n, |p| {
        let q = glam::Vec2::new(glam::Vec2::new(p.x, p.z).length() - 0.55, p.y);
        q.length() - 0.22
    })
}

fn opts(filter: Filter, policy: CachePolicy) -> RenderOptions {
    RenderOptions {
        filter,
        shading_filter: filter,
        cache_policy: policy,
        ..Default::default()
    }
}

/// What a downsampled frame `down` changed against the exact one: `holes`, pixels that hit
/// in `exact` with all 8 neighbours hitting too (the surface around them is seen whole, so
/// a miss there is a crack), that miss in `down`; `silhouette`, hits of `exact` on its
/// mask's edge that miss in `down` (the coarse reconstruction, the tricubic B-spline's
/// above all, shrinks a convex surface slightly, by up to `(2h)²/(3R)`), and hits where the
/// exact image has an occlusion edge (a neighbour more than 2 voxels nearer or farther)
/// whose depth moved by more than [`DEPTH_VOXELS`] (a ray grazing a fold that now hits
/// what lies behind); the max and mean |Δdepth| (voxels) elsewhere where both hit.
fn holes_and_depth(exact: &Frame, down: &Frame, h: f32) -> (usize, usize, f32, f32) {
    let (w, ht) = (exact.gbuffer.width() as i64, exact.gbuffer.height() as i64);
    let hit = |x: i64, y: i64| {
        x >= 0 && y >= 0 && x < w && y < ht && exact.gbuffer.get(x as u32, y as u32).is_hit()
    };
    let (mut holes, mut silhouette, mut max, mut sum, mut n) = (0, 0, 0.0f32, 0.0f64, 0usize);
    for y in 0..ht {
        for x in 0..w {
            let a = exact.gbuffer.get(x as u32, y as u32);
            let b = down.gbuffer.get(x as u32, y as u32);
            if a.is_hit() && !b.is_hit() {
                let interior = (-1..=1).all(|dy| (-1..=1).all(|dx| hit(x + dx, y + dy)));
                if interior {
                    holes += 1;
                } else {
                    silhouette += 1;
                }
            }
            if a.is_hit() && b.is_hit() {
                let d = (a.depth - b.depth).abs() / h;
                let edge = (-1..=1).any(|dy| {
                    (-1..=1).any(|dx| {
                        !hit(x + dx, y + dy)
                            || (exact.gbuffer.get((x + dx) as u32, (y + dy) as u32).depth - a.depth)
                                .abs()
                                > 2.0 * h
                    })
                });
                if edge && d > DEPTH_VOXELS {
                    silhouette += 1;
                    continue;
                }
                max = max.max(d);
                sum += f64::from(d);
                n += 1;
            }
        }
    }
    (holes, silhouette, max, (sum / n.max(1) as f64) as f32)
}

/// A cache large enough: the policy changes nothing, bit for bit, on both twins.
#[test]
fn a_large_cache_changes_nothing() {
    let cam = perspective(Vec3::new(0.4, 0.9, 2.6), 64, 64);
    for mut t in twins("a_large_cache_changes_nothing") {
        for (name, g) in [("sphere", sphere_grid(65)), ("torus", torus_grid(65))] {
            let v = vol(g);
            for filter in [Filter::Trilinear, Filter::Tricubic] {
                t.set_cache_bytes(DEFAULT_CACHE_BYTES);
                let a = t
                    .render(&v, &cam, &opts(filter, CachePolicy::Passes))
                    .unwrap();
                t.set_cache_bytes(DEFAULT_CACHE_BYTES);
                let b = t
                    .render(&v, &cam, &opts(filter, CachePolicy::Downsample))
                    .unwrap();
                assert_eq!(a.gbuffer, b.gbuffer, "{t}: {name} {filter:?}");
                assert_eq!(b.stats.bricks_downsampled, 0, "{t}");
                assert_eq!(b.stats.passes, 1, "{t}");
            }
        }
    }
}

/// A cache of about half the active bricks, on both twins: one pass, some bricks
/// downsampled, no holes, few silhouette changes, depths within [`DEPTH_VOXELS`] of the
/// exact image; the same frame again reloads nothing and is the same image; the passes
/// policy on the same cache is exact again. Holes and the identities are exact on both
/// twins; the silhouette count may have [`raycast_tol::MASK_PX`] more pixels per frame on
/// the GPU (two frames: grazing rays) and the depth bound adds [`raycast_tol::Z_VOXEL`]
/// per frame. That the CPU cache's own count of half-resolution bricks matches the frame's
/// is the CPU's bookkeeping (CPU-only).
#[test]
fn a_half_size_cache_downsamples_in_one_pass_without_holes() {
    use raycast_tol::{MASK_PX, Z_VOXEL};
    let cam = perspective(Vec3::new(0.4, 0.9, 2.6), 96, 96);
    for mut t in twins("a_half_size_cache_downsamples_in_one_pass_without_holes") {
        let extra_px = t.tol(0, 2 * MASK_PX);
        let tol_depth = t.tol(DEPTH_VOXELS, DEPTH_VOXELS + 2.0 * Z_VOXEL);
        for (name, g) in [("sphere", sphere_grid(65)), ("torus", torus_grid(65))] {
            let v = vol(g);
            let h = v.spacing();
            for filter in [Filter::Trilinear, Filter::Tricubic] {
                t.set_cache_bytes(DEFAULT_CACHE_BYTES);
                let exact = t
                    .render(&v, &cam, &opts(filter, CachePolicy::Passes))
                    .unwrap();
                let active = exact.stats.bricks_active;
                let cap = active / 2;
                t.set_cache_bricks(cap).unwrap();
                let down = t
                    .render(&v, &cam, &opts(filter, CachePolicy::Downsample))
                    .unwrap();
                let (holes, silhouette, max, mean) = holes_and_depth(&exact, &down, h);
                eprintln!(
                    "{t}, {name} {filter:?}: {active} active bricks, cache {cap}: {} downsampled, {} pass(es); {} hits exact, {} downsampled; holes {holes}, silhouette/occlusion-edge pixels changed {silhouette}; |Δdepth| max {max:.3} mean {mean:.4} voxel",
                    down.stats.bricks_downsampled,
                    down.stats.passes,
                    exact.stats.hits,
                    down.stats.hits
                );
                assert_eq!(down.stats.passes, 1, "{t}, {name} {filter:?}");
                assert!(down.stats.bricks_downsampled > 0, "{t}, {name} {filter:?}");
                assert!(
                    down.stats.bricks_downsampled < active,
                    "{t}, {name} {filter:?}"
                );
                if let Some(small) = t.cpu_cache() {
                    assert_eq!(small.downsampled(), down.stats.bricks_downsampled);
                }
                assert_eq!(
                    holes, 0,
                    "{t}, {name} {filter:?}: holes in the downsampled image"
                );
                assert!(
                    silhouette * 200 <= exact.stats.hits as usize + 200 * extra_px,
                    "{t}, {name} {filter:?}: {silhouette}"
                );
                assert!(
                    max <= tol_depth,
                    "{t}, {name} {filter:?}: |Δdepth| {max} voxel"
                );
                // The same frame again: every brick a hit, nothing reloaded, the same image.
                let again = t
                    .render(&v, &cam, &opts(filter, CachePolicy::Downsample))
                    .unwrap();
                assert_eq!(again.gbuffer, down.gbuffer, "{t}");
                assert_eq!(again.stats.bricks_loaded, 0, "{t}");
                // The passes policy on the same cache is exact again.
                let passes = t
                    .render(&v, &cam, &opts(filter, CachePolicy::Passes))
                    .unwrap();
                assert!(passes.stats.passes > 1, "{t}");
                assert_eq!(passes.stats.bricks_downsampled, 0, "{t}");
                assert_eq!(passes.gbuffer, exact.gbuffer, "{t}, {name} {filter:?}");
            }
        }
    }
}

/// The corner (first cell) of brick `n`.
fn corner(v: &Volume, n: usize) -> IVec3 {
    let c = v.brick_coord(n);
    IVec3::new(c[0] as i32, c[1] as i32, c[2] as i32) * v.layout().brick as i32
}

/// The half brick's trilinear reconstruction at grid sample `g` from its stored coarse
/// samples `hb` (lerps x, y, z as the kernel's fetch).
fn coarse_at(v: &Volume, hb: &[f32], hn: usize, g: IVec3) -> f32 {
    let s = v.layout().half_side() as i32;
    let e = IVec3::new(g.x.div_euclid(2), g.y.div_euclid(2), g.z.div_euclid(2)) * 2;
    let t = (g - e).as_vec3() * 0.5;
    let l = (e - corner(v, hn)) / 2 + IVec3::ONE;
    let at = |d: IVec3| {
        let m = l + d;
        hb[(m.x + s * (m.y + s * m.z)) as usize]
    };
    let lerp = |a: f32, b: f32, t: f32| a + t * (b - a);
    let x00 = lerp(at(IVec3::new(0, 0, 0)), at(IVec3::new(1, 0, 0)), t.x);
    let x10 = lerp(at(IVec3::new(0, 1, 0)), at(IVec3::new(1, 1, 0)), t.x);
    let x01 = lerp(at(IVec3::new(0, 0, 1)), at(IVec3::new(1, 0, 1)), t.x);
    let x11 = lerp(at(IVec3::new(0, 1, 1)), at(IVec3::new(1, 1, 1)), t.x);
    lerp(lerp(x00, x10, t.y), lerp(x01, x11, t.y), t.z)
}

/// What the face checks measured over every face shared by a full- and a half-resolution
/// brick.
#[derive(Debug, Default)]
struct FaceReport {
    faces: usize,
    samples: usize,
    /// Stored face samples of the full brick that differ from the half brick's value.
    stored_diff: usize,
    /// The same without matching (the full brick as `fill_brick` stores it).
    stored_diff_unmatched: usize,
    max_unmatched: f32,
    /// Max |Δ| of the kernel's reconstructions from both sides at points on the face.
    trilinear: f32,
    trilinear_unmatched: f32,
    tricubic: f32,
    tricubic_unmatched: f32,
}

fn face_report(v: &Volume, cache: &BrickCache, cam: &isokit_field::Camera) -> FaceReport {
    let lay = v.layout();
    let (r, b) = (lay.brick as i32, lay.block as i32);
    let ss = v.slot_samples();
    let hs = v.half_slot_samples();
    let pool = cache.pool();
    let u = uniforms(v, cam, &RenderOptions::default()).unwrap();
    let top = IVec3::new(
        v.dims()[0] as i32 - 1,
        v.dims()[1] as i32 - 1,
        v.dims()[2] as i32 - 1,
    );
    let bd = v.brick_dims();
    let mut rep = FaceReport::default();
    let mut unmatched_pool = pool.to_vec();
    for n in 0..v.brick_count() {
        if let Some(s) = cache.slot_of(n) {
            v.fill_brick(n, &mut unmatched_pool[s * ss..(s + 1) * ss]);
        }
    }
    for fnb in 0..v.brick_count() {
        let Some(fs) = cache.slot_of(fnb) else {
            continue;
        };
        let fc = v.brick_coord(fnb);
        for axis in 0..3 {
            for dir in [-1i32, 1] {
                let mut hc = fc;
                let k = fc[axis] as i32 + dir;
                if k < 0 || k >= bd[axis] as i32 {
                    continue;
                }
                hc[axis] = k as usize;
                let hn = v.brick_index(hc);
                let Some(hk) = cache.half_slot_of(hn) else {
                    continue;
                };
                rep.faces += 1;
                let fb = &pool[fs * ss..(fs + 1) * ss];
                let fu = &unmatched_pool[fs * ss..(fs + 1) * ss];
                let hb = &pool[hk * hs..(hk + 1) * hs];
                let (f0, h0) = (corner(v, fnb), corner(v, hn));
                let face = if dir > 0 { f0[axis] + r } else { f0[axis] };
                let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
                let side = lay.brick_side() as i32;
                // Stored samples on the face.
                for j in f0[a2]..=(f0[a2] + r).min(top[a2]) {
                    for i in f0[a1]..=(f0[a1] + r).min(top[a1]) {
                        let mut g = IVec3::ZERO;
                        g[axis] = face;
                        g[a1] = i;
                        g[a2] = j;
                        let l = g - (f0 - IVec3::ONE);
                        let m = (l.x + side * (l.y + side * l.z)) as usize;
                        let want = coarse_at(v, hb, hn, g);
                        rep.samples += 1;
                        rep.stored_diff += usize::from(fb[m] != want);
                        rep.stored_diff_unmatched += usize::from(fu[m] != want);
                        rep.max_unmatched = rep.max_unmatched.max((fu[m] - want).abs());
                    }
                }
                // The kernel's reconstructions from both sides at points on the face.
                let fref = cache.reference()[fnb];
                let href = cache.reference()[hn];
                let steps = 4 * r;
                for j in 0..=steps {
                    for i in 0..=steps {
                        let mut p = Vec3::ZERO;
                        p[axis] = face as f32;
                        p[a1] = (f0[a1] as f32 + i as f32 * 0.25).min(top[a1] as f32);
                        p[a2] = (f0[a2] as f32 + j as f32 * 0.25).min(top[a2] as f32);
                        let block_of = |base: IVec3, inside: i32| {
                            let mut c = (p / b as f32).floor().as_ivec3();
                            for a in 0..3 {
                                c[a] = c[a].clamp(base[a] / b, (base[a] + r) / b - 1);
                            }
                            c[axis] = inside;
                            c
                        };
                        let (fcell, hcell) = if dir > 0 {
                            (block_of(f0, face / b - 1), block_of(h0, face / b))
                        } else {
                            (block_of(f0, face / b), block_of(h0, face / b - 1))
                        };
                        let lf = kernel::locate(&u, fref, fcell, p);
                        let lh = kernel::locate(&u, href, hcell, p);
                        let val = |pool: &[f32], f, l| kernel::value_at(&u, pool, f, l);
                        let hv = val(pool, FILTER_TRILINEAR, &lh);
                        rep.trilinear = rep
                            .trilinear
                            .max((val(pool, FILTER_TRILINEAR, &lf) - hv).abs());
                        rep.trilinear_unmatched = rep
                            .trilinear_unmatched
                            .max((val(&unmatched_pool, FILTER_TRILINEAR, &lf) - hv).abs());
                        let hc3 = val(pool, FILTER_TRICUBIC, &lh);
                        rep.tricubic = rep
                            .tricubic
                            .max((val(pool, FILTER_TRICUBIC, &lf) - hc3).abs());
                        rep.tricubic_unmatched = rep
                            .tricubic_unmatched
                            .max((val(&unmatched_pool, FILTER_TRICUBIC, &lf) - hc3).abs());
                    }
                }
            }
        }
    }
    rep
}

/// Hanging samples on every face shared by a full- and a half-resolution brick: matched
/// exactly (trilinear) or to rounding (tricubic), mismatched without matching. CPU-only: reads
/// the CPU cache's pool through `kernel::` functions.
#[test]
fn hanging_samples_are_matched_on_shared_faces() {
    let cam = perspective(Vec3::new(0.4, 0.9, 2.6), 48, 48);
    for (name, g) in [("sphere", sphere_grid(65)), ("torus", torus_grid(65))] {
        let v = vol(g);
        let h = v.spacing();
        let mut big = BrickCache::for_volume(&v);
        let exact = render(&v, &mut big, &cam, &RenderOptions::default()).unwrap();
        for filter in [Filter::Trilinear, Filter::Tricubic] {
            let mut small = BrickCache::new(&v, exact.stats.bricks_active / 2).unwrap();
            let down = render(&v, &mut small, &cam, &opts(filter, CachePolicy::Downsample));
            assert!(down.unwrap().stats.bricks_downsampled > 0);
            let rep = face_report(&v, &small, &cam);
            eprintln!("{name} (h = {h}), matched for {filter:?}: {rep:?}");
            assert!(rep.faces > 0 && rep.samples > 0, "{name}: no shared face");
            // Unmatched, the full brick's face samples are not the coarse neighbour's
            // values (the odd ones: the field is curved), and both filters see a step.
            assert!(
                rep.stored_diff_unmatched > 0 && rep.max_unmatched > 1e-4,
                "{name}"
            );
            assert!(rep.trilinear_unmatched > 1e-4, "{name}");
            assert!(rep.tricubic_unmatched > 1e-4, "{name}");
            match filter {
                Filter::Trilinear => {
                    // The stored face samples are the coarse neighbour's values, exactly,
                    // and the trilinear reconstructions agree to rounding (a lerp at
                    // fraction 1 on the full side).
                    assert_eq!(rep.stored_diff, 0, "{name}");
                    assert!(rep.trilinear <= 1e-6, "{name}: {}", rep.trilinear);
                    assert!(rep.trilinear_unmatched > 100.0 * rep.trilinear.max(1e-7));
                    // Residual: the tricubic filter on trilinear-matched samples (a
                    // trilinear search with tricubic shading): below a voxel in field units.
                    assert!(rep.tricubic <= h, "{name}: {}", rep.tricubic);
                }
                Filter::Tricubic => {
                    // Subdivided control points: the B-splines of both sides agree to
                    // rounding.
                    assert!(rep.tricubic <= 1e-5, "{name}: {}", rep.tricubic);
                    assert!(rep.tricubic_unmatched > 100.0 * rep.tricubic.max(1e-7));
                }
            }
        }
    }
}

/// The low-detail rule: a field flat in one half and detailed in the other downsamples the
/// flat bricks first. CPU-only: reads the CPU cache's slots (the GPU renderer runs the same
/// host bookkeeping on its private cache).
#[test]
fn flat_bricks_are_downsampled_first() {
    // A plane y = 0.05, bumpy where x > 0 (bumps of ±0.08, a few voxels across): the bricks
    // of the flat half have no detail (the field is linear), those of the bumpy half some.
    let g = grid_of(65, |p| {
        let bump = if p.x > 0.0 {
            0.08 * (14.0 * p.x).sin() * (14.0 * p.z).sin()
        } else {
            0.0
        };
        p.y - 0.05 + bump
    });
    let v = vol(g);
    let cam = perspective(Vec3::new(0.3, 2.2, 1.6), 64, 64);
    let mut big = BrickCache::for_volume(&v);
    let exact = render(&v, &mut big, &cam, &RenderOptions::default()).unwrap();
    let active = exact.stats.bricks_active;
    let mut small = BrickCache::new(&v, (active * 2).div_ceil(3)).unwrap();
    let o = opts(Filter::Tricubic, CachePolicy::Downsample);
    let down = render(&v, &mut small, &cam, &o).unwrap();
    let r = v.layout().brick as i32;
    let flat = |n: usize| corner(&v, n).x + r <= 32; // cells with x <= 0
    let stored: Vec<usize> = (0..v.brick_count())
        .filter(|&n| small.slot_of(n).is_some() || small.half_slot_of(n).is_some())
        .collect();
    let half: Vec<usize> = stored
        .iter()
        .copied()
        .filter(|&n| small.half_slot_of(n).is_some())
        .collect();
    let n_flat = stored.iter().filter(|&&n| flat(n)).count();
    eprintln!(
        "flat/bumpy: {active} active ({n_flat} flat), cache {}: {} downsampled, {} pass(es)",
        small.capacity(),
        half.len(),
        down.stats.passes
    );
    assert_eq!(stored.len(), active);
    assert_eq!(down.stats.passes, 1);
    assert!(
        !half.is_empty() && half.len() <= n_flat,
        "{} {n_flat}",
        half.len()
    );
    assert!(
        half.iter().all(|&n| flat(n)),
        "a bumpy brick was downsampled first"
    );
    let max_half = half.iter().map(|&n| v.brick_detail(n)).fold(0.0, f32::max);
    let min_full = stored
        .iter()
        .filter(|&&n| small.slot_of(n).is_some())
        .map(|&n| v.brick_detail(n))
        .fold(f32::INFINITY, f32::min);
    eprintln!("detail: downsampled max {max_half:e}, full min {min_full:e}");
    assert!(max_half <= min_full);
    assert!(max_half < 1e-5);
}

/// A cache too small even at half resolution falls back to passes, exact, on both twins.
#[test]
fn a_cache_too_small_even_at_half_resolution_renders_in_passes() {
    let v = vol(sphere_grid(65));
    let cam = perspective(Vec3::new(0.4, 0.9, 2.6), 48, 48);
    for mut t in twins("a_cache_too_small_even_at_half_resolution_renders_in_passes") {
        let exact = t.render(&v, &cam, &RenderOptions::default()).unwrap();
        t.set_cache_bricks(1).unwrap();
        let o = opts(Filter::Tricubic, CachePolicy::Downsample);
        let f = t.render(&v, &cam, &o).unwrap();
        assert!(f.stats.passes > 1, "{t}");
        assert_eq!(f.stats.bricks_downsampled, 0, "{t}");
        assert_eq!(f.gbuffer, exact.gbuffer, "{t}");
    }
}

/// The policy's names. CPU-only: parsing, nothing is rendered.
#[test]
fn the_policy_parses() {
    assert_eq!("passes".parse::<CachePolicy>(), Ok(CachePolicy::Passes));
    assert_eq!(
        "Downsample".parse::<CachePolicy>(),
        Ok(CachePolicy::Downsample)
    );
    assert!("half".parse::<CachePolicy>().is_err());
    assert_eq!(RenderOptions::default().cache_policy, CachePolicy::Passes);
}

/// Combined volumes (union, difference) downsample both fields, on both twins: one pass, no
/// holes, few silhouette changes, depths within [`DEPTH_VOXELS`] (on the GPU with the same
/// allowances as [`a_half_size_cache_downsamples_in_one_pass_without_holes`]).
#[test]
fn combined_volumes_downsample_both_fields() {
    use isokit_render::Combine;
    use raycast_tol::{MASK_PX, Z_VOXEL};
    let (a, b) = csg_pair();
    let cam = perspective(Vec3::new(0.4, 0.9, 2.6), 64, 64);
    for mut t in twins("combined_volumes_downsample_both_fields") {
        let extra_px = t.tol(0, 2 * MASK_PX);
        let tol_depth = t.tol(DEPTH_VOXELS, DEPTH_VOXELS + 2.0 * Z_VOXEL);
        for combine in [Combine::Union, Combine::Difference] {
            let v = vol(a.clone()).with_operand(b.clone(), combine).unwrap();
            let h = v.spacing();
            t.set_cache_bytes(DEFAULT_CACHE_BYTES);
            let exact = t.render(&v, &cam, &RenderOptions::default()).unwrap();
            t.set_cache_bricks(exact.stats.bricks_active / 2).unwrap();
            let o = opts(Filter::Tricubic, CachePolicy::Downsample);
            let down = t.render(&v, &cam, &o).unwrap();
            let (holes, silhouette, max, mean) = holes_and_depth(&exact, &down, h);
            eprintln!(
                "{t}, {combine:?}: {} active, {} downsampled, {} pass(es); holes {holes}, silhouette {silhouette}; |Δdepth| max {max:.3} mean {mean:.4} voxel",
                exact.stats.bricks_active, down.stats.bricks_downsampled, down.stats.passes
            );
            assert_eq!(down.stats.passes, 1, "{t}");
            assert!(down.stats.bricks_downsampled > 0, "{t}");
            assert_eq!(holes, 0, "{t}, {combine:?}");
            assert!(
                silhouette * 100 <= exact.stats.hits as usize + 100 * extra_px,
                "{t}, {combine:?}"
            );
            assert!(max <= tol_depth, "{t}, {combine:?}: {max}");
        }
    }
}
