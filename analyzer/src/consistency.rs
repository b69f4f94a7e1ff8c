//! Whether an estimator's σ means what it says: its errors against the truth normalised by
//! the σ it reports, and its innovations normalised by their covariance (the NIS it logs).
//!
//! * **1σ and 2σ coverage**: the fractions of samples with |e| ≤ σ and ≤ 2σ (68.27 % and
//!   95.45 % for a Gaussian error with an honest σ).
//! * **Mean (e/σ)² per signal** (expectation 1), read against the central 95 % interval of
//!   the mean of n χ²(1) variables, n corrected for autocorrelation (see
//!   [`effective_samples`]): below it the σ is *too wide*, above it *too narrow*.
//! * **NEES** of the compared outputs: per sample, Σᵢ (eᵢ/σᵢ)² over the pairs that have a σ.
//!   The logs carry marginal σ only, so the errors are normalised as if uncorrelated: the
//!   mean keeps its expectation (the number of signals) whatever the correlation, but the
//!   χ²(m) band the samples are counted in assumes independent errors.
//! * **NIS** (from `/estimate`'s `nis`, the NIS of the update at that sample): its mean
//!   against the mean number of measurement rows used, derived from `/measurements` (see
//!   [`innovation_consistency`]).
//!
//! The χ² quantiles are computed here (the analyzer does not depend on the estimators):
//! the regularised incomplete gamma function, inverted by bisection, below 10⁴ degrees of
//! freedom, and the Wilson–Hilferty approximation (relative error below 1e-7 there) above.

use std::collections::BTreeMap;

use serde::Serialize;

use log_format::read::Run;
use log_format::write::{ESTIMATE, MEASUREMENTS};

/// What a mean normalised square says of the σ behind it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Reading {
    /// Inside the 95 % interval of its expectation: the σ is as large as the errors.
    #[serde(rename = "consistent")]
    Consistent,
    /// Below the interval: the errors are smaller than the σ says (σ too pessimistic).
    #[serde(rename = "too wide")]
    TooWide,
    /// Above the interval: the errors are larger than the σ says (σ overconfident).
    #[serde(rename = "too narrow")]
    TooNarrow,
}

impl Reading {
    /// `consistent`, `too wide` or `too narrow`.
    pub fn text(self) -> &'static str {
        match self {
            Reading::Consistent => "consistent",
            Reading::TooWide => "too wide",
            Reading::TooNarrow => "too narrow",
        }
    }

    /// The reading of `ratio`, a mean of squares divided by its expectation, worth
    /// `dof` χ² degrees of freedom: outside the central 95 % interval of χ²(dof)/dof.
    pub fn of(ratio: f64, dof: f64) -> (Reading, [f64; 2]) {
        let [lo, hi] = chi_square_central_95(dof);
        let interval = [lo / dof, hi / dof];
        let reading = if ratio < interval[0] {
            Reading::TooWide
        } else if ratio > interval[1] || ratio.is_nan() {
            Reading::TooNarrow
        } else {
            Reading::Consistent
        };
        (reading, interval)
    }
}

/// The σ-normalised squared error of one signal, `(e/σ)²`, over the compared samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NormalisedError {
    /// Mean of `(e/σ)²`; 1 for an honest σ (∞ where σ = 0 with an error).
    pub mean_square: f64,
    /// Samples compared.
    pub samples: usize,
    /// The samples the mean is worth, for its autocorrelation ([`effective_samples`]).
    pub effective_samples: f64,
    /// Central 95 % interval of the mean for an honest σ: χ²(ν)/ν at ν = `effective_samples`.
    pub interval: [f64; 2],
    /// Below the interval: σ too wide; above: too narrow.
    pub reading: Reading,
}

/// What the σ of one signal says against its errors.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaFigures {
    /// Fraction of samples with `|estimate − truth| ≤ σ`.
    pub one_sigma_coverage: f64,
    /// Fraction of samples with `|estimate − truth| ≤ 2σ`.
    pub two_sigma_coverage: f64,
    /// The mean `(e/σ)²` and its reading.
    pub normalised_error: NormalisedError,
    /// `(e/σ)²` sample by sample, for the NEES.
    pub squares: Vec<f64>,
}

