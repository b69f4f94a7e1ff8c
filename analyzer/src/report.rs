//! Pairs estimated signals with their truth and computes every metric.
//!
//! Pairing rule: a signal `X` on `/truth` pairs with the signal of the same
//! name on `/estimate` (or the channel [`Options::estimate_topic`] names); `X_std` on `/estimate`, if present, is its standard
//! deviation (for the ±2σ band, the 1σ and 2σ coverages and the normalised errors of
//! `consistency.rs`). `--pair truth.X=estimate.Y`
//! adds or replaces a pair. Samples are matched by time stamp; only the
//! times both channels have are compared.
//!
//! Tolerance rule: `X_tolerance` on `/truth`, beside `X`, is the half-width of an accuracy
//! requirement on `X` (same unit, ≥ 0): the fraction of samples whose error is within it is
//! reported, and it is not itself compared (unless `--pair` names it).

use std::borrow::Cow;
use std::collections::BTreeMap;

use serde::Serialize;

use crate::compare::pair_name;
use crate::consistency::{innovation_consistency, nees, sigma_figures, Nees, Nis, NormalisedError};
use crate::metrics::{compare_with_running_rmse, running_rmse, Metrics};
use crate::psd::{agreement_band, welch_pair, Spectrum};
use log_format::read::Run;
use log_format::write::{ESTIMATE, TRUTH};
use log_format::LogError;

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
    /// The time (s) from which the metrics, the ±2σ coverage and the spectra are taken
    /// (a filter's start-up left out); the series stay whole. Default: the first sample.
    pub from: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            rmse_window: 1.0,
            psd_segment: 1024,
            agreement_db: 3.0,
            pairs: Vec::new(),
            estimate_topic: ESTIMATE.to_string(),
            from: f64::NEG_INFINITY,
        }
    }
}

/// The analysis of one pair: metrics for machines, series for the recording.
#[derive(Debug, Clone, Serialize)]
pub struct PairReport<'a> {
    /// The truth signal.
    pub truth: String,
    /// The estimate signal.
    pub estimate: String,
    /// Unit of both.
    pub unit: String,
    /// Samples compared (from [`Options::from`] on).
    pub samples: usize,
    /// Time of the first sample compared (s).
    pub compared_from: f64,
    /// The metrics.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Fraction of samples whose error is within ±σ (`None` without σ; 0.6827 for a
    /// Gaussian error with an honest σ).
    pub one_sigma_coverage: Option<f64>,
    /// Fraction of samples whose error is within ±2σ (`None` without σ; 0.9545 for a
    /// Gaussian error with an honest σ).
    pub two_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (expectation 1) with its reading (`None` without σ).
    pub normalised_error: Option<NormalisedError>,
    /// The accuracy requirement on the truth signal, if `/truth` has its `<truth>_tolerance`.
    pub tolerance: Option<Tolerance<'a>>,
    /// Fraction of samples whose error is within ± the tolerance (`None` without one).
    pub in_tolerance: Option<f64>,
    /// The widest band (Hz) where the spectra agree within the threshold.
    pub psd_agreement_band: Option<(f64, f64)>,
    /// Compared times (s); borrowed from the run where the channels' samples line up.
    #[serde(skip)]
    pub time: Cow<'a, [f64]>,
    /// Truth values at those times.
    #[serde(skip)]
    pub truth_values: Cow<'a, [f64]>,
    /// Estimate values at those times.
    #[serde(skip)]
    pub estimate_values: Cow<'a, [f64]>,
    /// σ of the estimate, if logged.
    #[serde(skip)]
    pub sigma: Option<Cow<'a, [f64]>>,
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

/// An accuracy requirement: the truth signal `X_tolerance`, the half-width of the band
/// that `X`'s error (estimate − truth) should stay within.
#[derive(Debug, Clone, Serialize)]
pub struct Tolerance<'a> {
    /// Its truth signal's name.
    pub signal: String,
    /// Its truth signal's description (where the requirement comes from).
    pub description: String,
    /// Its values at the compared times (≥ 0, in the unit of the pair).
    #[serde(skip)]
    pub values: Cow<'a, [f64]>,
}

/// The tolerance of the truth signal `X` is the truth signal `X` + this.
pub const TOLERANCE_SUFFIX: &str = "_tolerance";

/// The suffix of an estimate's σ: `F_std` is the standard deviation of the estimate `F`.
pub const SIGMA_SUFFIX: &str = "_std";

/// The analysis of a log.
#[derive(Debug, Clone, Serialize)]
pub struct Report<'a> {
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
    pub pairs: Vec<PairReport<'a>>,
    /// The NEES of the pairs that have a σ (`None` if none has).
    pub nees: Option<Nees>,
    /// The NIS consistency (`None` if `/estimate` has no `nis`).
    pub nis: Option<Nis>,
}

