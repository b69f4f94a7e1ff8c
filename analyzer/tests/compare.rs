//! Runs of one case are compared in one table (best marked) and one JSON document; runs
//! that do not share their truth are refused, saying why.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use analyzer::compare::{compare_runs, Column, Goal, COLUMNS};
use analyzer::report::Options;
use log_format::read::{read_log, Run};
use log_format::write::{LogWriter, SignalSpec, ESTIMATE, TRUTH};
use log_format::LogError;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-analyzer-compare-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// 1000 samples at 100 Hz of `case` with `seed` (the truth's phase), estimated by `filter`
/// with an error of amplitude `error`.
fn write_run(path: &Path, case: &str, seed: u32, filter: Option<&str>, error: f64) {
    let mut metadata = BTreeMap::from([("case".to_string(), case.to_string()), ("seed".to_string(), seed.to_string())]);
    if let Some(filter) = filter {
        metadata.insert("filter".into(), filter.into());
    }
    let mut w = LogWriter::create(path, &metadata).unwrap();
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "load"), SignalSpec::new("G", "N", "other")]).unwrap();
    let e = w.add_channel(ESTIMATE, &[SignalSpec::new("F", "N", "load"), SignalSpec::new("G", "N", "other")]).unwrap();
    for k in 0..1000 {
        let time = k as f64 * 0.01;
        let truth = (time + f64::from(seed)).sin();
        let wobble = ((k * 7919 % 13) as f64 - 6.0) / 6.0;
        w.write(t, time, &[truth, 2.0 * truth]).unwrap();
        // The more wrong a filter on F, the less on G: each is best at one signal.
        w.write(e, time, &[truth + error * wobble, 2.0 * truth + (0.3 - error) * wobble]).unwrap();
    }
    w.finish().unwrap();
}

fn runs(specs: &[(&str, &str, u32, Option<&str>, f64)]) -> Vec<Run> {
    specs
        .iter()
        .map(|(name, case, seed, filter, error)| {
            let path = temp(&format!("{name}.mcap"));
            write_run(&path, case, *seed, *filter, *error);
            read_log(&path).unwrap()
        })
        .collect()
}

#[test]
fn the_table_has_a_row_per_run_and_marks_the_best_of_each_metric() {
    let runs = runs(&[
        ("ckf", "harmonic", 1, Some("CKF"), 0.05),
        ("ukf", "harmonic", 1, Some("UKF"), 0.2),
        ("ekf", "harmonic", 1, Some("EKF"), 0.1),
    ]);
    let comparison = compare_runs(&runs, &Options::default()).unwrap();
    assert_eq!(comparison.labels, ["CKF", "UKF", "EKF"]);
    // F: CKF is best; G: UKF is (its error on G is the smallest).
    assert_eq!(comparison.best[0]["signal"], "F");
    assert_eq!(comparison.best[0]["rmse"], "CKF");
    assert_eq!(comparison.best[1]["rmse"], "UKF");
    let table = comparison.table();
    let row = |label: &str, signal: usize| {
        table
            .split("\nF [N]")
            .nth(1)
            .unwrap()
            .split("\nG [N]")
            .nth(signal)
            .unwrap()
            .lines()
            .find(|l| l.starts_with(label))
            .unwrap()
            .to_string()
    };
    let rmse_of = |row: &str| row.split_whitespace().nth(2).unwrap().to_string();
    assert!(rmse_of(&row("CKF", 0)).ends_with('*'), "{table}");
    assert!(!rmse_of(&row("UKF", 0)).ends_with('*'), "{table}");
    assert!(rmse_of(&row("UKF", 1)).ends_with('*'), "{table}");
    assert!(table.contains("* best of the runs"), "{table}");
    // The JSON: labels, each run's report, the best runs.
    let json = temp("comparison.json");
    comparison.write_json(&json).unwrap();
    let value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(value["labels"][2], "EKF");
    assert_eq!(value["runs"].as_array().unwrap().len(), 3);
    assert_eq!(value["runs"][1]["metadata"]["filter"], "UKF");
    assert_eq!(value["best"][1]["rmse"], "UKF");
}

