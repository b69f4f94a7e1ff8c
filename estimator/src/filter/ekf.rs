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
//! The `2n + 1` points `x̂, x̂ ± hⱼ·eⱼ` go to the model in blocks, as the
//! sigma-point filters' do.

use crate::math;
use nalgebra::{DMatrix, DVector};

use crate::error::{FilterError, Stage};
use crate::filter::core::{core_accessors, ensure_finite, steps_with_avx2, Core};
use crate::filter::correction::Correction;
use crate::filter::point_blocks::PointBlocks;
use crate::filter::{check_scale, FilterKind, StateEstimator};
use crate::gaussian::Gaussian;
use crate::linalg::{mul_to, symmetrize, tr_mul_add, Lanes};
use crate::model::{Model, BLOCK_POINTS};
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
    /// `x̂` (point 0), `x̂ + hⱼ·eⱼ` (point `1 + j`), `x̂ − hⱼ·eⱼ` (point `1 + n + j`).
    points: PointBlocks,
    /// The difference steps `hⱼ`.
    steps: DVector<f64>,
    /// The distances `(x̂ⱼ + hⱼ) − (x̂ⱼ − hⱼ)` actually taken.
    widths: DVector<f64>,
    /// `φ` at the points.
    propagated: PointBlocks,
    /// `h` at the points.
    observed: PointBlocks,
    /// For the models' point-by-point defaults on blocks (`2n + m`).
    model_scratch: Vec<f64>,
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
            points: PointBlocks::new(n, 2 * n + 1),
            steps: DVector::zeros(n),
            widths: DVector::zeros(n),
            propagated: PointBlocks::new(n, 2 * n + 1),
            observed: PointBlocks::new(m, 2 * n + 1),
            model_scratch: vec![0.0; 2 * n + m],
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

    /// Spreads `x̂` and `x̂ ± hⱼ·eⱼ` into their blocks (the padding holds `x̂`).
    #[inline(always)]
    fn spread(&mut self) {
        let n = self.core.n();
        let x = self.core.x.as_slice();
        for (j, (step, width)) in self.steps.iter_mut().zip(self.widths.iter_mut()).enumerate() {
            *step =
                math::cbrt(f64::EPSILON) * x[j].abs().max(self.p[(j, j)].max(0.0).sqrt()).max(f64::MIN_POSITIVE.sqrt());
            // The step actually taken after rounding, so that linear maps are differenced exactly.
            *width = (x[j] + *step) - (x[j] - *step);
        }
        for (b, block) in self.points.blocks_mut().enumerate() {
            for l in 0..BLOCK_POINTS {
                for (row, &xi) in block.iter_mut().zip(x) {
                    row[l] = xi;
                }
                let p = b * BLOCK_POINTS + l;
                if (1..=n).contains(&p) {
                    block[p - 1][l] = x[p - 1] + self.steps[p - 1];
                } else if (n + 1..=2 * n).contains(&p) {
                    block[p - 1 - n][l] = x[p - 1 - n] - self.steps[p - 1 - n];
                }
            }
        }
    }

    /// The time update (compiled once for the baseline CPU and once with AVX2 and FMA, see `steps_with_avx2!`).
    #[inline(always)]
    fn predict_body<L: Lanes>(&mut self, _lanes: L, u: &[f64], dt: f64) -> Result<(), FilterError> {
        self.core.begin_predict(u, dt)?;
        let n = self.core.n();
        let t = self.core.t;
        self.spread();
        let u = self.core.u.as_slice();
        for (x, y) in self.points.blocks().zip(self.propagated.blocks_mut()) {
            self.core.model.transition_block(t, dt, x, u, y, &mut self.model_scratch);
        }
        let y = &self.propagated;
        for (i, x_i) in self.core.x_next.iter_mut().enumerate() {
            *x_i = y.get(i, 0);
        }
        for j in 0..n {
            for i in 0..n {
                self.f_t[(j, i)] = (y.get(i, 1 + j) - y.get(i, 1 + n + j)) / self.widths[j];
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
        if let Some(cross) = &mut self.core.cross {
            // P·Fᵀ, the linearised Cov(x, φ(x)).
            cross.copy_from(&self.pf_t);
        }
        std::mem::swap(&mut self.core.x, &mut self.core.x_next);
        std::mem::swap(&mut self.p, &mut self.p_next);
        self.core.t = t + dt;
        Ok(())
    }

    /// The measurement update (compiled once for the baseline CPU and once with AVX2 and FMA).
    #[inline(always)]
    fn update_body<L: Lanes>(&mut self, _lanes: L, z: &[f64]) -> Result<(), FilterError> {
        let mv = self.core.begin_update(z)?;
        if mv == 0 {
            self.core.innovation.record_none();
            return Ok(());
        }
        let n = self.core.n();
        self.spread();
        let (t, u) = (self.core.t, self.core.u.as_slice());
        for (x, z) in self.points.blocks().zip(self.observed.blocks_mut()) {
            self.core.model.observe_block(t, x, u, z, &mut self.model_scratch);
        }
        let observed = &self.observed;
        for (a, &row) in self.core.innovation.rows().iter().enumerate() {
            self.correction.z_hat[a] = observed.get(row, 0);
            for j in 0..n {
                self.h_t[(j, a)] = (observed.get(row, 1 + j) - observed.get(row, 1 + n + j)) / self.widths[j];
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
        )
    }
}

impl<M: Model> StateEstimator for ExtendedKalman<M> {
    core_accessors!();

    fn kind(&self) -> FilterKind {
        FilterKind::Ekf
    }

    steps_with_avx2!(<M: Model> ExtendedKalman<M>);

    fn write_covariance(&self, out: &mut DMatrix<f64>) {
        out.copy_from(&self.p);
    }

    fn variance(&self, i: usize) -> f64 {
        self.p[(i, i)]
    }

    fn snapshot_into(&self, out: &mut crate::filter::Snapshot) {
        self.core.snapshot_into(FilterKind::Ekf, &self.p, out)
    }

    fn restore(&mut self, snapshot: &crate::filter::Snapshot) -> Result<(), FilterError> {
        let covariance = self.core.restore(FilterKind::Ekf, snapshot)?;
        self.p.copy_from_slice(covariance);
        Ok(())
    }

    fn scale_covariance(&mut self, factor: f64) -> Result<(), FilterError> {
        check_scale(factor)?;
        self.p.scale_mut(factor);
        Ok(())
    }

    fn mix_with(&mut self, other: &crate::filter::Snapshot, weight: f64) -> Result<(), FilterError> {
        self.core.mix_covariance(FilterKind::Ekf, &mut self.p, &mut self.p_next, other, weight)
    }

    fn add_process_noise(&mut self, factor: f64, states: &[bool]) -> Result<(), FilterError> {
        self.core.add_process_noise_to(&mut self.p, &mut self.p_next, factor, states)
    }

    fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError> {
        self.core.reset(t0, prior)?;
        self.p.copy_from(&prior.covariance);
        Ok(())
    }
}
