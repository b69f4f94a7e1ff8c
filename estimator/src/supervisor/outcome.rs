//! What one gated sample gives: the fate of each row, the update made, and
//! the fault-flag changes its commit reports.

/// What became of one measurement row in an update.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowOutcome {
    /// Not finite in `z`: left out.
    Missing,
    /// Used.
    Used,
    /// Failed the gate: left out.
    Rejected,
    /// Repeated its value `stuck_after` times: left out.
    Stuck,
    /// Its wiring is inconsistent with the other channels (`wiring.rs`) and
    /// the supervisor leaves such channels out
    /// ([`SupervisorSettings::wiring_leaves_out`](crate::SupervisorSettings::wiring_leaves_out)).
    Inconsistent,
}

/// What became of the rival a re-acquisition set aside (`rival.rs`) at a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Revision {
    /// No rival was alive.
    None,
    /// Both beliefs were scored; the data have not decided yet. The evidence
    /// this sample added for the rival (nats).
    Weighed(f64),
    /// The re-acquired belief won: the rival is dropped.
    Confirmed,
    /// The rival won: the re-acquisition that `trigger` (a row of `z`) set
    /// off is undone, and this update is the rival's.
    Undone {
        /// The channel whose failures triggered the re-acquisition.
        trigger: usize,
    },
    /// The rival won: the jump that `trigger` alone explained, which its
    /// review had confirmed, is undone (the sensor, not the state, had
    /// changed), and this update is the rival's.
    JumpUndone {
        /// The channel whose failure the jump explained.
        trigger: usize,
    },
    /// The challenger of an inconsistent filter (started from where the
    /// states have been) won: the filter restarts, and this update is the
    /// challenger's.
    Restarted,
}

/// The outcome of one gated update.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Per row of `z`.
    pub rows: Vec<RowOutcome>,
    /// The covariance was inflated and every row used; the channel whose
    /// persistent failure triggered it.
    pub reacquired: Option<usize>,
    /// The factor the covariance was inflated by (1 without a re-acquisition).
    pub inflation: f64,
    /// NIS of the update made (0 without rows).
    pub nis: f64,
    /// Its degrees of freedom: the rows used.
    pub dof: usize,
    /// The largest normalised innovation `νᵢ²/Sᵢᵢ` of the first pass (all
    /// available rows), 0 without rows.
    pub worst_ratio: f64,
    /// The first pass's normalised innovations, each clipped at the gate, summed.
    pub clipped_ratios: f64,
    /// How many rows that sum has.
    pub gated_rows: usize,
    /// Per row: the bias step taken (0 for none; see [`QuantizedSteps`](crate::QuantizedSteps)).
    pub steps: Vec<f64>,
    /// The factor `c` of the jump taken (`P + c·Q`, see `jump.rs`), 0 for none.
    pub jump: f64,
    /// Per row: its failure was explained by that jump and it was used.
    pub explained: Vec<bool>,
    /// One row alone explained it: the jump is reviewed at the next sample.
    /// The belief shown is the mixture of the jump and the fault hypothesis
    /// (the fault's mean), unless [`Outcome::continued`].
    pub ambiguous: bool,
    /// That row's change was under way (a jump of it confirmed within
    /// [`SupervisorSettings::change_memory`](crate::SupervisorSettings::change_memory)
    /// samples): the belief shown is the jump's.
    pub continued: bool,
    /// The jump of the previous sample was reviewed at this one.
    pub reviewed: bool,
    /// Per row: the review found the previous sample's jump a gross error of
    /// this row, which counts as rejected at the commit (one sample late);
    /// this update started from the belief without it.
    pub retracted: Vec<bool>,
    /// The first pass's normalised innovations of the rows finally used, each
    /// clipped (the adaptation's evidence, `adaptation.rs`), summed.
    pub adaptation_ratios: f64,
    /// Their shares `(Sᵢᵢ − rᵢ)/Sᵢᵢ` of the innovation variance that `P` makes, summed.
    pub adaptation_share: f64,
    /// How many rows those sums have.
    pub adaptation_rows: usize,
    /// A re-acquisition at this sample kept the update the gate alone would
    /// have made as its rival (`rival.rs`).
    pub forked: bool,
    /// The rival forked at this sample is a challenger of the inconsistent
    /// filter, started from where the states have been (`rival.rs`).
    pub challenged: bool,
    /// The rival forked at this sample is the fault hypothesis of a jump that
    /// one row alone explained, which its review has just confirmed (`rival.rs`).
    pub jump_forked: Option<usize>,
    /// A refuted channel used again at this sample, its probation passed
    /// (`channel.rs`); the belief without it is forked as the rival.
    pub released: Option<usize>,
    /// What became of the rival of an earlier re-acquisition or challenge.
    pub revision: Revision,
    /// The filter restarted at this sample (`restart.rs`) before its update.
    pub restarted: bool,
    /// Per row: the multiple its rejected innovations sit at and how many in
    /// a row, for the channel to remember at the commit.
    pub(super) watch: Vec<(i64, u32)>,
}

impl Outcome {
    /// This update is a rival's that undid a re-acquisition (`rival.rs`).
    pub fn undone(&self) -> bool {
        matches!(self.revision, Revision::Undone { .. })
    }

    /// This update is a rival's: a re-acquisition undone, or a challenger
    /// that restarted the filter.
    pub fn replaced(&self) -> bool {
        matches!(self.revision, Revision::Undone { .. } | Revision::JumpUndone { .. } | Revision::Restarted)
    }

    /// The outcome before any sample, for `m` rows: all missing, nothing done.
    pub(super) fn none(m: usize) -> Self {
        Self {
            rows: vec![RowOutcome::Missing; m],
            reacquired: None,
            inflation: 1.0,
            nis: 0.0,
            dof: 0,
            worst_ratio: 0.0,
            clipped_ratios: 0.0,
            gated_rows: 0,
            steps: vec![0.0; m],
            jump: 0.0,
            explained: vec![false; m],
            ambiguous: false,
            continued: false,
            reviewed: false,
            retracted: vec![false; m],
            adaptation_ratios: 0.0,
            adaptation_share: 0.0,
            adaptation_rows: 0,
            forked: false,
            challenged: false,
            jump_forked: None,
            released: None,
            revision: Revision::None,
            restarted: false,
            watch: vec![(0, 0); m],
        }
    }

    /// The gate rejected none of the rows.
    pub(super) fn rejected_none(&self) -> bool {
        !self.rows.contains(&RowOutcome::Rejected)
    }

    /// Rows were available (not missing) and the update used none of them.
    pub(super) fn nothing_used(&self) -> bool {
        self.rows.iter().any(|r| *r != RowOutcome::Missing) && self.dof == 0
    }
}

/// A change of a channel's fault flag, for a driver to report once per episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FaultChange {
    /// The channel (row of `z`).
    pub channel: usize,
    /// Faulty from now on (`true`) or again good (`false`).
    pub faulty: bool,
}
