//! `analyzer`: metrics and recordings from kalfmu MCAP logs.
//!
//! Usage:
//!   analyzer report RUN.mcap… [--json OUT.json] [--rrd OUT.rrd] [--pair truth.X=estimate.Y]… [--estimate-topic /smoothed]…
//!   analyzer compare RUN.mcap…   (the same: several runs of one case, compared)
//!
//! Exit codes: 0 done, 1 the log or the analysis failed (the message names
//! the file, channel and time), 2 bad arguments.

use std::path::PathBuf;
use std::process::ExitCode;

use analyzer::compare::compare_runs;
use analyzer::report::Options;
use analyzer::rrd::write_rrd;
use analyzer::views::views;
use clap::{Parser, Subcommand};
use log_format::read::read_log;
use log_format::LogError;
use rayon::prelude::*;

#[derive(Debug, Parser)]
#[command(name = "analyzer", version, about = "Metrics and recordings from kalfmu MCAP logs")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Pair each run's estimates with the truth, print the metrics of every run in one table
    /// (the best marked), write JSON and one Rerun recording. Runs must share their truth.
    #[command(visible_alias = "compare")]
    Report(ReportArgs),
}

#[derive(Debug, clap::Args)]
struct ReportArgs {
    /// The MCAP logs: one run, or several runs of one case (same truth) to compare.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Write the metrics as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write a Rerun recording (.rrd, for the Rerun viewer 0.41) here.
    #[arg(long)]
    rrd: Option<PathBuf>,
    /// Pair a truth signal with an estimate signal: truth.X=estimate.Y (repeatable).
    #[arg(long = "pair", value_parser = parse_pair)]
    pairs: Vec<(String, String)>,
    /// Running-RMSE window in seconds.
    #[arg(long, default_value_t = 1.0)]
    rmse_window: f64,
    /// Welch segment length in samples.
    #[arg(long, default_value_t = 1024)]
    psd_segment: usize,
    /// The channel of the estimates (e.g. /prediction: an FMU's outputs read right after
    /// each step; /smoothed: its fixed-lag smoothed outputs). Repeated, each log is compared
    /// through each channel, as that many runs (`/estimate` and `/smoothed`: filtered and smoothed).
    #[arg(long, default_values_t = [log_format::write::ESTIMATE.to_string()])]
    estimate_topic: Vec<String>,
    /// Take the metrics, the ±2σ coverage and the spectra from this time (s) on, leaving a
    /// filter's start-up out; the recording still shows the whole run.
    #[arg(long)]
    from: Option<f64>,
}

fn parse_pair(s: &str) -> Result<(String, String), String> {
    let (t, e) = s.split_once('=').ok_or("expected truth.X=estimate.Y")?;
    let t = t.strip_prefix("truth.").ok_or("the left side must be truth.<signal>")?;
    let e = e.strip_prefix("estimate.").ok_or("the right side must be estimate.<signal>")?;
    Ok((t.to_string(), e.to_string()))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: &Cli) -> Result<(), LogError> {
    match &cli.command {
        Command::Report(args) => {
            let logs = args.logs.par_iter().map(|log| read_log(log)).collect::<Result<Vec<_>, _>>()?;
            for warning in logs.iter().flat_map(|run| run.skip_warnings().into_iter().chain(run.recovery_warning())) {
                eprintln!("warning: {warning}");
            }
            let runs = views(&logs, &args.estimate_topic)?;
            let options = Options {
                rmse_window: args.rmse_window,
                psd_segment: args.psd_segment,
                pairs: args.pairs.clone(),
                from: args.from.unwrap_or(f64::NEG_INFINITY),
                ..Options::default()
            };
            let comparison = compare_runs(&runs, &options)?;
            print!("{}", comparison.table());
            if let Some(path) = &args.json {
                comparison.write_json(path)?;
            }
            if let Some(path) = &args.rrd {
                write_rrd(&comparison, &runs, path)?;
            }
            Ok(())
        }
    }
}
