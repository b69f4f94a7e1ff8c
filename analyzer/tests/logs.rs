//! The log format round-trips, the report computes what it should, and every
//! kind of bad input is a clear error naming the file, channel and time.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analyzer::report::{analyse, Options};
use log_format::read::{read_log, Channel, Signal};
use log_format::write::{write_channels, LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, PREDICTION, TRUTH};
use log_format::LogError;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-analyzer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// 20 s at 100 Hz: truth `F = 10 sin(2π·1.5 t)`, estimate = truth + a small
/// deterministic error, σ = 0.1, and a measurement with one missing value.
fn write_run(path: &Path, mutate: impl Fn(usize, &mut f64, &mut f64)) {
    let metadata = BTreeMap::from([("study".to_string(), "test".to_string()), ("seed".to_string(), "7".to_string())]);
    let mut w = LogWriter::create(path, &metadata).unwrap();
    let m = w.add_channel(MEASUREMENTS, &[SignalSpec::new("a", "m/s2", "acceleration")]).unwrap();
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "true load")]).unwrap();
    let e = w
        .add_channel(
            ESTIMATE,
            &[SignalSpec::new("F", "N", "estimated load"), SignalSpec::new("F_std", "N", "its deviation")],
        )
        .unwrap();
    for k in 0..2000 {
        let mut time = k as f64 * 0.01;
        let truth = 10.0 * (2.0 * std::f64::consts::PI * 1.5 * time).sin();
        let mut estimate = truth + 0.05 * ((k * 7919 % 13) as f64 - 6.0) / 6.0;
        mutate(k, &mut time, &mut estimate);
        w.write(m, time, &[if k == 5 { f64::NAN } else { truth / 8.0 }]).unwrap();
        w.write(t, time, &[truth]).unwrap();
        w.write(e, time, &[estimate, 0.1]).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_log_round_trips_with_its_metadata_units_and_missing_values() {
    let path = temp("roundtrip.mcap");
    write_run(&path, |_, _, _| {});
    let run = read_log(&path).unwrap();
    assert_eq!(run.metadata["seed"], "7");
    let m = run.channel(MEASUREMENTS).unwrap();
    assert_eq!(m.time.len(), 2000);
    assert!(m.signal("a").unwrap().values[5].is_nan(), "a missing value reads back as NaN");
    let e = run.channel(ESTIMATE).unwrap();
    assert_eq!(e.signal("F").unwrap().spec, SignalSpec::new("F", "N", "estimated load"));
    assert_eq!(e.time[1], 0.01);
}

#[test]
fn channels_read_back_are_written_again_as_they_were_even_on_other_time_grids() {
    let path = temp("rewritten_source.mcap");
    write_run(&path, |_, _, _| {});
    let run = read_log(&path).unwrap();
    // A channel of its own span (from the tenth sample, every other one), made in memory.
    let truth = run.channel(TRUTH).unwrap();
    let later = Channel {
        topic: "/later".into(),
        time: truth.time[10..].iter().step_by(2).copied().collect(),
        signals: vec![Signal {
            spec: SignalSpec::new("G", "N", "a later channel"),
            values: truth.signals[0].values[10..].iter().step_by(2).map(|v| -v).collect(),
        }],
    };
    let copy = temp("rewritten.mcap");
    let channels: Vec<&Channel> = run.channels.iter().chain([&later]).collect();
    write_channels(&copy, &run.metadata, &channels).unwrap();
    let again = read_log(&copy).unwrap();
    assert_eq!(again.metadata, run.metadata);
    for channel in channels {
        let read = again.channel(&channel.topic).unwrap();
        assert_eq!(read.time, channel.time, "{}", channel.topic);
        for (a, b) in read.signals.iter().zip(&channel.signals) {
            assert_eq!(a.spec, b.spec);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a.values), bits(&b.values), "{} {}: bit for bit, NaN too", channel.topic, a.spec.name);
        }
    }
}

