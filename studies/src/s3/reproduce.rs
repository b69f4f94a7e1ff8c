//! S3 in `kalfmu reproduce`: each case (random track, dipped joint, twist, random track
//! with alignment) simulated once on the car as built, then run through the packaged FMU
//! with the paper's filter (SRCKF) four ways: the paper's force model (random walks) and
//! ours (forces returning to the weighed static load), each with the 20 accelerations
//! alone and with the eight primary deflections too. The user has the catalogue car and
//! the weighed wheel load. One log per run, one comparison per case; the tables print per
//! wheel the correlation and the steady RMSE of the left and right forces, their sum and
//! their difference, beside the paper's figures.
//!
//! Definitions:
//! - every figure is taken after a settling time of 0.5 s, in the recordings too; the
//!   steady RMSE is the RMSE from then on;
//! - **L − R** is the wheelset's difference `F_NL − F_NR`, **sum** `F_NL + F_NR`, each
//!   with its σ from the FMU's covariance (its outputs `F_diff<j>`, `F_sum<j>`);
//! - **2σ**, **(e/σ)²** and **NIS/rows**: whether the FMU's σ is honest, the analyzer's
//!   figures (docs/analyzer.md): the share of errors inside ±2σ (0.9545 for an honest σ),
//!   the mean σ-normalised squared error (1) with its reading, the run's Σ NIS / Σ rows
//!   used (1);
//! - **vs library**: the largest difference between the FMU's forces and the same filter
//!   run in-process on the same measurements (`study::run_filter`);
//! - **ceiling**: per case, the most any vertical model gives ([`ceiling`]): each
//!   wheelset's equations fed with the truth's noise-free vertical motion and the car's
//!   true data; what it misses of `L − R` is the lateral dynamics' share;
//! - **sm**: the FMU's fixed-lag smoothed forces (its `smoothing_lag`, [`SMOOTHING_LAG`],
//!   logged on `/smoothed` at the times they describe), taken like the filtered ones but
//!   ending one lag before the run does; each wheelset's smoothed sum and `L − R` are
//!   formed here from its smoothed `L` and `R`, without a σ (the FMU gives no smoothed
//!   covariance of a wheelset's two forces). Our force model's runs only: a smoother of
//!   the 42 states costs several times the filter, and the paper's runs are there for
//!   comparison.
//!
//! Start values (`--set`, `--values`) go to every FMU run; the in-process filter takes
//! those it has a parameter for ([`Tuning::set`](start_values::SetByName::set)). The
//! paper's runs keep their random walks: a `force_return_rate` given is ours.
//!
//! The figures are written as `table.json` too ([`Table`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use analyzer::consistency::{Nis, NormalisedError};
use analyzer::report::{analyse, Options, PairReport};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::{read_log, Run, Signal};
use log_format::write::{SignalSpec, ESTIMATE, SMOOTHED, TRUTH};
use serde::Serialize;
use start_values::{SetByName, StartValues};

use super::ceiling::{ceiling, Ceiling};
use super::fmu_run::{self, Simulated, IDENTIFIER};
use super::study::{forces_in_model_order, run_filter, user_vehicle, ForceModel, Sensors, Tuning};
use crate::comparison::{compare_case, largest_difference, rows_of, units, write_table, Compared};
use crate::smoothed::SMOOTHING_LAG;
use cosim::fmu_driver::ImportedFmu;
use cosim::master::Counts;
use shard::Shard;
use truth::s3::cases::{measure, simulate, Case, Measurements, Settings, Truth};

/// The settling time before the figures are taken (s).
pub const SETTLE: f64 = 0.5;

/// The filter of every run: the paper's.
const FILTER: FilterKind = FilterKind::SrCkf;

/// The paper's figures (its SRCKF on its SIMPACK truth, the random track, accelerations
/// only, random-walk forces): the lowest correlation of a left and of a right wheel, of a
/// wheelset's sum, and the steady RMSE of wheelset 1's left force (kN).
pub const PAPER: PaperFigures = PaperFigures {
    left_correlation_min: 0.747,
    right_correlation_min: 0.720,
    sum_correlation: 0.999,
    rmse_left_1: 0.394,
};

