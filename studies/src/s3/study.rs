//! S3's estimator set-up in-process: the user's catalogue car, the tuning, a filter run
//! behind the supervisor as the FMU runs it, and each wheel's score against the truth for
//! the left and right forces, their sum and their difference.
//!
//! Two force models ([`ForceModel`]): the paper's random walks, and forces that return to
//! the weighed static wheel load; two sensor sets ([`Sensors`]): the 20 accelerations, or
//! those and the eight primary deflections.

use estimator::models::{RollVehicle, WheelRailRoll};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, Sample, SupervisedFilter, Supervisor, SupervisorSettings,
    UnscentedParams,
};
use start_values::SetByName;
use truth::s3::cases::{Measurements, Settings, Truth, ACCELERATIONS, CONTACT, DEFLECTIONS};

/// How the estimator models the eight forces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ForceModel {
    /// Random walks, eq. (26) of `[Chen2025]`: the baseline.
    RandomWalk,
    /// Gauss–Markov processes returning to the static wheel load at this rate (1/s).
    Returning(f64),
}

impl ForceModel {
    /// The model's `force_return_rate`.
    pub fn rate(&self) -> f64 {
        match *self {
            ForceModel::RandomWalk => 0.0,
            ForceModel::Returning(r) => r,
        }
    }

    /// As a table prints it.
    pub fn label(&self) -> String {
        match *self {
            ForceModel::RandomWalk => "paper (random walk)".into(),
            ForceModel::Returning(r) => format!("ours (return {r} /s)"),
        }
    }
}

/// Which sensors the user has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensors {
    /// The 20 vertical accelerations.
    Accelerations,
    /// The accelerations and the eight primary deflections.
    WithDeflections,
}

impl Sensors {
    /// As a table prints it.
    pub fn label(&self) -> &'static str {
        match self {
            Sensors::Accelerations => "accelerations",
            Sensors::WithDeflections => "+ deflections",
        }
    }
}

/// The filter set-up: the process noise as in S2 (the motion states' per sample, the
/// forces' as an intensity), the sensors' noise as the data acquisition's specification.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuning {
    /// Process noise std per sample of the car body's and bogies' coordinates and rates.
    pub body_std: f64,
    /// … of the wheelsets' coordinates and rates.
    pub wheelset_std: f64,
    /// Intensity of the forces' noise (N²/s).
    pub force_intensity: f64,
    /// The force model.
    pub forces: ForceModel,
    /// The accelerometers' noise (m/s²), in the model's row order.
    pub acceleration_std: [f64; 20],
    /// The deflection transducers' noise (m), in the model's row order.
    pub deflection_std: [f64; 8],
    /// The model's error in the deflections (m), added to the transducers' noise in `R`.
    pub deflection_model_error: f64,
    /// Prior std of the 34 motion states.
    pub prior_motion_std: f64,
    /// Prior std of the forces about the static wheel load (N).
    pub prior_force_std: f64,
    /// Sample time (s).
    pub dt: f64,
}

impl Tuning {
    /// The truth's seed the tuning was chosen on: tables report the seeds after it.
    pub const CHOSEN_ON_SEED: u64 = 1;
    /// The car body's and bogies' process noise intensity: S2's (3e-5 per sample at 1 kHz).
    pub const BODY_INTENSITY: f64 = 9e-7;
    /// The wheelsets': S2's (1e-5 per sample at 1 kHz).
    pub const WHEELSET_INTENSITY: f64 = 1e-7;
    /// The forces' noise intensity (N²/s), with [`Tuning::FORCE_RETURN_RATE`] chosen on
    /// seed 1 (`examples/s3_explore.rs`): S2's 1e13, made for welds, lets the side-to-side
    /// patterns wander by kN; the FMU's default.
    pub const FORCE_INTENSITY: f64 = 1e9;
    /// The forces' return rate to the static wheel load (1/s) of [`ForceModel::Returning`]
    /// by default: the FMU's.
    pub const FORCE_RETURN_RATE: f64 = 5.0;
    /// The model's error in a primary deflection (m), chosen on seed 1
    /// (`examples/s3_explore.rs`, `DEFLECTION_FLOOR`): the truth's deflections carry the
    /// car as built, its track and its lateral motion, which the model has not, and 2 % of
    /// a deflection's RMS (tens of µm) made the gate reject thousands of rows and the
    /// filter trust the deflections over the accelerations; that σ ×3 to ×30
    /// (`DEFLECTION_R_SCALE`) still rejected hundreds of rows on the joint, a floor of 0.3,
    /// 1 and 3 mm none, and 0.3 mm separated the sides best. The FMU's default.
    pub const DEFLECTION_MODEL_ERROR: f64 = 3e-4;

