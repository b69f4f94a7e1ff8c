//! S2 in `kalfmu reproduce`: each case (random track, corrugation, weld) simulated once
//! on the as-built car, then run through the packaged FMU with every filter, the user's
//! catalogue vehicle and the study's one tuning; one log per run, one comparison per case;
//! the table per wheelset beside the paper's figures (SRCKF), and every filter's worst
//! wheel.
//!
//! Definitions (the paper reports wheelset 1 only, and defines none of them):
//! - every figure is taken after a settling time of 0.5 s, in the recordings too;
//! - **RMSE mean and variance**: of the running RMSE over a trailing 0.2 s window, the
//!   curve the paper plots and summarises by its mean (kN) and variance (kN²);
//! - **RMSE/σ_dyn**: the RMSE over the true force's standard deviation about its mean, its
//!   dynamic part;
//! - **weld peak error**: of the peak dynamic force, `max F − F̄` (F̄ the true mean), the
//!   estimate's peak taken within ±20 ms of the truth's, relative to the truth's;
//! - **PSD band**: the widest band where the spectra (Welch, 1 s segments) agree within
//!   3 dB;
//! - **2σ**: the fraction of samples whose error is inside the FMU's ±2σ;
//! - **1σ**, **(e/σ)²** and **NIS/rows**: whether the FMU's σ is honest, the analyzer's
//!   figures (docs/analyzer.md, "Is the σ honest?"): the fraction inside ±σ (0.6827 for an
//!   honest σ), the mean σ-normalised squared error (1) with its reading, and the run's
//!   Σ NIS / Σ measurement rows used (1) with its reading; every filter's table shows the
//!   wheel whose (e/σ)² is the farthest from 1 (in ratio);
//! - **vs library**: the largest difference between the FMU's forces and the same filter
//!   run in-process on the same measurements (`study::run_filter`): the FMU in a
//!   co-simulation must give what our own runs give;
//! - **smoothed**: the FMU's fixed-lag smoothed forces (its `smoothing_lag`,
//!   [`SMOOTHING_LAG`], logged on `/smoothed` at the times they describe), taken like the
//!   filtered ones: their correlation, RMSE over the true force's dynamic σ and share inside
//!   their own ±2σ (the run's last lag has no smoothed estimate yet).
//!
//! Then the unseen tracks, spectra the set-up was not made for (German low and high
//! interference, FRA class 6), each at its own speed between 40 and 160 km/h, at both
//! rates, with the SRCKF (`--quick`: one of them); the paper has no figures for them.
//!
//! Start values (`--set`, `--values`) go to every FMU run; the in-process filter takes
//! those it has a parameter for ([`Tuning::set`]). The others (the vehicle's, the
//! supervisor's, …) reach the FMU only: the header names them, and "vs library" then
//! measures their effect rather than the FMU's agreement with the library.
//!
//! The figures are written as `table.json` too ([`Table`]): every filter's, every wheel's.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use start_values::{SetByName, StartValues};

use analyzer::consistency::{Nis, NormalisedError, Reading};
use analyzer::report::{analyse, Options, PairReport};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::read_log;
use log_format::write::{ESTIMATE, PREDICTION, SMOOTHED};
use serde::Serialize;

use super::fmu_run::{self, Simulated, IDENTIFIER};
use super::study::{run_filter, user_vehicle, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of, units, write_table, Compared};
use crate::smoothed::SMOOTHING_LAG;
use cosim::fmu_driver::ImportedFmu;
use cosim::master::Counts;
use shard::Shard;
use truth::s2::cases::{as_built, measure, Case, Scenario, Settings, Truth};
use truth::s2::irregularity::TrackSpectrum;
use truth::s2::parameters::Vehicle;

/// The settling time before the figures are taken (s).
const SETTLE: f64 = 0.5;
/// The running RMSE's window (s).
const RMSE_WINDOW: f64 = 0.2;
/// How far from the true peak the estimate's peak is looked for (s).
const PEAK_WINDOW: f64 = 0.02;

/// The paper's figures for wheelset 1 (SRCKF, 200 Hz): correlation, RMSE mean (kN) and
/// variance (kN²).
fn published(case: Case) -> (f64, f64, f64) {
    match case {
        Case::Random => (0.988, 0.175, 0.027),
        Case::Corrugation => (0.999, 0.142, 0.028),
        Case::Weld => (0.969, 0.101, 0.004),
    }
}

/// One wheel's figures.
#[derive(Debug, Clone, Copy, PartialEq)]
struct WheelFigures {
    correlation: f64,
    rmse: f64,
    running_rmse_mean: f64,
    running_rmse_var: f64,
    dynamic_std: f64,
    peak_error: f64,
    band: Option<(f64, f64)>,
    two_sigma: f64,
    one_sigma: f64,
    normalised_error: Option<NormalisedError>,
}

