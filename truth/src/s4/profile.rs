//! The motions the S4 train runs: the paper's test run and a jerk-limited run up to
//! 500 km/h. A profile is a chain of pieces of constant jerk, so its position, speed and
//! acceleration are known in closed form at any instant (a cubic, its derivative and its
//! second derivative): the truth needs no integrator, and the channels sample it exactly.
//!
//! Position and speed are continuous across pieces; acceleration may jump where a
//! profile says so (the paper's run switches between ±2.5 m/s² and 0 at once), and does
//! not in a jerk-limited run.

use super::parameters::{
    HIGH_SPEED_ACCELERATION, HIGH_SPEED_CRUISE, HIGH_SPEED_DECELERATION, HIGH_SPEED_JERK, HIGH_SPEED_TOP_SPEED,
    PAPER_ACCELERATION, PAPER_DECELERATION, PAPER_SPEED_SAMPLES, PAPER_START_SPEED, PAPER_STOP_POSITION,
    PAPER_TOP_SPEED, TELEGRAM_INTERVAL,
};

/// The motion of the train's reference point at one instant, along the guideway.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct State {
    /// Position (m) from where the run starts.
    pub position: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// Acceleration (m/s²).
    pub acceleration: f64,
    /// Jerk (m/s³).
    pub jerk: f64,
}

impl State {
    /// This state `tau` seconds on, at constant jerk.
    fn advanced(&self, tau: f64) -> State {
        let (p, v, a, j) = (self.position, self.speed, self.acceleration, self.jerk);
        State {
            position: p + v * tau + a * tau * tau / 2.0 + j * tau * tau * tau / 6.0,
            speed: v + a * tau + j * tau * tau / 2.0,
            acceleration: a + j * tau,
            jerk: j,
        }
    }
}

/// A stretch of constant jerk: its state when it starts and how long it lasts.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    start_time: f64,
    duration: f64,
    start: State,
}

/// A rest-to-rest run within limits of acceleration and jerk: an S-curve up to the top
/// speed, a cruise, and an S-curve down to a stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JerkLimitedRun {
    /// Top speed (m/s).
    pub top_speed: f64,
    /// Largest acceleration (m/s²).
    pub acceleration: f64,
    /// Largest deceleration (m/s², positive).
    pub deceleration: f64,
    /// Largest jerk (m/s³).
    pub jerk: f64,
    /// Time at the top speed (s).
    pub cruise: f64,
}

impl Default for JerkLimitedRun {
    /// The high-speed run: 0 → 500 km/h → stop (`parameters`).
    fn default() -> Self {
        Self {
            top_speed: HIGH_SPEED_TOP_SPEED,
            acceleration: HIGH_SPEED_ACCELERATION,
            deceleration: HIGH_SPEED_DECELERATION,
            jerk: HIGH_SPEED_JERK,
            cruise: HIGH_SPEED_CRUISE,
        }
    }
}

/// A motion along the guideway, from time 0 to [`Profile::duration`].
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// In time order, each starting where the one before ends.
    pieces: Vec<Piece>,
}

impl Profile {
    /// The paper's test run (§3.1): from 0.2 m/s at 2.5 m/s² up to 5.6 m/s, a cruise,
    /// 2.5 m/s² down to a stop at 506.4 m (after 92.59 s), then standing there until the
    /// recording's 5,695 speeds are complete (113.9 s; `docs/studies/s4.md`).
    pub fn paper() -> Self {
        let (v0, v, acc, dec) = (PAPER_START_SPEED, PAPER_TOP_SPEED, PAPER_ACCELERATION, PAPER_DECELERATION);
        let (t_acc, t_dec) = ((v - v0) / acc, v / dec);
        let cruise_distance = PAPER_STOP_POSITION - (v0 + v) / 2.0 * t_acc - v / 2.0 * t_dec;
        let t_cruise = cruise_distance / v;
        let t_stand = PAPER_SPEED_SAMPLES as f64 * TELEGRAM_INTERVAL - (t_acc + t_cruise + t_dec);
        let mut profile = Self::starting(v0, &[(t_acc, acc, 0.0), (t_cruise, 0.0, 0.0), (t_dec, -dec, 0.0)]);
        profile.stand(t_stand);
        profile
    }

