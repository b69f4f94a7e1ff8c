//! The extended Kalman filter, with Jacobians by central finite differences
//! of the discrete transition and of the measurement function — the baseline
//! the papers compare their sigma-point filters against.
//!
//! ```text
//! predict:  x̂⁻ = φ(x̂),  F = ∂φ/∂x,  P⁻ = F·P·Fᵀ + Q
//! update:   ẑ = h(x̂⁻),  H = ∂h/∂x,  S = H·P⁻·Hᵀ + R,  C = P⁻·Hᵀ, then the Kalman correction
//! ```
//!
//! The difference step for state `j` is `∛ε·max(|x̂ⱼ|, σⱼ)` (σⱼ² = Pⱼⱼ), the
//! classical balance of truncation against rounding error for central differences.

use nalgebra::{DMatrix, DVector};

use crate::error::{FilterError, Stage};
use crate::filter::core::{core_accessors, ensure_finite, Core};
use crate::filter::correction::Correction;
use crate::filter::{FilterKind, Innovation, StateEstimator};
use crate::gaussian::Gaussian;
use crate::linalg::{mul_to, symmetrize, tr_mul_add};
use crate::model::Model;
use crate::noise::Noise;

/// EKF with finite-difference Jacobians.
#[derive(Debug, Clone)]
pub struct ExtendedKalman<M> {
    core: Core<M>,
    p: DMatrix<f64>,
    p_next: DMatrix<f64>,
    /// `Fᵀ` (`n × n`): column `i` holds `∂φᵢ/∂x`.
    f_t: DMatrix<f64>,
    /// `Hᵀ` on the used rows (`n × m`, first `mv` columns used).
    h_t: DMatrix<f64>,
    /// `P·Fᵀ`.
    pf_t: DMatrix<f64>,
    x_plus: DVector<f64>,
    x_minus: DVector<f64>,
    f_plus: DVector<f64>,
    f_minus: DVector<f64>,
    z_plus: DVector<f64>,
    z_minus: DVector<f64>,
    correction: Correction,
}

impl<M: Model> ExtendedKalman<M> {
    /// An EKF starting from `prior` at time 0.
    pub fn new(model: M, noise: Noise, prior: &Gaussian) -> Result<Self, FilterError> {
        let core = Core::new(model, noise, 0.0, prior)?;
        let (n, m) = (core.n(), core.m());
        Ok(Self {
            p: prior.covariance.clone(),
            p_next: DMatrix::zeros(n, n),
            f_t: DMatrix::zeros(n, n),
            h_t: DMatrix::zeros(n, m),
            pf_t: DMatrix::zeros(n, n),
            x_plus: DVector::zeros(n),
            x_minus: DVector::zeros(n),
            f_plus: DVector::zeros(n),
            f_minus: DVector::zeros(n),
            z_plus: DVector::zeros(m),
            z_minus: DVector::zeros(m),
            correction: Correction::new(n, m),
            core,
        })
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.core.model
    }

    /// The model, to change its parameters between steps.
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.core.model
    }

    /// Writes `x̂ ± h·eⱼ` into `x_plus`/`x_minus`; returns their actual distance.
    fn perturb(&mut self, j: usize) -> f64 {
        let x = &self.core.x;
        let h = f64::EPSILON.cbrt() * x[j].abs().max(self.p[(j, j)].max(0.0).sqrt()).max(f64::MIN_POSITIVE.sqrt());
        self.x_plus.copy_from(x);
        self.x_minus.copy_from(x);
        self.x_plus[j] += h;
        self.x_minus[j] -= h;
        // The step actually taken after rounding, so that linear maps are differenced exactly.
        self.x_plus[j] - self.x_minus[j]
    }
}

impl<M: Model> StateEstimator for ExtendedKalman<M> {
    core_accessors!();

    fn kind(&self) -> FilterKind {
        FilterKind::Ekf
    }

