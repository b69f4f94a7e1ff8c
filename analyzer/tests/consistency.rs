//! The σ an estimator reports is read against its errors: Gaussian errors of known σ give
//! the coverages, the mean (e/σ)² and the NEES of an honest σ; a σ twice too wide or too
//! narrow is flagged; a logged NIS distributed as χ²(rows used) reads consistent, with the
//! rows used derived from `/measurements` and the cumulative rejection counter.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analyzer::compare::compare_runs;
use analyzer::consistency::Reading;
use analyzer::report::{analyse, Options};
use log_format::read::read_log;
use log_format::write::{LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, TRUTH};

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-analyzer-consistency-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Standard normal variates from a fixed seed (SplitMix64 and Box–Muller).
struct Gaussian(u64);

impl Gaussian {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

const SAMPLES: usize = 100_000;

/// The true σ of the three signals at sample `k`: constant, varying, and large.
fn true_sigma(signal: usize, k: usize) -> f64 {
    match signal {
        0 => 0.5,
        1 => 1.0 + 0.5 * (k as f64 * 1e-3).sin(),
        _ => 20.0,
    }
}

/// `SAMPLES` at 100 Hz of three signals A, B, C: truth a sine, estimate = truth + a
/// Gaussian error of σ `true_sigma` (white, or AR(1) of coefficient `ar` with that marginal
/// σ), the σ logged being `logged[i]` times the true one.
fn write_sigma_run(path: &Path, seed: u64, ar: f64, logged: [f64; 3]) {
    let mut w = LogWriter::create(path, &BTreeMap::from([("seed".to_string(), "1".to_string())])).unwrap();
    let names = ["A", "B", "C"];
    let truth_specs: Vec<SignalSpec> = names.iter().map(|n| SignalSpec::new(n, "m", "true")).collect();
    let estimate_specs: Vec<SignalSpec> = names
        .iter()
        .flat_map(|n| [SignalSpec::new(n, "m", "estimate"), SignalSpec::new(&format!("{n}_std"), "m", "its σ")])
        .collect();
    let t = w.add_channel(TRUTH, &truth_specs).unwrap();
    let e = w.add_channel(ESTIMATE, &estimate_specs).unwrap();
    let mut gaussian = Gaussian(seed);
    let mut state = [0.0; 3];
    let innovation_scale = (1.0 - ar * ar).sqrt();
    for k in 0..SAMPLES {
        let time = k as f64 * 0.01;
        let truth: Vec<f64> = (0..3).map(|i| (time * (i + 1) as f64).sin() * 10.0).collect();
        let mut estimate = Vec::with_capacity(6);
        for i in 0..3 {
            // A unit-variance AR(1) (white when ar = 0), scaled by the true σ.
            state[i] = if k == 0 { gaussian.next() } else { ar * state[i] + innovation_scale * gaussian.next() };
            let sigma = true_sigma(i, k);
            estimate.push(truth[i] + sigma * state[i]);
            estimate.push(logged[i] * sigma);
        }
        w.write(t, time, &truth).unwrap();
        w.write(e, time, &estimate).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn an_honest_sigma_has_the_gaussian_coverages_and_a_nees_of_its_signals() {
    let path = temp("honest.mcap");
    write_sigma_run(&path, 7, 0.0, [1.0; 3]);
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    for p in &report.pairs {
        // Sampling standard deviations at N = 10⁵: 0.0015 (1σ), 0.00066 (2σ), 0.0045 (mean).
        let (one, two) = (p.one_sigma_coverage.unwrap(), p.two_sigma_coverage.unwrap());
        assert!((one - 0.6827).abs() < 0.005, "{}: 1σ coverage {one}", p.truth);
        assert!((two - 0.9545).abs() < 0.0025, "{}: 2σ coverage {two}", p.truth);
        let n = p.normalised_error.unwrap();
        assert!((n.mean_square - 1.0).abs() < 0.015, "{}: mean (e/σ)² {}", p.truth, n.mean_square);
        assert_eq!(n.reading, Reading::Consistent, "{}: {n:?}", p.truth);
        assert!(n.effective_samples > 0.95 * SAMPLES as f64, "white errors: {n:?}");
        assert!(n.interval[0] < 1.0 && n.interval[0] > 0.98 && n.interval[1] < 1.02, "{n:?}");
    }
    let nees = report.nees.as_ref().unwrap();
    assert_eq!((nees.signals.as_slice(), nees.dof, nees.samples), (&["A", "B", "C"].map(String::from)[..], 3, SAMPLES));
    // Var(NEES) = 2·3: the mean's standard deviation is 0.0077.
    assert!((nees.mean - 3.0).abs() < 0.03, "NEES mean {}", nees.mean);
    assert!((nees.in_band - 0.95).abs() < 0.004, "NEES in its 95 % band: {}", nees.in_band);
    assert!((nees.band[0] - 0.215_795).abs() < 1e-5 && (nees.band[1] - 9.348_404).abs() < 1e-5, "{:?}", nees.band);
    assert!(report.nis.is_none(), "no nis, no NIS figures");
}

#[test]
fn a_sigma_twice_too_wide_or_too_narrow_is_flagged_in_the_report_table_and_json() {
    let path = temp("wide_narrow.mcap");
    write_sigma_run(&path, 11, 0.0, [1.0, 2.0, 0.5]);
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    let [honest, wide, narrow] = [0, 1, 2].map(|i| &report.pairs[i]);
    assert_eq!(honest.normalised_error.unwrap().reading, Reading::Consistent);
    let w = wide.normalised_error.unwrap();
    assert!((w.mean_square - 0.25).abs() < 0.005 && w.reading == Reading::TooWide, "{w:?}");
    // Within a σ twice too wide: within 2 true σ.
    assert!((wide.one_sigma_coverage.unwrap() - 0.9545).abs() < 0.0025, "{:?}", wide.one_sigma_coverage);
    let n = narrow.normalised_error.unwrap();
    assert!((n.mean_square - 4.0).abs() < 0.06 && n.reading == Reading::TooNarrow, "{n:?}");
    assert!((narrow.two_sigma_coverage.unwrap() - 0.6827).abs() < 0.005, "{:?}", narrow.two_sigma_coverage);
    // The NEES is the sum of the three: 1 + 0.25 + 4, far outside its band.
    let nees = report.nees.as_ref().unwrap();
    assert!((nees.mean - 5.25).abs() < 0.08 && nees.in_band < 0.9, "{nees:?}");

    // Compared with the honest run of the same truth: table and JSON.
    let honest_path = temp("honest_for_comparison.mcap");
    write_sigma_run(&honest_path, 7, 0.0, [1.0; 3]);
    let runs = [read_log(&honest_path).unwrap(), read_log(&path).unwrap()];
    let comparison = compare_runs(&runs, &Options::default()).unwrap();
    let table = comparison.table();
    assert!(table.contains("1σ cov") && table.contains("(e/σ)² mean"), "{table}");
    let b_rows: Vec<&str> = table.split("\nB [m]").nth(1).unwrap().lines().collect();
    let row = b_rows.iter().find(|l| l.starts_with("wide_narrow")).unwrap();
    assert!(row.contains(" too wide"), "{table}");
    let c_rows: Vec<&str> = table.split("\nC [m]").nth(1).unwrap().lines().collect();
    assert!(c_rows.iter().any(|l| l.starts_with("wide_narrow") && l.contains(" too narrow")), "{table}");
    assert!(c_rows.iter().any(|l| l.starts_with("honest_for_comparison") && l.contains(" consistent*")), "{table}");
    assert!(table.contains("NEES: Σ (e/σ)² over A, B, C (3 dof)") && table.contains("NEES mean/dof"), "{table}");
    let consistency_row = table.lines().rev().find(|l| l.starts_with("honest_for_comparison")).unwrap();
    assert!(consistency_row.split_whitespace().nth(1).unwrap().ends_with("/3*"), "{table}");
    let json = temp("wide_narrow.json");
    comparison.write_json(&json).unwrap();
    let value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let pair = &value["runs"][1]["pairs"][1];
    assert_eq!(pair["normalised_error"]["reading"], "too wide", "{pair}");
    assert!(pair["one_sigma_coverage"].as_f64().unwrap() > 0.9);
    assert_eq!(value["runs"][1]["pairs"][2]["normalised_error"]["reading"], "too narrow");
    assert_eq!(value["runs"][0]["nees"]["dof"], 3);
    assert!(value["runs"][1]["nees"]["mean"].as_f64().unwrap() > 5.0);
    assert_eq!(value["best_consistency"]["nees_mean"], "honest_for_comparison");
    assert_eq!(value["best"][2]["normalised_error"], "honest_for_comparison");
}

#[test]
fn autocorrelated_honest_errors_are_worth_fewer_samples_and_still_read_consistent() {
    let path = temp("ar.mcap");
    let ar: f64 = 0.95;
    write_sigma_run(&path, 3, ar, [1.0, 2.0, 0.5]);
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    // For a Gaussian AR(1), (e/σ)² has autocorrelation ar^(2k): 1 + 2Σ = (1 + ar²)/(1 − ar²).
    let expected = SAMPLES as f64 * (1.0 - ar * ar) / (1.0 + ar * ar);
    for p in &report.pairs {
        let n = p.normalised_error.unwrap();
        assert!((n.effective_samples - expected).abs() < 0.2 * expected, "{}: {n:?} vs {expected}", p.truth);
    }
    let readings: Vec<Reading> = report.pairs.iter().map(|p| p.normalised_error.unwrap().reading).collect();
    assert_eq!(readings, [Reading::Consistent, Reading::TooWide, Reading::TooNarrow]);
}

/// `SAMPLES` at 100 Hz: truth and estimate F (no σ), three measurement rows a, b, c and a
/// control u on `/measurements` (the parameters name `r_a_std`, `r_b_std`, `r_c_std`), `c`
/// missing every third sample, one row rejected every tenth (the cumulative
/// `rejected_measurements` on `/estimate` steps there), and `nis` the sum of squares of as
/// many standard normals as rows used, times `scale`. Returns the mean rows used.
fn write_nis_run(path: &Path, scale: f64, with_measurements: bool) -> f64 {
    let parameters = r#"{"r_a_std": 0.1, "r_b_std": 0.2, "r_c_std": 0.3, "q_std": 1.0}"#;
    let metadata = BTreeMap::from([("parameters".to_string(), parameters.to_string())]);
    let mut w = LogWriter::create(path, &metadata).unwrap();
    let m = with_measurements.then(|| {
        let specs = ["a", "b", "c", "u"].map(|n| SignalSpec::new(n, "m", "input"));
        w.add_channel(MEASUREMENTS, &specs).unwrap()
    });
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "true load")]).unwrap();
    let specs = [
        SignalSpec::new("F", "N", "estimate"),
        SignalSpec::new("nis", "1", "NIS of the last update"),
        SignalSpec::new("rejected_measurements", "1", "rows rejected so far"),
    ];
    let e = w.add_channel(ESTIMATE, &specs).unwrap();
    let mut gaussian = Gaussian(42);
    let (mut rejected, mut rows_total) = (0.0, 0.0);
    for k in 0..SAMPLES {
        let time = k as f64 * 0.01;
        let c = if k % 3 == 0 { f64::NAN } else { 0.3 };
        let rejected_here = usize::from(k % 10 == 0);
        rejected += rejected_here as f64;
        let rows = 3 - usize::from(c.is_nan()) - rejected_here;
        rows_total += rows as f64;
        let nis = scale * (0..rows).map(|_| gaussian.next().powi(2)).sum::<f64>();
        if let Some(m) = m {
            w.write(m, time, &[0.1, 0.2, c, 5.0]).unwrap();
        }
        let truth = time.sin();
        w.write(t, time, &[truth]).unwrap();
        w.write(e, time, &[truth + 0.01, nis, rejected]).unwrap();
    }
    w.finish().unwrap();
    rows_total / SAMPLES as f64
}