/// The coverages, the normalised squared errors and their mean with its reading, of
/// `estimate` against `truth` with the standard deviation `sigma` (all of one length).
pub fn sigma_figures(truth: &[f64], estimate: &[f64], sigma: &[f64]) -> SigmaFigures {
    let n = truth.len();
    let (mut one, mut two) = (0usize, 0usize);
    let mut squares = Vec::with_capacity(n);
    for ((t, e), s) in truth.iter().zip(estimate).zip(sigma) {
        let error = (e - t).abs();
        one += usize::from(error <= *s);
        two += usize::from(error <= 2.0 * s);
        // A σ of 0 with no error is a value known exactly and right: it adds nothing.
        squares.push(if error == 0.0 { 0.0 } else { (error / s).powi(2) });
    }
    let mean_square = squares.iter().sum::<f64>() / n as f64;
    let (effective, (reading, interval)) = if mean_square.is_finite() {
        let effective = effective_samples(&squares);
        (effective, Reading::of(mean_square, effective))
    } else {
        (f64::NAN, (Reading::TooNarrow, [f64::NAN; 2]))
    };
    SigmaFigures {
        one_sigma_coverage: one as f64 / n as f64,
        two_sigma_coverage: two as f64 / n as f64,
        normalised_error: NormalisedError { mean_square, samples: n, effective_samples: effective, interval, reading },
        squares,
    }
}

/// The normalised estimation error squared of the compared outputs that have a σ.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Nees {
    /// The compared signals summed (those with a σ), in the report's order.
    pub signals: Vec<String>,
    /// Their number: the NEES's expectation and its χ² degrees of freedom.
    pub dof: usize,
    /// Samples.
    pub samples: usize,
    /// Time mean of the NEES.
    pub mean: f64,
    /// The central 95 % band of χ²(`dof`).
    pub band: [f64; 2],
    /// Fraction of samples whose NEES is inside the band (0.95 for honest, independent errors).
    pub in_band: f64,
}

/// The NEES of the signals `names` whose σ-normalised squared errors, sample by sample, are
/// `squares` ([`SigmaFigures::squares`], all of one length); `None` without any.
pub fn nees(names: Vec<String>, squares: &[Vec<f64>]) -> Option<Nees> {
    let samples = squares.first()?.len();
    let dof = squares.len();
    let band = chi_square_central_95(dof as f64);
    let (mut sum, mut inside) = (0.0, 0usize);
    for k in 0..samples {
        let nees: f64 = squares.iter().map(|s| s[k]).sum();
        sum += nees;
        inside += usize::from(band[0] <= nees && nees <= band[1]);
    }
    Some(Nees {
        signals: names,
        dof,
        samples,
        mean: sum / samples as f64,
        band,
        in_band: inside as f64 / samples as f64,
    })
}

/// The innovation consistency: the NIS the estimator logs against the rows it used.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Nis {
    /// Samples with a finite NIS (from [`crate::report::Options::from`] on).
    pub samples: usize,
    /// Mean NIS.
    pub mean: f64,
    /// Mean number of measurement rows used per sample, the mean NIS's expectation; `None`
    /// when the log does not say (no `/measurements` at the NIS's times).
    pub rows_used_mean: Option<f64>,
    /// How the rows used were derived.
    pub rows_used_from: String,
    /// Whether the rows the innovation gate rejected are known (from the cumulative
    /// `rejected_measurements` on `/estimate`, differenced); if not, a rejected row counts
    /// as used and the expectation is an upper bound.
    pub rejections_known: bool,
    /// `Σ NIS / Σ rows used`: 1 for an honest innovation covariance.
    pub ratio: Option<f64>,
    /// The χ² degrees of freedom the ratio is worth: Σ rows used, corrected for the
    /// autocorrelation of `NIS − rows` ([`effective_samples`]).
    pub effective_dof: Option<f64>,
    /// Central 95 % interval of the ratio for an honest filter: χ²(ν)/ν at ν = `effective_dof`.
    pub interval: Option<[f64; 2]>,
    /// Below the interval the innovation covariance is too wide, above too narrow.
    pub reading: Option<Reading>,
    /// Fraction of the samples with rows used whose NIS is inside the central 95 % band of
    /// χ²(rows used).
    pub in_band: Option<f64>,
}

