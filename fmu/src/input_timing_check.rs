//! Whether the master's call pattern fits `input_timing`: does it hand over
//! the plant's outputs of `t` before `fmi2DoStep(t, h)` (Jacobi), or those of
//! `t + h`, having stepped the plant first (Gauss–Seidel)?
//!
//! The measurements cannot tell. Every estimation model is time-invariant, so
//! a Gauss–Seidel master only shifts the input stream by one step, and the two
//! alignments are the same filter started from priors one prediction apart:
//! their likelihoods differ only through the prior at the start, the
//! difference dies out within seconds, and on the studies' truth data its sign
//! was wrong as often as right. The call pattern can: masters that propagate
//! initial values (fmpy's `simulate_fmu`, OMSimulator, SSP runners) set the
//! plant's outputs of `t₀` on our inputs before `fmi2ExitInitializationMode`.
//! Before the first `fmi2DoStep(t₀, h)` a Jacobi master sets those outputs of
//! `t₀` again (the same row, bit for bit) or nothing new; a Gauss–Seidel
//! master has stepped the plant and sets its outputs of `t₀ + h`, a different row.
//!
//! A row that is the same at the first step only means "the same instant" if
//! the plant's outputs move at all: a plant at rest (or a master that sets
//! nothing) hands over the same row under either ordering. So that verdict
//! waits for the second step, whose row must differ from the first's; a row
//! that stands still over both says nothing and leaves the check undecided.
//! No threshold enters: rows are compared bit for bit (two NaN, missing, are
//! the same), and only the rows set before `fmi2ExitInitializationMode`.
//!
//! Nothing is allocated after the instance is made: the kept row is sized at
//! instantiation.

use crate::timing::InputTiming;

/// The `input_timing_check` output before a verdict (and for good when none can be made).
pub const UNDECIDED: i32 = 0;
/// The `input_timing_check` output when the master's ordering fits `input_timing`.
pub const FITS: i32 = 1;
/// The `input_timing_check` output when it fits the other `input_timing`.
pub const OTHER_FITS: i32 = 2;

/// Where the check is, as an FMU state saves it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Before `fmi2ExitInitializationMode`; or no input was set before it; or
    /// the inputs stood still over the first two steps: nothing to tell.
    Undecided,
    /// The inputs set before `fmi2ExitInitializationMode` are kept; the first
    /// step compares its inputs with them.
    BeforeFirstStep,
    /// The first step's inputs were those set in initialisation mode; the
    /// second step's must differ for that to mean "the same instant".
    BeforeSecondStep,
    /// The master hands over the plant's outputs of `t` before
    /// `fmi2DoStep(t, h)` (Jacobi): `input_timing` = 1 fits.
    SameInstant,
    /// It hands over those of `t + h` (Gauss–Seidel): `input_timing` = 2 fits.
    NextInstant,
}

impl Phase {
    const ALL: [Phase; 5] =
        [Phase::Undecided, Phase::BeforeFirstStep, Phase::BeforeSecondStep, Phase::SameInstant, Phase::NextInstant];

    /// The tag an FMU state stores.
    pub fn tag(self) -> u8 {
        Self::ALL.iter().position(|p| *p == self).unwrap_or(0) as u8
    }

    /// The phase of a stored tag, if it is one.
    pub fn from_tag(tag: u8) -> Option<Self> {
        Self::ALL.get(usize::from(tag)).copied()
    }
}

/// The check of one instance.
#[derive(Debug, Clone, PartialEq)]
pub struct InputTimingCheck {
    phase: Phase,
    /// The row the next step's inputs are compared with: those standing at
    /// `fmi2ExitInitializationMode` (and equal, where compared, to the first step's).
    row: Vec<f64>,
    /// Per measurement row: set before `fmi2ExitInitializationMode`. A row
    /// never set there has no value to compare.
    compared: Vec<bool>,
}