/// Where the paper's figures come from.
const PAPER_SOURCE: &str = "SRCKF figures of the paper (Chen et al. 2025) on its SIMPACK whole-car truth, random track";

/// The paper's figures.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PaperFigures {
    /// The lowest correlation of a left wheel's force.
    pub left_correlation_min: f64,
    /// … of a right wheel's.
    pub right_correlation_min: f64,
    /// The correlation of a wheelset's sum.
    pub sum_correlation: f64,
    /// The steady RMSE of wheelset 1's left force (kN).
    pub rmse_left_1: f64,
}

/// The four ways each case runs: the paper's force model and ours, each with the
/// accelerations alone and with the deflections.
fn configurations() -> [(ForceModel, Sensors); 4] {
    let ours = ForceModel::Returning(Tuning::FORCE_RETURN_RATE);
    [
        (ForceModel::RandomWalk, Sensors::Accelerations),
        (ours, Sensors::Accelerations),
        (ForceModel::RandomWalk, Sensors::WithDeflections),
        (ours, Sensors::WithDeflections),
    ]
}

/// A run's name in its log's file name: `paper_accelerations`, `ours_deflections`, ….
fn run_name(forces: ForceModel, sensors: Sensors) -> String {
    let model = if forces == ForceModel::RandomWalk { "paper" } else { "ours" };
    let sensors = if sensors == Sensors::Accelerations { "accelerations" } else { "deflections" };
    format!("{model}_{sensors}")
}

/// The figures of S3's table, as `table.json` has them.
#[derive(Debug, Serialize)]
pub struct Table {
    /// `"S3"`.
    pub study: &'static str,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field.
    pub units: BTreeMap<&'static str, &'static str>,
    /// Where the `paper` figures come from.
    pub paper_source: &'static str,
    /// The paper's figures.
    pub paper: PaperFigures,
    /// One entry per case.
    pub cases: Vec<CaseFigures>,
}

/// The set-up of a [`Table`].
#[derive(Debug, Serialize)]
pub struct TableSettings {
    /// Speed of the car (m/s).
    pub speed: f64,
    /// Simulated duration (s).
    pub duration: f64,
    /// Sampling rate (Hz).
    pub rate: f64,
    /// Seed of the track and of the noise.
    pub seed: u64,
    /// The seed the tuning was chosen on, which the table is not of.
    pub tuning_chosen_on_seed: u64,
    /// Sensor noise as a fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// Figures are taken from this time on (s).
    pub settle: f64,
    /// The filter.
    pub filter: &'static str,
    /// Whether this is `--quick`'s short run.
    pub quick: bool,
    /// The start values given, by name.
    pub start_values: BTreeMap<String, f64>,
    /// Those the in-process filter does not take: they reach the FMU only.
    pub start_values_fmu_only: Vec<String>,
}

/// One case of a [`Table`].
#[derive(Debug, Serialize)]
pub struct CaseFigures {
    /// `random`, `joint`, `twist` or `random_alignment`.
    pub case: String,
    /// Why the case's runs could not be compared, if they could not.
    pub failure: Option<String>,
    /// The most a vertical model gives, per wheelset ([`ceiling`]).
    pub vertical_ceiling: Vec<Ceiling>,
    /// One entry per force model and sensor set.
    pub runs: Vec<RunFigures>,
}

/// One run of a case through the FMU.
#[derive(Debug, Serialize)]
pub struct RunFigures {
    /// `random walk` (the paper's) or `returning` (ours).
    pub force_model: &'static str,
    /// The forces' return rate (1/s); 0 for random walks.
    pub force_return_rate: f64,
    /// `accelerations` or `+ deflections`.
    pub sensors: &'static str,
    /// Why the run failed, if it did (then the other fields are `null` or empty).
    pub failure: Option<String>,
    /// Measurement rows the FMU's gate left out.
    pub rejected_rows: Option<i32>,
    /// The largest difference between the FMU's forces and the same filter's in-process (N).
    pub fmu_vs_in_process_max_abs_difference: Option<f64>,
    /// The run's NIS, the analyzer's.
    pub nis: Option<Nis>,
    /// Wheelsets 1 to 4.
    pub wheelsets: Vec<WheelsetFigures>,
}

