//! Study S5's first truth: the paper's 6-DOF missile on a flat Earth ([`plant`]), flying
//! the rudder inputs both truths fly ([`manoeuvre`]: the standard manoeuvre, and a second,
//! `roll-turn`, that the estimators were not tuned on), its numbers each with its source
//! ([`parameters`]), sampled with each sensor's noise ([`flight`]). The second truth,
//! JSBSim on a round rotating Earth, is a Python driver in `truth/s5_jsbsim/`.

pub mod flight;
pub mod manoeuvre;
pub mod parameters;
pub mod plant;
