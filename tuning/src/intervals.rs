//! Confidence intervals from the curvature of the log-likelihood at its maximum: the
//! observed information `I = −∇²ℓ` in log-parameter space, by central finite differences,
//! its inverse the asymptotic covariance of the log-parameters [Schweppe1965;
//! Mehra1970], a standard error per parameter, the 95 % interval `θ̂ ± 1.96·se`, and
//! `exp` back to the parameter (so the interval is a factor either way, and positive).
//!
//! A parameter is **not identifiable** when the data hardly constrain it: its 95 %
//! interval spans more than a factor 10 either way (`se > ln 10 / 1.96` in log units), or
//! the curvature along it is flat or of the wrong sign (the information matrix is not
//! positive definite there). Such parameters are set aside, held at their estimates, and
//! the others' intervals are those with them fixed ([`SetAside`] says why); a set-aside
//! parameter's interval is only formal.
//!
//! The `2p` probes that scale the steps and the `p(p+1)` evaluations of the curvature
//! are independent and run in parallel (rayon).

use nalgebra::{DMatrix, SymmetricEigen};
use rayon::prelude::*;

use crate::optimise::Objective;

/// The standard normal's 97.5 % quantile: a two-sided 95 % interval is `± Z95·se`.
pub const Z95: f64 = 1.959_963_984_540_054;

/// The largest standard error (log units) of an identifiable parameter: its 95 %
/// interval within a factor 10 either way.
pub const MAX_IDENTIFIABLE_SE: f64 = std::f64::consts::LN_10 / Z95;

/// The local shape of `ℓ` around a point, by finite differences.
#[derive(Debug, Clone, PartialEq)]
pub struct Curvature {
    /// The log-parameters.
    pub theta: Vec<f64>,
    /// `ℓ(θ)`.
    pub log_likelihood: f64,
    /// `∇ℓ` (central differences).
    pub gradient: Vec<f64>,
    /// `∇²ℓ`.
    pub hessian: DMatrix<f64>,
    /// The step of each log-parameter.
    pub steps: Vec<f64>,
    /// Evaluations of `ℓ` made.
    pub evaluations: usize,
    /// How many of them failed (`ℓ = −∞`): the curvature is then unknown.
    pub failed: usize,
}

/// The finite-difference step as a fraction of the parameter's standard error.
const STEP_FRACTION: f64 = 0.2;

/// The smallest and largest finite-difference step (log units).
const STEP_RANGE: (f64, f64) = (1e-4, 0.5);

