//! S2 in `kalfmu reproduce`: each case (random track, corrugation, weld) simulated once
//! on the as-built car, then run through the packaged FMU with every filter, the user's
//! catalogue vehicle and the study's one tuning; one log per run, one comparison per case;
//! the table per wheelset beside the paper's figures (SRCKF), and every filter's worst
//! wheel.
//!
//! Definitions (the paper reports wheelset 1 only, and defines none of them):
//! - every figure is taken after a settling time of 0.5 s, in the recordings too;
//! - **RMSE mean and variance**: of the running RMSE over a trailing 0.2 s window, the
//!   curve the paper plots and summarises by its mean (kN) and variance (kN²);
//! - **RMSE/σ_dyn**: the RMSE over the true force's standard deviation about its mean, its
//!   dynamic part;
//! - **weld peak error**: of the peak dynamic force, `max F − F̄` (F̄ the true mean), the
//!   estimate's peak taken within ±20 ms of the truth's, relative to the truth's;
//! - **PSD band**: the widest band where the spectra (Welch, 1 s segments) agree within
//!   3 dB;
//! - **2σ**: the fraction of samples whose error is inside the FMU's ±2σ;
//! - **1σ**, **(e/σ)²** and **NIS/rows**: whether the FMU's σ is honest, the analyzer's
//!   figures (docs/analyzer.md, "Is the σ honest?"): the fraction inside ±σ (0.6827 for an
//!   honest σ), the mean σ-normalised squared error (1) with its reading, and the run's
//!   Σ NIS / Σ measurement rows used (1) with its reading; every filter's table shows the
//!   wheel whose (e/σ)² is the farthest from 1 (in ratio);
//! - **vs library**: the largest difference between the FMU's forces and the same filter
//!   run in-process on the same measurements (`study::run_filter`): the FMU in a
//!   co-simulation must give what our own runs give.
//!
//! The figures are written as `table.json` too ([`Table`]): every filter's, every wheel's.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use start_values::StartValues;

use analyzer::consistency::{Nis, NormalisedError, Reading};
use analyzer::report::{analyse, Options, PairReport};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::read_log;
use log_format::write::{ESTIMATE, PREDICTION};
use serde::Serialize;

use super::fmu_run::{self, Simulated, IDENTIFIER};
use super::study::{run_filter, user_vehicle, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of, units, write_table};
use cosim::fmu_driver::ImportedFmu;
use cosim::master::Counts;
use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
use truth::s2::parameters::Vehicle;

/// The settling time before the figures are taken (s).
const SETTLE: f64 = 0.5;
/// The running RMSE's window (s).
const RMSE_WINDOW: f64 = 0.2;
/// How far from the true peak the estimate's peak is looked for (s).
const PEAK_WINDOW: f64 = 0.02;

/// The paper's figures for wheelset 1 (SRCKF, 200 Hz): correlation, RMSE mean (kN) and
/// variance (kN²).
fn published(case: Case) -> (f64, f64, f64) {
    match case {
        Case::Random => (0.988, 0.175, 0.027),
        Case::Corrugation => (0.999, 0.142, 0.028),
        Case::Weld => (0.969, 0.101, 0.004),
    }
}

/// One wheel's figures.
#[derive(Debug, Clone, Copy, PartialEq)]
struct WheelFigures {
    correlation: f64,
    rmse: f64,
    running_rmse_mean: f64,
    running_rmse_var: f64,
    dynamic_std: f64,
    peak_error: f64,
    band: Option<(f64, f64)>,
    two_sigma: f64,
    one_sigma: f64,
    normalised_error: Option<NormalisedError>,
}

