//! `kalfmu replay`: runs one filter of the library on measurements given as
//! JSON and writes the estimates as JSON, so that other implementations
//! (filterpy in the Python suite) can be compared on identical data.
//!
//! The spec (a JSON object; unknown fields are refused):
//!
//! ```text
//! model         "oscillator_2dof_stiffness" | "oscillator_2dof_damping" | "wheel_rail_vertical_24"
//! substeps      RK4 steps per sample (default 1)
//! filter        CKF | SRCKF | SVD-CKF | UKF | EKF (any case)
//! ukf           {"alpha", "beta", "kappa"} for the UKF (each optional; default 1e-3, 2, 0)
//! q, r          process / measurement noise: a list (the diagonal) or a list of rows
//! x0, p0        the prior mean (list) and covariance (diagonal list or list of rows)
//! dt            the sample period (s)
//! measurements  one row of m values per sample; null marks a missing value
//! first_at_prior  true: the first row is measured at the prior's time (default false)
//! repeat        run the whole sequence this many times, for timing (default 1)
//! ```
//!
//! Each sample is one `predict(&[], dt)` then one `update(row)`; with
//! `first_at_prior` the first row is an update only, at the prior's time, as
//! an estimator FMU takes the inputs set at its start time. The output
//! holds, per sample, the mean and the standard deviations before the update
//! (`predicted_means`, `predicted_std`: what an estimator FMU outputs right
//! after the step to that sample), the mean and the covariance after the update (row-major
//! `n × n`), the NIS, the log-likelihood and the number of rows used, and
//! `step_ns`: the mean wall-clock time of one predict + update (+ storing the
//! estimate in preallocated buffers) over all repetitions. With `repeat > 1`
//! the estimates are those of the last repetition (they are all identical).

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::PathBuf;
use std::str::FromStr;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context};
use estimator::models::{Oscillator2Dof, Oscillator2DofLoad, VerticalVehicle, WheelRailVertical};
use estimator::{
    build_filter, Discretized, FilterError, FilterKind, Gaussian, Model, Noise, StateEstimator, UnscentedParams,
    VectorField,
};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Command-line arguments of `kalfmu replay`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON spec to read (standard input when absent).
    #[arg(long, value_name = "PATH")]
    pub input: Option<PathBuf>,
    /// Where to write the JSON results (standard output when absent).
    #[arg(long, value_name = "PATH")]
    pub output: Option<PathBuf>,
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let text = match &args.input {
        Some(path) => {
            std::fs::read_to_string(path).with_context(|| format!("cannot read the spec {}", path.display()))?
        }
        None => {
            let mut text = String::new();
            std::io::stdin().read_to_string(&mut text).context("cannot read the spec from standard input")?;
            text
        }
    };
    let output = Replay::from_json(&text)?.run()?;
    match &args.output {
        Some(path) => {
            let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
            write_json(BufWriter::new(file), &output).with_context(|| format!("cannot write {}", path.display()))
        }
        None => write_json(BufWriter::new(std::io::stdout().lock()), &output).context("cannot write the results"),
    }
}

fn write_json<W: Write>(mut out: W, output: &Output) -> anyhow::Result<()> {
    serde_json::to_writer(&mut out, output)?;
    out.write_all(b"\n")?;
    out.flush()?;
    Ok(())
}

/// The spec as written in JSON, before validation.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Model name (see [`ModelKind`]).
    pub model: String,
    /// RK4 steps per sample.
    #[serde(default = "one")]
    pub substeps: usize,
    /// Filter name, parsed by [`FilterKind::from_str`].
    pub filter: String,
    /// Unscented parameters (UKF only).
    #[serde(default)]
    pub ukf: Option<UkfSpec>,
    /// Process noise `Q`: diagonal list or list of rows.
    pub q: Value,
    /// Measurement noise `R`: diagonal list or list of rows.
    pub r: Value,
    /// Prior mean.
    pub x0: Vec<f64>,
    /// Prior covariance: diagonal list or list of rows.
    pub p0: Value,
    /// Sample period.
    pub dt: f64,
    /// Measurement rows; `null` is a missing value.
    pub measurements: Vec<Vec<Option<f64>>>,
    /// The first row is the measurement at the prior's time (no predict before it).
    #[serde(default)]
    pub first_at_prior: bool,
    /// How many times to run the sequence.
    #[serde(default = "one")]
    pub repeat: usize,
}