#[test]
fn the_report_pairs_by_name_and_measures_the_known_error() {
    let path = temp("report.mcap");
    write_run(&path, |_, _, _| {});
    let run = read_log(&path).unwrap();
    let report = analyse(&run, &Options::default()).unwrap();
    assert_eq!(report.pairs.len(), 1);
    let p = &report.pairs[0];
    assert_eq!((p.truth.as_str(), p.estimate.as_str(), p.samples), ("F", "F", 2000));
    assert!(p.metrics.correlation > 0.9999);
    assert!(p.metrics.rmse < 0.05 && p.metrics.rmse > 0.01, "{}", p.metrics.rmse);
    assert_eq!(p.two_sigma_coverage, Some(1.0), "every error is within 2σ = 0.2");
    let (lo, hi) = p.psd_agreement_band.unwrap();
    assert!(lo <= 1.5 && hi >= 1.5, "the spectra agree around the 1.5 Hz line: {lo}–{hi}");
}

#[test]
fn metrics_from_a_time_leave_the_start_up_out_and_keep_the_whole_series() {
    // The first 2 s carry a start-up error of 5 N, far outside the 2σ = 0.2 band.
    let path = temp("from.mcap");
    write_run(&path, |k, _, estimate| {
        if k < 200 {
            *estimate += 5.0;
        }
    });
    let run = read_log(&path).unwrap();
    let whole = analyse(&run, &Options::default()).unwrap();
    let settled = analyse(&run, &Options { from: 2.0, ..Options::default() }).unwrap();
    let (w, s) = (&whole.pairs[0], &settled.pairs[0]);
    assert!(w.metrics.rmse > 1.0 && w.two_sigma_coverage < Some(0.95), "{}", w.metrics.rmse);
    assert_eq!((s.samples, s.compared_from), (1800, 2.0));
    assert!(s.metrics.rmse < 0.05 && s.two_sigma_coverage == Some(1.0), "{}", s.metrics.rmse);
    assert_eq!(
        s.metrics.correlation,
        analyzer::metrics::correlation(&s.truth_values[200..], &s.estimate_values[200..])
    );
    assert_eq!((s.time.len(), s.running_rmse.len()), (2000, 2000), "the series stay whole");
    let late = analyse(&run, &Options { from: 19.98, ..Options::default() }).unwrap_err();
    assert!(late.to_string().contains("only 2 samples from t = 19.98 s on"), "{late}");
}

#[test]
fn an_explicit_pair_replaces_the_naming_rule_and_a_bad_pair_is_named() {
    let path = temp("pair.mcap");
    write_run(&path, |_, _, _| {});
    let run = read_log(&path).unwrap();
    let options = Options { pairs: vec![("F".into(), "F_std".into())], ..Options::default() };
    let report = analyse(&run, &options).unwrap();
    assert_eq!((report.pairs[0].truth.as_str(), report.pairs[0].estimate.as_str()), ("F", "F_std"));
    let options = Options { pairs: vec![("F".into(), "G".into())], ..Options::default() };
    let err = analyse(&run, &options).unwrap_err().to_string();
    assert!(err.contains("/estimate has no signal 'G'"), "{err}");
}

