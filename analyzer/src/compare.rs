//! Runs of one case compared: each run's estimates against the truth they share, in one
//! table across the runs (rows are runs, columns are the metrics, the best value marked),
//! then one table of each run's consistency figures (NEES, NIS: `consistency.rs`), one
//! JSON document, and one Rerun recording (`rrd.rs`).
//!
//! Runs are comparable when they share their truth: the same compared truth signals, at
//! the same times, with the same values bit for bit (the same case and seed), and the same
//! tolerances (`X_tolerance`, see `report.rs`). Runs that do not are refused, naming both
//! files and where their truths part.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use log_format::read::Run;
use log_format::LogError;
use rayon::prelude::*;
use serde::Serialize;

use crate::report::{analyse, Options, PairReport, Report};

/// The metadata keys that say which case a run is.
pub const CASE_KEYS: [&str; 3] = ["study", "case", "seed"];

/// Which value of a metric is best.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Goal {
    /// The highest.
    Highest,
    /// The lowest.
    Lowest,
    /// The nearest to this value.
    Nearest(f64),
}

/// A column of the comparison table: one metric of a compared signal.
#[derive(Debug, Clone, Copy)]
pub struct Column {
    /// Its key in the JSON report.
    pub key: &'static str,
    /// Its heading.
    pub heading: &'static str,
    /// Which value is best.
    pub goal: Goal,
    /// Its value for a pair (`None`: not defined for it).
    pub value: fn(&PairReport) -> Option<f64>,
    /// Its text for a pair.
    pub text: fn(&PairReport) -> String,
    /// Shown only for the signals where some run has a value: a metric most logs do not
    /// define would add an empty column to all their tables.
    pub where_defined: bool,
}

/// Four significant digits, in plain notation from 0.001 to 99 999: RMSEs of 1e-4 m and of
/// 100 N both read.
fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let magnitude = v.abs().log10().floor();
    if (-3.0..5.0).contains(&magnitude) {
        format!("{v:.*}", (3.0 - magnitude).max(0.0) as usize)
    } else {
        format!("{v:.3e}")
    }
}

fn band_text(p: &PairReport) -> String {
    p.psd_agreement_band.map_or("—".into(), |(lo, hi)| format!("{lo:.2}–{hi:.2}"))
}

fn normalised_error_text(p: &PairReport) -> String {
    p.normalised_error.map_or("—".into(), |n| format!("{} {}", significant(n.mean_square), n.reading.text()))
}

/// The metrics compared, in table order.
pub const COLUMNS: [Column; 12] = [
    Column {
        key: "correlation",
        heading: "corr",
        goal: Goal::Highest,
        value: |p| Some(p.metrics.correlation),
        text: |p| format!("{:.5}", p.metrics.correlation),
        where_defined: false,
    },
    Column {
        key: "rmse",
        heading: "RMSE",
        goal: Goal::Lowest,
        value: |p| Some(p.metrics.rmse),
        text: |p| significant(p.metrics.rmse),
        where_defined: false,
    },
    Column {
        key: "rmse_converged",
        heading: "RMSE conv",
        goal: Goal::Lowest,
        value: |p| Some(p.metrics.rmse_converged),
        text: |p| significant(p.metrics.rmse_converged),
        where_defined: false,
    },
    Column {
        key: "convergence_time",
        heading: "t_conv (s)",
        goal: Goal::Lowest,
        value: |p| Some(p.metrics.convergence_time),
        text: |p| format!("{:.2}", p.metrics.convergence_time),
        where_defined: false,
    },
    Column {
        key: "running_rmse_peak",
        heading: "run. peak",
        goal: Goal::Lowest,
        value: |p| Some(p.metrics.running_rmse_peak),
        text: |p| significant(p.metrics.running_rmse_peak),
        where_defined: false,
    },
    Column {
        key: "running_rmse_max_converged",
        heading: "run. max conv",
        goal: Goal::Lowest,
        value: |p| Some(p.metrics.running_rmse_max_converged),
        text: |p| significant(p.metrics.running_rmse_max_converged),
        where_defined: false,
    },
    Column {
        key: "one_sigma_coverage",
        heading: "1σ cov",
        // A consistent Gaussian estimate has 68.27 % of its errors within ±σ.
        goal: Goal::Nearest(0.6827),
        value: |p| p.one_sigma_coverage,
        text: |p| p.one_sigma_coverage.map_or("—".into(), |v| format!("{v:.3}")),
        where_defined: true,
    },
    Column {
        key: "two_sigma_coverage",
        heading: "2σ cov",
        // A consistent Gaussian estimate has 95.45 % of its errors within ±2σ.
        goal: Goal::Nearest(0.9545),
        value: |p| p.two_sigma_coverage,
        text: |p| p.two_sigma_coverage.map_or("—".into(), |v| format!("{v:.3}")),
        where_defined: false,
    },
    Column {
        key: "normalised_error",
        heading: "(e/σ)² mean",
        // Scored by its logarithm: a σ twice too wide (0.25) is as far from 1 as one twice
        // too narrow (4).
        goal: Goal::Nearest(0.0),
        value: |p| p.normalised_error.map(|n| n.mean_square.ln()),
        text: normalised_error_text,
        where_defined: true,
    },
    Column {
        key: "in_tolerance",
        heading: "in tolerance",
        goal: Goal::Highest,
        value: |p| p.in_tolerance,
        text: |p| p.in_tolerance.map_or("—".into(), |v| format!("{v:.3}")),
        where_defined: true,
    },
    Column {
        key: "final_relative_error",
        heading: "final rel",
        goal: Goal::Lowest,
        value: |p| p.metrics.final_relative_error,
        text: |p| p.metrics.final_relative_error.map_or("—".into(), |v| format!("{v:.2e}")),
        where_defined: true,
    },
    Column {
        key: "psd_agreement_band",
        heading: "PSD ±3 dB (Hz)",
        // The widest band of agreement.
        goal: Goal::Highest,
        value: |p| p.psd_agreement_band.map(|(lo, hi)| hi - lo),
        text: band_text,
        where_defined: false,
    },
];

