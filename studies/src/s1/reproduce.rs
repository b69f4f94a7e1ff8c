//! S1 in `kalfmu reproduce`: every case through the packaged FMU with every filter,
//! one log per run and one comparison per case, and the table beside the paper's figures,
//! printed and written as `table.json` ([`Table`]); then the unseen cases, loads the
//! set-up was not made for, with the SRCKF at 1 %, the run's and 5 % noise (`--quick`: one
//! of them), their paper columns blank. Beside each filter's accuracy, whether
//! its σ of the load is honest: the analyzer's 1σ and 2σ coverage and mean (e/σ)² of `F`,
//! and its NIS against the measurement rows used (docs/analyzer.md, "Is the σ honest?").

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use start_values::StartValues;

use analyzer::consistency::{Nis, NormalisedError, Reading};
use analyzer::metrics::Metrics;
use analyzer::report::{analyse, Options, PairReport, Report};
use anyhow::Context;
use estimator::FilterKind;
use indicatif::{ProgressBar, ProgressStyle};
use log_format::read::read_log;
use log_format::write::PREDICTION;

use serde::Serialize;

use crate::comparison::{compare_case, log_path, units, write_table, Compared};
use crate::smoothed::{smoothed_figures, SmoothedFigures};
use cosim::fmu_driver::ImportedFmu;
use shard::Shard;
use truth::s1::plant::Truth;
use truth::s1::{Case, Settings};

/// The figures of S1's table, as `table.json` has them.
#[derive(Debug, Serialize)]
pub struct Table {
    /// `"S1"`.
    pub study: &'static str,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field (see [`units`]).
    pub units: BTreeMap<&'static str, &'static str>,
    /// Where the `paper` figures come from.
    pub paper_source: &'static str,
    /// One entry per case, in the table's order.
    pub cases: Vec<CaseFigures>,
}

/// The set-up of a [`Table`].
#[derive(Debug, Serialize)]
pub struct TableSettings {
    /// Simulated duration (s).
    pub duration: f64,
    /// Sampling rate (Hz).
    pub rate: f64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// Seed of the load and of the noise.
    pub seed: u64,
    /// The running RMSE's trailing window (s).
    pub rmse_window: f64,
    /// Whether this is `--quick`'s short run (one unseen case instead of all).
    pub quick: bool,
    /// The start values given (`--set`, `--values`), set on every FMU run over the study's
    /// parameters; empty without any.
    pub start_values: BTreeMap<String, f64>,
}

/// One case of a [`Table`]: the paper's SRCKF figures and every filter's, or for an
/// unseen case the SRCKF's alone.
#[derive(Debug, Serialize)]
pub struct CaseFigures {
    /// The case, as printed (`stiffness/random`, `damping/chirp`, …).
    pub case: String,
    /// Whether the paper published figures for the case: `false` for the unseen cases
    /// (`truth::s1::Case::UNSEEN`), loads the set-up was not made for.
    pub published: bool,
    /// The accelerometer noise of the case's runs, a fraction of each channel's RMS (the
    /// settings' for the paper's cases; 1 %, the settings' or 5 % for the unseen ones).
    pub noise_fraction: f64,
    /// The paper's SRCKF figures; `null` for an unseen case, and each figure `null` where
    /// the paper gives none.
    pub paper: Option<PaperFigures>,
    /// Why the case's runs could not be compared, if they could not (then `filters` is empty).
    pub failure: Option<String>,
    /// One entry per filter kind, in the table's order (an unseen case: the SRCKF only).
    pub filters: Vec<FilterFigures>,
}

/// The paper's figures of a case (its SRCKF).
#[derive(Debug, Serialize)]
pub struct PaperFigures {
    /// Correlation of the identified load with the true one.
    pub correlation: f64,
    /// Largest running RMSE (N).
    pub running_rmse_peak: Option<f64>,
    /// The bound the running RMSE stays under after the start (N).
    pub running_rmse_max_converged: Option<f64>,
}

