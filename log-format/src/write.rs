//! The kalfmu log format: MCAP with one ROS 1 message definition per channel and
//! binary messages, so Foxglove, the Python `mcap` reader (with `mcap-ros1-support`)
//! and other MCAP tools decode the logs as they are, and the reader (`read.rs`) reads
//! them at memory speed. `docs/log-format.md` is the reference; this module is its
//! writer and its schema parser.
//!
//! * Channels: `/measurements`, `/truth`, `/estimate`, `/prediction` (any other topic
//!   is read too). Message encoding `ros1`, schema encoding `ros1msg`.
//! * The schema is `float64 <signal>  # [<unit>] <description>`, one line per signal.
//! * One message per sample: `log_time = publish_time =` simulation time in ns, and
//!   the body the signals' values as little-endian IEEE 754 doubles in schema order
//!   (ROS 1 serialisation of that definition); a missing value is NaN, and ±∞ stays ±∞.
//! * A metadata record `kalfmu` holds the run's description (study, case, seed,
//!   filter, parameters, software version), all as strings.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::LogError;
use crate::read::Channel;

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
/// Topic of the smoothed estimates: each stamped with the time it describes, given
/// measurements after it too (an estimator FMU's fixed-lag outputs, `smoothing_lag`).
pub const SMOOTHED: &str = "/smoothed";
/// The name of the metadata record.
pub const METADATA: &str = "kalfmu";
/// The channels' message encoding.
pub const MESSAGE_ENCODING: &str = "ros1";
/// The channels' schema encoding.
pub const SCHEMA_ENCODING: &str = "ros1msg";
/// The only field type of the format.
const FIELD_TYPE: &str = "float64";

/// One signal of a channel: its name, unit and description.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SignalSpec {
    /// Field name in the messages.
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

/// The ROS 1 type name of a channel's schema: `kalfmu/` and the topic in CamelCase
/// (`/truth` → `kalfmu/Truth`).
pub fn schema_name(topic: &str) -> String {
    let mut name = String::from("kalfmu/");
    for part in topic.split(|c: char| !c.is_ascii_alphanumeric()).filter(|p| !p.is_empty()) {
        let mut chars = part.chars();
        name.extend(chars.next().map(|c| c.to_ascii_uppercase()));
        name.push_str(chars.as_str());
    }
    if name.len() == "kalfmu/".len() || !name["kalfmu/".len()..].starts_with(|c: char| c.is_ascii_alphabetic()) {
        name.insert_str("kalfmu/".len(), "Channel");
    }
    name
}

/// The ROS 1 message definition of a channel with these signals.
pub fn schema(topic: &str, signals: &[SignalSpec]) -> String {
    let mut text = format!(
        "# kalfmu log channel {topic}: one value per signal, NaN where missing; \
         time is the message's log_time (docs/log-format.md)\n"
    );
    for s in signals {
        let description = s.description.replace(['\n', '\r'], " ");
        text.push_str(&format!("{FIELD_TYPE} {}  # [{}] {description}\n", s.name, s.unit));
    }
    text
}

/// The signals of a channel's message definition, or what is not the format's.
pub fn parse_schema(text: &str) -> Result<Vec<SignalSpec>, String> {
    let mut signals: Vec<SignalSpec> = Vec::new();
    for line in text.lines() {
        let (declaration, comment) = line.split_once('#').unwrap_or((line, ""));
        let mut words = declaration.split_whitespace();
        let Some(kind) = words.next() else { continue };
        let (Some(name), None) = (words.next(), words.next()) else {
            return Err(format!("'{}' is not a field declaration 'float64 <name>'", line.trim()));
        };
        if kind != FIELD_TYPE {
            return Err(format!("field '{name}' is {kind}; the format has {FIELD_TYPE} fields only"));
        }
        let valid = name.starts_with(|c: char| c.is_ascii_alphabetic())
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !valid {
            return Err(format!("'{name}' is not a field name (a letter, then letters, digits or _)"));
        }
        if signals.iter().any(|s| s.name == name) {
            return Err(format!("field '{name}' is declared twice"));
        }
        let (unit, description) = unit_and_description(comment);
        signals.push(SignalSpec::new(name, unit, description));
    }
    Ok(signals)
}

