//! The one error type of reading and analysing logs: every message names the file, and where it
//! applies the channel, the signal and the time.

use std::path::PathBuf;

/// What went wrong reading or analysing a log.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The file could not be read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("{file}: cannot write the MCAP log: {source}")]
    Mcap {
        /// The file.
        file: PathBuf,
        /// What the MCAP writer reported.
        source: mcap::McapError,
    },
    /// The file is not an MCAP file at all.
    #[error("{file}: not an MCAP file (it does not start with the MCAP magic bytes)")]
    NotMcap {
        /// The file.
        file: PathBuf,
    },
    /// The MCAP file is cut short or damaged before anything could be recovered.
    #[error("{file}: a truncated or damaged MCAP file: {what}")]
    Truncated {
        /// The file.
        file: PathBuf,
        /// Where and what.
        what: String,
    },
    /// Every channel with messages is in an encoding the reader does not know.
    #[error("{file}: no channel can be read: {what}")]
    Unreadable {
        /// The file.
        file: PathBuf,
        /// Each channel and why it was skipped.
        what: String,
    },
    /// A channel the analysis needs is not in the log.
    #[error("{file}: channel {channel} is missing (the log has: {present})")]
    MissingChannel {
        /// The file.
        file: PathBuf,
        /// The channel.
        channel: String,
        /// The channels it has.
        present: String,
    },
    /// A channel's schema or encoding is not the log format's.
    #[error("{file}: channel {channel}: {what}")]
    Schema {
        /// The file.
        file: PathBuf,
        /// The channel.
        channel: String,
        /// What does not match.
        what: String,
    },
    /// A message does not match its channel's schema.
    #[error("{file}: channel {channel} at t = {time} s: {what}")]
    Message {
        /// The file.
        file: PathBuf,
        /// The channel.
        channel: String,
        /// Simulation time of the message.
        time: f64,
        /// What is wrong.
        what: String,
    },
    /// Time does not increase within a channel.
    #[error("{file}: channel {channel}: time goes from {previous} s back to {time} s (message {index})")]
    NonMonotonicTime {
        /// The file.
        file: PathBuf,
        /// The channel.
        channel: String,
        /// The earlier time.
        previous: f64,
        /// The time that is not later.
        time: f64,
        /// Index of the message in the channel.
        index: usize,
    },
    /// A signal the analysis uses has a NaN or infinite value.
    #[error("{file}: channel {channel}, signal {signal}: not finite at t = {time} s")]
    NotFinite {
        /// The file.
        file: PathBuf,
        /// The channel.
        channel: String,
        /// The signal.
        signal: String,
        /// Time of the first bad value.
        time: f64,
    },
    /// The analysis cannot be done as asked (pairing, lengths).
    #[error("{file}: {what}")]
    Analysis {
        /// The file.
        file: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// Two runs compared do not share their truth.
    #[error("{file} and {other} do not share their truth, so their estimates cannot be compared: {what}")]
    NotComparable {
        /// The run refused.
        file: PathBuf,
        /// The first run, whose truth the others must share.
        other: PathBuf,
        /// Where the truths part.
        what: String,
    },
    /// The Rerun recording could not be written.
    #[error("{file}: cannot write the Rerun recording: {what}")]
    Rrd {
        /// The `.rrd` file.
        file: PathBuf,
        /// What went wrong.
        what: String,
    },
}
