//! S4 in `kalfmu reproduce`: on the paper's test run (and, without `--quick`, the
//! 500 km/h run), with the default faults and then with the `frequent` faults (the four
//! fault rates ten times the default's: a case neither the jerk of the tuning nor the
//! detectors' settings were chosen on), every filter kind through the packaged FMU,
//! checked against the same filter in-process; then the study's table (`s4-compare`'s)
//! with ours read from the FMU's outputs (SRCKF, the FMU's default), beside the raw
//! average and the paper's pipeline (in-process: the paper's method, not our FMU); one
//! log per run and one comparison recording per case (`out/s4/`), and the figures as
//! `table.json` there ([`Table`]). Per filter, whether the FMU's σ of speed and position is
//! honest, from the analyzer's report of its log (docs/analyzer.md, "Is the σ honest?"):
//! their 1σ and 2σ coverage and mean (e/σ)² with its reading, and the NIS against the
//! measurement rows used.
//!
//! Every FMU run also smooths its position and speed (`smoothing_lag`
//! [`SMOOTHING_LAG`], 5 telegrams: a fixed-lag smoother inside the FMU, logged on
//! `/smoothed`). Each filter's smoothed speed and position are scored from its log by the
//! analyzer as ours is, against the truth at the telegram each describes
//! ([`SmoothedScores`]); the SRCKF's is the comparison's `ours smoothed` row.
//!
//! Start values (`--set`, `--values`) go to every FMU run over the study's parameters and,
//! where the in-process filter has them ([`Tuning::set`]), to the in-process run it is
//! checked against. Those it does not have (the supervisor's and the slips' settings,
//! `filter`, `sample_time`, …) reach the FMU only: its difference from the in-process run
//! then measures what they change, which the `vs library` line says.

use std::collections::BTreeMap;
use std::path::Path;

use start_values::{SetByName, StartValues};

use analyzer::consistency::{Nis, NormalisedError, Reading};
use analyzer::report::{analyse, Options, PairReport, Report};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::{read_log, Run};
use log_format::write::{ESTIMATE, SMOOTHED};
use serde::Serialize;

use super::baselines;
use super::compare::{compare_with, print_comparison, Comparison, PAPER_MEAN_REDUCTION, PAPER_RANGE};
use super::fmu_run::{self, COMPARED, IDENTIFIER};
use super::metrics::{reduction, score_position, score_speed, SpeedScore};
use super::ours::{self, Settings, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of, units, write_table, Compared};
use crate::smoothed::SMOOTHING_LAG;
use cosim::fmu_driver::ImportedFmu;
use truth::s4::channels::simulate;
use truth::s4::faults::{FaultProfile, Faults};
use truth::s4::profile::Profile;

/// The figures of S4's tables, as `table.json` has them.
#[derive(Serialize)]
pub struct Table {
    /// `"S4"`.
    pub study: &'static str,
    /// Seed of the noise and the faults (as `settings.seed`).
    pub seed: u64,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field (see [`units`]).
    pub units: BTreeMap<&'static str, &'static str>,
    /// The paper's figures (§3.2), of its test run.
    pub paper: PaperFigures,
    /// One entry per case run: `paper` and `paper_frequent`, and without `--quick`
    /// `high_speed` and `high_speed_frequent`.
    pub profiles: Vec<ProfileFigures>,
}

/// The set-up of a [`Table`].
#[derive(Serialize)]
pub struct TableSettings {
    /// Seed of the noise and the faults.
    pub seed: u64,
    /// Whether this is `--quick`'s short set (the paper's run alone, with both fault models).
    pub quick: bool,
    /// The start values given (`--set`, `--values`), set on every FMU run over the study's
    /// parameters; empty without any.
    pub start_values: BTreeMap<String, f64>,
    /// Those of `start_values` the in-process filter does not take ([`Tuning::takes`]):
    /// they reach the FMU only, and `fmu_vs_in_process_max_abs_difference` then measures
    /// their effect.
    pub start_values_fmu_only: Vec<String>,
}

/// The paper's figures: its pipeline against the raw average.
#[derive(Serialize)]
pub struct PaperFigures {
    /// The reduction of the mean speed error, `(before − after)/before`.
    pub mean_abs_error_reduction_from_raw: f64,
    /// The raw average's speed range (m/s).
    pub raw_average_speed_range: f64,
    /// The speed range after its pipeline (m/s).
    pub paper_fused_ukf_speed_range: f64,
}

