//! Times `analyzer report --rrd` on a synthetic log of N samples.
//!
//! Usage:
//!   cargo run --release -p analyzer --example bench_report -- [N] [DIR] [ENCODING]
//!
//! N defaults to 10⁷ and DIR to the system's temporary directory. ENCODING is the
//! messages': `ros1` (the format's own, by its writer; the default), or `json` (with a
//! jsonschema) or `cdr` (with a ros2msg schema) as other tools log them. The log has one
//! `/truth` channel (`x`: two sines) and one `/estimate` channel (`x` = truth plus
//! Gaussian noise of σ = 0.05 from a fixed-seed generator, and `x_std` = 0.05), sampled at
//! 1 kHz. Prints the time to write the log, to read and analyse it (the median and the best
//! of five, with samples/s), and
//! to write the `.rrd`, with both file sizes. For peak memory run it under `/usr/bin/time -v`;
//! for the figure on one core, under `taskset -c 0`.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

use analyzer::compare::compare_runs;
use analyzer::report::Options;
use analyzer::rrd::write_rrd;
use log_format::read::read_log;
use log_format::write::{ChannelId, LogWriter, SignalSpec, ESTIMATE, METADATA, TRUTH};

/// Sampling rate of the synthetic log (Hz).
const RATE: f64 = 1000.0;
/// σ of the estimate's noise.
const NOISE: f64 = 0.05;
/// Times read + analyse is timed.
const REPEATS: usize = 5;

/// xorshift64* with Box–Muller: Gaussian samples, the same on every run.
struct Gaussian(u64);