impl WheelFigures {
    /// From the analyzer's report of a pair, its metrics taken from [`SETTLE`] on.
    fn of(pair: &PairReport<'_>, rate: f64) -> Self {
        let skip = pair.time.len() - pair.samples;
        let (t, e) = (&pair.truth_values[skip..], &pair.estimate_values[skip..]);
        let n = t.len() as f64;
        let mean = t.iter().sum::<f64>() / n;
        let running = &pair.running_rmse[skip..];
        let running_mean = running.iter().sum::<f64>() / n;
        let peak = t.iter().enumerate().fold((0, f64::NEG_INFINITY), |b, (k, &v)| if v > b.1 { (k, v) } else { b });
        let reach = (PEAK_WINDOW * rate).round() as usize;
        let around = &e[peak.0.saturating_sub(reach)..(peak.0 + reach + 1).min(e.len())];
        let estimated_peak = around.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Self {
            correlation: pair.metrics.correlation,
            rmse: pair.metrics.rmse,
            running_rmse_mean: running_mean,
            running_rmse_var: running.iter().map(|r| (r - running_mean).powi(2)).sum::<f64>() / n,
            dynamic_std: (t.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt(),
            peak_error: (estimated_peak - peak.1) / (peak.1 - mean),
            band: pair.psd_agreement_band,
            two_sigma: pair.two_sigma_coverage.unwrap_or(f64::NAN),
            one_sigma: pair.one_sigma_coverage.unwrap_or(f64::NAN),
            normalised_error: pair.normalised_error,
        }
    }
}

/// The figures of S2's tables, as `table.json` has them: every filter's on every wheel,
/// of which the printed tables show the SRCKF's per wheel and every filter's worst wheel.
#[derive(Debug, Serialize)]
pub struct Table {
    /// `"S2"`.
    pub study: &'static str,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field (see [`units`]).
    pub units: BTreeMap<&'static str, &'static str>,
    /// Where the `paper` figures come from.
    pub paper_source: &'static str,
    /// One entry per case, in the tables' order.
    pub cases: Vec<CaseFigures>,
}

/// The set-up of a [`Table`].
#[derive(Debug, Serialize)]
pub struct TableSettings {
    /// Speed of the car (m/s).
    pub speed: f64,
    /// Simulated duration (s).
    pub duration: f64,
    /// Sampling rate (Hz).
    pub rate: f64,
    /// Seed of the track and of the noise.
    pub seed: u64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// Figures are taken from this time on (s).
    pub settle: f64,
    /// The running RMSE's trailing window (s).
    pub rmse_window: f64,
    /// Whether this is `--quick`'s short run (one unseen track instead of six runs).
    pub quick: bool,
    /// The start values given (`--set`, `--values`), set on every FMU run over the study's
    /// parameters and, those the in-process filter has, on it; empty without any.
    pub start_values: BTreeMap<String, f64>,
    /// Those of `start_values` the in-process filter does not take ([`Tuning::takes`]):
    /// they reach the FMU only, and `fmu_vs_in_process_max_abs_difference` then measures
    /// their effect.
    pub start_values_fmu_only: Vec<String>,
}

/// One case of a [`Table`].
#[derive(Debug, Serialize)]
pub struct CaseFigures {
    /// The case on its track: `random`, `corrugation`, `weld` (the paper's, FRA class 5),
    /// or `random/<spectrum>` on an unseen track (`random/german-low`, …).
    pub case: String,
    /// Whether the paper published figures for the case: `false` for the unseen tracks
    /// (`truth::s2::cases::Scenario::UNSEEN`), which the set-up was not made for.
    pub published: bool,
    /// Speed of the car in the case's runs (m/s): the settings' for the paper's cases, the
    /// track's own for an unseen one.
    pub speed: f64,
    /// Sampling rate of the case's runs (Hz).
    pub rate: f64,
    /// The paper's SRCKF figures, for wheelset 1; `null` for an unseen track.
    pub paper: Option<PaperFigures>,
    /// Why the case's runs could not be compared, if they could not (then only the
    /// failed filters are listed).
    pub failure: Option<String>,
    /// One entry per filter kind, in the tables' order (an unseen track: the SRCKF only).
    pub filters: Vec<FilterFigures>,
}

/// The paper's figures of a case (its SRCKF, wheelset 1, 200 Hz).
#[derive(Debug, Serialize)]
pub struct PaperFigures {
    /// Correlation of the estimated force with the true one.
    pub correlation: f64,
    /// Mean of the running RMSE (kN).
    pub running_rmse_mean: f64,
    /// Variance of the running RMSE (kN²).
    pub running_rmse_variance: f64,
}

/// One filter's run of a case through the FMU.
#[derive(Debug, Serialize)]
pub struct FilterFigures {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Why the run failed, if it did (then the other fields are `null`).
    pub failure: Option<String>,
    /// Measurement rows the FMU's gate left out.
    pub rejected_rows: Option<i32>,
    /// The largest difference between the FMU's forces and the same filter's in-process (N).
    pub fmu_vs_in_process_max_abs_difference: Option<f64>,
    /// The worst of the four wheels, as the table of every filter prints it.
    pub worst_wheel: Option<WorstWheel>,
    /// Wheelsets 1 to 4.
    pub wheels: Vec<WheelTable>,
    /// The NIS of the run's updates against the measurement rows they used, the analyzer's
    /// (`null` if the run failed or its log has no `nis`).
    pub nis: Option<Nis>,
}

/// The worst figure of the four wheels, each on its own wheel.
#[derive(Debug, Serialize)]
pub struct WorstWheel {
    /// The lowest correlation.
    pub correlation_min: f64,
    /// The largest RMSE over the true force's dynamic σ.
    pub rmse_over_dynamic_std_max: f64,
    /// The weld's peak error of the largest magnitude (%); `null` for the other cases.
    pub weld_peak_error_max_abs: Option<f64>,
    /// The lowest share of errors inside the FMU's ±2σ.
    pub two_sigma_coverage_min: Option<f64>,
    /// The lowest share of errors inside the FMU's ±σ.
    pub one_sigma_coverage_min: Option<f64>,
    /// The wheelset whose mean `(e/σ)²` is the farthest from 1 in ratio (`null` without σ).
    pub normalised_error_worst_wheelset: Option<usize>,
    /// Its mean `(e/σ)²` with its reading.
    pub normalised_error_worst: Option<NormalisedError>,
    /// The lowest correlation of the forces read right after the step.
    pub after_step_correlation_min: f64,
    /// The worst of the four wheels' smoothed forces.
    pub smoothed: SmoothedWorstWheel,
}

/// The worst figure of the four wheels' fixed-lag smoothed forces, each on its own wheel.
#[derive(Debug, Serialize)]
pub struct SmoothedWorstWheel {
    /// The lowest correlation.
    pub correlation_min: f64,
    /// The largest RMSE over the true force's dynamic σ.
    pub rmse_over_dynamic_std_max: f64,
    /// The lowest share of errors inside the smoothed ±2σ.
    pub two_sigma_coverage_min: Option<f64>,
}

/// One wheel's figures, the force read at t after the inputs of t were set.
#[derive(Debug, Serialize)]
pub struct WheelTable {
    /// The wheelset, 1 to 4.
    pub wheelset: usize,
    /// Correlation with the true force.
    pub correlation: f64,
    /// RMSE (kN).
    pub rmse: f64,
    /// Mean of the running RMSE (kN).
    pub running_rmse_mean: f64,
    /// Variance of the running RMSE (kN²).
    pub running_rmse_variance: f64,
    /// The true force's standard deviation about its mean (kN).
    pub dynamic_std: f64,
    /// RMSE over the true force's dynamic σ.
    pub rmse_over_dynamic_std: f64,
    /// The error of the peak dynamic force (%); `null` for the cases without a weld.
    pub weld_peak_error: Option<f64>,
    /// The widest band where the spectra agree within 3 dB, `[low, high]` (Hz).
    pub psd_agreement_band: Option<(f64, f64)>,
    /// Share of the errors inside the FMU's ±2σ (`null` without σ).
    pub two_sigma_coverage: Option<f64>,
    /// Share of the errors inside the FMU's ±σ (`null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (1 for an honest σ) with its reading (`null` without σ).
    pub normalised_error: Option<NormalisedError>,
    /// Correlation of the force read right after the step with the truth at t + dt.
    pub after_step_correlation: f64,
    /// The FMU's fixed-lag smoothed force.
    pub smoothed: SmoothedWheel,
}

/// One wheel's fixed-lag smoothed force (the FMU's `smoothing_lag`, on `/smoothed`) against
/// the truth, its figures taken as the filtered force's.
#[derive(Debug, Serialize)]
pub struct SmoothedWheel {
    /// The smoothing lag (s).
    pub lag: f64,
    /// Correlation with the true force.
    pub correlation: f64,
    /// RMSE (kN).
    pub rmse: f64,
    /// RMSE over the true force's dynamic σ.
    pub rmse_over_dynamic_std: f64,
    /// Share of the errors inside the smoothed ±σ (`null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// Share of the errors inside the smoothed ±2σ (`null` without σ).
    pub two_sigma_coverage: Option<f64>,
}

impl SmoothedWheel {
    /// From the smoothed force's figures `s`.
    fn new(s: &WheelFigures) -> Self {
        Self {
            lag: SMOOTHING_LAG,
            correlation: s.correlation,
            rmse: s.rmse / 1e3,
            rmse_over_dynamic_std: s.rmse / s.dynamic_std,
            one_sigma_coverage: Some(s.one_sigma).filter(|c| !c.is_nan()),
            two_sigma_coverage: Some(s.two_sigma).filter(|c| !c.is_nan()),
        }
    }
}

impl WheelTable {
    /// Wheelset `wheelset`'s table entry of `case` from its figures `w`, those after the
    /// step `a` and those of its smoothed force `s`.
    fn new(case: Case, wheelset: usize, w: &WheelFigures, a: &WheelFigures, s: &WheelFigures) -> Self {
        Self {
            wheelset,
            correlation: w.correlation,
            rmse: w.rmse / 1e3,
            running_rmse_mean: w.running_rmse_mean / 1e3,
            running_rmse_variance: w.running_rmse_var / 1e6,
            dynamic_std: w.dynamic_std / 1e3,
            rmse_over_dynamic_std: w.rmse / w.dynamic_std,
            weld_peak_error: weld_percent(case, w.peak_error),
            psd_agreement_band: w.band,
            two_sigma_coverage: Some(w.two_sigma).filter(|c| !c.is_nan()),
            one_sigma_coverage: Some(w.one_sigma).filter(|c| !c.is_nan()),
            normalised_error: w.normalised_error,
            after_step_correlation: a.correlation,
            smoothed: SmoothedWheel::new(s),
        }
    }
}

/// The units of S2's [`Table`].
const UNITS: [(&str, &str); 14] = [
    ("speed", "m/s"),
    ("duration", "s"),
    ("rate", "Hz"),
    ("settle", "s"),
    ("rmse_window", "s"),
    ("lag", "s"),
    ("rmse", "kN"),
    ("running_rmse_mean", "kN"),
    ("running_rmse_variance", "kN²"),
    ("dynamic_std", "kN"),
    ("weld_peak_error", "%"),
    ("weld_peak_error_max_abs", "%"),
    ("psd_agreement_band", "Hz"),
    ("fmu_vs_in_process_max_abs_difference", "N"),
];

/// Where the paper's figures come from.
const PAPER_SOURCE: &str = "SRCKF figures of the paper (Chen et al. 2025) for wheelset 1 at 200 Hz";

/// The unseen tracks, each at its speed (km/h): spread over the 40–160 km/h the study
/// covers, one spectrum at each end and one between.
const UNSEEN: [(TrackSpectrum, f64); 3] =
    [(TrackSpectrum::GERMAN_LOW, 40.0), (TrackSpectrum::GERMAN_HIGH, 160.0), (TrackSpectrum::FRA_6, 100.0)];

/// The filter of the unseen tracks: the paper's. Every kind at both rates would be 24 runs
/// more through the FMU and in-process, taking the table past twice its time without them.
const UNSEEN_FILTER: FilterKind = FilterKind::SrCkf;

/// The other of the study's two rates (Hz).
fn other_rate(rate: f64) -> f64 {
    if rate == 200.0 {
        1000.0
    } else {
        200.0
    }
}

/// The unseen runs: the random case on each of [`UNSEEN`] at its speed, at the settings'
/// rate and then at the other ([`other_rate`]); with `quick` one, German high interference
/// at 160 km/h at the settings' rate.
fn unseen_runs(settings: &Settings, quick: bool) -> Vec<(Scenario, Settings)> {
    let at = |(spectrum, km_h): (TrackSpectrum, f64), rate: f64| {
        let scenario = Scenario { case: Case::Random, spectrum };
        (scenario, Settings { speed: km_h / 3.6, rate, ..scenario.settings(settings) })
    };
    if quick {
        return vec![at(UNSEEN[1], settings.rate)];
    }
    let rates = [settings.rate, other_rate(settings.rate)];
    rates.iter().flat_map(|&rate| UNSEEN.iter().map(move |&u| at(u, rate))).collect()
}

/// What every run of the study shares.
struct Given<'a> {
    fmu: &'a ImportedFmu,
    start_values: &'a StartValues,
    catalogue: &'a Vehicle,
    /// The static wheel load as weighed (N).
    weighed: f64,
}