/// `--estimate-topic` compares the truth with another channel of estimates:
/// an FMU's outputs read after each step (`/prediction`), here the truth
/// delayed by one sample, whose known error the report measures.
#[test]
fn another_estimate_channel_is_compared_when_named() {
    let path = temp("prediction.mcap");
    let mut w = LogWriter::create(&path, &BTreeMap::new()).unwrap();
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "true load")]).unwrap();
    let e = w.add_channel(ESTIMATE, &[SignalSpec::new("F", "N", "estimate")]).unwrap();
    let p = w.add_channel(PREDICTION, &[SignalSpec::new("F", "N", "one sample late")]).unwrap();
    let truth = |k: usize| 10.0 * (2.0 * std::f64::consts::PI * 1.5 * k as f64 * 0.01).sin();
    for k in 0..2000 {
        let time = k as f64 * 0.01;
        w.write(t, time, &[truth(k)]).unwrap();
        w.write(e, time, &[truth(k)]).unwrap();
        w.write(p, time, &[truth(k.saturating_sub(1))]).unwrap();
    }
    w.finish().unwrap();
    let run = read_log(&path).unwrap();
    let exact = analyse(&run, &Options::default()).unwrap();
    assert_eq!(exact.pairs[0].metrics.rmse, 0.0);
    let late = analyse(&run, &Options { estimate_topic: PREDICTION.into(), ..Options::default() }).unwrap();
    // One sample of a 1.5 Hz sine of amplitude 10: RMS 10/√2 · 2 sin(π·1.5·0.01) ≈ 0.666.
    let expected = 10.0 / 2f64.sqrt() * 2.0 * (std::f64::consts::PI * 1.5 * 0.01).sin();
    assert!((late.pairs[0].metrics.rmse - expected).abs() < 0.01 * expected, "{}", late.pairs[0].metrics.rmse);
    let missing = Options { estimate_topic: "/nowhere".into(), ..Options::default() };
    assert!(analyse(&run, &missing).unwrap_err().to_string().contains("/nowhere"));
}

#[test]
fn a_corrupt_chunk_or_a_missing_file_is_an_error_naming_it() {
    let path = temp("whole.mcap");
    write_run(&path, |_, _, _| {});
    let mut corrupt = std::fs::read(&path).unwrap();
    for b in &mut corrupt[200..400] {
        *b ^= 0x5a;
    }
    let corrupt_path = temp("corrupt.mcap");
    std::fs::write(&corrupt_path, &corrupt).unwrap();
    let err = read_log(&corrupt_path).unwrap_err();
    assert!(matches!(err, LogError::Truncated { .. }), "{err}");
    assert!(err.to_string().contains("corrupt.mcap"), "{err}");
    let err = read_log(&temp("absent.mcap")).unwrap_err();
    assert!(matches!(err, LogError::Io { .. }) && err.to_string().contains("absent.mcap"), "{err}");
}

#[test]
fn a_missing_channel_is_named_with_the_channels_present() {
    let path = temp("no_truth.mcap");
    let mut w = LogWriter::create(&path, &BTreeMap::new()).unwrap();
    let e = w.add_channel(ESTIMATE, &[SignalSpec::new("F", "N", "estimate")]).unwrap();
    for k in 0..10 {
        w.write(e, k as f64, &[1.0]).unwrap();
    }
    w.finish().unwrap();
    let err = analyse(&read_log(&path).unwrap(), &Options::default()).unwrap_err().to_string();
    assert!(err.contains("channel /truth is missing (the log has: /estimate)"), "{err}");
}

