//! The MCAP container, read as a stream: the records of the data section in file order,
//! chunks decompressed (zstd, lz4 or none) and checked against their CRC, a few chunks in
//! memory at a time. It knows nothing of the kalfmu format; `read.rs` does.
//!
//! A log whose writer died ends without its summary and footer, possibly in the middle of
//! a record or of a chunk. Like `mcap recover`, this reads every complete record up to the
//! damage, including the complete records of a chunk cut short (decompressing the part of
//! it that is there; the CRC of such a chunk cannot be checked, which the [`Damage`] says),
//! and then reports where the readable part ends and why. A file that does not start with
//! the MCAP magic is refused as not MCAP.
//!
//! Record layout (mcap.dev/spec): `opcode: u8, length: u64 LE, body`; strings are
//! `u32 length + UTF-8`, maps `u32 byte length + key/value pairs`.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use crate::error::LogError;

/// The 8 bytes an MCAP file starts (and ends) with.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// Records larger than this are taken as corrupt lengths rather than allocated.
const MAX_RECORD: u64 = 1 << 31;

const OP_FOOTER: u8 = 0x02;
const OP_STATISTICS: u8 = 0x0B;
const OP_SUMMARY_OFFSET: u8 = 0x0E;
const OP_SCHEMA: u8 = 0x03;
const OP_CHANNEL: u8 = 0x04;
const OP_MESSAGE: u8 = 0x05;
const OP_CHUNK: u8 = 0x06;
const OP_METADATA: u8 = 0x0C;
const OP_DATA_END: u8 = 0x0F;

/// A record the kalfmu reader uses; the others (indexes, statistics, attachments) are skipped.
#[derive(Debug)]
pub enum Record<'a> {
    /// A schema.
    Schema {
        /// Its id (channels refer to it).
        id: u16,
        /// Its name.
        name: &'a str,
        /// How `data` is written (`ros1msg`, `jsonschema`, …).
        encoding: &'a str,
        /// The schema itself.
        data: &'a [u8],
    },
    /// A channel.
    Channel {
        /// Its id (messages refer to it).
        id: u16,
        /// Its schema's id (0: none).
        schema_id: u16,
        /// The topic.
        topic: &'a str,
        /// How its messages are encoded.
        message_encoding: &'a str,
    },
    /// A message.
    Message {
        /// The channel's id.
        channel_id: u16,
        /// Log time (ns).
        log_time: u64,
        /// The encoded message.
        data: &'a [u8],
    },
    /// A metadata record.
    Metadata {
        /// Its name.
        name: &'a str,
        /// Its key/value pairs.
        entries: BTreeMap<String, String>,
    },
}

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

