//! Reads a log of the kalfmu format (see `log.rs`) into memory, checking it
//! as it goes: a corrupt or truncated container, a schema that is not the
//! format's, a message that does not match its schema, time that does not
//! increase — each a [`LogError`] naming the file, the channel and the time.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::error::LogError;
use crate::log::{SignalSpec, METADATA};

/// One signal's samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Name, unit and description from the schema.
    pub spec: SignalSpec,
    /// One value per message of the channel (NaN where the message had `null`).
    pub values: Vec<f64>,
}

/// One channel's samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// The topic.
    pub topic: String,
    /// Simulation time of each message (s).
    pub time: Vec<f64>,
    /// The signals, in schema order.
    pub signals: Vec<Signal>,
}

impl Channel {
    /// The signal called `name`.
    pub fn signal(&self, name: &str) -> Option<&Signal> {
        self.signals.iter().find(|s| s.spec.name == name)
    }
}

/// A whole log.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Where it was read from.
    pub file: PathBuf,
    /// The `kalfmu` metadata record (empty if the log has none).
    pub metadata: BTreeMap<String, String>,
    /// The channels that have messages, in the order they first appear.
    pub channels: Vec<Channel>,
}

impl Run {
    /// The channel on `topic`, or an error saying which channels there are.
    pub fn channel(&self, topic: &str) -> Result<&Channel, LogError> {
        self.channels.iter().find(|c| c.topic == topic).ok_or_else(|| LogError::MissingChannel {
            file: self.file.clone(),
            channel: topic.into(),
            present: self.channels.iter().map(|c| c.topic.as_str()).collect::<Vec<_>>().join(", "),
        })
    }
}

/// Reads and checks the log at `path`.
pub fn read_log(path: &Path) -> Result<Run, LogError> {
    let file = path.to_path_buf();
    let bytes = std::fs::read(path).map_err(|source| LogError::Io { file: file.clone(), source })?;
    let mcap_error = |source| LogError::Mcap { file: file.clone(), source };
    let metadata = read_metadata(&bytes).map_err(mcap_error)?;
    let mut channels: Vec<Channel> = Vec::new();
    let mut by_id: BTreeMap<u16, usize> = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).map_err(mcap_error)? {
        let message = message.map_err(mcap_error)?;
        let index = match by_id.get(&message.channel.id) {
            Some(&i) => i,
            None => {
                let channel = open_channel(&file, &message.channel)?;
                if channels.iter().any(|c| c.topic == channel.topic) {
                    return Err(schema_error(&file, &channel.topic, "two channels have this topic".into()));
                }
                channels.push(channel);
                by_id.insert(message.channel.id, channels.len() - 1);
                channels.len() - 1
            }
        };
        let channel = &mut channels[index];
        // Divide (correctly rounded) rather than multiply by 1e-9: 990000000 ns reads as 0.99 s.
        let time = message.log_time as f64 / 1e9;
        if let Some(&previous) = channel.time.last() {
            if time <= previous {
                return Err(LogError::NonMonotonicTime {
                    file,
                    channel: channel.topic.clone(),
                    previous,
                    time,
                    index: channel.time.len(),
                });
            }
        }
        let problem =
            |what: String| LogError::Message { file: file.clone(), channel: channel.topic.clone(), time, what };
        let body: Value = serde_json::from_slice(&message.data).map_err(|e| problem(format!("not JSON: {e}")))?;
        let Value::Object(fields) = body else {
            return Err(problem("the message is not a JSON object".into()));
        };
        if let Some(unknown) = fields.keys().find(|k| *k != "timestamp" && channel.signal(k).is_none()) {
            return Err(problem(format!("field '{unknown}' is not in the channel's schema")));
        }
        let mut row = Vec::with_capacity(channel.signals.len());
        for signal in &channel.signals {
            let value = match fields.get(&signal.spec.name) {
                Some(Value::Number(n)) => n.as_f64().unwrap_or(f64::NAN),
                Some(Value::Null) => f64::NAN,
                Some(other) => return Err(problem(format!("field '{}' is {other}, not a number", signal.spec.name))),
                None => return Err(problem(format!("field '{}' of the schema is missing", signal.spec.name))),
            };
            row.push(value);
        }
        channel.time.push(time);
        for (signal, value) in channel.signals.iter_mut().zip(row) {
            signal.values.push(value);
        }
    }
    Ok(Run { file, metadata, channels })
}

fn schema_error(file: &Path, topic: &str, what: String) -> LogError {
    LogError::Schema { file: file.to_path_buf(), channel: topic.into(), what }
}

/// A channel from its MCAP record: checks the encodings and reads the signals from the schema.
fn open_channel(file: &Path, channel: &mcap::Channel<'_>) -> Result<Channel, LogError> {
    let topic = &channel.topic;
    if channel.message_encoding != "json" {
        return Err(schema_error(file, topic, format!("message encoding is '{}', not json", channel.message_encoding)));
    }
    let schema = channel.schema.as_ref().ok_or_else(|| schema_error(file, topic, "has no schema".into()))?;
    if schema.encoding != "jsonschema" {
        return Err(schema_error(file, topic, format!("schema encoding is '{}', not jsonschema", schema.encoding)));
    }
    let parsed: Value = serde_json::from_slice(&schema.data)
        .map_err(|e| schema_error(file, topic, format!("schema is not JSON: {e}")))?;
    let properties = parsed
        .get("properties")
        .and_then(Value::as_object)
        .ok_or_else(|| schema_error(file, topic, "schema has no 'properties' object".into()))?;
    let mut signals = Vec::new();
    for (name, property) in properties.iter().filter(|(name, _)| *name != "timestamp") {
        let text = |key: &str| property.get(key).and_then(Value::as_str).unwrap_or("").to_string();
        signals.push(Signal {
            spec: SignalSpec { name: name.clone(), unit: text("unit"), description: text("description") },
            values: Vec::new(),
        });
    }
    Ok(Channel { topic: topic.clone(), time: Vec::new(), signals })
}

/// The `kalfmu` metadata record, found through the summary (or an empty map).
fn read_metadata(bytes: &[u8]) -> Result<BTreeMap<String, String>, mcap::McapError> {
    let Some(summary) = mcap::Summary::read(bytes)? else {
        return Ok(BTreeMap::new());
    };
    match summary.metadata_indexes.iter().find(|i| i.name == METADATA) {
        Some(index) => Ok(mcap::read::metadata(bytes, index)?.metadata),
        None => Ok(BTreeMap::new()),
    }
}
