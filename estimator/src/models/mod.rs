//! The estimation models of the studies, and small models for tests and examples.

mod linear;
mod oscillator_2dof;
mod piecewise;
mod wheel_rail_vertical;

pub use linear::LinearGaussian;
pub use oscillator_2dof::{Oscillator2Dof, Oscillator2DofLoad};
pub use piecewise::PiecewiseLinear;
pub use wheel_rail_vertical::{VerticalVehicle, WheelRailVertical};
