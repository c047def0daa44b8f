//! [`PointSdf`]: a signed distance field from oriented points (002 Sec. 4.3.4–4.3.5).

use crate::far::{blend_weight, blend_weight_of_distance, centroid_distance, sigma_bar};
use crate::knn::Knn;
use crate::normals::{NormalOptions, NormalReport, estimate_normals};
use crate::solve::{Preconditioner, SolveStats, bicgstab, gmres, lsqr_to};
use crate::winding::{WindingNumber, WindingOptions, areas_with};
use crate::{PointsError, check_points, unit_normals};
use glam::{DVec3, Vec3};
use isokit_field::PointCloud;
use isokit_field::{Aabb, Field};
use rayon::prelude::*;
use sprs::CsMat;
use std::time::Instant;

/// Krylov vectors kept by GMRES between restarts.
const GMRES_RESTART: usize = 50;

/// How far from 1/2 the winding number must be to override the closest sample's side
/// ([`SignRule::Winding`]): it is near 0 or 1 a few spacings off the surface.
pub const WINDING_MARGIN: f64 = 0.25;

/// The default damping of [`Solver::Lsqr`] (chosen by the measurements in the crate docs).
pub const DEFAULT_DAMPING: f64 = 0.05;

/// The blending weights of the local linear fields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Weighting {
    /// 002 Eq. 4.10, the default: `(1 − r²/R²)³` with R the distance from the evaluation
    /// point to its k-th nearest sample. Not interpolating by itself, so the constants of
    /// the linear fields come from a sparse solve.
    PolyGauss,
    /// Shepard's inverse-square weights `1/r²` (interpolating; no solve). Evaluated over the
    /// k nearest samples only, not all of them: a truncation of the infinite support.
    Shepard,
    /// The truncated inverse-square weights of \[Nie04\] (002 Eq. 4.9),
    /// `max(R_i − r, 0)²/r²`, with each sample's cutoff `R_i` the distance to its
    /// `neighbours`-th nearest other sample (Nie04 uses 18). Interpolating; no solve. Where
    /// no support reaches, the near field is undefined and the far field is used.
    Nie04 {
        /// Neighbours inside each sample's support.
        neighbours: usize,
    },
}

impl Weighting {
    /// Name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Weighting::PolyGauss => "poly-gauss",
            Weighting::Shepard => "shepard",
            Weighting::Nie04 { .. } => "nie04",
        }
    }
}

/// The solver for the constants of [`Weighting::PolyGauss`] (see the crate docs for the
/// measurements behind the default).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// The default: damped least squares `min ‖A c − b‖² + λ²‖c‖²` by LSQR, with λ
    /// [`PointSdfOptions::damping`]. Well posed on every cloud; on random clouds, where the
    /// plain system is numerically singular, it keeps the constants small and the field
    /// between the samples accurate.
    Lsqr,
    /// The plain system `A c = b` by restarted GMRES(50) with a right Jacobi preconditioner
    /// (its residual never grows, so the iteration cap acts as a regularization).
    Gmres,
    /// The plain system by restarted GMRES(50) with a right ILU(0) preconditioner. Unstable
    /// on random clouds (tiny pivots); kept for the comparison.
    GmresIlu0,
    /// The plain system by BiCGSTAB with a Jacobi preconditioner (for comparison).
    Bicgstab,
}

impl Solver {
    /// Name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Solver::Lsqr => "LSQR",
            Solver::Gmres => "GMRES",
            Solver::GmresIlu0 => "GMRES+ILU(0)",
            Solver::Bicgstab => "BiCGSTAB",
        }
    }
}

/// Where the far field (the distance to the closest sample) gets its sign.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignRule {
    /// The side of the closest sample's tangent plane (002 Sec. 4.3.5). Wrong beside sharp
    /// edges, where the closest sample may lie on the face whose plane does not separate
    /// the point from the solid (e.g. below the rim of a pocket, in the pocket).
    Nearest,
    /// The default: the winding number of the oriented cloud ([`crate::winding`]; inside
    /// where it exceeds 3/4, outside below 1/4, [`WINDING_MARGIN`]) where the
    /// nearest-sample rule is ambiguous, i.e. where the `far_k` nearest samples do not all
    /// put the point on the same side of their tangent planes; the closest sample's side
    /// elsewhere and where the winding number is not clear.
    Winding,
    /// The winding number wherever the far field counts (blend weight below 1), whatever
    /// the samples agree on (with the same margin). For comparison: slower, same signs in
    /// the measurements.
    WindingEverywhere,
}

