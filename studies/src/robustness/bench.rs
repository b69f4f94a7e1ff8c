//! One estimator FMU on its study's truth, driven through the C ABI (the `fmi`
//! importer) as a master drives it, with and without a fault episode, and
//! what an engineer asks of the pair: how soon the estimate is back, how far
//! off it is after, whether the flags and `filter_healthy` told the truth.

use cosim::fmu_driver::ImportedFmu;
use start_values::StartValues;

use super::episode::Episode;

/// An estimator FMU and the data of its study.
pub struct Bench {
    /// The study, as the table names it.
    pub study: &'static str,
    /// The FMU's model identifier.
    pub identifier: &'static str,
    /// The measurement inputs, in the order of the rows of `z`.
    pub inputs: Vec<&'static str>,
    /// The control inputs, in the order of the rows of `u` (none: empty).
    pub controls: Vec<&'static str>,
    /// The sample time (s).
    pub dt: f64,
    /// The measurements, per sample.
    pub z: Vec<Vec<f64>>,
    /// The controls, per sample (none: empty).
    pub u: Vec<Vec<f64>>,
    /// The estimates scored (each has a `<name>_std` output).
    pub targets: Vec<&'static str>,
    /// Their truth, per sample.
    pub truth: Vec<Vec<f64>>,
    /// The FMU's Real parameters (the study's set-up).
    pub parameters: Vec<(&'static str, f64)>,
    /// Its Integer parameters.
    pub integers: Vec<(&'static str, i32)>,
    /// The recovery time this FMU is held to (s): 2 s, 0.5 s for S2 and S3.
    pub bound: f64,
    /// The user's start values over the study's (`--set`, `--values`).
    pub start_values: StartValues,
}

/// What the FMU showed at each sample of a run (read after the inputs of the sample).
pub struct Trace {
    /// The scored estimates.
    pub estimate: Vec<Vec<f64>>,
    /// Their σ.
    pub std: Vec<Vec<f64>>,
    /// `filter_healthy`.
    pub healthy: Vec<bool>,
    /// `<input>_fault`, per input.
    pub faulty: Vec<Vec<bool>>,
    /// `<input>_status`, per input (the FMU's `InputStatus`: 5 is inconsistent).
    pub status: Vec<Vec<i32>>,
    /// Steps the FMU answered with fmi2Warning (a lost filter).
    pub warnings: usize,
    /// The step the FMU refused (fmi2Discard: its filter failed), which ends the run.
    pub failure: Option<String>,
}

impl Bench {
    /// The RMS of each measurement channel (finite samples).
    pub fn rms(&self) -> Vec<f64> {
        (0..self.inputs.len())
            .map(|c| {
                let (sum, n) = self
                    .z
                    .iter()
                    .filter(|row| row[c].is_finite())
                    .fold((0.0, 0usize), |(s, n), row| (s + row[c] * row[c], n + 1));
                (sum / n.max(1) as f64).sqrt()
            })
            .collect()
    }

    /// Runs the FMU over the first `samples` of `z` (the bench's own when `None`).
    pub fn drive(&self, fmu: &ImportedFmu, z: Option<&[Vec<f64>]>, samples: usize) -> anyhow::Result<Trace> {
        let z = z.unwrap_or(&self.z);
        let samples = samples.min(z.len());
        let names: Vec<&str> = self.inputs.iter().chain(&self.controls).copied().collect();
        let input_vrs: Vec<u32> = names.iter().map(|n| fmu.vr(n)).collect::<anyhow::Result<_>>()?;
        let target_vrs: Vec<u32> = self
            .targets
            .iter()
            .flat_map(|n| [fmu.vr(n), fmu.vr(&format!("{n}_std"))])
            .collect::<anyhow::Result<_>>()?;
        let fault_vrs: Vec<u32> =
            self.inputs.iter().map(|n| fmu.vr(&format!("{n}_fault"))).collect::<anyhow::Result<_>>()?;
        let status_vrs: Vec<u32> =
            self.inputs.iter().map(|n| fmu.vr(&format!("{n}_status"))).collect::<anyhow::Result<_>>()?;
        let healthy_vr = [fmu.vr("filter_healthy")?];
        let row = |k: usize| -> Vec<f64> { z[k].iter().chain(self.u.get(k).into_iter().flatten()).copied().collect() };
        let end = (samples.max(1) - 1) as f64 * self.dt;
        let mut instance = fmu.instantiate(
            self.identifier,
            0.0,
            end,
            &self.parameters,
            &self.integers,
            &self.start_values,
            (&input_vrs, &row(0)),
        )?;
        let n = self.targets.len();
        let mut trace = Trace {
            estimate: Vec::with_capacity(samples),
            std: Vec::with_capacity(samples),
            healthy: Vec::with_capacity(samples),
            faulty: Vec::with_capacity(samples),
            status: Vec::with_capacity(samples),
            warnings: 0,
            failure: None,
        };
        let m = self.inputs.len();
        let (mut values, mut flags, mut status, mut healthy) = (vec![0.0; 2 * n], vec![0; m], vec![0; m], [0]);
        for k in 0..samples {
            instance.set_inputs(&input_vrs, &row(k))?;
            instance.read_as_is(&target_vrs, &mut values)?;
            instance.read_booleans(&fault_vrs, &mut flags)?;
            instance.read_integers(&status_vrs, &mut status)?;
            instance.read_booleans(&healthy_vr, &mut healthy)?;
            trace.status.push(status.clone());
            trace.estimate.push(values.iter().step_by(2).copied().collect());
            trace.std.push(values.iter().skip(1).step_by(2).copied().collect());
            trace.faulty.push(flags.iter().map(|&f| f != 0).collect());
            trace.healthy.push(healthy[0] != 0);
            if k + 1 < samples {
                match instance.do_step(self.dt) {
                    Ok(warned) => trace.warnings += usize::from(warned),
                    Err(e) => {
                        trace.failure = Some(e.to_string());
                        return Ok(trace);
                    }
                }
            }
        }
        instance.terminate()?;
        Ok(trace)
    }
}

/// What one episode did, against the clean run.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// From the episode's end until every later 0.1 s window's error stays
    /// within 2× the clean run's (s); `None`: not within the horizon.
    pub recovery: Option<f64>,
    /// The largest error from the recovery to the horizon, in the clean run's RMS errors.
    pub error_after: f64,
    /// Samples with a fault flag on an input none of whose last three samples was corrupted.
    pub false_flags: usize,
    /// Samples (from the episode's start to the horizon) where `filter_healthy`
    /// disagrees with the error (healthy while the estimates are beyond 3σ on average, or not healthy within it).
    pub disagreements: usize,
    /// Those samples.
    pub judged: usize,
    /// Steps answered with fmi2Warning.
    pub warnings: usize,
    /// The FMU refused a step (its filter failed): the run ended there.
    pub failed: bool,
}

/// Each sample's error over the scored estimates: the RMS over the targets
/// of the error in units of that target's clean RMS error `scale`.
fn errors(trace: &Trace, truth: &[Vec<f64>], scale: &[f64]) -> Vec<f64> {
    trace
        .estimate
        .iter()
        .zip(truth)
        .map(|(e, t)| {
            let sum: f64 = e.iter().zip(t).zip(scale).map(|((e, t), s)| ((e - t) / s).powi(2)).sum();
            let e = (sum / scale.len() as f64).sqrt();
            if e.is_nan() {
                f64::INFINITY
            } else {
                e
            }
        })
        .collect()
}

/// Each target's RMS error over the clean run from `from` on.
pub fn clean_scale(clean: &Trace, truth: &[Vec<f64>], from: usize) -> Vec<f64> {
    let n = truth[0].len();
    (0..n)
        .map(|j| {
            let rows = clean.estimate[from..].iter().zip(&truth[from..]);
            let (sum, count) = rows.fold((0.0, 0usize), |(s, c), (e, t)| (s + (e[j] - t[j]).powi(2), c + 1));
            (sum / count.max(1) as f64).sqrt().max(f64::MIN_POSITIVE)
        })
        .collect()
}

/// Judges `faulty` against `clean` for `episode`, up to `horizon` (exclusive), with 0.1 s windows of `window` samples.
pub fn judge(
    bench: &Bench,
    clean: &Trace,
    faulty: &Trace,
    episode: &Episode,
    scale: &[f64],
    window: usize,
    horizon: usize,
) -> Verdict {
    let failed = faulty.failure.is_some() && faulty.estimate.len() < horizon;
    let horizon = horizon.min(faulty.estimate.len());
    let (e_clean, e_fault) = (errors(clean, &bench.truth, scale), errors(faulty, &bench.truth, scale));
    let rms = |e: &[f64]| (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt();
    let end = episode.end().min(horizon);
    let windows: Vec<usize> = (end..horizon.saturating_sub(window)).step_by(window.max(1) / 2 + 1).collect();
    let bad = |k: usize| rms(&e_fault[k..k + window]) > 2.0 * rms(&e_clean[k..k + window]).max(1.0);
    let last_bad = windows.iter().rev().find(|&&k| bad(k));
    let recovered_at = match (failed, last_bad) {
        (true, _) => None,
        (false, None) => Some(end),
        (false, Some(&k)) => (k + window < horizon.saturating_sub(window)).then_some(k + window),
    };
    let recovery = recovered_at.map(|k| (k - end) as f64 * bench.dt);
    let error_after = recovered_at.map_or(f64::INFINITY, |k| e_fault[k..horizon].iter().copied().fold(0.0, f64::max));
    let corrupted =
        |k: usize, c: usize| episode.channels.contains(&c) && (episode.start..episode.end() + 3).contains(&k);
    let false_flags =
        (0..horizon).filter(|&k| (0..bench.inputs.len()).any(|c| faulty.faulty[k][c] && !corrupted(k, c))).count();
    let mut disagreements = 0;
    for k in episode.start..horizon {
        let mean_square: f64 = faulty.estimate[k]
            .iter()
            .zip(&bench.truth[k])
            .zip(&faulty.std[k])
            .map(|((e, t), s)| ((e - t) / s).powi(2))
            .sum::<f64>()
            / scale.len() as f64;
        let admitted = mean_square <= 9.0;
        disagreements += usize::from(faulty.healthy[k] != admitted);
    }
    Verdict {
        recovery,
        error_after,
        false_flags,
        disagreements,
        judged: horizon.saturating_sub(episode.start),
        warnings: faulty.warnings,
        failed,
    }
}
