//! The rudder inputs both S5 truths fly: `truth/data/s5_manoeuvre.json`, one file so
//! that our 6-DOF and the JSBSim driver cannot drift apart (`docs/studies/s5.md`).
//!
//! ## A second manoeuvre
//!
//! `roll-turn` (`truth/data/s5_manoeuvre_roll_turn.json`, [`Manoeuvre::roll_turn`]) is a
//! schedule the estimators were not tuned on, over the same 20 s with the coefficients
//! changing at the same 10 s: roll-heavy, roll doublets and a 3-2-1-1 of ±3° on δx (three
//! times the standard's ±1°) and a roll held one way then back (±1°, ±1.5°), with a
//! sustained pull of ±1.5° on δy for 6 s in each half (a turn, banked by the roll held
//! meanwhile) where the standard has short 3-2-1-1s and steps, and yaw doublets of ±1.5°
//! on δz at other instants than the standard's. Every control still moves in each half,
//! and every switch is on the 5 ms grid. [`Manoeuvre::named`] loads either by name
//! (`standard`, `roll-turn`); the standard file is unchanged. The JSBSim driver flies
//! the same files (`fly.py --manoeuvre standard|roll-turn`, its log naming the file). Over the
//! 20 s the roll rate's RMS is 8.7 °/s against the standard's 5.1 °/s, α stays within
//! ±3.4° and the missile climbs from 10 to 12.4 km. Our choice `[est]`, not the paper's.

use serde::Deserialize;

/// The manoeuvre file, compiled in.
const FILE: &str = include_str!("../../data/s5_manoeuvre.json");

/// The second manoeuvre's file, compiled in.
const ROLL_TURN_FILE: &str = include_str!("../../data/s5_manoeuvre_roll_turn.json");

/// The three controls' piecewise-constant deflections.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Manoeuvre {
    /// Length of the run (s).
    pub duration: f64,
    /// When the coefficients change (s).
    pub change_at: f64,
    controls: Controls,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
struct Controls {
    delta_x: Vec<[f64; 3]>,
    delta_y: Vec<[f64; 3]>,
    delta_z: Vec<[f64; 3]>,
}

impl Manoeuvre {
    /// The names [`Manoeuvre::named`] knows: the study's manoeuvre, then the second.
    pub const NAMES: [&'static str; 2] = ["standard", "roll-turn"];

    /// The study's manoeuvre.
    pub fn standard() -> Self {
        serde_json::from_str(FILE).expect("truth/data/s5_manoeuvre.json is a manoeuvre (a unit test reads it)")
    }

    /// The second manoeuvre, roll-heavy with a sustained pull (the module documentation).
    pub fn roll_turn() -> Self {
        serde_json::from_str(ROLL_TURN_FILE)
            .expect("truth/data/s5_manoeuvre_roll_turn.json is a manoeuvre (a unit test reads it)")
    }

    /// A manoeuvre by its name in [`Manoeuvre::NAMES`].
    pub fn named(name: &str) -> Result<Self, String> {
        match name {
            "standard" => Ok(Self::standard()),
            "roll-turn" => Ok(Self::roll_turn()),
            _ => Err(format!("unknown manoeuvre '{name}'; expected one of {}", Self::NAMES.join(", "))),
        }
    }

    /// A manoeuvre from the text of a manoeuvre file (the format of
    /// `truth/data/s5_manoeuvre.json`).
    pub fn from_json(text: &str) -> Result<Self, String> {
        serde_json::from_str(text).map_err(|e| format!("not a manoeuvre: {e}"))
    }

    /// No deflection at all for `duration` seconds: a flight that excites nothing.
    pub fn quiet(duration: f64) -> Self {
        let none = Controls { delta_x: Vec::new(), delta_y: Vec::new(), delta_z: Vec::new() };
        Self { duration, change_at: f64::INFINITY, controls: none }
    }

    /// This manoeuvre flown `times` times in a row, with no change of the coefficients.
    pub fn repeated(&self, times: usize) -> Self {
        let repeat = |segments: &[[f64; 3]]| -> Vec<[f64; 3]> {
            (0..times)
                .flat_map(|n| {
                    let offset = n as f64 * self.duration;
                    segments.iter().map(move |[a, b, d]| [a + offset, b + offset, *d])
                })
                .collect()
        };
        let c = &self.controls;
        Self {
            duration: self.duration * times as f64,
            change_at: f64::INFINITY,
            controls: Controls {
                delta_x: repeat(&c.delta_x),
                delta_y: repeat(&c.delta_y),
                delta_z: repeat(&c.delta_z),
            },
        }
    }

    /// The deflections `δx, δy, δz` (rad) at `t`: the sum of the segments `[start, end)`
    /// covering it.
    pub fn deflection(&self, t: f64) -> [f64; 3] {
        let at = |segments: &[[f64; 3]]| {
            segments.iter().filter(|[start, end, _]| *start <= t && t < *end).map(|s| s[2].to_radians()).sum()
        };
        [at(&self.controls.delta_x), at(&self.controls.delta_y), at(&self.controls.delta_z)]
    }

    /// The deflections held over the sample interval `[k·T, (k+1)·T)`, as a control
    /// computer outputs them: taken at the interval's middle, so that a switch on the grid
    /// is never missed by a rounding of `k·T`.
    pub fn held(&self, k: usize, sample_time: f64) -> [f64; 3] {
        self.deflection((k as f64 + 0.5) * sample_time)
    }

    /// Every instant a deflection changes (s), sorted.
    pub fn switches(&self) -> Vec<f64> {
        let c = &self.controls;
        let mut t: Vec<f64> =
            [&c.delta_x, &c.delta_y, &c.delta_z].into_iter().flatten().flat_map(|s| [s[0], s[1]]).collect();
        t.sort_by(f64::total_cmp);
        t.dedup();
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_control_moves_in_each_half_and_switches_on_the_5_ms_grid() {
        let m = Manoeuvre::standard();
        assert_eq!((m.duration, m.change_at), (20.0, 10.0));
        for half in [0.0, 10.0] {
            for axis in 0..3 {
                let moved = (0..2000).any(|k| m.deflection(half + k as f64 * 0.005)[axis] != 0.0);
                assert!(moved, "control {axis} moves in the half from {half} s");
            }
        }
        // The truth integrates between samples with the deflection of the sample: a switch
        // off the grid would be a difference between the truth and the estimator's model.
        for t in m.switches() {
            assert!((t / 0.005 - (t / 0.005).round()).abs() < 1e-9, "switch at {t} s");
        }
        assert_eq!(m.deflection(0.15)[1], 2f64.to_radians(), "the 3-2-1-1 on δy starts at 0.1 s");
    }
}
