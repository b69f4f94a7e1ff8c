//! S4's scoring and the paper's pipeline do what `studies::s4::metrics` and
//! `studies::s4::paper` say: the metrics give the mean, maximum and ranges of hand-made
//! series; a raw speed is scored against our true speed at the telegram it is known, off
//! by its lag alone (≤ |acc|·Δt/2) and by nothing against the paper's truth; the ETCS band
//! runs from ±2 km/h to ±12 km/h; detections and false alarms count as defined, and a
//! fault's effect is exactly where the simulator puts it; the paper's pipeline fuses
//! better than the raw average and its UKF (a scalar Kalman filter) is smoother.

use studies::s4::metrics::{
    effect_telegrams, etcs_speed_band, fraction_in_band, reduction, score_detection, score_position, score_speed,
    true_position_for_samples, true_speed_for_samples, DetectionScore, DetectionSettings, SpeedScore, FAULT_KINDS,
};
use studies::s4::paper::{raw_average, run_paper, PaperRun, PaperSettings};
use truth::s4::channels::{simulate, Channel};
use truth::s4::faults::{Fault, FaultKind, Faults};
use truth::s4::parameters::{SLOT_PITCH, TELEGRAM_INTERVAL};
use truth::s4::profile::Profile;

const DT: f64 = TELEGRAM_INTERVAL;
const KMH: f64 = 1.0 / 3.6;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn speed_metrics_give_the_mean_of_the_absolute_error_its_maximum_and_the_ranges() {
    let truth = [0.0, 1.0, 2.0, 3.0, 2.0];
    let estimate = [0.5, 0.5, 2.0, 4.0, f64::NAN];
    // Errors 0.5, −0.5, 0, 1 (the NaN is left out).
    let s = score_speed(&estimate, &truth);
    assert_eq!((s.error.n, s.error.missing), (4, 1));
    assert!(close(s.mean_abs_error, 0.5, 1e-15), "mean |e| {}", s.mean_abs_error);
    assert!(close(s.mean_error, 0.25, 1e-15), "signed mean {}", s.mean_error);
    assert!(close(s.error.rms, (1.5f64 / 4.0).sqrt(), 1e-15));
    assert_eq!(s.max_abs_error, 1.0);
    assert_eq!(s.error_range, 1.5, "max e − min e = 1 − (−0.5)");
    assert_eq!(s.speed_range, 3.5, "max − min of the estimate: 4 − 0.5");
    assert_eq!(s.true_range, 3.0, "of the truth over the same samples");

    // A constant bias: mean |e| = bias, error range 0, the speed range the truth's.
    let biased: Vec<f64> = truth.iter().map(|t| t - 0.2).collect();
    let b = score_speed(&biased, &truth);
    assert!(close(b.mean_abs_error, 0.2, 1e-15) && close(b.mean_error, -0.2, 1e-15));
    assert!(b.error_range.abs() < 1e-15 && close(b.speed_range, b.true_range, 1e-15));

    // Position: mean and largest |e|.
    let p = score_position(&[10.0, 20.5, 29.0], &[10.0, 20.0, 30.0]);
    assert!(close(p.mean_abs, 0.5, 1e-15) && p.max_abs == 1.0, "{p:?}");

    // The paper's reductions are (before − after)/before: 11.09 → 5.62 m/s is its −49.3 %.
    assert!(close(reduction(11.09, 5.62), 0.493, 5e-4));
    assert!(close(reduction(0.12, 0.06), 0.5, 1e-15));
}

#[test]
#[should_panic(expected = "aligned")]
fn series_of_different_lengths_are_refused() {
    score_speed(&[1.0, 2.0], &[1.0]);
}

/// The largest |acceleration| at either end of each telegram interval.
fn interval_acceleration(recording: &truth::s4::recording::Recording) -> Vec<f64> {
    recording.truth.windows(2).map(|w| w[0].acceleration.abs().max(w[1].acceleration.abs())).collect()
}

