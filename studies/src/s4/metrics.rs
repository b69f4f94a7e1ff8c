//! Scoring S4's estimates against the truth, as the study asks of it: speed errors as the paper
//! reports them (§3.2), position errors, fault detections and false alarms, and the ETCS
//! speed-accuracy band.
//!
//! # Which truth a speed estimate is scored against (alignment)
//!
//! A raw speed `v(a) = (P(a + 1) − P(a))/Δt` is the mean speed over `[a·Δt, (a + 1)·Δt]`
//! and is known at telegram `a + 1`; so are the fused and filtered speeds built from it.
//! **Every speed sample `a` is scored against our true speed at telegram `a + 1`**, the
//! reference point's speed from the profile at the instant the estimate becomes known
//! ([`true_speed_for_samples`]): what a train controller using it at that instant needs.
//! The differencing therefore costs the raw speed a lag error of up to `|acc|·Δt/2`
//! (exactly `acc·Δt/2` under constant acceleration, 0.025 m/s in the paper's run at
//! 2.5 m/s²; nothing in cruise or at standstill), which an estimator of the speed *now*
//! may remove. The paper's own truth, the difference of the mean true position over the
//! same interval (`Recording::paper_true_speed`, aligned sample for sample), scores the
//! interval's mean instead and sees no lag; [`score_speed`] takes either.
//!
//! A position estimate at telegram `k` is scored against the reference point's true
//! position there ([`true_position_for_samples`] for the speed samples' telegrams).
//!
//! # The paper's figures, and what they are here
//!
//! - **Mean speed error** (平均速度误差, "改进前平均速度误差为0.12 m/s … 平均速度误差为
//!   0.08 m/s，减小了32.6%"): the mean of `|error|` ([`SpeedScore::mean_abs_error`]). It
//!   cannot be the signed mean: the raw speeds are differences of positions, so their
//!   signed errors telescope, `Σ_a e(a) = (e_P(n − 1) − e_P(0))/Δt`, and the raw average's
//!   signed mean error over 5,695 samples is the change of its position error over
//!   113.9 s, millimetres per minute: never 0.12 m/s. The signed mean is kept too
//!   ([`SpeedScore::mean_error`]). The reduction is [`reduction`], `(before − after)/before`
//!   (0.12 → 0.08 printed as −32.6 %, so the paper's unrounded means give it).
//! - **Maximum speed error** (速度误差最大达5.6 m/s; after filtering 基本稳定在0.44 m/s以内):
//!   the largest `|error|` ([`SpeedScore::max_abs_error`]).
//! - **Speed range** (速度极差, "改进前速度测量值极差为11.09 m/s，改进后速度极差为5.62 m/s，
//!   速度极差降低了49.3%"): `max − min` of the speed estimate over the run
//!   ([`SpeedScore::speed_range`]), against the true range (5.6 m/s on the paper's run,
//!   [`SpeedScore::true_range`]). Ranges of the error, `max e − min e`, are
//!   [`SpeedScore::error_range`].
//! - **Position error**: mean and maximum `|error|` ([`ErrorStats`]).
//!
//! # Detection scoring
//!
//! Flags come per telegram and channel (`flags[k][c]`, `k = 0 … n − 1`): channel `c`'s
//! reading at telegram `k` was declared faulty. A fault shows in the speeds known at these
//! telegrams (its *effect*, [`effect_telegrams`]):
//!
//! - a dropout or a resend of telegrams `s … e − 1` (its record's `s..e`): the speeds
//!   known at `s … e − 1` read 0, the one known at `e` jumps: telegrams `s ..= e`;
//! - a spike at `s`: the speeds known at `s` and `s + 1` (off one way, then back);
//! - a slot slip at `s`: the one speed known at `s` jumps (the position stays off);
//! - an offset: none; it never shows in a difference of positions.
//!
//! A fault is **detected** when its channel is flagged at a telegram of its effect or up to
//! `latency` telegrams after it ([`DetectionSettings::latency`], default 1: one telegram
//! late, the latency the study allows). An offset is detected when the detector says so for
//! its channel: the caller passes a per-channel "offset detected" bool (for instance, an
//! estimated offset beyond its uncertainty); flags never count for an offset, or any false
//! alarm anywhere would "detect" it. A **false alarm** is a flag at a telegram of a channel
//! with no dropout, resend, spike or slip whose effect-plus-latency window covers it
//! (offsets, being everywhere, excuse nothing); its fraction is over all channel-telegrams
//! flagged or not, `4·flags.len()`. A channel said to have an offset it does not have is an
//! offset false alarm, counted apart.
//!
//! # ETCS speed accuracy
//!
//! ERA SUBSET-041 §5.3.1: ±2 km/h up to 30 km/h, rising linearly to ±12 km/h at
//! 500 km/h ([`etcs_speed_band`]). Beyond 500 km/h the subset says nothing; the band is
//! held at ±12 km/h there.

