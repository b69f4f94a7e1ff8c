//! How a channel's messages become samples: one decoder per message encoding the reader
//! knows (`ros1` with the format's `float64` definitions, `json`, `cdr` with `ros2msg`
//! definitions), chosen from the channel's and its schema's encodings.

use crate::cdr::CdrDecoder;
use crate::json::JsonDecoder;
use crate::write::{parse_schema, SignalSpec, MESSAGE_ENCODING, SCHEMA_ENCODING};

/// Elements of one array read as signals; the rest are skipped (an array that long is data,
/// e.g. an image, rather than signals).
pub(crate) const MAX_ELEMENTS: usize = 256;

/// One message's values, one slot per signal of its channel (NaN until a value is found),
/// and the signals the message adds to its channel (a longer sequence, a JSON key the
/// schema does not declare).
#[derive(Debug, Default)]
pub(crate) struct Row {
    /// The values, by signal index.
    pub values: Vec<f64>,
    /// The signals added by this message, indexed from the channel's count before it.
    pub added: Vec<SignalSpec>,
}

impl Row {
    /// A row for a channel of `signals` signals, all missing.
    pub fn reset(&mut self, signals: usize) {
        self.values.clear();
        self.values.resize(signals, f64::NAN);
        self.added.clear();
    }

    /// Adds a signal to the channel; returns its index.
    pub fn add(&mut self, spec: SignalSpec) -> usize {
        self.values.push(f64::NAN);
        self.added.push(spec);
        self.values.len() - 1
    }
}

/// A channel's decoder.
#[derive(Debug)]
pub(crate) enum Decoder {
    /// The format's own messages: `fields` little-endian doubles.
    Ros1 {
        /// The number of `float64` fields of the definition.
        fields: usize,
    },
    /// JSON objects.
    Json(JsonDecoder),
    /// CDR-serialised ROS 2 messages.
    Cdr(CdrDecoder),
}

/// What the reader does with a channel.
#[derive(Debug)]
pub(crate) enum Opening {
    /// Reads it with this decoder; these are the signals known before any message.
    Read(Decoder, Vec<SignalSpec>),
    /// Skips it, for this reason (an encoding the reader does not know).
    Skip(String),
}

/// The decoder of a channel with these encodings and schema; `Err` for a schema that its
/// encoding's decoder cannot read.
pub(crate) fn open(message_encoding: &str, schema: Option<(&str, &str, &[u8])>) -> Result<Opening, String> {
    let (schema_name, schema_encoding, data) = schema.unwrap_or(("", "", b""));
    let text = || std::str::from_utf8(data).map_err(|_| "the schema is not UTF-8 text".to_string());
    let expect = |wanted: &str| {
        if schema_encoding == wanted {
            Ok(())
        } else {
            Err(format!("schema encoding is '{schema_encoding}', where {message_encoding} messages take {wanted}"))
        }
    };
    match message_encoding {
        MESSAGE_ENCODING => {
            expect(SCHEMA_ENCODING)?;
            let signals = parse_schema(text()?)?;
            Ok(Opening::Read(Decoder::Ros1 { fields: signals.len() }, signals))
        }
        "json" => {
            // A JSON channel may have no schema: its signals are then the keys its messages have.
            if !schema_encoding.is_empty() {
                expect("jsonschema")?;
            }
            let (decoder, signals) = JsonDecoder::new(data)?;
            Ok(Opening::Read(Decoder::Json(decoder), signals))
        }
        "cdr" => {
            expect("ros2msg")?;
            let (decoder, signals) = CdrDecoder::new(schema_name, text()?)?;
            Ok(Opening::Read(Decoder::Cdr(decoder), signals))
        }
        other => Ok(Opening::Skip(format!(
            "message encoding '{other}' is not read (the reader reads ros1, json and cdr; docs/log-format.md)"
        ))),
    }
}
