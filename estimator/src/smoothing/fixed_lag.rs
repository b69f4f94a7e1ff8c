//! Fixed-lag smoothing: the estimate of the sample `L` samples back given the
//! measurements up to now, step by step, in bounded memory, without allocating.
//!
//! It is the fixed-interval backward pass (`fixed_interval.rs`) unrolled forward.
//! With `Gⱼ = Cⱼ·(P⁻ⱼ₊₁)⁻¹` the gain of the step from `tⱼ` and `Bⱼᵢ = Gⱼ·Gⱼ₊₁⋯Gᵢ₋₁`
//! (`Bⱼⱼ = I`), expanding `m_s = m + G·(m_s' − m⁻)` and `P_s = P + G·(P_s' − P⁻)·Gᵀ`
//! from the last sample `k` gives
//!
//! ```text
//! m_{j|k} = mⱼ + Σᵢ₌ⱼ₊₁..ₖ Bⱼᵢ·(mᵢ − m⁻ᵢ),     P_{j|k} = Pⱼ + Σᵢ₌ⱼ₊₁..ₖ Bⱼᵢ·(Pᵢ − P⁻ᵢ)·Bⱼᵢᵀ,
//! ```
//!
//! so a new step `k → k + 1` adds one term to every instant still within the lag:
//! `Bⱼ ← Bⱼ·Gₖ`, then `Bⱼ·(mₖ₊₁ − m⁻ₖ₊₁)` to its mean and the diagonal of
//! `Bⱼ·(Pₖ₊₁ − P⁻ₖ₊₁)·Bⱼᵀ` to its variances. Only the rows of `Bⱼ` of the
//! smoothed states are kept: per step `2·p·n²` per instant for `p` smoothed states
//! of `n`, on `L` instants, after the gain's `n³`. The result is the fixed-interval
//! smoother's on the measurements up to `k`, to rounding, whatever the filter kind:
//! the filter's own cross-covariance and the prediction its update started from are
//! the [`Transition`].

use nalgebra::{DMatrix, DVector};

use crate::error::{FilterError, Stage};
use crate::gaussian::Gaussian;
use crate::linalg::{cholesky_in_place, dot, solve_lower, Lanes};

/// What a smoother needs of one prediction of a filter from `t` to `t'`: the
/// link between the two instants and the Gaussian the update at `t'` started from.
#[derive(Debug, Clone, PartialEq)]
pub struct Transition {
    /// `Cov(x(t), x(t'))` given the measurements up to `t`.
    pub cross: DMatrix<f64>,
    /// The predicted Gaussian at `t'`, as the update there started from it.
    pub predicted: Gaussian,
}

impl Transition {
    /// A transition of `n` states, zero.
    pub fn zeros(n: usize) -> Self {
        Self {
            cross: DMatrix::zeros(n, n),
            predicted: Gaussian { mean: DVector::zeros(n), covariance: DMatrix::zeros(n, n) },
        }
    }
}

/// The smoothed states at one instant, as the smoother shows them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaggedEstimate<'a> {
    /// The instant they describe (s).
    pub time: f64,
    /// The smoothed means of the smoothed states, in their order.
    pub means: &'a [f64],
    /// Their smoothed variances.
    pub variances: &'a [f64],
}

/// A fixed-lag smoother of the states `states` of an `n`-state filter, `lag`
/// samples back: a ring of the last `lag + 1` instants, each with its smoothed
/// means and variances so far and the rows of `Bⱼ` for those states.
#[derive(Debug, Clone)]
pub struct FixedLagSmoother {
    n: usize,
    states: Vec<usize>,
    capacity: usize,
    /// Ring position of the oldest instant, and how many are held.
    head: usize,
    len: usize,
    times: Vec<f64>,
    /// `p` per instant.
    means: Vec<f64>,
    variances: Vec<f64>,
    /// `Bⱼᵀ` restricted to the smoothed states: `n × p` per instant, column
    /// `a` the row of `Bⱼ` of state `states[a]`.
    rows: Vec<f64>,
    /// The step being added.
    step: StepTerms,
    /// One instant, advanced over a step not yet added ([`Self::estimate_with`]).
    scratch_rows: Vec<f64>,
    scratch_means: Vec<f64>,
    scratch_variances: Vec<f64>,
}