/// One case's run: a motion and a fault model.
#[derive(Serialize)]
pub struct ProfileFigures {
    /// The case, the stem of its logs and recording: `paper`, `paper_frequent`,
    /// `high_speed`, `high_speed_frequent`.
    pub case: &'static str,
    /// The motion: `paper` (the paper's test run) or `high_speed` (to 500 km/h).
    pub profile: &'static str,
    /// The fault model ([`FaultProfile`]'s name): `default` or `frequent`.
    pub faults: &'static str,
    /// Whether the settings were chosen on this case's fault model (`default`): `false`
    /// for `frequent`, a case unlike the tuning's and not the paper's.
    pub tuned_on: bool,
    /// The run's duration (s).
    pub duration: f64,
    /// Telegrams per channel.
    pub telegrams: usize,
    /// Every filter kind through the FMU against the same filter in-process.
    pub filters: Vec<FilterCheck>,
    /// The kind `comparison`'s `ours` ran.
    pub compared_filter: &'static str,
    /// The raw average, the paper's pipeline (in-process) and ours (through the FMU) scored
    /// against the truth: `raw_average`, `paper_fused`, `paper_fused_ukf` and `ours`, each
    /// with its `speed` score, `position_max_abs_error`, `in_etcs_band_fraction` and
    /// `mean_abs_error_reduction_from_raw`; `paper_detection` and `our_detection`, with
    /// `false_alarm_fraction` of the channel-telegrams. `null` if the run failed.
    pub comparison: Option<serde_json::Value>,
}

/// One filter kind's run through the FMU.
#[derive(Serialize)]
pub struct FilterCheck {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Why the run failed, if it did.
    pub failure: Option<String>,
    /// The largest difference of position (m), speed (m/s), offsets (m) and weights (1)
    /// between the FMU's outputs and the same filter's in-process.
    pub fmu_vs_in_process_max_abs_difference: Option<f64>,
    /// What the FMU's σ of the speed says against its errors (`null` if the run or the
    /// comparison failed).
    pub speed: Option<SignalSigma>,
    /// The same of the position.
    pub position: Option<SignalSigma>,
    /// The NIS of the run's updates against the measurement rows they used (`null` if the
    /// run or the comparison failed, or the log has no `nis`).
    pub nis: Option<Nis>,
    /// The FMU's fixed-lag smoothed speed and position scored against the truth (`null` if
    /// the run failed or its `/smoothed` could not be scored).
    pub smoothed: Option<SmoothedScores>,
}

/// A run's fixed-lag smoothed speed and position (the FMU's `smoothing_lag`, on
/// `/smoothed`), scored as the comparison scores ours: each smoothed estimate against the
/// truth at the telegram it describes, from telegram 1 (ours' first) to the last the
/// run's smoothed estimates reach, `n − 1 − lag/Δt` (the last `lag` has none yet).
#[derive(Serialize)]
pub struct SmoothedScores {
    /// The smoothing lag (s): the estimate of that much before the newest telegram.
    pub lag: f64,
    /// Telegrams scored.
    pub telegrams: usize,
    /// The smoothed speed's score (as ours' `speed`).
    pub speed: SpeedScore,
    /// The largest `|e|` of the smoothed position (m).
    #[serde(rename = "position_max_abs_error")]
    pub position_max: f64,
    /// Fraction of the smoothed speeds within the ETCS band at the true speed (the
    /// analyzer's `in_tolerance` of `speed_tolerance`).
    #[serde(rename = "in_etcs_band_fraction")]
    pub in_band: f64,
    /// The reduction of the mean speed error from the raw average's (over all of ours'
    /// telegrams), `(before − after)/before`; `null` if the comparison failed.
    pub mean_abs_error_reduction_from_raw: Option<f64>,
    /// What the smoothed σ of the speed says against its errors.
    pub speed_sigma: SignalSigma,
    /// The same of the position.
    pub position_sigma: SignalSigma,
}

