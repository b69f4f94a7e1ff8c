//! The kalfmu log format: MCAP logs of co-simulation runs (measurements, truth,
//! estimates), their writer, and a streaming reader that checks them, recovers what a
//! log cut short holds, and also reads the JSON and ROS 2 (CDR) channels other tools log.
//! `docs/log-format.md` is the reference. It depends on MCAP only (no analysis, no
//! recordings), so a crate that writes logs builds little.
//!
//! ```no_run
//! use std::collections::BTreeMap;
//! use log_format::write::{LogWriter, SignalSpec, TRUTH};
//! let mut writer = LogWriter::create("run.mcap".as_ref(), &BTreeMap::new()).unwrap();
//! let truth = writer.add_channel(TRUTH, &[SignalSpec::new("F", "N", "load")]).unwrap();
//! writer.write(truth, 0.0, &[1.5]).unwrap();
//! writer.finish().unwrap();
//! let run = log_format::read::read_log("run.mcap".as_ref()).unwrap();
//! assert_eq!(run.channel(TRUTH).unwrap().signal("F").unwrap().values, [1.5]);
//! ```

mod cdr;
pub mod container;
mod decode;
pub mod error;
mod json;
pub mod read;
mod ros2msg;
pub mod write;

pub use error::LogError;
