//! The innovation log-likelihood of a filter over recorded samples: the prediction-error
//! decomposition of the Gaussian likelihood of the measurements [Schweppe1965], the
//! criterion of maximum-likelihood noise identification [Mehra1970]:
//!
//! ```text
//! ℓ = Σ_k −½ (ln det S_k + ν_kᵀ S_k⁻¹ ν_k + m_k ln 2π)
//! ```
//!
//! with `ν_k`, `S_k` and `m_k` the innovation, its covariance and the rows used by the
//! update at sample `k` (`estimator::Innovation`, whose `log_likelihood` is this term).
//! The filter runs as the FMU runs it (`fmu/src/timing.rs`): its belief starts at the
//! first sample; at each sample the controls of that sample are held, the measurement
//! updates (missing rows left out), and the prediction to the next sample uses the
//! controls held over the interval; samples absent from the log are predictions only.
//!
//! **No gate, a cap.** The FMU's innovation gate would leave rows out depending on the
//! parameters, so the likelihood would jump as a row crosses the gate. Instead a row whose
//! normalised innovation `r = ν_i/√S_ii` exceeds the cap `c` (default 4) is capped twice,
//! both smoothly in the parameters (twice differentiable, so that the finite-difference
//! curvature of `intervals.rs` stays meaningful when many rows are near the cap):
//!
//! - in the likelihood, its term `−r²/2` becomes `−T(r)` with, for `u = |r| − c > 0`,
//!   `T = c²/2 + c²·ln(|r|/c) + u²·e^{−u/c}`: the Gaussian core joined, with its value,
//!   slope and curvature, to a logarithmic tail. The tail bounds the row's influence on
//!   the scale of `S` (`|r|·T'(r)` stays below `1.8·c²` and tends to `c²`: a gross error
//!   pulls a noise level as a row near the cap would), where a Huber (linear) tail
//!   [Huber1964] would pull it in proportion to the error. A bounded (redescending) tail
//!   would remove even that, but it has a degenerate maximum — `S → 0` with every row an
//!   outlier — which the logarithmic one has not as long as `c > 1` (per row, `ln(1/σ)`
//!   from `ln det S` against `c²·ln(1/σ)` from the tail);
//! - in the filter (`winsorise`), the row is taken at `ẑ_i + √S_ii·ψ(r)` with
//!   `ψ = ±(c + (c/2)·tanh(2u/c))`, which joins the identity at `c` with its slope and
//!   curvature and saturates at `1.5·c` (the update redone from the belief before it; `ẑ`
//!   and `S` do not depend on `z`), so the gross error does not drag the state and make
//!   the rows after it large too. The row's Gaussian term, `−ψ²/2`, is then replaced by
//!   `−T(r)`.
//!
//! For a consistent filter a row exceeds 4σ with probability 6·10⁻⁵, so the cap leaves a
//! clean log's fit as it is. Far from the optimum (a start decades off) most rows exceed
//! the cap, and a winsorising filter could not follow the data at all: the fit therefore
//! searches without winsorising and refines with it (`fit.rs`).
//!
//! A filter that fails (a factorisation, a non-finite state) at a trial point makes that
//! point's likelihood `−∞`, which the optimiser treats as a very bad point, not an error.

use estimator::StateEstimator;
use rayon::prelude::*;

use crate::optimise::Objective;
use crate::record::Record;

/// What builds the filter whose likelihood is fitted: from parameter values (natural
/// units, each positive; the fit works on their logarithms) to a filter ready at the
/// first sample.
pub trait FilterFactory: Sync {
    /// The number of parameters a filter is built from.
    fn parameter_count(&self) -> usize;
    /// The filter with these parameter values, its belief at `start_time`.
    fn build(&self, values: &[f64], start_time: f64) -> Result<Box<dyn StateEstimator>, String>;
    /// The filter's sample time (s): one update and one prediction per sample.
    fn sample_time(&self) -> f64;
}

/// The robust cap on a row's normalised innovation (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustCap {
    /// `c`: rows with `|ν_i/√S_ii| > c` count with a logarithmic tail; infinite: no cap.
    pub threshold: f64,
    /// Whether the filter takes such rows at the cap (else as they are).
    pub winsorise: bool,
}

