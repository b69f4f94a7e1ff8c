//! Adaptive inverse-variance weights from running second moments: the paper's
//! eqs. (8)–(11) (after 翟翌立 et al.'s adaptive weighted fusion).
//!
//! With `x_i = x + e_i`, the errors independent, zero-mean and independent of
//! the true `x`, the second moments are `R_ii = E[x_i²] = E[x²] + σ_i²` and
//! `R_ij = E[x_i·x_j] = E[x²]` (`i ≠ j`), so `σ_i² = R_ii − R_ij`. The paper
//! estimates them by running means over the samples `t = 1, 2, …`:
//!
//! ```text
//! R_ii(t) = (t − 1)/t · R_ii(t − 1) + x_i²(t)/t
//! R_ij(t) = (t − 1)/t · R_ij(t − 1) + x_i(t)·x_j(t)/t                     (not printed; the same form)
//! σ_i²(t) = (t − 1)/t · R_ii(t − 1) + x_i²(t)/t − 1/(n − 1) · Σ_{j≠i} R_ij(t)      (9), n = 4: ⅓
//! w_i(t)  = (1/σ_i²(t)) / Σ_j (1/σ_j²(t))                                   (10)
//! x̂ = Σ_i w_i·x_i,   Σ_i w_i = 1,   σ² = Σ_i w_i²·σ_i²                        (11)
//! ```
//!
//! The paper calls `R_ii` and `R_ij` auto- and cross-covariance functions, but
//! (9) only holds for the uncentred moments above, which is what is kept here.
//!
//! **Why σ_i² can be ≤ 0.** The estimate is the running mean of
//! `x_i·(x_i − x̄_{−i}) = (x + e_i)(e_i − ē_{−i})`: besides `σ_i²` it holds the
//! cross term `x·(e_i − ē_{−i})`, of zero mean but standard deviation
//! `≈ |x|·σ_e·√(4/3)/√t` after `t` samples. At 5 m/s with a speed noise of
//! 0.1 m/s that swamps `σ_e² = 0.01` until `t` is in the thousands, so early
//! on (and at `t = 1` for every reading below the others' mean) the estimate
//! is negative. The rule used here, so that no weight is ever NaN:
//!
//! 1. a present channel whose estimate is finite and positive uses it;
//! 2. a present channel whose estimate is `≤ 0`, non-finite or undefined (no
//!    partner seen yet) is taken to be as quiet as the quietest channel with a
//!    positive estimate (its estimate says "below the resolution of the
//!    others"), i.e. it uses the smallest positive estimate present;
//! 3. when no present channel has a positive estimate, all present channels
//!    weigh the same.
//!
//! **Missing readings** (NaN or infinite) are skipped: a moment is the mean
//! over the samples in which both of its channels were present, each with its
//! own count `t`, eq. (9) uses the partners ever seen with channel `i`, and a
//! missing channel gets weight 0 while the present ones share 1. No channel
//! present: all weights 0 and no estimate.

/// What the weights of one sample rest on (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeightBasis {
    /// Every present channel had a positive variance estimate (rule 1).
    Estimated,
    /// This many present channels lacked a positive estimate and took the
    /// smallest positive one (rule 2).
    Floored(usize),
    /// No present channel had a positive estimate: equal weights (rule 3).
    Equal,
    /// No channel was present.
    NoReadings,
}

/// The weights and the fused value of one sample, eqs. (9)–(11).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weighting<const N: usize> {
    /// `w_i`: 0 for a missing channel; the present ones sum to 1.
    pub weights: [f64; N],
    /// The estimate of eq. (9) as computed (may be ≤ 0); `None` for a
    /// channel never seen, or never seen together with another.
    pub raw_variances: [Option<f64>; N],
    /// The `σ_i²` the weights were formed from, after the rule; `None` for a
    /// missing channel and under [`WeightBasis::Equal`].
    pub variances: [Option<f64>; N],
    /// What the weights rest on.
    pub basis: WeightBasis,
    /// The fused value `x̂ = Σ w_i·x_i`; `None` when no channel is present.
    pub value: Option<f64>,
    /// `σ² = Σ w_i²·σ_i²` of eq. (11); `None` under [`WeightBasis::Equal`] or
    /// [`WeightBasis::NoReadings`].
    pub variance: Option<f64>,
}

/// The running moments `R_ij` of `N` channels; each update allocates nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveWeights<const N: usize> {
    /// `R_ij(t)`, symmetric.
    moments: [[f64; N]; N],
    /// The sample count `t` of each `R_ij`: the samples with both channels present.
    counts: [[u64; N]; N],
}

impl<const N: usize> Default for AdaptiveWeights<N> {
    fn default() -> Self {
        Self { moments: [[0.0; N]; N], counts: [[0; N]; N] }
    }
}

impl<const N: usize> AdaptiveWeights<N> {
    /// No samples yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets every sample.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// `R_ij(t)` (0 before any sample with both channels present).
    pub fn moment(&self, i: usize, j: usize) -> f64 {
        self.moments[i][j]
    }

