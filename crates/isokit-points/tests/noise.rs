//! The automatic `k` and damping (`isokit_points::noise`): on clean and noisy clouds of a
//! torus, the knobs chosen from the noise estimate give an RMS error (lattice nodes within 2
//! spacings of the surface, against the exact distance) within 1.2× of the best setting of
//! the grid k ∈ {8, 16, 32, 64} × damping ∈ {0.05, 0.2, 1}.

use glam::{DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_points::noise::estimate_noise;
use isokit_points::{PointSdf, PointSdfOptions};
use rayon::prelude::*;

const MAJOR: f64 = 0.6;
const MINOR: f64 = 0.25;

fn torus_sdf(p: DVec3) -> f64 {
    let q = (p.x * p.x + p.y * p.y).sqrt() - MAJOR;
    (q * q + p.z * p.z).sqrt() - MINOR
}

/// `n` samples of the torus with exact normals (`isokit_field::generate::torus_cloud`), moved
/// by isotropic Gaussian noise of deviation `sigma`.
fn torus_cloud(n: usize, sigma: f64, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let c = isokit_field::generate::torus_cloud(MAJOR as f32, MINOR as f32, n, seed);
    let mut r = SplitMix64::new(seed + 1);
    let p = c
        .points
        .iter()
        .map(|q| {
            let d = DVec3::new(r.gaussian(), r.gaussian(), r.gaussian());
            (q.as_dvec3() + sigma * d).as_vec3()
        })
        .collect();
    (p, c.normals.unwrap())
}

/// RMS error in spacings at the nodes of a 40-sample lattice over the torus within 2
/// spacings of its surface.
fn rms_error(p: &[Vec3], n: &[Vec3], k: usize, damping: f64) -> f64 {
    let opts = PointSdfOptions {
        k,
        damping,
        ..PointSdfOptions::default()
    };
    let sdf = PointSdf::new(p, n, &opts).unwrap();
    let lo = DVec3::new(-0.95, -0.95, -0.35);
    let h = 1.9 / 39.0;
    let nodes: Vec<DVec3> = (0..40 * 40 * 15)
        .map(|i| lo + h * DVec3::new((i % 40) as f64, ((i / 40) % 40) as f64, (i / 1600) as f64))
        .filter(|x| torus_sdf(*x).abs() <= 2.0 * h)
        .collect();
    let sum: f64 = nodes
        .par_iter()
        .map(|x| {
            let e = sdf.evaluate(*x).value - torus_sdf(*x);
            e * e
        })
        .sum();
    (sum / nodes.len() as f64).sqrt() / h
}

fn check(noise: f64) {
    let diag = 2.0 * (2.0 * (MAJOR + MINOR).powi(2) + MINOR * MINOR).sqrt();
    let (p, n) = torus_cloud(12_000, noise * diag, 17);
    let est = estimate_noise(&p).unwrap();
    let (k, damping) = est.knobs();
    let auto = rms_error(&p, &n, k, damping);
    let mut best = (f64::INFINITY, 0, 0.0);
    for gk in [8, 16, 32, 64] {
        for gd in [0.05, 0.2, 1.0] {
            let e = rms_error(&p, &n, gk, gd);
            if e < best.0 {
                best = (e, gk, gd);
            }
        }
    }
    eprintln!(
        "noise {:.1}% of the diagonal: estimate {:.3} spacings, chosen k {k}, damping {damping}: RMS {auto:.3} spacings; best k {}, damping {}: {:.3}",
        100.0 * noise,
        est.ratio(),
        best.1,
        best.2,
        best.0
    );
    assert!(auto <= 1.2 * best.0, "{auto} against the best {}", best.0);
}

#[test]
fn automatic_knobs_on_a_clean_cloud() {
    check(0.0);
}

#[test]
fn automatic_knobs_with_half_a_percent_noise() {
    check(0.005);
}

#[test]
fn automatic_knobs_with_two_percent_noise() {
    check(0.02);
}
