//! Specification of `kalfmu-tune --smoothed-log` on a log of S1 (made here from S1's
//! truth simulator, as the studies log it): the log written keeps the input's channels and
//! adds, at every sample, the FMU's filtered state estimates on `/estimate` and the
//! estimates given the whole log on `/smoothed`, with their σ. The smoothed load is closer
//! to the truth than the filtered one, its σ is never wider, and at the last sample,
//! which no later sample informs, the two are the same.

#[path = "support/simulated_logs.rs"]
mod simulated_logs;

use std::path::PathBuf;
use std::process::Command;

use log_format::read::read_log;
use log_format::write::{ESTIMATE, MEASUREMENTS, SMOOTHED, TRUTH};
use tuning::smoothed_log::SMOOTHING_KEY;

fn scratch(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("smoothed_log_{}_{name}", std::process::id()))
}

fn rmse(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

#[test]
fn the_smoothed_log_holds_the_filtered_and_the_whole_log_estimates_of_every_sample() {
    let log = scratch("s1.mcap");
    simulated_logs::write_s1(&log, 10.0, 5, 0.05).unwrap();
    let template = scratch("out_{log}.mcap");
    let output = Command::new(env!("CARGO_BIN_EXE_kalfmu-tune"))
        .arg(&log)
        .arg("--evaluate")
        .arg("--smoothed-log")
        .arg(&template)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{text}{}", String::from_utf8_lossy(&output.stderr));
    let stem = log.file_stem().unwrap().to_string_lossy();
    let written = PathBuf::from(template.to_string_lossy().replace("{log}", &stem));
    assert!(text.contains(&format!("wrote {}: 2001 samples", written.display())), "{text}");

    let source = read_log(&log).unwrap();
    let run = read_log(&written).unwrap();
    assert_eq!(run.metadata["filter"], "SRCKF");
    assert!(run.metadata[SMOOTHING_KEY].starts_with("fixed-interval"));
    assert_eq!(run.metadata["study"], source.metadata["study"], "the source's metadata is kept");
    for topic in [TRUTH, MEASUREMENTS] {
        assert_eq!(run.channel(topic).unwrap(), source.channel(topic).unwrap(), "{topic} as it was");
    }
    let (filtered, smoothed) = (run.channel(ESTIMATE).unwrap(), run.channel(SMOOTHED).unwrap());
    let times = &source.channel(MEASUREMENTS).unwrap().time;
    assert_eq!(&filtered.time, times);
    assert_eq!(&smoothed.time, times);
    let names = |c: &log_format::read::Channel| c.signals.iter().map(|s| s.spec.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(filtered), names(smoothed));
    assert!(names(filtered).iter().any(|n| n == "F_std"), "{:?}", names(filtered));

    let truth = &source.channel(TRUTH).unwrap().signal("F").unwrap().values;
    let values = |c: &log_format::read::Channel, name: &str| c.signal(name).unwrap().values.clone();
    let (f, s) = (values(filtered, "F"), values(smoothed, "F"));
    let (f_std, s_std) = (values(filtered, "F_std"), values(smoothed, "F_std"));
    let (e_filtered, e_smoothed) = (rmse(&f, truth), rmse(&s, truth));
    println!("load RMSE: filtered {e_filtered:.4} N, smoothed {e_smoothed:.4} N");
    assert!(e_smoothed < 0.8 * e_filtered, "smoothed {e_smoothed} against filtered {e_filtered}");
    for k in 0..f.len() {
        assert!(s_std[k] <= f_std[k] * (1.0 + 1e-9), "sample {k}: smoothed σ {} > filtered σ {}", s_std[k], f_std[k]);
    }
    let last = f.len() - 1;
    assert_eq!((s[last], s_std[last]), (f[last], f_std[last]), "the last sample has nothing after it");
}

#[test]
fn several_logs_need_a_name_per_log() {
    let log = scratch("one.mcap");
    simulated_logs::write_s1(&log, 1.0, 1, 0.05).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_kalfmu-tune"))
        .args([&log, &log])
        .args(["--evaluate", "--smoothed-log"])
        .arg(scratch("fixed.mcap"))
        .output()
        .unwrap();
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("{log}"));
}
