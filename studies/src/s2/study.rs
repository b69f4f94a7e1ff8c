//! The S2 study's estimator, set up as a user would have it, and its scores.
//!
//! **The user's vehicle is not the truth's** ([`truth::s2::cases::as_built`]). The
//! estimator has the catalogue values ([`Vehicle::ZHAI_PASSENGER`]) and one measured
//! number: the static wheel load, as a weighbridge gives it. It has no track and no Hertz
//! contact.

use estimator::models::{PiecewiseLinear, VerticalVehicle};
use start_values::SetByName;
use truth::s2::cases::{Measurements, Settings, Truth};
use truth::s2::parameters::Vehicle;

/// `vehicle` as the estimation model has it: halved onto one rail, the same laws (the
/// primary damper's two slopes), and the static wheel load an eighth of its weight.
pub fn vertical_vehicle(vehicle: &Vehicle) -> VerticalVehicle {
    let v = vehicle;
    let damper = PiecewiseLinear::new(
        [v.primary_damping, v.primary_damping_beyond, v.primary_damping_beyond],
        [v.primary_damper_knee; 2],
    )
    .expect("a catalogue damper is a valid law");
    VerticalVehicle::half_of(
        (v.car_body_mass, v.car_body_pitch_inertia),
        (v.bogie_mass, v.bogie_pitch_inertia),
        v.wheelset_mass,
        (v.primary_stiffness, damper),
        (v.secondary_stiffness, v.secondary_damping),
        v.half_bogie_spacing,
        v.half_wheelbase,
    )
}

/// The vehicle as the estimator knows it: `catalogue` halved onto one rail, with the static
/// wheel load `weighed` (N) instead of the catalogue's.
pub fn user_vehicle(catalogue: &Vehicle, weighed: f64) -> VerticalVehicle {
    VerticalVehicle { static_wheel_load: weighed, ..vertical_vehicle(catalogue) }
}

/// The filter set-up: eq. (22) of the paper, except three values.
/// - The forces' noise is an intensity, so that it means the same at 200 Hz and 1 kHz.
/// - `R` is set from the noise added.
/// - The motion states' noise is a white-noise intensity too: 9e-7 (car body, bogies) and
///   1e-7 (wheelsets) per second, a std of 3e-5 and 1e-5 per sample at 1 kHz, not
///   eq. (22)'s 1e-3 and 1e-6 per sample. With eq. (22)'s values the positions drift
///   unobserved, and the forces' σ grows to 270 kN while their error is 0.2 kN (first probe,
///   `examples/s2_explore.rs`, wheel 1 at 1 kHz: random 0.986 → 0.9985, corrugation
///   0.9991 → 0.9997, weld 0.993 → 0.988 with 1e-4 and 1e-5 per sample). The car body's and
///   bogies' 3e-5 makes σ honest: with 1e-4 it was 0.84 kN against an RMSE of 0.2 kN and
///   the ±2σ band held every error; with 3e-5 it holds 98.5 % of them (random track, seed
///   1); with 2e-5 and below the FMU's gate starts rejecting the weld's impact as if it
///   were a sensor fault (`reproduce`, 1 kHz). Per sample instead of per second, the same
///   numbers at 200 Hz let the gate reject 319 rows of the corrugation case.
///
/// The noises are held as standard deviations, as the FMU takes them: the FMU's filter and
/// the in-process one then square the same numbers and agree to the last bit. Every field
/// but the sample time is an FMU parameter ([`Tuning::fmu_parameters`],
/// [`Tuning::fmu_integers`]) and can be set by that name ([`Tuning::set`]), so that start
/// values a user gives reach the in-process filter as they reach the FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuning {
    /// Process noise std per sample of the six car-body and bogie coordinates and their
    /// velocities (eq. (22): variance 1e-3; here from [`Tuning::BODY_INTENSITY`]).
    pub body_std: f64,
    /// … of the four wheelset coordinates and their velocities (eq. (22): variance 1e-6;
    /// here from [`Tuning::WHEELSET_INTENSITY`]).
    pub wheelset_std: f64,
    /// The forces' random-walk intensity (N²/s): `Q_F = q·Δt` per sample. [est: 1e13, from
    /// a first probe over 1e11–1e14; eq. (22) has 1e9 per 5 ms sample, 2e11 N²/s]
    pub force_intensity: f64,
    /// The sensors' noise (m/s²): `R = diag(σ²)`.
    pub sensor_std: [f64; 7],
    /// Prior std of the 20 motion states (eq. (22): variance 1e-2).
    pub prior_motion_std: f64,
    /// Prior std of the four forces (N; eq. (22): variance 1e-2), about the static wheel load.
    pub prior_force_std: f64,
    /// The UKF's parameters (the cubature rule's points for the others).
    pub unscented: estimator::UnscentedParams,
    /// RK4 steps per sample of the estimation model.
    pub rk4_substeps: usize,
    /// Sample time (s).
    pub dt: f64,
}

