//! Study S2's truth: a vehicle–track coupled model richer than the estimator's
//! ([`plant`]): the vehicle ([`vehicle`]) on one rail of a ballasted track ([`track`])
//! through Hertz contacts, over irregularities ([`irregularity`]), with its data in one
//! place ([`parameters`]); the paper's cases, the car as built and the noisy measurements
//! ([`cases`]), the signals sampled as a data acquisition does ([`daq`]), and the truth as a
//! plant a master steps sample by sample ([`recording`]).

pub mod cases;
pub mod daq;
pub mod irregularity;
pub mod parameters;
pub mod plant;
pub mod recording;
pub mod track;
pub mod vehicle;