    /// The set-up for `settings` and the recorded noise of `measurements` (the sensors'
    /// specification a user has from the datasheet), with `forces`.
    pub fn new(settings: &Settings, measurements: &Measurements, forces: ForceModel) -> Self {
        Self {
            body_std: (Self::BODY_INTENSITY / settings.rate).sqrt(),
            wheelset_std: (Self::WHEELSET_INTENSITY / settings.rate).sqrt(),
            force_intensity: Self::FORCE_INTENSITY,
            forces,
            acceleration_std: in_model_order(&ACCELERATIONS, &measurements.accelerations_noise_std, 0),
            deflection_std: in_model_order(&DEFLECTIONS, &measurements.deflections_noise_std, 20),
            deflection_model_error: Self::DEFLECTION_MODEL_ERROR,
            prior_motion_std: 0.1,
            prior_force_std: 0.1,
            dt: 1.0 / settings.rate,
        }
    }

    /// `Q` over a sample and `R`, in the model's orders.
    pub fn noise(&self) -> Result<Noise, String> {
        let mut q = Vec::with_capacity(42);
        for _ in 0..2 {
            q.extend([self.body_std.powi(2); 9]);
            q.extend([self.wheelset_std.powi(2); 8]);
        }
        q.extend([self.force_intensity * self.dt; 8]);
        // As the FMU sums them, to the last bit.
        let model_error = self.deflection_model_error * self.deflection_model_error;
        let deflections = self.deflection_std.iter().map(|s| s * s + model_error);
        let r: Vec<f64> = self.acceleration_std.iter().map(|s| s * s).chain(deflections).collect();
        Noise::diagonal(&q, &r).map_err(|e| e.to_string())
    }

    /// The prior: at rest, every wheel at the static load.
    pub fn prior(&self, vehicle: &RollVehicle) -> Gaussian {
        let mut mean = [0.0; 42];
        mean[WheelRailRoll::FORCES..].fill(vehicle.static_wheel_load);
        let mut variances = [self.prior_motion_std.powi(2); 42];
        variances[WheelRailRoll::FORCES..].fill(self.prior_force_std.powi(2));
        Gaussian::diagonal(&mean, &variances)
    }
}

/// The tuning's names for the FMU's parameters it has, besides the sensors'.
const NAMES: [&str; 7] = [
    "p0_motion_std",
    "p0_force_std",
    "q_body_std",
    "q_wheelset_std",
    "force_noise_intensity",
    "force_return_rate",
    "deflection_model_error",
];

/// The FMU's noise parameter of each sensor, `r_<input>_std`, in the model's row order.
pub const SENSOR_NOISE_PARAMETERS: [&str; 28] = [
    "r_a_ab_L1_std",
    "r_a_ab_R1_std",
    "r_a_ab_L2_std",
    "r_a_ab_R2_std",
    "r_a_ab_L3_std",
    "r_a_ab_R3_std",
    "r_a_ab_L4_std",
    "r_a_ab_R4_std",
    "r_a_bf_L1_std",
    "r_a_bf_R1_std",
    "r_a_bf_L2_std",
    "r_a_bf_R2_std",
    "r_a_bf_L3_std",
    "r_a_bf_R3_std",
    "r_a_bf_L4_std",
    "r_a_bf_R4_std",
    "r_a_cb_FL_std",
    "r_a_cb_FR_std",
    "r_a_cb_RL_std",
    "r_a_cb_RR_std",
    "r_d_p_L1_std",
    "r_d_p_R1_std",
    "r_d_p_L2_std",
    "r_d_p_R2_std",
    "r_d_p_L3_std",
    "r_d_p_R3_std",
    "r_d_p_L4_std",
    "r_d_p_R4_std",
];

impl Tuning {
    /// The same set-up as the estimator FMU's Real parameters (the sample time aside: it
    /// is the measurements' clock).
    pub fn fmu_parameters(&self) -> Vec<(&'static str, f64)> {
        let values = [
            self.prior_motion_std,
            self.prior_force_std,
            self.body_std,
            self.wheelset_std,
            self.force_intensity,
            self.forces.rate(),
            self.deflection_model_error,
        ];
        let mut p: Vec<(&'static str, f64)> = NAMES.into_iter().zip(values).collect();
        let sensors = self.acceleration_std.iter().chain(&self.deflection_std);
        p.extend(SENSOR_NOISE_PARAMETERS.into_iter().zip(sensors.copied()));
        p
    }
}

impl SetByName for Tuning {
    fn takes(name: &str) -> bool {
        NAMES.contains(&name) || SENSOR_NOISE_PARAMETERS.contains(&name)
    }

