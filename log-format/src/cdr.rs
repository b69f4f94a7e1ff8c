//! CDR channels: message encoding `cdr`, schema encoding `ros2msg` (see `ros2msg.rs`), as
//! ROS 2 bags have them.
//!
//! Signals are the numbers of the message: each numeric or `bool` (1 or 0) field is a
//! signal named by its path, nested messages flattened with `.` (`pose.position.x`) and
//! array elements named by their index (`q[0]`); a sequence's elements become signals as
//! messages bring them (NaN in the messages without them). Not signals: strings, byte
//! sequences (`uint8[]`: data, not signals), sequences of messages, elements past
//! [`MAX_ELEMENTS`], and time stamps and durations (`builtin_interfaces/Time`, as in a
//! `std_msgs/Header`): the time of a sample is its message's `log_time`, as for every
//! channel. A field's comment `# [unit] description` gives its unit and description.
//!
//! The definition is compiled once into a flat list of reads, then each message is read
//! by walking it: the CDR of ROS 2 (XCDR1: each primitive aligned to its size, counted
//! from the end of the 4-byte encapsulation header), little- or big-endian, and the plain
//! XCDR2 (alignment at most 4).

use crate::decode::{Row, MAX_ELEMENTS};
use crate::ros2msg::{is_time, parse, Count, Definitions, Field, Kind, Primitive};
use crate::write::{unit_and_description, SignalSpec};

/// Nesting deeper than this is taken as a definition that refers to itself.
const MAX_DEPTH: usize = 32;

/// A CDR channel's decoder.
#[derive(Debug)]
pub struct CdrDecoder {
    reads: Vec<Read>,
}

/// One step of reading a message.
#[derive(Debug)]
enum Read {
    /// A number, into a signal's slot or dropped.
    Value { primitive: Primitive, slot: Option<usize> },
    /// A string, dropped.
    Text,
    /// The same reads `count` times, dropped (an array of strings or of messages).
    Repeat { count: usize, reads: Vec<Read> },
    /// A sequence of numbers: element `i` into `slots[i]`, each added (with the field's
    /// unit and description) when a message first has that element.
    Numbers { primitive: Primitive, path: String, unit: String, description: String, slots: Vec<usize> },
    /// A sequence of anything else, dropped.
    Sequence { reads: Vec<Read> },
}

impl CdrDecoder {
    /// The decoder of channels of type `name` with this `ros2msg` schema, and its signals.
    pub fn new(name: &str, schema: &str) -> Result<(Self, Vec<SignalSpec>), String> {
        let definitions = parse(name, schema)?;
        let mut signals = Vec::new();
        let root = definitions
            .types
            .get(&definitions.root)
            .ok_or_else(|| format!("the schema does not define the channel's type {}", definitions.root))?;
        let reads = compile(&definitions, root, "", Some(&mut signals), 0)?;
        Ok((Self { reads }, signals))
    }

    /// Reads one message into `row`.
    pub fn decode(&mut self, data: &[u8], row: &mut Row) -> Result<(), String> {
        let Some((header, body)) = data.split_first_chunk::<4>() else {
            return Err(format!("{} bytes, shorter than the CDR header", data.len()));
        };
        let (little, max_align) = match header[1] {
            0x00 => (false, 8),
            0x01 => (true, 8),
            0x06 => (false, 4),
            0x07 => (true, 4),
            other => {
                return Err(format!(
                    "CDR representation 0x{other:02x}: only plain CDR and XCDR2 (0x00, 0x01, 0x06, 0x07) are read"
                ))
            }
        };
        let mut cursor = Cursor { data: body, at: 0, little, max_align };
        run(&mut self.reads, &mut cursor, Some(row))
            .map_err(|()| format!("{} bytes: the message ends before its fields do", data.len()))
    }
}

