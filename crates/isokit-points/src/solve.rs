//! Iterative solvers for the sparse, non-symmetric partition-of-unity system.
//!
//! The matrix `A_ij` (normalized weight of sample j at sample i) is row-stochastic and not
//! symmetric (each row has its own support radius), and it is not diagonally dominant: with
//! k neighbours the diagonal is `1/Σ_j w_ij`, typically 0.1–0.3. On random clouds it is
//! also numerically singular and indefinite (see the crate docs), so the exact solution of
//! `A c = b` is not what the field wants; [`lsqr`] solves the damped least-squares problem
//! `min ‖A c − b‖² + λ²‖c‖²` instead, which is well posed for every cloud.
//!
//! - [`lsqr`]: LSQR (Paige–Saunders 1982) with damping λ, on products with `A` and `Aᵀ`.
//!   The default.
//! - [`gmres`]: restarted GMRES (Saad–Schultz 1986) with a right [`Preconditioner`]
//!   (Jacobi or ILU(0), [`Ilu0`]), for the plain system.
//! - [`bicgstab`]: BiCGSTAB (van der Vorst 1992) with a Jacobi preconditioner, for the plain
//!   system.
//!
//! All work on sprs CSR matrices; matrix–vector products run in parallel with rayon.

use rayon::prelude::*;
use sprs::CsMat;

/// The outcome of a solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Unknowns.
    pub unknowns: usize,
    /// Stored non-zeros of the matrix.
    pub nonzeros: usize,
    /// Iterations taken (0 when the right-hand side vanishes).
    pub iterations: usize,
    /// Final relative residual `‖b − A x‖ / ‖b‖` (recomputed, not the recurrence's).
    pub relative_residual: f64,
    /// True when the solver's stopping test was met: the relative residual below the
    /// tolerance for [`gmres`] and [`bicgstab`], the least-squares optimality (or a
    /// vanishing residual, or the residual target of [`lsqr_to`]) for [`lsqr`].
    pub converged: bool,
    /// [`lsqr_to`] only: true when the residual's RMS target stopped it (before the first
    /// iteration, or in an iteration whose optimality test had not stopped it already).
    pub reached_target: bool,
    /// The damping λ of [`lsqr`] (0 for the other solvers).
    pub damping: f64,
    /// [`lsqr`] only: `‖Āᵀ r̄‖ / (‖Ā‖ ‖r̄‖)` of the damped problem at the last iterate, 0
    /// at its exact minimizer (0 for the other solvers; ∞ when [`lsqr_to`] stopped before its
    /// first iteration, where it was not estimated).
    pub optimality: f64,
    /// Largest entry of `|b − A x|` at the returned `x`. For [`crate::PointSdf`]'s system
    /// it is the largest `|f_near(p_i)|` over the samples, in world units: how far the near
    /// field is from interpolating zero at the samples.
    pub max_sample_value: f64,
    /// Seconds of the whole solve step: assembling the matrix (one k-nearest query per
    /// sample, which also gives the winding number's sample areas where it is built),
    /// iterating, and the true residual `b − A c` (`relative_residual`, `max_sample_value`).
    pub seconds: f64,
}

