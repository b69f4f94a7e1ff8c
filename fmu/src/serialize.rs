//! The serialised FMU state: a versioned, pointer-free byte string that a
//! fresh instance — in this process or another — restores bit-exactly.
//!
//! ```text
//! "KALFMUS\0"  format version (u32)  GUID (u32 length + UTF-8)
//! state (u8)  time, start time (f64)  stop time present (u8) + f64
//! last successful time (f64)
//! values (u32 count + f64 each)
//! then an estimator's:
//!   off-grid reported (u8)  inputs set at this point (u8)
//!   per input channel (u32 count, then each): ever set (u8)  missing reported (u8)
//!   input timing check: phase (u8), per input channel (as many): compared (u8)  kept value (f64)
//!   estimation present (u8) [ samples (u64)  measured (u8)  skipped (u64)  NIS (f64)
//!                             supervisor memory (u32 count + u64 each)
//!                             controls in force (u32 count + f64 each)
//!                             input statuses of the latest update (u32 count + u8 InputStatus value each)
//!                             kind (u8)  time (f64)  input, mean, covariance (u32 count + f64 each)
//!                             smoothing (u32 count + f64 each) ]
//! or a plant's:
//!   plant present (u8) [ the plant's own bytes (u32 length + bytes, `Plant::save`) ]
//! ```
//!
//! All numbers little-endian. Version 4 added the controls in force (the
//! controls the filter holds for its sample are the snapshot's input);
//! version 6 has the supervisor memory's self-describing layout (a header,
//! then named records); version 7 adds the input statuses (the outcome of
//! each measurement row in the latest update, which the `<input>_status`
//! outputs show and the supervisor's memory does not hold); version 8 carries
//! the supervisor memory of layout 3 (the adapted scale on `Q` and the jump
//! under review, with its two beliefs); version 9 adds the input timing check
//! (`input_timing_check.rs`: where it is, and the inputs set in
//! initialisation mode it compares the first steps' with); version 10 adds the
//! smoothing (`estimator::SupervisedFilter::save_smoothing`: the open step and
//! the fixed-lag smoother's instants; empty when `smoothing_lag` is 0); version
//! 11 splits the shell's part from the behaviour's, for the plant FMUs. The
//! filter and its twin for reads, or the plant, are rebuilt from the parameter
//! values and their state restored; the outputs are computed afresh at the
//! next read, from exactly that.

use estimator::{FilterKind, Snapshot};

use crate::estimating::Estimating;
use crate::estimators::{status_outcome, status_value};
use crate::input_timing_check::Phase;
use crate::instance::{Behaviour, Instance};
use crate::simulating::Simulating;
use crate::state::ModelState;
use crate::timing::{Estimation, Progress};

const MAGIC: &[u8; 8] = b"KALFMUS\0";
const VERSION: u32 = 11;

/// Serialises the instance's state. Reads nothing it would change: saving
/// leaves every later output as it would have been.
pub fn save(instance: &Instance) -> Vec<u8> {
    let shell = &instance.shell;
    let mut w = Writer(Vec::with_capacity(128 + 8 * shell.values.len()));
    w.0.extend_from_slice(MAGIC);
    w.u32(VERSION);
    w.bytes(instance.guid().as_bytes());
    w.u8(shell.state as u8);
    w.f64(shell.time);
    w.f64(shell.start_time);
    w.u8(u8::from(shell.stop_time.is_some()));
    w.f64(shell.stop_time.unwrap_or(0.0));
    w.f64(shell.last_successful_time);
    w.f64s(&shell.values);
    match &instance.behaviour {
        Behaviour::Estimator(e) => save_estimator(&mut w, e),
        Behaviour::Plant(p) => match &p.plant {
            None => w.u8(0),
            Some(plant) => {
                w.u8(1);
                w.bytes(&plant.save());
            }
        },
    }
    w.0
}

fn save_estimator(w: &mut Writer, e: &Estimating) {
    w.u8(u8::from(e.off_grid_reported));
    w.u8(u8::from(e.inputs_set));
    w.u32(e.input_ever_set.len() as u32);
    for (&set, &reported) in e.input_ever_set.iter().zip(&e.missing_reported) {
        w.u8(u8::from(set));
        w.u8(u8::from(reported));
    }
    let (phase, compared, kept) = e.timing_check.saved();
    w.u8(phase.tag());
    for (&c, &x) in compared.iter().zip(kept) {
        w.u8(u8::from(c));
        w.f64(x);
    }
    match e.estimation.as_ref().map(Estimation::progress) {
        None => w.u8(0),
        Some(p) => {
            w.u8(1);
            w.u64(p.samples);
            w.u8(u8::from(p.measured));
            w.u64(p.skipped);
            w.f64(p.nis);
            w.u32(p.supervisor.len() as u32);
            for &word in &p.supervisor {
                w.u64(word);
            }
            w.f64s(&p.controls);
            w.u32(p.statuses.len() as u32);
            for &status in &p.statuses {
                w.u8(status_value(status) as u8);
            }
            w.u8(kind_tag(p.belief.kind));
            w.f64(p.belief.time);
            w.f64s(&p.belief.input);
            w.f64s(&p.belief.mean);
            w.f64s(&p.belief.covariance);
            w.f64s(&p.smoothing);
        }
    }
}

