//! `Tria`: the triangularisation at the heart of square-root filters.
//!
//! Given a compound matrix `A` (`n × r`, any `r`), `Tria(A)` is a lower-triangular
//! `S` with `S·Sᵀ = A·Aᵀ`. It is computed as `Rᵀ` from a Householder QR of `Aᵀ`
//! (Arasaratnam & Haykin 2009, eq. (41)); `Q` is never formed.

use super::{axpy, dot};

/// Triangularises in place.
///
/// `at` holds `Aᵀ` (`rows × cols`, column-major, leading dimension `ld`) and is
/// destroyed. The lower-triangular `cols × cols` result is written to `s`
/// (leading dimension `lds`), its strict upper triangle zeroed and its diagonal
/// made non-negative (column signs of a square root are free; fixing them makes
/// the factor unique, equal to the Cholesky factor of `A·Aᵀ` when that exists).
pub(crate) fn tria(at: &mut [f64], ld: usize, rows: usize, cols: usize, s: &mut [f64], lds: usize) {
    let steps = rows.min(cols);
    for k in 0..steps {
        let (head, tail) = at.split_at_mut((k + 1) * ld);
        let v = &mut head[k * ld + k..k * ld + rows];
        let norm2 = dot(v, v);
        let x0 = v[0];
        if norm2 == 0.0 {
            continue;
        }
        let norm = norm2.sqrt();
        let alpha = if x0 >= 0.0 { -norm } else { norm };
        // v = x − α·e₁, so vᵀv = 2‖x‖(‖x‖ + |x₀|): no cancellation.
        v[0] = x0 - alpha;
        let tau = 1.0 / (norm * (norm + x0.abs()));
        for j in k + 1..cols {
            let col = &mut tail[(j - k - 1) * ld + k..(j - k - 1) * ld + rows];
            let w = dot(v, col);
            if w != 0.0 {
                axpy(-tau * w, v, col);
            }
        }
        v[0] = alpha;
    }
    // S = Rᵀ with rows of R (columns of S) flipped to a non-negative diagonal.
    for k in 0..cols {
        let s_col = &mut s[k * lds..k * lds + cols];
        s_col[..k].fill(0.0);
        if k >= steps {
            s_col[k..].fill(0.0);
            continue;
        }
        let sign = if at[k * ld + k] < 0.0 { -1.0 } else { 1.0 };
        for (j, sv) in s_col.iter_mut().enumerate().skip(k) {
            *sv = sign * at[j * ld + k];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn compound(n: usize, r: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, r, |i, j| (((i * 13 + j * 7) % 17) as f64 - 8.0) / 3.0)
    }

    fn run(a: &DMatrix<f64>) -> DMatrix<f64> {
        let (n, r) = a.shape();
        let mut at = a.transpose();
        let mut s = DMatrix::from_element(n, n, f64::NAN);
        tria(at.as_mut_slice(), r, r, n, s.as_mut_slice(), n);
        s
    }

    #[test]
    fn square_root_reproduces_a_a_transposed_and_is_lower_with_positive_diagonal() {
        for &(n, r) in &[(1, 1), (3, 9), (6, 18), (24, 72), (5, 5)] {
            let a = compound(n, r);
            let s = run(&a);
            let aat = &a * a.transpose();
            assert!((&s * s.transpose() - &aat).norm() <= 1e-12 * aat.norm(), "n={n} r={r}");
            for j in 0..n {
                assert!(s[(j, j)] >= 0.0);
                for i in 0..j {
                    assert_eq!(s[(i, j)], 0.0);
                }
            }
        }
    }

    #[test]
    fn equals_the_cholesky_factor_when_a_a_transposed_is_positive_definite() {
        let a = compound(6, 18);
        let aat = &a * a.transpose();
        let l = aat.clone().cholesky().unwrap().l();
        assert!((run(&a) - l).norm() < 1e-11 * aat.norm());
    }

    #[test]
    fn rank_deficient_input_gives_a_valid_factor() {
        // Fewer columns than rows, and a zero column: S·Sᵀ must still equal A·Aᵀ.
        let mut a = compound(5, 3);
        a.column_mut(1).fill(0.0);
        let s = run(&a);
        let aat = &a * a.transpose();
        assert!((&s * s.transpose() - &aat).norm() <= 1e-12 * aat.norm());
    }
}
