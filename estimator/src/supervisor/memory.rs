//! What the supervisor remembers between samples, as words for a driver's
//! saved state (an FMU state), and how those words are laid out.
//!
//! The memory describes itself: a header says what it is and what it is
//! for, then come the records, each a fixed list of named fields of one word
//! (counters as they are, flags as 0 or 1, floats by their bits):
//!
//! ```text
//! Header          tag, version, channels (m), channel_words, window (w)
//! Channel   × m   bad_run, rejected_run, faulty, rejected, stuck, since_reacquisition,
//!                 suspended, refuted, probation_run, since_change, last_value, repeats, step_multiple, step_run, inconsistent, wiring_run,
//!                 bias_evidence, bias_weight, scale_evidence, scale_weight, scale_norm,
//!                 offset_sum, offset_weight, fit_evidence, fit_e, fit_g, fit_norm, fit_offset, fit_weight,
//!                 prediction_mean, predictions
//! Reacquisition   lost_run, count, since_last, inflation, undone, restarts,
//!                 since_challenge
//! Cursor          next, filled
//! WindowEntry × w clipped_ratios, rows
//! Adaptation      log_scale, mean_ratio
//! Jumps           taken, retracted
//! ReviewHeader    active, kind, time, inputs, states
//! ReviewRow × m   explained
//! RivalHeader     active, hypothesis, clean_run, trigger, evidence, entries, kind, time, inputs, states
//! WindowEntry × w the rival's window entries (the first `entries` hold samples)
//! ClimateHeader   learnt, states
//! SignatureHeader time, states
//! then, as floats, the two beliefs under review (the fault hypothesis, then the
//! jump's), then the rival's: each its inputs, states means and states²
//! covariance words; then the climate's states means, states variances and
//! states mean variances of the filter; then, where signatures are kept, their
//! effects (states × 2m, column by column) and per channel their evidence (2),
//! information (3) and fit information (3)
//! ```
//!
//! The `record!` lines below are that table: a record's words are its fields
//! in the order listed, and each list must name every field of its struct
//! (it builds the struct back from them). The consistency verdict is not
//! saved: it is judged afresh from the window. The pending outcome of a gate
//! is not part of the memory.

use super::adaptation::Adaptation;
use super::channel::Channel;
use super::consistency::{Cursor, WindowEntry};
use super::jump::Jumps;
use super::reacquisition::Reacquisition;
use super::rival::Hypothesis;
use super::Supervisor;
use crate::error::FilterError;
use crate::filter::{FilterKind, Snapshot};

/// The first word of every supervisor memory.
const TAG: u64 = u64::from_le_bytes(*b"KFSUPMEM");

/// The layout's version: 2 is the self-describing one.
const VERSION: u64 = 10;

/// A value that is one word of the memory.
trait Word: Sized {
    /// What a valid word is, for the error messages.
    const VALID: &'static str;
    fn to_word(self) -> u64;
    /// `None` when the word is not a valid value.
    fn from_word(word: u64) -> Option<Self>;
}

impl Word for u64 {
    const VALID: &'static str = "a count";
    fn to_word(self) -> u64 {
        self
    }
    fn from_word(word: u64) -> Option<Self> {
        Some(word)
    }
}

impl Word for u32 {
    const VALID: &'static str = "a count below 2³²";
    fn to_word(self) -> u64 {
        u64::from(self)
    }
    fn from_word(word: u64) -> Option<Self> {
        u32::try_from(word).ok()
    }
}

impl Word for usize {
    const VALID: &'static str = "an index";
    fn to_word(self) -> u64 {
        self as u64
    }
    fn from_word(word: u64) -> Option<Self> {
        usize::try_from(word).ok()
    }
}

impl Word for i64 {
    const VALID: &'static str = "a signed count";
    fn to_word(self) -> u64 {
        self as u64
    }
    fn from_word(word: u64) -> Option<Self> {
        Some(word as i64)
    }
}

impl Word for bool {
    const VALID: &'static str = "a flag (0 or 1)";
    fn to_word(self) -> u64 {
        u64::from(self)
    }
    fn from_word(word: u64) -> Option<Self> {
        match word {
            0 => Some(false),
            1 => Some(true),
            _ => None,
        }
    }
}