/// Reads the records of the data section of the MCAP file at `path`, in file order, and
/// passes each to `visit` (which may stop the stream with an error of its own).
///
/// Two threads share the work: one reads the file and decompresses and checks every other
/// chunk, the caller's decompresses the others and parses and visits the records, so that
/// on two cores neither waits long for the other (decompression is most of the cost). At
/// most six chunk buffers are alive at once, whatever the file's size.
pub fn read_records(
    path: &Path,
    mut visit: impl FnMut(Record<'_>) -> Result<(), LogError>,
) -> Result<Ending, LogError> {
    let io = |source| LogError::Io { file: path.to_path_buf(), source };
    let file = File::open(path).map_err(io)?;
    let file_len = file.metadata().map_err(io)?.len();
    // Small: the chunks (hundreds of kB) are longer, so they bypass the buffer and are
    // copied once, straight from the file into their own buffers.
    let mut input = BufReader::with_capacity(1 << 16, file);
    let mut magic = [0u8; 8];
    let got = read_up_to(&mut input, &mut magic).map_err(io)?;
    if magic[..got] != MAGIC[..got] || got == 0 {
        return Err(LogError::NotMcap { file: path.to_path_buf() });
    }
    if got < MAGIC.len() {
        return Err(LogError::Truncated {
            file: path.to_path_buf(),
            what: format!("the file ends after {got} bytes, inside the MCAP magic"),
        });
    }
    let damaged = |offset, what: String| Ok(Ending::Damaged(Damage { offset, what, file_len }));
    let mut zstd = zstd::bulk::Decompressor::new().map_err(io)?;
    let mut decompressed = Vec::new();
    std::thread::scope(|scope| {
        let (pieces, received) = std::sync::mpsc::sync_channel(2);
        let (spares, spare) = std::sync::mpsc::channel();
        let producer = Producer { input, file_len, offset: MAGIC.len() as u64, chunks: 0, pieces, spare };
        scope.spawn(move || producer.run());
        for produced in received {
            let piece = match produced {
                Produced::Piece(piece) => piece,
                Produced::End(ending) => return ending.map_err(io),
            };
            let (records, kind) = match piece.kind {
                Kind::Compressed { start, cut } => {
                    decompressed.clear();
                    if let Err(what) = chunk(&mut zstd, &piece.bytes, start, cut, &mut decompressed) {
                        return damaged(start, what);
                    }
                    (&decompressed[..], Kind::Chunk { start, whole: !cut })
                }
                kind => (&piece.bytes[..], kind),
            };
            if let Some((offset, what)) = visit_records(records, &kind, &mut visit)? {
                return damaged(offset, what);
            }
            // Back to the producer, to be filled again.
            let _ = spares.send(piece.bytes);
        }
        Err(io(std::io::Error::other("the reading thread stopped without saying why")))
    })
}

/// Passes the records of `bytes` on; `Ok(Some((offset, what)))` where they are damaged.
fn visit_records(
    bytes: &[u8],
    kind: &Kind,
    visit: &mut impl FnMut(Record<'_>) -> Result<(), LogError>,
) -> Result<Option<(u64, String)>, LogError> {
    let mut at = 0;
    for k in 0.. {
        if at == bytes.len() {
            break;
        }
        let Some((opcode, body)) = split_record(&bytes[at..]) else {
            return Ok(match *kind {
                // The rest of a cut chunk: its damage comes next.
                Kind::Chunk { whole: false, .. } => None,
                Kind::Chunk { start, .. } => {
                    Some((start, format!("chunk at byte {start}: a record overruns the chunk")))
                }
                Kind::Records { .. } | Kind::Compressed { .. } => {
                    unreachable!("the producer batches whole records only")
                }
            });
        };
        at += 9 + body.len();
        match dispatch(opcode, body, visit) {
            Ok(()) => {}
            Err(Stop::Visitor(e)) => return Err(e),
            Err(Stop::Damage(what)) => {
                return Ok(Some(match kind {
                    Kind::Records { offsets } => (offsets[k], format!("record 0x{opcode:02x}: {what}")),
                    Kind::Chunk { start, .. } | Kind::Compressed { start, .. } => {
                        (*start, format!("chunk at byte {start}: {what}"))
                    }
                }));
            }
        }
    }
    Ok(None)
}

/// The message count of each channel id, from the statistics record of a complete file's
/// summary (`None` for a file without one, e.g. cut short). The reader uses it to size its
/// arrays once instead of growing them; nothing else trusts it.
pub fn message_counts(path: &Path) -> Option<BTreeMap<u16, u64>> {
    use std::io::{Seek, SeekFrom};
    let mut file = File::open(path).ok()?;
    let file_len = file.metadata().ok()?.len();
    // Footer record (opcode, length 20, summary start, summary offset start, CRC) and magic.
    let mut tail = [0u8; 37];
    file.seek(SeekFrom::Start(file_len.checked_sub(tail.len() as u64)?)).ok()?;
    file.read_exact(&mut tail).ok()?;
    if tail[0] != OP_FOOTER || &tail[29..] != MAGIC {
        return None;
    }
    let mut footer = Fields { data: &tail[9..29], at: 0 };
    let (_, offsets_start) = (footer.u64().ok()?, footer.u64().ok()?);
    let offsets_len = (file_len - tail.len() as u64).checked_sub(offsets_start)?;
    if offsets_start == 0 || offsets_len > 1 << 20 {
        return None;
    }
    let mut offsets = vec![0u8; offsets_len as usize];
    file.seek(SeekFrom::Start(offsets_start)).ok()?;
    file.read_exact(&mut offsets).ok()?;
    let mut at = 0;
    let (start, length) = loop {
        let (opcode, body) = split_record(&offsets[at..])?;
        at += 9 + body.len();
        let mut r = Fields { data: body, at: 0 };
        if opcode == OP_SUMMARY_OFFSET && r.take(1).ok()?[0] == OP_STATISTICS {
            break (r.u64().ok()?, r.u64().ok()?);
        }
    };
    if length > 1 << 20 {
        return None;
    }
    let mut group = vec![0u8; length as usize];
    file.seek(SeekFrom::Start(start)).ok()?;
    file.read_exact(&mut group).ok()?;
    let (opcode, body) = split_record(&group)?;
    if opcode != OP_STATISTICS {
        return None;
    }
    // message count, schema, channel, attachment, metadata and chunk counts, start and end time
    let mut r = Fields { data: body, at: 8 + 2 + 4 * 4 + 8 + 8 };
    let map_len = r.u32().ok()? as usize;
    let mut map = Fields { data: r.take(map_len).ok()?, at: 0 };
    let mut counts = BTreeMap::new();
    while map.at < map.data.len() {
        counts.insert(map.u16().ok()?, map.u64().ok()?);
    }
    Some(counts)
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

/// What the reading thread passes on: records to visit, then how the data section ended.
enum Produced {
    Piece(Piece),
    End(std::io::Result<Ending>),
}

/// Complete records, one after the other (`opcode, length, body`).
struct Piece {
    bytes: Vec<u8>,
    kind: Kind,
}

enum Kind {
    /// Records outside chunks, with the byte offset of each.
    Records { offsets: Vec<u64> },
    /// A chunk record's body as it is in the file, for the consumer to decompress (`cut`:
    /// the file ends inside it).
    Compressed { start: u64, cut: bool },
    /// A chunk's decompressed records; `whole: false` for a cut chunk, whose last record may
    /// be incomplete.
    Chunk { start: u64, whole: bool },
}

/// Records outside chunks are passed on in batches of about this many bytes.
const BATCH: usize = 1 << 20;

/// The reading thread: reads the records, decompresses and checks the chunks.
struct Producer<R> {
    input: R,
    file_len: u64,
    offset: u64,
    /// Chunks met so far: every second one goes on compressed, for the consumer.
    chunks: u64,
    pieces: std::sync::mpsc::SyncSender<Produced>,
    spare: std::sync::mpsc::Receiver<Vec<u8>>,
}

impl<R: Read> Producer<R> {
    fn run(mut self) {
        let ending = self.produce();
        let _ = self.pieces.send(Produced::End(ending));
    }

    /// A buffer the consumer gave back, or a new one.
    fn buffer(&self) -> Vec<u8> {
        let mut buffer = self.spare.try_recv().unwrap_or_default();
        buffer.clear();
        buffer
    }

    /// Passes `piece` on; `false` when the consumer has stopped.
    fn send(&self, piece: Piece) -> bool {
        self.pieces.send(Produced::Piece(piece)).is_ok()
    }

    /// Reads up to the end of the data section or the damage. A consumer that stops early
    /// ends this with `Complete`, which it no longer reads.
    fn produce(&mut self) -> std::io::Result<Ending> {
        let mut zstd = zstd::bulk::Decompressor::new()?;
        let mut body = Vec::new();
        let mut batch = (self.buffer(), Vec::new());
        let damaged = |offset, what: String, file_len| Ok(Ending::Damaged(Damage { offset, what, file_len }));
        loop {
            let start = self.offset;
            let mut head = [0u8; 9];
            let got = read_up_to(&mut self.input, &mut head)?;
            let opcode = head[0];
            let length = u64::from_le_bytes(head[1..].try_into().expect("8 bytes"));
            self.offset += got as u64;
            let remaining = self.file_len.saturating_sub(self.offset);
            let complete = opcode == OP_DATA_END || opcode == OP_FOOTER;
            let ending = if got == 0 {
                Some(damaged(
                    start,
                    "the file ends without its data-end record, summary and footer".into(),
                    self.file_len,
                ))
            } else if got < head.len() {
                Some(damaged(start, format!("the file ends inside a record header ({got} of 9 bytes)"), self.file_len))
            } else if complete {
                Some(Ok(Ending::Complete))
            } else if length > MAX_RECORD {
                Some(damaged(
                    start,
                    format!("record 0x{opcode:02x} claims {length} bytes: a corrupt length"),
                    self.file_len,
                ))
            } else {
                None
            };
            // Records outside chunks go on before a chunk or the end, in file order.
            if (ending.is_some() || opcode == OP_CHUNK) && !batch.0.is_empty() {
                let (bytes, offsets) = std::mem::replace(&mut batch, (self.buffer(), Vec::new()));
                if !self.send(Piece { bytes, kind: Kind::Records { offsets } }) {
                    return Ok(Ending::Complete);
                }
            }
            if let Some(ending) = ending {
                return ending;
            }
            body.clear();
            body.resize(length.min(remaining) as usize, 0);
            let got = read_up_to(&mut self.input, &mut body)?;
            body.truncate(got);
            self.offset += got as u64;
            let cut = (got as u64) < length;
            if opcode == OP_CHUNK {
                self.chunks += 1;
                let piece = if self.chunks.is_multiple_of(2) {
                    let fresh = self.buffer();
                    Piece { bytes: std::mem::replace(&mut body, fresh), kind: Kind::Compressed { start, cut } }
                } else {
                    let mut records = self.buffer();
                    if let Err(what) = chunk(&mut zstd, &body, start, cut, &mut records) {
                        return damaged(start, what, self.file_len);
                    }
                    Piece { bytes: records, kind: Kind::Chunk { start, whole: !cut } }
                };
                if !self.send(piece) {
                    return Ok(Ending::Complete);
                }
                if cut {
                    let what = "the file ends inside this chunk; its complete records were read, but their CRC \
                                cannot be checked";
                    return damaged(start, format!("chunk at byte {start}: {what}"), self.file_len);
                }
            } else if cut {
                let what = format!("the file ends inside record 0x{opcode:02x} ({got} of {length} bytes)");
                return damaged(start, what, self.file_len);
            } else if matches!(opcode, OP_SCHEMA | OP_CHANNEL | OP_MESSAGE | OP_METADATA) {
                batch.0.push(opcode);
                batch.0.extend_from_slice(&length.to_le_bytes());
                batch.0.extend_from_slice(&body);
                batch.1.push(start);
                if batch.0.len() >= BATCH {
                    let (bytes, offsets) = std::mem::replace(&mut batch, (self.buffer(), Vec::new()));
                    if !self.send(Piece { bytes, kind: Kind::Records { offsets } }) {
                        return Ok(Ending::Complete);
                    }
                }
            }
        }
    }
}

/// Why a record could not be used: the file's damage, or the visitor's own error.
enum Stop {
    Damage(String),
    Visitor(LogError),
}

impl From<String> for Stop {
    fn from(what: String) -> Self {
        Stop::Damage(what)
    }
}

/// A chunk record's body (cut short if `cut`), decompressed into `records` and checked
/// against its declared size and CRC when whole; as much as decompresses when cut.
fn chunk(
    zstd: &mut zstd::bulk::Decompressor<'static>,
    body: &[u8],
    start: u64,
    cut: bool,
    records: &mut Vec<u8>,
) -> Result<(), String> {
    let header = match chunk_header(body) {
        Ok(h) => h,
        Err(what) if cut => return Err(format!("the file ends inside a chunk header ({what})")),
        Err(what) => return Err(format!("chunk at byte {start}: {what}")),
    };
    if header.uncompressed_size > MAX_RECORD {
        return Err(format!(
            "chunk at byte {start} claims {} uncompressed bytes: a corrupt length",
            header.uncompressed_size
        ));
    }
    let compressed = &body[header.records_start..];
    let compressed = &compressed[..compressed.len().min(header.records_length as usize)];
    let whole = compressed.len() as u64 == header.records_length;
    let decoded = decompress(zstd, header.compression, compressed, header.uncompressed_size as usize, whole, records);
    if !whole {
        return Ok(());
    }
    decoded.map_err(|what| format!("chunk at byte {start}: {what}"))?;
    if records.len() as u64 != header.uncompressed_size {
        return Err(format!(
            "chunk at byte {start}: {} bytes decompressed, {} declared",
            records.len(),
            header.uncompressed_size
        ));
    }
    if header.crc != 0 && crc32fast::hash(records) != header.crc {
        return Err(format!("chunk at byte {start}: CRC mismatch, the chunk is corrupt"));
    }
    Ok(())
}

/// A chunk's header fields.
struct ChunkHeader<'a> {
    uncompressed_size: u64,
    crc: u32,
    compression: &'a str,
    records_length: u64,
    records_start: usize,
}

fn chunk_header(body: &[u8]) -> Result<ChunkHeader<'_>, String> {
    let mut r = Fields { data: body, at: 0 };
    r.u64()?; // message start time
    r.u64()?; // message end time
    let uncompressed_size = r.u64()?;
    let crc = r.u32()?;
    let compression = r.string()?;
    let records_length = r.u64()?;
    Ok(ChunkHeader { uncompressed_size, crc, compression, records_length, records_start: r.at })
}

/// Decompresses `records` into `out`; when the chunk is cut (`!whole`) as much as can be.
fn decompress(
    zstd: &mut zstd::bulk::Decompressor<'static>,
    compression: &str,
    records: &[u8],
    size: usize,
    whole: bool,
    out: &mut Vec<u8>,
) -> Result<(), String> {
    match compression {
        "" => {
            out.extend_from_slice(records);
            Ok(())
        }
        "zstd" if whole => {
            out.reserve(size);
            zstd.decompress_to_buffer(records, out).map(|_| ()).map_err(|e| format!("zstd: {e}"))
        }
        "zstd" => {
            let decoder = zstd::stream::read::Decoder::with_buffer(records).map_err(|e| format!("zstd: {e}"))?;
            read_what_decodes(decoder, out)
        }
        "lz4" => {
            let decoder = lz4::Decoder::new(records).map_err(|e| format!("lz4: {e}"))?;
            if whole {
                out.reserve(size);
            }
            read_what_decodes(decoder, out)
        }
        other => Err(format!("unknown chunk compression '{other}'")),
    }
}

/// Reads a decoder to its end or its first error, keeping what it gave.
fn read_what_decodes(mut decoder: impl Read, out: &mut Vec<u8>) -> Result<(), String> {
    let mut buf = [0u8; 1 << 16];
    loop {
        match decoder.read(&mut buf) {
            Ok(0) => return Ok(()),
            Ok(n) => out.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.to_string()),
        }
    }
}

