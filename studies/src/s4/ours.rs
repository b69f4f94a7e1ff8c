//! Our estimator for S4, beyond the paper: a filter on the four **position**
//! channels instead of on their differenced speeds, with each channel's offset as a state
//! ([`PrwTrain`]), run behind the library's [`Supervisor`] so that a faulty channel is
//! left out and flagged rather than averaged in. Any [`FilterKind`] runs it.
//!
//! Every telegram: predict by Δt, hand the four positions to the gate (which takes in a
//! slot slip once one has shown, below), commit. What happens to each fault of the channel
//! model (`docs/studies/s4.md`):
//!
//! - **Dropped telegrams** are missing rows (NaN): the train's computer knows that nothing
//!   arrived (`Recording::received`).
//! - **Resent telegrams** are stuck: a position bit-identical to the channel's previous
//!   one is old content, not a measurement (a live channel has noise on every telegram),
//!   and the supervisor leaves it out from its first repeat (`stuck_after` = 2). A master
//!   driving the FMU passes the held position through a dropout and the same happens.
//! - **Spikes** fail the innovation gate on their telegram and are left out.
//! - **Slot slips** ([`SlipHandling`]): the channel's position steps by ±86 mm for good.
//!   The default, [`SlipHandling::Rebase`], is the supervisor's quantised bias steps
//!   ([`QuantizedSteps`], quantum the slot pitch): a channel rejected on
//!   [`Settings::slip_after`] of its telegrams in a row (missing ones skipped) whose
//!   innovation sits each time within [`Settings::slip_tolerance`] of the same non-zero
//!   multiple of the pitch has slipped by that multiple; its offset estimate is re-based
//!   by it (the mean shifted, the covariance kept: the pitch is exact) and the slip is
//!   reported. A spike cannot do that: it lasts one telegram and the next comes through
//!   clean. The alternative, [`SlipHandling::Reacquire`], leaves the slip to the
//!   supervisor's re-acquisition: after `reacquire_after` (10) failures it inflates the
//!   whole covariance and uses every row. Measured on the paper's run (seed 1, SRCKF;
//!   `tests/s4_ours.rs`) it fails, for two reasons. The inflated covariance cannot tell
//!   one channel's slip from the train and the other three channels moving, so the step
//!   is shared out (three quarters to the slipped offset, a quarter to the position and
//!   the other three offsets); the others then fail the gate in turn and re-acquire too.
//!   And the inflation also multiplies the unobservable direction (the common offset, see
//!   [`PrwTrain`]), which no measurement shrinks again: the position's σ went from
//!   0.025 m to 4,100 m over six re-acquisitions, the filter was unhealthy for 2,681
//!   telegrams, lost the gate for whole telegrams, and the speed error reached 6.0 m/s
//!   (0.107 m/s re-based). Re-basing keeps the covariance, so the common offset keeps
//!   its prior, and it leaves the channel out for 3 telegrams instead of 10.
//! - **Installation offsets** are the offset states, learnt within the first telegrams;
//!   their common part stays at its prior (see [`PrwTrain`]).
//!
//! **What the position is.** Without markers the filter's position is the reference point
//! as the four channels see it on average: the true reference position plus the mean of
//! the four installation offsets (|mean| ≤ 50 mm by the fault model), which no data can
//! separate. Slips do not move it: a re-based slip goes into its channel's offset.
//!
//! **The channel weights** ([`PrwTrain::speed_weights`]): each channel's share in the
//! correction of the speed by the next telegram, `|K_v,i| / Σⱼ |K_v,j|` from the
//! covariance after the update, over the channels not flagged faulty; a faulty channel
//! weighs 0; with all four in and their offsets learnt, each weighs about ¼.
//!
//! The filter has the marker row of [`PrwTrain`], missing throughout: our recordings have
//! no markers, and the estimator FMU has the row.

use estimator::models::PrwTrain;
use estimator::{
    build_filter, FilterKind, Gaussian, Noise, QuantizedSteps, RowOutcome, Sample, SupervisedFilter, Supervisor,
    SupervisorSettings, UnscentedParams,
};
use nalgebra::DMatrix;
use start_values::SetByName;

use truth::s4::channels::Channel;
use truth::s4::parameters::SLOT_PITCH;
use truth::s4::recording::Recording;