impl Word for Hypothesis {
    const VALID: &'static str = "a rival's hypothesis (0 re-acquisition, 1 challenger, 2 jump fault, 3 release)";
    fn to_word(self) -> u64 {
        Hypothesis::ALL.iter().position(|h| *h == self).unwrap_or(0) as u64
    }
    fn from_word(word: u64) -> Option<Self> {
        usize::try_from(word).ok().and_then(|i| Hypothesis::ALL.get(i).copied())
    }
}

impl Word for f64 {
    const VALID: &'static str = "a float";
    fn to_word(self) -> u64 {
        self.to_bits()
    }
    fn from_word(word: u64) -> Option<Self> {
        Some(f64::from_bits(word))
    }
}

/// A struct saved as one word per field.
trait Record: Sized {
    /// The fields, in the order of their words.
    const FIELDS: &'static [&'static str];
    /// The number of words.
    const WORDS: usize = Self::FIELDS.len();
    /// Appends the record's words.
    fn save(&self, out: &mut Vec<u64>);
    /// The record from its [`Record::WORDS`] words; `what` names it in errors.
    fn load(words: &[u64], what: &str) -> Result<Self, FilterError>;
}

/// Declares a struct's record: its fields, in the order of their words.
macro_rules! record {
    ($record:ident { $($field:ident),+ $(,)? }) => {
        impl Record for $record {
            const FIELDS: &'static [&'static str] = &[$(stringify!($field)),+];
            fn save(&self, out: &mut Vec<u64>) {
                $(out.push(Word::to_word(self.$field));)+
            }
            fn load(words: &[u64], what: &str) -> Result<Self, FilterError> {
                let mut words = words.iter().copied();
                Ok(Self { $($field: field(words.next(), what, stringify!($field))?,)+ })
            }
        }
    };
}

/// What the memory is and what it is for.
struct Header {
    /// [`TAG`].
    tag: u64,
    /// [`VERSION`].
    version: u64,
    /// The supervisor's measurement channels.
    channels: u64,
    /// Words per channel record.
    channel_words: u64,
    /// Entries in the consistency window.
    window: u64,
}

record!(Header { tag, version, channels, channel_words, window });

/// The jump under review (`jump.rs`), and the size of its belief.
struct ReviewHeader {
    /// A jump awaits its review.
    active: bool,
    /// The belief's filter kind, as its position in `FilterKind::ALL`.
    kind: usize,
    /// The belief's time.
    time: f64,
    /// Its held inputs.
    inputs: usize,
    /// Its states (the covariance has their square).
    states: usize,
}

/// Whether a row's failure was explained by the jump under review.
struct ReviewRow {
    explained: bool,
}

/// The rival of a re-acquisition (`rival.rs`), and the size of its belief.
struct RivalHeader {
    /// A rival is alive.
    active: bool,
    /// What it stands for ([`Hypothesis::ALL`]'s index).
    hypothesis: Hypothesis,
    /// Samples in a row the filter's own update rejected no row (a jump's rival).
    clean_run: u32,
    /// The channel that triggered the re-acquisition.
    trigger: usize,
    /// The evidence for it so far (nats).
    evidence: f64,
    /// Its window entries since the fork.
    entries: usize,
    /// Its belief's filter kind, time and size, as the review's.
    kind: usize,
    time: f64,
    inputs: usize,
    states: usize,
}

/// Where the states have been (`restart.rs`): how much was learnt, for how many states.
struct ClimateHeader {
    learnt: u64,
    states: usize,
}

/// The fault signatures (`signature.rs`): the time of the belief they are
/// of, and the states of their effects (0: none kept).
struct SignatureHeader {
    time: f64,
    states: usize,
}

record!(ClimateHeader { learnt, states });
record!(SignatureHeader { time, states });
record!(ReviewHeader { active, kind, time, inputs, states });
record!(RivalHeader { active, hypothesis, clean_run, trigger, evidence, entries, kind, time, inputs, states });
record!(ReviewRow { explained });
record!(Adaptation { log_scale, mean_ratio });
record!(Jumps { taken, retracted });
record!(Channel {
    bad_run,
    rejected_run,
    faulty,
    rejected,
    stuck,
    since_reacquisition,
    suspended,
    refuted,
    probation_run,
    since_change,
    last_value,
    repeats,
    step_multiple,
    step_run,
    inconsistent,
    wiring_run,
    bias_evidence,
    bias_weight,
    scale_evidence,
    scale_weight,
    scale_norm,
    offset_sum,
    offset_weight,
    fit_evidence,
    fit_e,
    fit_g,
    fit_norm,
    fit_offset,
    fit_weight,
    prediction_mean,
    predictions,
});
record!(Reacquisition { lost_run, count, since_last, inflation, undone, restarts, since_challenge });
record!(Cursor { next, filled });
record!(WindowEntry { clipped_ratios, rows });

