//! Cholesky factorisation `A = L·Lᵀ` and the two triangular solves that use it.

use super::axpy;
use super::lanes::Lanes;

/// Overwrites the lower triangle of the `n×n` matrix in `a` (leading dimension
/// `ld`) by its Cholesky factor `L` and zeroes the strict upper triangle.
///
/// Returns the index of the first pivot that is not positive (or not finite)
/// when `A` is not numerically positive definite; `a` is then garbage.
#[inline(always)]
pub(crate) fn cholesky_in_place(a: &mut [f64], ld: usize, n: usize) -> Result<(), usize> {
    // Right-looking, column oriented: every inner loop runs down a contiguous column.
    for j in 0..n {
        let d = a[j * ld + j];
        if !(d > 0.0 && d.is_finite()) {
            return Err(j);
        }
        let d = d.sqrt();
        let (head, tail) = a.split_at_mut((j + 1) * ld);
        let col_j = &mut head[j * ld..j * ld + n];
        col_j[j] = d;
        let inv = 1.0 / d;
        for v in &mut col_j[j + 1..n] {
            *v *= inv;
        }
        for k in j + 1..n {
            let col_k = &mut tail[(k - j - 1) * ld..(k - j - 1) * ld + n];
            let l_kj = col_j[k];
            if l_kj != 0.0 {
                axpy(-l_kj, &col_j[k..n], &mut col_k[k..n]);
            }
        }
    }
    for j in 1..n {
        a[j * ld..j * ld + j].fill(0.0);
    }
    Ok(())
}

/// Solves `L·X = B` in place for a lower-triangular `L` (`n×n`, leading
/// dimension `ldl`) and `n_rhs` right-hand sides stored as the columns of `b`
/// (leading dimension `ldb`). Returns `false` on a zero diagonal.
#[inline(always)]
pub(crate) fn solve_lower(l: &[f64], ldl: usize, n: usize, b: &mut [f64], ldb: usize, n_rhs: usize) -> bool {
    for r in 0..n_rhs {
        let x = &mut b[r * ldb..r * ldb + n];
        for j in 0..n {
            let d = l[j * ldl + j];
            if d == 0.0 {
                return false;
            }
            x[j] /= d;
            let xj = x[j];
            if xj != 0.0 {
                axpy(-xj, &l[j * ldl + j + 1..j * ldl + n], &mut x[j + 1..n]);
            }
        }
    }
    true
}

/// Solves `Lᵀ·x = b` in place for a lower-triangular `L` (`n×n`, leading
/// dimension `ldl`) and one right-hand side: with [`solve_lower`], `A⁻¹·b`
/// for `A = L·Lᵀ`.
pub(crate) fn solve_lower_transposed(l: &[f64], ldl: usize, n: usize, b: &mut [f64]) {
    for j in (0..n).rev() {
        let mut v = b[j];
        for i in j + 1..n {
            v -= l[j * ldl + i] * b[i];
        }
        b[j] = v / l[j * ldl + j];
    }
}

/// Solves `X·Lᵀ = B` in place for a lower-triangular `L` (`n×n`, leading
/// dimension `ldl`) and `B` of `rows × n` (leading dimension `ldb ≥ rows`),
/// column by column, each a linear combination of the columns before it
/// ([`Lanes::combine`]); `scratch` takes `n` coefficients. Returns `false` on
/// a zero diagonal.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn solve_right_lower_transposed<L: Lanes>(
    lanes: L,
    l: &[f64],
    ldl: usize,
    n: usize,
    b: &mut [f64],
    ldb: usize,
    rows: usize,
    scratch: &mut [f64],
) -> bool {
    // Column a of X·Lᵀ is Σ_{c ≤ a} L[a, c]·X[:, c]: forward over the columns.
    for a in 0..n {
        let d = l[a * ldl + a];
        if d == 0.0 {
            return false;
        }
        let (done, rest) = b.split_at_mut(a * ldb);
        let x_a = &mut rest[..rows];
        let c = &mut scratch[..a];
        for (k, c) in c.iter_mut().enumerate() {
            *c = -l[k * ldl + a];
        }
        substitute(lanes, x_a, c, done, ldb, d);
    }
    true
}

