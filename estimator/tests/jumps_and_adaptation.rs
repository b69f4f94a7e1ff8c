//! Model mismatch told from sensor faults, and the process noise learnt
//! online, as a specification (`SupervisorSettings::adaptive`), every filter
//! kind, on linear-Gaussian models where the truth is the model:
//!
//! * a true jump of the state is never rejected, whether one row sees it or
//!   several agree on it, and it is followed; a local jump opens only the
//!   states its failing rows see;
//! * a spike that the other rows contradict is rejected at its sample;
//! * a spike no other row can contradict is taken as a jump, and its review
//!   at the next sample retracts it: it counts as rejected, and the belief is
//!   the one without it;
//! * a step that one row alone shows is held for its review and followed
//!   from the next sample; while that change is under way its further steps
//!   are followed at their samples; where single-row jumps are shown, the
//!   first is followed at its sample too, and a spike shows for one sample
//!   inside its σ before its review retracts it;
//! * a filter told `Q` ten times too large or too small is consistent again
//!   within 300 samples (3 s);
//! * a saved memory with a jump under review continues exactly.

mod common;

use common::*;
use estimator::models::LinearGaussian;
use estimator::{
    build_filter, FilterKind, Gaussian, Noise, RowOutcome, StateEstimator, Supervisor, SupervisorSettings,
    UnscentedParams,
};
use nalgebra::{DMatrix, DVector};

const DT: f64 = 0.01;

fn adaptive() -> SupervisorSettings {
    SupervisorSettings::default().adaptive(200)
}

fn filter_for(
    kind: FilterKind,
    model: LinearGaussian,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
    prior: &Gaussian,
) -> Box<dyn StateEstimator> {
    let noise = Noise::new(q, r).unwrap();
    build_filter(kind, model, noise, prior, UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 }).unwrap()
}

/// Predict with the controls of the last sample held, hold this sample's,
/// gate, commit, the commit's scale on `Q` taken by the filter: one sample of
/// the supervised loop (`SupervisedFilter`).
fn step(f: &mut dyn StateEstimator, s: &mut Supervisor, held: &[f64], u: &[f64], z: &[f64]) -> estimator::Outcome {
    f.predict(held, DT).unwrap();
    f.hold_input(u).unwrap();
    let outcome = s.gate(f, z).unwrap().clone();
    s.commit(|_| {});
    s.scale_process_noise_of(f).unwrap();
    outcome
}

/// Two random-walk states; rows 0 and 1 both measure the first, row 2 the second.
struct Redundant {
    model: LinearGaussian,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
    prior: Gaussian,
    truth: Vec<DVector<f64>>,
    measurements: Vec<Vec<f64>>,
}

fn redundant(steps: usize, seed: u64, jump_at: Option<usize>) -> Redundant {
    let a = DMatrix::identity(2, 2);
    let b = DMatrix::zeros(2, 1);
    let h = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    let q = DMatrix::from_diagonal(&DVector::from_column_slice(&[1e-3, 1e-3]));
    let r = DMatrix::from_diagonal(&DVector::from_column_slice(&[1e-2, 1e-2, 1e-2]));
    let prior = Gaussian { mean: DVector::zeros(2), covariance: DMatrix::identity(2, 2) * 1e-2 };
    let model = LinearGaussian::new(a, b, h.clone());
    let mut rng = rng(seed);
    let mut x = DVector::zeros(2);
    let (mut truth, mut measurements) = (Vec::new(), Vec::new());
    for k in 0..steps {
        if k > 0 {
            x += correlated(&mut rng, &q);
        }
        if Some(k) == jump_at {
            x[0] += 10.0; // 100 σ of either row that sees it
        }
        measurements.push((&h * &x + correlated(&mut rng, &r)).iter().copied().collect());
        truth.push(x.clone());
    }
    Redundant { model, q, r, prior, truth, measurements }
}

#[test]
fn a_true_jump_several_rows_agree_on_is_never_rejected_and_is_followed() {
    let case = redundant(300, 3, Some(150));
    for kind in FilterKind::ALL {
        let mut f = filter_for(kind, case.model.clone(), case.q.clone(), case.r.clone(), &case.prior);
        let mut s = Supervisor::new(adaptive(), 3).unwrap();
        for (k, z) in case.measurements.iter().enumerate() {
            let outcome = step(f.as_mut(), &mut s, &[0.0], &[0.0], z);
            assert!(outcome.rows.iter().all(|r| *r == RowOutcome::Used), "{kind} sample {k}: {:?}", outcome.rows);
            if k == 150 {
                assert!(outcome.jump > 0.0 && outcome.explained[0] && outcome.explained[1], "{kind}: {outcome:?}");
            }
            if k > 150 {
                let error = (f.mean()[0] - case.truth[k][0]).abs();
                assert!(error < 4.0 * f.variance(0).sqrt() + 1e-9, "{kind} sample {k}: error {error}");
            }
        }
        assert_eq!((s.rejected(), s.retracted_jumps(), s.reacquisitions()), (0, 0, 0), "{kind}");
        assert!(s.jumps() >= 1, "{kind}");
    }
}