/// One filter's run of a case through the FMU, checked against the same filter
/// in-process, and its figures.
struct Ran {
    kind: FilterKind,
    counts: Counts,
    /// The largest difference from the in-process filter (N).
    difference: f64,
    /// Each wheel's figures of the feedthrough reading …
    wheels: Vec<WheelFigures>,
    /// … and of the reading after the step …
    after: Vec<WheelFigures>,
    /// … and of the FMU's fixed-lag smoothed forces.
    smoothed: Vec<WheelFigures>,
    nis: Option<Nis>,
}

/// One case's runs: the filters that ran, those that failed with why, and why the runs
/// could not be compared if they could not.
struct CaseRuns {
    ran: Vec<Ran>,
    failed: Vec<(FilterKind, String)>,
    comparison_failure: Option<String>,
    recording: Option<std::path::PathBuf>,
}

/// Runs `kinds` on `scenario` at `settings`, whose truth is `truth`, through the FMU (logs `<stem>_<filter>.mcap`),
/// each checked against the same filter in-process, and compares them (`<stem>.json`,
/// `<stem>.rrd`).
fn run_case(
    given: &Given<'_>,
    (scenario, settings, truth): (Scenario, &Settings, &Truth),
    kinds: &[FilterKind],
    stem: &Path,
) -> anyhow::Result<CaseRuns> {
    let Given { fmu, start_values, catalogue, weighed } = *given;
    let measurements = measure(truth, settings.noise_fraction, settings.seed);
    let tuning = Tuning::new(settings, measurements.noise_std);
    let parameters = fmu_run::parameters(catalogue, weighed, &tuning);
    let integers = tuning.fmu_integers();
    // The in-process filter has the start values it has a parameter for; the others reach
    // the FMU only (`report` says which).
    let mut in_process = tuning.clone();
    in_process.set_known(start_values).map_err(anyhow::Error::msg)?;
    let sim = Simulated {
        scenario,
        settings,
        truth,
        measurements: &measurements,
        parameters: &parameters,
        integers: &integers,
        start_values,
    };
    let vehicle = user_vehicle(catalogue, weighed);
    let mut runs = Vec::new();
    let mut checked_runs: Vec<(FilterKind, Counts, f64)> = Vec::new();
    let mut failed = Vec::new();
    for &kind in kinds {
        let log = log_path(stem, kind);
        let fmu_run = fmu_run::run(fmu, kind, &sim, &log).and_then(|counts| Ok((counts, read_log(&log)?)));
        let checked = fmu_run.and_then(|(counts, run)| {
            let library = run_filter(kind, vehicle, &in_process, &measurements).map_err(anyhow::Error::msg)?;
            let logged = rows_of(run.channel(ESTIMATE)?, ["F_N1", "F_N2", "F_N3", "F_N4"])?;
            let difference = largest_difference(&logged, &library.forces)?;
            Ok((counts, run, difference))
        });
        match checked {
            Ok((counts, run, difference)) => {
                runs.push(run);
                checked_runs.push((kind, counts, difference));
            }
            Err(e) => failed.push((kind, format!("{e:#}"))),
        }
    }
    // The recordings' and the JSON's metrics are the table's: from the settling time on.
    let options = Options {
        rmse_window: RMSE_WINDOW,
        psd_segment: settings.rate.round() as usize,
        from: SETTLE,
        ..Options::default()
    };
    let mut recording = None;
    let figures = compare_case(&runs, &[], &options, stem, Some(FilterKind::SrCkf)).and_then(
        |Compared { comparison, recording: written, .. }| {
            recording = Some(written);
            let mut per_run = Vec::new();
            for (report, run) in comparison.runs.iter().zip(&runs) {
                let after = analyse(run, &Options { estimate_topic: PREDICTION.into(), ..options.clone() })?;
                let smoothed = analyse(run, &Options { estimate_topic: SMOOTHED.into(), ..options.clone() })?;
                let wheels = |pairs: &[PairReport<'_>]| -> Vec<WheelFigures> {
                    pairs.iter().map(|p| WheelFigures::of(p, settings.rate)).collect()
                };
                per_run
                    .push(([wheels(&report.pairs), wheels(&after.pairs), wheels(&smoothed.pairs)], report.nis.clone()));
            }
            Ok(per_run)
        },
    );
    let (ran, comparison_failure) = match figures {
        Ok(figures) => {
            let ran = checked_runs.into_iter().zip(figures).map(
                |((kind, counts, difference), ([wheels, after, smoothed], nis))| Ran {
                    kind,
                    counts,
                    difference,
                    wheels,
                    after,
                    smoothed,
                    nis,
                },
            );
            (ran.collect(), None)
        }
        Err(e) => (Vec::new(), Some(e.to_string())),
    };
    Ok(CaseRuns { ran, failed, comparison_failure, recording })
}

