//! Study S1: two masses in series, `ground —(k₁, c₁)— m₁ —(k₂, c₂)— m₂`, with the
//! unknown load `F` on the free mass `m₂` (our reading of `[Gong2024]`,
//! whose figure of the chain is missing). One element of the ground link is nonlinear.
//!
//! ```text
//! m₁·z̈₁ = −F_k1(z₁) − F_c1(ż₁) + k₂·(z₂ − z₁) + c₂·(ż₂ − ż₁)
//! m₂·z̈₂ = F − k₂·(z₂ − z₁) − c₂·(ż₂ − ż₁)
//! ```
//!
//! [`Oscillator2Dof`] is the physical system (used by the truth simulator as
//! well); [`Oscillator2DofLoad`] the estimation model of the paper: the state
//! `[z₁, z₂, F, ż₁, ż₂, Ḟ]` with `F` a second-order random walk (`F̈ = 0` plus
//! noise) and the measurements `[z̈₁, z̈₂]` (eqs. (5)–(7)).

use crate::model::{Component, Observation, VectorField};
use crate::models::PiecewiseLinear;

/// The physical two-mass chain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oscillator2Dof {
    /// Mass `m₁` (kg).
    pub m1: f64,
    /// Mass `m₂` (kg).
    pub m2: f64,
    /// Ground spring law `F_k1(z₁)` (N).
    pub k1: PiecewiseLinear,
    /// Ground damper law `F_c1(ż₁)` (N).
    pub c1: PiecewiseLinear,
    /// Coupling stiffness `k₂` (N/m).
    pub k2: f64,
    /// Coupling damping `c₂` (N·s/m).
    pub c2: f64,
}

impl Oscillator2Dof {
    /// Table 1 of the paper: `k₁` nonlinear (5, 20, 30 N/m; δ = 0.1, 0.2 m),
    /// `k₂ = 15 N/m`, `c₁ = 5`, `c₂ = 3 N·s/m`, `m₁ = 4`, `m₂ = 8 kg`.
    pub fn stiffness_nonlinear() -> Self {
        Self {
            m1: 4.0,
            m2: 8.0,
            k1: PiecewiseLinear::new([5.0, 20.0, 30.0], [0.1, 0.2]).expect("table 1 is valid"),
            c1: PiecewiseLinear::linear(5.0),
            k2: 15.0,
            c2: 3.0,
        }
    }

    /// Table 2 of the paper: `c₁` nonlinear (2, 30, 40 N·s/m; ε = 0.05, 0.10 m/s),
    /// `k₁ = 10`, `k₂ = 15 N/m`, `c₂ = 3 N·s/m`, `m₁ = 4`, `m₂ = 8 kg`.
    pub fn damping_nonlinear() -> Self {
        Self {
            m1: 4.0,
            m2: 8.0,
            k1: PiecewiseLinear::linear(10.0),
            c1: PiecewiseLinear::new([2.0, 30.0, 40.0], [0.05, 0.10]).expect("table 2 is valid"),
            k2: 15.0,
            c2: 3.0,
        }
    }

    /// Accelerations `(z̈₁, z̈₂)` for positions, velocities and the load `F`.
    #[inline]
    pub fn accelerations(&self, z1: f64, z2: f64, v1: f64, v2: f64, load: f64) -> (f64, f64) {
        let ([a1], [a2]) = self.accelerations_lanes(&[z1], &[z2], &[v1], &[v2], &[load]);
        (a1, a2)
    }

    /// [`accelerations`](Self::accelerations) lane by lane (one point per
    /// lane), in the shape the compiler vectorises across points.
    #[inline(always)]
    pub fn accelerations_lanes<const L: usize>(
        &self,
        z1: &[f64; L],
        z2: &[f64; L],
        v1: &[f64; L],
        v2: &[f64; L],
        load: &[f64; L],
    ) -> ([f64; L], [f64; L]) {
        let (spring, damper) = (self.k1.force_lanes(z1), self.c1.force_lanes(v1));
        let (mut a1, mut a2) = ([0.0; L], [0.0; L]);
        for l in 0..L {
            let coupling = self.k2 * (z2[l] - z1[l]) + self.c2 * (v2[l] - v1[l]);
            let ground = spring[l] + damper[l];
            a1[l] = (coupling - ground) / self.m1;
            a2[l] = (load[l] - coupling) / self.m2;
        }
        (a1, a2)
    }
}

/// The paper's augmented estimation model: state `[z₁, z₂, F, ż₁, ż₂, Ḟ]`,
/// measurements `[z̈₁, z̈₂]` (m/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oscillator2DofLoad {
    /// The physical chain the estimator assumes.
    pub chain: Oscillator2Dof,
}

impl Oscillator2DofLoad {
    /// Index of the load `F` in the state.
    pub const LOAD: usize = 2;
    /// The unknown input's state that a jump moves: `F` (a step of the load).
    /// Not `Ḟ`: opened by the same jump in proportion to its random walk, its
    /// variance would reach 1e11 N²/s² for a 100 N step, unobserved at that
    /// sample, and the covariance would lose its definiteness.
    pub const UNKNOWN_INPUTS: [usize; 1] = [2];
    /// Names of the state components, in order.
    pub const STATE_NAMES: [&'static str; 6] = ["z1", "z2", "F", "z1_dot", "z2_dot", "F_dot"];
    /// Names of the measurements, in order.
    pub const MEASUREMENT_NAMES: [&'static str; 2] = ["z1_ddot", "z2_ddot"];

    /// The model for a chain.
    pub fn new(chain: Oscillator2Dof) -> Self {
        Self { chain }
    }
}

impl Oscillator2DofLoad {
    /// `ẋ` lane by lane: `L = 1` for one point, or a block of points.
    #[inline(always)]
    fn derivative_lanes<const L: usize>(&self, x: &[[f64; L]], dxdt: &mut [[f64; L]]) {
        let (a1, a2) = self.chain.accelerations_lanes(&x[0], &x[1], &x[3], &x[4], &x[2]);
        dxdt[0] = x[3];
        dxdt[1] = x[4];
        dxdt[2] = x[5];
        dxdt[3] = a1;
        dxdt[4] = a2;
        dxdt[5] = [0.0; L];
    }

    /// `[z̈₁, z̈₂]` lane by lane.
    #[inline(always)]
    fn observe_lanes<const L: usize>(&self, x: &[[f64; L]], z: &mut [[f64; L]]) {
        (z[0], z[1]) = self.chain.accelerations_lanes(&x[0], &x[1], &x[3], &x[4], &x[2]);
    }
}

impl VectorField for Oscillator2DofLoad {
    fn state_dim(&self) -> usize {
        6
    }

    fn derivative(&self, _t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        self.derivative_lanes::<1>(x.as_chunks().0, dxdt.as_chunks_mut().0);
    }

    #[inline(always)]
    fn derivative_block(&self, _t: f64, x: &[Component], _u: &[f64], dxdt: &mut [Component], _scratch: &mut [f64]) {
        self.derivative_lanes(x, dxdt);
    }
}

impl Observation for Oscillator2DofLoad {
    fn measurement_dim(&self) -> usize {
        2
    }

    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.observe_lanes::<1>(x.as_chunks().0, z.as_chunks_mut().0);
    }

    #[inline(always)]
    fn observe_block(&self, _t: f64, x: &[Component], _u: &[f64], z: &mut [Component], _scratch: &mut [f64]) {
        self.observe_lanes(x, z);
    }
}
