//! A tuning probe of S2, in-process and quick: each case simulated
//! on the as-built car (`s2::study`), sampled at RATE Hz with 2 % sensor noise, and the
//! SRCKF on the user's 24-state model with the study's tuning, its force intensity set to
//! Q_INTENSITY (N²/s). Prints, per case and wheel, the correlation, the RMSE after 0.5 s and
//! its ratio to the force's dynamic standard deviation.
//!
//!   cargo run --release -p studies --example s2_explore -- [RATE] [Q_INTENSITY]

use estimator::FilterKind;
use studies::s2::study::{run_filter, score, user_vehicle, Tuning};
use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
use truth::s2::parameters::Vehicle;

fn main() {
    let mut args = std::env::args().skip(1);
    let rate: f64 = args.next().map_or(1000.0, |s| s.parse().expect("RATE in Hz"));
    let intensity: Option<f64> = args.next().map(|s| s.parse().expect("Q_INTENSITY in N²/s"));
    let settings = Settings { rate, ..Settings::default() };
    let vehicle = user_vehicle(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load());
    for case in Case::ALL {
        let truth = simulate(case, &settings);
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let mut tuning = Tuning::new(&settings, measurements.noise_std);
        if let Some(q) = intensity {
            tuning.force_intensity = q;
        }
        let estimates = match run_filter(FilterKind::SrCkf, vehicle, &tuning, &measurements) {
            Ok(e) => e,
            Err(e) => {
                println!("{}: failed at {e}", case.name());
                continue;
            }
        };
        for (j, s) in score(&truth, &estimates, rate, 0.5).iter().enumerate() {
            println!(
                "{:<12} wheel {}: corr {:.4}, RMSE {:.3} kN, dynamic std {:.3} kN, RMSE/std {:.2}, final σ {:.0} N",
                case.name(),
                j + 1,
                s.correlation,
                s.rmse / 1e3,
                s.dynamic_std / 1e3,
                s.rmse / s.dynamic_std,
                estimates.std.last().expect("a sample")[j]
            );
        }
    }
}