#[test]
fn a_noise_free_raw_speed_errs_by_its_lag_alone_against_our_truth_and_not_at_all_against_the_papers() {
    let noise_free = Faults { noise_std: 0.0, ..Faults::none() };
    for (name, profile) in [("paper", Profile::paper()), ("high-speed", Profile::high_speed())] {
        let recording = simulate(&profile, &noise_free, 1);
        let ours = true_speed_for_samples(&recording);
        let papers = recording.paper_true_speed();
        let acc = interval_acceleration(&recording);
        assert_eq!(ours.len(), recording.n_telegrams() - 1, "one truth per speed sample");
        // Rounding of positions of up to tens of km, differenced over 0.02 s.
        let far = recording.truth.last().unwrap().position.abs().max(1.0);
        let rounding = 8.0 * f64::EPSILON * far / DT;
        let mut largest_lag = 0.0f64;
        for c in Channel::ALL {
            let raw = recording.raw_speed(c);
            for a in 0..raw.len() {
                let lag = raw[a] - ours[a];
                assert!(lag.abs() <= acc[a] * DT / 2.0 + rounding, "{name} {c:?} a = {a}: {lag} vs {}", acc[a]);
                assert!((raw[a] - papers[a]).abs() <= rounding, "{name} {c:?} a = {a}: {} vs {}", raw[a], papers[a]);
                largest_lag = largest_lag.max(lag.abs());
            }
        }
        // The bound is reached: the raw speed is scored at the end of its interval, where
        // it lags by acc·Δt/2 under constant acceleration (not at its middle, where it is exact).
        let steepest = acc.iter().cloned().fold(0.0, f64::max);
        assert!(largest_lag > 0.9 * steepest * DT / 2.0, "{name}: largest lag {largest_lag}, steepest {steepest}");
        // The same for the raw average, and the mean of the four positions is the reference position.
        let avg = score_speed(&raw_average(&recording), &ours);
        assert!(avg.max_abs_error <= steepest * DT / 2.0 + rounding, "{name}: {avg:?}");
        let run = run_paper(&recording, &PaperSettings::default()).unwrap();
        let position = score_position(&run.position, &true_position_for_samples(&recording));
        assert!(position.max_abs <= 8.0 * f64::EPSILON * far, "{name}: {position:?}");
    }
}

#[test]
fn the_etcs_band_is_2_km_h_up_to_30_km_h_rising_linearly_to_12_km_h_at_500_km_h() {
    let at = |kmh: f64| etcs_speed_band(kmh * KMH) / KMH;
    let tol = 1e-12;
    assert!(close(at(0.0), 2.0, tol));
    assert!(close(at(10.0), 2.0, tol));
    assert!(close(at(30.0), 2.0, tol));
    assert!(close(at(500.0), 12.0, tol));
    assert!(close(at(265.0), 7.0, tol), "the middle of 30…500 km/h: {}", at(265.0));
    assert!(close(at(77.0), 3.0, tol), "one tenth of the way: {}", at(77.0));
    assert!(close(at(-265.0), 7.0, tol), "symmetric in the sign of the speed");
    assert!(close(at(600.0), 12.0, tol), "held beyond 500 km/h");
    // Continuous and non-decreasing.
    let mut last = at(0.0);
    for i in 0..=6000 {
        let b = at(i as f64 * 0.1);
        assert!(b >= last - 1e-12 && b - last <= 0.1 * 10.0 / 470.0 + 1e-12, "{} km/h", i as f64 * 0.1);
        last = b;
    }

    // The fraction inside: 2 km/h at standstill, 7 km/h at 265 km/h; the edge counts as inside.
    let truth = [0.0, 0.0, 265.0 * KMH, 265.0 * KMH];
    let estimate = [1.9 * KMH, -2.1 * KMH, 272.0 * KMH - 1e-9, f64::NAN];
    assert!(close(fraction_in_band(&estimate, &truth), 0.5, 1e-15));
}

fn fault(kind: FaultKind, channel: Channel, telegrams: std::ops::Range<usize>) -> Fault {
    Fault { kind, channel, telegrams }
}

fn flags_at(n: usize, at: &[(usize, Channel)]) -> Vec<[bool; 4]> {
    let mut flags = vec![[false; 4]; n];
    at.iter().for_each(|&(k, c)| flags[k][c as usize] = true);
    flags
}

