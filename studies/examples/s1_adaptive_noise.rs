//! The sensor noise learnt online (`estimator::SageHusa`) on S1: the SRCKF
//! behind the supervisor, with the accelerometers' `R` told right, 10 times
//! too small and 10 times too large, each with and without the Sage–Husa
//! estimate (forgetting 0.995). Prints the load's correlation and RMSE after
//! convergence, the gate's rejections, and the learnt `R` over the true one.
//!
//! ```text
//! cargo run --release -p studies --example s1_adaptive_noise [-- CASE]
//! ```

use analyzer::metrics::compare;
use estimator::models::Oscillator2DofLoad;
use estimator::{FilterKind, Noise, SageHusa, Supervisor, SupervisorSettings};
use studies::s1::Tuning;
use truth::s1::{simulate, Case, Settings};

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "stiffness/random".into());
    let case: Case = name.parse().unwrap_or_else(|e: String| panic!("{e}"));
    let settings = Settings::default();
    let (truth, measurements) = simulate(&case, &settings);
    let tuning = Tuning::new(&settings, measurements.noise_std);
    let right = tuning.noise();
    let true_r: Vec<f64> = measurements.noise_std.iter().map(|s| s * s).collect();
    println!("S1 {case}, SRCKF behind the supervisor, 60 s; R told × scale, with and without Sage–Husa (b = 0.995)");
    println!(
        "{:>7} {:>6} {:>9} {:>10} {:>9} {:>22}",
        "R ×", "learn", "corr", "RMSE conv", "rejected", "learnt R / true R"
    );
    for scale in [0.1, 1.0, 10.0] {
        for learn in [false, true] {
            let told: Vec<f64> = true_r.iter().map(|r| r * scale).collect();
            let r = nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(&told));
            let noise = Noise::new(right.q().clone(), r).expect("a valid noise");
            let mut filter = tuning.filter(FilterKind::SrCkf, &case, noise).expect("the SRCKF");
            let mut supervisor = Supervisor::new(SupervisorSettings::default(), 2).expect("the supervisor");
            let mut sage_husa = SageHusa::new(&told, 0.995, 1e-3).expect("Sage–Husa");
            let mut load = Vec::with_capacity(measurements.acceleration.len());
            for (k, z) in measurements.acceleration.iter().enumerate() {
                if k > 0 {
                    filter.predict(&[], settings.dt()).expect("predict");
                }
                supervisor.gate(filter.as_mut(), z).expect("update");
                supervisor.commit(|_| {});
                if learn {
                    let variances = sage_husa.learn(filter.innovation());
                    filter.set_measurement_variances(variances).expect("variances");
                }
                load.push(filter.mean()[Oscillator2DofLoad::LOAD]);
            }
            let c = compare(&truth.load, &load, 0.0, settings.dt(), settings.rmse_window);
            let learnt = filter.noise().r();
            let ratio: Vec<String> = (0..2).map(|i| format!("{:.3}", learnt[(i, i)] / true_r[i])).collect();
            println!(
                "{scale:>7} {:>6} {:>9.5} {:>10.4} {:>9} {:>22}",
                if learn { "yes" } else { "no" },
                c.correlation,
                c.rmse_converged,
                supervisor.rejected(),
                ratio.join(", ")
            );
        }
    }
}
