//! The arguments of `isokit points` and the library settings they make.

use super::FarRuleArg;
use isokit_field::PointCloud;
use isokit_points::noise::{NoiseEstimate, estimate_noise};
use isokit_points::{
    CloudGridOptions, FarRule, NormalOptions, NormalSource, PointSdfOptions, PointsError, SignRule,
    Solver, Weighting,
};
use std::path::PathBuf;

/// Where the normals come from.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normals {
    /// The cloud's own normals (PLY nx ny nz, or XYZ with six columns).
    Given,
    /// Estimated: PCA over the k nearest, oriented over a minimum spanning tree.
    Estimate,
}

/// Weights of the partition of unity.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weights {
    /// (1 − r²/R²)³ with a sparse solve for interpolation (002 Eq. 4.10).
    PolyGauss,
    /// Shepard's inverse-square weights over the k nearest.
    Shepard,
    /// Truncated inverse-square weights of Nie04 (002 Eq. 4.9), `--nie04-neighbours` per
    /// support.
    Nie04,
}

/// Solver for the constants of the poly-gauss weights.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverArg {
    /// Damped least squares (LSQR), damping `--damping`: well posed on every cloud.
    Lsqr,
    /// The plain interpolation system by GMRES(50), Jacobi-preconditioned, stopped at
    /// `--max-iter`.
    Gmres,
    /// The plain interpolation system by BiCGSTAB, Jacobi-preconditioned.
    Bicgstab,
}

/// Where the far field gets its sign.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignArg {
    /// The side of the closest sample's tangent plane: wrong beside sharp edges.
    Nearest,
    /// The winding number of the oriented cloud (Barill et al. 2018) where the nearest
    /// samples disagree on the side, the closest sample's side elsewhere.
    Winding,
    /// The winding number wherever the far field counts (also spelled as in scene files,
    /// `winding_everywhere`).
    #[value(alias = "winding_everywhere")]
    WindingEverywhere,
}

/// Arguments of `isokit points`.
#[derive(clap::Args, Debug)]
#[command(after_help = crate::cmd::volume_args::LAYOUT)]
pub struct Args {
    /// Point cloud (.ply or .xyz).
    pub cloud: PathBuf,
    /// Output volume (.nrrd or .npy).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples along the longest side of the padded bounds.
    #[arg(long, default_value_t = 64)]
    pub res: usize,
    /// Narrow band: evaluate only the bricks that may come within W of the surface and
    /// clamp the output to ±W (the sign is kept). Without it every sample is evaluated.
    #[arg(long)]
    pub band: Option<f32>,
    /// Brick edge in samples for `--band` (a power of two from 2 to 256). Small bricks
    /// follow the surface more closely (4: 34% of a 128-grid evaluated around a torus, 8:
    /// 53%), at one extra evaluation per brick.
    #[arg(long, default_value_t = 4)]
    pub brick: usize,
    /// Nearest samples per evaluation (partition of unity support) [default: chosen from
    /// the cloud's noise estimate: 16, or 64 on a noisy cloud].
    #[arg(long)]
    pub k: Option<usize>,
    /// Nearest samples for the far-field weight; at least `--k` are used. The spread rule
    /// needs more than the centroid rule: `--far-rule spread --far-k 64` was the former
    /// default.
    #[arg(long, default_value_t = PointSdfOptions::default().far_k)]
    pub far_k: usize,
    /// How the far-field weight judges the distance from the surface.
    #[arg(long, value_enum, default_value_t = FarRuleArg::Centroid)]
    pub far_rule: FarRuleArg,
    /// Turn the far-field blend off (near field everywhere).
    #[arg(long)]
    pub no_far: bool,
    /// Sign of the far field away from the surface.
    #[arg(long, value_enum, default_value_t = SignArg::Winding)]
    pub sign: SignArg,
    /// Where normals come from [default: given when the cloud has them, else estimate].
    #[arg(long, value_enum)]
    pub normals: Option<Normals>,
    /// Neighbours for normal estimation.
    #[arg(long, default_value_t = 16)]
    pub normal_k: usize,
    /// Partition-of-unity weights.
    #[arg(long, value_enum, default_value_t = Weights::PolyGauss)]
    pub weights: Weights,
    /// Neighbours inside each sample's support for `--weights nie04`.
    #[arg(long, default_value_t = 18)]
    pub nie04_neighbours: usize,
    /// Solver for the constants (poly-gauss weights only).
    #[arg(long, value_enum, default_value_t = SolverArg::Lsqr)]
    pub solver: SolverArg,
    /// Damping λ of the LSQR solve: small values interpolate the samples closely, large
    /// ones (1 and more, with a larger `--k`) average noisy samples [default: chosen from
    /// the cloud's noise estimate: 0.05, or 1 on a noisy cloud].
    #[arg(long)]
    pub damping: Option<f64>,
    /// Iteration limit of the solve.
    #[arg(long, default_value_t = PointSdfOptions::default().max_iter)]
    pub max_iter: usize,
    /// Stop the LSQR solve once the field at the samples (the damped residual's root mean
    /// square) is within this fraction of the grid's spacing: a grid much coarser than the
    /// samples' spacing cannot tell the full solve from a shorter one. 0 solves until the
    /// least-squares optimality test holds. Other solvers and weights ignore it.
    #[arg(long, default_value_t = isokit_points::SOLVE_TO_GRID)]
    pub solve_to_grid: f64,
    #[command(flatten)]
    pub lattice: crate::cmd::volume_args::LatticeArgs,
    #[command(flatten)]
    pub out: crate::cmd::volume_args::VolumeOut,
}

