//! Fault episodes as real sensors and real wiring make them, drawn at random
//! from a seed and put into a table of measurements.
//!
//! | kind | what the channels read during the episode |
//! |---|---|
//! | burst | their value plus ±(3 … 10⁶)·rms, of one sign or alternating, 1 to 1000 samples |
//! | offset | their value plus (3 … 30)·rms, of either sign |
//! | stuck | the value of the episode's first sample, bit for bit |
//! | saturation | their value clipped at ±(0.3 … 1)·rms |
//! | dropout | NaN (missing) |
//! | flipped | their value times −1 (a sign wired wrong) |
//! | unit ×9.81 | their value times 9.81 (g read as m/s²) |
//! | unit ÷9.81 | their value divided by 9.81 (m/s² read as g) |
//! | swapped | two channels' values exchanged |
//!
//! Each episode hits one channel, or (one in four) a random subset of them,
//! or (one in eight) every one; `swapped` hits two.

use std::fmt;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// What an episode does to its channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum FaultKind {
    /// Gross errors of one sign or alternating.
    Burst,
    /// A constant offset.
    Offset,
    /// The first value held.
    Stuck,
    /// Clipped at a limit.
    Saturation,
    /// Missing.
    Dropout,
    /// The sign wired wrong.
    Flipped,
    /// In g read as m/s².
    UnitTimesG,
    /// In m/s² read as g.
    UnitOverG,
    /// Two channels exchanged.
    Swapped,
}

impl FaultKind {
    /// Every kind, in the table's order.
    pub const ALL: [FaultKind; 9] = [
        FaultKind::Burst,
        FaultKind::Offset,
        FaultKind::Stuck,
        FaultKind::Saturation,
        FaultKind::Dropout,
        FaultKind::Flipped,
        FaultKind::UnitTimesG,
        FaultKind::UnitOverG,
        FaultKind::Swapped,
    ];
}

impl fmt::Display for FaultKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FaultKind::Burst => "burst",
            FaultKind::Offset => "offset",
            FaultKind::Stuck => "stuck",
            FaultKind::Saturation => "saturation",
            FaultKind::Dropout => "dropout",
            FaultKind::Flipped => "flipped",
            FaultKind::UnitTimesG => "unit x9.81",
            FaultKind::UnitOverG => "unit /9.81",
            FaultKind::Swapped => "swapped",
        })
    }
}

/// One fault episode.
#[derive(Debug, Clone, PartialEq)]
pub struct Episode {
    /// What it does.
    pub kind: FaultKind,
    /// The channels it hits (measurement rows).
    pub channels: Vec<usize>,
    /// Its first sample.
    pub start: usize,
    /// Its length in samples.
    pub length: usize,
    /// The size, in channel RMS (burst, offset, saturation), signed.
    pub size: f64,
    /// A burst alternates in sign.
    pub alternating: bool,
}

/// Draws an episode over `m` channels starting at `start`, at most `max_length` samples long.
pub fn draw(rng: &mut ChaCha8Rng, m: usize, start: usize, max_length: usize) -> Episode {
    let kind = FaultKind::ALL[rng.random_range(0..FaultKind::ALL.len())];
    let channels = if kind == FaultKind::Swapped {
        let a = rng.random_range(0..m);
        let b = (a + rng.random_range(1..m.max(2))) % m;
        vec![a, b]
    } else {
        match rng.random_range(0..8) {
            0 => (0..m).collect(),
            1 | 2 => {
                let mut some: Vec<usize> = (0..m).filter(|_| rng.random_bool(0.5)).collect();
                if some.is_empty() {
                    some.push(rng.random_range(0..m));
                }
                some
            }
            _ => vec![rng.random_range(0..m)],
        }
    };
    // Lengths and sizes log-uniform over their ranges.
    let log_uniform = |rng: &mut ChaCha8Rng, low: f64, high: f64| -> f64 {
        (low.ln() + rng.random::<f64>() * (high.ln() - low.ln())).exp()
    };
    let length = (log_uniform(rng, 1.0, max_length as f64).round() as usize).clamp(1, max_length);
    let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let size = sign
        * match kind {
            FaultKind::Burst => log_uniform(rng, 3.0, 1e6),
            FaultKind::Offset => log_uniform(rng, 3.0, 30.0),
            FaultKind::Saturation => log_uniform(rng, 0.3, 1.0),
            _ => 0.0,
        };
    Episode { kind, channels, start, length, size, alternating: rng.random_bool(0.5) }
}

impl Episode {
    /// The samples after it (its end, exclusive).
    pub fn end(&self) -> usize {
        self.start + self.length
    }

    /// Its samples on its channels made missing instead (NaN): what a perfect
    /// fault detector would leave the filter, the best a supervisor can do.
    pub fn as_missing(&self) -> Episode {
        Episode { kind: FaultKind::Dropout, size: 0.0, alternating: false, ..self.clone() }
    }

    /// Puts the episode into `z` (rows of measurements), `rms` per channel.
    pub fn apply(&self, z: &mut [Vec<f64>], rms: &[f64]) {
        let end = self.end().min(z.len());
        if self.start >= end {
            return;
        }
        let held: Vec<f64> = self.channels.iter().map(|&c| z[self.start][c]).collect();
        for (j, row) in z[self.start..end].iter_mut().enumerate() {
            let sign = if self.alternating && j % 2 == 1 { -1.0 } else { 1.0 };
            if self.kind == FaultKind::Swapped {
                row.swap(self.channels[0], self.channels[1]);
                continue;
            }
            for (&c, &first) in self.channels.iter().zip(&held) {
                let v = row[c];
                row[c] = match self.kind {
                    FaultKind::Burst => v + sign * self.size * rms[c],
                    FaultKind::Offset => v + self.size * rms[c],
                    FaultKind::Stuck => first,
                    FaultKind::Saturation => v.clamp(-self.size.abs() * rms[c], self.size.abs() * rms[c]),
                    FaultKind::Dropout => f64::NAN,
                    FaultKind::Flipped => -v,
                    FaultKind::UnitTimesG => 9.81 * v,
                    FaultKind::UnitOverG => v / 9.81,
                    FaultKind::Swapped => v,
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn an_episode_changes_its_channels_over_its_samples_only() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..200 {
            let episode = draw(&mut rng, 4, 10, 30);
            let clean: Vec<Vec<f64>> = (0..60).map(|k| (0..4).map(|c| 1.0 + (k * 4 + c) as f64).collect()).collect();
            let mut z = clean.clone();
            episode.apply(&mut z, &[1.0; 4]);
            for (k, (row, good)) in z.iter().zip(&clean).enumerate() {
                for c in 0..4 {
                    let inside = (episode.start..episode.end()).contains(&k) && episode.channels.contains(&c);
                    let same = row[c].to_bits() == good[c].to_bits();
                    // Inside, a stuck channel's first sample and a clip that does not bite keep the value.
                    assert!(inside || same, "{episode:?} changed sample {k} of channel {c}");
                    if inside && episode.kind == FaultKind::Dropout {
                        assert!(row[c].is_nan());
                    }
                }
            }
        }
    }
}