fn detected(score: &DetectionScore) -> Vec<(&'static str, usize, usize)> {
    score.kinds.iter().map(|k| (k.name, k.detected, k.injected)).collect()
}

#[test]
fn a_fault_is_detected_by_a_flag_on_its_channel_over_its_effect_or_one_telegram_later_and_other_flags_are_false_alarms()
{
    use Channel::*;
    let n = 20;
    let faults = [
        // Telegrams 3 and 4 dropped: the speeds known at 3, 4 read 0, the one at 5 jumps.
        fault(FaultKind::Dropout, HeadLeft, 3..5),
        // Spike at 10: the speeds known at 10 and 11.
        fault(FaultKind::Spike { error: 0.05 }, HeadRight, 10..11),
        // Slip at 8: the speed known at 8.
        fault(FaultKind::SlotSlip { step: SLOT_PITCH }, TailLeft, 8..n),
        // Resent at 15: the speeds known at 15 and 16.
        fault(FaultKind::Resend, TailRight, 15..16),
        fault(FaultKind::Offset { error: 0.03 }, HeadLeft, 0..n),
        fault(FaultKind::Offset { error: -0.02 }, HeadRight, 0..n),
    ];
    assert_eq!(effect_telegrams(&faults[0], n), 3..6);
    assert_eq!(effect_telegrams(&faults[1], n), 10..12);
    assert_eq!(effect_telegrams(&faults[2], n), 8..9);
    assert_eq!(effect_telegrams(&faults[3], n), 15..17);
    assert!(effect_telegrams(&faults[4], n).is_empty());
    let flags = flags_at(
        n,
        &[
            (6, HeadLeft),   // one late: the dropout detected
            (12, HeadRight), // one late: the spike detected
            (9, TailLeft),   // one late: the slip detected
            (10, TailLeft),  // two late: a false alarm
            (1, TailRight),  // before its resend: a false alarm, the resend missed
            (19, HeadLeft),  // an offset excuses nothing: a false alarm
        ],
    );
    let offsets = [true, false, false, true]; // head-left's found, head-right's missed, tail-right's imagined
    let score = score_detection(&faults, &flags, offsets, DetectionSettings::default());
    assert_eq!(FAULT_KINDS, ["dropout", "resend", "spike", "slot slip", "offset"]);
    assert_eq!(
        detected(&score),
        [("dropout", 1, 1), ("resend", 0, 1), ("spike", 1, 1), ("slot slip", 1, 1), ("offset", 1, 2)]
    );
    assert_eq!(score.false_alarms, 3);
    assert_eq!(score.false_alarms_per_channel, [1, 0, 1, 1]);
    assert_eq!((score.flagged, score.channel_telegrams, score.offset_false_alarms), (6, 80, 1));
    assert!(close(score.false_alarm_fraction(), 3.0 / 80.0, 1e-15));
    assert_eq!(score.kind("spike").unwrap().detected, 1);

    // With no latency allowed, the late flags miss and count as false alarms.
    let strict = score_detection(&faults, &flags, offsets, DetectionSettings { latency: 0 });
    assert_eq!(
        detected(&strict),
        [("dropout", 0, 1), ("resend", 0, 1), ("spike", 0, 1), ("slot slip", 0, 1), ("offset", 1, 2)]
    );
    assert_eq!(strict.false_alarms, 6);

    // Flagging nothing detects nothing and raises no alarm.
    let silent = score_detection(&faults, &vec![[false; 4]; n], [false; 4], DetectionSettings::default());
    assert!(silent.kinds.iter().all(|k| k.detected == 0) && silent.false_alarms == 0 && silent.flagged == 0);
}

#[test]
fn a_faults_effect_is_exactly_where_its_raw_speeds_differ_from_the_same_run_without_faults() {
    // Same seed, same noise: the raw speeds differ by the faults alone (offsets cancel).
    let profile = Profile::paper();
    let faults = Faults::default().scaled(10.0);
    let faulty = simulate(&profile, &faults, 7);
    let clean = simulate(&profile, &Faults::none(), 7);
    let n = faulty.n_telegrams();
    let mut kinds_seen = std::collections::HashSet::new();
    for c in Channel::ALL {
        let mut effect = vec![false; n];
        for f in faulty.faults.iter().filter(|f| f.channel == c) {
            kinds_seen.insert(f.kind.name());
            effect_telegrams(f, n).for_each(|k| effect[k] = true);
        }
        let (a, b) = (faulty.raw_speed(c), clean.raw_speed(c));
        for k in 1..n {
            let differs = (a[k - 1] - b[k - 1]).abs() > 1e-6;
            assert_eq!(differs, effect[k], "{c:?}, speed known at telegram {k}: {} vs {}", a[k - 1], b[k - 1]);
        }
    }
    assert_eq!(kinds_seen.len(), 5, "every kind injected: {kinds_seen:?}");
}

