//! The S2 study's pieces: the user's vehicle is not the truth's, the noise is what it says,
//! and the SRCKF on the user's model follows the truth's forces through a weld.

use analyzer::metrics::correlation;
use estimator::FilterKind;
use studies::s2::study::{run_filter, user_vehicle, Tuning};
use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
use truth::s2::parameters::Vehicle;

#[test]
fn the_users_vehicle_is_the_catalogue_not_the_car_as_built() {
    let (catalogue, built) = (Vehicle::ZHAI_PASSENGER, as_built());
    assert!(built.car_body_mass > 1.05 * catalogue.car_body_mass);
    assert!(built.primary_stiffness > 1.04 * catalogue.primary_stiffness);
    let user = user_vehicle(&catalogue, built.static_wheel_load());
    assert_eq!(user.car_body_mass, catalogue.car_body_mass / 2.0);
    assert_eq!(user.primary_stiffness, catalogue.primary_stiffness);
    // The one measured number: the static wheel load, from a weighbridge.
    assert_eq!(user.static_wheel_load, built.static_wheel_load());
}

#[test]
fn the_measurements_carry_the_stated_noise() {
    let settings = Settings { duration: 2.0, ..Settings::default() };
    let truth = simulate(Case::Random, &settings);
    assert_eq!(truth.time.len(), 2001);
    assert_eq!(truth.time[1], 1e-3);
    let measurements = measure(&truth, 0.02, 3);
    for ch in 0..7 {
        let n = truth.accelerations.len() as f64;
        let rms = (truth.accelerations.iter().map(|a| a[ch] * a[ch]).sum::<f64>() / n).sqrt();
        assert!((measurements.noise_std[ch] - 0.02 * rms).abs() < 1e-12 * rms);
        let noise: Vec<f64> =
            measurements.accelerations.iter().zip(&truth.accelerations).map(|(z, a)| z[ch] - a[ch]).collect();
        let std = (noise.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        assert!((std / measurements.noise_std[ch] - 1.0).abs() < 0.1, "channel {ch}: {std}");
    }
    assert_eq!(measure(&truth, 0.02, 3), measurements, "seeded");
}

#[test]
fn the_srckf_on_the_users_model_follows_every_wheel_through_a_weld_at_1_khz() {
    let settings = Settings::default();
    let truth = simulate(Case::Weld, &settings);
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    let vehicle = user_vehicle(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load());
    let estimates =
        run_filter(FilterKind::SrCkf, vehicle, &Tuning::new(&settings, measurements.noise_std), &measurements).unwrap();
    let skip = 500;
    for j in 0..4 {
        let t: Vec<f64> = truth.contact[skip..].iter().map(|c| c[j]).collect();
        let e: Vec<f64> = estimates.forces[skip..].iter().map(|f| f[j]).collect();
        let c = correlation(&t, &e);
        assert!(c > 0.98, "wheel {}: correlation {c}", j + 1);
    }
}

#[test]
fn every_filter_kind_runs_the_24_state_model() {
    let settings = Settings { duration: 2.0, ..Settings::default() };
    let truth = simulate(Case::Corrugation, &settings);
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    let vehicle = user_vehicle(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load());
    let tuning = Tuning::new(&settings, measurements.noise_std);
    for kind in FilterKind::ALL {
        let estimates = run_filter(kind, vehicle, &tuning, &measurements).unwrap_or_else(|e| panic!("{kind}: {e}"));
        let t: Vec<f64> = truth.contact[500..].iter().map(|c| c[0]).collect();
        let e: Vec<f64> = estimates.forces[500..].iter().map(|f| f[0]).collect();
        let c = correlation(&t, &e);
        assert!(c > 0.99, "{kind}: correlation {c}");
    }
}
