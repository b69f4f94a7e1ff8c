//! The supervisor's settings and their legal ranges.

use crate::error::FilterError;

/// The supervisor's settings; `Default` is what the studies use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupervisorSettings {
    /// Probability of the gate quantiles: a row of a consistent filter is
    /// rejected with probability `1 − gate_probability`. Default `1 − 1e-6`
    /// (a row beyond about 4.9σ). `1` turns the gate off.
    pub gate_probability: f64,
    /// Consecutive rejected or missing samples that make a channel faulty. Default 3.
    pub fault_after: u32,
    /// Consecutive gate failures of a channel before the filter re-acquires. Default 10.
    pub reacquire_after: u32,
    /// Consecutive bit-identical values that make a channel stuck. Default 5.
    pub stuck_after: u32,
    /// A row this many σ of its innovation away is never used, not even to
    /// re-acquire: no state the model can reach explains it (a 100 N step of
    /// the S1 load is about 250σ). Default 1e5.
    pub implausible_sigmas: f64,
    /// Samples in the consistency window. Default 200.
    pub window: usize,
    /// The consistency test's false-alarm probability per sample for a
    /// consistent filter. Default 1e-6.
    pub consistency_probability: f64,
    /// How far above its χ² bound the windowed NIS may go before the filter
    /// is inconsistent. Default 3 (the σ understate the errors by more than √3).
    pub consistency_margin: f64,
    /// The most the re-acquisitions may multiply the covariance by in total
    /// between two samples that pass the gate whole. Default 1e8: two full
    /// re-acquisitions (S1's load step and S5's change of every coefficient
    /// each take one).
    pub max_inflation: f64,
    /// A failing row that a jump of the unknown inputs explains, and the
    /// other rows do not contradict, is used from `P + c·Q` instead of being
    /// rejected, and reviewed at the next sample (`jump.rs`). Default on.
    pub jumps: bool,
    /// Samples after a confirmed jump of a row (`jump.rs`) during which a
    /// further jump that row alone explains is shown at its sample, and
    /// still reviewed at the next: the change under way goes on (a weld's
    /// impact rings for tens of samples at 1 kHz), where a new spike would
    /// have to come right after a confirmed change. 0: every jump one row
    /// alone explains waits for its review. Default 10.
    pub change_memory: u32,
    /// The belief shown after a jump that one row alone explains, before any
    /// change of that row is under way, has the jump's mean instead of the
    /// fault hypothesis's (the covariance is the mixture's either way, and
    /// the review at the next sample still decides). One sample cannot tell
    /// a spike from a step: `false` (the default) holds the estimate until
    /// the review confirms the change, so a spike moves nothing; `true`
    /// follows an impact at its sample, so a spike shows for one sample,
    /// inside its σ. For unknown inputs that one sensor alone reads at
    /// their first sample, where impacts are the signal (S2's and S3's
    /// wheel–rail forces behind their axle boxes).
    pub show_single_row_jumps: bool,
    /// A re-acquisition keeps the update the gate alone would have made as
    /// a rival, and the data of the next samples decide which of the two
    /// stays (`rival.rs`). Default on.
    pub revise: bool,
    /// Samples over which the process-noise scale adapts (`adaptation.rs`):
    /// its gain per sample is the inverse. 0 turns the adaptation off (the
    /// scale stays 1). Default 200. The scale is on the unknown inputs' noise
    /// ([`Supervisor::scaled_states`](super::Supervisor::scaled_states)).
    pub adaptation_window: usize,
    /// The least the adaptation may scale the `Q` given by. Default 1e-2; 1
    /// lets it only raise `Q`, for an unknown input whose noise is set for
    /// rare hard events a quiet stretch would unlearn (S2's welds).
    pub min_process_noise_scale: f64,
    /// The most the adaptation may scale the `Q` given by. Default 1e2: a
    /// user's `Q` is taken to be at most a hundred times wrong either way
    /// (wider bounds let S2's filter, whose innovations are small for reasons
    /// no scale on `Q` reaches, drive its `Q` down until its weld is lost).
    pub max_process_noise_scale: f64,
    /// The wiring scores' threshold (`wiring.rs`): a channel whose bias or
    /// scale score passes it is inconsistent. Infinite (the default) turns the
    /// check off; 8 for standard-normal scores.
    pub wiring_sigmas: f64,
    /// What an inconsistent channel's verdict does (`wiring.rs`). `true`: the
    /// worst one is left out, while at most a third of the channels pass;
    /// right only where the channels contradict each other directly (S4's
    /// telegrams of one position). `false` (the default): every channel
    /// that passes is named, stays in the updates, and the filter is
    /// inconsistent while one does; where a free unknown input follows a
    /// channel (S2's and S3's axle boxes, each with its own wheel force) the
    /// other channels show its mistake, and leaving out the worst would
    /// blame them (docs/supervisor.md § Wiring checks).
    pub wiring_leaves_out: bool,
    /// Whether the wiring checks also follow each channel's fault through the
    /// filter's dynamics (`signature.rs`): where an unknown input follows a
    /// channel, its mistake shows only in the other channels, and only this
    /// test sees it there. Without `wiring_leaves_out` only the likeliest
    /// channel is named (its status inconsistent, still used) and the filter
    /// is inconsistent while it is: no estimate changes. It costs two model
    /// transitions per channel and sample, and products with `P` (S3: the
    /// supervised step more than twice as long). Off by default; on in S2 and
    /// S3.
    pub wiring_signatures: bool,
    /// Whether a jump opens only the jump states its failing rows see (their
    /// observation moves with them), not every one. Right where each unknown
    /// input acts on a body of its own and its sensors see it at once (S2's
    /// and S3's wheel–rail forces): opened, a force only passing rows see is
    /// set by them alone, from one sample, for as long as an impact rings
    /// (S2's weld under a tuned σ: 1.27–1.30 times the gate-off RMSE, against
    /// 1.33–1.35 with every force opened). Wrong where the unknown inputs
    /// reach the rows through the dynamics (S5's aerodynamic coefficients: a
    /// failing overload then left the moments closed, and the yaw rate failed
    /// the gate at start-up on clean data). Costs one observation per jump
    /// state on a sample some row fails. Off by default.
    pub local_jumps: bool,
}

