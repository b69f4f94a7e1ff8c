//! Wiring checks: a channel whose sign, unit or zero is wrong.
//!
//! A sign wired the wrong way round, an acceleration in g taken for m/s²,
//! gravity left in: each is small enough on one sample to pass the gate, and
//! with many channels the others outvote it, so the gate never says so (S3
//! with one axle-box accelerometer flipped ran healthy, that wheelset's
//! forces wrong). But the innovations of such a channel are not white noise:
//! they follow the channel's own predicted value (`ν ≈ (k − 1)·ẑ` for a
//! scale `k`: −2·ẑ for a flipped sign) or sit off zero (`ν ≈ b` for an
//! offset `b`). Each channel is watched for both, with two scores from the
//! normalised innovations `eₖ = νₖ/√Sₖₖ` of the predictions before each update
//! (every available row's, a rejected one's once it has been rejected as
//! long as a re-acquisition's trigger), clipped at the gate's
//! `±√χ²`, forgetting with `λ = 1 − 1/window`:
//!
//! * **bias**: `Σ λʲ·e / √(Σ λ²ʲ)`;
//! * **scale**: `Σ λʲ·e·g / √(Σ λ²ʲ·g²)`, with `g = (ẑ − z̄)/√S` the channel's
//!   prediction about its forgetting mean, known before the sample comes.
//!
//! For a consistent filter the `e` are independent with unit variance and
//! each `g` is fixed before its `e`, so both scores are standard normal: at
//! a threshold of 8 ([`SupervisorSettings::wiring_sigmas`]; infinite, off,
//! by default) the per-sample false-alarm rate is that of an 8σ event,
//! 1e-15. Model mismatch makes small effects significant, so a score counts
//! only where its effect is wiring-sized ([`Channel::wiring_score`]); what
//! mismatch still adds is measured (`kalfmu robustness --wiring`, clean
//! runs; `estimator/tests/wiring.rs`).
//!
//! A channel whose score has passed the threshold for a tenth of a window is
//! inconsistent, and it is taken back once its score is below half the
//! threshold. What the verdict does depends on whether the data can say
//! which channel is wrong ([`SupervisorSettings::wiring_leaves_out`]):
//!
//! * **Left out**, where the channels contradict each other directly (S4's
//!   four telegrams of one position), or where the fault signatures say
//!   which channel's mistake the others show (`signature.rs`): the worst
//!   channel, while at most a third of the available ones (one, with fewer
//!   than six) pass and at least three are available. Its row outcome is
//!   [`RowOutcome::Inconsistent`](super::RowOutcome::Inconsistent); it is
//!   still predicted before each update and scored. A channel named by its
//!   signature stays out for five windows (`WIRING_HOLD_WINDOWS`), then is tried
//!   again.
//! * **Named** (the default), where an unknown input follows a channel (S2's
//!   and S3's axle boxes, each driven by its own wheel force: a flipped one
//!   drags its force along, and the bogie frame's channels show the mistake):
//!   kept in the updates, and the filter is inconsistent (`filter_healthy`
//!   false) while one is named. Leaving one out on a wrong verdict would
//!   lose a right channel's data, so no estimate changes. Without signatures
//!   every channel that passes is named in the log (the one wrong and the
//!   ones showing it look alike). With them (S2, S3) one channel is named,
//!   its status inconsistent ([`Supervisor::statuses`]): the likeliest,
//!   which is the one whose own scores pass if any does (its innovations
//!   show the mistake directly), else the one with the largest signature
//!   score, named once it leads and has passed for a tenth of a window
//!   (half a window for a signature alone: at a mistake's start every
//!   neighbour's signature fits for a few samples). It stays named until its
//!   score is below half the threshold; then the next may be named.
//!
//! The fit of `ν = (k − 1)·(ẑ − z̄) + b` behind the scores says what is
//! likely wrong ([`Channel::wiring_fit`]).
//!
//! What no check of innovations can see: a channel that no other contradicts
//! (every channel flipped together; S1's load channel, whose load follows
//! whatever it reads). docs/supervisor.md says how a user checks those.

use super::channel::Channel;
use super::outcome::RowOutcome;
use super::Supervisor;

