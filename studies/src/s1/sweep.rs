//! `kalfmu s1-sweep`: the S1 SRCKF over many seeds and noise levels, to
//! show that the published-case figures are not a lucky draw. The runs go to
//! all cores; `--shard K/N` runs a share of them (its table then covers the
//! seeds of that share only). `--set` and `--values` change the study's tuning
//! (`s1::Tuning::set`: its FMU parameter names) in every run.

use std::fmt::Write as _;

use estimator::FilterKind;
use start_values::{SetByName, StartValues};

use crate::s1::{self};
use crate::shard::{self, Shard};
use truth::s1::{Case, Settings};

/// Command-line arguments of `kalfmu s1-sweep`.
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
    /// Run only the runs K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Start values over the study's tuning, by the FMU's parameter names (those of
    /// `s1::Tuning`; the chain and the supervisor are not the in-process filter's).
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// Runs the sweep and prints, per case and noise level, the correlation over
/// the seeds (min, mean) and how many seeds reach the project's goal.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    // A name or value the tuning refuses costs no run.
    s1::Tuning::new(&Settings::default(), [1.0; 2]).set_all(&start_values).map_err(anyhow::Error::msg)?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S1 {} over seeds 1..={} ({} s each): correlation of identified vs true load",
        args.filter, args.seeds, args.duration
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "start values over the study's tuning in every run: {}", start_values.summary());
    }
    let _ =
        writeln!(out, "{:<19} {:>7} {:>9} {:>9} {:>6} {:>12}", "case", "noise", "min", "mean", "goal", "seeds ≥ goal");
    let mut jobs = Vec::new();
    for case in Case::ALL {
        for &noise in &args.noise {
            for seed in 1..=args.seeds {
                let settings = Settings { seed, noise_fraction: noise, duration: args.duration, ..Settings::default() };
                settings.validate().map_err(anyhow::Error::msg)?;
                jobs.push((case, settings));
            }
        }
    }
    let runs = shard::run(&jobs, args.shard, |(case, settings)| {
        let (truth, measurements) = truth::s1::simulate(case, settings);
        s1::run_filter(args.filter, case, settings, &truth, &measurements, &start_values)
    });
    let mut failures = 0;
    for case in Case::ALL {
        for &noise in &args.noise {
            let mut corr = Vec::new();
            let mut seeds = 0;
            for (j, run) in &runs {
                let (c, settings) = &jobs[*j];
                if *c != case || settings.noise_fraction != noise {
                    continue;
                }
                seeds += 1;
                match &run.metrics {
                    Some(metrics) => corr.push(metrics.correlation),
                    None => {
                        failures += 1;
                        eprintln!(
                            "{case} noise {noise} seed {}: {}",
                            settings.seed,
                            run.failure.clone().unwrap_or_default()
                        );
                    }
                }
            }
            if seeds == 0 {
                continue;
            }
            let min = corr.iter().copied().fold(f64::INFINITY, f64::min);
            let mean = corr.iter().sum::<f64>() / corr.len().max(1) as f64;
            let goal = super::correlation_goal(&case);
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
                seeds
            );
        }
    }
    print!("{out}");
    if failures > 0 {
        anyhow::bail!("{failures} run(s) failed");
    }
    Ok(())
}
