//! S5 in `kalfmu reproduce`, for both truths. The first (our 6-DOF, as the paper has
//! it): the flight measured once, then every filter through the packaged FMU, checked bit
//! for bit against the same filter in-process. The second: JSBSim flies the missile on its
//! own rotating Earth in its own atmosphere, and its Python driver steps the packaged FMU
//! through fmpy, as a flight simulator would (`truth/s5_jsbsim/fly.py`), once per
//! filter. For each: the paper's Tables 1 and 2 with each filter's relative error beside
//! the paper's SVD-CKF, and the time to come back after the change; one log per run and
//! one comparison recording per truth (`out/s5/`), and the tables' figures as `table.json`
//! there ([`Table`]). Per filter, whether its σ of the coefficients is honest, from the
//! analyzer's report of its log (docs/analyzer.md, "Is the σ honest?"): their NEES, each
//! coefficient's 1σ and 2σ coverage and mean (e/σ)² with its reading, and the NIS against
//! the measurement rows used.
//!
//! Every FMU run also smooths the coefficients (`smoothing_lag` [`SMOOTHING_LAG`], 20
//! samples: a fixed-lag smoother inside the FMU; on `/smoothed` in our runs' logs, and
//! rebuilt from the `_smoothed` outputs and `smoothed_time` on the JSBSim driver's
//! `/estimate`). The tables give each filter's smoothed estimate's relative error beside
//! its filtered one: of Table 1's instant, and for Table 2 of the last instant the smoothed
//! estimates reach, the lag before the end ([`SmoothedRun`]).
//!
//! Beside the published manoeuvre, each truth flies `roll-turn`
//! ([`truth::s5::manoeuvre::Manoeuvre::roll_turn`]), one the tuning was not chosen on and
//! the paper does not fly: the same figures, its paper columns blank (`null` in the
//! JSON). `--quick` flies it on the first truth only.
//!
//! Start values (`--set`, `--values`) go to every FMU run, ours and the JSBSim driver's,
//! over the study's parameters and, where the in-process filter has them
//! ([`Tuning::set`]), to the in-process run the first truth's are checked against. Those
//! it does not have (the airframe's, the supervisor's, `filter`, `sample_time`, …) reach
//! the FMU only: its difference from the in-process run then measures what they change,
//! which the `vs library` line says.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use start_values::{SetByName, StartValues};

use analyzer::compare::Comparison;
use analyzer::consistency::{Nees, Nis, NormalisedError, Reading};
use analyzer::report::{analyse, Options, Report};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::{read_log, Channel, Run, Signal};
use log_format::write::{SignalSpec, ESTIMATE, SMOOTHED, TRUTH};
use serde::Serialize;

use super::fmu_run::{self, Flown, IDENTIFIER};
use super::study::{run_filter, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of, units, write_table, Compared};
use crate::smoothed::{SmoothedFigures, SMOOTHING_LAG};
use cosim::fmu_driver::{filter_enumeration, ImportedFmu};
use truth::s5::flight::{measure, simulate_named, Settings};
use truth::s5::manoeuvre::Manoeuvre;
use truth::s5::parameters::{NAMES, PAPER_SVD_CKF_AFTER, PAPER_SVD_CKF_BEFORE};

/// The metrics, the ±2σ coverage and the spectra of the recordings are taken from here
/// on (s): the filters' start-up left out.
const SETTLE: f64 = 0.5;

/// One filter's run through the FMU: its coefficients and the true ones, sample by sample.
struct FilterRun {
    kind: FilterKind,
    coefficients: Vec<[f64; 10]>,
    /// The coefficients in force, sample by sample.
    truth: Vec<[f64; 10]>,
    /// What the first truth's runs check besides (the JSBSim driver has no in-process twin).
    checked: Option<Checked>,
    /// What the analyzer's report of its log says of its σ (`None` until the runs are
    /// compared, or if they could not be).
    sigma: Option<RunSigma>,
    /// Its smoothed coefficients (`None` if they could not be read).
    smoothed: Option<SmoothedRun>,
}

/// A run's fixed-lag smoothed coefficients, from its log's `/smoothed` by the analyzer:
/// each stamped with the time it describes, the last the lag before the run's end.
struct SmoothedRun {
    /// The times described (s).
    time: Vec<f64>,
    /// The smoothed coefficients at those times.
    coefficients: Vec<[f64; 10]>,
    /// The coefficients in force then.
    truth: Vec<[f64; 10]>,
    /// Each coefficient's smoothed figures from [`SETTLE`] on, by name.
    figures: BTreeMap<&'static str, SmoothedFigures>,
}