impl SignRule {
    /// Name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            SignRule::Nearest => "nearest",
            SignRule::Winding => "winding",
            SignRule::WindingEverywhere => "winding-everywhere",
        }
    }
}

/// How far from the surface a point is judged to be, for the far-field blend weight
/// (002 Sec. 4.3.5, ERRATA 6).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FarRule {
    /// The default: the height above the centroid of the `far_k` nearest samples over the
    /// radius of their disc ([`crate::far::centroid_distance`]). On the surface in a gap of
    /// a random sampling it stays 0, so the weight stays 1 there.
    #[default]
    Centroid,
    /// 002 Eq. 4.12–4.14: inferred from the relative spread σ̄ of the distances to the
    /// `far_k` nearest samples ([`crate::far::sigma_bar`]). It reads a gap of the sampling
    /// as distance from the surface and mixes the distance to the closest sample into the
    /// surface there (measured in the crate docs, "The far-field weight").
    Spread,
}

impl FarRule {
    /// Name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            FarRule::Centroid => "centroid",
            FarRule::Spread => "spread",
        }
    }
}

/// Knobs of [`PointSdf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSdfOptions {
    /// Nearest samples per evaluation (the partition of unity's support and the far-field
    /// statistics), the sample itself included when evaluating at a sample. Clamped to the
    /// cloud size.
    pub k: usize,
    /// Weights of the partition of unity.
    pub weighting: Weighting,
    /// Blend with the signed distance to the closest sample away from the surface
    /// (Sec. 4.3.5, ERRATA 6). Off: the near field everywhere.
    pub far_field: bool,
    /// Nearest samples whose positions ([`FarRule::Centroid`]) or distances
    /// ([`FarRule::Spread`]) give the far-field weight (at least `k` are used). More samples
    /// fluctuate less on irregular clouds, so the weight stays nearer 1 on the surface, and
    /// cost more (see the crate docs for the measured effect).
    pub far_k: usize,
    /// How the far-field weight judges the distance from the surface.
    pub far_rule: FarRule,
    /// Solver of the sparse system.
    pub solver: Solver,
    /// Damping λ of [`Solver::Lsqr`] (dimensionless: the matrix is row-stochastic). Larger
    /// values keep the constants nearer 0 (each linear field through its sample) and need
    /// fewer iterations; smaller values interpolate the samples more closely, until the
    /// ill-conditioning of random clouds spoils the field between them.
    pub damping: f64,
    /// Stopping tolerance: the relative residual for GMRES and BiCGSTAB, the least-squares
    /// optimality `‖Āᵀ r̄‖/(‖Ā‖ ‖r̄‖)` for LSQR.
    pub tol: f64,
    /// Iteration limit of the solve.
    pub max_iter: usize,
    /// [`Solver::Lsqr`] only: also stop once the root mean square of the residual, the near
    /// field at the samples (with the damping term), is at most this, in world units; 0:
    /// solve to `tol`. [`crate::cloud_to_grid`] sets it from the grid's spacing
    /// ([`crate::CloudGridOptions::solve_to_grid`]): a grid much coarser than the samples'
    /// spacing cannot tell the constants of a full solve from smaller ones.
    pub residual_target: f64,
    /// Where the far field gets its sign (only with `far_field`).
    pub sign: SignRule,
}

impl Default for PointSdfOptions {
    fn default() -> Self {
        Self {
            k: 16,
            weighting: Weighting::PolyGauss,
            far_field: true,
            far_k: 16,
            far_rule: FarRule::Centroid,
            solver: Solver::Lsqr,
            damping: DEFAULT_DAMPING,
            tol: 1e-4,
            max_iter: 200,
            residual_target: 0.0,
            sign: SignRule::Winding,
        }
    }
}

/// Where the normals of [`PointSdf::from_cloud`] come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NormalSource {
    /// The cloud's own normals (an error when it has none).
    Given,
    /// Estimated by [`estimate_normals`].
    Estimate(NormalOptions),
}

