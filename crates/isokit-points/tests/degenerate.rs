//! Degenerate input gives a result or a clear error, never a panic.

use glam::{DVec3, Vec3};
use isokit_field::Field;
mod common;
use common::all_weightings;
use isokit_points::{
    NormalOptions, PointSdf, PointSdfOptions, PointsError, Weighting, estimate_normals,
};

fn sphere(n: usize) -> (Vec<Vec3>, Vec<Vec3>) {
    let cloud = isokit_io::generate::torus_cloud(1.0, 0.4, n, 3);
    (cloud.points, cloud.normals.unwrap())
}

#[test]
fn empty_nan_and_bad_normals_are_errors() {
    let o = PointSdfOptions::default();
    assert_eq!(PointSdf::new(&[], &[], &o).unwrap_err(), PointsError::Empty);
    let p = vec![Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X];
    let n = vec![Vec3::Z; 3];
    let e = PointSdf::new(&p, &n, &o).unwrap_err();
    assert!(
        matches!(e, PointsError::NonFinitePoint { index: 1, .. }),
        "{e}"
    );
    println!("{e}");
    let e = estimate_normals(&p, &NormalOptions::default()).unwrap_err();
    assert!(matches!(e, PointsError::NonFinitePoint { index: 1, .. }));
    let p = vec![Vec3::ZERO, Vec3::X];
    let e = PointSdf::new(&p, &[Vec3::Z, Vec3::ZERO], &o).unwrap_err();
    assert_eq!(e, PointsError::BadNormal { index: 1 });
    let e = PointSdf::new(&p, &[Vec3::Z], &o).unwrap_err();
    assert!(matches!(e, PointsError::NormalCount { .. }));
    let e = PointSdf::new(&p, &[Vec3::Z; 2], &PointSdfOptions { k: 0, ..o }).unwrap_err();
    assert!(matches!(e, PointsError::Parameter(_)));
    let e = estimate_normals(&p, &NormalOptions::default()).unwrap_err();
    assert!(matches!(e, PointsError::TooFewPoints { .. }), "{e}");
}

#[test]
fn fewer_points_than_k() {
    for n in [1usize, 2, 3, 5] {
        let p: Vec<Vec3> = (0..n).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let nn = vec![Vec3::Z; n];
        for o in all_weightings() {
            let sdf = PointSdf::new(&p, &nn, &o).unwrap();
            assert_eq!(sdf.options().k, n);
            // Above and below the line of samples: the sign follows the normals.
            let up = sdf.value(Vec3::new(0.3, 0.0, 0.5));
            let down = sdf.value(Vec3::new(0.3, 0.0, -0.5));
            assert!(
                up > 0.0 && down < 0.0,
                "n {n} {:?}: {up} {down}",
                o.weighting
            );
        }
    }
    let p: Vec<Vec3> = (0..5)
        .map(|i| Vec3::new(i as f32, (i * i) as f32, 0.0))
        .collect();
    let rep = estimate_normals(&p, &NormalOptions::default()).unwrap();
    assert_eq!(rep.k, 5);
    assert!(rep.normals.iter().all(|n| n.is_finite()));
}

#[test]
fn duplicate_points() {
    let (p, n) = sphere(2000);
    let mut p2 = p.clone();
    p2.extend_from_slice(&p);
    let mut n2 = n.clone();
    n2.extend_from_slice(&n);
    let a = PointSdf::new(&p, &n, &PointSdfOptions::default()).unwrap();
    let b = PointSdf::new(&p2, &n2, &PointSdfOptions::default()).unwrap();
    assert_eq!(b.stats().duplicates_removed, 2000);
    for q in [
        Vec3::new(1.4, 0.0, 0.0),
        Vec3::new(0.2, 0.9, 0.1),
        Vec3::splat(3.0),
    ] {
        assert_eq!(a.value(q), b.value(q));
    }
    // Duplicates in normal estimation: PCA still sees the plane.
    let rep = estimate_normals(&p2, &NormalOptions::default()).unwrap();
    let flips = rep
        .normals
        .iter()
        .zip(&n2)
        .filter(|(a, b)| a.dot(**b) < 0.0)
        .count();
    assert_eq!(flips, 0);
    // All points the same.
    let same = vec![Vec3::ONE; 50];
    let sdf = PointSdf::new(&same, &vec![Vec3::X; 50], &PointSdfOptions::default()).unwrap();
    assert_eq!(sdf.stats().samples, 1);
    assert!(sdf.value(Vec3::new(2.0, 1.0, 1.0)) > 0.0);
    let rep = estimate_normals(&same, &NormalOptions::default()).unwrap();
    assert_eq!(rep.unreliable.len(), 50);
}