/// One filter's figures on a case: the load `F` read at t after the inputs of t were set
/// (`feedthrough`, the table's first columns) and right after the step (`after_step`).
#[derive(Debug, Serialize)]
pub struct FilterFigures {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Why the run failed, if it did (then the figures are `null`).
    pub failure: Option<String>,
    /// The figures of the feedthrough reading.
    pub feedthrough: Option<FeedthroughFigures>,
    /// The figures of the reading after `fmi2DoStep`, against the truth at t + dt.
    pub after_step: Option<AfterStepFigures>,
    /// The NIS of the run's updates against the measurement rows they used, the analyzer's
    /// (`null` if the run failed or its log has no `nis`).
    pub nis: Option<Nis>,
    /// The FMU's fixed-lag smoothed load (`smoothing_lag`, on `/smoothed`) against the
    /// truth (`null` if the run failed).
    pub smoothed: Option<SmoothedFigures>,
}

/// The feedthrough reading's figures of the load.
#[derive(Debug, Serialize)]
pub struct FeedthroughFigures {
    /// Correlation with the true load.
    pub correlation: f64,
    /// RMSE after the convergence time (N).
    pub rmse_converged: f64,
    /// Largest running RMSE (N).
    pub running_rmse_peak: f64,
    /// Largest running RMSE after the convergence time (N).
    pub running_rmse_max_converged: f64,
    /// When the estimate is taken to have converged (s).
    pub convergence_time: f64,
    /// The widest band where the spectra agree within 3 dB, `[low, high]` (Hz).
    pub psd_agreement_band: Option<(f64, f64)>,
    /// Fraction of samples whose error is within the FMU's ±σ of the load (0.6827 for an
    /// honest σ and a Gaussian error; `null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// Fraction of samples whose error is within ±2σ (0.9545 for an honest σ).
    pub two_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (1 for an honest σ) with its reading, the analyzer's.
    pub normalised_error: Option<NormalisedError>,
}

/// The after-step reading's figures of the load.
#[derive(Debug, Serialize)]
pub struct AfterStepFigures {
    /// Correlation with the true load.
    pub correlation: f64,
    /// RMSE after the convergence time (N).
    pub rmse_converged: f64,
}

/// The units of S1's [`Table`].
const UNITS: [(&str, &str); 8] = [
    ("duration", "s"),
    ("rate", "Hz"),
    ("rmse_window", "s"),
    ("rmse_converged", "N"),
    ("running_rmse_peak", "N"),
    ("running_rmse_max_converged", "N"),
    ("convergence_time", "s"),
    ("psd_agreement_band", "Hz"),
];

/// The noise levels, besides the run's own, at which the unseen cases run in the full
/// table: the ends of the 1–5 % the study covers.
const UNSEEN_NOISE: [f64; 2] = [0.01, 0.05];

/// The FMU's default filter: its run stands for the others in a case's recording when they
/// all agree within its σ (`comparison::compare_case`).
const DEFAULT_FILTER: FilterKind = FilterKind::SrCkf;

/// The filter of the unseen cases: the paper's, and the FMU's default. Every kind on each
/// of them at three noise levels would be 90 runs more, over four times the table's time.
const UNSEEN_FILTER: FilterKind = DEFAULT_FILTER;

/// The unseen cases the table adds, each with its noise fraction: with `quick`, one short
/// one at the run's noise (the band to 20 Hz, twice the bandwidth the set-up assumes; the
/// chirp, which sweeps over the whole run, would sweep six times as fast in the short run
/// as in the full one); otherwise each of [`Case::UNSEEN`] at 1 %, the run's noise and
/// 5 %, in that order.
fn unseen_runs(settings: &Settings, quick: bool) -> Vec<(Case, f64)> {
    if quick {
        let band = Case::unseen(truth::s1::Nonlinearity::Stiffness, truth::s1::UnseenLoad::Band20);
        return vec![(band, settings.noise_fraction)];
    }
    let mut noises = UNSEEN_NOISE.to_vec();
    noises.push(settings.noise_fraction);
    noises.sort_by(f64::total_cmp);
    noises.dedup();
    Case::UNSEEN.iter().flat_map(|&case| noises.iter().map(move |&noise| (case, noise))).collect()
}

