//! What a measurement update reports: the innovation, its covariance, the
//! normalised innovation squared (NIS) and the Gaussian log-likelihood.

use crate::math;
use nalgebra::{DMatrix, DVector};

/// Diagnostics of the last update. Rows that were missing (non-finite in `z`)
/// are NaN in the residual, the predicted measurement and the covariance.
#[derive(Debug, Clone)]
pub struct Innovation {
    rows: Vec<usize>,
    predicted: DVector<f64>,
    residual: DVector<f64>,
    covariance: DMatrix<f64>,
    nis: f64,
    log_likelihood: f64,
}

impl Innovation {
    pub(crate) fn new(m: usize) -> Self {
        Self {
            rows: Vec::with_capacity(m),
            predicted: DVector::from_element(m, f64::NAN),
            residual: DVector::from_element(m, f64::NAN),
            covariance: DMatrix::from_element(m, m, f64::NAN),
            nis: 0.0,
            log_likelihood: 0.0,
        }
    }

    /// Selects the finite rows of `z`; returns how many there are.
    pub(crate) fn select_rows(&mut self, z: &[f64]) -> usize {
        self.rows.clear();
        self.rows.extend(z.iter().enumerate().filter(|(_, v)| v.is_finite()).map(|(i, _)| i));
        self.rows.len()
    }

    /// The rows of `z` used by the last update, in order.
    pub fn rows(&self) -> &[usize] {
        &self.rows
    }

    /// How many rows of `z` the last update used.
    pub fn rows_used(&self) -> usize {
        self.rows.len()
    }

    /// The predicted measurement `ẑ`.
    pub fn predicted(&self) -> &DVector<f64> {
        &self.predicted
    }

    /// The innovation `ν = z − ẑ`.
    pub fn residual(&self) -> &DVector<f64> {
        &self.residual
    }

    /// The innovation covariance `S`.
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.covariance
    }

    /// The normalised innovation squared `νᵀ·S⁻¹·ν` (χ² with `rows_used` degrees of
    /// freedom for a consistent filter); 0 when no row was used.
    pub fn nis(&self) -> f64 {
        self.nis
    }

    /// `log N(ν; 0, S)`; 0 when no row was used.
    pub fn log_likelihood(&self) -> f64 {
        self.log_likelihood
    }

    /// Records an update from its compact (used-rows) quantities: `ẑ` and `ν`
    /// (length ≥ used rows), `S` (leading dimension `ld_s`), and the lower
    /// Cholesky factor `L` of `S` with `e = L⁻¹·ν` (leading dimension `ld_l`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record(
        &mut self,
        predicted: &[f64],
        residual: &[f64],
        s: &[f64],
        ld_s: usize,
        l: &[f64],
        ld_l: usize,
        e: &[f64],
    ) {
        let mv = self.rows.len();
        self.predicted.fill(f64::NAN);
        self.residual.fill(f64::NAN);
        self.covariance.fill(f64::NAN);
        for (a, &ra) in self.rows.iter().enumerate() {
            self.predicted[ra] = predicted[a];
            self.residual[ra] = residual[a];
            for (b, &rb) in self.rows.iter().enumerate() {
                self.covariance[(ra, rb)] = s[b * ld_s + a];
            }
        }
        self.nis = e[..mv].iter().map(|v| v * v).sum();
        let log_det: f64 = (0..mv).map(|i| 2.0 * math::ln(l[i * ld_l + i].abs())).sum();
        self.log_likelihood = -0.5 * (self.nis + log_det + mv as f64 * math::ln(2.0 * std::f64::consts::PI));
    }

    /// Records an update in which every row was missing.
    pub(crate) fn record_none(&mut self) {
        self.predicted.fill(f64::NAN);
        self.residual.fill(f64::NAN);
        self.covariance.fill(f64::NAN);
        self.nis = 0.0;
        self.log_likelihood = 0.0;
    }
}
