//! Fault signatures: which channel's wiring the other channels contradict.
//!
//! Where an unknown input follows a channel (each S2 or S3 axle box is driven
//! by its own wheel force), a flipped channel drags its force along: its own
//! innovations stay white and the channel's scores in `wiring.rs` see
//! nothing. The mistake shows only in the other channels (the bogie frame
//! above it), and there only through the filter's dynamics, a few samples
//! later. A test that knows those dynamics sees it: the generalised
//! likelihood ratio of an additive fault `β·r` on one channel
//! ([WillskyJones1976], docs/references.md), with the regressors `r` the channel's
//! prediction about its mean (a scale: a flipped sign, a unit) and 1 (an
//! offset: gravity left in).
//!
//! For each channel and regressor the fault's *signature* is followed: its
//! effect `μ` on the mean. With `F` and `H` the model linearised at the mean
//! (differences of the model, [`StateEstimator::transition_differences`]),
//! `P⁻`, `S = H·P⁻·Hᵀ + R` on the first pass's rows `a`, and the rows used
//! `u`:
//!
//! ```text
//! μ⁻ = F·μ⁺                                  (the prediction)
//! ρ  = r·e_c − H·μ⁻                          (its effect on the innovations, rows a)
//! μ⁺ = μ⁻ + P⁻·H_uᵀ·S_u⁻¹·ρ_u                (the update's gain)
//! ```
//!
//! The gain is that of the linearised model, not the filter's own: with the
//! filter's `S` and these `F`, `H` the recursion need not be stable, and it
//! diverged on S3 with deflection transducers (high gains).
//!
//! The evidence forgets over a quarter of the window, `λ = 1 − 4/window`
//! (over a whole window a short fault's evidence outlasted it, and with it
//! the verdict: in `kalfmu robustness`'s S3 flips `filter_healthy`
//! disagreed with the error in 21 % of the samples, against 9 % over a
//! quarter), and not at all from a sample with a gross error on some row (a
//! burst is no wiring): `a = Σ λʲ·ρ̃ᵀν̃` and
//! `B = Σ λ²ʲ·ρ̃ᵀρ̃` (whitened by the Cholesky factor of `S`), and the score
//! is `√(aᵀB⁻¹a)`: for a consistent filter `aᵀB⁻¹a` is χ² with two degrees
//! of freedom, so a score above `wiring_sigmas` = 8 comes by chance about
//! once in 1e14 samples. As in `wiring.rs`, a score counts only where the
//! fault it fits is wiring-sized (the fit `β̂` with `λʲ` weights: a scale
//! term beyond [`SCALE_TOLERANCE`], an offset beyond [`BIAS_TOLERANCE`] σ).
//! The fit's scale is that of the channel's *prediction*, which a flipped
//! channel has already dragged along, so its sign says nothing; once the
//! channel is left out, its own scores (`wiring.rs`) name the cause.
//!
//! The model is linearised at the predicted mean of each sample, not at the
//! last posterior: the two agree where the model is linear over a sample
//! (the vehicle models but for their dampers' kinks).

use nalgebra::{DMatrix, DVector};

use super::wiring::{forgetting, BIAS_TOLERANCE, SCALE_TOLERANCE};
use super::Supervisor;
use crate::error::FilterError;
use crate::filter::{Innovation, StateEstimator};
use crate::linalg::{cholesky_in_place, mul_to, solve_lower, solve_lower_transposed, tr_mul_add};

/// The offset of a difference, relative to each state's scale
/// ([`state_scale`]): small against the models' kinks, large against rounding.
pub(super) const PROBE: f64 = 1e-3;

/// State `i`'s scale for a difference of the model: its σ, or, where the
/// filter is certain of it (a state no noise reaches), its size.
pub(super) fn state_scale(filter: &dyn StateEstimator, i: usize) -> f64 {
    let std = filter.variance(i).max(0.0).sqrt();
    if std > 0.0 && std.is_finite() {
        std
    } else {
        filter.mean()[i].abs().max(1.0)
    }
}

/// Regressors per channel: its prediction about its mean (a scale), and 1 (an offset).
const KINDS: usize = 2;