fn one() -> usize {
    1
}

/// The scaled unscented parameters; a missing field takes its default.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UkfSpec {
    /// Spread `α`.
    pub alpha: Option<f64>,
    /// `β`.
    pub beta: Option<f64>,
    /// `κ`.
    pub kappa: Option<f64>,
}

/// The models a replay can run, all discretised by RK4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelKind {
    /// `Oscillator2DofLoad` on `Oscillator2Dof::stiffness_nonlinear()` (n = 6, m = 2).
    Oscillator2DofStiffness,
    /// `Oscillator2DofLoad` on `Oscillator2Dof::damping_nonlinear()` (n = 6, m = 2).
    Oscillator2DofDamping,
    /// Study S2's `WheelRailVertical` on `VerticalVehicle::zhai_passenger()` (n = 24, m = 7).
    WheelRailVertical24,
}

impl ModelKind {
    /// Every model, in a fixed order.
    pub const ALL: [ModelKind; 3] =
        [ModelKind::Oscillator2DofStiffness, ModelKind::Oscillator2DofDamping, ModelKind::WheelRailVertical24];

    /// The name used in specs.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Oscillator2DofStiffness => "oscillator_2dof_stiffness",
            ModelKind::Oscillator2DofDamping => "oscillator_2dof_damping",
            ModelKind::WheelRailVertical24 => "wheel_rail_vertical_24",
        }
    }

    /// State and measurement dimensions `(n, m)`.
    pub fn dims(self) -> (usize, usize) {
        match self {
            ModelKind::Oscillator2DofStiffness | ModelKind::Oscillator2DofDamping => (6, 2),
            ModelKind::WheelRailVertical24 => {
                let model = wheel_rail();
                (VectorField::state_dim(&model), estimator::Observation::measurement_dim(&model))
            }
        }
    }
}

/// Study S2's estimation model on the catalogue vehicle.
fn wheel_rail() -> WheelRailVertical {
    WheelRailVertical { vehicle: VerticalVehicle::zhai_passenger() }
}

impl FromStr for ModelKind {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|k| k.name()).collect();
            anyhow::anyhow!("unknown model '{s}'; expected one of {}", names.join(", "))
        })
    }
}

/// A validated replay: everything needed to build the filter and run it.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The model.
    pub model: ModelKind,
    /// RK4 steps per sample.
    pub substeps: usize,
    /// The filter.
    pub kind: FilterKind,
    /// Unscented parameters (used by the UKF only).
    pub ukf: UnscentedParams,
    /// `Q` and `R`.
    pub noise: Noise,
    /// The prior at `t = 0`.
    pub prior: Gaussian,
    /// Sample period.
    pub dt: f64,
    /// The measurements, row after row (`steps × m`, NaN where missing).
    pub measurements: Vec<f64>,
    /// Number of samples.
    pub steps: usize,
    /// The first row is measured at the prior's time.
    pub first_at_prior: bool,
    /// Repetitions of the whole sequence.
    pub repeat: usize,
}

/// The results of a replay, as written in JSON.
#[derive(Debug, Clone, Serialize)]
pub struct Output {
    /// The filter's short name.
    pub filter: String,
    /// The model's name.
    pub model: String,
    /// State dimension.
    pub n: usize,
    /// Measurement dimension.
    pub m: usize,
    /// Number of samples.
    pub steps: usize,
    /// Repetitions run.
    pub repeat: usize,
    /// Mean before each update (after its predict; the prior for a first row at the prior's time).
    pub predicted_means: Vec<Vec<f64>>,
    /// Standard deviations before each update (square roots of the diagonal of `P`).
    pub predicted_std: Vec<Vec<f64>>,
    /// Mean after each update.
    pub means: Vec<Vec<f64>>,
    /// Covariance after each update (rows of `P`).
    pub covariances: Vec<Vec<Vec<f64>>>,
    /// NIS of each update (0 when no row was used).
    pub nis: Vec<f64>,
    /// Log-likelihood of each update (0 when no row was used).
    pub log_likelihood: Vec<f64>,
    /// Rows of `z` used by each update.
    pub rows_used: Vec<usize>,
    /// Mean wall-clock nanoseconds per predict + update (storing the estimate
    /// in preallocated buffers included; building the filter and the output not).
    pub step_ns: f64,
}