impl SmoothedScores {
    /// The scores of `run`'s `/smoothed` from `from` (s) on, by the analyzer.
    fn of(run: &Run, from: f64) -> anyhow::Result<Self> {
        let report = analyse(run, &Options { estimate_topic: SMOOTHED.into(), from, ..Options::default() })?;
        let pair = |signal: &str| {
            let pair = report.pairs.iter().find(|p| p.truth == signal);
            let pair = pair.with_context(|| format!("{} has no smoothed {signal}", run.file.display()))?;
            // The analyzer's series are whole; its figures start at `from`.
            let first = pair.time.iter().position(|&t| t >= from).unwrap_or(pair.time.len());
            Ok::<_, anyhow::Error>((pair, first))
        };
        let ((speed, first), (position, first_position)) = (pair("speed")?, pair("position")?);
        let sigma = |pair: &PairReport<'_>| SignalSigma {
            one_sigma_coverage: pair.one_sigma_coverage,
            two_sigma_coverage: pair.two_sigma_coverage,
            normalised_error: pair.normalised_error,
        };
        Ok(Self {
            lag: SMOOTHING_LAG,
            telegrams: speed.samples,
            speed: score_speed(&speed.estimate_values[first..], &speed.truth_values[first..]),
            position_max: score_position(
                &position.estimate_values[first_position..],
                &position.truth_values[first_position..],
            )
            .max_abs,
            in_band: speed.in_tolerance.context("the log's truth has no speed_tolerance")?,
            mean_abs_error_reduction_from_raw: None,
            speed_sigma: sigma(speed),
            position_sigma: sigma(position),
        })
    }

    /// Its row of the comparison's speed table, below ours, `raw` the raw average's mean
    /// speed error.
    fn row(&self, raw: Option<f64>) -> String {
        let against_raw =
            raw.map_or("—".into(), |raw| format!("{:.1}%", -100.0 * reduction(raw, self.speed.mean_abs_error)));
        format!(
            "{:<22} {:>9.4} {:>9} {:>9.3} {:>12.3} {:>9.3} {:>10.4} {:>7.2}%",
            format!("ours smoothed ({SMOOTHING_LAG} s)"),
            self.speed.mean_abs_error,
            against_raw,
            self.speed.max_abs_error,
            self.speed.speed_range,
            self.speed.error_range,
            self.position_max,
            100.0 * self.in_band
        )
    }
}

/// `text` with `line` inserted after its row labelled `label` (a row of
/// [`print_comparison`]'s speed table), or at its end if it has none.
fn insert_after_row(text: &mut String, label: &str, line: &str) {
    let row = format!("\n{label:<22} ");
    let at = text.find(&row).and_then(|start| text[start + 1..].find('\n').map(|end| start + 1 + end + 1));
    match at {
        Some(at) => text.insert_str(at, &format!("{line}\n")),
        None => text.push_str(&format!("{line}\n")),
    }
}

/// The analyzer's figures of one estimated signal's σ against its errors.
#[derive(Serialize)]
pub struct SignalSigma {
    /// Fraction of samples whose error is within ±σ (0.6827 for an honest σ and a Gaussian
    /// error; `null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// Fraction of samples whose error is within ±2σ (0.9545).
    pub two_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (1 for an honest σ) with its reading.
    pub normalised_error: Option<NormalisedError>,
}

impl SignalSigma {
    /// The figures of the pair of `signal` in `report`; `None` if it has no such pair.
    fn of(report: &Report<'_>, signal: &str) -> Option<Self> {
        let pair: &PairReport<'_> = report.pairs.iter().find(|p| p.truth == signal)?;
        Some(Self {
            one_sigma_coverage: pair.one_sigma_coverage,
            two_sigma_coverage: pair.two_sigma_coverage,
            normalised_error: pair.normalised_error,
        })
    }

    /// `1σ/2σ (e/σ)² reading`, as the σ lines print it (`0.819/0.991 0.5658 too wide`).
    fn text(this: Option<&Self>) -> String {
        let Some(s) = this else { return "—".into() };
        let coverage = |c: Option<f64>| c.map_or("—".into(), |c| format!("{c:.3}"));
        let normalised = s.normalised_error.map_or("—".into(), |n| read(n.mean_square, n.reading));
        format!("{}/{} {normalised}", coverage(s.one_sigma_coverage), coverage(s.two_sigma_coverage))
    }
}

/// A mean normalised square with its reading, to four significant digits.
fn read(value: f64, reading: Reading) -> String {
    let digits = if value.is_finite() && value != 0.0 { (3 - value.abs().log10().floor() as i32).max(0) } else { 0 };
    format!("{value:.digits$} {}", reading.text(), digits = digits as usize)
}

