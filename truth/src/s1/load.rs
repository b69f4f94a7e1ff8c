//! The two loads of study S1, as continuous functions of time (the truth
//! integrator evaluates them at its RK4 stage times, not on the sample grid).
//!
//! * **Random** (the paper does not say how it made its random load): a
//!   band-limited Gaussian process by the spectral representation method
//!   (Shinozuka & Deodatis 1991): `F(t) = Σ aₖ·cos(2π fₖ t + φₖ)` with
//!   `K = 400` components of equal amplitude on a flat one-sided spectrum
//!   from 0.1 Hz to 10 Hz, frequencies jittered inside their bins and phases
//!   uniform in `[0, 2π)`, both drawn from a ChaCha8 stream seeded with the
//!   study seed; scaled to an RMS of `rms` (default 10 N).
//! * **Harmonic**: `F(t) = Σ Aᵢ·sin(2π fᵢ t)` at 1, 2, 3, 5 and 7 Hz with
//!   amplitudes 8, 6, 5, 4 and 3 N.

use std::f64::consts::TAU;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A load as a sum of cosines `Σ aₖ·cos(ωₖ t + φₖ)`, with its exact
/// derivative, plus an optional step (a true jump, for the fault studies).
#[derive(Debug, Clone)]
pub struct Load {
    components: Vec<(f64, f64, f64)>,
    step: Option<Step>,
}

/// A step of `size` N at `at` s, rising over [`Step::RISE`] s as a half
/// cosine: continuous, so the truth integrator stays exact to RK4 order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Start of the rise (s).
    pub at: f64,
    /// Height (N).
    pub size: f64,
}

impl Step {
    /// Rise time (s): 10 ms, two filter samples at 200 Hz.
    pub const RISE: f64 = 0.01;

    fn value(&self, t: f64) -> f64 {
        let u = ((t - self.at) / Self::RISE).clamp(0.0, 1.0);
        self.size * 0.5 * (1.0 - (std::f64::consts::PI * u).cos())
    }

    fn rate(&self, t: f64) -> f64 {
        let u = (t - self.at) / Self::RISE;
        if (0.0..=1.0).contains(&u) {
            self.size * 0.5 * std::f64::consts::PI / Self::RISE * (std::f64::consts::PI * u).sin()
        } else {
            0.0
        }
    }
}

impl Load {
    /// The band-limited random load (see the module documentation).
    pub fn random(seed: u64, rms: f64) -> Self {
        const COMPONENTS: usize = 400;
        const BAND: (f64, f64) = (0.1, 10.0);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let width = (BAND.1 - BAND.0) / COMPONENTS as f64;
        // Each cosine of amplitude a has mean square a²/2: K·a²/2 = rms².
        let amplitude = rms * (2.0 / COMPONENTS as f64).sqrt();
        let components = (0..COMPONENTS)
            .map(|k| {
                let f = BAND.0 + (k as f64 + rng.random::<f64>()) * width;
                (amplitude, TAU * f, TAU * rng.random::<f64>())
            })
            .collect();
        Self { components, step: None }
    }

    /// The same load with a step added.
    pub fn with_step(self, step: Step) -> Self {
        Self { step: Some(step), ..self }
    }

    /// The sum of harmonics at 1, 2, 3, 5 and 7 Hz.
    pub fn harmonic() -> Self {
        let components = [(1.0, 8.0), (2.0, 6.0), (3.0, 5.0), (5.0, 4.0), (7.0, 3.0)]
            .iter()
            // sin(x) = cos(x − π/2).
            .map(|&(f, a)| (a, TAU * f, -std::f64::consts::FRAC_PI_2))
            .collect();
        Self { components, step: None }
    }

    /// A constant load (a cosine of zero frequency).
    pub fn constant(value: f64) -> Self {
        Self { components: vec![(value, 0.0, 0.0)], step: None }
    }

    /// `F(t)`.
    pub fn value(&self, t: f64) -> f64 {
        let step = self.step.map_or(0.0, |s| s.value(t));
        self.components.iter().map(|(a, w, p)| a * (w * t + p).cos()).sum::<f64>() + step
    }