/// How a [`PointSdf`] was built.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Samples used (after removing exact duplicates).
    pub samples: usize,
    /// Exact duplicate positions removed (the first of each kept, with its normal).
    pub duplicates_removed: usize,
    /// The k actually used.
    pub k: usize,
    /// The sparse solve ([`Weighting::PolyGauss`] only).
    pub solve: Option<SolveStats>,
    /// Seconds to build (tree, solve, winding number).
    pub seconds: f64,
    /// Seconds building the winding number (areas and tree; with [`Weighting::PolyGauss`]
    /// the areas come from the solve's assembly and count there); 0 without one.
    pub winding_seconds: f64,
    /// Sum of the sample areas of the winding number (≈ the surface area); 0 without one.
    pub winding_area: f64,
}

/// One evaluation, split into its parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation {
    /// The field: `w·near + (1 − w)·far` (or `near` without the far field).
    pub value: f64,
    /// The partition-of-unity near field; `None` where no weight reaches ([`Weighting::Nie04`]).
    pub near: Option<f64>,
    /// Distance to the closest sample, signed by [`PointSdfOptions::sign`].
    pub far: f64,
    /// The winding number at the point, where the sign rule evaluated it.
    pub winding: Option<f64>,
    /// The blend weight `w` (1 on the surface, 0 far away; 1 when the far field is off).
    pub weight: f64,
}

/// A signed distance field approximated from oriented samples: local linear fields
/// `f_i(x) = c_i + n_i·(x − p_i)` blended by a partition of unity, blended in turn with the
/// signed distance to the closest sample away from the surface.
///
/// The field is defined everywhere (the support radius adapts to the evaluation point),
/// comes close to zero at the samples (within a few hundredths of the sample spacing on
/// random clouds with the default damped solve: [`BuildStats::solve`] reports it), has
/// gradient ≈ `n_i` at sample i, and tends to the distance to the cloud far away.
///
/// The samples are stored in spatial (Morton) order, not in input order.
#[derive(Debug)]
pub struct PointSdf {
    pts: Vec<DVec3>,
    nrm: Vec<DVec3>,
    c: Vec<f64>,
    /// Nie04 cutoff radius per sample.
    support: Vec<f64>,
    support_max: f64,
    knn: Knn,
    opts: PointSdfOptions,
    bounds: Aabb,
    stats: BuildStats,
    /// The winding number for [`SignRule::Winding`] and [`SignRule::WindingEverywhere`].
    winding: Option<WindingNumber>,
}