/// The worst of a run's four wheels.
fn worst_wheel(case: Case, r: &Ran) -> WorstWheel {
    let worst =
        |f: fn(&WheelFigures) -> f64, pick: fn(f64, f64) -> f64, start: f64| r.wheels.iter().map(f).fold(start, pick);
    let worst_normalised_error = farthest_from_one(&r.wheels);
    WorstWheel {
        correlation_min: worst(|w| w.correlation, f64::min, f64::INFINITY),
        rmse_over_dynamic_std_max: worst(|w| w.rmse / w.dynamic_std, f64::max, 0.0),
        weld_peak_error_max_abs: weld_percent(
            case,
            worst(|w| w.peak_error, |a, b| if b.abs() > a.abs() { b } else { a }, 0.0),
        ),
        two_sigma_coverage_min: Some(worst(|w| w.two_sigma, f64::min, f64::INFINITY)).filter(|c| !c.is_nan()),
        one_sigma_coverage_min: Some(worst(|w| w.one_sigma, f64::min, f64::INFINITY)).filter(|c| !c.is_nan()),
        normalised_error_worst_wheelset: worst_normalised_error.map(|(j, _)| j + 1),
        normalised_error_worst: worst_normalised_error.map(|(_, n)| n),
        after_step_correlation_min: r.after.iter().map(|a| a.correlation).fold(f64::INFINITY, f64::min),
        smoothed: SmoothedWorstWheel {
            correlation_min: r.smoothed.iter().map(|s| s.correlation).fold(f64::INFINITY, f64::min),
            rmse_over_dynamic_std_max: r.smoothed.iter().map(|s| s.rmse / s.dynamic_std).fold(0.0, f64::max),
            two_sigma_coverage_min: Some(r.smoothed.iter().map(|s| s.two_sigma).fold(f64::INFINITY, f64::min))
                .filter(|c| !c.is_nan()),
        },
    }
}