/// One field from its word.
fn field<T: Word>(word: Option<u64>, what: &str, name: &str) -> Result<T, FilterError> {
    let word = word.ok_or_else(|| invalid(format!("{what} is cut short before `{name}`")))?;
    T::from_word(word).ok_or_else(|| invalid(format!("{what}: `{name}` is {word}, not {}", T::VALID)))
}

fn invalid(why: String) -> FilterError {
    FilterError::InvalidSetting(format!("supervisor memory: {why}"))
}

/// `to` made a copy of `from`, in its own buffer.
fn refill(to: &mut Vec<f64>, from: &[f64]) {
    to.clear();
    to.extend_from_slice(from);
}

/// A saved belief of `inputs` inputs and `states` states, of filter kind and
/// time `at`, from its floats (inputs, means, covariance words).
fn fill_belief(belief: &mut Snapshot, at: (FilterKind, f64), inputs: usize, states: usize, floats: &[f64]) {
    let (input, rest) = floats.split_at(inputs);
    let (mean, covariance) = rest.split_at(states);
    (belief.kind, belief.time) = at;
    refill(&mut belief.input, input);
    refill(&mut belief.mean, mean);
    refill(&mut belief.covariance, covariance);
}

/// The words of `count` records of type `R` from `at`, and where the next part starts.
fn records<R: Record>(words: &[u64], at: usize, count: usize) -> (&[u64], usize) {
    let end = at + R::WORDS * count;
    (&words[at..end], end)
}

impl Supervisor {
    /// The length of this supervisor's memory in words.
    fn memory_words(&self) -> usize {
        let (m, w) = (self.channels.len(), self.window.saved().1.len());
        Header::WORDS
            + m * Channel::WORDS
            + Reacquisition::WORDS
            + Cursor::WORDS
            + w * WindowEntry::WORDS
            + Adaptation::WORDS
            + Jumps::WORDS
            + ReviewHeader::WORDS
            + m * ReviewRow::WORDS
            + RivalHeader::WORDS
            + w * WindowEntry::WORDS
            + ClimateHeader::WORDS
            + SignatureHeader::WORDS
    }

    /// The review's header as saved: the belief only while a jump awaits review.
    fn review_header(&self) -> ReviewHeader {
        let belief = &self.review.hypothesis;
        let active = self.review.active;
        ReviewHeader {
            active,
            kind: if active { FilterKind::ALL.iter().position(|k| *k == belief.kind).unwrap_or(0) } else { 0 },
            time: if active { belief.time } else { 0.0 },
            inputs: if active { belief.input.len() } else { 0 },
            states: if active { belief.mean.len() } else { 0 },
        }
    }

    /// The rival's header as saved: the belief only while a rival is alive.
    fn rival_header(&self) -> RivalHeader {
        let (rival, active) = (&self.rival, self.rival.active);
        let belief = &rival.belief;
        RivalHeader {
            active,
            hypothesis: if active { rival.hypothesis } else { Hypothesis::Reacquisition },
            clean_run: if active { rival.clean_run } else { 0 },
            trigger: if active { rival.trigger } else { 0 },
            evidence: if active { rival.evidence } else { 0.0 },
            entries: if active { rival.entries.len() } else { 0 },
            kind: if active { FilterKind::ALL.iter().position(|k| *k == belief.kind).unwrap_or(0) } else { 0 },
            time: if active { belief.time } else { 0.0 },
            inputs: if active { belief.input.len() } else { 0 },
            states: if active { belief.mean.len() } else { 0 },
        }
    }

