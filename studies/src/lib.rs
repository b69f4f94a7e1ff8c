//! The studies, one module per study: each study's estimator set-up, its runs behind the
//! supervised loop (`estimator::SupervisedFilter`), its sweeps and fault runs, and its part
//! of `kalfmu reproduce` through the packaged FMU. The truths are the `truth` crate's; the
//! co-simulation master is the `cosim` crate's. No study imports another's: what they
//! share is [`comparison`] and [`shard`].

pub mod comparison;
pub mod robustness;
pub mod s1;
pub mod s2;
pub mod s3;
pub mod s4;
pub mod s5;
pub mod smoothed;
pub mod system;
pub use shard;
