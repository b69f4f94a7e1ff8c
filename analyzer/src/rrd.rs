//! The Rerun recording of a comparison (`analyzer report RUN.mcap… --rrd OUT.rrd`; one run
//! is a comparison of one), for the Rerun viewer 0.41.
//!
//! Entity paths (`<signal>` is the compared truth signal's name, or `X~Y` when `--pair` pairs
//! differently named signals; `<run>` is the run's label, its filter); each view's lines are
//! one entity, a scalar per line and row, named in the legend; series are on the `sim_time`
//! duration timeline:
//!
//! | path | what |
//! |---|---|
//! | `signals/<signal>` | the truth the runs share; each run's estimate; its ± 2σ band, where σ is logged (shown for the first run, the others' in the legend, to switch on); truth ± tolerance, where `/truth` has `<signal>_tolerance` (in the legend, to switch on) |
//! | `errors/<signal>` | each run's estimate − truth; ± tolerance, where `/truth` has `<signal>_tolerance` |
//! | `rmse/<signal>` | each run's running RMSE |
//! | `measurements/<signal>` | what the first run's estimator was fed; missing (NaN) samples left out; a view per unit |
//! | `psd/<signal>/loglog/truth`, `…/<run>` | Welch PSDs, log-log, static (see [`PSD_VIEW`]) |
//! | `report` | the metrics tables, the runs' metadata and parameters, markdown, static |
//!
//! The blueprint opens one tab per signal (truth and estimates with their bands; error and
//! running RMSE side by side; the spectra) beside the report and the measurements: one view,
//! or a grid of one view per unit where they have several.
//!
//! Series longer than [`MAX_ROWS`] samples are drawn as their min/max envelope (see
//! [`envelope_bucket`]), and the views say so: the viewer cannot show more points than it
//! has pixels, and the log keeps every sample.
//!
//! Reproducible: the recording id is the logs' file names, there is no wall-clock
//! `log_time` timeline, and the recording's chunk and row ids are counted rather than
//! drawn at random, so writing the same comparison twice gives the same recording chunks.
//! Only the blueprint (its own store, built by the SDK with random ids) differs.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use rerun::blueprint::components::PanelState;
use rerun::blueprint::{
    Blueprint, BlueprintPanel, ContainerLike, Grid, Horizontal, SelectionPanel, Spatial2DView, Tabs, TextDocumentView,
    TimePanel, TimeSeriesView, Vertical,
};
use rerun::log::{Chunk, ChunkId, RowId};
use rerun::time::TimePoint;
use rerun::{
    AsComponents, Color, EntityPath, EntityPathPart, LineStrips2D, MediaType, Points2D, Radius, RecordingInfo,
    RecordingStream, RecordingStreamBuilder, Scalars, SeriesLines, TextDocument, TimeColumn, Transform3D,
};

use crate::compare::{pair_name, Comparison, COLUMNS};
use crate::psd::Spectrum;
use crate::report::PairReport;
use log_format::read::{Run, Signal};
use log_format::write::{SignalSpec, MEASUREMENTS};
use log_format::LogError;

/// Application id of the recordings.
pub const APPLICATION_ID: &str = "kalfmu";
/// The timeline of every series: simulation time, a duration in seconds.
pub const TIMELINE: &str = "sim_time";
/// Rows per chunk of a series. The viewer's store compacts chunks up to 4096 rows
/// (`ChunkStoreConfig::DEFAULT`), so chunks of that size are what it would build itself,
/// and a 10⁷-sample series never sits in one huge Arrow array.
pub const ROWS_PER_CHUNK: usize = 4096;
/// The most rows a series gets. Longer ones are drawn as their min/max envelope: 50 000
/// rows keep every sample of 50 s at 1 kHz, and a 4K screen shows under 4 000 columns.
/// With this bound the recording of a long run is far smaller than its log.
pub const MAX_ROWS: usize = 50_000;
/// The most decades of power a PSD view shows below its highest: lower values are drawn at
/// that floor (and the view says so), so that a truth spectrum falling to 1e-17 does not
/// squash everything else into a few pixels.
pub const MAX_DECADES: f32 = 8.0;

/// How the PSD views show log-log, written here once because the viewer cannot.
///
/// Rerun 0.41 has no logarithmic axes: a `TimeSeriesView` plots against a timeline only
/// (linear, integer nanoseconds or sequence numbers) and `ScalarAxis` has no log scale.
/// So each spectrum is a 2D line strip through `(log10 f/Hz, log10 PSD/(unit²/Hz))` in a
/// `Spatial2DView`, framed, with grid lines at the decades labelled in plain numbers
/// (`0.1 Hz`, `1 Hz`, `10 Hz`; `1e-3`): the logged coordinates are the true logarithms (hover
/// shows them), and a static `Transform3D` on `psd/<signal>/loglog` scales the box to a 3:1
/// aspect, as wide as the view, and flips y, because 2D views point y down. The DC bin
/// (f = 0) and any bin with zero power have no logarithm and are left out; values more than
/// [`MAX_DECADES`] below the highest are drawn at that floor.
pub const PSD_VIEW: &str = "x = log10(f / Hz), y = log10(PSD / (unit²/Hz)); grid lines at decades; \
DC bin left out; at most 8 decades shown, lower values drawn at the floor; y is flipped for display so that power grows upward";