/// Bit for bit, two NaN (a missing measurement) being the same whatever their payloads.
fn same_value(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

impl InputTimingCheck {
    /// Undecided, for `m` measurement rows.
    pub fn new(m: usize) -> Self {
        Self { phase: Phase::Undecided, row: vec![f64::NAN; m], compared: vec![false; m] }
    }

    /// Back to undecided (`fmi2Reset`).
    pub fn reset(&mut self) {
        self.phase = Phase::Undecided;
        self.row.fill(f64::NAN);
        self.compared.fill(false);
    }

    /// At `fmi2ExitInitializationMode`: `row` the measurements standing,
    /// `set` which of them the master has set.
    pub fn at_exit(&mut self, row: &[f64], set: &[bool]) {
        self.row.copy_from_slice(row);
        self.compared.copy_from_slice(set);
        self.phase = if set.iter().any(|&s| s) { Phase::BeforeFirstStep } else { Phase::Undecided };
    }

    /// At `fmi2DoStep` with the measurements `row` standing. Returns the
    /// verdict when this step makes it.
    pub fn at_step(&mut self, row: &[f64]) -> Option<Phase> {
        // Decided, or nothing to tell: later steps change nothing (and cost nothing).
        if !matches!(self.phase, Phase::BeforeFirstStep | Phase::BeforeSecondStep) {
            return None;
        }
        let unchanged = self.compared.iter().zip(&self.row).zip(row).all(|((&c, &a), &b)| !c || same_value(a, b));
        self.phase = match (self.phase, unchanged) {
            (Phase::BeforeFirstStep, false) => Phase::NextInstant,
            (Phase::BeforeFirstStep, true) => Phase::BeforeSecondStep,
            (_, false) => Phase::SameInstant,
            (_, true) => Phase::Undecided,
        };
        matches!(self.phase, Phase::SameInstant | Phase::NextInstant).then_some(self.phase)
    }

    /// The phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The `input_timing_check` output for an instance with `timing`.
    pub fn value(&self, timing: InputTiming) -> i32 {
        match (self.phase, timing) {
            (Phase::SameInstant, InputTiming::AtCommunicationPoint) | (Phase::NextInstant, InputTiming::AtStepEnd) => {
                FITS
            }
            (Phase::SameInstant, InputTiming::AtStepEnd) | (Phase::NextInstant, InputTiming::AtCommunicationPoint) => {
                OTHER_FITS
            }
            _ => UNDECIDED,
        }
    }

    /// What an FMU state saves: the phase, then per measurement row whether
    /// it is compared and the kept value.
    pub fn saved(&self) -> (Phase, &[bool], &[f64]) {
        (self.phase, &self.compared, &self.row)
    }

    /// Restores what [`InputTimingCheck::saved`] gave (of an instance with as many rows).
    pub fn restore(&mut self, phase: Phase, compared: &[bool], row: &[f64]) -> Result<(), String> {
        if compared.len() != self.compared.len() || row.len() != self.row.len() {
            return Err(format!(
                "the input timing check of the FMU state has {} rows, the FMU {}",
                row.len(),
                self.row.len()
            ));
        }
        self.phase = phase;
        self.compared.copy_from_slice(compared);
        self.row.copy_from_slice(row);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const JACOBI: [[f64; 2]; 3] = [[0.1, f64::NAN], [0.1, f64::NAN], [0.2, 0.3]];
    const GAUSS_SEIDEL: [[f64; 2]; 3] = [[0.1, f64::NAN], [0.2, 0.3], [0.4, 0.5]];

    /// Exit with `rows[0]` (all set), then a step per later row; the verdicts and the final phase.
    fn run(rows: &[[f64; 2]]) -> (Vec<Option<Phase>>, Phase) {
        let mut check = InputTimingCheck::new(2);
        check.at_exit(&rows[0], &[true, true]);
        let verdicts = rows[1..].iter().map(|r| check.at_step(r)).collect();
        (verdicts, check.phase())
    }

    #[test]
    fn a_jacobi_master_is_told_at_the_second_step_a_gauss_seidel_one_at_the_first() {
        assert_eq!(run(&JACOBI), (vec![None, Some(Phase::SameInstant)], Phase::SameInstant));
        assert_eq!(run(&GAUSS_SEIDEL), (vec![Some(Phase::NextInstant), None], Phase::NextInstant));
    }

    #[test]
    fn a_row_that_stands_still_or_was_never_set_tells_nothing() {
        let still = [[0.5, 0.5]; 3];
        assert_eq!(run(&still), (vec![None, None], Phase::Undecided));
        let mut check = InputTimingCheck::new(2);
        check.at_exit(&[f64::NAN; 2], &[false, false]);
        assert_eq!((check.at_step(&[1.0, 2.0]), check.phase()), (None, Phase::Undecided));
    }

    #[test]
    fn only_the_rows_set_in_initialisation_mode_are_compared_nan_equal_to_nan() {
        let mut check = InputTimingCheck::new(2);
        // The second row was never set: its value at the step is no evidence.
        check.at_exit(&[0.1, f64::NAN], &[true, false]);
        let other_nan = f64::from_bits(f64::NAN.to_bits() ^ 1);
        assert_eq!(check.at_step(&[0.1, 7.0]), None);
        assert_eq!(check.phase(), Phase::BeforeSecondStep);
        let mut check = InputTimingCheck::new(2);
        check.at_exit(&[0.1, f64::NAN], &[true, true]);
        assert_eq!(check.at_step(&[0.1, other_nan]), None);
        assert_eq!(check.phase(), Phase::BeforeSecondStep);
    }

    #[test]
    fn the_value_says_whether_the_set_timing_fits() {
        let mut check = InputTimingCheck::new(1);
        assert_eq!(check.value(InputTiming::AtCommunicationPoint), UNDECIDED);
        check.restore(Phase::SameInstant, &[true], &[0.0]).unwrap();
        assert_eq!((check.value(InputTiming::AtCommunicationPoint), check.value(InputTiming::AtStepEnd)), (1, 2));
        check.restore(Phase::NextInstant, &[true], &[0.0]).unwrap();
        assert_eq!((check.value(InputTiming::AtCommunicationPoint), check.value(InputTiming::AtStepEnd)), (2, 1));
        assert!(check.restore(Phase::NextInstant, &[true, true], &[0.0, 0.0]).is_err());
        for phase in Phase::ALL {
            assert_eq!(Phase::from_tag(phase.tag()), Some(phase));
        }
        assert_eq!(Phase::from_tag(5), None);
    }
}
