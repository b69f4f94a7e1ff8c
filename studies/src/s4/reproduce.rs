//! S4 in `kalfmu reproduce`: on the paper's test run (and, without `--quick`, the
//! 500 km/h run), with the default faults, every filter kind through the packaged FMU,
//! checked against the same filter in-process; then the study's table (`s4-compare`'s)
//! with ours read from the FMU's outputs (SRCKF, the FMU's default), beside the raw
//! average and the paper's pipeline (in-process: the paper's method, not our FMU); one
//! log per run and one comparison recording per profile (`out/s4/`), and the figures as
//! `table.json` there ([`Table`]).

use std::collections::BTreeMap;
use std::path::Path;

use analyzer::report::Options;
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::read_log;
use log_format::write::ESTIMATE;
use serde::Serialize;

use super::compare::{compare_with, print_comparison, Comparison, PAPER_MEAN_REDUCTION, PAPER_RANGE};
use super::fmu_run::{self, COMPARED, IDENTIFIER};
use super::metrics::reduction;
use super::ours::{self, Settings, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of, units, write_table};
use cosim::fmu_driver::ImportedFmu;
use truth::s4::channels::simulate;
use truth::s4::faults::Faults;
use truth::s4::profile::Profile;

/// The figures of S4's tables, as `table.json` has them.
#[derive(Serialize)]
pub struct Table {
    /// `"S4"`.
    pub study: &'static str,
    /// Seed of the noise and the faults.
    pub seed: u64,
    /// The unit of each dimensional field (see [`units`]).
    pub units: BTreeMap<&'static str, &'static str>,
    /// The paper's figures (§3.2), of its test run.
    pub paper: PaperFigures,
    /// One entry per profile run: `paper`, and without `--quick` `high_speed`.
    pub profiles: Vec<ProfileFigures>,
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

/// One profile's run.
#[derive(Serialize)]
pub struct ProfileFigures {
    /// `paper` or `high_speed`.
    pub profile: &'static str,
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
}

/// The units of S4's [`Table`].
const UNITS: [(&str, &str); 14] = [
    ("duration", "s"),
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

/// Runs S4 through its FMU, prints the tables and writes them as `table.json` in `out/s4`;
/// returns the number of failed runs.
pub fn report(seed: u64, quick: bool, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    let dir = out.join("s4");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    println!(
        "S4: maglev position and speed from four PRW position channels (head/tail × left/right, a telegram every \
         0.02 s), the default faults of docs/studies/s4.md, seed {seed}; ours from {} driven through the fmi importer, \
         logs and recordings in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    let mut cases = vec![("paper", Profile::paper(), Tuning::paper())];
    if !quick {
        cases.push(("high_speed", Profile::high_speed(), Tuning::jerk_limited()));
    }
    let mut failures = 0;
    let mut profiles = Vec::new();
    for (case, profile, tuning) in cases {
        let recording = simulate(&profile, &Faults::default(), seed);
        println!("{case}: {:.1} s, {} telegrams", profile.duration(), recording.n_telegrams());
        let stem = dir.join(case);
        let mut logs = Vec::new();
        let mut line = format!("{:<22}", "vs library (largest |Δ|)");
        let mut table = None;
        let mut filters = Vec::new();
        for kind in FilterKind::ALL {
            let log = log_path(&stem, kind);
            let checked = fmu_run::run(&fmu, kind, &recording, &tuning, case, &log).and_then(|_| {
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
                    filters.push(FilterCheck {
                        filter: kind.name(),
                        failure: None,
                        fmu_vs_in_process_max_abs_difference: Some(difference),
                    });
                }
                Err(e) => {
                    failures += 1;
                    println!("{kind}: FAILED: {e:#}");
                    filters.push(FilterCheck {
                        filter: kind.name(),
                        failure: Some(format!("{e:#}")),
                        fmu_vs_in_process_max_abs_difference: None,
                    });
                }
            }
        }
        profiles.push(ProfileFigures {
            profile: case,
            duration: profile.duration(),
            telegrams: recording.n_telegrams(),
            filters,
            compared_filter: FilterKind::SrCkf.name(),
            comparison: table.as_ref().map(comparison_figures).transpose()?,
        });
        let mut text = String::new();
        if let Some(c) = &table {
            text.push_str(
                "ours: the SRCKF through the FMU; its detections and offsets are the same filter's in-process, \
                 which the FMU equals (vs library)\n",
            );
            print_comparison(&mut text, seed, c);
        }
        print!("{text}");
        println!("{line}");
        match compare_case(&logs, &Options::default(), &stem) {
            Ok((_, recording)) => println!("comparison recording, every filter in one: {}", recording.display()),
            Err(e) => {
                failures += 1;
                println!("FAILED to compare the filters: {e}");
            }
        }
    }
    write_table(
        &dir,
        &Table {
            study: "S4",
            seed,
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