    /// `F(t₀ + j·step)` for `j = 0 … count−1`, by rotating each component's
    /// phasor instead of calling `cos` (400 components × millions of RK4
    /// stages otherwise dominate the study's run time). The phasors are
    /// re-anchored exactly every 1024 samples, so rounding cannot accumulate.
    pub fn tabulate(&self, t0: f64, step: f64, count: usize) -> Vec<f64> {
        const ANCHOR: usize = 1024;
        let mut out = Vec::with_capacity(count);
        let rotation: Vec<(f64, f64)> =
            self.components.iter().map(|(_, w, _)| ((w * step).cos(), (w * step).sin())).collect();
        let mut phasor = vec![(0.0, 0.0); self.components.len()];
        for j in 0..count {
            if j % ANCHOR == 0 {
                let t = t0 + j as f64 * step;
                for (z, (a, w, p)) in phasor.iter_mut().zip(&self.components) {
                    *z = (a * (w * t + p).cos(), a * (w * t + p).sin());
                }
            }
            let step = self.step.map_or(0.0, |s| s.value(t0 + j as f64 * step));
            out.push(phasor.iter().map(|z| z.0).sum::<f64>() + step);
            for (z, r) in phasor.iter_mut().zip(&rotation) {
                *z = (z.0 * r.0 - z.1 * r.1, z.0 * r.1 + z.1 * r.0);
            }
        }
        out
    }

    /// `Ḟ(t)`.
    pub fn rate(&self, t: f64) -> f64 {
        let step = self.step.map_or(0.0, |s| s.rate(t));
        self.components.iter().map(|(a, w, p)| -a * w * (w * t + p).sin()).sum::<f64>() + step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_load_has_the_requested_rms_and_depends_on_the_seed_only() {
        let load = Load::random(7, 10.0);
        let n = 200_000;
        let ms: f64 = (0..n).map(|k| load.value(k as f64 * 1e-3).powi(2)).sum::<f64>() / n as f64;
        assert!((ms.sqrt() - 10.0).abs() < 0.5, "rms {}", ms.sqrt());
        assert_eq!(Load::random(7, 10.0).value(1.234), load.value(1.234));
        assert_ne!(Load::random(8, 10.0).value(1.234), load.value(1.234));
    }

    #[test]
    fn rate_is_the_derivative_of_the_value() {
        for load in [Load::random(1, 10.0), Load::harmonic()] {
            let (t, h) = (3.3, 1e-6);
            let numeric = (load.value(t + h) - load.value(t - h)) / (2.0 * h);
            assert!((numeric - load.rate(t)).abs() < 1e-5 * load.rate(t).abs().max(1.0));
        }
    }

    #[test]
    fn a_step_rises_continuously_and_its_rate_is_its_derivative() {
        let load = Load::constant(1.0).with_step(Step { at: 2.0, size: 100.0 });
        assert_eq!((load.value(1.999), load.value(2.0)), (1.0, 1.0));
        assert!((load.value(2.005) - 51.0).abs() < 1e-9);
        assert_eq!(load.value(2.011), 101.0);
        let (t, h) = (2.003, 1e-7);
        let numeric = (load.value(t + h) - load.value(t - h)) / (2.0 * h);
        assert!((numeric - load.rate(t)).abs() < 1e-4 * load.rate(t));
    }

    #[test]
    fn tabulated_values_equal_direct_evaluation() {
        let load = Load::random(5, 10.0).with_step(Step { at: 0.1, size: 30.0 });
        let table = load.tabulate(0.0, 5e-5, 5000);
        for j in [0, 1, 1023, 1024, 1025, 4999] {
            assert!((table[j] - load.value(j as f64 * 5e-5)).abs() < 1e-10, "sample {j}");
        }
    }

    #[test]
    fn harmonic_load_starts_at_zero_with_the_published_frequencies() {
        let load = Load::harmonic();
        assert!(load.value(0.0).abs() < 1e-12);
        // Period 1 s: all five frequencies are integers.
        assert!((load.value(0.37) - load.value(1.37)).abs() < 1e-9);
    }
}