    /// Sets the FMU parameter `name` to `value` as the in-process filter has it. An error
    /// names what is wrong: a name the tuning does not have (the vehicle's, the static
    /// wheel load, the supervisor's, `sample_time` are the FMU's only), or a value the FMU
    /// would refuse too (not finite, negative). A `force_return_rate` of 0 is the paper's
    /// random walks.
    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if !Self::takes(name) {
            return Err(format!(
                "'{name}' is not a parameter the in-process S3 filter takes (it takes {} and r_<input>_std)",
                NAMES.join(", ")
            ));
        }
        if !value.is_finite() || value < 0.0 {
            return Err(format!("{name} = {value}: not a finite number of at least zero"));
        }
        match name {
            "p0_motion_std" => self.prior_motion_std = value,
            "p0_force_std" => self.prior_force_std = value,
            "q_body_std" => self.body_std = value,
            "q_wheelset_std" => self.wheelset_std = value,
            "force_noise_intensity" => self.force_intensity = value,
            "deflection_model_error" => self.deflection_model_error = value,
            "force_return_rate" => {
                self.forces = if value == 0.0 { ForceModel::RandomWalk } else { ForceModel::Returning(value) }
            }
            _ => {
                let row = SENSOR_NOISE_PARAMETERS.iter().position(|&n| n == name).expect("taken");
                if row < 20 {
                    self.acceleration_std[row] = value;
                } else {
                    self.deflection_std[row - 20] = value;
                }
            }
        }
        Ok(())
    }
}

/// The user's car: the catalogue's ([`RollVehicle::zhai_passenger`]) with the static wheel
/// load as weighed (N).
pub fn user_vehicle(weighed: f64) -> RollVehicle {
    RollVehicle { static_wheel_load: weighed, ..RollVehicle::zhai_passenger() }
}

/// The values of the truth's channels `names` (in the truth's order) in the model's row
/// order, starting at row `first` of [`WheelRailRoll::MEASUREMENT_NAMES`].
pub(crate) fn in_model_order<const N: usize>(names: &[&str; N], values: &[f64; N], first: usize) -> [f64; N] {
    std::array::from_fn(|row| {
        let name = WheelRailRoll::MEASUREMENT_NAMES[first + row];
        values[names.iter().position(|&n| n == name).expect("the truth records every sensor the model reads")]
    })
}

/// The truth's eight forces (in [`CONTACT`]'s order) in the model's
/// ([`WheelRailRoll::FORCE_NAMES`]: `F_NL1, F_NR1, F_NL2, …`).
pub(crate) fn forces_in_model_order(contact: &[f64; 8]) -> [f64; 8] {
    std::array::from_fn(|k| {
        contact[CONTACT.iter().position(|&n| n == WheelRailRoll::FORCE_NAMES[k]).expect("the same eight forces")]
    })
}

/// One filter's estimates of the eight forces in the truth's order ([`CONTACT`]), sample
/// by sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Estimates {
    /// The forces (N).
    pub forces: Vec<[f64; 8]>,
    /// Their standard deviations (N).
    pub std: Vec<[f64; 8]>,
    /// Each wheelset's `F_L + F_R` standard deviation (N), from the covariance.
    pub sum_std: Vec<[f64; 4]>,
    /// Each wheelset's `F_L − F_R` standard deviation (N), from the covariance.
    pub difference_std: Vec<[f64; 4]>,
    /// Measurement rows the gate left out.
    pub rejected: u64,
}

/// The state index of each of the truth's [`CONTACT`] forces.
fn contact_states() -> [usize; 8] {
    std::array::from_fn(|c| {
        let k = WheelRailRoll::FORCE_NAMES.iter().position(|&n| n == CONTACT[c]).expect("the same eight forces");
        WheelRailRoll::FORCES + k
    })
}

