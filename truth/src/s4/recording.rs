//! A recorded run: what the train's computer received from the four channels, telegram
//! by telegram, beside the truth and the faults injected, and the speeds derived from
//! them: the raw speed as the train computes it and the two true speeds.

use super::channels::Channel;
use super::faults::Fault;
use super::profile::State;

/// Telegrams `k = 0, 1, …, n − 1` at `k · telegram_interval`.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Time between telegrams (s).
    pub telegram_interval: f64,
    /// The reference point's true motion at each telegram.
    pub truth: Vec<State>,
    /// Per channel (`channel as usize`), the position the train's computer holds at
    /// each telegram (m): the one received, or the last one held through a dropout, or
    /// the last one again when it was resent.
    pub position: [Vec<f64>; 4],
    /// Per channel, whether the telegram arrived: false where it was dropped. A resent
    /// telegram arrives: only its content tells it is old.
    pub received: [Vec<bool>; 4],
    /// Every fault injected, channel by channel: the ground truth for detectors.
    pub faults: Vec<Fault>,
}

impl Recording {
    /// How many telegrams each channel sent.
    pub fn n_telegrams(&self) -> usize {
        self.truth.len()
    }

    /// The time of telegram `k` (s).
    pub fn time(&self, k: usize) -> f64 {
        k as f64 * self.telegram_interval
    }

    /// The true position of `channel`'s sensor at each telegram (m): the reference
    /// position plus the channel's lever.
    pub fn true_position(&self, channel: Channel) -> Vec<f64> {
        self.truth.iter().map(|s| s.position + channel.lever()).collect()
    }

    /// The raw speed of `channel` as the train computes it, the paper's eq. (2):
    /// `v(a) = (P(a+1) − P(a)) / Δt` for `a = 0 … n − 2`, known at telegram `a + 1`.
    /// Through a dropout or a resend the position is held, so it reads 0, then jumps by
    /// the distance run meanwhile at the first fresh telegram.
    pub fn raw_speed(&self, channel: Channel) -> Vec<f64> {
        differences(&self.position[channel as usize], self.telegram_interval)
    }

    /// Our true speed: the reference point's speed from the profile at each telegram
    /// (m/s), exact, aligned with the telegrams.
    pub fn true_speed(&self) -> Vec<f64> {
        self.truth.iter().map(|s| s.speed).collect()
    }

    /// The paper's true speed (§3.1): the difference of the mean of the four true
    /// positions over one telegram interval, aligned with [`Recording::raw_speed`]. It is
    /// the mean speed over `[a·Δt, (a+1)·Δt]`, so it equals our true speed at the
    /// interval's middle, and differs from it at either end by up to `|acceleration|·Δt/2`
    /// (0.025 m/s at 2.5 m/s²).
    pub fn paper_true_speed(&self) -> Vec<f64> {
        let mean: Vec<f64> = (0..self.n_telegrams())
            .map(|k| Channel::ALL.iter().map(|&c| self.truth[k].position + c.lever()).sum::<f64>() / 4.0)
            .collect();
        differences(&mean, self.telegram_interval)
    }
}

/// `(x[a+1] − x[a]) / dt` for each neighbouring pair.
fn differences(x: &[f64], dt: f64) -> Vec<f64> {
    x.windows(2).map(|w| (w[1] - w[0]) / dt).collect()
}