/// The FMU's names of the sensors' noise, in the measurement order of eq. (7).
const SENSOR_NOISE_PARAMETERS: [&str; 7] = [
    "r_z_c_ddot_std",
    "r_z_t1_ddot_std",
    "r_z_t2_ddot_std",
    "r_z_w1_ddot_std",
    "r_z_w2_ddot_std",
    "r_z_w3_ddot_std",
    "r_z_w4_ddot_std",
];

impl Tuning {
    /// The intensity of the car body's and bogies' process noise (units²/s): a std of 3e-5
    /// per sample at 1 kHz.
    pub const BODY_INTENSITY: f64 = 9e-7;
    /// … of the wheelsets': 1e-5 per sample at 1 kHz.
    pub const WHEELSET_INTENSITY: f64 = 1e-7;

    /// Every FMU parameter a tuning sets, by the name [`Tuning::fmu_parameters`] and
    /// [`Tuning::fmu_integers`] give it: the names [`Tuning::set`] takes.
    pub const NAMES: [&'static str; 16] = [
        "p0_motion_std",
        "p0_force_std",
        "q_body_std",
        "q_wheelset_std",
        "force_noise_intensity",
        "ukf_alpha",
        "ukf_beta",
        "ukf_kappa",
        "r_z_c_ddot_std",
        "r_z_t1_ddot_std",
        "r_z_t2_ddot_std",
        "r_z_w1_ddot_std",
        "r_z_w2_ddot_std",
        "r_z_w3_ddot_std",
        "r_z_w4_ddot_std",
        "rk4_substeps",
    ];

    /// The study's set-up for these settings and sensors.
    pub fn new(settings: &Settings, sensor_std: [f64; 7]) -> Self {
        Self {
            body_std: (Self::BODY_INTENSITY / settings.rate).sqrt(),
            wheelset_std: (Self::WHEELSET_INTENSITY / settings.rate).sqrt(),
            force_intensity: 1e13,
            sensor_std,
            prior_motion_std: 0.1,
            prior_force_std: 0.1,
            unscented: estimator::UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 },
            rk4_substeps: 1,
            dt: 1.0 / settings.rate,
        }
    }

    /// The same set-up as the estimator FMU's Real parameters (the sample time aside: it
    /// is the measurements' clock).
    pub fn fmu_parameters(&self) -> Vec<(&'static str, f64)> {
        let estimator::UnscentedParams { alpha, beta, kappa } = self.unscented;
        let mut p = vec![
            ("p0_motion_std", self.prior_motion_std),
            ("p0_force_std", self.prior_force_std),
            ("q_body_std", self.body_std),
            ("q_wheelset_std", self.wheelset_std),
            ("force_noise_intensity", self.force_intensity),
            ("ukf_alpha", alpha),
            ("ukf_beta", beta),
            ("ukf_kappa", kappa),
        ];
        p.extend(SENSOR_NOISE_PARAMETERS.into_iter().zip(self.sensor_std));
        p
    }

    /// … and its Integer parameters.
    pub fn fmu_integers(&self) -> Vec<(&'static str, i32)> {
        vec![("rk4_substeps", self.rk4_substeps as i32)]
    }

    /// `Q` and `R` for the library's filters, in the state order of
    /// [`WheelRailVertical`](estimator::models::WheelRailVertical).
    pub fn noise(&self) -> estimator::Noise {
        let mut q = Vec::with_capacity(24);
        for _ in 0..2 {
            q.extend([self.body_std * self.body_std; 6]);
            q.extend([self.wheelset_std * self.wheelset_std; 4]);
        }
        q.extend([self.force_intensity * self.dt; 4]);
        let r: Vec<f64> = self.sensor_std.iter().map(|s| s * s).collect();
        estimator::Noise::diagonal(&q, &r).expect("the S2 tuning is a valid covariance pair")
    }

    /// The prior: at static equilibrium with the forces at the static wheel load (eq. (22)).
    pub fn prior(&self, vehicle: &VerticalVehicle) -> estimator::Gaussian {
        use estimator::models::WheelRailVertical;
        let mut mean = [0.0; 24];
        mean[WheelRailVertical::FORCES..].fill(vehicle.static_wheel_load);
        let mut variances = [self.prior_motion_std * self.prior_motion_std; 24];
        variances[WheelRailVertical::FORCES..].fill(self.prior_force_std * self.prior_force_std);
        estimator::Gaussian::diagonal(&mean, &variances)
    }
}

impl SetByName for Tuning {
    /// Whether [`Tuning::set`] takes `name`.
    fn takes(name: &str) -> bool {
        Self::NAMES.contains(&name)
    }