/// The first complete record of `data`: its opcode and body.
fn split_record(data: &[u8]) -> Option<(u8, &[u8])> {
    let length = u64::from_le_bytes(data.get(1..9)?.try_into().ok()?);
    let end = 9usize.checked_add(usize::try_from(length).ok()?)?;
    Some((data[0], data.get(9..end)?))
}

/// Parses a record the reader uses and passes it on.
fn dispatch(opcode: u8, body: &[u8], visit: &mut impl FnMut(Record<'_>) -> Result<(), LogError>) -> Result<(), Stop> {
    let mut r = Fields { data: body, at: 0 };
    let record = match opcode {
        OP_MESSAGE => {
            let channel_id = r.u16()?;
            r.u32()?; // sequence
            let log_time = r.u64()?;
            r.u64()?; // publish time
            Record::Message { channel_id, log_time, data: &body[r.at..] }
        }
        OP_SCHEMA => Record::Schema { id: r.u16()?, name: r.string()?, encoding: r.string()?, data: r.bytes()? },
        OP_CHANNEL => {
            Record::Channel { id: r.u16()?, schema_id: r.u16()?, topic: r.string()?, message_encoding: r.string()? }
        }
        OP_METADATA => {
            let name = r.string()?;
            let map_len = r.u32()? as usize;
            let mut map = Fields { data: r.take(map_len)?, at: 0 };
            let mut entries = BTreeMap::new();
            while map.at < map.data.len() {
                entries.insert(map.string()?.to_string(), map.string()?.to_string());
            }
            Record::Metadata { name, entries }
        }
        _ => return Ok(()),
    };
    visit(record).map_err(Stop::Visitor)
}

/// Little-endian fields of a record body.
struct Fields<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Fields<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.data.len());
        let end = end.ok_or_else(|| format!("a field overruns its record ({} bytes)", self.data.len()))?;
        let bytes = &self.data[self.at..end];
        self.at = end;
        Ok(bytes)
    }

    fn u16(&mut self) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2)?.try_into().expect("2 bytes")))
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }

    fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.u32()? as usize;
        self.take(n)
    }

    fn string(&mut self) -> Result<&'a str, String> {
        std::str::from_utf8(self.bytes()?).map_err(|_| "a string is not UTF-8".to_string())
    }
}
