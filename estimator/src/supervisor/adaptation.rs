//! The process noise learnt online: a bounded scale `s` on the unknown
//! inputs' part of the `Q` the user gave (the states
//! [`Supervisor::scaled_states`](super::Supervisor::scaled_states) names and
//! those their noise couples to, such as a load's rate), driven by the
//! normalised innovations of the rows each update used. The motion states'
//! noise stays as given: it stands for the model's own error, which the
//! innovations do not show where a state is barely observed (S2's wheelset
//! positions under their axle boxes), and a scale learnt there shrank their
//! σ below their errors (S2's random track: 2σ coverage 0.42).
//!
//! A user knows the sensors' noise from a datasheet; the process noise of the
//! unknown inputs (a load's spectrum, a track's irregularity, an aerodynamic
//! coefficient's drift) is a guess. A `Q` too small makes the filter lag and
//! its innovations too large (the gate then takes the lag for sensor faults);
//! one too large makes its σ too wide. Both show in the mean normalised
//! innovation per row, which is 1 for a consistent filter. Per committed
//! sample with rows used:
//!
//! ```text
//! ρ̄ = mean over the rows used of min(νᵢ²/Sᵢᵢ, c)      (first pass, c: χ²(1) quantile 1 − 1e-6)
//! f = mean over the rows used of (Sᵢᵢ − rᵢ)/Sᵢᵢ        (the share of Sᵢᵢ that P, hence Q, makes)
//! ρ̂ ← ρ̂ + (ρ̄ − ρ̂)/W                                  (W: SupervisorSettings::adaptation_window)
//! ln s ← clamp(ln s + clamp((ρ̂ − 1)/(W·ρ̂·max(f, 0.1)), ±1/W), ln s_min, ln s_max)
//! ```
//!
//! This is a stochastic-approximation (Robbins–Monro) step towards `E[ρ̄] = 1`
//! with a constant gain, so it forgets: its memory is about `W` samples.
//! Dividing by the running mean `ρ̂` and by `f` makes it a Newton step on
//! `ln ρ̂` (`d ln S/d ln s ≈ f`): about `ln ρ̂/(W·f)` per sample, as fast down
//! as up; with `Q` ten times too large `ρ̂` is only somewhat below 1, and an
//! absolute step would crawl. Where `R` alone makes `S` (`f` small) no scale
//! on `Q` can move `ρ̄`: the step is then bounded by `f ≥ 0.1`, and the
//! scale by its bounds. The clip bounds what one
//! gross error can do: a row rejected by the gate teaches nothing, and one
//! glitch the gate let through moves `ln s` by at most `c/W`. The bounds keep
//! the scale in a range a user can state (`Q` at most 100 times wrong by
//! default), and each step is at most `1/W`: `P`, hence `S`, answers a new
//! `Q` only over the filter's own time constant, and larger steps overshoot.
//! The scale applies from the next prediction on.
//!
//! What it cannot do: tell `Q` from a wrong `R` when both are wrong, since a
//! scale on `Q` alone is fitted. The offline tuning from a log estimates both
//! where the data can tell them apart.

use super::outcome::Outcome;
use crate::math;

/// Below this share of `S` made by `P`, a scale on `Q` barely moves the
/// innovations: the step is that of this share (bounded, and the scale's
/// bounds hold it where `R` alone makes `S`).
const MIN_SHARE: f64 = 0.1;
use super::settings::SupervisorSettings;

/// The adapted scale on `Q`, as its logarithm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Adaptation {
    /// `ln s`.
    pub log_scale: f64,
    /// `ρ̂`, the running mean normalised innovation per row used.
    pub mean_ratio: f64,
}

impl Adaptation {
    /// The scale 1: `Q` as given.
    pub fn new() -> Self {
        Self { log_scale: 0.0, mean_ratio: 1.0 }
    }

    /// The scale on `Q`.
    pub fn scale(&self) -> f64 {
        math::exp(self.log_scale)
    }

    /// Learns from a committed sample's outcome (nothing when the adaptation
    /// is off or no row was used).
    pub fn learn(&mut self, outcome: &Outcome, settings: &SupervisorSettings) {
        let rows = outcome.adaptation_rows;
        if settings.adaptation_window == 0 || rows == 0 {
            return;
        }
        let rows = rows as f64;
        let (mean_ratio, share) = (outcome.adaptation_ratios / rows, outcome.adaptation_share / rows);
        let window = settings.adaptation_window as f64;
        self.mean_ratio += (mean_ratio - self.mean_ratio) / window;
        // A Newton step on ln ρ̂ against ln s: d ln S/d ln s ≈ f.
        // On the running mean: a step clipped sample by sample would be biased
        // (a sample's ρ̄ is skewed, χ²-like, and mostly its large values are cut).
        let newton = (self.mean_ratio - 1.0) / (window * self.mean_ratio.max(0.05) * share.max(MIN_SHARE));
        // At most 1/W per sample: P, hence S, answers a new Q only over the
        // filter's own time constant, and larger steps overshoot.
        let step = newton.clamp(-1.0 / window, 1.0 / window);
        if step.is_finite() {
            let (low, high) = (math::ln(settings.min_process_noise_scale), math::ln(settings.max_process_noise_scale));
            self.log_scale = (self.log_scale + step).clamp(low, high);
        }
    }

    /// A saved `ln s` is one the settings allow.
    pub fn fits(&self, settings: &SupervisorSettings) -> bool {
        let s = self.log_scale;
        self.mean_ratio.is_finite()
            && self.mean_ratio >= 0.0
            && s.is_finite()
            && s >= math::ln(settings.min_process_noise_scale) - 1e-12
            && s <= math::ln(settings.max_process_noise_scale) + 1e-12
    }
}
