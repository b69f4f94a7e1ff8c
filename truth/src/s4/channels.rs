//! The four PRW position channels and how they record a run: each channel's sensor reads
//! the train's reference position plus its lever along the train, with its noise and its
//! faults, once per telegram (every 0.02 s, on the dot).
//!
//! Randomness is seeded and split so that it is reproducible bit for bit: ChaCha8 from
//! the seed, one stream per channel for its noise and one for its faults. A channel's
//! noise is therefore the same whatever the fault rates, and a run with faults differs
//! from the same seed's run without them by its faults alone.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::faults::{FaultKind, Faults};
use super::parameters::{HEAD_TO_TAIL, TELEGRAM_INTERVAL};
use super::profile::Profile;
use super::recording::Recording;

/// One of the four redundant position channels: head or tail car, left or right stator.
/// `channel as usize` indexes a [`Recording`]'s per-channel arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Head car, left side.
    HeadLeft,
    /// Head car, right side.
    HeadRight,
    /// Tail car, left side.
    TailLeft,
    /// Tail car, right side.
    TailRight,
}

impl Channel {
    /// The four, in the recording's order.
    pub const ALL: [Channel; 4] = [Channel::HeadLeft, Channel::HeadRight, Channel::TailLeft, Channel::TailRight];

    /// The sensor's position ahead of the reference point along the train (m): the
    /// reference point is midway between head and tail, so the mean of the four levers
    /// is 0 and the mean of the four true positions is the reference position.
    pub fn lever(self) -> f64 {
        match self {
            Channel::HeadLeft | Channel::HeadRight => HEAD_TO_TAIL / 2.0,
            Channel::TailLeft | Channel::TailRight => -HEAD_TO_TAIL / 2.0,
        }
    }

    /// A short name for tables and plots.
    pub fn name(self) -> &'static str {
        match self {
            Channel::HeadLeft => "head-left",
            Channel::HeadRight => "head-right",
            Channel::TailLeft => "tail-left",
            Channel::TailRight => "tail-right",
        }
    }
}

/// Records `profile` through the four channels with `faults`: one telegram at every
/// `k · 0.02 s` from 0 to the profile's end.
pub fn simulate(profile: &Profile, faults: &Faults, seed: u64) -> Recording {
    let n = (profile.duration() / TELEGRAM_INTERVAL).round() as usize + 1;
    let truth: Vec<_> = (0..n).map(|k| profile.state(k as f64 * TELEGRAM_INTERVAL)).collect();
    let moving: Vec<bool> = truth.iter().map(|s| s.speed > 0.0).collect();
    let mut recording = Recording {
        telegram_interval: TELEGRAM_INTERVAL,
        truth,
        position: Default::default(),
        received: Default::default(),
        faults: Vec::new(),
    };
    let base = ChaCha8Rng::seed_from_u64(seed ^ 0x5555_0004);
    for channel in Channel::ALL {
        let c = channel as usize;
        let mut noise = base.clone();
        noise.set_stream(2 * c as u64);
        let mut events = base.clone();
        events.set_stream(2 * c as u64 + 1);

        let clean: Vec<f64> = recording
            .true_position(channel)
            .into_iter()
            .map(|x| {
                let e: f64 = StandardNormal.sample(&mut noise);
                x + faults.noise_std * e
            })
            .collect();
        let drawn = faults.draw(channel, &moving, &mut events);
        let mut error = vec![0.0; n];
        for fault in &drawn {
            if let FaultKind::Spike { error: e } | FaultKind::SlotSlip { step: e } | FaultKind::Offset { error: e } =
                fault.kind
            {
                fault.telegrams.clone().for_each(|k| error[k] += e);
            }
        }
        let mut position: Vec<f64> = clean.iter().zip(&error).map(|(x, e)| x + e).collect();
        let mut received = vec![true; n];
        for fault in drawn.iter().filter(|f| matches!(f.kind, FaultKind::Dropout | FaultKind::Resend)) {
            let held = position[fault.telegrams.start - 1];
            for k in fault.telegrams.clone() {
                position[k] = held;
                received[k] = fault.kind == FaultKind::Resend;
            }
        }
        recording.position[c] = position;
        recording.received[c] = received;
        recording.faults.extend(drawn);
    }
    recording
}
