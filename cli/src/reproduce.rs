//! `kalfmu reproduce`: the main job. For every study and case it runs the
//! truth simulator, drives the packaged estimator FMU through the `fmi`
//! importer exactly as an external simulator would, writes the MCAP log,
//! analyses it with the analyzer (reading the log back, as a user would), and
//! prints our figures beside the papers'. Each study's table is its own
//! module's (`s1::reproduce`, `s2::reproduce`, …).
//!
//! # The tables as JSON
//!
//! Each study also writes the figures of the table it prints as `<out>/<study>/table.json`
//! (`out/s1/table.json`, `out/s2/…`, `out/s3/…`, `out/s4/…`, `out/s5/…`), beside its logs, so that
//! scripts and tests need not parse the printed text. The numbers are full precision, not
//! the printed digits; a figure that is not a number is `null`, and so is one a run could
//! not give (its entry's `failure` then says why). Every file has `study` (`"S1"`, …) and
//! `units`, the unit of each dimensional field by name (fields it does not list are
//! dimensionless: correlations, fractions, counts). Filter kinds are named as printed
//! (`CKF`, `SRCKF`, `SVD-CKF`, `UKF`, `EKF`).
//!
//! Beside every accuracy figure, each study prints and writes whether the σ behind it is
//! honest: the analyzer's figures of the filter's log (`analyzer::consistency`; the
//! comparison's `<case>.json` has the same numbers), under the analyzer's names. Per signal
//! (the *σ figures*): `one_sigma_coverage` and `two_sigma_coverage` (0.6827 and 0.9545 for
//! an honest σ) and `normalised_error` (`mean_square`, 1 for an honest σ, `samples`,
//! `effective_samples`, `interval`, `reading`: `consistent`, `too wide` or `too narrow`);
//! per run `nis` (`mean`, `samples`, `rows_used_mean`, `rows_used_from`,
//! `rejections_known`, `ratio` Σ NIS / Σ rows used, `effective_dof`, `interval`,
//! `reading`, `in_band`) and, in S5, `nees` (`signals`, `dof`, `samples`, `mean`, `band`,
//! `in_band`). All of them are dimensionless, whatever `units` says of a namesake (S4's
//! `mean`, a speed error's).
//!
//! - **S1** (`studies::s1::reproduce::Table`): `settings` (`duration`, `rate`,
//!   `noise_fraction`, `seed`, `rmse_window`, `quick`, `start_values`: the `--set` and
//!   `--values` given, by name, `{}` without any); `cases[]`, the paper's four and then
//!   the unseen ones (`truth::s1::Case::UNSEEN`, loads the set-up was not made for: all
//!   six at 1 %, the run's and 5 % noise, or with `--quick` one), each with `case`,
//!   `published` (`false` for an unseen case), `noise_fraction` (its runs'), `paper`
//!   (`correlation`, `running_rmse_peak`, `running_rmse_max_converged`; `null` for an
//!   unseen case), `failure`, and `filters[]` (every kind; an unseen case the SRCKF only):
//!   `filter`, `failure`, `feedthrough` (`correlation`, `rmse_converged`,
//!   `running_rmse_peak`, `running_rmse_max_converged`, `convergence_time`,
//!   `psd_agreement_band` `[low, high]`, and the σ figures of the load `F`) and
//!   `after_step` (`correlation`, `rmse_converged`), and `nis`. An unseen case's logs and
//!   comparison are in `<out>/s1/unseen/` (`<case>_noise<percent>…`, `2p0` for 2 %).
//! - **S2** (`studies::s2::reproduce::Table`): `settings` (`speed`, `duration`, `rate`,
//!   `seed`, `noise_fraction`, `settle`, `rmse_window`, `quick`, `start_values`, and
//!   `start_values_fmu_only`: those the in-process filter has no parameter for, which
//!   reach the FMU only, so that `fmu_vs_in_process_max_abs_difference` then measures
//!   their effect); `cases[]`, the paper's three and then the unseen tracks
//!   (`truth::s2::cases::Scenario::UNSEEN`: `random/german-low` at 40 km/h,
//!   `random/german-high` at 160, `random/fra6` at 100, at the run's rate and then the
//!   other of 200 Hz and 1 kHz, or with `--quick` one), each with `case`, `published`,
//!   `speed` and `rate` (its runs'), `paper` (wheelset 1: `correlation`,
//!   `running_rmse_mean`, `running_rmse_variance`; `null` for an unseen track), `failure`,
//!   and `filters[]` (every kind, not only the SRCKF the first table prints; an unseen
//!   track the SRCKF only, its logs in `<out>/s2/unseen/`):
//!   `filter`, `failure`, `rejected_rows`, `fmu_vs_in_process_max_abs_difference`,
//!   `worst_wheel` (the second table's columns: `correlation_min`,
//!   `rmse_over_dynamic_std_max`, `weld_peak_error_max_abs`, `two_sigma_coverage_min`,
//!   `after_step_correlation_min`, `one_sigma_coverage_min`, and the wheel whose mean
//!   (e/σ)² is the farthest from 1 in ratio, `normalised_error_worst_wheelset` with its
//!   `normalised_error_worst`), `wheels[]` (`wheelset` 1–4, `correlation`, `rmse`,
//!   `running_rmse_mean`, `running_rmse_variance`, `dynamic_std`,
//!   `rmse_over_dynamic_std`, `weld_peak_error`, `psd_agreement_band`,
//!   `two_sigma_coverage`, `after_step_correlation`, `one_sigma_coverage`,
//!   `normalised_error`) and `nis`.
//! - **S3** (`studies::s3::reproduce::Table`): `settings` (`speed`, `duration`, `rate`,
//!   `seed`: the truth's, `--seed` plus one, `tuning_chosen_on_seed` 1, `noise_fraction`,
//!   `settle`, `filter` `SRCKF`, `quick`, `start_values`, `start_values_fmu_only`);
//!   `paper` (`left_correlation_min`, `right_correlation_min`, `sum_correlation`,
//!   `rmse_left_1`); `cases[]` (`random`, `joint`, `twist`, `random_alignment`), each with
//!   `case`, `failure`, `vertical_ceiling[]` (per wheelset the most a vertical model gives,
//!   `left_correlation`, `right_correlation`, `sum_correlation`,
//!   `difference_correlation`) and `runs[]`, the paper's random walks and ours with the
//!   accelerations alone and with the deflections: `force_model` (`random walk` or
//!   `returning`), `force_return_rate`, `sensors` (`accelerations` or `+ deflections`),
//!   `failure`, `rejected_rows`, `fmu_vs_in_process_max_abs_difference`, `nis` and
//!   `wheelsets[]` (`wheelset` 1–4 with `left`, `right`, `sum` and `difference`, each
//!   `correlation`, `rmse`, and the σ figures). Logs `<case>_<paper|ours>_<accelerations|
//!   deflections>.mcap`, comparisons `<case>.json`, `<case>.rrd`.
//! - **S4** (`studies::s4::reproduce::Table`): `seed`; `settings` (`seed`, `quick`,
//!   `start_values`, the values given by name, and `start_values_fmu_only`, those the
//!   in-process filter does not take); `paper` (`mean_abs_error_reduction_from_raw`,
//!   `raw_average_speed_range`, `paper_fused_ukf_speed_range`); `profiles[]`, one per case
//!   (`paper`, `paper_frequent`, and without `--quick` `high_speed`,
//!   `high_speed_frequent`), each with `case`, `profile` (the motion: `paper` or
//!   `high_speed`), `faults` (`default` or `frequent`, the default's rates ×10), `tuned_on`
//!   (`false` for `frequent`: a case the settings were not chosen on, not the paper's),
//!   `duration`, `telegrams`, `filters[]` (`filter`, `failure`,
//!   `fmu_vs_in_process_max_abs_difference`, `speed` and `position`, each with its σ
//!   figures, and `nis`), `compared_filter` and `comparison`: `raw_average`,
//!   `paper_fused`, `paper_fused_ukf` and `ours`, each with `speed` (`mean_abs_error`,
//!   `max_abs_error`, `speed_range`, `error_range`, `true_range`, …),
//!   `position_max_abs_error`, `in_etcs_band_fraction` and
//!   `mean_abs_error_reduction_from_raw`; `paper_detection` and `our_detection`, each with
//!   `kinds[]` (`name`, `injected`, `detected`), `false_alarms`, `channel_telegrams` and
//!   `false_alarm_fraction`.
//! - **S5** (`studies::s5::reproduce::Table`): `settings` (`seed`, `sample_time`,
//!   `noise_scale`, `quick`, `start_values`, `start_values_fmu_only`), `paper_claim`;
//!   `truths[]`, one per case (`6dof`, `6dof_roll_turn`, `jsbsim`, and without `--quick`
//!   `jsbsim_roll_turn`), each with `truth` (`6dof` or `jsbsim`), `manoeuvre` (`standard`,
//!   the published one, or `roll-turn`), `tuned_on` (`false` for `roll-turn`: a manoeuvre
//!   the tuning was not chosen on, not the paper's), `case` (the stem of its logs),
//!   `failures[]` (`filter`, `failure`), `tables[]` (`table` `Table 1` or `Table 2`,
//!   `time`, `coefficients[]`: `coefficient`, `true_value`, `paper_svd_ckf`,
//!   `paper_svd_ckf_relative_error` (both `null` for `roll-turn`), `relative_error` by
//!   filter kind) and `filters[]` (`filter`, `back_within_3_percent`,
//!   `back_within_1_percent`, `rejected_rows`, `fmu_vs_in_process_max_abs_difference` (these
//!   two for the first truth only), `nees` and `nis`, `one_sigma_coverage_min` and
//!   `two_sigma_coverage_min` of the coefficients, `normalised_error_worst_coefficient` (the
//!   farthest from 1 in ratio), and `coefficients`, each coefficient's σ figures by name).