/// Analyses a run.
pub fn analyse<'a>(run: &'a Run, options: &Options) -> Result<Report<'a>, LogError> {
    let file = &run.file;
    let fail = |what: String| LogError::Analysis { file: file.clone(), what };
    let truth = run.channel(TRUTH)?;
    let topic = options.estimate_topic.as_str();
    let estimate = run.channel(topic)?;
    // A tolerance is a requirement on its signal, not an estimated quantity: left unpaired
    // even where the estimates happen to have a namesake.
    let is_tolerance = |name: &str| {
        name.strip_suffix(TOLERANCE_SUFFIX).is_some_and(|x| truth.signals.iter().any(|s| s.spec.name == x))
    };
    let mut pairs: Vec<(String, String)> = truth
        .signals
        .iter()
        .filter(|s| estimate.signal(&s.spec.name).is_some() && !is_tolerance(&s.spec.name))
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
    let common = Common::of(&truth.time, &estimate.time);
    if common.len() < 4 {
        return Err(fail(format!("{TRUTH} and {topic} share only {} time stamps", common.len())));
    }
    let time = common.pick(&truth.time, 0);
    let dt = (time[time.len() - 1] - time[0]) / (time.len() - 1) as f64;
    if let Some(w) = time.windows(2).find(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt) {
        return Err(fail(format!(
            "samples are not evenly spaced (step {} s at t = {} s, mean {dt} s)",
            w[1] - w[0],
            w[0]
        )));
    }
    let first = time.iter().position(|&t| t >= options.from).unwrap_or(time.len());
    if time.len() - first < 4 {
        return Err(fail(format!(
            "only {} samples from t = {} s on, where the metrics start",
            time.len() - first,
            options.from
        )));
    }
    let mut reports = Vec::new();
    let (mut nees_signals, mut nees_squares) = (Vec::new(), Vec::new());
    for (t_name, e_name) in pairs {
        let t_signal = truth.signal(&t_name).ok_or_else(|| fail(format!("{TRUTH} has no signal '{t_name}'")))?;
        let e_signal = estimate.signal(&e_name).ok_or_else(|| fail(format!("{topic} has no signal '{e_name}'")))?;
        let picked = |values: &'a [f64], channel: &str, signal: &str, side: usize| {
            let out = common.pick(values, side);
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
        let truth_values = picked(&t_signal.values, TRUTH, &t_name, 0)?;
        let estimate_values = picked(&e_signal.values, topic, &e_name, 1)?;
        let sigma_name = format!("{e_name}{SIGMA_SUFFIX}");
        let sigma = match estimate.signal(&sigma_name) {
            Some(s) => Some(picked(&s.values, topic, &sigma_name, 1)?),
            None => None,
        };
        let w = ((options.rmse_window / dt).round() as usize).max(1);
        let running_rmse = running_rmse(&truth_values, &estimate_values, w);
        let (t, e) = (&truth_values[first..], &estimate_values[first..]);
        let metrics = compare_with_running_rmse(t, e, &running_rmse[first..], time[first], dt);
        let sigma_figures = sigma.as_ref().map(|s| sigma_figures(t, e, &s[first..]));
        let tolerance_signal = format!("{t_name}{TOLERANCE_SUFFIX}");
        let tolerance = match truth.signal(&tolerance_signal) {
            Some(s) => {
                let values = picked(&s.values, TRUTH, &tolerance_signal, 0)?;
                if let Some(k) = values.iter().position(|v| *v < 0.0) {
                    return Err(fail(format!(
                        "{TRUTH} signal '{tolerance_signal}' is negative ({}) at t = {} s; a tolerance is a half-width",
                        values[k], time[k]
                    )));
                }
                Some(Tolerance { signal: tolerance_signal, description: s.spec.description.clone(), values })
            }
            None => None,
        };
        let in_tolerance = tolerance.as_ref().map(|tol| {
            let inside =
                t.iter().zip(e).zip(&tol.values[first..]).filter(|((t, e), bound)| (*e - *t).abs() <= **bound).count();
            inside as f64 / t.len() as f64
        });
        let fs = 1.0 / dt;
        let [truth_spectrum, estimate_spectrum] = welch_pair(t, e, fs, options.psd_segment);
        reports.push(PairReport {
            truth: t_name,
            estimate: e_name,
            unit: t_signal.spec.unit.clone(),
            samples: time.len() - first,
            compared_from: time[first],
            metrics,
            one_sigma_coverage: sigma_figures.as_ref().map(|f| f.one_sigma_coverage),
            two_sigma_coverage: sigma_figures.as_ref().map(|f| f.two_sigma_coverage),
            normalised_error: sigma_figures.as_ref().map(|f| f.normalised_error),
            tolerance,
            in_tolerance,
            psd_agreement_band: agreement_band(&truth_spectrum, &estimate_spectrum, options.agreement_db),
            running_rmse,
            time: time.clone(),
            truth_values,
            estimate_values,
            sigma,
            truth_spectrum,
            estimate_spectrum,
        });
        if let Some(figures) = sigma_figures {
            nees_signals.push(pair_name(&reports[reports.len() - 1]));
            nees_squares.push(figures.squares);
        }
    }
    Ok(Report {
        file: run.file.display().to_string(),
        metadata: run.metadata.clone(),
        rmse_window: options.rmse_window,
        psd_segment: options.psd_segment,
        agreement_db: options.agreement_db,
        pairs: reports,
        nees: nees(nees_signals, &nees_squares),
        nis: innovation_consistency(run, time[first]),
    })
}

