//! The rudder inputs both S5 truths fly: `truth/data/s5_manoeuvre.json`, one file so
//! that our 6-DOF and the JSBSim driver cannot drift apart (`docs/studies/s5.md`).

use serde::Deserialize;

/// The manoeuvre file, compiled in.
const FILE: &str = include_str!("../../data/s5_manoeuvre.json");

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
    /// The study's manoeuvre.
    pub fn standard() -> Self {
        serde_json::from_str(FILE).expect("truth/data/s5_manoeuvre.json is a manoeuvre (a unit test reads it)")
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
