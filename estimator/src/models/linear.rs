//! A linear-Gaussian model `x' = A·x + B·u`, `z = H·x`: the case in which every
//! filter of this crate must reproduce the Kalman filter exactly.

use nalgebra::DMatrix;

use crate::model::{Observation, Process};

/// Discrete-time linear model (`Δt` is ignored: `A` is per sample).
#[derive(Debug, Clone)]
pub struct LinearGaussian {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    h: DMatrix<f64>,
}

impl LinearGaussian {
    /// `A` (`n × n`), `B` (`n × p`), `H` (`m × n`).
    pub fn new(a: DMatrix<f64>, b: DMatrix<f64>, h: DMatrix<f64>) -> Self {
        assert!(
            a.is_square() && b.nrows() == a.nrows() && h.ncols() == a.nrows(),
            "inconsistent LinearGaussian shapes"
        );
        Self { a, b, h }
    }

    /// `A`.
    pub fn a(&self) -> &DMatrix<f64> {
        &self.a
    }

    /// `B`.
    pub fn b(&self) -> &DMatrix<f64> {
        &self.b
    }

    /// `H`.
    pub fn h(&self) -> &DMatrix<f64> {
        &self.h
    }
}

impl Process for LinearGaussian {
    fn state_dim(&self) -> usize {
        self.a.nrows()
    }

    fn input_dim(&self) -> usize {
        self.b.ncols()
    }

    fn transition(&mut self, _t: f64, _dt: f64, x: &[f64], u: &[f64], x_next: &mut [f64]) {
        for (i, out) in x_next.iter_mut().enumerate() {
            let ax: f64 = x.iter().enumerate().map(|(j, xj)| self.a[(i, j)] * xj).sum();
            let bu: f64 = u.iter().enumerate().map(|(j, uj)| self.b[(i, j)] * uj).sum();
            *out = ax + bu;
        }
    }
}

impl Observation for LinearGaussian {
    fn measurement_dim(&self) -> usize {
        self.h.nrows()
    }

    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        for (i, out) in z.iter_mut().enumerate() {
            *out = (0..self.h.ncols()).map(|j| self.h[(i, j)] * x[j]).sum();
        }
    }
}