/// How far from 1 a channel's scale must be to be wiring: a sign (−1), a
/// unit (9.81 or 0.102) are far beyond it, model mismatch (a few %) within.
pub const SCALE_TOLERANCE: f64 = 0.5;
/// How far from 0 a channel's mean normalised innovation must be to be
/// wiring (in σ of the innovation): gravity left in is far beyond it.
pub const BIAS_TOLERANCE: f64 = 1.0;

/// How long a channel named by its signature stays out before it is tried
/// again, in consistency windows.
const WIRING_HOLD_WINDOWS: usize = 5;

/// The memory of the fit, of the recent score and of a verdict's wait: a
/// tenth of the scores' `memory` (samples), at least two.
fn fit_memory(memory: usize) -> usize {
    (memory / 10).max(2)
}

/// The forgetting factor `λ` of sums with a memory of `memory` samples.
pub(super) fn forgetting(memory: usize) -> f64 {
    1.0 - 1.0 / memory.max(2) as f64
}

impl Supervisor {
    /// A belief in flux (re-acquired, restarted, jumped, under revision)
    /// predicts what its own episode did, not what the wiring does.
    pub(super) fn in_flux(&self) -> bool {
        let pending = &self.pending;
        pending.reacquired.is_some()
            || pending.restarted
            || pending.jump > 0.0
            || pending.revision != super::outcome::Revision::None
            || self.rival.active
            || self.review.active
    }

    /// Scores each channel's prediction of the pending sample and decides
    /// which channels are inconsistent once their score has passed the
    /// threshold for a tenth of a window: where the verdict names, every such
    /// channel; where it leaves out, at most one more per sample, the worst,
    /// and only while at least three channels are available and at most a
    /// third of them (one with fewer than six) pass. One is taken back once
    /// its score is below half the threshold.
    pub(super) fn commit_wiring(&mut self, flux: bool) {
        let threshold = self.settings.wiring_sigmas;
        if !threshold.is_finite() {
            return;
        }
        let (memory, clip) = (self.settings.window, self.thresholds.row.min(1e6).sqrt());
        let reacquire_after = self.settings.reacquire_after;
        let work = &mut self.work;
        let signatures = &self.signatures;
        let (wiring_signatures, left_out) = (self.settings.wiring_signatures, self.settings.wiring_leaves_out);
        let hold = WIRING_HOLD_WINDOWS * memory;
        // The signatures' test assumes the model right: where the filter's
        // own innovations say it is not (S3 with deflection transducers, whose
        // mismatch the car's model does not cover), its verdicts mean nothing.
        let consistent = self.window.consistent();
        let mut available = 0;
        for (c, channel) in self.channels.iter_mut().enumerate() {
            let row = self.pending.rows[c];
            work.wiring_scores[c] = 0.0;
            if matches!(row, RowOutcome::Missing | RowOutcome::Stuck) {
                continue;
            }
            available += 1;
            // A row the gate rejects teaches the scores only once its run of
            // rejections is as long as a re-acquisition's trigger: a burst of
            // gross errors is no wiring, a flipped telegram that fails the
            // gate for good is.
            if !flux && !channel.gross_error(row, reacquire_after) {
                channel.learn_wiring(work.residuals[c], work.first_variances[c], self.z_offered[c], memory, clip);
                if channel.inconsistent && channel.recent_score(memory) < threshold / 4.0 {
                    // The mistake has ended (its last tenth of a window is
                    // quiet): the window's evidence of it goes ten times
                    // faster, so that the channel is not judged on a past
                    // fault for a whole window (S4: 4 s at 50 Hz).
                    channel.forget_wiring_evidence(memory);
                }
            }
            let own = channel.wiring_score();
            // A channel left out adds nothing to its signature's evidence, so
            // its score would stand still: its own probe's scores decide
            // whether it is taken back.
            let followed = wiring_signatures && consistent && !(channel.inconsistent && left_out);
            let score =
                if followed { own.max(signatures.wiring_score(c, work.first_variances[c].sqrt())) } else { own };
            work.wiring_scores[c] = score;
            // Left out, a channel that an unknown input follows has a weak
            // probe (its prediction without it is wide): a quiet probe does
            // not say it is right again. Where signatures are followed it is
            // tried again after a hold, its signature's evidence fresh: a
            // mistake that persists is named again within a tenth of a second
            // (S3), a passing fault is over.
            let held = wiring_signatures && left_out && (channel.bad_run as usize) < hold;
            if channel.inconsistent && score < threshold / 2.0 && !held {
                channel.inconsistent = false;
            }
            channel.wiring_run = if score > threshold { channel.wiring_run.saturating_add(1) } else { 0 };
        }
        // A verdict waits a tenth of a window past the threshold: by then the
        // fit that names the likely cause describes the fault.
        let settled = fit_memory(memory) as u32;
        if !self.settings.wiring_leaves_out {
            if wiring_signatures {
                // The likeliest channel named (see the module documentation).
                if self.channels.iter().any(|c| c.inconsistent) {
                    return;
                }
                let scores = &self.work.wiring_scores;
                let own_passes = |channel: &Channel| channel.wiring_score() > threshold;
                let leader = self.channels.iter().enumerate().filter(|(_, channel)| channel.wiring_run > 0).max_by(
                    |(a, first), (b, second)| {
                        own_passes(first).cmp(&own_passes(second)).then(scores[*a].total_cmp(&scores[*b]))
                    },
                );
                if let Some((c, channel)) = leader {
                    let wait = if own_passes(channel) { settled } else { 5 * settled };
                    if channel.wiring_run >= wait {
                        self.channels[c].inconsistent = true;
                    }
                }
                return;
            }
            // Named, kept, and the filter inconsistent: every channel whose
            // innovations disagree may be the one wrong or the one showing it.
            for channel in &mut self.channels {
                channel.inconsistent |= channel.wiring_run >= settled;
            }
            return;
        }
        // Where signatures are followed, no channel is left out while the
        // filter is inconsistent: its model, not a channel, is then in doubt.
        if wiring_signatures && !consistent {
            return;
        }
        // With two channels the data cannot say which one is wrong (S1: a
        // flipped load channel makes the other one disagree).
        let scores = &self.work.wiring_scores;
        let above = scores.iter().filter(|&&s| s > threshold).count();
        if available < 3 || above == 0 || above > (available / 3).max(1) {
            return;
        }
        let worst = self
            .channels
            .iter_mut()
            .enumerate()
            .filter(|(c, channel)| {
                !channel.inconsistent && !matches!(self.pending.rows[*c], RowOutcome::Missing | RowOutcome::Stuck)
            })
            .max_by(|a, b| scores[a.0].total_cmp(&scores[b.0]));
        if let Some((c, channel)) = worst.filter(|(_, channel)| channel.wiring_run >= settled) {
            channel.inconsistent = true;
            // The others' signatures were scored against innovations this
            // channel's mistake was in: they start again (a neighbour's
            // signature looks much like the culprit's), and so does its own,
            // for when it is taken back.
            self.signatures.forget_all();
            for (other, channel) in self.channels.iter_mut().enumerate() {
                if other != c && !channel.inconsistent {
                    channel.wiring_run = 0;
                }
            }
        }
    }
}

