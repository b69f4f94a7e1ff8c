//! The Rerun recording of a report (`analyzer report RUN.mcap --rrd OUT.rrd`), for
//! the Rerun viewer 0.36.
//!
//! Entity paths (`<pair>` is the truth signal's name, or `X~Y` when `--pair` pairs
//! differently named signals); series are on the `sim_time` duration timeline:
//!
//! | path | what |
//! |---|---|
//! | `signals/<pair>/truth`, `…/estimate` | the compared samples |
//! | `signals/<pair>/plus_2sigma`, `…/minus_2sigma` | estimate ± 2σ, where σ is logged |
//! | `errors/<pair>/error`, `…/running_rmse` | estimate − truth, and its running RMSE |
//! | `measurements/<signal>` | what the estimator was fed; missing (NaN) samples left out |
//! | `psd/<pair>/loglog/truth`, `…/estimate` | Welch PSDs, log-log, static (see [`PSD_VIEW`]) |
//! | `report` | metrics table and metadata, markdown, static |
//!
//! The blueprint opens one tab per pair (truth/estimate/band, error/running RMSE,
//! PSD) beside the report and the measurements.
//!
//! Reproducible: the recording id is the log's file name, there is no wall-clock
//! `log_time` timeline, and the recording's chunk and row ids are counted rather than
//! drawn at random, so writing the same report twice gives the same recording chunks.
//! Only the blueprint (its own store, built by the SDK with random ids) differs.

use std::fmt::Write as _;
use std::path::Path;

use rerun::blueprint::{
    Blueprint, ContainerLike, Horizontal, Spatial2DView, Tabs, TextDocumentView, TimePanel, TimeSeriesView, Vertical,
};
use rerun::log::{Chunk, ChunkId, RowId};
use rerun::time::TimePoint;
use rerun::{
    AsComponents, Color, EntityPath, EntityPathPart, LineStrips2D, MediaType, Points2D, Radius, RecordingInfo,
    RecordingStream, RecordingStreamBuilder, Scalars, SeriesLines, TextDocument, TimeColumn, Transform3D,
};

use crate::error::LogError;
use crate::log::MEASUREMENTS;
use crate::psd::Spectrum;
use crate::read::Run;
use crate::report::{PairReport, Report};

/// Application id of the recordings.
pub const APPLICATION_ID: &str = "kalfmu";
/// The timeline of every series: simulation time, a duration in seconds.
pub const TIMELINE: &str = "sim_time";
/// Rows per chunk of a series. The viewer's store compacts chunks up to 4096 rows
/// (`ChunkStoreConfig::DEFAULT`), so chunks of that size are what it would build itself,
/// and a 10⁷-sample series never sits in one huge Arrow array.
pub const ROWS_PER_CHUNK: usize = 4096;

/// How the PSD views show log-log, written here once because the viewer cannot.
///
/// Rerun 0.36 has no logarithmic axes: a `TimeSeriesView` plots against a timeline only
/// (linear, integer nanoseconds or sequence numbers) and `ScalarAxis` has no log scale.
/// So each spectrum is a 2D line strip through `(log10 f/Hz, log10 PSD/(unit²/Hz))` in a
/// `Spatial2DView`, with decade grid lines labelled `1e<k>`: the logged coordinates are the
/// true logarithms (hover shows them), and a static `Transform3D` on `psd/<pair>/loglog`
/// scales the box to a 16:10 aspect and flips y, because 2D views point y down.
/// The DC bin (f = 0) and any bin with zero power have no logarithm and are left out.
pub const PSD_VIEW: &str = "x = log10(f / Hz), y = log10(PSD / (unit²/Hz)); grid lines at decades; \
DC bin left out; y is flipped for display so that power grows upward";

/// Time part of the counted row and chunk ids (a fixed instant instead of the wall clock).
const ID_TIME_NS: u128 = 1;
/// Plot box of the PSD views (scene units after the transform).
const PSD_WIDTH: f32 = 16.0;
const PSD_HEIGHT: f32 = 10.0;

