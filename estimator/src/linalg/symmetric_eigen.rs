//! Eigen-decomposition of a symmetric matrix by cyclic Jacobi rotations.
//!
//! For a symmetric `P` this *is* the singular value decomposition the SVD-CKF
//! asks for: `P = U·Σ·Vᵀ` with `U` the eigenvectors and `Σ = |Λ|` (a negative
//! eigenvalue moves its sign into `V`). Jacobi is chosen because, with a
//! stopping test relative to each pair's own diagonal (Demmel & Veselić, SIAM J.
//! Matrix Anal. Appl. 13(4), 1992), it is accurate to working precision on
//! small eigenvalues, which is exactly where a covariance goes wrong, and
//! because it runs in buffers allocated once.

use nalgebra::{DMatrix, DVector};

/// Workspace and result of a symmetric eigen-decomposition `A = V·diag(λ)·Vᵀ`.
#[derive(Debug, Clone)]
pub struct SymmetricEigen {
    a: DMatrix<f64>,
    vectors: DMatrix<f64>,
    values: DVector<f64>,
}

/// Jacobi did not reach a diagonal matrix (only for non-finite input in practice).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NotConverged;

const MAX_SWEEPS: usize = 60;

impl SymmetricEigen {
    /// Buffers for `n × n` matrices.
    pub fn new(n: usize) -> Self {
        Self { a: DMatrix::zeros(n, n), vectors: DMatrix::zeros(n, n), values: DVector::zeros(n) }
    }

    /// Eigenvectors, one per column, in the order of [`Self::values`].
    pub fn vectors(&self) -> &DMatrix<f64> {
        &self.vectors
    }

    /// Eigenvalues (unsorted).
    pub fn values(&self) -> &DVector<f64> {
        &self.values
    }

    /// Decomposes the symmetric part of `m` (only its lower triangle is read).
    pub fn decompose(&mut self, m: &DMatrix<f64>) -> Result<(), NotConverged> {
        let n = self.a.nrows();
        debug_assert_eq!(m.shape(), (n, n));
        for j in 0..n {
            for i in j..n {
                self.a[(i, j)] = m[(i, j)];
                self.a[(j, i)] = m[(i, j)];
            }
        }
        self.vectors.fill_with_identity();
        if self.a.iter().any(|v| !v.is_finite()) {
            return Err(NotConverged);
        }
        for _ in 0..MAX_SWEEPS {
            // Demmel & Veselić's criterion: a pair is negligible when small against the
            // geometric mean of its own diagonal entries, not against the whole matrix.
            // With it the small eigenvalues of a graded covariance (variances from 1e-10
            // to 1e10 in S2) come out to working precision relative to themselves; against
            // the matrix norm they were left with absolute errors of eps·‖P‖.
            let mut rotated = false;
            for q in 1..n {
                for p in 0..q {
                    let apq = self.a[(p, q)];
                    if apq != 0.0 && apq.abs() > f64::EPSILON * (self.a[(p, p)] * self.a[(q, q)]).abs().sqrt() {
                        self.rotate(p, q);
                        rotated = true;
                    }
                }
            }
            if !rotated {
                for i in 0..n {
                    self.values[i] = self.a[(i, i)];
                }
                return Ok(());
            }
        }
        Err(NotConverged)
    }

    /// One Jacobi rotation annihilating `a[p, q]` (Golub & Van Loan, alg. 8.5.1).
    fn rotate(&mut self, p: usize, q: usize) {
        let apq = self.a[(p, q)];
        if apq == 0.0 {
            return;
        }
        let tau = (self.a[(q, q)] - self.a[(p, p)]) / (2.0 * apq);
        let t =
            if tau >= 0.0 { 1.0 / (tau + (1.0 + tau * tau).sqrt()) } else { -1.0 / (-tau + (1.0 + tau * tau).sqrt()) };
        let c = 1.0 / (1.0 + t * t).sqrt();
        let s = t * c;
        let n = self.a.nrows();
        // A ← Jᵀ·A·J on rows/columns p and q.
        for k in 0..n {
            let akp = self.a[(k, p)];
            let akq = self.a[(k, q)];
            self.a[(k, p)] = c * akp - s * akq;
            self.a[(k, q)] = s * akp + c * akq;
        }
        for k in 0..n {
            let apk = self.a[(p, k)];
            let aqk = self.a[(q, k)];
            self.a[(p, k)] = c * apk - s * aqk;
            self.a[(q, k)] = s * apk + c * aqk;
        }
        self.a[(p, q)] = 0.0;
        self.a[(q, p)] = 0.0;
        for k in 0..n {
            let vkp = self.vectors[(k, p)];
            let vkq = self.vectors[(k, q)];
            self.vectors[(k, p)] = c * vkp - s * vkq;
            self.vectors[(k, q)] = s * vkp + c * vkq;
        }
    }