/// `y = A x`, row by row over the raw CSR arrays (a row view per row cost twice the
/// instructions of the products themselves), in chunks of rows per task.
fn matvec(a: &CsMat<f64>, x: &[f64], y: &mut [f64]) {
    let ip = a.indptr();
    let ip = ip.raw_storage();
    let base = ip.first().copied().unwrap_or(0);
    let (ix, d) = (a.indices(), a.data());
    y.par_iter_mut()
        .enumerate()
        .with_min_len(512)
        .for_each(|(i, yi)| {
            // Rows past the matrix's read 0, as an absent row view did.
            *yi = match (ip.get(i), ip.get(i + 1)) {
                (Some(&s), Some(&e)) => {
                    let r = s - base..e - base;
                    ix[r.clone()]
                        .iter()
                        .zip(&d[r])
                        .map(|(&j, &v)| v * x[j])
                        .sum()
                }
                _ => 0.0,
            };
        });
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// The common start of the solvers: `x = 0` of `n` unknowns, the statistics, and `‖b‖`;
/// `stats.converged` is already true when there is nothing to solve (`b = 0` or `n = 0`).
fn start(a: &CsMat<f64>, n: usize, b: &[f64]) -> (Vec<f64>, SolveStats, f64) {
    let bnorm = norm(b);
    let stats = SolveStats {
        unknowns: n,
        nonzeros: a.nnz(),
        converged: bnorm == 0.0 || n == 0,
        ..SolveStats::default()
    };
    (vec![0.0; n], stats, bnorm)
}

/// The inverse diagonal of `a` (1 where the diagonal is zero, missing or not finite).
fn jacobi(a: &CsMat<f64>) -> Vec<f64> {
    (0..a.rows())
        .map(|i| match a.get(i, i) {
            Some(&d) if d != 0.0 && d.is_finite() => 1.0 / d,
            _ => 1.0,
        })
        .collect()
}

/// Solves `A x = b` by Jacobi-preconditioned BiCGSTAB from `x = 0`, until the relative
/// residual is below `tol` or `max_iter` iterations. `A` must be square CSR with a non-zero
/// diagonal (ours has the self weight). Returns the solution and the statistics.
pub fn bicgstab(a: &CsMat<f64>, b: &[f64], tol: f64, max_iter: usize) -> (Vec<f64>, SolveStats) {
    let n = b.len();
    let (mut x, mut stats, bnorm) = start(a, n, b);
    if stats.converged {
        return (x, stats);
    }
    let dinv = jacobi(a);
    let mut r = b.to_vec();
    let r0 = r.clone();
    let (mut rho, mut alpha, mut omega) = (1.0f64, 1.0f64, 1.0f64);
    let mut v = vec![0.0; n];
    let mut p = vec![0.0; n];
    let (mut y, mut z, mut s, mut t) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut best = (f64::INFINITY, x.clone());
    for it in 1..=max_iter {
        stats.iterations = it;
        let rho_new = dot(&r0, &r);
        if rho_new == 0.0 || !rho_new.is_finite() {
            break; // breakdown; the best iterate so far is returned
        }
        let beta = (rho_new / rho) * (alpha / omega);
        rho = rho_new;
        for i in 0..n {
            p[i] = r[i] + beta * (p[i] - omega * v[i]);
            y[i] = dinv[i] * p[i];
        }
        matvec(a, &y, &mut v);
        let r0v = dot(&r0, &v);
        if r0v == 0.0 || !r0v.is_finite() {
            break;
        }
        alpha = rho / r0v;
        for i in 0..n {
            s[i] = r[i] - alpha * v[i];
        }
        if norm(&s) / bnorm < tol {
            for i in 0..n {
                x[i] += alpha * y[i];
            }
            best = (norm(&s) / bnorm, x.clone());
            break;
        }
        for i in 0..n {
            z[i] = dinv[i] * s[i];
        }
        matvec(a, &z, &mut t);
        let tt = dot(&t, &t);
        omega = if tt > 0.0 { dot(&t, &s) / tt } else { 0.0 };
        for i in 0..n {
            x[i] += alpha * y[i] + omega * z[i];
            r[i] = s[i] - omega * t[i];
        }
        let rel = norm(&r) / bnorm;
        if rel < best.0 {
            best = (rel, x.clone());
        }
        if rel < tol || omega == 0.0 || !rel.is_finite() {
            break;
        }
    }
    finish(a, b, best.1, bnorm, tol, stats)
}

/// Records the true relative residual of the returned iterate `x` (not the recurrence's
/// estimate), whether it meets `tol`, and the largest residual entry.
fn finish(
    a: &CsMat<f64>,
    b: &[f64],
    x: Vec<f64>,
    bnorm: f64,
    tol: f64,
    mut stats: SolveStats,
) -> (Vec<f64>, SolveStats) {
    let mut ax = vec![0.0; b.len()];
    matvec(a, &x, &mut ax);
    let res: Vec<f64> = b.iter().zip(&ax).map(|(bi, axi)| bi - axi).collect();
    stats.relative_residual = norm(&res) / bnorm;
    stats.converged = stats.relative_residual < tol;
    stats.max_sample_value = res.iter().fold(0.0, |m: f64, r| m.max(r.abs()));
    (x, stats)
}

/// The right preconditioner `M` of [`gmres`]: GMRES works on `A M⁻¹` and returns
/// `x = M⁻¹ y`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preconditioner {
    /// `M = diag(A)` (zero or non-finite diagonal entries taken as 1).
    Jacobi,
    /// `M = L U`, the incomplete LU factorization of `A` on its own sparsity pattern
    /// ([`Ilu0`]).
    Ilu0,
}

