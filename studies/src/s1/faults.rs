//! Study S1 with gross measurement errors: the noisy accelerations of a case
//! with one fault injected, every filter of the library behind the
//! supervisor (`estimator::Supervisor`: gate, fault flags, re-acquisition,
//! consistency), and what an engineer asks of it: how often it rejects good
//! data, how soon it flags the fault, how far the load estimate strays (in
//! its own σ), and how soon it follows a true jump of the load.
//!
//! The faults start at [`FAULT_START`]; `rms` is the channel's RMS over the
//! run. Saturation, sticking and drift hit `z1_ddot`, where the other channel
//! (`z2_ddot`, which reads `F/m₂` almost directly) keeps the load observable;
//! the same faults on `z2_ddot` make a sensor error and a load change
//! indistinguishable for a while, so they are the `… z2` rows.
//!
//! | fault | what |
//! |---|---|
//! | healthy | none: the false-alarm reference |
//! | spikes | single samples of ±100·rms, every 5 s on `z2_ddot`, 2.5 s later on `z1_ddot` |
//! | saturation | `z1_ddot` clipped at ±3·rms over the whole run |
//! | stuck | `z1_ddot` holds its value for 5 s |
//! | drift | `z1_ddot` offset growing by 1·rms per second for 10 s, then gone |
//! | stuck z2, drift z2 | the same on `z2_ddot` |
//! | dropout | `z2_ddot` missing (NaN) for 1 s, 10 s later both channels for 0.5 s |
//! | burst | ten samples (50 ms) of ±100·rms, alternating, on `z1_ddot`: long enough to re-acquire |
//! | burst z2 | the same ten samples on `z2_ddot` |
//! | load step | no sensor fault: the true load steps by 10× its RMS (100 N) |

use std::fmt;

use analyzer::metrics::correlation;
use estimator::models::Oscillator2DofLoad;
use estimator::{FilterKind, RowOutcome, Sample, SupervisedFilter, Supervisor, SupervisorSettings};

use start_values::{SetByName, StartValues};

use super::Tuning;
use truth::s1::load::Step;
use truth::s1::plant::Truth;
use truth::s1::{simulate_with, Case, Measurements, Settings};

/// When the faults start (s).
pub const FAULT_START: f64 = 20.0;

/// The length of a burst (samples): the default `reacquire_after` is 10.
pub const BURST_SAMPLES: usize = 10;

/// One injected fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// None.
    Healthy,
    /// Single samples of 100× the channel RMS.
    Spikes,
    /// Clipped at 3× the channel RMS.
    Saturation,
    /// The channel holds one value.
    Stuck,
    /// A growing offset.
    Drift,
    /// The load channel holds one value.
    StuckLoadChannel,
    /// A growing offset on the load channel.
    DriftLoadChannel,
    /// Missing samples.
    Dropout,
    /// A burst of gross errors of alternating sign.
    Burst,
    /// The same burst on the load channel.
    BurstLoadChannel,
    /// A true step of the load (no sensor fault).
    LoadStep,
}

impl Fault {
    /// Every fault, in the table's order.
    pub const ALL: [Fault; 11] = [
        Fault::Healthy,
        Fault::Spikes,
        Fault::Saturation,
        Fault::Stuck,
        Fault::Drift,
        Fault::StuckLoadChannel,
        Fault::DriftLoadChannel,
        Fault::Dropout,
        Fault::Burst,
        Fault::BurstLoadChannel,
        Fault::LoadStep,
    ];
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Fault::Healthy => "healthy",
            Fault::Spikes => "spikes",
            Fault::Saturation => "saturation",
            Fault::Stuck => "stuck",
            Fault::Drift => "drift",
            Fault::StuckLoadChannel => "stuck z2",
            Fault::DriftLoadChannel => "drift z2",
            Fault::Dropout => "dropout",
            Fault::Burst => "burst",
            Fault::BurstLoadChannel => "burst z2",
            Fault::LoadStep => "load step",
        })
    }
}

/// A case with a fault injected.
pub struct Injected {
    /// The fault.
    pub fault: Fault,
    /// The truth (with the load step, for [`Fault::LoadStep`]).
    pub truth: Truth,
    /// The measurements the estimator sees.
    pub measurements: Measurements,
    /// Per sample and channel: the value is corrupted (differs from the healthy sensor's).
    pub corrupted: Vec<[bool; 2]>,
}

