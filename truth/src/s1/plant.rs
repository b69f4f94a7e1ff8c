//! The S1 truth simulator: the physical two-mass chain of `[Gong2024]`
//! (continuous piecewise-linear element, load on m₂) driven by a load that
//! varies continuously in time, integrated with RK4 at a fine step (1e-4 s by
//! default, 50 steps per 200 Hz sample) and sampled at the estimator rate.
//!
//! It differs from what the estimator assumes in the ways a real test does:
//! the load is not a random walk, the integration is 50× finer, and the
//! accelerometers are noisy (noise is added by the study, not here).

use estimator::models::Oscillator2Dof;

use super::load::Load;

/// The true history at the sample times `tₖ = k·dt`, `k = 0 … n` (the chain
/// starts at rest at `t = 0`, where the load already acts).
#[derive(Debug, Clone, Default)]
pub struct Truth {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// `[z₁, z₂, ż₁, ż₂]` at each sample (m, m/s).
    pub motion: Vec<[f64; 4]>,
    /// The load `F` (N).
    pub load: Vec<f64>,
    /// Its rate `Ḟ` (N/s).
    pub load_rate: Vec<f64>,
    /// The noise-free accelerations `[z̈₁, z̈₂]` (m/s²).
    pub acceleration: Vec<[f64; 2]>,
}

impl Truth {
    /// The RMS of each acceleration over the whole history (m/s²).
    pub fn acceleration_rms(&self) -> [f64; 2] {
        let n = self.acceleration.len() as f64;
        let rms = |i: usize| (self.acceleration.iter().map(|a| a[i] * a[i]).sum::<f64>() / n).sqrt();
        [rms(0), rms(1)]
    }
}

/// Simulates `samples` samples of `dt` from rest, with `substeps` RK4 steps
/// per sample: `samples + 1` instants with the start.
pub fn simulate(chain: &Oscillator2Dof, load: &Load, dt: f64, samples: usize, substeps: usize) -> Truth {
    let h = dt / substeps as f64;
    // The load at every RK4 stage time: the grid of half steps.
    let table = load.tabulate(0.0, 0.5 * h, 2 * samples * substeps + 1);
    let f = |load: f64, x: &[f64; 4]| -> [f64; 4] {
        let (a1, a2) = chain.accelerations(x[0], x[1], x[2], x[3], load);
        [x[2], x[3], a1, a2]
    };
    let mut x = [0.0; 4];
    let mut truth = Truth::default();
    let mut record = |t: f64, x: [f64; 4], at: usize| {
        let rates = f(table[at], &x);
        truth.time.push(t);
        truth.motion.push(x);
        truth.load.push(load.value(t));
        truth.load_rate.push(load.rate(t));
        truth.acceleration.push([rates[2], rates[3]]);
    };
    record(0.0, x, 0);
    for k in 0..samples {
        for s in 0..substeps {
            // Stage times from the step count (index 2j is t = j·h), so time never drifts.
            let j = 2 * (k * substeps + s);
            let k1 = f(table[j], &x);
            let k2 = f(table[j + 1], &add(&x, 0.5 * h, &k1));
            let k3 = f(table[j + 1], &add(&x, 0.5 * h, &k2));
            let k4 = f(table[j + 2], &add(&x, h, &k3));
            for i in 0..4 {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        record((k + 1) as f64 * dt, x, 2 * (k + 1) * substeps);
    }
    truth
}

fn add(x: &[f64; 4], h: f64, k: &[f64; 4]) -> [f64; 4] {
    [x[0] + h * k[0], x[1] + h * k[1], x[2] + h * k[2], x[3] + h * k[3]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn static_load_settles_at_the_static_deflection_of_the_chain() {
        // A constant 2 N on the stiffness-nonlinear chain: the spring law reaches
        // 2 N on its second piece, at z₁ = δ₁ + (2 − k₁₁·δ₁)/k₁₂ = 0.175 m, and
        // z₂ = z₁ + F/k₂, once the motion has died out (after 100 s it is down to ~2e-6 m).
        let chain = Oscillator2Dof::stiffness_nonlinear();
        let truth = simulate(&chain, &Load::constant(2.0), 0.005, 20_000, 10);
        let last = truth.motion.last().unwrap();
        assert!((last[0] - 0.175).abs() < 1e-5, "z1 = {}", last[0]);
        assert!((last[1] - (0.175 + 2.0 / 15.0)).abs() < 1e-5, "z2 = {}", last[1]);
    }

    #[test]
    fn halving_the_step_changes_the_samples_by_the_rk4_error_only() {
        let chain = Oscillator2Dof::stiffness_nonlinear();
        let load = Load::random(3, 10.0);
        let fine = simulate(&chain, &load, 0.005, 2000, 50);
        let finer = simulate(&chain, &load, 0.005, 2000, 100);
        let gap =
            fine.acceleration.iter().zip(&finer.acceleration).map(|(a, b)| (a[1] - b[1]).abs()).fold(0.0, f64::max);
        let scale = finer.acceleration.iter().map(|a| a[1].abs()).fold(0.0, f64::max);
        assert!(gap < 1e-6 * scale, "RK4 at 1e-4 s is not converged: gap {gap}, scale {scale}");
    }
}
