//! Study S1: dynamic load identification on a 2-DOF nonlinear spring–damper
//! chain with an SRCKF `[Gong2024]`. Its four cases (stiffness- or
//! damping-nonlinear chain × random or harmonic load) run with every filter of
//! the library; `reproduce` adds the six unseen ones of [`Case::UNSEEN`] (loads
//! the set-up was not made for, of which the paper has no figures) with the SRCKF.
//!
//! Pipeline of one case: the truth simulator ([`truth::s1`]) integrates the
//! physical chain under a continuous load and adds white noise of a fixed
//! fraction of each channel's RMS to the two accelerations; the estimator
//! (augmented state `[z₁, z₂, F, ż₁, ż₂, Ḟ]`, RK4 once per sample) sees only
//! those noisy accelerations; the estimated load is compared with the true one
//! ([`analyzer::metrics`]).

pub mod export;
pub mod fault_table;
pub mod faults;
pub mod fmu_run;
pub mod reproduce;
pub mod sweep;
pub mod system;

use estimator::models::Oscillator2DofLoad;
use estimator::{build_filter, Discretized, FilterError, FilterKind, Gaussian, Noise, StateEstimator, UnscentedParams};
use nalgebra::DMatrix;
use start_values::{SetByName, StartValues};
use truth::s1::plant::Truth;
use truth::s1::{Case, LoadKind, Measurements, Nonlinearity, Settings};

use analyzer::metrics::{compare, Metrics};

/// The paper's figures for one case (its SRCKF).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Published {
    /// Correlation between identified and true load.
    pub correlation: f64,
    /// Largest running RMSE (N): at the start for the random loads, the
    /// maximum of the fluctuating curve for the harmonic ones.
    pub running_rmse_peak: Option<f64>,
    /// The bound the running RMSE stays under after the start (N).
    pub running_rmse_max_converged: Option<f64>,
}

/// What the paper reports for its SRCKF on `case`; `None` for the unseen cases, of which
/// it reports nothing.
pub fn published(case: &Case) -> Option<Published> {
    if !case.is_published() {
        return None;
    }
    Some(match (case.nonlinearity, case.load) {
        (Nonlinearity::Stiffness, LoadKind::Random) => {
            Published { correlation: 0.997, running_rmse_peak: Some(17.553), running_rmse_max_converged: Some(2.052) }
        }
        (Nonlinearity::Damping, LoadKind::Random) => {
            Published { correlation: 0.999, running_rmse_peak: Some(1.258), running_rmse_max_converged: Some(0.033) }
        }
        (Nonlinearity::Stiffness, LoadKind::Harmonic) => {
            Published { correlation: 0.997, running_rmse_peak: Some(0.866), running_rmse_max_converged: None }
        }
        (Nonlinearity::Damping, LoadKind::Harmonic) => {
            Published { correlation: 0.999, running_rmse_peak: Some(0.234), running_rmse_max_converged: None }
        }
    })
}

/// The project's goal for the SRCKF correlation: ≥ 0.998 stiffness, ≥ 0.999 damping.
pub fn correlation_goal(case: &Case) -> f64 {
    match case.nonlinearity {
        Nonlinearity::Stiffness => 0.998,
        Nonlinearity::Damping => 0.999,
    }
}

/// The estimator set-up: one documented setting for all four cases, not
/// tuned per seed (a scan of `q` over 1e5–1e10 changes the SRCKF
/// correlation by less than 1e-3).
///
/// * The load is a second-order random walk: `F̈` is white noise of intensity
///   `q` (N²/s³), whose exact discretisation over `dt` is the (F, Ḟ) block
///   `q·[dt³/3, dt²/2; dt²/2, dt]`. `q` comes from what an engineer knows of
///   the load before the test — RMS σ ≈ 10 N, bandwidth f ≈ 10 Hz: a flat
///   band has `E[F̈²] = σ²·(2πf)⁴/5`, and the random walk of `Ḟ` must allow
///   that change per sample, so `q = σ²·(2πf)⁴/5 · dt`.
/// * The positions and velocities get small process noise covering the
///   RK4-per-sample discretisation (`1e-12 m²`, `1e-10 (m/s)²`).
/// * `R` is the accelerometers' noise variance (the sensor specification).
/// * The prior: the chain starts at rest (σ 1 mm, 1 mm/s), the load is unknown
///   (σ 20 N, 500 N/s).
/// * The filter's rule and model: the UKF at α = 1, β = 2, κ = 0 (the cubature rule's
///   points for the others), RK4 once per sample.
///
/// Every field but the sample time is an FMU parameter ([`Tuning::fmu_parameters`],
/// [`Tuning::fmu_integers`]) and can be set by that name ([`Tuning::set`]), so that start values a user gives reach
/// the in-process filter as they reach the FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuning {
    /// Process noise std of z₁, z₂ per sample (m).
    pub position_std: f64,
    /// Process noise std of ż₁, ż₂ per sample (m/s).
    pub velocity_std: f64,
    /// Intensity `q` of the white `F̈` (N²/s³).
    pub load_intensity: f64,
    /// Accelerometer noise std (m/s²).
    pub sensor_std: [f64; 2],
    /// Prior mean of `[z₁, z₂, F, ż₁, ż₂, Ḟ]`.
    pub prior_mean: [f64; 6],
    /// Prior std of `[z₁, z₂, F, ż₁, ż₂, Ḟ]`.
    pub prior_std: [f64; 6],
    /// The UKF's parameters.
    pub unscented: UnscentedParams,
    /// RK4 steps per sample of the estimation model.
    pub rk4_substeps: usize,
    /// Sample time (s).
    pub dt: f64,
}