impl FixedLagSmoother {
    /// A smoother of the states `states` (indices into the `n` states), `lag`
    /// samples back. Empty until [`Self::start`].
    pub fn new(n: usize, states: &[usize], lag: usize) -> Result<Self, FilterError> {
        if states.is_empty() || states.iter().any(|&s| s >= n) {
            return Err(FilterError::InvalidSetting(format!(
                "a fixed-lag smoother needs states among the {n}, got {states:?}"
            )));
        }
        let p = states.len();
        let capacity = lag.checked_add(1).ok_or_else(|| FilterError::InvalidSetting("lag too long".into()))?;
        Ok(Self {
            n,
            states: states.to_vec(),
            capacity,
            head: 0,
            len: 0,
            times: vec![0.0; capacity],
            means: vec![0.0; capacity * p],
            variances: vec![0.0; capacity * p],
            rows: vec![0.0; capacity * n * p],
            step: StepTerms {
                gain_t: DMatrix::zeros(n, n),
                factor: DMatrix::zeros(n, n),
                delta_mean: DVector::zeros(n),
                delta_covariance: DMatrix::zeros(n, n),
                advanced: DVector::zeros(n),
                spread: DVector::zeros(n),
            },
            scratch_rows: vec![0.0; n * p],
            scratch_means: vec![0.0; p],
            scratch_variances: vec![0.0; p],
        })
    }

    /// The lag in samples.
    pub fn lag(&self) -> usize {
        self.capacity - 1
    }

    /// The smoothed states.
    pub fn states(&self) -> &[usize] {
        &self.states
    }

    /// Starts again from the filtered belief `mean`, `covariance` at `time`:
    /// the instants before can no longer be smoothed.
    pub fn start(&mut self, time: f64, mean: &DVector<f64>, covariance: &DMatrix<f64>) {
        self.head = 0;
        self.len = 0;
        self.append(time, mean, covariance);
    }

    /// Adds the step to `time`: the filter's `transition` to it and its
    /// filtered belief there. When the step cannot be added (a singular
    /// prediction, a non-finite term) the smoother starts again from that
    /// belief ([`Self::start`]) and says why.
    pub fn push(
        &mut self,
        time: f64,
        transition: &Transition,
        mean: &DVector<f64>,
        covariance: &DMatrix<f64>,
    ) -> Result<(), FilterError> {
        let advanced = self.step.prepare(transition, mean, covariance).and_then(|()| {
            if self.len == self.capacity {
                self.head = (self.head + 1) % self.capacity;
                self.len -= 1;
            }
            let (p, np) = (self.states.len(), self.n * self.states.len());
            for k in 0..self.len {
                let slot = (self.head + k) % self.capacity;
                self.step.advance(
                    &mut self.rows[slot_range(slot, np)],
                    &mut self.means[slot_range(slot, p)],
                    &mut self.variances[slot_range(slot, p)],
                )?;
            }
            Ok(())
        });
        match advanced {
            Ok(()) => {
                self.append(time, mean, covariance);
                Ok(())
            }
            Err(error) => {
                self.start(time, mean, covariance);
                Err(error)
            }
        }
    }