    fn predict(&mut self, u: &[f64], dt: f64) -> Result<(), FilterError> {
        self.core.begin_predict(u, dt)?;
        let n = self.core.n();
        let t = self.core.t;
        self.core.model.transition(
            t,
            dt,
            self.core.x.as_slice(),
            self.core.u.as_slice(),
            self.core.x_next.as_mut_slice(),
        );
        for j in 0..n {
            let width = self.perturb(j);
            let u = self.core.u.as_slice();
            self.core.model.transition(t, dt, self.x_plus.as_slice(), u, self.f_plus.as_mut_slice());
            self.core.model.transition(t, dt, self.x_minus.as_slice(), u, self.f_minus.as_mut_slice());
            for i in 0..n {
                self.f_t[(j, i)] = (self.f_plus[i] - self.f_minus[i]) / width;
            }
        }
        ensure_finite(self.core.x_next.as_slice(), Stage::Predict, "propagated state")?;
        ensure_finite(self.f_t.as_slice(), Stage::Predict, "Jacobian F")?;
        // P⁻ = Fᵀᵀ·(P·Fᵀ) + Q.
        mul_to(self.p.as_slice(), n, n, n, self.f_t.as_slice(), n, n, self.pf_t.as_mut_slice(), n);
        self.p_next.copy_from(self.core.noise.q());
        tr_mul_add(self.f_t.as_slice(), n, n, n, self.pf_t.as_slice(), n, n, self.p_next.as_mut_slice(), n);
        symmetrize(&mut self.p_next);
        ensure_finite(self.p_next.as_slice(), Stage::Predict, "predicted covariance P")?;
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        std::mem::swap(&mut self.p, &mut self.p_next);
        self.core.t = t + dt;
        Ok(())
    }

    fn update(&mut self, z: &[f64]) -> Result<&Innovation, FilterError> {
        let mv = self.core.begin_update(z)?;
        if mv == 0 {
            self.core.innovation.record_none();
            return Ok(&self.core.innovation);
        }
        let n = self.core.n();
        let t = self.core.t;
        self.core.model.observe(t, self.core.x.as_slice(), self.core.u.as_slice(), self.z_plus.as_mut_slice());
        for (a, &row) in self.core.innovation.rows().iter().enumerate() {
            self.correction.z_hat[a] = self.z_plus[row];
        }
        for j in 0..n {
            let width = self.perturb(j);
            let u = self.core.u.as_slice();
            self.core.model.observe(t, self.x_plus.as_slice(), u, self.z_plus.as_mut_slice());
            self.core.model.observe(t, self.x_minus.as_slice(), u, self.z_minus.as_mut_slice());
            for (a, &row) in self.core.innovation.rows().iter().enumerate() {
                self.h_t[(j, a)] = (self.z_plus[row] - self.z_minus[row]) / width;
            }
        }
        ensure_finite(&self.h_t.as_slice()[..self.h_t.nrows() * mv], Stage::Update, "Jacobian H")?;
        // C = P·Hᵀ, S = H·C + R on the used rows.
        let cr = &mut self.correction;
        mul_to(self.p.as_slice(), n, n, n, self.h_t.as_slice(), n, mv, cr.c.as_mut_slice(), n);
        cr.set_noise_part(self.core.noise.r(), self.core.innovation.rows());
        let m = cr.s.nrows();
        tr_mul_add(self.h_t.as_slice(), n, mv, n, cr.c.as_slice(), n, mv, cr.s.as_mut_slice(), m);
        cr.apply(
            &self.core.z,
            (&mut self.core.x, &mut self.core.x_next),
            (&mut self.p, &mut self.p_next),
            &mut self.core.innovation,
        )?;
        Ok(&self.core.innovation)
    }

    fn write_covariance(&self, out: &mut DMatrix<f64>) {
        out.copy_from(&self.p);
    }

    fn variance(&self, i: usize) -> f64 {
        self.p[(i, i)]
    }

    fn snapshot(&self) -> crate::filter::Snapshot {
        self.core.snapshot(FilterKind::Ekf, &self.p)
    }

    fn restore(&mut self, snapshot: &crate::filter::Snapshot) -> Result<(), FilterError> {
        let covariance = self.core.restore(FilterKind::Ekf, snapshot)?;
        self.p.copy_from_slice(covariance);
        Ok(())
    }

    fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError> {
        self.core.reset(t0, prior)?;
        self.p.copy_from(&prior.covariance);
        Ok(())
    }
}
