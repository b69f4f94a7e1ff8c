//! The co-simulation masters of the studies: they load packaged FMUs through the `fmi`
//! crate's importer ([`fmu_driver`]) and step them as an external simulator would: an
//! estimator FMU against a truth, writing the run as an MCAP log ([`master`]), or a
//! system of FMUs from an SSP archive ([`ssp`], [`system_master`]).

pub mod fmu_driver;
pub mod master;
pub mod ssp;
pub mod system_master;
