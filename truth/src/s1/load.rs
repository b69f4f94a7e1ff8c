//! The loads of study S1, as continuous functions of time (the truth
//! integrator evaluates them at its RK4 stage times, not on the sample grid).
//!
//! The paper's two:
//!
//! * **Random** (the paper does not say how it made its random load): a
//!   band-limited Gaussian process by the spectral representation method
//!   `[Shinozuka1991]`: `F(t) = Σ aₖ·cos(2π fₖ t + φₖ)` with
//!   `K = 400` components of equal amplitude on a flat one-sided spectrum
//!   from 0.1 Hz to 10 Hz, frequencies jittered inside their bins and phases
//!   uniform in `[0, 2π)`, both drawn from a ChaCha8 stream seeded with the
//!   study seed; scaled to an RMS of `rms` (default 10 N).
//! * **Harmonic**: `F(t) = Σ Aᵢ·sin(2π fᵢ t)` at 1, 2, 3, 5 and 7 Hz with
//!   amplitudes 8, 6, 5, 4 and 3 N.
//!
//! ## Loads the estimators were not tuned on
//!
//! Three more, for scoring the study's one filter setting (tuned on the two
//! above) on data it has not seen. Each keeps the random load's RMS
//! convention: its RMS over the run is `rms` (the study's `load_rms`, 10 N),
//! the chirp's to within a percent, the band's in expectation; the steps add
//! theirs to the random background's.
//!
//! * **Band to 20 Hz** ([`Load::band_limited`] with [`Load::BAND_20`]): the
//!   random load's construction `[Shinozuka1991]` on a flat one-sided
//!   spectrum from 0.2 to 20 Hz, 800 components (the random load's density
//!   of lines, 40 per hertz), twice the paper's band: half its power lies
//!   above the 10 Hz the estimators were tuned to.
//! * **Steps** ([`Load::steps`]): the random load of the same seed (its
//!   background, bit for bit) plus a train of steps, each rising over
//!   [`Step::RISE`] (10 ms) as a half cosine. The instants are irregular:
//!   the first 2–6 s in, then gaps uniform in 3–12 s, none within 2 s of the
//!   end, each on the 1 ms grid (seven to nine over 60 s for the seeds
//!   1–10). Each step moves the step level to a new level uniform in
//!   ±2.5·`rms`, drawn again until the move is at least 1·`rms`: steps of
//!   10–50 N of either sign at the default RMS, the level never beyond
//!   ±25 N. They come from a ChaCha8 stream of their own (the seed
//!   `^ 0x57E9_5000`), so the background is the random load's; the steps
//!   drawn are recorded ([`Load::steps_taken`]).
//! * **Chirp** ([`Load::chirp`], [`Chirp`]): a logarithmic sweep
//!   `F(t) = √2·rms·sin(φ(t))` from 0.1 Hz at `t = 0` to 15 Hz at the end of
//!   the run, the instantaneous frequency `f(t) = f₀·(f₁/f₀)^(t/T)`, so
//!   `φ(t) = 2π·f₀·T/ln(f₁/f₀)·((f₁/f₀)^(t/T) − 1)`: equal time per octave
//!   (8.3 s per octave over 60 s), the chain's modes (0.1–0.6 Hz) crossed
//!   slowly, `F(0) = 0` as the chain starts at rest. Deterministic.

use estimator::math;
use std::f64::consts::TAU;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A load as a sum of cosines `Σ aₖ·cos(ωₖ t + φₖ)`, with its exact
/// derivative, plus optional steps (true jumps, for the fault studies and the
/// step-train load) and an optional chirp.
#[derive(Debug, Clone)]
pub struct Load {
    components: Vec<(f64, f64, f64)>,
    steps: Vec<Step>,
    chirp: Option<Chirp>,
}

/// A logarithmic sine sweep `amplitude·sin(φ(t))` whose instantaneous
/// frequency runs from `start` Hz at `t = 0` to `end` Hz at `t = duration`
/// (and on beyond it by the same law).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chirp {
    /// Amplitude (N).
    pub amplitude: f64,
    /// Frequency at `t = 0` (Hz).
    pub start: f64,
    /// Frequency at `t = duration` (Hz).
    pub end: f64,
    /// Length of the sweep (s).
    pub duration: f64,
}

impl Chirp {
    /// The sweep rate `ln(end/start)/duration` (1/s).
    fn rate(&self) -> f64 {
        math::ln(self.end / self.start) / self.duration
    }

    /// The instantaneous frequency `f(t) = start·e^{rate·t}` (Hz).
    pub fn frequency(&self, t: f64) -> f64 {
        self.start * math::exp(self.rate() * t)
    }