/// The incomplete LU factorization with no fill, ILU(0): `L` (unit lower) and `U` share the
/// sparsity pattern of `A`, and `(L U)_ij = A_ij` on that pattern (Saad, *Iterative Methods
/// for Sparse Linear Systems*, Alg. 10.4).
///
/// `A` is not diagonally dominant here, so pivots can come out tiny or zero: a pivot below
/// `1e-12` times the row's largest magnitude is replaced by that bound (with its sign) and
/// counted in [`Ilu0::small_pivots`].
#[derive(Clone, Debug)]
pub struct Ilu0 {
    lu: CsMat<f64>,
    diag: Vec<usize>,
    small_pivots: usize,
    smallest_pivot: f64,
}

impl Ilu0 {
    /// Factors a square CSR matrix. A missing diagonal entry counts as a zero pivot (the
    /// factor then uses the bound above on the row's existing entries only).
    pub fn new(a: &CsMat<f64>) -> Self {
        let n = a.rows();
        let mut lu = if a.is_csr() { a.clone() } else { a.to_csr() };
        // sprs keeps the indices of each row sorted.
        let indptr: Vec<usize> = lu.indptr().raw_storage().to_vec();
        let indices: Vec<usize> = lu.indices().to_vec();
        let data = lu.data_mut();
        let mut diag = vec![usize::MAX; n];
        let mut pos = vec![usize::MAX; n];
        let mut small = 0usize;
        let mut smallest = f64::INFINITY;
        for i in 0..n {
            let (lo, hi) = (indptr[i], indptr[i + 1]);
            for m in lo..hi {
                pos[indices[m]] = m;
                if indices[m] == i {
                    diag[i] = m;
                }
            }
            let scale = data[lo..hi]
                .iter()
                .fold(0.0f64, |s, v| s.max(v.abs()))
                .max(1e-300);
            for m in lo..hi {
                let k = indices[m];
                if k >= i {
                    break;
                }
                let dk = diag[k];
                if dk == usize::MAX {
                    continue;
                }
                let lik = data[m] / data[dk];
                data[m] = lik;
                for mm in dk + 1..indptr[k + 1] {
                    let j = indices[mm];
                    let pj = pos[j];
                    if pj != usize::MAX && pj >= lo && pj < hi {
                        data[pj] -= lik * data[mm];
                    }
                }
            }
            if diag[i] != usize::MAX {
                let d = &mut data[diag[i]];
                smallest = smallest.min(d.abs() / scale);
                if d.is_nan() || d.abs() < 1e-12 * scale {
                    small += 1;
                    *d = if *d < 0.0 {
                        -1e-12 * scale
                    } else {
                        1e-12 * scale
                    };
                }
            } else {
                small += 1;
            }
            for m in lo..hi {
                pos[indices[m]] = usize::MAX;
            }
        }
        Self {
            lu,
            diag,
            small_pivots: small,
            smallest_pivot: smallest,
        }
    }

    /// Pivots that were (nearly) zero and replaced; many of them mean the factor is a poor
    /// approximation of `A`.
    pub fn small_pivots(&self) -> usize {
        self.small_pivots
    }

    /// The smallest |pivot| `|U_ii|` relative to the largest magnitude in row i of `A`,
    /// before any replacement (infinite for an empty matrix). Tiny values make `(L U)⁻¹`
    /// huge and the preconditioned operator badly conditioned.
    pub fn smallest_pivot(&self) -> f64 {
        self.smallest_pivot
    }

