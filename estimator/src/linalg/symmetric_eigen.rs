//! Eigen-decomposition of a symmetric matrix by Jacobi rotations.
//!
//! For a symmetric `P` this *is* the singular value decomposition the SVD-CKF
//! asks for: `P = U·Σ·Vᵀ` with `U` the eigenvectors and `Σ = |Λ|` (a negative
//! eigenvalue moves its sign into `V`). Jacobi is chosen because, with a
//! stopping test relative to each pair's own diagonal (Demmel & Veselić, SIAM J.
//! Matrix Anal. Appl. 13(4), 1992), it is accurate to working precision on
//! small eigenvalues, which is exactly where a covariance goes wrong, and
//! because it runs in buffers allocated once.
//!
//! A positive definite `P` (every covariance a filter keeps, in practice) takes
//! the fast path of that paper: Cholesky with diagonal pivoting, `Πᵀ·P·Π = L·Lᵀ`,
//! then one-sided Jacobi rotations of the columns of `X = Π·L` until they are
//! orthogonal. `X·Xᵀ = P` throughout, so the final columns are the eigenvectors
//! scaled by `√λ`, and the rotations need not be accumulated. The accuracy is
//! that of two-sided Jacobi: for `P = D·C·D` (`D` diagonal, `C` well
//! conditioned) `L = D·L_C`, and a one-sided rotation mixes entries within a
//! row only, so each row keeps its error relative to its own scale `√P_ii`.
//! It is faster three ways (`scripts/instructions-per-step`: S2's SVD-CKF step
//! took 3.7 M instructions with two-sided Jacobi alone, 1.1 M now; the CKF's 0.52 M):
//!
//! - `XᵀX = LᵀL` is much nearer diagonal than `P`: the pivoted factor puts its
//!   weight on the diagonal (Drmač & Veselić, SIAM J. Matrix Anal. Appl. 29(4),
//!   2008). S2's covariances take 5.2 sweeps on average, the last one only to
//!   confirm; without the pivoting, 10.7.
//! - A rotation updates two contiguous columns (padded to whole chunks of
//!   lanes for the AVX2 kernels) and, by formula, two column norms, where the
//!   two-sided method updates two rows and two columns of `P` and two
//!   eigenvectors.
//! - The pairs are taken by anti-diagonals of the Gram matrix, which lets the
//!   CPU overlap their long chains of square roots and divisions (see
//!   [`SymmetricEigen::one_sided`]).
//!
//! An indefinite or singular `P` fails the Cholesky factorisation and takes
//! two-sided cyclic Jacobi on `P` itself, which is defined for every finite
//! symmetric matrix. Either path depends on `P` alone: nothing is carried
//! from one call to the next, so a filter's state is its mean and covariance.

use nalgebra::{DMatrix, DVector};

use crate::linalg::lanes::LANES;
use crate::linalg::{with_avx2, Lanes};

