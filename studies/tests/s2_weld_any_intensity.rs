//! The weld is never locked out, whatever the forces' noise intensity a user sets: from a
//! thousandth of the default to ten times it, no measurement row is rejected, every wheel
//! follows the truth through the impact, and where the impact is not yet told from a
//! spike (one axle box alone shows it, for one sample) the σ shown covers the error.

use analyzer::metrics::correlation;
use estimator::FilterKind;
use studies::s2::study::{run_filter, user_vehicle, Tuning};
use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
use truth::s2::parameters::Vehicle;

#[test]
fn the_weld_is_followed_at_every_force_intensity_and_never_rejected() {
    let settings = Settings { duration: 2.5, seed: 5, ..Settings::default() };
    let truth = simulate(Case::Weld, &settings);
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    let vehicle = user_vehicle(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load());
    let default = Tuning::new(&settings, measurements.noise_std);
    let skip = 500;
    for factor in [1e-3, 1e-2, 1e-1, 1.0, 10.0] {
        let tuning = Tuning { force_intensity: default.force_intensity * factor, ..default.clone() };
        let q = tuning.force_intensity;
        let estimates = run_filter(FilterKind::SrCkf, vehicle, &tuning, &measurements).unwrap();
        assert_eq!(estimates.rejected, 0, "intensity {q:e}: rows rejected");
        for j in 0..4 {
            let t: Vec<f64> = truth.contact[skip..].iter().map(|c| c[j]).collect();
            let e: Vec<f64> = estimates.forces[skip..].iter().map(|f| f[j]).collect();
            let worst = (skip..truth.contact.len())
                .map(|k| (estimates.forces[k][j] - truth.contact[k][j]).abs() / estimates.std[k][j])
                .fold(0.0, f64::max);
            assert!(worst < 3.0, "intensity {q:e} wheel {}: an error of {worst:.1}σ", j + 1);
            // The samples whose σ is the two hypotheses' mixture, wider than the rest: the
            // impacts, each shown for one sample between a step and a spike.
            let std: Vec<f64> = estimates.std[skip..].iter().map(|s| s[j]).collect();
            let mut sorted = std.clone();
            sorted.sort_by(f64::total_cmp);
            let wide_from = 5.0 * sorted[sorted.len() / 2];
            let wide = std.iter().filter(|s| **s >= wide_from).count();
            assert!(wide <= 4, "intensity {q:e} wheel {}: {wide} samples undecided", j + 1);
            let (t, e): (Vec<f64>, Vec<f64>) =
                t.iter().zip(&e).zip(&std).filter(|(_, s)| **s < wide_from).map(|((a, b), _)| (*a, *b)).unzip();
            let c = correlation(&t, &e);
            assert!(c > 0.999, "intensity {q:e} wheel {}: correlation {c} outside the undecided samples", j + 1);
        }
    }
}
