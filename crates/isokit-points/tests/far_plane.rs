//! ERRATA item 6 on a dense regular planar sampling (002 Eq. 4.13–4.15): the corrected
//! weight is ≈ 1 on the plane and 0 beyond about 5 spacings, the scale-invariant distance
//! grows linearly, and the printed Eq. 4.15 gives w ≈ 0.5 on the surface. Then the
//! centroid rule (the default) against the spread rule of 002 on the same plane and in a gap
//! of it.

use glam::{DVec3, Vec3};
use isokit_points::far::centroid_distance;
use isokit_points::far::{blend_weight, blend_weight_printed, scale_invariant_distance, sigma_bar};
use isokit_points::knn::Knn;
use isokit_points::{FarRule, PointSdf, PointSdfOptions};

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
            far_rule: FarRule::Spread,
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

/// The scale-invariant distance of the centroid rule at `x` over its `m` nearest samples.
fn centroid_at(knn: &Knn, p: &[Vec3], x: DVec3, m: usize) -> f64 {
    let mut nb = Vec::new();
    knn.nearest(x, m, &mut nb);
    centroid_distance(x, nb.iter().map(|&(j, _)| (p[j].as_dvec3(), DVec3::Z))).unwrap()
}

#[test]
fn centroid_rule_reaches_as_far_as_the_spread_rule() {
    let (p, _) = plane();
    let knn = Knn::new(&p).unwrap();
    // The dissertation's statistics over 64 samples against the centroid of 16, 32 and 64: the
    // same distance within 25% from one spacing up, whatever the number of samples.
    for step in 4..=32 {
        let z = step as f64 * 0.25;
        let x = DVec3::new(0.5, 0.5, z);
        let mut nb = Vec::new();
        knn.nearest(x, 64, &mut nb);
        let spread =
            scale_invariant_distance(sigma_bar(nb.iter().map(|&(_, d2)| d2.sqrt())).unwrap());
        for m in [16, 32, 64] {
            let c = centroid_at(&knn, &p, x, m);
            println!("z {z:5.2}: spread {spread:.3}, centroid of {m} {c:.3}");
            assert!(
                (c / spread - 1.0).abs() < 0.25,
                "z {z}, m {m}: {c} against {spread}"
            );
        }
    }
}

#[test]
fn centroid_rule_stays_on_the_surface_in_a_gap() {
    // The lattice with every sample within 3.5 spacings of the origin removed: a gap 7
    // spacings wide, as random clouds have them.
    let (p, n): (Vec<Vec3>, Vec<Vec3>) = plane()
        .0
        .into_iter()
        .filter(|q| q.length() > 3.5)
        .map(|q| (q, Vec3::Z))
        .unzip();
    let field = |rule| {
        PointSdf::new(
            &p,
            &n,
            &PointSdfOptions {
                far_rule: rule,
                // The spread rule over its former default.
                far_k: if rule == FarRule::Spread { 64 } else { 16 },
                ..PointSdfOptions::default()
            },
        )
        .unwrap()
    };
    let (centroid, spread) = (field(FarRule::Centroid), field(FarRule::Spread));
    for (x, y) in [(0.0, 0.0), (0.7, -0.4), (1.5, 1.0)] {
        for z in [0.0, 0.5, 1.0] {
            let q = DVec3::new(x, y, z);
            let (c, s) = (centroid.evaluate(q), spread.evaluate(q));
            println!(
                "({x}, {y}, {z}): centroid w {:.3} f {:.4}; spread w {:.3} f {:.4}",
                c.weight, c.value, s.weight, s.value
            );
            // The near field is exact on a plane; the centroid rule keeps the weight near 1
            // up to a spacing above the gap, where the closest sample is 2.5–5 spacings away.
            assert!((c.value - z).abs() < 0.05, "centroid: {}", c.value);
            if z == 0.0 {
                assert_eq!(c.weight, 1.0);
                // The spread rule reads the gap as height and mixes in the distance to the
                // closest sample (2.5–3.5 spacings here).
                assert!(s.weight < 0.9 && s.value > 0.1, "spread: {s:?}");
            }
        }
    }
}

#[test]
fn past_the_edge_of_an_open_surface_the_far_field_takes_over() {
    // Beside the lattice, in its plane: every nearest sample lies on the edge with the same
    // normal, so the height above them is 0; the offset beyond their disc must count.
    let (p, n) = plane();
    for rule in [FarRule::Centroid, FarRule::Spread] {
        let sdf = PointSdf::new(
            &p,
            &n,
            &PointSdfOptions {
                far_rule: rule,
                ..PointSdfOptions::default()
            },
        )
        .unwrap();
        let mut last = f64::INFINITY;
        for past in [1.0, 5.0, 12.0, 20.0, 30.0] {
            let e = sdf.evaluate(DVec3::new(40.0 + past, 0.0, 0.0));
            println!(
                "{rule:?}, {past} past the edge: w {:.3}, f {:.3}",
                e.weight, e.value
            );
            assert!(e.weight <= last, "{rule:?} {past}: the weight grows");
            last = e.weight;
            if past >= 30.0 {
                // The distance to the edge, not the continued plane's 0.
                assert_eq!(e.weight, 0.0, "{rule:?} {past}");
                assert!(
                    (e.value - past).abs() < 1e-9,
                    "{rule:?} {past}: {}",
                    e.value
                );
            }
        }
    }
}
