//! Comparison metrics between a true and an estimated signal, as the studies
//! report them. Definitions (the papers give only the RMSE formula, eq. (24)):
//!
//! * **correlation**: Pearson's coefficient over the whole record;
//! * **running RMSE** at sample k: the RMSE over the trailing window of `w`
//!   samples ending at k (fewer at the start, so its first value is the
//!   first error) — it shows the start-up transient and then fluctuates, as
//!   the papers' RMSE plots do;
//! * **convergence time**: the first time after which the running RMSE never
//!   exceeds twice the RMSE of the second half of the record;
//! * **RMSE after convergence**, and the **maximum running RMSE after
//!   convergence** (the papers' "then stays under …");
//! * **steady running RMSE mean and variance**: over the converged part;
//! * **relative error of the final value** `|ê_N − e_N| / |e_N|`, meaningful
//!   for constant parameters (aerodynamic coefficients).

/// The metrics of one estimated signal against its truth.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Metrics {
    /// Pearson correlation coefficient over the whole record.
    pub correlation: f64,
    /// RMSE over the whole record.
    pub rmse: f64,
    /// Simulation time from which the estimate is taken to have converged (s).
    pub convergence_time: f64,
    /// RMSE from the convergence time on.
    pub rmse_converged: f64,
    /// Largest running RMSE (usually at the start).
    pub running_rmse_peak: f64,
    /// Largest running RMSE from the convergence time on.
    pub running_rmse_max_converged: f64,
    /// Mean of the running RMSE from the convergence time on.
    pub running_rmse_mean_converged: f64,
    /// Variance of the running RMSE from the convergence time on.
    pub running_rmse_var_converged: f64,
    /// Relative error of the last sample, `|estimate − truth| / |truth|`; `None` where the
    /// truth ends near zero (below [`NEAR_ZERO`] of its RMS: a train at rest, a load
    /// passing zero), where the ratio says nothing of the estimate.
    pub final_relative_error: Option<f64>,
}

/// Pearson's correlation coefficient; NaN when either signal is constant.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    sab / (saa * sbb).sqrt()
}

/// Root-mean-square of `a − b`.
pub fn rmse(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt()
}

/// Trailing-window RMSE of `a − b` (window `w` samples, partial at the start).
pub fn running_rmse(a: &[f64], b: &[f64], w: usize) -> Vec<f64> {
    let n = a.len().min(b.len());
    let sq = |k: usize| (a[k] - b[k]).powi(2);
    let mut out = Vec::with_capacity(n);
    let mut sum = 0.0;
    // The running sum keeps an absolute rounding error of a few eps times the
    // largest sum it has held; re-summing the window exactly whenever the sum
    // falls 1000× below that peak (a large error leaving the window) keeps the
    // relative error near 1e-12, and every 4096 samples bounds any drift.
    let mut peak = 0.0_f64;
    for k in 0..n {
        sum += sq(k);
        if k >= w {
            sum -= sq(k - w);
        }
        peak = peak.max(sum);
        if k % 4096 == 4095 || sum < 1e-3 * peak {
            sum = ((k + 1).saturating_sub(w)..=k).map(sq).sum();
            peak = sum;
        }
        let count = (k + 1).min(w);
        out.push((sum.max(0.0) / count as f64).sqrt());
    }
    out
}

/// All metrics of `estimate` against `truth`, sampled every `dt` from the
/// simulation time `t0`, with a running-RMSE window of `window` seconds.
pub fn compare(truth: &[f64], estimate: &[f64], t0: f64, dt: f64, window: f64) -> Metrics {
    let w = ((window / dt).round() as usize).max(1);
    compare_with_running_rmse(truth, estimate, &running_rmse(truth, estimate, w), t0, dt)
}

/// [`compare`] given the running RMSE already computed (by [`running_rmse`]).
pub fn compare_with_running_rmse(truth: &[f64], estimate: &[f64], running: &[f64], t0: f64, dt: f64) -> Metrics {
    let n = truth.len();
    let steady = rmse(&truth[n / 2..], &estimate[n / 2..]);
    let threshold = 2.0 * steady;
    let converged_from = running.iter().rposition(|&r| r > threshold).map_or(0, |k| k + 1).min(n - 1);
    let tail = &running[converged_from..];
    let mean = tail.iter().sum::<f64>() / tail.len() as f64;
    Metrics {
        correlation: correlation(truth, estimate),
        rmse: rmse(truth, estimate),
        convergence_time: t0 + converged_from as f64 * dt,
        rmse_converged: rmse(&truth[converged_from..], &estimate[converged_from..]),
        running_rmse_peak: running.iter().copied().fold(0.0, f64::max),
        running_rmse_max_converged: tail.iter().copied().fold(0.0, f64::max),
        running_rmse_mean_converged: mean,
        running_rmse_var_converged: tail.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / tail.len() as f64,
        final_relative_error: final_relative_error(truth, estimate),
    }
}

