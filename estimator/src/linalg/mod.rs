//! Dense kernels the filters need, written to work in place on buffers the
//! filter owns, so that a filter step allocates nothing.
//!
//! nalgebra's own `QR`, `SVD` and `SymmetricEigen` allocate their results on
//! every call, which rules them out inside a simulator's step; matrix products
//! and views still come from nalgebra. All matrices are column-major slices
//! with a leading dimension (`ld`), so that a top-left block of a larger
//! workspace (fewer valid measurement rows) is handled without copying.

mod cholesky;
mod dispatch;
mod lanes;
mod symmetric_eigen;
mod tria;

pub(crate) use cholesky::{
    cholesky_in_place, solve_lower, solve_lower_transposed, solve_right_lower, solve_right_lower_transposed,
};
pub(crate) use dispatch::read_environment;
pub use dispatch::{kernels_available, kernels_in_use, with_portable_kernels, Kernels, PORTABLE_VARIABLE};
#[cfg(target_arch = "x86_64")]
pub(crate) use lanes::Avx2;
pub(crate) use lanes::{with_avx2, Lanes, Portable};
pub use symmetric_eigen::SymmetricEigen;
pub(crate) use tria::Tria;

/// Dot product with four independent accumulators over exact chunks (no
/// bounds checks, and a reduction order the compiler may vectorise).
#[inline(always)]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0_f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    let mut sum = (acc[0] + acc[2]) + (acc[1] + acc[3]);
    for (x, y) in ra.iter().zip(rb) {
        sum += x * y;
    }
    sum
}

/// `Σ xᵢ` with four independent accumulators, as [`dot`]: a single running
/// sum would wait on each addition's latency.
#[inline(always)]
pub(crate) fn sum(x: &[f64]) -> f64 {
    let mut acc = [0.0_f64; 4];
    let chunks = x.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..4 {
            acc[l] += c[l];
        }
    }
    let mut total = (acc[0] + acc[2]) + (acc[1] + acc[3]);
    for v in rest {
        total += v;
    }
    total
}

/// `y += alpha * x`.
#[inline(always)]
pub(crate) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    debug_assert_eq!(x.len(), y.len());
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// `C = A·B` for column-major `A` (`rows × inner`, ld `lda`), `B` (`inner × cols`, ld `ldb`),
/// `C` (ld `ldc`). (nalgebra's `gemm` packs through `matrixmultiply`, which allocates.)
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mul_to(
    a: &[f64],
    lda: usize,
    rows: usize,
    inner: usize,
    b: &[f64],
    ldb: usize,
    cols: usize,
    c: &mut [f64],
    ldc: usize,
) {
    for j in 0..cols {
        let c_col = &mut c[j * ldc..j * ldc + rows];
        c_col.fill(0.0);
        for k in 0..inner {
            let bkj = b[j * ldb + k];
            if bkj != 0.0 {
                axpy(bkj, &a[k * lda..k * lda + rows], c_col);
            }
        }
    }
}

/// `C += Aᵀ·B` for column-major `A` (`inner × rows`, ld `lda`), `B` (`inner × cols`, ld `ldb`),
/// `C` (`rows × cols`, ld `ldc`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn tr_mul_add(
    a: &[f64],
    lda: usize,
    rows: usize,
    inner: usize,
    b: &[f64],
    ldb: usize,
    cols: usize,
    c: &mut [f64],
    ldc: usize,
) {
    for j in 0..cols {
        let b_col = &b[j * ldb..j * ldb + inner];
        for i in 0..rows {
            c[j * ldc + i] += dot(&a[i * lda..i * lda + inner], b_col);
        }
    }
}

/// `P = L·Lᵀ` for a lower-triangular `L` (`n × n`, leading dimension `ldl`),
/// written in full to `out` (leading dimension `ldo`): column j below the
/// diagonal is `Σ_{k ≤ j} L_jk·L[j.., k]`, axpys down contiguous columns, then
/// mirrored.
pub(crate) fn lower_gram(l: &[f64], ldl: usize, n: usize, out: &mut [f64], ldo: usize) {
    for j in 0..n {
        let col = &mut out[j * ldo + j..j * ldo + n];
        col.fill(0.0);
        for k in 0..=j {
            axpy(l[k * ldl + j], &l[k * ldl + j..k * ldl + n], col);
        }
    }
    for j in 0..n {
        for i in j + 1..n {
            out[i * ldo + j] = out[j * ldo + i];
        }
    }
}

/// Replaces a square matrix by its symmetric part, `(A + Aᵀ)/2`.
pub(crate) fn symmetrize(a: &mut nalgebra::DMatrix<f64>) {
    let n = a.nrows();
    for j in 0..n {
        for i in j + 1..n {
            let m = 0.5 * (a[(i, j)] + a[(j, i)]);
            a[(i, j)] = m;
            a[(j, i)] = m;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn lower_gram_is_l_times_l_transposed_on_a_leading_block() {
        // A 4 × 4 lower-triangular L in the top-left of a 6 × 6 buffer, as S_zz on the used rows.
        let full = DMatrix::from_fn(6, 6, |i, j| if j <= i { (i * 3 + j) as f64 - 4.5 } else { 0.0 });
        let l = full.view((0, 0), (4, 4)).into_owned();
        let mut out = DMatrix::from_element(6, 6, f64::NAN);
        lower_gram(full.as_slice(), 6, 4, out.as_mut_slice(), 6);
        let expected = &l * l.transpose();
        assert_eq!(out.view((0, 0), (4, 4)).into_owned(), expected);
        assert!(out.column(5).iter().all(|v| v.is_nan()), "entries outside the block are left alone");
    }
}