    /// The oldest instant held: `lag` samples before the last one added once
    /// that many were, else the first.
    pub fn estimate(&self) -> Option<LaggedEstimate<'_>> {
        (self.len > 0).then(|| {
            let p = self.states.len();
            let slot = self.head;
            LaggedEstimate {
                time: self.times[slot],
                means: &self.means[slot_range(slot, p)],
                variances: &self.variances[slot_range(slot, p)],
            }
        })
    }

    /// What [`Self::estimate`] would show after [`Self::push`] of this step to
    /// `time`, without adding it (a read before the step is final): where the
    /// push would start again, the step's own belief.
    pub fn estimate_with(
        &mut self,
        time: f64,
        transition: &Transition,
        mean: &DVector<f64>,
        covariance: &DMatrix<f64>,
    ) -> LaggedEstimate<'_> {
        if self.len == 0 || self.capacity == 1 || self.step.prepare(transition, mean, covariance).is_err() {
            return self.own_estimate(time, mean, covariance);
        }
        let index = usize::from(self.len == self.capacity);
        let slot = (self.head + index) % self.capacity;
        let (p, np) = (self.states.len(), self.n * self.states.len());
        self.scratch_rows.copy_from_slice(&self.rows[slot_range(slot, np)]);
        self.scratch_means.copy_from_slice(&self.means[slot_range(slot, p)]);
        self.scratch_variances.copy_from_slice(&self.variances[slot_range(slot, p)]);
        if self.step.advance(&mut self.scratch_rows, &mut self.scratch_means, &mut self.scratch_variances).is_err() {
            return self.own_estimate(time, mean, covariance);
        }
        LaggedEstimate { time: self.times[slot], means: &self.scratch_means, variances: &self.scratch_variances }
    }

    /// The smoothed states of the filtered belief `mean`, `covariance` at
    /// `time` (an estimate with nothing after it to smooth with).
    pub fn own_estimate(&mut self, time: f64, mean: &DVector<f64>, covariance: &DMatrix<f64>) -> LaggedEstimate<'_> {
        for (a, &s) in self.states.iter().enumerate() {
            self.scratch_means[a] = mean[s];
            self.scratch_variances[a] = covariance[(s, s)];
        }
        LaggedEstimate { time, means: &self.scratch_means, variances: &self.scratch_variances }
    }

    /// The instants held, oldest first, as words for a saved state:
    /// `[count, then per instant: time, means, variances, rows of B]`.
    pub fn save(&self, out: &mut Vec<f64>) {
        let p = self.states.len();
        let np = self.n * p;
        out.push(self.len as f64);
        for k in 0..self.len {
            let slot = (self.head + k) % self.capacity;
            out.push(self.times[slot]);
            out.extend_from_slice(&self.means[slot_range(slot, p)]);
            out.extend_from_slice(&self.variances[slot_range(slot, p)]);
            out.extend_from_slice(&self.rows[slot_range(slot, np)]);
        }
    }

    /// Takes back what [`Self::save`] wrote, for a smoother of the same states
    /// and lag; returns the words it used. On error nothing changes.
    pub fn load(&mut self, words: &[f64]) -> Result<usize, FilterError> {
        let p = self.states.len();
        let per = 1 + 2 * p + self.n * p;
        let bad = |why: &str| FilterError::InvalidSetting(format!("a saved fixed-lag smoother {why}"));
        let count = *words.first().ok_or_else(|| bad("is empty"))?;
        if !(count >= 0.0 && count <= self.capacity as f64 && count.fract() == 0.0) {
            return Err(bad(&format!("holds {count} instants, at most {} fit", self.capacity)));
        }
        let count = count as usize;
        let used = 1 + count * per;
        let body = words.get(1..used).ok_or_else(|| bad("is truncated"))?;
        if body.iter().any(|v| !v.is_finite()) {
            return Err(bad("has non-finite values"));
        }
        let np = self.n * p;
        for (slot, instant) in body.chunks_exact(per).enumerate() {
            self.times[slot] = instant[0];
            self.means[slot_range(slot, p)].copy_from_slice(&instant[1..1 + p]);
            self.variances[slot_range(slot, p)].copy_from_slice(&instant[1 + p..1 + 2 * p]);
            self.rows[slot_range(slot, np)].copy_from_slice(&instant[1 + 2 * p..]);
        }
        (self.head, self.len) = (0, count);
        Ok(used)
    }

    /// A new instant: its filtered belief, `B = I` on its states.
    fn append(&mut self, time: f64, mean: &DVector<f64>, covariance: &DMatrix<f64>) {
        let slot = (self.head + self.len) % self.capacity;
        self.len += 1;
        self.times[slot] = time;
        let (n, p) = (self.n, self.states.len());
        let rows = &mut self.rows[slot_range(slot, n * p)];
        rows.fill(0.0);
        for (a, &s) in self.states.iter().enumerate() {
            self.means[slot * p + a] = mean[s];
            self.variances[slot * p + a] = covariance[(s, s)];
            rows[a * n + s] = 1.0;
        }
    }
}

/// The terms of one step: its gain and what the update changed.
#[derive(Debug, Clone)]
struct StepTerms {
    /// `Gᵀ = (P⁻)⁻¹·Cᵀ`.
    gain_t: DMatrix<f64>,
    /// The Cholesky factor of `P⁻`.
    factor: DMatrix<f64>,
    /// `m − m⁻`.
    delta_mean: DVector<f64>,
    /// `P − P⁻`.
    delta_covariance: DMatrix<f64>,
    /// `n`-vectors: a row of `B` advanced, and `(P − P⁻)·b`.
    advanced: DVector<f64>,
    spread: DVector<f64>,
}

