//! `kalfmu`: reproduce the published studies, and replay filters on data.
//!
//! Usage:
//!   kalfmu reproduce [--study s1] [--quick]
//!   kalfmu s1-sweep [--seeds 10] [--noise 0.01,0.02,0.05]
//!   kalfmu s1-faults [--case stiffness/random] [--shard K/N]
//!   kalfmu s2-sweep [--speeds 40,80,120,160] [--errors 0.05,0.1] [--rates 200,1000] [--seeds 3] [--shard K/N]
//!   kalfmu s3-sweep [--cases random,joint] [--speeds 40,80,120,160] [--errors 0.1] [--rates 200,1000] [--seeds 3] [--shard K/N]
//!   kalfmu s4-compare [--profile paper|high-speed] [--seeds 1] [--filter SRCKF] [--shard K/N]
//!   kalfmu s5-monte-carlo [--runs 100] [--filters SVD-CKF,CKF] [--shard K/N]
//!   kalfmu s5-robustness [--seeds 5] [--shard K/N]
//!   kalfmu replay < spec.json > estimates.json
//!   kalfmu s1-export --case stiffness/random [--duration 60] [--seed 1] [--noise 0.02] --out s1.csv
//!   kalfmu s5-export [--duration 20] [--seed 1] --out s5.csv

mod replay;
mod reproduce;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "kalfmu", version, about = "Reproduce the kalfmu studies and replay filters on data")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Reproduce the published studies and print our figures beside the papers'.
    Reproduce(reproduce::Args),
    /// Study S1 over many seeds and noise levels.
    S1Sweep(studies::s1::sweep::Args),
    /// Study S1 with gross measurement errors injected, every filter behind the supervisor.
    S1Faults(studies::s1::fault_table::Args),
    /// Every estimator FMU through random fault episodes: recovery, error after, false flags, health.
    Robustness(studies::robustness::Args),
    /// Study S2 across speeds, vehicle-parameter errors, sampling rates and track seeds.
    S2Sweep(studies::s2::sweep::Args),
    /// Study S3 across speeds, the user's car-body mass, roll inertia and primary stiffness, rates and seeds.
    S3Sweep(studies::s3::sweep::Args),
    /// Study S4 in-process: the raw average, the paper's pipeline and ours, scored against the truth.
    S4Compare(studies::s4::compare::Args),
    /// Study S5's filters over many noise seeds: error spread, consistency, Cramér–Rao.
    S5MonteCarlo(studies::s5::monte_carlo::Args),
    /// Study S5's filters where they may fail: tiny R, long runs, no excitation.
    S5Robustness(studies::s5::robustness::Args),
    /// Run one filter on measurements given as JSON (stdin), write estimates as JSON (stdout).
    Replay(replay::Args),
    /// Write the noisy accelerations and the true load of one S1 case as CSV (an FMU input table).
    S1Export(studies::s1::export::Args),
    /// Write one S1 case as an SSP system: the plant FMU wired to the estimator FMU, with its parameter set.
    S1System(studies::s1::system::Args),
    /// Write one S2 case as an SSP system: the plant FMU wired to the estimator FMU, with its parameter set.
    S2System(studies::s2::system::Args),
    /// Write one S5 flight as an SSP system: the plant FMU wired to the estimator FMU, with its parameter set.
    S5System(studies::s5::system::Args),
    /// Write the noisy measurements, the deflections and the true coefficients of the S5 flight as CSV.
    S5Export(studies::s5::export::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Reproduce(args) => reproduce::run(args),
        Command::S1Sweep(args) => studies::s1::sweep::run(args),
        Command::S1Faults(args) => studies::s1::fault_table::run_command(args),
        Command::Robustness(args) => studies::robustness::run_command(args),
        Command::S2Sweep(args) => studies::s2::sweep::run(args),
        Command::S3Sweep(args) => studies::s3::sweep::run(args),
        Command::S4Compare(args) => studies::s4::compare::run(args),
        Command::S5MonteCarlo(args) => studies::s5::monte_carlo::run(args),
        Command::S5Robustness(args) => studies::s5::robustness::run(args),
        Command::Replay(args) => replay::run(args),
        Command::S1Export(args) => studies::s1::export::run(args),
        Command::S1System(args) => studies::s1::system::run(args),
        Command::S2System(args) => studies::s2::system::run(args),
        Command::S5System(args) => studies::s5::system::run(args),
        Command::S5Export(args) => studies::s5::export::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
