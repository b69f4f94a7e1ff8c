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
//! - **vs library**: the largest difference between the FMU's forces and the same filter
//!   run in-process on the same measurements (`study::run_filter`): the FMU in a
//!   co-simulation must give what our own runs give.

use std::fmt::Write as _;
use std::path::Path;

use analyzer::report::{analyse, Options, PairReport};
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::read_log;
use log_format::write::{ESTIMATE, PREDICTION};

use super::fmu_run::{self, Simulated, IDENTIFIER};
use super::study::{run_filter, user_vehicle, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of};
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
        }
    }
}

/// Runs S2 through its FMU and prints the tables; returns the number of failed runs.
pub fn report(settings: &Settings, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
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
        "{:<12} {:>5} {:>8} {:>6} {:>8} {:>6} {:>8} {:>6} {:>8} {:>8} {:>12} {:>6} {:>10}",
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
        "after step"
    );
    let mut filters = String::new();
    let _ = writeln!(
        filters,
        "{:<12} {:<8} {:>9} {:>11} {:>9} {:>10} {:>9} {:>10} {:>12}",
        "case", "filter", "corr min", "RMSE/σd max", "peak err", "2σ min", "rejected", "after step", "vs library N"
    );
    let mut failures = 0;
    let mut recordings = Vec::new();
    for case in Case::ALL {
        let truth = simulate(case, settings);
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let tuning = Tuning::new(settings, measurements.noise_std);
        let parameters = fmu_run::parameters(&catalogue, truth_car.static_wheel_load(), &tuning);
        let sim = Simulated { case, settings, truth: &truth, measurements: &measurements, parameters: &parameters };
        let stem = dir.join(case.name());
        let mut runs = Vec::new();
        let mut ran: Vec<(FilterKind, Counts, f64)> = Vec::new();
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
                per_run.push((wheels(&report.pairs), wheels(&after.pairs)));
            }
            Ok(per_run)
        });
        let figures = match figures {
            Ok(figures) => figures,
            Err(e) => {
                failures += 1;
                let _ = writeln!(filters, "{:<12} FAILED to compare the filters: {e}", case.name());
                continue;
            }
        };
        let (paper_corr, paper_rmse, paper_var) = published(case);
        for ((kind, counts, difference), (wheels, after)) in ran.iter().zip(&figures) {
            if *kind == FilterKind::SrCkf {
                for (j, (w, a)) in wheels.iter().zip(after).enumerate() {
                    let paper = |v: f64, digits: usize| if j == 0 { format!("{v:.digits$}") } else { "".into() };
                    let _ = writeln!(
                        srckf,
                        "{:<12} {:>5} {:>8.4} {:>6} {:>8.3} {:>6} {:>8.4} {:>6} {:>8.3} {:>8} {:>12} {:>6.3} {:>10.4}",
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
                        a.correlation
                    );
                }
            }
            let worst = |f: fn(&WheelFigures) -> f64, pick: fn(f64, f64) -> f64, start: f64| {
                wheels.iter().map(f).fold(start, pick)
            };
            let _ = writeln!(
                filters,
                "{:<12} {:<8} {:>9.4} {:>11.3} {:>9} {:>10.3} {:>9} {:>10.4} {:>12.1e}",
                case.name(),
                kind.name(),
                worst(|w| w.correlation, f64::min, f64::INFINITY),
                worst(|w| w.rmse / w.dynamic_std, f64::max, 0.0),
                peak(case, worst(|w| w.peak_error, |a, b| if b.abs() > a.abs() { b } else { a }, 0.0)),
                worst(|w| w.two_sigma, f64::min, f64::INFINITY),
                counts.rejected,
                after.iter().map(|a| a.correlation).fold(f64::INFINITY, f64::min),
                difference
            );
        }
    }
    println!("SRCKF (the paper's filter), per wheelset; the paper's figures are for wheelset 1:");
    print!("{srckf}");
    println!("every filter, the worst of the four wheels (rejected: measurement rows the FMU's gate left out):");
    print!("{filters}");
    println!(
        "paper: SRCKF figures of the seed study for wheelset 1 at 200 Hz, its truth and estimator sharing one model \
         (RMSE 0.2 % of the wheel load); ours differ (track, Hertz contact, the user's catalogue values)"
    );
    println!("comparison recordings, every filter of a case in one (open with the Rerun viewer 0.36 or newer):");
    for recording in &recordings {
        println!("  {}", recording.display());
    }
    Ok(failures)
}

/// The weld's peak error as a percentage; the other cases have none.
fn peak(case: Case, error: f64) -> String {
    if case == Case::Weld {
        format!("{:+.1} %", 100.0 * error)
    } else {
        "—".into()
    }
}