/// The FMU's names of the prior mean, in the state order.
const PRIOR_MEAN_PARAMETERS: [&str; 6] = ["x0_z1", "x0_z2", "x0_F", "x0_z1_dot", "x0_z2_dot", "x0_F_dot"];
/// The FMU's names of the prior std, in the state order.
const PRIOR_STD_PARAMETERS: [&str; 6] =
    ["p0_z1_std", "p0_z2_std", "p0_F_std", "p0_z1_dot_std", "p0_z2_dot_std", "p0_F_dot_std"];
/// The FMU's names of the accelerometers' noise, in the measurement order.
const SENSOR_NOISE_PARAMETERS: [&str; 2] = ["r_z1_ddot_std", "r_z2_ddot_std"];

impl Tuning {
    /// Every FMU parameter a tuning sets, by the name [`Tuning::fmu_parameters`] and
    /// [`Tuning::fmu_integers`] give it: the names [`Tuning::set`] takes.
    pub const NAMES: [&'static str; 21] = [
        "q_z_std",
        "q_z_dot_std",
        "load_noise_intensity",
        "r_z1_ddot_std",
        "r_z2_ddot_std",
        "p0_z1_std",
        "p0_z2_std",
        "p0_F_std",
        "p0_z1_dot_std",
        "p0_z2_dot_std",
        "p0_F_dot_std",
        "x0_z1",
        "x0_z2",
        "x0_F",
        "x0_z1_dot",
        "x0_z2_dot",
        "x0_F_dot",
        "ukf_alpha",
        "ukf_beta",
        "ukf_kappa",
        "rk4_substeps",
    ];