impl SmoothedRun {
    /// The smoothed coefficients of `run`, the analyzer's pairs of its `/smoothed` with its truth.
    fn of(run: &Run) -> anyhow::Result<Self> {
        let report = analyse(run, &Options { estimate_topic: SMOOTHED.into(), from: SETTLE, ..Options::default() })?;
        let pairs = NAMES
            .iter()
            .map(|&name| {
                let pair = report.pairs.iter().find(|p| p.truth == name);
                pair.with_context(|| format!("{} has no smoothed {name}", run.file.display()))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let time = pairs[0].time.to_vec();
        anyhow::ensure!(pairs.iter().all(|p| *p.time == *time), "the smoothed coefficients' times differ");
        let rows = |columns: Vec<&[f64]>| -> Vec<[f64; 10]> {
            (0..time.len()).map(|k| std::array::from_fn(|i| columns[i][k])).collect()
        };
        let figures = NAMES
            .iter()
            .zip(&pairs)
            .map(|(&name, pair)| {
                let figures = SmoothedFigures {
                    lag: SMOOTHING_LAG,
                    correlation: pair.metrics.correlation,
                    rmse_converged: pair.metrics.rmse_converged,
                    one_sigma_coverage: pair.one_sigma_coverage,
                    two_sigma_coverage: pair.two_sigma_coverage,
                };
                (name, figures)
            })
            .collect();
        Ok(Self {
            coefficients: rows(pairs.iter().map(|p| &*p.estimate_values).collect()),
            truth: rows(pairs.iter().map(|p| &*p.truth_values).collect()),
            time,
            figures,
        })
    }

    /// The index of the smoothed estimate of time `t` (to the nanosecond), if there is one.
    fn at(&self, t: f64) -> Option<usize> {
        let ns = |t: f64| (t * 1e9).round() as i64;
        self.time.binary_search_by_key(&ns(t), |&s| ns(s)).ok()
    }
}

/// The JSBSim driver's log with the `/smoothed` channel our runs' logs have: its
/// `/estimate` has every output of the FMU, so the `_smoothed` ones and their
/// `smoothed_time`, each logged once per time it describes, as the co-simulation master
/// logs them (`cosim::master`).
fn with_smoothed_channel(mut run: Run) -> anyhow::Result<Run> {
    let estimate = run.channel(ESTIMATE)?;
    let column = |name: &str| {
        let signal = estimate.signal(name).with_context(|| format!("{ESTIMATE} has no {name}"));
        signal.map(|s| s.values.as_slice())
    };
    let described = column("smoothed_time")?;
    let mut kept = Vec::new();
    let mut last = f64::NEG_INFINITY;
    for (k, &t) in described.iter().enumerate() {
        if t > last {
            kept.push(k);
            last = t;
        }
    }
    let mut signals = Vec::new();
    for suffix in ["", "_std"] {
        for name in NAMES {
            let values = column(&format!("{name}_smoothed{suffix}"))?;
            let unit = estimate.signal(name).map(|s| s.spec.unit.clone()).unwrap_or_default();
            signals.push(Signal {
                spec: SignalSpec::new(&format!("{name}{suffix}"), &unit, "FMU fixed-lag smoothed output"),
                values: kept.iter().map(|&k| values[k]).collect(),
            });
        }
    }
    let time = kept.iter().map(|&k| described[k]).collect();
    run.channels.push(Channel { topic: SMOOTHED.into(), time, signals });
    Ok(run)
}

/// The analyzer's figures of a run's σ: of the coefficients and of its innovations.
#[derive(Debug, Clone)]
struct RunSigma {
    nees: Option<Nees>,
    nis: Option<Nis>,
    coefficients: BTreeMap<&'static str, SignalSigma>,
}

impl RunSigma {
    /// The figures of `report`, the analyzer's report of a run's log.
    fn of(report: &Report<'_>) -> Self {
        let coefficients = NAMES
            .iter()
            .filter_map(|&name| {
                let pair = report.pairs.iter().find(|p| p.truth == name)?;
                let sigma = SignalSigma {
                    one_sigma_coverage: pair.one_sigma_coverage,
                    two_sigma_coverage: pair.two_sigma_coverage,
                    normalised_error: pair.normalised_error,
                };
                Some((name, sigma))
            })
            .collect();
        Self { nees: report.nees.clone(), nis: report.nis.clone(), coefficients }
    }

    /// The lowest coverage of the coefficients, by `coverage`; `None` if none has a σ.
    fn coverage_min(&self, coverage: fn(&SignalSigma) -> Option<f64>) -> Option<f64> {
        self.coefficients.values().filter_map(coverage).reduce(f64::min)
    }

    /// The coefficient whose mean `(e/σ)²` is the farthest from 1 in ratio, with it.
    fn worst(&self) -> Option<(&'static str, NormalisedError)> {
        let distance = |n: &NormalisedError| n.mean_square.ln().abs();
        self.coefficients
            .iter()
            .filter_map(|(&name, s)| s.normalised_error.map(|n| (name, n)))
            .max_by(|a, b| distance(&a.1).total_cmp(&distance(&b.1)))
    }
}

/// Each run's [`RunSigma`] from the comparison of their logs, `comparison.runs[i]` being of
/// `runs[i]` (a run's log is kept exactly when the run is).
fn attach_sigma(runs: &mut [FilterRun], comparison: &Comparison<'_>) {
    for (run, report) in runs.iter_mut().zip(&comparison.runs) {
        run.sigma = Some(RunSigma::of(report));
    }
}

/// A run checked against the same filter in-process.
struct Checked {
    /// The largest difference of a coefficient from the in-process run's.
    difference: f64,
    /// Measurement rows the FMU's gate rejected.
    rejected: i32,
}

/// The figures of S5's tables, as `table.json` has them.
#[derive(Debug, Serialize)]
pub struct Table {
    /// `"S5"`.
    pub study: &'static str,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field (see [`units`]).
    pub units: BTreeMap<&'static str, &'static str>,
    /// What the paper claims of its filters.
    pub paper_claim: &'static str,
    /// Each truth flying each manoeuvre: the first truth (`6dof`, our 6-DOF) through the
    /// published manoeuvre and through `roll-turn`, then the second (`jsbsim`) the same
    /// (with `--quick`, through the published manoeuvre only).
    pub truths: Vec<TruthFigures>,
}

/// The set-up of a [`Table`].
#[derive(Debug, Serialize)]
pub struct TableSettings {
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The sample time of the measurements and of the FMU's step (s).
    pub sample_time: f64,
    /// The sensor noise as a multiple of docs/studies/s5.md's.
    pub noise_scale: f64,
    /// Whether this is `--quick`'s short set (`roll-turn` on the first truth only).
    pub quick: bool,
    /// The start values given (`--set`, `--values`), set on every FMU run over the study's
    /// parameters; empty without any.
    pub start_values: BTreeMap<String, f64>,
    /// Those of `start_values` the in-process filter does not take ([`Tuning::takes`]):
    /// they reach the FMU only, and `fmu_vs_in_process_max_abs_difference` then measures
    /// their effect.
    pub start_values_fmu_only: Vec<String>,
}

/// One truth's tables of one manoeuvre.
#[derive(Debug, Serialize)]
pub struct TruthFigures {
    /// `6dof` or `jsbsim`.
    pub truth: &'static str,
    /// The manoeuvre flown ([`Manoeuvre::NAMES`]): `standard`, the published one, or
    /// `roll-turn`.
    pub manoeuvre: &'static str,
    /// Whether the tuning was chosen on this manoeuvre: `false` for `roll-turn`, a case
    /// unlike the tuning's and not the paper's (its paper figures are `null`).
    pub tuned_on: bool,
    /// The stem of its logs and recording: `6dof`, `6dof_roll_turn`, `jsbsim`,
    /// `jsbsim_roll_turn`.
    pub case: &'static str,
    /// The runs that failed, each with why.
    pub failures: Vec<FilterFailure>,
    /// The paper's Tables 1 and 2 (empty if no run succeeded).
    pub tables: Vec<CoefficientTable>,
    /// Each successful filter's figures after the change.
    pub filters: Vec<FilterFigures>,
}

/// A run that failed.
#[derive(Debug, Serialize)]
pub struct FilterFailure {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Why it failed.
    pub failure: String,
}

/// One of the paper's tables: each coefficient's relative error at one instant.
#[derive(Debug, Serialize)]
pub struct CoefficientTable {
    /// `Table 1` (before the change) or `Table 2` (after it).
    pub table: &'static str,
    /// The instant of the estimates (s).
    pub time: f64,
    /// The instant of the smoothed estimates (s): `time` for Table 1, and for Table 2 the
    /// last the smoothed estimates reach, the lag before the end (`null` if no run has
    /// smoothed estimates there).
    pub smoothed_time: Option<f64>,
    /// The ten coefficients, in the paper's order.
    pub coefficients: Vec<CoefficientRow>,
}

/// One coefficient's row of a [`CoefficientTable`].
#[derive(Debug, Serialize)]
pub struct CoefficientRow {
    /// The coefficient (`Cx0`, …).
    pub coefficient: &'static str,
    /// Its true value at the table's instant.
    pub true_value: f64,
    /// The paper's SVD-CKF estimate (`null` for a manoeuvre the paper does not fly).
    pub paper_svd_ckf: Option<f64>,
    /// The paper's SVD-CKF's relative error from the true value (%; `null` likewise).
    pub paper_svd_ckf_relative_error: Option<f64>,
    /// Each filter's relative error from the true value (%), by filter kind.
    pub relative_error: BTreeMap<&'static str, f64>,
    /// Each filter's smoothed estimate's relative error from the true value at
    /// `smoothed_time` (%), by filter kind.
    pub smoothed_relative_error: BTreeMap<&'static str, f64>,
}

/// One filter's figures after the change (at 10 s in both manoeuvres).
#[derive(Debug, Serialize)]
pub struct FilterFigures {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Time after the change from which every coefficient stays within 3 % (s); `null`
    /// if never.
    pub back_within_3_percent: Option<f64>,
    /// The same within 1 % (s).
    pub back_within_1_percent: Option<f64>,
    /// Measurement rows the FMU's gate rejected (the first truth's runs only).
    pub rejected_rows: Option<i32>,
    /// The largest difference of a coefficient from the same filter's in-process (the
    /// first truth's runs only).
    pub fmu_vs_in_process_max_abs_difference: Option<f64>,
    /// The NEES of the ten coefficients, the analyzer's (`mean` against `dof`, and the
    /// fraction `in_band`); `null` if the runs could not be compared.
    pub nees: Option<Nees>,
    /// The NIS of the run's updates against the measurement rows they used, the analyzer's.
    pub nis: Option<Nis>,
    /// The lowest 1σ coverage of the coefficients (0.6827 each for an honest σ).
    pub one_sigma_coverage_min: Option<f64>,
    /// The lowest 2σ coverage of the coefficients (0.9545).
    pub two_sigma_coverage_min: Option<f64>,
    /// The coefficient whose mean `(e/σ)²` is the farthest from 1 in ratio.
    pub normalised_error_worst_coefficient: Option<&'static str>,
    /// Each coefficient's σ against its errors, by name.
    pub coefficients: BTreeMap<&'static str, SignalSigma>,
    /// Its smoothed coefficients' figures (`null` if the run's could not be read).
    pub smoothed: Option<SmoothedCoefficients>,
}

/// A filter's fixed-lag smoothed coefficients (the FMU's `smoothing_lag`) after the change
/// and over the run.
#[derive(Debug, Serialize)]
pub struct SmoothedCoefficients {
    /// The smoothing lag (s).
    pub lag: f64,
    /// Time after the change from which every smoothed coefficient stays within 3 %, up to
    /// the last time the smoothed estimates reach (s); `null` if never.
    pub back_within_3_percent: Option<f64>,
    /// The same within 1 % (s).
    pub back_within_1_percent: Option<f64>,
    /// Each coefficient's smoothed figures against its truth from 0.5 s on (correlation,
    /// RMSE after convergence, 1σ and 2σ coverage), by name.
    pub coefficients: BTreeMap<&'static str, SmoothedFigures>,
}

/// The analyzer's figures of one coefficient's σ against its errors.
#[derive(Debug, Clone, Serialize)]
pub struct SignalSigma {
    /// Fraction of samples whose error is within ±σ (0.6827 for an honest σ and a Gaussian
    /// error; `null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// Fraction of samples whose error is within ±2σ (0.9545).
    pub two_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (1 for an honest σ) with its reading.
    pub normalised_error: Option<NormalisedError>,
}

/// The units of S5's [`Table`].
const UNITS: [(&str, &str); 9] = [
    ("sample_time", "s"),
    ("time", "s"),
    ("smoothed_time", "s"),
    ("lag", "s"),
    ("paper_svd_ckf_relative_error", "%"),
    ("relative_error", "%"),
    ("smoothed_relative_error", "%"),
    ("back_within_3_percent", "s"),
    ("back_within_1_percent", "s"),
];

/// What the paper claims, as the tables' footnote prints it.
const PAPER_CLAIM: &str = "SVD-CKF within 3 % and CKF within 5 % of every coefficient, in both tables";

/// One truth flying one manoeuvre.
#[derive(Debug, Clone, Copy)]
struct Case {
    /// `6dof` or `jsbsim`.
    truth: &'static str,
    /// The manoeuvre's name.
    manoeuvre: &'static str,
    /// The stem of its logs and recording.
    name: &'static str,
}

impl Case {
    /// Whether the tuning was chosen on its manoeuvre, the published one.
    fn tuned_on(&self) -> bool {
        self.manoeuvre == "standard"
    }

    /// What the tables' titles and the truth's line say of the manoeuvre.
    fn manoeuvre_text(&self) -> String {
        if self.tuned_on() {
            "the published manoeuvre".into()
        } else {
            format!(
                "the {} manoeuvre (truth/data/s5_manoeuvre_roll_turn.json), one the tuning was not chosen on and \
                 the paper does not fly: no paper figures",
                self.manoeuvre
            )
        }
    }
}

/// The cases in the order printed: each truth through the published manoeuvre, then
/// through `roll-turn` (with `quick`, the first truth's only).
fn cases(quick: bool) -> Vec<Case> {
    let mut cases = vec![
        Case { truth: "6dof", manoeuvre: "standard", name: "6dof" },
        Case { truth: "6dof", manoeuvre: "roll-turn", name: "6dof_roll_turn" },
        Case { truth: "jsbsim", manoeuvre: "standard", name: "jsbsim" },
    ];
    if !quick {
        cases.push(Case { truth: "jsbsim", manoeuvre: "roll-turn", name: "jsbsim_roll_turn" });
    }
    cases
}

/// What every case's runs are given.
struct Given<'a> {
    settings: &'a Settings,
    /// The in-process filter's tuning, the start values it takes set.
    tuning: &'a Tuning,
    start_values: &'a StartValues,
    /// The start values the in-process filter does not take.
    fmu_only: &'a [String],
    fmu: &'a ImportedFmu,
    fmu_path: &'a Path,
    dir: &'a Path,
    python: &'a Path,
}

/// Runs S5 through its FMU for both truths and both manoeuvres, prints the tables and
/// writes them as `table.json` in `out/s5`; `python` runs the JSBSim driver. Returns the
/// number of failed runs.
pub fn report(
    settings: &Settings,
    start_values: &StartValues,
    quick: bool,
    fmu_dir: &Path,
    out: &Path,
    python: &Path,
) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    // A misspelt name or a value of the wrong type costs no run.
    fmu.check_start_values(start_values)?;
    let dir = out.join("s5");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut tuning = Tuning::new(settings.noise_scale);
    let fmu_only = tuning.set_known(start_values).map_err(anyhow::Error::msg)?;
    println!(
        "S5: tactical-missile force coefficients online, 20 states, 12 measurements every {} s — truth 1: the paper's \
         6-DOF (flat Earth, ISA), the ten coefficients changing at 10 s; sensor noise as docs/studies/s5.md × {}, seed {}",
        settings.sample_time, settings.noise_scale, settings.seed
    );
    println!(
        "estimates from {} driven through the fmi importer with the deflections as inputs; logs and the comparison \
         recordings in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    if let Some(line) = start_values.header(&fmu_only) {
        println!("{line}");
    }
    let fmu_path = fmu_dir.join(format!("{IDENTIFIER}.fmu"));
    let given = Given {
        settings,
        tuning: &tuning,
        start_values,
        fmu_only: &fmu_only,
        fmu: &fmu,
        fmu_path: &fmu_path,
        dir: &dir,
        python,
    };
    let mut failures = 0;
    let mut truths = Vec::new();
    for case in cases(quick) {
        let (case_failures, figures) = match case.truth {
            "6dof" => six_dof(&given, case)?,
            _ => jsbsim(&given, case)?,
        };
        failures += case_failures;
        truths.push(figures);
    }
    match run_system(&given, fmu_dir) {
        Ok((path, c)) => print_system(&path, &c),
        Err(e) => {
            failures += 1;
            println!("system: roll-turn as an SSP archive FAILED: {e:#}");
        }
    }
    if truths.iter().flat_map(|t| &t.filters).any(|f| f.smoothed.is_some()) {
        println!(
            "smoothed (after │ in the tables, and `the same, smoothed`): the FMU's fixed-lag estimates (smoothing_lag = \
             {SMOOTHING_LAG} s, {} samples: the estimate of that much before the newest sample, given the measurements \
             up to it, so known {SMOOTHING_LAG} s after the instant it describes); none of the last {SMOOTHING_LAG} s, \
             so Table 2's are of the last instant they reach (the coefficients there being Table 2's too), and the \
             time back within 3 % / 1 % is of the instants described up to it; each σ line ends with the filter's \
             lowest smoothed 1σ/2σ coverage of the coefficients (from {SETTLE} s on)",
            (SMOOTHING_LAG / settings.sample_time).round()
        );
    }
    write_table(
        &dir,
        &Table {
            study: "S5",
            settings: TableSettings {
                seed: settings.seed,
                sample_time: settings.sample_time,
                noise_scale: settings.noise_scale,
                quick,
                start_values: start_values.iter().map(|(n, v)| (n.to_string(), v)).collect(),
                start_values_fmu_only: fmu_only.clone(),
            },
            units: units(&UNITS),
            paper_claim: PAPER_CLAIM,
            truths,
        },
    )?;
    Ok(failures)
}

