//! Reads a log into memory as one array per signal, streaming the file and checking it as
//! it goes: the format's own `ros1` channels (see `write.rs`), and the `json` and `cdr`
//! channels other writers log (see `json.rs`, `cdr.rs`). A schema its decoder cannot read,
//! a message that does not match its schema, time that does not increase — each a
//! [`LogError`] naming the file, the channel and the time. A channel in an encoding the
//! reader does not know is skipped, saying why. A container cut short is read up to the
//! cut (see `container.rs`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mcap::records::Record;

use crate::container::{message_counts, read_records, Damage, Ending, Visit};
use crate::decode::{open, Decoder, Opening, Row};
use crate::error::LogError;
use crate::write::{SignalSpec, METADATA};

/// One signal's samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Name, unit and description from the schema.
    pub spec: SignalSpec,
    /// One value per message of the channel (NaN where the message had none).
    pub values: Vec<f64>,
}

/// One channel's samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// The topic.
    pub topic: String,
    /// Time of each message (s): its `log_time`.
    pub time: Vec<f64>,
    /// The signals, in schema order (then in the order messages added them).
    pub signals: Vec<Signal>,
}

impl Channel {
    /// The signal called `name`.
    pub fn signal(&self, name: &str) -> Option<&Signal> {
        self.signals.iter().find(|s| s.spec.name == name)
    }
}

/// A channel the reader left out, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Skipped {
    /// The topic.
    pub topic: String,
    /// Why it was not read.
    pub reason: String,
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
    /// The channels with messages that were not read (an unknown encoding).
    pub skipped: Vec<Skipped>,
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

    /// One warning per skipped channel, naming the file, the channel and the reason.
    pub fn skip_warnings(&self) -> Vec<String> {
        self.skipped
            .iter()
            .map(|s| format!("{}: channel {} is skipped: {}", self.file.display(), s.topic, s.reason))
            .collect()
    }

    /// The channel on `topic`, or an error saying which channels there are.
    pub fn channel(&self, topic: &str) -> Result<&Channel, LogError> {
        self.channels.iter().find(|c| c.topic == topic).ok_or_else(|| {
            let mut present = self.channels.iter().map(|c| c.topic.as_str()).collect::<Vec<_>>().join(", ");
            for s in &self.skipped {
                present.push_str(&format!("; skipped {}: {}", s.topic, s.reason));
            }
            LogError::MissingChannel { file: self.file.clone(), channel: topic.into(), present }
        })
    }
}

/// Reads and checks the log at `path`, streaming it record by record.
///
/// A log cut short (a writer that died) is read up to the damage: [`Run::damage`] says
/// where and why, and [`Run::recovery_warning`] what was recovered. A file with no
/// complete message before its damage is an error, and so is one whose every channel
/// with messages is skipped.
pub fn read_log(path: &Path) -> Result<Run, LogError> {
    let mut reader = Reader {
        file: path.to_path_buf(),
        metadata: BTreeMap::new(),
        schemas: BTreeMap::new(),
        declared: BTreeMap::new(),
        channels: Vec::new(),
        decoders: Vec::new(),
        skipped: Vec::new(),
        row: Row::default(),
        slots: vec![UNSEEN; 1 << 16],
        counts: message_counts(path).unwrap_or_default(),
        // A count from a corrupt summary could ask for any memory: none above 8 messages
        // per byte of file is believed (the smallest message, 40 bytes, would need a
        // compression ratio of 320).
        most: std::fs::metadata(path).map_or(0, |m| m.len().saturating_mul(8)),
    };
    let ending = read_records(path, &mut reader)?;
    let Reader { file, metadata, mut channels, decoders, skipped, .. } = reader;
    // One JSON schema often serves several topics: a property none of a channel's messages
    // has a number for is not a signal of that channel.
    for (channel, decoder) in channels.iter_mut().zip(&decoders) {
        if let Decoder::Json(_) = decoder {
            channel.signals.retain(|s| s.values.iter().any(|v| !v.is_nan()));
        }
    }
    if channels.is_empty() && !skipped.is_empty() {
        let reasons: Vec<String> = skipped.iter().map(|s| format!("{}: {}", s.topic, s.reason)).collect();
        return Err(LogError::Unreadable { file, what: reasons.join("; ") });
    }
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
    Ok(Run { file, metadata, channels, skipped, damage })
}

/// A channel id without messages so far.
const UNSEEN: u32 = 0;
/// A channel id whose messages are skipped.
const SKIPPED: u32 = u32::MAX;

/// The state of a read: the records so far, and the samples.
struct Reader {
    file: PathBuf,
    metadata: BTreeMap<String, String>,
    /// Schema id → name, encoding, data.
    schemas: BTreeMap<u16, (String, String, Vec<u8>)>,
    /// Channel id → topic, message encoding, schema id.
    declared: BTreeMap<u16, (String, String, u16)>,
    channels: Vec<Channel>,
    /// One per channel.
    decoders: Vec<Decoder>,
    skipped: Vec<Skipped>,
    row: Row,
    /// Channel id → [`UNSEEN`], [`SKIPPED`], or 1 + its index in `channels`.
    slots: Vec<u32>,
    /// Messages per channel id, from the summary.
    counts: BTreeMap<u16, u64>,
    /// The most messages a channel is believed to have.
    most: u64,
}