    /// The study's setting for these settings and accelerometer noise.
    pub fn new(settings: &Settings, noise_std: [f64; 2]) -> Self {
        const LOAD_RMS: f64 = 10.0;
        const LOAD_BANDWIDTH: f64 = 10.0;
        let dt = settings.dt();
        Self {
            position_std: 1e-6,
            velocity_std: 1e-5,
            // The same prior knowledge holds for both loads of the paper (the harmonics end at 7 Hz).
            load_intensity: LOAD_RMS.powi(2) * (std::f64::consts::TAU * LOAD_BANDWIDTH).powi(4) / 5.0 * dt,
            sensor_std: noise_std,
            prior_mean: [0.0; 6],
            prior_std: [1e-3, 1e-3, 20.0, 1e-3, 1e-3, 500.0],
            unscented: UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 },
            rk4_substeps: 1,
            dt,
        }
    }

    /// `Q` and `R` for the library's filters.
    pub fn noise(&self) -> Noise {
        let (dt, q_load) = (self.dt, self.load_intensity);
        let mut q = DMatrix::zeros(6, 6);
        for i in [0, 1] {
            q[(i, i)] = self.position_std.powi(2);
            q[(i + 3, i + 3)] = self.velocity_std.powi(2);
        }
        let (f, fd) = (Oscillator2DofLoad::LOAD, Oscillator2DofLoad::LOAD + 3);
        q[(f, f)] = q_load * dt.powi(3) / 3.0;
        q[(f, fd)] = q_load * dt.powi(2) / 2.0;
        q[(fd, f)] = q[(f, fd)];
        q[(fd, fd)] = q_load * dt;
        let r = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(&[
            self.sensor_std[0].powi(2),
            self.sensor_std[1].powi(2),
        ]));
        Noise::new(q, r).expect("the S1 tuning is a valid covariance pair")
    }

    /// The study's estimator of `kind` for `case` from this prior with
    /// `noise` (usually [`Tuning::noise`]): the chain's augmented model, RK4
    /// `rk4_substeps` times per sample, the UKF at the tuning's parameters.
    pub fn filter(&self, kind: FilterKind, case: &Case, noise: Noise) -> Result<Box<dyn StateEstimator>, FilterError> {
        let model = Discretized::rk4(Oscillator2DofLoad::new(case.chain()), self.rk4_substeps);
        build_filter(kind, model, noise, &self.prior(), self.unscented)
    }

    /// The prior: the documented mean and deviations.
    pub fn prior(&self) -> Gaussian {
        Gaussian::diagonal(&self.prior_mean, &self.prior_std.map(|s| s * s))
    }

    /// The same setting as the estimator FMU's Real parameters.
    pub fn fmu_parameters(&self) -> Vec<(&'static str, f64)> {
        let mut p = vec![
            ("q_z_std", self.position_std),
            ("q_z_dot_std", self.velocity_std),
            ("load_noise_intensity", self.load_intensity),
        ];
        p.extend(SENSOR_NOISE_PARAMETERS.into_iter().zip(self.sensor_std));
        p.extend(PRIOR_STD_PARAMETERS.into_iter().zip(self.prior_std));
        p.extend(PRIOR_MEAN_PARAMETERS.into_iter().zip(self.prior_mean));
        let UnscentedParams { alpha, beta, kappa } = self.unscented;
        p.extend([("ukf_alpha", alpha), ("ukf_beta", beta), ("ukf_kappa", kappa)]);
        p
    }

    /// … and its Integer parameters.
    pub fn fmu_integers(&self) -> Vec<(&'static str, i32)> {
        vec![("rk4_substeps", self.rk4_substeps as i32)]
    }
}

impl SetByName for Tuning {
    /// Whether [`Tuning::set`] takes `name`: every FMU parameter a tuning writes.
    fn takes(name: &str) -> bool {
        Self::NAMES.contains(&name)
    }

    /// Sets the FMU parameter `name` to `value` as the in-process filter has it, so that
    /// [`Tuning::fmu_parameters`] (or [`Tuning::fmu_integers`]) then writes `value` for
    /// it. An error names what is wrong: a name the tuning does not have (the chain's, the
    /// supervisor's, `filter`, `sample_time`, … are the FMU's only: the in-process runs
    /// take the chain from the case and the supervisor from their command), or a value the
    /// FMU would refuse too (not finite, a negative σ or intensity, a number of RK4 steps
    /// that is not a positive integer).
    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if name == "sample_time" {
            return Err("sample_time is the measurements' clock (the study's rate), not a tuning".into());
        }
        if !Self::takes(name) {
            return Err(format!(
                "'{name}' is not a parameter the in-process S1 filter takes (it takes {})",
                Self::NAMES.join(", ")
            ));
        }
        if !value.is_finite() {
            return Err(format!("{name} = {value}: not a finite number"));
        }
        let index = |names: &[&str]| names.iter().position(|&n| n == name);
        if let Some(i) = index(&PRIOR_MEAN_PARAMETERS) {
            self.prior_mean[i] = value;
            return Ok(());
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
                let slot = if let Some(i) = index(&PRIOR_STD_PARAMETERS) {
                    &mut self.prior_std[i]
                } else if let Some(i) = index(&SENSOR_NOISE_PARAMETERS) {
                    &mut self.sensor_std[i]
                } else {
                    match name {
                        "q_z_std" => &mut self.position_std,
                        "q_z_dot_std" => &mut self.velocity_std,
                        _ => &mut self.load_intensity,
                    }
                };
                *slot = value;
            }
        }
        Ok(())
    }
}

/// The result of one filter on one case.
#[derive(Debug, Clone)]
pub struct FilterRun {
    /// The filter.
    pub kind: FilterKind,
    /// The identified load at each sample (N).
    pub load: Vec<f64>,
    /// Its standard deviation (N).
    pub load_std: Vec<f64>,
    /// Metrics against the true load; `None` when the filter failed.
    pub metrics: Option<Metrics>,
    /// The error that stopped the filter, with the time.
    pub failure: Option<String>,
}