    /// What the supervisor remembers between samples, as words (see the
    /// layout in `memory.rs`: a header, then named records), for a driver's
    /// saved state; the pending outcome is not part of it.
    /// [`Supervisor::load`] takes it back.
    pub fn save(&self, out: &mut Vec<u64>) {
        out.clear();
        let (cursor, entries) = self.window.saved();
        let header = Header {
            tag: TAG,
            version: VERSION,
            channels: self.channels.len() as u64,
            channel_words: Channel::WORDS as u64,
            window: entries.len() as u64,
        };
        header.save(out);
        for channel in &self.channels {
            channel.save(out);
        }
        self.reacquisition.save(out);
        cursor.save(out);
        for entry in entries {
            entry.save(out);
        }
        self.adaptation.save(out);
        self.jumps.save(out);
        let review = self.review_header();
        review.save(out);
        for &explained in &self.review.explained {
            ReviewRow { explained }.save(out);
        }
        let rival = self.rival_header();
        rival.save(out);
        for k in 0..entries.len() {
            let entry = if rival.active { self.rival.entries.get(k).copied() } else { None };
            entry.unwrap_or_default().save(out);
        }
        ClimateHeader { learnt: self.climate.learnt, states: self.climate.mean.len() }.save(out);
        let signatures = &self.signatures;
        SignatureHeader { time: signatures.time, states: signatures.effect.nrows() }.save(out);
        if review.active {
            for belief in [&self.review.hypothesis, &self.review.jumped] {
                for v in belief.input.iter().chain(&belief.mean).chain(&belief.covariance) {
                    out.push(v.to_bits());
                }
            }
        }
        if rival.active {
            let belief = &self.rival.belief;
            for v in belief.input.iter().chain(&belief.mean).chain(&belief.covariance) {
                out.push(v.to_bits());
            }
        }
        for v in self.climate.mean.iter().chain(&self.climate.variance).chain(&self.climate.doubt) {
            out.push(v.to_bits());
        }
        if signatures.effect.nrows() > 0 {
            let per_channel = signatures.evidence.iter().zip(&signatures.information).zip(&signatures.fit_information);
            let per_channel = per_channel.flat_map(|((a, b), f)| a.iter().chain(b).chain(f));
            for v in signatures.effect.iter().chain(per_channel) {
                out.push(v.to_bits());
            }
        }
    }

