//! What every study's part of `reproduce` shares: a case's runs compared and recorded, an
//! FMU's outputs set against the same filter in-process, where the logs go, and the table's
//! figures written as JSON.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analyzer::compare::{compare_runs, Comparison};
use analyzer::report::Options;
use analyzer::rrd::write_rrd;
use analyzer::views::{align, views};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::{Channel, Run};
use log_format::write::{ESTIMATE, SMOOTHED};

/// The metadata key of a baseline's log that says what it computes.
pub const PIPELINE: &str = "pipeline";

/// One case's runs compared, and what its recording shows.
pub struct Compared<'a> {
    /// Every run of the case (not the baselines), compared: the figures the study prints.
    pub comparison: Comparison<'a>,
    /// The Rerun recording, `<stem>.rrd`.
    pub recording: PathBuf,
    /// The labels of the runs the recording shows, in its order.
    pub shown: Vec<String>,
}

/// One case's runs compared: the comparison, written as `<stem>.json` and as the Rerun
/// recording `<stem>.rrd`.
///
/// - Given a `default` (the FMU's default filter, where the runs are filter kinds), where
///   every run agrees with the run of `default` within that run's σ at every sample, the
///   recording holds that run alone, with its smoothed estimates (`/smoothed`) as a second
///   run where it has them, its report naming the others and how far they are (in σ): five
///   overlaid lines identical to four digits show nothing a reviewer can use.
/// - `baselines` are the runs the study compares ours with (S4's raw average and the paper's
///   pipeline), logs of the same truth made outside the FMU; they follow the case's runs in
///   the recording (whose measurements view is the first run's), and every shown run is cut
///   to the signals and the span all have.
///
/// The JSON and the returned comparison keep every run of `runs`, and only those.
pub fn compare_case<'a>(
    runs: &'a [Run],
    baselines: &[Run],
    options: &Options,
    stem: &Path,
    default: Option<FilterKind>,
) -> Result<Compared<'a>, log_format::LogError> {
    let comparison = compare_runs(runs, options)?;
    let recording = stem.with_extension("rrd");
    comparison.write_json(&stem.with_extension("json"))?;
    let mut notes = Vec::new();
    let mut shown: Vec<Run> = Vec::new();
    match default.and_then(|default| stand_in(&comparison, default).map(|found| (default, found))) {
        Some((default, (index, note))) => {
            // The default's run, and its smoothed estimates beside it where the FMU smoothed.
            let alone = &runs[index..=index];
            let topics: Vec<String> = [ESTIMATE, SMOOTHED]
                .into_iter()
                .filter(|topic| alone[0].channel(topic).is_ok())
                .map(String::from)
                .collect();
            shown.extend(views(alone, &topics)?);
            notes.push(note);
            if topics.len() > 1 {
                notes.push(format!(
                    "**Smoothed beside it.** The {default}'s fixed-lag smoothed estimates (the FMU's `smoothing_lag`) \
                     are the second run, on the signals the FMU smooths and the span they cover."
                ));
            }
        }
        None if baselines.is_empty() => {
            write_rrd(&comparison, runs, &recording)?;
            let shown = comparison.labels.clone();
            return Ok(Compared { comparison, recording, shown });
        }
        None => shown.extend(runs.iter().cloned()),
    }
    if !baselines.is_empty() {
        shown.extend(baselines.iter().cloned());
        align(&mut shown);
        let described: Vec<String> = baselines
            .iter()
            .map(|b| {
                let label = b.metadata.get("filter").map_or("a baseline", String::as_str);
                match b.metadata.get(PIPELINE) {
                    Some(what) => format!("*{label}*: {what}"),
                    None => format!("*{label}*"),
                }
            })
            .collect();
        notes.push(format!(
            "**Baselines.** What the study compares ours with, computed outside the FMU from the same measurements \
             (their logs are beside this recording's): {}. Every run is shown on the signals and over the span all of \
             them have.",
            described.join("; ")
        ));
    }
    let mut figures = compare_runs(&shown, options)?;
    figures.notes = notes;
    write_rrd(&figures, &shown, &recording)?;
    let shown = figures.labels;
    Ok(Compared { comparison, recording, shown })
}