/// Runs one filter over the measurements of a case, the study's tuning with
/// `start_values` over it (every name one [`Tuning::set`] takes).
pub fn run_filter(
    kind: FilterKind,
    case: &Case,
    settings: &Settings,
    truth: &Truth,
    measurements: &Measurements,
    start_values: &StartValues,
) -> FilterRun {
    let mut tuning = Tuning::new(settings, measurements.noise_std);
    let mut run = FilterRun { kind, load: Vec::new(), load_std: Vec::new(), metrics: None, failure: None };
    let built = tuning.set_all(start_values).map_err(|e| e.to_string());
    let mut filter = match built.and_then(|()| tuning.filter(kind, case, tuning.noise()).map_err(|e| e.to_string())) {
        Ok(f) => f,
        Err(e) => {
            run.failure = Some(format!("setup: {e}"));
            return run;
        }
    };
    let dt = settings.dt();
    // The measurement at t = 0 updates the prior; each later one follows a predict.
    for (k, z) in measurements.acceleration.iter().enumerate() {
        let predicted = if k == 0 { Ok(()) } else { filter.predict(&[], dt) };
        if let Err(e) = predicted.and_then(|_| filter.update(z).map(|_| ())) {
            run.failure = Some(format!("t = {:.3} s (sample {k}): {e}", truth.time[k]));
            return run;
        }
        run.load.push(filter.mean()[Oscillator2DofLoad::LOAD]);
        run.load_std.push(filter.variance(Oscillator2DofLoad::LOAD).max(0.0).sqrt());
    }
    run.metrics = Some(compare(&truth.load, &run.load, truth.time[0], dt, settings.rmse_window));
    run
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tuning() -> Tuning {
        Tuning::new(&Settings::default(), [0.02, 0.03])
    }

    /// A value no parameter has by default, and one the FMU takes for each name: an
    /// integer in its bounds for `rk4_substeps`, a positive number otherwise.
    fn new_value(name: &str, old: f64) -> f64 {
        if name == "rk4_substeps" {
            old + 2.0
        } else {
            old * 1.5 + 0.25
        }
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
            let value = new_value(name, old);
            t.set(name, value).unwrap_or_else(|e| panic!("{name}: {e}"));
            // `name` reports `value`, and nothing else moved.
            let expected: Vec<(&str, f64)> =
                written(&tuning()).into_iter().map(|(n, v)| (n, if n == name { value } else { v })).collect();
            assert_eq!(written(&t), expected, "{name}");
        }
    }

    #[test]
    fn a_value_set_reaches_the_in_process_filter() {
        let mut t = tuning();
        t.set("load_noise_intensity", 3e6).unwrap();
        t.set("r_z2_ddot_std", 0.5).unwrap();
        t.set("x0_F", 4.0).unwrap();
        let noise = t.noise();
        let (f, fd) = (Oscillator2DofLoad::LOAD, Oscillator2DofLoad::LOAD + 3);
        assert_eq!(noise.q()[(fd, fd)], 3e6 * t.dt);
        assert_eq!(noise.q()[(f, f)], 3e6 * t.dt.powi(3) / 3.0);
        assert_eq!(noise.r()[(1, 1)], 0.25);
        assert_eq!(t.prior().mean[f], 4.0);
    }

    #[test]
    fn names_and_values_the_fmu_would_refuse_are_refused_and_change_nothing() {
        let mut t = tuning();
        for (name, value) in [
            ("m1", 4.0),
            ("sample_time", 0.01),
            ("filter", 2.0),
            ("gate_probability", 0.99),
            ("q_z_std", -1.0),
            ("p0_F_std", f64::NAN),
            ("x0_F", f64::INFINITY),
            ("rk4_substeps", 1.5),
            ("rk4_substeps", 0.0),
        ] {
            let e = t.set(name, value).expect_err(name);
            assert!(e.contains(name), "{e}");
        }
        assert_eq!(t, tuning());
        assert!(t.set("m1", 4.0).unwrap_err().contains("load_noise_intensity"), "the error lists what it takes");
    }

    #[test]
    fn set_known_leaves_the_fmu_only_names_to_the_fmu_and_set_all_refuses_them() {
        let mut values = StartValues::none();
        values.insert("load_noise_intensity", 2e6);
        values.insert("m1", 4.5);
        let mut t = tuning();
        assert_eq!(t.set_known(&values).unwrap(), vec!["m1".to_string()]);
        assert_eq!(t.load_intensity, 2e6);
        let mut t = tuning();
        assert!(t.set_all(&values).unwrap_err().contains("m1"));
    }

    #[test]
    fn the_unseen_cases_have_no_paper_figures() {
        assert!(Case::ALL.iter().all(|c| published(c).is_some()));
        assert!(Case::UNSEEN.iter().all(|c| published(c).is_none()));
    }
}