/// The worst-wheel columns every filter's table and the unseen table share, from
/// `corr min` on (without the weld's peak error); the last has the `(e/σ)²`, the NIS and
/// the smoothed forces' columns.
fn worst_columns(worst: &WorstWheel, r: &Ran) -> [String; 8] {
    [
        format!("{:>9.4}", worst.correlation_min),
        format!("{:>11.3}", worst.rmse_over_dynamic_std_max),
        format!("{:>10.3}", worst.two_sigma_coverage_min.unwrap_or(f64::NAN)),
        format!("{:>9}", r.counts.rejected),
        format!("{:>10.4}", worst.after_step_correlation_min),
        format!("{:>12.1e}", r.difference),
        format!("{:>7}", worst.one_sigma_coverage_min.map_or("—".into(), |c| format!("{c:.3}"))),
        format!(
            "{:>20} {:>17}  {:>12.4} {:>11.3} {:>7.3}",
            worst
                .normalised_error_worst_wheelset
                .zip(worst.normalised_error_worst)
                .map_or("—".into(), |(j, n)| format!("{j}: {}", read(Some((n.mean_square, n.reading))))),
            read(r.nis.as_ref().and_then(|n| n.ratio.zip(n.reading))),
            worst.smoothed.correlation_min,
            worst.smoothed.rmse_over_dynamic_std_max,
            worst.smoothed.two_sigma_coverage_min.unwrap_or(f64::NAN)
        ),
    ]
}

/// A run's entry of `table.json`.
fn filter_figures(case: Case, r: &Ran, worst: WorstWheel) -> FilterFigures {
    FilterFigures {
        filter: r.kind.name(),
        failure: None,
        rejected_rows: Some(r.counts.rejected),
        fmu_vs_in_process_max_abs_difference: Some(r.difference),
        worst_wheel: Some(worst),
        wheels: r
            .wheels
            .iter()
            .zip(&r.after)
            .zip(&r.smoothed)
            .enumerate()
            .map(|(j, ((w, a), s))| WheelTable::new(case, j + 1, w, a, s))
            .collect(),
        nis: r.nis.clone(),
    }
}

/// A failed run's entry of `table.json`.
fn failed_figures(kind: FilterKind, why: String) -> FilterFigures {
    FilterFigures {
        filter: kind.name(),
        failure: Some(why),
        rejected_rows: None,
        fmu_vs_in_process_max_abs_difference: None,
        worst_wheel: None,
        wheels: Vec::new(),
        nis: None,
    }
}