/// The run of `default` and the note that it stands for the others, if there are others
/// and each one's estimates are within the `default` run's σ of its own at every compared
/// sample, for every signal (each signal must have a σ).
fn stand_in(comparison: &Comparison, default: FilterKind) -> Option<(usize, String)> {
    let runs = &comparison.runs;
    let index = runs.iter().position(|r| r.metadata.get("filter").map(String::as_str) == Some(default.name()))?;
    if runs.len() < 2 {
        return None;
    }
    let mut distances = Vec::new();
    for (i, run) in runs.iter().enumerate().filter(|(i, _)| *i != index) {
        let mut largest = 0.0_f64;
        for (own, other) in runs[index].pairs.iter().zip(&run.pairs) {
            let sigma = own.sigma.as_ref()?;
            if own.estimate_values.len() != other.estimate_values.len() {
                return None;
            }
            for ((a, b), s) in own.estimate_values.iter().zip(other.estimate_values.iter()).zip(sigma.iter()) {
                let distance = (a - b).abs() / s;
                // Missing in both agrees; missing in one, or a σ of 0 or NaN, does not.
                if distance.is_nan() && !(a.is_nan() && b.is_nan()) {
                    return None;
                }
                largest = largest.max(distance);
            }
        }
        if largest > 1.0 {
            return None;
        }
        distances.push(format!("{} {largest:.2}", comparison.labels[i]));
    }
    let note = format!(
        "**One run stands for all.** Every filter kind's estimates are within the {default}'s σ of its own at every \
         sample (largest |difference| / σ: {}), so this recording shows the {default} (the FMU's default) alone; \
         every run's figures are in the comparison's JSON and in the printed table.",
        distances.join(", ")
    );
    Some((index, note))
}

/// The signals `names` of `channel`, one row per sample.
pub fn rows_of<const N: usize>(channel: &Channel, names: [&str; N]) -> anyhow::Result<Vec<[f64; N]>> {
    let columns: Vec<&[f64]> = names
        .iter()
        .map(|n| {
            channel.signal(n).map(|s| s.values.as_slice()).with_context(|| format!("{} has no {n}", channel.topic))
        })
        .collect::<anyhow::Result<_>>()?;
    Ok((0..channel.time.len()).map(|k| std::array::from_fn(|i| columns[i][k])).collect())
}

/// The largest difference between two runs' rows, entry by entry: how far an FMU's
/// outputs are from the same filter in-process. An error if their lengths differ.
pub fn largest_difference<const N: usize>(a: &[[f64; N]], b: &[[f64; N]]) -> anyhow::Result<f64> {
    anyhow::ensure!(a.len() == b.len(), "{} samples against {}", a.len(), b.len());
    Ok(a.iter().zip(b).flat_map(|(x, y)| x.iter().zip(y).map(|(u, v)| (u - v).abs())).fold(0.0, f64::max))
}

/// The log of one filter's run of a case: `<stem>_<filter>.mcap`, e.g. `weld_srckf.mcap`.
pub fn log_path(stem: &Path, kind: estimator::FilterKind) -> PathBuf {
    case_log_path(stem, &kind.name().to_lowercase().replace('-', ""))
}

/// A log of the case `stem` beside its filters' logs: `<stem>_<suffix>.mcap`.
pub fn case_log_path(stem: &Path, suffix: &str) -> PathBuf {
    let case = stem.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    stem.with_file_name(format!("{case}_{suffix}.mcap"))
}

/// The name of the file in each study's output directory that holds the figures of the
/// table `reproduce` prints (`out/s1/table.json`, …; see the `kalfmu reproduce` docs).
pub const TABLE_FILE: &str = "table.json";

