//! A log's measurements run offline through an estimator FMU's whole loop, with the
//! estimates given the whole log written as a topic of their own: the offline review of a
//! recorded run.
//!
//! The estimator runs as an FMU instance runs it (`kalfmu_fmu::estimating`: its filter
//! behind its supervisor — gate, fault flags, jumps, adaptation — with the parameters the
//! command was given or fitted), at the log's sample times on the FMU's grid (an instant of
//! the grid without a sample is a prediction only), keeping each prediction's transition.
//! The backward pass (`estimator::smoothing::fixed_interval`, the RTS form of the filter's
//! own point rule, a rejected row staying rejected) then gives each sample's estimate given
//! every sample of the log. The log written has the input log's channels (its `/truth` and
//! `/measurements` as they were; an earlier run's `/estimate`, `/prediction` and
//! `/smoothed` are left out, being another run's) and, at each sample:
//!
//! - `/estimate`: the filtered estimate of each of the FMU's state outputs, `<name>`, with
//!   its standard deviation `<name>_std`, as the FMU outputs them at that sample;
//! - `/smoothed`: the smoothed estimates of the same, under the same names.
//!
//! `analyzer report OUT.mcap --estimate-topic /estimate --estimate-topic /smoothed` then
//! compares the two against the truth, where the log has one.

use std::collections::BTreeMap;
use std::path::Path;

use estimator::{FilterKind, RunRecorder};
use kalfmu_fmu::variables::Role;
use log_format::read::{Channel, Run, Signal};
use log_format::write::{write_channels, SignalSpec, ESTIMATE, PREDICTION, SMOOTHED};

use crate::fmu_estimator::FmuEstimator;
use crate::record::Record;

/// What the run over the log counted.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// Samples written to each of `/estimate` and `/smoothed`.
    pub samples: usize,
    /// Measurement rows the gate rejected.
    pub rejected_rows: u64,
    /// Measurement rows missing (non-finite) in the log.
    pub missing_rows: u64,
}

/// The metadata key that says how the log's `/smoothed` was made.
pub const SMOOTHING_KEY: &str = "smoothing";

/// Runs `estimator` with the fitted parameters at `fitted` over `record` (the samples of
/// `run`), smooths the run, and writes `run` with `/estimate` and `/smoothed` to `path`.
pub fn write(
    run: &Run,
    record: &Record,
    estimator: &FmuEstimator,
    fitted: &[f64],
    path: &Path,
) -> Result<Written, String> {
    let times = record.times();
    let &start = times.first().ok_or("the log has no sample to smooth")?;
    let dt = estimator.value("sample_time")?;
    let kind: FilterKind = estimator.filter()?;
    let mut supervised = estimator.supervised(fitted, start)?;
    supervised.keep_transitions();
    let states = state_outputs(estimator);
    let mut recorder = RunRecorder::new();
    // The recorder's instant of each sample (grid instants without a sample are in between).
    let mut instant_of_sample = Vec::with_capacity(record.len());
    let mut filtered: Vec<Vec<f64>> = vec![Vec::with_capacity(record.len()); 2 * states.len()];
    let mut held = supervised.filter().snapshot().input;
    let (mut grid, mut instants) = (0_u64, 0_usize);
    let failed = |what: &str, t: f64, e: &dyn std::fmt::Display| format!("{what} at t = {t} s failed: {e}");
    for (k, &t) in times.iter().enumerate() {
        let target = record.grid_index(k, dt);
        while grid < target {
            supervised.predict(&held, dt).map_err(|e| failed("the prediction", t, &e))?;
            grid += 1;
            if grid < target {
                recorder.push(supervised.filter(), supervised.transition()).map_err(|e| e.to_string())?;
                instants += 1;
            }
        }
        held.copy_from_slice(record.control(k));
        supervised.hold_input(&held).map_err(|e| failed("holding the controls", t, &e))?;
        supervised.update(record.measurement(k), t).map_err(|e| failed("the update", t, &e))?;
        recorder.push(supervised.filter(), supervised.transition()).map_err(|e| e.to_string())?;
        instant_of_sample.push(instants);
        instants += 1;
        let belief = supervised.filter();
        for (j, state) in states.iter().enumerate() {
            filtered[2 * j].push(belief.mean()[state.index]);
            filtered[2 * j + 1].push(belief.variance(state.index).sqrt());
        }
    }
    let smoothed_run = recorder.smooth().map_err(|e| format!("the backward pass failed: {e}"))?;
    let mut smoothed: Vec<Vec<f64>> = vec![Vec::with_capacity(record.len()); 2 * states.len()];
    for &instant in &instant_of_sample {
        let belief = &smoothed_run[instant];
        for (j, state) in states.iter().enumerate() {
            smoothed[2 * j].push(belief.mean[state.index]);
            smoothed[2 * j + 1].push(belief.covariance[(state.index, state.index)].sqrt());
        }
    }
    let channel = |topic: &str, columns: Vec<Vec<f64>>, what: &str| Channel {
        topic: topic.into(),
        time: times.to_vec(),
        signals: states
            .iter()
            .flat_map(|s| {
                [
                    SignalSpec::new(&s.name, &s.unit, &format!("{what}: {}", s.description)),
                    SignalSpec::new(&format!("{}_std", s.name), &s.unit, &format!("{what}: its standard deviation")),
                ]
            })
            .zip(columns)
            .map(|(spec, values)| Signal { spec, values })
            .collect(),
    };
    let estimate = channel(ESTIMATE, filtered, "filtered, given the samples up to this one");
    let smoothed = channel(SMOOTHED, smoothed, "smoothed, given every sample of the log");
    let kept = run.channels.iter().filter(|c| ![ESTIMATE, PREDICTION, SMOOTHED].contains(&c.topic.as_str()));
    let channels: Vec<&Channel> = kept.chain([&estimate, &smoothed]).collect();
    let parameters: BTreeMap<String, f64> = estimator.parameters_with(fitted).into_iter().collect();
    let mut metadata = run.metadata.clone();
    metadata.insert("filter".into(), kind.name().into());
    metadata.insert("parameters".into(), serde_json::to_string(&parameters).map_err(|e| e.to_string())?);
    metadata.insert("model_identifier".into(), estimator.descriptor().model_identifier.into());
    metadata.insert("source_log".into(), run.file.display().to_string());
    metadata.insert(
        SMOOTHING_KEY.into(),
        "fixed-interval: /smoothed is each sample's estimate given every sample of the log (kalfmu-tune \
         --smoothed-log)"
            .into(),
    );
    metadata.insert("software".into(), format!("kalfmu {}", env!("CARGO_PKG_VERSION")));
    write_channels(path, &metadata, &channels).map_err(|e| e.to_string())?;
    Ok(Written {
        samples: record.len(),
        rejected_rows: supervised.supervisor().rejected(),
        missing_rows: supervised.skipped(),
    })
}

/// One of the FMU's state outputs.
struct StateOutput {
    /// The state's index in the filter.
    index: usize,
    name: String,
    unit: String,
    description: String,
}

/// The FMU's state outputs (`Role::Estimate`), in the order of their states.
fn state_outputs(estimator: &FmuEstimator) -> Vec<StateOutput> {
    let mut states: Vec<StateOutput> = estimator
        .descriptor()
        .variables
        .iter()
        .filter_map(|v| match v.role {
            Role::Estimate(index) => Some(StateOutput {
                index,
                name: v.name.to_string(),
                unit: v.unit.unwrap_or("").to_string(),
                description: v.description.to_string(),
            }),
            _ => None,
        })
        .collect();
    states.sort_by_key(|s| s.index);
    states
}