/// The signal of the estimator's NIS on `/estimate`.
pub const NIS: &str = "nis";
/// The estimators' cumulative count of rows the innovation gate rejected, on `/estimate`.
pub const REJECTED: &str = "rejected_measurements";

/// The NIS consistency of `run` from the time `from` on, when `/estimate` has `nis` (the
/// NIS of the update at each sample: outputs are read after the inputs of their time are
/// set), whichever channel the estimates are compared from.
///
/// Rows used at a sample: the measurement rows on `/measurements` at that time that are not
/// NaN (missing), less the rows the gate rejected there — the step of the cumulative
/// `rejected_measurements` on `/estimate` since the previous sample, when the log carries
/// it. The measurement rows are the `/measurements` signals `X` whose noise parameter
/// `r_X_std` the metadata's `parameters` names (the kalfmu FMUs' convention; the others are
/// control inputs), or every `/measurements` signal when it names none. Rows an estimator
/// leaves out for another reason (a stuck input) are not in the log and count as used.
pub fn innovation_consistency(run: &Run, from: f64) -> Option<Nis> {
    let estimate = run.channel(ESTIMATE).ok()?;
    let nis = estimate.signal(NIS)?;
    let first = estimate.time.iter().position(|&t| t >= from).unwrap_or(estimate.time.len());
    let rejected = estimate.signal(REJECTED).map(|s| &s.values);
    let measurements = run.channel(MEASUREMENTS).ok();
    let noise_parameters: Vec<String> = run
        .metadata
        .get("parameters")
        .and_then(|p| serde_json::from_str::<BTreeMap<String, serde_json::Value>>(p).ok())
        .map(|p| p.into_keys().collect())
        .unwrap_or_default();
    let is_row = |name: &str| noise_parameters.contains(&format!("r_{name}_std"));
    let rows_named = measurements.is_some_and(|m| m.signals.iter().any(|s| is_row(&s.spec.name)));
    let rows: Option<Vec<&[f64]>> = measurements.map(|m| {
        m.signals.iter().filter(|s| !rows_named || is_row(&s.spec.name)).map(|s| s.values.as_slice()).collect()
    });
    // The measurement sample at each estimate time, by the stamp to the nanosecond.
    let key = |t: f64| (t * 1e9).round() as i64;
    let measurement_index: BTreeMap<i64, usize> =
        measurements.map(|m| m.time.iter().enumerate().map(|(j, &t)| (key(t), j)).collect()).unwrap_or_default();

    let (mut values, mut used) = (Vec::new(), Vec::new());
    let mut all_rows_known = measurements.is_some();
    for k in first..estimate.time.len() {
        let value = nis.values[k];
        if !value.is_finite() {
            continue;
        }
        let rows_here = rows.as_ref().zip(measurement_index.get(&key(estimate.time[k]))).map(|(rows, &j)| {
            let present = rows.iter().filter(|r| r[j].is_finite()).count() as f64;
            let rejected_here = rejected.map_or(0.0, |r| {
                let before = if k == 0 { 0.0 } else { r[k - 1] };
                (r[k] - before).max(0.0)
            });
            (present - rejected_here).max(0.0)
        });
        all_rows_known &= rows_here.is_some();
        values.push(value);
        used.push(rows_here.unwrap_or(f64::NAN));
    }
    let samples = values.len();
    if samples == 0 {
        return None;
    }
    let mean = values.iter().sum::<f64>() / samples as f64;
    let rows_used_from = if measurements.is_none() {
        format!("unknown: the log has no {MEASUREMENTS}")
    } else if !all_rows_known {
        format!("unknown: {MEASUREMENTS} lacks some of the NIS's time stamps")
    } else {
        format!(
            "{} on {MEASUREMENTS} that are not NaN{}",
            if rows_named { "the signals whose r_<signal>_std the parameters set" } else { "the signals" },
            if rejected.is_some() {
                format!(", less the step of {ESTIMATE} {REJECTED} since the previous sample")
            } else {
                format!("; rejections unknown ({ESTIMATE} has no {REJECTED})")
            }
        )
    };
    let mut report = Nis {
        samples,
        mean,
        rows_used_mean: None,
        rows_used_from,
        rejections_known: rejected.is_some(),
        ratio: None,
        effective_dof: None,
        interval: None,
        reading: None,
        in_band: None,
    };
    if !all_rows_known {
        return Some(report);
    }
    let total_rows: f64 = used.iter().sum();
    report.rows_used_mean = Some(total_rows / samples as f64);
    if total_rows > 0.0 {
        let ratio = values.iter().sum::<f64>() / total_rows;
        let deviations: Vec<f64> = values.iter().zip(&used).map(|(v, r)| v - r).collect();
        let dof = total_rows * effective_samples(&deviations) / samples as f64;
        let (reading, interval) = Reading::of(ratio, dof);
        let mut bands: BTreeMap<u64, [f64; 2]> = BTreeMap::new();
        let (mut inside, mut with_rows) = (0usize, 0usize);
        for (v, r) in values.iter().zip(&used) {
            if *r > 0.0 {
                let band = *bands.entry(*r as u64).or_insert_with(|| chi_square_central_95(*r));
                with_rows += 1;
                inside += usize::from(band[0] <= *v && *v <= band[1]);
            }
        }
        report.ratio = Some(ratio);
        report.effective_dof = Some(dof);
        report.interval = Some(interval);
        report.reading = Some(reading);
        report.in_band = Some(inside as f64 / with_rows as f64);
    }
    Some(report)
}