impl WheelFigures {
    /// From the analyzer's report of a pair, its metrics taken from [`SETTLE`] on.
    fn of(pair: &PairReport<'_>, rate: f64) -> Self {
        let skip = pair.time.len() - pair.samples;
        let (t, e) = (&pair.truth_values[skip..], &pair.estimate_values[skip..]);
        let n = t.len() as f64;
        let mean = t.iter().sum::<f64>() / n;
        let running = &pair.running_rmse[skip..];
        let running_mean = running.iter().sum::<f64>() / n;
        let peak = t.iter().enumerate().fold((0, f64::NEG_INFINITY), |b, (k, &v)| if v > b.1 { (k, v) } else { b });
        let reach = (PEAK_WINDOW * rate).round() as usize;
        let around = &e[peak.0.saturating_sub(reach)..(peak.0 + reach + 1).min(e.len())];
        let estimated_peak = around.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Self {
            correlation: pair.metrics.correlation,
            rmse: pair.metrics.rmse,
            running_rmse_mean: running_mean,
            running_rmse_var: running.iter().map(|r| (r - running_mean).powi(2)).sum::<f64>() / n,
            dynamic_std: (t.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt(),
            peak_error: (estimated_peak - peak.1) / (peak.1 - mean),
            band: pair.psd_agreement_band,
            two_sigma: pair.two_sigma_coverage.unwrap_or(f64::NAN),
            one_sigma: pair.one_sigma_coverage.unwrap_or(f64::NAN),
            normalised_error: pair.normalised_error,
        }
    }
}

/// The figures of S2's tables, as `table.json` has them: every filter's on every wheel,
/// of which the printed tables show the SRCKF's per wheel and every filter's worst wheel.
#[derive(Debug, Serialize)]
pub struct Table {
    /// `"S2"`.
    pub study: &'static str,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field (see [`units`]).
    pub units: BTreeMap<&'static str, &'static str>,
    /// Where the `paper` figures come from.
    pub paper_source: &'static str,
    /// One entry per case, in the tables' order.
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
    /// Accelerometer noise as a fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// Figures are taken from this time on (s).
    pub settle: f64,
    /// The running RMSE's trailing window (s).
    pub rmse_window: f64,
}

/// One case of a [`Table`].
#[derive(Debug, Serialize)]
pub struct CaseFigures {
    /// The case: `random`, `corrugation` or `weld`.
    pub case: &'static str,
    /// The paper's SRCKF figures, for wheelset 1.
    pub paper: PaperFigures,
    /// Why the case's runs could not be compared, if they could not (then only the
    /// failed filters are listed).
    pub failure: Option<String>,
    /// One entry per filter kind, in the tables' order.
    pub filters: Vec<FilterFigures>,
}

/// The paper's figures of a case (its SRCKF, wheelset 1, 200 Hz).
#[derive(Debug, Serialize)]
pub struct PaperFigures {
    /// Correlation of the estimated force with the true one.
    pub correlation: f64,
    /// Mean of the running RMSE (kN).
    pub running_rmse_mean: f64,
    /// Variance of the running RMSE (kN²).
    pub running_rmse_variance: f64,
}

/// One filter's run of a case through the FMU.
#[derive(Debug, Serialize)]
pub struct FilterFigures {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Why the run failed, if it did (then the other fields are `null`).
    pub failure: Option<String>,
    /// Measurement rows the FMU's gate left out.
    pub rejected_rows: Option<i32>,
    /// The largest difference between the FMU's forces and the same filter's in-process (N).
    pub fmu_vs_in_process_max_abs_difference: Option<f64>,
    /// The worst of the four wheels, as the table of every filter prints it.
    pub worst_wheel: Option<WorstWheel>,
    /// Wheelsets 1 to 4.
    pub wheels: Vec<WheelTable>,
    /// The NIS of the run's updates against the measurement rows they used, the analyzer's
    /// (`null` if the run failed or its log has no `nis`).
    pub nis: Option<Nis>,
}

/// The worst figure of the four wheels, each on its own wheel.
#[derive(Debug, Serialize)]
pub struct WorstWheel {
    /// The lowest correlation.
    pub correlation_min: f64,
    /// The largest RMSE over the true force's dynamic σ.
    pub rmse_over_dynamic_std_max: f64,
    /// The weld's peak error of the largest magnitude (%); `null` for the other cases.
    pub weld_peak_error_max_abs: Option<f64>,
    /// The lowest share of errors inside the FMU's ±2σ.
    pub two_sigma_coverage_min: Option<f64>,
    /// The lowest share of errors inside the FMU's ±σ.
    pub one_sigma_coverage_min: Option<f64>,
    /// The wheelset whose mean `(e/σ)²` is the farthest from 1 in ratio (`null` without σ).
    pub normalised_error_worst_wheelset: Option<usize>,
    /// Its mean `(e/σ)²` with its reading.
    pub normalised_error_worst: Option<NormalisedError>,
    /// The lowest correlation of the forces read right after the step.
    pub after_step_correlation_min: f64,
}

/// One wheel's figures, the force read at t after the inputs of t were set.
#[derive(Debug, Serialize)]
pub struct WheelTable {
    /// The wheelset, 1 to 4.
    pub wheelset: usize,
    /// Correlation with the true force.
    pub correlation: f64,
    /// RMSE (kN).
    pub rmse: f64,
    /// Mean of the running RMSE (kN).
    pub running_rmse_mean: f64,
    /// Variance of the running RMSE (kN²).
    pub running_rmse_variance: f64,
    /// The true force's standard deviation about its mean (kN).
    pub dynamic_std: f64,
    /// RMSE over the true force's dynamic σ.
    pub rmse_over_dynamic_std: f64,
    /// The error of the peak dynamic force (%); `null` for the cases without a weld.
    pub weld_peak_error: Option<f64>,
    /// The widest band where the spectra agree within 3 dB, `[low, high]` (Hz).
    pub psd_agreement_band: Option<(f64, f64)>,
    /// Share of the errors inside the FMU's ±2σ (`null` without σ).
    pub two_sigma_coverage: Option<f64>,
    /// Share of the errors inside the FMU's ±σ (`null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (1 for an honest σ) with its reading (`null` without σ).
    pub normalised_error: Option<NormalisedError>,
    /// Correlation of the force read right after the step with the truth at t + dt.
    pub after_step_correlation: f64,
}

impl WheelTable {
    /// Wheelset `wheelset`'s table entry of `case` from its figures `w` and those after
    /// the step `a`.
    fn new(case: Case, wheelset: usize, w: &WheelFigures, a: &WheelFigures) -> Self {
        Self {
            wheelset,
            correlation: w.correlation,
            rmse: w.rmse / 1e3,
            running_rmse_mean: w.running_rmse_mean / 1e3,
            running_rmse_variance: w.running_rmse_var / 1e6,
            dynamic_std: w.dynamic_std / 1e3,
            rmse_over_dynamic_std: w.rmse / w.dynamic_std,
            weld_peak_error: weld_percent(case, w.peak_error),
            psd_agreement_band: w.band,
            two_sigma_coverage: Some(w.two_sigma).filter(|c| !c.is_nan()),
            one_sigma_coverage: Some(w.one_sigma).filter(|c| !c.is_nan()),
            normalised_error: w.normalised_error,
            after_step_correlation: a.correlation,
        }
    }
}

/// The units of S2's [`Table`].
const UNITS: [(&str, &str); 13] = [
    ("speed", "m/s"),
    ("duration", "s"),
    ("rate", "Hz"),
    ("settle", "s"),
    ("rmse_window", "s"),
    ("rmse", "kN"),
    ("running_rmse_mean", "kN"),
    ("running_rmse_variance", "kN²"),
    ("dynamic_std", "kN"),
    ("weld_peak_error", "%"),
    ("weld_peak_error_max_abs", "%"),
    ("psd_agreement_band", "Hz"),
    ("fmu_vs_in_process_max_abs_difference", "N"),
];

/// Where the paper's figures come from.
const PAPER_SOURCE: &str = "SRCKF figures of the paper (Chen et al. 2025) for wheelset 1 at 200 Hz";

/// Runs S2 through its FMU, prints the tables and writes them as `table.json` in
/// `out/s2`; returns the number of failed runs.
pub fn report(settings: &Settings, start_values: &StartValues, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    fmu.check_start_values(start_values)?;
    let dir = out.join("s2");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let truth_car = as_built();
    let catalogue = Vehicle::ZHAI_PASSENGER;
    println!(
        "S2: wheel-rail vertical forces of one rail, 10-DOF vehicle + 4 forces (24 states) — {:.0} km/h, {} s at {} Hz, \
         FRA class 5 track (seed {}), accelerometer noise {:.1} % of RMS",
        settings.speed * 3.6,
        settings.duration,
        settings.rate,
        settings.seed,
        100.0 * settings.noise_fraction
    );
    println!(
        "truth: vehicle-track coupled (modal rail on discrete supports, sleepers, ballast, Hertz contact, Zhai's \
         integrator at 1e-4 s) on the car as built: car body {:.0} kg (catalogue {:.0}), primary {:.3} MN/m (catalogue \
         {:.3}); the estimator has the catalogue car, the weighed wheel load {:.2} kN, no track, no Hertz",
        truth_car.car_body_mass,
        catalogue.car_body_mass,
        truth_car.primary_stiffness / 1e6,
        catalogue.primary_stiffness / 1e6,
        truth_car.static_wheel_load() / 1e3
    );
    println!(
        "estimates from {} driven through the fmi importer; per run a log (<case>_<filter>.mcap), per case a \
         comparison of every filter (<case>.json, <case>.rrd) in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    println!(
        "after {SETTLE} s: correlation; running RMSE ({RMSE_WINDOW} s window) mean and variance; RMSE over the true \
         force's dynamic σ; weld: peak dynamic force error; spectra within 3 dB; share of errors inside the FMU's ±2σ"
    );
    // The recordings' and the JSON's metrics are the table's: from the settling time on.
    let options = Options {
        rmse_window: RMSE_WINDOW,
        psd_segment: settings.rate.round() as usize,
        from: SETTLE,
        ..Options::default()
    };
    let mut srckf = String::new();
    let _ = writeln!(
        srckf,
        "{:<12} {:>5} {:>8} {:>6} {:>8} {:>6} {:>8} {:>6} {:>8} {:>8} {:>12} {:>6} {:>10} {:>6} {:>17}",
        "case",
        "wheel",
        "corr",
        "paper",
        "RMSE kN",
        "paper",
        "var kN²",
        "paper",
        "RMSE/σd",
        "peak err",
        "PSD ±3dB Hz",
        "2σ",
        "after step",
        "1σ",
        "(e/σ)²"
    );
    let mut filters = String::new();
    let _ = writeln!(
        filters,
        "{:<12} {:<8} {:>9} {:>11} {:>9} {:>10} {:>9} {:>10} {:>12} {:>7} {:>20} {:>17}",
        "case",
        "filter",
        "corr min",
        "RMSE/σd max",
        "peak err",
        "2σ min",
        "rejected",
        "after step",
        "vs library N",
        "1σ min",
        "(e/σ)² worst wheel",
        "NIS/rows"
    );
    let mut failures = 0;
    let mut recordings = Vec::new();
    let mut cases = Vec::new();
    for case in Case::ALL {
        let truth = simulate(case, settings);
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let tuning = Tuning::new(settings, measurements.noise_std);
        let parameters = fmu_run::parameters(&catalogue, truth_car.static_wheel_load(), &tuning);
        let sim = Simulated {
            case,
            settings,
            truth: &truth,
            measurements: &measurements,
            parameters: &parameters,
            start_values,
        };
        let stem = dir.join(case.name());
        let mut runs = Vec::new();
        let mut ran: Vec<(FilterKind, Counts, f64)> = Vec::new();
        let (paper_corr, paper_rmse, paper_var) = published(case);
        let mut case_figures = CaseFigures {
            case: case.name(),
            paper: PaperFigures {
                correlation: paper_corr,
                running_rmse_mean: paper_rmse,
                running_rmse_variance: paper_var,
            },
            failure: None,
            filters: Vec::new(),
        };
        let vehicle = user_vehicle(&catalogue, truth_car.static_wheel_load());
        for kind in FilterKind::ALL {
            let log = log_path(&stem, kind);
            let fmu_run = fmu_run::run(&fmu, kind, &sim, &log).and_then(|counts| Ok((counts, read_log(&log)?)));
            let checked = fmu_run.and_then(|(counts, run)| {
                let library = run_filter(kind, vehicle, &tuning, &measurements).map_err(anyhow::Error::msg)?;
                let logged = rows_of(run.channel(ESTIMATE)?, ["F_N1", "F_N2", "F_N3", "F_N4"])?;
                let difference = largest_difference(&logged, &library.forces)?;
                Ok((counts, run, difference))
            });
            match checked {
                Ok((counts, run, difference)) => {
                    runs.push(run);
                    ran.push((kind, counts, difference));
                }
                Err(e) => {
                    failures += 1;
                    let _ = writeln!(filters, "{:<12} {:<8} FAILED: {e:#}", case.name(), kind.name());
                    case_figures.filters.push(FilterFigures {
                        filter: kind.name(),
                        failure: Some(format!("{e:#}")),
                        rejected_rows: None,
                        fmu_vs_in_process_max_abs_difference: None,
                        worst_wheel: None,
                        wheels: Vec::new(),
                        nis: None,
                    });
                }
            }
        }
        let figures = compare_case(&runs, &options, &stem).and_then(|(comparison, recording)| {
            recordings.push(recording);
            let mut per_run = Vec::new();
            for (report, run) in comparison.runs.iter().zip(&runs) {
                let after = analyse(run, &Options { estimate_topic: PREDICTION.into(), ..options.clone() })?;
                let wheels = |pairs: &[PairReport<'_>]| -> Vec<WheelFigures> {
                    pairs.iter().map(|p| WheelFigures::of(p, settings.rate)).collect()
                };
                per_run.push((wheels(&report.pairs), wheels(&after.pairs), report.nis.clone()));
            }
            Ok(per_run)
        });
        let figures = match figures {
            Ok(figures) => figures,
            Err(e) => {
                failures += 1;
                let _ = writeln!(filters, "{:<12} FAILED to compare the filters: {e}", case.name());
                case_figures.failure = Some(e.to_string());
                cases.push(case_figures);
                continue;
            }
        };
        for ((kind, counts, difference), (wheels, after, nis)) in ran.iter().zip(&figures) {
            if *kind == FilterKind::SrCkf {
                for (j, (w, a)) in wheels.iter().zip(after).enumerate() {
                    let paper = |v: f64, digits: usize| if j == 0 { format!("{v:.digits$}") } else { "".into() };
                    let _ = writeln!(
                        srckf,
                        "{:<12} {:>5} {:>8.4} {:>6} {:>8.3} {:>6} {:>8.4} {:>6} {:>8.3} {:>8} {:>12} {:>6.3} {:>10.4} \
                         {:>6.3} {:>17}",
                        case.name(),
                        j + 1,
                        w.correlation,
                        paper(paper_corr, 3),
                        w.running_rmse_mean / 1e3,
                        paper(paper_rmse, 3),
                        w.running_rmse_var / 1e6,
                        paper(paper_var, 3),
                        w.rmse / w.dynamic_std,
                        peak(case, w.peak_error),
                        w.band.map_or("—".into(), |(lo, hi)| format!("{lo:.0}–{hi:.0}")),
                        w.two_sigma,
                        a.correlation,
                        w.one_sigma,
                        read(w.normalised_error.map(|n| (n.mean_square, n.reading)))
                    );
                }
            }
            let worst = |f: fn(&WheelFigures) -> f64, pick: fn(f64, f64) -> f64, start: f64| {
                wheels.iter().map(f).fold(start, pick)
            };
            let worst_normalised_error = farthest_from_one(wheels);
            let worst_wheel = WorstWheel {
                correlation_min: worst(|w| w.correlation, f64::min, f64::INFINITY),
                rmse_over_dynamic_std_max: worst(|w| w.rmse / w.dynamic_std, f64::max, 0.0),
                weld_peak_error_max_abs: weld_percent(
                    case,
                    worst(|w| w.peak_error, |a, b| if b.abs() > a.abs() { b } else { a }, 0.0),
                ),
                two_sigma_coverage_min: Some(worst(|w| w.two_sigma, f64::min, f64::INFINITY)).filter(|c| !c.is_nan()),
                one_sigma_coverage_min: Some(worst(|w| w.one_sigma, f64::min, f64::INFINITY)).filter(|c| !c.is_nan()),
                normalised_error_worst_wheelset: worst_normalised_error.map(|(j, _)| j + 1),
                normalised_error_worst: worst_normalised_error.map(|(_, n)| n),
                after_step_correlation_min: after.iter().map(|a| a.correlation).fold(f64::INFINITY, f64::min),
            };
            let _ = writeln!(
                filters,
                "{:<12} {:<8} {:>9.4} {:>11.3} {:>9} {:>10.3} {:>9} {:>10.4} {:>12.1e} {:>7} {:>20} {:>17}",
                case.name(),
                kind.name(),
                worst_wheel.correlation_min,
                worst_wheel.rmse_over_dynamic_std_max,
                peak(case, worst(|w| w.peak_error, |a, b| if b.abs() > a.abs() { b } else { a }, 0.0)),
                worst(|w| w.two_sigma, f64::min, f64::INFINITY),
                counts.rejected,
                worst_wheel.after_step_correlation_min,
                difference,
                worst_wheel.one_sigma_coverage_min.map_or("—".into(), |c| format!("{c:.3}")),
                worst_normalised_error.map_or("—".into(), |(j, n)| format!(
                    "{}: {}",
                    j + 1,
                    read(Some((n.mean_square, n.reading)))
                )),
                read(nis.as_ref().and_then(|n| n.ratio.zip(n.reading)))
            );
            case_figures.filters.push(FilterFigures {
                filter: kind.name(),
                failure: None,
                rejected_rows: Some(counts.rejected),
                fmu_vs_in_process_max_abs_difference: Some(*difference),
                worst_wheel: Some(worst_wheel),
                wheels: wheels
                    .iter()
                    .zip(after)
                    .enumerate()
                    .map(|(j, (w, a))| WheelTable::new(case, j + 1, w, a))
                    .collect(),
                nis: nis.clone(),
            });
        }
        let order = |f: &FilterFigures| FilterKind::ALL.iter().position(|k| k.name() == f.filter);
        case_figures.filters.sort_by_key(order);
        cases.push(case_figures);
    }
    write_table(
        &dir,
        &Table {
            study: "S2",
            settings: TableSettings {
                speed: settings.speed,
                duration: settings.duration,
                rate: settings.rate,
                seed: settings.seed,
                noise_fraction: settings.noise_fraction,
                settle: SETTLE,
                rmse_window: RMSE_WINDOW,
            },
            units: units(&UNITS),
            paper_source: PAPER_SOURCE,
            cases,
        },
    )?;
    println!("SRCKF (the paper's filter), per wheelset; the paper's figures are for wheelset 1:");
    print!("{srckf}");
    println!("every filter, the worst of the four wheels (rejected: measurement rows the FMU's gate left out):");
    print!("{filters}");
    println!(
        "paper: {PAPER_SOURCE}, its truth and estimator sharing one model (RMSE 0.2 % of the wheel load); ours differ \
         (track, Hertz contact, the user's catalogue values)"
    );
    println!("comparison recordings, every filter of a case in one (open with the Rerun viewer 0.36 or newer):");
    for recording in &recordings {
        println!("  {}", recording.display());
    }
    Ok(failures)
}

/// The wheel (index from 0) whose mean `(e/σ)²` is the farthest from 1 in ratio (a σ twice
/// too wide as far as one twice too narrow), with it; `None` if no wheel has a σ.
fn farthest_from_one(wheels: &[WheelFigures]) -> Option<(usize, NormalisedError)> {
    let distance = |n: &NormalisedError| n.mean_square.ln().abs();
    wheels
        .iter()
        .enumerate()
        .filter_map(|(j, w)| w.normalised_error.map(|n| (j, n)))
        .max_by(|a, b| distance(&a.1).total_cmp(&distance(&b.1)))
}

/// A mean normalised square with its reading, as the tables print it (`0.867 consistent`);
/// `—` where the analyzer has none.
fn read(figure: Option<(f64, Reading)>) -> String {
    figure.map_or("—".into(), |(value, reading)| format!("{value:.3} {}", reading.text()))
}

/// The weld's peak error as printed, a percentage; the other cases have none.
fn peak(case: Case, error: f64) -> String {
    weld_percent(case, error).map_or("—".into(), |percent| format!("{percent:+.1} %"))
}

/// The weld's peak error `error` (a fraction) in percent; `None` for the other cases.
fn weld_percent(case: Case, error: f64) -> Option<f64> {
    (case == Case::Weld).then_some(100.0 * error)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wheel's figures in the units `WheelFigures` has them: forces in N.
    fn wheel() -> WheelFigures {
        WheelFigures {
            correlation: 0.99,
            rmse: 300.0,
            running_rmse_mean: 250.0,
            running_rmse_var: 4.0e4,
            dynamic_std: 3000.0,
            peak_error: -0.5,
            band: Some((1.0, 27.0)),
            two_sigma: f64::NAN,
            one_sigma: f64::NAN,
            normalised_error: None,
        }
    }

    #[test]
    fn a_wheel_is_written_in_the_tables_units_and_under_their_names() {
        let after_step = WheelFigures { correlation: 0.98, ..wheel() };
        let json = serde_json::to_value(WheelTable::new(Case::Weld, 2, &wheel(), &after_step)).unwrap();
        let expected = serde_json::json!({
            "wheelset": 2,
            "correlation": 0.99,
            "rmse": 0.3,
            "running_rmse_mean": 0.25,
            "running_rmse_variance": 0.04,
            "dynamic_std": 3.0,
            "rmse_over_dynamic_std": 0.1,
            "weld_peak_error": -50.0,
            "psd_agreement_band": [1.0, 27.0],
            "two_sigma_coverage": null,
            "one_sigma_coverage": null,
            "normalised_error": null,
            "after_step_correlation": 0.98,
        });
        assert_eq!(json, expected);
        // Each dimensional figure has its unit in the table's `units`.
        let units = units(&UNITS);
        for (name, unit) in [("rmse", "kN"), ("running_rmse_variance", "kN²"), ("weld_peak_error", "%")] {
            assert_eq!(units[name], unit, "{name}");
        }
    }

    #[test]
    fn the_worst_normalised_error_is_the_farthest_from_one_in_ratio() {
        let with_mean = |mean_square: f64| WheelFigures {
            normalised_error: Some(NormalisedError {
                mean_square,
                samples: 100,
                effective_samples: 100.0,
                interval: [0.7, 1.3],
                reading: Reading::Consistent,
            }),
            ..wheel()
        };
        // 0.3 is farther from 1 in ratio (1/0.3 ≈ 3.3) than 2.5, though nearer in difference.
        let wheels = [with_mean(1.1), with_mean(2.5), with_mean(0.3), wheel()];
        let (index, worst) = farthest_from_one(&wheels).unwrap();
        assert_eq!((index, worst.mean_square), (2, 0.3));
        assert_eq!(farthest_from_one(&[wheel(), wheel()]), None);
    }

    #[test]
    fn only_the_weld_has_a_peak_error() {
        for case in [Case::Random, Case::Corrugation] {
            assert_eq!(WheelTable::new(case, 1, &wheel(), &wheel()).weld_peak_error, None, "{}", case.name());
            assert_eq!(peak(case, -0.5), "—");
        }
        assert_eq!(peak(Case::Weld, -0.5), "-50.0 %");
    }
}
