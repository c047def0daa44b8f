//! Frames after an edit of the field ([`render_reusing`]): the pixels of the kept frame whose
//! rays meet no changed block are copied, the others traced. The image must be the one a
//! full tracing of the new field gives, bit for bit, for every camera, option set and cache
//! size; and the copy must be worth it (most pixels taken after a local edit).

use glam::Vec3;
use isokit_field::{BrickGrid, Camera, Grid};
use isokit_render::{
    BrickCache, Frame, KeptFrame, Layout, RenderOptions, Shading, ShadingMode, Volume, VolumeData,
    changed_blocks, render, render_reusing, shade, shade_reusing,
};

mod common;
use common::*;

/// Two spheres; the edit grows the smaller one (a primitive's radius).
fn spheres(r: f32) -> Grid {
    grid_of(64, |p| {
        let a = (p - Vec3::new(-0.45, 0.1, 0.0)).length() - 0.35;
        let b = (p - Vec3::new(0.5, -0.2, -0.3)).length() - r;
        a.min(b)
    })
}

/// A band of `g` as a scene samples one (bricks of 8 within 3 voxels of the surface,
/// values beyond read as ±4 voxels).
fn band(g: &Grid) -> Volume {
    let h = g.spacing();
    Volume::from_brick_grid(
        BrickGrid::from_grid(g, 8, 1, 3.0 * h, 4.0 * h).unwrap(),
        Layout::default(),
    )
    .unwrap()
}

fn frame(v: &Volume, cam: &Camera, o: &RenderOptions, kept: Option<&KeptFrame>) -> Frame {
    let mut cache = BrickCache::for_volume(v);
    render_reusing(v, &mut cache, cam, o, kept).unwrap()
}

#[test]
fn an_edit_reuses_the_pixels_it_cannot_change_and_the_image_is_unchanged() {
    let base = RenderOptions::default();
    let variants = [
        ("default", base),
        ("caps, iso 0.05", RenderOptions { iso: 0.05, ..base }),
        (
            "fixed search, no caps",
            RenderOptions {
                search: isokit_render::Search::Fixed,
                caps: false,
                ..base
            },
        ),
        (
            "trilinear, curvature",
            RenderOptions {
                filter: isokit_render::Filter::Trilinear,
                curvature: true,
                ..base
            },
        ),
    ];
    let (before, after) = (spheres(0.25), spheres(0.28));
    let pairs = [
        ("dense", volume(before.clone()), volume(after.clone())),
        ("band", band(&before), band(&after)),
    ];
    for (vn, old, new) in &pairs {
        let (mut rays, mut reused) = (0u64, 0u64);
        for (cn, cam) in cameras(71, 53) {
            for (on, o) in &variants {
                let kept = KeptFrame::new(old, &frame(old, &cam, o, None), None);
                let full = frame(new, &cam, o, None);
                let again = frame(new, &cam, o, Some(&kept));
                let at = format!("{vn}, {cn}, {on}");
                assert_eq!(again.gbuffer.pixels(), full.gbuffer.pixels(), "{at}");
                assert_eq!(again.gbuffer.samples(), full.gbuffer.samples(), "{at}");
                assert_eq!(full.stats.rays_reused, 0, "{at}");
                assert!(again.stats.rays_reused < again.stats.rays, "{at}");
                rays += again.stats.rays;
                reused += again.stats.rays_reused;
                // The kept frame of the same volume: every ray taken.
                let same = KeptFrame::new(new, &full, Some(kept));
                let copy = frame(new, &cam, o, Some(&same));
                assert_eq!(copy.gbuffer.pixels(), full.gbuffer.pixels(), "{at}");
                assert_eq!(copy.stats.rays_reused, copy.stats.rays, "{at}");
            }
        }
        // A dense distance field changes wherever the grown sphere is the nearer one; a
        // band only near its surface, where most rays of these views do not pass.
        eprintln!("{vn}: {reused} of {rays} rays taken from the kept frames");
        if *vn == "band" {
            assert!(reused * 2 > rays, "{vn}: {reused} of {rays}");
        }
    }
}

