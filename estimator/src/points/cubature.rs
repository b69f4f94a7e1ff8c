//! The third-degree spherical–radial cubature rule (Arasaratnam & Haykin,
//! "Cubature Kalman filters", IEEE TAC 54(6), 2009, eq. (30)):
//! `2n` points `x̂ ± √n·A·eⱼ`, all of weight `1/(2n)`.

use super::SigmaPoints;

impl SigmaPoints {
    /// The cubature points for an `n`-dimensional state.
    pub fn cubature(n: usize) -> Self {
        Self { n, spread: (n as f64).sqrt(), center: None, weight: 0.5 / n as f64 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_points_have_unit_covariance() {
        let p = SigmaPoints::cubature(6);
        assert_eq!(p.len(), 12);
        let total: f64 = (0..p.len()).map(|i| p.mean_weight(i)).sum();
        assert!((total - 1.0).abs() < 1e-15);
        // Σ w·(c·eⱼ)(c·eⱼ)ᵀ over ± pairs = 2·w·c² = 1 per axis.
        assert!((2.0 * p.weight() * p.spread().powi(2) - 1.0).abs() < 1e-15);
    }
}
