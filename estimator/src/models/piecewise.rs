//! A continuous, odd, piecewise-linear element law with three slopes — the
//! nonlinear spring or damper of study S1 (eqs. (2), (3) of `[Gong2024]` in their
//! continuous form, `docs/studies/s1.md`), and the nonlinear primary damper of study S2 (two slopes).
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

    /// `F(b)`, without branches: each segment contributes its slope times the
    /// part of `|b|` that lies in it. For finite `b` the sums are those of the
    /// three-case formula above, in the same order, so the numbers are the
    /// same bit for bit; a NaN or infinite `b` gives NaN.
    #[inline(always)]
    pub fn force(&self, b: f64) -> f64 {
        self.force_lanes(&[b])[0]
    }

    /// [`force`](Self::force) lane by lane, in the loop shape the compiler
    /// vectorises across points (`min`/`max` rather than comparisons and
    /// selects, which it turns into branches or scalar code).
    #[inline(always)]
    pub fn force_lanes<const L: usize>(&self, b: &[f64; L]) -> [f64; L] {
        let [k1, k2, k3] = self.slopes;
        let [d1, d2] = self.breaks;
        let mut out = [0.0; L];
        for (o, &b) in out.iter_mut().zip(b) {
            let a = b.abs();
            // With infinite breakpoints (a linear law) `second` and `third` are
            // max(−∞ or NaN, 0) = 0, as they should be.
            let first = a.min(d1);
            let second = (a.min(d2) - d1).max(0.0);
            let third = (a - d2).max(0.0);
            // `min` and `max` drop a NaN, so `0·a` carries it (it is +0 for finite `a`).
            *o = (k1 * first + k2 * second + k3 * third + 0.0 * a).copysign(b);
        }
        out
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
        for b in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(law.force(b).is_nan(), "F({b})");
            assert!(PiecewiseLinear::linear(7.0).force(b).is_nan(), "linear F({b})");
        }
    }

    /// The three-case formula of the module documentation, branch by branch.
    fn by_cases(law: &PiecewiseLinear, b: f64) -> f64 {
        let ([k1, k2, k3], [d1, d2]) = (law.slopes, law.breaks);
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

    #[test]
    fn branch_free_law_equals_the_three_case_formula_bit_for_bit_on_finite_input() {
        let laws = [
            PiecewiseLinear::new([5.0, 20.0, 30.0], [0.1, 0.2]).unwrap(),
            PiecewiseLinear::new([2e3, 5e2, 5e2], [0.1, 0.1]).unwrap(),
            PiecewiseLinear::new([-1.0, 0.0, 3.0], [0.0, 0.3]).unwrap(),
            PiecewiseLinear::linear(7.0),
            PiecewiseLinear::linear(-0.5),
        ];
        for law in &laws {
            for i in -400..=400 {
                let b = i as f64 * 1.37e-3;
                assert_eq!(law.force(b).to_bits(), by_cases(law, b).to_bits(), "{law:?} at {b}");
            }
            for b in [0.1, -0.1, 0.2, 0.0, -0.0, 1e300, -1e300, f64::MIN_POSITIVE] {
                assert_eq!(law.force(b).to_bits(), by_cases(law, b).to_bits(), "{law:?} at {b}");
            }
        }
    }

    #[test]
    fn breakpoints_out_of_order_are_refused() {
        assert!(PiecewiseLinear::new([1.0, 2.0, 3.0], [0.2, 0.1]).is_err());
    }
}
