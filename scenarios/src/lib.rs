//! Truth simulators and study runners. Depends on the estimation library for
//! the physical laws and the filters; the filters never see the truth.

pub mod replay;