fn row(name: &str, s: &SpeedScore, band: f64) {
    eprintln!(
        "  {name:<13} {:>9.4} {:>9.4} {:>9.4} {:>9.3} {:>9.3} {:>8.2} %",
        s.mean_abs_error,
        s.mean_error,
        s.max_abs_error,
        s.speed_range,
        s.error_range,
        100.0 * band
    );
}

fn table(title: &str, run: &PaperRun, truth: &[f64], m: usize) -> [SpeedScore; 3] {
    let scores = [&run.raw_average, &run.fused, &run.filtered].map(|x| score_speed(&x[..m], &truth[..m]));
    eprintln!("{title} ({m} samples; true range {:.3} m/s)", scores[0].true_range);
    eprintln!(
        "  {:<13} {:>9} {:>9} {:>9} {:>9} {:>9} {:>10}",
        "", "mean|e|", "mean e", "max|e|", "range", "e range", "in ETCS"
    );
    for ((name, s), x) in
        ["raw average", "fused", "UKF-filtered"].iter().zip(&scores).zip([&run.raw_average, &run.fused, &run.filtered])
    {
        row(name, s, fraction_in_band(&x[..m], &truth[..m]));
    }
    let r = |i: usize| {
        (
            100.0 * reduction(scores[0].mean_abs_error, scores[i].mean_abs_error),
            100.0 * reduction(scores[0].speed_range, scores[i].speed_range),
        )
    };
    let ((fm, fr), (um, ur)) = (r(1), r(2));
    eprintln!(
        "  against the raw average: fused mean error −{fm:.1} %, range −{fr:.1} %; UKF mean error −{um:.1} %, range −{ur:.1} % (paper: −32.6 %, −49.3 %)"
    );
    scores
}