/// Simulates `case` and injects `fault` (see the module documentation).
pub fn inject(fault: Fault, case: &Case, settings: &Settings) -> Injected {
    let mut load = truth::s1::load(case, settings);
    if fault == Fault::LoadStep {
        load = load.with_step(Step { at: FAULT_START, size: 10.0 * settings.load_rms });
    }
    let dt = settings.dt();
    let (truth, mut measurements) = simulate_with(case, settings, &load);
    let n = truth.time.len();
    let rms = truth.acceleration_rms();
    let start = (FAULT_START / dt).round() as usize;
    let samples = |seconds: f64| (seconds / dt).round() as usize;
    let z = &mut measurements.acceleration;
    let mut corrupted = vec![[false; 2]; n];
    let mut set = |k: usize, c: usize, value: f64, z: &mut Vec<[f64; 2]>| {
        if k < n {
            z[k][c] = value;
            corrupted[k][c] = true;
        }
    };
    match fault {
        Fault::Healthy | Fault::LoadStep => {}
        Fault::Spikes => {
            for (j, k) in (start..n).step_by(samples(5.0)).enumerate() {
                let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
                let (a, b) = (z[k][1] + sign * 100.0 * rms[1], k + samples(2.5));
                set(k, 1, a, z);
                if b < n {
                    let v = z[b][0] - sign * 100.0 * rms[0];
                    set(b, 0, v, z);
                }
            }
        }
        Fault::Saturation => {
            for k in 0..n {
                let limit = 3.0 * rms[0];
                if z[k][0].abs() > limit {
                    let v = z[k][0].clamp(-limit, limit);
                    set(k, 0, v, z);
                }
            }
        }
        Fault::Stuck | Fault::StuckLoadChannel => {
            let c = usize::from(fault == Fault::StuckLoadChannel);
            if let Some(&held) = z.get(start).map(|row| &row[c]) {
                for k in start + 1..(start + samples(5.0)).min(n) {
                    set(k, c, held, z);
                }
            }
        }
        Fault::Drift | Fault::DriftLoadChannel => {
            let c = usize::from(fault == Fault::DriftLoadChannel);
            for k in start + 1..(start + samples(10.0)).min(n) {
                let v = z[k][c] + rms[c] * (k - start) as f64 * dt;
                set(k, c, v, z);
            }
        }
        Fault::Burst | Fault::BurstLoadChannel => {
            let c = usize::from(fault == Fault::BurstLoadChannel);
            for (j, k) in (start..start + BURST_SAMPLES).enumerate() {
                let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
                let v = z[k][c] + sign * 100.0 * rms[c];
                set(k, c, v, z);
            }
        }
        Fault::Dropout => {
            for k in start..start + samples(1.0) {
                set(k, 1, f64::NAN, z);
            }
            for k in start + samples(10.0)..start + samples(10.5) {
                set(k, 0, f64::NAN, z);
                set(k, 1, f64::NAN, z);
            }
        }
    }
    Injected { fault, truth, measurements, corrupted }
}

/// What one filter made of one injected fault.
#[derive(Debug, Clone)]
pub struct FaultRun {
    /// The filter.
    pub kind: FilterKind,
    /// The fault.
    pub fault: Fault,
    /// Rows rejected although not corrupted.
    pub false_rejections: u64,
    /// Good rows offered (finite and not corrupted).
    pub good_rows: u64,
    /// Corrupted, finite rows rejected / offered.
    pub corrupted_rejected: (u64, u64),
    /// Samples from the first corrupted sample to the first flag on its
    /// channel (rejected, or faulty when missing); `None` without corruption.
    pub detection_delay: Option<usize>,
    /// Samples during which a fault flag was raised on a channel that was not corrupted then.
    pub false_fault_samples: u64,
    /// Samples with the filter unhealthy (inconsistent or lost).
    pub unhealthy_samples: u64,
    /// The largest `|F̂ − F| / σ` after the first second.
    pub max_error_sigmas: f64,
    /// Correlation of `F̂` with `F` after the first second.
    pub correlation: f64,
    /// For the load step: seconds from the step until the error stays within
    /// 3σ for 0.5 s; for a burst, from its last sample.
    pub recovery: Option<f64>,
    /// For a burst: the largest `|F̂ − F|` from 0.5 s after it to the end,
    /// over the RMS error of the 10 s before it (N/N).
    pub error_after_recovery: Option<f64>,
    /// Re-acquisitions.
    pub reacquisitions: u64,
    /// Of those, the ones their rival's evidence undid.
    pub undone: u64,
    /// Why the filter stopped, if it did.
    pub failure: Option<String>,
}

/// Runs `kind` behind the supervisor over an injected case, with the study's tuning.
pub fn run(
    kind: FilterKind,
    injected: &Injected,
    case: &Case,
    settings: &Settings,
    supervision: SupervisorSettings,
) -> FaultRun {
    run_with(kind, injected, case, settings, supervision, &StartValues::none())
}