/// The parts of a saved state, checked against the instance it is for.
pub struct Saved {
    state: ModelState,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    last_successful_time: f64,
    values: Vec<f64>,
    behaviour: SavedBehaviour,
}

/// The behaviour's part of a saved state.
enum SavedBehaviour {
    Estimator(Box<SavedEstimator>),
    /// The plant's own bytes, once it is built.
    Plant(Option<Vec<u8>>),
}

struct SavedEstimator {
    off_grid_reported: bool,
    inputs_set: bool,
    input_ever_set: Vec<bool>,
    missing_reported: Vec<bool>,
    check_phase: Phase,
    check_compared: Vec<bool>,
    check_row: Vec<f64>,
    progress: Option<Progress>,
}

/// Parses a saved state and checks it against `instance`: its GUID, its number
/// of variables, and for an estimator its measurement channels and controls.
pub fn parse(bytes: &[u8], instance: &Instance) -> Result<Saved, String> {
    let mut r = Reader { bytes, at: 0 };
    if r.take(8)? != MAGIC {
        return Err("not a kalfmu FMU state (bad magic)".into());
    }
    let version = r.u32()?;
    if version != VERSION {
        return Err(format!("FMU state format version {version}, this FMU reads version {VERSION}"));
    }
    let saved_guid = r.bytes()?;
    if saved_guid != instance.guid().as_bytes() {
        return Err(format!("FMU state of another FMU (GUID {})", String::from_utf8_lossy(saved_guid)));
    }
    let state = ModelState::from_tag(r.u8()?).ok_or("bad model state tag")?;
    // Only the states an instance can be saved in: a restored StartAndEnd or
    // StepInProgress would refuse even fmi2Reset.
    if matches!(state, ModelState::StartAndEnd | ModelState::StepInProgress | ModelState::StepCanceled) {
        return Err(format!("bad model state {} (never saved)", state.name()));
    }
    let (time, start_time) = (r.f64()?, r.f64()?);
    let (has_stop, stop) = (r.u8()?, r.f64()?);
    let last_successful_time = r.f64()?;
    let values = r.f64s()?;
    let n_values = instance.shell.values.len();
    if values.len() != n_values {
        return Err(format!("FMU state has {} values, the FMU has {n_values} variables", values.len()));
    }
    let (behaviour, running) = match &instance.behaviour {
        Behaviour::Estimator(e) => {
            let d = &e.descriptor;
            let saved = parse_estimator(&mut r, d.measurement_dim(), d.control_dim())?;
            let running = saved.progress.is_some();
            (SavedBehaviour::Estimator(Box::new(saved)), running)
        }
        Behaviour::Plant(_) => {
            let plant = match r.u8()? {
                0 => None,
                _ => Some(r.bytes()?.to_vec()),
            };
            let running = plant.is_some();
            (SavedBehaviour::Plant(plant), running)
        }
    };
    if r.at != bytes.len() {
        return Err(format!("{} trailing bytes after the FMU state", bytes.len() - r.at));
    }
    if !running && matches!(state, ModelState::StepComplete | ModelState::StepFailed) {
        return Err(format!("FMU state in {} without a filter or plant", state.name()));
    }
    Ok(Saved {
        state,
        time,
        start_time,
        stop_time: (has_stop != 0).then_some(stop),
        last_successful_time,
        values,
        behaviour,
    })
}

/// An estimator's part, for `m` measurement channels and `k` controls.
fn parse_estimator(r: &mut Reader<'_>, m: usize, k: usize) -> Result<SavedEstimator, String> {
    let (off_grid_reported, inputs_set) = (r.u8()? != 0, r.u8()? != 0);
    let n_inputs = r.u32()? as usize;
    if n_inputs != m {
        return Err(format!("FMU state has {n_inputs} input channels, the FMU has {m}"));
    }
    let (mut input_ever_set, mut missing_reported) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for _ in 0..m {
        input_ever_set.push(r.u8()? != 0);
        missing_reported.push(r.u8()? != 0);
    }
    let check_phase = Phase::from_tag(r.u8()?).ok_or("bad input timing check phase")?;
    let (mut check_compared, mut check_row) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for _ in 0..m {
        check_compared.push(r.u8()? != 0);
        check_row.push(r.f64()?);
    }
    let progress = match r.u8()? {
        0 => None,
        _ => {
            let (samples, measured, skipped, nis) = (r.u64()?, r.u8()? != 0, r.u64()?, r.f64()?);
            let words = r.u32()? as usize;
            if words > r.bytes.len() / 8 {
                return Err("FMU state is truncated".into());
            }
            let supervisor = (0..words).map(|_| r.u64()).collect::<Result<Vec<u64>, String>>()?;
            let controls = r.f64s()?;
            if controls.len() != k || controls.iter().any(|u| !u.is_finite()) {
                return Err(format!(
                    "FMU state has {} controls (or a non-finite one), the FMU has {k}",
                    controls.len()
                ));
            }
            if r.u32()? as usize != m {
                return Err(format!("FMU state has another number of input statuses than the FMU's {m} inputs"));
            }
            let statuses = (0..m)
                .map(|_| r.u8().and_then(|v| status_outcome(i32::from(v)).ok_or(format!("bad input status {v}"))))
                .collect::<Result<Vec<_>, String>>()?;
            let kind = kind_of(r.u8()?)?;
            let time = r.f64()?;
            let (input, mean, covariance) = (r.f64s()?, r.f64s()?, r.f64s()?);
            let belief = Snapshot { kind, time, input, mean, covariance };
            let smoothing = r.f64s()?;
            Some(Progress { samples, measured, skipped, nis, supervisor, controls, statuses, belief, smoothing })
        }
    };
    Ok(SavedEstimator {
        off_grid_reported,
        inputs_set,
        input_ever_set,
        missing_reported,
        check_phase,
        check_compared,
        check_row,
        progress,
    })
}