use std::ops::Range;

use truth::s4::faults::{Fault, FaultKind};
use truth::s4::recording::Recording;

/// Statistics of an error series `e = estimate − truth`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    /// Samples scored (both finite).
    pub n: usize,
    /// Samples left out because the estimate (or the truth) was not finite.
    pub missing: usize,
    /// Mean of `|e|`.
    pub mean_abs: f64,
    /// Mean of `e` (signed: the bias).
    pub mean: f64,
    /// Root mean square of `e`.
    pub rms: f64,
    /// Largest `|e|`.
    pub max_abs: f64,
    /// Smallest `e`.
    pub min: f64,
    /// Largest `e`.
    pub max: f64,
}

impl ErrorStats {
    /// Over the pairs where both are finite. Panics when the lengths differ.
    pub fn new(estimate: &[f64], truth: &[f64]) -> Self {
        assert_eq!(estimate.len(), truth.len(), "an estimate and its truth must be aligned sample for sample");
        let mut s = Self {
            n: 0,
            missing: 0,
            mean_abs: 0.0,
            mean: 0.0,
            rms: 0.0,
            max_abs: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        };
        let (mut sum_abs, mut sum, mut sum_sq) = (0.0, 0.0, 0.0);
        for (x, t) in estimate.iter().zip(truth) {
            let e = x - t;
            if !e.is_finite() {
                s.missing += 1;
                continue;
            }
            s.n += 1;
            sum_abs += e.abs();
            sum += e;
            sum_sq += e * e;
            s.max_abs = s.max_abs.max(e.abs());
            s.min = s.min.min(e);
            s.max = s.max.max(e);
        }
        if s.n == 0 {
            return Self {
                mean_abs: f64::NAN,
                mean: f64::NAN,
                rms: f64::NAN,
                max_abs: f64::NAN,
                min: f64::NAN,
                max: f64::NAN,
                ..s
            };
        }
        let n = s.n as f64;
        Self { mean_abs: sum_abs / n, mean: sum / n, rms: (sum_sq / n).sqrt(), ..s }
    }

    /// `max e − min e`.
    pub fn range(&self) -> f64 {
        self.max - self.min
    }
}

/// A speed series scored as the paper scores it (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SpeedScore {
    /// The error statistics.
    pub error: ErrorStats,
    /// The paper's mean speed error (平均速度误差): mean of `|e|` (m/s).
    pub mean_abs_error: f64,
    /// The signed mean error (m/s).
    pub mean_error: f64,
    /// The largest `|e|` (m/s).
    pub max_abs_error: f64,
    /// The range of the error, `max e − min e` (m/s).
    pub error_range: f64,
    /// The paper's speed range (速度极差): `max − min` of the estimate (m/s), over the
    /// samples scored.
    pub speed_range: f64,
    /// `max − min` of the truth over the same samples (m/s).
    pub true_range: f64,
}

/// `max − min` of the finite values (NaN if none).
pub fn range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if lo <= hi {
        hi - lo
    } else {
        f64::NAN
    }
}