/// The noise tuning and the prior of the filter: every number the estimator is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuning {
    /// White-jerk intensity `q` (m²/s⁵) of the constant-acceleration model.
    pub jerk_intensity: f64,
    /// Random-walk intensity of the offsets (m²/s); 0: constants.
    pub offset_walk: f64,
    /// Each channel's position noise (m) in [`Channel::ALL`]'s order, the sensor's
    /// specification: `R = σ²` on its row.
    pub channel_noise_std: [f64; 4],
    /// A marker reading's noise (m).
    pub marker_noise_std: f64,
    /// Prior σ of each channel's offset (m).
    pub offset_prior_std: f64,
    /// Prior mean of the position (m); `None`: the first telegrams' mean reading less
    /// their levers, which is what a train knows when it starts.
    pub prior_position: Option<f64>,
    /// Prior σ of the position around its prior mean (m).
    pub position_prior_std: f64,
    /// Prior mean of the speed (m/s).
    pub prior_speed: f64,
    /// Prior σ of the speed (m/s).
    pub speed_prior_std: f64,
    /// Prior mean of the acceleration (m/s²).
    pub prior_acceleration: f64,
    /// Prior σ of the acceleration (m/s²).
    pub acceleration_prior_std: f64,
    /// The UKF's spread: α = 1, β = 2, κ = 0 in every study's runs (λ = 0: the cubature
    /// rule's 2n points, and a centre point with no weight in the mean).
    pub unscented: UnscentedParams,
}

/// The FMU's parameter of each channel's noise, in [`Channel::ALL`]'s order.
pub const CHANNEL_NOISE_PARAMETERS: [&str; 4] =
    ["r_P_head_left_std", "r_P_head_right_std", "r_P_tail_left_std", "r_P_tail_right_std"];

impl Tuning {
    /// For the paper's run, whose acceleration jumps between 0 and ±2.5 m/s² at once.
    ///
    /// - Jerk intensity `q = 10 m²/s⁵`. A white-jerk model spreads a jump of the
    ///   acceleration over time: too small a `q` lags a 2.5 m/s² jump until the four
    ///   channels' innovations leave the gate together (at `q = 0.1` whole telegrams were
    ///   rejected and the filter re-acquired at the jumps); too large lets the noise into
    ///   the speed. Swept by decades on seeds 1–10 with the default faults
    ///   (`tuning_sweep` in `tests/s4_ours.rs`, SRCKF; speed error max / RMS, gate
    ///   rejections off any fault): 0.3: 0.133 / 0.011 m/s, 13 false rejections; 1:
    ///   0.121 / 0.012, 1; 3: 0.115 / 0.015, 0; **10: 0.107 / 0.020, 0**; 30: 0.124 /
    ///   0.025, 0; 100: 0.157 / 0.033, 0. 10 has the smallest largest error and three
    ///   times the smallest `q` that keeps the gate quiet at the jumps. It is a choice
    ///   for this class of motion (jumps of 2.5 m/s² a few times a run), made on the
    ///   simulator: the paper gives no jerk.
    /// - `R = (1.5 mm)²` per channel: the sensor's specification (our estimate,
    ///   1–2 mm), not a value fitted to the simulator's truth.
    /// - Offsets: prior σ 0.05 m, the largest installation error the fault model
    ///   allows; constants (no walk: nothing in the fault model drifts).
    /// - A marker reading to 0.01 m [est: a balise's position on the guideway surveyed to
    ///   the centimetre]; no recording of ours has markers yet.
    /// - Position σ 1 m around the first telegram's mean reading less its lever (vague, so
    ///   that reading is not counted twice); speed σ 150 m/s and acceleration σ 3 m/s²
    ///   around 0: the filter starts without knowing the motion.
    pub fn paper() -> Self {
        Self {
            jerk_intensity: 10.0,
            offset_walk: 0.0,
            channel_noise_std: [1.5e-3; 4],
            marker_noise_std: 0.01,
            offset_prior_std: 0.05,
            prior_position: None,
            position_prior_std: 1.0,
            prior_speed: 0.0,
            speed_prior_std: 150.0,
            prior_acceleration: 0.0,
            acceleration_prior_std: 3.0,
            unscented: UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 },
        }
    }

    /// For a jerk-limited run (the 500 km/h run: jerk at most 0.5 m/s³, the acceleration
    /// at most 0.8 m/s², no jumps): `q = 0.01 m²/s⁵`, the rest as [`Tuning::paper`].
    /// Swept the same way on the high-speed run (speed error max / RMS): 0.001: 0.030 /
    /// 0.0032 m/s; 0.003: 0.024 / 0.0033; **0.01: 0.022 / 0.0040**; 0.03: 0.025 /
    /// 0.0051; 0.1: 0.031 / 0.0067; 1: 0.051 / 0.012 (seeds 1–10). Gate rejections off any
    /// fault in 820,880 rows: 3 at 0.001, 1 from 0.003 to 0.3 (what the gate's 1e-6 per
    /// row gives), 0 at 1. 0.01 has the smallest largest error. The
    /// paper's `q = 10` runs it too, with 0.076 / 0.020 m/s on seed 1.
    pub fn jerk_limited() -> Self {
        Self { jerk_intensity: 0.01, ..Self::paper() }
    }

    /// The model with these numbers and `levers`, with the marker row (missing where no
    /// marker passes, as everywhere in our recordings). Its one `channel_noise_std` (the
    /// largest of the four) is not the filter's `R`: [`Tuning::noise`] has each channel's.
    pub fn model(&self, levers: [f64; 4]) -> PrwTrain {
        PrwTrain {
            marker: true,
            jerk_intensity: self.jerk_intensity,
            offset_walk: self.offset_walk,
            channel_noise_std: self.channel_noise_std.into_iter().fold(0.0, f64::max),
            marker_noise_std: self.marker_noise_std,
            ..PrwTrain::new(levers)
        }
    }

    /// `Q` of `model` over `dt`, and `R` from each channel's noise and the marker's, as the
    /// FMU forms them.
    pub fn noise(&self, model: &PrwTrain, dt: f64) -> Result<Noise, String> {
        let mut r = DMatrix::zeros(PrwTrain::MARKER + 1, PrwTrain::MARKER + 1);
        for (c, std) in self.channel_noise_std.iter().enumerate() {
            r[(c, c)] = std.powi(2);
        }
        r[(PrwTrain::MARKER, PrwTrain::MARKER)] = self.marker_noise_std.powi(2);
        Noise::new(model.process_noise(dt), r).map_err(|e| e.to_string())
    }

    /// The FMU parameters a tuning sets, each by the name `fmu_run::parameters` gives it
    /// (the recording's `sample_time` aside: it is the data's clock, not a tuning).
    pub const NAMES: [&'static str; 17] = [
        "jerk_intensity",
        "offset_walk",
        "r_P_head_left_std",
        "r_P_head_right_std",
        "r_P_tail_left_std",
        "r_P_tail_right_std",
        "r_marker_position_std",
        "prior_offset_std",
        "prior_position",
        "prior_position_std",
        "prior_speed",
        "prior_speed_std",
        "prior_acceleration",
        "prior_acceleration_std",
        "ukf_alpha",
        "ukf_beta",
        "ukf_kappa",
    ];
}

