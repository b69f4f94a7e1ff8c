//! Study S2: wheel–rail vertical forces from car-body, bogie and axle-box accelerations
//! (seed `002_…`: a 10-DOF vertical vehicle augmented with the four wheel–rail forces,
//! SRCKF). `SCENARIOS.md` digests the paper.
//!
//! Built so far:
//! - the truth, a vehicle–track coupled model richer than the estimator's ([`plant`]): the
//!   vehicle ([`vehicle`]) on one rail of a ballasted track ([`track`]) through Hertz
//!   contacts, over irregularities ([`irregularity`]), with its data in one place
//!   ([`parameters`]);
//! - the study's cases, the car as built against the user's catalogue vehicle, the sampled
//!   and noisy measurements, the tuning and a filter run ([`study`]); the estimation model
//!   is `estimator::models::WheelRailVertical`.
//!
//! Still to come (issue 19): the FMU, `reproduce`'s table, the sweep, the benchmarks;
//! `reproduce` lists S2 as not built.

pub mod irregularity;
pub mod parameters;
pub mod plant;
pub mod study;
pub mod sweep;
pub mod track;
pub mod vehicle;
