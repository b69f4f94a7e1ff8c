//! The study's baselines as logs beside ours: the raw average, the paper's fused speed
//! and the paper's pipeline with its UKF ([`super::paper`]), each written as a run of the
//! case, so that the comparison recording sets them beside the FMU's estimates and the
//! analyzer scores them the same way.
//!
//! A baseline's log has our run's `/truth` (bit for bit, as the analyzer requires of runs
//! it compares) and, on `/estimate`, its speed and position stamped with the telegram each
//! is known at (`a + 1` for speed sample `a`): a baseline has no estimate at telegram 0,
//! before two positions give a speed. Its position is the mean of the four channel
//! positions; only the UKF has a σ (of the speed: the square root of its variance). Where
//! the fusion had no channel (every reading missing or rejected) the fused speed holds its
//! last value, as a display would; the log's metadata counts those telegrams
//! (`held_telegrams`). The metadata's `pipeline` says what each computes.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context;
use log_format::read::{read_log, Channel, Run, Signal};
use log_format::write::{write_channels, SignalSpec, ESTIMATE, TRUTH};

use super::paper::{run_paper, PaperRun, PaperSettings};
use crate::comparison::{case_log_path, PIPELINE};
use analyzer::compare::CASE_KEYS;
use truth::s4::recording::Recording;

/// A baseline: the end of its log's name ([`case_log_path`]), its label (the log's
/// `filter`), what it is, and its estimates from the paper's run.
struct Baseline {
    suffix: &'static str,
    label: &'static str,
    description: &'static str,
    series: fn(&PaperRun) -> Series,
}

/// A baseline's estimates, one per speed sample `a` (known at telegram `a + 1`).
struct Series {
    speed: Vec<f64>,
    /// The σ of the speed, where the baseline has one.
    speed_std: Option<Vec<f64>>,
    /// Samples whose value is the last one held (the fusion had no channel).
    held: usize,
}

/// The baselines, in the order the study's table lists them.
const BASELINES: [Baseline; 3] = [
    Baseline {
        suffix: "raw_average",
        label: "raw average",
        description: "the plain mean of the four channels' differenced speeds (the paper's measured speed) and of \
                      their positions",
        series: |paper| Series { speed: paper.raw_average.clone(), speed_std: None, held: 0 },
    },
    Baseline {
        suffix: "paper_fused",
        label: "paper fused",
        description: "the paper's Grubbs test and adaptive weighted fusion of the four speeds, eq. (19); position: \
                      the raw average's (the paper estimates none)",
        series: |paper| {
            let (speed, held) = held_through_gaps(&paper.fused);
            Series { speed, speed_std: None, held }
        },
    },
    Baseline {
        suffix: "paper_ukf",
        label: "paper UKF",
        description: "the paper's UKF (a random walk of the speed, Q = 0.01, R = 0.1) on its fused speed; position: \
                      the raw average's",
        series: |paper| Series {
            speed: paper.filtered.clone(),
            speed_std: Some(paper.filtered_variance.iter().map(|v| v.sqrt()).collect()),
            held: 0,
        },
    },
];

/// Writes the baselines of `recording` beside `ours` (a log of an FMU run of the same
/// recording, whose truth they share) as `<stem>_<suffix>.mcap`, and returns them read
/// back, in [`BASELINES`]' order.
pub fn write(recording: &Recording, ours: &Run, stem: &Path) -> anyhow::Result<Vec<Run>> {
    let paper = run_paper(recording, &PaperSettings::default()).context("the paper's pipeline")?;
    let truth = ours.channel(TRUTH)?;
    anyhow::ensure!(
        truth.time.len() == paper.len() + 1,
        "{} has {} truth samples for {} telegrams",
        ours.file.display(),
        truth.time.len(),
        paper.len() + 1
    );
    let mut runs = Vec::new();
    for baseline in &BASELINES {
        let series = (baseline.series)(&paper);
        let mut metadata: BTreeMap<String, String> = ours
            .metadata
            .iter()
            .filter(|(k, _)| CASE_KEYS.contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        metadata.insert("filter".into(), baseline.label.into());
        metadata.insert(PIPELINE.into(), baseline.description.into());
        metadata.insert("held_telegrams".into(), series.held.to_string());
        metadata.insert("software".into(), format!("kalfmu {}", env!("CARGO_PKG_VERSION")));
        let mut signals = vec![
            SignalSpec::new("speed", "m/s", "the baseline's speed (the log's pipeline says how it is computed)"),
            SignalSpec::new("position", "m", "the mean of the four channel positions"),
        ];
        let mut columns = vec![series.speed, paper.position.clone()];
        if let Some(std) = series.speed_std {
            signals.push(SignalSpec::new("speed_std", "m/s", "the UKF's standard deviation of its speed"));
            columns.push(std);
        }
        // Speed sample `a` is known at telegram `a + 1`; a baseline's estimates start at its
        // first finite speed.
        let first = columns[0].iter().position(|v| v.is_finite()).unwrap_or(columns[0].len());
        let estimate = Channel {
            topic: ESTIMATE.into(),
            time: truth.time[first + 1..].to_vec(),
            signals: signals
                .into_iter()
                .zip(columns)
                .map(|(spec, values)| Signal { spec, values: values[first..].to_vec() })
                .collect(),
        };
        let path = case_log_path(stem, baseline.suffix);
        write_channels(&path, &metadata, &[truth, &estimate])?;
        runs.push(read_log(&path)?);
    }
    Ok(runs)
}

/// `values` with each non-finite value after the first finite one replaced by the last
/// finite one, and how many were.
fn held_through_gaps(values: &[f64]) -> (Vec<f64>, usize) {
    let mut last = f64::NAN;
    let mut held = 0;
    let out = values
        .iter()
        .map(|&v| {
            if v.is_finite() {
                last = v;
            } else if last.is_finite() {
                held += 1;
            }
            last
        })
        .collect();
    (out, held)
}
