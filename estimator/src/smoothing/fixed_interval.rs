//! Fixed-interval smoothing: the Rauch–Tung–Striebel backward pass `[Rauch1965]` in its
//! sigma-point form (the cubature Kalman smoother `[Arasaratnam2011]`, the unscented RTS
//! smoother `[Sarkka2008]`), which needs of each step only the filtered Gaussian at `t_k`,
//! the predicted one at `t_{k+1}` as the filter had it before its update there, and the
//! cross-covariance `C = Cov(x_k, x_{k+1} | z_1…z_k)`.
//!
//! [`cross_covariance`] gives `C` for any [`Process`] from the filtered Gaussian by the
//! filter's own point rule: the points of `N(m_k, P_k)` through one transition, as the
//! filter's prediction moved them; [`linearised_cross_covariance`] gives the EKF's, `P·Fᵀ`
//! with `F` the transition's Jacobian by the EKF's central differences. The predicted
//! Gaussian is taken as the filter had it, after whatever the supervisor did to it (a
//! jump's inflated covariance then loosens the link across the jump, as it should); a row
//! the gate rejected is in no filtered Gaussian, so it stays out of the smoothed one.
//!
//! Backward: `G = C·P⁻⁻¹`, `m_s = m + G·(m_s' − m⁻)`, `P_s = P + G·(P_s' − P⁻)·Gᵀ`, from the
//! last filtered Gaussian (which is its own smoothed one) to the first.
//!
//! The square-root form, for the SRCKF ([`smooth_square_root`], the square-root cubature
//! smoother of `[Arasaratnam2011]`), never forms a covariance: with `X` and `Y` the
//! weighted, centred points before and after the transition (`P = X·Xᵀ`, `C = X·Yᵀ`,
//! `P⁻ = Y·Yᵀ + S_Q·S_Qᵀ`), `G` comes from two triangular solves with `S⁻` and the
//! smoothed root is `Tria([X − G·Y, G·S_Q, G·S_s'])`, whose product is `P_s` above.

use crate::math;
use nalgebra::{DMatrix, DVector};

use crate::error::FilterError;
use crate::gaussian::Gaussian;
use crate::model::Process;
use crate::points::SigmaPoints;

/// What the backward pass needs of one filter step from `t_k` to `t_{k+1}`.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothingStep {
    /// The filtered Gaussian at `t_k`.
    pub filtered: Gaussian,
    /// The predicted Gaussian at `t_{k+1}`, before the update there.
    pub predicted: Gaussian,
    /// `Cov(x_k, x_{k+1})` given the measurements up to `t_k`.
    pub cross: DMatrix<f64>,
}

/// The cross-covariance `Cov(x_k, x_{k+1})` of `filtered` and its prediction over `dt`
/// with the inputs `u`, by the point rule `points`: `Σ wᵢ (Xᵢ − m)(φ(Xᵢ) − m⁻)ᵀ`, the
/// points `Xᵢ = m ± c·A·eⱼ` (and the centre) with `A` the Cholesky factor of `P`. The
/// process noise, independent of `x_k`, adds nothing.
pub fn cross_covariance(
    process: &mut impl Process,
    points: &SigmaPoints,
    filtered: &Gaussian,
    t: f64,
    dt: f64,
    u: &[f64],
) -> Result<DMatrix<f64>, FilterError> {
    let n = filtered.mean.len();
    if points.state_dim() != n || process.state_dim() != n {
        return Err(FilterError::InvalidSetting(format!(
            "a smoothing step of {n} states with a point rule for {} and a process of {}",
            points.state_dim(),
            process.state_dim()
        )));
    }
    let root = filtered
        .covariance
        .clone()
        .cholesky()
        .ok_or_else(|| FilterError::InvalidSetting("a filtered covariance that is not positive definite".into()))?
        .l();
    let (offsets, deviations) = deviations(process, points, &filtered.mean, &root, t, dt, u);
    let weights = DVector::from_iterator(points.len(), (0..points.len()).map(|i| points.covariance_weight(i)));
    Ok(offsets * DMatrix::from_diagonal(&weights) * deviations.transpose())
}

