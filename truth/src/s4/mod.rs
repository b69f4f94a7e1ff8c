//! Study S4's truth: a maglev train's motion and its four redundant long-stator PRW
//! position channels. The conventions and the fault model are in `docs/studies/s4.md`.
//!
//! - The numbers, each with its source ([`parameters`]).
//! - The motions, exact at any instant: the paper's test run and a jerk-limited run to
//!   500 km/h ([`profile`]).
//! - The channels, head and tail × left and right, recording a run ([`channels`]) with
//!   their noise and faults ([`faults`]: the default fault rates, and named profiles
//!   such as `frequent` at ten times them); the recording, its raw speeds and its true
//!   speeds ([`recording`]).

pub mod channels;
pub mod faults;
pub mod parameters;
pub mod profile;
pub mod recording;
