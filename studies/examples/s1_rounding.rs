//! How much rounding decides the last digits of the S1 table. On one case it
//! runs the CKF and the SRCKF (equal in exact arithmetic), and the CKF again
//! from a prior covariance scaled by 1 + 1e-12, and prints the largest
//! difference of the load estimates in each 5 s window.
//!
//! ```text
//! cargo run --release -p studies --example s1_rounding [-- CASE]
//! ```
//!
//! CASE is `stiffness/harmonic` (default), `stiffness/random`, `damping/random`
//! or `damping/harmonic`. The study's settings and tuning are the defaults of
//! `kalfmu reproduce`.

use estimator::models::Oscillator2DofLoad;
use estimator::{CubatureKalman, Discretized, Gaussian, SquareRootCubature, StateEstimator};
use studies::s1::Tuning;
use truth::s1::{simulate, Case, Settings};

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "stiffness/harmonic".into());
    let case = Case::ALL.into_iter().find(|c| c.to_string() == name).unwrap_or_else(|| {
        panic!("unknown case {name:?}: use stiffness/random, damping/random, stiffness/harmonic or damping/harmonic")
    });
    let settings = Settings::default();
    let (_, measurements) = simulate(&case, &settings);
    let tuning = Tuning::new(&settings, measurements.noise_std);
    let prior = tuning.prior();
    let nudged = Gaussian { mean: prior.mean.clone(), covariance: &prior.covariance * (1.0 + 1e-12) };
    let model = || Discretized::rk4(Oscillator2DofLoad::new(case.chain()), 1);
    let mut filters: Vec<Box<dyn StateEstimator>> = vec![
        Box::new(CubatureKalman::cubature(model(), tuning.noise(), &prior).expect("CKF")),
        Box::new(SquareRootCubature::new(model(), tuning.noise(), &prior).expect("SRCKF")),
        Box::new(CubatureKalman::cubature(model(), tuning.noise(), &nudged).expect("CKF, nudged prior")),
    ];
    let dt = settings.dt();
    let per_window = (5.0 / dt).round() as usize;
    println!("S1 {name}: largest |ΔF| (N) in each 5 s window");
    println!("{:>8}  {:>14}  {:>26}", "until", "CKF − SRCKF", "CKF − CKF(P₀·(1 + 1e-12))");
    let (mut worst_sr, mut worst_nudged) = (0.0_f64, 0.0_f64);
    for (k, z) in measurements.acceleration.iter().enumerate() {
        let loads: Vec<f64> = filters
            .iter_mut()
            .map(|f| {
                // The measurement at t = 0 updates the prior; later ones follow a predict.
                let predicted = if k == 0 { Ok(()) } else { f.predict(&[], dt) };
                predicted.and_then(|_| f.update(z).map(|_| ())).expect("the filters run through S1");
                f.mean()[Oscillator2DofLoad::LOAD]
            })
            .collect();
        worst_sr = worst_sr.max((loads[0] - loads[1]).abs());
        worst_nudged = worst_nudged.max((loads[0] - loads[2]).abs());
        if k > 0 && k % per_window == 0 {
            println!("{:>7.0}s  {:>14.2e}  {:>26.2e}", k as f64 * dt, worst_sr, worst_nudged);
            (worst_sr, worst_nudged) = (0.0, 0.0);
        }
    }
}
