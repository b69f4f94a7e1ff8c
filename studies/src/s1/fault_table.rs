//! `kalfmu s1-faults`: every filter behind the supervisor on S1 with each
//! fault of `s1/faults.rs` injected; prints per run the false rejections,
//! the detection delay, the load error in σ and the recovery after a true
//! step. The runs are independent: they go to both cores, and `--shard K/N`
//! runs every N-th one (from the K-th) for a batch system. `--set` and
//! `--values` change the study's tuning (`s1::Tuning::set`) in every run.

use std::fmt::Write as _;

use estimator::{FilterKind, SupervisorSettings};
use start_values::{SetByName, StartValues};

use crate::s1::faults::{inject, run_with, Fault};
use crate::s1::Tuning;
use crate::shard::{self, Shard};
use truth::s1::{Case, Settings};

/// Command-line arguments of `kalfmu s1-faults`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The case.
    #[arg(long, default_value = "stiffness/random")]
    pub case: Case,
    /// Seed of the load and the noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    #[arg(long, default_value_t = Settings::default().noise_fraction)]
    pub noise: f64,
    /// Only these faults (comma-separated names as printed, e.g. healthy,spikes); all by default.
    #[arg(long, value_delimiter = ',')]
    pub faults: Vec<String>,
    /// Simulated duration in seconds (the faults start at 20 s).
    #[arg(long, default_value_t = 60.0)]
    pub duration: f64,
    /// Gate probability (1 turns the gate off).
    #[arg(long, default_value_t = SupervisorSettings::default().gate_probability)]
    pub gate: f64,
    /// The supervisor as it was before it took jumps and adapted Q: every
    /// failing row rejected, Q as given (`SupervisorSettings::fixed`).
    #[arg(long)]
    pub fixed: bool,
    /// Run only the runs K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Start values over the study's tuning, by the FMU's parameter names (those of
    /// `s1::Tuning`; the chain and the supervisor are not the in-process filter's: the
    /// supervisor has --gate and --fixed).
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// Runs the subcommand.
pub fn run_command(args: &Args) -> anyhow::Result<()> {
    let settings =
        Settings { seed: args.seed, duration: args.duration, noise_fraction: args.noise, ..Settings::default() };
    settings.validate().map_err(anyhow::Error::msg)?;
    if args.duration <= super::faults::FAULT_START {
        anyhow::bail!(
            "the faults start at {} s: the duration must be longer, got {} s",
            super::faults::FAULT_START,
            args.duration
        );
    }
    for name in &args.faults {
        if !Fault::ALL.iter().any(|f| f.to_string() == *name) {
            let names: Vec<String> = Fault::ALL.iter().map(Fault::to_string).collect();
            anyhow::bail!("unknown fault '{name}'; expected one of {}", names.join(", "));
        }
    }
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    // A name or value the tuning refuses costs no run.
    Tuning::new(&settings, [1.0; 2]).set_all(&start_values).map_err(anyhow::Error::msg)?;
    let defaults = if args.fixed { SupervisorSettings::default().fixed() } else { SupervisorSettings::default() };
    let supervision = SupervisorSettings { gate_probability: args.gate, ..defaults };
    supervision.validate()?;
    let jobs: Vec<(Fault, FilterKind)> = Fault::ALL
        .iter()
        .filter(|f| args.faults.is_empty() || args.faults.contains(&f.to_string()))
        .flat_map(|&f| FilterKind::ALL.iter().map(move |&k| (f, k)))
        .collect();
    let results = shard::run(&jobs, args.shard, |&(fault, kind)| {
        let injected = inject(fault, &args.case, &settings);
        run_with(kind, &injected, &args.case, &settings, supervision, &start_values)
    });
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S1 {} with faults from 20 s ({} s, seed {}, noise {:.1} % of RMS, gate probability 1 − {:.0e}); supervisor: {}",
        args.case,
        args.duration,
        args.seed,
        100.0 * args.noise,
        1.0 - args.gate,
        if args.fixed {
            "fixed (every failing row rejected, Q as given: SupervisorSettings::fixed)"
        } else {
            "defaults of estimator::SupervisorSettings (jumps taken, Q adapted)"
        }
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "start values over the study's tuning in every run: {}", start_values.summary());
    }
    let _ = writeln!(
        out,
        "{:<11} {:<8} {:>13} {:>12} {:>7} {:>10} {:>9} {:>10} {:>8} {:>9} {:>7} {:>7}",
        "fault",
        "filter",
        "false rej.",
        "bad rej.",
        "delay",
        "false flt",
        "unhealthy",
        "max |e|/σ",
        "corr",
        "recovery",
        "after",
        "reacq."
    );
    let mut failures = 0;
    for (_, r) in &results {
        if let Some(why) = &r.failure {
            failures += 1;
            let _ = writeln!(out, "{:<11} {:<8} FAILED: {why}", r.fault.to_string(), r.kind.name());
            continue;
        }
        let rate = r.false_rejections as f64 / r.good_rows.max(1) as f64;
        let _ = writeln!(
            out,
            "{:<11} {:<8} {:>5} {:>7.1e} {:>5}/{:<6} {:>7} {:>10} {:>9} {:>10.2} {:>8.5} {:>9} {:>7} {:>7}",
            r.fault.to_string(),
            r.kind.name(),
            r.false_rejections,
            rate,
            r.corrupted_rejected.0,
            r.corrupted_rejected.1,
            r.detection_delay.map_or("—".into(), |d| d.to_string()),
            r.false_fault_samples,
            r.unhealthy_samples,
            r.max_error_sigmas,
            r.correlation,
            r.recovery.map_or("—".into(), |t| format!("{t:.3}s")),
            r.error_after_recovery.map_or("—".into(), |x| format!("{x:.2}")),
            format!("{}/{}", r.reacquisitions, r.undone)
        );
    }
    print!("{out}");
    println!("false rej.: good rows rejected (count, rate); bad rej.: corrupted finite rows rejected / offered; delay: samples from the first corrupted sample to the first flag on its channel");
    println!("false flt: samples a channel was flagged faulty with no corrupted or missing sample in its last fault_after samples; unhealthy: samples inconsistent or lost");
    println!("recovery: from a load step or a burst's last sample until |e| stays within 3σ for 0.5 s; after: a burst's largest |e| from 0.5 s after it, over the RMS error of the 10 s before it; reacq.: re-acquisitions/undone");
    // A filter that fails under a fault is a finding of the study, so it is a row of the
    // table; the command fails only when it cannot run (bad arguments).
    if failures > 0 {
        println!("FAILED: {failures} run(s) stopped with a filter error; the table gives each one's time and reason");
    }
    Ok(())
}
