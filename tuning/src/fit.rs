//! The fit, generic over what builds the filter: maximum likelihood of the log-parameters
//! by the simplex ([`optimise`](crate::optimise)), optionally on the leading seconds of
//! the records only (a cheap coarse search), then Newton steps on the whole records with
//! the finite-difference curvature ([`intervals`](crate::intervals)), which also gives
//! the intervals. The FMU path (`FmuEstimator`) and the tests' linear-Gaussian models go
//! through this one function.
//!
//! The search takes the robust cap in the likelihood only, the filter taking every row as
//! it is: from a start far off, most rows exceed the cap, and a filter that took them at
//! the cap could not follow the data. The refinement, the curvature and the reported
//! likelihood are those of the cap as given (winsorising: a gross error does not drag
//! the filter's state); on a clean log the two agree to the few rows beyond the cap.

use std::time::{Duration, Instant};

use crate::intervals::{curvature, gradient, intervals, newton_step, scaled_steps, Curvature, Interval};
use crate::likelihood::{Evaluation, FilterFactory, Likelihood};
use crate::optimise::{maximise, Maximum, SearchOptions};

/// How to fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// The simplex search.
    pub search: SearchOptions,
    /// Search on the first this many seconds of each record, then refine on the whole.
    pub coarse_seconds: Option<f64>,
    /// The probe step that scales the curvature's steps (log units: 0.1 is a 10.5 % change).
    pub curvature_probe: f64,
    /// The most Newton steps on the whole records after the search.
    pub refinements: usize,
    /// A Newton step whose predicted gain in `ℓ` is below this is not taken: the search
    /// has converged.
    pub refinement_tolerance: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            search: SearchOptions::default(),
            coarse_seconds: None,
            curvature_probe: 0.1,
            refinements: 8,
            refinement_tolerance: 1e-2,
        }
    }
}

/// What a fit found.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The start values (natural units).
    pub start: Vec<f64>,
    /// The likelihood at the start over the whole records.
    pub start_evaluation: Evaluation,
    /// The estimates with their 95 % intervals.
    pub intervals: Vec<Interval>,
    /// The likelihood at the estimates over the whole records (with the NIS).
    pub evaluation: Evaluation,
    /// The simplex search (on the leading seconds when coarse).
    pub search: Maximum,
    /// Newton steps taken after the search.
    pub refinements: usize,
    /// Per parameter: the likelihood is rough along it at the scale of its standard error
    /// (its curvature is taken over the probe's scale: see `intervals::scaled_steps`).
    pub rough: Vec<bool>,
    /// The gain in `ℓ` a further Newton step predicts at the estimates (on the parameters
    /// the data determine; `None` when the curvature is unknown).
    pub remaining_gain: Option<f64>,
    /// Whether that gain is below the tolerance: the estimates are at a maximum.
    pub converged: bool,
    /// The curvature at the estimates.
    pub curvature: Curvature,
    /// Evaluations of `ℓ` for the curvatures and steps (the search's are in `search`).
    pub curvature_evaluations: usize,
    /// Wall time of the search.
    pub search_time: Duration,
    /// Wall time of the refinement and the curvature.
    pub curvature_time: Duration,
}

impl Fit {
    /// The estimates (natural units).
    pub fn values(&self) -> Vec<f64> {
        self.intervals.iter().map(|i| i.estimate).collect()
    }

    /// Every evaluation of `ℓ` the fit made.
    pub fn evaluations(&self) -> u64 {
        // The start, the search, the evaluation after it, the curvatures and steps.
        2 + self.search.evaluations + self.curvature_evaluations as u64
    }
}