/// The manoeuvre the system case flies: one the estimators were not tuned on.
const SYSTEM_MANOEUVRE: &str = "roll-turn";

/// Writes the first truth through [`SYSTEM_MANOEUVRE`] as a system of the plant and
/// estimator FMUs (`<dir>/s5_system.ssp`), runs it and compares it with that case's
/// in-process run of SVD-CKF.
fn run_system(given: &Given<'_>, fmu_dir: &Path) -> anyhow::Result<(PathBuf, crate::system::Compared)> {
    let kind = FilterKind::SvdCkf;
    let system = super::system::system(SYSTEM_MANOEUVRE, given.settings, kind, given.start_values, given.fmu)?;
    let path = given.dir.join("s5_system.ssp");
    crate::system::write(&system, fmu_dir, &path)?;
    let unpack = given.dir.join(".s5_system_fmus");
    let case = cases(true).into_iter().find(|c| c.truth == "6dof" && c.manoeuvre == SYSTEM_MANOEUVRE);
    let in_process = log_path(&given.dir.join(case.context("the system's case is one of the cases")?.name), kind);
    let compared = crate::system::run_and_compare(&path, &unpack, &NAMES, &in_process)?;
    Ok((path, compared))
}

/// The system case's line: its coefficients' figures against the plant's, beside the
/// in-process run's estimates.
fn print_system(path: &Path, c: &crate::system::Compared) {
    let pairs = &c.run.pairs;
    let worst = |f: fn(&crate::system::PairFigures) -> f64| pairs.iter().map(|(_, p)| f(p)).fold(f64::NAN, f64::min);
    let rmse: Vec<String> = pairs.iter().map(|(n, p)| format!("{n} {}", significant(p.rmse))).collect();
    println!(
        "system: truth 1 through {SYSTEM_MANOEUVRE} as an SSP archive, the plant FMU kalfmu_s5_flight wired to \
         {IDENTIFIER} ({}), under a Jacobi master over the fmi importer, SVD-CKF, against the plant's coefficients \
         at the same {} time stamps: RMSE over the whole flight {}; lowest correlation {:.4}, lowest 2σ coverage \
         {:.3}; ran at {:.0}× real time; {}",
        path.display(),
        c.system.samples,
        rmse.join(", "),
        worst(|p| p.correlation),
        worst(|p| p.two_sigma_coverage),
        c.run.real_time_factor,
        if c.bit_for_bit {
            "the estimates and σ are the in-process co-simulation's bit for bit".to_string()
        } else {
            format!("the estimates differ from the in-process co-simulation's by up to {:.3e}", c.largest_difference)
        }
    );
}

