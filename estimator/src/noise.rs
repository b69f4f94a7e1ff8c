//! The noise covariances `Q` and `R` of one filter instance, validated once and
//! kept with a square root each (the square-root filter needs them every step).
//!
//! `Q` carries a scale: the filters use `D·Q₀·D` (root `D·S_Q₀`) where `Q₀` is
//! the matrix given and `D` is `√s` on the scaled states, 1 on the others.
//! An online adaptation of the process noise sets `s` every sample
//! ([`Noise::set_q_scale`]), in place and exactly (from `Q₀`, not by
//! compounding factors).

use nalgebra::{DMatrix, DVector};

use crate::error::FilterError;
use crate::linalg::{SymmetricEigen, Tria};

/// Process noise `Q` (`n × n`) and measurement noise `R` (`m × m`).
///
/// Both must be symmetric positive semi-definite; zeros are allowed (a state
/// without process noise, a "perfect" sensor), and the square-root and SVD
/// filters cope with them. Their square roots are lower triangular, `Tria(U·√Λ)`
/// from an eigen-decomposition, so singular matrices have one too (a Cholesky
/// factorisation would fail on them).
#[derive(Debug, Clone)]
pub struct Noise {
    /// `D·Q₀·D`.
    q: DMatrix<f64>,
    r: DMatrix<f64>,
    /// `D·S_Q₀`.
    q_sqrt: DMatrix<f64>,
    /// `Q₀` and `S_Q₀`, as given.
    q_given: DMatrix<f64>,
    q_sqrt_given: DMatrix<f64>,
    /// `s`.
    q_scale: f64,
    /// The states `D` scales.
    q_scaled: Vec<bool>,
    r_sqrt: DMatrix<f64>,
    /// `S_Rᵀ`: its columns are the rows of `S_R`, which the SRCKF copies into
    /// its compounds every step, one per used measurement row.
    r_sqrt_t: DMatrix<f64>,
}

impl Noise {
    /// Full `Q` and `R`. Fails on a matrix that is not square, not finite, not
    /// symmetric (relative 1e-12) or has an eigenvalue below `−1e-12·‖·‖`.
    pub fn new(q: DMatrix<f64>, r: DMatrix<f64>) -> Result<Self, FilterError> {
        let q_sqrt = lower_square_root("process noise Q", &q)?;
        let r_sqrt = lower_square_root("measurement noise R", &r)?;
        let r_sqrt_t = r_sqrt.transpose();
        let (q_given, q_sqrt_given) = (q.clone(), q_sqrt.clone());
        let q_scaled = vec![true; q.nrows()];
        Ok(Self { q, r, q_sqrt, q_given, q_sqrt_given, q_scale: 1.0, q_scaled, r_sqrt, r_sqrt_t })
    }

    /// Diagonal `Q` and `R` from their diagonals (variances).
    pub fn diagonal(q: &[f64], r: &[f64]) -> Result<Self, FilterError> {
        Self::new(
            DMatrix::from_diagonal(&DVector::from_column_slice(q)),
            DMatrix::from_diagonal(&DVector::from_column_slice(r)),
        )
    }

    /// `Q`: the matrix given, with [`Noise::q_scale`] on the scaled states.
    pub fn q(&self) -> &DMatrix<f64> {
        &self.q
    }

    /// The scale on the `Q` given (1 unless set).
    pub fn q_scale(&self) -> f64 {
        self.q_scale
    }

    /// Puts the scale `scale` on the process noise of the states `states`
    /// selects (`states[i]`; all when empty) and of the states whose noise
    /// `Q₀` couples to theirs, in place (no allocation): `Q = D·Q₀·D`,
    /// `D = √scale` on those states and 1 elsewhere, so `Q` stays positive
    /// semi-definite and its root `D·S_Q₀` lower triangular. The coupled states
    /// belong with them: a load's rate, driven by the same white noise as the
    /// load, takes the load's scale. Fails, changing nothing, unless `scale` is
    /// finite and positive and `states` is empty or one flag per state.
    pub fn set_q_scale(&mut self, scale: f64, states: &[bool]) -> Result<(), FilterError> {
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(FilterError::InvalidSetting(format!(
                "a process-noise scale must be finite and > 0, got {scale}"
            )));
        }
        let n = self.q_given.nrows();
        if !states.is_empty() {
            crate::error::check_len("process-noise scaled states", n, states.len())?;
        }
        let given = &self.q_given;
        let scaled = |i: usize| states.is_empty() || states[i] || (0..n).any(|j| states[j] && given[(i, j)] != 0.0);
        let unchanged = scale == self.q_scale && (0..n).all(|i| scaled(i) == self.q_scaled[i]);
        if unchanged {
            return Ok(());
        }
        for i in 0..n {
            self.q_scaled[i] = scaled(i);
        }
        let root = scale.sqrt();
        let d = |i: usize| if self.q_scaled[i] { root } else { 1.0 };
        for j in 0..n {
            for i in 0..n {
                self.q[(i, j)] = d(i) * self.q_given[(i, j)] * d(j);
                self.q_sqrt[(i, j)] = d(i) * self.q_sqrt_given[(i, j)];
            }
        }
        self.q_scale = scale;
        Ok(())
    }

    /// `R`.
    pub fn r(&self) -> &DMatrix<f64> {
        &self.r
    }

    /// The lower-triangular square root `S_Q` with `S_Q·S_Qᵀ = Q` (the SRCKF's
    /// predict exploits the triangle).
    pub fn q_sqrt(&self) -> &DMatrix<f64> {
        &self.q_sqrt
    }

    /// The lower-triangular square root `S_R` with `S_R·S_Rᵀ = R`.
    pub fn r_sqrt(&self) -> &DMatrix<f64> {
        &self.r_sqrt
    }

    /// `S_Rᵀ`: column `i` is row `i` of `S_R`.
    pub(crate) fn r_sqrt_transposed(&self) -> &DMatrix<f64> {
        &self.r_sqrt_t
    }

    /// Replaces the variances of a diagonal `R` in place (no allocation: an
    /// adaptive estimate of the sensor noise sets them every sample). Fails,
    /// changing nothing, if `R` has off-diagonal entries or a variance is
    /// negative or not finite.
    pub fn set_r_diagonal(&mut self, variances: &[f64]) -> Result<(), FilterError> {
        crate::error::check_len("measurement variances", self.r.nrows(), variances.len())?;
        let m = self.r.nrows();
        if (0..m).any(|i| (0..m).any(|j| i != j && self.r[(i, j)] != 0.0)) {
            return Err(FilterError::InvalidSetting("only a diagonal R can take new variances in place".into()));
        }
        if let Some(v) = variances.iter().find(|v| !(**v >= 0.0 && v.is_finite())) {
            return Err(FilterError::InvalidSetting(format!("a measurement variance must be finite and ≥ 0, got {v}")));
        }
        for (i, &v) in variances.iter().enumerate() {
            self.r[(i, i)] = v;
            self.r_sqrt[(i, i)] = v.sqrt();
            self.r_sqrt_t[(i, i)] = v.sqrt();
        }
        Ok(())
    }

    /// The state dimension `Q` is for.
    pub fn state_dim(&self) -> usize {
        self.q.nrows()
    }

    /// The measurement dimension `R` is for.
    pub fn measurement_dim(&self) -> usize {
        self.r.nrows()
    }
}