impl PointSdf {
    /// Builds the field from points and their outward normals (any non-zero length).
    ///
    /// Errors: empty input, mismatched lengths, non-finite points, zero or non-finite
    /// normals, `k = 0`, a non-positive tolerance.
    pub fn new(
        points: &[Vec3],
        normals: &[Vec3],
        opts: &PointSdfOptions,
    ) -> Result<Self, PointsError> {
        let t0 = Instant::now();
        check_points(points)?;
        let nrm = unit_normals(points, normals)?;
        if opts.k == 0 {
            return Err(PointsError::Parameter("k must be at least 1".into()));
        }
        if !(opts.tol > 0.0 && opts.tol.is_finite()) {
            return Err(PointsError::Parameter(format!(
                "solver tolerance {} must be positive",
                opts.tol
            )));
        }
        if !(opts.damping >= 0.0 && opts.damping.is_finite()) {
            return Err(PointsError::Parameter(format!(
                "damping {} must be finite and non-negative",
                opts.damping
            )));
        }
        if !(opts.residual_target >= 0.0 && opts.residual_target.is_finite()) {
            return Err(PointsError::Parameter(format!(
                "residual target {} must be finite and non-negative",
                opts.residual_target
            )));
        }
        if let Weighting::Nie04 { neighbours } = opts.weighting {
            if neighbours == 0 {
                return Err(PointsError::Parameter(
                    "Nie04 neighbours must be at least 1".into(),
                ));
            }
        }
        // Remove exact duplicates: they would make rows of the system identical.
        let mut order: Vec<usize> = (0..points.len()).collect();
        let key = |i: usize| points[i].to_array().map(f32::to_bits);
        order.sort_by_key(|&i| (key(i), i));
        let mut keep = vec![true; points.len()];
        for w in order.windows(2) {
            if points[w[0]] == points[w[1]] {
                keep[w[1].max(w[0])] = false;
            }
        }
        // Equal positions are adjacent after the sort, but -0.0 and 0.0 differ in bits and
        // compare equal: they stay (harmless duplicates at worst, never a panic).
        let mut kept: Vec<usize> = (0..points.len()).filter(|&i| keep[i]).collect();
        let duplicates_removed = points.len() - kept.len();
        // Spatial (Morton) order: neighbours get nearby indices, so the gathers of the
        // sparse products and of every evaluation stay in cache (measured 2–3× faster
        // solves on a shuffled 10^6-sample cloud).
        let bounds = Aabb::from_points(points);
        let size = bounds.size().max_element().max(f32::MIN_POSITIVE);
        let code = |p: Vec3| {
            let q = ((p - bounds.min) / size * 1_048_575.0)
                .clamp(Vec3::ZERO, Vec3::splat(1_048_575.0))
                .as_uvec3();
            isokit_field::morton::encode(q)
        };
        kept.par_sort_by_cached_key(|&i| (code(points[i]), i));
        let pts: Vec<DVec3> = kept.iter().map(|&i| points[i].as_dvec3()).collect();
        let nrm: Vec<DVec3> = kept.iter().map(|&i| nrm[i]).collect();
        let pts32: Vec<Vec3> = kept.iter().map(|&i| points[i]).collect();
        let knn = Knn::new(&pts32)?;
        let n = pts.len();
        let mut opts = *opts;
        opts.k = opts.k.min(n);
        opts.far_k = opts.far_k.max(opts.k).min(n);

        let mut sdf = Self {
            bounds: Aabb::from_points(&pts32),
            c: vec![0.0; n],
            support: Vec::new(),
            support_max: 0.0,
            pts,
            nrm,
            knn,
            opts,
            winding: None,
            stats: BuildStats {
                samples: n,
                duplicates_removed,
                k: opts.k,
                ..BuildStats::default()
            },
        };
        let winding =
            (opts.far_field && opts.sign != SignRule::Nearest).then(WindingOptions::default);
        let mut areas = None;
        match opts.weighting {
            Weighting::PolyGauss => areas = sdf.solve(winding.map(|w| w.area_k)),
            Weighting::Shepard => {}
            Weighting::Nie04 { neighbours } => {
                // The sample itself is its own nearest: ask for one more.
                let m = (neighbours + 1).min(n);
                let support: Vec<f64> = sdf
                    .pts
                    .par_iter()
                    .map_init(Vec::new, |buf, &p| {
                        sdf.knn.nearest_again(p, m, buf);
                        buf.last().map_or(0.0, |&(_, d2)| d2.sqrt())
                    })
                    .collect();
                sdf.support_max = support.iter().copied().fold(0.0, f64::max);
                sdf.support = support;
            }
        }
        if let Some(w) = winding {
            let t = Instant::now();
            let areas = areas.unwrap_or_else(|| areas_with(&sdf.knn, &sdf.pts, &sdf.nrm, w.area_k));
            let wn = WindingNumber::build(sdf.pts.clone(), sdf.nrm.clone(), areas, w.beta)?;
            sdf.stats.winding_area = wn.total_area();
            sdf.winding = Some(wn);
            sdf.stats.winding_seconds = t.elapsed().as_secs_f64();
        }
        sdf.stats.seconds = t0.elapsed().as_secs_f64();
        Ok(sdf)
    }

    /// Builds the field from a cloud, with its own normals or estimated ones (then the
    /// normal report comes back too).
    pub fn from_cloud(
        cloud: &PointCloud,
        normals: NormalSource,
        opts: &PointSdfOptions,
    ) -> Result<(Self, Option<NormalReport>), PointsError> {
        match normals {
            NormalSource::Given => {
                let n = cloud.normals.as_ref().ok_or(PointsError::NoNormals)?;
                Ok((Self::new(&cloud.points, n, opts)?, None))
            }
            NormalSource::Estimate(no) => {
                let rep = estimate_normals(&cloud.points, &no)?;
                let sdf = Self::new(&cloud.points, &rep.normals, opts)?;
                Ok((sdf, Some(rep)))
            }
        }
    }

    /// The options in use (k clamped to the cloud size).
    pub fn options(&self) -> &PointSdfOptions {
        &self.opts
    }

