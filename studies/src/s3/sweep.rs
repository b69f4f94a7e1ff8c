//! `kalfmu s3-sweep`: how the S3 estimate of the left and right forces degrades, with no
//! retuning, across speeds, errors in the user's car-body mass, car-body roll inertia and
//! primary stiffness, the sampling rate and the track's seed; each run with the
//! accelerations alone and with the primary deflections too. The runs go to all cores;
//! `--shard K/N` runs a share of them. `--set` and `--values` change the study's tuning
//! (`study::Tuning::set`: its FMU parameter names) in every run; the vehicle is the sweep's
//! own variable.

use std::fmt::Write as _;

use estimator::models::RollVehicle;
use estimator::FilterKind;
use start_values::{SetByName, StartValues};

use super::study::{run_filter, score, user_vehicle, ForceModel, Sensors, Tuning, WheelsetScore};
use crate::shard::{self, Shard};
use truth::s3::cases::{as_built, measure, simulate, Case, Measurements, Settings};

/// Command-line arguments of `kalfmu s3-sweep`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Cases: random, joint, twist, random_alignment.
    #[arg(long, value_delimiter = ',', default_values_t = Case::ALL.to_vec())]
    pub cases: Vec<Case>,
    /// Speeds (km/h).
    #[arg(long, value_delimiter = ',', default_values_t = vec![40.0, 80.0, 120.0, 160.0])]
    pub speeds: Vec<f64>,
    /// Relative errors of the user's car-body mass, car-body roll inertia and primary
    /// stiffness against the car as built, each alone, applied as too low and too high (at
    /// 80 km/h).
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.10])]
    pub errors: Vec<f64>,
    /// Sampling rates (Hz).
    #[arg(long, value_delimiter = ',', default_values_t = vec![200.0, 1000.0])]
    pub rates: Vec<f64>,
    /// Number of track and noise seeds (2 … N + 1: the study's tuning was chosen on seed 1,
    /// `study::Tuning::CHOSEN_ON_SEED`).
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
    /// `s3::study::Tuning`: the vehicle's are the sweep's own variable).
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// What the user has of the car: the catalogue (which is not the car as built), or the
/// catalogue with one value the as-built one off by a relative error.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Variant {
    Catalogue,
    CarBodyMass(f64),
    CarBodyRollInertia(f64),
    PrimaryStiffness(f64),
}

impl Variant {
    fn name(&self) -> String {
        match self {
            Variant::Catalogue => "catalogue".into(),
            Variant::CarBodyMass(e) => format!("m_c {:+.0} %", 100.0 * e),
            Variant::CarBodyRollInertia(e) => format!("I_cx {:+.0} %", 100.0 * e),
            Variant::PrimaryStiffness(e) => format!("K_p {:+.0} %", 100.0 * e),
        }
    }

