//! Iterative solution of the sparse, non-symmetric partition-of-unity system.
//!
//! Restarted GMRES (Saad–Schultz 1986) and BiCGSTAB (van der Vorst 1992), both with a
//! Jacobi (diagonal) preconditioner, on sprs CSR matrix–vector products. The matrix `A_ij` (normalized weight of sample j at sample i) is
//! row-stochastic and not symmetric (each row has its own support radius), and it is not
//! diagonally dominant: with k neighbours the diagonal is `1/Σ_j w_ij`, typically 0.1–0.3,
//! so Jacobi and Gauss–Seidel carry no convergence guarantee. Both Krylov methods need only
//! products with `A` (no transpose); see the crate docs for the measured iteration counts
//! and residuals.

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
    /// True when the tolerance was met.
    pub converged: bool,
    /// Largest `|f_near(p_i)|` over the samples after the solve, in world units: how far
    /// the near field is from interpolating zero at the samples.
    pub max_sample_value: f64,
    /// Seconds of the whole solve step: assembling the matrix (one k-nearest query per
    /// sample), iterating, and evaluating the field at every sample for `max_sample_value`.
    pub seconds: f64,
}

fn matvec(a: &CsMat<f64>, x: &[f64], y: &mut [f64]) {
    y.par_iter_mut().enumerate().for_each(|(i, yi)| {
        *yi = a
            .outer_view(i)
            .map_or(0.0, |row| row.iter().map(|(j, &v)| v * x[j]).sum());
    });
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// Solves `A x = b` by Jacobi-preconditioned BiCGSTAB from `x = 0`, until the relative
/// residual is below `tol` or `max_iter` iterations. `A` must be square CSR with a non-zero
/// diagonal (ours has the self weight). Returns the solution and the statistics (with
/// `max_sample_value` left 0 for the caller).
pub fn bicgstab(a: &CsMat<f64>, b: &[f64], tol: f64, max_iter: usize) -> (Vec<f64>, SolveStats) {
    let n = b.len();
    let mut stats = SolveStats {
        unknowns: n,
        nonzeros: a.nnz(),
        ..SolveStats::default()
    };
    let mut x = vec![0.0; n];
    let bnorm = norm(b);
    if bnorm == 0.0 || n == 0 {
        stats.converged = true;
        return (x, stats);
    }
    let dinv: Vec<f64> = (0..n)
        .map(|i| match a.get(i, i) {
            Some(&d) if d != 0.0 && d.is_finite() => 1.0 / d,
            _ => 1.0,
        })
        .collect();
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
/// estimate) and whether it meets `tol`.
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
    (x, stats)
}

/// Solves `A x = b` by restarted GMRES(`restart`) with a right Jacobi preconditioner from
/// `x = 0`, until the relative residual is below `tol` or `max_iter` inner iterations. The
/// residual norm never increases, so stopping early returns the best iterate of the
/// Krylov space explored (which regularizes a nearly singular system).
pub fn gmres(
    a: &CsMat<f64>,
    b: &[f64],
    tol: f64,
    max_iter: usize,
    restart: usize,
) -> (Vec<f64>, SolveStats) {
    let n = b.len();
    let mut stats = SolveStats {
        unknowns: n,
        nonzeros: a.nnz(),
        ..SolveStats::default()
    };
    let mut x = vec![0.0; n];
    let bnorm = norm(b);
    if bnorm == 0.0 || n == 0 {
        stats.converged = true;
        return (x, stats);
    }
    let m = restart.max(1);
    let dinv: Vec<f64> = (0..n)
        .map(|i| match a.get(i, i) {
            Some(&d) if d != 0.0 && d.is_finite() => 1.0 / d,
            _ => 1.0,
        })
        .collect();
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
            for i in 0..n {
                z[i] = dinv[i] * v[j][i];
            }
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
        for (l, yl) in y.iter().enumerate() {
            for i in 0..n {
                x[i] += dinv[i] * v[l][i] * yl;
            }
        }
        if g[used].abs() / bnorm < tol {
            break;
        }
    }
    stats.iterations = total;
    finish(a, b, x, bnorm, tol, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sprs::TriMat;

    /// Solves `A x = A xs` with `solve` and checks that it recovers `xs`.
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
        let a = [
            (0, 0, 0.5),
            (0, 1, 0.3),
            (0, 2, 0.2),
            (1, 0, 0.1),
            (1, 1, 0.6),
            (1, 2, 0.3),
            (2, 0, 0.4),
            (2, 2, 0.6),
        ];
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
        recovers(&a, |a, b| gmres(a, b, 1e-12, 100, 2));
    }
}
