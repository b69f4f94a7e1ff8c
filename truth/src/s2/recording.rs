//! S2's truth as a plant that is stepped: the coupled vehicle–track [`Simulation`] at its
//! integration step, recorded by the vehicle's data acquisition ([`AntiAlias`]) at its
//! sampling rate, one sample at a time. The DAQ's filter is linear-phase and its samples
//! are time-stamped for its delay, so the sample of `t` needs the signals up to half the
//! filter's length after `t`: the recording runs the simulation that far ahead. The
//! study's batch truth ([`super::cases::simulate`]) is this recording stepped sample by
//! sample, so a master that steps it gets the study's truth to the bit.

use std::collections::VecDeque;

use super::daq::AntiAlias;
use super::plant::{Simulation, SimulationState};

/// The raw signals of one integration step: the seven accelerations, the four forces.
type Raw = ([f64; 7], [f64; 4]);

/// A simulation recorded at a rate.
#[derive(Debug, Clone)]
pub struct Recording {
    simulation: Simulation,
    daq: AntiAlias,
    /// Integration steps per sample.
    per_sample: usize,
    /// The raw signals the next samples need, from integration step `first` on.
    raw: VecDeque<Raw>,
    first: usize,
    /// The sample the recording stands at.
    sample: usize,
}

/// The state of a [`Recording`] (see [`Recording::state`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingState {
    /// The simulation's.
    pub simulation: SimulationState,
    /// The raw signals kept, from integration step `first` on.
    pub raw: Vec<Raw>,
    /// See `raw`.
    pub first: usize,
    /// The sample the recording stands at.
    pub sample: usize,
}

impl Recording {
    /// `simulation`, at its start, recorded at `rate` (Hz): its sample time must be a whole
    /// number of the simulation's steps `dt`.
    pub fn new(simulation: Simulation, dt: f64, rate: f64) -> Result<Self, String> {
        let steps = 1.0 / (rate * dt);
        if !(steps >= 1.0 && (steps - steps.round()).abs() <= 1e-9 * steps) {
            return Err(format!("the sample time 1/{rate} s must be a whole number of the {dt} s integration steps"));
        }
        let daq = AntiAlias::new(dt, rate);
        let mut recording =
            Self { simulation, daq, per_sample: steps.round() as usize, raw: VecDeque::new(), first: 0, sample: 0 };
        recording.push_raw();
        recording.run_ahead();
        Ok(recording)
    }

    /// The sample the recording stands at: `k`, at `k / rate` s.
    pub fn sample_index(&self) -> usize {
        self.sample
    }

    /// The seven accelerations and the four forces of the current sample, as the DAQ records them.
    pub fn sample(&self) -> Raw {
        let centre = self.sample * self.per_sample;
        let raw = |i: usize| &self.raw[i - self.first];
        let accelerations = std::array::from_fn(|c| self.daq.at(centre, |i| raw(i).0[c]));
        let contact = std::array::from_fn(|j| self.daq.at(centre, |i| raw(i).1[j]));
        (accelerations, contact)
    }

    /// Moves on `samples` samples.
    pub fn advance(&mut self, samples: usize) {
        for _ in 0..samples {
            self.sample += 1;
            self.run_ahead();
            let oldest = (self.sample * self.per_sample).saturating_sub(self.daq.half_length());
            while self.first < oldest {
                self.raw.pop_front();
                self.first += 1;
            }
        }
    }

    /// What makes the recording where it is, beside its construction.
    pub fn state(&self) -> RecordingState {
        RecordingState {
            simulation: self.simulation.state(),
            raw: self.raw.iter().copied().collect(),
            first: self.first,
            sample: self.sample,
        }
    }

    /// Back to a [`Recording::state`] of a recording built alike.
    pub fn resume(&mut self, state: &RecordingState) -> Result<(), String> {
        let needed = state.sample * self.per_sample + self.daq.half_length() + 1;
        if state.first + state.raw.len() != needed || state.first > state.sample * self.per_sample {
            return Err("a recording state of another rate or filter".into());
        }
        let mut simulation = self.simulation.clone();
        simulation.resume(&state.simulation)?;
        self.simulation = simulation;
        self.raw = state.raw.iter().copied().collect();
        self.first = state.first;
        self.sample = state.sample;
        Ok(())
    }

    /// Simulates until the raw signals reach half the filter's length past the current sample.
    fn run_ahead(&mut self) {
        let needed = self.sample * self.per_sample + self.daq.half_length();
        while self.first + self.raw.len() <= needed {
            self.simulation.step();
            self.push_raw();
        }
    }

    fn push_raw(&mut self) {
        let s = self.simulation.sample();
        self.raw.push_back((s.accelerations, s.contact));
    }
}
