//! `kalfmu robustness`: every estimator FMU, through the C ABI, on its study's
//! truth with seeded random fault episodes (`episode.rs`), each run against
//! the same FMU on the clean data (`bench.rs`) and once more with the
//! episode's samples missing instead: what a perfect fault detector would
//! leave the filter, so the data's own limit. Per FMU and fault kind it
//! prints how soon the estimate was back (median and worst), how far off it
//! was after, the false fault flags and how often `filter_healthy`
//! disagreed with the error. The episodes are independent runs: they go to
//! both cores, and `--shard K/N` runs every N-th batch for a batch system.

pub mod bench;
pub mod benches;
pub mod episode;
pub mod wiring;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use bench::{clean_scale, judge, Bench, Verdict};
use cosim::fmu_driver::ImportedFmu;
use episode::{draw, Episode, FaultKind};
use shard::Shard;
use start_values::StartValues;

/// Command-line arguments of `kalfmu robustness`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Directory with the packaged FMUs (`package-fmus --out`).
    #[arg(long, default_value = "target/fmu")]
    pub fmu_dir: PathBuf,
    /// Fault episodes per FMU.
    #[arg(long, default_value_t = 200)]
    pub episodes: usize,
    /// Seed of the episodes (the truths keep their studies' seeds).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Only these studies (comma-separated: s1,s2,s3,s4,s5); all by default.
    #[arg(long, value_delimiter = ',')]
    pub studies: Vec<String>,
    /// Run only the batches K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Also list every episode not recovered within the bound, with what it
    /// did (with `--wiring`: every run).
    #[arg(long)]
    pub list_unrecovered: bool,
    /// Instead of the episodes: every wiring mistake (a sign, a unit, gravity
    /// left in, a swap) on every input, from half a second after the warm-up
    /// to the end of the run: is the input named, and is the filter called
    /// unhealthy where its estimate leaves its σ?
    #[arg(long)]
    pub wiring: bool,
    /// Start values over each FMU's own (its study's set-up), by the FMU's
    /// parameter names: how robust a user's tuning is (`kalfmu-tune` writes
    /// them). Every FMU run takes them; a name an FMU does not have is an error,
    /// so take one study at a time with `--studies`.
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// Episodes per batch: a batch loads the FMU once.
const BATCH: usize = 10;
/// The warm-up before any episode, and the span its start is drawn over (s).
const WARM_UP: f64 = 1.0;
/// The longest episode (samples).
const LONGEST: usize = 1000;

/// The benches of the studies asked for, each long enough for its episodes.
fn benches(studies: &[String]) -> anyhow::Result<Vec<Bench>> {
    type Make = fn(f64, u64) -> Bench;
    let all: [(&str, Make, f64, f64); 5] = [
        ("s1", benches::s1, 0.005, 2.0),
        ("s2", benches::s2, 0.001, 0.5),
        ("s3", benches::s3, 0.001, 0.5),
        ("s4", benches::s4, 0.02, 2.0),
        ("s5", benches::s5, 0.005, 2.0),
    ];
    for name in studies {
        if !all.iter().any(|(n, ..)| n == name) {
            anyhow::bail!("unknown study '{name}'; expected one of s1, s2, s3, s4, s5");
        }
    }
    Ok(all
        .iter()
        .filter(|(name, ..)| studies.is_empty() || studies.iter().any(|s| s == name))
        .map(|&(_, make, dt, bound)| make(2.0 * WARM_UP + LONGEST as f64 * dt + 2.0 * bound + 0.2, 1))
        .collect())
}