impl StepTerms {
    /// `Gᵀ`, `m − m⁻` and `P − P⁻` of the step into the scratch.
    fn prepare(
        &mut self,
        transition: &Transition,
        mean: &DVector<f64>,
        covariance: &DMatrix<f64>,
    ) -> Result<(), FilterError> {
        let n = self.gain_t.nrows();
        let predicted = &transition.predicted;
        let fits = transition.cross.shape() == (n, n)
            && predicted.mean.len() == n
            && predicted.covariance.shape() == (n, n)
            && mean.len() == n
            && covariance.shape() == (n, n);
        if !fits {
            return Err(FilterError::InvalidSetting(format!("a smoothing step that is not of {n} states")));
        }
        // Gᵀ from P⁻·Gᵀ = Cᵀ: the Cholesky factor, then L·Y = Cᵀ and Lᵀ·Gᵀ = Y.
        self.factor.copy_from(&predicted.covariance);
        cholesky_in_place(self.factor.as_mut_slice(), n, n).map_err(|_| FilterError::NotPositiveDefinite {
            stage: Stage::Smooth,
            matrix: "predicted covariance P⁻",
        })?;
        self.gain_t.tr_copy_from(&transition.cross);
        let l = self.factor.as_slice();
        let gain = self.gain_t.as_mut_slice();
        if !solve_lower(l, n, n, gain, n, n) {
            return Err(FilterError::NotPositiveDefinite { stage: Stage::Smooth, matrix: "predicted covariance P⁻" });
        }
        for column in gain.chunks_exact_mut(n) {
            for i in (0..n).rev() {
                let tail = dot(&l[i * n + i + 1..(i + 1) * n], &column[i + 1..]);
                column[i] = (column[i] - tail) / l[i * n + i];
            }
        }
        self.delta_mean.copy_from(mean);
        self.delta_mean -= &predicted.mean;
        self.delta_covariance.copy_from(covariance);
        self.delta_covariance -= &predicted.covariance;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(self.gain_t.as_slice())
            && finite(self.delta_mean.as_slice())
            && finite(self.delta_covariance.as_slice()))
        {
            return Err(FilterError::NonFinite { stage: Stage::Smooth, quantity: "smoother gain or step" });
        }
        Ok(())
    }

    /// One instant over the step: each row `b` of its `B` becomes `Gᵀ·b` (a
    /// row of `B·G`), its mean gains `b·Δm` and its variance `b·ΔP·b`; with
    /// AVX2 and FMA where the filters use them (`linalg::with_avx2!`), so a
    /// read before a step is final and the step itself take the same kernels.
    fn advance(&mut self, rows: &mut [f64], means: &mut [f64], variances: &mut [f64]) -> Result<(), FilterError> {
        crate::linalg::with_avx2!(fn<>(
            lanes,
            terms: &mut StepTerms = self,
            rows: &mut [f64] = rows,
            means: &mut [f64] = means,
            variances: &mut [f64] = variances
        ) -> Result<(), FilterError> {
            terms.advance_with(lanes, rows, means, variances)
        })
    }

    /// [`Self::advance`] on `lanes`: the two products are combinations of the
    /// columns of `Gᵀ` and of `ΔP` by the row ([`Lanes::combine`]).
    #[inline(always)]
    fn advance_with<L: Lanes>(
        &mut self,
        lanes: L,
        rows: &mut [f64],
        means: &mut [f64],
        variances: &mut [f64],
    ) -> Result<(), FilterError> {
        let n = self.gain_t.nrows();
        for (a, row) in rows.chunks_exact_mut(n).enumerate() {
            self.advanced.fill(0.0);
            lanes.combine(self.advanced.as_mut_slice(), row, self.gain_t.as_slice(), n);
            row.copy_from_slice(self.advanced.as_slice());
            self.spread.fill(0.0);
            lanes.combine(self.spread.as_mut_slice(), row, self.delta_covariance.as_slice(), n);
            means[a] += dot(row, self.delta_mean.as_slice());
            variances[a] += dot(row, self.spread.as_slice());
            if !(means[a].is_finite() && variances[a].is_finite()) {
                return Err(FilterError::NonFinite { stage: Stage::Smooth, quantity: "smoothed estimate" });
            }
        }
        Ok(())
    }
}

/// The entries of ring slot `slot` in a buffer of `width` entries per slot.
#[inline(always)]
fn slot_range(slot: usize, width: usize) -> std::ops::Range<usize> {
    slot * width..(slot + 1) * width
}