/// Runs the filter of `kind` on the user's `vehicle` over the measurements with `sensors`,
/// behind the supervisor as the FMU runs it (the forces' noise adapting upwards only, as in
/// S2; jumps of the forces taken).
pub fn run_filter(
    kind: FilterKind,
    vehicle: RollVehicle,
    tuning: &Tuning,
    measurements: &Measurements,
    sensors: Sensors,
) -> Result<Estimates, String> {
    let model = Discretized::rk4(WheelRailRoll { vehicle, force_return_rate: tuning.forces.rate() }, 1);
    let unscented = UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 };
    let filter =
        build_filter(kind, model, tuning.noise()?, &tuning.prior(&vehicle), unscented).map_err(|e| e.to_string())?;
    let settings = SupervisorSettings {
        min_process_noise_scale: 1.0,
        show_single_row_jumps: true,
        local_jumps: true,
        ..SupervisorSettings::default()
    };
    let supervisor = Supervisor::new(settings, 28)
        .and_then(|s| s.with_jump_states(42, &WheelRailRoll::UNKNOWN_INPUTS))
        .map_err(|e| e.to_string())?;
    let mut supervised = SupervisedFilter::new(filter, supervisor).map_err(|e| e.to_string())?;
    let rows: Vec<[f64; 28]> = measurements
        .accelerations
        .iter()
        .zip(&measurements.deflections)
        .map(|(a, d)| {
            let a = in_model_order(&ACCELERATIONS, a, 0);
            let d = match sensors {
                Sensors::WithDeflections => in_model_order(&DEFLECTIONS, d, 20),
                Sensors::Accelerations => [f64::NAN; 8],
            };
            std::array::from_fn(|r| if r < 20 { a[r] } else { d[r - 20] })
        })
        .collect();
    let states = contact_states();
    let mut estimates = Estimates::default();
    let samples = rows.iter().enumerate().map(|(k, z)| Sample { time: k as f64 * tuning.dt, z, controls: &[] });
    supervised
        .run(tuning.dt, samples, |step| {
            let mean = step.filter.mean();
            estimates.forces.push(states.map(|s| mean[s]));
            estimates.std.push(states.map(|s| step.filter.variance(s).max(0.0).sqrt()));
            let covariance = step.filter.covariance();
            let combined = |j: usize, sign: f64| {
                let (l, r) = (WheelRailRoll::FORCES + 2 * j, WheelRailRoll::FORCES + 2 * j + 1);
                (covariance[(l, l)] + covariance[(r, r)] + sign * 2.0 * covariance[(l, r)]).max(0.0).sqrt()
            };
            estimates.sum_std.push(std::array::from_fn(|j| combined(j, 1.0)));
            estimates.difference_std.push(std::array::from_fn(|j| combined(j, -1.0)));
        })
        .map_err(|e| e.to_string())?;
    estimates.rejected = supervised.supervisor().rejected();
    Ok(estimates)
}

/// How an estimate of one signal compares with its truth.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Score {
    /// Correlation.
    pub correlation: f64,
    /// RMSE (N).
    pub rmse: f64,
    /// The true signal's standard deviation about its mean (N).
    pub dynamic_std: f64,
    /// Share of the errors inside the filter's ±2σ (0.955 for an honest σ).
    pub two_sigma_coverage: f64,
    /// Mean of `(e/σ)²` (1 for an honest σ).
    pub normalised_error: f64,
}

/// One wheelset's scores: left, right, their sum and their difference.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WheelsetScore {
    /// `F_NL`.
    pub left: Score,
    /// `F_NR`.
    pub right: Score,
    /// `F_NL + F_NR`.
    pub sum: Score,
    /// `F_NL − F_NR`.
    pub difference: Score,
}