/// Runs S2 through its FMU, prints the tables and writes them as `table.json` in
/// `out/s2`; returns the number of failed runs. The paper's three cases run with every
/// filter kind at the settings' speed and rate; then the unseen tracks ([`unseen_runs`]:
/// three spectra at their speeds, at both rates, or with `quick` one) with the SRCKF, their
/// logs and comparisons in `out/s2/unseen`.
pub fn report(
    settings: &Settings,
    start_values: &StartValues,
    quick: bool,
    fmu_dir: &Path,
    out: &Path,
) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    // A misspelt name or a value of the wrong type costs no run.
    fmu.check_start_values(start_values)?;
    // … nor one the in-process filter would refuse; the names it has no parameter for
    // reach the FMU only.
    let fmu_only = Tuning::new(settings, [1.0; 7]).set_known(start_values).map_err(anyhow::Error::msg)?;
    let dir = out.join("s2");
    let unseen_dir = dir.join("unseen");
    std::fs::create_dir_all(&unseen_dir).with_context(|| format!("cannot create {}", unseen_dir.display()))?;
    let truth_car = as_built();
    let catalogue = Vehicle::ZHAI_PASSENGER;
    println!(
        "S2: wheel-rail vertical forces of one rail, 10-DOF vehicle + 4 forces (24 states) — {:.0} km/h, {} s at {} Hz, \
         FRA class 5 track (seed {}), accelerometer noise {:.1} % of RMS",
        settings.speed * 3.6,
        settings.duration,
        settings.rate,
        settings.seed,
        100.0 * settings.noise_fraction
    );
    if let Some(line) = start_values.header(&fmu_only) {
        println!("{line}");
    }
    println!(
        "truth: vehicle-track coupled (modal rail on discrete supports, sleepers, ballast, Hertz contact, Zhai's \
         integrator at 1e-4 s) on the car as built: car body {:.0} kg (catalogue {:.0}), primary {:.3} MN/m (catalogue \
         {:.3}); the estimator has the catalogue car, the weighed wheel load {:.2} kN, no track, no Hertz",
        truth_car.car_body_mass,
        catalogue.car_body_mass,
        truth_car.primary_stiffness / 1e6,
        catalogue.primary_stiffness / 1e6,
        truth_car.static_wheel_load() / 1e3
    );
    println!(
        "estimates from {} driven through the fmi importer; per run a log (<case>_<filter>.mcap), per case a \
         comparison of every filter (<case>.json, <case>.rrd) in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    println!(
        "after {SETTLE} s: correlation; running RMSE ({RMSE_WINDOW} s window) mean and variance; RMSE over the true \
         force's dynamic σ; weld: peak dynamic force error; spectra within 3 dB; share of errors inside the FMU's ±2σ"
    );
    let given = Given { fmu: &fmu, start_values, catalogue: &catalogue, weighed: truth_car.static_wheel_load() };
    let mut srckf = String::new();
    let _ = writeln!(
        srckf,
        "{:<12} {:>5} {:>8} {:>6} {:>8} {:>6} {:>8} {:>6} {:>8} {:>8} {:>12} {:>6} {:>10} {:>6} {:>17}  {:>8} {:>8} {:>6}",
        "case",
        "wheel",
        "corr",
        "paper",
        "RMSE kN",
        "paper",
        "var kN²",
        "paper",
        "RMSE/σd",
        "peak err",
        "PSD ±3dB Hz",
        "2σ",
        "after step",
        "1σ",
        "(e/σ)²",
        "smoothed",
        "RMSE/σd",
        "2σ"
    );
    let mut filters = String::new();
    let _ = writeln!(
        filters,
        "{:<12} {:<8} {:>9} {:>11} {:>9} {:>10} {:>9} {:>10} {:>12} {:>7} {:>20} {:>17}  {:>12} {:>11} {:>7}",
        "case",
        "filter",
        "corr min",
        "RMSE/σd max",
        "peak err",
        "2σ min",
        "rejected",
        "after step",
        "vs library N",
        "1σ min",
        "(e/σ)² worst wheel",
        "NIS/rows",
        "smoothed min",
        "RMSE/σd max",
        "2σ min"
    );
    // The truths first, on every core: they take most of the time (the coupled model at
    // 1e-4 s, about 1 s per run), and the FMU runs, one instance at a time, cannot share
    // them out.
    let paper_runs = Case::ALL.map(|case| (Scenario { case, spectrum: settings.spectrum }, settings.clone()));
    let unseen_runs = unseen_runs(settings, quick);
    let every_run: Vec<&(Scenario, Settings)> = paper_runs.iter().chain(&unseen_runs).collect();
    let truths: Vec<Truth> = shard::run(&every_run, Shard::ALL, |(scenario, settings)| scenario.simulate(settings))
        .into_iter()
        .map(|(_, truth)| truth)
        .collect();
    let (paper_truths, unseen_truths) = truths.split_at(paper_runs.len());
    let mut failures = 0;
    let mut recordings = Vec::new();
    let mut cases = Vec::new();
    for ((scenario, _), truth) in paper_runs.iter().zip(paper_truths) {
        let (scenario, case) = (*scenario, scenario.case);
        let runs = run_case(&given, (scenario, settings, truth), &FilterKind::ALL, &dir.join(case.name()))?;
        let (paper_corr, paper_rmse, paper_var) = published(case);
        let mut case_figures = CaseFigures {
            case: scenario.to_string(),
            published: scenario.is_published(),
            speed: settings.speed,
            rate: settings.rate,
            paper: Some(PaperFigures {
                correlation: paper_corr,
                running_rmse_mean: paper_rmse,
                running_rmse_variance: paper_var,
            }),
            failure: None,
            filters: Vec::new(),
        };
        recordings.extend(runs.recording);
        for (kind, why) in runs.failed {
            failures += 1;
            let _ = writeln!(filters, "{:<12} {:<8} FAILED: {why}", case.name(), kind.name());
            case_figures.filters.push(failed_figures(kind, why));
        }
        if let Some(e) = runs.comparison_failure {
            failures += 1;
            let _ = writeln!(filters, "{:<12} FAILED to compare the filters: {e}", case.name());
            case_figures.failure = Some(e);
            cases.push(case_figures);
            continue;
        }
        for r in &runs.ran {
            if r.kind == FilterKind::SrCkf {
                for (j, ((w, a), s)) in r.wheels.iter().zip(&r.after).zip(&r.smoothed).enumerate() {
                    let paper = |v: f64, digits: usize| if j == 0 { format!("{v:.digits$}") } else { "".into() };
                    let _ = writeln!(
                        srckf,
                        "{:<12} {:>5} {:>8.4} {:>6} {:>8.3} {:>6} {:>8.4} {:>6} {:>8.3} {:>8} {:>12} {:>6.3} {:>10.4} \
                         {:>6.3} {:>17}  {:>8.4} {:>8.3} {:>6.3}",
                        case.name(),
                        j + 1,
                        w.correlation,
                        paper(paper_corr, 3),
                        w.running_rmse_mean / 1e3,
                        paper(paper_rmse, 3),
                        w.running_rmse_var / 1e6,
                        paper(paper_var, 3),
                        w.rmse / w.dynamic_std,
                        peak(case, w.peak_error),
                        w.band.map_or("—".into(), |(lo, hi)| format!("{lo:.0}–{hi:.0}")),
                        w.two_sigma,
                        a.correlation,
                        w.one_sigma,
                        read(w.normalised_error.map(|n| (n.mean_square, n.reading))),
                        s.correlation,
                        s.rmse / s.dynamic_std,
                        s.two_sigma
                    );
                }
            }
            let worst = worst_wheel(case, r);
            let [corr, ratio, two, rejected, after, difference, one, rest] = worst_columns(&worst, r);
            let peak_error = worst.weld_peak_error_max_abs.map_or("—".into(), |p| format!("{p:+.1} %"));
            let _ = writeln!(
                filters,
                "{:<12} {:<8} {corr} {ratio} {peak_error:>9} {two} {rejected} {after} {difference} {one} {rest}",
                case.name(),
                r.kind.name(),
            );
            case_figures.filters.push(filter_figures(case, r, worst));
        }
        let order = |f: &FilterFigures| FilterKind::ALL.iter().position(|k| k.name() == f.filter);
        case_figures.filters.sort_by_key(order);
        cases.push(case_figures);
    }
    let mut unseen = String::new();
    let _ = writeln!(
        unseen,
        "{:<18} {:>5} {:>5} {:<8} {:>9} {:>11} {:>10} {:>9} {:>10} {:>12} {:>7} {:>20} {:>17}  {:>12} {:>11} {:>7}",
        "unseen track",
        "km/h",
        "Hz",
        "filter",
        "corr min",
        "RMSE/σd max",
        "2σ min",
        "rejected",
        "after step",
        "vs library N",
        "1σ min",
        "(e/σ)² worst wheel",
        "NIS/rows",
        "smoothed min",
        "RMSE/σd max",
        "2σ min"
    );
    for ((scenario, unseen_settings), truth) in unseen_runs.iter().zip(unseen_truths) {
        let (km_h, rate) = (unseen_settings.speed * 3.6, unseen_settings.rate);
        let name = format!("{}_{km_h:.0}kmh_{rate:.0}hz", scenario.to_string().replace('/', "_"));
        let runs = run_case(&given, (*scenario, unseen_settings, truth), &[UNSEEN_FILTER], &unseen_dir.join(name))?;
        let label = format!("{:<18} {km_h:>5.0} {rate:>5.0}", scenario.to_string());
        let mut case_figures = CaseFigures {
            case: scenario.to_string(),
            published: false,
            speed: unseen_settings.speed,
            rate,
            paper: None,
            failure: None,
            filters: Vec::new(),
        };
        for (kind, why) in runs.failed {
            failures += 1;
            let _ = writeln!(unseen, "{label} {:<8} FAILED: {why}", kind.name());
            case_figures.filters.push(failed_figures(kind, why));
        }
        if let Some(e) = runs.comparison_failure {
            failures += 1;
            let _ = writeln!(unseen, "{label} FAILED to compare: {e}");
            case_figures.failure = Some(e);
        }
        for r in &runs.ran {
            let worst = worst_wheel(scenario.case, r);
            let [corr, ratio, two, rejected, after, difference, one, rest] = worst_columns(&worst, r);
            let _ = writeln!(
                unseen,
                "{label} {:<8} {corr} {ratio} {two} {rejected} {after} {difference} {one} {rest}",
                r.kind.name()
            );
            case_figures.filters.push(filter_figures(scenario.case, r, worst));
        }
        cases.push(case_figures);
    }
    write_table(
        &dir,
        &Table {
            study: "S2",
            settings: TableSettings {
                speed: settings.speed,
                duration: settings.duration,
                rate: settings.rate,
                seed: settings.seed,
                noise_fraction: settings.noise_fraction,
                settle: SETTLE,
                rmse_window: RMSE_WINDOW,
                quick,
                start_values: start_values.iter().map(|(n, v)| (n.to_string(), v)).collect(),
                start_values_fmu_only: fmu_only.clone(),
            },
            units: units(&UNITS),
            paper_source: PAPER_SOURCE,
            cases,
        },
    )?;
    println!("SRCKF (the paper's filter), per wheelset; the paper's figures are for wheelset 1:");
    print!("{srckf}");
    println!(
        "every filter, the worst of the four wheels (rejected: measurement rows the FMU's gate left out){}:",
        fmu_only_note(&fmu_only)
    );
    print!("{filters}");
    println!(
        "unseen tracks, spectra the set-up was not made for (truth::s2::cases::Scenario::UNSEEN): the random case on \
         each at the speed and rate shown, {} s; no paper figures; {} only, the worst of the four wheels{}:",
        settings.duration,
        UNSEEN_FILTER.name(),
        if quick { "; --quick runs one" } else { "" }
    );
    print!("{unseen}");
    println!(
        "paper: {PAPER_SOURCE}, its truth and estimator sharing one model (RMSE 0.2 % of the wheel load); ours differ \
         (track, Hertz contact, the user's catalogue values)"
    );
    println!(
        "smoothed: the FMU's fixed-lag smoothed forces (smoothing_lag = {SMOOTHING_LAG} s, the estimate of that much \
         earlier given the measurements up to now; logged on /smoothed), from {SETTLE} s to one lag before the end: \
         correlation, RMSE over the true force's dynamic σ, share of errors inside their own ±2σ"
    );
    println!("comparison recordings, every filter of a case, or the default one standing for those within its σ (open with the Rerun viewer 0.41 or newer):");
    for recording in &recordings {
        println!("  {}", recording.display());
    }
    println!(
        "  and one per unseen run in {} (<track>_<km/h>kmh_<Hz>hz.rrd, {} in all)",
        unseen_dir.display(),
        unseen_runs.len()
    );
    Ok(failures)
}