/// Time part of the counted row and chunk ids (a fixed instant instead of the wall clock).
const ID_TIME_NS: u128 = 1;
/// Plot box of the PSD views (scene units after the transform): 3:1, the shape of the view.
const PSD_WIDTH: f32 = 30.0;
const PSD_HEIGHT: f32 = 10.0;
/// Columns of the grid of measurement views when the measurements have several units.
const MEASUREMENT_COLUMNS: u32 = 2;

/// Writes the Rerun recording of `comparison` (and of the first run's measurements) to `path`;
/// `runs` are the runs compared, in the same order.
///
/// Fails, naming `path`, if the file cannot be written, or if the `RERUN` environment
/// variable is `off`/`0`/`false`. Under that variable the SDK's streams write nothing
/// and report success; the recording stream here is forced on, but the SDK builds the
/// blueprint through a stream of its own that still obeys the variable (and then panics
/// in 0.41.0: `Blueprint::send` expects the messages that stream did not write), so this
/// refuses with a clear error instead.
pub fn write_rrd(comparison: &Comparison, runs: &[Run], path: &Path) -> Result<(), LogError> {
    let fail = |what: String| LogError::Rrd { file: path.to_path_buf(), what };
    if !rerun::decide_logging_enabled(true) {
        return Err(fail(format!(
            "the RERUN environment variable ('{}') disables the Rerun SDK; unset it to write a recording",
            std::env::var("RERUN").unwrap_or_default()
        )));
    }
    let names: Vec<String> = runs
        .iter()
        .map(|r| r.file.file_name().map_or_else(|| r.file.display().to_string(), |n| n.to_string_lossy().into()))
        .collect();
    let recording_id = names.join(" + ");
    let rec = RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(recording_id.clone())
        // Explicitly on, so that RERUN=off cannot turn this stream into a no-op.
        .enabled(true)
        // The SDK would otherwise add a RecordingInfo stamped with the wall clock, and the
        // same logs would no longer give the same file; the recording's name is logged below.
        .send_properties(false)
        .save(path)
        .map_err(|e| fail(e.to_string()))?;
    send_blueprint(&rec, blueprint(comparison, runs), whole_run(comparison, runs)).map_err(fail)?;
    rec.set_log_time_enabled(false);
    rec.set_log_tick_enabled(false);
    let mut recording = Recording { rec, path, next_id: 0 };
    recording.static_row(EntityPath::properties(), &RecordingInfo::update_fields().with_name(recording_id))?;
    recording.static_row(
        EntityPath::from("report"),
        &TextDocument::new(markdown(comparison)).with_media_type(MediaType::markdown()),
    )?;
    for k in 0..comparison.runs.first().map_or(0, |r| r.pairs.len()) {
        let pairs: Vec<&PairReport> = comparison.runs.iter().map(|r| &r.pairs[k]).collect();
        recording.signal(&pairs, &comparison.labels)?;
    }
    if let Some(channel) = runs.first().and_then(|r| r.channel(MEASUREMENTS).ok()) {
        for (signal, color) in channel.signals.iter().zip(measurement_colors(&channel.signals)) {
            let entity = entity(&["measurements", &signal.spec.name]);
            let label = with_unit(&signal.spec.name, &signal.spec.unit);
            recording.style(&entity, &[Line::new(label, color, 1.0, true)])?;
            recording.series(&entity, &channel.time, &[&signal.values])?;
        }
    }
    let Recording { rec, .. } = recording;
    rec.flush_blocking().map_err(|e| fail(e.to_string()))?;
    // Dropping the last handle joins the writer thread, which writes the footer.
    drop(rec);
    match std::fs::metadata(path) {
        Ok(m) if m.len() > 0 => Ok(()),
        Ok(_) => Err(fail("the SDK wrote an empty file".into())),
        Err(e) => Err(fail(format!("the SDK wrote no file ({e})"))),
    }
}

/// The entity path of these parts (each escaped as needed, so `X~Y` is one part).
fn entity(parts: &[&str]) -> EntityPath {
    EntityPath::new(parts.iter().map(|p| EntityPathPart::new(*p)).collect())
}

fn with_unit(name: &str, unit: &str) -> String {
    if unit.is_empty() {
        name.to_string()
    } else {
        format!("{name} [{unit}]")
    }
}

/// Samples per bucket of the min/max envelope of an `n`-sample series (1: every sample).
pub fn envelope_bucket(n: usize) -> usize {
    if n <= MAX_ROWS {
        1
    } else {
        n.div_ceil(MAX_ROWS / 2)
    }
}

/// The view-title note for a series of `n` samples drawn as an envelope.
fn envelope_note(n: usize) -> String {
    match envelope_bucket(n) {
        1 => String::new(),
        b => format!(" — min/max of every {b} samples (the log has all)"),
    }
}

/// The look of one line of a series.
#[derive(Clone)]
struct Line {
    name: String,
    color: Color,
    width: f32,
    /// Drawn, or only listed in the legend (to switch on there).
    shown: bool,
}

impl Line {
    fn new(name: String, color: Color, width: f32, shown: bool) -> Self {
        Self { name, color, width, shown }
    }
}

/// The truth's colour: light grey, drawn under the runs.
fn truth_color() -> Color {
    Color::from_rgb(225, 225, 225)
}

/// Matplotlib's tab10 without its grey.
const PALETTE: [(u8, u8, u8); 9] = [
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (23, 190, 207),
    (227, 119, 194),
    (188, 189, 34),
    (140, 86, 75),
    (31, 119, 180),
];

