//! Where some states of a model can plausibly be, as the user knows it (S2's
//! forces within 100 static wheel loads): a belief outside has lost the
//! state, whatever its innovations say. The supervisor restarts such a belief
//! (`restart.rs`); a driver can report it (an FMU's fmi2Warning).

use crate::error::FilterError;
use crate::filter::StateEstimator;

/// The plausible range of one state: its estimate within `bound` of `centre`,
/// and its σ at most `bound`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlausibleBound {
    /// The state (index into the model's state).
    pub state: usize,
    /// The centre of its range.
    pub centre: f64,
    /// The largest distance from the centre, and the largest σ.
    pub bound: f64,
}

/// A state of a belief found outside its plausible range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outside {
    /// The range it left.
    pub range: PlausibleBound,
    /// Its estimate.
    pub value: f64,
    /// Its σ.
    pub std: f64,
}

/// The plausible ranges of some states of a model; none by default.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlausibleRange {
    bounds: Vec<PlausibleBound>,
}

impl PlausibleRange {
    /// `bounds` for an `n`-state model; a state out of range, a centre that is
    /// not finite or a bound that is not positive is refused.
    pub fn new(n: usize, bounds: Vec<PlausibleBound>) -> Result<Self, FilterError> {
        let bad = |b: &&PlausibleBound| b.state >= n || !b.centre.is_finite() || b.bound.is_nan() || b.bound <= 0.0;
        if let Some(b) = bounds.iter().find(bad) {
            return Err(FilterError::InvalidSetting(format!(
                "plausible range of state {} ({} ± {}) for an {n}-state model",
                b.state, b.centre, b.bound
            )));
        }
        Ok(Self { bounds })
    }

    /// The first state of `belief` outside its range (an estimate that is not
    /// finite is outside), if any.
    pub fn first_outside(&self, belief: &dyn StateEstimator) -> Option<Outside> {
        self.bounds.iter().find_map(|&range| {
            let value = belief.mean()[range.state];
            let std = belief.variance(range.state).max(0.0).sqrt();
            let inside = (value - range.centre).abs() <= range.bound && std <= range.bound;
            (!inside).then_some(Outside { range, value, std })
        })
    }
}