    /// Solves `L U x = v` in place (forward then backward substitution, sequential).
    pub fn apply(&self, v: &mut [f64]) {
        let indptr = self.lu.indptr();
        let indptr = indptr.raw_storage();
        let (indices, data) = (self.lu.indices(), self.lu.data());
        let n = v.len();
        for i in 0..n {
            let mut s = v[i];
            for m in indptr[i]..indptr[i + 1] {
                let j = indices[m];
                if j >= i {
                    break;
                }
                s -= data[m] * v[j];
            }
            v[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = v[i];
            let d = self.diag[i];
            if d == usize::MAX {
                continue; // no pivot: leave the entry (identity row)
            }
            for m in d + 1..indptr[i + 1] {
                s -= data[m] * v[indices[m]];
            }
            v[i] = s / data[d];
        }
    }
}

/// The applied form of a [`Preconditioner`].
enum Prec {
    Jacobi(Vec<f64>),
    Ilu(Ilu0),
}

impl Prec {
    fn new(a: &CsMat<f64>, p: Preconditioner) -> Self {
        match p {
            Preconditioner::Jacobi => Prec::Jacobi(jacobi(a)),
            Preconditioner::Ilu0 => Prec::Ilu(Ilu0::new(a)),
        }
    }

    /// `out = M⁻¹ v`.
    fn apply(&self, v: &[f64], out: &mut [f64]) {
        match self {
            Prec::Jacobi(d) => out
                .iter_mut()
                .zip(v.iter().zip(d))
                .for_each(|(o, (vi, di))| *o = vi * di),
            Prec::Ilu(f) => {
                out.copy_from_slice(v);
                f.apply(out);
            }
        }
    }
}

/// Solves `A x = b` by restarted GMRES(`restart`) with the right preconditioner `prec` from
/// `x = 0`, until the relative residual is below `tol` or `max_iter` inner iterations. The
/// residual norm never increases, so stopping early returns the best iterate of the
/// Krylov space explored.
pub fn gmres(
    a: &CsMat<f64>,
    b: &[f64],
    tol: f64,
    max_iter: usize,
    restart: usize,
    prec: Preconditioner,
) -> (Vec<f64>, SolveStats) {
    let n = b.len();
    let (mut x, mut stats, bnorm) = start(a, n, b);
    if stats.converged {
        return (x, stats);
    }
    let m = restart.max(1);
    let prec = Prec::new(a, prec);
    let mut ax = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut total = 0usize;
    'outer: while total < max_iter {
        matvec(a, &x, &mut ax);
        let r: Vec<f64> = b.iter().zip(&ax).map(|(bi, a)| bi - a).collect();
        let beta = norm(&r);
        if beta / bnorm < tol {
            break;
        }
        let mut v: Vec<Vec<f64>> = vec![r.iter().map(|ri| ri / beta).collect()];
        let mut h = vec![vec![0.0f64; m]; m + 1];
        let (mut cs, mut sn) = (vec![0.0f64; m], vec![0.0f64; m]);
        let mut g = vec![0.0f64; m + 1];
        g[0] = beta;
        let mut used = 0;
        for j in 0..m {
            if total >= max_iter {
                break;
            }
            total += 1;
            prec.apply(&v[j], &mut z);
            matvec(a, &z, &mut w);
            // Modified Gram–Schmidt.
            for (i, vi) in v.iter().enumerate() {
                let hij = dot(&w, vi);
                h[i][j] = hij;
                w.iter_mut().zip(vi).for_each(|(wk, vk)| *wk -= hij * vk);
            }
            let hn = norm(&w);
            h[j + 1][j] = hn;
            for i in 0..j {
                let t = cs[i] * h[i][j] + sn[i] * h[i + 1][j];
                h[i + 1][j] = -sn[i] * h[i][j] + cs[i] * h[i + 1][j];
                h[i][j] = t;
            }
            let den = (h[j][j] * h[j][j] + h[j + 1][j] * h[j + 1][j]).sqrt();
            if den == 0.0 || !den.is_finite() {
                break;
            }
            cs[j] = h[j][j] / den;
            sn[j] = h[j + 1][j] / den;
            h[j][j] = den;
            h[j + 1][j] = 0.0;
            g[j + 1] = -sn[j] * g[j];
            g[j] *= cs[j];
            used = j + 1;
            let done = g[j + 1].abs() / bnorm < tol || hn == 0.0;
            if !done {
                v.push(w.iter().map(|wk| wk / hn).collect());
            }
            if done {
                break;
            }
        }
        if used == 0 {
            break 'outer;
        }
        // Back substitution, then x += M⁻¹ V y.
        let mut y = vec![0.0f64; used];
        for i in (0..used).rev() {
            let s: f64 = (i + 1..used).map(|l| h[i][l] * y[l]).sum();
            y[i] = (g[i] - s) / h[i][i];
        }
        let mut u = vec![0.0f64; n];
        for (l, yl) in y.iter().enumerate() {
            u.iter_mut().zip(&v[l]).for_each(|(ui, vi)| *ui += vi * yl);
        }
        prec.apply(&u, &mut z);
        x.iter_mut().zip(&z).for_each(|(xi, zi)| *xi += zi);
        if g[used].abs() / bnorm < tol {
            break;
        }
    }
    stats.iterations = total;
    finish(a, b, x, bnorm, tol, stats)
}

