//! The windowed consistency test.
//!
//! Each sample's available rows give their normalised innovations `νᵢ²/Sᵢᵢ`
//! (before the gate, each clipped at the gate's threshold so that one glitch
//! cannot flag a window). Summed over the last
//! [`SupervisorSettings::window`] samples they have the number of those rows
//! as mean for a consistent filter, and are close to χ² with that many
//! degrees of freedom. Above [`SupervisorSettings::consistency_margin`] times
//! the `1 − consistency_probability` quantile, the filter's σ no longer cover
//! the errors its innovations reveal: it is inconsistent (diverging). The
//! margin allows the model mismatch a real tuning leaves (S1, random load:
//! mean NIS per row 1.25, one-second windows up to 2.1).
//!
//! Rejected rows count: a channel that fails the gate for a whole window makes
//! the filter inconsistent too, since from the data alone it cannot tell
//! whether the sensor or the estimate is wrong (a drifting load sensor pulls
//! the load estimate with it); the channel flags say which channel disagrees.

use super::settings::SupervisorSettings;

/// One sample in the window.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct WindowEntry {
    /// The sample's normalised innovations, each clipped at the gate, summed.
    pub clipped_ratios: f64,
    /// How many rows that sum has.
    pub rows: usize,
}

/// Where the ring of entries stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct Cursor {
    /// The entry the next sample overwrites.
    pub next: usize,
    /// How many entries hold samples (the window length once full).
    pub filled: usize,
}

impl Cursor {
    /// A position a ring of `window` entries reaches: inside it, and while
    /// not yet full, right after the last sample.
    pub fn fits(&self, window: usize) -> bool {
        self.next < window && self.filled <= window && (self.filled == window || self.next == self.filled)
    }
}

/// The last `window` samples' clipped normalised innovations and the verdict on them.
#[derive(Debug, Clone)]
pub(super) struct ConsistencyWindow {
    /// A ring of the last samples.
    entries: Vec<WindowEntry>,
    cursor: Cursor,
    consistent: bool,
    /// The mean clipped normalised innovation per row (NaN before any row).
    windowed_nis: f64,
    probability: f64,
    margin: f64,
    /// Upper χ² bounds by total degrees of freedom, computed when first needed.
    bounds: Vec<f64>,
}

impl ConsistencyWindow {
    /// An empty window for a supervisor of `m` rows.
    pub fn new(settings: &SupervisorSettings, m: usize) -> Self {
        Self {
            entries: vec![WindowEntry::default(); settings.window],
            cursor: Cursor::default(),
            consistent: true,
            windowed_nis: f64::NAN,
            probability: settings.consistency_probability,
            margin: settings.consistency_margin,
            // The most degrees of freedom a window can have: no allocation later.
            bounds: vec![f64::NAN; settings.window * m + 1],
        }
    }

    /// The windowed NIS is within its bound.
    pub fn consistent(&self) -> bool {
        self.consistent
    }

    /// The mean clipped normalised innovation per row over the window.
    pub fn windowed_nis(&self) -> f64 {
        self.windowed_nis
    }

    /// The ring and its position, as saved.
    pub fn saved(&self) -> (Cursor, &[WindowEntry]) {
        (self.cursor, &self.entries)
    }

    /// Takes back a saved ring (checked by the caller) and judges it afresh.
    pub fn restore(&mut self, cursor: Cursor, entries: &[WindowEntry]) {
        self.cursor = cursor;
        self.entries.copy_from_slice(entries);
        self.judge();
    }

    /// Adds one sample, dropping the oldest once the window is full.
    pub fn push(&mut self, entry: WindowEntry) {
        let w = self.entries.len();
        self.entries[self.cursor.next] = entry;
        self.cursor.next = (self.cursor.next + 1) % w;
        self.cursor.filled = (self.cursor.filled + 1).min(w);
        self.judge();
    }

    /// Replaces the latest `entries.len()` samples (oldest first; at most
    /// those in the window) by `entries`, and judges afresh.
    pub fn replace_latest(&mut self, entries: &[WindowEntry]) {
        let w = self.entries.len();
        let k = entries.len().min(self.cursor.filled);
        for (back, entry) in entries[entries.len() - k..].iter().rev().enumerate() {
            self.entries[(self.cursor.next + w - 1 - back) % w] = *entry;
        }
        self.judge();
    }

    /// The verdict on the samples in the window, summed afresh (w additions:
    /// no drift of a running sum).
    fn judge(&mut self) {
        let (sum, total): (f64, usize) =
            self.entries[..self.cursor.filled].iter().fold((0.0, 0), |(s, d), e| (s + e.clipped_ratios, d + e.rows));
        self.consistent = total == 0 || sum <= self.margin * self.bound(total);
        self.windowed_nis = if total == 0 { f64::NAN } else { sum / total as f64 };
    }

    fn bound(&mut self, dof: usize) -> f64 {
        if dof >= self.bounds.len() {
            self.bounds.resize(dof + 1, f64::NAN);
        }
        if self.bounds[dof].is_nan() {
            self.bounds[dof] = chi_square::quantile(dof as f64, 1.0 - self.probability);
        }
        self.bounds[dof]
    }
}
