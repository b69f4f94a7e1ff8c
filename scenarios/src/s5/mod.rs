//! Study S5: a tactical missile's ten force coefficients identified online from twelve
//! measurements (seed `004_…`: a 20-state augmented 6-DOF, SVD-CKF against CKF), through a
//! change of every coefficient mid-flight. The conventions are `docs/s5-missile.md`.
//!
//! - The numbers, each with its source ([`parameters`]); the rudder inputs both truths fly
//!   ([`manoeuvre`]).
//! - The first truth, the paper's 6-DOF on a flat Earth ([`plant`]); the second, JSBSim,
//!   is a Python driver (`scenarios/s5_jsbsim/`).
//! - The study: sampling, noise, the one tuning, a filter run in-process ([`study`]).

pub mod excitation;
pub mod export;
pub mod fmu_run;
pub mod manoeuvre;
pub mod monte_carlo;
pub mod parameters;
pub mod plant;
pub mod reproduce;
pub mod robustness;
pub mod study;
