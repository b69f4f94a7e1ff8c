//! Study S2: wheel–rail vertical forces from car-body, bogie and axle-box accelerations,
//! a 10-DOF vertical vehicle augmented with the four wheel–rail forces and an SRCKF
//! `[Chen2025]`.
//!
//! - The truth is [`truth::s2`]: a vehicle–track coupled model richer than the estimator's.
//! - The study ([`study`]): the user's catalogue vehicle against the car as built, the
//!   tuning, a filter run in-process and its score; the estimation model is
//!   `estimator::models::WheelRailVertical`.
//! - Through the packaged FMU `kalfmu_s2_wheel_rail` ([`fmu_run`]): `reproduce`'s table
//!   ([`reproduce`]).
//! - The robustness sweep, in-process on both cores ([`sweep`]).

pub mod fmu_run;
pub mod reproduce;
pub mod study;
pub mod sweep;
pub mod system;