use std::path::PathBuf;

use anyhow::bail;

use start_values::StartValues;
use studies::{s1, s2, s3, s4, s5};

/// Command-line arguments of `kalfmu reproduce`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which study to run: s1, s2, s3, s4, s5 or all.
    #[arg(long, default_value = "all")]
    pub study: String,
    /// A short run for smoke tests (S1: 10 s of signal; S2: 2.5 s; each with one of its
    /// unseen cases instead of all; S3: 2 s); the figures are then not the published set-up.
    #[arg(long)]
    pub quick: bool,
    /// Seed of the random load or track, and of the measurement noise (S3 runs this seed
    /// plus one: its tuning was chosen on seed 1).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    #[arg(long, default_value_t = 0.02)]
    pub noise: f64,
    /// Simulated duration in seconds (default: S1 60, or 10 with --quick; S2 4, or 2.5; S3
    /// 4, or 2).
    #[arg(long)]
    pub duration: Option<f64>,
    /// S2's sampling rate (Hz): 1000 (axle-box data acquisition) or 200 (the paper).
    #[arg(long, default_value_t = truth::s2::cases::Settings::default().rate)]
    pub s2_rate: f64,
    /// Where the packaged FMUs are (`package-fmus` writes them to target/fmu).
    #[arg(long, default_value = "target/fmu")]
    pub fmu_dir: PathBuf,
    /// The Python that runs S5's JSBSim driver (scripts/setup --tests makes it).
    #[arg(long, default_value = ".venv/bin/python")]
    pub python: PathBuf,
    /// Where the logs, reports and recordings go.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Start values of the study's FMU over the study's own settings (they belong to one
    /// FMU, so they need --study).
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// The studies, in the order they run.
const STUDIES: [&str; 5] = ["s1", "s2", "s3", "s4", "s5"];

