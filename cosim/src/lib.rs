//! The co-simulation master of the studies: it loads a packaged estimator FMU through
//! the `fmi` crate's importer ([`fmu_driver`]) and steps it against a truth as an
//! external simulator would, writing the run as an MCAP log ([`master`]).

pub mod fmu_driver;
pub mod master;
