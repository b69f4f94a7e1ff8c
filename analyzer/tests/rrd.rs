//! The Rerun recording holds what the comparison computed: written from small logs, then
//! read back with Rerun's own decoder (`re_log_encoding`, `Chunk::from_arrow_msg`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analyzer::compare::{compare_runs, Comparison};
use analyzer::report::Options;
use analyzer::rrd::{envelope_bucket, write_rrd, MAX_ROWS, TIMELINE};
use log_format::read::{read_log, Run};
use log_format::write::{LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, TRUTH};
use rerun::external::re_log_encoding::DecoderApp;
use rerun::external::re_sdk_types::blueprint::archetypes::{ViewBlueprint, ViewContents};
use rerun::log::{Chunk, LogMsg};
use rerun::{EntityPath, Scalars, SeriesLines, StoreKind, TextDocument};

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-analyzer-rrd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `n` samples at 100 Hz: truth `F = 10 sin(2π·1.5 t)`, the estimate of filter `filter` =
/// truth + a small deterministic error scaled by `error`, σ = 0.1, and a measurement with
/// one missing value.
fn write_run(path: &Path, filter: &str, error: f64, n: usize) {
    let metadata = BTreeMap::from([
        ("study".to_string(), "rrd test".to_string()),
        ("seed".to_string(), "7".to_string()),
        ("filter".to_string(), filter.to_string()),
        ("parameters".to_string(), format!("{{\"q_std\":{error},\"kind\":\"{filter}\"}}")),
    ]);
    let mut w = LogWriter::create(path, &metadata).unwrap();
    let m = w.add_channel(MEASUREMENTS, &[SignalSpec::new("a", "m/s2", "acceleration")]).unwrap();
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "true load")]).unwrap();
    let e = w
        .add_channel(
            ESTIMATE,
            &[SignalSpec::new("F", "N", "estimated load"), SignalSpec::new("F_std", "N", "its deviation")],
        )
        .unwrap();
    for k in 0..n {
        let time = k as f64 * 0.01;
        let truth = 10.0 * (2.0 * std::f64::consts::PI * 1.5 * time).sin();
        let estimate = truth + error * ((k * 7919 % 13) as f64 - 6.0) / 6.0;
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

    /// The `sim_time` stamps (s) of the series at `path`, and its rows of scalars.
    fn series(&self, path: &str) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut times = Vec::new();
        let mut rows = Vec::new();
        for chunk in self.chunks(path).filter(|c| !c.is_static()) {
            let column = &chunk.timelines()[&TIMELINE.into()];
            times.extend(column.times_raw().iter().map(|&ns| ns as f64 / 1e9));
            rows.extend(chunk.iter_slices::<f64>(Scalars::descriptor_scalars().component).map(|row| row.to_vec()));
        }
        assert_eq!(times.len(), rows.len(), "{path}");
        (times, rows)
    }

    /// Column `k` of the series at `path`.
    fn line(&self, path: &str, k: usize) -> Vec<f64> {
        self.series(path).1.iter().map(|row| row[k]).collect()
    }

    /// The names given to the lines of the series at `path`.
    fn line_names(&self, path: &str) -> Vec<String> {
        let descriptor = SeriesLines::descriptor_names();
        self.chunks(path)
            .flat_map(|c| c.iter_slices::<String>(descriptor.component).flatten().map(|s| s.as_str().to_string()))
            .collect()
    }

    /// The colours given to the lines of the series at `path`.
    fn line_colors(&self, path: &str) -> Vec<u32> {
        let descriptor = SeriesLines::descriptor_colors();
        self.chunks(path).flat_map(|c| c.iter_slices::<u32>(descriptor.component).flatten().copied()).collect()
    }

    /// The blueprint's views: (class, origin).
    fn views(&self) -> Vec<(String, String)> {
        let mut views = Vec::new();
        for chunk in &self.blueprint {
            let classes = strings(chunk, ViewBlueprint::descriptor_class_identifier());
            let origins = strings(chunk, ViewBlueprint::descriptor_space_origin());
            views.extend(classes.into_iter().zip(origins));
        }
        views
    }

    /// The blueprint's view titles.
    fn view_names(&self) -> Vec<String> {
        self.blueprint.iter().flat_map(|c| strings(c, ViewBlueprint::descriptor_display_name())).collect()
    }

    /// The blueprint's views of a class: (title, origin, contents queries), by title.
    fn views_with_contents(&self, class: &str) -> Vec<(String, String, Vec<String>)> {
        let mut views = Vec::new();
        for chunk in &self.blueprint {
            if strings(chunk, ViewBlueprint::descriptor_class_identifier()) != [class] {
                continue;
            }
            // The SDK logs a view's contents at `<view>/ViewContents`.
            let contents = chunk.entity_path().join(&EntityPath::from_single_string("ViewContents"));
            let queries = self
                .blueprint
                .iter()
                .filter(|c| *c.entity_path() == contents)
                .flat_map(|c| strings(c, ViewContents::descriptor_query()))
                .collect();
            let title = strings(chunk, ViewBlueprint::descriptor_display_name()).concat();
            let origin = strings(chunk, ViewBlueprint::descriptor_space_origin()).concat();
            views.push((title, origin, queries));
        }
        views.sort();
        views
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

fn strings(chunk: &Chunk, descriptor: rerun::ComponentDescriptor) -> Vec<String> {
    chunk.iter_slices::<String>(descriptor.component).flatten().map(|s| s.as_str().to_string()).collect()
}

/// Two runs of one case (filters A and B, B twice as wrong), compared and recorded.
fn written(name: &str, n: usize) -> (&'static [Run], Comparison<'static>, Decoded) {
    let mut runs = Vec::new();
    for (filter, error) in [("A", 0.05), ("B", 0.1)] {
        let log = temp(&format!("{name}_{filter}.mcap"));
        write_run(&log, filter, error, n);
        runs.push(read_log(&log).unwrap());
    }
    // Leaked: the comparison borrows the runs' samples, for the whole test.
    let runs: &'static [Run] = Vec::leak(runs);
    let comparison = compare_runs(runs, &Options::default()).unwrap();
    let rrd = temp(&format!("{name}.rrd"));
    write_rrd(&comparison, runs, &rrd).unwrap();
    (runs, comparison, Decoded::read(&rrd))
}

#[test]
fn the_recording_overlays_the_truth_and_every_run() {
    let (_, comparison, rrd) = written("series", 2000);
    let (a, b) = (&comparison.runs[0].pairs[0], &comparison.runs[1].pairs[0]);
    assert_eq!(rrd.recording_ids, ["series_A.mcap + series_B.mcap"], "the recording id names the logs");
    // One entity per view, a line per scalar: truth, each estimate, each band's two edges.
    assert_eq!(rrd.line_names("signals/F"), ["truth F", "A F", "B F", "A ± 2σ", "A ± 2σ", "B ± 2σ", "B ± 2σ"]);
    assert_eq!(rrd.line_names("errors/F"), ["A", "B"]);
    assert_eq!(rrd.line_names("rmse/F"), ["A", "B"]);
    let (times, rows) = rrd.series("signals/F");
    assert_eq!((rows.len(), rows[0].len()), (2000, 7));
    assert_eq!((times[0], times[1999]), (0.0, 19.99));
    assert_eq!(rrd.line("signals/F", 0), a.truth_values[..], "every truth value, bit for bit");
    assert_eq!(rrd.line("signals/F", 2), b.estimate_values[..]);
    assert_eq!(rrd.line("signals/F", 5)[0], b.estimate_values[0] + 0.2, "B's upper edge");
    assert_eq!(rrd.line("signals/F", 6)[0], b.estimate_values[0] - 0.2, "B's lower edge");
    let error: Vec<f64> = b.estimate_values.iter().zip(b.truth_values.iter()).map(|(e, t)| e - t).collect();
    assert_eq!(rrd.line("errors/F", 1), error);
    assert_eq!(rrd.line("rmse/F", 0), a.running_rmse);
    let (times, measured) = rrd.series("measurements/a");
    assert_eq!(measured.len(), 1999, "the NaN sample is left out");
    assert_eq!((times[4], times[5]), (0.04, 0.06));
    // No wall clock: every temporal chunk is on sim_time alone.
    for chunk in rrd.recording.iter().filter(|c| !c.is_static()) {
        let names: Vec<String> = chunk.timelines().keys().map(|k| k.to_string()).collect();
        assert_eq!(names, [TIMELINE], "{}", chunk.entity_path());
    }
}

#[test]
fn a_long_series_is_drawn_as_its_envelope_and_the_view_says_so() {
    let n = 3 * MAX_ROWS + 17;
    let (_, comparison, rrd) = written("long", n);
    let a = &comparison.runs[0].pairs[0];
    let bucket = envelope_bucket(n);
    assert!(bucket > 1);
    let (times, rows) = rrd.series("errors/F");
    assert!(rows.len() <= MAX_ROWS + 2, "{} rows", rows.len());
    assert!(times.windows(2).all(|w| w[0] <= w[1]));
    // Every bucket's extremes are kept: the whole series' extremes, and each bucket's.
    let error: Vec<f64> = a.estimate_values.iter().zip(a.truth_values.iter()).map(|(e, t)| e - t).collect();
    let line = rrd.line("errors/F", 0);
    let (lo, hi) = error.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
    assert_eq!(line.iter().copied().fold(f64::INFINITY, f64::min), lo);
    assert_eq!(line.iter().copied().fold(f64::NEG_INFINITY, f64::max), hi);
    let third = &error[2 * bucket..3 * bucket];
    assert_eq!(line[4], third.iter().copied().fold(f64::INFINITY, f64::min));
    assert_eq!(line[5], third.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let note = format!("min/max of every {bucket} samples");
    assert!(rrd.text("report").contains(&note), "the report says so");
    let titles = rrd.view_names();
    assert!(titles.iter().filter(|t| t.contains(&note)).count() == 3, "the three time views say so: {titles:?}");
}

#[test]
fn the_recording_holds_the_spectra_the_tables_and_a_blueprint() {
    let (_, comparison, rrd) = written("static", 2000);
    let a = &comparison.runs[0].pairs[0];
    for leaf in ["truth", "A", "B"] {
        let path = format!("psd/F/loglog/{leaf}");
        let chunk = rrd.chunks(&path).next().unwrap_or_else(|| panic!("{path} is missing"));
        assert!(chunk.is_static());
        let points: usize = chunk
            .iter_slices::<&[[f32; 2]]>(rerun::LineStrips2D::descriptor_strips().component)
            .flatten()
            .map(|strip| strip.len())
            .sum();
        assert_eq!(points, a.truth_spectrum.frequency.len() - 1, "every bin but DC at {path}");
    }
    let text = rrd.text("report");
    // A row per metric, a column per run, the best in bold (A's error is the smaller).
    let row = text.lines().find(|l| l.starts_with("| RMSE |")).unwrap();
    let cells: Vec<&str> = row.split('|').map(str::trim).filter(|c| !c.is_empty()).collect();
    assert_eq!(cells.len(), 3, "{row}");
    assert!(cells[1].starts_with("**") && !cells[2].starts_with("**"), "{row}");
    let rmse = |cell: &str| cell.trim_matches('*').parse::<f64>().unwrap();
    assert!((rmse(cells[1]) - a.metrics.rmse).abs() < 1e-3 * a.metrics.rmse, "{row}");
    assert!(text.contains("| metric | A | B |"), "{text}");
    assert!(!text.contains("in tolerance"), "no tolerance, no column: {text}");
    // The metadata as a table with a column per run, the parameters one per row.
    assert!(text.contains("| seed | 7 | 7 |"), "{text}");
    assert!(text.contains("| parameter `q_std` | 0.05 | 0.1 |"), "{text}");
    assert!(text.contains("| parameter `kind` | A | B |"), "{text}");
    assert!(!text.contains("| parameters |"), "no JSON blob: {text}");
    let properties = EntityPath::properties();
    assert!(rrd.recording.iter().any(|c| *c.entity_path() == properties), "the recording properties name the logs");
    // The blueprint: its own store, activated, with its six views (`2D` is the Spatial2DView).
    assert_eq!(rrd.activations, 1);
    let mut views = rrd.views();
    views.sort();
    let expected = [
        ("2D", "/psd/F"),
        ("TextDocument", "/report"),
        ("TimeSeries", "/errors/F"),
        ("TimeSeries", "/measurements"),
        ("TimeSeries", "/rmse/F"),
        ("TimeSeries", "/signals/F"),
    ];
    let expected: Vec<(String, String)> = expected.iter().map(|(c, o)| (c.to_string(), o.to_string())).collect();
    assert_eq!(views, expected);
    let measurements = rrd.views_with_contents("TimeSeries").into_iter().find(|v| v.1 == "/measurements");
    assert_eq!(measurements.unwrap().2, ["$origin/**"], "a channel of one unit is one view of it all");
}

/// Every view opens on the whole run (the viewer's default would be 30 s either side of
/// the time cursor): its time axis, a `TimeAxis` property of the view, spans the first to
/// the last sample.
#[test]
fn every_view_opens_on_the_whole_run() {
    use rerun::external::re_sdk_types::blueprint::archetypes::TimeAxis;
    use rerun::external::re_sdk_types::blueprint::components::TimeRange;
    use rerun::external::re_sdk_types::encodings::{TimeInt, TimeRangeBoundary};
    let n = 2000;
    let (_, _, rrd) = written("range", n);
    let last = ((n - 1) as f64 * 0.01 * 1e9).round() as i64;
    let mut time_series = 0;
    for chunk in &rrd.blueprint {
        if strings(chunk, ViewBlueprint::descriptor_class_identifier()) != ["TimeSeries"] {
            continue;
        }
        time_series += 1;
        let axis = chunk.entity_path().join(&EntityPath::from_single_string("TimeAxis"));
        let ranges: Vec<TimeRange> = rrd
            .blueprint
            .iter()
            .filter(|c| *c.entity_path() == axis)
            .flat_map(|c| {
                let rows = c.iter_component::<TimeRange>(TimeAxis::descriptor_view_range().component);
                rows.flat_map(|row| row.to_vec()).collect::<Vec<_>>()
            })
            .collect();
        assert_eq!(ranges.len(), 1, "{axis}: one view range");
        assert_eq!(ranges[0].0.start, TimeRangeBoundary::Absolute(TimeInt(0)), "{axis}");
        assert_eq!(ranges[0].0.end, TimeRangeBoundary::Absolute(TimeInt(last)), "{axis}");
    }
    assert_eq!(time_series, 4, "the signal, its error, its running RMSE and the measurements");
}

/// Hovering a plot lists every visible series at that time (truth and each filter side by
/// side), not only the nearest point of one: a `PlotInteraction` property of every time
/// series view.
#[test]
fn hovering_a_plot_lists_every_series_at_that_time() {
    use rerun::external::re_sdk_types::blueprint::archetypes::PlotInteraction;
    use rerun::external::re_sdk_types::blueprint::components::TooltipMode;
    let (_, _, rrd) = written("tooltip", 200);
    let mut time_series = 0;
    for chunk in &rrd.blueprint {
        if strings(chunk, ViewBlueprint::descriptor_class_identifier()) != ["TimeSeries"] {
            continue;
        }
        time_series += 1;
        let interaction = chunk.entity_path().join(&EntityPath::from_single_string("PlotInteraction"));
        let modes: Vec<TooltipMode> = rrd
            .blueprint
            .iter()
            .filter(|c| *c.entity_path() == interaction)
            .flat_map(|c| {
                let rows = c.iter_component::<TooltipMode>(PlotInteraction::descriptor_tooltip_mode().component);
                rows.flat_map(|row| row.to_vec()).collect::<Vec<_>>()
            })
            .collect();
        assert_eq!(modes, [TooltipMode::All], "{interaction}");
    }
    assert_eq!(time_series, 4, "the signal, its error, its running RMSE and the measurements");
}

#[test]
fn measurements_in_several_units_get_a_view_per_unit() {
    // Units interleaved, as a missile's rates, altitude and rates again would be: the views
    // group by unit, not by neighbours in the schema.
    let log = temp("units.mcap");
    let mut w = LogWriter::create(&log, &BTreeMap::new()).unwrap();
    let m = w
        .add_channel(
            MEASUREMENTS,
            &[
                SignalSpec::new("p", "rad/s", "roll rate"),
                SignalSpec::new("h", "m", "altitude"),
                SignalSpec::new("q", "rad/s", "pitch rate"),
            ],
        )
        .unwrap();
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "true load")]).unwrap();
    let e = w.add_channel(ESTIMATE, &[SignalSpec::new("F", "N", "estimated load")]).unwrap();
    for k in 0..200 {
        let time = k as f64 * 0.01;
        w.write(m, time, &[0.1, 10_000.0 + time, -0.1]).unwrap();
        w.write(t, time, &[time]).unwrap();
        w.write(e, time, &[time]).unwrap();
    }
    w.finish().unwrap();
    let runs = [read_log(&log).unwrap()];
    let comparison = compare_runs(&runs, &Options::default()).unwrap();
    let path = temp("units.rrd");
    write_rrd(&comparison, &runs, &path).unwrap();
    let rrd = Decoded::read(&path);
    let measurements: Vec<(String, String, Vec<String>)> =
        rrd.views_with_contents("TimeSeries").into_iter().filter(|(_, origin, _)| origin == "/measurements").collect();
    let view = |title: &str, signals: &[&str]| {
        let queries = signals.iter().map(|s| format!("/measurements/{s}")).collect();
        (title.to_string(), "/measurements".to_string(), queries)
    };
    assert_eq!(measurements, [view("measurements [m]", &["h"]), view("measurements [rad/s]", &["p", "q"])]);
    assert_eq!(rrd.series("measurements/h").1[1], [10_000.01], "each signal is still logged on its own");
    let (p, q) = (rrd.line_colors("measurements/p"), rrd.line_colors("measurements/q"));
    assert_eq!((p.len(), q.len()), (1, 1), "every measurement has its colour");
    assert_ne!(p, q, "two lines of one view are told apart by colour");
}

