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
//!
//! The sigma-point filters call a model on blocks of [`BLOCK_POINTS`] points
//! at once (`transition_block`, `observe_block`, `derivative_block`), stored
//! as one [`Component`] per state or measurement row. The default methods run
//! the point-by-point functions, so a model need not know about blocks; a
//! model whose law is written lane by lane without branches overrides them,
//! and the compiler then vectorises it across the points. Both must give the
//! same numbers, bit for bit: the filters' results must not depend on which
//! one runs. When the points do not fill the last block, its spare lanes hold
//! a copy of a real point (the mean), and what the model returns for them is
//! not used.

/// Points in a block of the batched model calls.
pub const BLOCK_POINTS: usize = 8;

/// One state component (or measurement row) at each point of a block.
pub type Component = [f64; BLOCK_POINTS];

/// Runs a point-by-point function on a block: for each point, gathers its
/// components into `scratch`, calls `f(input, output)`, and scatters the output.
/// `scratch` holds at least `input.len() + output.len()` values.
pub(crate) fn pointwise(
    input: &[Component],
    output: &mut [Component],
    scratch: &mut [f64],
    mut f: impl FnMut(&[f64], &mut [f64]),
) {
    let (x, rest) = scratch.split_at_mut(input.len());
    let y = &mut rest[..output.len()];
    for p in 0..BLOCK_POINTS {
        for (xi, c) in x.iter_mut().zip(input) {
            *xi = c[p];
        }
        f(x, y);
        for (c, yi) in output.iter_mut().zip(y.iter()) {
            c[p] = *yi;
        }
    }
}

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
    /// [`transition`](Self::transition) at the points of a block: `x` and
    /// `x_next` hold `n` components each. `scratch` has at least `2·n` values
    /// for the default, which goes point by point.
    fn transition_block(
        &mut self,
        t: f64,
        dt: f64,
        x: &[Component],
        u: &[f64],
        x_next: &mut [Component],
        scratch: &mut [f64],
    ) {
        pointwise(x, x_next, scratch, |x, y| self.transition(t, dt, x, u, y));
    }
}

/// The measurement function of a model.
pub trait Observation {
    /// The measurement dimension `m`.
    fn measurement_dim(&self) -> usize;
    /// Writes the noise-free measurement `h(t, x, u)` into `z`.
    fn observe(&self, t: f64, x: &[f64], u: &[f64], z: &mut [f64]);
    /// [`observe`](Self::observe) at the points of a block: `x` holds `n`
    /// components and `z` `m`. `scratch` has at least `n + m` values for the
    /// default, which goes point by point.
    fn observe_block(&self, t: f64, x: &[Component], u: &[f64], z: &mut [Component], scratch: &mut [f64]) {
        pointwise(x, z, scratch, |x, z| self.observe(t, x, u, z));
    }
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
    /// [`derivative`](Self::derivative) at the points of a block. `scratch`
    /// has at least `2·n` values for the default, which goes point by point.
    fn derivative_block(&self, t: f64, x: &[Component], u: &[f64], dxdt: &mut [Component], scratch: &mut [f64]) {
        pointwise(x, dxdt, scratch, |x, d| self.derivative(t, x, u, d));
    }
}
