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
//! Asked to ([`SupervisedFilter::keep_transitions`]), the loop also keeps of
//! each prediction what a smoother needs (a [`Transition`]): the filter's
//! cross-covariance, and the prediction with what the gate did to it before
//! the update it kept ([`Supervisor::apply_pending_to_prediction`]). With a
//! [`FixedLagSmoother`] ([`SupervisedFilter::smooth_with_lag`]) each step is
//! added to it once its belief is final: at the commit of its update, or at
//! the next prediction when it had none.
//!
//! [`SupervisedFilter::run`] makes these steps over a sequence of samples and
//! shows each [`Step`] to an observer. A driver with its own clock (an FMU,
//! whose master decides when a sample is measured and when it is read) calls
//! the steps one by one: [`SupervisedFilter::predict`],
//! [`SupervisedFilter::hold_input`], [`SupervisedFilter::update`], and for a
//! read that must not touch the filter [`SupervisedFilter::preview`] on a copy,
//! later taken over by [`SupervisedFilter::commit_preview`].

use std::fmt;

use nalgebra::DMatrix;

use crate::error::FilterError;
use crate::filter::{Snapshot, StateEstimator};
use crate::smoothing::fixed_lag::{FixedLagSmoother, LaggedEstimate, Transition};
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
    /// A re-acquisition triggered by `channel` was undone: the belief the
    /// gate would have kept explained the later samples better (`rival.rs`).
    ReacquisitionUndone {
        /// The channel (row of `z`) that triggered it.
        channel: usize,
        /// The sample's instant (s).
        time: f64,
    },
    /// A jump that `channel` alone explained, and that its review had
    /// confirmed, was undone: the belief without it explained the later
    /// samples better (`rival.rs`).
    JumpUndone {
        /// The channel (row of `z`) whose failure the jump explained.
        channel: usize,
        /// The sample's instant (s).
        time: f64,
    },
    /// The filter restarted from where its states had been while it was
    /// healthy (`restart.rs`): it had used no row for a whole window, its
    /// belief had left its plausible range, or, inconsistent, a challenger
    /// started there explained the samples better (`rival.rs`).
    Restarted {
        /// The sample's instant (s).
        time: f64,
    },
    /// A channel's wiring became inconsistent with the other channels, or
    /// consistent again (`wiring.rs`).
    Wiring {
        /// The channel (row of `z`).
        channel: usize,
        /// Inconsistent from now on (`true`) or taken back (`false`).
        inconsistent: bool,
        /// Left out of the updates while it is inconsistent (`true`), or kept
        /// with the filter inconsistent ([`SupervisorSettings::wiring_leaves_out`](crate::SupervisorSettings::wiring_leaves_out)).
        left_out: bool,
        /// What its innovations say it reads: its scale
        /// ([`Channel::wiring_fit`](crate::Channel::wiring_fit)).
        scale: f64,
        /// And its mean innovation, in its unit.
        offset: f64,
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
    /// The fixed-lag smoother could not add a step (a singular prediction, a
    /// non-finite term) and starts again from the belief at `time`: until the
    /// lag has passed, its estimate is of a later instant than the lag says.
    SmoothingRestarted {
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
    /// The prediction to this sample, when transitions are kept and one was made.
    pub transition: Option<&'a Transition>,
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
    /// Each channel's wiring verdict before the commit, to report its changes.
    inconsistent: Vec<bool>,
    smoothing: Option<Box<Smoothing>>,
}

/// What the loop keeps for smoothing.
struct Smoothing {
    /// The last prediction; once its update is committed, with what the gate did to it.
    transition: Transition,
    /// A prediction was made since the last step was added (or since the start).
    open: bool,
    /// The instant the last prediction was made to.
    predicted_to: Option<f64>,
    /// The last prediction with what a pending (previewed) update did to it.
    pending: Transition,
    /// The filter's covariance, copied.
    covariance: DMatrix<f64>,
    fixed_lag: Option<FixedLagSmoother>,
}

impl SupervisedFilter {
    /// `filter` behind `supervisor`, which must have one channel per measurement row.
    pub fn new(filter: Box<dyn StateEstimator>, supervisor: Supervisor) -> Result<Self, FilterError> {
        let m = filter.measurement_dim();
        crate::error::check_len("supervisor channels", m, supervisor.channels().len())?;
        let nis = filter.innovation().nis();
        Ok(Self {
            filter,
            supervisor,
            skipped: 0,
            nis,
            events: Vec::with_capacity(3 * m + 3),
            inconsistent: vec![false; m],
            smoothing: None,
        })
    }

    /// From now on keeps of each prediction the [`Transition`] a smoother
    /// needs (allocates, here only).
    pub fn keep_transitions(&mut self) {
        if self.smoothing.is_none() {
            self.filter.keep_cross_covariance();
            let n = self.filter.state_dim();
            self.smoothing = Some(Box::new(Smoothing {
                transition: Transition::zeros(n),
                open: false,
                predicted_to: None,
                pending: Transition::zeros(n),
                covariance: DMatrix::zeros(n, n),
                fixed_lag: None,
            }));
        }
    }

    /// Smooths the states `states` `lag` samples back, from the current belief
    /// on ([`FixedLagSmoother`]); keeps the transitions.
    pub fn smooth_with_lag(&mut self, states: &[usize], lag: usize) -> Result<(), FilterError> {
        let mut smoother = FixedLagSmoother::new(self.filter.state_dim(), states, lag)?;
        self.keep_transitions();
        if let Some(smoothing) = self.smoothing.as_deref_mut() {
            self.filter.write_covariance(&mut smoothing.covariance);
            smoother.start(self.filter.time(), self.filter.mean(), &smoothing.covariance);
            smoothing.fixed_lag = Some(smoother);
            smoothing.open = false;
        }
        Ok(())
    }

    /// The fixed-lag smoother, if there is one.
    pub fn fixed_lag(&self) -> Option<&FixedLagSmoother> {
        self.smoothing.as_ref().and_then(|s| s.fixed_lag.as_ref())
    }

    /// The fixed-lag estimate with the belief as it stands: the smoother's,
    /// advanced over the last prediction when its step is not added yet.
    pub fn lagged_estimate(&mut self) -> Option<LaggedEstimate<'_>> {
        let smoothing = self.smoothing.as_deref_mut()?;
        let smoother = smoothing.fixed_lag.as_mut()?;
        if !smoothing.open {
            return smoother.estimate();
        }
        self.filter.write_covariance(&mut smoothing.covariance);
        let time = self.filter.time();
        Some(smoother.estimate_with(time, &smoothing.transition, self.filter.mean(), &smoothing.covariance))
    }

    /// The fixed-lag estimate a read of the pending update on `reader` shows
    /// ([`SupervisedFilter::preview`]): the step to it with the pending outcome.
    pub fn lagged_estimate_with_pending(&mut self, reader: &dyn StateEstimator) -> Option<LaggedEstimate<'_>> {
        let smoothing = self.smoothing.as_deref_mut()?;
        let smoother = smoothing.fixed_lag.as_mut()?;
        reader.write_covariance(&mut smoothing.covariance);
        if !smoothing.open {
            // An update at the smoother's own instant (the first sample's): its belief.
            return Some(smoother.own_estimate(reader.time(), reader.mean(), &smoothing.covariance));
        }
        // Copied in place: a read allocates nothing.
        let (from, pending) = (&smoothing.transition, &mut smoothing.pending);
        pending.cross.copy_from(&from.cross);
        pending.predicted.mean.copy_from(&from.predicted.mean);
        pending.predicted.covariance.copy_from(&from.predicted.covariance);
        let Transition { predicted, .. } = &mut smoothing.pending;
        self.supervisor.apply_pending_to_prediction(reader.noise().q(), &mut predicted.mean, &mut predicted.covariance);
        Some(smoother.estimate_with(reader.time(), &smoothing.pending, reader.mean(), &smoothing.covariance))
    }

    /// What the smoothing holds between samples, as words for a saved state
    /// (nothing when transitions are not kept): `[open, predicted to (NaN for
    /// none), C, m⁻, P⁻ (column-major), then the fixed-lag smoother's words]`.
    pub fn save_smoothing(&self, out: &mut Vec<f64>) {
        out.clear();
        let Some(smoothing) = self.smoothing.as_deref() else { return };
        let Transition { cross, predicted } = &smoothing.transition;
        out.push(f64::from(u8::from(smoothing.open)));
        out.push(smoothing.predicted_to.unwrap_or(f64::NAN));
        out.extend_from_slice(cross.as_slice());
        out.extend_from_slice(predicted.mean.as_slice());
        out.extend_from_slice(predicted.covariance.as_slice());
        if let Some(smoother) = &smoothing.fixed_lag {
            smoother.save(out);
        }
    }

    /// Takes back what [`SupervisedFilter::save_smoothing`] wrote, into a loop
    /// set up alike; on error nothing changes.
    pub fn load_smoothing(&mut self, words: &[f64]) -> Result<(), FilterError> {
        let bad = |why: &str| FilterError::InvalidSetting(format!("saved smoothing {why}"));
        let Some(smoothing) = self.smoothing.as_deref_mut() else {
            return if words.is_empty() { Ok(()) } else { Err(bad("for a loop that does not smooth")) };
        };
        let n = smoothing.covariance.nrows();
        let head = 2 + 2 * n * n + n;
        if words.len() < head {
            return Err(bad("is truncated"));
        }
        let (fixed, rest) = words.split_at(head);
        if !(fixed[0] == 0.0 || fixed[0] == 1.0) || fixed[2..].iter().any(|v| !v.is_finite()) {
            return Err(bad("has values out of range"));
        }
        match smoothing.fixed_lag.as_mut() {
            Some(smoother) => {
                let mut loaded = smoother.clone();
                if loaded.load(rest)? != rest.len() {
                    return Err(bad("has words left over"));
                }
                *smoother = loaded;
            }
            None if !rest.is_empty() => return Err(bad("has a fixed-lag smoother this loop has not")),
            None => {}
        }
        smoothing.open = fixed[0] == 1.0;
        smoothing.predicted_to = fixed[1].is_finite().then_some(fixed[1]);
        let Transition { cross, predicted } = &mut smoothing.transition;
        let (c, rest) = fixed[2..].split_at(n * n);
        let (m, p) = rest.split_at(n);
        cross.copy_from_slice(c);
        predicted.mean.copy_from_slice(m);
        predicted.covariance.copy_from_slice(p);
        Ok(())
    }

    /// The transition of the prediction to the current belief's instant, when
    /// transitions are kept and one was made (after the commit: with what the
    /// gate did to it).
    pub fn transition(&self) -> Option<&Transition> {
        let smoothing = self.smoothing.as_deref()?;
        (smoothing.predicted_to == Some(self.filter.time())).then_some(&smoothing.transition)
    }

    /// Adds the open step to the fixed-lag smoother with the filter's belief.
    fn add_open_step(&mut self) {
        let Some(smoothing) = self.smoothing.as_deref_mut() else { return };
        if !std::mem::take(&mut smoothing.open) {
            return;
        }
        let Some(smoother) = smoothing.fixed_lag.as_mut() else { return };
        self.filter.write_covariance(&mut smoothing.covariance);
        let time = self.filter.time();
        if smoother.push(time, &smoothing.transition, self.filter.mean(), &smoothing.covariance).is_err() {
            self.events.push(Event::SmoothingRestarted { time });
        }
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
        // A step without an update is final once the next prediction starts.
        self.add_open_step();
        self.filter.predict(controls, dt)?;
        if let Some(smoothing) = self.smoothing.as_deref_mut() {
            if let Some(cross) = self.filter.cross_covariance() {
                smoothing.transition.cross.copy_from(cross);
            }
            smoothing.transition.predicted.mean.copy_from(self.filter.mean());
            self.filter.write_covariance(&mut smoothing.transition.predicted.covariance);
            smoothing.open = true;
            smoothing.predicted_to = Some(self.filter.time());
        }
        Ok(())
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
        if let Some(smoothing) = self.smoothing.as_deref_mut() {
            if smoothing.open {
                let Transition { predicted, .. } = &mut smoothing.transition;
                let q = self.filter.noise().q();
                self.supervisor.apply_pending_to_prediction(q, &mut predicted.mean, &mut predicted.covariance);
                self.add_open_step();
            } else if let Some(smoother) = smoothing.fixed_lag.as_mut() {
                // An update with no prediction before it (the first sample's):
                // the smoother starts at its belief.
                self.filter.write_covariance(&mut smoothing.covariance);
                smoother.start(self.filter.time(), self.filter.mean(), &smoothing.covariance);
            }
        }
        self.skipped += missing_rows(z);
        self.nis = self.supervisor.pending().nis;
        if let Some(channel) = self.supervisor.pending().reacquired {
            self.events.push(Event::Reacquired { channel, time });
        }
        let undone = match self.supervisor.pending().revision {
            crate::supervisor::Revision::Undone { trigger } => {
                Some(Event::ReacquisitionUndone { channel: trigger, time })
            }
            crate::supervisor::Revision::JumpUndone { trigger } => Some(Event::JumpUndone { channel: trigger, time }),
            _ => None,
        };
        let pending = self.supervisor.pending();
        if pending.restarted || pending.revision == crate::supervisor::Revision::Restarted {
            self.events.push(Event::Restarted { time });
        }
        let (was_consistent, was_exhausted) = (self.supervisor.consistent(), self.supervisor.exhausted());
        let events = &mut self.events;
        for (before, channel) in self.inconsistent.iter_mut().zip(self.supervisor.channels()) {
            *before = channel.inconsistent;
        }
        self.supervisor.commit(|FaultChange { channel, faulty }| events.push(Event::Fault { channel, faulty, time }));
        for (channel, (state, &before)) in self.supervisor.channels().iter().zip(&self.inconsistent).enumerate() {
            if state.inconsistent != before {
                let (scale, offset) = state.wiring_fit();
                let left_out = self.supervisor.settings().wiring_leaves_out;
                let inconsistent = state.inconsistent;
                self.events.push(Event::Wiring { channel, inconsistent, left_out, scale, offset, time });
            }
        }
        if let Some(event) = undone {
            self.events.push(event);
        }
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
                transition: self.transition(),
            });
            self.events.clear();
        }
        Ok(())
    }
}

fn missing_rows(z: &[f64]) -> u64 {
    z.iter().filter(|v| !v.is_finite()).count() as u64
}