#[test]
fn a_nis_distributed_as_chi_square_of_the_rows_used_reads_consistent() {
    let path = temp("nis.mcap");
    let rows_mean = write_nis_run(&path, 1.0, true);
    // 3 rows, c missing on a third of the samples, one rejected on a tenth: 3 − 1/3 − 1/10.
    assert!((rows_mean - (3.0 - 1.0 / 3.0 - 0.1)).abs() < 1e-4, "{rows_mean}");
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    let nis = report.nis.as_ref().unwrap();
    assert_eq!(nis.samples, SAMPLES);
    assert!(nis.rejections_known, "{nis:?}");
    assert!((nis.rows_used_mean.unwrap() - rows_mean).abs() < 1e-12, "the control u is no row: {nis:?}");
    // Var(NIS) = 2·rows: the mean's standard deviation is about 0.007.
    assert!((nis.mean - rows_mean).abs() < 0.03, "{nis:?}");
    assert!((nis.ratio.unwrap() - 1.0).abs() < 0.012, "{nis:?}");
    assert_eq!(nis.reading, Some(Reading::Consistent), "{nis:?}");
    assert!((nis.in_band.unwrap() - 0.95).abs() < 0.005, "{nis:?}");
    assert!(nis.rows_used_from.contains("less the step of /estimate rejected_measurements"), "{}", nis.rows_used_from);
    assert!(report.nees.is_none(), "no σ, no NEES");
    let comparison = compare_runs(std::slice::from_ref(&run), &Options::default()).unwrap();
    let table = comparison.table();
    assert!(table.contains("NIS rows used: the signals whose r_<signal>_std the parameters set"), "{table}");
    assert!(table.contains("NIS/rows") && table.contains("consistent"), "{table}");
}

#[test]
fn a_nis_too_large_reads_too_narrow_and_without_measurements_its_expectation_is_unknown() {
    let path = temp("nis_large.mcap");
    write_nis_run(&path, 1.5, true);
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    let nis = report.nis.as_ref().unwrap();
    assert!((nis.ratio.unwrap() - 1.5).abs() < 0.02 && nis.reading == Some(Reading::TooNarrow), "{nis:?}");
    assert!(nis.in_band.unwrap() < 0.9, "{nis:?}");

    let path = temp("nis_alone.mcap");
    let rows_mean = write_nis_run(&path, 1.0, false);
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    let nis = report.nis.as_ref().unwrap();
    assert!((nis.mean - rows_mean).abs() < 0.03, "{nis:?}");
    assert_eq!((nis.rows_used_mean, nis.ratio, nis.reading), (None, None, None));
    assert_eq!(nis.rows_used_from, "unknown: the log has no /measurements");
    let table = compare_runs(std::slice::from_ref(&run), &Options::default()).unwrap().table();
    assert!(table.contains("unknown"), "{table}");
}