/// Scores `estimate` against `truth`, aligned sample for sample (non-finite pairs left
/// out). Panics when the lengths differ.
pub fn score_speed(estimate: &[f64], truth: &[f64]) -> SpeedScore {
    let error = ErrorStats::new(estimate, truth);
    let scored = |x: &[f64]| -> Vec<f64> {
        estimate.iter().zip(truth).zip(x).filter(|((e, t), _)| (*e - *t).is_finite()).map(|(_, &v)| v).collect()
    };
    SpeedScore {
        error,
        mean_abs_error: error.mean_abs,
        mean_error: error.mean,
        max_abs_error: error.max_abs,
        error_range: error.range(),
        speed_range: range(&scored(estimate)),
        true_range: range(&scored(truth)),
    }
}

/// A position series scored: mean and largest `|e|` are `mean_abs` and `max_abs`.
pub fn score_position(estimate: &[f64], truth: &[f64]) -> ErrorStats {
    ErrorStats::new(estimate, truth)
}

/// The relative reduction `(before − after)/before`: the paper's "减小了32.6%" is 0.326.
pub fn reduction(before: f64, after: f64) -> f64 {
    (before - after) / before
}

/// Our true speed for each speed sample `a = 0 … n − 2`: the profile's speed at
/// telegram `a + 1`, when the sample is known (see the module documentation).
pub fn true_speed_for_samples(recording: &Recording) -> Vec<f64> {
    recording.truth.iter().skip(1).map(|s| s.speed).collect()
}

/// The reference point's true position at telegram `a + 1` for each speed sample `a`.
pub fn true_position_for_samples(recording: &Recording) -> Vec<f64> {
    recording.truth.iter().skip(1).map(|s| s.position).collect()
}

/// The half-width of the ETCS speed-accuracy band (SUBSET-041 §5.3.1) at `speed` (m/s),
/// in m/s: 2 km/h up to 30 km/h, rising linearly to 12 km/h at 500 km/h, held there
/// beyond. Symmetric in the sign of the speed.
pub fn etcs_speed_band(speed: f64) -> f64 {
    let kmh = speed.abs() * 3.6;
    let band_kmh = if kmh <= 30.0 {
        2.0
    } else if kmh >= 500.0 {
        12.0
    } else {
        2.0 + 10.0 * (kmh - 30.0) / 470.0
    };
    band_kmh / 3.6
}

/// The fraction of samples whose error lies within the ETCS band at the true speed,
/// `|estimate − truth| ≤ band(truth)`; a non-finite estimate counts as outside. Panics
/// when the lengths differ; NaN for none.
pub fn fraction_in_band(estimate: &[f64], truth: &[f64]) -> f64 {
    assert_eq!(estimate.len(), truth.len(), "an estimate and its truth must be aligned sample for sample");
    let inside = estimate.iter().zip(truth).filter(|(x, t)| (*x - *t).abs() <= etcs_speed_band(**t)).count();
    inside as f64 / estimate.len() as f64
}

/// How detections are scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DetectionSettings {
    /// Telegrams after a fault's effect within which a flag still detects it (and is not
    /// a false alarm). Default 1.
    pub latency: usize,
}

impl Default for DetectionSettings {
    fn default() -> Self {
        Self { latency: 1 }
    }
}

/// The telegrams at which a fault shows in the raw speeds known there (see the module
/// documentation), within `0..n_telegrams`; empty for an offset.
pub fn effect_telegrams(fault: &Fault, n_telegrams: usize) -> Range<usize> {
    let Range { start, end } = fault.telegrams.clone();
    let effect = match fault.kind {
        FaultKind::Dropout | FaultKind::Resend | FaultKind::Spike { .. } => start..end + 1,
        FaultKind::SlotSlip { .. } => start..start + 1,
        FaultKind::Offset { .. } => 0..0,
    };
    effect.start.min(n_telegrams)..effect.end.min(n_telegrams)
}