#[test]
fn a_local_jump_opens_only_the_states_its_failing_rows_see() {
    // Rows 0 and 1 fail on the first state's jump; with local jumps the second
    // state, seen by row 2 alone, which passes, keeps its σ; without, it is
    // opened too, and row 2 alone sets it.
    let case = redundant(300, 3, Some(150));
    for kind in FilterKind::ALL {
        for local_jumps in [true, false] {
            let mut f = filter_for(kind, case.model.clone(), case.q.clone(), case.r.clone(), &case.prior);
            let mut s = Supervisor::new(SupervisorSettings { local_jumps, ..adaptive() }, 3).unwrap();
            let (mut before, mut jumped_before) = (f64::NAN, f64::NAN);
            for (k, z) in case.measurements.iter().enumerate().take(151) {
                let outcome = step(f.as_mut(), &mut s, &[0.0], &[0.0], z);
                if k == 149 {
                    (before, jumped_before) = (f.variance(1), f.variance(0));
                }
                if k == 150 {
                    assert!(outcome.jump > 0.0, "{kind}: {outcome:?}");
                    let (after, jumped) = (f.variance(1), f.variance(0));
                    let kept = (after / before - 1.0).abs() < 0.01;
                    assert_eq!(
                        kept, local_jumps,
                        "{kind} local {local_jumps}: the unseen state's σ² {before} → {after}"
                    );
                    assert!(jumped > 1.5 * jumped_before, "{kind}: the jumped state's σ² {jumped_before} → {jumped}");
                }
            }
        }
    }
}

#[test]
fn a_spike_the_other_rows_contradict_is_rejected_at_its_sample() {
    let mut case = redundant(300, 5, None);
    for k in [60, 140, 220] {
        case.measurements[k][0] += 10.0;
    }
    for kind in FilterKind::ALL {
        let mut f = filter_for(kind, case.model.clone(), case.q.clone(), case.r.clone(), &case.prior);
        let mut s = Supervisor::new(adaptive(), 3).unwrap();
        for (k, z) in case.measurements.iter().enumerate() {
            let outcome = step(f.as_mut(), &mut s, &[0.0], &[0.0], z);
            let spiked = [60, 140, 220].contains(&k);
            assert_eq!(outcome.rows[0] == RowOutcome::Rejected, spiked, "{kind} sample {k}: {outcome:?}");
            assert_eq!(outcome.jump, 0.0, "{kind} sample {k}: no jump");
        }
        assert_eq!(s.rejected(), 3, "{kind}");
    }
}

/// The case of `common::linear_case`: each of its rows sees a state no other row sees.
#[test]
fn a_spike_no_other_row_can_contradict_is_retracted_at_the_next_sample() {
    let case = linear_case(300, 12);
    let spikes = [49, 149, 249];
    for kind in FilterKind::ALL {
        let noise = || Noise::new(case.q.clone(), case.r.clone()).unwrap();
        let params = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
        let mut gated = build_filter(kind, case.model.clone(), noise(), &case.prior, params).unwrap();
        let mut plain = build_filter(kind, case.model.clone(), noise(), &case.prior, params).unwrap();
        let mut s = Supervisor::new(SupervisorSettings { adaptation_window: 0, ..adaptive() }, 3).unwrap();
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
            let held = &case.inputs[k.saturating_sub(1)];
            let (mut spiked, mut missing) = (z.clone(), z.clone());
            if spikes.contains(&k) {
                spiked[1] += 1e3; // about 2000 σ
                missing[1] = f64::NAN;
            }
            let outcome = step(gated.as_mut(), &mut s, held, u, &spiked);
            plain.predict(held, DT).unwrap();
            plain.hold_input(u).unwrap();
            plain.update(&missing).unwrap();
            if spikes.contains(&k) {
                assert!(outcome.jump > 0.0 && outcome.explained[1], "{kind} sample {k}: taken as a jump");
            } else {
                let after_spike = spikes.contains(&(k.wrapping_sub(1)));
                assert_eq!(outcome.retracted, [false, after_spike, false], "{kind} sample {k}");
                // From the sample after the spike on, the belief is the one without it.
                let (a, b) = (gated.mean(), plain.mean());
                let scale = b.amax().max(1.0);
                assert!((a - b).amax() <= 1e-9 * scale, "{kind} sample {k}: {a} vs {b}");
            }
        }
        assert_eq!((s.rejected(), s.jumps(), s.retracted_jumps()), (3, 3, 3), "{kind}");
    }
}

