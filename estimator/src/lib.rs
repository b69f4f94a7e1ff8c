//! Nonlinear Kalman filters for virtual sensors: the cubature Kalman filter
//! (CKF), its square-root (SRCKF) and SVD forms, the scaled unscented filter
//! (UKF) and a finite-difference EKF, on any state-space model.
//!
//! Problems are separate from solvers: a model implements [`Process`] and
//! [`Observation`] (or [`VectorField`] + [`Observation`], discretised by
//! [`Discretized`]), and every filter runs every model. Filters own all their
//! buffers: once built, `predict` and `update` allocate nothing, so they can
//! run inside a simulator's step. Failures are values ([`FilterError`]), and a
//! failed step leaves the belief as it was.
//!
//! This crate does no I/O: no files, no logging, no FFI.
//!
//! ```
//! use estimator::models::{Oscillator2Dof, Oscillator2DofLoad};
//! use estimator::{Discretized, Gaussian, Noise, SquareRootCubature, StateEstimator};
//!
//! let model = Discretized::rk4(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()), 1);
//! let noise = Noise::diagonal(&[1e-8, 1e-8, 1e-2, 1e-6, 1e-6, 10.0], &[1e-4, 1e-4]).unwrap();
//! let prior = Gaussian::diagonal(&[0.0; 6], &[1e-2, 1e-2, 100.0, 1e-2, 1e-2, 100.0]);
//! let mut filter = SquareRootCubature::new(model, noise, &prior).unwrap();
//! filter.predict(&[], 0.005).unwrap();
//! let innovation = filter.update(&[0.1, f64::NAN]).unwrap(); // second sensor missing
//! assert_eq!(innovation.rows_used(), 1);
//! let load = filter.mean()[Oscillator2DofLoad::LOAD];
//! let sigma = filter.variance(Oscillator2DofLoad::LOAD).sqrt();
//! assert!(load.is_finite() && sigma > 0.0);
//! ```

mod adaptive_noise;
mod chi_square;
mod error;
mod filter;
mod gaussian;
mod integrate;
mod linalg;
mod model;
mod noise;
mod points;
mod supervisor;

pub mod fusion;
pub mod models;

pub use adaptive_noise::SageHusa;
pub use error::{FilterError, Stage};
pub use filter::{
    build_filter, CholeskyRoot, CovarianceRoot, CubatureKalman, ExtendedKalman, FilterKind, Innovation,
    SigmaPointKalman, Snapshot, SquareRootCubature, StateEstimator, SvdCubature, SvdRoot, UnscentedKalman,
};
pub use gaussian::Gaussian;
pub use integrate::{Discretized, Rk4};
pub use linalg::SymmetricEigen;
pub use model::{Component, Model, Observation, Process, VectorField, BLOCK_POINTS};
pub use noise::Noise;
pub use points::{CenterWeights, SigmaPoints, UnscentedParams};
pub use supervisor::{Channel, FaultChange, Outcome, QuantizedSteps, RowOutcome, Supervisor, SupervisorSettings};