/// The units of S4's [`Table`]. `mean` is the speed error's: the `nis` objects' `mean` is
/// dimensionless, like every σ figure.
const UNITS: [(&str, &str); 15] = [
    ("duration", "s"),
    ("lag", "s"),
    ("raw_average_speed_range", "m/s"),
    ("paper_fused_ukf_speed_range", "m/s"),
    ("mean_abs_error", "m/s"),
    ("mean_error", "m/s"),
    ("max_abs_error", "m/s"),
    ("error_range", "m/s"),
    ("speed_range", "m/s"),
    ("true_range", "m/s"),
    ("mean_abs", "m/s"),
    ("mean", "m/s"),
    ("rms", "m/s"),
    ("position_max_abs_error", "m"),
    ("fmu_vs_in_process_max_abs_difference", "m, m/s or 1 (the largest of the quantities compared)"),
];

/// `comparison` as the table's JSON has it: with each estimator's reduction of the mean
/// speed error from the raw average's, and each detector's false alarms as a fraction of
/// the channel-telegrams, the figures the printed table derives.
fn comparison_figures(comparison: &Comparison) -> anyhow::Result<serde_json::Value> {
    let mut figures = serde_json::to_value(comparison)?;
    let mean_abs_error =
        |figures: &serde_json::Value, estimator: &str| figures[estimator]["speed"]["mean_abs_error"].as_f64();
    let raw = mean_abs_error(&figures, "raw_average").context("the raw average has no mean error")?;
    for estimator in ["raw_average", "paper_fused", "paper_fused_ukf", "ours"] {
        let mean = mean_abs_error(&figures, estimator).with_context(|| format!("{estimator} has no mean error"))?;
        figures[estimator]["mean_abs_error_reduction_from_raw"] = reduction(raw, mean).into();
    }
    for detector in ["paper_detection", "our_detection"] {
        let count = |name: &str| figures[detector][name].as_f64().with_context(|| format!("{detector} has no {name}"));
        let fraction = count("false_alarms")? / count("channel_telegrams")?;
        figures[detector]["false_alarm_fraction"] = fraction.into();
    }
    Ok(figures)
}

/// One case of the table: a motion, a fault model, and the tuning ours runs on it.
struct Case {
    /// The stem of its logs and recording.
    name: &'static str,
    /// The motion's name.
    profile: &'static str,
    motion: Profile,
    tuning: Tuning,
    faults: FaultProfile,
}

/// The cases: the paper's run with the default and then the frequent faults, and without
/// `--quick` the same for the 500 km/h run. Each motion keeps the tuning chosen for it on
/// the default faults: the frequent faults are a rate it was not chosen on.
fn cases(quick: bool) -> Vec<Case> {
    let mut motions = vec![("paper", Profile::paper(), Tuning::paper())];
    if !quick {
        motions.push(("high_speed", Profile::high_speed(), Tuning::jerk_limited()));
    }
    let mut cases = Vec::new();
    for (profile, motion, tuning) in motions {
        for (name, faults) in [(profile, FaultProfile::Default), (frequent_name(profile), FaultProfile::Frequent)] {
            cases.push(Case { name, profile, motion: motion.clone(), tuning, faults });
        }
    }
    cases
}

/// The case name of a motion's run with the frequent faults.
fn frequent_name(profile: &str) -> &'static str {
    match profile {
        "paper" => "paper_frequent",
        _ => "high_speed_frequent",
    }
}

