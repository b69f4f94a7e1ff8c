//! S1 in `kalfmu reproduce`: every case through the packaged FMU with every filter,
//! one log per run and one comparison per case, and the table beside the paper's figures,
//! printed and written as `table.json` ([`Table`]). Beside each filter's accuracy, whether
//! its σ of the load is honest: the analyzer's 1σ and 2σ coverage and mean (e/σ)² of `F`,
//! and its NIS against the measurement rows used (docs/analyzer.md, "Is the σ honest?").

use std::fmt::Write as _;
use std::path::Path;

use start_values::StartValues;

use analyzer::consistency::{Nis, NormalisedError, Reading};
use analyzer::report::{analyse, Options, PairReport, Report};
use anyhow::Context;
use estimator::FilterKind;
use indicatif::{ProgressBar, ProgressStyle};
use log_format::read::read_log;
use log_format::write::PREDICTION;

use serde::Serialize;

use crate::comparison::{compare_case, log_path, units, write_table};
use cosim::fmu_driver::ImportedFmu;
use truth::s1::{Case, Settings};

/// The figures of S1's table, as `table.json` has them.
#[derive(Debug, Serialize)]
pub struct Table {
    /// `"S1"`.
    pub study: &'static str,
    /// The set-up the figures are of.
    pub settings: TableSettings,
    /// The unit of each dimensional field (see [`units`]).
    pub units: std::collections::BTreeMap<&'static str, &'static str>,
    /// Where the `paper` figures come from.
    pub paper_source: &'static str,
    /// One entry per case, in the table's order.
    pub cases: Vec<CaseFigures>,
}

/// The set-up of a [`Table`].
#[derive(Debug, Serialize)]
pub struct TableSettings {
    /// Simulated duration (s).
    pub duration: f64,
    /// Sampling rate (Hz).
    pub rate: f64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// Seed of the load and of the noise.
    pub seed: u64,
    /// The running RMSE's trailing window (s).
    pub rmse_window: f64,
}

/// One case of a [`Table`]: the paper's SRCKF figures and every filter's.
#[derive(Debug, Serialize)]
pub struct CaseFigures {
    /// The case, as printed (`stiffness/random`, …).
    pub case: String,
    /// The paper's SRCKF figures; `null` where it gives none.
    pub paper: PaperFigures,
    /// Why the case's runs could not be compared, if they could not (then `filters` is empty).
    pub failure: Option<String>,
    /// One entry per filter kind, in the table's order.
    pub filters: Vec<FilterFigures>,
}

/// The paper's figures of a case (its SRCKF).
#[derive(Debug, Serialize)]
pub struct PaperFigures {
    /// Correlation of the identified load with the true one.
    pub correlation: f64,
    /// Largest running RMSE (N).
    pub running_rmse_peak: Option<f64>,
    /// The bound the running RMSE stays under after the start (N).
    pub running_rmse_max_converged: Option<f64>,
}

/// One filter's figures on a case: the load `F` read at t after the inputs of t were set
/// (`feedthrough`, the table's first columns) and right after the step (`after_step`).
#[derive(Debug, Serialize)]
pub struct FilterFigures {
    /// The filter kind (`SRCKF`, …).
    pub filter: &'static str,
    /// Why the run failed, if it did (then the figures are `null`).
    pub failure: Option<String>,
    /// The figures of the feedthrough reading.
    pub feedthrough: Option<FeedthroughFigures>,
    /// The figures of the reading after `fmi2DoStep`, against the truth at t + dt.
    pub after_step: Option<AfterStepFigures>,
    /// The NIS of the run's updates against the measurement rows they used, the analyzer's
    /// (`null` if the run failed or its log has no `nis`).
    pub nis: Option<Nis>,
}

/// The feedthrough reading's figures of the load.
#[derive(Debug, Serialize)]
pub struct FeedthroughFigures {
    /// Correlation with the true load.
    pub correlation: f64,
    /// RMSE after the convergence time (N).
    pub rmse_converged: f64,
    /// Largest running RMSE (N).
    pub running_rmse_peak: f64,
    /// Largest running RMSE after the convergence time (N).
    pub running_rmse_max_converged: f64,
    /// When the estimate is taken to have converged (s).
    pub convergence_time: f64,
    /// The widest band where the spectra agree within 3 dB, `[low, high]` (Hz).
    pub psd_agreement_band: Option<(f64, f64)>,
    /// Fraction of samples whose error is within the FMU's ±σ of the load (0.6827 for an
    /// honest σ and a Gaussian error; `null` without σ).
    pub one_sigma_coverage: Option<f64>,
    /// Fraction of samples whose error is within ±2σ (0.9545 for an honest σ).
    pub two_sigma_coverage: Option<f64>,
    /// The mean of `(e/σ)²` (1 for an honest σ) with its reading, the analyzer's.
    pub normalised_error: Option<NormalisedError>,
}

/// The after-step reading's figures of the load.
#[derive(Debug, Serialize)]
pub struct AfterStepFigures {
    /// Correlation with the true load.
    pub correlation: f64,
    /// RMSE after the convergence time (N).
    pub rmse_converged: f64,
}

