//! A cloud's field on a grid, and at given points: the pipeline `isokit points` and
//! `isokit query` run, and the Python bindings call.
//!
//! [`cloud_to_grid`] builds the [`PointSdf`] (normals given or estimated) and samples it on
//! a lattice, either densely (every sample, at f64 positions) or lazily within a narrow band:
//! one evaluation per brick decides, by the field's Lipschitz estimate (1.5, see
//! [`PointSdf`]'s `lipschitz`), which bricks may come within the band, the others read
//! `±band`, and the result is clamped to `±band` so that it equals the dense sampling clamped
//! the same way. [`query_cloud`] evaluates the field at given points.

use crate::{
    BuildStats, NormalOptions, NormalReport, NormalSource, PointSdf, PointSdfOptions, PointsError,
};
use glam::DVec3;
use isokit_field::{BrickGrid, FieldError, Grid, Job, PointCloud};
use rayon::prelude::*;
use std::time::Instant;

/// How [`cloud_to_grid`] builds and samples the field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudGridOptions {
    /// The field's knobs.
    pub field: PointSdfOptions,
    /// Where the normals come from; `None`: the cloud's own when it has them, else estimated
    /// with the default [`NormalOptions`] ([`NormalSource::for_cloud`]).
    pub normals: Option<NormalSource>,
    /// Narrow band half-width W: evaluate only the bricks that may come within W of the
    /// surface and clamp every sample to `±W` (the sign is kept). `None`: every sample.
    pub band: Option<f32>,
    /// Brick edge in samples for `band` (a power of two from 2 to 256). Small bricks follow
    /// the surface more closely, at one extra evaluation per brick.
    pub brick: usize,
    /// The solve of the constants stops once the field at the samples is within this
    /// fraction of the grid's spacing (root mean square; [`PointSdfOptions::residual_target`],
    /// which it raises to that at least). 0: solve to the field's own tolerance. Default
    /// [`SOLVE_TO_GRID`].
    pub solve_to_grid: f64,
}

/// The default [`CloudGridOptions::solve_to_grid`]: a thousandth of the grid's spacing. On
/// 10^6 samples and a 256 grid (7 sample spacings per grid spacing) the field at the samples
/// is below it before the first iteration, and the field at the grid's nodes near the surface
/// moves by about 1% RMS (BENCHMARKS.md); on clouds as fine as the grid the full solve's
/// residual is about as large, so little changes there.
pub const SOLVE_TO_GRID: f64 = 1e-3;

impl Default for CloudGridOptions {
    fn default() -> Self {
        Self {
            field: PointSdfOptions::default(),
            normals: None,
            band: None,
            brick: 4,
            solve_to_grid: SOLVE_TO_GRID,
        }
    }
}

/// The band sampling of [`cloud_to_grid`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandStats {
    /// The band half-width W.
    pub band: f32,
    /// The brick edge in samples.
    pub brick: usize,
    /// Share of the dense grid's samples that were evaluated (one per skipped brick
    /// included).
    pub evaluated_fraction: f64,
    /// Bricks evaluated.
    pub bricks_kept: usize,
    /// Bricks of the lattice.
    pub bricks_total: usize,
}

/// What [`cloud_to_grid`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudGridStats {
    /// The estimated normals' report; `None` when the cloud's own normals were used.
    pub normals: Option<NormalReport>,
    /// How the field was built: samples, duplicates, the solve.
    pub build: BuildStats,
    /// Seconds building the field, normal estimation included.
    pub build_seconds: f64,
    /// The band sampling; `None` for the dense one.
    pub band: Option<BandStats>,
    /// Seconds sampling the grid.
    pub sample_seconds: f64,
}