    /// Sets the FMU parameter `name` to `value` as the in-process filter has it, so that
    /// [`Tuning::fmu_parameters`] (or [`Tuning::fmu_integers`]) then writes `value` for
    /// it. An error names what is wrong: a name the tuning does not have (the vehicle's,
    /// the static wheel load, the supervisor's, `filter`, `sample_time`, … are the FMU's
    /// only), or a value the FMU would refuse too (not finite, a negative σ or intensity,
    /// a number of RK4 steps that is not an integer from 1 to 1000).
    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if name == "sample_time" {
            return Err("sample_time is the measurements' clock (the study's rate), not a tuning".into());
        }
        if !Self::takes(name) {
            return Err(format!(
                "'{name}' is not a parameter the in-process S2 filter takes (it takes {})",
                Self::NAMES.join(", ")
            ));
        }
        if !value.is_finite() {
            return Err(format!("{name} = {value}: not a finite number"));
        }
        match name {
            "ukf_alpha" => self.unscented.alpha = value,
            "ukf_beta" => self.unscented.beta = value,
            "ukf_kappa" => self.unscented.kappa = value,
            "rk4_substeps" => {
                // The FMU's bounds of the integer parameter.
                if !(1.0..=1000.0).contains(&value) || value.fract() != 0.0 {
                    return Err(format!("rk4_substeps = {value}: not an integer from 1 to 1000"));
                }
                self.rk4_substeps = value as usize;
            }
            _ => {
                if value < 0.0 {
                    return Err(format!("{name} = {value}: a σ or an intensity is not negative"));
                }
                let slot = match name {
                    "p0_motion_std" => &mut self.prior_motion_std,
                    "p0_force_std" => &mut self.prior_force_std,
                    "q_body_std" => &mut self.body_std,
                    "q_wheelset_std" => &mut self.wheelset_std,
                    "force_noise_intensity" => &mut self.force_intensity,
                    _ => {
                        let i = SENSOR_NOISE_PARAMETERS.iter().position(|&n| n == name);
                        &mut self.sensor_std[i.expect("every other name a tuning takes is a sensor's")]
                    }
                };
                *slot = value;
            }
        }
        Ok(())
    }
}

/// One filter's estimates of the four forces, sample by sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Estimates {
    /// The forces (N).
    pub forces: Vec<[f64; 4]>,
    /// Their standard deviations (N).
    pub std: Vec<[f64; 4]>,
    /// Measurement rows the supervisor's gate left out.
    pub rejected: u64,
}

/// The filter of `kind` on the user's vehicle (the tuning's RK4 steps per sample) behind
/// the supervisor as the FMU has it: its default settings, the forces' noise adapting
/// upwards only, jumps of the forces taken.
pub fn supervised_filter(
    kind: estimator::FilterKind,
    vehicle: VerticalVehicle,
    tuning: &Tuning,
) -> Result<estimator::SupervisedFilter, String> {
    use estimator::models::WheelRailVertical;
    let model = estimator::Discretized::rk4(WheelRailVertical { vehicle }, tuning.rk4_substeps);
    let filter = estimator::build_filter(kind, model, tuning.noise(), &tuning.prior(&vehicle), tuning.unscented)
        .map_err(|e| format!("setup: {e}"))?;
    let unknown_inputs = &WheelRailVertical::UNKNOWN_INPUTS;
    // The FMU's: the forces' noise adapts upwards only (see `kalfmu_fmu`'s S2 table), jumps
    // taken, one an axle box alone explains shown at its sample.
    let settings = estimator::SupervisorSettings {
        min_process_noise_scale: 1.0,
        show_single_row_jumps: true,
        local_jumps: true,
        ..estimator::SupervisorSettings::default()
    };
    let supervisor = estimator::Supervisor::new(settings, 7)
        .and_then(|s| s.with_jump_states(filter.state_dim(), unknown_inputs))
        .map_err(|e| format!("setup: {e}"))?;
    estimator::SupervisedFilter::new(filter, supervisor).map_err(|e| format!("setup: {e}"))
}

/// Runs the filter of `kind` ([`supervised_filter`]) over the measurements as the FMU runs
/// it: a row the gate rejects is left out of that update.
pub fn run_filter(
    kind: estimator::FilterKind,
    vehicle: VerticalVehicle,
    tuning: &Tuning,
    measurements: &Measurements,
) -> Result<Estimates, String> {
    use estimator::models::WheelRailVertical;
    let mut supervised = supervised_filter(kind, vehicle, tuning)?;
    let mut estimates = Estimates::default();
    let samples = measurements.accelerations.iter().enumerate().map(|(k, z)| estimator::Sample {
        time: k as f64 * tuning.dt,
        z,
        controls: &[],
    });
    supervised
        .run(tuning.dt, samples, |step| {
            let force = |j: usize| step.filter.mean()[WheelRailVertical::FORCES + j];
            let std = |j: usize| step.filter.variance(WheelRailVertical::FORCES + j).max(0.0).sqrt();
            estimates.forces.push([0, 1, 2, 3].map(force));
            estimates.std.push([0, 1, 2, 3].map(std));
        })
        .map_err(|e| e.to_string())?;
    estimates.rejected = supervised.supervisor().rejected();
    Ok(estimates)
}