/// A column of the consistency table: one figure of a run (its NEES or NIS).
#[derive(Debug, Clone, Copy)]
pub struct RunColumn {
    /// Its key in the JSON report's `best_consistency`.
    pub key: &'static str,
    /// Its heading.
    pub heading: &'static str,
    /// Which value is best (`None`: none is, the column informs).
    pub goal: Option<Goal>,
    /// Its value for a run's report (`None`: not defined for it).
    pub value: fn(&Report) -> Option<f64>,
    /// Its text for a run's report.
    pub text: fn(&Report) -> String,
}

fn or_dash(v: Option<f64>, text: impl Fn(f64) -> String) -> String {
    v.map_or("—".into(), text)
}

/// The consistency figures of a run, in table order.
pub const RUN_COLUMNS: [RunColumn; 7] = [
    RunColumn {
        key: "nees_mean",
        heading: "NEES mean/dof",
        // Scored by its ratio to its expectation, in logarithm (see `normalised_error`).
        goal: Some(Goal::Nearest(0.0)),
        value: |r| r.nees.as_ref().map(|n| (n.mean / n.dof as f64).ln()),
        text: |r| r.nees.as_ref().map_or("—".into(), |n| format!("{}/{}", significant(n.mean), n.dof)),
    },
    RunColumn {
        key: "nees_in_band",
        heading: "NEES in 95 %",
        goal: Some(Goal::Nearest(0.95)),
        value: |r| r.nees.as_ref().map(|n| n.in_band),
        text: |r| or_dash(r.nees.as_ref().map(|n| n.in_band), |v| format!("{v:.3}")),
    },
    RunColumn {
        key: "nis_mean",
        heading: "NIS mean",
        goal: None,
        value: |r| r.nis.as_ref().map(|n| n.mean),
        text: |r| or_dash(r.nis.as_ref().map(|n| n.mean), significant),
    },
    RunColumn {
        key: "nis_rows_used_mean",
        heading: "rows used",
        goal: None,
        value: |r| r.nis.as_ref().and_then(|n| n.rows_used_mean),
        text: |r| match &r.nis {
            None => "—".into(),
            Some(n) => n.rows_used_mean.map_or("unknown".into(), |v| format!("{v:.3}")),
        },
    },
    RunColumn {
        key: "nis_ratio",
        heading: "NIS/rows",
        goal: Some(Goal::Nearest(0.0)),
        value: |r| r.nis.as_ref().and_then(|n| n.ratio).map(f64::ln),
        text: |r| or_dash(r.nis.as_ref().and_then(|n| n.ratio), significant),
    },
    RunColumn {
        key: "nis_in_band",
        heading: "NIS in 95 %",
        goal: Some(Goal::Nearest(0.95)),
        value: |r| r.nis.as_ref().and_then(|n| n.in_band),
        text: |r| or_dash(r.nis.as_ref().and_then(|n| n.in_band), |v| format!("{v:.3}")),
    },
    RunColumn {
        key: "nis_reading",
        heading: "NIS reading",
        goal: None,
        value: |r| r.nis.as_ref().and_then(|n| n.ratio),
        text: |r| r.nis.as_ref().and_then(|n| n.reading).map_or("—".into(), |v| v.text().into()),
    },
];