impl Channel {
    /// Learns from one sample's innovation `residual` of this channel, its
    /// variance `variance` (of the prediction before the update) and the
    /// value offered `z`, forgetting over `memory` samples; the normalised
    /// innovation is clipped at `±clip`.
    pub(super) fn learn_wiring(&mut self, residual: f64, variance: f64, z: f64, memory: usize, clip: f64) {
        if !(residual.is_finite() && variance > 0.0 && variance.is_finite() && z.is_finite()) {
            return;
        }
        let lambda = forgetting(memory);
        let sigma = variance.sqrt();
        let e = (residual / sigma).clamp(-clip, clip);
        let predicted = z - residual;
        let g = if self.predictions == 0 { 0.0 } else { (predicted - self.prediction_mean) / sigma };
        self.bias_evidence = lambda * self.bias_evidence + e;
        self.bias_weight = lambda * lambda * self.bias_weight + 1.0;
        // A wrong scale makes `e` a multiple of `g` (8.81 for g taken for
        // m/s²): clipped at twelve times `g` it keeps that, while a gross
        // error (a burst) weighs no more than that.
        let bound = clip.max(12.0 * g.abs());
        let e_scale = (residual / sigma).clamp(-bound, bound);
        self.scale_evidence = lambda * self.scale_evidence + e_scale * g;
        self.scale_weight = lambda * lambda * self.scale_weight + g * g;
        self.scale_norm = lambda * self.scale_norm + g * g;
        self.offset_sum = lambda * self.offset_sum + e;
        self.offset_weight = lambda * self.offset_weight + 1.0;
        // The fit forgets ten times faster: at a verdict it describes the
        // fault, not the window's mix of before and after.
        let fast = forgetting(fit_memory(memory));
        self.fit_evidence = fast * self.fit_evidence + e_scale * g;
        self.fit_e = fast * self.fit_e + e_scale;
        self.fit_g = fast * self.fit_g + g;
        self.fit_norm = fast * self.fit_norm + g * g;
        self.fit_offset = fast * self.fit_offset + residual;
        self.fit_weight = fast * self.fit_weight + 1.0;
        self.predictions = self.predictions.saturating_add(1);
        let weight = 1.0 / self.predictions.min(memory as u64) as f64;
        self.prediction_mean += weight * (predicted - self.prediction_mean);
    }

