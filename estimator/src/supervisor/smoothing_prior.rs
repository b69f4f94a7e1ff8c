//! The prediction a supervised update started from, for a smoother: the
//! filter's prediction with what the gate did to it before the update it kept.
//!
//! A smoother links two instants through the prediction (`fixed_lag.rs`); a
//! jump, a re-acquisition or a bias step changes the state by more than the
//! prediction says, and must loosen or shift that link, or the smoother
//! carries the change back to before it happened:
//!
//! - a re-acquisition inflated the whole covariance by its factor;
//! - a jump added `c·Q` on the jump states (the belief after an ambiguous jump
//!   is a mixture of the jump and the fault hypothesis; its prediction is taken
//!   as the jump's, the looser of the two);
//! - an undone re-acquisition (`rival.rs`) put the rival's belief in place of
//!   the update of the prediction: the link is cut (the covariance scaled by
//!   [`CUT`]), so that nothing of the re-acquired belief is carried back;
//! - a restart (`restart.rs`) put a belief from the states' history in its
//!   place: cut too;
//! - a bias step moved its bias state's mean by the step, which is known to
//!   have been taken, so the prediction takes it too.
//!
//! A reviewed jump replaces the previous sample's belief; the smoother keeps the
//! link from the one committed there (the review is rare, and one sample long).

use nalgebra::{DMatrix, DVector};

use super::Supervisor;

/// The factor on a prediction's covariance that cuts its link to the step before.
const CUT: f64 = 1e8;

impl Supervisor {
    /// Applies to the prediction `mean`, `covariance` (made with the process
    /// noise `q`) what the pending update did to the prediction it started from.
    pub fn apply_pending_to_prediction(
        &self,
        q: &DMatrix<f64>,
        mean: &mut DVector<f64>,
        covariance: &mut DMatrix<f64>,
    ) {
        let outcome = &self.pending;
        if outcome.reacquired.is_some() {
            *covariance *= outcome.inflation;
        }
        if outcome.replaced() || outcome.restarted {
            *covariance *= CUT;
        }
        if outcome.jump > 0.0 {
            let n = covariance.nrows();
            let selected = |i: usize| self.jump_states.get(i).copied().unwrap_or(true);
            for j in (0..n).filter(|&j| selected(j)) {
                for i in (0..n).filter(|&i| selected(i)) {
                    covariance[(i, j)] += outcome.jump * q[(i, j)];
                }
            }
        }
        if let Some(steps) = &self.steps {
            for (&step, state) in outcome.steps.iter().zip(&steps.bias_states) {
                if let (Some(state), true) = (state, step != 0.0) {
                    mean[*state] += step;
                }
            }
        }
    }
}
