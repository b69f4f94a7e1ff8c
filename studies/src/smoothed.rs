//! The smoothed figures `reproduce` prints beside the filtered ones. Every FMU run of a
//! study also has the FMU smooth what it estimates (its `smoothing_lag`: the estimate of
//! that much earlier given the measurements up to now, a fixed-lag smoother inside the
//! FMU), logged on `/smoothed` and compared with the truth by the analyzer like the
//! filtered estimates on `/estimate`.

use analyzer::metrics::Metrics;
use analyzer::report::{analyse, Options};
use log_format::read::Run;
use log_format::write::SMOOTHED;
use serde::Serialize;

/// The `smoothing_lag` of every study's FMU runs (s): 20 samples of S1 and S5, 100 of S2
/// and S3, 5 telegrams of S4. A lag a monitor can wait for; the fixed-interval smoother's
/// gain (the whole run after each instant) is its ceiling (`docs/smoothing.md`).
pub const SMOOTHING_LAG: f64 = 0.1;

/// A signal's smoothed figures in one run.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SmoothedFigures {
    /// The smoothing lag (s).
    pub lag: f64,
    /// Correlation with the truth.
    pub correlation: f64,
    /// RMSE after the smoothed estimate's convergence time.
    pub rmse_converged: f64,
    /// Fraction of samples whose error is within the smoothed ±σ (0.6827 for an honest σ).
    pub one_sigma_coverage: Option<f64>,
    /// Fraction within ±2σ (0.9545 for an honest σ).
    pub two_sigma_coverage: Option<f64>,
}

/// The smoothed figures of the truth's `signal` in `run`, from its `/smoothed` channel.
pub fn smoothed_figures(run: &Run, options: &Options, signal: &str) -> anyhow::Result<SmoothedFigures> {
    let report = analyse(run, &Options { estimate_topic: SMOOTHED.into(), ..options.clone() })?;
    let pair = report
        .pairs
        .iter()
        .find(|p| p.truth == signal)
        .ok_or_else(|| anyhow::anyhow!("{} has no smoothed {signal}", run.file.display()))?;
    let Metrics { correlation, rmse_converged, .. } = pair.metrics;
    Ok(SmoothedFigures {
        lag: SMOOTHING_LAG,
        correlation,
        rmse_converged,
        one_sigma_coverage: pair.one_sigma_coverage,
        two_sigma_coverage: pair.two_sigma_coverage,
    })
}
