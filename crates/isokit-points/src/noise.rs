//! The knobs of [`crate::PointSdf`] chosen from the cloud: an estimate of the noise level,
//! and the `k` and damping that suit it.
//!
//! The estimate is the median over (up to [`NOISE_QUERIES`]) samples of the RMS distance of
//! their 16 nearest neighbours to their best-fitting plane (the square root of the smallest
//! eigenvalue of the neighbourhood's covariance, as in the normal estimation of Hoppe et al.
//! 1992), over the median distance between nearest samples. On clean clouds the ratio comes
//! from curvature alone and stays small; noise of the order of the spacing drives it towards
//! 1.
//!
//! The rule was read off a grid search (k ∈ {8, 16, 32, 64} × damping ∈ {0.05, 0.2, 1}, RMS
//! error within 2 spacings on a 48-sample lattice, 20,000 samples of the sphere, torus and
//! trefoil of `tests/peers/bench_points.py`, Gaussian noise of 0, 0.5% and 2% of the
//! diagonal): clean clouds gave ratios 0.04–0.21 and every setting within 2.3× of the best
//! (the default (16, 0.05) the best or equal), noisy ones 0.69–0.87 with (64, 1) the best in
//! every case (0.23–0.26 spacings against the default's 0.47–0.53 at 0.5% noise; 0.87–0.91
//! against 1.05–1.06 at 2%). So: above [`NOISY_RATIO`] the cloud is treated as noisy.

use crate::knn::Knn;
use crate::{PointSdfOptions, PointsError, check_points};
use glam::Vec3;
use rayon::prelude::*;

/// Samples whose neighbourhoods the estimate looks at (spread evenly over the cloud).
pub const NOISE_QUERIES: usize = 4000;

/// The ratio of [`NoiseEstimate`] above which a cloud is treated as noisy.
pub const NOISY_RATIO: f64 = 0.4;

/// Neighbours per evaluation and LSQR damping for noisy clouds (the best of the grid above).
pub const NOISY_KNOBS: (usize, f64) = (64, 1.0);

/// A cloud's noise level, measured (see the [module](self) docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseEstimate {
    /// Median RMS distance of a sample's 16 nearest neighbours to their plane (world units).
    pub deviation: f64,
    /// Median distance from a sample to its nearest other sample (world units).
    pub spacing: f64,
}

impl NoiseEstimate {
    /// `deviation / spacing` (0 when the spacing is 0).
    pub fn ratio(&self) -> f64 {
        if self.spacing > 0.0 {
            self.deviation / self.spacing
        } else {
            0.0
        }
    }

    /// `k` and damping for this noise level: [`NOISY_KNOBS`] above [`NOISY_RATIO`], else
    /// the defaults of [`PointSdfOptions`].
    pub fn knobs(&self) -> (usize, f64) {
        if self.ratio() > NOISY_RATIO {
            NOISY_KNOBS
        } else {
            let d = PointSdfOptions::default();
            (d.k, d.damping)
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let m = v.len() / 2;
    v.select_nth_unstable_by(m, f64::total_cmp);
    v[m]
}

/// Estimates the noise of a cloud (see the [module](self) docs).
///
/// ```
/// use glam::Vec3;
/// use isokit_points::noise::estimate_noise;
/// // A flat grid of samples: no noise at all.
/// let p: Vec<Vec3> = (0..400).map(|i| Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0)).collect();
/// let e = estimate_noise(&p).unwrap();
/// assert!(e.ratio() < 1e-6 && (e.spacing - 1.0).abs() < 1e-9);
/// ```
pub fn estimate_noise(points: &[Vec3]) -> Result<NoiseEstimate, PointsError> {
    check_points(points)?;
    let knn = Knn::new(points)?;
    let step = points.len().div_ceil(NOISE_QUERIES).max(1);
    let per: Vec<(f64, f64)> = (0..points.len())
        .step_by(step)
        .collect::<Vec<_>>()
        .par_iter()
        .map_init(Vec::new, |nb, &i| {
            let p = points[i].as_dvec3();
            knn.nearest(p, 17, nb);
            let spacing = nb.get(1).map_or(0.0, |&(_, d2)| d2.sqrt());
            let n = nb.len() as f64;
            let c = nb
                .iter()
                .map(|&(j, _)| points[j].as_dvec3())
                .sum::<glam::DVec3>()
                / n;
            let mut m = [[0.0f64; 3]; 3];
            for &(j, _) in nb.iter() {
                let d = points[j].as_dvec3() - c;
                for a in 0..3 {
                    for b in 0..3 {
                        m[a][b] += d[a] * d[b] / n;
                    }
                }
            }
            let (values, _) = crate::eigen::symmetric_eigen(m);
            (values[0].max(0.0).sqrt(), spacing)
        })
        .collect();
    Ok(NoiseEstimate {
        deviation: median(per.iter().map(|p| p.0).collect()),
        spacing: median(per.iter().map(|p| p.1).collect()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_raises_the_ratio_past_the_threshold() {
        let mut rng = isokit_field::rng::SplitMix64::new(5);
        let sphere: Vec<Vec3> = (0..5000).map(|_| rng.unit_vector()).collect();
        let clean = estimate_noise(&sphere).unwrap();
        assert!(clean.ratio() < NOISY_RATIO, "{clean:?}");
        assert_eq!(clean.knobs(), (16, 0.05));
        let diag = 2.0 * 3f32.sqrt();
        let noisy: Vec<Vec3> = sphere
            .iter()
            .map(|p| *p + 0.02 * diag * rng.unit_vector() * rng.range(0.0, 1.5))
            .collect();
        let e = estimate_noise(&noisy).unwrap();
        assert!(e.ratio() > NOISY_RATIO, "{e:?}");
        assert_eq!(e.knobs(), NOISY_KNOBS);
        assert!(estimate_noise(&[]).is_err());
    }
}