impl Default for SupervisorSettings {
    fn default() -> Self {
        Self {
            gate_probability: 1.0 - 1e-6,
            fault_after: 3,
            reacquire_after: 10,
            stuck_after: 5,
            implausible_sigmas: 1e5,
            window: 200,
            consistency_probability: 1e-6,
            consistency_margin: 3.0,
            max_inflation: 1e8,
            jumps: true,
            change_memory: 10,
            show_single_row_jumps: false,
            revise: true,
            adaptation_window: 200,
            min_process_noise_scale: 1e-2,
            max_process_noise_scale: 1e2,
            wiring_sigmas: f64::INFINITY,
            wiring_leaves_out: false,
            wiring_signatures: false,
            local_jumps: false,
        }
    }
}

impl SupervisorSettings {
    /// Checks the ranges, saying what is wrong.
    pub fn validate(&self) -> Result<(), FilterError> {
        let bad = |why: String| Err(FilterError::InvalidSetting(why));
        if !(self.gate_probability > 0.0 && self.gate_probability <= 1.0) {
            return bad(format!("gate probability must be in (0, 1], got {}", self.gate_probability));
        }
        if self.fault_after == 0 || self.reacquire_after == 0 || self.window == 0 || self.stuck_after < 2 {
            return bad("fault_after, reacquire_after and window must be at least 1, stuck_after at least 2".into());
        }
        if !(self.consistency_probability > 0.0 && self.consistency_probability < 1.0) {
            return bad(format!("consistency probability must be in (0, 1), got {}", self.consistency_probability));
        }
        if self.implausible_sigmas <= 0.0 || self.implausible_sigmas.is_nan() {
            return bad(format!("implausible_sigmas must be positive, got {}", self.implausible_sigmas));
        }
        if !(self.consistency_margin >= 1.0 && self.consistency_margin.is_finite()) {
            return bad(format!("consistency margin must be at least 1, got {}", self.consistency_margin));
        }
        if !(self.max_inflation >= 1.0 && self.max_inflation.is_finite()) {
            return bad(format!("max_inflation must be finite and at least 1, got {}", self.max_inflation));
        }
        if self.wiring_sigmas.is_nan() || self.wiring_sigmas <= 0.0 {
            return bad(format!("wiring_sigmas must be positive, got {}", self.wiring_sigmas));
        }
        let (low, high) = (self.min_process_noise_scale, self.max_process_noise_scale);
        if !(low > 0.0 && low <= 1.0 && high >= 1.0 && high.is_finite()) {
            return bad(format!(
                "the process-noise scale bounds must satisfy 0 < min ≤ 1 ≤ max < ∞, got [{low}, {high}]"
            ));
        }
        Ok(())
    }

    /// These settings with jumps taken and the process noise adapted over
    /// `window` samples.
    pub fn adaptive(self, window: usize) -> Self {
        Self { jumps: true, adaptation_window: window, ..self }
    }

    /// These settings as the supervisor was before it learnt `Q`, told
    /// jumps from faults, revised its re-acquisitions and checked the
    /// wiring: every failing row rejected, `Q` as given, a re-acquisition final.
    pub fn fixed(self) -> Self {
        Self { jumps: false, revise: false, adaptation_window: 0, wiring_sigmas: f64::INFINITY, ..self }
    }
}
