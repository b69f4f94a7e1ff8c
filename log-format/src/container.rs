//! The MCAP container, read as a stream through the `mcap` crate's sans-io
//! [`LinearReader`]: the records of the data section in file order, chunks decompressed
//! (zstd, lz4 or none) and checked against their CRC, one chunk in memory at a time. It
//! knows nothing of the kalfmu format; `read.rs` does.
//!
//! mcap's linear reader yields the file's top-level records whole (chunks too), so the
//! byte offset of every record is known by counting what it yields, and the damage can be
//! placed exactly; `mcap::parse_record` types the records and the chunk headers. A whole
//! chunk is then decompressed in one call and checked against its size and CRC *before*
//! any of its records is passed on, so a corrupt chunk gives nothing rather than wrong
//! numbers; its records are split here, and a message's fixed header read in place.
//!
//! Why not a second linear reader (with `prevalidate_chunk_crcs`) for the records inside
//! whole chunks, and `parse_record` for messages: measured with `read_log` on the log of
//! `analyzer/examples/bench_report.rs` with N = 2·10⁶ (4·10⁶ messages, one core of a loaded
//! machine, best of 3 per binary, interleaved): this file 221–233 ms, a second linear
//! reader 293–305 ms (+20 ns per record); `parse_record` (binrw) for each message had cost
//! about 100 ns more per record. The earlier own container parser took 228–237 ms.
//! The linear reader still does what is hard to get right: a chunk cut short is streamed
//! through it, decompressed as far as its bytes go.
//!
//! A log whose writer died ends without its summary and footer, possibly in the middle of
//! a record or of a chunk. Like `mcap recover`, this reads every complete record up to the
//! damage, including the complete records of a chunk cut short (read again from the file,
//! through a reader that decompresses as far as the bytes go; the CRC of such a chunk
//! cannot be checked, which the [`Damage`] says), and then reports where the readable part
//! ends and why. A file that does not start with the MCAP magic is refused as not MCAP.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use mcap::records::{op, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
use mcap::McapError;

use crate::error::LogError;

/// The 8 bytes an MCAP file starts (and ends) with.
pub const MAGIC: &[u8] = mcap::MAGIC;

/// Records (and chunks, compressed or not) larger than this are taken as corrupt lengths
/// rather than allocated.
const MAX_RECORD: usize = 1 << 31;

/// The least the file is read by at a time: the reader asks for 9 bytes per record header.
const READ_SIZE: usize = 1 << 16;

/// Opcode and length, before every record's body.
const RECORD_HEAD: u64 = 9;

/// Where and why the readable part of a file ends before its footer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte offset of the first record that could not be read completely.
    pub offset: u64,
    /// The file's length.
    pub file_len: u64,
    /// What was found there.
    pub what: String,
}

/// How a stream of records ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ending {
    /// At the end of the data section, as written by a writer that finished.
    Complete,
    /// Before it: the records before [`Damage::offset`] were all delivered.
    Damaged(Damage),
}

/// What the records of a data section are passed to; either may stop the stream with an
/// error of its own.
pub trait Visit {
    /// A message: its channel's id, its log time (ns) and the encoded message.
    fn message(&mut self, channel_id: u16, log_time: u64, data: &[u8]) -> Result<(), LogError>;
    /// A schema, channel or metadata record.
    fn record(&mut self, record: Record<'_>) -> Result<(), LogError>;
}

/// Reads the records of the data section of the MCAP file at `path`, in file order, and
/// passes each to `visit`. Chunk, index and summary records are not passed on; the records
/// inside chunks are.
pub fn read_records(path: &Path, visit: &mut impl Visit) -> Result<Ending, LogError> {
    let io = |source| LogError::Io { file: path.to_path_buf(), source };
    let mut file = File::open(path).map_err(io)?;
    let file_len = file.metadata().map_err(io)?.len();
    let mut magic = [0u8; 8];
    let got = read_up_to(&mut file, &mut magic).map_err(io)?;
    if got == 0 || magic[..got] != MAGIC[..got] {
        return Err(LogError::NotMcap { file: path.to_path_buf() });
    }
    if got < MAGIC.len() {
        return Err(LogError::Truncated {
            file: path.to_path_buf(),
            what: format!("the file ends after {got} bytes, inside the MCAP magic"),
        });
    }
    let damaged = |offset, what: String| Ok(Ending::Damaged(Damage { offset, file_len, what }));
    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_emit_chunks(true)
        .with_record_length_limit(MAX_RECORD);
    let mut records = LinearReader::new_with_options(options);
    let mut chunks = WholeChunks::new().map_err(io)?;
    // Offset of the next top-level record: the magic, then every record yielded so far.
    let mut offset = MAGIC.len() as u64;
    loop {
        let event = match records.next_event() {
            None => return damaged(offset, "the file ends without its data-end record, summary and footer".into()),
            Some(Ok(event)) => event,
            Some(Err(McapError::UnexpectedEof)) => {
                return cut_record(&mut file, offset, file_len, visit).map_err(io)?;
            }
            Some(Err(McapError::RecordTooLarge { opcode, len })) => {
                return damaged(offset, format!("record 0x{opcode:02x} claims {len} bytes: a corrupt length"));
            }
            Some(Err(e)) => return damaged(offset, format!("record at byte {offset}: {e}")),
        };
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let buffer = records.insert(need.max(READ_SIZE));
                let got = read_up_to(&mut file, buffer).map_err(io)?;
                records.notify_read(got);
            }
            LinearReadEvent::Record { opcode, data } => {
                let start = offset;
                offset += RECORD_HEAD + data.len() as u64;
                match opcode {
                    op::DATA_END | op::FOOTER => return Ok(Ending::Complete),
                    op::CHUNK => {
                        if let Err(what) = chunks.read(data, visit)? {
                            return damaged(start, format!("chunk at byte {start}: {what}"));
                        }
                    }
                    _ => {
                        if let Err(what) = pass_on(opcode, data, visit)? {
                            return damaged(start, format!("record 0x{opcode:02x}: {what}"));
                        }
                    }
                }
            }
        }
    }
}

