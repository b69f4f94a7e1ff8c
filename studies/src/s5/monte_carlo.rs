//! `kalfmu s5-monte-carlo`: the S5 filters over many noise seeds with one tuning, on
//! both cores (`--shard K/N` runs a share). For each filter and coefficient, at the end of
//! each half (just before the change, and at the end): the spread of the error over the
//! runs, its RMSE against the Cramér–Rao bound of the run's information, and the
//! consistency of the filter's covariance (the coefficients' NEES, whose mean over the runs
//! should be 10). `--set`/`--values` change the tuning by the FMU's parameter names
//! ([`Tuning::set`]).

use std::fmt::Write as _;

use estimator::FilterKind;

use super::excitation::cramer_rao;
use super::study::{run_filter, Tuning};
use crate::shard::{self, Shard};
use start_values::{SetByName, StartValues};
use truth::s5::flight::{flight, measure, simulate, Settings};
use truth::s5::parameters::NAMES;

/// Command-line arguments of `kalfmu s5-monte-carlo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Noise seeds 1 … N.
    #[arg(long, default_value_t = 100)]
    pub runs: u64,
    /// The filters (the paper compares SVD-CKF and CKF).
    #[arg(long, value_delimiter = ',', default_values_t = vec![FilterKind::SvdCkf, FilterKind::Ckf])]
    pub filters: Vec<FilterKind>,
    /// The sensors' noise scaled by this.
    #[arg(long, default_value_t = 1.0)]
    pub noise_scale: f64,
    /// Run only the runs K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// The tuning, by the FMU's parameter names, over the study's (`--set
    /// q_coefficient_relative_std=1e-4`); a name the in-process filter does not take is an
    /// error.
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// One run: the filter and the noise seed.
#[derive(Debug, Clone, Copy)]
struct Job {
    filter: FilterKind,
    seed: u64,
}

/// What one run leaves at one checkpoint: the coefficients' errors, their σ and the NEES.
#[derive(Debug, Clone, Copy)]
struct AtCheckpoint {
    error: [f64; 10],
    nees: f64,
}

/// Runs the Monte Carlo and prints one table per checkpoint.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    let mut tuning = Tuning::new(args.noise_scale);
    // Before the flight is flown: a misspelt name costs no run.
    tuning.set_all(&start_values).map_err(anyhow::Error::msg)?;
    let settings = Settings { noise_scale: args.noise_scale, ..Settings::default() };
    let truth = simulate(&settings);
    let half = (truth.time.len() - 1) / 2;
    // Just before the change (the last sample under the first coefficients) and the end.
    let checkpoints = [half - 1, truth.time.len() - 1];
    let f = flight();
    let bounds = [(0, half), (half, truth.time.len() - half)].map(|(first, count)| {
        cramer_rao(
            &f,
            &truth.motion[first],
            first,
            count,
            settings.sample_time,
            settings.truth_substeps,
            args.noise_scale,
        )
    });
    let jobs: Vec<Job> =
        args.filters.iter().flat_map(|&filter| (1..=args.runs).map(move |seed| Job { filter, seed })).collect();
    let results = shard::run(&jobs, args.shard, |job| {
        let z = measure(&truth, args.noise_scale, job.seed);
        run_filter(job.filter, &tuning, &truth, &z, settings.sample_time, &checkpoints).map(|e| {
            e.covariance_at
                .iter()
                .map(|(k, p)| {
                    let error: [f64; 10] = std::array::from_fn(|i| e.coefficients[*k][i] - truth.coefficients[*k][i]);
                    let v = nalgebra::DVector::from_row_slice(&error);
                    let nees = p.clone().cholesky().map_or(f64::NAN, |c| v.dot(&c.solve(&v)));
                    AtCheckpoint { error, nees }
                })
                .collect::<Vec<_>>()
        })
    });
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S5 Monte Carlo: {} noise seeds per filter, one tuning, sensor noise × {}; errors of each coefficient at the checkpoint",
        args.runs, args.noise_scale
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "tuning with the start values {}", start_values.summary());
    }
    let mut failures = 0;
    for (c, (label, &k)) in ["before the change (9.995 s)", "at the end (20 s)"].iter().zip(&checkpoints).enumerate() {
        let _ = writeln!(out, "\n{label}:");
        let _ = writeln!(
            out,
            "{:<8} {:<5} {:>9} {:>10} {:>10} {:>10} {:>9} {:>8} {:>9}",
            "filter", "coef", "true", "mean err", "std err", "max |err|", "RMSE", "CRB σ", "RMSE/CRB"
        );
        for &filter in &args.filters {
            let runs: Vec<&AtCheckpoint> = results
                .iter()
                .filter(|(j, _)| jobs[*j].filter == filter)
                .filter_map(|(j, r)| match r {
                    Ok(at) => Some(&at[c]),
                    Err(e) => {
                        if c == 0 {
                            failures += 1;
                            let _ = writeln!(out, "{filter} seed {} FAILED: {e}", jobs[*j].seed);
                        }
                        None
                    }
                })
                .collect();
            if runs.is_empty() {
                continue;
            }
            let n = runs.len() as f64;
            for i in 0..10 {
                let e: Vec<f64> = runs.iter().map(|r| r.error[i]).collect();
                let mean = e.iter().sum::<f64>() / n;
                let std = (e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
                let rmse = (e.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
                let max = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let crb = bounds[c].map_or(f64::NAN, |b| b[10 + i]);
                let _ = writeln!(
                    out,
                    "{:<8} {:<5} {:>9.4} {:>+10.2e} {:>10.2e} {:>10.2e} {:>9.2e} {:>8.1e} {:>9.1}",
                    filter.name(),
                    NAMES[i],
                    truth.coefficients[k][i],
                    mean,
                    std,
                    max,
                    rmse,
                    crb,
                    rmse / crb
                );
            }
            let nees: Vec<f64> = runs.iter().map(|r| r.nees).collect();
            let mean_nees = nees.iter().sum::<f64>() / n;
            // The 95 % interval of the mean of n χ²(10) variables: 10 ± 1.96·√(20/n).
            let half_width = 1.96 * (20.0 / n).sqrt();
            let _ = writeln!(
                out,
                "{:<8} NEES of the 10 coefficients: mean {mean_nees:.2} over {} runs (consistent: {:.2} to {:.2})",
                filter.name(),
                runs.len(),
                10.0 - half_width,
                10.0 + half_width
            );
        }
    }
    print!("{out}");
    if failures > 0 {
        anyhow::bail!("{failures} run(s) failed");
    }
    Ok(())
}