/// A noise fraction as a file name has it: `0.02` → `2p0`.
fn noise_label(fraction: f64) -> String {
    format!("{:.1}", 100.0 * fraction).replace('.', "p")
}

/// What every case's runs share.
struct Given<'a> {
    fmu: &'a ImportedFmu,
    start_values: &'a StartValues,
    options: &'a Options,
    bar: &'a ProgressBar,
    /// Each case's truth, simulated once for all its noise levels (the noise has a stream
    /// of its own, so the truth does not depend on it).
    truths: &'a [(Case, Truth)],
}

/// One filter's figures of the load on a case.
#[derive(Debug, Clone)]
struct Figures {
    /// The feedthrough reading's metrics.
    feedthrough: Metrics,
    /// Its spectra's band of agreement.
    band: Option<(f64, f64)>,
    /// The after-step reading's metrics.
    after_step: Metrics,
    /// The σ figures.
    sigma: SigmaOfLoad,
    /// The FMU's fixed-lag smoothed load.
    smoothed: SmoothedFigures,
}

/// Each filter's figures of a case or why its run failed; or why the runs could not be
/// compared.
type CaseRuns = Result<Vec<(FilterKind, anyhow::Result<Figures>)>, String>;

/// A case's runs of `kinds` through the FMU, logged and read back, compared in one
/// comparison (`<stem>.json`, `<stem>.rrd`): each filter's figures or why its run failed,
/// or why the runs could not be compared; and the recording, if written.
fn run_case(
    given: &Given<'_>,
    case: &Case,
    settings: &Settings,
    kinds: &[FilterKind],
    stem: &Path,
) -> (CaseRuns, Option<PathBuf>) {
    let Given { fmu, start_values, options, bar, truths } = *given;
    let truth = &truths.iter().find(|(c, _)| c == case).expect("every case's truth is simulated").1;
    // As `truth::s1::simulate` measures it: the noise at the settings' fraction and seed.
    let measurements = truth::s1::measure(truth, settings.noise_fraction, settings.seed);
    let mut runs = Vec::new();
    let mut rows: Vec<(FilterKind, anyhow::Result<usize>)> = Vec::new();
    for &kind in kinds {
        bar.set_message(format!("{case} {kind}"));
        let log = log_path(stem, kind);
        let sim = super::fmu_run::Simulated { case, settings, truth, measurements: &measurements, start_values };
        let result =
            super::fmu_run::run(fmu, kind, &sim, &log, &|| bar.inc(1)).and_then(|()| Ok(read_log(&log)?)).map(|run| {
                runs.push(run);
                runs.len() - 1
            });
        rows.push((kind, result));
    }
    let mut recording = None;
    let compared = compare_case(&runs, &[], options, stem, Some(DEFAULT_FILTER)).and_then(
        |Compared { comparison, recording: written, .. }| {
            recording = Some(written);
            let after_step =
                runs.iter().map(|run| analyse(run, &Options { estimate_topic: PREDICTION.into(), ..options.clone() }));
            let after_step = after_step.collect::<Result<Vec<_>, _>>()?;
            let smoothed = runs.iter().map(|run| smoothed_figures(run, options, "F"));
            let smoothed = smoothed
                .collect::<anyhow::Result<Vec<_>>>()
                .map_err(|e| log_format::LogError::Analysis { file: stem.into(), what: format!("{e:#}") })?;
            let loads = comparison.runs.iter().zip(&after_step).zip(smoothed).map(|((report, after), smoothed)| {
                let (Some(pair), Some(after)) = (load_pair(report), load_pair(after)) else {
                    return Err(format!("the report of {} has no load pair", report.file));
                };
                let sigma = SigmaOfLoad {
                    one_sigma_coverage: pair.one_sigma_coverage,
                    two_sigma_coverage: pair.two_sigma_coverage,
                    normalised_error: pair.normalised_error,
                    nis: report.nis.clone(),
                };
                Ok(Figures {
                    feedthrough: pair.metrics,
                    band: pair.psd_agreement_band,
                    after_step: after.metrics,
                    sigma,
                    smoothed,
                })
            });
            Ok(loads.collect::<Vec<_>>())
        },
    );
    let figures = compared.map_err(|e| e.to_string()).map(|loads| {
        rows.into_iter()
            .map(|(kind, result)| (kind, result.and_then(|i| loads[i].clone().map_err(anyhow::Error::msg))))
            .collect()
    });
    (figures, recording)
}