/// Solves the damped least-squares problem `min ‖A x − b‖² + damp²‖x‖²` by LSQR
/// (Paige & Saunders 1982, with their damping and stopping rules), from `x = 0`.
///
/// Stops when the damped system's residual is orthogonal to its range to `tol`
/// (`‖Āᵀ r̄‖ ≤ tol ‖Ā‖ ‖r̄‖`, with `Ā = [A; damp I]`, `r̄ = [b − A x; −damp x]`), when it
/// vanishes (`‖r̄‖ ≤ tol ‖b‖`), or after `max_iter` iterations (each one product with `A`
/// and one with `Aᵀ`). `stats.converged` says which; `stats.relative_residual` is
/// `‖b − A x‖/‖b‖` of the undamped equations, recomputed. The condition number of the
/// damped problem is at most `√(‖A‖² + damp²)/damp`, so the iteration count is bounded
/// for every `A`, singular or not.
pub fn lsqr(
    a: &CsMat<f64>,
    b: &[f64],
    damp: f64,
    tol: f64,
    max_iter: usize,
) -> (Vec<f64>, SolveStats) {
    lsqr_to(a, b, damp, tol, max_iter, 0.0)
}

/// [`lsqr`] that also stops, as converged, once the damped residual's root mean square
/// `‖r̄‖/√m` (m the rows; `‖r̄‖ ≥ ‖b − A x‖`, so the undamped residual is at least as small)
/// is at most `target_rms`, before the first iteration when `‖b‖/√m` already is
/// ([`SolveStats::reached_target`]). For a solution needed only to some absolute precision:
/// the field sampled on a grid much coarser than the samples' spacing.
pub fn lsqr_to(
    a: &CsMat<f64>,
    b: &[f64],
    damp: f64,
    tol: f64,
    max_iter: usize,
    target_rms: f64,
) -> (Vec<f64>, SolveStats) {
    let n = a.cols();
    let (mut x, mut stats, bnorm) = start(a, n, b);
    stats.damping = damp;
    if stats.converged {
        return (x, stats);
    }
    // The residual's norm at which its root mean square over the rows meets the target.
    let target = target_rms * (a.rows() as f64).sqrt();
    if bnorm <= target {
        stats.reached_target = true;
        stats.optimality = f64::INFINITY;
        return finish(a, b, x, bnorm, f64::INFINITY, stats);
    }
    let at: CsMat<f64> = a.transpose_view().to_csr();
    let mut u: Vec<f64> = b.iter().map(|v| v / bnorm).collect();
    let mut v = vec![0.0; n];
    matvec(&at, &u, &mut v);
    let mut alpha = norm(&v);
    if alpha == 0.0 {
        // b is orthogonal to the range of A: x = 0 is the least-squares solution.
        stats.converged = true;
        return finish(a, b, x, bnorm, f64::INFINITY, stats);
    }
    v.iter_mut().for_each(|e| *e /= alpha);
    let mut w = v.clone();
    let (mut rhobar, mut phibar) = (alpha, bnorm);
    let (mut anorm2, damp2) = (0.0f64, damp * damp);
    let mut res2 = 0.0f64;
    let mut au = vec![0.0; a.rows()];
    let mut atv = vec![0.0; n];
    let mut optimality = f64::INFINITY;
    let mut done = false;
    for it in 1..=max_iter {
        stats.iterations = it;
        // Bidiagonalization: β u = A v − α u, α v = Aᵀ u − β v.
        matvec(a, &v, &mut au);
        u.iter_mut()
            .zip(&au)
            .for_each(|(ui, ai)| *ui = ai - alpha * *ui);
        let beta = norm(&u);
        if beta > 0.0 {
            u.iter_mut().for_each(|e| *e /= beta);
            anorm2 += alpha * alpha + beta * beta + damp2;
            matvec(&at, &u, &mut atv);
            v.iter_mut()
                .zip(&atv)
                .for_each(|(vi, ai)| *vi = ai - beta * *vi);
            alpha = norm(&v);
            if alpha > 0.0 {
                v.iter_mut().for_each(|e| *e /= alpha);
            }
        }
        // Rotate the damping away, then the subdiagonal β.
        let rhobar1 = (rhobar * rhobar + damp2).sqrt();
        let (cs1, sn1) = (rhobar / rhobar1, damp / rhobar1);
        let psi = sn1 * phibar;
        phibar *= cs1;
        let rho = rhobar1.hypot(beta);
        let (cs, sn) = (rhobar1 / rho, beta / rho);
        let theta = sn * alpha;
        rhobar = -cs * alpha;
        let phi = cs * phibar;
        phibar *= sn;
        let tau = sn * phi;
        let (t1, t2) = (phi / rho, -theta / rho);
        x.iter_mut().zip(&w).for_each(|(xi, wi)| *xi += t1 * wi);
        w.iter_mut()
            .zip(&v)
            .for_each(|(wi, vi)| *wi = vi + t2 * *wi);
        // Stopping rules on the recurrences' norms.
        res2 += psi * psi;
        let rnorm = (phibar * phibar + res2).sqrt();
        let arnorm = alpha * tau.abs();
        let anorm = anorm2.sqrt();
        optimality = arnorm / (anorm * rnorm).max(f64::MIN_POSITIVE);
        if !optimality.is_finite() || !rnorm.is_finite() {
            break;
        }
        if optimality <= tol || rnorm <= tol * bnorm || alpha == 0.0 || beta == 0.0 {
            done = true;
            break;
        }
        if rnorm <= target {
            done = true;
            stats.reached_target = true;
            break;
        }
    }
    stats.optimality = optimality;
    let (x, mut stats) = finish(a, b, x, bnorm, f64::INFINITY, stats);
    stats.converged = done;
    (x, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sprs::TriMat;

    /// Solves `A x = A xs` with `solve` and checks that it recovers `xs`.
    /// A small nonsymmetric, diagonally dominant system shared by the solver tests.
    const NONSYMMETRIC: [(usize, usize, f64); 8] = [
        (0, 0, 0.5),
        (0, 1, 0.3),
        (0, 2, 0.2),
        (1, 0, 0.1),
        (1, 1, 0.6),
        (1, 2, 0.3),
        (2, 0, 0.4),
        (2, 2, 0.6),
    ];

    fn recovers(
        triplets: &[(usize, usize, f64)],
        solve: impl Fn(&CsMat<f64>, &[f64]) -> (Vec<f64>, SolveStats),
    ) {
        let mut t = TriMat::new((3, 3));
        for &(i, j, v) in triplets {
            t.add_triplet(i, j, v);
        }
        let a: CsMat<f64> = t.to_csr();
        let xs = [1.0, -2.0, 3.0];
        let mut b = vec![0.0; 3];
        matvec(&a, &xs, &mut b);
        let (x, st) = solve(&a, &b);
        assert!(st.converged, "{st:?}");
        for i in 0..3 {
            assert!((x[i] - xs[i]).abs() < 1e-9, "{x:?}");
        }
    }

    #[test]
    fn bicgstab_solves_a_small_nonsymmetric_system() {
        let a = NONSYMMETRIC;
        recovers(&a, |a, b| bicgstab(a, b, 1e-12, 100));
    }

    #[test]
    fn gmres_solves_a_small_indefinite_system() {
        let a = [
            (0, 0, 0.2),
            (0, 1, 0.8),
            (1, 0, 0.7),
            (1, 1, 0.1),
            (1, 2, 0.2),
            (2, 2, 1.0),
        ];
        recovers(&a, |a, b| {
            gmres(a, b, 1e-12, 100, 2, Preconditioner::Jacobi)
        });
        recovers(&a, |a, b| gmres(a, b, 1e-12, 100, 2, Preconditioner::Ilu0));
    }

    #[test]
    fn ilu0_is_exact_without_fill() {
        // A tridiagonal matrix has an LU factorization without fill, so ILU(0) is exact
        // and preconditioned GMRES converges in one iteration.
        let n = 6;
        let mut t = TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 4.0 + i as f64);
            if i + 1 < n {
                t.add_triplet(i, i + 1, -1.0 - 0.1 * i as f64);
                t.add_triplet(i + 1, i, 2.0);
            }
        }
        let a: CsMat<f64> = t.to_csr();
        let f = Ilu0::new(&a);
        assert_eq!(f.small_pivots(), 0);
        let xs: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut b = vec![0.0; n];
        matvec(&a, &xs, &mut b);
        let mut y = b.clone();
        f.apply(&mut y);
        for i in 0..n {
            assert!((y[i] - xs[i]).abs() < 1e-12, "{y:?} {xs:?}");
        }
        let (_, st) = gmres(&a, &b, 1e-10, 10, 5, Preconditioner::Ilu0);
        assert_eq!(st.iterations, 1, "{st:?}");
        // A zero pivot is counted and replaced, not divided by.
        let mut t = TriMat::new((2, 2));
        t.add_triplet(0, 1, 1.0);
        t.add_triplet(1, 0, 1.0);
        t.add_triplet(1, 1, 1.0);
        let f = Ilu0::new(&t.to_csr());
        assert_eq!(f.small_pivots(), 1);
        let mut y = vec![1.0, 2.0];
        f.apply(&mut y);
        assert!(y.iter().all(|v| v.is_finite()), "{y:?}");
    }

    #[test]
    fn ilu0_matches_the_matrix_on_its_pattern() {
        // A random sparse non-symmetric matrix with a non-symmetric pattern, diagonally
        // dominant so that no pivot is small: (L U)_ij = A_ij wherever A_ij is stored.
        let n = 60;
        let mut rng = isokit_field::rng::SplitMix64::new(4);
        let mut t = TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 8.0);
            for _ in 0..5 {
                let j = (rng.next_f64() * n as f64) as usize % n;
                if j != i {
                    t.add_triplet(i, j, rng.next_f64() - 0.5);
                }
            }
        }
        let a: CsMat<f64> = t.to_csr();
        let f = Ilu0::new(&a);
        assert_eq!(f.small_pivots(), 0);
        let dense = |m: &CsMat<f64>| {
            let mut d = vec![0.0; n * n];
            for (i, row) in m.outer_iterator().enumerate() {
                for (j, &v) in row.iter() {
                    d[i * n + j] = v;
                }
            }
            d
        };
        let lu = dense(&f.lu);
        let l = |i: usize, j: usize| match i.cmp(&j) {
            std::cmp::Ordering::Greater => lu[i * n + j],
            std::cmp::Ordering::Equal => 1.0,
            std::cmp::Ordering::Less => 0.0,
        };
        let u = |i: usize, j: usize| if i <= j { lu[i * n + j] } else { 0.0 };
        for (i, row) in a.outer_iterator().enumerate() {
            for (j, &v) in row.iter() {
                let p: f64 = (0..n).map(|k| l(i, k) * u(k, j)).sum();
                assert!((p - v).abs() < 1e-12, "({i}, {j}): {p} vs {v}");
            }
        }
        // And it pays: fewer GMRES iterations than with Jacobi.
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
        let (_, sj) = gmres(&a, &b, 1e-10, 200, 50, Preconditioner::Jacobi);
        let (_, si) = gmres(&a, &b, 1e-10, 200, 50, Preconditioner::Ilu0);
        assert!(sj.converged && si.converged);
        assert!(si.iterations < sj.iterations, "{si:?} {sj:?}");
    }

    #[test]
    fn lsqr_solves_and_damps() {
        let a = NONSYMMETRIC;
        recovers(&a, |a, b| lsqr(a, b, 0.0, 1e-14, 100));
        // Damped: the normal equations (AᵀA + λ²I) x = Aᵀb, checked densely; and a
        // singular matrix gives the finite, minimum-norm-like damped solution.
        let mut t = TriMat::new((3, 3));
        for &(i, j, v) in &a {
            t.add_triplet(i, j, v);
        }
        let m: CsMat<f64> = t.to_csr();
        let b = [1.0, -1.0, 0.5];
        let lam = 0.3;
        let (x, st) = lsqr(&m, &b, lam, 1e-14, 100);
        assert!(st.converged && st.optimality < 1e-12, "{st:?}");
        let dense = |i: usize, j: usize| m.get(i, j).copied().unwrap_or(0.0);
        for r in 0..3 {
            let mut lhs = lam * lam * x[r];
            let mut rhs = 0.0;
            for (i, bi) in b.iter().enumerate() {
                let ax: f64 = (0..3).map(|j| dense(i, j) * x[j]).sum();
                lhs += dense(i, r) * ax;
                rhs += dense(i, r) * bi;
            }
            assert!((lhs - rhs).abs() < 1e-12, "row {r}: {lhs} {rhs}");
        }
        let mut t = TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 0, 1.0);
        let (x, st) = lsqr(&t.to_csr(), &[1.0, 3.0], 1e-3, 1e-12, 50);
        assert!(st.converged, "{st:?}");
        assert!((x[0] - 2.0).abs() < 1e-5 && x[1] == 0.0, "{x:?}");
    }

    #[test]
    fn lsqr_stops_at_the_residual_target() {
        // A 1-D Laplacian plus identity (well posed, many iterations to converge fully).
        let n = 400;
        let mut t = TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 3.0);
            if i > 0 {
                t.add_triplet(i, i - 1, -1.0);
            }
            if i + 1 < n {
                t.add_triplet(i, i + 1, -1.0);
            }
        }
        let a: CsMat<f64> = t.to_csr();
        let b: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let rms = |x: &[f64]| {
            let mut ax = vec![0.0; n];
            matvec(&a, x, &mut ax);
            (b.iter()
                .zip(&ax)
                .map(|(p, q)| (p - q) * (p - q))
                .sum::<f64>()
                / n as f64)
                .sqrt()
        };
        let (full, fs) = lsqr(&a, &b, 0.0, 1e-12, 500);
        let (same, ss) = lsqr_to(&a, &b, 0.0, 1e-12, 500, 0.0);
        assert_eq!(full, same);
        assert!(!fs.reached_target && !ss.reached_target);
        let b_rms = rms(&vec![0.0; n]);
        for frac in [0.3, 0.05, 1e-3] {
            let target = frac * b_rms;
            let (x, st) = lsqr_to(&a, &b, 0.0, 1e-12, 500, target);
            println!(
                "target {frac} of the right-hand side: {} iterations against {}",
                st.iterations, fs.iterations
            );
            assert!(st.converged && st.reached_target, "{st:?}");
            assert!(st.iterations < fs.iterations, "{st:?}");
            assert!(rms(&x) <= target, "{} > {target}", rms(&x));
        }
        // A target the right-hand side already meets: no iteration, x = 0.
        let (x, st) = lsqr_to(&a, &b, 0.05, 1e-12, 500, b_rms * 1.0001);
        assert!(st.reached_target && st.iterations == 0 && x.iter().all(|&v| v == 0.0));
    }
}
