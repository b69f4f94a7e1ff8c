//! `scenarios reproduce`: runs the studies end to end and prints our figures
//! beside the papers'. Only study S1 exists so far; the others are listed as
//! not built, never skipped silently.

use std::fmt::Write as _;

use anyhow::bail;
use estimator::FilterKind;

use crate::s1::{self, Case, Settings};

/// Command-line arguments of `scenarios reproduce`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which study to run: s1, s2, s3, s4, s5 or all.
    #[arg(long, default_value = "all")]
    pub study: String,
    /// A short run (10 s of signal) for smoke tests; the figures are then not the published set-up.
    #[arg(long)]
    pub quick: bool,
    /// Seed of the random load and of the measurement noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    #[arg(long, default_value_t = Settings::default().noise_fraction)]
    pub noise: f64,
    /// Simulated duration in seconds (default 60, or 10 with --quick).
    #[arg(long)]
    pub duration: Option<f64>,
}

/// The studies of `SCENARIOS.md` and whether they are built.
const STUDIES: [(&str, &str, bool); 5] = [
    ("s1", "dynamic load on a 2-DOF nonlinear chain (SRCKF)", true),
    ("s2", "wheel-rail vertical forces, 10-DOF vehicle (SRCKF)", false),
    ("s3", "left/right wheel-rail forces, 17-DOF vehicle (SRCKF)", false),
    ("s4", "maglev speed from four PRW channels (fusion + UKF)", false),
    ("s5", "missile aerodynamic coefficients (SVD-CKF vs CKF)", false),
];

/// Runs the subcommand; fails if any filter run failed or the study is unknown.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let wanted = args.study.to_ascii_lowercase();
    if wanted != "all" && !STUDIES.iter().any(|(id, _, _)| *id == wanted) {
        bail!("unknown study '{}'; expected one of s1, s2, s3, s4, s5, all", args.study);
    }
    let mut failures = 0;
    for (id, title, built) in STUDIES {
        if wanted != "all" && wanted != id {
            continue;
        }
        if !built {
            println!("{}: {title} — not built yet", id.to_uppercase());
            continue;
        }
        let settings = Settings {
            seed: args.seed,
            noise_fraction: args.noise,
            duration: args.duration.unwrap_or(if args.quick { 10.0 } else { Settings::default().duration }),
            ..Settings::default()
        };
        settings.validate().map_err(anyhow::Error::msg)?;
        failures += report_s1(&settings);
    }
    if failures > 0 {
        bail!("{failures} filter run(s) failed");
    }
    Ok(())
}

/// Prints the S1 table; returns the number of failed runs.
fn report_s1(settings: &Settings) -> usize {
    println!(
        "S1: dynamic load on a 2-DOF nonlinear chain — {} s at {} Hz, truth RK4 at {:.0e} s, accelerometer noise {:.1} % of RMS, seed {}",
        settings.duration,
        settings.rate,
        settings.dt() / settings.truth_substeps() as f64,
        100.0 * settings.noise_fraction,
        settings.seed
    );
    println!(
        "running RMSE over a trailing {} s window; 'converged' = after the convergence time (see scenarios/src/metrics.rs)",
        settings.rmse_window
    );
    let mut table = String::new();
    let _ = writeln!(
        table,
        "{:<19} {:<8} {:>8} {:>7} {:>10} {:>11} {:>8} {:>13} {:>8} {:>7}",
        "case", "filter", "corr", "paper", "RMSE conv", "run. peak", "paper", "run. max conv", "paper", "t_conv"
    );
    let mut failures = 0;
    for case in Case::ALL {
        let (truth, measurements) = s1::simulate(&case, settings);
        let published = case.published();
        for kind in FilterKind::ALL {
            let run = s1::run_filter(kind, &case, settings, &truth, &measurements);
            let paper = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.3}"));
            match (&run.comparison, &run.failure) {
                (Some(c), _) => {
                    let _ = writeln!(
                        table,
                        "{:<19} {:<8} {:>8.5} {:>7.3} {:>10.4} {:>11.3} {:>8} {:>13.4} {:>8} {:>6.2}s",
                        case.to_string(),
                        kind.name(),
                        c.correlation,
                        published.correlation,
                        c.rmse_converged,
                        c.running_rmse_peak,
                        paper(published.running_rmse_peak),
                        c.running_rmse_max_converged,
                        paper(published.running_rmse_max_converged),
                        c.convergence_time
                    );
                }
                (None, failure) => {
                    failures += 1;
                    let why = failure.as_deref().unwrap_or("no result");
                    let _ = writeln!(table, "{:<19} {:<8} FAILED: {why}", case.to_string(), kind.name());
                }
            }
        }
    }
    print!("{table}");
    println!("paper: SRCKF figures of Gong et al. 2024 (correlation; running-RMSE peak; bound after the start), N");
    failures
}
