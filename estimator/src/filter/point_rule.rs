//! The point set of a covariance-form sigma-point filter, as a type: the
//! filter's type then says what was built ([`CubatureKalman`](crate::CubatureKalman)
//! and [`UnscentedKalman`](crate::UnscentedKalman) are different types, each
//! with only its own constructor).
//!
//! ```
//! use estimator::models::{Oscillator2Dof, Oscillator2DofLoad};
//! use estimator::{CubatureKalman, Discretized, FilterKind, Gaussian, Noise, StateEstimator};
//! use estimator::{UnscentedKalman, UnscentedParams};
//!
//! let model = || Discretized::rk4(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()), 1);
//! let noise = Noise::diagonal(&[1e-8, 1e-8, 1e-2, 1e-6, 1e-6, 10.0], &[1e-4, 1e-4]).unwrap();
//! let prior = Gaussian::diagonal(&[0.0; 6], &[1e-2, 1e-2, 100.0, 1e-2, 1e-2, 100.0]);
//! let ckf: CubatureKalman<_> = CubatureKalman::cubature(model(), noise.clone(), &prior).unwrap();
//! let cubature_like = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
//! let ukf: UnscentedKalman<_> = UnscentedKalman::unscented(model(), noise, &prior, cubature_like).unwrap();
//! assert_eq!((ckf.kind(), ukf.kind()), (FilterKind::Ckf, FilterKind::Ukf));
//! ```
//!
//! A UKF type has no CKF constructor:
//!
//! ```compile_fail,E0599
//! use estimator::models::{Oscillator2Dof, Oscillator2DofLoad};
//! use estimator::{Discretized, Gaussian, Noise, UnscentedKalman};
//!
//! let model = Discretized::rk4(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()), 1);
//! let noise = Noise::diagonal(&[1e-8, 1e-8, 1e-2, 1e-6, 1e-6, 10.0], &[1e-4, 1e-4]).unwrap();
//! let prior = Gaussian::diagonal(&[0.0; 6], &[1e-2, 1e-2, 100.0, 1e-2, 1e-2, 100.0]);
//! let _ = UnscentedKalman::cubature(model, noise, &prior);
//! ```

/// A point set a [`SigmaPointKalman`](crate::SigmaPointKalman) spreads; sealed:
/// [`CubaturePoints`] or [`UnscentedPoints`].
pub trait PointRule: sealed::Sealed {
    /// The rule's name, for messages.
    const NAME: &'static str;
}

/// The third-degree spherical-radial cubature rule: `2n` equally weighted points.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CubaturePoints;

/// The scaled unscented transform: `2n + 1` points with their own weights.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UnscentedPoints;

impl PointRule for CubaturePoints {
    const NAME: &'static str = "cubature";
}

impl PointRule for UnscentedPoints {
    const NAME: &'static str = "unscented";
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::CubaturePoints {}
    impl Sealed for super::UnscentedPoints {}
}
