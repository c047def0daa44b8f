//! Clouds sampled from analytic shapes with exact normals and exact signed distances.

#![allow(dead_code)]

use glam::{DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_points::knn::Knn;

/// Draws a surface point and its normal.
pub type Sampler = Box<dyn Fn(&mut SplitMix64) -> (DVec3, DVec3)>;

/// An analytic test shape: exact signed distance, and a sampler of surface points with
/// exact outward normals.
pub struct Shape {
    /// Name for reports.
    pub name: &'static str,
    /// Exact signed distance.
    pub sdf: Box<dyn Fn(DVec3) -> f64 + Sync>,
    /// A surface point and its exact outward unit normal.
    pub sample: Sampler,
    /// Smallest radius of curvature (offsets along the normal stay exact below it).
    pub min_radius: f64,
}

/// The unit sphere.
pub fn sphere() -> Shape {
    let r = 1.0;
    Shape {
        name: "sphere",
        sdf: Box::new(move |p: DVec3| p.length() - r),
        sample: Box::new(move |rng| {
            let n = rng.unit_vector().as_dvec3().normalize();
            (n * r, n)
        }),
        min_radius: r,
    }
}

/// Torus R = 1, r = 0.35 around z, sampled uniformly by area.
pub fn torus() -> Shape {
    let (big, small) = (1.0f64, 0.35f64);
    Shape {
        name: "torus",
        sdf: Box::new(move |p: DVec3| {
            let q = (p.x * p.x + p.y * p.y).sqrt() - big;
            (q * q + p.z * p.z).sqrt() - small
        }),
        sample: Box::new(move |rng| {
            loop {
                let phi = std::f64::consts::TAU * rng.next_f64();
                let theta = std::f64::consts::TAU * rng.next_f64();
                if rng.next_f64() > (big + small * theta.cos()) / (big + small) {
                    continue;
                }
                let n = DVec3::new(
                    theta.cos() * phi.cos(),
                    theta.cos() * phi.sin(),
                    theta.sin(),
                );
                let c = DVec3::new(big * phi.cos(), big * phi.sin(), 0.0);
                return (c + small * n, n);
            }
        }),
        min_radius: small,
    }
}

/// A box of half-size (0.8, 0.6, 0.5) with edges rounded by 0.25, sampled uniformly by area
/// (rejection from a thin shell, then the exact projection).
pub fn rounded_box() -> Shape {
    let half = DVec3::new(0.8, 0.6, 0.5);
    let r = 0.25;
    let inner = half - DVec3::splat(r);
    let sdf = move |p: DVec3| {
        let q = p.abs() - inner;
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - r
    };
    Shape {
        name: "rounded box",
        sdf: Box::new(sdf),
        sample: Box::new(move |rng| {
            loop {
                let x = DVec3::new(
                    (2.0 * rng.next_f64() - 1.0) * (half.x + 0.01),
                    (2.0 * rng.next_f64() - 1.0) * (half.y + 0.01),
                    (2.0 * rng.next_f64() - 1.0) * (half.z + 0.01),
                );
                if sdf(x).abs() > 0.01 {
                    continue;
                }
                let q = x.clamp(-inner, inner);
                let d = x - q;
                if d.length() < 1e-6 {
                    continue;
                }
                let n = d.normalize();
                return (q + r * n, n);
            }
        }),
        min_radius: r,
    }
}

/// `n` samples with exact normals, from a seed.
pub fn cloud(shape: &Shape, n: usize, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let (p, nn) = (shape.sample)(&mut rng);
            (p.as_vec3(), nn.as_vec3())
        })
        .unzip()
}

/// Mean distance from each sample to its nearest other sample.
pub fn spacing(points: &[Vec3]) -> f64 {
    let knn = Knn::new(points).unwrap();
    let mut buf = Vec::new();
    let mut s = 0.0;
    for p in points {
        knn.nearest(p.as_dvec3(), 2, &mut buf);
        s += buf[1].1.sqrt();
    }
    s / points.len() as f64
}

/// `m` points offset from fresh surface samples (seed `seed`) along the exact normal by
/// t ∈ [−2h, 2h], with their exact signed distances.
pub fn band_points(shape: &Shape, h: f64, m: usize, seed: u64) -> Vec<(DVec3, f64)> {
    let mut rng = SplitMix64::new(seed);
    (0..m)
        .map(|_| {
            let (p, n) = (shape.sample)(&mut rng);
            let t = (2.0 * rng.next_f64() - 1.0) * 2.0 * h;
            let x = p + t * n;
            (x, (shape.sdf)(x))
        })
        .collect()
}

/// RMS and max of `f(x) − exact` over `pts`.
pub fn rms_max(pts: &[(DVec3, f64)], f: impl Fn(DVec3) -> f64) -> (f64, f64) {
    let (mut s2, mut max) = (0.0, 0.0f64);
    for &(x, exact) in pts {
        let e = f(x) - exact;
        s2 += e * e;
        max = max.max(e.abs());
    }
    ((s2 / pts.len().max(1) as f64).sqrt(), max)
}

/// Default options with each of the three weightings (partition of unity, Shepard, Nie04).
pub fn all_weightings() -> [isokit_points::PointSdfOptions; 3] {
    use isokit_points::{PointSdfOptions, Weighting};
    [
        Weighting::PolyGauss,
        Weighting::Shepard,
        Weighting::Nie04 { neighbours: 18 },
    ]
    .map(|weighting| PointSdfOptions {
        weighting,
        ..PointSdfOptions::default()
    })
}