/// The table's header line, its first column titled `first`.
fn header(first: &str) -> String {
    format!(
        "{:<22} {:<8} {:>8} {:>6} {:>9} {:>9} {:>7} {:>10} {:>7} {:>7} {:>12}  {:>10} {:>10}  {:>6} {:>6} {:>17} {:>17}  \
         {:>9} {:>9} {:>6}",
        first,
        "filter",
        "corr",
        "paper",
        "RMSE conv",
        "run.peak",
        "paper",
        "run.max cv",
        "paper",
        "t_conv",
        "PSD ±3dB Hz",
        "after step",
        "RMSE conv",
        "1σ F",
        "2σ F",
        "(e/σ)² F",
        "NIS/rows",
        "smoothed",
        "RMSE conv",
        "2σ F"
    )
}

/// One filter's line of the table; the paper's columns blank without `paper`.
fn line(label: &str, kind: FilterKind, f: &Figures, paper: Option<&super::Published>) -> String {
    let (c, a, sigma, s) = (&f.feedthrough, &f.after_step, &f.sigma, &f.smoothed);
    let figure = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.3}"));
    let (paper_corr, paper_peak, paper_max) = match paper {
        Some(p) => (format!("{:.3}", p.correlation), figure(p.running_rmse_peak), figure(p.running_rmse_max_converged)),
        None => (String::new(), String::new(), String::new()),
    };
    format!(
        "{:<22} {:<8} {:>8.5} {:>6} {:>9.4} {:>9.3} {:>7} {:>10.4} {:>7} {:>6.2}s {:>12}  {:>10.5} {:>10.4}  {:>6} \
         {:>6} {:>17} {:>17}  {:>9.5} {:>9.4} {:>6}",
        label,
        kind.name(),
        c.correlation,
        paper_corr,
        c.rmse_converged,
        c.running_rmse_peak,
        paper_peak,
        c.running_rmse_max_converged,
        paper_max,
        c.convergence_time,
        f.band.map_or("—".into(), |(lo, hi)| format!("{lo:.2}–{hi:.1}")),
        a.correlation,
        a.rmse_converged,
        coverage(sigma.one_sigma_coverage),
        coverage(sigma.two_sigma_coverage),
        read(sigma.normalised_error.map(|n| (n.mean_square, n.reading))),
        read(sigma.nis.as_ref().and_then(|n| n.ratio.zip(n.reading))),
        s.correlation,
        s.rmse_converged,
        coverage(s.two_sigma_coverage)
    )
}

impl FilterFigures {
    /// A run's entry from its figures.
    fn of(kind: FilterKind, f: Figures) -> Self {
        let (c, a) = (f.feedthrough, f.after_step);
        Self {
            filter: kind.name(),
            failure: None,
            feedthrough: Some(FeedthroughFigures {
                correlation: c.correlation,
                rmse_converged: c.rmse_converged,
                running_rmse_peak: c.running_rmse_peak,
                running_rmse_max_converged: c.running_rmse_max_converged,
                convergence_time: c.convergence_time,
                psd_agreement_band: f.band,
                one_sigma_coverage: f.sigma.one_sigma_coverage,
                two_sigma_coverage: f.sigma.two_sigma_coverage,
                normalised_error: f.sigma.normalised_error,
            }),
            after_step: Some(AfterStepFigures { correlation: a.correlation, rmse_converged: a.rmse_converged }),
            nis: f.sigma.nis,
            smoothed: Some(f.smoothed),
        }
    }

