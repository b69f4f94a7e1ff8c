//! Whether the fitted filter is consistent with the log: for a consistent filter the
//! innovations are white with covariance `S`, so the sum of the NIS over the updates is
//! χ² with as many degrees of freedom as rows were used [BarShalom2001], and the
//! mean NIS per row lies in `[χ²_{R}(0.025), χ²_{R}(0.975)] / R` with probability 0.95.

/// The two-sided band of the mean NIS per row for `rows` rows used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NisBand {
    /// Rows used (the degrees of freedom).
    pub rows: usize,
    /// The probability the band holds for a consistent filter.
    pub probability: f64,
    /// Lower end of the mean NIS per row.
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
}

impl NisBand {
    /// The band holding with `probability` for `rows` rows.
    pub fn new(rows: usize, probability: f64) -> Self {
        let dof = rows.max(1) as f64;
        let tail = 0.5 * (1.0 - probability);
        Self {
            rows,
            probability,
            lower: chi_square::quantile(dof, tail) / dof,
            upper: chi_square::quantile(dof, 1.0 - tail) / dof,
        }
    }

    /// The 95 % band.
    pub fn at_95(rows: usize) -> Self {
        Self::new(rows, 0.95)
    }

    /// Whether a mean NIS per row lies in it.
    pub fn contains(&self, mean_nis: f64) -> bool {
        self.lower <= mean_nis && mean_nis <= self.upper
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_is_the_chi_square_quantiles_per_row_also_for_a_long_log() {
        // scipy.stats.chi2.ppf([0.025, 0.975], 100) / 100.
        let b = NisBand::at_95(100);
        assert!((b.lower - 0.7422193).abs() < 1e-6 && (b.upper - 1.2956120).abs() < 1e-6, "{b:?}");
        // Large R: the mean is about N(1, 2/R), so the band is 1 ± 1.96·√(2/R).
        for rows in [8_000, 420_000] {
            let b = NisBand::at_95(rows);
            let half = 1.959964 * (2.0 / rows as f64).sqrt();
            assert!((b.lower - (1.0 - half)).abs() < 0.02 * half, "{rows}: {b:?}");
            assert!((b.upper - (1.0 + half)).abs() < 0.02 * half, "{rows}: {b:?}");
        }
    }
}
