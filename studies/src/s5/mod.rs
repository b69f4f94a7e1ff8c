//! Study S5: a tactical missile's ten force coefficients identified online from twelve
//! measurements, a 20-state augmented 6-DOF, SVD-CKF against CKF `[Jiang2024]`, through a
//! change of every coefficient mid-flight. The conventions are in `docs/studies/s5.md`.
//!
//! - The truths are [`truth::s5`] (the paper's 6-DOF) and JSBSim (`truth/s5_jsbsim/`).
//! - The study: the one tuning and a filter run in-process ([`study`]); how much the
//!   manoeuvre tells about each coefficient ([`excitation`]).
//! - Through the packaged FMU `kalfmu_s5_missile` ([`fmu_run`]): `reproduce`'s table
//!   ([`reproduce`]); its Monte Carlo ([`monte_carlo`]) and robustness runs
//!   ([`robustness`]); the flight as an FMU input table ([`export`]).
//! - As a system of FMUs, the plant FMU `kalfmu_s5_flight` wired to the estimator FMU in an
//!   SSP archive ([`system`]).

pub mod excitation;
pub mod export;
pub mod fmu_run;
pub mod monte_carlo;
pub mod reproduce;
pub mod robustness;
pub mod study;
pub mod system;
