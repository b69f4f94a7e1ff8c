//! The fault model of a PRW position channel (our estimates, `docs/studies/s4.md`), and the faults drawn from it, recorded as the ground
//! truth that detectors are scored against.
//!
//! Per channel and telegram, independently of the other channels:
//! - white position noise, always;
//! - a burst of dropped telegrams: nothing arrives and the train's computer holds the
//!   last position, so the raw speed reads 0 and then jumps;
//! - a burst of resent telegrams: the last telegram arrives again, position and all;
//! - a spike: one telegram's position off, so the raw speed is off one way and then back;
//! - a slot slip, while the train moves: a slot counted once too often or too rarely, a
//!   step of one slot pitch that stays;
//! - a constant installation offset for the whole run.
//!
//! Faults do not overlap: a new one starts only after the telegram that ends the last
//! burst or spike has come through clean, so that each shows exactly as its record says
//! (a spike just before a dropout would otherwise be held through it).
//!
//! ## Fault profiles
//!
//! [`Faults::default`] is the study's channel, the one the detectors were tuned on. Any
//! other rate is [`Faults::scaled`] (the four rates times a factor, sizes, offsets and noise
//! kept); [`FaultProfile`] names three, parsed from `default`, `none` and `frequent`:
//! `frequent` ([`Faults::frequent`]) is the default with its four rates ten times higher
//! ([`Faults::FREQUENT_FACTOR`]): dropouts, resends and spikes 1e-2 per telegram, slot
//! slips 1e-3 per moving telegram, a fault starting every 32 telegrams (0.65 s) or so on
//! each channel, against one in 320 by default. The rates are ours `[est]`, as the
//! default's are. Each channel's noise stream does not depend on the profile, and the
//! fault stream is the same seed's, so a frequent run differs from the default run of the
//! same seed by its faults alone.

use std::ops::{Range, RangeInclusive};

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use super::channels::Channel;
use super::parameters::{SLOT_PITCH, TELEGRAM_INTERVAL};

/// What went wrong, with its size where it has one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultKind {
    /// Telegrams lost; the last position held.
    Dropout,
    /// The last telegram received again.
    Resend,
    /// One telegram's position off by `error` (m).
    Spike {
        /// The position error (m); the raw speed is off by `error / Δt`, then by `−error / Δt`.
        error: f64,
    },
    /// The position off by `step` (m), ±[`SLOT_PITCH`], from the fault's first telegram on.
    SlotSlip {
        /// The step (m).
        step: f64,
    },
    /// The position off by `error` (m) over the whole run.
    Offset {
        /// The installation error (m).
        error: f64,
    },
}

impl FaultKind {
    /// The kind's name, for tables of detections per fault type.
    pub fn name(&self) -> &'static str {
        match self {
            FaultKind::Dropout => "dropout",
            FaultKind::Resend => "resend",
            FaultKind::Spike { .. } => "spike",
            FaultKind::SlotSlip { .. } => "slot slip",
            FaultKind::Offset { .. } => "offset",
        }
    }
}

/// A named fault model (the module documentation's profiles).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FaultProfile {
    /// [`Faults::default`], the study's channel.
    Default,
    /// [`Faults::none`], noise alone.
    None,
    /// [`Faults::frequent`], the default's rates ten times higher.
    Frequent,
}

impl FaultProfile {
    /// The three.
    pub const ALL: [FaultProfile; 3] = [FaultProfile::Default, FaultProfile::None, FaultProfile::Frequent];

    /// Its name: `default`, `none`, `frequent`.
    pub fn name(&self) -> &'static str {
        match self {
            FaultProfile::Default => "default",
            FaultProfile::None => "none",
            FaultProfile::Frequent => "frequent",
        }
    }

    /// Its fault model.
    pub fn faults(&self) -> Faults {
        match self {
            FaultProfile::Default => Faults::default(),
            FaultProfile::None => Faults::none(),
            FaultProfile::Frequent => Faults::frequent(),
        }
    }
}

impl std::fmt::Display for FaultProfile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Parses a name of [`FaultProfile::name`].
impl std::str::FromStr for FaultProfile {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        FaultProfile::ALL.into_iter().find(|p| p.name() == s).ok_or_else(|| {
            let names: Vec<&str> = FaultProfile::ALL.iter().map(FaultProfile::name).collect();
            format!("unknown fault profile '{s}'; expected one of {}", names.join(", "))
        })
    }
}

/// One injected fault: the ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    /// What happened.
    pub kind: FaultKind,
    /// To which channel.
    pub channel: Channel,
    /// The telegrams it affects: a burst's dropped or resent telegrams, a spike's one
    /// telegram, a slip's telegrams from the slip to the end, an offset's all.
    pub telegrams: Range<usize>,
}

/// Bursts of bad telegrams.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bursts {
    /// Probability that a burst starts at a telegram.
    pub probability: f64,
    /// The longest burst, in telegrams; lengths are uniform from 1 to this.
    pub longest: usize,
}

