//! The supervisor's saved memory as a specification: it describes itself (a
//! header of tag, version, channel count, words per channel and window
//! length, then named records), it continues exactly after a round trip, and
//! a memory of another size, window or version, of the wrong length or with
//! a corrupted word is refused with what does not match, changing nothing.

mod common;

use common::*;
use estimator::{build_filter, FilterKind, Noise, StateEstimator, Supervisor, SupervisorSettings, UnscentedParams};

/// The layout as documented in `supervisor/memory.rs`, by field name.
const HEADER: [&str; 5] = ["tag", "version", "channels", "channel_words", "window"];
const CHANNEL: [&str; 31] = [
    "bad_run",
    "rejected_run",
    "faulty",
    "rejected",
    "stuck",
    "since_reacquisition",
    "suspended",
    "refuted",
    "probation_run",
    "since_change",
    "last_value",
    "repeats",
    "step_multiple",
    "step_run",
    "inconsistent",
    "wiring_run",
    "bias_evidence",
    "bias_weight",
    "scale_evidence",
    "scale_weight",
    "scale_norm",
    "offset_sum",
    "offset_weight",
    "fit_evidence",
    "fit_e",
    "fit_g",
    "fit_norm",
    "fit_offset",
    "fit_weight",
    "prediction_mean",
    "predictions",
];
const REACQUISITION: [&str; 7] =
    ["lost_run", "count", "since_last", "inflation", "undone", "restarts", "since_challenge"];
const CURSOR: [&str; 2] = ["next", "filled"];
const WINDOW_ENTRY: [&str; 2] = ["clipped_ratios", "rows"];
const RIVAL_HEADER: [&str; 10] =
    ["active", "hypothesis", "clean_run", "trigger", "evidence", "entries", "kind", "time", "inputs", "states"];

fn position(fields: &[&str], name: &str) -> usize {
    fields.iter().position(|f| *f == name).unwrap_or_else(|| panic!("no field {name}"))
}

fn header_word(name: &str) -> usize {
    position(&HEADER, name)
}

fn channel_word(channel: usize, name: &str) -> usize {
    HEADER.len() + channel * CHANNEL.len() + position(&CHANNEL, name)
}

fn reacquisition_word(m: usize, name: &str) -> usize {
    HEADER.len() + m * CHANNEL.len() + position(&REACQUISITION, name)
}

fn cursor_word(m: usize, name: &str) -> usize {
    HEADER.len() + m * CHANNEL.len() + REACQUISITION.len() + position(&CURSOR, name)
}

fn entry_word(m: usize, entry: usize, name: &str) -> usize {
    HEADER.len()
        + m * CHANNEL.len()
        + REACQUISITION.len()
        + CURSOR.len()
        + entry * WINDOW_ENTRY.len()
        + position(&WINDOW_ENTRY, name)
}

fn filter(kind: FilterKind, case: &LinearCase) -> Box<dyn StateEstimator> {
    let noise = Noise::new(case.q.clone(), case.r.clone()).unwrap();
    build_filter(kind, case.model.clone(), noise, &case.prior, UnscentedParams::default()).unwrap()
}

/// The fixed supervisor (no jumps, `Q` as given): these memories hold
/// rejections and re-acquisitions; `jumps_and_adaptation.rs` saves one with a
/// jump under review and an adapted scale.
fn settings(window: usize) -> SupervisorSettings {
    // With the wiring checks and their signatures, whose sums are memory too.
    SupervisorSettings { window, wiring_sigmas: 8.0, wiring_signatures: true, ..SupervisorSettings::default().fixed() }
}

/// A supervisor of 3 channels after 150 samples with spikes (rejections),
/// a stuck stretch and a missing row, on a filter of `kind`.
fn busy(kind: FilterKind, window: usize) -> (Box<dyn StateEstimator>, Supervisor, LinearCase) {
    let case = linear_case(300, 31);
    let (mut f, mut s) = (filter(kind, &case), Supervisor::new(settings(window), 3).unwrap());
    for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate().take(150) {
        let mut z = z.clone();
        if k % 17 == 3 {
            z[0] += 400.0;
        }
        if (60..90).contains(&k) {
            z[2] = 0.75;
        }
        if k % 11 == 0 {
            z[1] = f64::NAN;
        }
        f.predict(u, 0.01).unwrap();
        s.gate(f.as_mut(), &z).unwrap();
        s.commit(|_| {});
    }
    (f, s, case)
}