/// The units of S1's [`Table`].
const UNITS: [(&str, &str); 8] = [
    ("duration", "s"),
    ("rate", "Hz"),
    ("rmse_window", "s"),
    ("rmse_converged", "N"),
    ("running_rmse_peak", "N"),
    ("running_rmse_max_converged", "N"),
    ("convergence_time", "s"),
    ("psd_agreement_band", "Hz"),
];

/// Runs S1 through its FMU, prints the table and writes it as `table.json` in `out/s1`;
/// returns the number of failed runs.
pub fn report(settings: &Settings, start_values: &StartValues, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, "kalfmu_s1_load")?;
    fmu.check_start_values(start_values)?;
    let dir = out.join("s1");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    println!(
        "S1: dynamic load on a 2-DOF nonlinear chain — {} s at {} Hz, truth RK4 at {:.0e} s, accelerometer noise {:.1} % of RMS, seed {}",
        settings.duration,
        settings.rate,
        settings.dt() / settings.truth_substeps() as f64,
        100.0 * settings.noise_fraction,
        settings.seed
    );
    println!(
        "estimates from {} driven through the fmi importer; per run a log (<case>_<filter>.mcap), per case a comparison \
         of every filter (<case>.json, and the Rerun recording <case>.rrd) in {}",
        fmu_dir.join("kalfmu_s1_load.fmu").display(),
        dir.display()
    );
    println!(
        "running RMSE over a trailing {} s window; 'conv' = after the convergence time (analyzer/src/metrics.rs)",
        settings.rmse_window
    );
    println!(
        "two readings of the FMU's outputs, as a master has them: at t after the inputs of t were set (feedthrough, \
         the first columns) and right after fmi2DoStep(t, dt), the estimate at t + dt predicted from the measurements \
         up to t ('after step'); each compared with the truth at its own time stamp"
    );
    let runs = (Case::ALL.len() * FilterKind::ALL.len()) as u64;
    let ticks_per_run = (settings.samples() / 1000) as u64;
    let bar = ProgressBar::new(runs * ticks_per_run.max(1));
    bar.set_style(ProgressStyle::with_template("{bar:40} {pos}/{len} {msg} [{elapsed}]").expect("a valid template"));
    let mut table = String::new();
    let _ = writeln!(
        table,
        "{:<19} {:<8} {:>8} {:>6} {:>9} {:>9} {:>7} {:>10} {:>7} {:>7} {:>12}  {:>10} {:>10}  {:>6} {:>6} {:>17} {:>17}",
        "case",
        "filter",
        "corr",
        "paper",
        "RMSE conv",
        "run.peak",
        "paper",
        "run.max cv",
        "paper",
        "t_conv",
        "PSD ±3dB Hz",
        "after step",
        "RMSE conv",
        "1σ F",
        "2σ F",
        "(e/σ)² F",
        "NIS/rows"
    );
    let mut failures = 0;
    let mut recordings = Vec::new();
    let options = Options { rmse_window: settings.rmse_window, ..Options::default() };
    let paper = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.3}"));
    let mut cases = Vec::new();
    for case in Case::ALL {
        let (truth, measurements) = truth::s1::simulate(&case, settings);
        let published = super::published(&case);
        let case_stem = dir.join(case.to_string().replace('/', "_"));
        // Each filter's run through the FMU, logged and read back.
        let mut runs = Vec::new();
        let mut rows: Vec<(FilterKind, anyhow::Result<usize>)> = Vec::new();
        for kind in FilterKind::ALL {
            bar.set_message(format!("{case} {kind}"));
            let log = log_path(&case_stem, kind);
            let sim = super::fmu_run::Simulated {
                case: &case,
                settings,
                truth: &truth,
                measurements: &measurements,
                start_values,
            };
            let result = super::fmu_run::run(&fmu, kind, &sim, &log, &|| bar.inc(1))
                .and_then(|()| Ok(read_log(&log)?))
                .map(|run| {
                    runs.push(run);
                    runs.len() - 1
                });
            rows.push((kind, result));
        }
        // All of the case's runs in one comparison: JSON and one recording.
        let compared = compare_case(&runs, &options, &case_stem).and_then(|(comparison, recording)| {
            recordings.push(recording);
            let after_step =
                runs.iter().map(|run| analyse(run, &Options { estimate_topic: PREDICTION.into(), ..options.clone() }));
            let after_step = after_step.collect::<Result<Vec<_>, _>>()?;
            let loads = comparison.runs.iter().zip(&after_step).map(|(report, after)| {
                let (Some(pair), Some(after)) = (load_pair(report), load_pair(after)) else {
                    return Err(format!("the report of {} has no load pair", report.file));
                };
                let sigma = SigmaOfLoad {
                    one_sigma_coverage: pair.one_sigma_coverage,
                    two_sigma_coverage: pair.two_sigma_coverage,
                    normalised_error: pair.normalised_error,
                    nis: report.nis.clone(),
                };
                Ok((pair.metrics, pair.psd_agreement_band, after.metrics, sigma))
            });
            Ok(loads.collect::<Vec<_>>())
        });
        let mut figures = CaseFigures {
            case: case.to_string(),
            paper: PaperFigures {
                correlation: published.correlation,
                running_rmse_peak: published.running_rmse_peak,
                running_rmse_max_converged: published.running_rmse_max_converged,
            },
            failure: None,
            filters: Vec::new(),
        };
        let loads = match compared {
            Ok(loads) => loads,
            Err(e) => {
                failures += 1;
                let _ = writeln!(table, "{:<19} FAILED to compare the filters: {e}", case.to_string());
                figures.failure = Some(e.to_string());
                cases.push(figures);
                continue;
            }
        };
        for (kind, result) in rows {
            match result.and_then(|i| loads[i].clone().map_err(anyhow::Error::msg)) {
                Ok((c, band, a, sigma)) => {
                    let _ = writeln!(
                        table,
                        "{:<19} {:<8} {:>8.5} {:>6.3} {:>9.4} {:>9.3} {:>7} {:>10.4} {:>7} {:>6.2}s {:>12}  {:>10.5} \
                         {:>10.4}  {:>6} {:>6} {:>17} {:>17}",
                        case.to_string(),
                        kind.name(),
                        c.correlation,
                        published.correlation,
                        c.rmse_converged,
                        c.running_rmse_peak,
                        paper(published.running_rmse_peak),
                        c.running_rmse_max_converged,
                        paper(published.running_rmse_max_converged),
                        c.convergence_time,
                        band.map_or("—".into(), |(lo, hi)| format!("{lo:.2}–{hi:.1}")),
                        a.correlation,
                        a.rmse_converged,
                        coverage(sigma.one_sigma_coverage),
                        coverage(sigma.two_sigma_coverage),
                        read(sigma.normalised_error.map(|n| (n.mean_square, n.reading))),
                        read(sigma.nis.as_ref().and_then(|n| n.ratio.zip(n.reading)))
                    );
                    figures.filters.push(FilterFigures {
                        filter: kind.name(),
                        failure: None,
                        feedthrough: Some(FeedthroughFigures {
                            correlation: c.correlation,
                            rmse_converged: c.rmse_converged,
                            running_rmse_peak: c.running_rmse_peak,
                            running_rmse_max_converged: c.running_rmse_max_converged,
                            convergence_time: c.convergence_time,
                            psd_agreement_band: band,
                            one_sigma_coverage: sigma.one_sigma_coverage,
                            two_sigma_coverage: sigma.two_sigma_coverage,
                            normalised_error: sigma.normalised_error,
                        }),
                        after_step: Some(AfterStepFigures {
                            correlation: a.correlation,
                            rmse_converged: a.rmse_converged,
                        }),
                        nis: sigma.nis,
                    });
                }
                Err(e) => {
                    failures += 1;
                    let _ = writeln!(table, "{:<19} {:<8} FAILED: {e:#}", case.to_string(), kind.name());
                    figures.filters.push(FilterFigures {
                        filter: kind.name(),
                        failure: Some(format!("{e:#}")),
                        feedthrough: None,
                        after_step: None,
                        nis: None,
                    });
                }
            }
        }
        cases.push(figures);
    }
    bar.finish_and_clear();
    write_table(
        &dir,
        &Table {
            study: "S1",
            settings: TableSettings {
                duration: settings.duration,
                rate: settings.rate,
                noise_fraction: settings.noise_fraction,
                seed: settings.seed,
                rmse_window: settings.rmse_window,
            },
            units: units(&UNITS),
            paper_source: PAPER_SOURCE,
            cases,
        },
    )?;
    print!("{table}");
    println!("paper: {PAPER_SOURCE} (correlation; running-RMSE peak; bound after the start), N");
    println!("comparison recordings, every filter of a case in one (open with the Rerun viewer 0.36 or newer):");
    for recording in &recordings {
        println!("  {}", recording.display());
    }
    Ok(failures)
}

/// Where the paper's figures come from, as the table's footnote names it.
const PAPER_SOURCE: &str = "SRCKF figures of Gong et al. 2024";

/// The report's pair of the load `F`.
fn load_pair<'a>(report: &'a Report<'_>) -> Option<&'a PairReport<'a>> {
    report.pairs.iter().find(|p| p.truth == "F")
}

/// What the analyzer's report of a run says of its σ: of the load `F` (feedthrough reading)
/// and of its innovations.
#[derive(Debug, Clone)]
struct SigmaOfLoad {
    one_sigma_coverage: Option<f64>,
    two_sigma_coverage: Option<f64>,
    normalised_error: Option<NormalisedError>,
    nis: Option<Nis>,
}

/// A coverage as the table prints it; `—` without σ.
fn coverage(fraction: Option<f64>) -> String {
    fraction.map_or("—".into(), |f| format!("{f:.3}"))
}

/// A mean normalised square with its reading, as the table prints it (`1.056 consistent`);
/// `—` where the analyzer has none.
fn read(figure: Option<(f64, Reading)>) -> String {
    figure.map_or("—".into(), |(value, reading)| format!("{value:.3} {}", reading.text()))
}
