//! `scenarios s1-sweep`: the S1 SRCKF over many seeds and noise levels, to
//! show that the published-case figures are not a lucky draw.

use std::fmt::Write as _;

use estimator::FilterKind;

use crate::s1::{self, Case, Settings};

/// Command-line arguments of `scenarios s1-sweep`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Number of seeds (1 … N).
    #[arg(long, default_value_t = 10)]
    pub seeds: u64,
    /// Accelerometer noise levels, as fractions of each channel's RMS.
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.01, 0.02, 0.05])]
    pub noise: Vec<f64>,
    /// Simulated duration in seconds.
    #[arg(long, default_value_t = 60.0)]
    pub duration: f64,
    /// The filter to sweep.
    #[arg(long, default_value = "SRCKF")]
    pub filter: FilterKind,
}

/// Runs the sweep and prints, per case and noise level, the correlation over
/// the seeds (min, mean) and how many seeds reach the project's goal.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S1 {} over seeds 1..={} ({} s each): correlation of identified vs true load",
        args.filter, args.seeds, args.duration
    );
    let _ =
        writeln!(out, "{:<19} {:>7} {:>9} {:>9} {:>6} {:>12}", "case", "noise", "min", "mean", "goal", "seeds ≥ goal");
    let mut failures = 0;
    for case in Case::ALL {
        for &noise in &args.noise {
            let mut corr = Vec::new();
            for seed in 1..=args.seeds {
                let settings = Settings { seed, noise_fraction: noise, duration: args.duration, ..Settings::default() };
                settings.validate().map_err(anyhow::Error::msg)?;
                let (truth, measurements) = s1::simulate(&case, &settings);
                let run = s1::run_filter(args.filter, &case, &settings, &truth, &measurements);
                match run.comparison {
                    Some(c) => corr.push(c.correlation),
                    None => {
                        failures += 1;
                        eprintln!("{case} noise {noise} seed {seed}: {}", run.failure.unwrap_or_default());
                    }
                }
            }
            let min = corr.iter().copied().fold(f64::INFINITY, f64::min);
            let mean = corr.iter().sum::<f64>() / corr.len().max(1) as f64;
            let goal = case.correlation_goal();
            let met = corr.iter().filter(|&&c| c >= goal).count();
            let _ = writeln!(
                out,
                "{:<19} {:>6.1}% {:>9.5} {:>9.5} {:>6.3} {:>9}/{}",
                case.to_string(),
                100.0 * noise,
                min,
                mean,
                goal,
                met,
                args.seeds
            );
        }
    }
    print!("{out}");
    if failures > 0 {
        anyhow::bail!("{failures} run(s) failed");
    }
    Ok(())
}