/// Runs S4 through its FMU, prints the tables and writes them as `table.json` in `out/s4`;
/// returns the number of failed runs.
pub fn report(seed: u64, quick: bool, start_values: &StartValues, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    // A misspelt name or a value of the wrong type costs no run.
    fmu.check_start_values(start_values)?;
    let dir = out.join("s4");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    // Checked on the tuning of the first case: every case's takes the same names.
    let fmu_only = Tuning::paper().set_known(start_values).map_err(anyhow::Error::msg)?;
    println!(
        "S4: maglev position and speed from four PRW position channels (head/tail × left/right, a telegram every \
         0.02 s), the default faults of docs/studies/s4.md and, as a case not tuned on, ten times their rates \
         (frequent), seed {seed}; ours from {} driven through the fmi importer, logs and recordings in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    if let Some(line) = start_values.header(&fmu_only) {
        println!("{line}");
    }
    let mut failures = 0;
    let mut profiles = Vec::new();
    // The smoothing lag in telegrams (the same interval in every case).
    let mut lag_telegrams = 0;
    for case in cases(quick) {
        let Case { name: case_name, profile: profile_name, motion: profile, faults, .. } = &case;
        let mut tuning = case.tuning;
        tuning.set_known(start_values).map_err(anyhow::Error::msg)?;
        let recording = simulate(profile, &faults.faults(), seed);
        let tuned_on = *faults == FaultProfile::Default;
        print!("{case_name}: {:.1} s, {} telegrams", profile.duration(), recording.n_telegrams());
        if tuned_on {
            println!();
        } else {
            println!(
                "; faults {faults}: the default's four rates ×{} — a case unlike the tuning's (chosen on the default \
                 faults), not the paper's",
                Faults::FREQUENT_FACTOR
            );
        }
        let stem = dir.join(case_name);
        let mut logs = Vec::new();
        let mut line = format!("{:<22}", "vs library (largest |Δ|)");
        let mut table = None;
        let mut filters = Vec::new();
        // The entry of `filters` of each log, in the order of `logs`.
        let mut logged = Vec::new();
        for kind in FilterKind::ALL {
            let log = log_path(&stem, kind);
            let checked = fmu_run::run(&fmu, kind, &recording, &tuning, case_name, start_values, &log).and_then(|_| {
                let run = read_log(&log)?;
                let through_fmu = rows_of(run.channel(ESTIMATE)?, COMPARED)?;
                let library = ours::run(&recording, &Settings::new(kind, tuning)).map_err(anyhow::Error::msg)?;
                // The same quantities, in the order of `COMPARED`.
                let in_process: Vec<[f64; 10]> = library
                    .estimates
                    .iter()
                    .map(|e| {
                        let [o, w] = [e.offsets, e.weights];
                        [e.position, e.speed, o[0], o[1], o[2], o[3], w[0], w[1], w[2], w[3]]
                    })
                    .collect();
                let difference = largest_difference(&through_fmu, &in_process)?;
                if kind == FilterKind::SrCkf {
                    let speed: Vec<f64> = through_fmu[1..].iter().map(|r| r[1]).collect();
                    let position: Vec<f64> = through_fmu[1..].iter().map(|r| r[0]).collect();
                    table = Some(compare_with(&recording, &library, &speed, &position).map_err(anyhow::Error::msg)?);
                }
                logs.push(run);
                Ok(difference)
            });
            match checked {
                Ok(difference) => {
                    line.push_str(&format!(" {}: {difference:.1e}", kind.name()));
                    logged.push(filters.len());
                    filters.push(FilterCheck {
                        filter: kind.name(),
                        failure: None,
                        fmu_vs_in_process_max_abs_difference: Some(difference),
                        speed: None,
                        position: None,
                        nis: None,
                        smoothed: None,
                    });
                }
                Err(e) => {
                    failures += 1;
                    println!("{kind}: FAILED: {e:#}");
                    filters.push(FilterCheck {
                        filter: kind.name(),
                        failure: Some(format!("{e:#}")),
                        fmu_vs_in_process_max_abs_difference: None,
                        speed: None,
                        position: None,
                        nis: None,
                        smoothed: None,
                    });
                }
            }
        }
        line.push_str(&fmu_only_note(&fmu_only));
        // The raw average and the paper's pipeline, logged beside ours for the recording.
        let ours_log = logs.iter().find(|run| run.metadata.get("filter").map(String::as_str) == Some("SRCKF"));
        let baselines = match ours_log.map(|ours| baselines::write(&recording, ours, &stem)) {
            Some(Ok(baselines)) => baselines,
            Some(Err(e)) => {
                failures += 1;
                println!("FAILED to log the baselines: {e:#}");
                Vec::new()
            }
            None => Vec::new(),
        };
        let compared = compare_case(&logs, &baselines, &Options::default(), &stem, Some(FilterKind::SrCkf));
        if let Ok(Compared { comparison, .. }) = &compared {
            for (report, &i) in comparison.runs.iter().zip(&logged) {
                filters[i].speed = SignalSigma::of(report, "speed");
                filters[i].position = SignalSigma::of(report, "position");
                filters[i].nis = report.nis.clone();
            }
        }
        let figures = table.as_ref().map(comparison_figures).transpose()?;
        let raw = figures.as_ref().and_then(|f| f["raw_average"]["speed"]["mean_abs_error"].as_f64());
        // From telegram 1 on, as ours (halfway to it: a log's times are to the nanosecond).
        let from = 0.5 * (recording.time(0) + recording.time(1));
        for (run, &i) in logs.iter().zip(&logged) {
            match SmoothedScores::of(run, from) {
                Ok(mut smoothed) => {
                    smoothed.mean_abs_error_reduction_from_raw =
                        raw.map(|raw| reduction(raw, smoothed.speed.mean_abs_error));
                    filters[i].smoothed = Some(smoothed);
                }
                Err(e) => {
                    failures += 1;
                    println!("{}: FAILED to score the smoothed estimates: {e:#}", filters[i].filter);
                }
            }
        }
        lag_telegrams = (SMOOTHING_LAG / recording.telegram_interval).round() as usize;
        let sigma_lines: Vec<String> = filters
            .iter()
            .filter(|f| f.failure.is_none())
            .map(|f| {
                let nis = f.nis.as_ref().and_then(|n| n.ratio.zip(n.reading));
                format!(
                    "  {:<8} speed {:<30} position {:<30} NIS/rows {:<16} smoothed speed {}",
                    f.filter,
                    SignalSigma::text(f.speed.as_ref()),
                    SignalSigma::text(f.position.as_ref()),
                    nis.map_or("—".into(), |(ratio, reading)| read(ratio, reading)),
                    SignalSigma::text(f.smoothed.as_ref().map(|s| &s.speed_sigma))
                )
            })
            .collect();
        let ours = filters.iter().find(|f| f.filter == FilterKind::SrCkf.name());
        let smoothed_row = ours.and_then(|f| f.smoothed.as_ref()).map(|s| s.row(raw));
        profiles.push(ProfileFigures {
            case: case_name,
            profile: profile_name,
            faults: faults.name(),
            tuned_on,
            duration: profile.duration(),
            telegrams: recording.n_telegrams(),
            filters,
            compared_filter: FilterKind::SrCkf.name(),
            comparison: figures,
        });
        let mut text = String::new();
        if let Some(c) = &table {
            text.push_str(if fmu_only.is_empty() {
                "ours: the SRCKF through the FMU; its detections and offsets are the same filter's in-process, \
                 which the FMU equals (vs library)\n"
            } else {
                "ours: the SRCKF through the FMU; its detections and offsets are the same filter's in-process, \
                 without the start values it does not take (vs library)\n"
            });
            print_comparison(&mut text, seed, *faults, c);
            if let Some(row) = &smoothed_row {
                insert_after_row(&mut text, "ours", row);
            }
        }
        print!("{text}");
        println!("{line}");
        if compared.is_ok() {
            println!(
                "σ of each filter (analyzer): 1σ/2σ coverage (0.683/0.955 if honest) and (e/σ)² mean (1) with its \
                 reading; Σ NIS / Σ rows used (1)"
            );
            for sigma_line in &sigma_lines {
                println!("{sigma_line}");
            }
        }
        match compared {
            Ok(Compared { recording, shown, .. }) => println!(
                "comparison recording ({}: every filter, or the default one standing for those within its σ, then \
                 the baselines): {}",
                shown.join(", "),
                recording.display()
            ),
            Err(e) => {
                failures += 1;
                println!("FAILED to compare the filters: {e}");
            }
        }
    }
    println!(
        "smoothed: the FMU's fixed-lag estimates (smoothing_lag = {SMOOTHING_LAG} s, {lag_telegrams} telegrams: the \
         estimate of that much before the newest telegram, given the telegrams up to it; logged on /smoothed), scored \
         as ours against the truth at the telegram each describes, over telegrams 1 … n − {}, the last {SMOOTHING_LAG} \
         s having none yet: `ours smoothed` (the SRCKF's) in each speed table, and each filter's smoothed speed σ \
         (1σ/2σ coverage, (e/σ)²)",
        lag_telegrams + 1
    );
    write_table(
        &dir,
        &Table {
            study: "S4",
            seed,
            settings: TableSettings {
                seed,
                quick,
                start_values: start_values.iter().map(|(n, v)| (n.to_string(), v)).collect(),
                start_values_fmu_only: fmu_only,
            },
            units: units(&UNITS),
            paper: PaperFigures {
                mean_abs_error_reduction_from_raw: PAPER_MEAN_REDUCTION,
                raw_average_speed_range: PAPER_RANGE.0,
                paper_fused_ukf_speed_range: PAPER_RANGE.1,
            },
            profiles,
        },
    )?;
    Ok(failures)
}

/// What the `vs library` line says of start values the in-process filter does not take:
/// nothing without any.
fn fmu_only_note(fmu_only: &[String]) -> String {
    if fmu_only.is_empty() {
        return String::new();
    }
    format!(" (start values in the FMU only, not in-process: {}; a difference is theirs)", fmu_only.join(", "))
}