    /// The larger of the bias and scale scores over the last tenth of a
    /// window (the fit's sums), about standard normal for a consistent channel.
    fn recent_score(&self, memory: usize) -> f64 {
        // Σλ²ʲ = Σλʲ/(1 + λ) at a steady state of the forgetting sums.
        let fast = forgetting(fit_memory(memory));
        let bias = if self.fit_weight > 0.0 { self.fit_e / (self.fit_weight / (1.0 + fast)).sqrt() } else { 0.0 };
        let scale = if self.fit_norm > 0.0 { self.fit_evidence / (self.fit_norm / (1.0 + fast)).sqrt() } else { 0.0 };
        bias.abs().max(scale.abs())
    }

    /// Lets the window's evidence decay at the fit's rate for one more sample.
    fn forget_wiring_evidence(&mut self, memory: usize) {
        let (lambda, fast) = (forgetting(memory), forgetting(fit_memory(memory)));
        let extra = fast / lambda;
        self.bias_evidence *= extra;
        self.scale_evidence *= extra;
        self.offset_sum *= extra;
    }

    /// The bias score: standard normal for a consistent channel.
    pub fn bias_score(&self) -> f64 {
        if self.bias_weight > 0.0 {
            self.bias_evidence / self.bias_weight.sqrt()
        } else {
            0.0
        }
    }

    /// The scale score: standard normal for a consistent channel.
    pub fn scale_score(&self) -> f64 {
        if self.scale_weight > 0.0 {
            self.scale_evidence / self.scale_weight.sqrt()
        } else {
            0.0
        }
    }

    /// The larger of the two scores' magnitudes, each counted only where
    /// its effect is large enough to be wiring (a scale off 1 by more than
    /// [`SCALE_TOLERANCE`], a mean innovation beyond [`BIAS_TOLERANCE`] σ):
    /// model mismatch makes small effects significant (S1's `z2_ddot`
    /// predicted 2 % too large gives a scale score of −20 on clean data).
    pub fn wiring_score(&self) -> f64 {
        let scale = if self.scale_norm > 0.0 { 1.0 + self.scale_evidence / self.scale_norm } else { 1.0 };
        let mean = if self.offset_weight > 0.0 { self.offset_sum / self.offset_weight } else { 0.0 };
        // An offset also moves the scale score (the innovations do not
        // average out over the prediction's swings): it is read as a bias.
        if mean.abs() > BIAS_TOLERANCE {
            self.bias_score().abs()
        } else if (scale - 1.0).abs() > SCALE_TOLERANCE {
            self.scale_score().abs()
        } else {
            0.0
        }
    }

    /// What the innovations say the channel reads: its scale `k` (about −1
    /// for a flipped sign, 9.81 for g taken for m/s², 0.102 for m/s² taken
    /// for g) and its mean innovation `b` (its unit: about 9.81 m/s² for
    /// gravity left in), from the fit of `ν = (k − 1)·(ẑ − z̄) + b` (the
    /// scale score's sums). Both are rough (a state the
    /// fault has moved biases them), enough to name a likely cause, not to
    /// correct it.
    pub fn wiring_fit(&self) -> (f64, f64) {
        // The weighted least squares of `e = a + (k − 1)·g`: an offset
        // does not pass for a scale.
        let determinant = self.fit_weight * self.fit_norm - self.fit_g * self.fit_g;
        let slope = self.fit_weight * self.fit_evidence - self.fit_g * self.fit_e;
        let scale = if determinant > 0.0 { 1.0 + slope / determinant } else { 1.0 };
        let offset = if self.fit_weight > 0.0 { self.fit_offset / self.fit_weight } else { 0.0 };
        (scale, offset)
    }
}