/// Run `i`'s colour, from the start of the palette.
fn run_color(i: usize) -> Color {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    Color::from_rgb(r, g, b)
}

/// The measurements' colours, one per signal: within a view (the signals of one unit) each
/// line its own, from the end of the palette, so that they are not read as runs. The
/// viewer's own colour of an entity comes from a hash of its path and can give two lines of
/// one view the same hue.
fn measurement_colors(signals: &[Signal]) -> Vec<Color> {
    let groups = unit_groups(signals);
    signals
        .iter()
        .map(|signal| {
            let k = groups
                .iter()
                .find(|(unit, _)| *unit == signal.spec.unit)
                .and_then(|(_, names)| names.iter().position(|name| *name == signal.spec.name))
                .unwrap_or(0);
            let (r, g, b) = PALETTE[PALETTE.len() - 1 - k % PALETTE.len()];
            Color::from_rgb(r, g, b)
        })
        .collect()
}

fn band_color(i: usize) -> Color {
    let [r, g, b, _] = run_color(i).to_array();
    Color::from_unmultiplied_rgba(r, g, b, 120)
}

/// The tolerance's colour: gold, a hue no run has.
fn tolerance_color(alpha: u8) -> Color {
    Color::from_unmultiplied_rgba(255, 200, 0, alpha)
}

fn grid_color() -> Color {
    Color::from_unmultiplied_rgba(160, 160, 160, 140)
}

/// A recording being written, with the counter of its row and chunk ids.
struct Recording<'a> {
    rec: RecordingStream,
    path: &'a Path,
    next_id: u64,
}