#[test]
fn a_filter_told_q_ten_times_wrong_is_consistent_within_three_seconds() {
    let case = linear_case(3_000, 21);
    for (told, direction) in [(10.0, "too large"), (0.1, "too small")] {
        for kind in FilterKind::ALL {
            let mut f = filter_for(kind, case.model.clone(), &case.q * told, case.r.clone(), &case.prior);
            let mut s = Supervisor::new(adaptive(), 3).unwrap();
            let (mut sum, mut rows) = (0.0, 0);
            for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
                let outcome = step(f.as_mut(), &mut s, &case.inputs[k.saturating_sub(1)], u, z);
                if k >= 300 {
                    sum += outcome.nis;
                    rows += outcome.dof;
                }
            }
            let mean = sum / rows as f64;
            let scale = s.process_noise_scale() * told;
            println!("{kind} Q {direction}: mean NIS per row after 3 s {mean:.3}, Q learnt {scale:.3} of the truth");
            assert!((0.9..1.1).contains(&mean), "{kind} Q {direction}: mean NIS per row {mean}");
            assert!((0.5..2.0).contains(&scale), "{kind} Q {direction}: learnt {scale} of the true Q");
            assert_eq!(s.rejected(), 0, "{kind} Q {direction}");
        }
    }
}

#[test]
fn a_memory_saved_with_a_jump_under_review_continues_exactly() {
    let case = linear_case(200, 4);
    for kind in FilterKind::ALL {
        let params = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
        let noise = || Noise::new(case.q.clone(), case.r.clone()).unwrap();
        let mut f = build_filter(kind, case.model.clone(), noise(), &case.prior, params).unwrap();
        let mut s = Supervisor::new(adaptive(), 3).unwrap();
        let mut zs = case.measurements.clone();
        zs[100][1] += 1e3; // a spike no other row can contradict
        let held = |k: usize| &case.inputs[k.saturating_sub(1)];
        for (k, z) in zs.iter().enumerate().take(101) {
            step(f.as_mut(), &mut s, held(k), &case.inputs[k], z);
        }
        let mut words = Vec::new();
        s.save(&mut words);
        let mut t = Supervisor::new(adaptive(), 3).unwrap();
        t.load(&words).unwrap();
        let mut again = Vec::new();
        t.save(&mut again);
        assert_eq!(again, words, "{kind}");
        let mut g = build_filter(kind, case.model.clone(), noise(), &case.prior, params).unwrap();
        g.restore(&f.snapshot()).unwrap();
        t.scale_process_noise_of(g.as_mut()).unwrap();
        for (k, z) in zs.iter().enumerate().skip(101) {
            let a = step(f.as_mut(), &mut s, held(k), &case.inputs[k], z);
            let b = step(g.as_mut(), &mut t, held(k), &case.inputs[k], z);
            assert_eq!(a, b, "{kind} sample {k}");
            if k == 101 {
                assert!(a.reviewed && a.retracted[1], "{kind}: the spike is reviewed and retracted");
            }
        }
        assert_eq!(f.mean(), g.mean(), "{kind}");
    }
}

/// A linear case: its model, `Q`, `R`, prior, true states and measurements.
type Case = (LinearGaussian, DMatrix<f64>, DMatrix<f64>, Gaussian, Vec<DVector<f64>>, Vec<Vec<f64>>);

/// Two random walks, each seen by one row alone (nothing can contradict either),
/// with a step of the first of 100 σ of its row at `steps[0]` and more steps
/// after it (an impact that rings): `(model, q, r, prior, truth, measurements)`.
fn single_row_steps(n: usize, seed: u64, steps: &[(usize, f64)]) -> Case {
    let model = LinearGaussian::new(DMatrix::identity(2, 2), DMatrix::zeros(2, 1), DMatrix::identity(2, 2));
    let q = DMatrix::identity(2, 2) * 1e-4;
    let r = DMatrix::identity(2, 2) * 1e-2;
    let prior = Gaussian { mean: DVector::zeros(2), covariance: DMatrix::identity(2, 2) * 1e-2 };
    let mut rng = rng(seed);
    let mut x = DVector::zeros(2);
    let (mut truth, mut measurements) = (Vec::new(), Vec::new());
    for k in 0..n {
        if k > 0 {
            x += correlated(&mut rng, &q);
        }
        if let Some((_, size)) = steps.iter().find(|(at, _)| *at == k) {
            x[0] += size;
        }
        measurements.push((&x + correlated(&mut rng, &r)).iter().copied().collect());
        truth.push(x.clone());
    }
    (model, q, r, prior, truth, measurements)
}