#[test]
fn changed_blocks_are_those_whose_support_holds_a_changed_sample() {
    let g = sphere_grid(64);
    let old = volume(g.clone());
    // One sample changed, on a block face along x (63 cells: blocks of 8, x = 16 is the
    // first sample of block 2 and the last of block 1's support).
    for (x, want) in [(16usize, vec![1usize, 2]), (20, vec![2]), (15, vec![1, 2])] {
        let mut h = g.clone();
        let v = h.get(x, 30, 40);
        h.set(x, 30, 40, v + 1e-3);
        let new = volume(h);
        let changed = changed_blocks(&old, &new).unwrap();
        let bd = new.block_dims();
        let marked: Vec<[usize; 3]> = (0..changed.len())
            .filter(|&n| changed[n])
            .map(|n| [n % bd[0], (n / bd[0]) % bd[1], n / (bd[0] * bd[1])])
            .collect();
        // y = 30 lies in block 3's support only (block 2's ends at 25, block 4's starts at
        // 31); z = 40 in block 4's (up to 41) and block 5's (from 39).
        let mut expected = Vec::new();
        for cz in [4, 5] {
            for cy in [3] {
                for &cx in &want {
                    expected.push([cx, cy, cz]);
                }
            }
        }
        assert_eq!(marked, expected, "sample x = {x}");
    }
    // Another lattice: no comparison.
    assert!(changed_blocks(&old, &volume(sphere_grid(48))).is_none());
    // The same samples: nothing changed.
    assert!(!changed_blocks(&old, &volume(g)).unwrap().iter().any(|&c| c));
}

#[test]
fn nothing_is_reused_across_cameras_or_isovalues() {
    let (old, new) = (volume(spheres(0.25)), volume(spheres(0.28)));
    let o = RenderOptions::default();
    let a = perspective(Vec3::new(1.9, 1.3, 3.6), 40, 30);
    let b = perspective(Vec3::new(1.9, 1.3, 3.5), 40, 30);
    let kept = KeptFrame::new(&old, &frame(&old, &a, &o, None), None);
    let f = frame(&new, &b, &o, Some(&kept));
    assert_eq!(f.stats.rays_reused, 0);
    let iso = RenderOptions { iso: 0.01, ..o };
    let f = frame(&new, &a, &iso, Some(&kept));
    assert_eq!(f.stats.rays_reused, 0);
    let mut cache = BrickCache::for_volume(&new);
    assert_eq!(
        f.gbuffer.pixels(),
        render(&new, &mut cache, &a, &iso).unwrap().gbuffer.pixels()
    );
}

#[test]
fn the_kept_image_gives_the_colours_of_unchanged_pixels_and_only_those() {
    let (old, new) = (band(&spheres(0.25)), band(&spheres(0.28)));
    let o = RenderOptions {
        curvature: true,
        ..RenderOptions::default()
    };
    for (cn, cam) in cameras(64, 48) {
        for mode in [
            ShadingMode::Phong,
            ShadingMode::Curvature,
            ShadingMode::Silhouette,
            ShadingMode::Flow,
        ] {
            let sh = Shading {
                mode,
                ..Shading::default()
            };
            let before = frame(&old, &cam, &o, None);
            let mut kept = KeptFrame::new(&old, &before, None);
            kept.keep_image(&shade(&before.gbuffer, &before.uniforms, &sh).unwrap(), &sh);
            let after = frame(&new, &cam, &o, Some(&kept));
            let full = shade(&after.gbuffer, &after.uniforms, &sh).unwrap();
            let again = shade_reusing(&after.gbuffer, &after.uniforms, &sh, Some(&kept)).unwrap();
            assert_eq!(again, full, "{cn}, {}", mode.name());
            // Another shading: nothing is taken.
            let other = Shading {
                ambient: 0.3,
                ..sh.clone()
            };
            let full = shade(&after.gbuffer, &after.uniforms, &other).unwrap();
            let again =
                shade_reusing(&after.gbuffer, &after.uniforms, &other, Some(&kept)).unwrap();
            assert_eq!(again, full, "{cn}, {}, other shading", mode.name());
        }
    }
}

