//! ERRATA item 6 on a dense regular planar sampling (002 Eq. 4.13–4.15): the corrected
//! weight is ≈ 1 on the plane and 0 beyond about 5 spacings, the scale-invariant distance
//! grows linearly, and the printed Eq. 4.15 gives w ≈ 0.5 on the surface.

use glam::{DVec3, Vec3};
use isokit_points::far::{blend_weight, blend_weight_printed, scale_invariant_distance, sigma_bar};
use isokit_points::knn::Knn;
use isokit_points::{PointSdf, PointSdfOptions};

const K: usize = 20;

fn plane() -> (Vec<Vec3>, Vec<Vec3>) {
    let mut p = Vec::new();
    for j in -40..=40 {
        for i in -40..=40 {
            p.push(Vec3::new(i as f32, j as f32, 0.0));
        }
    }
    let n = vec![Vec3::Z; p.len()];
    (p, n)
}

fn stats(knn: &Knn, x: DVec3) -> f64 {
    let mut nb = Vec::new();
    knn.nearest(x, K, &mut nb);
    sigma_bar(nb.iter().map(|&(_, d2)| d2.sqrt())).unwrap()
}

#[test]
fn corrected_weight_on_a_regular_plane() {
    let (p, n) = plane();
    let knn = Knn::new(&p).unwrap();
    let sdf = PointSdf::new(
        &p,
        &n,
        &PointSdfOptions {
            k: K,
            far_k: K,
            ..PointSdfOptions::default()
        },
    )
    .unwrap();
    // Over the plane at a cell centre (a generic surface point between samples) and at a
    // quarter position; spacing 1.
    for (ox, oy) in [(0.5, 0.5), (0.25, 0.0)] {
        let mut ds = Vec::new();
        println!("offset ({ox}, {oy}): z, σ̄, d̃, w, w printed (Eq. 4.15), f");
        for step in 0..=32 {
            let z = step as f64 * 0.25;
            let x = DVec3::new(ox, oy, z);
            let s = stats(&knn, x);
            let (d, w, wp) = (
                scale_invariant_distance(s),
                blend_weight(s),
                blend_weight_printed(s),
            );
            let f = sdf.evaluate(x).value;
            println!("{z:5.2} {s:.4} {d:6.3} {w:.3} {wp:.3} {f:.4}");
            ds.push((z, d));
            if z == 0.0 {
                assert!(w > 0.9, "w = {w} on the plane");
                assert!((wp - 0.5).abs() < 0.15, "printed w = {wp} on the plane");
                assert!(f.abs() < 1e-9, "f = {f} on the plane");
            }
            if z >= 5.0 {
                assert_eq!(w, 0.0, "w = {w} at z = {z}");
            }
            // The near field is exact on a plane; the far field is the distance to the
            // closest sample, at most sqrt(z² + 1/2) here.
            assert!(
                f >= z - 1e-9 && f <= (z * z + 0.5).sqrt() + 1e-9,
                "f = {f} at z = {z}"
            );
        }
        // d̃ grows linearly with z: slopes over [1, 2], [2, 4] and [4, 8] agree within 15%.
        let at = |z: f64| ds.iter().find(|(zz, _)| *zz == z).unwrap().1;
        let slopes = [
            at(2.0) - at(1.0),
            (at(4.0) - at(2.0)) / 2.0,
            (at(8.0) - at(4.0)) / 4.0,
        ];
        println!("slopes of d̃: {slopes:?}");
        for s in slopes {
            assert!((s / slopes[1] - 1.0).abs() < 0.15, "{slopes:?}");
        }
        // The printed weight already vanishes by about one spacing, where the corrected one
        // is still above 1/2: the printed form does not behave.
        let s1 = stats(&knn, DVec3::new(ox, oy, 1.0));
        println!(
            "z = 1: w {:.3}, printed {:.3}",
            blend_weight(s1),
            blend_weight_printed(s1)
        );
    }
}