    /// Takes back what [`Supervisor::save`] wrote for a supervisor of the same
    /// size and window. A memory of another version, size or window, of
    /// another length than its header says, or with a value out of range, is
    /// refused with what does not match; on error nothing changes.
    pub fn load(&mut self, words: &[u64]) -> Result<(), FilterError> {
        let (m, w) = (self.channels.len(), self.window.saved().1.len());
        if words.len() < Header::WORDS {
            return Err(invalid(format!("{} words, fewer than its {}-word header", words.len(), Header::WORDS)));
        }
        let header = Header::load(&words[..Header::WORDS], "the header")?;
        if header.tag != TAG {
            return Err(invalid(format!("no supervisor memory: its first word is {:#018x}, not the tag", header.tag)));
        }
        if header.version != VERSION {
            return Err(invalid(format!("layout version {}, this supervisor reads version {VERSION}", header.version)));
        }
        if header.channels != m as u64 {
            return Err(invalid(format!("{} channels, this supervisor has {m}", header.channels)));
        }
        if header.channel_words != Channel::WORDS as u64 {
            return Err(invalid(format!(
                "{} words per channel, version {VERSION} has {}",
                header.channel_words,
                Channel::WORDS
            )));
        }
        if header.window != w as u64 {
            return Err(invalid(format!("a window of {} samples, this supervisor's settings have {w}", header.window)));
        }
        let fixed = self.memory_words();
        if words.len() < fixed {
            return Err(invalid(format!("{} words, its header says {fixed}", words.len())));
        }
        let signature_at = fixed - SignatureHeader::WORDS;
        let signature = SignatureHeader::load(&words[signature_at..fixed], "the signatures")?;
        let climate_at = signature_at - ClimateHeader::WORDS;
        let climate = ClimateHeader::load(&words[climate_at..signature_at], "the climate")?;
        let rival_at = climate_at - RivalHeader::WORDS - w * WindowEntry::WORDS;
        let review_at = rival_at - ReviewHeader::WORDS - m * ReviewRow::WORDS;
        let review = ReviewHeader::load(&words[review_at..review_at + ReviewHeader::WORDS], "the review")?;
        let rival = RivalHeader::load(&words[rival_at..rival_at + RivalHeader::WORDS], "the rival")?;
        let belief_words = 2 * (review.inputs + review.states + review.states * review.states);
        let rival_words = rival.inputs + rival.states + rival.states * rival.states;
        let climate_words = 3 * climate.states;
        let signature_words = if signature.states > 0 { signature.states * 2 * m + 8 * m } else { 0 };
        let expected = fixed + belief_words + rival_words + climate_words + signature_words;
        if words.len() != expected {
            return Err(invalid(format!("{} words, its header says {expected}", words.len())));
        }
        let Some(&kind) = FilterKind::ALL.get(review.kind) else {
            return Err(invalid(format!(
                "the review's filter kind {} is none of the {}",
                review.kind,
                FilterKind::ALL.len()
            )));
        };
        if !review.active && belief_words != 0 {
            return Err(invalid("a belief is saved with no jump under review".into()));
        }
        if !rival.active && rival_words != 0 {
            return Err(invalid("a rival's belief is saved with no rival alive".into()));
        }
        let Some(&rival_kind) = FilterKind::ALL.get(rival.kind) else {
            return Err(invalid(format!(
                "the rival's filter kind {} is none of the {}",
                rival.kind,
                FilterKind::ALL.len()
            )));
        };
        if rival.trigger >= m || rival.entries >= w.max(1) || !rival.evidence.is_finite() {
            return Err(invalid(format!(
                "the rival (trigger {}, {} entries, evidence {}) does not fit {m} channels and a {w}-sample window",
                rival.trigger, rival.entries, rival.evidence
            )));
        }

        let (channel_words, at) = records::<Channel>(words, Header::WORDS, m);
        let mut channels = self.channels.clone();
        for (c, (channel, words)) in channels.iter_mut().zip(channel_words.chunks_exact(Channel::WORDS)).enumerate() {
            *channel = Channel::load(words, &format!("channel {c}"))?;
        }
        let (reacquisition_words, at) = records::<Reacquisition>(words, at, 1);
        let reacquisition = Reacquisition::load(reacquisition_words, "the re-acquisition record")?;
        let max_inflation = self.settings.max_inflation;
        if !(reacquisition.inflation >= 1.0 && reacquisition.inflation <= max_inflation) {
            return Err(invalid(format!(
                "the inflation {} is outside [1, max_inflation = {max_inflation}]",
                reacquisition.inflation
            )));
        }
        let (cursor_words, at) = records::<Cursor>(words, at, 1);
        let cursor = Cursor::load(cursor_words, "the window's cursor")?;
        if !cursor.fits(w) {
            return Err(invalid(format!(
                "the window's cursor (next {}, filled {}) is not a position of a {w}-sample window",
                cursor.next, cursor.filled
            )));
        }
        let (entry_words, at) = records::<WindowEntry>(words, at, w);
        let mut entries = Vec::with_capacity(w);
        for (k, words) in entry_words.chunks_exact(WindowEntry::WORDS).enumerate() {
            let entry = WindowEntry::load(words, &format!("window entry {k}"))?;
            if !(entry.clipped_ratios >= 0.0 && entry.clipped_ratios.is_finite()) || entry.rows > m {
                return Err(invalid(format!(
                    "window entry {k} ({} over {} rows) is not a sum of normalised innovations of at most {m} rows",
                    entry.clipped_ratios, entry.rows
                )));
            }
            entries.push(entry);
        }
        let (adaptation_words, at) = records::<Adaptation>(words, at, 1);
        let adaptation = Adaptation::load(adaptation_words, "the adaptation")?;
        if !adaptation.fits(&self.settings) {
            return Err(invalid(format!(
                "the process-noise scale e^{} is outside [{}, {}]",
                adaptation.log_scale, self.settings.min_process_noise_scale, self.settings.max_process_noise_scale
            )));
        }
        let (jump_words, at) = records::<Jumps>(words, at, 1);
        let jumps = Jumps::load(jump_words, "the jump counts")?;
        let (row_words, at) = records::<ReviewRow>(words, at + ReviewHeader::WORDS, m);
        let mut explained = Vec::with_capacity(m);
        for (c, words) in row_words.chunks_exact(ReviewRow::WORDS).enumerate() {
            explained.push(ReviewRow::load(words, &format!("review row {c}"))?.explained);
        }
        let (rival_entry_words, at) = records::<WindowEntry>(words, at + RivalHeader::WORDS, w);
        let mut rival_entries = Vec::with_capacity(w);
        for (k, words) in rival_entry_words.chunks_exact(WindowEntry::WORDS).take(rival.entries).enumerate() {
            let entry = WindowEntry::load(words, &format!("rival window entry {k}"))?;
            if !(entry.clipped_ratios >= 0.0 && entry.clipped_ratios.is_finite()) || entry.rows > m {
                return Err(invalid(format!("rival window entry {k} is not a sum of at most {m} rows")));
            }
            rival_entries.push(entry);
        }
        let floats: Vec<f64> =
            words[at + ClimateHeader::WORDS + SignatureHeader::WORDS..].iter().map(|w| f64::from_bits(*w)).collect();
        let (review_floats, rest) = floats.split_at(belief_words);
        let (rival_floats, rest) = rest.split_at(rival_words);
        let (climate_floats, signature_floats) = rest.split_at(climate_words);
        if signature_floats.iter().any(|v| !v.is_finite()) {
            return Err(invalid("the signatures hold a value that is not finite".into()));
        }
        let (climate_mean, climate_variances) = climate_floats.split_at(climate.states);
        let (climate_variance, climate_doubt) = climate_variances.split_at(climate.states);
        if climate_mean.iter().any(|v| !v.is_finite())
            || climate_variances.iter().any(|v| !(*v >= 0.0 && v.is_finite()))
        {
            return Err(invalid(
                "the climate holds a mean that is not finite or a variance that is not a variance".into(),
            ));
        }
        let (hypothesis, jumped) = review_floats.split_at(belief_words / 2);

        self.channels = channels;
        self.adaptation = adaptation;
        self.jumps = jumps;
        self.review.active = review.active;
        self.review.explained = explained;
        if review.active {
            for (belief, floats) in [(&mut self.review.hypothesis, hypothesis), (&mut self.review.jumped, jumped)] {
                fill_belief(belief, (kind, review.time), review.inputs, review.states, floats);
            }
        }
        self.rival.active = rival.active;
        self.rival.hypothesis = rival.hypothesis;
        self.rival.clean_run = rival.clean_run;
        (self.rival.trigger, self.rival.evidence) = (rival.trigger, rival.evidence);
        self.rival.entries.clear();
        self.rival.entries.extend_from_slice(&rival_entries);
        if rival.active {
            let belief = &mut self.rival.belief;
            fill_belief(belief, (rival_kind, rival.time), rival.inputs, rival.states, rival_floats);
        }
        self.climate.learnt = climate.learnt;
        refill(&mut self.climate.mean, climate_mean);
        refill(&mut self.climate.variance, climate_variance);
        refill(&mut self.climate.doubt, climate_doubt);
        self.reacquisition = reacquisition;
        self.window.restore(cursor, &entries);
        self.signatures.load(signature.time, signature.states, m, signature_floats);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_record_lists_its_fields_once() {
        fn unique(fields: &[&str]) -> bool {
            fields.iter().enumerate().all(|(i, f)| !fields[..i].contains(f))
        }
        assert!(unique(Header::FIELDS) && unique(Channel::FIELDS) && unique(Reacquisition::FIELDS));
        assert!(unique(Cursor::FIELDS) && unique(WindowEntry::FIELDS));
    }

    #[test]
    fn a_record_is_saved_as_many_words_as_it_has_fields_and_loads_back() {
        let channel = Channel {
            bad_run: 1,
            rejected_run: 2,
            faulty: true,
            rejected: 4,
            stuck: 5,
            since_reacquisition: 6,
            suspended: true,
            refuted: true,
            probation_run: 3,
            since_change: 7,
            last_value: 1.5f64.to_bits(),
            repeats: 9,
            step_multiple: -3,
            step_run: 11,
            inconsistent: true,
            wiring_run: 12,
            bias_evidence: -13.5,
            bias_weight: 14.0,
            scale_evidence: 15.0,
            scale_weight: 16.0,
            scale_norm: 17.0,
            offset_sum: 19.0,
            offset_weight: 20.0,
            fit_evidence: 20.5,
            fit_e: 20.0625,
            fit_g: -20.03125,
            fit_norm: 20.25,
            fit_offset: -20.75,
            fit_weight: 20.125,
            prediction_mean: -21.0,
            predictions: 22,
        };
        let mut words = Vec::new();
        channel.save(&mut words);
        assert_eq!(words.len(), Channel::WORDS);
        assert_eq!(words.len(), 31);
        assert_eq!(Channel::load(&words, "channel 0").unwrap(), channel);
    }

    #[test]
    fn a_bad_field_is_named_in_the_error() {
        let mut words = Vec::new();
        Channel::new().save(&mut words);
        words[Channel::FIELDS.iter().position(|f| *f == "suspended").unwrap()] = 2;
        let error = Channel::load(&words, "channel 3").unwrap_err().to_string();
        assert!(error.contains("channel 3: `suspended` is 2, not a flag (0 or 1)"), "{error}");
    }
}