#[test]
fn writing_twice_gives_the_same_recording_chunks() {
    let (runs, comparison, first) = written("twice", 2000);
    let dir = temp("again");
    std::fs::create_dir_all(&dir).unwrap();
    let again = dir.join("twice.rrd");
    write_rrd(&comparison, runs, &again).unwrap();
    let second = Decoded::read(&again);
    assert_eq!(first.recording_ids, second.recording_ids);
    assert_eq!(first.recording.len(), second.recording.len());
    assert!(first.recording == second.recording, "same chunk ids, row ids and data");
}

#[test]
fn rerun_off_in_the_environment_is_an_error_not_a_missing_file() {
    let log = temp("off.mcap");
    write_run(&log, "A", 0.05, 2000);
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

/// 200 samples at 100 Hz of filter `filter`: truth `F = k`, its tolerance `F_tolerance`
/// (0.5 on the first half of every 8 samples, 0.25 on the second, times `scale`), and the
/// estimate `F` off by the errors `ERRORS` in turn (exact in binary, so that `≤` at the
/// edge is exact). The estimates also have an `F_tolerance`, which must not be compared.
fn write_tolerance_run(path: &Path, filter: &str, scale: f64) {
    const ERRORS: [f64; 8] = [0.0, 0.375, -0.625, 0.5, 0.125, -0.375, 0.25, -0.125];
    let metadata = BTreeMap::from([("filter".to_string(), filter.to_string())]);
    let mut w = LogWriter::create(path, &metadata).unwrap();
    let t = w
        .add_channel(
            TRUTH,
            &[SignalSpec::new("F", "N", "true load"), SignalSpec::new("F_tolerance", "N", "load accuracy required")],
        )
        .unwrap();
    let e = w
        .add_channel(
            ESTIMATE,
            &[SignalSpec::new("F", "N", "estimated load"), SignalSpec::new("F_tolerance", "N", "a namesake")],
        )
        .unwrap();
    for k in 0..200 {
        let time = k as f64 * 0.01;
        let tolerance = scale * if k % 8 < 4 { 0.5 } else { 0.25 };
        w.write(t, time, &[k as f64, tolerance]).unwrap();
        w.write(e, time, &[k as f64 + ERRORS[k % 8], 7.0]).unwrap();
    }
    w.finish().unwrap();
}

#[test]
fn a_tolerance_is_drawn_as_a_band_and_scored_not_compared() {
    let log = temp("tolerance.mcap");
    write_tolerance_run(&log, "A", 1.0);
    let runs: &'static [Run] = Vec::leak(vec![read_log(&log).unwrap()]);
    let comparison = compare_runs(runs, &Options::default()).unwrap();
    let pairs = &comparison.runs[0].pairs;
    assert_eq!(pairs.len(), 1, "F alone is compared, not F_tolerance");
    // Of every 8 errors, |0|, |0.375| ≤ 0.5, |−0.625| > 0.5, |0.5| ≤ 0.5 (the edge is in);
    // |0.125| ≤ 0.25, |−0.375| > 0.25, |0.25| ≤ 0.25, |−0.125| ≤ 0.25: 6 of 8.
    assert_eq!(pairs[0].in_tolerance, Some(0.75));
    let tolerance = pairs[0].tolerance.as_ref().unwrap();
    assert_eq!((tolerance.signal.as_str(), tolerance.description.as_str()), ("F_tolerance", "load accuracy required"));
    let table = comparison.table();
    assert!(table.contains("in tolerance: |estimate − truth| ≤ F_tolerance (load accuracy required)"), "{table}");
    let row = table.lines().find(|l| l.starts_with("A ")).unwrap();
    assert_eq!(row.split_whitespace().nth(8), Some("0.750"), "the in-tolerance column, after 2σ cov (—): {table}");
    let json = temp("tolerance.json");
    comparison.write_json(&json).unwrap();
    let value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(value["runs"][0]["pairs"][0]["in_tolerance"], 0.75);
    assert_eq!(value["runs"][0]["pairs"][0]["tolerance"]["signal"], "F_tolerance");

    let path = temp("tolerance.rrd");
    write_rrd(&comparison, runs, &path).unwrap();
    let rrd = Decoded::read(&path);
    // The band's two edges, one legend entry, after the runs' lines in both views.
    assert_eq!(rrd.line_names("errors/F"), ["A", "± F_tolerance", "± F_tolerance"]);
    assert_eq!(rrd.line_names("signals/F"), ["truth F", "A F", "truth ± F_tolerance", "truth ± F_tolerance"]);
    let tolerance: Vec<f64> = (0..200).map(|k| if k % 8 < 4 { 0.5 } else { 0.25 }).collect();
    assert_eq!(rrd.line("errors/F", 1), tolerance);
    assert_eq!(rrd.line("errors/F", 2), tolerance.iter().map(|v| -v).collect::<Vec<_>>());
    let truth: Vec<f64> = (0..200).map(f64::from).collect();
    let upper: Vec<f64> = truth.iter().zip(&tolerance).map(|(t, v)| t + v).collect();
    assert_eq!(rrd.line("signals/F", 2), upper);
    assert_eq!(rrd.line("signals/F", 3)[7], 7.0 - 0.25);
    assert!(rrd.recording.iter().all(|c| !c.entity_path().to_string().contains("F_tolerance")), "not a signal");
    let titles = rrd.view_names();
    assert!(titles.contains(&"F [N]: error (estimate − truth), tolerance ± F_tolerance".to_string()), "{titles:?}");
    let text = rrd.text("report");
    assert!(text.contains("| in tolerance | 0.750 |"), "{text}");
    assert!(text.contains("Tolerance `F_tolerance`: load accuracy required."), "{text}");
}

#[test]
fn runs_held_to_other_tolerances_are_refused_and_a_negative_tolerance_too() {
    let (tight, loose, negative) = (temp("tight.mcap"), temp("loose.mcap"), temp("negative.mcap"));
    write_tolerance_run(&tight, "A", 1.0);
    write_tolerance_run(&loose, "B", 2.0);
    write_tolerance_run(&negative, "C", -1.0);
    let runs = [read_log(&tight).unwrap(), read_log(&loose).unwrap()];
    let err = compare_runs(&runs, &Options::default()).unwrap_err().to_string();
    assert!(err.contains("the tolerance of truth F differs"), "{err}");
    let runs = [read_log(&negative).unwrap()];
    let err = compare_runs(&runs, &Options::default()).unwrap_err().to_string();
    assert!(err.contains("'F_tolerance' is negative (-0.5) at t = 0 s"), "{err}");
}
