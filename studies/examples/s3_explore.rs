//! A probe of S3, in-process: each case of `truth::s3` at 80 km/h and 1 kHz with 2 %
//! sensor noise (seed SEED), the SRCKF on the catalogue car with the paper's random-walk
//! forces and with forces returning to the static load at RATE /s (by default the
//! study's, `Tuning::FORCE_RETURN_RATE`), each with the
//! accelerations alone and with the primary deflections. Prints per configuration the
//! worst wheelset's correlations of left, right, sum and difference, wheelset 1's left
//! RMSE, and the lowest 2σ coverage of left, right and difference. The environment varies the tuning: FORCE_INTENSITY (N²/s, the forces'
//! noise, by default `Tuning::FORCE_INTENSITY`), MOTION_SCALE (a factor on the motion states' noise), DEFLECTION_R_SCALE (a
//! factor on the deflection transducers' σ); SERIES prints the twist's forces every 0.25 s
//! with the deflections.
//!
//!   cargo run --release -p studies --example s3_explore -- [SEED] [RATE …]

use estimator::FilterKind;
use studies::s3::study::{run_filter, score, user_vehicle, ForceModel, Sensors, Tuning};
use truth::s3::cases::{measure, simulate, Case, Settings};

fn main() {
    let mut args = std::env::args().skip(1);
    let seed: u64 = args.next().map_or(1, |s| s.parse().expect("SEED"));
    let mut rates: Vec<f64> = args.map(|s| s.parse().expect("RATE in 1/s")).collect();
    if rates.is_empty() {
        rates.push(Tuning::FORCE_RETURN_RATE);
    }
    let settings = Settings { seed, ..Settings::default() };
    let mut models = vec![ForceModel::RandomWalk];
    models.extend(rates.iter().map(|&r| ForceModel::Returning(r)));
    for case in Case::ALL {
        let truth = simulate(case, &settings).expect("the default settings run");
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        for &forces in &models {
            for sensors in [Sensors::Accelerations, Sensors::WithDeflections] {
                let mut tuning = Tuning::new(&settings, &measurements, forces);
                let env = |n: &str| std::env::var(n).ok().map(|v| v.parse::<f64>().expect(n));
                if let Some(q) = env("FORCE_INTENSITY") {
                    tuning.force_intensity = q;
                }
                if let Some(s) = env("MOTION_SCALE") {
                    tuning.body_std *= s;
                    tuning.wheelset_std *= s;
                }
                if let Some(s) = env("DEFLECTION_R_SCALE") {
                    tuning.deflection_std = tuning.deflection_std.map(|d| d * s);
                }
                if let Some(floor) = env("DEFLECTION_FLOOR") {
                    tuning.deflection_std = tuning.deflection_std.map(|d| d.hypot(floor));
                }
                let label = format!("{:<17} {:<22} {:<14}", case.to_string(), forces.label(), sensors.label());
                let vehicle = user_vehicle(settings.vehicle.static_wheel_load());
                match run_filter(FilterKind::SrCkf, vehicle, &tuning, &measurements, sensors) {
                    Err(e) => println!("{label} failed: {e}"),
                    Ok(estimates) => {
                        let s = score(&truth, &estimates, settings.rate, 0.5);
                        if std::env::var("SERIES").is_ok() && case == Case::Twist && sensors == Sensors::WithDeflections
                        {
                            for k in (0..truth.time.len()).step_by(250) {
                                let (t, e) = (&truth.contact[k], &estimates.forces[k]);
                                println!("t {:.2} true L1 {:.0} R1 {:.0} L4 {:.0} R4 {:.0} | est L1 {:.0} R1 {:.0} L4 {:.0} R4 {:.0}", truth.time[k], t[0], t[4], t[3], t[7], e[0], e[4], e[3], e[7]);
                            }
                        }
                        let worst = |f: &dyn Fn(&studies::s3::study::WheelsetScore) -> f64| {
                            s.iter().map(f).fold(f64::INFINITY, f64::min)
                        };
                        println!(
                            "{label} L {:.3} R {:.3} sum {:.4} diff {:.3}  L1 RMSE {:.3} kN  rejected {}  \
                             2σ min L {:.2} R {:.2} diff {:.2}",
                            worst(&|w| w.left.correlation),
                            worst(&|w| w.right.correlation),
                            worst(&|w| w.sum.correlation),
                            worst(&|w| w.difference.correlation),
                            s[0].left.rmse / 1e3,
                            estimates.rejected,
                            worst(&|w| w.left.two_sigma_coverage),
                            worst(&|w| w.right.two_sigma_coverage),
                            worst(&|w| w.difference.two_sigma_coverage),
                        );
                    }
                }
            }
        }
    }
}