    /// How the field was built: samples, duplicates, solver iterations and residual.
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }

    /// The samples (f64, duplicates removed, in spatial order).
    pub fn samples(&self) -> &[DVec3] {
        &self.pts
    }

    /// The unit normals of [`PointSdf::samples`].
    pub fn normals(&self) -> &[DVec3] {
        &self.nrm
    }

    /// The winding number of the samples, built for [`SignRule::Winding`] and
    /// [`SignRule::WindingEverywhere`] (with the far field on); `None` otherwise.
    pub fn winding_number(&self) -> Option<&WindingNumber> {
        self.winding.as_ref()
    }

    /// The constants `c_i` of the local linear fields (0 without a solve).
    pub fn constants(&self) -> &[f64] {
        &self.c
    }

    /// Normalized PolyGauss weights of the neighbours `nb` (sorted by distance, the last
    /// one at the support radius) into `w`.
    fn poly_gauss(nb: &[(usize, f64)], w: &mut Vec<f64>) {
        w.clear();
        let r2 = nb.last().map_or(0.0, |&(_, d2)| d2);
        if r2 > 0.0 {
            w.extend(nb.iter().map(|&(_, d2)| (1.0 - d2 / r2).max(0.0).powi(3)));
        }
        let sum: f64 = w.iter().sum();
        if sum > 0.0 {
            w.iter_mut().for_each(|x| *x /= sum);
        } else {
            // All neighbours at the same distance (or coincident): equal weights.
            w.clear();
            w.extend(std::iter::repeat_n(1.0 / nb.len() as f64, nb.len()));
        }
    }

    /// The interpolation system `A c = b` of [`Weighting::PolyGauss`] (002 Sec. 4.3.4):
    /// `A_ij` the normalized weight (Eq. 4.10, radius the distance to the k-th nearest
    /// sample of `p_i`) of sample j at sample i, and `b_i = −Σ_j A_ij n_j·(p_i − p_j)`, so
    /// that `(A c − b)_i` is the near field at `p_i` for the constants `c`. CSR, one row
    /// per sample (k entries, the k-th with weight 0). Assembled afresh on each call (one
    /// k-nearest query per sample), for analysis; the constants in use come from
    /// [`PointSdf::constants`].
    pub fn interpolation_system(&self) -> (CsMat<f64>, Vec<f64>) {
        let (a, b, _) = self.assemble(None);
        (a, b)
    }

    /// [`PointSdf::interpolation_system`], and with `area_k` the winding number's sample
    /// areas ([`crate::winding::point_areas`] over `area_k` neighbours) from the same
    /// neighbour query: each sample asks once for as many nearest samples as either needs,
    /// and each part reads its leading ones (the answers are sorted, so they are the same
    /// as a query of that size).
    fn assemble(&self, area_k: Option<usize>) -> (CsMat<f64>, Vec<f64>, Option<Vec<f64>>) {
        let n = self.pts.len();
        let k = self.opts.k;
        let area_m = area_k.map(|a| (a + 1).min(n));
        let m = area_m.map_or(k, |a| a.max(k));
        // Every row holds exactly k entries (k ≤ n, and every sample is finite).
        let mut indices = vec![0usize; n * k];
        let mut data = vec![0.0f64; n * k];
        let mut b = vec![0.0f64; n];
        let mut areas = vec![0.0f64; n];
        indices
            .par_chunks_mut(k.max(1))
            .zip(data.par_chunks_mut(k.max(1)))
            .zip(b.par_iter_mut())
            .zip(areas.par_iter_mut())
            .enumerate()
            .for_each_init(
                || (Vec::new(), Vec::new(), Vec::new()),
                |(nb, w, row), (i, (((ix, d), bi), area))| {
                    let p = self.pts[i];
                    // Consecutive samples are near (spatial order): the last answer bounds
                    // the search.
                    self.knn.nearest_again(p, m, nb);
                    let near = &nb[..k.min(nb.len())];
                    Self::poly_gauss(near, w);
                    row.clear();
                    *bi = 0.0;
                    for (&(j, _), &wj) in near.iter().zip(w.iter()) {
                        *bi -= wj * self.nrm[j].dot(p - self.pts[j]);
                        row.push((j, wj));
                    }
                    row.sort_unstable_by_key(|&(j, _)| j);
                    for ((x, v), &(j, wj)) in ix.iter_mut().zip(d.iter_mut()).zip(row.iter()) {
                        (*x, *v) = (j, wj);
                    }
                    if let Some(am) = area_m {
                        *area = crate::winding::voronoi_area(i, &self.pts, &self.nrm, &nb[..am]);
                    }
                },
            );
        let indptr: Vec<usize> = (0..=n).map(|i| i * k).collect();
        // The k nearest are distinct, so this succeeds; should a row ever repeat a column,
        // the triplet form sums the repeats instead of failing.
        let a = CsMat::try_new((n, n), indptr, indices, data).unwrap_or_else(|(ip, ix, d, _)| {
            let mut tri = sprs::TriMat::with_capacity((n, n), d.len());
            for i in 0..n {
                for m in ip[i]..ip[i + 1] {
                    tri.add_triplet(i, ix[m], d[m]);
                }
            }
            tri.to_csr()
        });
        (a, b, area_m.map(|_| areas))
    }

    /// The sparse solve of the constants; with `area_k`, the winding number's sample areas
    /// from the assembly's neighbour query (see [`PointSdf::assemble`]).
    fn solve(&mut self, area_k: Option<usize>) -> Option<Vec<f64>> {
        let t0 = Instant::now();
        let (a, b, areas) = self.assemble(area_k);
        let o = &self.opts;
        let (c, mut st) = match o.solver {
            Solver::Lsqr => lsqr_to(&a, &b, o.damping, o.tol, o.max_iter, o.residual_target),
            Solver::Bicgstab => bicgstab(&a, &b, o.tol, o.max_iter),
            Solver::Gmres => gmres(
                &a,
                &b,
                o.tol,
                o.max_iter,
                GMRES_RESTART,
                Preconditioner::Jacobi,
            ),
            Solver::GmresIlu0 => gmres(
                &a,
                &b,
                o.tol,
                o.max_iter,
                GMRES_RESTART,
                Preconditioner::Ilu0,
            ),
        };
        self.c = c;
        st.seconds = t0.elapsed().as_secs_f64();
        self.stats.solve = Some(st);
        areas
    }

    fn linear(&self, j: usize, x: DVec3) -> f64 {
        self.c[j] + self.nrm[j].dot(x - self.pts[j])
    }

    /// The near field alone at `x`.
    pub fn near(&self, x: DVec3) -> Option<f64> {
        let mut nb = Vec::new();
        self.knn.nearest(x, self.opts.k, &mut nb);
        self.near_with(x, &nb)
    }

    fn near_with(&self, x: DVec3, nb: &[(usize, f64)]) -> Option<f64> {
        match self.opts.weighting {
            Weighting::PolyGauss => {
                let mut w = Vec::with_capacity(nb.len());
                Self::poly_gauss(nb, &mut w);
                Some(
                    nb.iter()
                        .zip(&w)
                        .map(|(&(j, _), &wj)| wj * self.linear(j, x))
                        .sum(),
                )
            }
            Weighting::Shepard => self.inverse_square(x, nb, |_, d2| 1.0 / d2),
            Weighting::Nie04 { .. } => {
                let mut cand = Vec::new();
                self.knn
                    .within(x, self.support_max * self.support_max, &mut cand);
                self.inverse_square(x, &cand, |j, d2| {
                    let r = d2.sqrt();
                    (self.support[j] - r).max(0.0).powi(2) / d2
                })
            }
        }
    }

    /// Partition of unity with weights singular at the samples: at a sample, the average of
    /// the linear fields of the samples there.
    fn inverse_square(
        &self,
        x: DVec3,
        nb: &[(usize, f64)],
        phi: impl Fn(usize, f64) -> f64,
    ) -> Option<f64> {
        let hits: Vec<usize> = nb
            .iter()
            .filter(|&&(_, d2)| d2 == 0.0)
            .map(|&(j, _)| j)
            .collect();
        if !hits.is_empty() {
            return Some(hits.iter().map(|&j| self.linear(j, x)).sum::<f64>() / hits.len() as f64);
        }
        let (mut sw, mut sf) = (0.0, 0.0);
        for &(j, d2) in nb {
            let w = phi(j, d2);
            if w > 0.0 && w.is_finite() {
                sw += w;
                sf += w * self.linear(j, x);
            }
        }
        (sw > 0.0).then(|| sf / sw)
    }

    /// The field and its parts at `x` (f64).
    pub fn evaluate(&self, x: DVec3) -> Evaluation {
        self.evaluate_after(x, &mut Vec::new())
    }

    /// [`PointSdf::evaluate`] where `nb` holds the neighbours found at an earlier point (best
    /// a nearby one: they bound the search, [`Knn::nearest_again`]) and receives this
    /// point's. The result is the same whatever `nb` holds.
    pub(crate) fn evaluate_after(&self, x: DVec3, nb: &mut Vec<(usize, f64)>) -> Evaluation {
        let kq = if self.opts.far_field {
            self.opts.far_k
        } else {
            self.opts.k
        };
        self.knn.nearest_again(x, kq, nb);
        let nb = &nb[..];
        let (j0, d0) = nb[0];
        let side = self.nrm[j0].dot(x - self.pts[j0]);
        let near = self.near_with(x, &nb[..self.opts.k.min(nb.len())]);
        let weight = if !self.opts.far_field {
            1.0
        } else {
            match self.opts.far_rule {
                // A lone sample spans no disc: the far field, the distance to it.
                FarRule::Centroid => {
                    centroid_distance(x, nb.iter().map(|&(j, _)| (self.pts[j], self.nrm[j])))
                        .map_or(0.0, blend_weight_of_distance)
                }
                // At a point coinciding with all its samples (mean distance 0): on the surface.
                FarRule::Spread => {
                    sigma_bar(nb.iter().map(|&(_, d2)| d2.sqrt())).map_or(1.0, blend_weight)
                }
            }
        };
        let mut winding = None;
        let mut outside = side >= 0.0;
        if let Some(wn) = &self.winding
            && weight < 1.0
        {
            let ask = match self.opts.sign {
                SignRule::Nearest => false,
                SignRule::WindingEverywhere => true,
                // Ambiguous: the nearest samples' tangent planes disagree on the side.
                SignRule::Winding => nb
                    .iter()
                    .any(|&(j, _)| (self.nrm[j].dot(x - self.pts[j]) >= 0.0) != outside),
            };
            if ask {
                // Near the surface the winding number of a cloud wanders around 1/2 (each
                // sample is a dipole, not a patch): only a clear answer overrides the side.
                let v = wn.value(x);
                winding = Some(v);
                if (v - 0.5).abs() > WINDING_MARGIN {
                    outside = v < 0.5;
                }
            }
        }
        let far = if outside { d0.sqrt() } else { -d0.sqrt() };
        let value = match near {
            Some(v) => weight * v + (1.0 - weight) * far,
            None => far,
        };
        Evaluation {
            value,
            near,
            far,
            winding,
            weight,
        }
    }
}