    /// The user's car, with the static wheel load as weighed on the car as built.
    fn vehicle(&self) -> RollVehicle {
        let built = as_built();
        let mut v = user_vehicle(built.static_wheel_load());
        match *self {
            Variant::Catalogue => {}
            Variant::CarBodyMass(e) => v.car_body_mass = built.vertical.car_body_mass * (1.0 + e),
            Variant::CarBodyRollInertia(e) => v.car_body_roll_inertia = built.car_body_roll_inertia * (1.0 + e),
            Variant::PrimaryStiffness(e) => v.primary_stiffness = built.vertical.primary_stiffness * (1.0 + e),
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

/// The worst wheelset of a run: the lowest correlations of left, right, sum and
/// difference, and the lowest share inside ±2σ of the three.
fn worst(scores: &[WheelsetScore; 4]) -> [f64; 5] {
    let min = |f: &dyn Fn(&WheelsetScore) -> f64| scores.iter().map(f).fold(f64::INFINITY, f64::min);
    [
        min(&|w| w.left.correlation),
        min(&|w| w.right.correlation),
        min(&|w| w.sum.correlation),
        min(&|w| w.difference.correlation),
        min(&|w| w.left.two_sigma_coverage.min(w.right.two_sigma_coverage).min(w.difference.two_sigma_coverage)),
    ]
}

/// Runs the sweep and prints one table: per case, rate, speed, vehicle variant and sensor
/// set, the worst wheelset's correlations (the lowest over the seeds, and the mean of each
/// seed's lowest for the left and right wheels) and 2σ coverage.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    // A name or value the tuning refuses costs no run.
    let ours = ForceModel::Returning(Tuning::FORCE_RETURN_RATE);
    Tuning::new(&Settings::default(), &Measurements::default(), ours)
        .set_all(&start_values)
        .map_err(anyhow::Error::msg)?;
    let mut variants = vec![Variant::Catalogue];
    let signed: Vec<f64> = args.errors.iter().flat_map(|&e| [-e, e]).collect();
    variants.extend(signed.iter().map(|&e| Variant::CarBodyMass(e)));
    variants.extend(signed.iter().map(|&e| Variant::CarBodyRollInertia(e)));
    variants.extend(signed.iter().map(|&e| Variant::PrimaryStiffness(e)));
    let mut jobs = Vec::new();
    for &case in &args.cases {
        for &rate in &args.rates {
            for &speed in &args.speeds {
                // The parameter errors at 80 km/h only; the speeds with the catalogue.
                for &variant in &variants {
                    if variant != Variant::Catalogue && speed != 80.0 {
                        continue;
                    }
                    for seed in Tuning::CHOSEN_ON_SEED + 1..=Tuning::CHOSEN_ON_SEED + args.seeds {
                        jobs.push(Job { row: Row { case, speed, rate, variant }, seed });
                    }
                }
            }
        }
    }
    let sensor_sets = [Sensors::Accelerations, Sensors::WithDeflections];
    let results = shard::run(&jobs, args.shard, |&Job { row, seed }| -> Result<Vec<[f64; 5]>, String> {
        let settings =
            Settings { speed: row.speed / 3.6, rate: row.rate, duration: args.duration, seed, ..Settings::default() };
        let truth = simulate(row.case, &settings)?;
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let mut tuning = Tuning::new(&settings, &measurements, ours);
        tuning.set_all(&start_values)?;
        sensor_sets
            .iter()
            .map(|&sensors| {
                run_filter(args.filter, row.variant.vehicle(), &tuning, &measurements, sensors)
                    .map(|e| worst(&score(&truth, &e, settings.rate, 0.5)))
            })
            .collect()
    });
    let mut out = String::new();
    let built = as_built();
    let _ = writeln!(
        out,
        "S3 {} with forces returning to the static load, on the car as built (car body {:.0} kg, roll inertia {:.0} \
         kg·m², primary {:.3} MN/m); the user has the catalogue car, or it with the car-body mass m_c, roll inertia \
         I_cx or primary stiffness K_p the as-built value off by the error shown; seeds 2..={}, {} s per run; the \
         worst of the four wheelsets after 0.5 s: correlation of L, R (lowest over the seeds and mean), sum and L − R \
         (lowest), and the lowest share of L, R and L − R errors inside ±2σ",
        args.filter,
        built.vertical.car_body_mass,
        built.car_body_roll_inertia,
        built.vertical.primary_stiffness / 1e6,
        Tuning::CHOSEN_ON_SEED + args.seeds,
        args.duration
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "start values over the study's tuning in every run: {}", start_values.summary());
    }
    let _ = writeln!(
        out,
        "{:<17} {:>5} {:>5} {:<10} {:<14} {:>4} {:>7} {:>7} {:>7} {:>7} {:>8} {:>7} {:>6}",
        "case",
        "Hz",
        "km/h",
        "vehicle",
        "sensors",
        "runs",
        "L min",
        "L mean",
        "R min",
        "R mean",
        "sum min",
        "L−R min",
        "2σ min"
    );
    let mut failures = 0;
    // A row's seeds are consecutive jobs, and the results keep the jobs' order.
    for runs in results.chunk_by(|a, b| jobs[a.0].row == jobs[b.0].row) {
        let Row { case, speed, rate, variant } = jobs[runs[0].0].row;
        let mut per_sensors: Vec<Vec<[f64; 5]>> = vec![Vec::new(); sensor_sets.len()];
        for (j, result) in runs {
            match result {
                Ok(worsts) => {
                    for (s, w) in worsts.iter().enumerate() {
                        per_sensors[s].push(*w);
                    }
                }
                Err(e) => {
                    failures += 1;
                    let _ = writeln!(
                        out,
                        "{case:<17} {rate:>5} {speed:>5} {:<10} FAILED (seed {}): {e}",
                        variant.name(),
                        jobs[*j].seed
                    );
                }
            }
        }
        for (sensors, worsts) in sensor_sets.iter().zip(&per_sensors) {
            if worsts.is_empty() {
                continue;
            }
            let min = |i: usize| worsts.iter().map(|w| w[i]).fold(f64::INFINITY, f64::min);
            let mean = |i: usize| worsts.iter().map(|w| w[i]).sum::<f64>() / worsts.len() as f64;
            let _ = writeln!(
                out,
                "{:<17} {rate:>5} {speed:>5} {:<10} {:<14} {:>4} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>8.4} {:>7.3} {:>6.2}",
                case.to_string(),
                variant.name(),
                sensors.label(),
                worsts.len(),
                min(0),
                mean(0),
                min(1),
                mean(1),
                min(2),
                min(3),
                min(4)
            );
        }
    }
    print!("{out}");
    if failures > 0 {
        anyhow::bail!("{failures} run(s) failed");
    }
    Ok(())
}
