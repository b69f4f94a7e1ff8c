//! S5's first truth, "as the paper has it": the rigid-body 6-DOF of eq. (1) on a flat,
//! non-rotating Earth in the ISA, its forces from the coefficient model (3) and its moments
//! from the moment model, integrated by RK4 at a step ten times finer than the 5 ms
//! sampling. The equations are the estimator's (`estimator::models::Airframe`): the paper's
//! truth and estimator share them, and so does this one; the outside truth with its own
//! Earth and atmosphere is JSBSim (`truth/s5_jsbsim/`).

use estimator::models::Airframe;

use super::manoeuvre::Manoeuvre;

/// The truth's state: the ten motion states of `docs/studies/s5.md`.
pub type Motion = [f64; 10];

/// The rigid body flying the manoeuvre, its coefficients switching at `change_at`.
#[derive(Debug, Clone)]
pub struct Flight {
    /// The airframe.
    pub airframe: Airframe,
    /// The coefficients before and after the change.
    pub coefficients: [[f64; 10]; 2],
    /// The rudder inputs.
    pub manoeuvre: Manoeuvre,
}

impl Flight {
    /// The coefficients in force over the sample interval `[k·T, (k+1)·T)`: taken at its
    /// middle, so that a change on the grid is never missed by a rounding of `k·T`.
    pub fn coefficients_over(&self, k: usize, sample_time: f64) -> &[f64; 10] {
        &self.coefficients[usize::from((k as f64 + 0.5) * sample_time >= self.manoeuvre.change_at)]
    }

    /// Advances `x` by one RK4 step of `dt` under the coefficients `c` and deflections
    /// `delta`.
    pub fn step(&self, c: &[f64; 10], delta: &[f64; 3], dt: f64, x: &Motion) -> Motion {
        let f = |x: &Motion| {
            let mut d = [0.0; 10];
            self.airframe.motion_derivative(x, c, delta, &mut d);
            d
        };
        let add = |x: &Motion, k: &Motion, h: f64| -> Motion { std::array::from_fn(|i| x[i] + h * k[i]) };
        let k1 = f(x);
        let k2 = f(&add(x, &k1, dt / 2.0));
        let k3 = f(&add(x, &k2, dt / 2.0));
        let k4 = f(&add(x, &k3, dt));
        std::array::from_fn(|i| x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    /// The motion at every sample `k·sample_time` from `start` to the manoeuvre's end,
    /// `substeps` RK4 steps per sample.
    pub fn fly(&self, start: &Motion, sample_time: f64, substeps: usize) -> Vec<Motion> {
        let samples = (self.manoeuvre.duration / sample_time).round() as usize;
        let h = sample_time / substeps as f64;
        let mut x = *start;
        let mut out = Vec::with_capacity(samples + 1);
        out.push(x);
        for k in 0..samples {
            let (c, delta) = (self.coefficients_over(k, sample_time), self.manoeuvre.held(k, sample_time));
            for _ in 0..substeps {
                x = self.step(c, &delta, h, &x);
            }
            out.push(x);
        }
        out
    }
}
