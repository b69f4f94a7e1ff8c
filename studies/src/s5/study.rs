//! The S5 study: the filter set up once for every filter kind, run in-process behind the
//! supervised loop, the coefficients scored against the truth before and after the change.

use estimator::models::{Airframe, Missile6Dof};
use estimator::UnscentedParams;
use start_values::SetByName;
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
    /// The UKF's spread: α = 1, β = 2, κ = 0 in every study's runs (λ = 0: the cubature
    /// rule's 2n points, and a centre point with no weight in the mean).
    pub unscented: UnscentedParams,
    /// RK4 steps of the filter's model per sample: 1.
    pub rk4_substeps: usize,
}

/// The FMU's parameter of each sensor's noise, in the measurements' order
/// ([`Missile6Dof::MEASUREMENT_NAMES`]: `r_<measurement>_std`).
pub const SENSOR_NOISE_PARAMETERS: [&str; 12] = [
    "r_omega_x_std",
    "r_omega_y_std",
    "r_omega_z_std",
    "r_Nx_std",
    "r_Ny_std",
    "r_Nz_std",
    "r_phi_std",
    "r_psi_std",
    "r_gamma_std",
    "r_h_std",
    "r_alpha_std",
    "r_beta_std",
];

/// The FMU's parameter of each state's prior mean, in the state's order
/// ([`Missile6Dof::STATE_NAMES`]: `prior_<state>`).
pub const PRIOR_PARAMETERS: [&str; 20] = [
    "prior_Vx",
    "prior_Vy",
    "prior_Vz",
    "prior_phi",
    "prior_psi",
    "prior_gamma",
    "prior_h",
    "prior_omega_x",
    "prior_omega_y",
    "prior_omega_z",
    "prior_Cx0",
    "prior_Cx_a",
    "prior_Cx_b",
    "prior_Cx_d",
    "prior_Cy0",
    "prior_Cy_a",
    "prior_Cy_d",
    "prior_Cz0",
    "prior_Cz_b",
    "prior_Cz_d",
];

/// The FMU's parameter of each state's prior std (`prior_<state>_std`).
pub const PRIOR_STD_PARAMETERS: [&str; 20] = [
    "prior_Vx_std",
    "prior_Vy_std",
    "prior_Vz_std",
    "prior_phi_std",
    "prior_psi_std",
    "prior_gamma_std",
    "prior_h_std",
    "prior_omega_x_std",
    "prior_omega_y_std",
    "prior_omega_z_std",
    "prior_Cx0_std",
    "prior_Cx_a_std",
    "prior_Cx_b_std",
    "prior_Cx_d_std",
    "prior_Cy0_std",
    "prior_Cy_a_std",
    "prior_Cy_d_std",
    "prior_Cz0_std",
    "prior_Cz_b_std",
    "prior_Cz_d_std",
];

/// The FMU's parameters of the motion states' process noise, in [`Tuning::motion_std`]'s
/// order.
pub const MOTION_NOISE_PARAMETERS: [&str; 4] = ["q_velocity_std", "q_angle_std", "q_altitude_std", "q_rate_std"];

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
            unscented: UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 },
            rk4_substeps: 1,
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

impl SetByName for Tuning {
    /// Whether [`Tuning::set`] takes `name`: every FMU parameter `fmu_run::parameters` and
    /// `fmu_run::integers` write from a tuning (the flight's `sample_time` aside).
    fn takes(name: &str) -> bool {
        SENSOR_NOISE_PARAMETERS.contains(&name)
            || PRIOR_PARAMETERS.contains(&name)
            || PRIOR_STD_PARAMETERS.contains(&name)
            || MOTION_NOISE_PARAMETERS.contains(&name)
            || ["q_coefficient_relative_std", "ukf_alpha", "ukf_beta", "ukf_kappa", "rk4_substeps"].contains(&name)
    }

    /// Sets the FMU parameter `name` to `value` as the in-process filter has it, so that
    /// `fmu_run::parameters` (or `fmu_run::integers`) then writes `value` for it. An error
    /// names what is wrong: a name the tuning does not have (the airframe's, the
    /// supervisor's, `filter`, `sample_time`, … are the FMU's only), or a value the FMU
    /// would refuse too (not finite, a negative σ, a number of RK4 steps that is not a
    /// positive integer).
    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if name == "sample_time" {
            return Err("sample_time is the flight's sample time (its measurements' clock), not a tuning".into());
        }
        if !Self::takes(name) {
            return Err(format!(
                "'{name}' is not a parameter the in-process S5 filter takes (it takes r_<measurement>_std, \
                 prior_<state>, prior_<state>_std, {}, q_coefficient_relative_std, ukf_alpha, ukf_beta, ukf_kappa, \
                 rk4_substeps)",
                MOTION_NOISE_PARAMETERS.join(", ")
            ));
        }
        if !value.is_finite() {
            return Err(format!("{name} = {value}: not a finite number"));
        }
        let index = |names: &[&str]| names.iter().position(|&n| n == name);
        if let Some(i) = index(&PRIOR_PARAMETERS) {
            self.prior_mean[i] = value;
            return Ok(());
        }
        match name {
            "ukf_alpha" => self.unscented.alpha = value,
            "ukf_beta" => self.unscented.beta = value,
            "ukf_kappa" => self.unscented.kappa = value,
            "rk4_substeps" => {
                if value < 1.0 || value.fract() != 0.0 || value > u32::MAX as f64 {
                    return Err(format!("rk4_substeps = {value}: not a positive integer"));
                }
                self.rk4_substeps = value as usize;
            }
            _ => {
                if value < 0.0 {
                    return Err(format!("{name} = {value}: a σ is not negative"));
                }
                let slot = if let Some(i) = index(&SENSOR_NOISE_PARAMETERS) {
                    &mut self.sensor_std[i]
                } else if let Some(i) = index(&PRIOR_STD_PARAMETERS) {
                    &mut self.prior_std[i]
                } else if let Some(i) = index(&MOTION_NOISE_PARAMETERS) {
                    &mut self.motion_std[i]
                } else {
                    &mut self.coefficient_relative_std
                };
                *slot = value;
            }
        }
        Ok(())
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
    let model =
        estimator::Discretized::rk4(Missile6Dof { airframe: Airframe::tactical_missile() }, tuning.rk4_substeps);
    let filter = estimator::build_filter(kind, model, tuning.noise(), &tuning.prior(), tuning.unscented)
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