fn saved(s: &Supervisor) -> Vec<u64> {
    let mut words = Vec::new();
    s.save(&mut words);
    words
}

fn refusal(words: &[u64], window: usize) -> String {
    let mut fresh = Supervisor::new(settings(window), 3).unwrap();
    let before = saved(&fresh);
    let error = fresh.load(words).expect_err("the memory must be refused").to_string();
    assert_eq!(saved(&fresh), before, "a refused memory changes nothing ({error})");
    error
}

#[test]
fn the_memory_starts_with_a_header_that_says_what_it_is_and_what_it_is_for() {
    let (_, s, _) = busy(FilterKind::Ckf, 50);
    let words = saved(&s);
    assert_eq!(words[header_word("tag")].to_le_bytes(), *b"KFSUPMEM");
    assert_eq!(words[header_word("version")], 10);
    assert_eq!(words[header_word("channels")], 3);
    assert_eq!(words[header_word("channel_words")], CHANNEL.len() as u64);
    assert_eq!(words[header_word("window")], 50);
    // After the window's entries: the adaptation (2 words), the jump counts (2),
    // the review's header (5) and a flag per channel, the rival's header and its
    // window of entries, the climate's header (2), the signatures' header (2),
    // the climate's means, variances and mean filter variances of the 4 states,
    // and the signatures' effects (4 states × 2 per channel) and 8 sums per
    // channel; no belief, with no jump under review and no rival.
    let tail = entry_word(3, 50, "clipped_ratios");
    let rival = tail + 2 + 2 + 5 + 3;
    let climate = rival + RIVAL_HEADER.len() + 50 * WINDOW_ENTRY.len();
    assert_eq!(words.len(), climate + 2 + 2 + 3 * 4 + 4 * 2 * 3 + 8 * 3, "the signatures end the memory");
    assert_eq!(words[climate + 1], 4, "the climate of 4 states");
    assert_eq!(words[climate + 3], 4, "signatures of 4 states");
    assert_eq!(words[rival + position(&RIVAL_HEADER, "active")], 0, "the fixed supervisor keeps no rival");
    assert_eq!(f64::from_bits(words[tail]), 0.0, "ln of the process-noise scale: not adapted");
    // The named fields hold what the supervisor reports.
    for (c, channel) in s.channels().iter().enumerate() {
        assert_eq!(words[channel_word(c, "rejected")], channel.rejected, "channel {c}");
        assert_eq!(words[channel_word(c, "stuck")], channel.stuck, "channel {c}");
        assert_eq!(words[channel_word(c, "faulty")], u64::from(channel.faulty), "channel {c}");
    }
    assert!(s.channels()[0].rejected > 0 && s.channels()[2].stuck > 0, "the run has rejections and a stuck stretch");
    assert_eq!(words[reacquisition_word(3, "count")], s.reacquisitions());
    assert_eq!(f64::from_bits(words[reacquisition_word(3, "inflation")]), 1.0);
    assert_eq!(words[cursor_word(3, "filled")], 50, "150 samples fill a window of 50");
    assert_eq!(words[cursor_word(3, "next")], 0, "and wrap it three times");
}

