//! The Rerun recording holds what the report computed: written from a small log, then
//! read back with Rerun's own decoder (`re_log_encoding`, `Chunk::from_arrow_msg`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analyzer::log::{LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, TRUTH};
use analyzer::read::{read_log, Run};
use analyzer::report::{analyse, Options, Report};
use analyzer::rrd::{write_rrd, TIMELINE};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::external::re_sdk_types::blueprint::archetypes::ViewBlueprint;
use rerun::log::{Chunk, LogMsg};
use rerun::{EntityPath, Scalars, StoreKind, TextDocument};

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-analyzer-rrd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// 20 s at 100 Hz: truth `F = 10 sin(2π·1.5 t)`, estimate = truth + a small
/// deterministic error, σ = 0.1, and a measurement with one missing value.
fn write_run(path: &Path) {
    let metadata =
        BTreeMap::from([("study".to_string(), "rrd test".to_string()), ("seed".to_string(), "7".to_string())]);
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
        let time = k as f64 * 0.01;
        let truth = 10.0 * (2.0 * std::f64::consts::PI * 1.5 * time).sin();
        let estimate = truth + 0.05 * ((k * 7919 % 13) as f64 - 6.0) / 6.0;
        w.write(m, time, &[if k == 5 { f64::NAN } else { truth / 8.0 }]).unwrap();
        w.write(t, time, &[truth]).unwrap();
        w.write(e, time, &[estimate, 0.1]).unwrap();
    }
    w.finish().unwrap();
}

/// What a `.rrd` file holds, decoded by Rerun's reader.
#[derive(Default)]
struct Decoded {
    recording_ids: Vec<String>,
    recording: Vec<Chunk>,
    blueprint: Vec<Chunk>,
    activations: usize,
}

impl Decoded {
    fn read(path: &Path) -> Self {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut out = Self::default();
        for msg in DecoderApp::decode_eager(file).unwrap() {
            match msg.unwrap() {
                LogMsg::SetStoreInfo(info) if info.info.store_id.kind() == StoreKind::Recording => {
                    out.recording_ids.push(info.info.store_id.recording_id().to_string());
                }
                LogMsg::SetStoreInfo(_) => {}
                LogMsg::ArrowMsg(store, msg) => {
                    let chunk = Chunk::from_arrow_msg(&msg).unwrap();
                    match store.kind() {
                        StoreKind::Recording => out.recording.push(chunk),
                        StoreKind::Blueprint => out.blueprint.push(chunk),
                    }
                }
                LogMsg::BlueprintActivationCommand(_) => out.activations += 1,
            }
        }
        out
    }

    /// The recording's chunks at `path`, in file order.
    fn chunks<'a>(&'a self, path: &str) -> impl Iterator<Item = &'a Chunk> + 'a {
        let path = EntityPath::from(path);
        self.recording.iter().filter(move |c| *c.entity_path() == path)
    }

    /// The `sim_time` stamps (s) and scalar values of the series at `path`.
    fn series(&self, path: &str) -> (Vec<f64>, Vec<f64>) {
        let mut times = Vec::new();
        let mut values = Vec::new();
        for chunk in self.chunks(path).filter(|c| !c.is_static()) {
            let column = &chunk.timelines()[&TIMELINE.into()];
            times.extend(column.times_raw().iter().map(|&ns| ns as f64 / 1e9));
            for row in chunk.iter_slices::<f64>(Scalars::descriptor_scalars().component) {
                assert_eq!(row.len(), 1, "one scalar per row at {path}");
                values.push(row[0]);
            }
        }
        assert_eq!(times.len(), values.len(), "{path}");
        (times, values)
    }

    fn text(&self, path: &str) -> String {
        let mut text = String::new();
        for chunk in self.chunks(path) {
            for row in chunk.iter_slices::<String>(TextDocument::descriptor_text().component) {
                row.iter().for_each(|s| text.push_str(s.as_str()));
            }
        }
        text
    }
}

fn written(name: &str) -> (Report<'static>, Decoded, PathBuf) {
    let log = temp(&format!("{name}.mcap"));
    write_run(&log);
    // Leaked: the report borrows the run's samples, for the whole test.
    let run: &'static Run = Box::leak(Box::new(read_log(&log).unwrap()));
    let report = analyse(run, &Options::default()).unwrap();
    let rrd = temp(&format!("{name}.rrd"));
    write_rrd(&report, run, &rrd).unwrap();
    (report, Decoded::read(&rrd), rrd)
}