/// Parses a record and passes it to `visit` if the reader uses it: the outer `Err` is the
/// visitor's, the inner one what is wrong with the record.
fn pass_on(opcode: u8, data: &[u8], visit: &mut impl Visit) -> Result<Result<(), String>, LogError> {
    if opcode == op::MESSAGE {
        // The fixed header (channel id, sequence, log time, publish time) read in place:
        // `mcap::parse_record` does the same through `binrw`, at more than the cost of
        // decoding the message (see the file's header).
        let Some((header, body)) = data.split_first_chunk::<22>() else {
            return Ok(Err(format!("a message record of {} bytes, shorter than its header", data.len())));
        };
        let channel_id = u16::from_le_bytes([header[0], header[1]]);
        let log_time = u64::from_le_bytes(header[6..14].try_into().expect("8 bytes"));
        return visit.message(channel_id, log_time, body).map(Ok);
    }
    if !matches!(opcode, op::SCHEMA | op::CHANNEL | op::METADATA) {
        return Ok(Ok(()));
    }
    match mcap::parse_record(opcode, data) {
        Ok(record) => visit.record(record).map(Ok),
        Err(e) => Ok(Err(e.to_string())),
    }
}

/// Reads whole chunk records: decompresses each into one buffer, checks its size and CRC,
/// then passes on its records. (See the file's header for why this is not a second
/// `LinearReader`.)
struct WholeChunks {
    zstd: zstd::bulk::Decompressor<'static>,
    records: Vec<u8>,
}

impl WholeChunks {
    fn new() -> std::io::Result<Self> {
        Ok(Self { zstd: zstd::bulk::Decompressor::new()?, records: Vec::new() })
    }

    /// Passes on the records of the chunk whose record body is `body`.
    fn read(&mut self, body: &[u8], visit: &mut impl Visit) -> Result<Result<(), String>, LogError> {
        let (header, compressed) = match mcap::parse_record(op::CHUNK, body) {
            Ok(Record::Chunk { header, data }) => (header, data),
            Ok(_) => unreachable!("a chunk's opcode parses as a chunk"),
            Err(e) => return Ok(Err(e.to_string())),
        };
        let size = header.uncompressed_size;
        if size > MAX_RECORD as u64 {
            return Ok(Err(format!("claims {size} uncompressed bytes: a corrupt length")));
        }
        self.records.clear();
        let records: &[u8] = match header.compression.as_str() {
            "" => &compressed,
            "zstd" => {
                self.records.reserve(size as usize);
                if let Err(e) = self.zstd.decompress_to_buffer(&compressed, &mut self.records) {
                    return Ok(Err(format!("zstd: {e}")));
                }
                &self.records
            }
            "lz4" => {
                self.records.reserve(size as usize);
                let decoded = lz4::Decoder::new(&compressed[..]).and_then(|mut d| d.read_to_end(&mut self.records));
                if let Err(e) = decoded {
                    return Ok(Err(format!("lz4: {e}")));
                }
                &self.records
            }
            other => return Ok(Err(format!("unknown chunk compression '{other}'"))),
        };
        if records.len() as u64 != size {
            return Ok(Err(format!("{} bytes decompressed, {size} declared", records.len())));
        }
        if header.uncompressed_crc != 0 && crc32fast::hash(records) != header.uncompressed_crc {
            return Ok(Err("CRC mismatch, the chunk is corrupt".into()));
        }
        let mut at = 0;
        while at < records.len() {
            let Some((opcode, body)) = split_record(&records[at..]) else {
                return Ok(Err("a record overruns the chunk".into()));
            };
            at += RECORD_HEAD as usize + body.len();
            if let Err(what) = pass_on(opcode, body, visit)? {
                return Ok(Err(what));
            }
        }
        Ok(Ok(()))
    }
}

