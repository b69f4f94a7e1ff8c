//! Grubbs' test for one outlier among `n` readings of the same quantity
//! (Grubbs 1950; NIST/SEMATECH e-Handbook §1.3.5.17), step 1 of the paper's
//! preprocessing ("通过格拉布斯准则…将异常速度信息剔除").
//!
//! The statistic is `G = max_i |x_i − x̄| / s`, with `s` the sample standard
//! deviation (divisor `n − 1`). The reading farthest from the mean is an
//! outlier at two-sided level `α` when `G > G_crit`,
//!
//! ```text
//! G_crit(n, α) = (n − 1)/√n · √(t² / (n − 2 + t²)),   t = upper α/(2n) point of t(n − 2),
//! ```
//!
//! computed here for any `n ≥ 3`, not read from a table (one-sided: `α/n`).
//!
//! **The test is weak for four channels.** Samuelson's inequality bounds
//! `G ≤ (n − 1)/√n` for every data set, with equality only when all readings
//! but one are equal: 1.5 at `n = 4`, against `G_crit(4, 0.05) = 1.48125`
//! exactly (at `n = 4`, `t²/(2 + t²) = (1 − α/4)²`, so `G_crit = 1.5·(1 − α/4)`;
//! tables print 1.4812 or 1.4813 depending on how they round the tie). A spike
//! is rejected only when the other three agree closely: beside `{−a, 0, a}`
//! (standard deviation `a`) it must lie beyond `10.23·a`. Two equal faulty
//! channels mask each other (`{a, a, b, b}` gives `G = 0.866`), and so do two
//! spikes of either sign.
//!
//! **Iteration.** The paper does not say whether it retests after a rejection,
//! nor which `α` it uses. The default is one pass (at most one rejection per
//! sample) at `α = 0.05`; [`GrubbsSettings::max_rejections`] allows the
//! classical remove-and-retest loop, which at `n = 3` rejects only when two
//! readings nearly coincide (`G_crit(3) = 1.15430` against a bound of 1.15470:
//! `{0, ε, 1}` loses its 1 for `ε < 0.0298`).
//!
//! Missing readings (NaN or infinite) take no part: the test runs on the
//! `m` finite readings, and not at all when `m < 3`.

use super::student_t;
use crate::FilterError;

/// The two-sided critical value `G_crit(n, α)`: a reading is an outlier when
/// `G > G_crit`. NaN for `n < 3` or `α` outside `(0, 1)`.
pub fn critical_value(n: usize, alpha: f64) -> f64 {
    critical_value_for_tail(n, alpha / (2.0 * n as f64), alpha)
}

/// The one-sided critical value (the largest, or the smallest, reading tested
/// alone): `t` at the upper `α/n` point.
pub fn critical_value_one_sided(n: usize, alpha: f64) -> f64 {
    critical_value_for_tail(n, alpha / n as f64, alpha)
}

fn critical_value_for_tail(n: usize, tail: f64, alpha: f64) -> f64 {
    if n < 3 || alpha.is_nan() || alpha <= 0.0 || alpha >= 1.0 {
        return f64::NAN;
    }
    let nf = n as f64;
    let t = student_t::inverse_upper_tail(nf - 2.0, tail);
    let t2 = t * t;
    (nf - 1.0) / nf.sqrt() * (t2 / (nf - 2.0 + t2)).sqrt()
}

/// The largest `G` any `n` readings can give, `(n − 1)/√n` (Samuelson).
pub fn max_statistic(n: usize) -> f64 {
    let nf = n as f64;
    (nf - 1.0) / nf.sqrt()
}

/// The reading farthest from the mean and its Grubbs statistic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extreme {
    /// Index of the reading farthest from the mean (the first of a tie).
    pub index: usize,
    /// `G = |x_index − x̄| / s`; 0 when all readings are equal.
    pub statistic: f64,
    /// How many finite readings took part.
    pub n_readings: usize,
}

/// Grubbs' statistic over the finite readings (non-finite ones are missing);
/// `None` with fewer than three.
pub fn statistic(readings: &[f64]) -> Option<Extreme> {
    statistic_where(readings, |_| true)
}

