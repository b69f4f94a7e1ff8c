//! `kalfmu robustness --wiring`: the installation mistakes a new user makes,
//! each on one input (or a pair) from half a second after the warm-up to the
//! end of the run, through the packaged FMU. Per FMU and mistake it prints
//! how often the input was named (its `<input>_status` inconsistent) within
//! 2 s and how soon, how often a right input was blamed instead, and, of the
//! runs whose estimate the mistake drives beyond its σ, how often
//! `filter_healthy` said so within 2 s. The runs are independent: both cores,
//! `--shard K/N`.

use std::fmt::Write as _;

use anyhow::Context;
use cosim::fmu_driver::ImportedFmu;

use super::bench::{Bench, Trace};
use super::Args;

/// The `InputStatus` value of an inconsistent input.
const INCONSISTENT: i32 = 5;
/// How soon a mistake must be named, and an estimate beyond its σ called unhealthy (s).
const WITHIN: f64 = 2.0;
/// Standard gravity (m/s²).
const GRAVITY: f64 = 9.81;

/// A wiring mistake on one input, or a pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mistake {
    /// The sign wired the wrong way round.
    Flipped,
    /// In g where m/s² are expected (9.81 times too large).
    TimesG,
    /// In m/s² where g is expected (9.81 times too small).
    OverG,
    /// Gravity left in (+9.81 m/s²; inputs in m/s² only).
    Gravity,
    /// Exchanged with the next input of the same unit.
    Swapped,
}

impl Mistake {
    const ALL: [Mistake; 5] = [Mistake::Flipped, Mistake::TimesG, Mistake::OverG, Mistake::Gravity, Mistake::Swapped];

    fn name(self) -> &'static str {
        match self {
            Mistake::Flipped => "flipped",
            Mistake::TimesG => "unit x9.81",
            Mistake::OverG => "unit /9.81",
            Mistake::Gravity => "gravity in",
            Mistake::Swapped => "swapped",
        }
    }
}

/// One run: a mistake on `channels` (one input; two for a swap).
#[derive(Debug, Clone)]
struct Case {
    mistake: Mistake,
    channels: Vec<usize>,
}

/// What one run showed.
#[derive(Debug, Clone, Default)]
struct Finding {
    /// When a wrong input was first named inconsistent, from the mistake's start (s).
    named: Option<f64>,
    /// The first right input named inconsistent, and when (s, from the mistake's start).
    blamed: Option<(usize, f64)>,
    /// When the estimate first went beyond its σ (mean (e/σ)² of the scored estimates above 9), from the start (s).
    beyond: Option<f64>,
    /// `filter_healthy` was false within [`WITHIN`] of that.
    unhealthy: bool,
    /// Why the FMU refused a step, if it did.
    failed: Option<String>,
}

/// The cases of a bench: every mistake on every input it applies to.
fn cases(bench: &Bench, fmu: &ImportedFmu) -> Vec<Case> {
    let units: Vec<String> = bench.inputs.iter().map(|n| fmu.unit(n)).collect();
    let m = bench.inputs.len();
    let mut cases = Vec::new();
    for mistake in Mistake::ALL {
        for c in 0..m {
            let channels = match mistake {
                Mistake::Gravity if units[c] != "m/s2" => continue,
                Mistake::Swapped => {
                    let Some(other) = (1..m).map(|j| (c + j) % m).find(|&o| units[o] == units[c]) else { continue };
                    let pair = [c.min(other), c.max(other)];
                    if cases.iter().any(|k: &Case| k.mistake == Mistake::Swapped && k.channels == pair) {
                        continue;
                    }
                    pair.to_vec()
                }
                _ => vec![c],
            };
            cases.push(Case { mistake, channels });
        }
    }
    cases
}

/// The measurements with `case` put in from sample `start` on.
fn apply(bench: &Bench, case: &Case, start: usize) -> Vec<Vec<f64>> {
    let mut z = bench.z.clone();
    for row in &mut z[start..] {
        let c = case.channels[0];
        match case.mistake {
            Mistake::Flipped => row[c] = -row[c],
            Mistake::TimesG => row[c] *= GRAVITY,
            Mistake::OverG => row[c] /= GRAVITY,
            Mistake::Gravity => row[c] += GRAVITY,
            Mistake::Swapped => row.swap(c, case.channels[1]),
        }
    }
    z
}

/// Judges a run of `case` from sample `start`.
fn judge(bench: &Bench, trace: &Trace, case: &Case, start: usize) -> Finding {
    let within = (WITHIN / bench.dt).round() as usize;
    let seconds = |k: usize| (k - start) as f64 * bench.dt;
    let samples = trace.estimate.len();
    let named =
        (start..samples).find(|&k| case.channels.iter().any(|&c| trace.status[k][c] == INCONSISTENT)).map(seconds);
    let blamed = (start..samples).find_map(|k| {
        let right = |&(c, &s): &(usize, &i32)| s == INCONSISTENT && !case.channels.contains(&c);
        trace.status[k].iter().enumerate().find(right).map(|(c, _)| (c, seconds(k)))
    });
    let beyond = (start..samples).find(|&k| {
        let terms = trace.estimate[k].iter().zip(&bench.truth[k]).zip(&trace.std[k]);
        let mean_square = terms.map(|((e, t), s)| ((e - t) / s).powi(2)).sum::<f64>() / bench.targets.len() as f64;
        mean_square.is_nan() || mean_square > 9.0
    });
    let unhealthy = beyond.is_some_and(|k| trace.healthy[k..(k + within).min(samples)].iter().any(|h| !h));
    Finding { named, blamed, beyond: beyond.map(seconds), unhealthy, failed: trace.failure.clone() }
}

