//! The integrator: RK4 is fourth-order accurate, and sub-stepping a sample is
//! the same as taking the smaller steps by hand.

use estimator::math;
use estimator::{Discretized, Observation, Process, Rk4, VectorField};

/// The harmonic oscillator `ẍ = −ω²x` with `x(0) = 1, ẋ(0) = 0`: `x(t) = cos ωt`, `ẋ(t) = −ω sin ωt`.
struct Harmonic {
    omega: f64,
}

impl VectorField for Harmonic {
    fn state_dim(&self) -> usize {
        2
    }
    fn derivative(&self, _t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        dxdt[0] = x[1];
        dxdt[1] = -self.omega * self.omega * x[0];
    }
}

impl Observation for Harmonic {
    fn measurement_dim(&self) -> usize {
        1
    }
    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        z[0] = x[0];
    }
}

/// `ẋ = t·x`, non-autonomous, with `x(t) = exp(t²/2)`: checks the stage times.
struct TimeVarying;

impl VectorField for TimeVarying {
    fn state_dim(&self) -> usize {
        1
    }
    fn derivative(&self, t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        dxdt[0] = t * x[0];
    }
}

/// The error norm of the whole state at t = 1.
fn error_at_one<F: VectorField>(f: &F, x0: &[f64], exact: &[f64], steps: usize) -> f64 {
    let mut rk4 = Rk4::new(x0.len());
    let h = 1.0 / steps as f64;
    let mut x = x0.to_vec();
    let mut next = x.clone();
    for k in 0..steps {
        rk4.step(f, k as f64 * h, h, &x, &[], &mut next);
        x.copy_from_slice(&next);
    }
    x.iter().zip(exact).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt()
}

fn observed_order<F: VectorField>(f: &F, x0: &[f64], exact: &[f64]) -> f64 {
    // Far enough into the asymptotic range (h·ω ≤ 0.03) and far from rounding (errors ≫ 1e-13).
    let e1 = error_at_one(f, x0, exact, 100);
    let e2 = error_at_one(f, x0, exact, 200);
    math::ln(e1 / e2) / std::f64::consts::LN_2
}

#[test]
fn rk4_converges_with_order_four_on_odes_with_known_solutions() {
    let p = observed_order(&Harmonic { omega: 3.0 }, &[1.0, 0.0], &[math::cos(3.0), -3.0 * math::sin(3.0)]);
    assert!((3.9..4.1).contains(&p), "harmonic oscillator: observed order {p}");
    let p = observed_order(&TimeVarying, &[1.0], &[math::exp(0.5)]);
    assert!((3.9..4.1).contains(&p), "x' = t x: observed order {p}");
}

#[test]
fn discretized_substeps_equal_hand_made_smaller_steps() {
    let mut process = Discretized::rk4(Harmonic { omega: 2.0 }, 4);
    let mut one_sample = [0.0; 2];
    process.transition(0.3, 0.1, &[1.0, 0.5], &[], &mut one_sample);
    let mut rk4 = Rk4::new(2);
    let mut x = [1.0, 0.5];
    for s in 0..4 {
        let mut next = [0.0; 2];
        rk4.step(&Harmonic { omega: 2.0 }, 0.3 + s as f64 * 0.025, 0.025, &x, &[], &mut next);
        x = next;
    }
    assert_eq!(one_sample, x);
    assert_eq!(process.measurement_dim(), 1);
}