/// Why [`cloud_to_grid`] failed.
#[derive(Debug, thiserror::Error)]
pub enum CloudGridError {
    /// The cloud cannot become a field (empty, non-finite, no normals, bad knobs).
    #[error(transparent)]
    Points(#[from] PointsError),
    /// The lattice or the bricks are invalid, or the job was cancelled.
    #[error(transparent)]
    Field(#[from] FieldError),
}

impl From<isokit_field::Cancelled> for CloudGridError {
    fn from(c: isokit_field::Cancelled) -> Self {
        Self::Field(c.into())
    }
}

impl NormalSource {
    /// The cloud's own normals when it has them, else estimated with `estimate`.
    pub fn for_cloud(cloud: &PointCloud, estimate: NormalOptions) -> Self {
        if cloud.normals.is_some() {
            NormalSource::Given
        } else {
            NormalSource::Estimate(estimate)
        }
    }
}

/// Builds the field of `cloud` and overwrites every sample of `grid` (which gives the
/// lattice: dimensions, origin, spacing) with it, densely or within a band (see the module
/// docs). Progress goes to `job`: stage `"points"` per sample for the dense sampling,
/// `"sampling bricks"` per brick for the band; cancellation is checked per slice or brick.
///
/// While the band is sampled the dense buffer is freed; `grid` gets a new one at the end.
pub fn cloud_to_grid(
    cloud: &PointCloud,
    grid: &mut Grid,
    opts: &CloudGridOptions,
    job: &Job,
) -> Result<CloudGridStats, CloudGridError> {
    if let Some(w) = opts.band
        && !(w.is_finite() && w > 0.0)
    {
        return Err(PointsError::Parameter(format!("band {w} must be finite and positive")).into());
    }
    let source = opts
        .normals
        .unwrap_or_else(|| NormalSource::for_cloud(cloud, NormalOptions::default()));
    let target = opts.solve_to_grid * f64::from(grid.spacing());
    if !(opts.solve_to_grid >= 0.0 && target.is_finite()) {
        return Err(PointsError::Parameter(format!(
            "solve-to-grid fraction {} must be finite and non-negative",
            opts.solve_to_grid
        ))
        .into());
    }
    let field = PointSdfOptions {
        residual_target: opts.field.residual_target.max(target),
        ..opts.field
    };
    let t = Instant::now();
    let (sdf, normals) = PointSdf::from_cloud(cloud, source, &field)?;
    let build_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let band = match opts.band {
        Some(w) => {
            let (dims, origin, spacing) = (grid.dims(), grid.origin(), grid.spacing());
            drop(std::mem::replace(
                grid,
                Grid::new([1, 1, 1], origin, spacing)?,
            ));
            let bricks =
                BrickGrid::sample_field_job(&sdf, dims, origin, spacing, opts.brick, 0, w, w, job)?;
            let stats = BandStats {
                band: w,
                brick: opts.brick,
                evaluated_fraction: bricks.evaluated_fraction(),
                bricks_kept: bricks.brick_count(),
                bricks_total: bricks.brick_dims().iter().product(),
            };
            *grid = bricks.to_grid()?;
            // Kept bricks hold values beyond the band.
            grid.clamp_to_band(w);
            Some(stats)
        }
        None => {
            isokit_field::fill_slices(
                grid,
                job,
                "points",
                |_, positions, values| {
                    let mut nb = Vec::new();
                    for (p, v) in positions.zip(values.iter_mut()) {
                        *v = sdf.evaluate_after(p, &mut nb).value as f32;
                    }
                },
                |(), ()| (),
            )?;
            None
        }
    };
    Ok(CloudGridStats {
        normals,
        build: sdf.stats().clone(),
        build_seconds,
        band,
        sample_seconds: t.elapsed().as_secs_f64(),
    })
}

/// What [`query_cloud`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudQuery {
    /// The field at each query point, in their order; NaN at non-finite points.
    pub distances: Vec<f32>,
    /// Query points that were not finite.
    pub non_finite: usize,
    /// Samples of the field (after removing duplicates).
    pub samples: usize,
    /// True when the normals were estimated (the cloud has none).
    pub normals_estimated: bool,
    /// Seconds building the field, normal estimation included.
    pub build_seconds: f64,
}

impl PointSdf {
    /// The field at many points, in parallel, as f32; NaN at non-finite points. Points
    /// near their predecessors (a grid, a path) are answered faster.
    pub fn values_at(&self, points: &[DVec3]) -> Vec<f32> {
        points
            .par_iter()
            .map_init(Vec::new, |nb, p| {
                if p.is_finite() {
                    self.evaluate_after(*p, nb).value as f32
                } else {
                    f32::NAN
                }
            })
            .collect()
    }
}

/// The field of `cloud` built with `opts` (normals given when the cloud has them, else
/// estimated with the defaults) at `points`.
pub fn query_cloud(
    cloud: &PointCloud,
    points: &[DVec3],
    opts: &PointSdfOptions,
) -> Result<CloudQuery, PointsError> {
    let source = NormalSource::for_cloud(cloud, NormalOptions::default());
    let t = Instant::now();
    let (sdf, report) = PointSdf::from_cloud(cloud, source, opts)?;
    let build_seconds = t.elapsed().as_secs_f64();
    let distances = sdf.values_at(points);
    Ok(CloudQuery {
        non_finite: distances.iter().filter(|d| d.is_nan()).count(),
        distances,
        samples: sdf.stats().samples,
        normals_estimated: report.is_some(),
        build_seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use isokit_field::{Aabb, Field};

    fn torus() -> (PointCloud, Grid) {
        let cloud = isokit_field::generate::torus_cloud(1.0, 0.35, 3000, 7);
        let grid = Grid::covering(Aabb::from_points(&cloud.points), 40, 0.2).unwrap();
        (cloud, grid)
    }

    /// On a cloud much finer than the grid the solve stops at the grid's precision (after
    /// one iteration here, against 64), and the grid differs from the fully solved one by little
    /// beside its spacing; 0 solves fully.
    #[test]
    fn the_solve_stops_at_the_grid_precision() {
        let cloud = isokit_field::generate::torus_cloud(1.0, 0.35, 60_000, 7);
        let grid = Grid::covering(Aabb::from_points(&cloud.points), 24, 0.2).unwrap();
        let h = f64::from(grid.spacing());
        let job = Job::default();
        let run = |solve_to_grid| {
            let mut g = grid.clone();
            let opts = CloudGridOptions {
                solve_to_grid,
                ..Default::default()
            };
            let st = cloud_to_grid(&cloud, &mut g, &opts, &job).unwrap();
            (g, st.build.solve.unwrap())
        };
        let (short, s) = run(SOLVE_TO_GRID);
        let (full, f) = run(0.0);
        println!("grid precision: {s:?}\nfull: {f:?}");
        assert!(
            s.reached_target && s.iterations < f.iterations,
            "{s:?} {f:?}"
        );
        assert!(!f.reached_target && f.converged, "{f:?}");
        let near = |v: f32| f64::from(v.abs()) < h;
        let worst = short
            .data()
            .iter()
            .zip(full.data())
            .filter(|(a, b)| near(**a) || near(**b))
            .map(|(a, b)| f64::from((a - b).abs()))
            .fold(0.0, f64::max);
        println!(
            "largest difference within a spacing of the surface: {:.2e} h",
            worst / h
        );
        assert!(worst < 0.01 * h, "{worst} against spacing {h}");
        let bad = CloudGridOptions {
            solve_to_grid: -1.0,
            ..Default::default()
        };
        assert!(cloud_to_grid(&cloud, &mut grid.clone(), &bad, &job).is_err());
    }

    /// The band path equals the dense path clamped to ±W (the lazy one evaluates at f32
    /// positions, the dense one at f64 ones), and evaluates less.
    #[test]
    fn band_equals_the_clamped_dense_grid() {
        let (cloud, mut dense) = torus();
        let mut band = dense.clone();
        let job = Job::default();
        let d = cloud_to_grid(&cloud, &mut dense, &CloudGridOptions::default(), &job).unwrap();
        assert!(d.band.is_none() && d.normals.is_none());
        let w = 0.05;
        let opts = CloudGridOptions {
            band: Some(w),
            ..Default::default()
        };
        let b = cloud_to_grid(&cloud, &mut band, &opts, &job).unwrap();
        let s = b.band.unwrap();
        assert!(
            s.evaluated_fraction < 1.0 && s.bricks_kept < s.bricks_total,
            "{s:?}"
        );
        assert_eq!((band.dims(), band.origin()), (dense.dims(), dense.origin()));
        for (x, y) in dense.data().iter().zip(band.data()) {
            assert!((x.clamp(-w, w) - y).abs() < 1e-5, "{x} vs {y}");
        }
        let bad = CloudGridOptions {
            band: Some(f32::NAN),
            ..Default::default()
        };
        assert!(cloud_to_grid(&cloud, &mut band, &bad, &job).is_err());
    }

    /// Evaluating points one after another, each neighbour search bounded by the previous
    /// point's answer (a brick's samples, a grid's rows, a list of queries), gives every
    /// value bit for bit as evaluating each point alone, in any order and across jumps.
    #[test]
    fn nearby_values_equal_single_values() {
        let (cloud, _) = torus();
        let sdf = PointSdf::new(
            &cloud.points,
            cloud.normals.as_ref().unwrap(),
            &PointSdfOptions::default(),
        )
        .unwrap();
        let mut pts: Vec<glam::Vec3> = (0..512)
            .map(|n| {
                glam::Vec3::new(
                    1.0 + 0.02 * (n % 8) as f32,
                    0.02 * ((n / 8) % 8) as f32,
                    -0.2 + 0.05 * (n / 64) as f32,
                )
            })
            .collect();
        pts.extend([
            glam::Vec3::new(0.0, 0.0, 3.0),
            glam::Vec3::new(-1.3, 0.0, 0.0),
            glam::Vec3::new(1.0, 0.0, 0.0),
            glam::Vec3::NAN,
            glam::Vec3::new(0.3, -0.9, 0.1),
        ]);
        let single: Vec<f32> = pts.iter().map(|&p| sdf.value(p)).collect();
        for order in [false, true] {
            let mut p = pts.clone();
            let mut want = single.clone();
            if order {
                p.reverse();
                want.reverse();
            }
            let mut out = vec![0.0; p.len()];
            sdf.values_nearby(&p, &mut out);
            for (i, (a, b)) in out.iter().zip(&want).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "point {i} {}", p[i]);
            }
        }
        let at: Vec<DVec3> = pts.iter().map(|p| p.as_dvec3()).collect();
        for (i, v) in sdf.values_at(&at).iter().enumerate() {
            if pts[i].is_finite() {
                assert_eq!(v.to_bits(), single[i].to_bits(), "point {i}");
            } else {
                assert!(v.is_nan());
            }
        }
    }

    /// Without normals they are estimated and reported; the queries match the field.
    #[test]
    fn estimated_normals_and_queries() {
        let (mut cloud, mut grid) = torus();
        cloud.normals = None;
        let s = cloud_to_grid(
            &cloud,
            &mut grid,
            &CloudGridOptions::default(),
            &Job::default(),
        )
        .unwrap();
        assert!(s.normals.is_some());
        let pts = [
            DVec3::new(1.35, 0.0, 0.0),
            DVec3::NAN,
            DVec3::new(0.0, 0.0, 2.0),
        ];
        let q = query_cloud(&cloud, &pts, &PointSdfOptions::default()).unwrap();
        assert!(q.normals_estimated && q.non_finite == 1, "{q:?}");
        assert!(q.distances[0].abs() < 0.03, "{q:?}");
        assert!(q.distances[2] > 0.5, "{q:?}");
        let (sdf, _) = PointSdf::from_cloud(
            &cloud,
            NormalSource::for_cloud(&cloud, NormalOptions::default()),
            &PointSdfOptions::default(),
        )
        .unwrap();
        assert_eq!(q.distances[2], sdf.value(glam::Vec3::new(0.0, 0.0, 2.0)));
    }
}