impl RobustCap {
    /// No cap: the plain Gaussian likelihood of the filter on the data as they are.
    pub const NONE: RobustCap = RobustCap { threshold: f64::INFINITY, winsorise: false };
    /// `c = 4`, winsorising: a clean row of a consistent filter exceeds it once in 16 000.
    pub const DEFAULT: RobustCap = RobustCap { threshold: 4.0, winsorise: true };

    /// A cap at `threshold` (infinite: none), winsorising.
    pub fn at(threshold: f64) -> Self {
        Self { threshold, winsorise: threshold.is_finite() }
    }

    /// Whether it caps anything.
    pub fn is_active(&self) -> bool {
        self.threshold.is_finite()
    }

    /// The same cap in the likelihood only, the filter taking the data as they are.
    pub fn in_likelihood_only(self) -> Self {
        Self { winsorise: false, ..self }
    }
}

impl Default for RobustCap {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The likelihood of one parameter vector over one or more records, and what the
/// consistency check needs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Evaluation {
    /// `ℓ`, with the cap's Huber terms.
    pub log_likelihood: f64,
    /// Samples whose update used at least one row.
    pub updates: usize,
    /// Measurement rows used, over all updates.
    pub rows: usize,
    /// `Σ νᵀS⁻¹ν` over the updates (the rows beyond the cap included).
    pub nis: f64,
    /// Rows beyond the cap.
    pub capped_rows: usize,
    /// The first filter failure, if the filter failed: the likelihood is then `−∞`.
    pub failure: Option<String>,
}

impl Evaluation {
    /// `ℓ`, or `−∞` when the filter failed or `ℓ` is not a number.
    pub fn value(&self) -> f64 {
        if self.failure.is_some() || self.log_likelihood.is_nan() {
            f64::NEG_INFINITY
        } else {
            self.log_likelihood
        }
    }

    /// The mean NIS per row used: 1 for a consistent filter.
    pub fn nis_per_row(&self) -> f64 {
        self.nis / self.rows as f64
    }

    /// The evaluation of several records together (independent runs: their terms add).
    fn add(&mut self, other: Evaluation) {
        self.log_likelihood += other.log_likelihood;
        self.updates += other.updates;
        self.rows += other.rows;
        self.nis += other.nis;
        self.capped_rows += other.capped_rows;
        if self.failure.is_none() {
            self.failure = other.failure;
        }
    }

    fn failed(mut self, what: String) -> Self {
        self.failure = Some(what);
        self
    }
}

/// Runs `filter` (its belief at the first sample) over `record` on the grid of
/// `sample_time`, and sums the likelihood of its innovations.
pub fn evaluate(filter: &mut dyn StateEstimator, record: &Record, sample_time: f64, cap: RobustCap) -> Evaluation {
    let mut sum = Evaluation::default();
    let Some(&start) = record.times().first() else { return sum };
    let mut z = vec![0.0; record.measurement_dim()];
    // The controls the filter holds: those of its last sample (at the start, its own).
    let mut held = filter.snapshot().input;
    let mut before = filter.snapshot();
    let mut grid = 0_u64;
    for k in 0..record.len() {
        let t = record.times()[k];
        let target = record.grid_index(k, sample_time);
        while grid < target {
            if let Err(e) = filter.predict(&held, sample_time) {
                return sum.failed(format!(
                    "the prediction to t = {} s failed: {e}",
                    start + (grid + 1) as f64 * sample_time
                ));
            }
            grid += 1;
        }
        let u = record.control(k);
        if u.iter().zip(&held).any(|(a, b)| a.to_bits() != b.to_bits()) {
            if let Err(e) = filter.hold_input(u) {
                return sum.failed(format!("holding the controls at t = {t} s failed: {e}"));
            }
            held.copy_from_slice(u);
        }
        z.copy_from_slice(record.measurement(k));
        if cap.winsorise {
            filter.snapshot_into(&mut before);
        }
        let (mut term, mut nis, rows, tails) = match filter.update(&z) {
            Ok(innovation) => {
                (innovation.log_likelihood(), innovation.nis(), innovation.rows_used(), cap.tails(innovation))
            }
            Err(e) => return sum.failed(format!("the update at t = {t} s failed: {e}")),
        };
        if rows == 0 {
            continue;
        }
        if cap.winsorise && tails.capped > 0 {
            winsorise(filter.innovation(), &mut z, cap.threshold);
            if let Err(e) = filter.restore(&before) {
                return sum.failed(format!("restoring the belief at t = {t} s failed: {e}"));
            }
            match filter.update(&z) {
                // The capped rows count −ψ²/2 in the Gaussian term; their tails replace it.
                Ok(innovation) => {
                    term = innovation.log_likelihood() + tails.winsorised_excess;
                    nis = innovation.nis();
                }
                Err(e) => return sum.failed(format!("the winsorised update at t = {t} s failed: {e}")),
            }
        } else {
            term += tails.excess;
        }
        if !term.is_finite() {
            return sum.failed(format!("the innovation at t = {t} s is not finite"));
        }
        sum.log_likelihood += term;
        sum.nis += nis;
        sum.rows += rows;
        sum.capped_rows += tails.capped;
        sum.updates += 1;
    }
    sum
}

