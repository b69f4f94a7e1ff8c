//! Truth simulators and study runners. Depends on the estimation library for
//! the physical laws and the filters; the filters never see the truth.

pub mod cosimulation;
pub mod fmu_driver;
pub mod jobs;
pub mod replay;
pub mod reproduce;
pub mod s1;
pub mod s1_faults;
pub mod s2;
pub mod s4;
pub mod s5;
pub mod sweep;
