//! # isokit-points
//!
//! Point cloud → signed distance field, after 002 Sec. 4.3 (the meshless distance
//! transform).
//!
//! - [`estimate_normals`]: PCA over the k nearest samples, orientation propagated over a
//!   minimum spanning tree of the k-nearest graph (Hoppe et al. 1992), unreliable normals
//!   reported.
//! - [`PointSdf`]: local linear fields `c_i + n_i·(x − p_i)` blended by a partition of unity
//!   with the weight `(1 − r²/R²)³` (R the distance to the evaluation point's k-th nearest
//!   sample, so the field is defined everywhere), constants `c_i` from a damped sparse
//!   least-squares solve so that the field nearly vanishes at the samples, and a blend with
//!   the signed distance to the closest sample away from the surface ([`far`], ERRATA 6;
//!   its sign from the cloud's winding number, [`winding`], where the nearest samples
//!   disagree). It is a [`isokit_field::Field`]. Comparison variants: [`Weighting::Shepard`] and
//!   [`Weighting::Nie04`].
//! - [`cloud_to_grid`] and [`query_cloud`]: the field sampled on a grid (densely, or lazily
//!   by bricks within a narrow band) and at given points; what `isokit points` and
//!   `isokit query` call.
//!
//! Not for: clouds without a surface (volumetric scatter), or exact distances (use a mesh
//! and `isokit-kdtree`); the field is an approximation whose error is stated below.
//!
//! ```
//! use isokit_points::{PointSdf, PointSdfOptions};
//! use isokit_field::Field;
//! use glam::Vec3;
//!
//! let cloud = isokit_io::generate::torus_cloud(1.0, 0.3, 4000, 7);
//! let sdf = PointSdf::new(&cloud.points, cloud.normals.as_ref().unwrap(),
//!     &PointSdfOptions::default()).unwrap();
//! // On the tube's outer equator, and 0.1 outside it.
//! assert!(sdf.value(Vec3::new(1.3, 0.0, 0.0)).abs() < 0.02);
//! assert!((sdf.value(Vec3::new(1.4, 0.0, 0.0)) - 0.1).abs() < 0.02);
//! ```
//!
//! ## The solver
//! The constants solve `A c = b` ([`PointSdf::interpolation_system`]): `A_ij` is the
//! normalized weight (Eq. 4.10) of sample j at sample i, `b_i = −Σ_j A_ij n_j·(p_i − p_j)`, so
//! `(A c − b)_i` is exactly the near field at `p_i` (same neighbours, same weights as an
//! evaluation there). That is the assembly 002 Sec. 4.3.4 describes; it is not the cause of
//! the stagnation that GMRES and BiCGSTAB showed on random clouds. The system is:
//!
//! - **Ill-posed on random clouds.** `A` is row-stochastic, not symmetric, not diagonally
//!   dominant, and on random samplings numerically singular and indefinite. A dense
//!   analysis of 3000 random samples of the unit sphere (k = 16, numpy SVD) gives singular
//!   values from 1.0 down to 9e-9 (condition 1e8), 30% of them below 1e-2, and 670 of 3000
//!   eigenvalues with a negative real part; the smallest singular vectors sit on pairs of
//!   samples closer than 0.03 h (h the mean nearest-sample spacing), whose rows are nearly
//!   equal, but thinning pairs closer than 0.1–0.5 h leaves the condition at 5e5–2e7 and the
//!   exact solution as bad as below. The same analysis
//!   of a Fibonacci (quasi-regular) sphere gives condition 8 at k = 8 and 1.5e4 at k = 16.
//! - **Its exact solution is a bad field.** Solved exactly (dense LU, `tests/solver.rs`,
//!   1500 random samples of the sphere) the field vanishes at the samples to 3e-13 h, but
//!   with constants up to 3.1e3 h, and the near field *between* the samples is off by 2.05 h
//!   RMS (27.6 h max) in the band ±2h, against 0.038 h with the damped solve below. On the
//!   Fibonacci sphere the exact solution is harmless (constants ≤ 0.35 h, 0.006 h RMS).
//!   Driving the residual down is the wrong goal on random clouds; the stalled Krylov
//!   solvers were regularizing by stopping early.
//! - **ILU(0) does not help.** Without pivoting its pivots come out as small as 4e-6 of
//!   their row ([`solve::Ilu0::smallest_pivot`]), so `(LU)⁻¹` is huge and GMRES on the
//!   preconditioned operator ends with a residual larger than `b` (table below).
//!
//! So the default is [`Solver::Lsqr`]: the damped least-squares problem
//! `min ‖A c − b‖² + λ²‖c‖²` by LSQR ([`solve::lsqr`]). It is well posed for every cloud
//! (its condition is at most `√(1 + λ²)/λ`, since `‖A‖ ≈ 1`), converges in a number of
//! iterations that does not grow with the cloud (63–65 at λ = 0.05 to an optimality of
//! 1e-4, for 6000 and 10^6 samples alike), and its prior `c = 0` (each linear field through its
//! sample) is the right one. λ is dimensionless because `A` is row-stochastic. Measured on
//! 6000 samples of the unit sphere, k = 16 (`cargo test -p isokit-points --test solver --
//! --nocapture`; "near band" is the near field alone against the exact distance at 3000
//! points within ±2h of the surface):
//!
//! | sampling | solver | iterations | relative residual | max \|f(p_i)\| | max \|c\| | near band RMS | near band max |
//! | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |
//! | random | none (c = 0) | 0 | 1 | 0.090 h | 0 | 0.053 h | 0.16 h |
//! | random | LSQR λ 0.3 | 13 | 0.17 | 0.028 h | 0.09 h | 0.020 h | 0.12 h |
//! | random | LSQR λ 0.1 | 34 | 0.11 | 0.020 h | 0.16 h | 0.018 h | 0.11 h |
//! | random | **LSQR λ 0.05 (default)** | 63 | 0.097 | **0.018 h** | 0.21 h | **0.018 h** | 0.12 h |
//! | random | LSQR λ 0.01 | 242 | 0.063 | 0.012 h | 0.76 h | 0.019 h | 0.21 h |
//! | random | GMRES (old default, cap 30) | 30 | 0.081 | 0.015 h | 0.96 h | 0.020 h | 0.24 h |
//! | random | GMRES, cap 400 | 400 | 0.075 | 0.018 h | 2.1 h | 0.023 h | 0.30 h |
//! | random | GMRES + ILU(0), cap 100 | 100 | 24 | 65 h | 2.7e3 h | 0.62 h | 18 h |
//! | random | BiCGSTAB, cap 100 | 100 | 0.10 | 0.024 h | 0.58 h | 0.018 h | 0.20 h |
//! | Fibonacci | none (c = 0) | 0 | 1 | 0.026 h | 0 | 0.024 h | 0.031 h |
//! | Fibonacci | **LSQR λ 0.05 (default)** | 46 | 0.006 | 0.0015 h | 0.04 h | 0.0023 h | 0.009 h |
//! | Fibonacci | GMRES, cap 400 | 400 | 3e-4 | 4e-5 h | 0.08 h | 0.0024 h | 0.009 h |
//! | Fibonacci | GMRES + ILU(0), cap 100 | 100 | 39 | 23 h | 310 h | 1.0 h | 18 h |
//!
//! The damped solve converges where the plain solvers stall, keeps the constants 5–10×
//! smaller than GMRES does, and halves the largest error between the samples. It brings the field within
//! 0.018 h of zero at every sample of the random sphere (0.040 h on the random torus and
//! 0.042 h on the rounded box; 0.09–0.23 h with no solve; asserted below 0.02 h and
//! 0.05 h). The *relative* residual `‖A c − b‖/‖b‖` stays near 10% on random clouds by
//! construction: `b` is itself tiny (curvature × h²), and the part of it left lies in the
//! near-null space, where fitting it would take the large constants above. Smaller λ
//! interpolates more closely but makes the field worse from about 0.01 on; 0.03–0.1 are
//! equally accurate between the samples, and 0.05 leaves 0.018 h at the samples against
//! 0.020 h at 0.1 and 0.028 h at 0.3, for 1.9× the iterations of 0.1. On noisy clouds the same knob turns
//! interpolation into approximation: with noise of about one spacing (0.5% of the
//! bounding diagonal) the band error of the torus falls from 0.98 h (default) to 0.31 h with
//! `k = 64, damping = 1` (`tests/meshes.rs`). On a 10^6-sample torus the whole solve step
//! (assembly, 65 iterations, the check of every sample) takes 5.5 s on 2 shared cores;
//! storing the samples in Morton order made it 2.7× faster (15 s before).
//!
//! A grid much coarser than the samples' spacing cannot tell the solved constants from
//! smaller ones: [`cloud_to_grid`] stops the solve once the root mean square of the field at
//! the samples is below a thousandth of the grid's spacing ([`CloudGridOptions::solve_to_grid`],
//! [`solve::lsqr_to`]). On 10^6 samples and a 256 grid (about 7 sample spacings per grid
//! spacing) that holds before the first iteration on the sphere and torus. The field at the
//! grid nodes within a spacing of the surface then moves by 1% RMS (sphere 4.58e-5 → 4.62e-5;
//! 10^5 samples on a 128 grid, one iteration, 9.25e-5 → 9.38e-5), and the build saves about
//! 2 s. Where the cloud is as fine as the grid, the full solve's residual is about that
//! large, so the solve runs as before. `PointSdf` itself, `isokit query` and scenes solve
//! fully.
//!
//! ## Accuracy
//! Error against the exact signed distance at 4000 points within ±2h of the surface, default
//! options (`cargo test -p isokit-points --test shapes --test meshes -- --nocapture`):
//!
//! | cloud | samples | h | RMS | max | near field alone: RMS / max | max \|f(p_i)\| |
//! | --- | ---: | --- | --- | --- | --- | --- |
//! | sphere r = 1 (random) | 6000 | 0.0227 | 0.017 h | 0.12 h | 0.018 h / 0.12 h | 0.018 h |
//! | torus 1, 0.35 (random) | 6000 | 0.0238 | 0.031 h | 0.18 h | 0.032 h / 0.17 h | 0.040 h |
//! | rounded box | 6000 | 0.0179 | 0.030 h | 0.23 h | 0.031 h / 0.23 h | 0.042 h |
//! | `data/sphere.obj` (1280 faces) | 20,000 | 0.0125 | 0.020 h | 0.16 h | 0.020 h / 0.15 h | 0.040 h |
//! | `data/torus.off` (2304 faces) | 20,000 | 0.0131 | 0.041 h | 0.31 h | 0.041 h / 0.32 h | 0.090 h |
//! | `data/trefoil.ply` (6144 faces) | 20,000 | 0.0142 | 0.067 h | 0.71 h | 0.070 h / 0.73 h | 0.132 h |
//!
//! Mesh clouds are sampled uniformly by area with exact face normals and compared with the
//! mesh's exact distance (`isokit_kdtree::mesh::MeshSdf`); their creases (face normals jump
//! across every edge) cost accuracy at the samples. Asserted bounds: RMS below 0.1 h (0.15 h
//! on the trefoil), max below 0.75 h (1.0 h), no spurious zero crossing on 40³ grids over the
//! padded bounds, and beyond the blend's reach the field equals the distance to the cloud
//! exactly. With estimated normals (k = 16; 0 flips, angle RMS 0.8°–2.3°) the RMS is
//! 0.017–0.033 h. Comparison variants on the random torus: Shepard RMS 0.121 h (max 0.47 h),
//! Nie04 0.063 h (max 0.28 h). With 0.5% noise and exact normals, Shepard's averaging does
//! better than the default (torus 0.48 h against 0.98 h) and the smoothing options better
//! still (0.31 h); with a density varying 20:1 along x (trefoil) the default stays at
//! 0.12 h RMS, Nie04 0.17 h, Shepard 0.30 h.
//!
//! ## The far-field weight
//! Away from the surface the field blends into the signed distance to the closest sample,
//! with a weight that falls from 1 to 0 over a scale-invariant distance from the surface
//! (002 Sec. 4.3.5, [`far`]). The dissertation infers that distance from the spread σ̄ of
//! the distances to the nearest samples ([`FarRule::Spread`]). A random cloud has gaps
//! several spacings wide, and in a gap every sample is far, as above the surface: σ̄ reads
//! the gap as height, the weight falls, and the distance to the closest sample (up to the
//! gap's radius) leaks into the surface. That was most of the error near the surface (the
//! near field alone was 2× more accurate). The default [`FarRule::Centroid`] measures the
//! distance directly, as the height of the point above the centroid of its `far_k` = 16
//! nearest samples along their mean normal over the radius of their disc
//! ([`far::centroid_distance`]): 0 in a gap, the same slope as σ̄ above a plane (within 25%
//! from one spacing up, `tests/far_plane.rs`), so the blend reaches as far.
//!
//! Same tests, the spread rule over 64 samples (the former default) → the centroid rule over
//! 16, band ±2h RMS / max: random sphere 0.037 h / 0.34 h → 0.017 h / 0.12 h, random torus
//! 0.050 / 0.55 → 0.031 / 0.18, rounded box 0.047 / 0.40 → 0.030 / 0.23, `sphere.obj` 0.041
//! / 0.33 → 0.020 / 0.16, `torus.off` 0.055 / 0.44 → 0.041 / 0.31, `trefoil.ply` 0.073 / 0.58
//! → 0.067 / 0.71 (its creases: the near field alone has 0.73), the 20:1 density 0.16 / 3.0
//! → 0.12 / 1.8. Over 32 samples the figures are within 3% of these (the centroid of 16 is
//! as good a measure, and the query that the partition of unity makes anyway gives it). On
//! noisy clouds the default moves by 1–4% (torus at 0.5% noise 0.949 → 0.981 h). On 10^6 samples the gaps grow (the largest empty disc among n random samples
//! grows like √(ln n) spacings): the Hausdorff distance of the sphere's mesh at `--res 256`
//! fell from 6.9e-4 to 7.4e-5 with this weight alone, 6.5e-5 with the solve stopped at the
//! grid's precision (BENCHMARKS.md, "The far-field weight in the gaps of a random cloud").
//! Past the edge of an open surface, in its plane, every nearest sample lies on the edge and
//! the height above them is 0: there the lateral offset beyond their disc counts as distance,
//! and the field becomes the distance to the edge from about 25 spacings out (the spread
//! rule's over 16 samples from 12; `tests/far_plane.rs`) instead of continuing the plane's 0.
//!
//! ## The sign far from the surface
//! The far field is the distance to the closest sample, and its sign used to be the side of
//! that sample's tangent plane (002 Sec. 4.3.5, [`SignRule::Nearest`]). Beside a sharp edge
//! the closest sample may lie on the face whose plane does not separate the point from the
//! solid (below the rim of a pocket, seen from inside the pocket; diagonally off a box's
//! edge), so the sign is wrong there many spacings away. The default [`SignRule::Winding`]
//! asks the fast winding number of the oriented cloud ([`winding`], Barill et al. 2018)
//! wherever the `far_k` nearest samples do not all put the point on the same side of their
//! tangent planes (inside where it exceeds 3/4, outside below 1/4: near the surface a
//! cloud's winding number wanders around 1/2), and keeps the closest sample's side where
//! they agree or it is not clear. [`SignRule::WindingEverywhere`] asks it wherever the far field counts; it
//! gave the same counts below, so the cheaper rule is the default. Only the far part's sign
//! changes; the near field and the blend weight are as before.
//!
//! Wrong signs at the nodes of the `isokit points --res 64` lattice (30,000 area-uniform
//! samples with exact face normals, padded bounds) farther than 3 grid spacings from the
//! surface (plus 3 noise deviations with noise), against the exact signed distance of the
//! mesh (`cargo test -p isokit-points --test sign -- --nocapture`):
//!
//! | cloud | nodes | nearest | winding (default) | winding everywhere |
//! | --- | ---: | ---: | ---: | ---: |
//! | blob with a pocket (union of spheres, cube cut from the top) | 124,797 | 26 (up to 12.8 spacings away) | 0 | 0 |
//! | box with a pocket (exact polyhedron) | 175,704 | 32 (11.2) | 0 | 0 |
//! | thin plate, sheets 2 spacings apart | 35,136 | 9 (7.3) | 0 | 0 |
//! | sharp box | 87,172 | 109 (7.3) | 0 | 0 |
//! | the same, noise 0.5% of the diagonal: blob | 123,261 | 29 | 0 | 0 |
//! | box with a pocket | 157,818 | 885 | 0 | 0 |
//! | thin plate | 44,554 | 477 | 0 | 0 |
//! | sharp box | 86,904 | 509 | 0 | 0 |
//! | noise 2%: blob | 124,107 | 174 | 0 | 0 |
//! | box with a pocket | 139,724 | 2885 | 0 | 0 |
//! | thin plate | 60,938 | 2813 | 0 | 0 |
//! | sharp box | 88,004 | 1967 | 0 | 0 |
//!
//! The winding number's tree (β = 2, first-order expansions) is within 0.082 of the direct
//! sum at 2000 random points around the blob (RMS 0.016; 0.004 at β = 8), which leaves the
//! inside/outside answer unchanged at every one of them beyond 0.05 from the surface; the
//! sample areas sum to the mesh's area within 0.6%. On the same cloud, areas and points
//! (`tests/peers/check_winding.py`) libigl's `fast_winding_number` for clouds agrees with
//! the direct sum to 2.6e-6 exactly (β = 0) and, at β = 2, is off by up to 0.26 (RMS
//! 0.014) at order 1 and 0.061 (RMS 0.0022) at order 2; no inside/outside answer differs.
//! Against libigl's exact signed distance of the blob's mesh
//! (`tests/peers/points_sign_counts.py`) the `--res 64` field has 27 wrong signs beyond 3
//! spacings with the nearest-sample rule and 0 with the default on 30,000 samples, 78 and 0
//! on 300,000.
//!
//! The wrong signs also reached into the band beside the sharp edges: the largest error at
//! the nodes within 2 spacings of the surface (same lattices) falls from 1.25 to 0.61
//! spacings on the blob, 1.98 to 0.73 on the box with a pocket, 2.37 to 0.43 on the thin
//! plate, 2.71 to 0.82 on the sharp box and 3.07 to 0.79 on the CSG part (RMS 0.020–0.055
//! spacings; with the spread weight of 002 it was 2.50 to 0.60 on the blob, 3.90 to 0.19 on
//! 300,000 samples, against libigl's exact distance); `tests/sign.rs` asserts at most 1.
//!
//! Cost, release build (`cargo run --release -p isokit-points --example points_grid --
//! CLOUD RES RULE`; 2 shared cores under a load of 5, so ±15%): the winding number builds in
//! 0.08–0.10 s for 30,000 samples and 0.6–1.0 s for 300,000 (per-sample areas and the tree).
//! Sampling seconds, nearest / winding / winding everywhere: 30,000 samples, 64-grid 2.08 /
//! 1.84 / 1.93, 128-grid 15.1 / 15.6 / 17.0; 300,000 samples, 64-grid 6.2 / 6.4 / 6.1,
//! 128-grid 39.9 / 42.3 / 32.1. The tree query costs little beside the 64-nearest query
//! every evaluation made then (the spread weight over 64 samples); the rest is noise.
//!
//! ## Speed
//! Nearly all of an evaluation is its k-nearest query ([`knn::Knn`], exact; k = 16 on clean
//! clouds), shared by the partition of unity and the far-field weight. Points evaluated one
//! after another (a brick's samples through [`isokit_field::Field::values_nearby`], a grid's
//! rows, [`PointSdf::values_at`]) bound each query by the previous point's answer. The
//! solve's assembly gives the winding number's sample areas from its own neighbour query. On
//! a 10^5-sample torus (`--res 128 --band 0.082`, one thread) `isokit points` takes 8.5 G
//! instructions: 19.4 G with 002's weight over 64 samples (`--far-rule spread --far-k 64`),
//! 11.9 G with the centroid weight over 16, then 8.5 G with the solve stopped at the grid's
//! precision and the shared query. On 10^6 samples, `isokit points --res 256` with a band of
//! 3 cells took 4.2 s on 2 cores (torus; sphere 5.6 s, trefoil 6.8 s) against 4.7 s (6.0 s,
//! 3.8 s) for Open3D's screened Poisson at depth 8 in the same run, with smaller Chamfer and
//! Hausdorff distances on the sphere and torus (BENCHMARKS.md, "The far-field weight in the
//! gaps of a random cloud").