/// Runs the subcommand.
pub fn run_command(args: &Args) -> anyhow::Result<()> {
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    let mut benches = benches(&args.studies)?;
    for bench in &mut benches {
        bench.start_values = start_values.clone();
    }
    let set_up = if start_values.is_empty() {
        "the study's default case".to_string()
    } else {
        format!("the study's default case, {}", start_values.summary())
    };
    if args.wiring {
        let start = WARM_UP + 0.5;
        println!(
            "robustness --wiring: each wiring mistake on each input from {start} s into {set_up} to the end \
             of the run; the packaged FMUs of {} through the fmi importer",
            args.fmu_dir.display()
        );
        for bench in &benches {
            print!("{}", wiring::study(bench, args, start)?);
        }
        println!("{}", wiring::LEGEND);
        return Ok(());
    }
    println!(
        "robustness: {} fault episodes per FMU (seed {}), each 1 to {LONGEST} samples from {WARM_UP}–{} s into \
         {set_up}, on one input, some or all; the packaged FMUs of {} through the fmi importer",
        args.episodes,
        args.seed,
        2.0 * WARM_UP,
        args.fmu_dir.display()
    );
    for (index, bench) in benches.iter().enumerate() {
        let table = study(bench, args, index as u64)?;
        print!("{table}");
    }
    println!(
        "recovery: from an episode's end until every later 0.1 s window's error is within 2× the clean run's (the \
         error of a sample: the RMS over the scored estimates of their errors in their clean RMS errors), over a \
         horizon of twice the FMU's bound; 'n of N' recovered within the bound; after: the largest such error from the \
         recovery to the horizon; as missing: episodes recovered within the bound when the same samples are \
         missing instead (NaN, what a perfect fault detector would leave the filter: the data's own limit); false flags: samples with <input>_fault on an input none of whose last 3 samples \
         was corrupted; healthy ≠ error: the share of samples from the episode's start to the horizon where \
         filter_healthy disagrees with the error (mean (e/σ)² of the scored estimates within 9); lost: steps answered \
         with fmi2Warning; failed: runs the FMU ended with fmi2Discard (its filter failed: the last good estimate kept)"
    );
    Ok(())
}

