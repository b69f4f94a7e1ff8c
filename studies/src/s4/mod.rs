//! Study S4: a maglev train's speed and position from four redundant long-stator PRW
//! position channels: the paper's outlier rejection, adaptive weighted fusion and UKF on
//! the differenced speeds `[MaglevUKF2024]`, against ours on the positions. The truth is
//! [`truth::s4`]; the conventions and the fault model are in `docs/studies/s4.md`.
//!
//! - The paper's pipeline ([`paper`]), ours on the positions ([`ours`]), their scores
//!   ([`metrics`]) and the command that compares them ([`compare`]).
//! - Ours through the packaged FMU ([`fmu_run`]) in `kalfmu reproduce` ([`reproduce`]), the
//!   raw average and the paper's pipeline logged beside it ([`baselines`]).

pub mod baselines;
pub mod compare;
pub mod fmu_run;
pub mod metrics;
pub mod ours;
pub mod paper;
pub mod reproduce;
