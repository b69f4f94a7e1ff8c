//! The S5 study: the flight sampled every 5 ms with each sensor's noise, the filter set
//! up once for every filter kind, and the coefficients scored against the truth before and
//! after the change.

use estimator::models::{Airframe, Missile6Dof};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::manoeuvre::Manoeuvre;
use super::parameters::{start, AFTER, BEFORE, SENSOR_STD};
use super::plant::{Flight, Motion};

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

/// Flies the study's flight and samples it.
pub fn simulate(settings: &Settings) -> Truth {
    simulate_flight(&flight(), settings)
}

/// Flies `flight` from the study's start and samples it.
pub fn simulate_flight(flight: &Flight, settings: &Settings) -> Truth {
    let motion = flight.fly(&start(), settings.sample_time, settings.truth_substeps);
    let mut truth = Truth::default();
    for (k, x) in motion.into_iter().enumerate() {
        let c = *flight.coefficients_over(k, settings.sample_time);
        let delta = flight.manoeuvre.held(k, settings.sample_time);
        let mut z = [0.0; 12];
        flight.airframe.measure(&x, &c, &delta, &mut z);
        truth.time.push(k as f64 * settings.sample_time);
        truth.motion.push(x);
        truth.coefficients.push(c);
        truth.deflections.push(delta);
        truth.measurements.push(z);
    }
    truth
}

/// Adds each sensor's seeded white noise (`SENSOR_STD` × `scale`).
pub fn measure(truth: &Truth, scale: f64, seed: u64) -> Vec<[f64; 12]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5555_0005);
    truth
        .measurements
        .iter()
        .map(|z| {
            std::array::from_fn(|i| {
                let e: f64 = StandardNormal.sample(&mut rng);
                z[i] + scale * SENSOR_STD[i] * e
            })
        })
        .collect()
}

/// The filter set-up, one for every filter kind and both halves of the flight.
///
/// - `R` from the sensors' noise (the paper's eq. (18) has zeros on its diagonal).
/// - The motion states' process noise is small: the model is the truth's up to the
///   integration step (RK4 at 5 ms against 0.5 ms).
/// - The coefficients are random walks of 5e-5 of their magnitude per sample: a change is
///   caught by the supervisor's re-acquisition (the gate rejects the overloads the old
///   coefficients cannot explain, then inflates the covariance), not by a large random walk,
///   which would drown the small coefficients (`examples/s5_explore.rs`: with 2e-3, C_z^δ
///   stayed 13 % off; with 5e-5 every coefficient is within 0.2 % before and after the
///   change, and back within 3 % 0.4 s after it).
/// - The prior: the motion from the navigation system at launch (V within 5 m/s, angles
///   within 0.01 rad, h within 10 m); the coefficients a wind-tunnel estimate 20 % off with a
///   σ of 30 % (and 0.02 at least).
#[derive(Debug, Clone, PartialEq)]
pub struct Tuning {
    /// Process noise std per sample of the velocities (m/s), angles (rad), altitude (m)
    /// and rates (rad/s).
    pub motion_std: [f64; 4],
    /// Process noise std per sample of each coefficient, relative to its prior magnitude.
    pub coefficient_relative_std: f64,
    /// The sensors' noise std.
    pub sensor_std: [f64; 12],
    /// The prior mean.
    pub prior_mean: [f64; 20],
    /// The prior std.
    pub prior_std: [f64; 20],
}

impl Tuning {
    /// The study's set-up for sensors of noise `SENSOR_STD × noise_scale`.
    pub fn new(noise_scale: f64) -> Self {
        let mut prior_mean = [0.0; 20];
        prior_mean[..10].copy_from_slice(&start());
        let mut prior_std = [0.0; 20];
        prior_std[..10].copy_from_slice(&[5.0, 5.0, 5.0, 0.01, 0.01, 0.01, 10.0, 0.01, 0.01, 0.01]);
        for i in 0..10 {
            prior_mean[10 + i] = 1.2 * BEFORE[i];
            prior_std[10 + i] = (0.3 * BEFORE[i].abs()).max(0.02);
        }
        Self {
            motion_std: [1e-3, 1e-6, 1e-3, 1e-6],
            coefficient_relative_std: 5e-5,
            sensor_std: SENSOR_STD.map(|s| s * noise_scale),
            prior_mean,
            prior_std,
        }
    }