/// The unit and the description of a field's comment, `[<unit>] <description>` (no
/// brackets: no unit).
pub fn unit_and_description(comment: &str) -> (&str, &str) {
    let comment = comment.trim();
    match comment.strip_prefix('[').and_then(|c| c.split_once(']')) {
        Some((unit, description)) => (unit.trim(), description.trim()),
        None => ("", comment),
    }
}

/// Writes a log; channels are declared first, then samples in time order.
pub struct LogWriter {
    file: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: Vec<(u16, String, usize)>,
    sequence: u32,
    body: Vec<u8>,
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
            .compression_level(1)
            .profile("")
            .create(BufWriter::new(file))
            .map_err(mcap)?;
        writer
            .write_metadata(&mcap::records::Metadata { name: METADATA.into(), metadata: metadata.clone() })
            .map_err(mcap)?;
        Ok(Self { file: path.to_path_buf(), writer, channels: Vec::new(), sequence: 0, body: Vec::new() })
    }

    /// Declares a channel and its signals.
    pub fn add_channel(&mut self, topic: &str, signals: &[SignalSpec]) -> Result<ChannelId, LogError> {
        let mcap = |source| LogError::Mcap { file: self.file.clone(), source };
        let schema = schema(topic, signals);
        let schema_id =
            self.writer.add_schema(&schema_name(topic), SCHEMA_ENCODING, schema.as_bytes()).map_err(mcap)?;
        let id = self.writer.add_channel(schema_id, topic, MESSAGE_ENCODING, &BTreeMap::new()).map_err(mcap)?;
        self.channels.push((id, topic.into(), signals.len()));
        Ok(ChannelId(self.channels.len() - 1))
    }

    /// Writes one sample: `values` in the order of the channel's signals.
    pub fn write(&mut self, channel: ChannelId, time: f64, values: &[f64]) -> Result<(), LogError> {
        let (id, topic, count) = &self.channels[channel.0];
        if values.len() != *count || time < 0.0 || time.is_nan() {
            return Err(LogError::Message {
                file: self.file.clone(),
                channel: topic.clone(),
                time,
                what: format!("{} values for {count} signals (time must be ≥ 0)", values.len()),
            });
        }
        let nanos = (time * 1e9).round() as u64;
        self.body.clear();
        for &v in values {
            self.body.extend_from_slice(&v.to_le_bytes());
        }
        let header = mcap::records::MessageHeader {
            channel_id: *id,
            sequence: self.sequence,
            log_time: nanos,
            publish_time: nanos,
        };
        self.sequence = self.sequence.wrapping_add(1);
        self.writer
            .write_to_known_channel(&header, &self.body)
            .map_err(|source| LogError::Mcap { file: self.file.clone(), source })
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<(), LogError> {
        self.writer.finish().map_err(|source| LogError::Mcap { file: self.file.clone(), source })?;
        Ok(())
    }
}

/// Writes `channels` (read from logs, or made in memory) as a log at `path` with
/// `metadata`, their samples merged in time order (at one time, in the order given).
pub fn write_channels(path: &Path, metadata: &BTreeMap<String, String>, channels: &[&Channel]) -> Result<(), LogError> {
    let mut log = LogWriter::create(path, metadata)?;
    let mut samples = Vec::new();
    for &channel in channels {
        let specs: Vec<SignalSpec> = channel.signals.iter().map(|s| s.spec.clone()).collect();
        let id = log.add_channel(&channel.topic, &specs)?;
        samples.extend(channel.time.iter().enumerate().map(|(k, &t)| (t, id, channel, k)));
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut values = Vec::new();
    for (time, id, channel, k) in samples {
        values.clear();
        values.extend(channel.signals.iter().map(|s| s.values[k]));
        log.write(id, time, &values)?;
    }
    log.finish()
}
