//! Nonlinear Kalman filters for virtual sensors: the cubature Kalman filter
//! (CKF), its square-root (SRCKF) and SVD forms, the scaled unscented filter
//! (UKF) and a finite-difference EKF, on any state-space model; and the
//! fixed-interval (RTS) smoother of their runs, [`smooth`], its cross-covariances
//! by each filter's own rule ([`cross_covariance`], [`linearised_cross_covariance`]).
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
//! A step runs its dense kernels with AVX2 and FMA where the CPU has them,
//! and portable loops otherwise (the two agree to rounding, not bit for bit).
//! The portable path can be forced, to test on an x86-64 machine what a CPU
//! without AVX2 runs: for the process with the environment variable
//! `KALFMU_PORTABLE=1` ([`PORTABLE_VARIABLE`], read once), or for one thread
//! and one closure with [`with_portable_kernels`]; [`kernels_in_use`] says
//! which path a step takes, [`kernels_available`] what the CPU offers.
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
mod error;
mod filter;
mod gaussian;
mod integrate;
mod linalg;
mod model;
mod noise;
mod points;
mod smoothing;
mod supervised;
mod supervisor;

pub mod fusion;
pub mod math;
pub mod models;

pub use adaptive_noise::SageHusa;
pub use error::{FilterError, Stage};
pub use filter::{
    build_filter, CholeskyRoot, CovarianceRoot, CubatureKalman, CubaturePoints, ExtendedKalman, FilterKind, Innovation,
    PointRule, SigmaPointKalman, Snapshot, SquareRootCubature, StateEstimator, SvdCubature, SvdRoot, UnscentedKalman,
    UnscentedPoints,
};
pub use gaussian::Gaussian;
pub use integrate::{Discretized, Rk4};
pub use linalg::{
    kernels_available, kernels_in_use, with_portable_kernels, Kernels, SymmetricEigen, PORTABLE_VARIABLE,
};
pub use model::{Component, Model, Observation, Process, VectorField, BLOCK_POINTS};
pub use noise::Noise;
pub use points::{CenterWeights, SigmaPoints, UnscentedParams};
pub use smoothing::fixed_interval::{
    cross_covariance, linearised_cross_covariance, smooth, smooth_square_root, RootGaussian, RunRecorder,
    SmoothingStep, SquareRootStep,
};
pub use smoothing::fixed_lag::{FixedLagSmoother, LaggedEstimate, Transition};
pub use supervised::{Event, RunError, Sample, Step, SupervisedFilter};
pub use supervisor::{
    Channel, FaultChange, Outcome, Outside, PlausibleBound, PlausibleRange, QuantizedSteps, Revision, RowOutcome,
    Supervisor, SupervisorSettings,
};
