//! A continuous, odd, piecewise-linear element law with three slopes — the
//! nonlinear spring or damper of study S1 (eqs. (2), (3) as corrected in
//! `SCENARIOS.md`), and the nonlinear primary damper of study S2 (two slopes).
//!
//! ```text
//! F(b) = k₁·b                                               |b| ≤ δ₁
//!      = sign(b)·[k₁·δ₁ + k₂·(|b| − δ₁)]                    δ₁ < |b| ≤ δ₂
//!      = sign(b)·[k₁·δ₁ + k₂·(δ₂ − δ₁) + k₃·(|b| − δ₂)]     |b| > δ₂
//! ```

use crate::error::FilterError;

/// Slopes `k₁, k₂, k₃` and breakpoints `0 ≤ δ₁ ≤ δ₂`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiecewiseLinear {
    slopes: [f64; 3],
    breaks: [f64; 2],
}

impl PiecewiseLinear {
    /// A piecewise-linear law; breakpoints must satisfy `0 ≤ δ₁ ≤ δ₂` and every value be finite.
    pub fn new(slopes: [f64; 3], breaks: [f64; 2]) -> Result<Self, FilterError> {
        let finite = slopes.iter().chain(&breaks).all(|v| v.is_finite());
        if !finite || breaks[0] < 0.0 || breaks[1] < breaks[0] {
            return Err(FilterError::InvalidSetting(format!(
                "piecewise-linear law needs finite slopes and 0 <= delta1 <= delta2, got slopes {slopes:?}, breaks {breaks:?}"
            )));
        }
        Ok(Self { slopes, breaks })
    }

    /// A linear law `F = k·b`.
    pub fn linear(k: f64) -> Self {
        Self { slopes: [k; 3], breaks: [f64::INFINITY; 2] }
    }

    /// The slopes `k₁, k₂, k₃`.
    pub fn slopes(&self) -> [f64; 3] {
        self.slopes
    }

    /// The breakpoints `δ₁, δ₂`.
    pub fn breaks(&self) -> [f64; 2] {
        self.breaks
    }

    /// `F(b)`.
    #[inline]
    pub fn force(&self, b: f64) -> f64 {
        let [k1, k2, k3] = self.slopes;
        let [d1, d2] = self.breaks;
        let a = b.abs();
        let magnitude = if a <= d1 {
            k1 * a
        } else if a <= d2 {
            k1 * d1 + k2 * (a - d1)
        } else {
            k1 * d1 + k2 * (d2 - d1) + k3 * (a - d2)
        };
        magnitude.copysign(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn law_is_continuous_at_its_breakpoints_and_odd() {
        let law = PiecewiseLinear::new([5.0, 20.0, 30.0], [0.1, 0.2]).unwrap();
        for &d in &[0.1, 0.2] {
            let (below, above) = (law.force(d - 1e-12), law.force(d + 1e-12));
            assert!((below - above).abs() < 1e-9, "jump at {d}");
        }
        assert!((law.force(0.15) - (5.0 * 0.1 + 20.0 * 0.05)).abs() < 1e-14);
        assert!((law.force(-0.3) + (0.5 + 2.0 + 3.0)).abs() < 1e-14);
        assert_eq!(PiecewiseLinear::linear(7.0).force(-2.0), -14.0);
    }

    #[test]
    fn breakpoints_out_of_order_are_refused() {
        assert!(PiecewiseLinear::new([1.0, 2.0, 3.0], [0.2, 0.1]).is_err());
    }
}
