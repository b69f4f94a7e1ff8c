//! A recorded run as the fit takes it, from a kalfmu MCAP log (`docs/log-format.md`):
//! the channel `/measurements` holds what the estimator was fed, one signal per FMU input
//! named as the input (`z1_ddot`, …; controls too, e.g. S5's `delta_x`), NaN where a
//! measurement is missing, stamped with the time it was set; the metadata record `kalfmu`
//! holds `parameters`, a JSON object of the FMU parameters the run set (the user's vehicle,
//! the sample time, the tuning), as `cosim::master` writes it for every study. No other
//! channel is read: tuning needs no truth.
//!
//! Which FMU a log is of: the metadata's `model_identifier` if a writer put it there,
//! else the one estimator whose every input is a signal of `/measurements`.

use std::path::Path;

use kalfmu_fmu::estimators::{self, Descriptor};
use kalfmu_fmu::variables::Role;
use log_format::read::{read_log, Run};
use log_format::write::MEASUREMENTS;

use crate::record::Record;

/// The metadata key that names the FMU, where a writer gives it.
pub const MODEL_IDENTIFIER_KEY: &str = "model_identifier";
/// The metadata key of the parameters set, a JSON object.
pub const PARAMETERS_KEY: &str = "parameters";

/// Reads the log at `path`; a log cut short is read up to the cut, with its warning.
pub fn read(path: &Path) -> Result<(Run, Vec<String>), String> {
    let run = read_log(path).map_err(|e| e.to_string())?;
    let mut warnings = run.skip_warnings();
    warnings.extend(run.recovery_warning());
    Ok((run, warnings))
}

/// The names of an estimator's inputs: the measurements by row, then the controls.
fn input_names(descriptor: &Descriptor) -> (Vec<String>, Vec<String>) {
    let name_of = |role: Role| {
        descriptor.variables.iter().find(|v| v.role == role).map(|v| v.name.to_string()).unwrap_or_default()
    };
    let measurements = (0..descriptor.measurement_dim()).map(|r| name_of(Role::Measurement(r))).collect();
    let controls = (0..descriptor.control_dim()).map(|j| name_of(Role::Control(j))).collect();
    (measurements, controls)
}

/// The model identifier of the FMU the log's measurements are for.
pub fn identify(run: &Run) -> Result<String, String> {
    if let Some(id) = run.metadata.get(MODEL_IDENTIFIER_KEY) {
        return Ok(id.clone());
    }
    let channel = run.channel(MEASUREMENTS).map_err(|e| e.to_string())?;
    let fits: Vec<&'static str> = estimators::all()
        .iter()
        .filter(|d| {
            let (m, u) = input_names(d);
            m.iter().chain(&u).all(|name| channel.signal(name).is_some())
        })
        .map(|d| d.model_identifier)
        .collect();
    match fits.as_slice() {
        [one] => Ok(one.to_string()),
        [] => Err(format!(
            "{}: the signals of {MEASUREMENTS} ({}) are the inputs of no estimator FMU; name it with --fmu",
            run.file.display(),
            channel.signals.iter().map(|s| s.spec.name.as_str()).collect::<Vec<_>>().join(", ")
        )),
        several => Err(format!(
            "{}: the measurements fit several estimator FMUs ({}); name one with --fmu",
            run.file.display(),
            several.join(", ")
        )),
    }
}

/// The FMU parameters the run set, from the metadata's `parameters` (none if it has none).
pub fn logged_parameters(run: &Run) -> Result<Vec<(String, f64)>, String> {
    let Some(text) = run.metadata.get(PARAMETERS_KEY) else { return Ok(Vec::new()) };
    let object: serde_json::Map<String, serde_json::Value> = serde_json::from_str(text)
        .map_err(|e| format!("{}: the metadata's {PARAMETERS_KEY} is not a JSON object: {e}", run.file.display()))?;
    object
        .into_iter()
        .map(|(name, value)| match value.as_f64() {
            Some(v) => Ok((name, v)),
            None => Err(format!("{}: logged parameter {name} is {value}, not a number", run.file.display())),
        })
        .collect()
}

/// The samples of the log's `/measurements` in the order of `descriptor`'s inputs.
pub fn record(run: &Run, descriptor: &Descriptor) -> Result<Record, String> {
    let channel = run.channel(MEASUREMENTS).map_err(|e| e.to_string())?;
    let (measurements, controls) = input_names(descriptor);
    let column = |name: &String| {
        channel.signal(name).map(|s| s.values.as_slice()).ok_or_else(|| {
            format!(
                "{}: {MEASUREMENTS} has no signal {name}, an input of {}",
                run.file.display(),
                descriptor.model_identifier
            )
        })
    };
    let z: Vec<&[f64]> = measurements.iter().map(column).collect::<Result<_, _>>()?;
    let u: Vec<&[f64]> = controls.iter().map(column).collect::<Result<_, _>>()?;
    let mut record = Record::new(z.len(), u.len());
    let (mut zk, mut uk) = (vec![0.0; z.len()], vec![0.0; u.len()]);
    for (k, &t) in channel.time.iter().enumerate() {
        for (v, c) in zk.iter_mut().zip(&z) {
            *v = c[k];
        }
        for (v, c) in uk.iter_mut().zip(&u) {
            *v = c[k];
        }
        record.push(t, &zk, &uk).map_err(|e| format!("{}: {e}", run.file.display()))?;
    }
    Ok(record)
}