/// Runs the subcommand; fails if any filter run failed or the study is unknown.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let wanted = args.study.to_ascii_lowercase();
    if wanted != "all" && !STUDIES.contains(&wanted.as_str()) {
        bail!("unknown study '{}'; expected one of s1, s2, s3, s4, s5, all", args.study);
    }
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    if !start_values.is_empty() && wanted == "all" {
        bail!("--set and --values give one FMU's parameters: name its study with --study");
    }
    if let Some(lag) = start_values.get("smoothing_lag") {
        bail!(
            "smoothing_lag = {lag}: reproduce sets it ({} s) and prints the smoothed figures of that lag; run the FMU \
             with another lag through your own master",
            studies::smoothed::SMOOTHING_LAG
        );
    }
    let mut failures = 0;
    for id in STUDIES {
        if wanted != "all" && wanted != id {
            continue;
        }
        failures += match id {
            "s1" => {
                let settings = truth::s1::Settings {
                    seed: args.seed,
                    noise_fraction: args.noise,
                    duration: args.duration.unwrap_or(if args.quick {
                        10.0
                    } else {
                        truth::s1::Settings::default().duration
                    }),
                    ..truth::s1::Settings::default()
                };
                settings.validate().map_err(anyhow::Error::msg)?;
                s1::reproduce::report(&settings, &start_values, args.quick, &args.fmu_dir, &args.out)?
            }
            "s2" => {
                let settings = truth::s2::cases::Settings {
                    seed: args.seed,
                    noise_fraction: args.noise,
                    rate: args.s2_rate,
                    // The weld reaches the last wheel 1.9 s in.
                    duration: args.duration.unwrap_or(if args.quick {
                        2.5
                    } else {
                        truth::s2::cases::Settings::default().duration
                    }),
                    ..truth::s2::cases::Settings::default()
                };
                settings.validate().map_err(anyhow::Error::msg)?;
                s2::reproduce::report(&settings, &start_values, args.quick, &args.fmu_dir, &args.out)?
            }
            "s3" => {
                let settings = truth::s3::cases::Settings {
                    // Its tuning was chosen on seed 1: the table is of the seeds after it.
                    seed: args.seed + s3::study::Tuning::CHOSEN_ON_SEED,
                    noise_fraction: args.noise,
                    // The joint reaches the last wheel 1.8 s in.
                    duration: args.duration.unwrap_or(if args.quick {
                        2.0
                    } else {
                        truth::s3::cases::Settings::default().duration
                    }),
                    ..truth::s3::cases::Settings::default()
                };
                settings.validate().map_err(anyhow::Error::msg)?;
                s3::reproduce::report(&settings, &start_values, args.quick, &args.fmu_dir, &args.out)?
            }
            "s4" => s4::reproduce::report(args.seed, args.quick, &start_values, &args.fmu_dir, &args.out)?,
            "s5" => {
                let settings =
                    truth::s5::flight::Settings { seed: args.seed, ..truth::s5::flight::Settings::default() };
                s5::reproduce::report(&settings, &start_values, args.quick, &args.fmu_dir, &args.out, &args.python)?
            }
            _ => unreachable!("every study has a table"),
        };
        println!();
    }
    if failures > 0 {
        bail!("{failures} filter run(s) failed");
    }
    Ok(())
}