impl SetByName for Tuning {
    /// Whether [`Tuning::set`] takes `name`.
    fn takes(name: &str) -> bool {
        Self::NAMES.contains(&name)
    }

    /// Sets the FMU parameter `name` to `value` as the in-process filter has it, so that
    /// `fmu_run::parameters` then writes `value` for it. An error names what is wrong: a
    /// name the tuning does not have (the FMU's supervisor and slip settings, `filter`, …
    /// are the FMU's only), or a value the FMU would refuse too (not finite, or a negative
    /// σ or intensity).
    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if name == "sample_time" {
            return Err(
                "sample_time is the recording's telegram interval, not a tuning of the in-process filter".into()
            );
        }
        if !value.is_finite() {
            return Err(format!("{name} = {value}: not a finite number"));
        }
        let mean = |slot: &mut f64| *slot = value;
        let spread = |slot: &mut f64| {
            if value < 0.0 {
                return Err(format!("{name} = {value}: a σ or an intensity is not negative"));
            }
            *slot = value;
            Ok(())
        };
        match name {
            "jerk_intensity" => spread(&mut self.jerk_intensity)?,
            "offset_walk" => spread(&mut self.offset_walk)?,
            "r_marker_position_std" => spread(&mut self.marker_noise_std)?,
            "prior_offset_std" => spread(&mut self.offset_prior_std)?,
            "prior_position" => self.prior_position = Some(value),
            "prior_position_std" => spread(&mut self.position_prior_std)?,
            "prior_speed" => mean(&mut self.prior_speed),
            "prior_speed_std" => spread(&mut self.speed_prior_std)?,
            "prior_acceleration" => mean(&mut self.prior_acceleration),
            "prior_acceleration_std" => spread(&mut self.acceleration_prior_std)?,
            "ukf_alpha" => mean(&mut self.unscented.alpha),
            "ukf_beta" => mean(&mut self.unscented.beta),
            "ukf_kappa" => mean(&mut self.unscented.kappa),
            _ => match CHANNEL_NOISE_PARAMETERS.iter().position(|&n| n == name) {
                Some(c) => spread(&mut self.channel_noise_std[c])?,
                None => {
                    return Err(format!(
                        "'{name}' is not a parameter the in-process S4 filter takes (it takes {})",
                        Self::NAMES.join(", ")
                    ))
                }
            },
        }
        Ok(())
    }
}

