//! The truth simulators of the studies: plants richer than the estimators that are
//! tried on them, and their sensors, every one of which carries noise. A study's
//! estimator never sees what is here except through the measurements.
//!
//! The plants use the estimation library's physical laws only where the study's paper
//! has its truth share them with its estimator (S1's chain law, S5's airframe); they
//! never build a filter.

pub mod s1;
pub mod s2;
pub mod s3;
pub mod s4;
pub mod s5;
pub mod sensor_noise;
