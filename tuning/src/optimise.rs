//! The search for the maximum of a log-likelihood: argmin's Nelder–Mead simplex
//! [NelderMead1965] on `−ℓ`, which needs no gradient (a finite-difference gradient of a
//! filter's likelihood costs a filter run per parameter) and takes a failed point as a
//! bad one. The search stays inside a box around the start (`bound` in log units either
//! way), so a parameter the data do not determine cannot wander off to 10⁻³⁰⁰.

use std::sync::atomic::{AtomicU64, Ordering};

use argmin::core::{CostFunction, Error, Executor, State, TerminationReason};
use argmin::solver::neldermead::NelderMead;

/// A function of the log-parameters to maximise.
pub trait Objective: Sync {
    /// The number of log-parameters.
    fn dimension(&self) -> usize;
    /// `ℓ(θ)`; `−∞` where it cannot be computed (a failed filter).
    fn log_likelihood(&self, theta: &[f64]) -> f64;
}

/// How the simplex searches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchOptions {
    /// The initial simplex: the start and one vertex this far along each axis (log units).
    pub initial_step: f64,
    /// Converged when the standard deviation of `ℓ` over the simplex's vertices is below this.
    pub tolerance: f64,
    /// The most iterations.
    pub max_iterations: u64,
    /// Half-width of the search box around the start (log units).
    pub bound: f64,
}

impl Default for SearchOptions {
    fn default() -> Self {
        // A step of 1 is a factor e. A spread of 0.05 in ℓ puts the vertices within about
        // half a standard error of the maximum, where the Newton steps of the refinement
        // (`fit.rs`) take over: in ten dimensions the simplex's last contractions cost
        // hundreds of evaluations a Newton step saves. The box is six decades either way.
        Self { initial_step: 1.0, tolerance: 0.05, max_iterations: 3000, bound: 6.0 * std::f64::consts::LN_10 }
    }
}

/// The maximum found.
#[derive(Debug, Clone, PartialEq)]
pub struct Maximum {
    /// Its log-parameters.
    pub theta: Vec<f64>,
    /// `ℓ` there.
    pub log_likelihood: f64,
    /// Simplex iterations.
    pub iterations: u64,
    /// Evaluations of `ℓ`.
    pub evaluations: u64,
    /// Whether the simplex converged (else it ran out of iterations).
    pub converged: bool,
}

/// The cost argmin minimises: `−ℓ`, with failures and points outside the box as a very
/// large finite cost (the simplex sorts its vertices by cost; a NaN or an infinity
/// would break its arithmetic).
struct NegativeLogLikelihood<'a, O: Objective> {
    objective: &'a O,
    centre: &'a [f64],
    bound: f64,
    evaluations: AtomicU64,
}

/// The cost of a point where `ℓ` cannot be computed.
const FAILED: f64 = 1e100;

impl<O: Objective> CostFunction for NegativeLogLikelihood<'_, O> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, theta: &Self::Param) -> Result<f64, Error> {
        // Outside the box, or not a number.
        if theta.iter().zip(self.centre).any(|(t, c)| (t - c).is_nan() || (t - c).abs() > self.bound) {
            return Ok(FAILED);
        }
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let l = self.objective.log_likelihood(theta);
        Ok(if l.is_finite() { -l } else { FAILED })
    }
}

/// Maximises `objective` from `start` by Nelder–Mead.
pub fn maximise<O: Objective>(objective: &O, start: &[f64], options: &SearchOptions) -> Result<Maximum, String> {
    let n = objective.dimension();
    if start.len() != n || n == 0 {
        return Err(format!("{} start values for {n} parameters", start.len()));
    }
    let mut simplex = vec![start.to_vec()];
    for i in 0..n {
        let mut vertex = start.to_vec();
        vertex[i] += options.initial_step;
        simplex.push(vertex);
    }
    let cost = NegativeLogLikelihood { objective, centre: start, bound: options.bound, evaluations: AtomicU64::new(0) };
    let solver = NelderMead::new(simplex).with_sd_tolerance(options.tolerance).map_err(|e| e.to_string())?;
    let result = Executor::new(cost, solver)
        .configure(|state| state.max_iters(options.max_iterations))
        .run()
        .map_err(|e| format!("the Nelder-Mead search failed: {e}"))?;
    let state = result.state();
    let theta = state.get_best_param().cloned().unwrap_or_else(|| start.to_vec());
    let best = state.get_best_cost();
    let converged = matches!(state.get_termination_reason(), Some(TerminationReason::SolverConverged));
    let iterations = state.get_iter();
    let evaluations = result.problem().problem.as_ref().map_or(0, |c| c.evaluations.load(Ordering::Relaxed));
    Ok(Maximum {
        theta,
        log_likelihood: if best >= FAILED { f64::NEG_INFINITY } else { -best },
        iterations,
        evaluations,
        converged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ℓ = −½ Σ ((θᵢ − aᵢ)/sᵢ)²`, failing left of −5 in the first coordinate.
    struct Quadratic;

    impl Objective for Quadratic {
        fn dimension(&self) -> usize {
            2
        }
        fn log_likelihood(&self, theta: &[f64]) -> f64 {
            if theta[0] < -5.0 {
                return f64::NEG_INFINITY;
            }
            -0.5 * (((theta[0] - 1.5) / 0.3).powi(2) + ((theta[1] + 2.0) / 2.0).powi(2))
        }
    }

    #[test]
    fn the_simplex_finds_the_maximum_and_says_how_long_it_took() {
        let options = SearchOptions { tolerance: 1e-4, ..SearchOptions::default() };
        let found = maximise(&Quadratic, &[-4.0, 3.0], &options).unwrap();
        assert!(found.converged);
        assert!((found.theta[0] - 1.5).abs() < 0.03 && (found.theta[1] + 2.0).abs() < 0.2, "{:?}", found.theta);
        assert!(found.log_likelihood > -1e-2);
        assert!(found.iterations > 5 && found.evaluations >= found.iterations);
    }

    #[test]
    fn the_box_keeps_the_search_near_the_start() {
        let options = SearchOptions { bound: 1.0, ..SearchOptions::default() };
        let found = maximise(&Quadratic, &[-4.0, 3.0], &options).unwrap();
        assert!(found.theta[0] <= -3.0 + 1e-9, "{:?}", found.theta);
    }
}