#[test]
fn coplanar_points() {
    let mut p = Vec::new();
    let mut rng = isokit_field::rng::SplitMix64::new(1);
    for _ in 0..1500 {
        p.push(Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.25));
    }
    let rep = estimate_normals(&p, &NormalOptions::default()).unwrap();
    // No x or y component to orient by: the tie-break turns them all to +z.
    assert!(
        rep.normals.iter().all(|n| n.z > 0.999),
        "{:?}",
        &rep.normals[..3]
    );
    assert!(rep.unreliable.is_empty());
    for o in all_weightings() {
        let sdf = PointSdf::new(&p, &rep.normals, &o).unwrap();
        for z in [0.25f32, 0.3, 0.5, 0.0] {
            let f = sdf.value(Vec3::new(0.1, -0.2, z));
            assert!(
                (f - (z - 0.25)).abs() < 0.02,
                "{:?} z {z}: {f}",
                o.weighting
            );
        }
    }
    // Collinear points: reported unreliable, no panic.
    let line: Vec<Vec3> = (0..30).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
    let rep = estimate_normals(&line, &NormalOptions::default()).unwrap();
    assert_eq!(rep.unreliable.len(), 30);
}

#[test]
fn flipped_normals_are_repaired_by_estimation() {
    let (p, mut n) = sphere(3000);
    for v in n.iter_mut().step_by(3) {
        *v = -*v;
    }
    let rep = estimate_normals(&p, &NormalOptions::default()).unwrap();
    let exact = sphere(3000).1;
    let flips = rep
        .normals
        .iter()
        .zip(&exact)
        .filter(|(a, b)| a.dot(**b) < 0.0)
        .count();
    assert_eq!(flips, 0);
    // With the flipped normals given, the field still builds and is finite.
    let sdf = PointSdf::new(&p, &n, &PointSdfOptions::default()).unwrap();
    assert!(sdf.evaluate(DVec3::new(1.4, 0.0, 0.0)).value.is_finite());
}

#[test]
fn extreme_scales() {
    for s in [1e-6f32, 1e6] {
        let (p, n) = sphere(2000);
        let p: Vec<Vec3> = p.iter().map(|q| *q * s).collect();
        let sdf = PointSdf::new(&p, &n, &PointSdfOptions::default()).unwrap();
        let f = sdf.value(Vec3::new(1.5 * s, 0.0, 0.0));
        assert!((f / s - 0.1).abs() < 0.01, "scale {s}: {}", f / s);
        let rep = estimate_normals(&p, &NormalOptions::default()).unwrap();
        let flips = rep
            .normals
            .iter()
            .zip(&n)
            .filter(|(a, b)| a.dot(**b) < 0.0)
            .count();
        assert_eq!(flips, 0, "scale {s}");
    }
}

