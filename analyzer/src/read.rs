//! Reads a log of the kalfmu format (see `log.rs`) into memory as one array per
//! signal, streaming the file and checking it as it goes: a schema that is not the
//! format's, a message that does not match its schema, time that does not increase —
//! each a [`LogError`] naming the file, the channel and the time. A container cut
//! short is read up to the cut (see `container.rs`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::container::{message_counts, read_records, Damage, Ending, Record};
use crate::error::LogError;
use crate::log::{parse_schema, SignalSpec, MESSAGE_ENCODING, METADATA, SCHEMA_ENCODING};

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
    /// Where the readable part ends, if the log was cut short or damaged.
    pub damage: Option<Damage>,
}

impl Run {
    /// For a damaged log: what was recovered (messages and time span per channel) and
    /// where the log ends. `None` for a complete log.
    pub fn recovery_warning(&self) -> Option<String> {
        let damage = self.damage.as_ref()?;
        let mut text = format!(
            "{}: the log is cut short at byte {} of {} ({}); recovered the messages before it:",
            self.file.display(),
            damage.offset,
            damage.file_len,
            damage.what
        );
        for c in &self.channels {
            let (first, last) = (c.time.first().copied().unwrap_or(0.0), c.time.last().copied().unwrap_or(0.0));
            text.push_str(&format!("\n  {}: {} messages, t = {first} s to {last} s", c.topic, c.time.len()));
        }
        Some(text)
    }

    /// The channel on `topic`, or an error saying which channels there are.
    pub fn channel(&self, topic: &str) -> Result<&Channel, LogError> {
        self.channels.iter().find(|c| c.topic == topic).ok_or_else(|| LogError::MissingChannel {
            file: self.file.clone(),
            channel: topic.into(),
            present: self.channels.iter().map(|c| c.topic.as_str()).collect::<Vec<_>>().join(", "),
        })
    }
}

/// Reads and checks the log at `path`, streaming it record by record.
///
/// A log cut short (a writer that died) is read up to the damage: [`Run::damage`] says
/// where and why, and [`Run::recovery_warning`] what was recovered. A file with no
/// complete message before its damage is an error.
pub fn read_log(path: &Path) -> Result<Run, LogError> {
    let file = path.to_path_buf();
    let mut metadata = BTreeMap::new();
    let mut schemas: BTreeMap<u16, (String, Vec<u8>)> = BTreeMap::new();
    let mut declared: BTreeMap<u16, (String, String, u16)> = BTreeMap::new();
    let mut channels: Vec<Channel> = Vec::new();
    // Channel id → 1 + index in `channels` (0: not seen yet); ids are u16.
    let mut slots = vec![0u32; 1 << 16];
    let counts = message_counts(path).unwrap_or_default();
    // A count from a corrupt summary could ask for any memory: none above 8 messages per
    // byte of file is believed (the smallest message, 40 bytes, would need a compression
    // ratio of 320).
    let most = std::fs::metadata(path).map_or(0, |m| m.len().saturating_mul(8));
    let ending = read_records(path, |record| {
        match record {
            Record::Message { channel_id, log_time, data } => {
                let slot = &mut slots[usize::from(channel_id)];
                if *slot == 0 {
                    let mut channel = open_channel(&file, channel_id, &declared, &schemas)?;
                    let count = counts.get(&channel_id).map_or(0, |&n| n.min(most) as usize);
                    channel.time.reserve_exact(count);
                    for signal in &mut channel.signals {
                        signal.values.reserve_exact(count);
                    }
                    if channels.iter().any(|c| c.topic == channel.topic) {
                        return Err(schema_error(&file, &channel.topic, "two channels have this topic".into()));
                    }
                    channels.push(channel);
                    *slot = channels.len() as u32;
                }
                let channel = &mut channels[*slot as usize - 1];
                // Divide (correctly rounded) rather than multiply by 1e-9: 990000000 ns reads as 0.99 s.
                let time = log_time as f64 / 1e9;
                if let Some(&previous) = channel.time.last() {
                    if time <= previous {
                        return Err(LogError::NonMonotonicTime {
                            file: file.clone(),
                            channel: channel.topic.clone(),
                            previous,
                            time,
                            index: channel.time.len(),
                        });
                    }
                }
                if data.len() != 8 * channel.signals.len() {
                    return Err(LogError::Message {
                        file: file.clone(),
                        channel: channel.topic.clone(),
                        time,
                        what: format!(
                            "{} bytes, where the schema's {} float64 fields take {}",
                            data.len(),
                            channel.signals.len(),
                            8 * channel.signals.len()
                        ),
                    });
                }
                channel.time.push(time);
                for (signal, bytes) in channel.signals.iter_mut().zip(data.chunks_exact(8)) {
                    signal.values.push(f64::from_le_bytes(bytes.try_into().expect("8 bytes")));
                }
            }
            Record::Schema { id, encoding, data, .. } => {
                schemas.insert(id, (encoding.to_string(), data.to_vec()));
            }
            Record::Channel { id, schema_id, topic, message_encoding } => {
                declared.insert(id, (topic.to_string(), message_encoding.to_string(), schema_id));
            }
            Record::Metadata { name, entries } => {
                if name == METADATA {
                    metadata = entries;
                }
            }
        }
        Ok(())
    })?;
    let damage = match ending {
        Ending::Complete => None,
        Ending::Damaged(damage) => {
            if channels.is_empty() {
                return Err(LogError::Truncated {
                    file,
                    what: format!(
                        "no complete message before byte {} of {}: {}",
                        damage.offset, damage.file_len, damage.what
                    ),
                });
            }
            Some(damage)
        }
    };
    Ok(Run { file, metadata, channels, damage })
}

fn schema_error(file: &Path, topic: &str, what: String) -> LogError {
    LogError::Schema { file: file.to_path_buf(), channel: topic.into(), what }
}

/// The channel `id` from its records: checks the encodings and reads the signals from the schema.
fn open_channel(
    file: &Path,
    id: u16,
    declared: &BTreeMap<u16, (String, String, u16)>,
    schemas: &BTreeMap<u16, (String, Vec<u8>)>,
) -> Result<Channel, LogError> {
    let Some((topic, message_encoding, schema_id)) = declared.get(&id) else {
        return Err(LogError::Schema {
            file: file.to_path_buf(),
            channel: format!("id {id}"),
            what: "a message comes before its channel record".into(),
        });
    };
    let fail = |what: String| schema_error(file, topic, what);
    if message_encoding != MESSAGE_ENCODING {
        return Err(fail(format!(
            "message encoding is '{message_encoding}', not {MESSAGE_ENCODING} (docs/log-format.md)"
        )));
    }
    let (encoding, data) = schemas.get(schema_id).ok_or_else(|| fail("has no schema".into()))?;
    if encoding != SCHEMA_ENCODING {
        return Err(fail(format!("schema encoding is '{encoding}', not {SCHEMA_ENCODING}")));
    }
    let text = std::str::from_utf8(data).map_err(|_| fail("the schema is not UTF-8 text".into()))?;
    let signals =
        parse_schema(text).map_err(fail)?.into_iter().map(|spec| Signal { spec, values: Vec::new() }).collect();
    Ok(Channel { topic: topic.clone(), time: Vec::new(), signals })
}