/// The number of independent samples the mean of `series` is worth: `n / (1 + 2 Σₖ (1 − k/n) ρₖ)`,
/// with ρₖ the autocorrelation of the series at lag k, summed up to its first lag at or
/// below zero (beyond it the estimates are noise). A crude correction: ρ is evaluated at
/// every lag to 16 and then at lags 25 % apart (interpolated linearly between them), so
/// that a slowly decorrelating series costs some 60 passes, not n.
pub fn effective_samples(series: &[f64]) -> f64 {
    let n = series.len();
    if n < 3 {
        return n as f64;
    }
    let mean = series.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = series.iter().map(|x| x - mean).collect();
    let c0: f64 = centred.iter().map(|x| x * x).sum();
    if c0 == 0.0 {
        return n as f64;
    }
    let weighted_rho = |lag: usize| {
        let c: f64 = centred[..n - lag].iter().zip(&centred[lag..]).map(|(a, b)| a * b).sum();
        (c / c0).max(0.0) * (1.0 - lag as f64 / n as f64)
    };
    // Σ_{k=a+1}^{b} f(k) ≈ (b − a)(f(a) + f(b))/2 + (f(b) − f(a))/2: exact for linear f.
    let (mut sum, mut lag, mut previous) = (0.0, 0usize, 1.0);
    loop {
        let next = if lag < 16 { lag + 1 } else { (lag as f64 * 1.25).ceil() as usize };
        if next >= n / 2 {
            break;
        }
        let f = weighted_rho(next);
        sum += (next - lag) as f64 * (previous + f) / 2.0 + (f - previous) / 2.0;
        if f <= 0.0 {
            break;
        }
        (lag, previous) = (next, f);
    }
    // The lag-0 term of the trapezoid above counted ρ₀ = 1 at its edge only: `sum` is Σ_{k≥1}.
    n as f64 / (1.0 + 2.0 * sum)
}

/// The central 95 % band `[q(0.025), q(0.975)]` of χ²(`dof`), `dof > 0` (not necessarily whole).
pub fn chi_square_central_95(dof: f64) -> [f64; 2] {
    [chi_square_quantile(dof, 0.025), chi_square_quantile(dof, 0.975)]
}

/// The standard normal quantiles of 0.025 and 0.975.
const NORMAL_975: f64 = 1.959_963_984_540_054;