impl Args {
    /// The library's settings; `cloud` decides the default normals (given when it has
    /// them, else estimated) and, with its noise estimate (returned when it was made), the
    /// default `k` and damping.
    pub fn options(
        &self,
        cloud: &PointCloud,
    ) -> Result<(CloudGridOptions, Option<NoiseEstimate>), PointsError> {
        let ((k, damping), noise) = match (self.k, self.damping) {
            (Some(k), Some(d)) => ((k, d), None),
            (k, d) => {
                let n = estimate_noise(&cloud.points)?;
                let (auto_k, auto_damping) = n.knobs();
                ((k.unwrap_or(auto_k), d.unwrap_or(auto_damping)), Some(n))
            }
        };
        let estimate = NormalOptions {
            k: self.normal_k,
            ..NormalOptions::default()
        };
        let normals = match self.normals {
            Some(Normals::Given) => NormalSource::Given,
            Some(Normals::Estimate) => NormalSource::Estimate(estimate),
            None => NormalSource::for_cloud(cloud, estimate),
        };
        let field = PointSdfOptions {
            k,
            far_k: self.far_k,
            far_field: !self.no_far,
            far_rule: match self.far_rule {
                FarRuleArg::Centroid => FarRule::Centroid,
                FarRuleArg::Spread => FarRule::Spread,
            },
            weighting: match self.weights {
                Weights::PolyGauss => Weighting::PolyGauss,
                Weights::Shepard => Weighting::Shepard,
                Weights::Nie04 => Weighting::Nie04 {
                    neighbours: self.nie04_neighbours,
                },
            },
            solver: match self.solver {
                SolverArg::Lsqr => Solver::Lsqr,
                SolverArg::Gmres => Solver::Gmres,
                SolverArg::Bicgstab => Solver::Bicgstab,
            },
            damping,
            max_iter: self.max_iter,
            sign: match self.sign {
                SignArg::Nearest => SignRule::Nearest,
                SignArg::Winding => SignRule::Winding,
                SignArg::WindingEverywhere => SignRule::WindingEverywhere,
            },
            ..PointSdfOptions::default()
        };
        let opts = CloudGridOptions {
            field,
            normals: Some(normals),
            band: self.band,
            brick: self.brick,
            solve_to_grid: self.solve_to_grid,
        };
        Ok((opts, noise))
    }
}