/// The points of the rule `points` about `mean` with the root `root` (`m ± c·S·eⱼ`, then
/// the centre), as offsets from the mean (`n × points`), and their images after one
/// transition as deviations from the images' weighted mean.
fn deviations(
    process: &mut impl Process,
    points: &SigmaPoints,
    mean: &DVector<f64>,
    root: &DMatrix<f64>,
    t: f64,
    dt: f64,
    u: &[f64],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, count, c) = (mean.len(), points.len(), points.spread());
    let mut offsets = DMatrix::zeros(n, count);
    for j in 0..n {
        offsets.set_column(j, &(root.column(j) * c));
        offsets.set_column(n + j, &(-root.column(j) * c));
    }
    let mut images = DMatrix::zeros(n, count);
    let mut next = vec![0.0; n];
    for i in 0..count {
        let x = mean + offsets.column(i);
        process.transition(t, dt, x.as_slice(), u, &mut next);
        images.set_column(i, &DVector::from_column_slice(&next));
    }
    let image_mean = (0..count).fold(DVector::zeros(n), |m, i| m + images.column(i) * points.mean_weight(i));
    for i in 0..count {
        let centred = images.column(i) - &image_mean;
        images.set_column(i, &centred);
    }
    (offsets, images)
}

/// The EKF's cross-covariance `P·Fᵀ`, `F = ∂φ/∂x` at the filtered mean by central
/// differences of step `∛ε·max(|mⱼ|, σⱼ)`, the EKF's own (`filter/ekf.rs`).
pub fn linearised_cross_covariance(
    process: &mut impl Process,
    filtered: &Gaussian,
    t: f64,
    dt: f64,
    u: &[f64],
) -> Result<DMatrix<f64>, FilterError> {
    let n = filtered.mean.len();
    if process.state_dim() != n {
        return Err(FilterError::InvalidSetting(format!(
            "a smoothing step of {n} states with a process of {}",
            process.state_dim()
        )));
    }
    let mut jacobian = DMatrix::zeros(n, n);
    let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..n {
        let m = filtered.mean[j];
        let step = math::cbrt(f64::EPSILON)
            * m.abs().max(filtered.covariance[(j, j)].max(0.0).sqrt()).max(f64::MIN_POSITIVE.sqrt());
        let mut x = filtered.mean.clone();
        x[j] = m + step;
        process.transition(t, dt, x.as_slice(), u, &mut plus);
        x[j] = m - step;
        process.transition(t, dt, x.as_slice(), u, &mut minus);
        // The step actually taken after rounding, so that linear maps are differenced exactly.
        let width = (m + step) - (m - step);
        for i in 0..n {
            jacobian[(i, j)] = (plus[i] - minus[i]) / width;
        }
    }
    Ok(&filtered.covariance * jacobian.transpose())
}

/// The smoothed Gaussians at `t_0 … t_N` from the `N` steps of a filter run and the
/// filtered Gaussian at `t_N`. Fails if a step's dimensions disagree or a predicted
/// covariance is singular.
pub fn smooth(steps: &[SmoothingStep], last: &Gaussian) -> Result<Vec<Gaussian>, FilterError> {
    let n = last.mean.len();
    let mut smoothed = vec![last.clone(); steps.len() + 1];
    for (k, step) in steps.iter().enumerate().rev() {
        let dims = [step.filtered.mean.len(), step.predicted.mean.len(), step.cross.nrows(), step.cross.ncols()];
        if dims.iter().any(|&d| d != n) {
            return Err(FilterError::InvalidSetting(format!("smoothing step {k} has dimensions {dims:?}, not {n}")));
        }
        // G = C·P⁻⁻¹, from P⁻·Gᵀ = Cᵀ (P⁻ symmetric).
        let gain_transposed = step
            .predicted
            .covariance
            .clone()
            .cholesky()
            .ok_or_else(|| FilterError::InvalidSetting(format!("the predicted covariance of step {k} is singular")))?
            .solve(&step.cross.transpose());
        let gain = gain_transposed.transpose();
        let after = &smoothed[k + 1];
        let mean = &step.filtered.mean + &gain * (&after.mean - &step.predicted.mean);
        let mut covariance =
            &step.filtered.covariance + &gain * (&after.covariance - &step.predicted.covariance) * &gain_transposed;
        // Symmetric to rounding.
        covariance = (&covariance + covariance.transpose()) * 0.5;
        smoothed[k] = Gaussian { mean, covariance };
    }
    Ok(smoothed)
}