/// What the `vs library` line says of start values the in-process filter does not take:
/// nothing without any.
fn fmu_only_note(fmu_only: &[String]) -> String {
    if fmu_only.is_empty() {
        return String::new();
    }
    format!(" (start values in the FMU only, not in-process: {}; a difference is theirs)", fmu_only.join(", "))
}

/// A case's figures before its runs: none yet.
fn figures_of(case: Case) -> TruthFigures {
    TruthFigures {
        truth: case.truth,
        manoeuvre: case.manoeuvre,
        tuned_on: case.tuned_on(),
        case: case.name,
        failures: Vec::new(),
        tables: Vec::new(),
        filters: Vec::new(),
    }
}

/// The first truth, our 6-DOF, through the case's manoeuvre: the flight measured once, then
/// every filter through the FMU, checked against the same filter in-process; prints the
/// tables and returns the number of failed runs and the tables' figures.
fn six_dof(given: &Given<'_>, case: Case) -> anyhow::Result<(usize, TruthFigures)> {
    let Given { settings, tuning, start_values, fmu, dir, .. } = *given;
    let change_at = Manoeuvre::named(case.manoeuvre).map_err(anyhow::Error::msg)?.change_at;
    let truth = simulate_named(case.manoeuvre, settings).map_err(anyhow::Error::msg)?;
    let measurements = measure(&truth, settings.noise_scale, settings.seed);
    if !case.tuned_on() {
        println!("truth 1 through {}", case.manoeuvre_text());
    }
    let stem = dir.join(case.name);
    let flown = Flown { truth: &truth, measurements: &measurements, manoeuvre: case.manoeuvre, case: case.name };
    let mut failures = 0;
    let (mut runs, mut logs) = (Vec::new(), Vec::new());
    let mut figures = figures_of(case);
    for kind in FilterKind::ALL {
        let log = log_path(&stem, kind);
        let through_fmu = fmu_run::run(fmu, kind, settings, tuning, &flown, start_values, &log).and_then(|counts| {
            let run = read_log(&log)?;
            let coefficients = rows_of(run.channel(ESTIMATE)?, NAMES)?;
            let library = run_filter(kind, tuning, &truth, &measurements, settings.sample_time, &[])
                .map_err(anyhow::Error::msg)?;
            let difference = largest_difference(&coefficients, &library.coefficients)?;
            let smoothed = smoothed_of(&run, kind, &mut failures);
            logs.push(run);
            let checked = Some(Checked { difference, rejected: counts.rejected });
            Ok(FilterRun { kind, coefficients, truth: truth.coefficients.clone(), checked, sigma: None, smoothed })
        });
        match through_fmu {
            Ok(r) => runs.push(r),
            Err(e) => {
                failures += 1;
                println!("{kind}: FAILED: {e:#}");
                figures.failures.push(FilterFailure { filter: kind.name(), failure: format!("{e:#}") });
            }
        }
    }
    if runs.is_empty() {
        return Ok((failures, figures));
    }
    let recording = match compare_case(
        &logs,
        &[],
        &Options { from: SETTLE, ..Options::default() },
        &stem,
        Some(FilterKind::SvdCkf),
    ) {
        Ok(Compared { comparison, recording, .. }) => {
            attach_sigma(&mut runs, &comparison);
            Some(recording)
        }
        Err(e) => {
            failures += 1;
            println!("FAILED to compare the filters: {e}");
            None
        }
    };
    let shown = Shown { case, change_at, sample_time: settings.sample_time, fmu_only: given.fmu_only };
    (figures.tables, figures.filters) = print_tables(&runs, &truth.time, &shown);
    if let Some(recording) = recording {
        println!(
            "comparison recording, every filter, or the default one standing for those within its σ: {}",
            recording.display()
        );
    }
    Ok((failures, figures))
}