fn score_of(truth: &[f64], estimate: &[f64], sigma: &[f64]) -> Score {
    let n = truth.len() as f64;
    let mean = truth.iter().sum::<f64>() / n;
    let honesty = analyzer::consistency::sigma_figures(truth, estimate, sigma);
    Score {
        correlation: analyzer::metrics::correlation(truth, estimate),
        rmse: analyzer::metrics::rmse(truth, estimate),
        dynamic_std: (truth.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt(),
        two_sigma_coverage: honesty.two_sigma_coverage,
        normalised_error: honesty.normalised_error.mean_square,
    }
}

/// Each wheelset's scores after the first `settle` seconds (the filter's start-up).
pub fn score(truth: &Truth, estimates: &Estimates, rate: f64, settle: f64) -> [WheelsetScore; 4] {
    let skip = ((settle * rate).round() as usize).min(truth.contact.len());
    let left = |j: usize| CONTACT.iter().position(|&n| n == format!("F_NL{}", j + 1)).expect("named");
    let right = |j: usize| CONTACT.iter().position(|&n| n == format!("F_NR{}", j + 1)).expect("named");
    std::array::from_fn(|j| {
        let (l, r) = (left(j), right(j));
        let series = |rows: &[[f64; 8]], f: &dyn Fn(&[f64; 8]) -> f64| rows[skip..].iter().map(f).collect::<Vec<_>>();
        let sigma = |rows: &[[f64; 4]]| rows[skip..].iter().map(|s| s[j]).collect::<Vec<_>>();
        let pair = |f: &dyn Fn(&[f64; 8]) -> f64, sigma: Vec<f64>| {
            score_of(&series(&truth.contact, f), &series(&estimates.forces, f), &sigma)
        };
        WheelsetScore {
            left: pair(&|c| c[l], series(&estimates.std, &|s| s[l])),
            right: pair(&|c| c[r], series(&estimates.std, &|s| s[r])),
            sum: pair(&|c| c[l] + c[r], sigma(&estimates.sum_std)),
            difference: pair(&|c| c[l] - c[r], sigma(&estimates.difference_std)),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use truth::s3::cases::{measure, simulate, Case};

    #[test]
    fn each_sensor_s_noise_reaches_the_row_of_its_name() {
        let settings = Settings { duration: 0.2, ..Settings::default() };
        let measurements = measure(&simulate(Case::Joint, &settings).unwrap(), 0.02, 1);
        let tuning = Tuning::new(&settings, &measurements, ForceModel::RandomWalk);
        for (c, name) in ACCELERATIONS.iter().enumerate() {
            let row = WheelRailRoll::MEASUREMENT_NAMES.iter().position(|n| n == name).unwrap();
            assert_eq!(tuning.acceleration_std[row], measurements.accelerations_noise_std[c], "{name}");
        }
        for (c, name) in DEFLECTIONS.iter().enumerate() {
            let row = WheelRailRoll::MEASUREMENT_NAMES.iter().position(|n| n == name).unwrap() - 20;
            assert_eq!(tuning.deflection_std[row], measurements.deflections_noise_std[c], "{name}");
        }
    }

    #[test]
    fn the_fmu_s_names_set_the_tuning_and_come_back_in_its_parameters() {
        let settings = Settings { duration: 0.2, ..Settings::default() };
        let measurements = measure(&simulate(Case::Joint, &settings).unwrap(), 0.02, 1);
        let mut tuning = Tuning::new(&settings, &measurements, ForceModel::Returning(5.0));
        for (name, value) in [("force_return_rate", 2.0), ("r_d_p_R3_std", 7e-5), ("q_body_std", 1e-4)] {
            tuning.set(name, value).unwrap();
            let written = tuning.fmu_parameters().into_iter().find(|(n, _)| *n == name).unwrap();
            assert_eq!(written.1, value, "{name}");
        }
        assert_eq!(
            tuning.deflection_std[WheelRailRoll::MEASUREMENT_NAMES[20..].iter().position(|&n| n == "d_p_R3").unwrap()],
            7e-5
        );
        tuning.set("force_return_rate", 0.0).unwrap();
        assert_eq!(tuning.forces, ForceModel::RandomWalk);
        assert_eq!(tuning.fmu_parameters().len(), 7 + 28);
        for (row, name) in SENSOR_NOISE_PARAMETERS.iter().enumerate() {
            assert_eq!(*name, format!("r_{}_std", WheelRailRoll::MEASUREMENT_NAMES[row]));
        }
        let before = tuning.clone();
        for (name, value) in
            [("car_body_mass", 3e4), ("r_a_ab_L9_std", 0.1), ("q_body_std", -1.0), ("p0_force_std", f64::NAN)]
        {
            assert!(tuning.set(name, value).is_err(), "{name} = {value}");
        }
        assert_eq!(tuning, before, "a refused value changes nothing");
    }

    #[test]
    fn a_run_estimates_every_force_in_the_truth_s_order_and_the_sums_follow() {
        let settings = Settings { duration: 1.0, ..Settings::default() };
        let truth = simulate(Case::Joint, &settings).unwrap();
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let tuning = Tuning::new(&settings, &measurements, ForceModel::Returning(5.0));
        let vehicle = user_vehicle(settings.vehicle.static_wheel_load());
        let estimates = run_filter(FilterKind::SrCkf, vehicle, &tuning, &measurements, Sensors::Accelerations).unwrap();
        assert_eq!(estimates.forces.len(), truth.contact.len());
        for wheelset in score(&truth, &estimates, settings.rate, 0.2) {
            // The sum of a wheelset's forces is what every accelerometer layout sees.
            assert!(wheelset.sum.correlation > 0.99, "{wheelset:?}");
        }
    }
}