/// Validates a covariance-like matrix and returns a square root of it.
pub(crate) fn psd_square_root(name: &str, m: &DMatrix<f64>) -> Result<DMatrix<f64>, FilterError> {
    check_symmetric(name, m)?;
    let n = m.nrows();
    let mut eigen = SymmetricEigen::new(n);
    eigen
        .decompose(m)
        .map_err(|_| FilterError::InvalidSetting(format!("{name}: eigen-decomposition did not converge")))?;
    let scale = eigen.max_abs_value();
    if eigen.min_value() < -1e-12 * scale {
        return Err(FilterError::InvalidSetting(format!(
            "{name} must be positive semi-definite; its smallest eigenvalue is {:e}",
            eigen.min_value()
        )));
    }
    let mut root = DMatrix::zeros(n, n);
    eigen.write_symmetric_square_root(&mut root);
    Ok(root)
}

/// A lower-triangular square root of a PSD matrix, with a non-negative diagonal.
pub(crate) fn lower_square_root(name: &str, m: &DMatrix<f64>) -> Result<DMatrix<f64>, FilterError> {
    let root = psd_square_root(name, m)?;
    let n = root.nrows();
    // Tria(root): the compound is `root` itself, its transpose filled row by row.
    let mut tria = Tria::dense(n, n);
    for j in 0..n {
        for (k, v) in tria.column_mut(j).iter_mut().enumerate() {
            *v = root[(j, k)];
        }
    }
    let mut lower = DMatrix::zeros(n, n);
    tria.factor(n, lower.as_mut_slice(), n);
    Ok(lower)
}

/// Square, finite, symmetric to a relative 1e-12.
pub(crate) fn check_symmetric(name: &str, m: &DMatrix<f64>) -> Result<(), FilterError> {
    if !m.is_square() {
        return Err(FilterError::InvalidSetting(format!("{name} must be square, got {}×{}", m.nrows(), m.ncols())));
    }
    if let Some(v) = m.iter().find(|v| !v.is_finite()) {
        return Err(FilterError::InvalidSetting(format!("{name} has a non-finite entry ({v})")));
    }
    let scale = m.amax();
    for j in 0..m.ncols() {
        for i in j + 1..m.nrows() {
            if (m[(i, j)] - m[(j, i)]).abs() > 1e-12 * scale {
                return Err(FilterError::InvalidSetting(format!("{name} is not symmetric at ({i}, {j})")));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagonal_noise_has_the_elementwise_square_root() {
        let noise = Noise::diagonal(&[4.0, 0.0, 9.0], &[0.25]).unwrap();
        assert_eq!(noise.q_sqrt().diagonal().as_slice(), &[2.0, 0.0, 3.0]);
        assert_eq!(noise.r_sqrt()[(0, 0)], 0.5);
    }

    #[test]
    fn square_roots_are_lower_triangular_even_for_a_full_singular_matrix() {
        // Q = v·vᵀ with v = (1, 2, 3): rank one, full.
        let v = nalgebra::DVector::from_column_slice(&[1.0, 2.0, 3.0]);
        let q = &v * v.transpose();
        let noise = Noise::new(q.clone(), DMatrix::identity(2, 2)).unwrap();
        let s = noise.q_sqrt();
        assert!((s * s.transpose() - &q).norm() < 1e-12 * q.norm());
        for j in 0..3 {
            for i in 0..j {
                assert_eq!(s[(i, j)], 0.0);
            }
        }
    }

    #[test]
    fn rejects_negative_asymmetric_and_non_finite_matrices_with_a_reason() {
        let err = Noise::diagonal(&[1.0, -1.0], &[1.0]).unwrap_err();
        assert!(err.to_string().contains("process noise Q must be positive semi-definite"), "{err}");
        let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
        let err = Noise::new(asym, DMatrix::identity(1, 1)).unwrap_err();
        assert!(err.to_string().contains("not symmetric"), "{err}");
        let err = Noise::diagonal(&[1.0], &[f64::NAN]).unwrap_err();
        assert!(err.to_string().contains("measurement noise R has a non-finite entry"), "{err}");
    }
}