/// The signatures and their evidence: the supervisor's memory of them.
#[derive(Debug, Clone)]
pub(super) struct Signatures {
    /// The effect on the mean of a unit fault, a column per channel and
    /// regressor (`2c` the scale, `2c + 1` the offset), after the last
    /// committed update (`n × 2m`; empty before the first).
    pub effect: DMatrix<f64>,
    /// Per channel, `a` (λʲ-weighted).
    pub evidence: Vec<[f64; KINDS]>,
    /// Per channel, `B` (λ²ʲ-weighted; `[xx, xy, yy]`).
    pub information: Vec<[f64; 3]>,
    /// Per channel, the fit's `Σ λʲ·ρ̃ᵀρ̃` (`[xx, xy, yy]`).
    pub fit_information: Vec<[f64; 3]>,
    /// The time of the belief `effect` is of (NaN: none).
    pub time: f64,
}

/// What a gate prepares for the commit.
#[derive(Debug, Clone, Default)]
pub(super) struct SignatureWork {
    /// `μ⁻`, then `μ⁺` (`n × 2m`).
    pub effect: DMatrix<f64>,
    /// `H` at the predicted mean (`m × n`).
    pub h: DMatrix<f64>,
    /// `P⁻` (`n × n`).
    pub p: DMatrix<f64>,
    /// `S = H·P⁻·Hᵀ + R` (`m × m`), and the first pass's rows.
    pub s: DMatrix<f64>,
    pub rows: Vec<usize>,
    /// Scratch: the probe offsets (`n × n`), `Hᵀ` and `P⁻·Hᵀ` (`n × m`), a
    /// Cholesky factor, vectors.
    offsets: DMatrix<f64>,
    ht: DMatrix<f64>,
    pht: DMatrix<f64>,
    factor: DMatrix<f64>,
    nu: DVector<f64>,
    /// `ρ` (`m × 2m`), `G` (`m × 2m`), `Hᵀ·G` (`n × 2m`), `L⁻¹·ρ_a`.
    rho: DMatrix<f64>,
    gain: DMatrix<f64>,
    spread: DMatrix<f64>,
    whitened: DMatrix<f64>,
    /// The states' scales (`σ`, or the size of a state the filter is certain
    /// of), each effect column's size in them, and one column of `ρ_u`.
    sigma: DVector<f64>,
    sizes: DVector<f64>,
    scratch: DVector<f64>,
    /// Prepared at this gate, its first pass still to come.
    prepared: bool,
    /// The first pass was made (the commit has something to learn from).
    ready: bool,
}

impl SignatureWork {
    /// The Cholesky factor of `S` on the first pass's rows that `keep`,
    /// in the top-left corner of `factor`; `false` where it fails.
    fn factor_s_on(&mut self, keep: impl Fn(usize) -> bool) -> bool {
        let m = self.factor.nrows();
        let mut count = 0;
        for (i, &a) in self.rows.iter().filter(|&&r| keep(r)).enumerate() {
            for (j, &b) in self.rows.iter().filter(|&&r| keep(r)).enumerate() {
                self.factor[(i, j)] = self.s[(a, b)];
            }
            count = i + 1;
        }
        cholesky_in_place(self.factor.as_mut_slice(), m, count).is_ok()
    }

    /// At the first pass of a gate the signatures were prepared for: keeps
    /// its rows.
    pub fn keep_first_pass(&mut self, innovation: &Innovation) {
        if !self.prepared {
            return;
        }
        self.prepared = false;
        self.rows.clear();
        self.rows.extend_from_slice(innovation.rows());
        self.ready = true;
    }
}

impl Default for Signatures {
    fn default() -> Self {
        Self {
            effect: DMatrix::zeros(0, 0),
            evidence: Vec::new(),
            information: Vec::new(),
            fit_information: Vec::new(),
            time: f64::NAN,
        }
    }
}

impl Signatures {
    fn reserve(&mut self, n: usize, m: usize) {
        if self.effect.nrows() != n || self.effect.ncols() != KINDS * m {
            self.effect = DMatrix::zeros(n, KINDS * m);
            self.evidence = vec![[0.0; KINDS]; m];
            self.information = vec![[0.0; 3]; m];
            self.fit_information = vec![[0.0; 3]; m];
            self.time = f64::NAN;
        }
    }

