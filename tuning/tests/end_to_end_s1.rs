//! Specification, end to end on study S1: from a log of the accelerations alone (laid out
//! as the studies log, made here from S1's truth simulator) `kalfmu-tune` infers the FMU
//! (`kalfmu_s1_load`), fits `load_noise_intensity` from a start three decades too low,
//! with the two accelerometers' noise, and the filter so tuned is consistent with the
//! log — its mean NIS per row inside the χ² 95 % band, where at the start it is far
//! outside — and the estimates are what the SSV file and the `--set` lines carry.
//!
//! The sensors' noise is fitted too: the FMU's load is a second-order random walk and the
//! truth's a band-limited random load, so with `R` held at the sensors' true noise no
//! load intensity makes the NIS 1 (the fit of the load's alone gives 0.93 per row on this
//! log); the likelihood's optimum in `R` is where the innovations' scale matches `S`.

#[path = "support/simulated_logs.rs"]
mod simulated_logs;

use std::path::PathBuf;
use std::process::Command;

use tuning::consistency::NisBand;
use tuning::{fit, log_input, ssv, FitOptions, FmuEstimator, Likelihood, RobustCap};

fn scratch(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("end_to_end_s1_{}_{name}", std::process::id()))
}

#[test]
fn the_fitted_load_noise_makes_the_filter_consistent_with_the_log() {
    let log = scratch("s1.mcap");
    simulated_logs::write_s1(&log, 20.0, 3, 0.02).unwrap();

    // The library path, as the command takes it.
    let (run, warnings) = log_input::read(&log).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(log_input::identify(&run).unwrap(), "kalfmu_s1_load", "inferred from the inputs' names");
    let mut estimator = FmuEstimator::by_identifier("kalfmu_s1_load").unwrap();
    for (name, value) in log_input::logged_parameters(&run).unwrap() {
        estimator.set(&name, value).unwrap();
    }
    let study_tuning = estimator.value("load_noise_intensity").unwrap();
    estimator.set("load_noise_intensity", study_tuning / 1000.0).unwrap();
    let fitted = ["load_noise_intensity", "r_z1_ddot_std", "r_z2_ddot_std"].map(String::from);
    estimator.choose_fitted(&fitted).unwrap();
    estimator.check().unwrap();
    let record = log_input::record(&run, estimator.descriptor()).unwrap();
    record.check_grid(estimator.value("sample_time").unwrap()).unwrap();
    assert_eq!(record.len(), 4001);
    let likelihood = Likelihood::new(&estimator, vec![record], RobustCap::DEFAULT);
    let found = fit(&likelihood, &estimator.start_values().unwrap(), &FitOptions::default()).unwrap();

    let band = NisBand::at_95(found.evaluation.rows);
    let (before, after) = (found.start_evaluation.nis_per_row(), found.evaluation.nis_per_row());
    println!(
        "load_noise_intensity {:.4e} [{:.4e}, {:.4e}] (start {:.4e}); NIS per row {before:.4} -> {after:.4}, band \
         [{:.4}, {:.4}] over {} rows, {} beyond the cap; {} + {} evaluations",
        found.intervals[0].estimate,
        found.intervals[0].lower,
        found.intervals[0].upper,
        found.start[0],
        band.lower,
        band.upper,
        found.evaluation.rows,
        found.evaluation.capped_rows,
        found.search.evaluations,
        found.curvature_evaluations
    );
    assert!(!band.contains(before), "the bad start is inconsistent: NIS per row {before}");
    assert!(band.contains(after), "the fitted filter is consistent: NIS per row {after} outside {band:?}");
    assert!(found.intervals.iter().all(|i| i.identifiable), "{:?}", found.intervals);
    assert!(found.evaluation.value() > found.start_evaluation.value() + 100.0);
    // A clean log: beyond 4σ only as often as the start of the run and the model's
    // imperfection make it (a Gaussian would give 0.5 of 8000).
    let capped = found.evaluation.capped_rows;
    assert!(capped * 1000 <= found.evaluation.rows, "{capped} rows beyond the cap");

    // The command: the same fit, its SSV and its --set line.
    let out = scratch("s1.ssv");
    let output = Command::new(env!("CARGO_BIN_EXE_kalfmu-tune"))
        .arg(&log)
        .args(["--fit", "load_noise_intensity,r_z1_ddot_std,r_z2_ddot_std"])
        .arg(format!("--set=load_noise_intensity={:e}", study_tuning / 1000.0))
        .arg("--ssv")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("kalfmu_s1_load, SRCKF"), "{stdout}");
    assert!(stdout.contains(": inside"), "{stdout}");
    let set = ssv::read(&out).unwrap();
    assert_eq!(set.parameters.len(), 3);
    let units = [Some("N2/s3"), Some("m/s2"), Some("m/s2")];
    for (((p, name), unit), interval) in set.parameters.iter().zip(&fitted).zip(units).zip(&found.intervals) {
        assert_eq!((&p.name, p.unit.as_deref()), (name, unit));
        assert_eq!(p.value, interval.estimate, "the command and the library fit the same");
        assert!(stdout.contains(&format!("--set {name}={:e}\n", p.value)), "{stdout}");
    }
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_file(&out);
}
