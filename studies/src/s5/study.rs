//! The S5 study: the filter set up once for every filter kind, run in-process behind the
//! supervised loop, the coefficients scored against the truth before and after the change.

use estimator::models::{Airframe, Missile6Dof};
use truth::s5::flight::Truth;
use truth::s5::parameters::{start, BEFORE, SENSOR_STD};

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
    let filter = estimator::build_filter(kind, model, tuning.noise(), &tuning.prior(), unscented)
        .map_err(|e| format!("setup: {e}"))?;
    let unknown_inputs = &estimator::models::Missile6Dof::UNKNOWN_INPUTS;
    let supervisor = estimator::Supervisor::new(supervision, 12)
        .and_then(|s| s.with_jump_states(filter.state_dim(), unknown_inputs))
        .map_err(|e| format!("setup: {e}"))?;
    let mut supervised = estimator::SupervisedFilter::new(filter, supervisor).map_err(|e| format!("setup: {e}"))?;
    let mut estimates = Estimates::default();
    // The deflections held over the last interval drive the prediction to a sample; those
    // of the sample are what it is measured with (the overloads).
    let samples = measurements
        .iter()
        .zip(&truth.deflections)
        .zip(&truth.time)
        .map(|((z, controls), &time)| estimator::Sample { time, z, controls });
    let c = Missile6Dof::COEFFICIENTS;
    supervised
        .run(sample_time, samples, |step| {
            estimates.healthy.push(step.supervisor.healthy());
            estimates.coefficients.push(std::array::from_fn(|i| step.filter.mean()[c + i]));
            estimates.std.push(std::array::from_fn(|i| step.filter.variance(c + i).max(0.0).sqrt()));
            if checkpoints.contains(&step.index) {
                estimates
                    .covariance_at
                    .push((step.index, step.filter.covariance().view((c, c), (10, 10)).into_owned()));
            }
        })
        .map_err(|e| e.to_string())?;
    estimates.rejected = supervised.supervisor().rejected();
    Ok(estimates)
}