#[test]
fn runs_that_do_not_share_their_truth_are_refused_saying_why() {
    let other_seed = runs(&[("a", "harmonic", 1, Some("CKF"), 0.05), ("b", "harmonic", 2, Some("UKF"), 0.05)]);
    let err = compare_runs(&other_seed, &Options::default()).unwrap_err();
    assert!(matches!(err, LogError::NotComparable { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("b.mcap and ") && text.contains("a.mcap do not share their truth"), "{text}");
    assert!(text.contains("truth F differs at sample 0") && text.contains("(seed 1 vs 2)"), "{text}");
    let other_case = runs(&[("c", "harmonic", 1, Some("CKF"), 0.05), ("d", "random", 1, Some("UKF"), 0.05)]);
    // The same truth under another case name is still the same truth: comparable.
    assert!(compare_runs(&other_case, &Options::default()).is_ok());
}

#[test]
fn runs_without_distinct_filters_are_named_by_their_files() {
    let runs = runs(&[("first", "h", 1, None, 0.05), ("second", "h", 1, Some("CKF"), 0.1)]);
    assert_eq!(compare_runs(&runs, &Options::default()).unwrap().labels, ["first", "second"]);
}

#[test]
fn the_words_every_file_begins_with_are_left_out_of_the_names() {
    let named = |files: &[&str]| {
        let specs: Vec<_> = files.iter().map(|f| (*f, "h", 1, None, 0.05)).collect();
        compare_runs(&runs(&specs), &Options::default()).unwrap().labels
    };
    let case = named(&["joint_paper_accelerations", "joint_ours_accelerations", "joint_ours_deflections"]);
    assert_eq!(case, ["paper_accelerations", "ours_accelerations", "ours_deflections"]);
    // Only whole words, and never a whole name.
    assert_eq!(named(&["weld_a1", "weld_a2"]), ["a1", "a2"]);
    assert_eq!(named(&["run", "run_2"]), ["run", "run_2"]);
    assert_eq!(named(&["s2-fast", "s2-slow"]), ["fast", "slow"]);
}

#[test]
fn the_best_follows_each_metrics_goal() {
    let coverage = COLUMNS.iter().find(|c| c.key == "two_sigma_coverage").unwrap();
    assert_eq!(coverage.goal, Goal::Nearest(0.9545));
    let correlation: &Column = &COLUMNS[0];
    assert_eq!((correlation.key, correlation.goal), ("correlation", Goal::Highest));
    assert!(COLUMNS.iter().filter(|c| c.goal == Goal::Lowest).count() >= 5);
}

#[test]
fn the_compare_command_prints_one_table_and_writes_one_recording() {
    let logs: Vec<PathBuf> = ["cli_ckf", "cli_ukf"]
        .iter()
        .zip([("CKF", 0.05), ("UKF", 0.1)])
        .map(|(name, (filter, error))| {
            let path = temp(&format!("{name}.mcap"));
            write_run(&path, "h", 1, Some(filter), error);
            path
        })
        .collect();
    let rrd = temp("cli.rrd");
    let out = Command::new(env!("CARGO_BIN_EXE_analyzer"))
        .arg("compare")
        .args(&logs)
        .arg("--rrd")
        .arg(&rrd)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("CKF: ") && stdout.contains("UKF: ") && stdout.contains("F [N]: 1000 samples"), "{stdout}");
    assert!(std::fs::metadata(&rrd).unwrap().len() > 0);
    let other = temp("cli_other.mcap");
    write_run(&other, "h", 3, Some("EKF"), 0.05);
    let out = Command::new(env!("CARGO_BIN_EXE_analyzer")).arg("compare").arg(&logs[0]).arg(&other).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("do not share their truth"));
}