    /// Writes `U·√Σ` (`Σ = |λ|`, the singular values of the decomposed matrix)
    /// into `out`: a square root of the matrix when it is positive semi-definite.
    pub fn write_svd_square_root(&self, out: &mut DMatrix<f64>) {
        let n = self.values.len();
        for j in 0..n {
            let scale = self.values[j].abs().sqrt();
            for i in 0..n {
                out[(i, j)] = self.vectors[(i, j)] * scale;
            }
        }
    }

    /// The smallest eigenvalue.
    pub fn min_value(&self) -> f64 {
        self.values.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// The largest eigenvalue magnitude.
    pub fn max_abs_value(&self) -> f64 {
        self.values.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reconstructs_a_symmetric_matrix_with_orthonormal_vectors() {
        let n = 9;
        let b = DMatrix::from_fn(n, n, |i, j| (((i * 5 + j * 11) % 13) as f64 - 6.0) / 4.0);
        let m = &b + b.transpose();
        let mut e = SymmetricEigen::new(n);
        e.decompose(&m).unwrap();
        let v = e.vectors();
        let rebuilt = v * DMatrix::from_diagonal(e.values()) * v.transpose();
        assert!((rebuilt - &m).norm() < 1e-13 * m.norm());
        assert!((v.transpose() * v - DMatrix::identity(n, n)).norm() < 1e-13);
        let mut sorted: Vec<f64> = e.values().iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        let mut reference: Vec<f64> = m.clone().symmetric_eigen().eigenvalues.iter().copied().collect();
        reference.sort_by(f64::total_cmp);
        for (a, b) in sorted.iter().zip(&reference) {
            assert!((a - b).abs() < 1e-12 * m.norm());
        }
    }

    #[test]
    fn svd_square_root_of_a_psd_matrix_reproduces_it() {
        let a = DMatrix::from_fn(4, 2, |i, j| (i + 2 * j) as f64 - 1.5);
        let p = &a * a.transpose(); // rank 2
        let mut e = SymmetricEigen::new(4);
        e.decompose(&p).unwrap();
        let mut r = DMatrix::zeros(4, 4);
        e.write_svd_square_root(&mut r);
        assert!((&r * r.transpose() - &p).norm() < 1e-12 * p.norm());
    }

    #[test]
    fn a_graded_covariance_is_rebuilt_to_working_precision_entry_by_entry() {
        // P = D·C·D: a well-conditioned correlation C, scales D from 1e-5 to 1e5, as S2's
        // covariance has them (positions against forces). Every entry, the smallest ones
        // too, must come back to rounding relative to its own scale √(P_ii·P_jj).
        let n = 12;
        let c =
            DMatrix::from_fn(n, n, |i, j| if i == j { 1.0 } else { 0.3 * (((i * 7 + j * 7) % 5) as f64 - 2.0) / 4.0 });
        let d: Vec<f64> = (0..n).map(|i| 10f64.powf(-5.0 + 10.0 * i as f64 / (n - 1) as f64)).collect();
        let p = DMatrix::from_fn(n, n, |i, j| d[i] * c[(i, j)] * d[j]);
        assert!(p.clone().cholesky().is_some(), "the test matrix is positive definite");
        let mut e = SymmetricEigen::new(n);
        e.decompose(&p).unwrap();
        let mut r = DMatrix::zeros(n, n);
        e.write_svd_square_root(&mut r);
        let rebuilt = &r * r.transpose();
        for i in 0..n {
            for j in 0..n {
                let scale = (p[(i, i)] * p[(j, j)]).sqrt();
                let error = (rebuilt[(i, j)] - p[(i, j)]).abs() / scale;
                assert!(error < 1e-12, "P[{i}, {j}] = {:e} rebuilt with relative error {error:e}", p[(i, j)]);
            }
        }
        // The smallest eigenvalue to working precision: that of the inverse's largest.
        let inverse = p.clone().cholesky().unwrap().inverse();
        let largest_of_inverse = inverse.symmetric_eigen().eigenvalues.iter().copied().fold(0.0, f64::max);
        assert!((e.min_value() * largest_of_inverse - 1.0).abs() < 1e-9, "{:e}", e.min_value());
    }

    #[test]
    fn non_finite_input_is_reported() {
        let mut e = SymmetricEigen::new(2);
        let m = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, f64::NAN, 1.0]);
        assert_eq!(e.decompose(&m), Err(NotConverged));
    }
}
