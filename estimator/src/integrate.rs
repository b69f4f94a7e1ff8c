//! The classical fourth-order Runge–Kutta step, and the adapter that turns a
//! continuous-time model into a discrete-time [`Process`].

use crate::model::{Component, Observation, Process, VectorField, BLOCK_POINTS};

/// Stage buffers for RK4 on `n` rows of `L` lanes each: one lane per point,
/// so the same arithmetic serves one point (`L = 1`) or a block of points.
#[derive(Debug, Clone)]
struct Stages<const L: usize> {
    k1: Vec<[f64; L]>,
    k2: Vec<[f64; L]>,
    k3: Vec<[f64; L]>,
    k4: Vec<[f64; L]>,
    stage: Vec<[f64; L]>,
}

impl<const L: usize> Stages<L> {
    fn new(n: usize) -> Self {
        let zeros = vec![[0.0; L]; n];
        Self { k1: zeros.clone(), k2: zeros.clone(), k3: zeros.clone(), k4: zeros.clone(), stage: zeros }
    }

    /// One step of size `h` from `(t, x)`, written to `x_next`:
    /// `x + h/6·(k1 + 2k2 + 2k3 + k4)`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn step<F: Lanewise<L> + ?Sized>(
        &mut self,
        f: &F,
        t: f64,
        h: f64,
        x: &[[f64; L]],
        u: &[f64],
        x_next: &mut [[f64; L]],
        scratch: &mut [f64],
    ) {
        debug_assert!(self.k1.len() == x.len() && x_next.len() == x.len());
        f.derivative_lanes(t, x, u, &mut self.k1, scratch);
        stage(&mut self.stage, x, 0.5 * h, &self.k1);
        f.derivative_lanes(t + 0.5 * h, &self.stage, u, &mut self.k2, scratch);
        stage(&mut self.stage, x, 0.5 * h, &self.k2);
        f.derivative_lanes(t + 0.5 * h, &self.stage, u, &mut self.k3, scratch);
        stage(&mut self.stage, x, h, &self.k3);
        f.derivative_lanes(t + h, &self.stage, u, &mut self.k4, scratch);
        // Flat slices of equal length: one loop the compiler vectorises.
        let len = x_next.len() * L;
        let (out, x) = (&mut x_next.as_flattened_mut()[..len], &x.as_flattened()[..len]);
        let (k1, k2) = (&self.k1.as_flattened()[..len], &self.k2.as_flattened()[..len]);
        let (k3, k4) = (&self.k3.as_flattened()[..len], &self.k4.as_flattened()[..len]);
        for i in 0..len {
            out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
}

/// A vector field's derivative on rows of `L` lanes: one point, or a block.
/// (A trait rather than a closure: a closure is compiled as a function of its
/// own, without the AVX2 of the filter step it is called from.)
trait Lanewise<const L: usize> {
    fn derivative_lanes(&self, t: f64, x: &[[f64; L]], u: &[f64], dxdt: &mut [[f64; L]], scratch: &mut [f64]);
}

impl<F: VectorField + ?Sized> Lanewise<1> for F {
    #[inline(always)]
    fn derivative_lanes(&self, t: f64, x: &[[f64; 1]], u: &[f64], dxdt: &mut [[f64; 1]], _scratch: &mut [f64]) {
        self.derivative(t, x.as_flattened(), u, dxdt.as_flattened_mut());
    }
}

impl<F: VectorField + ?Sized> Lanewise<BLOCK_POINTS> for F {
    #[inline(always)]
    fn derivative_lanes(&self, t: f64, x: &[Component], u: &[f64], dxdt: &mut [Component], scratch: &mut [f64]) {
        self.derivative_block(t, x, u, dxdt, scratch);
    }
}

/// `out = x + a·k`.
#[inline(always)]
fn stage<const L: usize>(out: &mut [[f64; L]], x: &[[f64; L]], a: f64, k: &[[f64; L]]) {
    let len = out.len() * L;
    let (out, x, k) = (&mut out.as_flattened_mut()[..len], &x.as_flattened()[..len], &k.as_flattened()[..len]);
    for i in 0..len {
        out[i] = x[i] + a * k[i];
    }
}

/// Stage buffers for RK4 on an `n`-state system, allocated once.
#[derive(Debug, Clone)]
pub struct Rk4 {
    stages: Stages<1>,
}

impl Rk4 {
    /// Buffers for an `n`-state system.
    pub fn new(n: usize) -> Self {
        Self { stages: Stages::new(n) }
    }

    /// One step of size `h` from `(t, x)`, written to `x_next`:
    /// `x + h/6·(k1 + 2k2 + 2k3 + k4)`.
    pub fn step<F: VectorField + ?Sized>(&mut self, f: &F, t: f64, h: f64, x: &[f64], u: &[f64], x_next: &mut [f64]) {
        self.stages.step(f, t, h, x.as_chunks().0, u, x_next.as_chunks_mut().0, &mut []);
    }
}

/// A continuous-time model discretised by `substeps` RK4 steps per sample.
///
/// It is a [`Process`], and an [`Observation`] when the wrapped model is one,
/// so `Discretized::rk4(model, 1)` is directly a filter's model. On blocks of
/// points it runs the same RK4 lane by lane through the model's
/// [`derivative_block`](VectorField::derivative_block).
#[derive(Debug, Clone)]
pub struct Discretized<F> {
    field: F,
    substeps: usize,
    rk4: Rk4,
    buffer: Vec<f64>,
    block_stages: Stages<BLOCK_POINTS>,
    block_buffer: Vec<Component>,
}

impl<F: VectorField> Discretized<F> {
    /// `substeps ≥ 1` RK4 steps of `Δt/substeps` per sample (0 is taken as 1).
    pub fn rk4(field: F, substeps: usize) -> Self {
        let n = field.state_dim();
        Self {
            field,
            substeps: substeps.max(1),
            rk4: Rk4::new(n),
            buffer: vec![0.0; n],
            block_stages: Stages::new(n),
            block_buffer: vec![[0.0; BLOCK_POINTS]; n],
        }
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
        self.rk4.step(&self.field, t, h, x, u, x_next);
        for s in 1..self.substeps {
            self.buffer.copy_from_slice(x_next);
            self.rk4.step(&self.field, t + s as f64 * h, h, &self.buffer, u, x_next);
        }
    }

    #[inline(always)]
    fn transition_block(
        &mut self,
        t: f64,
        dt: f64,
        x: &[Component],
        u: &[f64],
        x_next: &mut [Component],
        scratch: &mut [f64],
    ) {
        let h = dt / self.substeps as f64;
        self.block_stages.step(&self.field, t, h, x, u, x_next, scratch);
        for s in 1..self.substeps {
            self.block_buffer.copy_from_slice(x_next);
            let t = t + s as f64 * h;
            self.block_stages.step(&self.field, t, h, &self.block_buffer, u, x_next, scratch);
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

    #[inline(always)]
    fn observe_block(&self, t: f64, x: &[Component], u: &[f64], z: &mut [Component], scratch: &mut [f64]) {
        self.field.observe_block(t, x, u, z, scratch)
    }
}