/// The `p` quantile of χ²(`dof`): Wilson–Hilferty for p = 0.025 or 0.975 above 10⁴
/// degrees of freedom (within 1e-7 relative there, and far cheaper than bisecting the
/// incomplete gamma function), the shared `chi_square::quantile` below.
pub fn chi_square_quantile(dof: f64, p: f64) -> f64 {
    if dof >= 1e4 && (p == 0.025 || p == 0.975) {
        // Wilson–Hilferty: (X/ν)^(1/3) is nearly normal, of mean 1 − 2/(9ν) and variance 2/(9ν).
        let z = if p < 0.5 { -NORMAL_975 } else { NORMAL_975 };
        let v = 2.0 / (9.0 * dof);
        return dof * (1.0 - v + z * v.sqrt()).powi(3);
    }
    chi_square::quantile(dof, p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tabulated χ² quantiles (0.025 and 0.975; as printed by statistical tables and
    /// `scipy.stats.chi2.ppf`).
    const TABLE: [(f64, f64, f64); 10] = [
        (1.0, 0.000_982_069_117_175_255_5, 5.023_886_187_314_888),
        (2.0, 0.050_635_615_968_579_75, 7.377_758_908_227_871),
        (3.0, 0.215_795_282_623_897_85, 9.348_403_604_496_148),
        (5.0, 0.831_211_613_486_662_5, 12.832_501_994_030_027),
        (10.0, 3.246_972_780_236_841_3, 20.483_177_350_807_388),
        (12.0, 4.403_788_506_981_701_5, 23.336_664_158_645_34),
        (100.0, 74.221_927_474_923_73, 129.561_197_185_836_6),
        (1000.0, 914.257_153_799_259, 1_089.530_912_774_913_5),
        (1500.0, 1_394.555_030_534_884_7, 1_609.233_217_854_98),
        (100_000.0, 99_125.373_300_647_35, 100_878.415_305_665_58),
    ];

    #[test]
    fn chi_square_quantiles_match_the_tables() {
        for (dof, lo, hi) in TABLE {
            let [a, b] = chi_square_central_95(dof);
            // Exact inversion below 10⁴ degrees of freedom, Wilson–Hilferty above.
            let tolerance = if dof < 1e4 { 1e-9 } else { 1e-7 };
            assert!((a - lo).abs() <= tolerance * lo, "χ²({dof}) 0.025: {a} vs {lo}");
            assert!((b - hi).abs() <= tolerance * hi, "χ²({dof}) 0.975: {b} vs {hi}");
        }
        // A fractional degree of freedom, and the CDF itself.
        assert!((chi_square_quantile(0.7, 0.5) - 0.214_738_971_723_686_58).abs() < 1e-10);
        assert!((chi_square::cdf(2.5, 3.0) - 0.694_150_370_554_180_9).abs() < 1e-12);
    }

    #[test]
    fn white_noise_is_worth_its_samples_and_an_ar1_series_fewer() {
        // A deterministic LCG for uniform noise, and an AR(1) of coefficient 0.9 driven by it.
        let mut state = 12345u64;
        let mut uniform = || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let white: Vec<f64> = (0..100_000).map(|_| uniform()).collect();
        let n_white = effective_samples(&white);
        assert!(n_white > 97_000.0, "{n_white}");
        let mut x = 0.0;
        let ar: Vec<f64> = white
            .iter()
            .map(|w| {
                x = 0.9 * x + w;
                x
            })
            .collect();
        // ρₖ = 0.9ᵏ: 1 + 2 Σ ρₖ = (1 + 0.9)/(1 − 0.9) = 19.
        let n_ar = effective_samples(&ar);
        assert!((n_ar - 100_000.0 / 19.0).abs() < 0.1 * 100_000.0 / 19.0, "{n_ar}");
    }

    #[test]
    fn a_ratio_reads_against_its_interval() {
        assert_eq!(Reading::of(1.0, 1000.0).0, Reading::Consistent);
        assert_eq!(Reading::of(0.8, 1000.0).0, Reading::TooWide);
        assert_eq!(Reading::of(1.2, 1000.0).0, Reading::TooNarrow);
        // Worth 10 degrees of freedom only, 0.4 is still consistent (χ²(10)/10 ≥ 0.325).
        assert_eq!(Reading::of(0.4, 10.0).0, Reading::Consistent);
    }
}