impl Field for PointSdf {
    fn value(&self, p: Vec3) -> f32 {
        self.evaluate(p.as_dvec3()).value as f32
    }

    /// Each point's neighbour search starts bounded by the previous point's neighbours.
    fn values_nearby(&self, points: &[Vec3], out: &mut [f32]) {
        let mut nb = Vec::new();
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.evaluate_after(p.as_dvec3(), &mut nb).value as f32;
        }
    }

    /// The bounds of the samples. The zero set stays within about one sample spacing of
    /// them (it interpolates the samples and follows their normals).
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Approximate, not a proven bound: the blend of the near field (gradient ≈ the blended
    /// normals, |∇| ≤ 1 plus the variation of the weights) with the far field (|∇| = 1
    /// except across the Voronoi faces of the samples, where its sign may jump). The largest
    /// difference quotient measured (along x on a 32³ grid around the torus test cloud,
    /// `tests/shapes.rs`) is 1.06; 1.5 leaves a margin but is not proven.
    fn lipschitz(&self) -> f32 {
        1.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The assembly that also gives the winding number's areas from its neighbour query
    /// gives the same matrix and right-hand side as without them, and the same areas as their
    /// own query.
    #[test]
    fn areas_from_the_assembly_equal_their_own_query() {
        let cloud = isokit_field::generate::torus_cloud(1.0, 0.3, 3000, 11);
        let normals = cloud.normals.unwrap();
        for (k, n) in [(16, 3000), (4, 3000), (16, 10), (1, 1)] {
            let sdf = PointSdf::new(
                &cloud.points[..n],
                &normals[..n],
                &PointSdfOptions {
                    k,
                    ..PointSdfOptions::default()
                },
            )
            .unwrap();
            let (a, b) = sdf.interpolation_system();
            for area_k in [16, 3] {
                let (a2, b2, areas) = sdf.assemble(Some(area_k));
                assert_eq!(
                    (a.indptr(), a.indices(), a.data()),
                    (a2.indptr(), a2.indices(), a2.data())
                );
                assert_eq!(b, b2);
                let own = areas_with(&sdf.knn, &sdf.pts, &sdf.nrm, area_k);
                assert_eq!(areas.unwrap(), own, "k {k}, {n} samples, area_k {area_k}");
            }
        }
    }
}