/// [`run`] with `start_values` over the study's tuning (every name one [`Tuning::set`]
/// takes; a refused one is the run's setup failure).
pub fn run_with(
    kind: FilterKind,
    injected: &Injected,
    case: &Case,
    settings: &Settings,
    supervision: SupervisorSettings,
    start_values: &StartValues,
) -> FaultRun {
    let Injected { fault, truth, measurements, corrupted } = injected;
    let mut run = FaultRun {
        kind,
        fault: *fault,
        false_rejections: 0,
        good_rows: 0,
        corrupted_rejected: (0, 0),
        detection_delay: None,
        false_fault_samples: 0,
        unhealthy_samples: 0,
        max_error_sigmas: 0.0,
        correlation: f64::NAN,
        recovery: None,
        error_after_recovery: None,
        reacquisitions: 0,
        undone: 0,
        failure: None,
    };
    let mut tuning = Tuning::new(settings, measurements.noise_std);
    let built = tuning.set_all(start_values).and_then(|()| {
        let filter = tuning.filter(kind, case, tuning.noise()).map_err(|e| e.to_string())?;
        let n = filter.state_dim();
        let supervisor = Supervisor::new(supervision, 2)
            .and_then(|s| s.with_jump_states(n, &Oscillator2DofLoad::UNKNOWN_INPUTS))
            .map_err(|e| e.to_string())?;
        SupervisedFilter::new(filter, supervisor).map_err(|e| e.to_string())
    });
    let mut supervised = match built {
        Ok(supervised) => supervised,
        Err(e) => {
            run.failure = Some(format!("setup: {e}"));
            return run;
        }
    };
    let dt = settings.dt();
    let first_corrupted = corrupted.iter().position(|c| c[0] || c[1]);
    let (mut estimate, mut sigma) = (Vec::with_capacity(truth.time.len()), Vec::with_capacity(truth.time.len()));
    let samples = measurements.acceleration.iter().zip(&truth.time).map(|(z, &time)| Sample { time, z, controls: &[] });
    let looped = supervised.run(dt, samples, |step| {
        let k = step.index;
        let z = step.sample.z;
        for c in 0..2 {
            // A jump the review retracted: the previous sample's row was rejected, one sample late.
            if step.outcome.retracted[c] && k > 0 {
                if corrupted[k - 1][c] {
                    run.corrupted_rejected.0 += 1;
                    if run.detection_delay.is_none() {
                        run.detection_delay = first_corrupted.map(|f| k - f);
                    }
                } else {
                    run.false_rejections += 1;
                }
            }
            let (finite, bad) = (z[c].is_finite(), corrupted[k][c]);
            let left_out = matches!(step.outcome.rows[c], RowOutcome::Rejected | RowOutcome::Stuck);
            let flagged = left_out || step.supervisor.channels()[c].faulty;
            match (finite, bad, left_out) {
                (true, false, rejected) => {
                    run.good_rows += 1;
                    run.false_rejections += u64::from(rejected);
                }
                (true, true, rejected) => {
                    run.corrupted_rejected.0 += u64::from(rejected);
                    run.corrupted_rejected.1 += 1;
                }
                _ => {}
            }
            if bad && flagged && run.detection_delay.is_none() {
                run.detection_delay = first_corrupted.map(|f| k - f);
            }
            let recently_bad = (k.saturating_sub(supervision.fault_after as usize)..=k)
                .any(|j| corrupted[j][c] || !measurements.acceleration[j][c].is_finite());
            if step.supervisor.channels()[c].faulty && !recently_bad {
                run.false_fault_samples += 1;
            }
        }
        run.unhealthy_samples += u64::from(!step.supervisor.healthy());
        estimate.push(step.filter.mean()[Oscillator2DofLoad::LOAD]);
        sigma.push(step.filter.variance(Oscillator2DofLoad::LOAD).max(0.0).sqrt());
    });
    if let Err(e) = looped {
        run.failure = Some(e.to_string());
        return run;
    }
    run.reacquisitions = supervised.supervisor().reacquisitions();
    run.undone = supervised.supervisor().undone_reacquisitions();
    let after = (1.0 / dt).round() as usize;
    let errors: Vec<f64> = estimate.iter().zip(&truth.load).map(|(e, t)| e - t).collect();
    run.max_error_sigmas = errors[after..].iter().zip(&sigma[after..]).map(|(e, s)| e.abs() / s).fold(0.0, f64::max);
    run.correlation = correlation(&estimate[after..], &truth.load[after..]);
    let step = (FAULT_START / dt).round() as usize;
    let hold = (0.5 / dt).round() as usize;
    let from = match fault {
        Fault::LoadStep => Some(step),
        Fault::Burst | Fault::BurstLoadChannel => Some(step + BURST_SAMPLES - 1),
        _ => None,
    };
    if let Some(from) = from {
        let within = |k: usize| errors[k].abs() <= 3.0 * sigma[k];
        run.recovery = (from..errors.len().saturating_sub(hold))
            .find(|&k| (k..k + hold).all(within))
            .map(|k| (k - from) as f64 * dt);
    }
    if matches!(fault, Fault::Burst | Fault::BurstLoadChannel) {
        let before = &errors[step.saturating_sub(10 * (1.0 / dt).round() as usize)..step];
        let clean_rmse = (before.iter().map(|e| e * e).sum::<f64>() / before.len() as f64).sqrt();
        let worst = errors[step + BURST_SAMPLES + hold..].iter().fold(0.0_f64, |w, e| w.max(e.abs()));
        run.error_after_recovery = Some(worst / clean_rmse);
    }
    run
}