/// Steps for [`curvature`] scaled to each parameter's own curvature: a fifth of a standard
/// error, `0.2/√(−∂²ℓ/∂θᵢ²)`, from `ℓ` at `θ ± probe·eᵢ`, within [1e-4, 0.5]. A fixed step
/// cannot serve all: the central difference's error in the gradient is `h²/6·∂³ℓ`, and for
/// a sensor's standard deviation fitted on 10⁵ rows `∂³ℓ ≈ 2·∂²ℓ ≈ −4·10⁵`, so a step of
/// 0.1 would make the gradient wrong by hundreds. With a fifth of a standard error the
/// gain a Newton step predicts is right to about 0.003 (at one standard error, to 0.06:
/// too coarse to tell a maximum within 0.01).
///
/// That holds for a smooth likelihood. A model with kinks (S2's piecewise-linear damper:
/// sigma points crossing the knee) makes `ℓ` rough at small scales, by several units over
/// a 0.2 % change of a parameter, and a small step then measures the roughness, not the
/// curvature. So the curvature is checked at the scaled step too: where it differs from the
/// probe's by more than a factor 2, the parameter is **rough** and keeps the probe's step
/// (its curvature then that of `ℓ` smoothed over the probe's scale). `4p` evaluations, in
/// parallel; returns the steps, which parameters are rough, and the evaluations made.
pub fn scaled_steps<O: Objective>(
    objective: &O,
    theta: &[f64],
    at_theta: f64,
    probe: f64,
) -> (Vec<f64>, Vec<bool>, usize) {
    let n = theta.len();
    let second_differences = |steps: &[f64]| -> Vec<f64> {
        let points: Vec<Vec<f64>> = (0..2 * n)
            .map(|k| {
                let mut t = theta.to_vec();
                t[k / 2] += if k % 2 == 0 { steps[k / 2] } else { -steps[k / 2] };
                t
            })
            .collect();
        let values: Vec<f64> = points.par_iter().with_max_len(1).map(|p| objective.log_likelihood(p)).collect();
        (0..n).map(|i| (values[2 * i] - 2.0 * at_theta + values[2 * i + 1]) / (steps[i] * steps[i])).collect()
    };
    let at_probe = second_differences(&vec![probe; n]);
    let scaled: Vec<f64> = at_probe
        .iter()
        .map(|&second| {
            if second < 0.0 && second.is_finite() {
                (STEP_FRACTION / (-second).sqrt()).clamp(STEP_RANGE.0, STEP_RANGE.1)
            } else {
                STEP_RANGE.1
            }
        })
        .collect();
    let at_scaled = second_differences(&scaled);
    let rough: Vec<bool> = (0..n)
        .map(|i| {
            let ratio = at_scaled[i] / at_probe[i];
            // Only where the curvature is of some size: a flat parameter has no scale to miss.
            let sized = at_probe[i] < -1.0 / (MAX_IDENTIFIABLE_SE * MAX_IDENTIFIABLE_SE);
            sized && scaled[i] < probe && !(0.5..=2.0).contains(&ratio)
        })
        .collect();
    let steps = (0..n).map(|i| if rough[i] { probe } else { scaled[i] }).collect();
    (steps, rough, 4 * n)
}

/// The gradient of `objective` at `theta` (`ℓ(θ) = at_theta`) by central differences of
/// steps `steps` (`2p` evaluations, in parallel), and how many evaluations it made.
pub fn gradient<O: Objective>(objective: &O, theta: &[f64], at_theta: f64, steps: &[f64]) -> (Vec<f64>, usize) {
    let n = theta.len();
    let points: Vec<Vec<f64>> = (0..2 * n)
        .map(|k| {
            let mut t = theta.to_vec();
            t[k / 2] += if k % 2 == 0 { steps[k / 2] } else { -steps[k / 2] };
            t
        })
        .collect();
    let values: Vec<f64> = points.par_iter().with_max_len(1).map(|p| objective.log_likelihood(p)).collect();
    let g = (0..n)
        .map(|i| {
            let (plus, minus) = (values[2 * i], values[2 * i + 1]);
            // A failed side: the one-sided difference, else no slope known.
            match (plus.is_finite(), minus.is_finite()) {
                (true, true) => (plus - minus) / (2.0 * steps[i]),
                (true, false) => (plus - at_theta) / steps[i],
                (false, true) => (at_theta - minus) / steps[i],
                (false, false) => 0.0,
            }
        })
        .collect();
    (g, points.len())
}