/// The fault model of every channel: the imperfections' sizes and rates.
#[derive(Debug, Clone, PartialEq)]
pub struct Faults {
    /// Standard deviation of the position noise (m).
    pub noise_std: f64,
    /// Dropped telegrams.
    pub dropout: Bursts,
    /// Resent telegrams.
    pub resend: Bursts,
    /// Probability of a spike at a telegram.
    pub spike_probability: f64,
    /// The spike's error in the raw speed (m/s), uniform in magnitude over this range,
    /// of either sign: the position is off by that times Δt.
    pub spike_speed: RangeInclusive<f64>,
    /// Probability of a slot slip at a telegram while the train moves.
    pub slip_probability: f64,
    /// The installation offset (m), uniform in magnitude over this range, of either sign.
    pub offset: RangeInclusive<f64>,
}

impl Default for Faults {
    /// The paper-like channel: our estimated rates and sizes (`docs/studies/s4.md`).
    ///
    /// - Noise 1.5 mm: the middle of its 1–2 mm; a pole-phase angle accurate to 2.8°
    ///   (the paper's ref. [9]) on the 258 mm pole pitch is 2.0 mm.
    /// - Dropouts and resends: p = 1e-3 per telegram, bursts of 1–10 and 1–5.
    /// - Spikes: p = 1e-3 [est]; 1 to 5.6 m/s in the raw speed, the paper's largest
    ///   error, and 1 m/s [est] at least, ten times the raw speed's noise (√2·1.5 mm / 0.02 s
    ///   = 0.11 m/s), smaller errors being noise to any reader of it.
    /// - Slot slips: p = 1e-4 per telegram while moving [est], about two per run of the
    ///   paper over the four channels.
    /// - Offsets: 10 to 50 mm [est], a mounting tolerance of a few centimetres; below
    ///   10 mm (7σ of the noise) an offset is calibration, not a fault.
    fn default() -> Self {
        Self {
            noise_std: 1.5e-3,
            dropout: Bursts { probability: 1e-3, longest: 10 },
            resend: Bursts { probability: 1e-3, longest: 5 },
            spike_probability: 1e-3,
            spike_speed: 1.0..=5.6,
            slip_probability: 1e-4,
            offset: 0.01..=0.05,
        }
    }
}

impl Faults {
    /// How much more often faults come in [`Faults::frequent`]: ten times.
    pub const FREQUENT_FACTOR: f64 = 10.0;

    /// The default channel with its four fault rates [`Faults::FREQUENT_FACTOR`] times
    /// higher (the module documentation's profile `frequent`).
    pub fn frequent() -> Self {
        Self::default().scaled(Self::FREQUENT_FACTOR)
    }

    /// No faults, the default noise only.
    pub fn none() -> Self {
        Self { offset: 0.0..=0.0, ..Self::default().scaled(0.0) }
    }

    /// The same faults, their rates (dropouts, resends, spikes, slips) times `factor`;
    /// the sizes, the offsets and the noise stay. The four rates must still add up to
    /// less than 1 (at most one fault starts per telegram).
    pub fn scaled(&self, factor: f64) -> Self {
        Self {
            dropout: Bursts { probability: self.dropout.probability * factor, ..self.dropout },
            resend: Bursts { probability: self.resend.probability * factor, ..self.resend },
            spike_probability: self.spike_probability * factor,
            slip_probability: self.slip_probability * factor,
            ..self.clone()
        }
    }

    /// Draws `channel`'s faults over `moving.len()` telegrams, `moving[k]` telling
    /// whether the train moves at telegram `k`. Telegram 0 is clean: a burst needs a
    /// telegram to hold.
    pub(super) fn draw(&self, channel: Channel, moving: &[bool], rng: &mut ChaCha8Rng) -> Vec<Fault> {
        let n = moving.len();
        let mut faults = Vec::new();
        let mut record = |kind, telegrams| faults.push(Fault { kind, channel, telegrams });
        let sign = |rng: &mut ChaCha8Rng| if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        if *self.offset.end() > 0.0 {
            let error = sign(rng) * rng.random_range(self.offset.clone());
            record(FaultKind::Offset { error }, 0..n);
        }
        let mut k = 1;
        while k < n {
            // One uniform draw picks at most one fault: the kinds' probabilities stacked on [0, 1).
            let u: f64 = rng.random();
            let burst = |bursts: &Bursts, rng: &mut ChaCha8Rng| k..(k + rng.random_range(1..=bursts.longest)).min(n);
            let up_to_resend = self.dropout.probability + self.resend.probability;
            let up_to_spike = up_to_resend + self.spike_probability;
            let up_to_slip = up_to_spike + if moving[k] { self.slip_probability } else { 0.0 };
            k = if u < self.dropout.probability {
                let telegrams = burst(&self.dropout, rng);
                let next = telegrams.end + 1;
                record(FaultKind::Dropout, telegrams);
                next
            } else if u < up_to_resend {
                let telegrams = burst(&self.resend, rng);
                let next = telegrams.end + 1;
                record(FaultKind::Resend, telegrams);
                next
            } else if u < up_to_spike {
                let error = sign(rng) * rng.random_range(self.spike_speed.clone()) * TELEGRAM_INTERVAL;
                record(FaultKind::Spike { error }, k..k + 1);
                k + 2
            } else if u < up_to_slip {
                record(FaultKind::SlotSlip { step: sign(rng) * SLOT_PITCH }, k..n);
                k + 1
            } else {
                k + 1
            };
        }
        faults
    }
}