/// What the `vs library` figures mean when start values reach the FMU only: nothing to say
/// without any.
fn fmu_only_note(fmu_only: &[String]) -> String {
    if fmu_only.is_empty() {
        return String::new();
    }
    format!(
        "; start values in the FMU only, not in-process: {}, so a vs-library difference is theirs",
        fmu_only.join(", ")
    )
}

/// The wheel (index from 0) whose mean `(e/σ)²` is the farthest from 1 in ratio (a σ twice
/// too wide as far as one twice too narrow), with it; `None` if no wheel has a σ.
fn farthest_from_one(wheels: &[WheelFigures]) -> Option<(usize, NormalisedError)> {
    let distance = |n: &NormalisedError| n.mean_square.ln().abs();
    wheels
        .iter()
        .enumerate()
        .filter_map(|(j, w)| w.normalised_error.map(|n| (j, n)))
        .max_by(|a, b| distance(&a.1).total_cmp(&distance(&b.1)))
}

/// A mean normalised square with its reading, as the tables print it (`0.867 consistent`);
/// `—` where the analyzer has none.
fn read(figure: Option<(f64, Reading)>) -> String {
    figure.map_or("—".into(), |(value, reading)| format!("{value:.3} {}", reading.text()))
}

/// The weld's peak error as printed, a percentage; the other cases have none.
fn peak(case: Case, error: f64) -> String {
    weld_percent(case, error).map_or("—".into(), |percent| format!("{percent:+.1} %"))
}

