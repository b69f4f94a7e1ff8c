//! The Kalman correction shared by the covariance-form filters (CKF, SVD-CKF,
//! UKF, EKF): given the predicted measurement `ẑ`, the innovation covariance
//! `S` and the cross-covariance `C = P_xz` on the used rows,
//!
//! ```text
//! L·Lᵀ = S,  Y = L⁻¹·Cᵀ,  e = L⁻¹·ν
//! x̂⁺ = x̂ + Yᵀ·e          (= x̂ + K·ν with K = C·S⁻¹)
//! P⁺ = P − Yᵀ·Y           (= P − K·S·Kᵀ)
//! ```
//!
//! No explicit inverse, and `NIS = ‖e‖²`, `log det S = 2·Σ log Lᵢᵢ` come free.

use nalgebra::{DMatrix, DVector};

use crate::error::{FilterError, Stage};
use crate::filter::core::ensure_finite;
use crate::filter::Innovation;
use crate::linalg::{cholesky_in_place, dot, solve_lower};

/// Buffers of one correction, sized for all `m` rows; an update with `mv < m`
/// used rows works in their top-left blocks.
#[derive(Debug, Clone)]
pub(crate) struct Correction {
    /// `ẑ` on the used rows.
    pub z_hat: DVector<f64>,
    /// `S` on the used rows (`m × m` buffer, leading dimension `m`).
    pub s: DMatrix<f64>,
    /// `C = P_xz` (`n × m` buffer, first `mv` columns used).
    pub c: DMatrix<f64>,
    l: DMatrix<f64>,
    y: DMatrix<f64>,
    nu: DVector<f64>,
    e: DVector<f64>,
}

impl Correction {
    pub fn new(n: usize, m: usize) -> Self {
        Self {
            z_hat: DVector::zeros(m),
            s: DMatrix::zeros(m, m),
            c: DMatrix::zeros(n, m),
            l: DMatrix::zeros(m, m),
            y: DMatrix::zeros(m, n),
            nu: DVector::zeros(m),
            e: DVector::zeros(m),
        }
    }

    /// Starts `S` as `R` restricted to the used `rows` (the filters then add
    /// their measurement spread to it).
    pub fn set_noise_part(&mut self, r: &DMatrix<f64>, rows: &[usize]) {
        for (b, &rb) in rows.iter().enumerate() {
            for (a, &ra) in rows.iter().enumerate() {
                self.s[(a, b)] = r[(ra, rb)];
            }
        }
    }

    /// Applies the correction to the belief `(x, p)`, computing into the
    /// spare buffers `(x_next, p_next)` and swapping them in only on success
    /// (a failed update leaves the belief as it was), and records the
    /// diagnostics. `z` is the full measurement; its used rows are
    /// `innovation.rows()`, and `z_hat`, `s`, `c` must hold their values.
    #[inline(always)]
    pub fn apply(
        &mut self,
        z: &DVector<f64>,
        (x, x_next): (&mut DVector<f64>, &mut DVector<f64>),
        (p, p_next): (&mut DMatrix<f64>, &mut DMatrix<f64>),
        innovation: &mut Innovation,
    ) -> Result<(), FilterError> {
        let m = self.s.nrows();
        let n = x.len();
        let mv = innovation.rows_used();
        ensure_finite(&self.z_hat.as_slice()[..mv], Stage::Update, "predicted measurement")?;
        ensure_finite(self.s.as_slice(), Stage::Update, "innovation covariance S")?;
        for (a, &row) in innovation.rows().iter().enumerate() {
            self.nu[a] = z[row] - self.z_hat[a];
        }
        self.l.copy_from(&self.s);
        cholesky_in_place(self.l.as_mut_slice(), m, mv).map_err(|_| FilterError::NotPositiveDefinite {
            stage: Stage::Update,
            matrix: "innovation covariance S",
        })?;
        for a in 0..mv {
            for q in 0..n {
                self.y[(a, q)] = self.c[(q, a)];
            }
            self.e[a] = self.nu[a];
        }
        // L has a positive diagonal here, so the solves cannot fail.
        solve_lower(self.l.as_slice(), m, mv, self.y.as_mut_slice(), m, n);
        solve_lower(self.l.as_slice(), m, mv, self.e.as_mut_slice(), m, 1);
        let y = self.y.as_slice();
        let e = &self.e.as_slice()[..mv];
        for q in 0..n {
            x_next[q] = x[q] + dot(&y[q * m..q * m + mv], e);
        }
        for j in 0..n {
            for i in j..n {
                let v = p[(i, j)] - dot(&y[i * m..i * m + mv], &y[j * m..j * m + mv]);
                p_next[(i, j)] = v;
                p_next[(j, i)] = v;
            }
        }
        ensure_finite(x_next.as_slice(), Stage::Update, "updated state")?;
        ensure_finite(p_next.as_slice(), Stage::Update, "updated covariance P")?;
        innovation.record(self.z_hat.as_slice(), self.nu.as_slice(), self.s.as_slice(), m, self.l.as_slice(), m, e);
        std::mem::swap(x, x_next);
        std::mem::swap(p, p_next);
        Ok(())
    }
}