impl Recording<'_> {
    fn fail(&self, what: impl std::fmt::Display) -> LogError {
        LogError::Rrd { file: self.path.to_path_buf(), what: what.to_string() }
    }

    /// The next id: a TUID with a fixed time and a counter, so ids are unique, increasing
    /// and the same on every run.
    fn next_id(&mut self) -> u128 {
        self.next_id += 1;
        (ID_TIME_NS << 64) | u128::from(self.next_id)
    }

    /// Sends one static row of `what` at `entity`.
    fn static_row(&mut self, entity: EntityPath, what: &dyn AsComponents) -> Result<(), LogError> {
        let chunk_id = ChunkId::from_u128(self.next_id());
        let row_id = RowId::from_u128(self.next_id());
        let chunk = Chunk::builder_with_id(chunk_id, entity)
            .with_archetype(row_id, TimePoint::default(), what)
            .build()
            .map_err(|e| self.fail(e))?;
        self.rec.send_chunk(chunk);
        Ok(())
    }

    /// Names, colours and widens the lines of the series at `entity` (one per scalar of a row),
    /// each shown or only in the legend.
    fn style(&mut self, entity: &EntityPath, lines: &[Line]) -> Result<(), LogError> {
        let style = SeriesLines::new()
            .with_names(lines.iter().map(|l| l.name.clone()))
            .with_colors(lines.iter().map(|l| l.color))
            .with_widths(lines.iter().map(|l| l.width))
            .with_visible_series(lines.iter().map(|l| l.shown));
        self.static_row(entity.clone(), &style)
    }

    /// Sends series at `entity` on the `sim_time` timeline, one row per time with a scalar of
    /// each column, in chunks of [`ROWS_PER_CHUNK`] rows; rows with a value that is not finite
    /// are left out. A long series goes as its min/max envelope: of every [`envelope_bucket`]
    /// rows, one of each column's smallest value at the bucket's first time and one of its
    /// largest at its last. Returns the number of rows sent.
    fn series(&mut self, entity: &EntityPath, time: &[f64], columns: &[&[f64]]) -> Result<usize, LogError> {
        let n = columns.iter().map(|c| c.len()).fold(time.len(), usize::min);
        let bucket = envelope_bucket(n);
        let mut times = Vec::with_capacity(ROWS_PER_CHUNK);
        let mut scalars = Vec::with_capacity(ROWS_PER_CHUNK * columns.len());
        let mut n_rows = 0;
        let mut k = 0;
        while k < n {
            let end = (k + bucket).min(n);
            if bucket == 1 {
                if columns.iter().all(|c| c[k].is_finite()) {
                    times.push(time[k]);
                    scalars.extend(columns.iter().map(|c| c[k]));
                }
            } else {
                let finite = |c: &[f64]| c[k..end].iter().copied().filter(|v| v.is_finite()).collect::<Vec<_>>();
                let extremes: Vec<(f64, f64)> = columns
                    .iter()
                    .map(|c| finite(c))
                    .filter(|v| !v.is_empty())
                    .map(|v| {
                        (
                            v.iter().copied().fold(f64::INFINITY, f64::min),
                            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                        )
                    })
                    .collect();
                if extremes.len() == columns.len() {
                    times.push(time[k]);
                    scalars.extend(extremes.iter().map(|e| e.0));
                    times.push(time[end - 1]);
                    scalars.extend(extremes.iter().map(|e| e.1));
                }
            }
            if times.len() >= ROWS_PER_CHUNK {
                n_rows += self.send_rows(entity, &times, &scalars)?;
                times.clear();
                scalars.clear();
            }
            k = end;
        }
        if !times.is_empty() {
            n_rows += self.send_rows(entity, &times, &scalars)?;
        }
        Ok(n_rows)
    }

    /// One chunk of series: the columnar equivalent of `send_columns`, with counted ids;
    /// `values` holds the rows one after the other, each of the same number of scalars.
    fn send_rows(&mut self, entity: &EntityPath, times: &[f64], values: &[f64]) -> Result<usize, LogError> {
        let width = values.len() / times.len().max(1);
        let chunk_id = ChunkId::from_u128(self.next_id());
        let row_ids: Vec<RowId> = times.iter().map(|_| RowId::from_u128(self.next_id())).collect();
        let time = TimeColumn::new_duration_secs(TIMELINE, times.iter().copied());
        let timelines = std::iter::once((*time.timeline().name(), time)).collect();
        let components = Scalars::new(values.iter().copied())
            .columns(std::iter::repeat_n(width, times.len()))
            .map_err(|e| self.fail(e))?
            .map(|column| (column.descriptor, column.list_array))
            .collect();
        let chunk = Chunk::from_native_row_ids(chunk_id, entity.clone(), Some(true), &row_ids, timelines, components)
            .map_err(|e| self.fail(e))?;
        self.rec.send_chunk(chunk);
        Ok(times.len())
    }

    /// Everything of one compared signal, each view's lines as one entity with a scalar per
    /// line and row: the truth and the runs' estimates and bands; their errors; their running
    /// RMSEs; and the spectra.
    fn signal(&mut self, pairs: &[&PairReport], labels: &[String]) -> Result<(), LogError> {
        let first = pairs[0];
        let name = pair_name(first);
        let runs = || pairs.iter().zip(labels).enumerate();
        let mut lines = vec![Line::new(format!("truth {}", first.truth), truth_color(), 2.0, true)];
        let mut columns: Vec<&[f64]> = vec![&first.truth_values];
        for (i, (p, label)) in runs() {
            lines.push(Line::new(format!("{label} {}", p.estimate), run_color(i), 1.0, true));
            columns.push(&p.estimate_values);
        }
        let bands: Vec<Vec<f64>> = runs()
            .filter_map(|(_, (p, _))| p.sigma.as_ref().map(|sigma| (p, sigma)))
            .flat_map(|(p, sigma)| {
                [1.0, -1.0]
                    .map(|sign| p.estimate_values.iter().zip(sigma.iter()).map(|(e, s)| e + sign * 2.0 * s).collect())
            })
            .collect();
        for (i, (_, label)) in runs().filter(|(_, (p, _))| p.sigma.is_some()) {
            // The first run's band is shown; the others' are in the legend, to switch on.
            // One name for both edges: the legend lists (and switches) them as one entry.
            lines.push(Line::new(format!("{label} ± 2σ"), band_color(i), 0.75, i == 0));
            lines.push(Line::new(format!("{label} ± 2σ"), band_color(i), 0.75, i == 0));
        }
        columns.extend(bands.iter().map(Vec::as_slice));
        // Runs that share their truth share its tolerance (`check_shared_truth`): the first's.
        let tolerance = first.tolerance.as_ref();
        // A band's two edges get one name: the legend lists (and switches) them as one entry.
        // Around the errors the band is the yardstick: opaque, wider than the runs, shown.
        // Around the truth it is usually a few per cent of the axis, so its edges would cover
        // the truth and the estimates: thin, translucent, and in the legend only, to switch
        // on when zoomed in.
        let tolerance_lines = |name: String, around_truth: bool| {
            let line = if around_truth {
                Line::new(name, tolerance_color(140), 1.0, false)
            } else {
                Line::new(name, tolerance_color(255), 2.0, true)
            };
            [line.clone(), line]
        };
        let truth_band = match tolerance {
            Some(t) => {
                lines.extend(tolerance_lines(format!("truth ± {}", t.signal), true));
                edges(&first.truth_values, &t.values)
            }
            None => Vec::new(),
        };
        columns.extend(truth_band.iter().map(Vec::as_slice));
        let signals = entity(&["signals", &name]);
        self.style(&signals, &lines)?;
        self.series(&signals, &first.time, &columns)?;

        let errors: Vec<Vec<f64>> = pairs
            .iter()
            .map(|p| p.estimate_values.iter().zip(p.truth_values.iter()).map(|(e, t)| e - t).collect())
            .collect();
        let run_lines: Vec<Line> =
            runs().map(|(i, (_, label))| Line::new(label.clone(), run_color(i), 1.0, true)).collect();
        let mut error_lines = run_lines.clone();
        let mut error_columns: Vec<&[f64]> = errors.iter().map(Vec::as_slice).collect();
        let error_band = match tolerance {
            Some(t) => {
                error_lines.extend(tolerance_lines(format!("± {}", t.signal), false));
                edges(&vec![0.0; t.values.len()], &t.values)
            }
            None => Vec::new(),
        };
        error_columns.extend(error_band.iter().map(Vec::as_slice));
        let errors_entity = entity(&["errors", &name]);
        self.style(&errors_entity, &error_lines)?;
        self.series(&errors_entity, &first.time, &error_columns)?;
        let rmse_entity = entity(&["rmse", &name]);
        self.style(&rmse_entity, &run_lines)?;
        self.series(&rmse_entity, &first.time, &pairs.iter().map(|p| p.running_rmse.as_slice()).collect::<Vec<_>>())?;
        self.spectra(&name, pairs, labels)
    }

    /// The spectra of a signal, log-log (see [`PSD_VIEW`]): the truth's and each run's, with
    /// their frame, decade grid and tick labels.
    fn spectra(&mut self, name: &str, pairs: &[&PairReport], labels: &[String]) -> Result<(), LogError> {
        let mut curves = vec![("truth".to_string(), log_log(&pairs[0].truth_spectrum), truth_color())];
        for (i, (p, label)) in pairs.iter().zip(labels).enumerate() {
            curves.push((label.clone(), log_log(&p.estimate_spectrum), run_color(i)));
        }
        let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) =
            (f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY);
        for &[x, y] in curves.iter().flat_map(|c| &c.1) {
            (x_lo, x_hi, y_lo, y_hi) = (x_lo.min(x), x_hi.max(x), y_lo.min(y), y_hi.max(y));
        }
        if x_lo > x_hi {
            return Ok(());
        }
        // Whole decades of power, at least one, at most MAX_DECADES.
        let y_hi = y_hi.ceil();
        let y_lo = y_lo.floor().clamp(y_hi - MAX_DECADES, y_hi - 1.0);
        let (width, height) = ((x_hi - x_lo).max(0.1), y_hi - y_lo);

        let loglog = entity(&["psd", name, "loglog"]);
        self.static_row(loglog.clone(), &Transform3D::from_scale([PSD_WIDTH / width, -PSD_HEIGHT / height, 1.0]))?;

        // The frame, vertical lines at the decades of f, horizontal ones at the decades of the
        // PSD, the frequencies under the frame and the powers left of it. The viewer hangs a
        // point's label under the point, so the powers' points are raised by about half a
        // label's height (a twentieth of the box at the usual sizes): each number sits level
        // with its grid line.
        let mut grid = vec![vec![[x_lo, y_lo], [x_hi, y_lo], [x_hi, y_hi], [x_lo, y_hi], [x_lo, y_lo]]];
        let mut positions = Vec::new();
        let mut labels = Vec::new();
        let below = y_lo - 0.04 * height;
        let decades: Vec<i32> = (x_lo.ceil() as i32..=x_hi.floor() as i32).collect();
        for &k in &decades {
            grid.push(vec![[k as f32, y_lo], [k as f32, y_hi]]);
            positions.push([k as f32, below]);
            labels.push(format!("{} Hz", decade(k)));
        }
        if decades.len() < 2 {
            for x in [x_lo, x_hi] {
                positions.push([x, below]);
                labels.push(format!("{:.3} Hz", 10f64.powf(f64::from(x))));
            }
        }
        for j in y_lo as i32..=y_hi as i32 {
            grid.push(vec![[x_lo, j as f32], [x_hi, j as f32]]);
            positions.push([x_lo - 0.05 * width, j as f32 + 0.05 * height]);
            labels.push(format!("1e{j}"));
        }
        self.static_row(
            entity(&["psd", name, "loglog", "grid"]),
            &LineStrips2D::new(grid).with_colors([grid_color()]).with_radii([Radius::new_ui_points(0.5)]),
        )?;
        self.static_row(
            entity(&["psd", name, "loglog", "ticks"]),
            &Points2D::new(positions)
                .with_labels(labels)
                .with_show_labels(true)
                .with_colors([grid_color()])
                .with_radii([Radius::new_ui_points(0.0)]),
        )?;
        for (label, points, color) in curves {
            if points.is_empty() {
                continue;
            }
            let clipped: Vec<[f32; 2]> = points.iter().map(|&[x, y]| [x, y.max(y_lo)]).collect();
            self.static_row(
                entity(&["psd", name, "loglog", &label]),
                &LineStrips2D::new([clipped]).with_colors([color]).with_radii([Radius::new_ui_points(1.0)]),
            )?;
        }
        Ok(())
    }
}

