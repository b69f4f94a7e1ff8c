//! S4 in `kalfmu reproduce`: on the paper's test run (and, without `--quick`, the
//! 500 km/h run), with the default faults, every filter kind through the packaged FMU,
//! checked against the same filter in-process; then the table (`s4-compare`'s)
//! with ours read from the FMU's outputs (SRCKF, the FMU's default), beside the raw
//! average and the paper's pipeline (in-process: the paper's method, not our FMU); one
//! log per run and one comparison recording per profile (`out/s4/`).

use std::path::Path;

use analyzer::report::Options;
use anyhow::Context;
use estimator::FilterKind;
use log_format::read::read_log;
use log_format::write::ESTIMATE;

use super::compare::{compare_with, print_comparison};
use super::fmu_run::{self, COMPARED, IDENTIFIER};
use super::ours::{self, Settings, Tuning};
use crate::comparison::{compare_case, largest_difference, log_path, rows_of};
use cosim::fmu_driver::ImportedFmu;
use truth::s4::channels::simulate;
use truth::s4::faults::Faults;
use truth::s4::profile::Profile;

/// Runs S4 through its FMU and prints the tables; returns the number of failed runs.
pub fn report(seed: u64, quick: bool, fmu_dir: &Path, out: &Path) -> anyhow::Result<usize> {
    let fmu = ImportedFmu::load_packaged(fmu_dir, IDENTIFIER)?;
    let dir = out.join("s4");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    println!(
        "S4: maglev position and speed from four PRW position channels (head/tail × left/right, a telegram every \
         0.02 s), the default faults of docs/s4-maglev.md, seed {seed}; ours from {} driven through the fmi importer, \
         logs and recordings in {}",
        fmu_dir.join(format!("{IDENTIFIER}.fmu")).display(),
        dir.display()
    );
    let mut cases = vec![("paper", Profile::paper(), Tuning::paper())];
    if !quick {
        cases.push(("high_speed", Profile::high_speed(), Tuning::jerk_limited()));
    }
    let mut failures = 0;
    for (case, profile, tuning) in cases {
        let recording = simulate(&profile, &Faults::default(), seed);
        println!("{case}: {:.1} s, {} telegrams", profile.duration(), recording.n_telegrams());
        let stem = dir.join(case);
        let mut logs = Vec::new();
        let mut line = format!("{:<22}", "vs library (largest |Δ|)");
        let mut table = None;
        for kind in FilterKind::ALL {
            let log = log_path(&stem, kind);
            let checked = fmu_run::run(&fmu, kind, &recording, &tuning, case, &log).and_then(|_| {
                let run = read_log(&log)?;
                let through_fmu = rows_of(run.channel(ESTIMATE)?, COMPARED)?;
                let library = ours::run(&recording, &Settings::new(kind, tuning)).map_err(anyhow::Error::msg)?;
                // The same quantities, in the order of `COMPARED`.
                let in_process: Vec<[f64; 10]> = library
                    .estimates
                    .iter()
                    .map(|e| {
                        let [o, w] = [e.offsets, e.weights];
                        [e.position, e.speed, o[0], o[1], o[2], o[3], w[0], w[1], w[2], w[3]]
                    })
                    .collect();
                let difference = largest_difference(&through_fmu, &in_process)?;
                if kind == FilterKind::SrCkf {
                    let speed: Vec<f64> = through_fmu[1..].iter().map(|r| r[1]).collect();
                    let position: Vec<f64> = through_fmu[1..].iter().map(|r| r[0]).collect();
                    table = Some(compare_with(&recording, &library, &speed, &position).map_err(anyhow::Error::msg)?);
                }
                logs.push(run);
                Ok(difference)
            });
            match checked {
                Ok(difference) => line.push_str(&format!(" {}: {difference:.1e}", kind.name())),
                Err(e) => {
                    failures += 1;
                    println!("{kind}: FAILED: {e:#}");
                }
            }
        }
        let mut text = String::new();
        if let Some(c) = &table {
            text.push_str(
                "ours: the SRCKF through the FMU; its detections and offsets are the same filter's in-process, \
                 which the FMU equals (vs library)\n",
            );
            print_comparison(&mut text, seed, c);
        }
        print!("{text}");
        println!("{line}");
        match compare_case(&logs, &Options::default(), &stem) {
            Ok((_, recording)) => println!("comparison recording, every filter in one: {}", recording.display()),
            Err(e) => {
                failures += 1;
                println!("FAILED to compare the filters: {e}");
            }
        }
    }
    Ok(failures)
}