    /// A failed run's entry.
    fn failed(kind: FilterKind, why: String) -> Self {
        Self { filter: kind.name(), failure: Some(why), feedthrough: None, after_step: None, nis: None, smoothed: None }
    }
}

/// One case's part of the table.
struct Tabulated {
    /// Its lines.
    lines: String,
    /// Its entry of `table.json`.
    figures: CaseFigures,
    /// Its failed runs (or 1 if they could not be compared).
    failures: usize,
    /// Its comparison's recording, if written.
    recording: Option<PathBuf>,
}

/// Runs `case` at `settings` and tabulates it: a paper's case with every filter kind in
/// `dir`, beside the paper's figures; an unseen one with [`UNSEEN_FILTER`], labelled with
/// its noise, in files named with it.
fn tabulate(given: &Given<'_>, case: &Case, settings: &Settings, dir: &Path) -> Tabulated {
    let paper = super::published(case);
    let noise = settings.noise_fraction;
    let name = case.to_string().replace('/', "_");
    let (label, stem, kinds) = match paper {
        Some(_) => (case.to_string(), dir.join(name), &FilterKind::ALL[..]),
        None => {
            let percent = (1000.0 * noise).round() / 10.0;
            (
                format!("{case} {percent}%"),
                dir.join(format!("{name}_noise{}", noise_label(noise))),
                &[UNSEEN_FILTER][..],
            )
        }
    };
    let (runs, recording) = run_case(given, case, settings, kinds, &stem);
    let mut tabulated = Tabulated {
        lines: String::new(),
        figures: CaseFigures {
            case: case.to_string(),
            published: paper.is_some(),
            noise_fraction: noise,
            paper: paper.map(|p| PaperFigures {
                correlation: p.correlation,
                running_rmse_peak: p.running_rmse_peak,
                running_rmse_max_converged: p.running_rmse_max_converged,
            }),
            failure: None,
            filters: Vec::new(),
        },
        failures: 0,
        recording,
    };
    let (lines, figures) = (&mut tabulated.lines, &mut tabulated.figures);
    match runs {
        Err(e) => {
            tabulated.failures += 1;
            let _ = writeln!(lines, "{label:<22} FAILED to compare the filters: {e}");
            figures.failure = Some(e);
        }
        Ok(rows) => {
            for (kind, result) in rows {
                match result {
                    Ok(f) => {
                        let _ = writeln!(lines, "{}", line(&label, kind, &f, paper.as_ref()));
                        figures.filters.push(FilterFigures::of(kind, f));
                    }
                    Err(e) => {
                        tabulated.failures += 1;
                        let _ = writeln!(lines, "{label:<22} {:<8} FAILED: {e:#}", kind.name());
                        figures.filters.push(FilterFigures::failed(kind, format!("{e:#}")));
                    }
                }
            }
        }
    }
    tabulated
}