impl Reader {
    /// Opens channel `id` at its first message; returns its slot.
    fn open(&mut self, id: u16) -> Result<u32, LogError> {
        let (topic, opening) = open_channel(&self.file, id, &self.declared, &self.schemas)?;
        if self.channels.iter().any(|c| c.topic == topic) {
            return Err(schema_error(&self.file, &topic, "two channels have this topic".into()));
        }
        Ok(match opening {
            Opening::Skip(reason) => {
                self.skipped.push(Skipped { topic, reason });
                SKIPPED
            }
            Opening::Read(decoder, specs) => {
                let count = self.counts.get(&id).map_or(0, |&n| n.min(self.most) as usize);
                let signals =
                    specs.into_iter().map(|spec| Signal { spec, values: Vec::with_capacity(count) }).collect();
                self.channels.push(Channel { topic, time: Vec::with_capacity(count), signals });
                self.decoders.push(decoder);
                self.channels.len() as u32
            }
        })
    }
}

impl Visit for Reader {
    #[inline]
    fn message(&mut self, channel_id: u16, log_time: u64, data: &[u8]) -> Result<(), LogError> {
        let mut slot = self.slots[usize::from(channel_id)];
        if slot == UNSEEN {
            slot = self.open(channel_id)?;
            self.slots[usize::from(channel_id)] = slot;
        }
        if slot == SKIPPED {
            return Ok(());
        }
        let index = slot as usize - 1;
        let channel = &mut self.channels[index];
        // Divide (correctly rounded) rather than multiply by 1e-9: 990000000 ns reads as 0.99 s.
        let time = log_time as f64 / 1e9;
        if let Some(&previous) = channel.time.last() {
            if time <= previous {
                return Err(LogError::NonMonotonicTime {
                    file: self.file.clone(),
                    channel: channel.topic.clone(),
                    previous,
                    time,
                    index: channel.time.len(),
                });
            }
        }
        let file = &self.file;
        let message_error =
            |what: String| LogError::Message { file: file.clone(), channel: channel.topic.clone(), time, what };
        match &mut self.decoders[index] {
            Decoder::Ros1 { fields } => {
                if data.len() != 8 * *fields {
                    return Err(message_error(format!(
                        "{} bytes, where the schema's {fields} float64 fields take {}",
                        data.len(),
                        8 * *fields
                    )));
                }
                for (signal, bytes) in channel.signals.iter_mut().zip(data.chunks_exact(8)) {
                    signal.values.push(f64::from_le_bytes(bytes.try_into().expect("8 bytes")));
                }
            }
            decoder => {
                let row = &mut self.row;
                row.reset(channel.signals.len());
                let decoded = match decoder {
                    Decoder::Json(json) => json.decode(data, row),
                    Decoder::Cdr(cdr) => cdr.decode(data, row),
                    Decoder::Ros1 { .. } => unreachable!("read above"),
                };
                decoded.map_err(message_error)?;
                let earlier = channel.time.len();
                for spec in row.added.drain(..) {
                    channel.signals.push(Signal { spec, values: vec![f64::NAN; earlier] });
                }
                for (signal, &value) in channel.signals.iter_mut().zip(&row.values) {
                    signal.values.push(value);
                }
            }
        }
        channel.time.push(time);
        Ok(())
    }

    fn record(&mut self, record: Record<'_>) -> Result<(), LogError> {
        match record {
            Record::Schema { header, data } => {
                self.schemas.insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(c) => {
                self.declared.insert(c.id, (c.topic, c.message_encoding, c.schema_id));
            }
            Record::Metadata(m) if m.name == METADATA => self.metadata = m.metadata,
            _ => {}
        }
        Ok(())
    }
}

fn schema_error(file: &Path, topic: &str, what: String) -> LogError {
    LogError::Schema { file: file.to_path_buf(), channel: topic.into(), what }
}

/// The topic of channel `id`, and how to read it (from its records).
fn open_channel(
    file: &Path,
    id: u16,
    declared: &BTreeMap<u16, (String, String, u16)>,
    schemas: &BTreeMap<u16, (String, String, Vec<u8>)>,
) -> Result<(String, Opening), LogError> {
    let Some((topic, message_encoding, schema_id)) = declared.get(&id) else {
        return Err(LogError::Schema {
            file: file.to_path_buf(),
            channel: format!("id {id}"),
            what: "a message comes before its channel record".into(),
        });
    };
    let schema = match *schema_id {
        0 => None,
        schema_id => {
            let (name, encoding, data) =
                schemas.get(&schema_id).ok_or_else(|| schema_error(file, topic, "has no schema".into()))?;
            Some((name.as_str(), encoding.as_str(), data.as_slice()))
        }
    };
    let opening = open(message_encoding, schema).map_err(|what| schema_error(file, topic, what))?;
    Ok((topic.clone(), opening))
}
