//! S5 in `scenarios reproduce`: the flight of the first truth (our 6-DOF, as the paper has
//! it) measured once, then every filter through the packaged FMU; the paper's Tables 1 and
//! 2 with each filter's relative error beside its SVD-CKF's, the time to come back after
//! the change, and the difference from the same filter in-process (bit for bit). One log
//! per filter and one comparison recording (`out/s5/`).

use std::fmt::Write as _;
use std::path::Path;

use analyzer::log::ESTIMATE;
use analyzer::read::read_log;
use analyzer::report::Options;
use anyhow::Context;
use estimator::FilterKind;

use super::fmu_run::{self, IDENTIFIER};
use super::parameters::{AFTER, BEFORE, NAMES, PAPER_SVD_CKF_AFTER, PAPER_SVD_CKF_BEFORE};
use super::study::{measure, run_filter, simulate, Settings, Tuning};
use crate::fmu_driver::ImportedFmu;
use crate::reproduce::{compare_case, log_path};

/// One filter's run through the FMU: its coefficients sample by sample, and the largest
/// difference from the same filter in-process.
struct FilterRun {
    kind: FilterKind,
    coefficients: Vec<[f64; 10]>,
    difference: f64,
    rejected: i32,
}

/// Runs S5 through its FMU and prints the tables; returns the number of failed runs.
pub fn report(settings: &Settings, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    let dir = out.join("s5");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let truth = simulate(settings);
    let measurements = measure(&truth, settings.noise_scale, settings.seed);
    let tuning = Tuning::new(settings.noise_scale);
    println!(
        "S5: tactical-missile force coefficients online, 20 states, 12 measurements every {} s — truth 1: the paper's \
         6-DOF (flat Earth, ISA), the ten coefficients changing at 10 s; sensor noise as docs/s5-missile.md × {}, seed {}",
        settings.sample_time, settings.noise_scale, settings.seed
    );
    println!(
        "estimates from {} driven through the fmi importer with the deflections as inputs; logs and the comparison \
         recording in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    let stem = dir.join("6dof");
    let mut failures = 0;
    let mut runs = Vec::new();
    let mut logs = Vec::new();
    for kind in FilterKind::ALL {
        let log = log_path(&stem, kind);
        let through_fmu = fmu_run::run(&fmu, kind, settings, &truth, &measurements, &log).and_then(|counts| {
            let run = read_log(&log)?;
            let estimate = run.channel(ESTIMATE)?;
            let columns: Vec<&[f64]> = NAMES
                .iter()
                .map(|n| estimate.signal(n).map(|s| s.values.as_slice()).with_context(|| format!("no {n} logged")))
                .collect::<anyhow::Result<_>>()?;
            let coefficients: Vec<[f64; 10]> =
                (0..truth.time.len()).map(|k| std::array::from_fn(|i| columns[i][k])).collect();
            let library = run_filter(kind, &tuning, &truth, &measurements, settings.sample_time, &[])
                .map_err(anyhow::Error::msg)?;
            let difference = coefficients
                .iter()
                .zip(&library.coefficients)
                .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
                .fold(0.0, f64::max);
            logs.push(run);
            Ok(FilterRun { kind, coefficients, difference, rejected: counts.rejected })
        });
        match through_fmu {
            Ok(r) => runs.push(r),
            Err(e) => {
                failures += 1;
                println!("{kind}: FAILED: {e:#}");
            }
        }
    }
    let options = Options { from: 0.5, ..Options::default() };
    let recording = match compare_case(&logs, &options, &stem) {
        Ok((_, recording)) => Some(recording),
        Err(e) => {
            failures += 1;
            println!("FAILED to compare the filters: {e}");
            None
        }
    };
    let before = (settings.sample_time.recip() * 10.0).round() as usize - 1;
    let end = truth.time.len() - 1;
    for (title, k, true_values, paper) in [
        ("Table 1, before the change (at 9.995 s)", before, BEFORE, PAPER_SVD_CKF_BEFORE),
        ("Table 2, after the change (at 20 s)", end, AFTER, PAPER_SVD_CKF_AFTER),
    ] {
        println!("{title}: relative error of each filter's estimate, %");
        let mut header = format!("{:<6} {:>8} {:>9} {:>7}", "coef", "true", "paper SVD", "err %");
        for r in &runs {
            let _ = write!(header, " {:>8}", r.kind.name());
        }
        println!("{header}");
        for i in 0..10 {
            let mut row = format!(
                "{:<6} {:>8.4} {:>9.4} {:>+7.2}",
                NAMES[i],
                true_values[i],
                paper[i],
                100.0 * (paper[i] / true_values[i] - 1.0)
            );
            for r in &runs {
                let _ = write!(row, " {:>+8.3}", 100.0 * (r.coefficients[k][i] / true_values[i] - 1.0));
            }
            println!("{row}");
        }
    }
    let mut back = format!("{:<26}", "back within 3 % / 1 %, s");
    let mut rejected = format!("{:<26}", "rows rejected by the gate");
    let mut difference = format!("{:<26}", "vs library (largest |Δ|)");
    for r in &runs {
        let within = |bound: f64| {
            (before + 1..=end)
                .find(|&k| (k..=end).all(|j| (0..10).all(|i| (r.coefficients[j][i] / AFTER[i] - 1.0).abs() <= bound)))
                .map_or("never".to_string(), |k| format!("{:.2}", truth.time[k] - 10.0))
        };
        let _ = write!(back, " {:>12}", format!("{}/{}", within(0.03), within(0.01)));
        let _ = write!(rejected, " {:>12}", r.rejected);
        let _ = write!(difference, " {:>12.1e}", r.difference);
    }
    let names: String = runs.iter().map(|r| format!(" {:>12}", r.kind.name())).collect();
    println!("after the change{}{names}", " ".repeat(10));
    println!("{back}\n{rejected}\n{difference}");
    println!("paper: SVD-CKF within 3 % and CKF within 5 % of every coefficient, in both tables");
    if let Some(recording) = recording {
        println!("comparison recording, every filter in one: {}", recording.display());
    }
    Ok(failures)
}
