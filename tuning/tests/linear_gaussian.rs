//! Specification: on a linear-Gaussian model with known true noise, maximum likelihood
//! recovers it — the true `Q` and `R` lie inside the fit's own 95 % intervals in at least
//! 90 % of 50 seeds (each interval should hold in 95 %; below 90 % over 50 seeds is
//! what a biased fit or too narrow intervals give), and the fitted filter's mean NIS per
//! row lies in its χ² band as often.
//!
//! The model: a constant-velocity target, `x = [position, velocity]`, driven by white
//! acceleration of intensity `q` (`Q = q·[Δt³/3, Δt²/2; Δt²/2, Δt]`, the exact
//! discretisation), the position measured with noise of std `r`. The filter is the
//! library's SRCKF on a small `Model`, built through the same generic `fit` the FMU path
//! uses.

use estimator::{build_filter, FilterKind, Gaussian, Noise, Observation, Process, StateEstimator, UnscentedParams};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use tuning::consistency::NisBand;
use tuning::{fit, FilterFactory, FitOptions, Likelihood, Record, RobustCap};

const DT: f64 = 0.1;
const SAMPLES: usize = 1500;
const TRUE_Q: f64 = 0.5;
const TRUE_R: f64 = 0.3;

/// `x' = [p + Δt·v, v]`, `z = p`.
struct ConstantVelocity;

impl Process for ConstantVelocity {
    fn state_dim(&self) -> usize {
        2
    }
    fn transition(&mut self, _t: f64, dt: f64, x: &[f64], _u: &[f64], next: &mut [f64]) {
        next[0] = x[0] + dt * x[1];
        next[1] = x[1];
    }
}

impl Observation for ConstantVelocity {
    fn measurement_dim(&self) -> usize {
        1
    }
    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        z[0] = x[0];
    }
}

/// `Q` of white acceleration of intensity `q` over `dt`.
fn process_noise(q: f64, dt: f64) -> DMatrix<f64> {
    DMatrix::from_row_slice(2, 2, &[q * dt.powi(3) / 3.0, q * dt * dt / 2.0, q * dt * dt / 2.0, q * dt])
}

/// The parameters `[q, r]` to an SRCKF on the model, from a diffuse prior.
struct Factory;

impl FilterFactory for Factory {
    fn parameter_count(&self) -> usize {
        2
    }
    fn build(&self, values: &[f64], _start: f64) -> Result<Box<dyn StateEstimator>, String> {
        let noise = Noise::new(process_noise(values[0], DT), DMatrix::from_element(1, 1, values[1] * values[1]))
            .map_err(|e| e.to_string())?;
        let prior = Gaussian::diagonal(&[0.0, 0.0], &[100.0, 100.0]);
        build_filter(FilterKind::SrCkf, ConstantVelocity, noise, &prior, UnscentedParams::default())
            .map_err(|e| e.to_string())
    }
    fn sample_time(&self) -> f64 {
        DT
    }
}

/// A seeded run of the true system, its measurements as a record.
fn simulate(seed: u64) -> Record {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let q = process_noise(TRUE_Q, DT).cholesky().expect("Q is positive definite").l();
    let mut x = [0.0, 1.0];
    let mut record = Record::new(1, 0);
    for k in 0..SAMPLES {
        let v: f64 = StandardNormal.sample(&mut rng);
        record.push(k as f64 * DT, &[x[0] + TRUE_R * v], &[]).unwrap();
        let w: [f64; 2] = [StandardNormal.sample(&mut rng), StandardNormal.sample(&mut rng)];
        x = [x[0] + DT * x[1] + q[(0, 0)] * w[0], x[1] + q[(1, 0)] * w[0] + q[(1, 1)] * w[1]];
    }
    record
}

#[test]
fn maximum_likelihood_recovers_the_true_noise_within_its_own_intervals() {
    let seeds: Vec<u64> = (1..=50).collect();
    // Start a factor 10 and 3 off the truth.
    let start = [TRUE_Q / 10.0, TRUE_R * 3.0];
    let outcomes: Vec<(bool, bool, bool, f64, f64)> = seeds
        .par_iter()
        .map(|&seed| {
            let likelihood = Likelihood::new(&Factory, vec![simulate(seed)], RobustCap::DEFAULT);
            let found = fit(&likelihood, &start, &FitOptions::default()).expect("a fit");
            let [q, r] = [found.intervals[0], found.intervals[1]];
            assert!(q.identifiable && r.identifiable, "seed {seed}: both are determined by 1500 samples");
            let band = NisBand::at_95(found.evaluation.rows);
            (
                q.contains(TRUE_Q),
                r.contains(TRUE_R),
                band.contains(found.evaluation.nis_per_row()),
                q.estimate,
                r.estimate,
            )
        })
        .collect();
    let count = |pick: fn(&(bool, bool, bool, f64, f64)) -> bool| outcomes.iter().filter(|o| pick(o)).count();
    let (q_in, r_in, nis_in) = (count(|o| o.0), count(|o| o.1), count(|o| o.2));
    let mean = |pick: fn(&(bool, bool, bool, f64, f64)) -> f64| outcomes.iter().map(pick).sum::<f64>() / 50.0;
    println!(
        "of 50 seeds: Q in its 95 % interval {q_in}, R {r_in}, NIS in its band {nis_in}; mean estimates q {:.4} \
         (true {TRUE_Q}), r {:.4} (true {TRUE_R})",
        mean(|o| o.3),
        mean(|o| o.4)
    );
    assert!(q_in >= 45, "Q inside its interval in {q_in} of 50 seeds");
    assert!(r_in >= 45, "R inside its interval in {r_in} of 50 seeds");
    assert!(nis_in >= 45, "NIS inside its band in {nis_in} of 50 seeds");
    // Unbiased to well within the spread of one seed (se of ln q ≈ 0.1, of ln r ≈ 0.03).
    assert!((mean(|o| o.3) / TRUE_Q - 1.0).abs() < 0.05 && (mean(|o| o.4) / TRUE_R - 1.0).abs() < 0.02);
}