impl Replay {
    /// Parses and validates a JSON spec.
    pub fn from_json(text: &str) -> anyhow::Result<Self> {
        let spec: Spec = serde_json::from_str(text).context("invalid replay spec")?;
        Self::from_spec(spec)
    }

    /// Validates a spec: names, dimensions, positivity; builds `Q`, `R` and the prior.
    pub fn from_spec(spec: Spec) -> anyhow::Result<Self> {
        let model: ModelKind = spec.model.parse()?;
        let kind: FilterKind = spec.filter.parse()?;
        let (n, m) = model.dims();
        ensure!(spec.substeps >= 1, "substeps must be at least 1, got {}", spec.substeps);
        ensure!(spec.repeat >= 1, "repeat must be at least 1, got {}", spec.repeat);
        ensure!(spec.dt > 0.0 && spec.dt.is_finite(), "dt must be positive and finite, got {}", spec.dt);
        let ukf = match (&spec.ukf, kind) {
            (None, _) => UnscentedParams::default(),
            (Some(u), FilterKind::Ukf) => {
                let d = UnscentedParams::default();
                UnscentedParams {
                    alpha: u.alpha.unwrap_or(d.alpha),
                    beta: u.beta.unwrap_or(d.beta),
                    kappa: u.kappa.unwrap_or(d.kappa),
                }
            }
            (Some(_), other) => bail!("'ukf' parameters apply to the UKF only, but the filter is {other}"),
        };
        let (q, r) = (matrix("q", &spec.q, n)?, matrix("r", &spec.r, m)?);
        let noise = Noise::new(q, r).context("invalid noise covariances")?;
        ensure!(spec.x0.len() == n, "x0 has {} values, the model {} has {n} states", spec.x0.len(), model.name());
        let prior = Gaussian { mean: DVector::from_column_slice(&spec.x0), covariance: matrix("p0", &spec.p0, n)? };
        ensure!(!spec.measurements.is_empty(), "measurements is empty: nothing to replay");
        let steps = spec.measurements.len();
        let mut measurements = Vec::with_capacity(steps * m);
        for (k, row) in spec.measurements.iter().enumerate() {
            ensure!(
                row.len() == m,
                "measurements[{k}] has {} values, the model {} measures {m}",
                row.len(),
                model.name()
            );
            measurements.extend(row.iter().map(|v| v.unwrap_or(f64::NAN)));
        }
        Ok(Self {
            model,
            substeps: spec.substeps,
            kind,
            ukf,
            noise,
            prior,
            dt: spec.dt,
            measurements,
            steps,
            first_at_prior: spec.first_at_prior,
            repeat: spec.repeat,
        })
    }

