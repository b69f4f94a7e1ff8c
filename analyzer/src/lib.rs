//! The kalfmu analyzer: reads MCAP logs of co-simulation runs (measurements,
//! truth, estimates), computes the comparison metrics of the studies, and
//! writes Rerun recordings for review. It depends on the log format only,
//! never on the estimators.
//!
//! ```no_run
//! use analyzer::{read::read_log, report::{analyse, Options}};
//! let run = read_log(std::path::Path::new("run.mcap")).unwrap();
//! let report = analyse(&run, &Options::default()).unwrap();
//! print!("{}", report.table());
//! analyzer::rrd::write_rrd(&report, &run, std::path::Path::new("run.rrd")).unwrap();
//! ```

pub mod container;
pub mod error;
pub mod log;
pub mod metrics;
pub mod psd;
pub mod read;
pub mod report;
pub mod rrd;

pub use error::LogError;
