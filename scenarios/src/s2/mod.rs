//! Study S2: wheel–rail vertical forces from car-body, bogie and axle-box accelerations
//! (seed `002_…`: a 10-DOF vertical vehicle augmented with the four wheel–rail forces,
//! SRCKF). `SCENARIOS.md` digests the paper.
//!
//! - The truth, a vehicle–track coupled model richer than the estimator's ([`plant`]): the
//!   vehicle ([`vehicle`]) on one rail of a ballasted track ([`track`]) through Hertz
//!   contacts, over irregularities ([`irregularity`]), with its data in one place
//!   ([`parameters`]).
//! - The study ([`study`]): its cases, the car as built against the user's catalogue
//!   vehicle, the sampled and noisy measurements, the tuning, a filter run in-process and
//!   its score, the accelerations sampled as a data acquisition does ([`daq`]); the
//!   estimation model is `estimator::models::WheelRailVertical`.
//! - Through the packaged FMU `kalfmu_s2_wheel_rail` ([`fmu_run`]): `reproduce`'s table
//!   ([`reproduce`]).
//! - The robustness sweep, in-process on both cores ([`sweep`]).

pub mod daq;
pub mod fmu_run;
pub mod irregularity;
pub mod parameters;
pub mod plant;
pub mod reproduce;
pub mod study;
pub mod sweep;
pub mod track;
pub mod vehicle;