    /// The count `t` behind `R_ij`.
    pub fn n_samples(&self, i: usize, j: usize) -> u64 {
        self.counts[i][j]
    }

    /// Adds one sample (non-finite readings are missing) to the moments and
    /// returns its weights and fused value.
    pub fn update(&mut self, readings: &[f64; N]) -> Weighting<N> {
        for i in 0..N {
            for j in i..N {
                if readings[i].is_finite() && readings[j].is_finite() {
                    let t = self.counts[i][j] + 1;
                    let tf = t as f64;
                    let r = (tf - 1.0) / tf * self.moments[i][j] + readings[i] * readings[j] / tf;
                    (self.moments[i][j], self.moments[j][i]) = (r, r);
                    (self.counts[i][j], self.counts[j][i]) = (t, t);
                }
            }
        }
        self.weighting(readings)
    }

    /// Eq. (9) for channel `i` from the moments so far: `R_ii` minus the mean
    /// of the `R_ij` over the partners `j` seen with it.
    pub fn raw_variance(&self, i: usize) -> Option<f64> {
        if self.counts[i][i] == 0 {
            return None;
        }
        let partners = (0..N).filter(|&j| j != i && self.counts[i][j] > 0);
        let n_partners = partners.clone().count();
        if n_partners == 0 {
            return None;
        }
        Some(self.moments[i][i] - partners.map(|j| self.moments[i][j]).sum::<f64>() / n_partners as f64)
    }

    /// The weights of eq. (10) and the fusion of eq. (11) for `readings`,
    /// from the moments as they stand (without adding the sample).
    pub fn weighting(&self, readings: &[f64; N]) -> Weighting<N> {
        let present = readings.map(f64::is_finite);
        let raw_variances: [Option<f64>; N] = std::array::from_fn(|i| self.raw_variance(i));
        let valid = |i: usize| raw_variances[i].filter(|v| v.is_finite() && *v > 0.0);
        let n_present = present.iter().filter(|p| **p).count();
        let smallest = (0..N).filter(|&i| present[i]).filter_map(valid).fold(f64::INFINITY, f64::min);
        let mut out = Weighting {
            weights: [0.0; N],
            raw_variances,
            variances: [None; N],
            basis: WeightBasis::NoReadings,
            value: None,
            variance: None,
        };
        if n_present == 0 {
            return out;
        }
        if smallest.is_finite() {
            let mut n_floored = 0;
            for i in (0..N).filter(|&i| present[i]) {
                out.variances[i] = Some(valid(i).unwrap_or_else(|| {
                    n_floored += 1;
                    smallest
                }));
            }
            // w_i ∝ σ_min²/σ_i² ∈ (0, 1]: no overflow however small σ_min² is.
            let ratio = out.variances.map(|v| v.map_or(0.0, |v| smallest / v));
            let total: f64 = ratio.iter().sum();
            out.weights = ratio.map(|r| r / total);
            out.basis = if n_floored == 0 { WeightBasis::Estimated } else { WeightBasis::Floored(n_floored) };
            out.variance =
                Some((0..N).filter_map(|i| out.variances[i].map(|v| out.weights[i] * out.weights[i] * v)).sum());
        } else {
            out.weights = present.map(|p| if p { 1.0 / n_present as f64 } else { 0.0 });
            out.basis = WeightBasis::Equal;
        }
        out.value = Some((0..N).filter(|&i| present[i]).map(|i| out.weights[i] * readings[i]).sum());
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moments_are_running_means_of_products() {
        let mut w = AdaptiveWeights::<2>::new();
        w.update(&[1.0, 2.0]);
        w.update(&[3.0, f64::NAN]);
        w.update(&[5.0, 4.0]);
        assert!((w.moment(0, 0) - (1.0 + 9.0 + 25.0) / 3.0).abs() < 1e-14);
        assert!((w.moment(0, 1) - (2.0 + 20.0) / 2.0).abs() < 1e-14);
        assert!((w.moment(1, 1) - (4.0 + 16.0) / 2.0).abs() < 1e-14);
        assert_eq!((w.n_samples(0, 0), w.n_samples(0, 1), w.n_samples(1, 0)), (3, 2, 2));
    }

    #[test]
    fn first_sample_below_the_mean_floors_to_the_quietest() {
        // At t = 1, σ_i² = x_i·(x_i − mean of the others): 5.0 → 5·(5 − 5.1) < 0.
        let w = AdaptiveWeights::<3>::new().update(&[5.0, 5.2, 5.0]);
        assert_eq!(w.basis, WeightBasis::Floored(2));
        assert!((w.raw_variances[1].unwrap() - 5.2 * 0.2).abs() < 1e-12);
        assert!(w.weights.iter().all(|x| (x - 1.0 / 3.0).abs() < 1e-15), "{:?}", w.weights);
    }

    #[test]
    fn nothing_present_gives_no_value_and_zero_weights() {
        let w = AdaptiveWeights::<4>::new().update(&[f64::NAN; 4]);
        assert_eq!((w.basis, w.value, w.weights), (WeightBasis::NoReadings, None, [0.0; 4]));
    }
}