#[test]
fn the_recording_holds_every_series_of_the_report() {
    let (report, rrd, _) = written("series");
    let p = &report.pairs[0];
    assert_eq!(rrd.recording_ids, ["series.mcap"], "the recording id is the log's file name");
    for path in [
        "signals/F/truth",
        "signals/F/estimate",
        "signals/F/plus_2sigma",
        "signals/F/minus_2sigma",
        "errors/F/error",
        "errors/F/running_rmse",
        "measurements/a",
    ] {
        let (times, values) = rrd.series(path);
        let expected = if path == "measurements/a" { 1999 } else { 2000 };
        assert_eq!(values.len(), expected, "rows of {path}");
        assert_eq!((times[0], *times.last().unwrap()), (0.0, 19.99), "{path}");
    }
    let (_, truth) = rrd.series("signals/F/truth");
    let (_, estimate) = rrd.series("signals/F/estimate");
    assert_eq!(truth[..], p.truth_values[..], "every truth value, bit for bit");
    assert_eq!((estimate[0], estimate[1999]), (p.estimate_values[0], p.estimate_values[1999]));
    let (_, plus) = rrd.series("signals/F/plus_2sigma");
    assert_eq!(plus[0], p.estimate_values[0] + 0.2);
    let (_, rmse) = rrd.series("errors/F/running_rmse");
    assert_eq!(*rmse.last().unwrap(), *p.running_rmse.last().unwrap());
    let (times, measured) = rrd.series("measurements/a");
    assert_eq!((times[4], times[5]), (0.04, 0.06), "the NaN sample at 0.05 s is left out");
    assert!(measured.iter().all(|v| v.is_finite()));
    // No wall clock: every temporal chunk is on sim_time alone.
    for chunk in rrd.recording.iter().filter(|c| !c.is_static()) {
        let names: Vec<String> = chunk.timelines().keys().map(|k| k.to_string()).collect();
        assert_eq!(names, [TIMELINE], "{}", chunk.entity_path());
    }
}

#[test]
fn the_recording_holds_the_spectra_the_report_and_a_blueprint() {
    let (report, rrd, _) = written("static");
    let p = &report.pairs[0];
    for leaf in ["truth", "estimate"] {
        let path = format!("psd/F/loglog/{leaf}");
        let chunk = rrd.chunks(&path).next().unwrap_or_else(|| panic!("{path} is missing"));
        assert!(chunk.is_static());
        let points: usize = chunk
            .iter_slices::<&[[f32; 2]]>(rerun::LineStrips2D::descriptor_strips().component)
            .flatten()
            .map(|strip| strip.len())
            .sum();
        assert_eq!(points, p.truth_spectrum.frequency.len() - 1, "every bin but DC at {path}");
    }
    let text = rrd.text("report");
    let correlation = format!("{:.5}", p.comparison.correlation);
    assert!(text.contains(&correlation), "the report shows the correlation {correlation}:\n{text}");
    assert!(text.contains("| seed | 7 |"), "{text}");
    let properties = EntityPath::properties();
    assert!(rrd.recording.iter().any(|c| *c.entity_path() == properties), "the recording properties name the log");
    // The blueprint: its own store, activated, with its five views (`2D` is the Spatial2DView).
    assert_eq!(rrd.activations, 1);
    let strings = |chunk: &Chunk, descriptor: rerun::ComponentDescriptor| -> Vec<String> {
        chunk.iter_slices::<String>(descriptor.component).flatten().map(|s| s.as_str().to_string()).collect()
    };
    let mut views: Vec<(String, String)> = Vec::new();
    for chunk in &rrd.blueprint {
        let classes = strings(chunk, ViewBlueprint::descriptor_class_identifier());
        let origins = strings(chunk, ViewBlueprint::descriptor_space_origin());
        views.extend(classes.into_iter().zip(origins));
    }
    views.sort();
    let expected = [
        ("2D", "/psd/F"),
        ("TextDocument", "/report"),
        ("TimeSeries", "/errors/F"),
        ("TimeSeries", "/measurements"),
        ("TimeSeries", "/signals/F"),
    ];
    let expected: Vec<(String, String)> = expected.iter().map(|(c, o)| (c.to_string(), o.to_string())).collect();
    assert_eq!(views, expected);
}

#[test]
fn writing_twice_gives_the_same_recording_chunks() {
    let (report, first, _) = written("twice");
    let run = read_log(&temp("twice.mcap")).unwrap();
    let dir = temp("again");
    std::fs::create_dir_all(&dir).unwrap();
    let again = dir.join("twice.rrd");
    write_rrd(&report, &run, &again).unwrap();
    let second = Decoded::read(&again);
    assert_eq!(first.recording_ids, second.recording_ids);
    assert_eq!(first.recording.len(), second.recording.len());
    assert!(first.recording == second.recording, "same chunk ids, row ids and data");
}

#[test]
fn rerun_off_in_the_environment_is_an_error_not_a_missing_file() {
    let log = temp("off.mcap");
    write_run(&log);
    let rrd = temp("off.rrd");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_analyzer"))
        .args(["report", log.to_str().unwrap(), "--rrd", rrd.to_str().unwrap()])
        .env("RERUN", "off")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("off.rrd: cannot write the Rerun recording: the RERUN environment variable"), "{stderr}");
    assert!(!rrd.exists());
}