/// The reads of a message's `fields`, their signals named from `prefix`; `signals: None`
/// for a message read only to be skipped.
fn compile(
    definitions: &Definitions,
    fields: &[Field],
    prefix: &str,
    mut signals: Option<&mut Vec<SignalSpec>>,
    depth: usize,
) -> Result<Vec<Read>, String> {
    if depth > MAX_DEPTH {
        return Err(format!("the messages nest deeper than {MAX_DEPTH} levels at '{prefix}'"));
    }
    // An empty message is serialised as one byte.
    if fields.is_empty() {
        return Ok(vec![Read::Value { primitive: Primitive::U8, slot: None }]);
    }
    let mut reads = Vec::new();
    for field in fields {
        let path = format!("{prefix}{}", field.name);
        let recorded = match &field.kind {
            Kind::Message(ty) if is_time(ty) => None,
            _ => signals.as_deref_mut(),
        };
        let add = |signals: Option<&mut Vec<SignalSpec>>, name: &str| {
            signals.map(|signals| {
                let (unit, description) = unit_and_description(&field.comment);
                signals.push(SignalSpec::new(name, unit, description));
                signals.len() - 1
            })
        };
        match (&field.kind, field.count) {
            (Kind::Primitive(primitive), Count::One) => {
                reads.push(Read::Value { primitive: *primitive, slot: add(recorded, &path) });
            }
            (Kind::Primitive(primitive), Count::Fixed(n)) if n <= MAX_ELEMENTS && recorded.is_some() => {
                let signals = recorded.expect("checked");
                for i in 0..n {
                    reads.push(Read::Value {
                        primitive: *primitive,
                        slot: add(Some(&mut *signals), &format!("{path}[{i}]")),
                    });
                }
            }
            (Kind::Primitive(primitive), Count::Fixed(n)) => {
                reads.push(Read::Repeat { count: n, reads: vec![Read::Value { primitive: *primitive, slot: None }] });
            }
            (Kind::Primitive(primitive), Count::Sequence) if recorded.is_some() && *primitive != Primitive::U8 => {
                let (unit, description) = unit_and_description(&field.comment);
                let (unit, description) = (unit.to_string(), description.to_string());
                reads.push(Read::Numbers { primitive: *primitive, path, unit, description, slots: Vec::new() });
            }
            (Kind::Primitive(primitive), Count::Sequence) => {
                reads.push(Read::Sequence { reads: vec![Read::Value { primitive: *primitive, slot: None }] });
            }
            (Kind::String, Count::One) => reads.push(Read::Text),
            (Kind::String, Count::Fixed(count)) => reads.push(Read::Repeat { count, reads: vec![Read::Text] }),
            (Kind::String, Count::Sequence) => reads.push(Read::Sequence { reads: vec![Read::Text] }),
            (Kind::Message(ty), count) => {
                let inner = &definitions.types[ty];
                match count {
                    Count::One => reads.extend(compile(definitions, inner, &format!("{path}."), recorded, depth + 1)?),
                    Count::Fixed(n) if n <= MAX_ELEMENTS && recorded.is_some() => {
                        let signals = recorded.expect("checked");
                        for i in 0..n {
                            let prefix = format!("{path}[{i}].");
                            reads.extend(compile(definitions, inner, &prefix, Some(&mut *signals), depth + 1)?);
                        }
                    }
                    Count::Fixed(count) => {
                        reads.push(Read::Repeat { count, reads: compile(definitions, inner, "", None, depth + 1)? });
                    }
                    Count::Sequence => {
                        reads.push(Read::Sequence { reads: compile(definitions, inner, "", None, depth + 1)? });
                    }
                }
            }
        }
    }
    Ok(reads)
}

/// The bytes of a message after its header, and where the next field starts.
struct Cursor<'a> {
    data: &'a [u8],
    at: usize,
    little: bool,
    max_align: usize,
}

impl Cursor<'_> {
    fn take(&mut self, size: usize) -> Result<&[u8], ()> {
        let align = size.min(self.max_align);
        let start = self.at.next_multiple_of(align);
        let bytes = self.data.get(start..start + size).ok_or(())?;
        self.at = start + size;
        Ok(bytes)
    }

    fn u32(&mut self) -> Result<u32, ()> {
        let bytes: [u8; 4] = self.take(4)?.try_into().expect("4 bytes");
        Ok(if self.little { u32::from_le_bytes(bytes) } else { u32::from_be_bytes(bytes) })
    }

    fn value(&mut self, primitive: Primitive) -> Result<f64, ()> {
        let little = self.little;
        let bytes = self.take(primitive.size())?;
        macro_rules! number {
            ($t:ty) => {{
                let bytes = bytes.try_into().expect("the size of the type");
                (if little { <$t>::from_le_bytes(bytes) } else { <$t>::from_be_bytes(bytes) }) as f64
            }};
        }
        Ok(match primitive {
            Primitive::Bool => f64::from(u8::from(bytes[0] != 0)),
            Primitive::U8 => f64::from(bytes[0]),
            Primitive::I8 => f64::from(bytes[0] as i8),
            Primitive::I16 => number!(i16),
            Primitive::U16 => number!(u16),
            Primitive::I32 => number!(i32),
            Primitive::U32 => number!(u32),
            Primitive::I64 => number!(i64),
            Primitive::U64 => number!(u64),
            Primitive::F32 => number!(f32),
            Primitive::F64 => number!(f64),
        })
    }

    /// The length of a sequence or string, checked against the bytes left (each element
    /// takes at least one).
    fn length(&mut self) -> Result<usize, ()> {
        let n = self.u32()? as usize;
        if n > self.data.len() - self.at {
            return Err(());
        }
        Ok(n)
    }
}

/// Walks `reads` over the message; `row: None` where nothing is recorded.
fn run(reads: &mut [Read], cursor: &mut Cursor, mut row: Option<&mut Row>) -> Result<(), ()> {
    for read in reads {
        match read {
            Read::Value { primitive, slot } => {
                let value = cursor.value(*primitive)?;
                if let (Some(slot), Some(row)) = (slot, row.as_deref_mut()) {
                    row.values[*slot] = value;
                }
            }
            Read::Text => {
                let n = cursor.length()?;
                cursor.at += n;
            }
            Read::Repeat { count, reads } => {
                for _ in 0..*count {
                    run(reads, cursor, None)?;
                }
            }
            Read::Sequence { reads } => {
                for _ in 0..cursor.length()? {
                    run(reads, cursor, None)?;
                }
            }
            Read::Numbers { primitive, path, unit, description, slots } => {
                let n = cursor.length()?;
                for i in 0..n {
                    let value = cursor.value(*primitive)?;
                    let Some(row) = row.as_deref_mut() else { continue };
                    if i >= MAX_ELEMENTS {
                        continue;
                    }
                    if i == slots.len() {
                        slots.push(row.add(SignalSpec::new(&format!("{path}[{i}]"), unit, description)));
                    }
                    row.values[slots[i]] = value;
                }
            }
        }
    }
    Ok(())
}