/// The edges `centre + half_width` and `centre − half_width` of a band.
fn edges(centre: &[f64], half_width: &[f64]) -> Vec<Vec<f64>> {
    [1.0, -1.0].iter().map(|sign| centre.iter().zip(half_width).map(|(c, h)| c + sign * h).collect()).collect()
}

/// 10^k as people write it: `0.01`, `0.1`, `1`, `10`, `1000`.
fn decade(k: i32) -> String {
    if k >= 0 {
        format!("{}", 10u64.pow(k.min(18) as u32))
    } else {
        format!("0.{}1", "0".repeat((-k - 1) as usize))
    }
}

/// `(log10 f, log10 PSD)` of the bins that have both logarithms (not DC, not zero power).
fn log_log(s: &Spectrum) -> Vec<[f32; 2]> {
    s.frequency
        .iter()
        .zip(&s.density)
        .skip(1)
        .filter(|(f, d)| **f > 0.0 && **d > 0.0 && d.is_finite())
        .map(|(f, d)| [f.log10() as f32, d.log10() as f32])
        .collect()
}

/// A markdown table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// The comparison as markdown: a metrics table per signal (best in bold), the runs'
/// metadata and parameters as a table (a column per run), the views.
fn markdown(comparison: &Comparison) -> String {
    let labels = &comparison.labels;
    let several = labels.len() > 1;
    let mut md = String::new();
    let title = if several { format!("{} runs compared", labels.len()) } else { "report".to_string() };
    let _ = writeln!(md, "# kalfmu {title}\n");
    let Some(first) = comparison.runs.first() else { return md };
    let _ = writeln!(
        md,
        "Running RMSE over {} s; Welch segments of {} samples; spectra agree within ±{} dB. {}\n",
        first.rmse_window,
        first.psd_segment,
        first.agreement_db,
        if several {
            "**Bold**: the best of the runs (1σ coverage: nearest 0.6827; 2σ coverage: nearest 0.9545; (e/σ)² mean: nearest 1 in ratio; PSD band: widest)."
        } else {
            ""
        }
    );
    for note in &comparison.notes {
        let _ = writeln!(md, "{note}\n");
    }
    for k in 0..first.pairs.len() {
        let pairs: Vec<&PairReport> = comparison.runs.iter().map(|r| &r.pairs[k]).collect();
        let p = pairs[0];
        let _ = writeln!(
            md,
            "## {}\n\n{} samples compared, t = {} to {} s{}.\n",
            cell(&with_unit(&pair_name(p), &p.unit)),
            p.samples,
            p.compared_from,
            p.time.last().copied().unwrap_or(0.0),
            envelope_note(p.time.len())
        );
        if let Some(t) = &p.tolerance {
            let _ = writeln!(
                md,
                "Tolerance `{}`: {}. *in tolerance*: the fraction of samples with |estimate − truth| within it.\n",
                cell(&t.signal),
                cell(&t.description)
            );
        }
        // A row per metric and a column per run: it fits the side panel.
        let _ = write!(md, "| metric |");
        for label in labels {
            let _ = write!(md, " {} |", cell(label));
        }
        let _ = writeln!(md, "\n|---|{}", "---:|".repeat(labels.len()));
        for column in COLUMNS.iter().filter(|c| c.shown(&pairs)) {
            let best = column.best(&pairs);
            let _ = write!(md, "| {} |", column.heading);
            for (i, pair) in pairs.iter().enumerate() {
                let text = (column.text)(pair);
                if several && best == Some(i) {
                    let _ = write!(md, " **{text}** |");
                } else {
                    let _ = write!(md, " {text} |");
                }
            }
            md.push('\n');
        }
        md.push('\n');
    }
    let _ = writeln!(md, "## Runs\n");
    let _ = write!(md, "| |");
    for label in labels {
        let _ = write!(md, " {} |", cell(label));
    }
    let _ = writeln!(md, "\n|---|{}", "---|".repeat(labels.len()));
    for (key, values) in metadata_rows(comparison) {
        let _ = write!(md, "| {} |", cell(&key));
        for v in values {
            let _ = write!(md, " {} |", cell(&v));
        }
        md.push('\n');
    }
    let tolerances = if first.pairs.iter().any(|p| p.tolerance.is_some()) {
        "- Where the truth has `<signal>_tolerance`, an accuracy requirement: gold lines at ± it in \
         `errors/<signal>`, and at truth ± it in `signals/<signal>` (in the legend, to switch on).\n"
    } else {
        ""
    };
    let _ = writeln!(
        md,
        "\n## Views\n\n- `signals/<signal>`: the truth and each run's estimate with its ± 2σ band (the first run's \
         shown; click a legend entry to show or hide a line), on `{TIMELINE}` (s).\n\
         - `errors/<signal>`, `rmse/<signal>`: each run's estimate − truth and its running RMSE.\n\
         {tolerances}- `psd/<signal>/loglog`: Welch PSDs, {PSD_VIEW}.\n\
         - `measurements/<signal>`: the first run's estimator inputs, a view per unit; missing samples are left out.\n\
         - Series longer than {MAX_ROWS} samples are drawn as their min/max envelope: of every few samples, \
         the smallest and the largest at their own times (the view's title says how many); the log has them all.\n"
    );
    let _ = writeln!(
        md,
        "Written by analyzer {} with the Rerun SDK {}.",
        env!("CARGO_PKG_VERSION"),
        rerun::external::re_build_info::CrateVersion::LOCAL
    );
    md
}