/// Solves `X·L = B` in place (see [`solve_right_lower_transposed`] for the layout).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn solve_right_lower<L: Lanes>(
    lanes: L,
    l: &[f64],
    ldl: usize,
    n: usize,
    b: &mut [f64],
    ldb: usize,
    rows: usize,
    scratch: &mut [f64],
) -> bool {
    // Column a of X·L is Σ_{c ≥ a} L[c, a]·X[:, c]: backward over the columns.
    for a in (0..n).rev() {
        let d = l[a * ldl + a];
        if d == 0.0 {
            return false;
        }
        let (head, later) = b.split_at_mut((a + 1) * ldb);
        let x_a = &mut head[a * ldb..a * ldb + rows];
        let c = &mut scratch[..n - a - 1];
        for (c, &l_ca) in c.iter_mut().zip(&l[a * ldl + a + 1..a * ldl + n]) {
            *c = -l_ca;
        }
        substitute(lanes, x_a, c, later, ldb, d);
    }
    true
}

/// One column of a right triangular solve: `x = (x + Σₜ c[t]·column t)/d`,
/// with `c` the negated entries of `L` that couple `x` to the solved columns.
#[inline(always)]
fn substitute<L: Lanes>(lanes: L, x: &mut [f64], c: &[f64], columns: &[f64], ld: usize, d: f64) {
    lanes.combine(x, c, columns, ld);
    for v in x.iter_mut() {
        *v /= d;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::Portable;
    use nalgebra::DMatrix;

    fn spd(n: usize) -> DMatrix<f64> {
        let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i == j { 3.0 } else { 0.0 });
        &a * a.transpose() + DMatrix::identity(n, n)
    }

    #[test]
    fn factor_reconstructs_the_matrix_and_matches_nalgebra() {
        let a = spd(7);
        let mut l = a.clone();
        cholesky_in_place(l.as_mut_slice(), 7, 7).unwrap();
        assert!((&l * l.transpose() - &a).norm() < 1e-12 * a.norm());
        let reference = a.clone().cholesky().unwrap().l();
        assert!((&l - reference).norm() < 1e-12 * a.norm());
    }

    #[test]
    fn indefinite_matrix_names_its_pivot() {
        let mut a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert_eq!(cholesky_in_place(a.as_mut_slice(), 2, 2), Err(1));
        let mut nan = DMatrix::from_element(1, 1, f64::NAN);
        assert_eq!(cholesky_in_place(nan.as_mut_slice(), 1, 1), Err(0));
    }

    #[test]
    fn solve_inverts_the_factor() {
        let a = spd(5);
        let mut l = a.clone();
        cholesky_in_place(l.as_mut_slice(), 5, 5).unwrap();
        let b = DMatrix::from_fn(5, 3, |i, j| (i as f64) - 2.0 * j as f64);
        let mut x = b.clone();
        assert!(solve_lower(l.as_slice(), 5, 5, x.as_mut_slice(), 5, 3));
        assert!((&l * &x - &b).norm() < 1e-10 * b.norm());
    }

    #[test]
    fn right_solves_give_b_times_the_inverse() {
        // X·Lᵀ = B, then X·L = that: X = B·(L·Lᵀ)⁻¹ = B·A⁻¹, on a top-left block of a larger L.
        let a = spd(6);
        let mut l = a.clone();
        cholesky_in_place(l.as_mut_slice(), 6, 6).unwrap();
        let b = DMatrix::from_fn(9, 4, |i, j| (i as f64) * 0.5 - j as f64);
        let mut x = b.clone();
        let scratch = &mut [0.0; 6];
        assert!(solve_right_lower_transposed(Portable, l.as_slice(), 6, 4, x.as_mut_slice(), 9, 9, scratch));
        assert!(solve_right_lower(Portable, l.as_slice(), 6, 4, x.as_mut_slice(), 9, 9, scratch));
        let a4 = a.view((0, 0), (4, 4)).into_owned();
        assert!((&x * &a4 - &b).norm() < 1e-10 * b.norm());
        let mut singular = DMatrix::<f64>::zeros(2, 2);
        singular[(1, 1)] = 1.0;
        assert!(!solve_right_lower_transposed(Portable, singular.as_slice(), 2, 2, x.as_mut_slice(), 9, 9, scratch));
        assert!(!solve_right_lower(Portable, singular.as_slice(), 2, 2, x.as_mut_slice(), 9, 9, scratch));
    }
}