#[test]
fn opposite_normals_at_one_position_and_near_duplicates() {
    // The same position twice with opposite normals: the first is kept (exact duplicate),
    // so the result is the same as without the second.
    let (p, n) = sphere(1500);
    let mut p2 = p.clone();
    let mut n2 = n.clone();
    p2.push(p[10]);
    n2.push(-n[10]);
    let a = PointSdf::new(&p, &n, &PointSdfOptions::default()).unwrap();
    let b = PointSdf::new(&p2, &n2, &PointSdfOptions::default()).unwrap();
    assert_eq!(b.stats().duplicates_removed, 1);
    let q = p[10] * 1.05;
    assert_eq!(a.value(q), b.value(q));
    // Near duplicates (1e-7 apart, so not removed) with opposite normals: the system is
    // singular there, the damped solve still converges and the field stays finite.
    let mut p3 = p.clone();
    let mut n3 = n.clone();
    for i in (0..p.len()).step_by(50) {
        p3.push(p[i] + Vec3::splat(1e-7));
        n3.push(-n[i]);
    }
    let c = PointSdf::new(&p3, &n3, &PointSdfOptions::default()).unwrap();
    let st = c.stats().solve.unwrap();
    assert!(st.converged && st.relative_residual.is_finite(), "{st:?}");
    assert!(c.constants().iter().all(|v| v.is_finite()));
    for x in [Vec3::ZERO, Vec3::new(0.3, 0.2, 0.9), Vec3::splat(4.0)] {
        assert!(c.value(x).is_finite(), "{x}");
    }
}

#[test]
fn odd_options_give_a_result_or_a_clear_error() {
    let (p, n) = sphere(500);
    let o = PointSdfOptions::default();
    for damping in [-1.0, f64::NAN, f64::INFINITY] {
        let e = PointSdf::new(&p, &n, &PointSdfOptions { damping, ..o }).unwrap_err();
        assert!(matches!(e, PointsError::Parameter(_)), "{e}");
        println!("damping {damping}: {e}");
    }
    for tol in [0.0, -1.0, f64::NAN] {
        let e = PointSdf::new(&p, &n, &PointSdfOptions { tol, ..o }).unwrap_err();
        assert!(matches!(e, PointsError::Parameter(_)), "{e}");
    }
    let e = PointSdf::new(
        &p,
        &n,
        &PointSdfOptions {
            weighting: Weighting::Nie04 { neighbours: 0 },
            ..o
        },
    )
    .unwrap_err();
    assert!(matches!(e, PointsError::Parameter(_)), "{e}");
    let inf = vec![Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::X];
    let e = PointSdf::new(&inf, &[Vec3::Z; 3], &o).unwrap_err();
    assert!(
        matches!(e, PointsError::NonFinitePoint { index: 1, .. }),
        "{e}"
    );
    // Results: no iterations (constants 0), damping 0 (plain least squares), k = 1,
    // far_k below k, more Nie04 neighbours than points, every solver.
    // 0.1 outside the tube (R = 1, r = 0.4).
    let q = Vec3::new(1.5, 0.0, 0.0);
    for opts in [
        PointSdfOptions { max_iter: 0, ..o },
        PointSdfOptions { damping: 0.0, ..o },
        PointSdfOptions { k: 1, ..o },
        PointSdfOptions { far_k: 2, ..o },
        PointSdfOptions {
            solver: isokit_points::Solver::Gmres,
            ..o
        },
        PointSdfOptions {
            solver: isokit_points::Solver::Bicgstab,
            ..o
        },
    ] {
        let sdf = PointSdf::new(&p, &n, &opts).unwrap();
        let v = sdf.value(q);
        assert!((v - 0.1).abs() < 0.05, "{opts:?}: {v}");
    }
    // ILU(0)-preconditioned GMRES is unstable on these systems (see the crate docs): a
    // finite result, not an accurate one.
    let opts = PointSdfOptions {
        solver: isokit_points::Solver::GmresIlu0,
        ..o
    };
    assert!(PointSdf::new(&p, &n, &opts).unwrap().value(q).is_finite());
    // Every sample inside every Nie04 support: a global inverse-square blend, far from
    // exact but finite and with the right sign.
    let opts = PointSdfOptions {
        weighting: Weighting::Nie04 { neighbours: 10_000 },
        ..o
    };
    let v = PointSdf::new(&p, &n, &opts)
        .unwrap()
        .value(Vec3::new(2.0, 0.0, 0.0));
    assert!(v.is_finite() && v > 0.0, "{v}");
}
