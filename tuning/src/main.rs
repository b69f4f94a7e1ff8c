//! `kalfmu-tune`: fits an estimator FMU's noise parameters to recorded logs of its
//! measurements by maximum likelihood, prints the estimates with their 95 % intervals and
//! the fitted filter's consistency, and writes them as FMU start values (SSV) and as
//! `--set NAME=VALUE` lines, and on request each log with the tuned estimator's filtered
//! and whole-log smoothed estimates (`--smoothed-log`). `docs/tuning.md` is its manual.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Parser;
use estimator::FilterKind;
use log_format::read::Run;
use rayon::prelude::*;
use tuning::likelihood::RobustCap;
use tuning::optimise::SearchOptions;
use tuning::{fit, log_input, report, smoothed_log, ssv, FitOptions, FmuEstimator, Likelihood, Record, Shard};

/// Fit an estimator FMU's noise parameters to recorded logs (tuning from data).
#[derive(Parser, Debug)]
#[command(name = "kalfmu-tune", version)]
struct Cli {
    /// MCAP logs of the estimator's measurements and known inputs (channel /measurements).
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// The FMU's model identifier (e.g. kalfmu_s1_load); default: inferred from the logs.
    #[arg(long)]
    fmu: Option<String>,
    /// The parameters to fit, comma-separated; default: the FMU's tunable noise parameters.
    #[arg(long, value_delimiter = ',')]
    fit: Vec<String>,
    /// Parameter values (starts of fitted ones, fixed ones such as the vehicle's data):
    /// SSV files, then single values.
    #[command(flatten)]
    start_values: start_values::Options,
    /// The filter method (CKF, SRCKF, SVD-CKF, UKF, EKF); default: the FMU's default.
    #[arg(long)]
    filter: Option<String>,
    /// Use only the first this many seconds of each log.
    #[arg(long)]
    seconds: Option<f64>,
    /// Search on the first this many seconds, then refine on the whole span (faster).
    #[arg(long)]
    coarse_seconds: Option<f64>,
    /// Fit each log on its own (default: one fit over all logs together).
    #[arg(long)]
    per_log: bool,
    /// Use the logs K-1, K-1+N, … of the list (0-based), as the sweeps' --shard.
    #[arg(long, default_value = "1/1", value_name = "K/N")]
    shard: Shard,
    /// Write the estimates as FMU start values to this SSV file ({log} is the log's name).
    #[arg(long, value_name = "OUT.ssv")]
    ssv: Option<PathBuf>,
    /// Run the FMU's whole loop (gate, faults, adaptation) with the fitted values (with
    /// --evaluate: the start values) over each log and write it with the filtered
    /// estimates on /estimate and the estimates given the whole log (fixed-interval
    /// smoothing) on /smoothed, to this MCAP file ({log} is the log's name).
    #[arg(long, value_name = "OUT.mcap")]
    smoothed_log: Option<PathBuf>,
    /// The robust cap on a row's normalised innovation (inf: none).
    #[arg(long, default_value_t = RobustCap::DEFAULT.threshold)]
    cap: f64,
    /// Cap in the likelihood only: the filter takes the rows beyond the cap as they are.
    #[arg(long)]
    no_winsorise: bool,
    /// The simplex's initial step (ln units).
    #[arg(long, default_value_t = SearchOptions::default().initial_step)]
    initial_step: f64,
    /// The most simplex iterations.
    #[arg(long, default_value_t = SearchOptions::default().max_iterations)]
    max_iterations: u64,
    /// The most Newton steps on the whole span after the search.
    #[arg(long, default_value_t = FitOptions::default().refinements)]
    refinements: usize,
    /// Start from the FMU's start values, not from the parameters the log says were set.
    #[arg(long)]
    ignore_logged_parameters: bool,
    /// Only evaluate the likelihood and the NIS at the start values (no fit).
    #[arg(long)]
    evaluate: bool,
}