/// The samples two channels share: the index pairs `(i, j)` with `a[i] == b[j]` to the
/// nanosecond; as is usual, two ranges of the same length that line up.
enum Common {
    Ranges { a: usize, b: usize, len: usize },
    Pairs(Vec<[usize; 2]>),
}

impl Common {
    /// By a merge pass over two strictly increasing time series (two when they do not line
    /// up; none when they are the same series, the usual case).
    fn of(a: &[f64], b: &[f64]) -> Self {
        if a == b {
            return Common::Ranges { a: 0, b: 0, len: a.len() };
        }
        let mut first = None;
        let mut len = 0;
        let mut lined_up = true;
        merge(a, b, |i, j| {
            let &mut (i0, j0) = first.get_or_insert((i, j));
            lined_up &= i == i0 + len && j == j0 + len;
            len += 1;
        });
        match first {
            None => Common::Ranges { a: 0, b: 0, len: 0 },
            Some((a, b)) if lined_up => Common::Ranges { a, b, len },
            Some(_) => {
                let mut pairs = Vec::with_capacity(len);
                merge(a, b, |i, j| pairs.push([i, j]));
                Common::Pairs(pairs)
            }
        }
    }

    fn len(&self) -> usize {
        match self {
            Common::Ranges { len, .. } => *len,
            Common::Pairs(pairs) => pairs.len(),
        }
    }

    /// The shared samples of `values`, a series of side 0 (`a`) or 1 (`b`): borrowed when lined up.
    fn pick<'a>(&self, values: &'a [f64], side: usize) -> Cow<'a, [f64]> {
        match self {
            Common::Ranges { a, b, len } => {
                let start = if side == 0 { *a } else { *b };
                Cow::Borrowed(&values[start..start + len])
            }
            Common::Pairs(pairs) => Cow::Owned(pairs.iter().map(|p| values[p[side]]).collect()),
        }
    }
}

/// Calls `matched(i, j)` for each `a[i] == b[j]` (to the nanosecond) of two increasing series.
fn merge(a: &[f64], b: &[f64], mut matched: impl FnMut(usize, usize)) {
    let key = |t: f64| (t * 1e9).round() as i64;
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match key(a[i]).cmp(&key(b[j])) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                matched(i, j);
                i += 1;
                j += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_samples_are_borrowed_when_they_line_up_and_paired_when_not() {
        let a = [0.0, 0.01, 0.02, 0.03, 0.04];
        let values = [10.0, 11.0, 12.0, 13.0, 14.0];
        // The same stamps, and a channel starting one sample later (as /prediction does).
        assert!(matches!(Common::of(&a, &a), Common::Ranges { a: 0, b: 0, len: 5 }));
        let later = [0.01, 0.02, 0.03, 0.04, 0.05];
        let shifted = Common::of(&a, &later);
        assert!(matches!(shifted, Common::Ranges { a: 1, b: 0, len: 4 }));
        assert!(matches!(shifted.pick(&values, 0), Cow::Borrowed([11.0, 12.0, 13.0, 14.0])));
        // A gap: the samples either side are paired by their stamps.
        let gap = [0.0, 0.02, 0.03, 0.05];
        let paired = Common::of(&a, &gap);
        assert_eq!(paired.len(), 3);
        assert_eq!(paired.pick(&values, 0).as_ref(), [10.0, 12.0, 13.0]);
        assert_eq!(paired.pick(&[1.0, 2.0, 3.0, 4.0], 1).as_ref(), [1.0, 2.0, 3.0]);
        assert_eq!(Common::of(&a, &[1.0, 2.0]).len(), 0);
    }
}