/// The first record of `data`, opcode and body, if it is complete.
fn split_record(data: &[u8]) -> Option<(u8, &[u8])> {
    let (&[opcode], rest) = data.split_first_chunk::<1>()?;
    let (length, rest) = rest.split_first_chunk::<8>()?;
    let length = usize::try_from(u64::from_le_bytes(*length)).ok()?;
    Some((opcode, rest.get(..length)?))
}

/// A reader of a stream of records without the file's magic and end: chunks, as they are
/// in the data section.
fn chunk_stream_options() -> LinearReaderOptions {
    LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_skip_end_magic(true)
        .with_record_length_limit(MAX_RECORD)
}

/// What a chunk's error means, in the reader's words.
fn chunk_error(e: &McapError) -> String {
    match e {
        McapError::BadChunkCrc { .. } => "CRC mismatch, the chunk is corrupt".into(),
        McapError::UnsupportedCompression(name) => format!("unknown chunk compression '{name}'"),
        McapError::ChunkTooLarge(len) => format!("claims {len} bytes: a corrupt length"),
        e => e.to_string(),
    }
}

/// The file ends inside the record at `offset`: its header says which. A chunk cut short is
/// read again from its start, and its complete records are passed on.
fn cut_record(
    file: &mut File,
    offset: u64,
    file_len: u64,
    visit: &mut impl Visit,
) -> std::io::Result<Result<Ending, LogError>> {
    let damaged = |what: String| Ok(Ok(Ending::Damaged(Damage { offset, file_len, what })));
    let mut head = [0u8; RECORD_HEAD as usize];
    file.seek(SeekFrom::Start(offset))?;
    let got = read_up_to(file, &mut head)?;
    if got == 0 {
        return damaged("the file ends without its data-end record, summary and footer".into());
    }
    if got < head.len() {
        return damaged(format!("the file ends inside a record header ({got} of 9 bytes)"));
    }
    let (opcode, length) = (head[0], u64::from_le_bytes(head[1..].try_into().expect("8 bytes")));
    if opcode != op::CHUNK {
        let there = file_len - offset - RECORD_HEAD;
        return damaged(format!("the file ends inside record 0x{opcode:02x} ({there} of {length} bytes)"));
    }
    // Streams the chunk's bytes through a reader that decompresses as it goes, and passes on
    // each record it completes; the file's end stops it.
    file.seek(SeekFrom::Start(offset))?;
    let mut reader = LinearReader::new_with_options(chunk_stream_options());
    let mut records = 0;
    let what = loop {
        match reader.next_event() {
            Some(Ok(LinearReadEvent::ReadRequest(need))) => {
                let buffer = reader.insert(need.max(READ_SIZE));
                let got = read_up_to(file, buffer)?;
                reader.notify_read(got);
            }
            Some(Ok(LinearReadEvent::Record { opcode, data })) => match pass_on(opcode, data, visit) {
                Ok(Ok(())) => records += 1,
                Ok(Err(what)) => break what,
                Err(e) => return Ok(Err(e)),
            },
            Some(Err(McapError::UnexpectedEof)) | None if records == 0 => {
                break "the file ends inside this chunk before its first complete record".into();
            }
            Some(Err(McapError::UnexpectedEof)) | None => {
                break "the file ends inside this chunk; its complete records were read, but their CRC cannot be \
                       checked"
                    .into();
            }
            Some(Err(e)) => break chunk_error(&e),
        }
    };
    damaged(format!("chunk at byte {offset}: {what}"))
}

/// The message count of each channel id, from the statistics record of a complete file's
/// summary (`None` for a file without one, e.g. cut short). The reader uses it to size its
/// arrays once instead of growing them; nothing else trusts it.
pub fn message_counts(path: &Path) -> Option<BTreeMap<u16, u64>> {
    let mut file = File::open(path).ok()?;
    let file_len = file.metadata().ok()?.len();
    let options = SummaryReaderOptions::default().with_file_size(file_len).with_record_length_limit(1 << 24);
    let mut reader = SummaryReader::new_with_options(options);
    while let Some(event) = reader.next_event() {
        match event.ok()? {
            SummaryReadEvent::ReadRequest(need) => {
                let got = file.read(reader.insert(need)).ok()?;
                reader.notify_read(got);
            }
            SummaryReadEvent::SeekRequest(to) => reader.notify_seeked(file.seek(to).ok()?),
        }
    }
    Some(reader.finish()?.stats?.channel_message_counts)
}

/// Reads until `buf` is full or the input ends; returns the bytes read.
fn read_up_to(input: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut filled = 0;
    while filled < buf.len() {
        match input.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}