/// [`statistic`] over the finite readings `i` with `include(i)`.
fn statistic_where(readings: &[f64], include: impl Fn(usize) -> bool) -> Option<Extreme> {
    let taken = || readings.iter().enumerate().filter(|&(i, x)| x.is_finite() && include(i));
    let n = taken().count();
    if n < 3 {
        return None;
    }
    // Centre on the first reading before summing: the spread, not the level, matters.
    let origin = taken().next().map_or(0.0, |(_, &x)| x);
    let mean = origin + taken().map(|(_, &x)| x - origin).sum::<f64>() / n as f64;
    let sum_sq = taken().map(|(_, &x)| (x - mean) * (x - mean)).sum::<f64>();
    let (index, deviation) =
        taken()
            .map(|(i, &x)| (i, (x - mean).abs()))
            .fold((usize::MAX, -1.0), |best, c| if c.1 > best.1 { c } else { best });
    let s = (sum_sq / (n - 1) as f64).sqrt();
    let statistic = if s > 0.0 && s.is_finite() { (deviation / s).min(max_statistic(n)) } else { 0.0 };
    Some(Extreme { index, statistic, n_readings: n })
}

/// The test's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrubbsSettings {
    /// Two-sided significance level, in `(0, 1)`. Default 0.05.
    pub alpha: f64,
    /// Rejections per sample at most: 1 (default) tests once; more retests the
    /// remaining readings after each rejection. 0 never rejects.
    pub max_rejections: usize,
}

impl Default for GrubbsSettings {
    fn default() -> Self {
        Self { alpha: 0.05, max_rejections: 1 }
    }
}

/// Grubbs' test on `N` channels, with the critical values for every count of
/// present readings worked out once: testing a sample allocates nothing.
#[derive(Debug, Clone)]
pub struct Grubbs<const N: usize> {
    settings: GrubbsSettings,
    /// `critical[m − 1]` for `m` present readings; +∞ (never reject) below 3.
    critical: [f64; N],
}

impl<const N: usize> Grubbs<N> {
    /// Checks the settings and tabulates `G_crit(m, α)` for `m = 3..=N`.
    pub fn new(settings: GrubbsSettings) -> Result<Self, FilterError> {
        if !(settings.alpha > 0.0 && settings.alpha < 1.0) {
            return Err(FilterError::InvalidSetting(format!(
                "Grubbs' significance level α must lie in (0, 1), e.g. 0.05; got {}",
                settings.alpha
            )));
        }
        let critical =
            std::array::from_fn(|k| if k + 1 >= 3 { critical_value(k + 1, settings.alpha) } else { f64::INFINITY });
        Ok(Self { settings, critical })
    }

    /// The settings.
    pub fn settings(&self) -> GrubbsSettings {
        self.settings
    }

    /// The critical value used when `m` readings are present (+∞ below 3).
    pub fn critical(&self, m: usize) -> f64 {
        if m == 0 || m > N {
            f64::INFINITY
        } else {
            self.critical[m - 1]
        }
    }

    /// Which readings the test rejects: `true` marks an outlier. Missing
    /// readings are never marked. Each pass removes the reading farthest from
    /// the mean when `G > G_crit(m)` and stops at the first pass that does not.
    pub fn rejected(&self, readings: &[f64; N]) -> [bool; N] {
        let mut rejected = [false; N];
        for _ in 0..self.settings.max_rejections {
            match statistic_where(readings, |i| !rejected[i]) {
                Some(e) if e.statistic > self.critical(e.n_readings) => rejected[e.index] = true,
                _ => break,
            }
        }
        rejected
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_readings_have_a_closed_form_critical_value() {
        for alpha in [0.01, 0.05, 0.1] {
            assert!((critical_value(4, alpha) - 1.5 * (1.0 - alpha / 4.0)).abs() < 1e-13);
            assert!((critical_value_one_sided(4, alpha) - 1.5 * (1.0 - alpha / 2.0)).abs() < 1e-13);
        }
    }

    #[test]
    fn statistic_skips_missing_readings_and_is_zero_for_equal_ones() {
        let e = statistic(&[1.0, f64::NAN, 1.1, 0.9, 5.0]).unwrap();
        assert_eq!((e.index, e.n_readings), (4, 4));
        assert!(statistic(&[1.0, f64::NAN, f64::INFINITY, 2.0]).is_none());
        assert_eq!(statistic(&[3.0; 4]).unwrap().statistic, 0.0);
    }

    #[test]
    fn invalid_levels_are_refused_with_advice() {
        for alpha in [0.0, 1.0, -0.1, f64::NAN] {
            let err = Grubbs::<4>::new(GrubbsSettings { alpha, max_rejections: 1 }).unwrap_err();
            assert!(err.to_string().contains("(0, 1)"), "{err}");
        }
        assert!(critical_value(2, 0.05).is_nan());
    }
}