#[test]
fn without_the_log_determinant_the_criterion_would_not_recover_the_noise() {
    // The specification is able to fail: the NIS alone (the likelihood without ln det S)
    // is smallest for the largest R, so a fit of it runs to the edge of its box.
    struct NisOnly<'a>(Likelihood<'a, Factory>);
    impl tuning::optimise::Objective for NisOnly<'_> {
        fn dimension(&self) -> usize {
            2
        }
        fn log_likelihood(&self, theta: &[f64]) -> f64 {
            -0.5 * self.0.at(theta).nis
        }
    }
    let objective = NisOnly(Likelihood::new(&Factory, vec![simulate(7)], RobustCap::DEFAULT));
    let start = [TRUE_Q.ln(), TRUE_R.ln()];
    let found = tuning::optimise::maximise(&objective, &start, &Default::default()).unwrap();
    assert!(found.theta[1].exp() > 100.0 * TRUE_R, "{:?}", found.theta);
}

#[test]
fn a_few_gross_errors_do_not_pull_the_fit_with_the_cap_and_do_without_it() {
    let clean = simulate(11);
    let mut spiked = Record::new(1, 0);
    for k in 0..clean.len() {
        // Three gross errors of 200 σ, as a glitching sensor gives.
        let z = clean.measurement(k)[0] + if [300, 700, 1100].contains(&k) { 200.0 * TRUE_R } else { 0.0 };
        spiked.push(clean.times()[k], &[z], &[]).unwrap();
    }
    let start = [TRUE_Q, TRUE_R];
    let fitted = |record: &Record, cap: RobustCap| {
        let likelihood = Likelihood::new(&Factory, vec![record.clone()], cap);
        fit(&likelihood, &start, &FitOptions::default()).expect("a fit")
    };
    let reference = fitted(&clean, RobustCap::DEFAULT);
    let capped = fitted(&spiked, RobustCap::DEFAULT);
    let uncapped = fitted(&spiked, RobustCap::NONE);
    let shift = |f: &tuning::Fit, i: usize| {
        (f.intervals[i].estimate / reference.intervals[i].estimate).ln() / reference.intervals[i].log_standard_error
    };
    println!(
        "shift in standard errors of the clean fit: capped q {:.2}, r {:.2}; uncapped q {:.2}, r {:.2}; rows beyond \
         the cap {}",
        shift(&capped, 0),
        shift(&capped, 1),
        shift(&uncapped, 0),
        shift(&uncapped, 1),
        capped.evaluation.capped_rows
    );
    for (what, f) in [("clean", &reference), ("capped", &capped), ("uncapped", &uncapped)] {
        println!(
            "{what}: q {:.4}, r {:.4}, {} refinements, remaining gain {:?}, search {} evaluations",
            f.intervals[0].estimate, f.intervals[1].estimate, f.refinements, f.remaining_gain, f.search.evaluations
        );
        assert!(f.converged, "{what}: the fit ends at a maximum");
    }
    assert!(capped.evaluation.capped_rows >= 3, "the spikes are beyond the cap");
    // Each gross error beyond the cap pulls the noise scale as a row at the cap would
    // (c² = 16 instead of 200² = 40 000): three in 1500 rows move it by about one
    // standard error, within the fit's own interval.
    assert!(shift(&capped, 0).abs() < 1.5 && shift(&capped, 1).abs() < 1.5, "the cap keeps the fit");
    assert!(shift(&uncapped, 0).abs().max(shift(&uncapped, 1).abs()) > 3.0, "without it the spikes pull it");
}

#[test]
fn a_filter_that_fails_at_a_trial_point_is_a_bad_point_not_an_error() {
    // The same model, but no filter can be built for r above 2: the search must go round it.
    struct Fragile;
    impl FilterFactory for Fragile {
        fn parameter_count(&self) -> usize {
            2
        }
        fn build(&self, values: &[f64], start: f64) -> Result<Box<dyn StateEstimator>, String> {
            if values[1] > 2.0 {
                return Err(format!("r = {} is too large for this factory", values[1]));
            }
            Factory.build(values, start)
        }
        fn sample_time(&self) -> f64 {
            DT
        }
    }
    let likelihood = Likelihood::new(&Fragile, vec![simulate(5)], RobustCap::DEFAULT);
    let failed = likelihood.at_values(&[TRUE_Q, 3.0]);
    assert_eq!(failed.value(), f64::NEG_INFINITY);
    assert!(failed.failure.as_deref().unwrap_or("").contains("too large"), "{failed:?}");
    // From r = 1.5 the first simplex step (a factor e) lands where the filter fails.
    let found = fit(&likelihood, &[TRUE_Q, 1.5], &FitOptions::default()).expect("a fit despite the failures");
    assert!(found.intervals[1].contains(TRUE_R) || (found.intervals[1].estimate / TRUE_R).ln().abs() < 0.1);
    assert!(found.evaluation.failure.is_none());
}