#[test]
fn on_the_papers_run_the_fusion_beats_the_raw_average_and_its_ukf_is_smoother() {
    let recording = simulate(&Profile::paper(), &Faults::default(), 1);
    let settings = PaperSettings::default();
    let run = run_paper(&recording, &settings).unwrap();
    let n = recording.n_telegrams();

    // The series: one per speed sample a, known at telegram a + 1.
    assert_eq!(run.len(), n - 1);
    assert!(close(run.time[0], DT, 1e-15) && close(run.time[n - 2], (n - 1) as f64 * DT, 1e-9));
    assert_eq!(run.raw_average, raw_average(&recording));
    for a in 0..run.len() {
        assert!(run.fused[a].is_finite() && run.filtered[a].is_finite(), "a = {a}");
        assert!(close(run.weights[a].iter().sum::<f64>(), 1.0, 1e-12), "a = {a}: {:?}", run.weights[a]);
        assert!(run.weights[a].iter().all(|w| (0.0..=1.0).contains(w)));
        assert!(run.rejected[a].iter().filter(|&&r| r).count() <= settings.grubbs.max_rejections);
    }
    let flags = run.flags_by_telegram();
    assert_eq!((flags.len(), flags[0]), (n, [false; 4]));

    // The UKF on this linear random walk is the scalar Kalman filter, from the stated prior.
    let (q, r) = (settings.process_noise, settings.measurement_noise);
    let (mut x, mut p) = (run.fused[0], r);
    assert_eq!((run.filtered[0], run.filtered_variance[0]), (x, p), "the prior: first fused speed, variance R");
    for a in 1..run.len() {
        let predicted = p + q;
        let gain = predicted / (predicted + r);
        x += gain * (run.fused[a] - x);
        p = (1.0 - gain) * predicted;
        assert!(close(run.filtered[a], x, 1e-6), "a = {a}: UKF {} vs Kalman {x}", run.filtered[a]);
        assert!(close(run.filtered_variance[a], p, 1e-9), "a = {a}: {} vs {p}", run.filtered_variance[a]);
    }
    // … settling to the Riccati fixed point of Q and R.
    let steady_predicted = (q + (q * q + 4.0 * q * r).sqrt()) / 2.0;
    let steady = steady_predicted * r / (steady_predicted + r);
    assert!(close(*run.filtered_variance.last().unwrap(), steady, 1e-12));

    // The tables: against our truth at the telegram a speed is known, over the whole
    // recording and over the motion alone, and against the paper's truth.
    let ours = true_speed_for_samples(&recording);
    let papers = recording.paper_true_speed();
    let moving = recording.truth.iter().filter(|s| s.speed > 0.0).count();
    eprintln!("S4, the paper's run, Faults::default(), seed 1 (speeds in m/s):");
    let [raw, fused, filtered] =
        table("against our truth (the profile's speed when the sample is known)", &run, &ours, n - 1);
    table("  … over the motion alone", &run, &ours, moving);
    table("against the paper's truth (ΔP̄/Δt of the true positions)", &run, &papers, n - 1);
    let position = score_position(&run.position, &true_position_for_samples(&recording));
    eprintln!(
        "position (mean of the four channels, the same for all three): mean |e| {:.4} m, max |e| {:.4} m",
        position.mean_abs, position.max_abs
    );
    let offsets: Vec<f64> = recording
        .faults
        .iter()
        .filter_map(|f| if let FaultKind::Offset { error } = f.kind { Some(error) } else { None })
        .collect();
    eprintln!("  (the four offsets {offsets:.4?} m, their mean {:.4} m)", offsets.iter().sum::<f64>() / 4.0);
    let detection = score_detection(&recording.faults, &flags, [false; 4], DetectionSettings::default());
    eprintln!("Grubbs' rejections as detections (latency ≤ 1 telegram; the paper estimates no offset):");
    for k in &detection.kinds {
        eprintln!("  {:<10} {:>3} of {:>3} detected", k.name, k.detected, k.injected);
    }
    eprintln!(
        "  false alarms {} of {} channel-telegrams ({:.3} %), {} rejections in all",
        detection.false_alarms,
        detection.channel_telegrams,
        100.0 * detection.false_alarm_fraction(),
        detection.flagged
    );

    // The paper's claims, as they should hold on this run.
    assert!(fused.mean_abs_error < raw.mean_abs_error, "fused {fused:?}\nraw {raw:?}");
    assert!(filtered.speed_range < raw.speed_range, "filtered {filtered:?}\nraw {raw:?}");
    assert!(filtered.speed_range < fused.speed_range, "filtered {filtered:?}\nfused {fused:?}");
    // Sanity from the fault model: dropouts and resends start at 2e-3 per channel and
    // telegram, some 35 in the 4,400 cruise telegrams of four channels, and one of a single
    // telegram already puts its channel at 2·5.6 m/s, the raw average at 1.25·5.6 m/s
    // (give or take its noise, 0.05 m/s), beyond the true range of 5.6 m/s. And no
    // estimate can range less than the truth does by more than twice its largest error.
    assert!(raw.speed_range > 1.2 * raw.true_range, "{raw:?}");
    for s in [&raw, &fused, &filtered] {
        assert!(s.speed_range >= s.true_range - 2.0 * s.max_abs_error, "{s:?}");
        assert!(s.mean_abs_error <= s.max_abs_error && s.mean_error.abs() <= s.mean_abs_error);
    }
    // The raw average's signed errors telescope to the change of its position error over
    // the run: its signed mean is that change over the run's duration.
    let avg_position_error =
        |k: usize| recording.position.iter().map(|p| p[k]).sum::<f64>() / 4.0 - recording.truth[k].position;
    let telescoped = (avg_position_error(n - 1) - avg_position_error(0)) / ((n - 1) as f64 * DT);
    let against_papers = score_speed(&run.raw_average, &papers);
    assert!(close(against_papers.mean_error, telescoped, 1e-9), "{} vs {telescoped}", against_papers.mean_error);
}