/// Moves the rows of `z` whose normalised innovation exceeds `c` to `ẑ + σ·ψ(r)`.
fn winsorise(innovation: &estimator::Innovation, z: &mut [f64], c: f64) {
    for &row in innovation.rows() {
        let sigma = innovation.covariance()[(row, row)].sqrt();
        let r = innovation.residual()[row] / sigma;
        if r.abs() > c {
            z[row] = innovation.predicted()[row] + sigma * saturated(r, c);
        }
    }
}

/// `ψ(r)`: `r` up to `c`, then `±(c + (c/2)·tanh(2u/c))`, `u = |r| − c`.
fn saturated(r: f64, c: f64) -> f64 {
    if r.abs() <= c {
        r
    } else {
        r.signum() * (c + 0.5 * c * (2.0 * (r.abs() - c) / c).tanh())
    }
}

/// `T(r)`, the capped term's loss: `r²/2` up to `c`, then
/// `c²/2 + c²·ln(|r|/c) + u²·e^{−u/c}`, `u = |r| − c`.
fn tail_loss(r: f64, c: f64) -> f64 {
    let a = r.abs();
    if a <= c {
        0.5 * r * r
    } else {
        let u = a - c;
        0.5 * c * c + c * c * (a / c).ln() + u * u * (-u / c).exp()
    }
}

/// The rows of an update beyond the cap, and what their capped terms change.
#[derive(Debug, Clone, Copy, Default)]
struct Tails {
    /// How many rows.
    capped: usize,
    /// Added to the Gaussian term of the update that took the rows as they are:
    /// `Σ r²/2 − T(r)`.
    excess: f64,
    /// Added to the Gaussian term of the update that took them winsorised:
    /// `Σ ψ(r)²/2 − T(r)`.
    winsorised_excess: f64,
}

impl RobustCap {
    /// The rows of `innovation` beyond the cap.
    fn tails(&self, innovation: &estimator::Innovation) -> Tails {
        let c = self.threshold;
        let mut tails = Tails::default();
        if !self.is_active() {
            return tails;
        }
        for &row in innovation.rows() {
            let r = innovation.residual()[row] / innovation.covariance()[(row, row)].sqrt();
            if r.abs() > c {
                let loss = tail_loss(r, c);
                let psi = saturated(r, c);
                tails.excess += 0.5 * r * r - loss;
                tails.winsorised_excess += 0.5 * psi * psi - loss;
                tails.capped += 1;
            }
        }
        tails
    }
}

/// The likelihood of a filter factory's parameters over records: the objective of the fit.
pub struct Likelihood<'a, F: FilterFactory> {
    factory: &'a F,
    records: Vec<Record>,
    cap: RobustCap,
}

impl<'a, F: FilterFactory> Likelihood<'a, F> {
    /// The likelihood over `records` (independent runs of the same system).
    pub fn new(factory: &'a F, records: Vec<Record>, cap: RobustCap) -> Self {
        Self { factory, records, cap }
    }

    /// The same likelihood over the first `seconds` of each record.
    pub fn leading(&self, seconds: f64) -> Self {
        Self {
            factory: self.factory,
            records: self.records.iter().map(|r| r.leading(seconds)).collect(),
            cap: self.cap,
        }
    }