/// The smoothed coefficients of `run`, the log of `kind`'s run; `None`, said and counted
/// in `failures`, if they cannot be read.
fn smoothed_of(run: &Run, kind: FilterKind, failures: &mut usize) -> Option<SmoothedRun> {
    SmoothedRun::of(run)
        .map_err(|e| {
            *failures += 1;
            println!("{kind}: FAILED to read the smoothed coefficients: {e:#}");
        })
        .ok()
}

/// S5's second truth's driver, from the repository's root.
const DRIVER: &str = "truth/s5_jsbsim/fly.py";

/// The second truth: JSBSim through its Python driver, once per filter, through the case's
/// manoeuvre; prints the tables and returns the number of failed runs and the tables'
/// figures.
fn jsbsim(given: &Given<'_>, case: Case) -> anyhow::Result<(usize, TruthFigures)> {
    let Given { settings, start_values, fmu_path, dir, python, .. } = *given;
    let change_at = Manoeuvre::named(case.manoeuvre).map_err(anyhow::Error::msg)?.change_at;
    // The driver is found from where this crate was built: the repository's truth/.
    let driver = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(DRIVER);
    println!(
        "truth 2: JSBSim (WGS84 rotating Earth, US 1976 atmosphere) flies {}; {DRIVER} steps the FMU through fmpy \
         every {} s (seed {})",
        case.manoeuvre_text(),
        settings.sample_time,
        settings.seed
    );
    // The user's start values after the study's own settings, over which they go, as the
    // co-simulation master sets them.
    let user: Vec<String> = start_values.iter().flat_map(|(n, v)| ["--set".to_string(), format!("{n}={v}")]).collect();
    let stem = dir.join(case.name);
    let mut failures = 0;
    let (mut runs, mut logs) = (Vec::new(), Vec::new());
    let mut figures = figures_of(case);
    let mut time = Vec::new();
    for kind in FilterKind::ALL {
        let log = log_path(&stem, kind);
        let flown = std::process::Command::new(python)
            .arg(&driver)
            .arg(&log)
            .arg("--fmu")
            .arg(fmu_path)
            .args(["--seed", &settings.seed.to_string()])
            .args(["--manoeuvre", case.manoeuvre])
            .args(["--set", &format!("filter={}", filter_enumeration(kind))])
            .args(["--set", "ukf_alpha=1", "--set", "ukf_beta=2", "--set", "ukf_kappa=0"])
            .args(["--set", &format!("smoothing_lag={SMOOTHING_LAG}")])
            .args(&user)
            .output()
            .with_context(|| format!("cannot run {} (scripts/setup --tests installs it)", python.display()))
            .and_then(|output| {
                anyhow::ensure!(
                    output.status.success(),
                    "the JSBSim driver failed: {}",
                    String::from_utf8_lossy(&output.stderr).lines().last().unwrap_or_default()
                );
                let run = with_smoothed_channel(read_log(&log)?)?;
                let (truth, estimate) = (run.channel(TRUTH)?, run.channel(ESTIMATE)?);
                let samples = estimate.time.len().min(truth.time.len());
                time = estimate.time[..samples].to_vec();
                let (mut coefficients, mut true_values) = (rows_of(estimate, NAMES)?, rows_of(truth, NAMES)?);
                coefficients.truncate(samples);
                true_values.truncate(samples);
                let smoothed = smoothed_of(&run, kind, &mut failures);
                let filter_run =
                    FilterRun { kind, coefficients, truth: true_values, checked: None, sigma: None, smoothed };
                logs.push(run);
                Ok(filter_run)
            });
        match flown {
            Ok(r) => runs.push(r),
            Err(e) => {
                failures += 1;
                println!("{kind} (JSBSim): FAILED: {e:#}");
                figures.failures.push(FilterFailure { filter: kind.name(), failure: format!("{e:#}") });
            }
        }
    }
    if runs.is_empty() {
        return Ok((failures, figures));
    }
    // Compared before the tables are printed, which show the σ figures of the comparison.
    let compared =
        compare_case(&logs, &[], &Options { from: SETTLE, ..Options::default() }, &stem, Some(FilterKind::SvdCkf)).map(
            |Compared { comparison, recording, .. }| {
                attach_sigma(&mut runs, &comparison);
                recording
            },
        );
    let shown = Shown { case, change_at, sample_time: settings.sample_time, fmu_only: given.fmu_only };
    (figures.tables, figures.filters) = print_tables(&runs, &time, &shown);
    match compared {
        Ok(recording) => println!(
            "comparison recording, every filter, or the default one standing for those within its σ: {}",
            recording.display()
        ),
        Err(e) => {
            failures += 1;
            println!("FAILED to compare the JSBSim runs: {e}");
        }
    }
    Ok((failures, figures))
}