pub mod eigen;
mod error;
pub mod far;
mod grid;
pub mod knn;
pub mod noise;
pub mod normals;
mod sdf;
pub mod solve;
pub mod winding;

pub use error::PointsError;
pub use grid::{
    BandStats, CloudGridError, CloudGridOptions, CloudGridStats, CloudQuery, SOLVE_TO_GRID,
    cloud_to_grid, query_cloud,
};
pub use normals::{NormalOptions, NormalReport, estimate_normals};
pub use sdf::{
    BuildStats, DEFAULT_DAMPING, Evaluation, FarRule, NormalSource, PointSdf, PointSdfOptions,
    SignRule, Solver, WINDING_MARGIN, Weighting,
};
pub use solve::SolveStats;
pub use winding::{WindingNumber, WindingOptions, point_areas};

use glam::{DVec3, Vec3};

/// Checks the normals (one per point, finite, non-zero) and returns them as unit f64
/// vectors.
pub(crate) fn unit_normals(points: &[Vec3], normals: &[Vec3]) -> Result<Vec<DVec3>, PointsError> {
    if normals.len() != points.len() {
        return Err(PointsError::NormalCount {
            points: points.len(),
            normals: normals.len(),
        });
    }
    normals
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let n = n.as_dvec3();
            let len = n.length();
            if len.is_finite() && len > 1e-30 {
                Ok(n / len)
            } else {
                Err(PointsError::BadNormal { index: i })
            }
        })
        .collect()
}

/// Errors on an empty cloud or a non-finite coordinate.
pub(crate) fn check_points(points: &[Vec3]) -> Result<(), PointsError> {
    if points.is_empty() {
        return Err(PointsError::Empty);
    }
    if let Some((index, p)) = points.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(PointsError::NonFinitePoint {
            index,
            x: p.x,
            y: p.y,
            z: p.z,
        });
    }
    Ok(())
}