/// How a slot slip is taken in (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlipHandling {
    /// Re-base the channel's offset by the slipped multiple of the slot pitch once its
    /// innovation has sat there for [`Settings::slip_after`] telegrams.
    Rebase,
    /// Leave it to the supervisor's re-acquisition.
    Reacquire,
}

/// What a run is given besides the recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The filter.
    pub kind: FilterKind,
    /// Its numbers.
    pub tuning: Tuning,
    /// The supervisor's; default.
    pub supervisor: SupervisorSettings,
    /// How slips are taken in; default [`SlipHandling::Rebase`].
    pub slips: SlipHandling,
    /// Consecutive available telegrams a channel's innovation must sit at a multiple of
    /// the slot pitch before it counts as slipped; default 3 (a spike lasts one).
    pub slip_after: u32,
    /// How close (m) to the multiple: default 0.01, about 5σ of the innovation (the
    /// 1.5 mm noise and the prediction's own 1 mm), an eighth of the pitch.
    pub slip_tolerance: f64,
}

impl Settings {
    /// `kind` with `tuning`, the default supervisor and slip handling.
    pub fn new(kind: FilterKind, tuning: Tuning) -> Self {
        Self {
            kind,
            tuning,
            // A live position channel never repeats a reading bit for bit: a resent
            // telegram is stuck from its first repeat.
            // The FMU's: the acceleration's noise adapts upwards only (see
            // `kalfmu_fmu`'s S4 table), jumps taken.
            supervisor: SupervisorSettings {
                stuck_after: 2,
                min_process_noise_scale: 1.0,
                ..SupervisorSettings::default()
            },
            slips: SlipHandling::Rebase,
            slip_after: 3,
            slip_tolerance: 0.01,
        }
    }
}

/// The estimate after one telegram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Position of the reference point (m): the true one plus the mean installation offset.
    pub position: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// Acceleration (m/s²).
    pub acceleration: f64,
    /// Their σ.
    pub position_std: f64,
    /// See `position_std`.
    pub speed_std: f64,
    /// See `position_std`.
    pub acceleration_std: f64,
    /// Each channel's offset (m), with slips.
    pub offsets: [f64; 4],
    /// Their σ.
    pub offset_std: [f64; 4],
    /// Left out before the gate: not received (missing), or its content repeated (a
    /// resend, stuck).
    pub stale: [bool; 4],
    /// Rejected by the gate at this telegram.
    pub rejected: [bool; 4],
    /// The supervisor's fault flag: the channel's last `fault_after` telegrams were all
    /// left out (missing, stale, rejected or stuck).
    pub faulty: [bool; 4],
    /// Each channel's share in the speed's correction ([`PrwTrain::speed_weights`]) over
    /// the channels not faulty.
    pub weights: [f64; 4],
    /// The channel whose persistent failure made the supervisor re-acquire here.
    pub reacquired: Option<Channel>,
    /// The step (m) a channel's offset was re-based by here, as a slip (0: none).
    pub slip: [f64; 4],
    /// The supervisor's health: consistent and not lost.
    pub healthy: bool,
}

/// A slot slip taken in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlipEvent {
    /// The telegram at which the offset was re-based.
    pub telegram: usize,
    /// The channel.
    pub channel: Channel,
    /// The step (m): a multiple of the slot pitch.
    pub step: f64,
}

/// A run over a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The filter that ran.
    pub kind: FilterKind,
    /// One per telegram.
    pub estimates: Vec<Estimate>,
    /// Re-acquisitions per channel (the channel that triggered each).
    pub reacquisitions: [u64; 4],
    /// Slips re-based, in order.
    pub slips: Vec<SlipEvent>,
}

/// The position a run starts from without a [`Tuning::prior_position`]: the first
/// telegrams' mean reading less their levers.
pub fn first_position(recording: &Recording) -> f64 {
    Channel::ALL.iter().map(|&c| recording.position[c as usize][0] - c.lever()).sum::<f64>() / 4.0
}