/// What [`print_tables`] is told of the runs: their case, when the coefficients change,
/// the sample time, and the start values the in-process filter does not take.
struct Shown<'a> {
    case: Case,
    change_at: f64,
    sample_time: f64,
    fmu_only: &'a [String],
}

/// The paper's Tables 1 and 2 (each filter's relative error at the end of each half beside
/// the paper's SVD-CKF; blank for a manoeuvre the paper does not fly), the time back within
/// 3 % and 1 % after the change, and, for runs checked in-process, the gate's rejections
/// and the difference from the library; returns the same figures, the tables and each
/// filter's.
fn print_tables(runs: &[FilterRun], time: &[f64], shown: &Shown<'_>) -> (Vec<CoefficientTable>, Vec<FilterFigures>) {
    let end = time.len() - 1;
    // The last sample under the first coefficients.
    let before = (shown.change_at / shown.sample_time).round() as usize - 1;
    let relative_error = |estimate: f64, true_value: f64| 100.0 * (estimate / true_value - 1.0);
    let published = shown.case.tuned_on();
    let smoothed: Vec<(FilterKind, &SmoothedRun)> =
        runs.iter().filter_map(|r| r.smoothed.as_ref().map(|s| (r.kind, s))).collect();
    // The last time every run's smoothed estimates reach: Table 2's smoothed instant.
    let smoothed_end = smoothed.iter().filter_map(|(_, s)| s.time.last().copied()).reduce(f64::min);
    let mut tables = Vec::new();
    for (table, half, k, smoothed_at, paper) in [
        ("Table 1", "before the change", before, Some(time[before]), PAPER_SVD_CKF_BEFORE),
        ("Table 2", "after the change", end, smoothed_end, PAPER_SVD_CKF_AFTER),
    ] {
        let paper = published.then_some(paper);
        let true_values = runs[0].truth[k];
        // Each smoothed run's estimates and truth at the smoothed instant.
        let smoothed_rows: Vec<(FilterKind, [f64; 10], [f64; 10])> = smoothed
            .iter()
            .filter_map(|&(kind, s)| {
                let j = s.at(smoothed_at?)?;
                Some((kind, s.coefficients[j], s.truth[j]))
            })
            .collect();
        let smoothed_at = smoothed_at.filter(|_| !smoothed_rows.is_empty());
        let coefficients = (0..10)
            .map(|i| CoefficientRow {
                coefficient: NAMES[i],
                true_value: true_values[i],
                paper_svd_ckf: paper.map(|p| p[i]),
                paper_svd_ckf_relative_error: paper.map(|p| relative_error(p[i], true_values[i])),
                relative_error: runs
                    .iter()
                    .map(|r| (r.kind.name(), relative_error(r.coefficients[k][i], true_values[i])))
                    .collect(),
                smoothed_relative_error: smoothed_rows
                    .iter()
                    .map(|(kind, estimate, truth)| (kind.name(), relative_error(estimate[i], truth[i])))
                    .collect(),
            })
            .collect();
        tables.push(CoefficientTable { table, time: time[k], smoothed_time: smoothed_at, coefficients });
        // To the millisecond: a log's times are its nanoseconds over 1e9.
        let millisecond = |t: f64| (t * 1e3).round() / 1e3;
        let at = millisecond(time[k]);
        let title = if published {
            format!("{table}, {half} (at {at} s)")
        } else {
            format!("{}, {half} (at {at} s; {table}'s coefficients, no paper figures)", shown.case.manoeuvre)
        };
        let smoothed_title = match smoothed_at {
            Some(t) if t == time[k] => "; after │, of its smoothed estimate of the same instant".to_string(),
            Some(t) => format!("; after │, of its smoothed estimate of {} s, the last it reaches", millisecond(t)),
            None => String::new(),
        };
        println!("{title}: relative error of each filter's estimate, %{smoothed_title}");
        let mut header = format!("{:<6} {:>8} {:>9} {:>7}", "coef", "true", "paper SVD", "err %");
        for r in runs {
            let _ = write!(header, " {:>8}", r.kind.name());
        }
        if !smoothed_rows.is_empty() {
            header.push_str(" │");
            for (kind, ..) in &smoothed_rows {
                let _ = write!(header, " {:>8}", kind.name());
            }
        }
        println!("{header}");
        for i in 0..10 {
            let mut row = format!("{:<6} {:>8.4}", NAMES[i], true_values[i]);
            match paper {
                Some(p) => {
                    let _ = write!(row, " {:>9.4} {:>+7.2}", p[i], relative_error(p[i], true_values[i]));
                }
                // Blank, not zero: the paper has no estimate of this manoeuvre.
                None => row.push_str(&" ".repeat(1 + 9 + 1 + 7)),
            }
            for r in runs {
                let _ = write!(row, " {:>+8.3}", relative_error(r.coefficients[k][i], true_values[i]));
            }
            if !smoothed_rows.is_empty() {
                row.push_str(" │");
                for (_, estimate, truth) in &smoothed_rows {
                    let _ = write!(row, " {:>+8.3}", relative_error(estimate[i], truth[i]));
                }
            }
            println!("{row}");
        }
    }
    let after = runs[0].truth[end];
    let mut filters = Vec::new();
    let mut back = format!("{:<26}", "back within 3 % / 1 %, s");
    let mut back_smoothed = format!("{:<26}", "the same, smoothed, s");
    let mut rejected = format!("{:<26}", "rows rejected by the gate");
    let mut difference = format!("{:<26}", "vs library (largest |Δ|)");
    for r in runs {
        // The time after the change from which every coefficient stays within `bound`.
        let within = |bound: f64| {
            (before + 1..=end)
                .find(|&k| (k..=end).all(|j| (0..10).all(|i| (r.coefficients[j][i] / after[i] - 1.0).abs() <= bound)))
                .map(|k| time[k] - shown.change_at)
        };
        let (within_3, within_1) = (within(0.03), within(0.01));
        let text = |seconds: Option<f64>| seconds.map_or("never".to_string(), |s| format!("{s:.2}"));
        let _ = write!(back, " {:>12}", format!("{}/{}", text(within_3), text(within_1)));
        let smoothed = r.smoothed.as_ref().map(|s| {
            // The same, up to the last time the smoothed estimates reach.
            let within = |bound: f64| {
                let last = s.time.len().checked_sub(1)?;
                let from = s.time.iter().position(|&t| t > shown.change_at - 0.5 * shown.sample_time)?;
                (from..=last)
                    .find(|&k| {
                        (k..=last).all(|j| (0..10).all(|i| (s.coefficients[j][i] / after[i] - 1.0).abs() <= bound))
                    })
                    .map(|k| s.time[k] - shown.change_at)
            };
            SmoothedCoefficients {
                lag: SMOOTHING_LAG,
                back_within_3_percent: within(0.03),
                back_within_1_percent: within(0.01),
                coefficients: s.figures.clone(),
            }
        });
        let _ = write!(
            back_smoothed,
            " {:>12}",
            smoothed.as_ref().map_or("—".into(), |s| format!(
                "{}/{}",
                text(s.back_within_3_percent),
                text(s.back_within_1_percent)
            ))
        );
        if let Some(checked) = &r.checked {
            let _ = write!(rejected, " {:>12}", checked.rejected);
            let _ = write!(difference, " {:>12.1e}", checked.difference);
        }
        let sigma = r.sigma.as_ref();
        filters.push(FilterFigures {
            filter: r.kind.name(),
            back_within_3_percent: within_3,
            back_within_1_percent: within_1,
            rejected_rows: r.checked.as_ref().map(|c| c.rejected),
            fmu_vs_in_process_max_abs_difference: r.checked.as_ref().map(|c| c.difference),
            nees: sigma.and_then(|s| s.nees.clone()),
            nis: sigma.and_then(|s| s.nis.clone()),
            one_sigma_coverage_min: sigma.and_then(|s| s.coverage_min(|c| c.one_sigma_coverage)),
            two_sigma_coverage_min: sigma.and_then(|s| s.coverage_min(|c| c.two_sigma_coverage)),
            normalised_error_worst_coefficient: sigma.and_then(|s| s.worst()).map(|(name, _)| name),
            coefficients: sigma.map(|s| s.coefficients.clone()).unwrap_or_default(),
            smoothed,
        });
    }
    let names: String = runs.iter().map(|r| format!(" {:>12}", r.kind.name())).collect();
    println!("after the change{}{names}", " ".repeat(10));
    println!("{back}");
    if runs.iter().any(|r| r.smoothed.is_some()) {
        println!("{back_smoothed}");
    }
    if runs.iter().all(|r| r.checked.is_some()) {
        println!("{rejected}\n{difference}{}", fmu_only_note(shown.fmu_only));
    }
    if runs.iter().any(|r| r.sigma.is_some()) {
        println!(
            "σ of the coefficients (analyzer, from {SETTLE} s on, the change at {} s included): NEES mean/dof and the \
             share in its 95 % band; the lowest 1σ/2σ coverage (0.683/0.955 if honest); the worst (e/σ)² mean (1) \
             with its reading, and how many read too narrow; Σ NIS / Σ rows used (1)",
            shown.change_at
        );
        for r in runs {
            if let Some(sigma) = &r.sigma {
                println!("  {:<8} {}{}", r.kind.name(), sigma_line(sigma), smoothed_coverage(r.smoothed.as_ref()));
            }
        }
    }
    if published {
        println!("paper: {PAPER_CLAIM}");
    }
    (tables, filters)
}