#[test]
fn a_memory_loaded_into_a_fresh_supervisor_saves_the_same_words_and_continues_exactly() {
    for kind in FilterKind::ALL {
        let (mut f, mut s, case) = busy(kind, 50);
        let words = saved(&s);
        let mut t = Supervisor::new(settings(50), 3).unwrap();
        t.load(&words).unwrap();
        assert_eq!(saved(&t), words, "{kind}");
        assert_eq!((t.consistent(), t.windowed_nis().to_bits()), (s.consistent(), s.windowed_nis().to_bits()));
        let mut g = filter(kind, &case);
        g.restore(&f.snapshot()).unwrap();
        let reacquired_before = s.reacquisitions();
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate().skip(150) {
            let mut z = z.clone();
            z[1] += 0.1 * (k - 150) as f64; // a drift: rejections, then re-acquisitions
            f.predict(u, 0.01).unwrap();
            g.predict(u, 0.01).unwrap();
            let a = s.gate(f.as_mut(), &z).unwrap().clone();
            let b = t.gate(g.as_mut(), &z).unwrap().clone();
            assert_eq!(a, b, "{kind}");
            s.commit(|_| {});
            t.commit(|_| {});
            assert_eq!(saved(&s), saved(&t), "{kind}");
        }
        assert!(s.reacquisitions() > reacquired_before, "{kind}: the drift must make the supervisor re-acquire");
    }
}

#[test]
fn a_memory_of_another_channel_count_window_or_version_is_refused_saying_so() {
    let (_, s, _) = busy(FilterKind::SrCkf, 50);
    let words = saved(&s);
    let error = refusal(&words, 40);
    assert!(error.contains("a window of 50 samples, this supervisor's settings have 40"), "{error}");
    let four = Supervisor::new(settings(50), 4).unwrap();
    let mut other = four.clone();
    let error = other.load(&words).unwrap_err().to_string();
    assert!(error.contains("3 channels, this supervisor has 4"), "{error}");
    let error = refusal(&saved(&four), 50);
    assert!(error.contains("4 channels, this supervisor has 3"), "{error}");
    let mut older = words.clone();
    older[header_word("version")] = 1;
    let error = refusal(&older, 50);
    assert!(error.contains("layout version 1, this supervisor reads version 10"), "{error}");
    let mut wider = words.clone();
    wider[header_word("channel_words")] = 12;
    let error = refusal(&wider, 50);
    assert!(error.contains("12 words per channel"), "{error}");
    // The positional layout before the header: its first word is a channel's bad run.
    let error = refusal(&words[HEADER.len()..], 50);
    assert!(error.contains("no supervisor memory"), "{error}");
}

#[test]
fn a_memory_of_the_wrong_length_is_refused_saying_so() {
    let (_, s, _) = busy(FilterKind::Ukf, 50);
    let words = saved(&s);
    let error = refusal(&words[..words.len() - 1], 50);
    assert!(error.contains(&format!("{} words, its header says {}", words.len() - 1, words.len())), "{error}");
    let longer: Vec<u64> = words.iter().copied().chain([0]).collect();
    let error = refusal(&longer, 50);
    assert!(error.contains(&format!("{} words, its header says {}", words.len() + 1, words.len())), "{error}");
    let error = refusal(&words[..3], 50);
    assert!(error.contains("3 words, fewer than its 5-word header"), "{error}");
    assert!(refusal(&[], 50).contains("0 words"));
}

#[test]
fn a_corrupted_word_is_refused_naming_the_field() {
    let (_, s, _) = busy(FilterKind::Ekf, 50);
    let words = saved(&s);
    let corrupt = |at: usize, value: u64| {
        let mut bad = words.clone();
        bad[at] = value;
        refusal(&bad, 50)
    };
    let error = corrupt(channel_word(1, "faulty"), 7);
    assert!(error.contains("channel 1: `faulty` is 7, not a flag (0 or 1)"), "{error}");
    let error = corrupt(channel_word(2, "suspended"), 2);
    assert!(error.contains("channel 2: `suspended` is 2"), "{error}");
    let error = corrupt(channel_word(0, "bad_run"), 1 << 40);
    assert!(error.contains("channel 0: `bad_run` is 1099511627776, not a count below 2³²"), "{error}");
    let error = corrupt(reacquisition_word(3, "since_last"), u64::MAX);
    assert!(error.contains("`since_last`"), "{error}");
    for inflation in [0.5, f64::NAN, 1e9] {
        let error = corrupt(reacquisition_word(3, "inflation"), inflation.to_bits());
        assert!(error.contains("inflation") && error.contains("max_inflation"), "{inflation}: {error}");
    }
    let error = corrupt(cursor_word(3, "next"), 50);
    assert!(error.contains("the window's cursor (next 50, filled 50)"), "{error}");
    let error = corrupt(cursor_word(3, "filled"), 51);
    assert!(error.contains("filled 51"), "{error}");
    let error = corrupt(entry_word(3, 7, "rows"), 4);
    assert!(error.contains("window entry 7") && error.contains("at most 3 rows"), "{error}");
    for sum in [-1.0, f64::NAN, f64::INFINITY] {
        let error = corrupt(entry_word(3, 9, "clipped_ratios"), f64::to_bits(sum));
        assert!(error.contains("window entry 9"), "{sum}: {error}");
    }
}