/// The error of the first state over its σ after each sample, with `settings`.
fn errors_over_sigma(kind: FilterKind, settings: SupervisorSettings, steps: &[(usize, f64)]) -> Vec<f64> {
    let (model, q, r, prior, truth, measurements) = single_row_steps(200, 21, steps);
    let mut f = filter_for(kind, model, q, r, &prior);
    let mut s = Supervisor::new(SupervisorSettings { adaptation_window: 0, ..settings }, 2).unwrap();
    let mut ratios = Vec::new();
    for (k, z) in measurements.iter().enumerate() {
        step(f.as_mut(), &mut s, &[0.0], &[0.0], z);
        ratios.push((f.mean()[0] - truth[k][0]).abs() / f.variance(0).sqrt());
    }
    assert_eq!(s.retracted_jumps(), 0, "{kind}: a true step is never retracted");
    ratios
}

/// A step of 1 (10 σ of the row, 100 σ of the random walk's step) at sample 100, then the
/// same change ringing on: -1.5 at 103, +0.8 at 106, all inside `change_memory` of each other.
const RINGING: [(usize, f64); 3] = [(100, 1.0), (103, -1.5), (106, 0.8)];

#[test]
fn a_step_one_row_alone_shows_is_held_for_its_review_then_followed_while_it_rings() {
    for kind in FilterKind::ALL {
        let held = errors_over_sigma(kind, SupervisorSettings::default(), &RINGING);
        // At the step's own sample the estimate holds (an error of the step's size), about
        // 2σ of the mixture (the jump hypothesis's half of it covers the step; the noise
        // of the row adds a little).
        assert!(held[100] > 0.5 && held[100] <= 2.5, "{kind}: at the step {:.2} σ", held[100]);
        // From the next sample on it is followed, and the ringing that comes while the change
        // is under way is followed at its own samples.
        for (k, ratio) in held.iter().enumerate().skip(101) {
            assert!(*ratio < 4.0, "{kind} sample {k}: {ratio:.2} σ");
        }
        // Without a memory of the change, each ringing step is held for its review again.
        let forgetful =
            errors_over_sigma(kind, SupervisorSettings { change_memory: 0, ..Default::default() }, &RINGING);
        assert!(forgetful[103] > 0.5, "{kind}: held at 103 without the memory ({:.2} σ)", forgetful[103]);
    }
}

#[test]
fn where_single_row_jumps_are_shown_a_step_is_followed_at_its_sample() {
    let shown = SupervisorSettings { show_single_row_jumps: true, ..SupervisorSettings::default() };
    for kind in FilterKind::ALL {
        let ratios = errors_over_sigma(kind, shown, &RINGING);
        for (k, ratio) in ratios.iter().enumerate().skip(100) {
            assert!(*ratio < 4.0, "{kind} sample {k}: {ratio:.2} σ");
        }
        // Where nothing happened the setting changes nothing.
        let quiet = errors_over_sigma(kind, shown, &[]);
        assert_eq!(quiet, errors_over_sigma(kind, SupervisorSettings::default(), &[]), "{kind}");
    }
}

#[test]
fn where_single_row_jumps_are_shown_a_spike_shows_inside_its_sigma_and_is_retracted_next() {
    let (model, q, r, prior, _, mut measurements) = single_row_steps(200, 22, &[]);
    measurements[120][0] += 30.0; // 300 σ of the row, for one sample
    let shown = SupervisorSettings { show_single_row_jumps: true, adaptation_window: 0, ..Default::default() };
    for kind in FilterKind::ALL {
        let mut gated = filter_for(kind, model.clone(), q.clone(), r.clone(), &prior);
        let mut plain = filter_for(kind, model.clone(), q.clone(), r.clone(), &prior);
        let mut s = Supervisor::new(shown, 2).unwrap();
        for (k, z) in measurements.iter().enumerate() {
            let outcome = step(gated.as_mut(), &mut s, &[0.0], &[0.0], z);
            plain.predict(&[0.0], DT).unwrap();
            plain.hold_input(&[0.0]).unwrap();
            let mut without = z.clone();
            if k == 120 {
                without[0] = f64::NAN;
            }
            plain.update(&without).unwrap();
            let gap = (gated.mean()[0] - plain.mean()[0]).abs();
            if k == 120 {
                assert!(outcome.ambiguous && !outcome.continued, "{kind}: {outcome:?}");
                // The spike shows, but the belief without it is inside 2σ of what is shown.
                assert!(gap > 1.0 && gap <= 2.0 * gated.variance(0).sqrt(), "{kind}: gap {gap}");
            } else {
                assert_eq!(outcome.retracted, [k == 121, false], "{kind} sample {k}");
                assert!(gap <= 1e-9, "{kind} sample {k}: the belief without the spike, off by {gap}");
            }
        }
        assert_eq!((s.rejected(), s.retracted_jumps()), (1, 1), "{kind}");
    }
}