impl Gaussian {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn sample(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// The synthetic log's writer, in one of the encodings the reader reads.
enum Sink {
    /// The format's own writer.
    Ros1 { writer: LogWriter, truth: ChannelId, estimate: ChannelId },
    /// An MCAP writer with JSON or CDR messages, as Python's `mcap` or a ROS 2 bag has them.
    Foreign { writer: mcap::Writer<BufWriter<File>>, truth: u16, estimate: u16, cdr: bool, sequence: u32 },
}

impl Sink {
    fn create(path: &Path, encoding: &str) -> Result<Self, Box<dyn std::error::Error>> {
        let metadata = BTreeMap::from([("study".to_string(), "bench_report".to_string())]);
        if encoding == "ros1" {
            let mut writer = LogWriter::create(path, &metadata)?;
            let truth = writer.add_channel(TRUTH, &[SignalSpec::new("x", "m", "position")])?;
            let estimate = writer.add_channel(
                ESTIMATE,
                &[SignalSpec::new("x", "m", "estimated position"), SignalSpec::new("x_std", "m", "its deviation")],
            )?;
            return Ok(Sink::Ros1 { writer, truth, estimate });
        }
        let cdr = match encoding {
            "json" => false,
            "cdr" => true,
            other => return Err(format!("ENCODING must be ros1, json or cdr, not '{other}'").into()),
        };
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .compression_level(1)
            .create(BufWriter::new(File::create(path)?))?;
        writer.write_metadata(&mcap::records::Metadata { name: METADATA.into(), metadata })?;
        let mut channel = |topic: &str, fields: &[&str]| -> Result<u16, mcap::McapError> {
            let (name, schema_encoding, schema) = if cdr {
                let text: String = fields.iter().map(|f| format!("float64 {f}  # [m]\n")).collect();
                (format!("bench/msg/{}", &topic[1..]), "ros2msg", text)
            } else {
                let properties: Vec<String> =
                    fields.iter().map(|f| format!(r#""{f}": {{"type": "number", "unit": "m"}}"#)).collect();
                (
                    topic[1..].to_string(),
                    "jsonschema",
                    format!(r#"{{"type": "object", "properties": {{{}}}}}"#, properties.join(", ")),
                )
            };
            let schema = writer.add_schema(&name, schema_encoding, schema.as_bytes())?;
            writer.add_channel(schema, topic, if cdr { "cdr" } else { "json" }, &BTreeMap::new())
        };
        let truth = channel(TRUTH, &["x"])?;
        let estimate = channel(ESTIMATE, &["x", "x_std"])?;
        Ok(Sink::Foreign { writer, truth, estimate, cdr, sequence: 0 })
    }

    fn write(&mut self, t: f64, truth: f64, estimate: f64) -> Result<(), Box<dyn std::error::Error>> {
        match self {
            Sink::Ros1 { writer, truth: truth_channel, estimate: estimate_channel } => {
                writer.write(*truth_channel, t, &[truth])?;
                writer.write(*estimate_channel, t, &[estimate, NOISE])?;
            }
            Sink::Foreign { writer, truth: truth_channel, estimate: estimate_channel, cdr, sequence } => {
                let nanos = (t * 1e9).round() as u64;
                for (channel_id, values) in
                    [(*truth_channel, &[truth][..]), (*estimate_channel, &[estimate, NOISE][..])]
                {
                    let data = if *cdr {
                        let mut data = vec![0, 1, 0, 0];
                        values.iter().for_each(|v| data.extend_from_slice(&v.to_le_bytes()));
                        data
                    } else if values.len() == 1 {
                        format!(r#"{{"x": {}}}"#, values[0]).into_bytes()
                    } else {
                        format!(r#"{{"x": {}, "x_std": {}}}"#, values[0], values[1]).into_bytes()
                    };
                    let header = mcap::records::MessageHeader {
                        channel_id,
                        sequence: *sequence,
                        log_time: nanos,
                        publish_time: nanos,
                    };
                    writer.write_to_known_channel(&header, &data)?;
                }
                *sequence = sequence.wrapping_add(1);
            }
        }
        Ok(())
    }

    fn finish(self) -> Result<(), Box<dyn std::error::Error>> {
        match self {
            Sink::Ros1 { writer, .. } => writer.finish()?,
            Sink::Foreign { mut writer, .. } => {
                writer.finish()?;
            }
        }
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n_samples: usize = match args.next() {
        Some(n) => n.parse().map_err(|e| format!("N must be a count of samples: {e}"))?,
        None => 10_000_000,
    };
    let dir = args.next().map_or_else(std::env::temp_dir, PathBuf::from);
    let encoding = args.next().unwrap_or_else(|| "ros1".into());
    let log = dir.join(match encoding.as_str() {
        "ros1" => format!("bench_report_{n_samples}.mcap"),
        other => format!("bench_report_{n_samples}_{other}.mcap"),
    });
    let rrd = log.with_extension("rrd");
    let size = |p: &PathBuf| std::fs::metadata(p).map(|m| m.len() as f64 / 1e6).unwrap_or(f64::NAN);

    let start = Instant::now();
    let mut writer = Sink::create(&log, &encoding)?;
    let mut noise = Gaussian(0x9e37_79b9_7f4a_7c15);
    for k in 0..n_samples {
        let t = k as f64 / RATE;
        let truth = (2.0 * std::f64::consts::PI * 0.5 * t).sin() + 0.3 * (2.0 * std::f64::consts::PI * 7.0 * t).sin();
        writer.write(t, truth, truth + NOISE * noise.sample())?;
    }
    writer.finish()?;
    let write_s = start.elapsed().as_secs_f64();
    // The kernel's write-back of the new log would otherwise run during the reads timed below.
    std::fs::File::open(&log)?.sync_all()?;
    println!("write log:      {write_s:8.2} s  {:9.1} MB  {}", size(&log), log.display());

    // Read + analyse, as `analyzer report` does, REPEATS times: the median and the best,
    // because a 0.2 s figure on a shared machine varies by a third from run to run.
    let mut timings = Vec::new();
    for _ in 0..REPEATS {
        let start = Instant::now();
        let runs = [read_log(&log)?];
        let read_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        compare_runs(&runs, &Options::default())?;
        timings.push((read_s, start.elapsed().as_secs_f64()));
    }
    timings.sort_by(|a, b| (a.0 + a.1).total_cmp(&(b.0 + b.1)));
    for (which, (read_s, analyse_s)) in [("median", timings[REPEATS / 2]), ("best", timings[0])] {
        println!(
            "read + analyse: {:8.3} s  ({read_s:.3} s + {analyse_s:.3} s)  {:.3e} samples/s  ({which} of {REPEATS})",
            read_s + analyse_s,
            n_samples as f64 / (read_s + analyse_s)
        );
    }
    let runs = [read_log(&log)?];
    let comparison = compare_runs(&runs, &Options::default())?;

    let start = Instant::now();
    write_rrd(&comparison, &runs, &rrd)?;
    let rrd_s = start.elapsed().as_secs_f64();
    println!("write rrd:      {rrd_s:8.2} s  {:9.1} MB  {}", size(&rrd), rrd.display());
    print!("{}", comparison.table());
    Ok(())
}