/// Runs S1 through its FMU, prints the table and writes it as `table.json` in `out/s1`;
/// returns the number of failed runs. The paper's four cases run with every filter kind at
/// the settings' noise; the unseen cases ([`unseen_runs`]: all of them at 1 %, the run's
/// noise and 5 %, or with `quick` one) with the SRCKF, their logs and comparisons in
/// `out/s1/unseen`.
pub fn report(
    settings: &Settings,
    start_values: &StartValues,
    quick: bool,
    fmu_dir: &Path,
    out: &Path,
) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, "kalfmu_s1_load")?;
    // A misspelt name or a value of the wrong type costs no run.
    fmu.check_start_values(start_values)?;
    let dir = out.join("s1");
    let unseen_dir = dir.join("unseen");
    std::fs::create_dir_all(&unseen_dir).with_context(|| format!("cannot create {}", unseen_dir.display()))?;
    println!(
        "S1: dynamic load on a 2-DOF nonlinear chain — {} s at {} Hz, truth RK4 at {:.0e} s, accelerometer noise {:.1} % of RMS, seed {}",
        settings.duration,
        settings.rate,
        settings.dt() / settings.truth_substeps() as f64,
        100.0 * settings.noise_fraction,
        settings.seed
    );
    if !start_values.is_empty() {
        println!("start values, over the study's in every FMU run: {}", start_values.summary());
    }
    println!(
        "estimates from {} driven through the fmi importer; per run a log (<case>_<filter>.mcap), per case a comparison \
         of every filter (<case>.json, and the Rerun recording <case>.rrd) in {}",
        fmu_dir.join("kalfmu_s1_load.fmu").display(),
        dir.display()
    );
    println!(
        "running RMSE over a trailing {} s window; 'conv' = after the convergence time (analyzer/src/metrics.rs)",
        settings.rmse_window
    );
    println!(
        "two readings of the FMU's outputs, as a master has them: at t after the inputs of t were set (feedthrough, \
         the first columns) and right after fmi2DoStep(t, dt), the estimate at t + dt predicted from the measurements \
         up to t ('after step'); each compared with the truth at its own time stamp"
    );
    let unseen = unseen_runs(settings, quick);
    let runs = (Case::ALL.len() * FilterKind::ALL.len() + unseen.len()) as u64;
    let ticks_per_run = (settings.samples() / 1000) as u64;
    let bar = ProgressBar::new(runs * ticks_per_run.max(1));
    bar.set_style(ProgressStyle::with_template("{bar:40} {pos}/{len} {msg} [{elapsed}]").expect("a valid template"));
    let options = Options { rmse_window: settings.rmse_window, ..Options::default() };
    // The truths first, on every core: they take most of the time (a 60 s run is 1.2
    // million RK4 steps under a load of hundreds of harmonics), and the FMU runs, one
    // instance at a time, cannot share them out.
    let mut simulated: Vec<Case> = Case::ALL.to_vec();
    for (case, _) in &unseen {
        if !simulated.contains(case) {
            simulated.push(*case);
        }
    }
    bar.set_message("simulating the truths");
    let truths: Vec<(Case, Truth)> = shard::run(&simulated, Shard::ALL, |case| truth::s1::simulate(case, settings).0)
        .into_iter()
        .map(|(j, truth)| (simulated[j], truth))
        .collect();
    let given = Given { fmu: &fmu, start_values, options: &options, bar: &bar, truths: &truths };
    let mut table = header("case") + "\n";
    let mut failures = 0;
    let mut recordings = Vec::new();
    let mut cases = Vec::new();
    for case in Case::ALL {
        let tabulated = tabulate(&given, &case, settings, &dir);
        failures += tabulated.failures;
        table += &tabulated.lines;
        recordings.extend(tabulated.recording);
        cases.push(tabulated.figures);
    }
    let _ = writeln!(
        table,
        "unseen cases, loads the set-up was not made for (truth::s1::Case::UNSEEN: band-limited to 20 Hz, a train of \
         steps, a chirp 0.1–15 Hz): no paper figures, {} only, at the noise shown (% of RMS){}",
        UNSEEN_FILTER.name(),
        if quick { "; --quick runs one" } else { "" }
    );
    table += &(header("unseen case, noise") + "\n");
    for &(case, noise) in &unseen {
        let tabulated = tabulate(&given, &case, &Settings { noise_fraction: noise, ..*settings }, &unseen_dir);
        failures += tabulated.failures;
        table += &tabulated.lines;
        cases.push(tabulated.figures);
    }
    bar.finish_and_clear();
    let system_case = Case::ALL[0];
    let system_truth = &truths.iter().find(|(c, _)| *c == system_case).expect("simulated").1;
    let system = run_system(&fmu, &system_case, system_truth, settings, start_values, fmu_dir, &dir);
    failures += usize::from(system.is_err());
    write_table(
        &dir,
        &Table {
            study: "S1",
            settings: TableSettings {
                duration: settings.duration,
                rate: settings.rate,
                noise_fraction: settings.noise_fraction,
                seed: settings.seed,
                rmse_window: settings.rmse_window,
                quick,
                start_values: start_values.iter().map(|(n, v)| (n.to_string(), v)).collect(),
            },
            units: units(&UNITS),
            paper_source: PAPER_SOURCE,
            cases,
        },
    )?;
    print!("{table}");
    println!("paper: {PAPER_SOURCE} (correlation; running-RMSE peak; bound after the start), N");
    match system {
        Ok((path, c)) => {
            println!(
                "system: {system_case} as an SSP archive, the plant FMU kalfmu_s1_chain wired to kalfmu_s1_load ({}), \
                 under a Jacobi master over the fmi importer, {DEFAULT_FILTER}: F RMSE {:.4} N, 2σ coverage {:.3} \
                 against the plant's F at the same {} time stamps; the in-process co-simulation of the case: RMSE {:.4} N, \
                 2σ coverage {:.3}; {}",
                path.display(),
                c.system.rmse,
                c.system.two_sigma_coverage,
                c.system.samples,
                c.in_process.rmse,
                c.in_process.two_sigma_coverage,
                if c.bit_for_bit {
                    "the two estimates are the same bit for bit".to_string()
                } else {
                    format!("the estimates differ by up to {:.3e} N", c.largest_difference)
                }
            );
        }
        Err(e) => println!("system: {system_case} as an SSP archive FAILED: {e:#}"),
    }
    println!(
        "smoothed: the FMU's fixed-lag smoothed load (smoothing_lag = {} s, the estimate of that much earlier given \
         the measurements up to now; logged on /smoothed): correlation, RMSE after convergence, 2σ coverage",
        crate::smoothed::SMOOTHING_LAG
    );
    println!("comparison recordings, every filter of a case, or the default one standing for those within its σ (open with the Rerun viewer 0.41 or newer):");
    for recording in &recordings {
        println!("  {}", recording.display());
    }
    println!(
        "  and one per unseen case and noise in {} (<case>_noise<percent>.rrd, {} in all)",
        unseen_dir.display(),
        unseen.len()
    );
    Ok(failures)
}