/// The rows of the runs' table: the log file, each metadata key, and each parameter of the
/// `parameters` JSON object on a row of its own; one value per run (empty where absent).
fn metadata_rows(comparison: &Comparison) -> Vec<(String, Vec<String>)> {
    let runs = &comparison.runs;
    let mut rows = vec![("log".to_string(), runs.iter().map(|r| r.file.clone()).collect())];
    let mut keys: Vec<&String> = runs.iter().flat_map(|r| r.metadata.keys()).collect();
    keys.sort();
    keys.dedup();
    let parameters: Vec<BTreeMap<String, String>> = runs
        .iter()
        .map(|r| {
            let object = r.metadata.get("parameters").and_then(|p| serde_json::from_str::<serde_json::Value>(p).ok());
            match object {
                Some(serde_json::Value::Object(map)) => map
                    .into_iter()
                    .map(|(k, v)| (k, v.as_str().map_or_else(|| v.to_string(), str::to_string)))
                    .collect(),
                _ => BTreeMap::new(),
            }
        })
        .collect();
    for key in keys {
        let expanded = key == "parameters" && parameters.iter().any(|p| !p.is_empty());
        if !expanded {
            rows.push((key.clone(), runs.iter().map(|r| r.metadata.get(key).cloned().unwrap_or_default()).collect()));
        }
    }
    let mut names: Vec<&String> = parameters.iter().flat_map(|p| p.keys()).collect();
    names.sort();
    names.dedup();
    for name in names {
        rows.push((
            format!("parameter `{name}`"),
            parameters.iter().map(|p| p.get(name).cloned().unwrap_or_default()).collect(),
        ));
    }
    rows
}

