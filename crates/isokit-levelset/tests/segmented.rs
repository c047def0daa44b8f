//! Segmented distance fields (003): the crossing rule of Eq. 5–7, and the morph of two
//! segmented fields against the linear morph of the signed distances they encode.

use glam::Vec3;
use isokit_field::{Grid, Job};
use isokit_levelset::segmented::{Segmentation, mesh_segmented, morph_segmented};

#[test]
fn surfaces_pass_only_where_the_distances_meet_between_the_samples() {
    let seg = Segmentation::new(0.4, 1.0).unwrap();
    let w = 0.1;
    let f = |d: f32, r: i32| seg.encode(d, r).unwrap();
    // Regions 0 and 2, 0.03 and 0.07 from a surface between them: at 0.3 of the way.
    let (i, j, t) = seg.crossing(f(0.03, 0), f(0.07, 2), w).unwrap();
    assert_eq!((i, j), (0, 2));
    assert!((t - 0.3).abs() < 1e-5);
    // Beyond a rim: both 0.08 away from its edge, 0.16 > w: no surface (Eq. 7).
    assert!(seg.crossing(f(0.08, 0), f(0.08, 1), w).is_none());
    // One region on both sides: no surface.
    assert!(seg.crossing(f(0.01, 1), f(0.02, 1), w).is_none());
    // Clamped at δ, decoded back.
    assert_eq!(seg.decode(f(3.0, 5)), Some((5, 0.4)));
    assert!(seg.decode(-1.0).is_none() && seg.decode(f32::NAN).is_none());
    assert!(seg.encode(0.1, -1).is_err() && seg.encode(f32::NAN, 0).is_err());
    assert!(Segmentation::new(1.0, 1.0).is_err() && Segmentation::new(0.0, 1.0).is_err());
}

fn sphere_sd(c: Vec3, r: f32) -> impl Fn(Vec3) -> f32 {
    move |p| (p - c).length() - r
}

#[test]
fn the_morph_of_two_regions_is_the_linear_morph_of_signed_distances() {
    let h = 2.0 / 31.0;
    let g = Grid::new([32; 3], Vec3::splat(-1.0), h).unwrap();
    // δ = 4 spacings, as the command line samples: only samples within δ of both surfaces
    // blend exactly, and those are the ones compared.
    let seg = Segmentation::for_spacing(h).unwrap();
    let delta = seg.delta();
    let (a, b) = (
        sphere_sd(Vec3::new(-0.2, 0.0, 0.0), 0.45),
        sphere_sd(Vec3::new(0.25, 0.1, 0.0), 0.6),
    );
    let encode = |sd: &dyn Fn(Vec3) -> f32| {
        let mut out = g.clone();
        for k in 0..32 {
            for j in 0..32 {
                for i in 0..32 {
                    let v = sd(g.position(i, j, k));
                    out.set(i, j, k, seg.encode(v.abs(), i32::from(v < 0.0)).unwrap());
                }
            }
        }
        out
    };
    let (ga, gb) = (encode(&a), encode(&b));
    let t = 0.35;
    let m = morph_segmented(&ga, &gb, &seg, t).unwrap();
    let mut compared = 0;
    for k in 0..32 {
        for j in 0..32 {
            for i in 0..32 {
                let p = g.position(i, j, k);
                let (va, vb) = (a(p), b(p));
                if va.abs() >= delta || vb.abs() >= delta {
                    continue; // clamped at δ: only the band blends exactly
                }
                let want = (1.0 - t) * va + t * vb;
                let (r, d) = seg.decode(m.get(i, j, k)).unwrap();
                let got = if r == 1 { -d } else { d };
                assert!((got - want).abs() < 1e-5, "{p}: {got} {want}");
                compared += 1;
            }
        }
    }
    assert!(compared > 1000, "{compared}");
    // The ends are the operands (to the rounding of decoding and encoding again).
    for (t, g) in [(0.0, &ga), (1.0, &gb)] {
        let end = morph_segmented(&ga, &gb, &seg, t).unwrap();
        let worst = end
            .data()
            .iter()
            .zip(g.data())
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(worst < 1e-6, "{t}: {worst}");
    }
    // Its mesh: the blended sphere-like surface between regions 0 and 1, closed.
    let mesh = mesh_segmented(&m, &seg, &Job::new()).unwrap();
    assert_eq!(mesh.pairs().len(), 1);
    assert_eq!(mesh.mesh.validate().boundary_edges, 0);
    assert!(morph_segmented(&ga, &gb, &seg, 1.5).is_err());
}

#[test]
fn the_last_regions_keep_their_surfaces_through_f32_rounding() {
    // Planes z = 0.5 + f h between regions 4094 and 4095 (the last two), where D r rounds
    // the distances by up to ~3e-3 spacings: the edges across a plane meet it with d_u + d_v
    // = w, and each mesh is whole (25² quadrilaterals), as for regions 0 and 1. Without the
    // rounding's allowance in Eq. 7 some of these planes lose every quadrilateral.
    let h = 1.0 / 24.0;
    let seg = Segmentation::for_spacing(h).unwrap();
    let mesh = |lo: i32, f: f32| {
        let mut g = Grid::new([25; 3], Vec3::ZERO, h).unwrap();
        for k in 0..25 {
            for j in 0..25 {
                for i in 0..25 {
                    let d = g.position(i, j, k).z - (0.5 + f * h);
                    g.set(
                        i,
                        j,
                        k,
                        seg.encode(d.abs(), lo + i32::from(d > 0.0)).unwrap(),
                    );
                }
            }
        }
        mesh_segmented(&g, &seg, &Job::new()).unwrap()
    };
    for step in 1..20 {
        let f = step as f32 * 0.049;
        for lo in [0, 4094] {
            let m = mesh(lo, f);
            assert_eq!(
                m.mesh.triangles.len(),
                2 * 25 * 25,
                "regions {lo}, plane at {f} h"
            );
            let area = m.pairs()[0].2;
            assert!((area - 1.0).abs() < 1e-3, "{area}");
        }
    }
    // A spacing below δ is refused.
    let coarse = Grid::new([4; 3], Vec3::ZERO, 1.0).unwrap();
    assert!(mesh_segmented(&coarse, &seg, &Job::new()).is_err());
}