/// The curvature of `objective` at `theta` (`at_theta`: `ℓ(θ)` if already known), from
/// `ℓ` at `θ ± hᵢ·eᵢ` and `θ ± (hᵢ·eᵢ + hⱼ·eⱼ)`, all in parallel:
///
/// ```text
/// Hᵢᵢ = (ℓ(+i) − 2ℓ₀ + ℓ(−i)) / hᵢ²
/// Hᵢⱼ = (ℓ(+i+j) + ℓ(−i−j) − ℓ(+i) − ℓ(−i) − ℓ(+j) − ℓ(−j) + 2ℓ₀) / (2·hᵢ·hⱼ)
/// ```
pub fn curvature<O: Objective>(objective: &O, theta: &[f64], at_theta: Option<f64>, steps: &[f64]) -> Curvature {
    let n = theta.len();
    let shifted = |pairs: &[(usize, f64)]| {
        let mut t = theta.to_vec();
        for &(i, s) in pairs {
            t[i] += s;
        }
        t
    };
    let mut points: Vec<Vec<f64>> = Vec::new();
    if at_theta.is_none() {
        points.push(theta.to_vec());
    }
    for (i, &h) in steps.iter().enumerate() {
        points.push(shifted(&[(i, h)]));
        points.push(shifted(&[(i, -h)]));
    }
    for i in 0..n {
        for j in i + 1..n {
            points.push(shifted(&[(i, steps[i]), (j, steps[j])]));
            points.push(shifted(&[(i, -steps[i]), (j, -steps[j])]));
        }
    }
    let values: Vec<f64> = points.par_iter().with_max_len(1).map(|p| objective.log_likelihood(p)).collect();
    let failed =
        values.iter().filter(|v| !v.is_finite()).count() + usize::from(at_theta.is_some_and(|v| !v.is_finite()));
    let mut next = values.iter().copied();
    let f0 = at_theta.unwrap_or_else(|| next.next().unwrap_or(f64::NAN));
    let mut plus = vec![0.0; n];
    let mut minus = vec![0.0; n];
    for i in 0..n {
        plus[i] = next.next().unwrap_or(f64::NAN);
        minus[i] = next.next().unwrap_or(f64::NAN);
    }
    let mut hessian = DMatrix::zeros(n, n);
    let gradient: Vec<f64> = (0..n).map(|i| (plus[i] - minus[i]) / (2.0 * steps[i])).collect();
    for i in 0..n {
        hessian[(i, i)] = (plus[i] - 2.0 * f0 + minus[i]) / (steps[i] * steps[i]);
    }
    for i in 0..n {
        for j in i + 1..n {
            let pp = next.next().unwrap_or(f64::NAN);
            let mm = next.next().unwrap_or(f64::NAN);
            let h = (pp + mm - plus[i] - minus[i] - plus[j] - minus[j] + 2.0 * f0) / (2.0 * steps[i] * steps[j]);
            hessian[(i, j)] = h;
            hessian[(j, i)] = h;
        }
    }
    Curvature {
        theta: theta.to_vec(),
        log_likelihood: f0,
        gradient,
        hessian,
        steps: steps.to_vec(),
        evaluations: values.len(),
        failed,
    }
}

/// A parameter's estimate and 95 % interval (natural units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// The estimate `exp θ̂`.
    pub estimate: f64,
    /// `exp(θ̂ − 1.96·se)`.
    pub lower: f64,
    /// `exp(θ̂ + 1.96·se)`.
    pub upper: f64,
    /// The standard error of `θ̂ = ln(estimate)` (infinite where the curvature is flat).
    pub log_standard_error: f64,
    /// Whether the data determine it (see the module documentation).
    pub identifiable: bool,
    /// Why not, when not.
    pub set_aside: Option<SetAside>,
}

/// Why a parameter's interval is only formal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetAside {
    /// The likelihood hardly changes with it: its interval spans more than a factor 10 either way.
    Flat,
    /// The curvature has the wrong sign along it, alone or together with others: the point
    /// is no maximum along a direction it takes part in (the search stopped on a ridge or a
    /// saddle, or the finite differences are unsure there).
    NoMaximum,
    /// A filter failed at one of the curvature's points.
    Unknown,
}

impl Interval {
    /// Whether `value` lies in the interval.
    pub fn contains(&self, value: f64) -> bool {
        self.lower <= value && value <= self.upper
    }
}

/// The parameters the data determine (indices), the covariance of their log-parameters,
/// and the parameters set aside with the reason.
type Determined = (Vec<usize>, DMatrix<f64>, Vec<(usize, SetAside)>);

