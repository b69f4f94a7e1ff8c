//! `kalfmu s2-sweep`: how the S2 estimate degrades, with no retuning, across speeds,
//! errors in the user's car-body mass and primary stiffness, the sampling rate and the
//! random track's seed. The runs go to all cores; `--shard K/N` runs a share of them.
//! `--set` and `--values` change the study's tuning (`study::Tuning::set`: its FMU
//! parameter names) in every run; the vehicle is the sweep's own variable.

use std::fmt::Write as _;

use estimator::FilterKind;
use start_values::{SetByName, StartValues};

use super::study::{run_filter, score, user_vehicle, Tuning};
use crate::shard::{self, Shard};
use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
use truth::s2::parameters::Vehicle;

/// Command-line arguments of `kalfmu s2-sweep`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Speeds (km/h).
    #[arg(long, value_delimiter = ',', default_values_t = vec![40.0, 80.0, 120.0, 160.0])]
    pub speeds: Vec<f64>,
    /// Relative errors of the user's car-body mass and, separately, primary stiffness
    /// against the car as built, each applied as too low and too high.
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.05, 0.10])]
    pub errors: Vec<f64>,
    /// Sampling rates (Hz).
    #[arg(long, value_delimiter = ',', default_values_t = vec![200.0, 1000.0])]
    pub rates: Vec<f64>,
    /// Number of random-track seeds (1 … N).
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Simulated time per run (s).
    #[arg(long, default_value_t = 4.0)]
    pub duration: f64,
    /// The filter.
    #[arg(long, default_value = "SRCKF")]
    pub filter: FilterKind,
    /// Run only the runs K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Start values over the study's tuning, by the FMU's parameter names (those of
    /// `s2::study::Tuning`; the vehicle's and the supervisor's are not the in-process
    /// filter's). A value is the FMU's, so the same at every rate: `q_body_std` is a std
    /// per sample, where the study's own comes from an intensity per second.
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// What the user has of the vehicle: the catalogue (which is not the car as built), or the
/// catalogue with the car body's mass or the primary stiffness the as-built value off by a
/// relative error.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Variant {
    Catalogue,
    CarBodyMass(f64),
    PrimaryStiffness(f64),
}

impl Variant {
    fn name(&self) -> String {
        match self {
            Variant::Catalogue => "catalogue".into(),
            Variant::CarBodyMass(e) => format!("m_c {:+.0} %", 100.0 * e),
            Variant::PrimaryStiffness(e) => format!("K_p {:+.0} %", 100.0 * e),
        }
    }

    fn vehicle(&self) -> Vehicle {
        let mut v = Vehicle::ZHAI_PASSENGER;
        match self {
            Variant::Catalogue => {}
            Variant::CarBodyMass(e) => v.car_body_mass = as_built().car_body_mass * (1.0 + e),
            Variant::PrimaryStiffness(e) => v.primary_stiffness = as_built().primary_stiffness * (1.0 + e),
        }
        v
    }
}

/// One row of the table: the runs of every seed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Row {
    case: Case,
    speed: f64,
    rate: f64,
    variant: Variant,
}

/// One run of the grid.
#[derive(Debug, Clone, Copy)]
struct Job {
    row: Row,
    seed: u64,
}

/// Runs the sweep and prints one table: per case, rate, speed and vehicle variant, the
/// worst wheel's correlation (min and mean over the seeds) and RMSE over the dynamic σ.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    // A name or value the tuning refuses costs no run.
    Tuning::new(&Settings::default(), [1.0; 7]).set_all(&start_values).map_err(anyhow::Error::msg)?;
    let mut variants = vec![Variant::Catalogue];
    let signed: Vec<f64> = args.errors.iter().flat_map(|&e| [-e, e]).collect();
    variants.extend(signed.iter().map(|&e| Variant::CarBodyMass(e)));
    variants.extend(signed.iter().map(|&e| Variant::PrimaryStiffness(e)));
    let mut jobs = Vec::new();
    for case in Case::ALL {
        for &rate in &args.rates {
            for &speed in &args.speeds {
                // The parameter errors at 80 km/h only; the speeds with the catalogue.
                for &variant in &variants {
                    if variant != Variant::Catalogue && speed != 80.0 {
                        continue;
                    }
                    for seed in 1..=args.seeds {
                        jobs.push(Job { row: Row { case, speed, rate, variant }, seed });
                    }
                }
            }
        }
    }
    let results = shard::run(&jobs, args.shard, |&Job { row, seed }| {
        let settings =
            Settings { speed: row.speed / 3.6, rate: row.rate, duration: args.duration, seed, ..Settings::default() };
        let truth = simulate(row.case, &settings);
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let vehicle = user_vehicle(&row.variant.vehicle(), as_built().static_wheel_load());
        let mut tuning = Tuning::new(&settings, measurements.noise_std);
        tuning.set_all(&start_values)?;
        run_filter(args.filter, vehicle, &tuning, &measurements).map(|e| score(&truth, &e, settings.rate, 0.5))
    });
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S2 {} on the as-built car (car body 36 t, primary 0.578 MN/m); the user has the catalogue car (34 t, \
         0.550 MN/m), or it with the car-body mass m_c or the primary stiffness K_p the as-built value off by the \
         error shown; seeds 1..={}, {} s per run; worst of the four wheels after 0.5 s",
        args.filter, args.seeds, args.duration
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "start values over the study's tuning in every run: {}", start_values.summary());
    }
    let _ = writeln!(
        out,
        "{:<12} {:>6} {:>7} {:<10} {:>6} {:>9} {:>9} {:>12}",
        "case", "Hz", "km/h", "vehicle", "runs", "corr min", "corr mean", "RMSE/σ max"
    );
    let mut failures = 0;
    // A row's seeds are consecutive jobs, and the results keep the jobs' order.
    for runs in results.chunk_by(|a, b| jobs[a.0].row == jobs[b.0].row) {
        let Row { case, speed, rate, variant } = jobs[runs[0].0].row;
        let label = format!("{:<12} {rate:>6} {speed:>7} {:<10}", case.name(), variant.name());
        let mut correlations = Vec::new();
        let mut worst_ratio: f64 = 0.0;
        for (j, result) in runs {
            match result {
                Ok(scores) => {
                    correlations.push(scores.iter().map(|s| s.correlation).fold(f64::INFINITY, f64::min));
                    worst_ratio = scores.iter().map(|s| s.rmse / s.dynamic_std).fold(worst_ratio, f64::max);
                }
                Err(e) => {
                    failures += 1;
                    let _ = writeln!(out, "{label} FAILED (seed {}): {e}", jobs[*j].seed);
                }
            }
        }
        if correlations.is_empty() {
            continue;
        }
        let min = correlations.iter().copied().fold(f64::INFINITY, f64::min);
        let mean = correlations.iter().sum::<f64>() / correlations.len() as f64;
        let _ = writeln!(out, "{label} {:>6} {min:>9.4} {mean:>9.4} {worst_ratio:>12.2}", correlations.len());
    }
    print!("{out}");
    if failures > 0 {
        anyhow::bail!("{failures} run(s) failed");
    }
    Ok(())
}