    /// Builds the filter on the model, at `t = 0` from the prior.
    pub fn build(&self) -> anyhow::Result<Box<dyn StateEstimator>> {
        let filter = match self.model {
            ModelKind::Oscillator2DofStiffness => {
                self.build_on(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()))
            }
            ModelKind::Oscillator2DofDamping => {
                self.build_on(Oscillator2DofLoad::new(Oscillator2Dof::damping_nonlinear()))
            }
            ModelKind::WheelRailVertical24 => self.build_on(wheel_rail()),
        };
        filter.with_context(|| format!("cannot build the {} filter on {}", self.kind, self.model.name()))
    }

    fn build_on<F>(&self, field: F) -> Result<Box<dyn StateEstimator>, FilterError>
    where
        F: VectorField + estimator::Observation + 'static,
        Discretized<F>: Model,
    {
        build_filter(self.kind, Discretized::rk4(field, self.substeps), self.noise.clone(), &self.prior, self.ukf)
    }

    /// Runs the filter over the measurements `repeat` times and collects the
    /// estimates of the last run. A filter error names the step and its time.
    pub fn run(&self) -> anyhow::Result<Output> {
        let mut filter = self.build()?;
        let (n, m, steps) = (filter.state_dim(), filter.measurement_dim(), self.steps);
        let mut means = vec![0.0; steps * n];
        let mut predicted_means = vec![0.0; steps * n];
        let mut predicted_std = vec![0.0; steps * n];
        let mut covariances = vec![0.0; steps * n * n];
        let mut nis = vec![0.0; steps];
        let mut log_likelihood = vec![0.0; steps];
        let mut rows_used = vec![0usize; steps];
        let mut p = filter.covariance();
        let mut elapsed = Duration::ZERO;
        for _ in 0..self.repeat {
            filter.reset(0.0, &self.prior).context("cannot reset the filter")?;
            let start = Instant::now();
            for k in 0..steps {
                let z = &self.measurements[k * m..(k + 1) * m];
                let update_only = k == 0 && self.first_at_prior;
                if !update_only {
                    if let Err(err) = filter.predict(&[], self.dt) {
                        return Err(step_error(k, filter.time() + self.dt, "predict", err));
                    }
                }
                predicted_means[k * n..(k + 1) * n].copy_from_slice(filter.mean().as_slice());
                for (i, s) in predicted_std[k * n..(k + 1) * n].iter_mut().enumerate() {
                    *s = filter.variance(i).max(0.0).sqrt();
                }
                let innovation = match filter.update(z) {
                    Ok(innovation) => innovation,
                    Err(err) => return Err(step_error(k, filter.time(), "update", err)),
                };
                nis[k] = innovation.nis();
                log_likelihood[k] = innovation.log_likelihood();
                rows_used[k] = innovation.rows_used();
                means[k * n..(k + 1) * n].copy_from_slice(filter.mean().as_slice());
                filter.write_covariance(&mut p);
                covariances[k * n * n..(k + 1) * n * n].copy_from_slice(p.as_slice());
            }
            elapsed += start.elapsed();
        }
        let step_ns = elapsed.as_nanos() as f64 / (self.repeat * steps) as f64;
        Ok(Output {
            filter: self.kind.name().to_owned(),
            model: self.model.name().to_owned(),
            n,
            m,
            steps,
            repeat: self.repeat,
            predicted_means: predicted_means.chunks_exact(n).map(<[f64]>::to_vec).collect(),
            predicted_std: predicted_std.chunks_exact(n).map(<[f64]>::to_vec).collect(),
            means: means.chunks_exact(n).map(<[f64]>::to_vec).collect(),
            // Stored column-major; written as rows of P.
            covariances: covariances
                .chunks_exact(n * n)
                .map(|c| (0..n).map(|i| (0..n).map(|j| c[j * n + i]).collect()).collect())
                .collect(),
            nis,
            log_likelihood,
            rows_used,
            step_ns,
        })
    }
}

fn step_error(k: usize, t: f64, stage: &str, err: FilterError) -> anyhow::Error {
    anyhow::Error::new(err).context(format!("step {k} (t = {t} s): {stage} failed"))
}