/// The weld's peak error `error` (a fraction) in percent; `None` for the other cases.
fn weld_percent(case: Case, error: f64) -> Option<f64> {
    (case == Case::Weld).then_some(100.0 * error)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wheel's figures in the units `WheelFigures` has them: forces in N.
    fn wheel() -> WheelFigures {
        WheelFigures {
            correlation: 0.99,
            rmse: 300.0,
            running_rmse_mean: 250.0,
            running_rmse_var: 4.0e4,
            dynamic_std: 3000.0,
            peak_error: -0.5,
            band: Some((1.0, 27.0)),
            two_sigma: f64::NAN,
            one_sigma: f64::NAN,
            normalised_error: None,
        }
    }

    #[test]
    fn a_wheel_is_written_in_the_tables_units_and_under_their_names() {
        let after_step = WheelFigures { correlation: 0.98, ..wheel() };
        let smoothed = WheelFigures { correlation: 0.995, rmse: 150.0, two_sigma: 0.96, ..wheel() };
        let json = serde_json::to_value(WheelTable::new(Case::Weld, 2, &wheel(), &after_step, &smoothed)).unwrap();
        let expected = serde_json::json!({
            "wheelset": 2,
            "correlation": 0.99,
            "rmse": 0.3,
            "running_rmse_mean": 0.25,
            "running_rmse_variance": 0.04,
            "dynamic_std": 3.0,
            "rmse_over_dynamic_std": 0.1,
            "weld_peak_error": -50.0,
            "psd_agreement_band": [1.0, 27.0],
            "two_sigma_coverage": null,
            "one_sigma_coverage": null,
            "normalised_error": null,
            "after_step_correlation": 0.98,
            "smoothed": {
                "lag": SMOOTHING_LAG,
                "correlation": 0.995,
                "rmse": 0.15,
                "rmse_over_dynamic_std": 0.05,
                "one_sigma_coverage": null,
                "two_sigma_coverage": 0.96,
            },
        });
        assert_eq!(json, expected);
        // Each dimensional figure has its unit in the table's `units`.
        let units = units(&UNITS);
        for (name, unit) in [("rmse", "kN"), ("running_rmse_variance", "kN²"), ("weld_peak_error", "%"), ("lag", "s")]
        {
            assert_eq!(units[name], unit, "{name}");
        }
    }

    #[test]
    fn the_worst_normalised_error_is_the_farthest_from_one_in_ratio() {
        let with_mean = |mean_square: f64| WheelFigures {
            normalised_error: Some(NormalisedError {
                mean_square,
                samples: 100,
                effective_samples: 100.0,
                interval: [0.7, 1.3],
                reading: Reading::Consistent,
            }),
            ..wheel()
        };
        // 0.3 is farther from 1 in ratio (1/0.3 ≈ 3.3) than 2.5, though nearer in difference.
        let wheels = [with_mean(1.1), with_mean(2.5), with_mean(0.3), wheel()];
        let (index, worst) = farthest_from_one(&wheels).unwrap();
        assert_eq!((index, worst.mean_square), (2, 0.3));
        assert_eq!(farthest_from_one(&[wheel(), wheel()]), None);
    }

    #[test]
    fn only_the_weld_has_a_peak_error() {
        for case in [Case::Random, Case::Corrugation] {
            assert_eq!(WheelTable::new(case, 1, &wheel(), &wheel(), &wheel()).weld_peak_error, None, "{}", case.name());
            assert_eq!(peak(case, -0.5), "—");
        }
        assert_eq!(peak(Case::Weld, -0.5), "-50.0 %");
    }
}
