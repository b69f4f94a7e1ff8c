//! Problems, separate from solvers: a state-space model is two small traits,
//! and every filter in this crate runs any type that implements both.
//!
//! ```text
//! x_{k+1} = φ(t_k, Δt, x_k, u_k) + w_k     w_k ~ N(0, Q)     (Process)
//! z_k     = h(t_k, x_k, u_k)     + v_k     v_k ~ N(0, R)     (Observation)
//! ```
//!
//! A continuous-time model implements [`VectorField`] (`ẋ = f(t, x, u)`) and is
//! turned into a [`Process`] by [`Discretized`](crate::Discretized), one RK4
//! step (or several sub-steps) per sample, as the papers do. `Q` and `R` are
//! not part of the model: they are the tuning of one filter instance
//! ([`Noise`](crate::Noise)), so one physical model serves several tunings.
//!
//! All functions write into caller-owned slices; a model must not allocate in
//! them, so a filter step stays allocation-free.

/// The time update of a discrete-time model.
pub trait Process {
    /// The state dimension `n`.
    fn state_dim(&self) -> usize;
    /// The input dimension (known inputs `u`); zero by default.
    fn input_dim(&self) -> usize {
        0
    }
    /// Writes `φ(t, Δt, x, u)` (the state one sample later) into `x_next`.
    ///
    /// Takes `&mut self` so that an integrator can keep its stages in the model.
    fn transition(&mut self, t: f64, dt: f64, x: &[f64], u: &[f64], x_next: &mut [f64]);
}

/// The measurement function of a model.
pub trait Observation {
    /// The measurement dimension `m`.
    fn measurement_dim(&self) -> usize;
    /// Writes the noise-free measurement `h(t, x, u)` into `z`.
    fn observe(&self, t: f64, x: &[f64], u: &[f64], z: &mut [f64]);
}

/// A complete estimation model: a process and its observation.
pub trait Model: Process + Observation {}
impl<T: Process + Observation> Model for T {}

/// A continuous-time process `ẋ = f(t, x, u)`.
pub trait VectorField {
    /// The state dimension `n`.
    fn state_dim(&self) -> usize;
    /// The input dimension; zero by default.
    fn input_dim(&self) -> usize {
        0
    }
    /// Writes `f(t, x, u)` into `dxdt`.
    fn derivative(&self, t: f64, x: &[f64], u: &[f64], dxdt: &mut [f64]);
}
