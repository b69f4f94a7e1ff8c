//! Model mismatch told from sensor faults, and the process noise learnt
//! online, as a specification (`SupervisorSettings::adaptive`), every filter
//! kind, on linear-Gaussian models where the truth is the model:
//!
//! * a true jump of the state is never rejected, whether one row sees it or
//!   several agree on it, and it is followed;
//! * a spike that the other rows contradict is rejected at its sample;
//! * a spike no other row can contradict is taken as a jump, and its review
//!   at the next sample retracts it: it counts as rejected, and the belief is
//!   the one without it;
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