/// Writes `case` as a system of the plant and estimator FMUs (`<dir>/s1_system.ssp`), runs
/// it and compares it with the case's in-process run of [`DEFAULT_FILTER`].
fn run_system(
    fmu: &ImportedFmu,
    case: &Case,
    truth: &Truth,
    settings: &Settings,
    start_values: &StartValues,
    fmu_dir: &Path,
    dir: &Path,
) -> anyhow::Result<(PathBuf, crate::system::Compared)> {
    let noise_std = truth::s1::measure(truth, settings.noise_fraction, settings.seed).noise_std;
    let system = super::system::system(case, settings, noise_std, DEFAULT_FILTER, start_values, fmu)?;
    let path = dir.join("s1_system.ssp");
    crate::system::write(&system, fmu_dir, &path)?;
    let unpack = dir.join(".s1_system_fmus");
    let in_process = log_path(&dir.join(case.to_string().replace('/', "_")), DEFAULT_FILTER);
    let compared = crate::system::run_and_compare(&path, &unpack, &["F"], &in_process)?;
    Ok((path, compared))
}

/// Where the paper's figures come from, as the table's footnote names it.
const PAPER_SOURCE: &str = "SRCKF figures of Gong et al. 2024";

/// The report's pair of the load `F`.
fn load_pair<'a>(report: &'a Report<'_>) -> Option<&'a PairReport<'a>> {
    report.pairs.iter().find(|p| p.truth == "F")
}

/// What the analyzer's report of a run says of its σ: of the load `F` (feedthrough reading)
/// and of its innovations.
#[derive(Debug, Clone)]
struct SigmaOfLoad {
    one_sigma_coverage: Option<f64>,
    two_sigma_coverage: Option<f64>,
    normalised_error: Option<NormalisedError>,
    nis: Option<Nis>,
}

/// A coverage as the table prints it; `—` without σ.
fn coverage(fraction: Option<f64>) -> String {
    fraction.map_or("—".into(), |f| format!("{f:.3}"))
}

/// A mean normalised square with its reading, as the table prints it (`1.056 consistent`);
/// `—` where the analyzer has none.
fn read(figure: Option<(f64, Reading)>) -> String {
    figure.map_or("—".into(), |(value, reading)| format!("{value:.3} {}", reading.text()))
}
