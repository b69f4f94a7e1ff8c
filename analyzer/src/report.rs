//! Pairs estimated signals with their truth and computes every metric.
//!
//! Pairing rule: a signal `X` on `/truth` pairs with the signal of the same
//! name on `/estimate` (or the channel [`Options::estimate_topic`] names); `X_std` on `/estimate`, if present, is its standard
//! deviation (for the ±2σ band and its coverage). `--pair truth.X=estimate.Y`
//! adds or replaces a pair. Samples are matched by time stamp; only the
//! times both channels have are compared.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::error::LogError;
use crate::log::{ESTIMATE, TRUTH};
use crate::metrics::{compare, running_rmse, Comparison};
use crate::psd::{agreement_band, welch, Spectrum};
use crate::read::Run;

/// How to analyse.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Window of the running RMSE (s); default 1.
    pub rmse_window: f64,
    /// Welch segment length (samples); default 1024.
    pub psd_segment: usize,
    /// Agreement threshold of the spectra (dB); default 3.
    pub agreement_db: f64,
    /// Extra or replacing pairs `(truth signal, estimate signal)`.
    pub pairs: Vec<(String, String)>,
    /// The channel of the estimates; default `/estimate` (`/prediction` holds
    /// an estimator FMU's outputs read right after each step).
    pub estimate_topic: String,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            rmse_window: 1.0,
            psd_segment: 1024,
            agreement_db: 3.0,
            pairs: Vec::new(),
            estimate_topic: ESTIMATE.to_string(),
        }
    }
}

/// The analysis of one pair: metrics for machines, series for the recording.
#[derive(Debug, Clone, Serialize)]
pub struct PairReport {
    /// The truth signal.
    pub truth: String,
    /// The estimate signal.
    pub estimate: String,
    /// Unit of both.
    pub unit: String,
    /// Samples compared.
    pub samples: usize,
    /// The metrics.
    #[serde(flatten)]
    pub comparison: Comparison,
    /// Fraction of samples whose error is within ±2σ (`None` without σ).
    pub two_sigma_coverage: Option<f64>,
    /// The widest band (Hz) where the spectra agree within the threshold.
    pub psd_agreement_band: Option<(f64, f64)>,
    /// Compared times (s).
    #[serde(skip)]
    pub time: Vec<f64>,
    /// Truth values at those times.
    #[serde(skip)]
    pub truth_values: Vec<f64>,
    /// Estimate values at those times.
    #[serde(skip)]
    pub estimate_values: Vec<f64>,
    /// σ of the estimate, if logged.
    #[serde(skip)]
    pub sigma: Option<Vec<f64>>,
    /// Running RMSE.
    #[serde(skip)]
    pub running_rmse: Vec<f64>,
    /// Welch PSD of the truth.
    #[serde(skip)]
    pub truth_spectrum: Spectrum,
    /// Welch PSD of the estimate.
    #[serde(skip)]
    pub estimate_spectrum: Spectrum,
}

/// The analysis of a log.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The log file.
    pub file: String,
    /// Its metadata record.
    pub metadata: BTreeMap<String, String>,
    /// Running-RMSE window (s).
    pub rmse_window: f64,
    /// Welch segment (samples).
    pub psd_segment: usize,
    /// Spectrum agreement threshold (dB).
    pub agreement_db: f64,
    /// One entry per pair.
    pub pairs: Vec<PairReport>,
}