/// What a supervised run's fixed-interval smoothing needs, gathered step by step from
/// [`SupervisedFilter::run`](crate::SupervisedFilter::run)'s observer (the loop must keep
/// its transitions, [`SupervisedFilter::keep_transitions`](crate::SupervisedFilter::keep_transitions)):
/// each sample's filtered Gaussian and the transition to it. Holds about `3·n²` numbers per
/// sample.
#[derive(Debug, Clone, Default)]
pub struct RunRecorder {
    steps: Vec<SmoothingStep>,
    last: Option<Gaussian>,
}

impl RunRecorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes a sample's step: the transition to it (from the belief of the sample before)
    /// and its filtered belief. Fails if a sample after the first has no transition.
    pub fn observe(&mut self, step: &crate::supervised::Step<'_>) -> Result<(), FilterError> {
        self.push(step.filter, step.transition)
    }

    /// [`RunRecorder::observe`] for a driver that steps the loop itself: the filtered
    /// belief of a sample and the transition to it (`None` for the first).
    pub fn push(
        &mut self,
        filter: &dyn crate::filter::StateEstimator,
        transition: Option<&crate::smoothing::fixed_lag::Transition>,
    ) -> Result<(), FilterError> {
        let filtered = Gaussian { mean: filter.mean().clone(), covariance: filter.covariance() };
        if let Some(before) = self.last.take() {
            let transition = transition.ok_or_else(|| {
                FilterError::InvalidSetting("a smoothed run must keep its transitions (keep_transitions)".into())
            })?;
            self.steps.push(SmoothingStep {
                filtered: before,
                predicted: transition.predicted.clone(),
                cross: transition.cross.clone(),
            });
        }
        self.last = Some(filtered);
        Ok(())
    }

    /// The smoothed Gaussians of every sample observed, in order ([`smooth`]).
    pub fn smooth(&self) -> Result<Vec<Gaussian>, FilterError> {
        let last = self.last.as_ref().ok_or_else(|| FilterError::InvalidSetting("no sample to smooth".into()))?;
        smooth(&self.steps, last)
    }
}

/// What the square-root backward pass needs of one filter step from `t_k` to `t_{k+1}`:
/// roots (any square roots, `P = S·Sᵀ`), never covariances.
#[derive(Debug, Clone, PartialEq)]
pub struct SquareRootStep {
    /// The filtered mean at `t_k`.
    pub filtered_mean: DVector<f64>,
    /// A root of the filtered covariance, the filter's own (its points are taken from it).
    pub filtered_root: DMatrix<f64>,
    /// The predicted mean at `t_{k+1}`, before the update there.
    pub predicted_mean: DVector<f64>,
    /// A lower-triangular root of the predicted covariance.
    pub predicted_root: DMatrix<f64>,
    /// A root of what the predicted covariance holds beyond the points' spread: the
    /// step's process noise as the filter had it (its adapted scale included).
    pub process_noise_root: DMatrix<f64>,
    /// The step's start `t_k` (s).
    pub t: f64,
    /// The step's length (s).
    pub dt: f64,
    /// The inputs held over it.
    pub u: Vec<f64>,
}

/// A Gaussian by its mean and a root of its covariance, `P = S·Sᵀ`.
#[derive(Debug, Clone, PartialEq)]
pub struct RootGaussian {
    /// The mean.
    pub mean: DVector<f64>,
    /// A root of the covariance.
    pub root: DMatrix<f64>,
}

/// `Tria(A)`: a lower-triangular `n × n` root of `A·Aᵀ`, from the QR factors of `Aᵀ`.
fn tria(a: DMatrix<f64>) -> DMatrix<f64> {
    let n = a.nrows();
    let r = a.transpose().qr().r();
    let mut root = DMatrix::zeros(n, n);
    let rows = r.nrows().min(n);
    root.view_mut((0, 0), (n, rows)).copy_from(&r.rows(0, rows).transpose());
    root
}

