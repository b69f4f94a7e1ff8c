//! Times `analyzer report --rrd` on a synthetic log of N samples.
//!
//! Usage:
//!   cargo run --release -p analyzer --example bench_report -- [N] [DIR]
//!
//! N defaults to 10⁷ and DIR to the system's temporary directory. The log has one
//! `/truth` channel (`x`: two sines) and one `/estimate` channel (`x` = truth plus
//! Gaussian noise of σ = 0.05 from a fixed-seed generator, and `x_std` = 0.05), sampled at
//! 1 kHz. Prints the time to write the log, to read and analyse it (the median and the best
//! of five, with samples/s), and
//! to write the `.rrd`, with both file sizes. For peak memory run it under `/usr/bin/time -v`;
//! for the figure on one core, under `taskset -c 0`.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use analyzer::compare::compare_runs;
use analyzer::log::{LogWriter, SignalSpec, ESTIMATE, TRUTH};
use analyzer::read::read_log;
use analyzer::report::Options;
use analyzer::rrd::write_rrd;

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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n_samples: usize = match args.next() {
        Some(n) => n.parse().map_err(|e| format!("N must be a count of samples: {e}"))?,
        None => 10_000_000,
    };
    let dir = args.next().map_or_else(std::env::temp_dir, PathBuf::from);
    let log = dir.join(format!("bench_report_{n_samples}.mcap"));
    let rrd = log.with_extension("rrd");
    let size = |p: &PathBuf| std::fs::metadata(p).map(|m| m.len() as f64 / 1e6).unwrap_or(f64::NAN);

    let start = Instant::now();
    let metadata = BTreeMap::from([("study".to_string(), "bench_report".to_string())]);
    let mut writer = LogWriter::create(&log, &metadata)?;
    let truth_channel = writer.add_channel(TRUTH, &[SignalSpec::new("x", "m", "position")])?;
    let estimate_channel = writer.add_channel(
        ESTIMATE,
        &[SignalSpec::new("x", "m", "estimated position"), SignalSpec::new("x_std", "m", "its deviation")],
    )?;
    let mut noise = Gaussian(0x9e37_79b9_7f4a_7c15);
    for k in 0..n_samples {
        let t = k as f64 / RATE;
        let truth = (2.0 * std::f64::consts::PI * 0.5 * t).sin() + 0.3 * (2.0 * std::f64::consts::PI * 7.0 * t).sin();
        writer.write(truth_channel, t, &[truth])?;
        writer.write(estimate_channel, t, &[truth + NOISE * noise.sample(), NOISE])?;
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