/// One wheelset's figures.
#[derive(Debug, Clone, Serialize)]
pub struct WheelsetFigures {
    /// 1 to 4.
    pub wheelset: usize,
    /// `F_NL`.
    pub left: SignalFigures,
    /// `F_NR`.
    pub right: SignalFigures,
    /// `F_NL + F_NR`.
    pub sum: SignalFigures,
    /// `F_NL − F_NR`.
    pub difference: SignalFigures,
}

/// One estimated signal against its truth, after the settling time.
#[derive(Debug, Clone, Serialize)]
pub struct SignalFigures {
    /// Correlation.
    pub correlation: f64,
    /// Steady RMSE (kN).
    pub rmse: f64,
    /// Share of the errors inside the FMU's ±σ.
    pub one_sigma_coverage: Option<f64>,
    /// Share of the errors inside the FMU's ±2σ.
    pub two_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` with its reading.
    pub normalised_error: Option<NormalisedError>,
    /// The FMU's fixed-lag smoothed signal (`null` if the run has none).
    pub smoothed: Option<SmoothedSignal>,
}

impl SignalFigures {
    fn of(pair: &PairReport<'_>) -> Self {
        Self {
            correlation: pair.metrics.correlation,
            rmse: pair.metrics.rmse / 1e3,
            one_sigma_coverage: pair.one_sigma_coverage,
            two_sigma_coverage: pair.two_sigma_coverage,
            normalised_error: pair.normalised_error,
            smoothed: None,
        }
    }
}

/// One fixed-lag smoothed signal (the FMU's `smoothing_lag`, on `/smoothed`) against its
/// truth, after the settling time, its figures taken as the filtered signal's.
#[derive(Debug, Clone, Serialize)]
pub struct SmoothedSignal {
    /// The smoothing lag (s).
    pub lag: f64,
    /// Correlation.
    pub correlation: f64,
    /// Steady RMSE (kN).
    pub rmse: f64,
    /// Share of the errors inside the smoothed ±σ (`null` for the sum and `L − R`, formed
    /// from the smoothed forces without a σ).
    pub one_sigma_coverage: Option<f64>,
    /// Share of the errors inside the smoothed ±2σ (`null` for the sum and `L − R`).
    pub two_sigma_coverage: Option<f64>,
}

impl SmoothedSignal {
    fn of(pair: &PairReport<'_>) -> Self {
        Self {
            lag: SMOOTHING_LAG,
            correlation: pair.metrics.correlation,
            rmse: pair.metrics.rmse / 1e3,
            one_sigma_coverage: pair.one_sigma_coverage,
            two_sigma_coverage: pair.two_sigma_coverage,
        }
    }
}

/// The units of S3's [`Table`].
const UNITS: [(&str, &str); 7] = [
    ("speed", "m/s"),
    ("duration", "s"),
    ("rate", "Hz"),
    ("settle", "s"),
    ("lag", "s"),
    ("rmse", "kN"),
    ("fmu_vs_in_process_max_abs_difference", "N"),
];

/// Each wheelset's figures from a run's pairs, found by the truth's names.
fn wheelsets(pairs: &[PairReport<'_>]) -> anyhow::Result<Vec<WheelsetFigures>> {
    let find = |name: String| {
        pairs.iter().find(|p| p.truth == name).map(SignalFigures::of).with_context(|| format!("no {name} compared"))
    };
    (1..=4)
        .map(|j| {
            Ok(WheelsetFigures {
                wheelset: j,
                left: find(format!("F_NL{j}"))?,
                right: find(format!("F_NR{j}"))?,
                sum: find(format!("F_sum{j}"))?,
                difference: find(format!("F_diff{j}"))?,
            })
        })
        .collect()
}

/// The smoothed figures of `run` ([`smoothed_run`]) added to its `wheelsets`.
fn add_smoothed(wheelsets: &mut [WheelsetFigures], run: &Run, options: &Options) -> anyhow::Result<()> {
    let smoothed = smoothed_run(run)?;
    let report = analyse(&smoothed, &Options { estimate_topic: SMOOTHED.into(), ..options.clone() })?;
    let find = |name: String| {
        report
            .pairs
            .iter()
            .find(|p| p.truth == name)
            .map(SmoothedSignal::of)
            .with_context(|| format!("no smoothed {name}"))
    };
    for w in wheelsets {
        let j = w.wheelset;
        w.left.smoothed = Some(find(format!("F_NL{j}"))?);
        w.right.smoothed = Some(find(format!("F_NR{j}"))?);
        w.sum.smoothed = Some(find(format!("F_sum{j}"))?);
        w.difference.smoothed = Some(find(format!("F_diff{j}"))?);
    }
    Ok(())
}

/// The truth of `run` and its `/smoothed` channel, the eight smoothed forces with their σ,
/// to which each wheelset's sum `F_sum<j>` and difference `F_diff<j>` are added from its
/// smoothed `F_NL<j>` and `F_NR<j>`, without a σ: the FMU smooths the eight forces only,
/// and gives no smoothed covariance of a wheelset's two.
fn smoothed_run(run: &Run) -> anyhow::Result<Run> {
    let mut smoothed = run.channel(SMOOTHED)?.clone();
    for j in 1..=4 {
        let force = |name: String| {
            smoothed.signal(&name).map(|s| s.values.clone()).with_context(|| format!("{SMOOTHED} has no {name}"))
        };
        let (left, right) = (force(format!("F_NL{j}"))?, force(format!("F_NR{j}"))?);
        let formed = |name: String, description: &str, f: fn(f64, f64) -> f64| Signal {
            spec: SignalSpec::new(&name, "N", description),
            values: left.iter().zip(&right).map(|(&l, &r)| f(l, r)).collect(),
        };
        smoothed.signals.extend([
            formed(format!("F_sum{j}"), "smoothed F_NL + F_NR, formed from the smoothed forces", |l, r| l + r),
            formed(format!("F_diff{j}"), "smoothed F_NL − F_NR, formed from the smoothed forces", |l, r| l - r),
        ]);
    }
    Ok(Run {
        file: run.file.clone(),
        metadata: run.metadata.clone(),
        channels: vec![run.channel(TRUTH)?.clone(), smoothed],
        skipped: Vec::new(),
        damage: None,
    })
}

/// What every run of the study shares.
struct Given<'a> {
    fmu: &'a ImportedFmu,
    start_values: &'a StartValues,
    settings: &'a Settings,
}

/// Runs the four configurations of `case` through the FMU, each checked against the same
/// filter in-process, and compares them (`<dir>/<case>.json`, `.rrd`); the case's figures
/// and its recording.
fn run_case(given: &Given<'_>, case: Case, truth: &Truth, dir: &Path) -> (CaseFigures, Option<PathBuf>) {
    let Given { fmu, start_values, settings } = *given;
    let measurements = measure(truth, settings.noise_fraction, settings.seed);
    let vehicle = user_vehicle(settings.vehicle.static_wheel_load());
    let mut figures = Vec::new();
    let mut runs: Vec<Run> = Vec::new();
    // Each run's index in `figures`, its counts, its difference from the library and whether
    // it is smoothed (ours only: the smoother of the 42 states, 100 samples back, costs
    // several times the filter).
    let mut checked: Vec<(usize, Counts, f64, bool)> = Vec::new();
    for (forces, sensors) in configurations() {
        let smoothed = forces != ForceModel::RandomWalk;
        let mut tuning = Tuning::new(settings, &measurements, forces);
        let result = (|| -> anyhow::Result<(Counts, Run, f64)> {
            tuning.set_known(start_values).map_err(anyhow::Error::msg)?;
            if forces == ForceModel::RandomWalk {
                tuning.forces = ForceModel::RandomWalk;
            }
            let parameters = fmu_run::parameters(&vehicle, &tuning);
            // The paper's runs keep their random walks over a user's return rate.
            let mut given = StartValues::none();
            for (name, value) in start_values.iter() {
                if forces != ForceModel::RandomWalk || name != "force_return_rate" {
                    given.insert(name, value);
                }
            }
            let start_values = &given;
            let sim = Simulated {
                case,
                settings,
                truth,
                measurements: &measurements,
                sensors,
                parameters: &parameters,
                start_values,
                smoothed,
            };
            let log = dir.join(format!("{case}_{}.mcap", run_name(forces, sensors)));
            let counts = fmu_run::run(fmu, FILTER, &sim, &log)?;
            let run = read_log(&log)?;
            let library = run_filter(FILTER, vehicle, &tuning, &measurements, sensors).map_err(anyhow::Error::msg)?;
            let logged = rows_of(
                run.channel(ESTIMATE)?,
                ["F_NL1", "F_NR1", "F_NL2", "F_NR2", "F_NL3", "F_NR3", "F_NL4", "F_NR4"],
            )?;
            let in_process: Vec<[f64; 8]> = library.forces.iter().map(forces_in_model_order).collect();
            Ok((counts, run, largest_difference(&logged, &in_process)?))
        })();
        let mut entry = RunFigures {
            force_model: if forces == ForceModel::RandomWalk { "random walk" } else { "returning" },
            force_return_rate: tuning.forces.rate(),
            sensors: sensors.label(),
            failure: None,
            rejected_rows: None,
            fmu_vs_in_process_max_abs_difference: None,
            nis: None,
            wheelsets: Vec::new(),
        };
        match result {
            Ok((counts, run, difference)) => {
                checked.push((figures.len(), counts, difference, smoothed));
                runs.push(run);
            }
            Err(e) => entry.failure = Some(format!("{e:#}")),
        }
        figures.push(entry);
    }
    let options = Options { from: SETTLE, psd_segment: settings.rate.round() as usize, ..Options::default() };
    let stem = dir.join(case.name());
    let compared = compare_case(&runs, &[], &options, &stem, None).map_err(anyhow::Error::from).and_then(
        |Compared { comparison, recording: rrd, .. }| {
            for (((index, counts, difference, smoothed), report), run) in
                checked.iter().zip(&comparison.runs).zip(&runs)
            {
                let entry = &mut figures[*index];
                entry.rejected_rows = Some(counts.rejected);
                entry.fmu_vs_in_process_max_abs_difference = Some(*difference);
                entry.nis = report.nis.clone();
                entry.wheelsets = wheelsets(&report.pairs)?;
                if *smoothed {
                    add_smoothed(&mut entry.wheelsets, run, &options)?;
                }
            }
            Ok(rrd)
        },
    );
    let (failure, recording) = match compared {
        Ok(rrd) => (None, Some(rrd)),
        Err(e) => (Some(format!("{e:#}")), None),
    };
    let vertical_ceiling = ceiling(truth, &settings.vehicle, settings.rate, SETTLE).to_vec();
    (CaseFigures { case: case.to_string(), failure, vertical_ceiling, runs: figures }, recording)
}

/// The lowest of a figure over the four wheelsets.
fn lowest(run: &RunFigures, f: impl Fn(&WheelsetFigures) -> f64) -> f64 {
    run.wheelsets.iter().map(f).fold(f64::INFINITY, f64::min)
}

/// Every signal of a run: the wheelset, its name and its figures.
fn signals(run: &RunFigures) -> impl Iterator<Item = (usize, &'static str, &SignalFigures)> {
    run.wheelsets.iter().flat_map(|w| {
        [("L", &w.left), ("R", &w.right), ("sum", &w.sum), ("L−R", &w.difference)].map(|(n, s)| (w.wheelset, n, s))
    })
}

/// Runs S3 through its FMU, prints the tables and writes them as `table.json` in `out/s3`;
/// returns the number of failed runs.
pub fn report(
    settings: &Settings,
    start_values: &StartValues,
    quick: bool,
    fmu_dir: &Path,
    out: &Path,
) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    // A misspelt name or a value of the wrong type costs no run …
    fmu.check_start_values(start_values)?;
    // … nor one the in-process filter would refuse; the names it has no parameter for
    // reach the FMU only.
    let fmu_only = Tuning::new(settings, &Measurements::default(), ForceModel::RandomWalk)
        .set_known(start_values)
        .map_err(anyhow::Error::msg)?;
    let dir = out.join("s3");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let catalogue = user_vehicle(settings.vehicle.static_wheel_load());
    println!(
        "S3: left and right wheel-rail forces of a whole car, 17-DOF vehicle with roll + 8 forces (42 states) — {:.0} \
         km/h, {} s at {} Hz, German low-interference track (seed {}; the tuning was chosen on seed {}), sensor noise \
         {:.1} % of RMS",
        settings.speed * 3.6,
        settings.duration,
        settings.rate,
        settings.seed,
        Tuning::CHOSEN_ON_SEED,
        100.0 * settings.noise_fraction
    );
    if let Some(line) = start_values.header(&fmu_only) {
        println!("{line}");
    }
    println!(
        "truth: the whole car on two rails (lateral and yaw motion, conical treads, Kalker creep, Hertz contact per \
         wheel, S2's track under each rail) as built: car body {:.0} kg, primary {:.3} MN/m; the estimator has the \
         catalogue car ({:.0} kg, {:.3} MN/m) in bounce, pitch and roll, the weighed wheel load {:.2} kN, no lateral \
         motion, no track",
        settings.vehicle.vertical.car_body_mass,
        settings.vehicle.vertical.primary_stiffness / 1e6,
        catalogue.car_body_mass,
        catalogue.primary_stiffness / 1e6,
        catalogue.static_wheel_load / 1e3
    );
    println!(
        "estimates from {} ({}) driven through the fmi importer; per run a log (<case>_<model>_<sensors>.mcap), per \
         case a comparison of the four runs (<case>.json, <case>.rrd) in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        FILTER.name(),
        dir.display()
    );
    let truths: Vec<Result<Truth, String>> =
        shard::run(&Case::ALL, Shard::ALL, |case| simulate(*case, settings)).into_iter().map(|(_, t)| t).collect();
    let given = Given { fmu: &fmu, start_values, settings };
    let mut failures = 0;
    let mut cases = Vec::new();
    let mut recordings = Vec::new();
    for (case, truth) in Case::ALL.into_iter().zip(truths) {
        let truth = truth.map_err(anyhow::Error::msg).with_context(|| format!("the {case} truth"))?;
        let (figures, recording) = run_case(&given, case, &truth, &dir);
        failures += figures.runs.iter().filter(|r| r.failure.is_some()).count();
        failures += usize::from(figures.failure.is_some());
        recordings.extend(recording);
        cases.push(figures);
    }
    let table = Table {
        study: "S3",
        settings: TableSettings {
            speed: settings.speed,
            duration: settings.duration,
            rate: settings.rate,
            seed: settings.seed,
            tuning_chosen_on_seed: Tuning::CHOSEN_ON_SEED,
            noise_fraction: settings.noise_fraction,
            settle: SETTLE,
            filter: FILTER.name(),
            quick,
            start_values: start_values.iter().map(|(n, v)| (n.to_string(), v)).collect(),
            start_values_fmu_only: fmu_only,
        },
        units: units(&UNITS),
        paper_source: PAPER_SOURCE,
        paper: PAPER,
        cases,
    };
    write_table(&dir, &table)?;
    print!("{}", summary_table(&table.cases));
    print!("{}", wheel_table(&table.cases));
    println!("comparison recordings, the four runs of a case in one (open with the Rerun viewer 0.41 or newer):");
    for recording in &recordings {
        println!("  {}", recording.display());
    }
    Ok(failures)
}

/// The first table: per case and run the lowest correlations of the four wheelsets, the
/// steady RMSE of wheelset 1's left force and the largest, the σ's honesty, beside the
/// paper's.
fn summary_table(cases: &[CaseFigures]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "after {SETTLE} s, the lowest of the four wheelsets; RMSE of wheelset 1's left force and the largest of the \
         eight; 2σ: the lowest share of errors inside the FMU's ±2σ of the 16 signals (L, R, sum, L−R); (e/σ)²: the \
         signal farthest from 1; ceiling: the most any vertical model gives, its equations fed with the true vertical \
         motion (what it misses is the lateral dynamics'); sm: the same of the FMU's fixed-lag smoothed forces \
         (smoothing_lag = {SMOOTHING_LAG} s, the estimate of that much earlier given the measurements up to now; \
         logged on /smoothed) up to one lag before the end, of our force model's runs; L − R formed from the smoothed \
         L and R, 2σ of L and R:"
    );
    let _ = writeln!(
        out,
        "{:<17} {:<20} {:<14} {:>6} {:>6} {:>7} {:>6} {:>8} {:>8} {:>6} {:>24} {:>17} {:>8} {:>9}  {:>6} {:>6} {:>6} \
         {:>10} {:>6}",
        "case",
        "forces",
        "sensors",
        "L",
        "R",
        "sum",
        "L−R",
        "RMSE L1",
        "max kN",
        "2σ",
        "(e/σ)² worst",
        "NIS/rows",
        "rejected",
        "vs lib N",
        "sm L",
        "sm R",
        "sm L−R",
        "sm RMSE L1",
        "sm 2σ"
    );
    let _ = writeln!(
        out,
        "{:<17} {:<20} {:<14} {:>6.3} {:>6.3} {:>7.3} {:>6} {:>8.3}",
        "paper: random",
        "random walk",
        "accelerations",
        PAPER.left_correlation_min,
        PAPER.right_correlation_min,
        PAPER.sum_correlation,
        "—",
        PAPER.rmse_left_1
    );
    for case in cases {
        if let Some(e) = &case.failure {
            let _ = writeln!(out, "{:<17} FAILED to compare: {e}", case.case);
        }
        let ceiling_lowest = |f: fn(&Ceiling) -> f64| case.vertical_ceiling.iter().map(f).fold(f64::INFINITY, f64::min);
        let _ = writeln!(
            out,
            "{:<17} {:<20} {:<14} {:>6.3} {:>6.3} {:>7.4} {:>6.3}",
            case.case,
            "ceiling: vertical",
            "true motion",
            ceiling_lowest(|c| c.left_correlation),
            ceiling_lowest(|c| c.right_correlation),
            ceiling_lowest(|c| c.sum_correlation),
            ceiling_lowest(|c| c.difference_correlation),
        );
        for run in &case.runs {
            let label = format!("{:<17} {:<20} {:<14}", case.case, run.force_model, run.sensors);
            if let Some(e) = &run.failure {
                let _ = writeln!(out, "{label} FAILED: {e}");
                continue;
            }
            if run.wheelsets.is_empty() {
                continue;
            }
            let worst_sigma = signals(run)
                .filter_map(|(j, n, s)| s.normalised_error.map(|e| (j, n, e)))
                .max_by(|a, b| a.2.mean_square.ln().abs().total_cmp(&b.2.mean_square.ln().abs()));
            let two_sigma = signals(run).filter_map(|(_, _, s)| s.two_sigma_coverage).fold(f64::INFINITY, f64::min);
            let rmse_max = run.wheelsets.iter().flat_map(|w| [w.left.rmse, w.right.rmse]).fold(0.0, f64::max);
            let _ = writeln!(
                out,
                "{label} {:>6.3} {:>6.3} {:>7.4} {:>6.3} {:>8.3} {:>8.3} {:>6.3} {:>24} {:>17} {:>8} {:>9.1e}  {}",
                lowest(run, |w| w.left.correlation),
                lowest(run, |w| w.right.correlation),
                lowest(run, |w| w.sum.correlation),
                lowest(run, |w| w.difference.correlation),
                run.wheelsets[0].left.rmse,
                rmse_max,
                two_sigma,
                worst_sigma.map_or("—".into(), |(j, n, e)| format!(
                    "{n}{j}: {:.3} {}",
                    e.mean_square,
                    e.reading.text()
                )),
                run.nis
                    .as_ref()
                    .and_then(|n| n.ratio.zip(n.reading))
                    .map_or("—".into(), |(r, reading)| format!("{r:.3} {}", reading.text())),
                run.rejected_rows.unwrap_or(0),
                run.fmu_vs_in_process_max_abs_difference.unwrap_or(f64::NAN),
                smoothed_columns(run),
            );
        }
    }
    out
}

/// The summary table's smoothed columns of `run`: the lowest correlation of the four
/// wheelsets' smoothed L, R and L − R, the steady RMSE of wheelset 1's smoothed left force
/// and the lowest share of the smoothed L and R errors inside their ±2σ; `—` without them.
fn smoothed_columns(run: &RunFigures) -> String {
    let wheelsets: Option<Vec<[&SmoothedSignal; 3]>> = run
        .wheelsets
        .iter()
        .map(|w| Some([w.left.smoothed.as_ref()?, w.right.smoothed.as_ref()?, w.difference.smoothed.as_ref()?]))
        .collect();
    let Some(wheelsets) = wheelsets.filter(|w| !w.is_empty()) else {
        return format!("{:>6} {:>6} {:>6} {:>10} {:>6}", "—", "—", "—", "—", "—");
    };
    let lowest = |figures: &mut dyn Iterator<Item = Option<f64>>| figures.flatten().fold(f64::INFINITY, f64::min);
    let correlation = |side: usize| lowest(&mut wheelsets.iter().map(|w| Some(w[side].correlation)));
    format!(
        "{:>6.3} {:>6.3} {:>6.3} {:>10.3} {:>6.3}",
        correlation(0),
        correlation(1),
        correlation(2),
        wheelsets[0][0].rmse,
        lowest(&mut wheelsets.iter().flat_map(|w| [w[0].two_sigma_coverage, w[1].two_sigma_coverage]))
    )
}

/// The second table: every wheelset of every run, correlation and steady RMSE of L, R,
/// sum and L − R, and the share inside ±2σ; then those of the smoothed L, R and L − R.
fn wheel_table(cases: &[CaseFigures]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "per wheelset: correlation, steady RMSE (kN) and share inside ±2σ of L, R, sum and L − R; then the same of the \
         smoothed (sm) L, R and L − R (L − R formed from the smoothed L and R, without a σ):"
    );
    let _ = writeln!(
        out,
        "{:<17} {:<12} {:<14} {:>5} | {:>6} {:>6} {:>7} {:>6} | {:>6} {:>6} {:>6} {:>6} | {:>5} {:>5} {:>5} {:>5} \
         | {:>6} {:>6} {:>6} | {:>6} {:>6} {:>6} | {:>5} {:>5}",
        "case",
        "forces",
        "sensors",
        "wheel",
        "L",
        "R",
        "sum",
        "L−R",
        "L",
        "R",
        "sum",
        "L−R",
        "L",
        "R",
        "sum",
        "L−R",
        "sm L",
        "sm R",
        "sm L−R",
        "sm L",
        "sm R",
        "sm L−R",
        "sm L",
        "sm R"
    );
    for case in cases {
        for run in case.runs.iter().filter(|r| r.failure.is_none()) {
            for w in &run.wheelsets {
                let s = [&w.left, &w.right, &w.sum, &w.difference];
                let two = s.map(|s| s.two_sigma_coverage.unwrap_or(f64::NAN));
                let sm = [&w.left, &w.right, &w.difference].map(|s| s.smoothed.as_ref());
                let figure = |s: Option<&SmoothedSignal>, f: fn(&SmoothedSignal) -> Option<f64>, digits: usize| {
                    s.and_then(f).map_or("—".to_string(), |v| format!("{v:.digits$}"))
                };
                let correlation = sm.map(|s| figure(s, |s| Some(s.correlation), 3));
                let rmse = sm.map(|s| figure(s, |s| Some(s.rmse), 3));
                let two_sigma = sm.map(|s| figure(s, |s| s.two_sigma_coverage, 2));
                let _ = writeln!(
                    out,
                    "{:<17} {:<12} {:<14} {:>5} | {:>6.3} {:>6.3} {:>7.4} {:>6.3} | {:>6.3} {:>6.3} {:>6.3} {:>6.3} | \
                     {:>5.2} {:>5.2} {:>5.2} {:>5.2} | {:>6} {:>6} {:>6} | {:>6} {:>6} {:>6} | {:>5} {:>5}",
                    case.case,
                    run.force_model,
                    run.sensors,
                    w.wheelset,
                    s[0].correlation,
                    s[1].correlation,
                    s[2].correlation,
                    s[3].correlation,
                    s[0].rmse,
                    s[1].rmse,
                    s[2].rmse,
                    s[3].rmse,
                    two[0],
                    two[1],
                    two[2],
                    two[3],
                    correlation[0],
                    correlation[1],
                    correlation[2],
                    rmse[0],
                    rmse[1],
                    rmse[2],
                    two_sigma[0],
                    two_sigma[1],
                );
            }
        }
    }
    out
}