/// Runs the filter of `settings` over `recording` (see the module documentation).
pub fn run(recording: &Recording, settings: &Settings) -> Result<Run, String> {
    let n = recording.n_telegrams();
    let dt = recording.telegram_interval;
    let levers = Channel::ALL.map(Channel::lever);
    let tuning = &settings.tuning;
    let model = tuning.model(levers);
    let noise = tuning.noise(&model, dt).map_err(|e| format!("setup: {e}"))?;
    let position = tuning.prior_position.unwrap_or_else(|| first_position(recording));
    let offset_variance = tuning.offset_prior_std.powi(2);
    let prior = Gaussian::diagonal(
        &[position, tuning.prior_speed, tuning.prior_acceleration, 0.0, 0.0, 0.0, 0.0],
        &[
            tuning.position_prior_std.powi(2),
            tuning.speed_prior_std.powi(2),
            tuning.acceleration_prior_std.powi(2),
            offset_variance,
            offset_variance,
            offset_variance,
            offset_variance,
        ],
    );
    let filter =
        build_filter(settings.kind, model, noise, &prior, tuning.unscented).map_err(|e| format!("setup: {e}"))?;
    let mut supervisor = Supervisor::new(settings.supervisor, PrwTrain::MARKER + 1)
        .and_then(|s| s.with_jump_states(filter.state_dim(), &PrwTrain::UNKNOWN_INPUTS))
        .map_err(|e| format!("setup: {e}"))?;
    if settings.slips == SlipHandling::Rebase {
        let steps = QuantizedSteps {
            quantum: SLOT_PITCH,
            after: settings.slip_after,
            tolerance: settings.slip_tolerance,
            bias_states: model.bias_states(),
        };
        supervisor = supervisor.with_steps(steps).map_err(|e| format!("setup: {e}"))?;
    }

    let mut supervised = SupervisedFilter::new(filter, supervisor).map_err(|e| format!("setup: {e}"))?;
    let mut out =
        Run { kind: settings.kind, estimates: Vec::with_capacity(n), reacquisitions: [0; 4], slips: Vec::new() };
    // A dropped telegram is known not to have arrived; a resent one arrives, its content
    // old: the supervisor finds it stuck (see the module documentation).
    let telegrams: Vec<[f64; 5]> = (0..n)
        .map(|k| {
            let mut z = [f64::NAN; 5];
            for (zc, (position, received)) in z.iter_mut().zip(recording.position.iter().zip(&recording.received)) {
                if received[k] {
                    *zc = position[k];
                }
            }
            z
        })
        .collect();
    let samples = telegrams.iter().enumerate().map(|(k, z)| Sample { time: k as f64 * dt, z, controls: &[] });
    let mut p = DMatrix::zeros(PrwTrain::STATES, PrwTrain::STATES);
    supervised
        .run(dt, samples, |step| {
            let (k, outcome) = (step.index, step.outcome);
            let rows: [RowOutcome; 4] = std::array::from_fn(|c| outcome.rows[c]);
            let slip: [f64; 4] = std::array::from_fn(|c| outcome.steps[c]);
            if let Some(c) = outcome.reacquired {
                out.reacquisitions[c] += 1;
            }
            for (c, &step) in slip.iter().enumerate().filter(|(_, step)| **step != 0.0) {
                out.slips.push(SlipEvent { telegram: k, channel: Channel::ALL[c], step });
            }
            let x = step.filter.mean();
            step.filter.write_covariance(&mut p);
            let std = |i: usize| p[(i, i)].max(0.0).sqrt();
            let channels = step.supervisor.channels();
            let faulty: [bool; 4] = std::array::from_fn(|c| channels[c].faulty);
            out.estimates.push(Estimate {
                position: x[PrwTrain::POSITION],
                speed: x[PrwTrain::SPEED],
                acceleration: x[PrwTrain::ACCELERATION],
                position_std: std(PrwTrain::POSITION),
                speed_std: std(PrwTrain::SPEED),
                acceleration_std: std(PrwTrain::ACCELERATION),
                offsets: std::array::from_fn(|c| x[PrwTrain::OFFSETS + c]),
                offset_std: std::array::from_fn(|c| std(PrwTrain::OFFSETS + c)),
                stale: rows.map(|r| matches!(r, RowOutcome::Missing | RowOutcome::Stuck)),
                rejected: rows.map(|r| r == RowOutcome::Rejected),
                faulty,
                weights: PrwTrain::speed_weights(&p, tuning.channel_noise_std.map(|s| s.powi(2)), faulty.map(|f| !f)),
                reacquired: outcome.reacquired.map(|c| Channel::ALL[c]),
                slip,
                healthy: step.supervisor.healthy(),
            });
        })
        .map_err(|e| e.to_string())?;
    Ok(out)
}