/// Fits the parameters of `likelihood`'s factory from `start` (natural units, positive).
pub fn fit<F: FilterFactory>(
    likelihood: &Likelihood<'_, F>,
    start: &[f64],
    options: &FitOptions,
) -> Result<Fit, String> {
    let n = likelihood.factory().parameter_count();
    if start.len() != n {
        return Err(format!("{} start values for {n} parameters", start.len()));
    }
    if let Some(v) = start.iter().find(|v| !(**v > 0.0 && v.is_finite())) {
        return Err(format!("every start value must be positive and finite (the fit works on logarithms), got {v}"));
    }
    let theta0: Vec<f64> = start.iter().map(|v| v.ln()).collect();
    let start_evaluation = likelihood.at(&theta0);

    let clock = Instant::now();
    let searched = likelihood.with_cap(likelihood.cap().in_likelihood_only());
    let searched = match options.coarse_seconds {
        Some(seconds) => searched.leading(seconds),
        None => searched,
    };
    let search = maximise(&searched, &theta0, &options.search)?;
    drop(searched);
    let search_time = clock.elapsed();

    let clock = Instant::now();
    let mut theta = search.theta.clone();
    let mut at_best = likelihood.at(&theta);
    if !at_best.value().is_finite() && start_evaluation.value().is_finite() {
        // The coarse optimum fails on the whole records: refine from the start instead.
        theta = theta0.clone();
        at_best = start_evaluation.clone();
    }
    // The steps are scaled once, at the first point: near the maximum the shape changes little.
    let (steps, rough, probes) = scaled_steps(likelihood, &theta, at_best.value(), options.curvature_probe);
    let mut curv = curvature(likelihood, &theta, Some(at_best.value()), &steps);
    let mut curvature_evaluations = probes + curv.evaluations;
    // Newton steps with the Hessian kept (a chord method): after a step only the gradient
    // is new (2p evaluations, not p(p+1)); the Hessian is taken afresh when a step fails
    // with an old one or the predicted gain shrinks less than fourfold (the old Hessian
    // no longer fits), and at the last point, for the intervals.
    let mut fresh = true;
    let mut refinements = 0;
    let mut last_gain = f64::INFINITY;
    'refine: while refinements < options.refinements {
        let Some((step, gain)) = newton_step(&curv, 1.0) else { break };
        // (A NaN gain is no gain either.) Only a fresh Hessian can say the end is reached.
        let converged = gain.is_nan() || gain < options.refinement_tolerance;
        if converged && fresh {
            break;
        }
        if !fresh && (converged || gain > 0.25 * last_gain) {
            curv = curvature(likelihood, &theta, Some(at_best.value()), &steps);
            curvature_evaluations += curv.evaluations;
            fresh = true;
            last_gain = f64::INFINITY;
            continue;
        }
        last_gain = gain;
        for fraction in [1.0, 0.5, 0.25] {
            let trial: Vec<f64> = theta.iter().zip(&step).map(|(t, s)| t + fraction * s).collect();
            let evaluation = likelihood.at(&trial);
            curvature_evaluations += 1;
            if evaluation.value() > at_best.value() {
                theta = trial;
                at_best = evaluation;
                refinements += 1;
                let (g, evaluations) = gradient(likelihood, &theta, at_best.value(), &steps);
                curvature_evaluations += evaluations;
                curv = Curvature { theta: theta.clone(), log_likelihood: at_best.value(), gradient: g, ..curv };
                fresh = false;
                continue 'refine;
            }
        }
        if fresh {
            break;
        }
        curv = curvature(likelihood, &theta, Some(at_best.value()), &steps);
        curvature_evaluations += curv.evaluations;
        fresh = true;
    }
    if !fresh {
        curv = curvature(likelihood, &theta, Some(at_best.value()), &steps);
        curvature_evaluations += curv.evaluations;
    }
    let remaining_gain = newton_step(&curv, f64::INFINITY).map(|(_, gain)| gain);
    let curvature_time = clock.elapsed();
    Ok(Fit {
        start: start.to_vec(),
        start_evaluation,
        intervals: intervals(&curv),
        evaluation: at_best,
        search,
        refinements,
        rough,
        remaining_gain,
        converged: remaining_gain.is_some_and(|g| g < options.refinement_tolerance),
        curvature: curv,
        curvature_evaluations,
        search_time,
        curvature_time,
    })
}