/// How one wheel's estimate compares with its truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelScore {
    /// Correlation.
    pub correlation: f64,
    /// RMSE (N).
    pub rmse: f64,
    /// The true force's standard deviation about its mean: its dynamic part (N).
    pub dynamic_std: f64,
}

/// Each wheel's score after the first `settle` seconds (the filter's start-up).
pub fn score(truth: &Truth, estimates: &Estimates, rate: f64, settle: f64) -> [WheelScore; 4] {
    let skip = ((settle * rate).round() as usize).min(truth.contact.len());
    [0, 1, 2, 3].map(|j| {
        let t: Vec<f64> = truth.contact[skip..].iter().map(|c| c[j]).collect();
        let e: Vec<f64> = estimates.forces[skip..].iter().map(|f| f[j]).collect();
        let n = t.len() as f64;
        let mean = t.iter().sum::<f64>() / n;
        WheelScore {
            correlation: analyzer::metrics::correlation(&t, &e),
            rmse: analyzer::metrics::rmse(&t, &e),
            dynamic_std: (t.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt(),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use start_values::StartValues;

    fn tuning() -> Tuning {
        Tuning::new(&Settings::default(), [0.1, 0.2, 0.3, 1.0, 1.1, 1.2, 1.3])
    }

    /// Every parameter the tuning writes to the FMU, the Integer ones as numbers.
    fn written(t: &Tuning) -> Vec<(&'static str, f64)> {
        let integers = t.fmu_integers().into_iter().map(|(n, v)| (n, f64::from(v)));
        t.fmu_parameters().into_iter().chain(integers).collect()
    }

    #[test]
    fn every_parameter_the_tuning_writes_is_set_by_its_name() {
        // The names `set` takes are exactly those written, each once.
        let mut names: Vec<&str> = written(&tuning()).iter().map(|(n, _)| *n).collect();
        names.sort_unstable();
        let mut takes = Tuning::NAMES.to_vec();
        takes.sort_unstable();
        assert_eq!(names, takes);
        for (name, old) in written(&tuning()) {
            let mut t = tuning();
            // A new value the FMU takes: an integer in its bounds, or a positive number.
            let value = if name == "rk4_substeps" { old + 2.0 } else { old * 1.5 + 0.25 };
            t.set(name, value).unwrap_or_else(|e| panic!("{name}: {e}"));
            // `name` reports `value`, and nothing else moved.
            let expected: Vec<(&str, f64)> =
                written(&tuning()).into_iter().map(|(n, v)| (n, if n == name { value } else { v })).collect();
            assert_eq!(written(&t), expected, "{name}");
        }
    }

    #[test]
    fn the_two_prior_deviations_reach_their_own_states() {
        let mut t = tuning();
        t.set("p0_motion_std", 0.5).unwrap();
        t.set("p0_force_std", 300.0).unwrap();
        let vehicle = user_vehicle(&Vehicle::ZHAI_PASSENGER, 58e3);
        let prior = t.prior(&vehicle);
        assert_eq!(prior.covariance[(0, 0)], 0.25);
        assert_eq!(prior.covariance[(19, 19)], 0.25);
        assert_eq!(prior.covariance[(20, 20)], 9e4);
        assert_eq!(prior.mean[23], 58e3);
    }

    #[test]
    fn names_and_values_the_fmu_would_refuse_are_refused_and_change_nothing() {
        let mut t = tuning();
        for (name, value) in [
            ("car_body_mass", 36e3),
            ("static_wheel_load", 6e4),
            ("sample_time", 0.005),
            ("gate_probability", 0.99),
            ("q_body_std", -1.0),
            ("force_noise_intensity", f64::INFINITY),
            ("rk4_substeps", 0.5),
        ] {
            let e = t.set(name, value).expect_err(name);
            assert!(e.contains(name), "{e}");
        }
        assert_eq!(t, tuning());
        let mut values = StartValues::none();
        values.insert("force_noise_intensity", 2e12);
        values.insert("car_body_mass", 36e3);
        assert_eq!(t.set_known(&values).unwrap(), vec!["car_body_mass".to_string()]);
        assert_eq!(t.force_intensity, 2e12);
        assert!(tuning().set_all(&values).unwrap_err().contains("car_body_mass"));
    }
}