    /// `Q` and `R` in the state order of [`Missile6Dof`].
    pub fn noise(&self) -> estimator::Noise {
        let [v, angle, h, rate] = self.motion_std;
        let mut q = vec![v * v, v * v, v * v, angle * angle, angle * angle, angle * angle, h * h, rate * rate];
        q.extend([rate * rate; 2]);
        for i in 0..10 {
            let s = self.coefficient_relative_std * self.prior_mean[10 + i].abs().max(0.05);
            q.push(s * s);
        }
        let r: Vec<f64> = self.sensor_std.iter().map(|s| s * s).collect();
        estimator::Noise::diagonal(&q, &r).expect("the S5 tuning is a valid covariance pair")
    }

    /// The prior.
    pub fn prior(&self) -> estimator::Gaussian {
        estimator::Gaussian::diagonal(&self.prior_mean, &self.prior_std.map(|s| s * s))
    }
}

/// One filter's coefficient estimates, sample by sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Estimates {
    /// The coefficients.
    pub coefficients: Vec<[f64; 10]>,
    /// Their standard deviations.
    pub std: Vec<[f64; 10]>,
    /// Measurement rows the supervisor's gate left out.
    pub rejected: u64,
    /// The supervisor's health after each sample: consistent and not lost.
    pub healthy: Vec<bool>,
    /// The coefficients' covariance at the samples asked for (`checkpoints`).
    pub covariance_at: Vec<(usize, nalgebra::DMatrix<f64>)>,
}

/// Runs the filter of `kind` (RK4 once per sample) over `measurements`, behind the
/// supervisor with its default settings, as the FMU runs it; keeps the coefficients'
/// covariance at the samples `checkpoints`.
pub fn run_filter(
    kind: estimator::FilterKind,
    tuning: &Tuning,
    truth: &Truth,
    measurements: &[[f64; 12]],
    sample_time: f64,
    checkpoints: &[usize],
) -> Result<Estimates, String> {
    let supervision = estimator::SupervisorSettings::default();
    run_supervised(kind, tuning, truth, measurements, sample_time, checkpoints, supervision)
}

/// [`run_filter`] behind a supervisor with these settings.
pub fn run_supervised(
    kind: estimator::FilterKind,
    tuning: &Tuning,
    truth: &Truth,
    measurements: &[[f64; 12]],
    sample_time: f64,
    checkpoints: &[usize],
    supervision: estimator::SupervisorSettings,
) -> Result<Estimates, String> {
    let model = estimator::Discretized::rk4(Missile6Dof { airframe: Airframe::tactical_missile() }, 1);
    let unscented = estimator::UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 };
    let mut filter = estimator::build_filter(kind, model, tuning.noise(), &tuning.prior(), unscented)
        .map_err(|e| format!("setup: {e}"))?;
    let mut supervisor = estimator::Supervisor::new(supervision, 12).map_err(|e| format!("setup: {e}"))?;
    let mut estimates = Estimates::default();
    for (k, z) in measurements.iter().enumerate() {
        // The deflections held over the last interval drive the prediction to this
        // sample; those of this sample are what it is measured with (the overloads).
        let predicted = if k == 0 { Ok(()) } else { filter.predict(&truth.deflections[k - 1], sample_time) };
        predicted
            .and_then(|_| filter.hold_input(&truth.deflections[k]))
            .and_then(|_| supervisor.gate(filter.as_mut(), z).map(|_| ()))
            .map_err(|e| format!("t = {:.3} s (sample {k}): {e}", truth.time[k]))?;
        supervisor.commit(|_| {});
        estimates.healthy.push(supervisor.healthy());
        let c = Missile6Dof::COEFFICIENTS;
        estimates.coefficients.push(std::array::from_fn(|i| filter.mean()[c + i]));
        estimates.std.push(std::array::from_fn(|i| filter.variance(c + i).max(0.0).sqrt()));
        if checkpoints.contains(&k) {
            estimates.covariance_at.push((k, filter.covariance().view((c, c), (10, 10)).into_owned()));
        }
    }
    estimates.rejected = supervisor.rejected();
    Ok(estimates)
}