/// One FMU's wiring table.
pub fn study(bench: &Bench, args: &Args, start_time: f64) -> anyhow::Result<String> {
    let path = args.fmu_dir.join(format!("{}.fmu", bench.identifier));
    let fmu = ImportedFmu::load(&path).with_context(|| format!("cannot load {}", path.display()))?;
    let start = (start_time / bench.dt).round() as usize;
    let cases = cases(bench, &fmu);
    let clean = bench.drive(&fmu, None, bench.z.len())?;
    let clean_named = (0..clean.status.len()).filter(|&k| clean.status[k].contains(&INCONSISTENT)).count();
    let batches: Vec<&[Case]> = cases.chunks(4).collect();
    let results = shard::run(&batches, args.shard, |batch| -> anyhow::Result<Vec<(Case, Finding)>> {
        let fmu = ImportedFmu::load(&path)?;
        batch
            .iter()
            .map(|case| {
                let z = apply(bench, case, start);
                let trace =
                    bench.drive(&fmu, Some(&z), z.len()).with_context(|| format!("{}: {case:?}", bench.study))?;
                Ok((case.clone(), judge(bench, &trace, case, start)))
            })
            .collect()
    });
    let mut findings: Vec<(Case, Finding)> = Vec::new();
    for (_, batch) in results {
        findings.extend(batch?);
    }
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} ({}, {} inputs; mistakes from {start_time} s to the end, {:.1} s): clean run: {} samples with an input \
         named inconsistent",
        bench.study,
        bench.identifier,
        bench.inputs.len(),
        (bench.z.len() - start) as f64 * bench.dt,
        clean_named
    );
    let _ = writeln!(
        out,
        "  {:<11} {:>5} {:>13} {:>9} {:>8} {:>11} {:>12}",
        "mistake", "runs", "named ≤ 2 s", "median", "blamed", "beyond σ", "unhealthy"
    );
    for mistake in Mistake::ALL {
        let of: Vec<&Finding> = findings.iter().filter(|(c, _)| c.mistake == mistake).map(|(_, f)| f).collect();
        if of.is_empty() {
            continue;
        }
        let mut times: Vec<f64> = of.iter().filter_map(|f| f.named).filter(|&t| t <= WITHIN).collect();
        times.sort_by(f64::total_cmp);
        let median = times.get(times.len() / 2).map_or("—".into(), |t| format!("{t:.2} s"));
        let beyond = of.iter().filter(|f| f.beyond.is_some()).count();
        let unhealthy = of.iter().filter(|f| f.unhealthy).count();
        let failed = of.iter().filter(|f| f.failed.is_some()).count();
        let _ = writeln!(
            out,
            "  {:<11} {:>5} {:>13} {:>9} {:>8} {:>11} {:>12}{}",
            mistake.name(),
            of.len(),
            format!("{} of {}", times.len(), of.len()),
            median,
            of.iter().filter(|f| f.blamed.is_some()).count(),
            beyond,
            format!("{unhealthy} of {beyond}"),
            if failed > 0 { format!("  ({failed} failed)") } else { String::new() }
        );
    }
    if args.list_unrecovered {
        for (case, finding) in &findings {
            let names: Vec<&str> = case.channels.iter().map(|&c| bench.inputs[c]).collect();
            let _ = writeln!(
                out,
                "    {} {}: named {}, {}beyond σ {}, unhealthy {}{}",
                case.mistake.name(),
                names.join("+"),
                finding.named.map_or("never".into(), |t| format!("at {t:.3} s")),
                finding.blamed.map_or(String::new(), |(c, t)| format!("{} blamed at {t:.3} s, ", bench.inputs[c])),
                finding.beyond.map_or("never".into(), |t| format!("at {t:.3} s")),
                finding.unhealthy,
                finding.failed.as_ref().map_or(String::new(), |why| format!(", failed: {why}"))
            );
        }
    }
    Ok(out)
}

/// The legend under the tables.
pub const LEGEND: &str = "named ≤ 2 s: runs in which a wrong input's <input>_status became inconsistent within 2 s \
     of the mistake's start (median: how soon); blamed: runs in which a right input was named inconsistent; beyond σ: \
     runs whose scored estimates left their σ (mean (e/σ)² above 9) at some sample; unhealthy: of those, the runs in \
     which filter_healthy was false within 2 s of it; swapped: with the next input of the same unit; gravity in: \
     +9.81 on an input in m/s2";
