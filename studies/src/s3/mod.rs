//! Study S3: the left and right vertical wheel–rail forces of a whole car from vertical
//! accelerations (and, where a user has them, primary deflections), a 17-DOF vehicle with
//! roll augmented with the eight forces `[Chen2025]`.
//!
//! - The truth is [`truth::s3`]: a whole car on two rails with lateral dynamics, conical
//!   treads and Hertz contact, richer than the estimator's.
//! - The study ([`study`]): the tuning, the paper's force model and ours, a filter run
//!   in-process and its score per wheel, sum and difference; the estimation model is
//!   `estimator::models::WheelRailRoll`.
//! - Through the packaged FMU ([`fmu_run`]), as `kalfmu reproduce` runs it ([`reproduce`]),
//!   and the sweep of speeds, the user's car and rates ([`sweep`]).
pub mod ceiling;
pub mod fmu_run;
pub mod reproduce;
pub mod study;
pub mod sweep;