/// Writes the Rerun recording of `report` (and of `run`'s measurements) to `path`.
///
/// Fails, naming `path`, if the file cannot be written, or if the `RERUN` environment
/// variable is `off`/`0`/`false`. Under that variable the SDK's streams write nothing
/// and report success; the recording stream here is forced on, but the SDK builds the
/// blueprint through a stream of its own that still obeys the variable (and then panics
/// in 0.36.3), so this refuses with a clear error instead.
pub fn write_rrd(report: &Report, run: &Run, path: &Path) -> Result<(), LogError> {
    let fail = |what: String| LogError::Rrd { file: path.to_path_buf(), what };
    if !rerun::decide_logging_enabled(true) {
        return Err(fail(format!(
            "the RERUN environment variable ('{}') disables the Rerun SDK; unset it to write a recording",
            std::env::var("RERUN").unwrap_or_default()
        )));
    }
    let log_name = run.file.file_name().map_or_else(|| run.file.display().to_string(), |n| n.to_string_lossy().into());
    let rec = RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(log_name.clone())
        // Explicitly on, so that RERUN=off cannot turn this stream into a no-op.
        .enabled(true)
        .with_blueprint(blueprint(report, run))
        .save(path)
        .map_err(|e| fail(e.to_string()))?;
    rec.set_log_time_enabled(false);
    rec.set_log_tick_enabled(false);
    let mut recording = Recording { rec, path, next_id: 0 };
    recording.static_row(EntityPath::properties(), &RecordingInfo::update_fields().with_name(log_name))?;
    recording.static_row(
        EntityPath::from("report"),
        &TextDocument::new(markdown(report)).with_media_type(MediaType::markdown()),
    )?;
    for pair in &report.pairs {
        recording.pair(pair)?;
    }
    if let Ok(channel) = run.channel(MEASUREMENTS) {
        for signal in &channel.signals {
            let entity = entity(&["measurements", &signal.spec.name]);
            let label = with_unit(&signal.spec.name, &signal.spec.unit);
            recording.style(&entity, &label, None, 1.0)?;
            recording.series(&entity, &channel.time, signal.values.iter().copied())?;
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

/// The name of a pair in entity paths and views.
fn pair_name(p: &PairReport) -> String {
    if p.truth == p.estimate {
        p.truth.clone()
    } else {
        format!("{}~{}", p.truth, p.estimate)
    }
}

fn with_unit(name: &str, unit: &str) -> String {
    if unit.is_empty() {
        name.to_string()
    } else {
        format!("{name} [{unit}]")
    }
}

fn truth_color() -> Color {
    Color::from_rgb(31, 119, 180)
}

fn estimate_color() -> Color {
    Color::from_rgb(255, 127, 14)
}

fn band_color() -> Color {
    Color::from_unmultiplied_rgba(255, 127, 14, 110)
}

fn error_color() -> Color {
    Color::from_rgb(214, 39, 40)
}

fn rmse_color() -> Color {
    Color::from_rgb(148, 103, 189)
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

    /// Names, colours and widens the line of the series at `entity`.
    fn style(&mut self, entity: &EntityPath, name: &str, color: Option<Color>, width: f32) -> Result<(), LogError> {
        let mut lines = SeriesLines::new().with_names([name]).with_widths([width]);
        if let Some(color) = color {
            lines = lines.with_colors([color]);
        }
        self.static_row(entity.clone(), &lines)
    }

    /// Sends a series on the `sim_time` timeline in chunks of [`ROWS_PER_CHUNK`] rows,
    /// leaving out samples that are not finite. Returns the number of rows sent.
    fn series(
        &mut self,
        entity: &EntityPath,
        time: &[f64],
        values: impl IntoIterator<Item = f64>,
    ) -> Result<usize, LogError> {
        let mut times = Vec::with_capacity(ROWS_PER_CHUNK);
        let mut scalars = Vec::with_capacity(ROWS_PER_CHUNK);
        let mut n_rows = 0;
        for (&t, v) in time.iter().zip(values) {
            if !v.is_finite() {
                continue;
            }
            times.push(t);
            scalars.push(v);
            if times.len() == ROWS_PER_CHUNK {
                n_rows += self.send_rows(entity, &times, &scalars)?;
                times.clear();
                scalars.clear();
            }
        }
        if !times.is_empty() {
            n_rows += self.send_rows(entity, &times, &scalars)?;
        }
        Ok(n_rows)
    }

    /// One chunk of a series: the columnar equivalent of `send_columns`, with counted ids.
    fn send_rows(&mut self, entity: &EntityPath, times: &[f64], values: &[f64]) -> Result<usize, LogError> {
        let chunk_id = ChunkId::from_u128(self.next_id());
        let row_ids: Vec<RowId> = times.iter().map(|_| RowId::from_u128(self.next_id())).collect();
        let time = TimeColumn::new_duration_secs(TIMELINE, times.iter().copied());
        let timelines = std::iter::once((*time.timeline().name(), time)).collect();
        let components = Scalars::new(values.iter().copied())
            .columns_of_unit_batches()
            .map_err(|e| self.fail(e))?
            .map(|column| (column.descriptor, column.list_array))
            .collect();
        let chunk = Chunk::from_native_row_ids(chunk_id, entity.clone(), Some(true), &row_ids, timelines, components)
            .map_err(|e| self.fail(e))?;
        self.rec.send_chunk(chunk);
        Ok(times.len())
    }

    /// Everything of one pair: signals, band, error, running RMSE, spectra.
    fn pair(&mut self, p: &PairReport) -> Result<(), LogError> {
        let name = pair_name(p);
        let signals = |leaf: &str| entity(&["signals", &name, leaf]);
        let errors = |leaf: &str| entity(&["errors", &name, leaf]);
        let unit = |s: &str| with_unit(s, &p.unit);

        let truth = signals("truth");
        self.style(&truth, &unit(&format!("truth {}", p.truth)), Some(truth_color()), 1.5)?;
        self.series(&truth, &p.time, p.truth_values.iter().copied())?;
        let estimate = signals("estimate");
        self.style(&estimate, &unit(&format!("estimate {}", p.estimate)), Some(estimate_color()), 1.0)?;
        self.series(&estimate, &p.time, p.estimate_values.iter().copied())?;
        if let Some(sigma) = &p.sigma {
            let plus = signals("plus_2sigma");
            self.style(&plus, &unit("estimate + 2σ"), Some(band_color()), 0.75)?;
            self.series(&plus, &p.time, p.estimate_values.iter().zip(sigma.iter()).map(|(e, s)| e + 2.0 * s))?;
            let minus = signals("minus_2sigma");
            self.style(&minus, &unit("estimate − 2σ"), Some(band_color()), 0.75)?;
            self.series(&minus, &p.time, p.estimate_values.iter().zip(sigma.iter()).map(|(e, s)| e - 2.0 * s))?;
        }

        let error = errors("error");
        self.style(&error, &unit("error (estimate − truth)"), Some(error_color()), 1.0)?;
        self.series(&error, &p.time, p.estimate_values.iter().zip(p.truth_values.iter()).map(|(e, t)| e - t))?;
        let rmse = errors("running_rmse");
        self.style(&rmse, &unit("running RMSE"), Some(rmse_color()), 1.5)?;
        self.series(&rmse, &p.time, p.running_rmse.iter().copied())?;

        self.spectra(&name, p)
    }

    /// The two spectra of a pair, log-log (see [`PSD_VIEW`]), with their decade grid.
    fn spectra(&mut self, name: &str, p: &PairReport) -> Result<(), LogError> {
        let truth = log_log(&p.truth_spectrum);
        let estimate = log_log(&p.estimate_spectrum);
        let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) =
            (f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY);
        for &[x, y] in truth.iter().chain(&estimate) {
            (x_lo, x_hi, y_lo, y_hi) = (x_lo.min(x), x_hi.max(x), y_lo.min(y), y_hi.max(y));
        }
        if x_lo > x_hi {
            return Ok(());
        }
        // Whole decades of power, at least one.
        let y_lo = y_lo.floor();
        let y_hi = y_hi.ceil().max(y_lo + 1.0);

        let loglog = entity(&["psd", name, "loglog"]);
        let scale = [PSD_WIDTH / (x_hi - x_lo).max(0.1), -PSD_HEIGHT / (y_hi - y_lo), 1.0];
        self.static_row(loglog.clone(), &Transform3D::from_scale(scale))?;

        // The frame, vertical lines at the decades of f, horizontal ones at the decades of the PSD.
        let mut grid = vec![vec![[x_lo, y_lo], [x_hi, y_lo], [x_hi, y_hi], [x_lo, y_hi], [x_lo, y_lo]]];
        let mut positions = Vec::new();
        let mut labels = Vec::new();
        let decades: Vec<i32> = (x_lo.ceil() as i32..=x_hi.floor() as i32).collect();
        for &k in &decades {
            grid.push(vec![[k as f32, y_lo], [k as f32, y_hi]]);
            positions.push([k as f32, y_lo]);
            labels.push(format!("1e{k} Hz"));
        }
        if decades.len() < 2 {
            for x in [x_lo, x_hi] {
                positions.push([x, y_lo]);
                labels.push(format!("{:.3e} Hz", 10f64.powf(f64::from(x))));
            }
        }
        let psd_unit = if p.unit.is_empty() { "1/Hz".to_string() } else { format!("{}²/Hz", p.unit) };
        let n_decades = (y_hi - y_lo) as i32;
        let step = (n_decades / 12).max(1);
        for j in (y_lo as i32..=y_hi as i32).step_by(step as usize) {
            grid.push(vec![[x_lo, j as f32], [x_hi, j as f32]]);
            positions.push([x_lo, j as f32]);
            labels.push(format!("1e{j} {psd_unit}"));
        }
        self.static_row(
            loglog.clone(),
            &LineStrips2D::new(grid).with_colors([grid_color()]).with_radii([Radius::new_ui_points(0.5)]),
        )?;
        self.static_row(
            entity(&["psd", name, "loglog", "axes"]),
            &Points2D::new(positions)
                .with_labels(labels)
                .with_show_labels(true)
                .with_colors([grid_color()])
                .with_radii([Radius::new_ui_points(1.0)]),
        )?;
        for (leaf, points, color) in [("truth", truth, truth_color()), ("estimate", estimate, estimate_color())] {
            if points.is_empty() {
                continue;
            }
            self.static_row(
                entity(&["psd", name, "loglog", leaf]),
                &LineStrips2D::new([points])
                    .with_colors([color])
                    .with_radii([Radius::new_ui_points(1.0)])
                    .with_labels([leaf]),
            )?;
        }
        Ok(())
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

/// The report as markdown: the metrics table, the settings, the metadata, the views.
fn markdown(report: &Report) -> String {
    let cell = |s: &str| s.replace('|', "\\|").replace('\n', " ");
    let mut md = String::new();
    let _ = writeln!(md, "# kalfmu report: {}\n", cell(&report.file));
    let _ = writeln!(md, "## Metrics\n\n```text\n{}```\n", report.table());
    let _ = writeln!(
        md,
        "Running RMSE over {} s; Welch segments of {} samples; spectra agree within ±{} dB.\n",
        report.rmse_window, report.psd_segment, report.agreement_db
    );
    let _ = writeln!(md, "## Metadata\n\n| key | value |\n|---|---|");
    for (k, v) in &report.metadata {
        let _ = writeln!(md, "| {} | {} |", cell(k), cell(v));
    }
    let _ = writeln!(
        md,
        "\n## Views\n\n- `signals/<pair>`: truth, estimate and estimate ± 2σ, on `{TIMELINE}` (s).\n\
         - `errors/<pair>`: estimate − truth and its running RMSE.\n\
         - `psd/<pair>/loglog`: Welch PSDs, {PSD_VIEW}.\n\
         - `measurements/<signal>`: the estimator's inputs; missing samples are left out.\n"
    );
    let _ = writeln!(
        md,
        "Written by analyzer {} with the Rerun SDK {}.",
        env!("CARGO_PKG_VERSION"),
        rerun::build_info().version
    );
    md
}

/// One tab per pair (signals, errors, PSD), beside the report and the measurements.
fn blueprint(report: &Report, run: &Run) -> Blueprint {
    let tabs: Vec<ContainerLike> = report
        .pairs
        .iter()
        .map(|p| {
            let name = pair_name(p);
            let signals = if p.sigma.is_some() { "truth, estimate ± 2σ" } else { "truth, estimate" };
            Vertical::new([
                TimeSeriesView::new(format!("{}: {signals}", with_unit(&name, &p.unit)))
                    .with_origin(entity(&["signals", &name]))
                    .into(),
                TimeSeriesView::new(format!("{}: error, running RMSE", with_unit(&name, &p.unit)))
                    .with_origin(entity(&["errors", &name]))
                    .into(),
                Spatial2DView::new(format!("{name}: PSD truth vs estimate (log-log)"))
                    .with_origin(entity(&["psd", &name]))
                    .into(),
            ])
            .with_name(name)
            .with_row_shares([2.0, 1.0, 1.5])
            .into()
        })
        .collect();
    let mut side: Vec<ContainerLike> = vec![TextDocumentView::new("report").with_origin("report").into()];
    if run.channel(MEASUREMENTS).is_ok() {
        side.push(TimeSeriesView::new("measurements").with_origin("measurements").into());
    }
    let root = Horizontal::new([Tabs::new(tabs).into(), Vertical::new(side).into()]).with_column_shares([3.0, 2.0]);
    Blueprint::new(root)
        .with_auto_views(false)
        .with_auto_layout(false)
        .with_time_panel(TimePanel::new().with_timeline(TIMELINE))
}
