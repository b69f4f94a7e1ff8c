//! `scenarios`: reproduce the published studies, and replay filters on data.
//!
//! Usage:
//!   scenarios reproduce [--study s1] [--quick]
//!   scenarios s1-sweep [--seeds 10] [--noise 0.01,0.02,0.05]
//!   scenarios s1-faults [--case stiffness/random] [--shard K/N]
//!   scenarios s2-sweep [--speeds 40,80,120,160] [--errors 0.05,0.1] [--rates 200,1000] [--seeds 3] [--shard K/N]
//!   scenarios s4-compare [--profile paper|high-speed] [--seeds 1] [--filter SRCKF] [--shard K/N]
//!   scenarios s5-monte-carlo [--runs 100] [--filters SVD-CKF,CKF] [--shard K/N]
//!   scenarios s5-robustness [--seeds 5] [--shard K/N]
//!   scenarios replay < spec.json > estimates.json
//!   scenarios s1-export --case stiffness/random [--duration 60] [--seed 1] [--noise 0.02] --out s1.csv
//!   scenarios s5-export [--duration 20] [--seed 1] --out s5.csv

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
    /// Reproduce the published studies and print our figures beside the papers'.
    Reproduce(scenarios::reproduce::Args),
    /// Study S1 over many seeds and noise levels.
    S1Sweep(scenarios::sweep::Args),
    /// Study S1 with gross measurement errors injected, every filter behind the supervisor.
    S1Faults(scenarios::s1_faults::Args),
    /// Study S2 across speeds, vehicle-parameter errors, sampling rates and track seeds.
    S2Sweep(scenarios::s2::sweep::Args),
    /// Study S4 in-process: the raw average, the paper's pipeline and ours, scored against the truth.
    S4Compare(scenarios::s4::compare::Args),
    /// Study S5's filters over many noise seeds: error spread, consistency, Cramér–Rao.
    S5MonteCarlo(scenarios::s5::monte_carlo::Args),
    /// Study S5's filters where they may fail: tiny R, long runs, no excitation.
    S5Robustness(scenarios::s5::robustness::Args),
    /// Run one filter on measurements given as JSON (stdin), write estimates as JSON (stdout).
    Replay(scenarios::replay::Args),
    /// Write the noisy accelerations and the true load of one S1 case as CSV (an FMU input table).
    S1Export(scenarios::s1::export::Args),
    /// Write the noisy measurements, the deflections and the true coefficients of the S5 flight as CSV.
    S5Export(scenarios::s5::export::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Reproduce(args) => scenarios::reproduce::run(args),
        Command::S1Sweep(args) => scenarios::sweep::run(args),
        Command::S1Faults(args) => scenarios::s1_faults::run_command(args),
        Command::S2Sweep(args) => scenarios::s2::sweep::run(args),
        Command::S4Compare(args) => scenarios::s4::compare::run(args),
        Command::S5MonteCarlo(args) => scenarios::s5::monte_carlo::run(args),
        Command::S5Robustness(args) => scenarios::s5::robustness::run(args),
        Command::Replay(args) => scenarios::replay::run(args),
        Command::S1Export(args) => scenarios::s1::export::run(args),
        Command::S5Export(args) => scenarios::s5::export::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