    /// The phase `φ(t) = 2π·start·(e^{rate·t} − 1)/rate` (rad), `φ(0) = 0`.
    pub fn phase(&self, t: f64) -> f64 {
        let r = self.rate();
        TAU * self.start * math::exp_m1(r * t) / r
    }

    fn value(&self, t: f64) -> f64 {
        self.amplitude * math::sin(self.phase(t))
    }

    fn derivative(&self, t: f64) -> f64 {
        self.amplitude * math::cos(self.phase(t)) * TAU * self.frequency(t)
    }
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
        self.size * 0.5 * (1.0 - math::cos(std::f64::consts::PI * u))
    }

    fn rate(&self, t: f64) -> f64 {
        let u = (t - self.at) / Self::RISE;
        if (0.0..=1.0).contains(&u) {
            self.size * 0.5 * std::f64::consts::PI / Self::RISE * math::sin(std::f64::consts::PI * u)
        } else {
            0.0
        }
    }
}

impl Load {
    /// The paper's random band (Hz) and its number of components.
    pub const BAND_10: ((f64, f64), usize) = ((0.1, 10.0), 400);
    /// The unseen band to 20 Hz (Hz) and its number of components: the same
    /// density of lines, 40 per hertz.
    pub const BAND_20: ((f64, f64), usize) = ((0.2, 20.0), 800);
    /// The unseen chirp's start and end frequencies (Hz).
    pub const CHIRP_BAND: (f64, f64) = (0.1, 15.0);

    /// The band-limited random load (see the module documentation).
    pub fn random(seed: u64, rms: f64) -> Self {
        let (band, components) = Self::BAND_10;
        Self::band_limited(seed, rms, band, components)
    }