/// A log another tool wrote: JSON truth and estimates (estimate = truth + 0.5) beside a
/// channel in an encoding the reader does not know, which is skipped with a warning.
#[test]
fn json_channels_are_analysed_and_a_channel_in_an_unknown_encoding_is_skipped_with_a_warning() {
    let path = temp("json_and_protobuf.mcap");
    let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    let mut w = mcap::WriteOptions::new().create(file).unwrap();
    let schema = w.add_schema("Load", "jsonschema", br#"{"type": "object", "properties": {"F": {"type": "number"}}}"#);
    let schema = schema.unwrap();
    let truth = w.add_channel(schema, TRUTH, "json", &BTreeMap::new()).unwrap();
    let estimate = w.add_channel(schema, ESTIMATE, "json", &BTreeMap::new()).unwrap();
    let other = w.add_schema("pkg.Imu", "protobuf", b"").unwrap();
    let imu = w.add_channel(other, "/imu", "protobuf", &BTreeMap::new()).unwrap();
    for k in 0..500u64 {
        let header = |channel_id| mcap::records::MessageHeader {
            channel_id,
            sequence: k as u32,
            log_time: k * 10_000_000,
            publish_time: k * 10_000_000,
        };
        let f = (k as f64 * 0.05).sin();
        w.write_to_known_channel(&header(truth), format!(r#"{{"F": {f}}}"#).as_bytes()).unwrap();
        w.write_to_known_channel(&header(estimate), format!(r#"{{"F": {}}}"#, f + 0.5).as_bytes()).unwrap();
        w.write_to_known_channel(&header(imu), &[8, 1]).unwrap();
    }
    w.finish().unwrap();
    let run = read_log(&path).unwrap();
    assert_eq!(run.skipped.iter().map(|s| s.topic.as_str()).collect::<Vec<_>>(), ["/imu"]);
    let report = analyse(&run, &Options::default()).unwrap();
    assert_eq!((report.pairs[0].truth.as_str(), report.pairs[0].samples), ("F", 500));
    assert!((report.pairs[0].metrics.rmse - 0.5).abs() < 1e-12, "{}", report.pairs[0].metrics.rmse);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_analyzer")).arg("report").arg(&path).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("channel /imu is skipped: message encoding 'protobuf' is not read"), "{stderr}");
}

#[test]
fn a_schema_that_is_not_float64_fields_is_named_with_its_channel() {
    for (schema, expected) in [
        ("int32 count", "field 'count' is int32; the format has float64 fields only"),
        ("float64 x\nfloat64 x", "field 'x' is declared twice"),
        ("float64 a b", "is not a field declaration"),
        ("float64 9x", "'9x' is not a field name"),
    ] {
        let path = temp("bad_schema.mcap");
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut w = mcap::WriteOptions::new().create(file).unwrap();
        let id = w.add_schema("kalfmu/Truth", "ros1msg", schema.as_bytes()).unwrap();
        let channel = w.add_channel(id, TRUTH, "ros1", &BTreeMap::new()).unwrap();
        let header = mcap::records::MessageHeader { channel_id: channel, sequence: 0, log_time: 0, publish_time: 0 };
        w.write_to_known_channel(&header, &[0u8; 8]).unwrap();
        w.finish().unwrap();
        let err = read_log(&path).unwrap_err().to_string();
        assert!(err.contains("channel /truth: ") && err.contains(expected), "{schema:?}: {err}");
    }
}

#[test]
fn a_message_of_the_wrong_length_is_named_with_its_channel_and_time() {
    let path = temp("short_message.mcap");
    let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    let mut w = mcap::WriteOptions::new().create(file).unwrap();
    let id = w.add_schema("kalfmu/Truth", "ros1msg", b"float64 F  # [N] load\nfloat64 G").unwrap();
    let channel = w.add_channel(id, TRUTH, "ros1", &BTreeMap::new()).unwrap();
    let header = |t| mcap::records::MessageHeader { channel_id: channel, sequence: 0, log_time: t, publish_time: t };
    w.write_to_known_channel(&header(0), &[0u8; 16]).unwrap();
    w.write_to_known_channel(&header(500_000_000), &[0u8; 12]).unwrap();
    w.finish().unwrap();
    let err = read_log(&path).unwrap_err().to_string();
    assert!(
        err.contains("channel /truth at t = 0.5 s: 12 bytes, where the schema's 2 float64 fields take 16"),
        "{err}"
    );
}

#[test]
fn time_going_backwards_is_named_with_both_times() {
    let path = temp("backwards.mcap");
    write_run(&path, |k, time, _| {
        if k == 100 {
            *time = 0.5;
        }
    });
    let err = read_log(&path).unwrap_err().to_string();
    assert!(err.contains("channel /measurements: time goes from 0.99 s back to 0.5 s (message 100)"), "{err}");
}

#[test]
fn a_nan_in_a_compared_signal_is_an_error_naming_channel_signal_and_time() {
    let path = temp("nan.mcap");
    write_run(&path, |k, _, estimate| {
        if k == 300 {
            *estimate = f64::NAN;
        }
    });
    let err = analyse(&read_log(&path).unwrap(), &Options::default()).unwrap_err().to_string();
    assert!(err.contains("channel /estimate, signal F: not finite at t = 3 s"), "{err}");
}