    /// Takes back what the memory saved (`memory.rs`): the effects of
    /// `states` states for `m` channels, then the per-channel sums; none
    /// when `states` is 0.
    pub fn load(&mut self, time: f64, states: usize, m: usize, floats: &[f64]) {
        if states == 0 {
            *self = Self::default();
            return;
        }
        self.effect = DMatrix::from_column_slice(states, KINDS * m, &floats[..states * KINDS * m]);
        let per_channel = &floats[states * KINDS * m..];
        self.evidence.clear();
        self.information.clear();
        self.fit_information.clear();
        for words in per_channel.chunks_exact(8) {
            self.evidence.push([words[0], words[1]]);
            self.information.push([words[2], words[3], words[4]]);
            self.fit_information.push([words[5], words[6], words[7]]);
        }
        self.time = time;
    }

    /// Drops every channel's evidence.
    pub fn forget_all(&mut self) {
        self.evidence.iter_mut().for_each(|a| *a = [0.0; KINDS]);
        self.information.iter_mut().for_each(|b| *b = [0.0; 3]);
        self.fit_information.iter_mut().for_each(|f| *f = [0.0; 3]);
    }

    /// The score of channel `c` where the fault it fits is wiring-sized (a
    /// scale term beyond [`SCALE_TOLERANCE`], an offset beyond
    /// [`BIAS_TOLERANCE`] times `sigma`, the channel's innovation σ), else 0.
    pub fn wiring_score(&self, c: usize, sigma: f64) -> f64 {
        let (score, fit) = self.score(c);
        let sized = fit[0].abs() > SCALE_TOLERANCE || (sigma > 0.0 && fit[1].abs() > BIAS_TOLERANCE * sigma);
        if sized {
            score
        } else {
            0.0
        }
    }

    /// The score of channel `c` and the fit behind it: `√(aᵀB⁻¹a)`, and `β̂`.
    fn score(&self, c: usize) -> (f64, [f64; KINDS]) {
        let (Some(a), Some(b), Some(f)) = (self.evidence.get(c), self.information.get(c), self.fit_information.get(c))
        else {
            return (0.0, [0.0; KINDS]);
        };
        let quadratic = |m: &[f64; 3], v: &[f64; 2]| -> Option<[f64; 2]> {
            let det = m[0] * m[2] - m[1] * m[1];
            (det > 1e-12 * (m[0] * m[2]).max(f64::MIN_POSITIVE))
                .then(|| [(m[2] * v[0] - m[1] * v[1]) / det, (m[0] * v[1] - m[1] * v[0]) / det])
        };
        let Some(solved) = quadratic(b, a) else { return (0.0, [0.0; KINDS]) };
        let chi2 = (a[0] * solved[0] + a[1] * solved[1]).max(0.0);
        (chi2.sqrt(), quadratic(f, a).unwrap_or([0.0; KINDS]))
    }
}

impl Supervisor {
    /// At a gate, before its first pass, with `filter` at the predicted
    /// belief: predicts the signatures to this sample, and keeps `H` and
    /// `P⁻` for the commit. Where the model cannot be differenced there
    /// (a non-finite value), the signatures start again: a test of the
    /// wiring never fails a step.
    pub(super) fn prepare_signatures(&mut self, filter: &mut dyn StateEstimator) {
        if self.predict_signatures(filter).is_err() {
            self.signature_work.prepared = false;
            self.signatures.effect.fill(0.0);
            self.signatures.forget_all();
            self.signatures.time = f64::NAN;
        }
    }