/// One FMU's episodes and its table.
fn study(bench: &Bench, args: &Args, index: u64) -> anyhow::Result<String> {
    let path = args.fmu_dir.join(format!("{}.fmu", bench.identifier));
    let fmu = ImportedFmu::load(&path).with_context(|| format!("cannot load {}", path.display()))?;
    let clean = bench.drive(&fmu, None, bench.z.len())?;
    let warm = (WARM_UP / bench.dt).round() as usize;
    let scale = clean_scale(&clean, &bench.truth, warm);
    let window = ((0.1 / bench.dt).round() as usize).max(2);
    let after = (2.0 * bench.bound / bench.dt).round() as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(args.seed.wrapping_mul(1000).wrapping_add(index));
    let episodes: Vec<Episode> = (0..args.episodes)
        .map(|_| {
            let start = warm + rng_start(&mut rng, warm);
            draw(&mut rng, bench.inputs.len(), start, LONGEST)
        })
        .collect();
    let batches: Vec<&[Episode]> = episodes.chunks(BATCH).collect();
    let rms = bench.rms();
    let results = shard::run(&batches, args.shard, |batch| -> anyhow::Result<Vec<(Episode, Verdict, Verdict)>> {
        let fmu = ImportedFmu::load(&path)?;
        let run = |episode: &Episode| -> anyhow::Result<Verdict> {
            let mut z = bench.z.clone();
            episode.apply(&mut z, &rms);
            let horizon = episode.end() + after;
            let trace =
                bench.drive(&fmu, Some(&z), horizon).with_context(|| format!("{}: {episode:?}", bench.study))?;
            Ok(judge(bench, &clean, &trace, episode, &scale, window, horizon))
        };
        batch
            .iter()
            .map(|episode| {
                let verdict = run(episode)?;
                let missing =
                    if episode.kind == FaultKind::Dropout { verdict.clone() } else { run(&episode.as_missing())? };
                Ok((episode.clone(), verdict, missing))
            })
            .collect()
    });
    let mut by_kind: BTreeMap<FaultKind, Vec<(Verdict, Verdict)>> = BTreeMap::new();
    let mut unrecovered = Vec::new();
    for (_, batch) in results {
        for (episode, verdict, missing) in batch? {
            if !verdict.recovery.is_some_and(|t| t <= bench.bound) {
                unrecovered.push((episode.clone(), verdict.clone(), missing.clone()));
            }
            by_kind.entry(episode.kind).or_default().push((verdict, missing));
        }
    }
    let clean_flags = (warm..clean.faulty.len()).filter(|&k| clean.faulty[k].iter().any(|&f| f)).count();
    let clean_unhealthy = (warm..clean.healthy.len()).filter(|&k| !clean.healthy[k]).count();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} ({}, {} inputs, {:.0} Hz; recovery bound {} s): clean run: {} samples flagged faulty, {} not healthy of {}",
        bench.study,
        bench.identifier,
        bench.inputs.len(),
        1.0 / bench.dt,
        bench.bound,
        clean_flags,
        clean_unhealthy,
        clean.healthy.len() - warm
    );
    let _ = writeln!(
        out,
        "  {:<11} {:>9} {:>14} {:>11} {:>10} {:>22} {:>11} {:>13} {:>6}",
        "fault", "episodes", "within bound", "as missing", "median", "worst", "after", "false flags", "lost"
    );
    let _ = writeln!(out, "  {:>101}", "healthy ≠ error");
    for (kind, pairs) in &by_kind {
        let verdicts: Vec<&Verdict> = pairs.iter().map(|(v, _)| v).collect();
        let as_missing = pairs.iter().filter(|(_, m)| m.recovery.is_some_and(|t| t <= bench.bound)).count();
        let mut times: Vec<f64> = verdicts.iter().filter_map(|v| v.recovery).collect();
        times.sort_by(f64::total_cmp);
        let recovered = verdicts.iter().filter(|v| v.recovery.is_some_and(|t| t <= bench.bound)).count();
        let never = verdicts.len() - times.len();
        let failed = verdicts.iter().filter(|v| v.failed).count();
        let median = times.get(times.len() / 2).map_or("—".into(), |t| format!("{t:.3} s"));
        let worst = match (never, failed) {
            (0, _) => format!("{:.3} s", times.last().unwrap_or(&0.0)),
            (_, 0) => format!("{never} never"),
            _ => format!("{never} never ({failed} failed)"),
        };
        let after = verdicts.iter().map(|v| v.error_after).filter(|e| e.is_finite()).fold(0.0, f64::max);
        let flags: usize = verdicts.iter().map(|v| v.false_flags).sum();
        let (disagree, judged) = verdicts.iter().fold((0, 0), |(d, j), v| (d + v.disagreements, j + v.judged));
        let lost: usize = verdicts.iter().map(|v| v.warnings).sum();
        let _ = writeln!(
            out,
            "  {:<11} {:>9} {:>14} {:>11} {:>10} {:>22} {:>11.2} {:>13} {:>6} {:>8.3}",
            kind.to_string(),
            verdicts.len(),
            format!("{recovered} of {}", verdicts.len()),
            as_missing,
            median,
            worst,
            after,
            flags,
            lost,
            disagree as f64 / judged.max(1) as f64
        );
    }
    if args.list_unrecovered {
        for (episode, verdict, missing) in &unrecovered {
            let _ = writeln!(
                out,
                "    not recovered: {} on {} from {:.3} s for {} samples, size {:.3e}{}: recovery {}, error after {:.2}, \
                 {} lost steps{}; as missing: recovery {}",
                episode.kind,
                episode.channels.iter().map(|&c| bench.inputs[c]).collect::<Vec<_>>().join("+"),
                episode.start as f64 * bench.dt,
                episode.length,
                episode.size,
                if episode.alternating { " alternating" } else { "" },
                verdict.recovery.map_or("never".into(), |t| format!("{t:.3} s")),
                verdict.error_after,
                verdict.warnings,
                if verdict.failed { ", failed" } else { "" },
                missing.recovery.map_or("never".into(), |t| format!("{t:.3} s")),
            );
        }
    }
    Ok(out)
}

/// A start offset within the second after the warm-up (`warm` samples long).
fn rng_start(rng: &mut ChaCha8Rng, warm: usize) -> usize {
    use rand::RngExt;
    rng.random_range(0..warm.max(1))
}
