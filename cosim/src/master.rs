//! One estimator FMU driven over a run as a co-simulation master drives it, and logged:
//! at each sample instant `t` the plant's measurements of `t` are set as the FMU's inputs,
//! the outputs are read (the estimate at `t` given the measurements up to `t`, by direct
//! feedthrough), `fmi2DoStep(t, dt)` is called, and the outputs are read again (the
//! estimate at `t + dt` predicted from the measurements up to `t`). The log is the kalfmu
//! MCAP format (`docs/log-format.md`): the measurements, the truth, both readings
//! (`/estimate`, `/prediction`), the fixed-lag smoothed outputs when the study asks for
//! them (`/smoothed`), and the run's metadata with the parameters set. Each
//! study says what its FMU is given and what its truth is; the protocol is here, once.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{bail, Context};
use estimator::FilterKind;
use log_format::write::{ChannelId, LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, PREDICTION, SMOOTHED, TRUTH};

use start_values::StartValues;

use crate::fmu_driver::{filter_enumeration, ImportedFmu, Instance};

/// What a study gives the FMU and logs beside it.
pub struct Setup<'a> {
    /// The FMU.
    pub fmu: &'a ImportedFmu,
    /// The filter inside it.
    pub filter: FilterKind,
    /// Real parameters, by name.
    pub parameters: &'a [(&'static str, f64)],
    /// The Integer parameters it is set, the filter aside.
    pub integers: &'a [(&'static str, i32)],
    /// The user's start values, set over the study's parameters (`--set`, `--values`).
    pub start_values: &'a StartValues,
    /// The inputs, in the order of the measurement vectors, with their descriptions.
    pub inputs: &'a [(&'static str, &'static str)],
    /// The Real outputs logged on `/estimate` and `/prediction`.
    pub outputs: &'a [&'static str],
    /// The outputs whose fixed-lag smoothed values (`<name>_smoothed`, `_smoothed_std`,
    /// with `smoothing_lag` among the parameters) are logged on `/smoothed` as `<name>`
    /// and `<name>_std`, each stamped with the `smoothed_time` it describes.
    pub smoothed: &'a [&'static str],
    /// The truth's signals (those named as an output are compared with it).
    pub truth: &'a [SignalSpec],
    /// The study's metadata (study, case, seed, …); the filter, the parameters and the
    /// software are added.
    pub metadata: BTreeMap<String, String>,
}

/// What the FMU counted over a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Measurement rows left out as missing.
    pub skipped: i32,
    /// Measurement rows rejected by the innovation gate.
    pub rejected: i32,
}

/// Drives the FMU over the sample instants `times`, `dt` apart (the study's sample time, as
/// the FMU has it: a step computed from the times could miss its grid by a rounding), and
/// writes the log to `log`: `measured(k)` are the inputs of instant `k`, `truth(k)` the
/// truth there; `progress(k)` is called after each instant.
pub fn run(
    setup: &Setup<'_>,
    times: &[f64],
    dt: f64,
    measured: impl Fn(usize) -> Vec<f64>,
    truth: impl Fn(usize) -> Vec<f64>,
    log: &Path,
    mut progress: impl FnMut(usize),
) -> anyhow::Result<Counts> {
    let Setup { fmu, filter, parameters, integers, start_values, inputs, outputs, smoothed, .. } = *setup;
    let (first, last) = (times[0], times[times.len() - 1]);
    let study = setup.metadata.get("study").cloned().unwrap_or_default();
    let case = setup.metadata.get("case").cloned().unwrap_or_default();
    fmu.check_start_values(start_values)?;
    let input_vrs: Vec<u32> = inputs.iter().map(|(n, _)| fmu.vr(n)).collect::<anyhow::Result<_>>()?;
    let output_vrs: Vec<u32> = outputs.iter().map(|n| fmu.vr(n)).collect::<anyhow::Result<_>>()?;
    // The plant's outputs at the start, set in initialisation mode too, as masters that
    // propagate initial values do (fmpy, OMSimulator): the FMU's input_timing_check
    // then sees the ordering.
    let mut instance = fmu.instantiate(
        &format!("{study}-{case}-{filter}"),
        first,
        last,
        parameters,
        &[&[("filter", filter_enumeration(filter))], integers].concat(),
        start_values,
        (&input_vrs, &measured(0)),
    )?;
    let counters = [fmu.vr("skipped_measurements")?, fmu.vr("rejected_measurements")?];

    let mut metadata = setup.metadata.clone();
    // The values in force: the study's, then the user's over them.
    let parameters_json = start_values.over(parameters).into_iter().collect::<BTreeMap<_, _>>();
    metadata.insert("filter".into(), filter.name().into());
    metadata.insert("parameters".into(), serde_json::to_string(&parameters_json)?);
    metadata.insert("software".into(), format!("kalfmu {}", env!("CARGO_PKG_VERSION")));
    let mut w = LogWriter::create(log, &metadata)?;
    let unit = |n: &str| fmu.unit(n);
    let measured_specs: Vec<SignalSpec> = inputs.iter().map(|(n, what)| SignalSpec::new(n, &unit(n), what)).collect();
    let ch_m = w.add_channel(MEASUREMENTS, &measured_specs)?;
    let ch_t = w.add_channel(TRUTH, setup.truth)?;
    let specs =
        |what: &str| -> Vec<SignalSpec> { outputs.iter().map(|n| SignalSpec::new(n, &unit(n), what)).collect() };
    let ch_e = w.add_channel(ESTIMATE, &specs("FMU output read at t after the inputs of t were set"))?;
    let ch_p = w.add_channel(PREDICTION, &specs("FMU output read right after fmi2DoStep(t - dt, dt)"))?;
    let mut lagged = Lagged::new(fmu, smoothed, &mut w)?;

    let mut out = vec![0.0; outputs.len()];
    for (k, &t) in times.iter().enumerate() {
        let z = measured(k);
        let context = || format!("{study} {case} {filter} at t = {t} s");
        instance.set_inputs(&input_vrs, &z).with_context(context)?;
        instance.read(&output_vrs, &mut out).with_context(context)?;
        w.write(ch_m, t, &z)?;
        w.write(ch_t, t, &truth(k))?;
        w.write(ch_e, t, &out)?;
        if let Some(lagged) = lagged.as_mut() {
            lagged.log(&mut instance, &mut w).with_context(context)?;
        }
        if k + 1 < times.len() {
            instance.do_step(dt).with_context(context)?;
            instance.read(&output_vrs, &mut out).with_context(context)?;
            w.write(ch_p, times[k + 1], &out)?;
        }
        progress(k);
    }
    let mut counts = [0; 2];
    instance.read_integers(&counters, &mut counts)?;
    // This master hands over the plant's outputs of t before fmi2DoStep(t, h) (Jacobi);
    // an FMU that read the calls otherwise would have estimated the wrong instants.
    let mut check = [0];
    instance.read_integers(&[fmu.vr("input_timing_check")?], &mut check)?;
    instance.terminate()?;
    if let Some(lagged) = lagged.as_mut() {
        lagged.flush(&mut w)?;
    }
    w.finish()?;
    if check[0] == 2 {
        bail!("{study} {case} {filter}: the FMU's input_timing_check says this master's ordering fits the other input_timing");
    }
    Ok(Counts { skipped: counts[0], rejected: counts[1] })
}