/// Applies a parsed state: the filters or the plant are rebuilt from the saved
/// parameters and their state restored. On error the instance is unchanged.
pub fn apply(instance: &mut Instance, saved: Saved) -> Result<(), String> {
    match (&mut instance.behaviour, saved.behaviour) {
        (Behaviour::Estimator(e), SavedBehaviour::Estimator(s)) => {
            apply_estimator(e, *s, &saved.values, saved.start_time)?
        }
        (Behaviour::Plant(p), SavedBehaviour::Plant(s)) => apply_plant(p, s.as_deref(), &saved.values)?,
        _ => return Err("FMU state of another kind of FMU".into()),
    }
    // Outputs read in initialisation mode are computed from the restored values.
    instance.mark_initial_outputs_stale();
    let shell = &mut instance.shell;
    shell.state = saved.state;
    shell.time = saved.time;
    shell.start_time = saved.start_time;
    shell.stop_time = saved.stop_time;
    shell.last_successful_time = saved.last_successful_time;
    shell.values = saved.values;
    Ok(())
}

fn apply_estimator(e: &mut Estimating, saved: SavedEstimator, values: &[f64], start_time: f64) -> Result<(), String> {
    let mut timing_check = e.timing_check.clone();
    timing_check.restore(saved.check_phase, &saved.check_compared, &saved.check_row)?;
    let estimation = match &saved.progress {
        None => None,
        Some(progress) => {
            let fresh = crate::estimating::build_estimation(&e.descriptor, values, start_time, &progress.controls)?;
            Some(fresh.resume(progress).map_err(|e| format!("cannot restore the filter: {e}"))?)
        }
    };
    e.off_grid_reported = saved.off_grid_reported;
    e.inputs_set = saved.inputs_set;
    e.input_ever_set = saved.input_ever_set;
    e.missing_reported = saved.missing_reported;
    e.timing_check = timing_check;
    e.estimation = estimation;
    // Whether the restored belief is lost is judged at the next step.
    e.lost = false;
    e.mark_outputs_stale();
    Ok(())
}

fn apply_plant(p: &mut Simulating, saved: Option<&[u8]>, values: &[f64]) -> Result<(), String> {
    let plant = match saved {
        None => None,
        Some(bytes) => {
            let mut plant = p.build(values).map_err(|why| format!("cannot rebuild the plant: {why}"))?;
            plant.restore(bytes).map_err(|why| format!("cannot restore the plant: {why}"))?;
            Some(plant)
        }
    };
    p.plant = plant;
    p.mark_outputs_stale();
    Ok(())
}

fn kind_tag(kind: FilterKind) -> u8 {
    FilterKind::ALL.iter().position(|k| *k == kind).expect("every kind is in ALL") as u8
}

fn kind_of(tag: u8) -> Result<FilterKind, String> {
    FilterKind::ALL.get(tag as usize).copied().ok_or_else(|| format!("bad filter kind tag {tag}"))
}

/// Little-endian numbers into bytes (the plants' states use it too).
pub(crate) struct Writer(pub(crate) Vec<u8>);

impl Writer {
    pub(crate) fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    pub(crate) fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn bytes(&mut self, b: &[u8]) {
        self.u32(b.len() as u32);
        self.0.extend_from_slice(b);
    }
    pub(crate) fn f64s(&mut self, v: &[f64]) {
        self.u32(v.len() as u32);
        for &x in v {
            self.f64(x);
        }
    }
}

/// Little-endian numbers out of bytes, refusing a truncated or overlong string.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }
    /// Refuses bytes left over.
    pub(crate) fn finish(&self) -> Result<(), String> {
        match self.bytes.len() - self.at {
            0 => Ok(()),
            n => Err(format!("{n} trailing bytes")),
        }
    }
    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or("FMU state is truncated")?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    pub(crate) fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    pub(crate) fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }
    pub(crate) fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    pub(crate) fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    pub(crate) fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.u32()? as usize;
        self.take(n)
    }
    pub(crate) fn f64s(&mut self) -> Result<Vec<f64>, String> {
        let n = self.u32()? as usize;
        if n > self.bytes.len() / 8 {
            return Err("FMU state is truncated".into());
        }
        (0..n).map(|_| self.f64()).collect()
    }
}
