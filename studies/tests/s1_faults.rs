//! Study S1 with gross measurement errors, every filter kind behind the
//! supervisor: the figures `kalfmu s1-faults` prints, held to stated
//! bounds (40 s runs, faults from 20 s; `studies/src/s1/faults.rs` says
//! what each fault is). Where the other channel keeps the load observable
//! (faults on `z1_ddot`, spikes, dropouts) the load estimate stays within a
//! few of its σ; every sensor fault is flagged, none silently accepted; a
//! true step of the load is never rejected.

use estimator::{FilterKind, SupervisorSettings};
use studies::s1::faults::{inject, run, Fault, FaultRun};
use truth::s1::{Case, Settings};

fn runs(fault: Fault) -> Vec<FaultRun> {
    let case: Case = "stiffness/random".parse().unwrap();
    let settings = Settings { duration: 40.0, ..Settings::default() };
    let injected = inject(fault, &case, &settings);
    FilterKind::ALL
        .into_iter()
        .map(|kind| {
            let r = run(kind, &injected, &case, &settings, SupervisorSettings::default());
            assert!(r.failure.is_none(), "{fault} {kind}: {:?}", r.failure);
            r
        })
        .collect()
}

#[test]
fn healthy_data_raises_no_alarm() {
    for r in runs(Fault::Healthy) {
        assert_eq!((r.false_rejections, r.false_fault_samples, r.unhealthy_samples), (0, 0, 0), "{}", r.kind);
        assert!(r.max_error_sigmas < 5.0 && r.correlation > 0.9995, "{}: {r:?}", r.kind);
    }
}

/// A spike on `z1_ddot` is rejected at its sample: `z2_ddot` contradicts it. One
/// on `z2_ddot`, which only the load moves, could be a load step: it is
/// rejected at the next sample, which tells the two apart (meanwhile the
/// estimate holds, its σ widened to cover a step). The last spike falls on the
/// run's last sample, which no later sample reviews.
#[test]
fn spikes_are_rejected_at_their_sample_or_the_next_and_change_nothing() {
    for r in runs(Fault::Spikes) {
        assert_eq!(r.corrupted_rejected.0 + 1, r.corrupted_rejected.1, "{}: every spike but the last rejected", r.kind);
        assert!(r.corrupted_rejected.1 >= 7, "{}", r.kind);
        assert_eq!((r.detection_delay, r.false_rejections), (Some(1), 0), "{}", r.kind);
        assert!(r.max_error_sigmas < 5.0 && r.correlation > 0.9995, "{}: {r:?}", r.kind);
    }
}

#[test]
fn a_saturated_channel_is_rejected_where_clipping_matters() {
    for r in runs(Fault::Saturation) {
        let (rejected, offered) = r.corrupted_rejected;
        // The rest were clipped by less than the gate's width: no error worth a flag.
        assert!(rejected as f64 >= 0.85 * offered as f64 && offered > 20, "{}: {rejected}/{offered}", r.kind);
        assert!(r.detection_delay.is_some_and(|d| d <= 5), "{}: {r:?}", r.kind);
        assert!(r.max_error_sigmas < 5.0 && r.false_rejections == 0, "{}: {r:?}", r.kind);
    }
}

#[test]
fn a_stuck_channel_is_left_out_within_stuck_after_samples() {
    let settings = SupervisorSettings::default();
    for r in runs(Fault::Stuck) {
        assert!(r.detection_delay.is_some_and(|d| d < settings.stuck_after as usize), "{}: {r:?}", r.kind);
        assert!(r.corrupted_rejected.0 + settings.stuck_after as u64 >= r.corrupted_rejected.1, "{}", r.kind);
        assert!(r.max_error_sigmas < 5.0 && r.false_rejections == 0, "{}: {r:?}", r.kind);
    }
}

#[test]
fn a_drifting_channel_is_caught_and_the_load_stays_within_its_sigma() {
    for r in runs(Fault::Drift) {
        assert!(r.detection_delay.is_some_and(|d| d <= 30), "{}: {r:?}", r.kind);
        assert!(r.corrupted_rejected.0 as f64 >= 0.95 * r.corrupted_rejected.1 as f64, "{}: {r:?}", r.kind);
        // 0.99898 at worst (the EKF; 0.99903 with the fixed supervisor): `Q`
        // adapted on `z2_ddot` alone while `z1_ddot` drifts.
        assert!(r.max_error_sigmas < 6.0 && r.correlation > 0.9985, "{}: {r:?}", r.kind);
        // Persistent disagreement is reported: not healthy while it lasts.
        assert!(r.unhealthy_samples > 1000, "{}: {r:?}", r.kind);
    }
}

#[test]
fn a_dropout_is_flagged_and_the_prediction_covers_the_gap() {
    let settings = SupervisorSettings::default();
    for r in runs(Fault::Dropout) {
        assert!(r.detection_delay.is_some_and(|d| d < settings.fault_after as usize), "{}: {r:?}", r.kind);
        // The prediction covers the 0.5 s gap of both channels, or the filter
        // says it does not (the EKF's linearisation did not survive it with Q as given).
        assert!(r.max_error_sigmas < 6.0 || r.unhealthy_samples > 200, "{}: {r:?}", r.kind);
    }
}

/// Taken as a jump of the load: never rejected, followed from the next sample,
/// its σ honest throughout; no re-acquisition is needed.
#[test]
fn a_true_load_step_of_ten_times_the_rms_is_never_rejected_and_followed_at_once() {
    for r in runs(Fault::LoadStep) {
        assert_eq!((r.false_rejections, r.false_fault_samples, r.reacquisitions), (0, 0, 0), "{}: {r:?}", r.kind);
        assert!(r.recovery.is_some_and(|t| t <= 0.01), "{}: {r:?}", r.kind);
        assert!(r.max_error_sigmas < 5.0 && r.correlation > 0.9995, "{}: {r:?}", r.kind);
    }
}

/// A burst long enough to re-acquire (ten samples of ±100× the RMS): on
/// `z1_ddot` the re-acquisition takes it in, and its rival (the belief that
/// left the channel out) explains the next samples better and is kept; on
/// `z2_ddot` each sample is an ambiguous jump that its review retracts. Either
/// way the load is back within 3σ at once and stays there, and the filter is
/// healthy throughout.
#[test]
fn a_burst_that_re_acquires_is_undone_and_the_load_is_back_at_once() {
    for (fault, undone) in [(Fault::Burst, 1), (Fault::BurstLoadChannel, 0)] {
        for r in runs(fault) {
            assert_eq!(
                (r.false_rejections, r.unhealthy_samples, r.undone),
                (0, 0, undone),
                "{fault} {}: {r:?}",
                r.kind
            );
            assert!(r.corrupted_rejected.0 >= 9, "{fault} {}: {r:?}", r.kind);
            assert!(r.recovery.is_some_and(|t| t <= 0.01), "{fault} {}: {r:?}", r.kind);
            // The largest error after the burst is that of clean data: about 3.4× the RMS error.
            assert!(r.error_after_recovery.is_some_and(|x| x < 4.0), "{fault} {}: {r:?}", r.kind);
        }
    }
}