/// Workspace and result of a symmetric eigen-decomposition `A = V·diag(λ)·Vᵀ`.
#[derive(Debug, Clone)]
pub struct SymmetricEigen {
    /// The matrix two-sided rotations diagonalise.
    a: DMatrix<f64>,
    /// `X` of the positive definite path: `n` columns of `ld` rows, the rows
    /// past `n` zero.
    x: Vec<f64>,
    /// `n` rounded up to whole chunks of lanes.
    ld: usize,
    /// `xⱼᵀ·xⱼ` for each column of `x`.
    norms: Vec<f64>,
    /// The diagonal of the Schur complement the Cholesky factorisation has left.
    schur: Vec<f64>,
    /// The rows the Cholesky factorisation has pivoted on.
    pivoted: Vec<bool>,
    /// `−X[π(k), j]` for the columns `j < k` of `X`, as column `k` is formed;
    /// `√σⱼ·uₖⱼ` as column `k` of the symmetric square root is.
    coefficients: Vec<f64>,
    /// `√σⱼ`, the square roots of the singular values.
    root_values: Vec<f64>,
    /// `xₚᵀ·x_q` for the pairs of one anti-diagonal `p + q = d`.
    products: Vec<f64>,
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
        // Here and not in `decompose`: reading the environment allocates.
        crate::linalg::read_environment();
        let ld = n.div_ceil(LANES) * LANES;
        Self {
            a: DMatrix::zeros(n, n),
            x: vec![0.0; ld * n],
            ld,
            norms: vec![0.0; n],
            schur: vec![0.0; n],
            pivoted: vec![false; n],
            coefficients: vec![0.0; n],
            root_values: vec![0.0; n],
            products: vec![0.0; n / 2],
            vectors: DMatrix::zeros(n, n),
            values: DVector::zeros(n),
        }
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
        if (0..n).any(|j| m.view((j, j), (n - j, 1)).iter().any(|v| !v.is_finite())) {
            return Err(NotConverged);
        }
        with_avx2!(fn<>(lanes, eigen: &mut SymmetricEigen = self, m: &DMatrix<f64> = m) -> Result<(), NotConverged> {
            if eigen.pivoted_cholesky(lanes, m) {
                eigen.one_sided(lanes)
            } else {
                eigen.two_sided(m)
            }
        })
    }

    /// `Πᵀ·P·Π = L·Lᵀ` with the largest remaining diagonal entry as each pivot,
    /// written as `X = Π·L` into `x`: column `k` is formed whole, rows in `P`'s
    /// order, as `P[:, π(k)] − Σⱼ<ₖ X[π(k), j]·X[:, j]`, a combination of
    /// contiguous columns, so nothing is swapped. `false` when a pivot is not
    /// positive, i.e. `P` is not numerically positive definite.
    #[inline(always)]
    fn pivoted_cholesky<L: Lanes>(&mut self, lanes: L, m: &DMatrix<f64>) -> bool {
        let (n, ld) = (self.a.nrows(), self.ld);
        for i in 0..n {
            self.schur[i] = m[(i, i)];
        }
        self.pivoted.fill(false);
        for k in 0..n {
            let mut pivot = usize::MAX;
            for i in (0..n).filter(|&i| !self.pivoted[i]) {
                if pivot == usize::MAX || self.schur[i] > self.schur[pivot] {
                    pivot = i;
                }
            }
            let d = self.schur[pivot];
            if d.is_nan() || d <= 0.0 {
                return false;
            }
            for (j, c) in self.coefficients[..k].iter_mut().enumerate() {
                *c = -self.x[j * ld + pivot];
            }
            let (done, rest) = self.x.split_at_mut(k * ld);
            let column = &mut rest[..n];
            for (i, v) in column.iter_mut().enumerate() {
                *v = if i >= pivot { m[(i, pivot)] } else { m[(pivot, i)] };
            }
            lanes.combine(column, &self.coefficients[..k], done, ld);
            let root = d.sqrt();
            for (v, &before) in column.iter_mut().zip(&self.pivoted) {
                // Zero in exact arithmetic: `L` is triangular.
                *v = if before { 0.0 } else { *v / root };
            }
            column[pivot] = root;
            self.pivoted[pivot] = true;
            for (s, &v) in self.schur.iter_mut().zip(column.iter()) {
                *s -= v * v;
            }
        }
        true
    }

    /// One-sided cyclic Jacobi on the columns of `x` (Hestenes), then the
    /// eigenpairs `λⱼ = xⱼᵀ·xⱼ`, `vⱼ = xⱼ/√λⱼ`.
    ///
    /// The pairs go in row-cyclic order, (0, 1), (0, 2), (1, 2), (0, 3), …, taken
    /// by anti-diagonals `p + q = d`: a pair depends only on the pairs of smaller
    /// `d` that share a column with it, and the pairs of one anti-diagonal are
    /// disjoint, so this is the same sequence of rotations, bit for bit. All
    /// products of an anti-diagonal are formed first, then its rotations, so the
    /// chains of dependent operations of its pairs (product, square roots and
    /// divisions, rotation) overlap in the CPU instead of following one another:
    /// 1.5× faster than pair after pair.
    #[inline(always)]
    fn one_sided<L: Lanes>(&mut self, lanes: L) -> Result<(), NotConverged> {
        let (n, ld) = (self.a.nrows(), self.ld);
        // Below `ld·eps` the computed `xₚᵀ·x_q` (a sum of `ld` products, the padding
        // included) cannot tell the columns from orthogonal: its rounding error reaches
        // `ld·eps·‖xₚ‖·‖x_q‖`. Against `eps` alone, as the two-sided path tests (where
        // the rotated entry is set to an exact 0), the rounding a rotation leaves in
        // the product would be rotated away again and again.
        let inverse_tolerance = 1.0 / (ld as f64 * f64::EPSILON);
        for _ in 0..MAX_SWEEPS {
            // The norms are updated by formula within a sweep and summed afresh for
            // each, so that the sweep that finds nothing to rotate tests, and
            // reports, the columns' own norms.
            for (j, norm) in self.norms.iter_mut().enumerate() {
                let column = &self.x[j * ld..(j + 1) * ld];
                *norm = lanes.dot(column, column);
            }
            let mut rotated = false;
            for d in 1..(2 * n).saturating_sub(2) {
                let pairs = (d.saturating_sub(n - 1)..d.div_ceil(2)).map(|p| (p, d - p));
                for ((p, q), product) in pairs.clone().zip(&mut self.products) {
                    *product = lanes.dot(&self.x[p * ld..(p + 1) * ld], &self.x[q * ld..(q + 1) * ld]);
                }
                for ((p, q), &apq) in pairs.zip(&self.products) {
                    let (app, aqq) = (self.norms[p], self.norms[q]);
                    // The two-sided path's test on the Gram matrix `XᵀX`: |apq| against
                    // √(app·aqq), squared.
                    let scaled = apq * inverse_tolerance;
                    if apq != 0.0 && scaled * scaled > app * aqq {
                        let (c, s, t) = rotation(app, aqq, apq);
                        let [xp, xq] =
                            self.x.get_disjoint_mut([p * ld..(p + 1) * ld, q * ld..(q + 1) * ld]).expect("p < q");
                        lanes.rotate(xp, xq, c, s);
                        self.norms[p] = app - t * apq;
                        self.norms[q] = aqq + t * apq;
                        rotated = true;
                    }
                }
            }
            if !rotated {
                for j in 0..n {
                    let inverse_sigma = 1.0 / self.norms[j].sqrt();
                    self.values[j] = self.norms[j];
                    for (i, &v) in self.x[j * ld..j * ld + n].iter().enumerate() {
                        self.vectors[(i, j)] = v * inverse_sigma;
                    }
                }
                return Ok(());
            }
        }
        Err(NotConverged)
    }

    /// Two-sided cyclic Jacobi on `m` itself.
    fn two_sided(&mut self, m: &DMatrix<f64>) -> Result<(), NotConverged> {
        let n = self.a.nrows();
        for j in 0..n {
            for i in j..n {
                self.a[(i, j)] = m[(i, j)];
                self.a[(j, i)] = m[(i, j)];
            }
        }
        self.vectors.fill_with_identity();
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
        let (c, s, _) = rotation(self.a[(p, p)], self.a[(q, q)], apq);
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

    /// Writes `U·√Σ·Uᵀ` (`Σ = |λ|`, the singular values of the decomposed matrix)
    /// into `out`: for a positive semi-definite matrix, its symmetric square root,
    /// the one square root that is itself symmetric positive semi-definite.
    ///
    /// `U·√Σ` is a square root too, but not one the matrix decides: where
    /// eigenvalues are equal (a diagonal prior) any basis of their space is a `U`,
    /// and where they are nearly equal the basis swings with the last bits of the
    /// matrix; which one the Jacobi rotations reach depends on how the CPU rounds.
    /// `U·√Σ·Uᵀ` is the same for every such basis and a continuous function of the
    /// matrix, so points spread from it are the same on every CPU to rounding.
    ///
    /// Column `k` is `Σⱼ (√σⱼ·uₖⱼ)·uⱼ`, formed from its diagonal down in
    /// registers ([`Lanes::combine`], as the Cholesky factor's columns are); the
    /// upper triangle is the lower one's mirror, so the result is symmetric exactly.
    pub fn write_symmetric_square_root(&mut self, out: &mut DMatrix<f64>) {
        with_avx2!(fn<>(lanes, eigen: &mut SymmetricEigen = self, out: &mut DMatrix<f64> = out) -> () {
            eigen.symmetric_square_root(lanes, out)
        })
    }

    #[inline(always)]
    fn symmetric_square_root<L: Lanes>(&mut self, lanes: L, out: &mut DMatrix<f64>) {
        let n = self.values.len();
        debug_assert_eq!(out.shape(), (n, n));
        for (root, value) in self.root_values.iter_mut().zip(self.values.iter()) {
            *root = value.abs().sqrt();
        }
        out.fill(0.0);
        let vectors = self.vectors.as_slice();
        let root = out.as_mut_slice();
        for k in 0..n {
            for ((c, s), j) in self.coefficients.iter_mut().zip(&self.root_values).zip(0..n) {
                *c = s * vectors[j * n + k];
            }
            // Rows k.. of every eigenvector: `vectors[k..]` with leading dimension n.
            lanes.combine(&mut root[k * n + k..(k + 1) * n], &self.coefficients, &vectors[k..], n);
        }
        // On the slice, not by nalgebra's `fill_upper_triangle_with_lower_triangle`,
        // whose indexed copy costs S2's SVD-CKF step 1 % more instructions.
        for k in 0..n {
            for i in k + 1..n {
                root[i * n + k] = root[k * n + i];
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

/// The cosine `c`, sine `s` and tangent `t` of the rotation that annihilates
/// `apq` in the symmetric 2 × 2 matrix `[app apq; apq aqq]`, the smaller of the
/// two angles that do (Golub & Van Loan, alg. 8.5.1); the rotated diagonal is
/// `app − t·apq`, `aqq + t·apq`.
#[inline(always)]
fn rotation(app: f64, aqq: f64, apq: f64) -> (f64, f64, f64) {
    let tau = (aqq - app) / (2.0 * apq);
    let t = if tau >= 0.0 { 1.0 / (tau + (1.0 + tau * tau).sqrt()) } else { -1.0 / (-tau + (1.0 + tau * tau).sqrt()) };
    let c = 1.0 / (1.0 + t * t).sqrt();
    (c, t * c, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math;

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
    fn the_square_root_of_a_psd_matrix_is_symmetric_and_reproduces_it() {
        let a = DMatrix::from_fn(4, 2, |i, j| (i + 2 * j) as f64 - 1.5);
        let p = &a * a.transpose(); // rank 2
        let mut e = SymmetricEigen::new(4);
        e.decompose(&p).unwrap();
        let mut r = DMatrix::zeros(4, 4);
        e.write_symmetric_square_root(&mut r);
        assert_eq!(r, r.transpose());
        assert!((&r * &r - &p).norm() < 1e-12 * p.norm());
    }

    #[test]
    fn the_square_root_does_not_depend_on_the_basis_of_a_repeated_eigenvalue() {
        // Q·diag(4, 4, 4, 1)·Qᵀ: any basis of the first three eigenvectors is a `U`. The
        // one-sided and the two-sided rotations reach different ones, as two CPUs'
        // roundings may; the symmetric root is Q·diag(2, 2, 2, 1)·Qᵀ for both.
        let n = 4;
        let q = DMatrix::from_fn(n, n, |i, j| (((i * 5 + j * 3) % 7) as f64 - 3.0) + if i == j { 5.0 } else { 0.0 })
            .qr()
            .q();
        let lambda = DVector::from_vec(vec![4.0, 4.0, 4.0, 1.0]);
        let p = &q * DMatrix::from_diagonal(&lambda) * q.transpose();
        let p = (&p + p.transpose()) / 2.0;
        let expected = &q * DMatrix::from_diagonal(&lambda.map(f64::sqrt)) * q.transpose();
        let mut one_sided = SymmetricEigen::new(n);
        one_sided.decompose(&p).unwrap();
        let mut two_sided = SymmetricEigen::new(n);
        two_sided.two_sided(&p).unwrap();
        let overlap = (one_sided.vectors().transpose() * two_sided.vectors()).map(f64::abs);
        let off_permutation = overlap.row_iter().map(|row| 1.0 - row.max()).fold(0.0, f64::max);
        assert!(off_permutation > 1e-3, "the test needs two bases of the repeated eigenvalue's space");
        for (path, decomposition) in [("one-sided", &mut one_sided), ("two-sided", &mut two_sided)] {
            let mut r = DMatrix::zeros(n, n);
            decomposition.write_symmetric_square_root(&mut r);
            let error = (&r - &expected).norm() / expected.norm();
            assert!(error < 1e-14, "{path}: root off by {error:e}");
        }
    }

    #[test]
    fn a_graded_covariance_is_rebuilt_to_working_precision_entry_by_entry() {
        // P = D·C·D: a well-conditioned correlation C, scales D from 1e-5 to 1e5, as S2's
        // covariance has them (positions against forces). Every entry, the smallest ones
        // too, must come back to rounding relative to its own scale √(P_ii·P_jj).
        let n = 12;
        let c =
            DMatrix::from_fn(n, n, |i, j| if i == j { 1.0 } else { 0.3 * (((i * 7 + j * 7) % 5) as f64 - 2.0) / 4.0 });
        let d: Vec<f64> = (0..n).map(|i| math::powf(10.0, -5.0 + 10.0 * i as f64 / (n - 1) as f64)).collect();
        let p = DMatrix::from_fn(n, n, |i, j| d[i] * c[(i, j)] * d[j]);
        assert!(p.clone().cholesky().is_some(), "the test matrix is positive definite");
        let mut e = SymmetricEigen::new(n);
        e.decompose(&p).unwrap();
        let mut r = DMatrix::zeros(n, n);
        e.write_symmetric_square_root(&mut r);
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

    /// A positive definite `n × n` matrix with eigenvalues from 1e-2 to 1e2 and a
    /// dense eigenvector matrix.
    fn positive_definite(n: usize) -> DMatrix<f64> {
        let b =
            DMatrix::from_fn(n, n, |i, j| (((i * 7 + j * 3) % 11) as f64 - 5.0) / 3.0 + if i == j { 4.0 } else { 0.0 });
        let q = b.qr().q();
        let lambda = DMatrix::from_diagonal(&DVector::from_fn(n, |i, _| {
            math::powf(10.0, -2.0 + 4.0 * i as f64 / (n - 1) as f64)
        }));
        let p = &q * lambda * q.transpose();
        (&p + p.transpose()) / 2.0
    }

    #[test]
    fn a_positive_definite_matrix_gets_orthonormal_vectors_and_its_eigenvalues() {
        let n = 20;
        let p = positive_definite(n);
        let mut e = SymmetricEigen::new(n);
        e.decompose(&p).unwrap();
        let v = e.vectors();
        assert!((v.transpose() * v - DMatrix::identity(n, n)).norm() < 1e-13);
        let rebuilt = v * DMatrix::from_diagonal(e.values()) * v.transpose();
        assert!((rebuilt - &p).norm() < 1e-13 * p.norm());
        // Against the two-sided path on the same matrix (n = 20, not a whole number of
        // chunks of lanes), to rounding.
        let mut two_sided = SymmetricEigen::new(n);
        two_sided.two_sided(&p).unwrap();
        let sorted = |e: &SymmetricEigen| {
            let mut values: Vec<f64> = e.values().iter().copied().collect();
            values.sort_by(f64::total_cmp);
            values
        };
        for (a, b) in sorted(&e).iter().zip(&sorted(&two_sided)) {
            assert!((a - b).abs() < 1e-13 * p.norm(), "{a:e} against {b:e}");
        }
    }

    #[test]
    fn a_decomposition_depends_on_its_matrix_alone() {
        // What a filter saves is its mean and covariance: the square root of P must not
        // depend on the matrices decomposed before it.
        let n = 20;
        let (first, second) = (positive_definite(n), positive_definite(n).map(|v| 2.0 * v + 1e-3));
        let mut used = SymmetricEigen::new(n);
        used.decompose(&first).unwrap();
        used.decompose(&second).unwrap();
        let mut fresh = SymmetricEigen::new(n);
        fresh.decompose(&second).unwrap();
        assert_eq!(used.vectors(), fresh.vectors());
        assert_eq!(used.values(), fresh.values());
    }

    #[test]
    fn an_indefinite_matrix_gets_the_magnitudes_of_its_eigenvalues() {
        // diag(4, −1) turned by 30°: the SVD square root is U·diag(2, 1).
        let (c, s) = (3f64.sqrt() / 2.0, 0.5);
        let u = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]);
        let m = &u * DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, -1.0])) * u.transpose();
        let mut e = SymmetricEigen::new(2);
        e.decompose(&m).unwrap();
        assert!((e.min_value() + 1.0).abs() < 1e-14 && (e.max_abs_value() - 4.0).abs() < 1e-14);
        let mut r = DMatrix::zeros(2, 2);
        e.write_symmetric_square_root(&mut r);
        let expected = &u * DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 1.0])) * u.transpose();
        assert!((&r * r.transpose() - expected).norm() < 1e-14);
    }

    #[test]
    fn the_portable_path_agrees_with_the_avx2_path_to_rounding() {
        let n = 20;
        let p = positive_definite(n);
        let mut portable = SymmetricEigen::new(n);
        assert!(portable.pivoted_cholesky(crate::linalg::Portable, &p));
        portable.one_sided(crate::linalg::Portable).unwrap();
        let mut e = SymmetricEigen::new(n);
        e.decompose(&p).unwrap();
        let (mut r1, mut r2) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
        portable.write_symmetric_square_root(&mut r1);
        e.write_symmetric_square_root(&mut r2);
        // The same rotations in the same order: the columns agree up to rounding.
        assert!((&r1 - &r2).norm() < 1e-12 * r2.norm(), "{:e}", (&r1 - &r2).norm() / r2.norm());
    }
}