/// One log, read.
struct Log {
    path: PathBuf,
    run: Run,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let clock = Instant::now();
    let paths = cli.shard.select(&cli.logs);
    if paths.is_empty() {
        println!("shard {}/{} has none of the {} logs", cli.shard.index, cli.shard.count, cli.logs.len());
        return Ok(());
    }
    let logs: Vec<Log> = paths
        .par_iter()
        .map(|path| {
            let (run, warnings) = log_input::read(path).map_err(anyhow::Error::msg)?;
            for w in warnings {
                eprintln!("warning: {w}");
            }
            Ok(Log { path: path.clone(), run })
        })
        .collect::<anyhow::Result<_>>()?;
    let identifier = match &cli.fmu {
        Some(id) => id.clone(),
        None => {
            let ids: Vec<String> = logs
                .iter()
                .map(|l| log_input::identify(&l.run))
                .collect::<Result<_, _>>()
                .map_err(anyhow::Error::msg)?;
            if ids.iter().any(|id| id != &ids[0]) {
                bail!("the logs are of different FMUs ({}); fit them apart", ids.join(", "));
            }
            ids[0].clone()
        }
    };
    let groups: Vec<Vec<&Log>> =
        if cli.per_log { logs.iter().map(|l| vec![l]).collect() } else { vec![logs.iter().collect()] };
    if cli.per_log && groups.len() > 1 {
        if let Some(out) = &cli.ssv {
            if !out.to_string_lossy().contains("{log}") {
                bail!("--per-log with several logs: put {{log}} in the --ssv path, e.g. tuned_{{log}}.ssv");
            }
        }
    }
    if let Some(out) = &cli.smoothed_log {
        if logs.len() > 1 && !out.to_string_lossy().contains("{log}") {
            bail!("several logs: put {{log}} in the --smoothed-log path, e.g. smoothed_{{log}}.mcap");
        }
    }
    // Several groups run in parallel, one per task; each prints when all are done, in order.
    let outcomes: Vec<anyhow::Result<String>> =
        groups.par_iter().with_max_len(1).map(|group| tune(&cli, &identifier, group)).collect();
    let mut failed = 0;
    for outcome in outcomes {
        match outcome {
            Ok(text) => print!("{text}"),
            Err(e) => {
                failed += 1;
                eprintln!("error: {e:#}");
            }
        }
    }
    println!("total wall time {:.2} s", clock.elapsed().as_secs_f64());
    if failed > 0 {
        bail!("{failed} of the fits failed");
    }
    Ok(())
}

/// The file name of a log without its extension.
fn stem(path: &Path) -> String {
    path.file_stem().map_or_else(|| "log".into(), |s| s.to_string_lossy().into_owned())
}

