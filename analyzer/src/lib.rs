//! The kalfmu analyzer: reads MCAP logs of co-simulation runs (measurements,
//! truth, estimates) through the `log-format` crate, computes the comparison metrics
//! of the studies, and writes Rerun recordings for review. It depends on the log
//! format only, never on the estimators.
//!
//! ```no_run
//! use analyzer::{compare::compare_runs, report::Options};
//! use log_format::read::read_log;
//! let runs = [read_log("ckf.mcap".as_ref()).unwrap(), read_log("ukf.mcap".as_ref()).unwrap()];
//! let comparison = compare_runs(&runs, &Options::default()).unwrap();
//! print!("{}", comparison.table());
//! analyzer::rrd::write_rrd(&comparison, &runs, "case.rrd".as_ref()).unwrap();
//! ```

pub mod compare;
pub mod consistency;
pub mod metrics;
pub mod psd;
pub mod report;
pub mod rrd;
pub mod views;