    /// The same likelihood with another cap.
    pub fn with_cap(&self, cap: RobustCap) -> Self {
        Self { factory: self.factory, records: self.records.clone(), cap }
    }

    /// The cap.
    pub fn cap(&self) -> RobustCap {
        self.cap
    }

    /// The records.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// The factory.
    pub fn factory(&self) -> &F {
        self.factory
    }

    /// The evaluation at parameter values `values` (natural units); the records run in
    /// parallel (rayon) when there are several.
    pub fn at_values(&self, values: &[f64]) -> Evaluation {
        let sample_time = self.factory.sample_time();
        let one = |record: &Record| -> Evaluation {
            let start = record.times().first().copied().unwrap_or(0.0);
            match self.factory.build(values, start) {
                Ok(mut filter) => evaluate(filter.as_mut(), record, sample_time, self.cap),
                Err(why) => Evaluation::default().failed(format!("the filter cannot be built: {why}")),
            }
        };
        let parts: Vec<Evaluation> = if self.records.len() > 1 {
            self.records.par_iter().with_max_len(1).map(one).collect()
        } else {
            self.records.iter().map(one).collect()
        };
        parts.into_iter().fold(Evaluation::default(), |mut sum, part| {
            sum.add(part);
            sum
        })
    }

    /// The evaluation at the parameters whose logarithms are `theta`.
    pub fn at(&self, theta: &[f64]) -> Evaluation {
        let values: Vec<f64> = theta.iter().map(|t| t.exp()).collect();
        self.at_values(&values)
    }
}

impl<F: FilterFactory> Objective for Likelihood<'_, F> {
    fn dimension(&self) -> usize {
        self.factory.parameter_count()
    }

    fn log_likelihood(&self, theta: &[f64]) -> f64 {
        self.at(theta).value()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Value, slope and curvature by central differences at `x`.
    fn derivatives(f: impl Fn(f64) -> f64, x: f64) -> (f64, f64, f64) {
        let h = 1e-4;
        (f(x), (f(x + h) - f(x - h)) / (2.0 * h), (f(x + h) - 2.0 * f(x) + f(x - h)) / (h * h))
    }

    #[test]
    fn the_cap_joins_the_gaussian_smoothly_and_bounds_a_gross_errors_pull() {
        let c = 4.0;
        for (below, above) in [(c - 1e-9, c + 1e-9), (-c + 1e-9, -c - 1e-9)] {
            for f in [|r| tail_loss(r, 4.0), |r| saturated(r, 4.0)] {
                let (v0, _, _) = derivatives(f, below);
                let (v1, _, _) = derivatives(f, above);
                assert!((v0 - v1).abs() < 1e-6);
            }
        }
        // Slope and curvature continue across c (computed on each side, away from it).
        let (_, s_in, k_in) = derivatives(|r| tail_loss(r, c), c - 1e-3);
        let (_, s_out, k_out) = derivatives(|r| tail_loss(r, c), c + 1e-3);
        assert!((s_in - s_out).abs() < 1e-2 && (k_in - k_out).abs() < 1e-2, "{s_in} {s_out} {k_in} {k_out}");
        let (_, p_in, q_in) = derivatives(|r| saturated(r, c), c - 1e-3);
        let (_, p_out, q_out) = derivatives(|r| saturated(r, c), c + 1e-3);
        assert!((p_in - p_out).abs() < 1e-2 && (q_in - q_out).abs() < 1e-2);
        // Bounded influence on the scale, |r|·T'(r) ≤ 1.8 c², tending to c²; T increasing.
        let mut previous = tail_loss(c, c);
        for k in 1..20_000 {
            let r = c + 0.01 * k as f64;
            let (v, slope, _) = derivatives(|r| tail_loss(r, c), r);
            assert!(r * slope <= 1.8 * c * c && v > previous, "at r = {r}");
            previous = v;
        }
        let (_, slope, _) = derivatives(|r| tail_loss(r, c), 1e4);
        assert!((1e4 * slope / (c * c) - 1.0).abs() < 1e-3);
        assert!((saturated(1e6, c) - 1.5 * c).abs() < 1e-9 && saturated(-1e6, c) < -1.5 * c + 1e-9);
    }
}
