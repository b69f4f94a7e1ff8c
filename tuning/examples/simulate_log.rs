//! Writes a log to tune from, laid out as the studies write theirs, from S1's or S2's
//! truth simulator (no FMU run, no truth needed by the fit):
//!
//! ```sh
//! cargo run --release -p tuning --example simulate_log -- s2 60 s2_60s.mcap
//! ```
//!
//! Arguments: the study (`s1` or `s2`), the seconds, the output path, and optionally the
//! seed (default 1) and the noise fraction of each channel's RMS (default 0.02).

#[path = "../tests/support/simulated_logs.rs"]
mod simulated_logs;

use std::path::Path;

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: simulate_log s1|s2 SECONDS OUT.mcap [SEED] [NOISE_FRACTION]";
    let [study, seconds, out, rest @ ..] = args.as_slice() else { return Err(usage.into()) };
    let seconds: f64 = seconds.parse().map_err(|_| usage.to_string())?;
    let seed: u64 = rest.first().map_or(Ok(1), |s| s.parse()).map_err(|_| usage.to_string())?;
    let fraction: f64 = rest.get(1).map_or(Ok(0.02), |s| s.parse()).map_err(|_| usage.to_string())?;
    let clock = std::time::Instant::now();
    let noise: Vec<f64> = match study.as_str() {
        "s1" => simulated_logs::write_s1(Path::new(out), seconds, seed, fraction)?.to_vec(),
        "s2" => simulated_logs::write_s2(Path::new(out), seconds, seed, fraction)?.to_vec(),
        _ => return Err(usage.into()),
    };
    println!(
        "wrote {out}: {study}, {seconds} s, seed {seed}, sensor noise std {noise:?} ({:.1} s)",
        clock.elapsed().as_secs_f64()
    );
    Ok(())
}