/// How many times the largest RMSE the truth's range must be for its tab to open on
/// the errors: at 1000 the error is under a pixel of a values view.
pub const DWARFED: f64 = 1000.0;

/// Whether the range of `pair`'s truth is more than [`DWARFED`] times every run's RMSE
/// of it (`pairs`: the same signal in each run).
fn dwarfs_its_error<'a>(pair: &PairReport<'_>, pairs: impl Iterator<Item = &'a PairReport<'a>>) -> bool {
    let (low, high) = pair.truth_values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
        if v.is_finite() {
            (a.min(v), b.max(v))
        } else {
            (a, b)
        }
    });
    let error = pairs.map(|p| p.metrics.rmse).fold(0.0_f64, f64::max);
    high - low > DWARFED * error && error > 0.0
}

/// The span of the run in the recording's timeline (ns): the first and last time of the
/// compared series and the measurements.
fn whole_run(comparison: &Comparison, runs: &[Run]) -> (i64, i64) {
    let pairs = comparison.runs.iter().flat_map(|r| &r.pairs).map(|p| &*p.time);
    let measured = runs.iter().filter_map(|r| r.channel(MEASUREMENTS).ok()).map(|c| c.time.as_slice());
    let (first, last) = pairs.chain(measured).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
        (a.min(t.first().copied().unwrap_or(a)), b.max(t.last().copied().unwrap_or(b)))
    });
    if first <= last {
        (nanoseconds(first), nanoseconds(last))
    } else {
        (0, 0)
    }
}

/// Sends `blueprint` to `rec` with two properties on every view:
/// - the time axis on `span` (ns), so that the views open on the whole run: the viewer's
///   default is the 60 s around the time cursor, half of it empty at the start of a long run;
/// - the tooltip listing every visible series at the hovered time, so that hovering a plot
///   compares the truth and each filter at one instant (the default shows the nearest point
///   of one series).
///
/// The SDK's Rust blueprint API (0.41) has no setter for a view's properties, so the
/// blueprint the SDK builds is captured, and the properties (`view/<id>/TimeAxis`,
/// `view/<id>/PlotInteraction`, as the Python API logs them) are added to its store before it
/// is sent. Views that plot no time series ignore them.
fn send_blueprint(rec: &RecordingStream, blueprint: Blueprint, span: (i64, i64)) -> Result<(), String> {
    use rerun::blueprint::BlueprintActivation;
    use rerun::external::re_sdk_types::blueprint::archetypes::{PlotInteraction, TimeAxis};
    use rerun::external::re_sdk_types::blueprint::components::{TimeRange, TooltipMode};
    use rerun::external::re_sdk_types::encodings::{TimeInt, TimeRange as Range, TimeRangeBoundary};
    use rerun::log::LogMsg;

    let (capture, captured) =
        RecordingStreamBuilder::new(APPLICATION_ID).enabled(true).memory().map_err(|e| e.to_string())?;
    blueprint
        .send(&capture, BlueprintActivation { make_active: true, make_default: true })
        .map_err(|e| e.to_string())?;
    capture.flush_blocking().map_err(|e| e.to_string())?;
    let (mut messages, mut activation, mut store, mut views) = (Vec::new(), None, None, Vec::new());
    for message in captured.take() {
        match message {
            LogMsg::BlueprintActivationCommand(command) => activation = Some(command),
            LogMsg::SetStoreInfo(ref info) if info.info.store_id.is_blueprint() => {
                store = Some(info.info.store_id.clone());
                messages.push(message);
            }
            LogMsg::ArrowMsg(ref id, ref arrow) if id.is_blueprint() => {
                let chunk = Chunk::from_arrow_msg(arrow).map_err(|e| e.to_string())?;
                // A view's own entity, `view/<id>` (its properties are below it).
                let path = chunk.entity_path();
                if path.len() == 2 && path.iter().next().is_some_and(|part| part.unescaped_str() == "view") {
                    views.push(path.clone());
                }
                messages.push(message);
            }
            _ => {}
        }
    }
    let (Some(activation), Some(store)) = (activation, store) else {
        return Err("the SDK sent no blueprint".into());
    };
    let (properties, written) = RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(store.recording_id().clone())
        .enabled(true)
        .blueprint()
        .memory()
        .map_err(|e| e.to_string())?;
    properties.set_time_sequence("blueprint", 0);
    let range = TimeRange(Range {
        start: TimeRangeBoundary::Absolute(TimeInt(span.0)),
        end: TimeRangeBoundary::Absolute(TimeInt(span.1)),
    });
    views.sort();
    views.dedup();
    for view in &views {
        properties
            .log(format!("{view}/TimeAxis"), &TimeAxis::new().with_view_range(range))
            .map_err(|e| e.to_string())?;
        properties
            .log(format!("{view}/PlotInteraction"), &PlotInteraction::new().with_tooltip_mode(TooltipMode::All))
            .map_err(|e| e.to_string())?;
    }
    properties.flush_blocking().map_err(|e| e.to_string())?;
    messages.extend(written.take().into_iter().filter(|m| matches!(m, LogMsg::ArrowMsg(..))));
    rec.send_blueprint(messages, activation);
    Ok(())
}

