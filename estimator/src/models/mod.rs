//! The estimation models of the studies, and small models for tests and examples.

pub mod atmosphere;
mod linear;
mod missile_6dof;
mod oscillator_2dof;
mod piecewise;
mod prw_train;
mod wheel_rail_roll;
mod wheel_rail_vertical;

pub use linear::LinearGaussian;
pub use missile_6dof::{Air, Airframe, Missile6Dof, MomentModel};
pub use oscillator_2dof::{Oscillator2Dof, Oscillator2DofLoad};
pub use piecewise::PiecewiseLinear;
pub use prw_train::PrwTrain;
pub use wheel_rail_roll::{RollVehicle, WheelRailRoll};
pub use wheel_rail_vertical::{VerticalVehicle, WheelRailVertical};
