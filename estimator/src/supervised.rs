//! The supervised estimation loop: a filter behind its [`Supervisor`], stepped
//! sample by sample. Every driver (each study's runs, the FMU's time rules)
//! goes through this one type, so a rule of the loop (what is predicted with
//! which controls, when an outcome is counted, what is reported) lives here
//! and nowhere else.
//!
//! One sample `k` at `tₖ`, controls `uₖ` in force there, measurement `zₖ`:
//!
//! 1. **Predict** from `tₖ₋₁` to `tₖ` with the controls held over that
//!    interval, `uₖ₋₁` (a control computer's zero-order hold). The first
//!    sample is the prior's instant: nothing is predicted to it.
//! 2. **Hold** `uₖ`: the observation `h(x, uₖ)` of this sample sees them.
//! 3. **Gate and update** through the supervisor ([`Supervisor::gate`]).
//! 4. **Commit** the outcome ([`Supervisor::commit`]): channel runs, faults,
//!    the consistency window, the adaptation of the process noise, whose new
//!    scale on `Q` the filter takes for its next prediction; what changed
//!    becomes an [`Event`].
//!
//! [`SupervisedFilter::run`] makes these steps over a sequence of samples and
//! shows each [`Step`] to an observer. A driver with its own clock (an FMU,
//! whose master decides when a sample is measured and when it is read) calls
//! the steps one by one: [`SupervisedFilter::predict`],
//! [`SupervisedFilter::hold_input`], [`SupervisedFilter::update`], and for a
//! read that must not touch the filter [`SupervisedFilter::preview`] on a copy,
//! later taken over by [`SupervisedFilter::commit_preview`].

use std::fmt;

use crate::error::FilterError;
use crate::filter::{Snapshot, StateEstimator};
use crate::supervisor::{FaultChange, Outcome, Supervisor};

/// Something that happened at a sample, for a driver to report once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// A channel became faulty (`true`) or good again (`false`).
    Fault {
        /// The channel (row of `z`).
        channel: usize,
        /// Its new fault flag.
        faulty: bool,
        /// The sample's instant (s).
        time: f64,
    },
    /// The filter re-acquired; the channel that triggered it.
    Reacquired {
        /// The channel (row of `z`).
        channel: usize,
        /// The sample's instant (s).
        time: f64,
    },
    /// The filter became inconsistent (`false`) or consistent again (`true`).
    Consistent {
        /// The new consistency flag.
        consistent: bool,
        /// The sample's instant (s).
        time: f64,
    },
    /// The re-acquisitions spent their inflation budget (`true`), or a sample
    /// passed the gate whole again (`false`).
    Exhausted {
        /// The new flag.
        exhausted: bool,
        /// The sample's instant (s).
        time: f64,
    },
}

/// One sample of a run.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Its instant (s), for reports.
    pub time: f64,
    /// The measurement (non-finite rows: missing).
    pub z: &'a [f64],
    /// The controls in force at it (empty for a model without controls).
    pub controls: &'a [f64],
}

/// What an observer of [`SupervisedFilter::run`] sees after each sample.
pub struct Step<'a> {
    /// The sample's index in the run.
    pub index: usize,
    /// The sample.
    pub sample: &'a Sample<'a>,
    /// The supervisor's outcome of its update (committed).
    pub outcome: &'a Outcome,
    /// The belief after it.
    pub filter: &'a dyn StateEstimator,
    /// The supervisor after the commit.
    pub supervisor: &'a Supervisor,
    /// What changed at this sample.
    pub events: &'a [Event],
}

/// A failure of the loop at a sample: the filter's error, where it happened.
#[derive(Debug, Clone, PartialEq)]
pub struct RunError {
    /// The sample's index in the run.
    pub sample: usize,
    /// Its instant (s).
    pub time: f64,
    /// Which stage failed and why.
    pub error: FilterError,
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "t = {:.3} s (sample {}): {}", self.time, self.sample, self.error)
    }
}

impl std::error::Error for RunError {}

/// A filter behind a supervisor, with the counts a driver reports.
pub struct SupervisedFilter {
    filter: Box<dyn StateEstimator>,
    supervisor: Supervisor,
    /// Measurement rows left out as missing so far.
    skipped: u64,
    /// NIS of the latest committed update (kept here: a restored belief has no innovation).
    nis: f64,
    events: Vec<Event>,
}

impl SupervisedFilter {
    /// `filter` behind `supervisor`, which must have one channel per measurement row.
    pub fn new(filter: Box<dyn StateEstimator>, supervisor: Supervisor) -> Result<Self, FilterError> {
        let m = filter.measurement_dim();
        crate::error::check_len("supervisor channels", m, supervisor.channels().len())?;
        let nis = filter.innovation().nis();
        Ok(Self { filter, supervisor, skipped: 0, nis, events: Vec::with_capacity(2 * m + 2) })
    }

    /// The belief.
    pub fn filter(&self) -> &dyn StateEstimator {
        self.filter.as_ref()
    }

    /// The supervisor.
    pub fn supervisor(&self) -> &Supervisor {
        &self.supervisor
    }

    /// Measurement rows left out as missing so far.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    /// [`SupervisedFilter::skipped`] with the rows missing from the pending
    /// (previewed) update (what a read between a preview and its commit shows).
    pub fn skipped_with_pending(&self) -> u64 {
        self.skipped + missing_rows(self.supervisor.pending_measurement())
    }

    /// NIS of the latest committed update.
    pub fn nis(&self) -> f64 {
        self.nis
    }

    /// Step 1: predicts over `dt` with `controls` held over the interval.
    pub fn predict(&mut self, controls: &[f64], dt: f64) -> Result<(), FilterError> {
        self.filter.predict(controls, dt)
    }