/// The square-root smoothed means and lower-triangular roots at `t_0 … t_N` from the `N`
/// steps of a filter run with the point rule `points` and its filtered mean and root at
/// `t_N`. Fails if dimensions disagree or a predicted root is singular.
pub fn smooth_square_root(
    process: &mut impl Process,
    points: &SigmaPoints,
    steps: &[SquareRootStep],
    last: &RootGaussian,
) -> Result<Vec<RootGaussian>, FilterError> {
    let n = last.mean.len();
    if points.state_dim() != n || process.state_dim() != n || points.center().is_some_and(|c| c.covariance < 0.0) {
        return Err(FilterError::InvalidSetting(format!(
            "a square-root smoother of {n} states needs a process of as many and points of non-negative weights"
        )));
    }
    let mut smoothed = vec![last.clone(); steps.len() + 1];
    for (k, step) in steps.iter().enumerate().rev() {
        let square = |m: &DMatrix<f64>| m.nrows() == n && m.ncols() == n;
        let fits = step.filtered_mean.len() == n
            && step.predicted_mean.len() == n
            && square(&step.filtered_root)
            && square(&step.predicted_root)
            && step.process_noise_root.nrows() == n;
        if !fits {
            return Err(FilterError::InvalidSetting(format!("square-root smoothing step {k} is not of {n} states")));
        }
        // The points, weighted and centred, before (X) and after (Y) the transition.
        let (mut before, mut after) =
            deviations(process, points, &step.filtered_mean, &step.filtered_root, step.t, step.dt, &step.u);
        for i in 0..points.len() {
            let weight = points.covariance_weight(i).sqrt();
            before.column_mut(i).scale_mut(weight);
            after.column_mut(i).scale_mut(weight);
        }
        // G from S⁻·S⁻ᵀ·Gᵀ = Cᵀ = Y·Xᵀ: two triangular solves.
        let cross_transposed = &after * before.transpose();
        let singular = || FilterError::InvalidSetting(format!("the predicted root of step {k} is singular"));
        let half = step.predicted_root.solve_lower_triangular(&cross_transposed).ok_or_else(singular)?;
        let gain = step.predicted_root.tr_solve_lower_triangular(&half).ok_or_else(singular)?.transpose();
        let RootGaussian { mean: after_mean, root: after_root } = &smoothed[k + 1];
        let mean = &step.filtered_mean + &gain * (after_mean - &step.predicted_mean);
        let compound = DMatrix::from_columns(
            &(&before - &gain * &after)
                .column_iter()
                .chain((&gain * &step.process_noise_root).column_iter())
                .chain((&gain * after_root).column_iter())
                .map(|c| c.into_owned())
                .collect::<Vec<_>>(),
        );
        smoothed[k] = RootGaussian { mean, root: tria(compound) };
    }
    Ok(smoothed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator's exact discretisation, `x' = F·x`.
    struct Linear(DMatrix<f64>);

    impl Process for Linear {
        fn state_dim(&self) -> usize {
            self.0.nrows()
        }

        fn transition(&mut self, _t: f64, _dt: f64, x: &[f64], _u: &[f64], x_next: &mut [f64]) {
            x_next.copy_from_slice((&self.0 * DVector::from_column_slice(x)).as_slice());
        }
    }

    /// The Kalman filter and its RTS smoother, the textbook's, on `F`, `H`, `Q`, `R`, and
    /// the sigma-point pass from the same filtered and predicted Gaussians with `C`
    /// from the points: the two agree to rounding, for the cubature rule and the scaled
    /// unscented one, because the points carry a linear map exactly; so does the EKF's
    /// `C` by differences.
    #[test]
    fn on_a_linear_gaussian_model_it_is_the_kalman_rts_smoother() {
        let f = DMatrix::from_row_slice(3, 3, &[1.0, 0.01, 0.0, -0.4, 0.98, 0.01, 0.0, 0.0, 1.0]);
        let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, -40.0, -0.2, 1.0]);
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-6, 1e-5, 1e-2]));
        let r = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-4, 4e-2]));
        // A fixed, varied measurement sequence (the smoother's algebra, not the data, is checked).
        let zs: Vec<DVector<f64>> = (0..200)
            .map(|k| DVector::from_vec(vec![math::sin(0.07 * k as f64) * 0.1, math::cos(0.031 * k as f64)]))
            .collect();
        let mut filtered = Vec::new();
        let mut predicted = Vec::new();
        let mut x = Gaussian { mean: DVector::zeros(3), covariance: DMatrix::identity(3, 3) };
        for (k, z) in zs.iter().enumerate() {
            if k > 0 {
                x = Gaussian { mean: &f * &x.mean, covariance: &f * &x.covariance * f.transpose() + &q };
                predicted.push(x.clone());
            }
            let s = &h * &x.covariance * h.transpose() + &r;
            let gain = &x.covariance * h.transpose() * s.clone().try_inverse().unwrap();
            let mean = &x.mean + &gain * (z - &h * &x.mean);
            let covariance = (DMatrix::identity(3, 3) - &gain * &h) * &x.covariance;
            x = Gaussian { mean, covariance: (&covariance + covariance.transpose()) * 0.5 };
            filtered.push(x.clone());
        }
        // The textbook backward pass.
        let mut reference = filtered.clone();
        for k in (0..filtered.len() - 1).rev() {
            let p = &filtered[k].covariance;
            let gain = p * f.transpose() * predicted[k].covariance.clone().try_inverse().unwrap();
            reference[k] = Gaussian {
                mean: &filtered[k].mean + &gain * (&reference[k + 1].mean - &predicted[k].mean),
                covariance: p + &gain * (&reference[k + 1].covariance - &predicted[k].covariance) * gain.transpose(),
            };
        }
        let unscented =
            SigmaPoints::unscented(3, crate::UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 }).unwrap();
        for points in [Some(SigmaPoints::cubature(3)), Some(unscented), None] {
            let mut process = Linear(f.clone());
            let steps: Vec<SmoothingStep> = (0..filtered.len() - 1)
                .map(|k| SmoothingStep {
                    filtered: filtered[k].clone(),
                    predicted: predicted[k].clone(),
                    cross: match &points {
                        Some(points) => cross_covariance(&mut process, points, &filtered[k], 0.0, 0.01, &[]),
                        None => linearised_cross_covariance(&mut process, &filtered[k], 0.0, 0.01, &[]),
                    }
                    .unwrap(),
                })
                .collect();
            let smoothed = smooth(&steps, filtered.last().unwrap()).unwrap();
            for (s, r) in smoothed.iter().zip(&reference) {
                let scale = r.covariance.amax();
                assert!((&s.mean - &r.mean).amax() < 1e-9 * (1.0 + r.mean.amax()), "{} vs {}", s.mean, r.mean);
                assert!((&s.covariance - &r.covariance).amax() < 1e-9 * scale, "{} vs {}", s.covariance, r.covariance);
            }
            // Smoothing never widens: each smoothed variance at most the filtered one.
            for (s, f) in smoothed.iter().zip(&filtered) {
                for i in 0..3 {
                    assert!(s.covariance[(i, i)] <= f.covariance[(i, i)] * (1.0 + 1e-12));
                }
            }
        }
    }

    #[test]
    fn mismatched_steps_and_singular_predictions_are_refused() {
        let g = |n: usize| Gaussian { mean: DVector::zeros(n), covariance: DMatrix::identity(n, n) };
        let bad = SmoothingStep { filtered: g(2), predicted: g(3), cross: DMatrix::zeros(2, 2) };
        assert!(smooth(&[bad], &g(2)).is_err());
        let singular = SmoothingStep {
            filtered: g(2),
            predicted: Gaussian { mean: DVector::zeros(2), covariance: DMatrix::zeros(2, 2) },
            cross: DMatrix::zeros(2, 2),
        };
        assert!(smooth(&[singular], &g(2)).is_err());
        let mut process = Linear(DMatrix::identity(2, 2));
        assert!(cross_covariance(&mut process, &SigmaPoints::cubature(3), &g(2), 0.0, 0.1, &[]).is_err());
        assert!(linearised_cross_covariance(&mut process, &g(3), 0.0, 0.1, &[]).is_err());
    }
}