/// The fault kinds' names in the order [`DetectionScore::kinds`] lists them.
pub const FAULT_KINDS: [&str; 5] = ["dropout", "resend", "spike", "slot slip", "offset"];

/// Detections of one fault kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct KindScore {
    /// The kind's name ([`FaultKind::name`]).
    pub name: &'static str,
    /// Faults of this kind injected.
    pub injected: usize,
    /// Of these, detected.
    pub detected: usize,
}

/// Detections per fault kind and false alarms.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DetectionScore {
    /// One per kind, in [`FAULT_KINDS`]' order.
    pub kinds: [KindScore; 5],
    /// Flags covered by no fault's window.
    pub false_alarms: usize,
    /// The same, per channel.
    pub false_alarms_per_channel: [usize; 4],
    /// All flags raised.
    pub flagged: usize,
    /// Channel-telegrams scored, `4·flags.len()`.
    pub channel_telegrams: usize,
    /// Channels said to have an offset that have none.
    pub offset_false_alarms: usize,
}

impl DetectionScore {
    /// The score of the kind named `name`.
    pub fn kind(&self, name: &str) -> Option<&KindScore> {
        self.kinds.iter().find(|k| k.name == name)
    }

    /// False alarms as a fraction of the channel-telegrams.
    pub fn false_alarm_fraction(&self) -> f64 {
        self.false_alarms as f64 / self.channel_telegrams as f64
    }
}

/// Scores per-telegram, per-channel `flags` (`flags[k][c]`, one entry per telegram of the
/// recording the `faults` came from) and per-channel `offset_detected` against the
/// injected `faults` (see the module documentation).
pub fn score_detection(
    faults: &[Fault],
    flags: &[[bool; 4]],
    offset_detected: [bool; 4],
    settings: DetectionSettings,
) -> DetectionScore {
    let n = flags.len();
    let mut excused = vec![[false; 4]; n];
    let mut kinds = FAULT_KINDS.map(|name| KindScore { name, injected: 0, detected: 0 });
    let mut has_offset = [false; 4];
    for fault in faults {
        let c = fault.channel as usize;
        let kind = kinds.iter_mut().find(|k| k.name == fault.kind.name()).expect("every fault kind is listed");
        kind.injected += 1;
        let detected = if let FaultKind::Offset { .. } = fault.kind {
            has_offset[c] = true;
            offset_detected[c]
        } else {
            let effect = effect_telegrams(fault, n);
            let window = effect.start..(effect.end + settings.latency).min(n);
            window.clone().for_each(|k| excused[k][c] = true);
            window.clone().any(|k| flags[k][c])
        };
        kind.detected += usize::from(detected);
    }
    let mut false_alarms_per_channel = [0; 4];
    let mut flagged = 0;
    for (row, ok) in flags.iter().zip(&excused) {
        for c in 0..4 {
            flagged += usize::from(row[c]);
            false_alarms_per_channel[c] += usize::from(row[c] && !ok[c]);
        }
    }
    DetectionScore {
        kinds,
        false_alarms: false_alarms_per_channel.iter().sum(),
        false_alarms_per_channel,
        flagged,
        channel_telegrams: 4 * n,
        offset_false_alarms: (0..4).filter(|&c| offset_detected[c] && !has_offset[c]).count(),
    }
}

/// Telegrams of `channel` at which a fault makes a rejection by the gate right: a spike's
/// telegram, and the first 12 after a slot slip (until the supervisor has re-based the
/// slip into the channel's offset). A rejection anywhere else is a false one.
pub fn rejection_excused(recording: &Recording, channel: usize, telegram: usize) -> bool {
    recording.faults.iter().filter(|f| f.channel as usize == channel).any(|f| match f.kind {
        FaultKind::Spike { .. } => f.telegrams.contains(&telegram),
        FaultKind::SlotSlip { .. } => (f.telegrams.start..f.telegrams.start + 12).contains(&telegram),
        _ => false,
    })
}