    /// Step 2: holds the controls of the current sample for its update.
    pub fn hold_input(&mut self, controls: &[f64]) -> Result<(), FilterError> {
        self.filter.hold_input(controls)
    }

    /// Steps 3 and 4: the supervised update at the current sample, `time`,
    /// committed. On error the belief is as before and nothing is counted.
    pub fn update(&mut self, z: &[f64], time: f64) -> Result<&Outcome, FilterError> {
        self.supervisor.gate(self.filter.as_mut(), z)?;
        self.commit(z, time)?;
        Ok(self.supervisor.pending())
    }

    /// Step 3 on `reader`, a filter of the same build and noise holding a copy
    /// of the belief (it is given the adapted scale on `Q` here): the update a
    /// read shows, left pending; the filter is untouched.
    pub fn preview(&mut self, reader: &mut dyn StateEstimator, z: &[f64]) -> Result<&Outcome, FilterError> {
        // A review predicts on the reader: it must have the filter's Q.
        self.supervisor.scale_process_noise_of(reader)?;
        self.supervisor.gate(reader, z)
    }

    /// Step 4 for the update [`SupervisedFilter::preview`] made on `reader`
    /// with `z`: its belief becomes the filter's, bit for bit, and its outcome
    /// is committed (`copy` is the buffer the belief passes through).
    pub fn commit_preview(
        &mut self,
        reader: &dyn StateEstimator,
        copy: &mut Snapshot,
        z: &[f64],
        time: f64,
    ) -> Result<(), FilterError> {
        reader.snapshot_into(copy);
        self.filter.restore(copy)?;
        self.commit(z, time)
    }

    fn commit(&mut self, z: &[f64], time: f64) -> Result<(), FilterError> {
        self.skipped += missing_rows(z);
        self.nis = self.supervisor.pending().nis;
        if let Some(channel) = self.supervisor.pending().reacquired {
            self.events.push(Event::Reacquired { channel, time });
        }
        let (was_consistent, was_exhausted) = (self.supervisor.consistent(), self.supervisor.exhausted());
        let events = &mut self.events;
        self.supervisor.commit(|FaultChange { channel, faulty }| events.push(Event::Fault { channel, faulty, time }));
        if self.supervisor.consistent() != was_consistent {
            self.events.push(Event::Consistent { consistent: self.supervisor.consistent(), time });
        }
        if self.supervisor.exhausted() != was_exhausted {
            self.events.push(Event::Exhausted { exhausted: self.supervisor.exhausted(), time });
        }
        self.supervisor.scale_process_noise_of(self.filter.as_mut())
    }

    /// The scale on the `Q` given that the filter predicts with (see
    /// [`Supervisor::process_noise_scale`]).
    pub fn process_noise_scale(&self) -> f64 {
        self.supervisor.process_noise_scale()
    }

    /// Puts the adapted scale on `filter`'s `Q`, as on this one's (a reader's
    /// copy predicting to a read between samples).
    pub fn scale_process_noise_of(&self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        self.supervisor.scale_process_noise_of(filter)
    }

    /// Takes the events since the last call, oldest first.
    pub fn take_events(&mut self, mut each: impl FnMut(Event)) {
        for event in self.events.drain(..) {
            each(event);
        }
    }

    /// Replaces the belief by a saved one (an FMU state).
    pub fn restore(&mut self, belief: &Snapshot) -> Result<(), FilterError> {
        self.filter.restore(belief)
    }

    /// Takes back the counts and the supervisor's memory of a saved run
    /// ([`Supervisor::save`]); on error nothing changes.
    pub fn resume(&mut self, skipped: u64, nis: f64, supervisor: &[u64]) -> Result<(), FilterError> {
        let before = self.supervisor.clone();
        self.supervisor.load(supervisor)?;
        if let Err(e) = self.supervisor.scale_process_noise_of(self.filter.as_mut()) {
            self.supervisor = before;
            return Err(e);
        }
        (self.skipped, self.nis) = (skipped, nis);
        Ok(())
    }

    /// New `Q` and `R` (`Q` as given: the adapted scale stays on it); on
    /// error the filter keeps its noise.
    pub fn set_noise(&mut self, mut noise: crate::noise::Noise) -> Result<(), FilterError> {
        noise.set_q_scale(self.supervisor.process_noise_scale(), self.supervisor.scaled_states())?;
        self.filter.set_noise(noise)
    }

    /// Runs the loop over `samples`, `dt` apart, the first at the belief's
    /// instant; `observe` sees every sample's [`Step`]. Stops at the first
    /// failure, which the failed stage left without effect (every stage is
    /// transactional); no later sample is observed.
    pub fn run<'a>(
        &mut self,
        dt: f64,
        samples: impl IntoIterator<Item = Sample<'a>>,
        mut observe: impl FnMut(&Step<'_>),
    ) -> Result<(), RunError> {
        let mut held: Option<&'a [f64]> = None;
        for (index, sample) in samples.into_iter().enumerate() {
            let failed = |error| RunError { sample: index, time: sample.time, error };
            if let Some(controls) = held {
                self.predict(controls, dt).map_err(failed)?;
            }
            self.hold_input(sample.controls).map_err(failed)?;
            self.update(sample.z, sample.time).map_err(failed)?;
            held = Some(sample.controls);
            observe(&Step {
                index,
                sample: &sample,
                outcome: self.supervisor.pending(),
                filter: self.filter.as_ref(),
                supervisor: &self.supervisor,
                events: &self.events,
            });
            self.events.clear();
        }
        Ok(())
    }
}

fn missing_rows(z: &[f64]) -> u64 {
    z.iter().filter(|v| !v.is_finite()).count() as u64
}
