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
    /// Prior std of the 34 motion states.
    pub prior_motion_std: f64,
    /// Prior std of the forces about the static wheel load (N).
    pub prior_force_std: f64,
    /// Sample time (s).
    pub dt: f64,
}

impl Tuning {
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
        let r: Vec<f64> = self.acceleration_std.iter().chain(&self.deflection_std).map(|s| s * s).collect();
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

/// The values of the truth's channels `names` (in the truth's order) in the model's row
/// order, starting at row `first` of [`WheelRailRoll::MEASUREMENT_NAMES`].
fn in_model_order<const N: usize>(names: &[&str; N], values: &[f64; N], first: usize) -> [f64; N] {
    std::array::from_fn(|row| {
        let name = WheelRailRoll::MEASUREMENT_NAMES[first + row];
        values[names.iter().position(|&n| n == name).expect("the truth records every sensor the model reads")]
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
    let settings = SupervisorSettings { min_process_noise_scale: 1.0, ..SupervisorSettings::default() };
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
    fn a_run_estimates_every_force_in_the_truth_s_order_and_the_sums_follow() {
        let settings = Settings { duration: 1.0, ..Settings::default() };
        let truth = simulate(Case::Joint, &settings).unwrap();
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let tuning = Tuning::new(&settings, &measurements, ForceModel::Returning(5.0));
        let vehicle = RollVehicle::zhai_passenger();
        let estimates = run_filter(FilterKind::SrCkf, vehicle, &tuning, &measurements, Sensors::Accelerations).unwrap();
        assert_eq!(estimates.forces.len(), truth.contact.len());
        for wheelset in score(&truth, &estimates, settings.rate, 0.2) {
            // The sum of a wheelset's forces is what every accelerometer layout sees.
            assert!(wheelset.sum.correlation > 0.99, "{wheelset:?}");
        }
    }
}
