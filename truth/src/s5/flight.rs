//! S5's flight as the paper flies it: the missile of the study, the standard manoeuvre,
//! sampled every 5 ms with each sensor's noise; or another manoeuvre by name
//! ([`simulate_named`], [`flight_with`]: `roll-turn`, one the estimators were not tuned on).

use estimator::models::Airframe;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::manoeuvre::Manoeuvre;
use super::parameters::{start, AFTER, BEFORE, SENSOR_STD};
use super::plant::{Flight, FlyingPlant, Motion};
use crate::sensor_noise::SensorNoise;

/// How to run the study.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Sample time (s): 5 ms, the paper's T.
    pub sample_time: f64,
    /// RK4 steps of the truth per sample.
    pub truth_substeps: usize,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The sensors' noise scaled by this (1: [`SENSOR_STD`]).
    pub noise_scale: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Self { sample_time: 0.005, truth_substeps: 10, seed: 1, noise_scale: 1.0 }
    }
}

/// The truth at the sample times.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Truth {
    /// Sample times (s), from 0.
    pub time: Vec<f64>,
    /// The motion states.
    pub motion: Vec<Motion>,
    /// The coefficients in force over each sample interval.
    pub coefficients: Vec<[f64; 10]>,
    /// The deflections held over each sample interval (rad).
    pub deflections: Vec<[f64; 3]>,
    /// The twelve measurements, noise-free.
    pub measurements: Vec<[f64; 12]>,
}

/// The missile of the study flying the standard manoeuvre.
pub fn flight() -> Flight {
    Flight { airframe: Airframe::tactical_missile(), coefficients: [BEFORE, AFTER], manoeuvre: Manoeuvre::standard() }
}

/// The missile of the study flying `manoeuvre` (e.g. [`Manoeuvre::roll_turn`], or one of
/// [`Manoeuvre::named`]), its coefficients changing at the manoeuvre's `change_at`.
pub fn flight_with(manoeuvre: Manoeuvre) -> Flight {
    Flight { manoeuvre, ..flight() }
}

/// Flies the study's missile through the manoeuvre of that name from the study's start
/// and samples it: [`simulate`] for `standard`.
pub fn simulate_named(name: &str, settings: &Settings) -> Result<Truth, String> {
    simulate_flight(&flight_with(Manoeuvre::named(name)?), settings)
}

/// Flies the study's flight and samples it.
pub fn simulate(settings: &Settings) -> Truth {
    simulate_flight(&flight(), settings).expect("the study's flight stays finite (tests/s5_truth.rs)")
}

/// Flies `flight` from the study's start and samples it: the [`FlyingPlant`] stepped
/// sample by sample, each sample's coefficients and deflections those of the RK4 step that
/// starts it (those of the whole sample interval when, as in the studies' manoeuvres, they
/// change on the sample grid). Refused for a flight that diverges.
pub fn simulate_flight(flight: &Flight, settings: &Settings) -> Result<Truth, String> {
    let samples = (flight.manoeuvre.duration / settings.sample_time).round() as usize;
    let h = settings.sample_time / settings.truth_substeps as f64;
    let mut plant = FlyingPlant::new(flight.clone(), start(), h, None)?;
    let mut truth = Truth::default();
    for k in 0..=samples {
        if k > 0 {
            plant.advance(settings.truth_substeps)?;
        }
        truth.time.push(k as f64 * settings.sample_time);
        truth.motion.push(plant.motion());
        truth.coefficients.push(*plant.coefficients());
        truth.deflections.push(plant.deflections());
        truth.measurements.push(plant.measurements());
    }
    Ok(truth)
}

/// The sensors' noise of `seed` on the twelve measurements, of standard deviations `std`:
/// the stream [`measure`] draws from.
pub fn sensor_noise(seed: u64, std: [f64; 12]) -> SensorNoise<12> {
    SensorNoise::new(ChaCha8Rng::seed_from_u64(seed ^ 0x5555_0005), std)
}

/// Adds each sensor's seeded white noise (`SENSOR_STD` × `scale`).
pub fn measure(truth: &Truth, scale: f64, seed: u64) -> Vec<[f64; 12]> {
    let mut noise = sensor_noise(seed, SENSOR_STD.map(|s| scale * s));
    truth.measurements.iter().map(|&z| noise.measure(z)).collect()
}