    /// A band-limited random load of `components` equal cosines on a flat
    /// one-sided spectrum over `band` (Hz), RMS `rms`, seeded: the random
    /// load's construction on another band ([`Load::random`] is this with
    /// [`Load::BAND_10`]).
    pub fn band_limited(seed: u64, rms: f64, band: (f64, f64), components: usize) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let width = (band.1 - band.0) / components as f64;
        // Each cosine of amplitude a has mean square a²/2: K·a²/2 = rms².
        let amplitude = rms * (2.0 / components as f64).sqrt();
        let components = (0..components)
            .map(|k| {
                let f = band.0 + (k as f64 + rng.random::<f64>()) * width;
                (amplitude, TAU * f, TAU * rng.random::<f64>())
            })
            .collect();
        Self { components, steps: Vec::new(), chirp: None }
    }

    /// The random load of `seed` plus a seeded train of steps over a run of
    /// `duration` s (see the module documentation); the steps drawn are
    /// [`Load::steps_taken`].
    pub fn steps(seed: u64, rms: f64, duration: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x57E9_5000);
        let mut load = Self::random(seed, rms);
        let (mut at, mut level) = (2.0 + 4.0 * rng.random::<f64>(), 0.0);
        while at <= duration - 2.0 {
            let target = loop {
                let target = rms * 2.5 * (2.0 * rng.random::<f64>() - 1.0);
                if (target - level).abs() >= rms {
                    break target;
                }
            };
            // On the 1 ms grid, so that the records read cleanly.
            let at_ms = (at * 1000.0).round() / 1000.0;
            load.steps.push(Step { at: at_ms, size: target - level });
            level = target;
            at += 3.0 + 9.0 * rng.random::<f64>();
        }
        load
    }

    /// A logarithmic chirp of RMS `rms` from `band.0` Hz at `t = 0` to
    /// `band.1` Hz at `duration` (see [`Chirp`]).
    pub fn chirp(rms: f64, band: (f64, f64), duration: f64) -> Self {
        let chirp = Chirp { amplitude: rms * 2f64.sqrt(), start: band.0, end: band.1, duration };
        Self { components: Vec::new(), steps: Vec::new(), chirp: Some(chirp) }
    }

    /// The same load with a step added.
    pub fn with_step(mut self, step: Step) -> Self {
        self.steps.push(step);
        self
    }

    /// The steps in the load, in the order added.
    pub fn steps_taken(&self) -> &[Step] {
        &self.steps
    }

    /// The chirp in the load, if any.
    pub fn chirp_part(&self) -> Option<&Chirp> {
        self.chirp.as_ref()
    }

    /// The part of the load that is not a sum of cosines, at `t`: the steps and
    /// the chirp. One step alone is its own value, bit for bit.
    fn extra(&self, t: f64) -> f64 {
        let steps = match self.steps.split_first() {
            None => 0.0,
            Some((first, rest)) => rest.iter().fold(first.value(t), |sum, s| sum + s.value(t)),
        };
        match &self.chirp {
            None => steps,
            Some(chirp) => steps + chirp.value(t),
        }
    }

    /// The rate of [`Load::extra`].
    fn extra_rate(&self, t: f64) -> f64 {
        let steps = match self.steps.split_first() {
            None => 0.0,
            Some((first, rest)) => rest.iter().fold(first.rate(t), |sum, s| sum + s.rate(t)),
        };
        match &self.chirp {
            None => steps,
            Some(chirp) => steps + chirp.derivative(t),
        }
    }

    /// The sum of harmonics at 1, 2, 3, 5 and 7 Hz.
    pub fn harmonic() -> Self {
        let components = [(1.0, 8.0), (2.0, 6.0), (3.0, 5.0), (5.0, 4.0), (7.0, 3.0)]
            .iter()
            // sin(x) = cos(x − π/2).
            .map(|&(f, a)| (a, TAU * f, -std::f64::consts::FRAC_PI_2))
            .collect();
        Self { components, steps: Vec::new(), chirp: None }
    }

    /// A constant load (a cosine of zero frequency).
    pub fn constant(value: f64) -> Self {
        Self { components: vec![(value, 0.0, 0.0)], steps: Vec::new(), chirp: None }
    }

    /// `F(t)`.
    pub fn value(&self, t: f64) -> f64 {
        let step = self.extra(t);
        self.components.iter().map(|(a, w, p)| a * math::cos(w * t + p)).sum::<f64>() + step
    }

    /// `F(t₀ + j·step)` for `j = 0 … count−1`, by rotating each component's
    /// phasor instead of calling `cos` (400 components × millions of RK4
    /// stages otherwise dominate the study's run time). The phasors are
    /// re-anchored exactly every [`Self::ANCHOR`] samples, so rounding cannot accumulate.
    pub fn tabulate(&self, t0: f64, step: f64, count: usize) -> Vec<f64> {
        let mut out = Vec::with_capacity(count);
        self.tabulate_into(t0, step, 0, count, &mut out);
        out
    }

    /// The phasors are re-anchored at every multiple of this index.
    pub const ANCHOR: usize = 1024;

    /// Writes `F(t₀ + j·step)` for `j = first … first + count − 1` into `out` (cleared
    /// first): the values [`tabulate`](Self::tabulate) gives at those indices, to the bit,
    /// so a simulation can tabulate its load piece by piece. `first` is a multiple of
    /// [`Self::ANCHOR`].
    pub fn tabulate_into(&self, t0: f64, step: f64, first: usize, count: usize, out: &mut Vec<f64>) {
        assert_eq!(first % Self::ANCHOR, 0, "a piece of the table starts at an anchor");
        out.clear();
        let rotation: Vec<(f64, f64)> =
            self.components.iter().map(|(_, w, _)| (math::cos(w * step), math::sin(w * step))).collect();
        let mut phasor = vec![(0.0, 0.0); self.components.len()];
        for j in first..first + count {
            if j % Self::ANCHOR == 0 {
                let t = t0 + j as f64 * step;
                for (z, (a, w, p)) in phasor.iter_mut().zip(&self.components) {
                    *z = (a * math::cos(w * t + p), a * math::sin(w * t + p));
                }
            }
            let step = self.extra(t0 + j as f64 * step);
            out.push(phasor.iter().map(|z| z.0).sum::<f64>() + step);
            for (z, r) in phasor.iter_mut().zip(&rotation) {
                *z = (z.0 * r.0 - z.1 * r.1, z.0 * r.1 + z.1 * r.0);
            }
        }
    }

    /// `Ḟ(t)`.
    pub fn rate(&self, t: f64) -> f64 {
        let step = self.extra_rate(t);
        self.components.iter().map(|(a, w, p)| -a * w * math::sin(w * t + p)).sum::<f64>() + step
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_in_pieces_is_the_whole_table_to_the_bit() {
        let load = Load::random(3, 10.0).with_step(Step { at: 0.3, size: 5.0 });
        let whole = load.tabulate(0.0, 5e-5, 5 * Load::ANCHOR + 17);
        let mut piece = Vec::new();
        for first in (0..whole.len()).step_by(2 * Load::ANCHOR) {
            let count = (2 * Load::ANCHOR).min(whole.len() - first);
            load.tabulate_into(0.0, 5e-5, first, count, &mut piece);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&piece), bits(&whole[first..first + count]), "from {first}");
        }
    }

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