/// What a σ line says of the smoothed coefficients' σ: their lowest 1σ/2σ coverage.
fn smoothed_coverage(smoothed: Option<&SmoothedRun>) -> String {
    let Some(s) = smoothed else { return String::new() };
    let lowest = |coverage: fn(&SmoothedFigures) -> Option<f64>| {
        s.figures.values().filter_map(coverage).reduce(f64::min).map_or("—".into(), |c| format!("{c:.3}"))
    };
    format!("  smoothed 1σ/2σ min {}/{}", lowest(|f| f.one_sigma_coverage), lowest(|f| f.two_sigma_coverage))
}

/// A run's σ figures as the σ lines print them.
fn sigma_line(sigma: &RunSigma) -> String {
    let or_dash = |v: Option<f64>, text: &dyn Fn(f64) -> String| v.map_or("—".to_string(), text);
    let nees = sigma
        .nees
        .as_ref()
        .map_or("—".into(), |n| format!("{}/{} in 95 % {:.3}", significant(n.mean), n.dof, n.in_band));
    let coverage = format!(
        "{}/{}",
        or_dash(sigma.coverage_min(|c| c.one_sigma_coverage), &|c| format!("{c:.3}")),
        or_dash(sigma.coverage_min(|c| c.two_sigma_coverage), &|c| format!("{c:.3}"))
    );
    let narrow = sigma
        .coefficients
        .values()
        .filter(|c| c.normalised_error.is_some_and(|n| n.reading == Reading::TooNarrow))
        .count();
    let worst = sigma.worst().map_or("—".into(), |(name, n)| {
        format!("{name} {} {} ({narrow} of {} too narrow)", significant(n.mean_square), n.reading.text(), NAMES.len())
    });
    let nis = sigma.nis.as_ref().and_then(|n| n.ratio.zip(n.reading));
    let nis = nis.map_or("—".into(), |(ratio, reading)| format!("{} {}", significant(ratio), reading.text()));
    format!("NEES {nees}  1σ/2σ min {coverage}  (e/σ)² worst {worst}  NIS/rows {nis}")
}

/// `value` to four significant digits, in plain notation.
fn significant(value: f64) -> String {
    let digits = if value.is_finite() && value != 0.0 { (3 - value.abs().log10().floor() as i32).max(0) } else { 0 };
    format!("{value:.digits$}", digits = digits as usize)
}
