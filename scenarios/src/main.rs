//! `scenarios`: reproduce the published studies, and replay filters on data.
//!
//! Usage:
//!   scenarios reproduce [--study s1] [--quick]
//!   scenarios replay < spec.json > estimates.json

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "scenarios", version, about = "Reproduce the kalfmu studies and replay filters on data")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run one filter on measurements given as JSON (stdin), write estimates as JSON (stdout).
    Replay(scenarios::replay::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Replay(args) => scenarios::replay::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