/// Analyses a run.
pub fn analyse(run: &Run, options: &Options) -> Result<Report, LogError> {
    let file = &run.file;
    let fail = |what: String| LogError::Analysis { file: file.clone(), what };
    let truth = run.channel(TRUTH)?;
    let topic = options.estimate_topic.as_str();
    let estimate = run.channel(topic)?;
    let mut pairs: Vec<(String, String)> = truth
        .signals
        .iter()
        .filter(|s| estimate.signal(&s.spec.name).is_some())
        .map(|s| (s.spec.name.clone(), s.spec.name.clone()))
        .collect();
    for (t, e) in &options.pairs {
        pairs.retain(|(pt, _)| pt != t);
        pairs.push((t.clone(), e.clone()));
    }
    if pairs.is_empty() {
        return Err(fail(format!(
            "no signal of {TRUTH} has a namesake on {topic}; name one with --pair truth.X=estimate.Y"
        )));
    }
    // Samples at the times both channels have (time stamps are integral ns).
    let key = |t: f64| (t * 1e9).round() as i64;
    let estimate_index: BTreeMap<i64, usize> = estimate.time.iter().enumerate().map(|(i, &t)| (key(t), i)).collect();
    let common: Vec<(usize, usize)> =
        truth.time.iter().enumerate().filter_map(|(i, &t)| estimate_index.get(&key(t)).map(|&j| (i, j))).collect();
    if common.len() < 4 {
        return Err(fail(format!("{TRUTH} and {topic} share only {} time stamps", common.len())));
    }
    let time: Vec<f64> = common.iter().map(|&(i, _)| truth.time[i]).collect();
    let dt = (time[time.len() - 1] - time[0]) / (time.len() - 1) as f64;
    if let Some(w) = time.windows(2).find(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt) {
        return Err(fail(format!(
            "samples are not evenly spaced (step {} s at t = {} s, mean {dt} s)",
            w[1] - w[0],
            w[0]
        )));
    }
    let mut reports = Vec::new();
    for (t_name, e_name) in pairs {
        let t_signal = truth.signal(&t_name).ok_or_else(|| fail(format!("{TRUTH} has no signal '{t_name}'")))?;
        let e_signal = estimate.signal(&e_name).ok_or_else(|| fail(format!("{topic} has no signal '{e_name}'")))?;
        let picked = |values: &[f64], channel: &str, signal: &str, which: fn(&(usize, usize)) -> usize| {
            let out: Vec<f64> = common.iter().map(|p| values[which(p)]).collect();
            match out.iter().position(|v| !v.is_finite()) {
                Some(k) => Err(LogError::NotFinite {
                    file: file.clone(),
                    channel: channel.into(),
                    signal: signal.into(),
                    time: time[k],
                }),
                None => Ok(out),
            }
        };
        let truth_values = picked(&t_signal.values, TRUTH, &t_name, |p| p.0)?;
        let estimate_values = picked(&e_signal.values, topic, &e_name, |p| p.1)?;
        let sigma_name = format!("{e_name}_std");
        let sigma = match estimate.signal(&sigma_name) {
            Some(s) => Some(picked(&s.values, topic, &sigma_name, |p| p.1)?),
            None => None,
        };
        let comparison = compare(&truth_values, &estimate_values, time[0], dt, options.rmse_window);
        let w = ((options.rmse_window / dt).round() as usize).max(1);
        let two_sigma_coverage = sigma.as_ref().map(|s| {
            let inside = truth_values
                .iter()
                .zip(&estimate_values)
                .zip(s)
                .filter(|((t, e), s)| (*e - *t).abs() <= 2.0 * *s)
                .count();
            inside as f64 / truth_values.len() as f64
        });
        let fs = 1.0 / dt;
        let truth_spectrum = welch(&truth_values, fs, options.psd_segment);
        let estimate_spectrum = welch(&estimate_values, fs, options.psd_segment);
        reports.push(PairReport {
            truth: t_name,
            estimate: e_name,
            unit: t_signal.spec.unit.clone(),
            samples: time.len(),
            comparison,
            two_sigma_coverage,
            psd_agreement_band: agreement_band(&truth_spectrum, &estimate_spectrum, options.agreement_db),
            running_rmse: running_rmse(&truth_values, &estimate_values, w),
            time: time.clone(),
            truth_values,
            estimate_values,
            sigma,
            truth_spectrum,
            estimate_spectrum,
        });
    }
    Ok(Report {
        file: run.file.display().to_string(),
        metadata: run.metadata.clone(),
        rmse_window: options.rmse_window,
        psd_segment: options.psd_segment,
        agreement_db: options.agreement_db,
        pairs: reports,
    })
}

impl Report {
    /// The table printed by `analyzer report`.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "{}", self.file);
        for (k, v) in &self.metadata {
            let _ = writeln!(out, "  {k}: {v}");
        }
        let _ = writeln!(
            out,
            "{:<12} {:>6} {:>9} {:>10} {:>10} {:>8} {:>10} {:>10} {:>8} {:>10} {:>16}",
            "signal",
            "unit",
            "corr",
            "RMSE",
            "RMSE conv",
            "t_conv",
            "run. peak",
            "run. max",
            "2σ cov",
            "final rel",
            "PSD ±3 dB (Hz)"
        );
        for p in &self.pairs {
            let c = &p.comparison;
            let name = if p.truth == p.estimate { p.truth.clone() } else { format!("{}~{}", p.truth, p.estimate) };
            let coverage = p.two_sigma_coverage.map_or("—".into(), |v| format!("{:.3}", v));
            let band = p.psd_agreement_band.map_or("—".into(), |(lo, hi)| format!("{lo:.2}–{hi:.2}"));
            let _ = writeln!(
                out,
                "{:<12} {:>6} {:>9.5} {:>10.4} {:>10.4} {:>7.2}s {:>10.4} {:>10.4} {:>8} {:>10.2e} {:>16}",
                name,
                p.unit,
                c.correlation,
                c.rmse,
                c.rmse_converged,
                c.convergence_time,
                c.running_rmse_peak,
                c.running_rmse_max_converged,
                coverage,
                c.final_relative_error,
                band
            );
        }
        out
    }

    /// Writes the report as JSON.
    pub fn write_json(&self, path: &Path) -> Result<(), LogError> {
        let text = serde_json::to_string_pretty(self).expect("a report serialises");
        std::fs::write(path, text).map_err(|source| LogError::Io { file: path.to_path_buf(), source })
    }
}