    fn predict_signatures(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        let work = &mut self.signature_work;
        work.ready = false;
        work.prepared = false;
        if !self.settings.wiring_signatures || !self.settings.wiring_sigmas.is_finite() {
            return Ok(());
        }
        let (n, m) = (filter.state_dim(), self.channels.len());
        self.signatures.reserve(n, m);
        if work.effect.nrows() != n || work.effect.ncols() != KINDS * m {
            work.effect = DMatrix::zeros(n, KINDS * m);
            work.h = DMatrix::zeros(m, n);
            work.p = DMatrix::zeros(n, n);
            work.s = DMatrix::zeros(m, m);
            work.rows = Vec::with_capacity(m);
            work.offsets = DMatrix::zeros(n, n);
            work.ht = DMatrix::zeros(n, m);
            work.pht = DMatrix::zeros(n, m);
            work.factor = DMatrix::zeros(m, m);
            work.nu = DVector::zeros(m);
            work.rho = DMatrix::zeros(m, KINDS * m);
            work.gain = DMatrix::zeros(m, KINDS * m);
            work.spread = DMatrix::zeros(n, KINDS * m);
            work.whitened = DMatrix::zeros(m, KINDS * m);
            work.sigma = DVector::zeros(n);
            work.sizes = DVector::zeros(KINDS * m);
            work.scratch = DVector::zeros(m);
        }
        let sigma: &mut DVector<f64> = &mut work.sigma;
        for i in 0..n {
            sigma[i] = state_scale(filter, i);
        }
        // The prediction: each effect column scaled to a small offset, F·δ, scaled back.
        work.effect.copy_from(&self.signatures.effect);
        let dt = filter.time() - self.signatures.time;
        if dt > 0.0 {
            for (mut column, size) in work.effect.column_iter_mut().zip(work.sizes.iter_mut()) {
                *size = column.iter().zip(sigma.iter()).fold(0.0_f64, |s, (v, g)| s.max(v.abs() / g));
                if *size == 0.0 || !size.is_finite() {
                    column.fill(0.0);
                    continue;
                }
                column *= PROBE / *size;
            }
            let input = self.work.before.input.as_slice();
            filter.transition_differences(input, dt, &mut work.effect)?;
            for (mut column, &size) in work.effect.column_iter_mut().zip(work.sizes.iter()) {
                if size > 0.0 && size.is_finite() {
                    column *= size / PROBE;
                }
            }
        }
        work.offsets.fill(0.0);
        for i in 0..n {
            work.offsets[(i, i)] = PROBE * sigma[i];
        }
        filter.observation_differences(&work.offsets, &mut work.h)?;
        for i in 0..n {
            let scale = 1.0 / (PROBE * sigma[i]);
            work.h.column_mut(i).scale_mut(scale);
        }
        filter.write_covariance(&mut work.p);
        // S = H·P⁻·Hᵀ + R of the linearised model, so that the signatures'
        // gain is the Kalman gain of the very `F`, `H` they are propagated
        // with (with the filter's own `S` the two disagree where the gain is
        // high, and the signatures' recursion can diverge: S3 with its
        // deflection transducers).
        work.h.transpose_to(&mut work.ht);
        mul_to(work.p.as_slice(), n, n, n, work.ht.as_slice(), n, m, work.pht.as_mut_slice(), n);
        mul_to(work.h.as_slice(), m, m, n, work.pht.as_slice(), n, m, work.s.as_mut_slice(), m);
        work.s += filter.noise().r();
        work.prepared = true;
        Ok(())
    }

    /// At a commit: the signatures' effect on this sample's innovations, the
    /// evidence (unless the belief is in flux), and their update through the
    /// rows used.
    pub(super) fn commit_signatures(&mut self, flux: bool) {
        if !std::mem::take(&mut self.signature_work.ready) {
            return;
        }
        // A sample with a gross error on some row is no evidence of wiring:
        // clipped, a burst would still pass for a signature (`wiring.rs`
        // leaves such rows out of a channel's own scores alike).
        let reacquire_after = self.settings.reacquire_after;
        let mut rows = self.pending.rows.iter().zip(&self.channels);
        let gross = rows.any(|(&row, channel)| channel.gross_error(row, reacquire_after));
        // Where `S` cannot be factorised, the effects stay as predicted.
        self.learn_and_update_signatures(flux || gross);
        self.signatures.effect.copy_from(&self.signature_work.effect);
        self.signatures.time = self.work.before.time;
        let sums = self.signatures.evidence.iter().flatten().chain(self.signatures.information.iter().flatten());
        if sums.chain(self.signatures.effect.iter()).any(|v| !v.is_finite()) {
            // A linearisation gone wrong (a model far from linear over a
            // sample): the signatures start again rather than carry it.
            self.signatures.effect.fill(0.0);
            self.signatures.forget_all();
        }
    }

