//! Eigen-decomposition of symmetric 3×3 matrices (cyclic Jacobi, f64).
//!
//! Written out rather than taken from nalgebra: it is the only dense linear algebra the
//! crate needs, 40 lines, and keeps nalgebra out of the 2-core build.

/// Eigenvalues in ascending order and the matching unit eigenvectors (`vectors[i]` belongs
/// to `values[i]`) of the symmetric matrix `m` (row-major; only the upper triangle is read).
#[expect(
    clippy::needless_range_loop,
    reason = "index arithmetic on 3×3 matrices reads best as indices"
)]
pub fn symmetric_eigen(m: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut a = m;
    for i in 0..3 {
        for j in 0..i {
            a[i][j] = a[j][i];
        }
    }
    // v holds the eigenvectors as columns.
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let scale = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= 1e-15 * scale || off == 0.0 || !off.is_finite() {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            // Rotation that zeroes a[p][q] (Numerical Recipes' stable form).
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let values = order.map(|i| a[i][i]);
    let vectors = order.map(|i| [v[0][i], v[1][i], v[2][i]]);
    (values, vectors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reconstructs_a_random_symmetric_matrix() {
        let m = [[4.0, 1.0, -2.0], [1.0, 2.0, 0.5], [-2.0, 0.5, 3.0]];
        let (l, v) = symmetric_eigen(m);
        assert!(l[0] <= l[1] && l[1] <= l[2]);
        for i in 0..3 {
            // m v = λ v
            for r in 0..3 {
                let mv: f64 = (0..3).map(|c| m[r][c] * v[i][c]).sum();
                assert!(
                    (mv - l[i] * v[i][r]).abs() < 1e-12,
                    "{mv} vs {}",
                    l[i] * v[i][r]
                );
            }
            let n: f64 = v[i].iter().map(|x| x * x).sum();
            assert!((n - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn diagonal_and_zero_matrices() {
        let (l, v) = symmetric_eigen([[3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]);
        assert_eq!(l, [1.0, 2.0, 3.0]);
        assert_eq!(v[0], [0.0, 1.0, 0.0]);
        let (l, _) = symmetric_eigen([[0.0; 3]; 3]);
        assert_eq!(l, [0.0; 3]);
    }
}