    /// The high-speed run: [`JerkLimitedRun::default`].
    pub fn high_speed() -> Self {
        Self::jerk_limited(&JerkLimitedRun::default())
    }

    /// A rest-to-rest run within `run`'s limits. When the top speed is too low to reach
    /// the acceleration limit under the jerk limit (`v < a²/j`), the acceleration peaks at
    /// `√(v·j)` instead.
    pub fn jerk_limited(run: &JerkLimitedRun) -> Self {
        let s_curve = |limit: f64, sign: f64| -> Vec<(f64, f64, f64)> {
            let peak = limit.min((run.top_speed * run.jerk).sqrt());
            let t_jerk = peak / run.jerk;
            let t_flat = run.top_speed / peak - t_jerk;
            vec![(t_jerk, 0.0, sign * run.jerk), (t_flat, sign * peak, 0.0), (t_jerk, sign * peak, -sign * run.jerk)]
        };
        let mut segments = s_curve(run.acceleration, 1.0);
        segments.push((run.cruise, 0.0, 0.0));
        segments.extend(s_curve(run.deceleration, -1.0));
        Self::starting(0.0, &segments)
    }

    /// From position 0 at `speed`, each segment `(duration, acceleration at its start,
    /// jerk)` in turn; empty segments are left out.
    fn starting(speed: f64, segments: &[(f64, f64, f64)]) -> Self {
        let mut pieces: Vec<Piece> = Vec::with_capacity(segments.len());
        let mut state = State { speed, ..State::default() };
        let mut time = 0.0;
        for &(duration, acceleration, jerk) in segments.iter().filter(|s| s.0 > 0.0) {
            let start = State { acceleration, jerk, ..state };
            pieces.push(Piece { start_time: time, duration, start });
            state = start.advanced(duration);
            time += duration;
        }
        Self { pieces }
    }

    /// Stands still for `duration` where the profile ends: speed and acceleration exactly
    /// 0, not the rounding left by the braking.
    fn stand(&mut self, duration: f64) {
        let position = self.state(self.duration()).position;
        let start = State { position, ..State::default() };
        self.pieces.push(Piece { start_time: self.duration(), duration, start });
    }

    /// Length of the profile (s).
    pub fn duration(&self) -> f64 {
        self.pieces.last().map_or(0.0, |p| p.start_time + p.duration)
    }

    /// The motion at `t` (s), held at the ends outside `[0, duration]`.
    pub fn state(&self, t: f64) -> State {
        let t = t.clamp(0.0, self.duration());
        let i = self.pieces.partition_point(|p| p.start_time <= t).saturating_sub(1);
        let piece = &self.pieces[i];
        piece.start.advanced((t - piece.start_time).min(piece.duration))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_low_top_speed_peaks_below_the_acceleration_limit_and_still_reaches_it() {
        // 1 m/s with 0.8 m/s² and 0.5 m/s³: v < a²/j = 1.28 m/s, so the peak is √0.5.
        let run = JerkLimitedRun { top_speed: 1.0, cruise: 1.0, ..JerkLimitedRun::default() };
        let profile = Profile::jerk_limited(&run);
        let t_up = 2.0 * 0.5f64.sqrt() / 0.5;
        let top = profile.state(t_up);
        assert!((top.speed - 1.0).abs() < 1e-12 && top.acceleration.abs() < 1e-12, "{top:?}");
        assert!((profile.state(t_up / 2.0).acceleration - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((profile.duration() - (2.0 * t_up + 1.0)).abs() < 1e-12);
    }

    #[test]
    fn outside_the_profile_the_state_is_held() {
        let profile = Profile::paper();
        assert_eq!(profile.state(-1.0), profile.state(0.0));
        assert_eq!(profile.state(1e6), profile.state(profile.duration()));
        assert_eq!(profile.state(0.0).speed, 0.2);
    }
}