#[test]
fn a_window_not_yet_full_must_continue_right_after_its_last_sample() {
    // After 30 samples a window of 50 has 30 entries, and the next sample goes to entry 30.
    let case = linear_case(30, 32);
    let (mut f, mut s) = (filter(FilterKind::Ckf, &case), Supervisor::new(settings(50), 3).unwrap());
    for (u, z) in case.inputs.iter().zip(&case.measurements) {
        f.predict(u, 0.01).unwrap();
        s.gate(f.as_mut(), z).unwrap();
        s.commit(|_| {});
    }
    let words = saved(&s);
    assert_eq!((words[cursor_word(3, "next")], words[cursor_word(3, "filled")]), (30, 30));
    let mut bad = words.clone();
    bad[cursor_word(3, "next")] = 12;
    let error = refusal(&bad, 50);
    assert!(error.contains("not a position of a 50-sample window"), "{error}");
    assert!(Supervisor::new(settings(50), 3).unwrap().load(&words).is_ok());
}

/// A re-acquisition's rival (`rival.rs`) is part of the memory while it is
/// weighed: a supervisor loaded mid-way decides as the one saved does.
#[test]
fn a_memory_saved_while_a_rival_is_weighed_continues_exactly() {
    for kind in FilterKind::ALL {
        let case = linear_case(300, 33);
        let settings = SupervisorSettings { window: 50, revise: true, ..SupervisorSettings::default().fixed() };
        let (mut f, mut s) = (filter(kind, &case), Supervisor::new(settings, 3).unwrap());
        let mut saved_mid_way = None;
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
            let mut z = z.clone();
            if (100..115).contains(&k) {
                z[0] += if k % 2 == 0 { 400.0 } else { -400.0 };
            }
            f.predict(u, 0.01).unwrap();
            if let Some((g, t)) = saved_mid_way.as_mut() {
                let (g, t): (&mut Box<dyn StateEstimator>, &mut Supervisor) = (g, t);
                g.predict(u, 0.01).unwrap();
                let b = t.gate(g.as_mut(), &z).unwrap().clone();
                assert_eq!(s.gate(f.as_mut(), &z).unwrap(), &b, "{kind} at {k}");
                t.commit(|_| {});
            } else {
                s.gate(f.as_mut(), &z).unwrap();
            }
            s.commit(|_| {});
            if s.revising() && saved_mid_way.is_none() {
                let mut t = Supervisor::new(settings, 3).unwrap();
                t.load(&saved(&s)).unwrap();
                assert_eq!(saved(&t), saved(&s), "{kind}");
                let mut g = filter(kind, &case);
                g.restore(&f.snapshot()).unwrap();
                saved_mid_way = Some((g, t));
            }
        }
        let (_, t) = saved_mid_way.unwrap_or_else(|| panic!("{kind}: the burst must make the supervisor re-acquire"));
        assert_eq!(saved(&t), saved(&s), "{kind}");
        assert_eq!(t.undone_reacquisitions(), s.undone_reacquisitions(), "{kind}");
        assert_eq!(s.undone_reacquisitions(), 1, "{kind}: the burst's re-acquisition is undone");
    }
}
