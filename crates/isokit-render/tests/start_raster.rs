//! Where the CPU twin's rays start ([`StartRaster`]: the active blocks projected onto tiles
//! of the image). It only removes blocks the walk visits in front of the first active one,
//! so every pixel of the G-buffer is the same with and without it, bit for bit; and its
//! distances never exceed a hit's depth, nor does a tile it marks empty hold a hit.
//! CPU-only: the GPU twin walks from the box entry.

use glam::Vec3;
use isokit_field::Camera;
use isokit_render::kernel::{self, ID_MISS};
use isokit_render::{
    BrickCache, Combine, Inside, RenderOptions, StartRaster, Volume, render, uniforms,
};

mod common;
use common::*;

fn volumes() -> Vec<(&'static str, Volume)> {
    let (a, b) = csg_pair();
    vec![
        ("sphere", volume(sphere_grid(64))),
        ("two spheres", volume(two_spheres())),
        (
            "union",
            volume(a.clone())
                .with_operand(b.clone(), Combine::Union)
                .unwrap(),
        ),
        (
            "difference",
            volume(a).with_operand(b, Combine::Difference).unwrap(),
        ),
    ]
}

fn frame(
    v: &Volume,
    cam: &Camera,
    opts: &RenderOptions,
    bricks: Option<usize>,
) -> isokit_render::Frame {
    let mut cache = match bricks {
        Some(n) => BrickCache::new(v, n).unwrap(),
        None => BrickCache::for_volume(v),
    };
    render(v, &mut cache, cam, opts).unwrap()
}

#[test]
fn the_start_raster_changes_no_pixel() {
    let base = RenderOptions::default();
    let variants = [
        ("default", base),
        (
            "no caps",
            RenderOptions {
                caps: false,
                ..base
            },
        ),
        (
            "inside above",
            RenderOptions {
                inside: Inside::Above,
                ..base
            },
        ),
        ("iso 0.3", RenderOptions { iso: 0.3, ..base }),
    ];
    let mut compared = 0;
    for (vn, v) in volumes() {
        // Odd sizes: partial tiles at the edges, and the axis camera's middle column of rays
        // has a direction component of exactly 0.
        for (cn, cam) in cameras(73, 51) {
            for (on, opts) in &variants {
                for bricks in [None, Some(2)] {
                    let off = RenderOptions {
                        start_raster: false,
                        ..*opts
                    };
                    let with = frame(&v, &cam, opts, bricks);
                    let without = frame(&v, &cam, &off, bricks);
                    assert_eq!(
                        with.gbuffer.pixels(),
                        without.gbuffer.pixels(),
                        "{vn}, {cn}, {on}, cache {bricks:?}"
                    );
                    assert_eq!(
                        with.stats.samples, without.stats.samples,
                        "{vn}, {cn}, {on}"
                    );
                    compared += usize::from(with.stats.hits > 0);
                }
            }
        }
    }
    // Most combinations see the surface (the inside camera with caps sees caps).
    assert!(compared >= 120, "{compared}");
}

#[test]
fn the_start_raster_is_conservative() {
    let cases = volumes()
        .into_iter()
        .flat_map(|v| [(v.clone(), false), (v, true)]);
    for ((vn, v), caps) in cases {
        for (cn, cam) in cameras(75, 53) {
            let opts = RenderOptions {
                caps,
                iso: if caps { 0.35 } else { 0.0 },
                start_raster: false,
                ..Default::default()
            };
            let f = frame(&v, &cam, &opts, None);
            let u = uniforms(&v, &cam, &opts).unwrap();
            let ranges = v.trace_ranges(u.iso, u.inside_sign);
            let raster = StartRaster::build(&u, &ranges, &[]).expect("a single view");
            let (mut hits, mut empty_tiles_pixels, mut started_later) = (0, 0, 0);
            for py in 0..u.height {
                for px in 0..u.width {
                    let s = f.gbuffer.pixels()[(py * u.width + px) as usize];
                    let near = raster.near(px, py);
                    empty_tiles_pixels += usize::from(near == f32::INFINITY);
                    // A hit or a cap lies no nearer than the raster says; a tile it marks
                    // empty holds neither where its misses are final.
                    if s.id != ID_MISS {
                        hits += 1;
                        let t = s.depth / u.spacing;
                        let (ro, d) = kernel::pixel_ray(&u, px, py);
                        let o = (ro - Vec3::from_array(u.origin)) / u.spacing;
                        let t_enter = kernel::ray_box(&u, o, d).map_or(0.0, |b| b.0);
                        started_later += usize::from(near > t_enter + 1.0);
                        assert!(
                            near <= t,
                            "{vn}, {cn}, caps {caps}: pixel ({px}, {py}) near {near} > {t}"
                        );
                        // A surface lies in an active block: no farther than the raster's
                        // far end, where the walk stops.
                        let far = raster.far(px, py);
                        assert!(
                            s.id == kernel::ID_CAP || t <= far,
                            "{vn}, {cn}, caps {caps}: pixel ({px}, {py}) far {far} < {t}"
                        );
                    }
                    if near == f32::INFINITY && raster.misses_final() {
                        assert_eq!(s.id, ID_MISS, "{vn}, {cn}, caps {caps}: ({px}, {py})");
                    }
                }
            }
            eprintln!(
                "{vn}, {cn}, caps {caps}: {hits} hits and caps ({started_later} started a \
                 voxel or more inside), {empty_tiles_pixels} of {} pixels in empty tiles \
                 (final: {})",
                u.width * u.height,
                raster.misses_final()
            );
            assert!(hits > 0, "{vn}, {cn}");
            // The raster does skip: seen from outside, some tiles hold no active block and
            // some rays start more than a voxel past where they enter the volume.
            if cn == "far" || cn == "ortho" {
                assert!(started_later > 0, "{vn}, {cn}: {started_later} of {hits}");
                if !caps {
                    assert!(empty_tiles_pixels > 0, "{vn}, {cn}");
                }
            }
        }
    }
    // Skipping off: every block is active, nothing to raster.
    let v = volume(sphere_grid(32));
    let cam = perspective(Vec3::new(0.0, 0.0, 3.0), 16, 16);
    let opts = RenderOptions {
        skip_empty: false,
        ..Default::default()
    };
    let u = uniforms(&v, &cam, &opts).unwrap();
    assert!(StartRaster::build(&u, v.block_ranges(), &[]).is_none());
}