    /// The evidence of this sample (unless `flux`) and `μ⁺` into the work's effects.
    fn learn_and_update_signatures(&mut self, flux: bool) {
        let work = &mut self.signature_work;
        let m = self.channels.len();
        let k = work.rows.len();
        let clip = self.thresholds.row.min(1e6).sqrt();
        let lambda = forgetting(self.settings.window / 4);
        if k == 0 || !work.factor_s_on(|_| true) {
            return;
        }
        for (i, &r) in work.rows.iter().enumerate() {
            work.nu[i] = self.work.residuals[r];
        }
        solve_lower(work.factor.as_slice(), m, k, work.nu.as_mut_slice(), m, 1);
        for v in work.nu.iter_mut().take(k) {
            *v = v.clamp(-clip, clip);
        }
        // ρ = r·e_c − H·μ⁻ for every column (all rows; the direct term on
        // the channel's own row where it is available).
        let n = work.effect.nrows();
        let columns = KINDS * m;
        mul_to(work.h.as_slice(), m, m, n, work.effect.as_slice(), n, columns, work.rho.as_mut_slice(), m);
        work.rho.neg_mut();
        for c in 0..m {
            if !work.rows.contains(&c) {
                continue;
            }
            let prediction = self.z_offered[c] - self.work.residuals[c] - self.channels[c].prediction_mean;
            if prediction.is_finite() {
                work.rho[(c, KINDS * c)] += prediction;
            }
            work.rho[(c, KINDS * c + 1)] += 1.0;
        }
        if !flux {
            // Whitened on the first pass's rows: L⁻¹·ρ_a.
            for column in 0..KINDS * m {
                for (i, &r) in work.rows.iter().enumerate() {
                    work.whitened[(i, column)] = work.rho[(r, column)];
                }
            }
            solve_lower(work.factor.as_slice(), m, k, work.whitened.as_mut_slice(), m, KINDS * m);
            for c in 0..m {
                if !work.rows.contains(&c) {
                    continue;
                }
                let (x, y) = (work.whitened.column(KINDS * c), work.whitened.column(KINDS * c + 1));
                let (x, y) = (x.rows(0, k), y.rows(0, k));
                let nu = work.nu.rows(0, k);
                let a = &mut self.signatures.evidence[c];
                a[0] = lambda * a[0] + x.dot(&nu);
                a[1] = lambda * a[1] + y.dot(&nu);
                let products = [x.dot(&x), x.dot(&y), y.dot(&y)];
                let (b, f) = (&mut self.signatures.information[c], &mut self.signatures.fit_information[c]);
                for j in 0..3 {
                    b[j] = lambda * lambda * b[j] + products[j];
                    f[j] = lambda * f[j] + products[j];
                }
            }
        }
        // μ⁺ = μ⁻ + P⁻·Hᵀ·G, G = S_u⁻¹·ρ_u on the rows used (zero elsewhere).
        let rows = &self.pending.rows;
        let is_used = |r: &&usize| rows[**r] == super::RowOutcome::Used;
        let used = work.rows.iter().filter(is_used).count();
        if used > 0 {
            // The factor of S on the rows used only, in place of the first pass's.
            if used < k && !work.factor_s_on(|r| rows[r] == super::RowOutcome::Used) {
                return;
            }
            work.gain.fill(0.0);
            for column in 0..KINDS * m {
                let rho = &mut work.scratch;
                for (i, &r) in work.rows.iter().filter(is_used).enumerate() {
                    rho[i] = work.rho[(r, column)];
                }
                solve_lower(work.factor.as_slice(), m, used, rho.as_mut_slice(), m, 1);
                solve_lower_transposed(work.factor.as_slice(), m, used, rho.as_mut_slice());
                for (i, &r) in work.rows.iter().filter(is_used).enumerate() {
                    work.gain[(r, column)] = rho[i];
                }
            }
            // Hᵀ·G, then P⁻·(Hᵀ·G) added as P⁻ᵀ·(Hᵀ·G) (P⁻ is symmetric).
            work.spread.fill(0.0);
            let (h, gain, spread) = (work.h.as_slice(), work.gain.as_slice(), work.spread.as_mut_slice());
            tr_mul_add(h, m, n, m, gain, m, columns, spread, n);
            tr_mul_add(work.p.as_slice(), n, n, n, work.spread.as_slice(), n, columns, work.effect.as_mut_slice(), n);
        }
    }
}