/// One tab per signal (the signals with their bands; error and running RMSE side by side;
/// the spectra), beside the report and the measurements (a view per unit).
fn blueprint(comparison: &Comparison, runs: &[Run]) -> Blueprint {
    let first = comparison.runs.first();
    let window = first.map_or(0.0, |r| r.rmse_window);
    let tabs: Vec<ContainerLike> = first
        .map(|r| r.pairs.as_slice())
        .unwrap_or_default()
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let dwarfed = dwarfs_its_error(p, comparison.runs.iter().map(|r| &r.pairs[k]));
            let name = pair_name(p);
            let titled = with_unit(&name, &p.unit);
            let note = envelope_note(p.time.len());
            let bands = if p.sigma.is_some() { " ± 2σ" } else { "" };
            let tolerance = p.tolerance.as_ref().map_or(String::new(), |t| format!(", tolerance ± {}", t.signal));
            let psd_unit = if p.unit.is_empty() { "1/Hz".to_string() } else { format!("{}²/Hz", p.unit) };
            let values: ContainerLike = TimeSeriesView::new(format!("{titled}: truth and estimates{bands}{note}"))
                .with_origin(entity(&["signals", &name]))
                .into();
            let errors: ContainerLike = Horizontal::new([
                TimeSeriesView::new(format!("{titled}: error (estimate − truth){tolerance}{note}"))
                    .with_origin(entity(&["errors", &name]))
                    .into(),
                TimeSeriesView::new(format!("{titled}: running RMSE over {window} s{note}"))
                    .with_origin(entity(&["rmse", &name]))
                    .into(),
            ])
            .into();
            let spectra: ContainerLike = Spatial2DView::new(format!(
                "{name}: PSD [{psd_unit}] against frequency [Hz], log-log, {MAX_DECADES} decades at most"
            ))
            .with_origin(entity(&["psd", &name]))
            .into();
            // Where the truth's range dwarfs the error (a position over a run, an altitude)
            // the values are one line at any scale: the tab opens on the errors.
            let (rows, shares) = if dwarfed {
                ([errors, values, spectra], [2.0, 1.3, 1.7])
            } else {
                ([values, errors, spectra], [2.0, 1.3, 1.7])
            };
            Vertical::new(rows).with_name(name).with_row_shares(shares).into()
        })
        .collect();
    let mut side: Vec<ContainerLike> = vec![TextDocumentView::new("report").with_origin("report").into()];
    let mut shares = vec![3.0];
    if let Some((first_run, channel)) = runs.first().and_then(|r| r.channel(MEASUREMENTS).ok().map(|c| (r, c))) {
        let source = match comparison.labels.first() {
            Some(label) if runs.len() > 1 => format!(" (as fed to {label}; {})", first_run.file.display()),
            _ => String::new(),
        };
        match <[TimeSeriesView; 1]>::try_from(channel_views("measurements", &source, &channel.signals)) {
            Ok([view]) => {
                side.push(view.into());
                shares.push(2.0);
            }
            Err(views) => {
                // Two views a row, each row as tall as the one view of a single-unit channel,
                // so that each keeps room for its axis and legend.
                let rows = views.len().div_ceil(MEASUREMENT_COLUMNS as usize);
                side.push(Grid::new(views.into_iter().map(Into::into)).with_grid_columns(MEASUREMENT_COLUMNS).into());
                shares.push(2.0 * rows as f32);
            }
        }
    }
    let side = Vertical::new(side).with_row_shares(shares);
    let root = Horizontal::new([Tabs::new(tabs).into(), side.into()]).with_column_shares([3.0, 2.0]);
    // The side panels start collapsed: the views get the window.
    Blueprint::new(root)
        .with_auto_views(false)
        .with_auto_layout(false)
        .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
        .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed))
        .with_time_panel(TimePanel::new().with_timeline(TIMELINE).with_state(PanelState::Collapsed))
}

/// The time-series views of a channel whose signals are logged at `<origin>/<signal>`: one
/// of the whole channel if its signals share a unit, else one per unit (titled
/// `<origin> [<unit>]`, the units in the order the schema first names them), because one
/// axis for all lets the largest unit flatten the others (a missile's altitude of 10 km its
/// rates of a few rad/s). `note` ends every title.
fn channel_views(origin: &str, note: &str, signals: &[Signal]) -> Vec<TimeSeriesView> {
    let groups = unit_groups(signals);
    if groups.len() <= 1 {
        return vec![TimeSeriesView::new(format!("{origin}{note}")).with_origin(origin)];
    }
    groups
        .iter()
        .map(|(unit, names)| {
            let unit = if unit.is_empty() { "no unit" } else { unit };
            TimeSeriesView::new(format!("{origin} [{unit}]{note}"))
                .with_origin(origin)
                .with_contents(names.iter().map(|name| entity(&[origin, name]).to_string()))
        })
        .collect()
}

/// The names of `signals` by unit, the units in the order of their first signal.
fn unit_groups(signals: &[Signal]) -> Vec<(&str, Vec<&str>)> {
    let mut groups: Vec<(&str, Vec<&str>)> = Vec::new();
    for SignalSpec { name, unit, .. } in signals.iter().map(|s| &s.spec) {
        match groups.iter_mut().find(|(u, _)| u == unit) {
            Some((_, names)) => names.push(name),
            None => groups.push((unit, vec![name])),
        }
    }
    groups
}

/// A time of the recording's timeline, seconds → its integer nanoseconds.
fn nanoseconds(seconds: f64) -> i64 {
    (seconds * 1e9).round() as i64
}
