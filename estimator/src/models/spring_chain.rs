//! A 24-state augmented chain: ten masses in series from the ground, linear
//! springs and piecewise-linear dampers (two slopes, as the primary dampers of
//! study S2), four unknown forces as first-order random walks, and seven
//! accelerometers. It has the size of the S2 estimator (20 motion states plus
//! 4 forces, 7 measurements) and stands in for it in benchmarks until the
//! vehicle model lands.
//!
//! ```text
//! state  [z₁ … z₁₀, ż₁ … ż₁₀, F₁ … F₄]
//! mᵢ·z̈ᵢ = Fᵢ₋₁,ᵢ − Fᵢ,ᵢ₊₁ + (unknown force on i),   element force k·Δz + D(Δż)
//! z     [z̈ at masses 1, 2, 4, 5, 7, 8, 10]
//! ```

use crate::model::{Component, Observation, VectorField};
use crate::models::PiecewiseLinear;

const MASSES: usize = 10;
const FORCES: [usize; 4] = [2, 4, 6, 9];
const SENSORS: [usize; 7] = [0, 1, 3, 4, 6, 7, 9];

/// The ten-mass chain with four unknown forces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringChainForces {
    mass: f64,
    stiffness: f64,
    damper: PiecewiseLinear,
}

impl Default for SpringChainForces {
    /// 100 kg masses, 1e5 N/m springs, dampers 2e3 N·s/m up to 0.1 m/s, 5e2 beyond.
    fn default() -> Self {
        Self { mass: 100.0, stiffness: 1e5, damper: PiecewiseLinear::new([2e3, 5e2, 5e2], [0.1, 0.1]).expect("valid") }
    }
}

impl SpringChainForces {
    /// The force in element i, which joins mass i−1 (or the ground) to mass i.
    #[inline(always)]
    fn element<const L: usize>(&self, z: &[[f64; L]], v: &[[f64; L]], i: usize) -> [f64; L] {
        let (mut dz, mut dv) = (z[i], v[i]);
        if i > 0 {
            for l in 0..L {
                dz[l] -= z[i - 1][l];
                dv[l] -= v[i - 1][l];
            }
        }
        let mut force = self.damper.force_lanes(&dv);
        for l in 0..L {
            force[l] += self.stiffness * dz[l];
        }
        force
    }

    /// The accelerations `z̈`, lane by lane: `L = 1` for one point, or a
    /// block of points with one lane each (the same arithmetic, vectorised).
    /// No closures: they would be compiled apart, without the caller's AVX2.
    #[inline(always)]
    fn accelerations<const L: usize>(&self, x: &[[f64; L]], out: &mut [[f64; L]]) {
        let (z, v, f) = (&x[..MASSES], &x[MASSES..2 * MASSES], &x[2 * MASSES..]);
        // Multiplied by 1/m: a division per mass would cost more than the rest of the law.
        let inv_mass = 1.0 / self.mass;
        let mut below = self.element(z, v, 0);
        for (i, acc) in out.iter_mut().enumerate().take(MASSES) {
            let above = if i + 1 < MASSES { self.element(z, v, i + 1) } else { [0.0; L] };
            for l in 0..L {
                acc[l] = (above[l] - below[l]) * inv_mass;
            }
            below = above;
        }
        for (k, &i) in FORCES.iter().enumerate() {
            for l in 0..L {
                out[i][l] += f[k][l] * inv_mass;
            }
        }
    }

    #[inline(always)]
    fn derivative_lanes<const L: usize>(&self, x: &[[f64; L]], dxdt: &mut [[f64; L]]) {
        dxdt[..MASSES].copy_from_slice(&x[MASSES..2 * MASSES]);
        self.accelerations(x, &mut dxdt[MASSES..2 * MASSES]);
        dxdt[2 * MASSES..].fill([0.0; L]);
    }

    #[inline(always)]
    fn observe_lanes<const L: usize>(&self, x: &[[f64; L]], z: &mut [[f64; L]]) {
        let mut acc = [[0.0; L]; MASSES];
        self.accelerations(x, &mut acc);
        for (k, &i) in SENSORS.iter().enumerate() {
            z[k] = acc[i];
        }
    }
}

impl VectorField for SpringChainForces {
    fn state_dim(&self) -> usize {
        2 * MASSES + FORCES.len()
    }

    fn derivative(&self, _t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        self.derivative_lanes::<1>(x.as_chunks().0, dxdt.as_chunks_mut().0);
    }

    #[inline(always)]
    fn derivative_block(&self, _t: f64, x: &[Component], _u: &[f64], dxdt: &mut [Component], _scratch: &mut [f64]) {
        self.derivative_lanes(x, dxdt);
    }
}

impl Observation for SpringChainForces {
    fn measurement_dim(&self) -> usize {
        SENSORS.len()
    }

    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.observe_lanes::<1>(x.as_chunks().0, z.as_chunks_mut().0);
    }

    #[inline(always)]
    fn observe_block(&self, _t: f64, x: &[Component], _u: &[f64], z: &mut [Component], _scratch: &mut [f64]) {
        self.observe_lanes(x, z);
    }
}