/// The index of the best of `values` for `goal` (the first of equals); `None` if none is finite.
fn best_of(goal: Goal, values: impl Iterator<Item = Option<f64>>) -> Option<usize> {
    let score = |v: f64| match goal {
        Goal::Highest => -v,
        Goal::Lowest => v,
        Goal::Nearest(target) => (v - target).abs(),
    };
    values
        .enumerate()
        .filter_map(|(i, v)| v.filter(|v| v.is_finite()).map(|v| (i, score(v))))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

impl RunColumn {
    /// The index of the best of these runs; `None` if no value is defined or none is best.
    pub fn best(&self, runs: &[Report]) -> Option<usize> {
        best_of(self.goal?, runs.iter().map(|r| (self.value)(r)))
    }
}

impl Column {
    /// Whether the tables of these pairs (one signal's, one per run) show this column.
    pub fn shown(&self, pairs: &[&PairReport]) -> bool {
        !self.where_defined || pairs.iter().any(|p| (self.value)(p).is_some())
    }

    /// The index of the best of these pairs (the first of equals); `None` if no value is defined.
    pub fn best(&self, pairs: &[&PairReport]) -> Option<usize> {
        best_of(self.goal, pairs.iter().map(|p| (self.value)(p)))
    }
}

/// The runs of one case, analysed and compared.
#[derive(Debug, Serialize)]
pub struct Comparison<'a> {
    /// A short name per run: its filter (metadata `filter`), else its file's stem.
    pub labels: Vec<String>,
    /// Each run's report, in the order the runs were given.
    pub runs: Vec<Report<'a>>,
    /// Per compared signal (in the order of the first run's pairs), the label of the best
    /// run for each metric key; empty with a single run.
    pub best: Vec<BTreeMap<String, String>>,
    /// The label of the best run for each consistency figure that has a best
    /// ([`RUN_COLUMNS`]' keys); empty with a single run.
    pub best_consistency: BTreeMap<String, String>,
    /// What a reader of the report should know beyond the figures (e.g. which runs a
    /// recording leaves out, and why), a paragraph each; empty unless a driver adds some.
    pub notes: Vec<String>,
}

/// Analyses each run (on every core) and compares them; refuses runs that do not share
/// their truth.
pub fn compare_runs<'a>(runs: &'a [Run], options: &Options) -> Result<Comparison<'a>, LogError> {
    let Some(first) = runs.first() else {
        return Err(LogError::Analysis { file: "".into(), what: "no log to compare".into() });
    };
    let reports = runs.par_iter().map(|run| analyse(run, options)).collect::<Result<Vec<_>, _>>()?;
    for (run, report) in runs.iter().zip(&reports).skip(1) {
        check_shared_truth(first, &reports[0], run, report)?;
    }
    let labels = labels(runs);
    let mut best = Vec::new();
    if reports.len() > 1 {
        for k in 0..reports[0].pairs.len() {
            let pairs: Vec<&PairReport> = reports.iter().map(|r| &r.pairs[k]).collect();
            let mut of_signal = BTreeMap::from([("signal".to_string(), pair_name(pairs[0]))]);
            for column in &COLUMNS {
                if let Some(i) = column.best(&pairs) {
                    of_signal.insert(column.key.to_string(), labels[i].clone());
                }
            }
            best.push(of_signal);
        }
    }
    let mut best_consistency = BTreeMap::new();
    if reports.len() > 1 {
        for column in &RUN_COLUMNS {
            if let Some(i) = column.best(&reports) {
                best_consistency.insert(column.key.to_string(), labels[i].clone());
            }
        }
    }
    Ok(Comparison { labels, runs: reports, best, best_consistency, notes: Vec::new() })
}

/// The runs' short names: their filters if every run names a different one, else their
/// files' stems if those differ, less the words all of them begin with (`joint_ours_…`
/// and `joint_paper_…` are `ours_…` and `paper_…`: the shared case says nothing about a
/// run, and widens every column of the report), else `run 1`, `run 2`, …; a run seen
/// through another estimate channel ([`crate::views`]) has the channel's name after it
/// (`SRCKF smoothed`).
fn labels(runs: &[Run]) -> Vec<String> {
    let distinct = |names: &[String]| {
        let mut sorted = names.to_vec();
        sorted.sort();
        sorted.dedup();
        sorted.len() == names.len() && names.iter().all(|n| !n.is_empty())
    };
    let with_channel = |run: &Run, name: String| match run.metadata.get(crate::views::ESTIMATE_TOPIC) {
        Some(topic) => format!("{name} {}", topic.trim_start_matches('/')),
        None => name,
    };
    let named = |name: &dyn Fn(&Run) -> String| -> Vec<String> {
        runs.iter().map(|r| if name(r).is_empty() { String::new() } else { with_channel(r, name(r)) }).collect()
    };
    let filters = named(&|r| r.metadata.get("filter").cloned().unwrap_or_default());
    if distinct(&filters) {
        return filters;
    }
    let stem = |r: &Run| -> String { r.file.file_stem().map_or(String::new(), |s| s.to_string_lossy().into()) };
    let shared = shared_words(&runs.iter().map(stem).collect::<Vec<_>>());
    let stems = named(&|r| stem(r)[shared..].to_string());
    if distinct(&stems) {
        return stems;
    }
    (1..=runs.len()).map(|k| format!("run {k}")).collect()
}