/// The fixed-lag smoothed outputs a run logs on `/smoothed`.
struct Lagged {
    channel: ChannelId,
    /// `<name>_smoothed` and `<name>_smoothed_std` of each name, then `smoothed_time`.
    vrs: Vec<u32>,
    values: Vec<f64>,
    /// The latest values read of the newest smoothed time, not yet logged (the smoothed
    /// time then last entry): until the lag has passed the smoothed time stands at the
    /// start, and each read smooths it with more measurements; its last read is logged.
    pending: Option<Vec<f64>>,
}

impl Lagged {
    fn new(fmu: &ImportedFmu, names: &[&str], w: &mut LogWriter) -> anyhow::Result<Option<Self>> {
        if names.is_empty() {
            return Ok(None);
        }
        let mut vrs = Vec::new();
        let mut specs = Vec::new();
        for name in names {
            vrs.push(fmu.vr(&format!("{name}_smoothed"))?);
            specs.push(SignalSpec::new(
                name,
                &fmu.unit(name),
                "FMU fixed-lag smoothed output, stamped with smoothed_time",
            ));
        }
        for name in names {
            vrs.push(fmu.vr(&format!("{name}_smoothed_std"))?);
            specs.push(SignalSpec::new(
                &format!("{name}_std"),
                &fmu.unit(name),
                "standard deviation of the smoothed output",
            ));
        }
        vrs.push(fmu.vr("smoothed_time")?);
        let channel = w.add_channel(SMOOTHED, &specs)?;
        Ok(Some(Self { channel, values: vec![0.0; vrs.len()], vrs, pending: None }))
    }

    /// Reads the smoothed outputs; logs those of the smoothed time before when the
    /// smoothed time has moved on: each smoothed time once, as last read.
    fn log(&mut self, instance: &mut Instance, w: &mut LogWriter) -> anyhow::Result<()> {
        instance.read(&self.vrs, &mut self.values)?;
        let time = self.values[self.values.len() - 1];
        match &mut self.pending {
            Some(pending) if pending[pending.len() - 1] == time => pending.copy_from_slice(&self.values),
            _ => {
                self.flush(w)?;
                self.pending = Some(self.values.clone());
            }
        }
        Ok(())
    }

    /// Logs the values of the newest smoothed time (at the end of the run).
    fn flush(&mut self, w: &mut LogWriter) -> anyhow::Result<()> {
        if let Some(pending) = self.pending.take() {
            let (time, values) = pending.split_last().expect("smoothed_time is read");
            w.write(self.channel, *time, values)?;
        }
        Ok(())
    }
}