/// The parameters the data determine, and the covariance of their log-parameters.
///
/// Starting from all, a parameter is set aside (held at its estimate) while the
/// information matrix `I = −∇²ℓ` of those left is not positive definite — the one with
/// the largest weight in its least eigenvalue's direction — or while one of them has a
/// standard error above [`MAX_IDENTIFIABLE_SE`] — the largest first. Holding a flat
/// parameter fixed, rather than letting its infinite variance spread to the others
/// through the noise of the finite differences, gives the others the intervals they have
/// with it at its value (conditional intervals).
fn determined(curvature: &Curvature) -> Option<Determined> {
    if curvature.failed > 0 || curvature.hessian.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let information = -curvature.hessian.clone();
    let mut active: Vec<usize> = (0..curvature.theta.len()).collect();
    let mut aside = Vec::new();
    while !active.is_empty() {
        let sub = information.select_rows(&active).select_columns(&active);
        let eigen = SymmetricEigen::new(sub.clone());
        let (least, lambda) = eigen.eigenvalues.iter().copied().enumerate().fold((0, f64::INFINITY), |best, (j, l)| {
            if l < best.1 {
                (j, l)
            } else {
                best
            }
        });
        // Not positive definite (a NaN eigenvalue counts as not positive either).
        if lambda.is_nan() || lambda <= 0.0 {
            let v = eigen.eigenvectors.column(least);
            let heaviest = (0..active.len()).max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs())).unwrap_or(0);
            let i = active.remove(heaviest);
            // Flat if its own curvature is about nil; else no maximum: along it alone (the
            // curvature of the wrong sign) or in combination with others.
            let own = information[(i, i)];
            let flat = own.is_nan() || own.abs() < 1.0 / (MAX_IDENTIFIABLE_SE * MAX_IDENTIFIABLE_SE);
            aside.push((i, if flat { SetAside::Flat } else { SetAside::NoMaximum }));
            continue;
        }
        let covariance = sub.try_inverse()?;
        let (worst, se) = (0..active.len()).map(|a| (a, covariance[(a, a)].sqrt())).fold((0, 0.0), |best, (a, se)| {
            if se > best.1 {
                (a, se)
            } else {
                best
            }
        });
        if se > MAX_IDENTIFIABLE_SE {
            aside.push((active.remove(worst), SetAside::Flat));
            continue;
        }
        return Some((active, covariance, aside));
    }
    Some((active, DMatrix::zeros(0, 0), aside))
}

/// The intervals of the parameters at the point `curvature` was taken (its maximum). A
/// parameter set aside gets the formal interval of its own curvature `1/√Iᵢᵢ` (infinite
/// where that is not positive).
pub fn intervals(curvature: &Curvature) -> Vec<Interval> {
    let n = curvature.theta.len();
    let found = determined(curvature);
    (0..n)
        .map(|i| {
            let theta = curvature.theta[i];
            let determined_se = found
                .as_ref()
                .and_then(|(active, cov, _)| active.iter().position(|&a| a == i).map(|a| cov[(a, a)].sqrt()));
            let set_aside = match &found {
                None => Some(SetAside::Unknown),
                Some((_, _, aside)) => aside.iter().find(|(j, _)| *j == i).map(|(_, why)| *why),
            };
            let own = -curvature.hessian[(i, i)];
            let se = determined_se.unwrap_or(if own > 0.0 { 1.0 / own.sqrt() } else { f64::INFINITY });
            Interval {
                estimate: theta.exp(),
                lower: (theta - Z95 * se).exp(),
                upper: (theta + Z95 * se).exp(),
                log_standard_error: se,
                identifiable: determined_se.is_some(),
                set_aside,
            }
        })
        .collect()
}

