//! Study S4: a maglev train's speed and position from four redundant long-stator PRW
//! position channels (seed `003_…`: outlier rejection, adaptive weighted fusion and a UKF
//! on the differenced speeds). The conventions and the fault model are
//! `docs/s4-maglev.md`.
//!
//! - The numbers, each with its source ([`parameters`]).
//! - The motions, exact at any instant: the paper's test run and a jerk-limited run to
//!   500 km/h ([`profile`]).
//! - The channels, head and tail × left and right, recording a run ([`channels`]) with
//!   their noise and faults ([`faults`]); the recording, its raw speeds and its true
//!   speeds ([`recording`]).
//! - The paper's pipeline ([`paper`]), ours on the positions ([`ours`]), their scores
//!   ([`metrics`]) and the command that compares them ([`compare`]).
//! - Ours through the packaged FMU ([`fmu_run`]) in `scenarios reproduce` ([`reproduce`]).

pub mod channels;
pub mod compare;
pub mod faults;
pub mod fmu_run;
pub mod metrics;
pub mod ours;
pub mod paper;
pub mod parameters;
pub mod profile;
pub mod recording;
pub mod reproduce;