/// The length of the words (each ending in `_` or `-`) that every one of two or more
/// names begins with and none is made of alone; 0 for a single name. It ends after an
/// ASCII separator, so every name can be cut there.
fn shared_words(names: &[String]) -> usize {
    let Some((first, rest)) = names.split_first() else { return 0 };
    if rest.is_empty() {
        return 0;
    }
    let common = rest
        .iter()
        .fold(first.len(), |n, name| first.bytes().zip(name.bytes()).take(n).take_while(|(a, b)| a == b).count());
    let shared = first.as_bytes()[..common].iter().rposition(|&b| b == b'_' || b == b'-').map_or(0, |i| i + 1);
    if names.iter().any(|name| name.len() == shared) {
        return 0;
    }
    shared
}

/// The name of a compared signal: the truth's, or `X~Y` when `--pair` pairs different names.
pub fn pair_name(p: &PairReport) -> String {
    if p.truth == p.estimate {
        p.truth.clone()
    } else {
        format!("{}~{}", p.truth, p.estimate)
    }
}

/// Refuses `run` unless its compared truth is `first`'s, bit for bit.
fn check_shared_truth(first: &Run, first_report: &Report, run: &Run, report: &Report) -> Result<(), LogError> {
    let refuse = |what: String| {
        let differences: Vec<String> = CASE_KEYS
            .iter()
            .filter_map(|k| match (first.metadata.get(*k), run.metadata.get(*k)) {
                (Some(a), Some(b)) if a != b => Some(format!("{k} {a} vs {b}")),
                _ => None,
            })
            .collect();
        let why = if differences.is_empty() { String::new() } else { format!(" ({})", differences.join(", ")) };
        Err(LogError::NotComparable { file: run.file.clone(), other: first.file.clone(), what: format!("{what}{why}") })
    };
    let names = |r: &Report| r.pairs.iter().map(pair_name).collect::<Vec<_>>();
    if names(first_report) != names(report) {
        return refuse(format!(
            "they compare different signals ({} vs {})",
            names(first_report).join(", "),
            names(report).join(", ")
        ));
    }
    for (a, b) in first_report.pairs.iter().zip(&report.pairs) {
        if a.time.len() != b.time.len() {
            return refuse(format!(
                "truth {} has {} samples in one and {} in the other",
                a.truth,
                a.time.len(),
                b.time.len()
            ));
        }
        let same = |x: &f64, y: &f64| x.to_bits() == y.to_bits();
        if let Some(k) =
            (0..a.time.len()).find(|&k| !same(&a.time[k], &b.time[k]) || !same(&a.truth_values[k], &b.truth_values[k]))
        {
            return refuse(format!(
                "truth {} differs at sample {k} (t = {} s: {} vs {})",
                a.truth, a.time[k], a.truth_values[k], b.truth_values[k]
            ));
        }
        // The recording draws the first run's tolerance for all, and the runs' fractions in
        // tolerance are compared: they must be held to the same requirement.
        let bits =
            |p: &PairReport| p.tolerance.as_ref().map(|t| t.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
        if bits(a) != bits(b) {
            return refuse(format!("the tolerance of truth {} differs (or one has none)", a.truth));
        }
    }
    Ok(())
}

impl Comparison<'_> {
    /// The table printed by `analyzer report`/`compare`: per compared signal, a row per run,
    /// the best value of each column marked `*` (with two runs or more).
    pub fn table(&self) -> String {
        let mut out = String::new();
        let marks = self.runs.len() > 1;
        for (i, report) in self.runs.iter().enumerate() {
            let _ = writeln!(out, "{}: {}", self.labels[i], report.file);
        }
        for k in 0..self.runs.first().map_or(0, |r| r.pairs.len()) {
            let pairs: Vec<&PairReport> = self.runs.iter().map(|r| &r.pairs[k]).collect();
            let p = pairs[0];
            let _ = writeln!(
                out,
                "\n{} [{}]: {} samples, t = {} to {} s",
                pair_name(p),
                p.unit,
                p.samples,
                p.compared_from,
                p.time.last().copied().unwrap_or(0.0)
            );
            if let Some(tolerance) = &p.tolerance {
                let _ = writeln!(
                    out,
                    "in tolerance: |estimate − truth| ≤ {} ({})",
                    tolerance.signal, tolerance.description
                );
            }
            let columns: Vec<&Column> = COLUMNS.iter().filter(|c| c.shown(&pairs)).collect();
            let headings: Vec<&str> = columns.iter().map(|c| c.heading).collect();
            let best: Vec<Option<usize>> = columns.iter().map(|c| c.best(&pairs)).collect();
            let cells: Vec<Vec<String>> =
                pairs.iter().map(|pair| columns.iter().map(|column| (column.text)(pair)).collect()).collect();
            self.write_rows(&mut out, &headings, &cells, &best);
        }
        if self.runs.iter().any(|r| r.nees.is_some() || r.nis.is_some()) {
            let first = &self.runs[0];
            let from = first.pairs.first().map_or(0.0, |p| p.compared_from);
            let _ = writeln!(out, "\nconsistency from t = {from} s");
            // What each run's NEES sums and how its rows used were derived: once if the same for all.
            let notes = |note: fn(&Report) -> Option<String>| {
                let texts: Vec<Option<String>> = self.runs.iter().map(note).collect();
                if texts.iter().all(|t| *t == texts[0]) {
                    texts[0].iter().map(|t| format!("{t}\n")).collect::<String>()
                } else {
                    let labelled = self.labels.iter().zip(&texts);
                    labelled.filter_map(|(l, t)| t.as_ref().map(|t| format!("{l}: {t}\n"))).collect()
                }
            };
            out.push_str(&notes(|r| {
                r.nees.as_ref().map(|n| format!("NEES: Σ (e/σ)² over {} ({} dof)", n.signals.join(", "), n.dof))
            }));
            out.push_str(&notes(|r| r.nis.as_ref().map(|n| format!("NIS rows used: {}", n.rows_used_from))));
            let headings: Vec<&str> = RUN_COLUMNS.iter().map(|c| c.heading).collect();
            let best: Vec<Option<usize>> = RUN_COLUMNS.iter().map(|c| c.best(&self.runs)).collect();
            let cells: Vec<Vec<String>> =
                self.runs.iter().map(|run| RUN_COLUMNS.iter().map(|column| (column.text)(run)).collect()).collect();
            self.write_rows(&mut out, &headings, &cells, &best);
        }
        if marks {
            let _ = writeln!(
                out,
                "\n* best of the runs (1σ cov: nearest 0.6827; 2σ cov: nearest 0.9545, NEES and NIS in 95 %: \
                 nearest 0.95; (e/σ)², NEES/dof and NIS/rows: nearest 1 in ratio; PSD band: widest)"
            );
        }
        out
    }

    /// Writes a table: a heading row, then a row per run (labelled), the best of each
    /// column marked `*` with two runs or more.
    fn write_rows(&self, out: &mut String, headings: &[&str], cells: &[Vec<String>], best: &[Option<usize>]) {
        let marks = self.runs.len() > 1;
        let width = self.labels.iter().map(|l| l.chars().count()).max().unwrap_or(0).max(3);
        let widths: Vec<usize> = headings
            .iter()
            .enumerate()
            .map(|(j, h)| cells.iter().map(|row| row[j].chars().count() + 1).fold(h.chars().count(), usize::max))
            .collect();
        let _ = write!(out, "{:<width$}", "run");
        for (heading, w) in headings.iter().zip(&widths) {
            let _ = write!(out, "  {heading:>w$}");
        }
        out.push('\n');
        for (i, row) in cells.iter().enumerate() {
            let _ = write!(out, "{:<width$}", self.labels[i]);
            for ((text, best), w) in row.iter().zip(best).zip(&widths) {
                let mark = if marks && *best == Some(i) { "*" } else { " " };
                let _ = write!(out, "  {:>w$}", format!("{text}{mark}"), w = w);
            }
            out.push('\n');
        }
    }

    /// Writes the comparison as JSON: the labels, every run's report, and the best runs.
    pub fn write_json(&self, path: &Path) -> Result<(), LogError> {
        let text = serde_json::to_string_pretty(self).expect("a comparison serialises");
        std::fs::write(path, text).map_err(|source| LogError::Io { file: path.to_path_buf(), source })
    }
}