/// An `n × n` matrix from JSON: a list of `n` numbers (the diagonal) or a
/// list of `n` rows of `n` numbers.
fn matrix(name: &str, value: &Value, n: usize) -> anyhow::Result<DMatrix<f64>> {
    let shape = || format!("{name} must be a list of {n} numbers (the diagonal) or a list of {n} rows of {n} numbers");
    let list = value.as_array().with_context(|| format!("{}, got {}", shape(), kind_of(value)))?;
    ensure!(list.len() == n, "{}, got a list of length {}", shape(), list.len());
    let number = |v: &Value, at: String| -> anyhow::Result<f64> {
        v.as_f64().with_context(|| format!("{name}{at} must be a number, got {}", kind_of(v)))
    };
    let mut out = DMatrix::zeros(n, n);
    if list.iter().all(Value::is_array) {
        for (i, row) in list.iter().enumerate() {
            let row = row.as_array().expect("checked above");
            ensure!(row.len() == n, "{}; row {i} has length {}", shape(), row.len());
            for (j, v) in row.iter().enumerate() {
                out[(i, j)] = number(v, format!("[{i}][{j}]"))?;
            }
        }
    } else {
        for (i, v) in list.iter().enumerate() {
            out[(i, i)] = number(v, format!("[{i}]"))?;
        }
    }
    Ok(out)
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s1_spec(filter: &str, extra: &str) -> String {
        format!(
            r#"{{"model": "oscillator_2dof_stiffness", "filter": "{filter}", {extra}
                "q": [1e-8, 1e-8, 1e-2, 1e-6, 1e-6, 10.0], "r": [[1e-4, 0.0], [0.0, 1e-4]],
                "x0": [0, 0, 0, 0, 0, 0], "p0": [1e-2, 1e-2, 100, 1e-2, 1e-2, 100], "dt": 0.005,
                "measurements": [[0.1, -0.05], [null, 0.02], [0.08, 0.01], [null, null]]}}"#
        )
    }

    fn error_of(text: &str) -> String {
        format!("{:#}", Replay::from_json(text).unwrap_err())
    }

    #[test]
    fn spec_parses_with_defaults_diagonal_and_full_matrices_and_missing_values() {
        let replay = Replay::from_json(&s1_spec("srckf", "")).unwrap();
        assert_eq!(replay.model, ModelKind::Oscillator2DofStiffness);
        assert_eq!(replay.kind, FilterKind::SrCkf);
        assert_eq!((replay.substeps, replay.repeat, replay.steps), (1, 1, 4));
        assert_eq!(replay.ukf, UnscentedParams::default());
        assert_eq!(replay.noise.q()[(2, 2)], 1e-2);
        assert_eq!(replay.noise.q()[(0, 1)], 0.0);
        assert_eq!(replay.noise.r()[(1, 1)], 1e-4);
        assert_eq!(replay.prior.covariance[(5, 5)], 100.0);
        assert_eq!(replay.measurements.len(), 8);
        assert!(replay.measurements[2].is_nan() && replay.measurements[3] == 0.02);

        let ukf = Replay::from_json(&s1_spec("UKF", r#""ukf": {"alpha": 0.5}, "substeps": 3, "repeat": 2,"#)).unwrap();
        assert_eq!(ukf.ukf, UnscentedParams { alpha: 0.5, beta: 2.0, kappa: 0.0 });
        assert_eq!((ukf.substeps, ukf.repeat), (3, 2));
    }

    #[test]
    fn invalid_specs_are_refused_with_the_reason() {
        let spec = s1_spec("CKF", "").replace("oscillator_2dof_stiffness", "pendulum");
        assert!(error_of(&spec).contains("unknown model 'pendulum'; expected one of"), "{}", error_of(&spec));
        assert!(error_of(&s1_spec("kalman", "")).contains("unknown filter 'kalman'"));
        let spec = s1_spec("CKF", "").replace("[0.08, 0.01]", "[0.08]");
        assert!(
            error_of(&spec).contains("measurements[2] has 1 values, the model oscillator_2dof_stiffness measures 2")
        );
        let spec = s1_spec("CKF", "").replace("[0, 0, 0, 0, 0, 0]", "[0, 0]");
        assert!(error_of(&spec).contains("x0 has 2 values"));
        let spec = s1_spec("CKF", "").replace("[[1e-4, 0.0], [0.0, 1e-4]]", "[[1e-4, 0.0], [0.0]]");
        assert!(error_of(&spec).contains("r must be a list of 2 numbers (the diagonal) or a list of 2 rows"));
        let spec = s1_spec("CKF", "").replace("[[1e-4, 0.0], [0.0, 1e-4]]", "[1e-4, -1.0]");
        assert!(error_of(&spec).contains("positive semi-definite"), "{}", error_of(&spec));
        assert!(error_of(&s1_spec("CKF", r#""ukf": {"alpha": 1},"#)).contains("UKF only"));
        assert!(error_of(&s1_spec("CKF", r#""repeat": 0,"#)).contains("repeat must be at least 1"));
        assert!(error_of(&s1_spec("CKF", r#""tolerance": 1,"#)).contains("unknown field `tolerance`"));
        let spec = s1_spec("CKF", "").replace("0.005", "-1");
        assert!(error_of(&spec).contains("dt must be positive"));
    }

    #[test]
    fn a_tiny_run_gives_one_estimate_per_row_and_the_ukf_with_1_0_0_is_the_ckf() {
        let ckf = Replay::from_json(&s1_spec("CKF", "")).unwrap().run().unwrap();
        assert_eq!((ckf.filter.as_str(), ckf.n, ckf.m, ckf.steps), ("CKF", 6, 2, 4));
        assert_eq!(ckf.means.len(), 4);
        assert_eq!(ckf.covariances.len(), 4);
        assert!(ckf.covariances.iter().all(|p| p.len() == 6 && p.iter().all(|row| row.len() == 6)));
        assert_eq!(ckf.rows_used, vec![2, 1, 2, 0]);
        assert_eq!((ckf.nis[3], ckf.log_likelihood[3]), (0.0, 0.0));
        assert!(ckf.nis[..3].iter().all(|v| v.is_finite() && *v > 0.0));
        assert!(ckf.step_ns > 0.0);
        // A fully missing row changes nothing after the prediction; P stays symmetric.
        assert!(ckf.covariances[3][2][2] > ckf.covariances[2][2][2]);
        assert_eq!(ckf.covariances[1][0][3], ckf.covariances[1][3][0]);

        let ukf = Replay::from_json(&s1_spec("UKF", r#""ukf": {"alpha": 1, "beta": 0, "kappa": 0},"#)).unwrap();
        let ukf = ukf.run().unwrap();
        for (a, b) in ckf.means.iter().flatten().zip(ukf.means.iter().flatten()) {
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-6), "{a} vs {b}");
        }
    }

    #[test]
    fn repeated_runs_report_the_results_of_the_last_identical_repetition() {
        let once = Replay::from_json(&s1_spec("SRCKF", "")).unwrap().run().unwrap();
        let thrice = Replay::from_json(&s1_spec("SRCKF", r#""repeat": 3,"#)).unwrap().run().unwrap();
        assert_eq!(thrice.repeat, 3);
        assert_eq!(once.means, thrice.means);
        assert_eq!(once.covariances, thrice.covariances);
        assert_eq!(once.nis, thrice.nis);
    }

    #[test]
    fn every_model_and_filter_runs() {
        for model in ModelKind::ALL {
            let (n, m) = model.dims();
            for kind in FilterKind::ALL {
                let spec = serde_json::json!({
                    "model": model.name(), "filter": kind.name(), "substeps": 2,
                    "q": vec![1e-6; n], "r": vec![1e-4; m], "x0": vec![0.0; n], "p0": vec![1e-2; n], "dt": 1e-3,
                    "measurements": vec![vec![0.01; m]; 3],
                });
                let out = Replay::from_json(&spec.to_string()).unwrap().run().unwrap();
                assert_eq!((out.n, out.m, out.means.len()), (n, m, 3), "{} on {}", kind, model.name());
                assert!(out.means.iter().flatten().all(|v| v.is_finite()));
            }
        }
    }

    /// A wheel–rail replay at rest: zero motion, every force at `forces`, no acceleration measured.
    fn wheel_rail_at_rest(forces: f64) -> Output {
        let mut x0 = [0.0; 24];
        x0[WheelRailVertical::FORCES..].fill(forces);
        let q = [[1e-8; 6].as_slice(), &[1e-10; 4], &[1e-8; 6], &[1e-10; 4], &[1e7; 4]].concat();
        let p0 = [[1e-6; 10].as_slice(), &[1e-4; 10], &[1e6; 4]].concat();
        let spec = serde_json::json!({
            "model": "wheel_rail_vertical_24", "filter": "SRCKF", "substeps": 2,
            "q": q, "r": vec![1e-2; 7], "x0": x0, "p0": p0, "dt": 1e-3,
            "measurements": vec![vec![0.0; 7]; 5],
        });
        let out = Replay::from_json(&spec.to_string()).unwrap().run().unwrap();
        assert_eq!((out.model.as_str(), out.n, out.m), ("wheel_rail_vertical_24", 24, 7));
        out
    }

    #[test]
    fn the_wheel_rail_model_rests_under_zhai_s_static_wheel_load() {
        // Carrying its static wheel load, the catalogue car measures no acceleration: the
        // estimate stays at rest (up to rounding in the sigma points' sums).
        let p_st = VerticalVehicle::zhai_passenger().static_wheel_load;
        let rest = wheel_rail_at_rest(p_st);
        for x in &rest.means {
            assert!(x[..20].iter().all(|v| v.abs() < 1e-12), "{x:?}");
            assert!(x[20..].iter().all(|f| (f - p_st).abs() < 1e-6 * p_st), "{x:?}");
        }
        // A car carrying 1 kN more per wheel would be accelerated: the zero readings pull the
        // forces back down towards Zhai's load.
        let heavier = wheel_rail_at_rest(p_st + 1e3);
        for f in &heavier.means[4][20..] {
            assert!(*f < p_st + 500.0, "{f} N: not pulled towards the static load {p_st} N");
        }
    }

    #[test]
    fn a_filter_failure_names_the_step_its_time_and_the_error() {
        // P0 = 0 has no Cholesky factor: the CKF cannot spread its points.
        let spec = s1_spec("CKF", "").replace("[1e-2, 1e-2, 100, 1e-2, 1e-2, 100]", "[0, 0, 0, 0, 0, 0]");
        let err = format!("{:#}", Replay::from_json(&spec).unwrap().run().unwrap_err());
        assert!(err.contains("step 0 (t = 0.005 s): predict failed"), "{err}");
        assert!(err.contains("state covariance P is not positive definite"), "{err}");
    }
}