#[test]
fn a_volume_built_after_another_scans_only_its_changed_blocks_and_equals_a_fresh_one() {
    let (before, after) = (spheres(0.25), spheres(0.28));
    let h = before.spacing();
    let grids = |g: &Grid| BrickGrid::from_grid(g, 8, 1, 3.0 * h, 4.0 * h).unwrap();
    let old = band(&before);
    let fresh = band(&after);
    let built = Volume::new_after(
        VolumeData::Band(grids(&after)),
        Layout::default(),
        Some(&old),
    )
    .unwrap();
    assert_eq!(built.block_ranges(), fresh.block_ranges());
    assert_eq!(built.block_slopes(), fresh.block_slopes());
    // The changes it recorded are those a comparison finds, and some blocks kept theirs.
    let recorded = changed_blocks(&old, &built).unwrap();
    assert_eq!(Some(recorded.clone()), changed_blocks(&old, &fresh));
    let n = recorded.iter().filter(|&&c| c).count();
    assert!(n > 0 && n < recorded.len(), "{n} of {}", recorded.len());
    // And the frame after the old one's is the fresh volume's, bit for bit.
    let o = RenderOptions::default();
    for (cn, cam) in cameras(57, 41) {
        let kept = KeptFrame::new(&old, &frame(&old, &cam, &o, None), None);
        let again = frame(&built, &cam, &o, Some(&kept));
        assert_eq!(
            again.gbuffer.pixels(),
            frame(&fresh, &cam, &o, None).gbuffer.pixels(),
            "{cn}"
        );
        assert!(again.stats.rays_reused > 0, "{cn}");
    }
    // One cache for both frames: it keeps the bricks without a changed block.
    let cam = perspective(Vec3::new(1.9, 1.3, 3.6), 57, 41);
    let mut cache = BrickCache::for_volume(&old);
    let first = render(&old, &mut cache, &cam, &o).unwrap();
    let kept = KeptFrame::new(&old, &first, None);
    let again = render_reusing(&built, &mut cache, &cam, &o, Some(&kept)).unwrap();
    let fresh_frame = frame(&fresh, &cam, &o, None);
    assert_eq!(again.gbuffer.pixels(), fresh_frame.gbuffer.pixels());
    assert!(
        again.stats.bricks_loaded < fresh_frame.stats.bricks_loaded,
        "{} bricks loaded again, {} into a new cache",
        again.stats.bricks_loaded,
        fresh_frame.stats.bricks_loaded
    );
    // Another layout or a combined volume: a full scan, nothing recorded.
    let other = Volume::new_after(
        VolumeData::Band(grids(&after)),
        Layout {
            block: 4,
            brick: 32,
        },
        Some(&old),
    )
    .unwrap();
    assert!(changed_blocks(&old, &other).is_none());
}

#[test]
fn small_caches_reuse_exactly_and_a_downsampled_frame_is_not_reused() {
    use isokit_render::CachePolicy;
    let (old, new) = (band(&spheres(0.25)), band(&spheres(0.28)));
    let cam = perspective(Vec3::new(1.9, 1.3, 3.6), 61, 45);
    let with = |v: &Volume, o: &RenderOptions, slots: usize, kept: Option<&KeptFrame>| {
        let mut cache = BrickCache::new(v, slots).unwrap();
        render_reusing(v, &mut cache, &cam, o, kept).unwrap()
    };
    let full = frame(&new, &cam, &RenderOptions::default(), None);
    // Passes: a cache of 2 bricks renders the same image in several passes, and reuses.
    let passes = RenderOptions::default();
    let before = with(&old, &passes, 2, None);
    assert!(before.stats.passes > 1, "{:?}", before.stats);
    let kept = KeptFrame::new(&old, &before, None);
    let again = with(&new, &passes, 2, Some(&kept));
    assert_eq!(again.gbuffer.pixels(), full.gbuffer.pixels());
    assert!(again.stats.rays_reused > 0);
    // Downsample: the kept frame's half-resolution bricks are other samples; a full frame
    // after it takes nothing from it.
    let down = RenderOptions {
        cache_policy: CachePolicy::Downsample,
        ..RenderOptions::default()
    };
    let before = with(&old, &down, 2, None);
    assert!(before.stats.bricks_downsampled > 0, "{:?}", before.stats);
    let kept = KeptFrame::new(&old, &before, None);
    let again = frame(&new, &cam, &down, Some(&kept));
    assert_eq!(again.stats.rays_reused, 0);
    assert_eq!(again.gbuffer.pixels(), full.gbuffer.pixels());
}
