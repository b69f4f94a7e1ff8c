//! The classical fourth-order Runge–Kutta step, and the adapter that turns a
//! continuous-time model into a discrete-time [`Process`].

use crate::model::{Observation, Process, VectorField};

/// Stage buffers for RK4 on an `n`-state system, allocated once.
#[derive(Debug, Clone)]
pub struct Rk4 {
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    stage: Vec<f64>,
}

impl Rk4 {
    /// Buffers for an `n`-state system.
    pub fn new(n: usize) -> Self {
        Self { k1: vec![0.0; n], k2: vec![0.0; n], k3: vec![0.0; n], k4: vec![0.0; n], stage: vec![0.0; n] }
    }

    /// One step of size `h` from `(t, x)`, written to `x_next`:
    /// `x + h/6·(k1 + 2k2 + 2k3 + k4)`.
    pub fn step<F: VectorField + ?Sized>(&mut self, f: &F, t: f64, h: f64, x: &[f64], u: &[f64], x_next: &mut [f64]) {
        let n = x.len();
        debug_assert!(self.k1.len() == n && x_next.len() == n);
        f.derivative(t, x, u, &mut self.k1);
        stage(&mut self.stage, x, 0.5 * h, &self.k1);
        f.derivative(t + 0.5 * h, &self.stage, u, &mut self.k2);
        stage(&mut self.stage, x, 0.5 * h, &self.k2);
        f.derivative(t + 0.5 * h, &self.stage, u, &mut self.k3);
        stage(&mut self.stage, x, h, &self.k3);
        f.derivative(t + h, &self.stage, u, &mut self.k4);
        for i in 0..n {
            x_next[i] = x[i] + h / 6.0 * (self.k1[i] + 2.0 * self.k2[i] + 2.0 * self.k3[i] + self.k4[i]);
        }
    }
}

/// `out = x + a·k`.
#[inline]
fn stage(out: &mut [f64], x: &[f64], a: f64, k: &[f64]) {
    for ((o, xi), ki) in out.iter_mut().zip(x).zip(k) {
        *o = xi + a * ki;
    }
}

/// A continuous-time model discretised by `substeps` RK4 steps per sample.
///
/// It is a [`Process`], and an [`Observation`] when the wrapped model is one,
/// so `Discretized::rk4(model, 1)` is directly a filter's model.
#[derive(Debug, Clone)]
pub struct Discretized<F> {
    field: F,
    substeps: usize,
    rk4: Rk4,
    buffer: Vec<f64>,
}

impl<F: VectorField> Discretized<F> {
    /// `substeps ≥ 1` RK4 steps of `Δt/substeps` per sample (0 is taken as 1).
    pub fn rk4(field: F, substeps: usize) -> Self {
        let n = field.state_dim();
        Self { field, substeps: substeps.max(1), rk4: Rk4::new(n), buffer: vec![0.0; n] }
    }

    /// The continuous-time model.
    pub fn field(&self) -> &F {
        &self.field
    }

    /// The continuous-time model, to change its parameters between steps.
    pub fn field_mut(&mut self) -> &mut F {
        &mut self.field
    }

    /// RK4 steps per sample.
    pub fn substeps(&self) -> usize {
        self.substeps
    }
}

impl<F: VectorField> Process for Discretized<F> {
    fn state_dim(&self) -> usize {
        self.field.state_dim()
    }

    fn input_dim(&self) -> usize {
        self.field.input_dim()
    }

    fn transition(&mut self, t: f64, dt: f64, x: &[f64], u: &[f64], x_next: &mut [f64]) {
        let h = dt / self.substeps as f64;
        x_next.copy_from_slice(x);
        for s in 0..self.substeps {
            self.buffer.copy_from_slice(x_next);
            self.rk4.step(&self.field, t + s as f64 * h, h, &self.buffer, u, x_next);
        }
    }
}

impl<F: VectorField + Observation> Observation for Discretized<F> {
    fn measurement_dim(&self) -> usize {
        self.field.measurement_dim()
    }

    fn observe(&self, t: f64, x: &[f64], u: &[f64], z: &mut [f64]) {
        self.field.observe(t, x, u, z)
    }
}
