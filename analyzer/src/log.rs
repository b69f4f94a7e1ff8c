//! The kalfmu log format: MCAP, JSON messages with a JSON Schema per channel,
//! so Foxglove, PlotJuggler and other MCAP tools read the logs as they are.
//! `docs/log-format.md` is the reference; this module is its implementation.
//!
//! * Channels: `/measurements`, `/truth`, `/estimate` (any other topic is
//!   read too). Message encoding `json`, schema encoding `jsonschema`.
//! * One message per sample: `log_time = publish_time =` simulation time in
//!   ns, and the body `{"timestamp": {"sec": s, "nsec": ns}, "<signal>": value, …}`
//!   with every signal of the channel; a missing value (NaN) is `null`.
//! * The schema names each signal with `"unit"` and `"description"`.
//! * A metadata record `kalfmu` holds the run's description (study, case,
//!   seed, filter, parameters, software version), all as strings.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};

use crate::error::LogError;

/// The measurements channel.
pub const MEASUREMENTS: &str = "/measurements";
/// The truth channel (where a simulator knows it).
pub const TRUTH: &str = "/truth";
/// The estimator's outputs: for an estimator FMU, read at each time after the
/// inputs of that time were set (the estimate given the measurements up to it).
pub const ESTIMATE: &str = "/estimate";
/// An estimator FMU's outputs read right after `fmi2DoStep(t, h)`, stamped
/// `t + h`: the estimate there predicted from the measurements up to `t`.
pub const PREDICTION: &str = "/prediction";
/// The name of the metadata record.
pub const METADATA: &str = "kalfmu";

/// One signal of a channel: its name, unit and description.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SignalSpec {
    /// Field name in the JSON messages.
    pub name: String,
    /// Unit (SI, as in the FMUs: `N`, `m/s2`, …).
    pub unit: String,
    /// What it is.
    pub description: String,
}

impl SignalSpec {
    /// A signal.
    pub fn new(name: &str, unit: &str, description: &str) -> Self {
        Self { name: name.into(), unit: unit.into(), description: description.into() }
    }
}

/// The JSON Schema of a channel with these signals.
pub fn schema(topic: &str, signals: &[SignalSpec]) -> Value {
    let mut properties = Map::new();
    properties.insert(
        "timestamp".into(),
        json!({
            "type": "object",
            "description": "simulation time",
            "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
            "required": ["sec", "nsec"]
        }),
    );
    for s in signals {
        properties.insert(
            s.name.clone(),
            json!({"type": ["number", "null"], "unit": s.unit, "description": format!("{} [{}]", s.description, s.unit)}),
        );
    }
    let mut required = vec![Value::from("timestamp")];
    required.extend(signals.iter().map(|s| Value::from(s.name.clone())));
    json!({"title": topic, "type": "object", "properties": properties, "required": required})
}

/// Writes a log; channels are declared first, then samples in time order.
pub struct LogWriter {
    file: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: Vec<(u16, String, Vec<String>)>,
    sequence: u32,
}

/// A channel handle for [`LogWriter::write`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelId(usize);

impl LogWriter {
    /// Creates `path` (zstd-compressed chunks) with the run's metadata.
    pub fn create(path: &Path, metadata: &BTreeMap<String, String>) -> Result<Self, LogError> {
        let io = |source| LogError::Io { file: path.to_path_buf(), source };
        let mcap = |source| LogError::Mcap { file: path.to_path_buf(), source };
        let file = File::create(path).map_err(io)?;
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("")
            .create(BufWriter::new(file))
            .map_err(mcap)?;
        writer
            .write_metadata(&mcap::records::Metadata { name: METADATA.into(), metadata: metadata.clone() })
            .map_err(mcap)?;
        Ok(Self { file: path.to_path_buf(), writer, channels: Vec::new(), sequence: 0 })
    }

    /// Declares a channel and its signals.
    pub fn add_channel(&mut self, topic: &str, signals: &[SignalSpec]) -> Result<ChannelId, LogError> {
        let mcap = |source| LogError::Mcap { file: self.file.clone(), source };
        let schema = serde_json::to_vec(&schema(topic, signals)).expect("a JSON value serialises");
        let schema_id = self
            .writer
            .add_schema(&format!("kalfmu{}", topic.replace('/', ".")), "jsonschema", &schema)
            .map_err(mcap)?;
        let id = self.writer.add_channel(schema_id, topic, "json", &BTreeMap::new()).map_err(mcap)?;
        self.channels.push((id, topic.into(), signals.iter().map(|s| s.name.clone()).collect()));
        Ok(ChannelId(self.channels.len() - 1))
    }

    /// Writes one sample: `values` in the order of the channel's signals.
    pub fn write(&mut self, channel: ChannelId, time: f64, values: &[f64]) -> Result<(), LogError> {
        let (id, topic, names) = &self.channels[channel.0];
        if values.len() != names.len() || time < 0.0 || time.is_nan() {
            return Err(LogError::Message {
                file: self.file.clone(),
                channel: topic.clone(),
                time,
                what: format!("{} values for {} signals (time must be ≥ 0)", values.len(), names.len()),
            });
        }
        let nanos = (time * 1e9).round() as u64;
        let mut body = Map::with_capacity(names.len() + 1);
        body.insert("timestamp".into(), json!({"sec": nanos / 1_000_000_000, "nsec": nanos % 1_000_000_000}));
        for (name, &v) in names.iter().zip(values) {
            body.insert(name.clone(), if v.is_finite() { Value::from(v) } else { Value::Null });
        }
        let data = serde_json::to_vec(&Value::Object(body)).expect("a JSON value serialises");
        let header = mcap::records::MessageHeader {
            channel_id: *id,
            sequence: self.sequence,
            log_time: nanos,
            publish_time: nanos,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.writer
            .write_to_known_channel(&header, &data)
            .map_err(|source| LogError::Mcap { file: self.file.clone(), source })
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<(), LogError> {
        self.writer.finish().map_err(|source| LogError::Mcap { file: self.file.clone(), source })?;
        Ok(())
    }
}