/// The Newton step `I⁻¹·∇ℓ` towards the maximum of the quadratic model, on the
/// parameters the data determine (the others stay: along a flat direction the model
/// says nothing), each coordinate cut to `±max_step`; and the gain in `ℓ` the model
/// predicts for it (`None` when the curvature is unknown).
pub fn newton_step(curvature: &Curvature, max_step: f64) -> Option<(Vec<f64>, f64)> {
    let (active, covariance, _) = determined(curvature)?;
    let n = curvature.theta.len();
    let g: Vec<f64> = active.iter().map(|&i| curvature.gradient[i]).collect();
    let g = nalgebra::DVector::from_column_slice(&g);
    let mut delta = &covariance * &g;
    let largest = delta.amax();
    if largest > max_step {
        delta *= max_step / largest;
    }
    let information = -curvature.hessian.select_rows(&active).select_columns(&active);
    // The quadratic model's gain along the (possibly cut) step: gᵀδ − ½ δᵀIδ.
    let gain = g.dot(&delta) - 0.5 * delta.dot(&(&information * &delta));
    let mut step = vec![0.0; n];
    for (a, &i) in active.iter().enumerate() {
        step[i] = delta[a];
    }
    Some((step, gain))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ℓ = −½ (θ − a)ᵀ A (θ − a)` with a known inverse, and a third, flat coordinate.
    struct Gaussian;

    impl Objective for Gaussian {
        fn dimension(&self) -> usize {
            3
        }
        fn log_likelihood(&self, t: &[f64]) -> f64 {
            let (x, y) = (t[0] - 1.0, t[1] + 0.5);
            -0.5 * (400.0 * x * x + 2.0 * 100.0 * x * y + 100.0 * y * y)
        }
    }

    #[test]
    fn the_intervals_are_those_of_the_inverse_curvature_and_a_flat_parameter_is_named() {
        let c = curvature(&Gaussian, &[1.0, -0.5, 0.0], None, &[0.05; 3]);
        assert_eq!(c.evaluations, 1 + 6 + 6);
        assert!((c.hessian[(0, 1)] + 100.0).abs() < 1e-6 && (c.hessian[(0, 0)] + 400.0).abs() < 1e-6);
        // A = [[400, 100], [100, 100]]: A⁻¹ = [[1/300, −1/300], [−1/300, 4/300]].
        let iv = intervals(&c);
        assert!((iv[0].log_standard_error - (1.0_f64 / 300.0).sqrt()).abs() < 1e-6, "{:?}", iv[0]);
        assert!((iv[1].log_standard_error - (4.0_f64 / 300.0).sqrt()).abs() < 1e-6, "{:?}", iv[1]);
        assert!(iv[0].identifiable && iv[1].identifiable && !iv[2].identifiable);
        assert_eq!((iv[0].set_aside, iv[2].set_aside), (None, Some(SetAside::Flat)));
        let e = 1.0_f64.exp();
        assert!(iv[0].contains(e) && iv[0].lower < e && iv[0].upper > e);
    }

    #[test]
    fn the_newton_step_lands_on_the_maximum_along_the_determined_directions() {
        let (steps, rough, evaluations) =
            scaled_steps(&Gaussian, &[0.9, -0.4, 2.0], Gaussian.log_likelihood(&[0.9, -0.4, 2.0]), 0.1);
        assert_eq!((evaluations, rough), (12, vec![false; 3]));
        assert!((steps[0] - 0.01).abs() < 1e-9 && steps[2] == 0.5, "a fifth of the own standard error: {steps:?}");
        let c = curvature(&Gaussian, &[0.9, -0.4, 2.0], None, &steps);
        let (step, gain) = newton_step(&c, 10.0).unwrap();
        assert!((step[0] - 0.1).abs() < 1e-6 && (step[1] + 0.1).abs() < 1e-6, "{step:?}");
        assert!(step[2].abs() < 1e-9, "no step along the flat direction: {step:?}");
        let l = Gaussian.log_likelihood(&[0.9, -0.4, 2.0]);
        assert!((gain + l).abs() < 1e-6, "the gain takes ℓ to its maximum 0: {gain} vs {l}");
    }
}