/// Writes a study's table, `table`, as pretty-printed JSON to [`TABLE_FILE`] in `dir`;
/// returns the file's path. A figure that is not a number (NaN, ±∞) is written `null`.
pub fn write_table(dir: &Path, table: &impl serde::Serialize) -> anyhow::Result<PathBuf> {
    let path = dir.join(TABLE_FILE);
    let mut text = serde_json::to_string_pretty(table).context("cannot serialise the table")?;
    text.push('\n');
    std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

/// The `units` object of a table: each dimensional field's name and its unit. Fields it
/// does not list are dimensionless (correlations, fractions) or counts.
pub fn units(pairs: &[(&'static str, &'static str)]) -> BTreeMap<&'static str, &'static str> {
    pairs.iter().copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use log_format::read::Signal;
    use log_format::write::{SignalSpec, TRUTH};

    /// A run of `filter` whose estimate of `F` is the truth plus `offset`, σ 0.1.
    fn run(filter: &str, offset: f64) -> Run {
        let time: Vec<f64> = (0..50).map(|k| k as f64 * 0.01).collect();
        let truth: Vec<f64> = time.iter().map(|t| (3.0 * t).sin()).collect();
        let signal = |name: &str, values: Vec<f64>| Signal { spec: SignalSpec::new(name, "N", ""), values };
        let channel = |topic: &str, signals: Vec<Signal>| Channel { topic: topic.into(), time: time.clone(), signals };
        Run {
            file: format!("{filter}.mcap").into(),
            metadata: BTreeMap::from([("filter".to_string(), filter.to_string())]),
            channels: vec![
                channel(TRUTH, vec![signal("F", truth.clone())]),
                channel(
                    ESTIMATE,
                    vec![signal("F", truth.iter().map(|v| v + offset).collect()), signal("F_std", vec![0.1; 50])],
                ),
            ],
            skipped: Vec::new(),
            damage: None,
        }
    }

    #[test]
    fn the_default_stands_for_kinds_within_its_sigma_and_not_for_one_beyond() {
        let agreeing = [run("CKF", 0.05), run("SRCKF", 0.0)];
        let comparison = compare_runs(&agreeing, &Options::default()).unwrap();
        let (index, note) = stand_in(&comparison, FilterKind::SrCkf).expect("within σ");
        assert_eq!(index, 1);
        assert!(note.contains("CKF 0.50"), "{note}");
        let apart = [run("CKF", 0.15), run("SRCKF", 0.0)];
        assert!(stand_in(&compare_runs(&apart, &Options::default()).unwrap(), FilterKind::SrCkf).is_none());
        // No run of the default: nothing stands in.
        assert!(stand_in(&comparison, FilterKind::Ukf).is_none());
    }

    #[test]
    fn baselines_follow_the_runs_in_the_recording_but_not_in_the_comparison() {
        let dir = std::env::temp_dir().join(format!("kalfmu-compare-case-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let runs = [run("CKF", 0.05), run("SRCKF", 0.0)];
        // A baseline without σ whose first estimate is ten samples later.
        let mut baseline = run("raw average", 0.3);
        let estimate = baseline.channels.iter_mut().find(|c| c.topic == ESTIMATE).unwrap();
        estimate.signals.retain(|s| s.spec.name == "F");
        estimate.time.drain(..10);
        estimate.signals[0].values.drain(..10);
        baseline.metadata.insert(PIPELINE.into(), "the plain mean".into());
        let compared =
            compare_case(&runs, &[baseline], &Options::default(), &dir.join("case"), Some(FilterKind::SrCkf)).unwrap();
        assert_eq!(compared.comparison.labels, ["CKF", "SRCKF"], "the figures are the runs'");
        assert_eq!(compared.shown, ["SRCKF", "raw average"], "the default stands in, then the baseline");
        assert!(compared.recording.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_table_is_written_to_table_json_in_its_directory_with_nan_as_null() {
        let dir = std::env::temp_dir().join(format!("kalfmu-write-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let table = serde_json::json!({ "correlation": 0.5, "coverage": f64::NAN });
        let path = write_table(&dir, &table).unwrap();
        assert_eq!(path, dir.join("table.json"));
        let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(written, serde_json::json!({ "correlation": 0.5, "coverage": null }));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