/// Below this fraction of the truth's RMS, the truth's last value is near zero.
pub const NEAR_ZERO: f64 = 1e-3;

/// `|estimate − truth| / |truth|` at the last sample, unless the truth ends near zero.
fn final_relative_error(truth: &[f64], estimate: &[f64]) -> Option<f64> {
    let (&last, &estimated) = (truth.last()?, estimate.last()?);
    let rms = (truth.iter().map(|t| t * t).sum::<f64>() / truth.len() as f64).sqrt();
    (last.abs() > NEAR_ZERO * rms).then(|| (estimated - last).abs() / last.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_of_a_signal_with_an_affine_copy_is_one() {
        let a: Vec<f64> = (0..100).map(|k| (k as f64 * 0.1).sin()).collect();
        let b: Vec<f64> = a.iter().map(|x| 3.0 * x - 1.0).collect();
        assert!((correlation(&a, &b) - 1.0).abs() < 1e-12);
        let c: Vec<f64> = a.iter().map(|x| -x).collect();
        assert!((correlation(&a, &c) + 1.0).abs() < 1e-12);
    }

    #[test]
    fn running_rmse_starts_at_the_first_error_and_matches_a_direct_window() {
        let a = vec![0.0; 10_000];
        let b: Vec<f64> = (0..10_000).map(|k| if k == 0 { 5.0 } else { (k as f64).cos() }).collect();
        let r = running_rmse(&a, &b, 100);
        assert_eq!(r[0], 5.0);
        for k in [150, 4095, 4096, 9999] {
            let direct = rmse(&a[k - 99..=k], &b[k - 99..=k]);
            assert!((r[k] - direct).abs() < 1e-12, "k = {k}");
        }
    }

    #[test]
    fn running_rmse_stays_exact_after_a_large_error_leaves_the_window() {
        let n = 13_000;
        let a = vec![0.0; n];
        let b: Vec<f64> =
            (0..n).map(|k| if k < 500 { 10.0 } else { 1e-3 * ((k * 7919 % 97) as f64 / 48.0 - 1.0) }).collect();
        let r = running_rmse(&a, &b, 3000);
        for k in [3499, 3500, 3501, 5000, 8191, 12_999] {
            let direct = rmse(&a[k + 1 - 3000..=k], &b[k + 1 - 3000..=k]);
            assert!((r[k] - direct).abs() <= 1e-12 * direct, "k = {k}: {} vs {direct}", r[k]);
        }
    }

    #[test]
    fn convergence_time_is_the_end_of_the_start_up_transient() {
        let dt = 0.01;
        let truth: Vec<f64> = (0..2000).map(|k| (k as f64 * dt).sin()).collect();
        // An estimate that is 10 off for the first second, then 0.01 off.
        let estimate: Vec<f64> =
            truth.iter().enumerate().map(|(k, x)| x + if k < 100 { 10.0 } else { 0.01 * (k as f64).sin() }).collect();
        let c = compare(&truth, &estimate, 2.0, dt, 0.5);
        assert!((c.convergence_time - 3.5).abs() < 0.02, "simulation time: {}", c.convergence_time);
        assert!(c.running_rmse_peak >= 10.0 - 1e-9);
        assert!(c.running_rmse_max_converged < 0.02);
        assert!(c.rmse_converged < 0.01);
    }

    #[test]
    fn a_truth_ending_near_zero_has_no_final_relative_error() {
        let estimate = [1.1, 2.2, 0.05];
        let ends_at_rest = compare(&[1.0, 2.0, 0.0], &estimate, 1.0, 0.1, 0.0);
        assert_eq!(ends_at_rest.final_relative_error, None, "a train at rest: |e|/0");
        let ends_moving = compare(&[1.0, 2.0, 0.1], &estimate, 1.0, 0.1, 0.0);
        assert!((ends_moving.final_relative_error.unwrap() - 0.5).abs() < 1e-12);
    }
}