/// Fits one group of logs together and returns what to print.
fn tune(cli: &Cli, identifier: &str, logs: &[&Log]) -> anyhow::Result<String> {
    let mut estimator = FmuEstimator::by_identifier(identifier).map_err(anyhow::Error::msg)?;
    let mut out = String::new();
    if !cli.ignore_logged_parameters {
        let logged = log_input::logged_parameters(&logs[0].run).map_err(anyhow::Error::msg)?;
        for other in &logs[1..] {
            if log_input::logged_parameters(&other.run).map_err(anyhow::Error::msg)? != logged {
                out.push_str(&format!(
                    "note: {} set other parameters than {}; the first log's are used\n",
                    other.path.display(),
                    logs[0].path.display()
                ));
            }
        }
        for (name, value) in logged {
            if let Err(why) = estimator.set(&name, value) {
                out.push_str(&format!("note: logged parameter {name} = {value} not used: {why}\n"));
            }
        }
    }
    let given = start_values::StartValues::from_options(&cli.start_values).map_err(anyhow::Error::msg)?;
    for (name, value) in given.iter() {
        estimator.set(name, value).map_err(anyhow::Error::msg).context("--values/--set")?;
    }
    if let Some(name) = &cli.filter {
        let kind: FilterKind = name.parse().map_err(|e: estimator::FilterError| anyhow::anyhow!("--filter: {e}"))?;
        estimator.set_filter(kind).map_err(anyhow::Error::msg)?;
    }
    if !cli.fit.is_empty() {
        estimator.choose_fitted(&cli.fit).map_err(anyhow::Error::msg).context("--fit")?;
    }
    estimator.check().map_err(anyhow::Error::msg)?;
    let sample_time = estimator.value("sample_time").map_err(anyhow::Error::msg)?;
    let mut records = Vec::new();
    for log in logs {
        let mut record = log_input::record(&log.run, estimator.descriptor()).map_err(anyhow::Error::msg)?;
        if let Some(seconds) = cli.seconds {
            record = record.leading(seconds);
        }
        record.check_grid(sample_time).map_err(|e| anyhow::anyhow!("{}: {e}", log.path.display()))?;
        if record.is_empty() {
            bail!("{}: no sample in the span used", log.path.display());
        }
        records.push(record);
    }
    let names = estimator.fitted_names();
    let units: Vec<Option<&str>> = names.iter().map(|n| estimator.unit(n)).collect();
    let start = estimator.start_values().map_err(anyhow::Error::msg)?;
    let samples: usize = records.iter().map(|r| r.len()).sum();
    let seconds: f64 = records.iter().map(|r| r.duration() + sample_time).sum();
    let present: usize = records.iter().map(|r| r.present_rows()).sum();
    let sources: Vec<String> = logs.iter().map(|l| l.path.display().to_string()).collect();
    let kind = estimator.filter().map_err(anyhow::Error::msg)?;
    out.insert_str(
        0,
        &format!(
            "\n== {identifier}, {kind}, {} log(s): {}\ndata: {samples} samples, {seconds:.3} s at {} s, {present} \
             measurement rows present; fitting {}\n",
            logs.len(),
            sources.join(", "),
            sample_time,
            names.join(", ")
        ),
    );
    let cap = if cli.no_winsorise { RobustCap::at(cli.cap).in_likelihood_only() } else { RobustCap::at(cli.cap) };
    let likelihood = Likelihood::new(&estimator, records, cap);
    let options = FitOptions {
        search: SearchOptions {
            initial_step: cli.initial_step,
            max_iterations: cli.max_iterations,
            ..SearchOptions::default()
        },
        coarse_seconds: cli.coarse_seconds,
        refinements: cli.refinements,
        ..FitOptions::default()
    };
    if let Some(s) = cli.coarse_seconds {
        out.push_str(&format!("coarse search on the first {s} s of each log, then refinement on the whole span\n"));
    }
    if cli.evaluate {
        let clock = Instant::now();
        let e = likelihood.at_values(&start);
        let band = tuning::consistency::NisBand::at_95(e.rows);
        out.push_str(&format!(
            "log-likelihood at the start values: {:.3} ({:.3} s for one evaluation)\nNIS per row used: {:.4}; 95 % \
             band for {} rows [{:.4}, {:.4}]; rows beyond the cap: {}\n",
            e.value(),
            clock.elapsed().as_secs_f64(),
            e.nis_per_row(),
            e.rows,
            band.lower,
            band.upper,
            e.capped_rows
        ));
        if let Some(why) = e.failure {
            out.push_str(&format!("the filter failed: {why}\n"));
        }
        write_smoothed_logs(cli, &estimator, &start, logs, likelihood.records(), &mut out)?;
        return Ok(out);
    }
    let found = fit(&likelihood, &start, &options).map_err(anyhow::Error::msg)?;
    if std::env::var_os("KALFMU_TUNE_DEBUG").is_some() {
        out.push_str(&format!("hessian {:.4e}\ngradient {:?}\n", found.curvature.hessian, found.curvature.gradient));
    }
    out.push_str(&report::text(&found, &names, &units, cap));
    out.push('\n');
    out.push_str(&report::set_lines(&found, &names));
    if let Some(path) = &cli.ssv {
        let log_name = if logs.len() == 1 { stem(&logs[0].path) } else { "joint".into() };
        let path = PathBuf::from(path.to_string_lossy().replace("{log}", &log_name));
        let set_name = format!("{identifier} tuned from {log_name}");
        let set = report::parameter_set(&set_name, &sources.join(", "), &found, &names, &units);
        ssv::write(&path, &set).map_err(anyhow::Error::msg)?;
        out.push_str(&format!("wrote {}\n", path.display()));
    }
    let fitted: Vec<f64> = found.intervals.iter().map(|i| i.estimate).collect();
    write_smoothed_logs(cli, &estimator, &fitted, logs, likelihood.records(), &mut out)?;
    Ok(out)
}

/// With `--smoothed-log`: each log run through the FMU's whole loop at `fitted`, written
/// with its filtered and smoothed estimates (`tuning::smoothed_log`); `records` are the
/// logs' samples as the fit took them.
fn write_smoothed_logs(
    cli: &Cli,
    estimator: &FmuEstimator,
    fitted: &[f64],
    logs: &[&Log],
    records: &[Record],
    out: &mut String,
) -> anyhow::Result<()> {
    let Some(template) = &cli.smoothed_log else { return Ok(()) };
    for (log, record) in logs.iter().zip(records) {
        let path = PathBuf::from(template.to_string_lossy().replace("{log}", &stem(&log.path)));
        let written = smoothed_log::write(&log.run, record, estimator, fitted, &path)
            .map_err(|e| anyhow::anyhow!("{}: {e}", log.path.display()))?;
        out.push_str(&format!(
            "wrote {}: {} samples of {} with its filtered (/estimate) and whole-log smoothed (/smoothed) estimates; \
             the gate rejected {} rows, {} were missing\n",
            path.display(),
            written.samples,
            log.path.display(),
            written.rejected_rows,
            written.missing_rows
        ));
    }
    Ok(())
}
