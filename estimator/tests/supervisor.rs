//! The supervisor as a specification, on a linear-Gaussian model where the
//! filters are exactly consistent (the truth is the model): the gate never
//! fires on healthy data, a rejected row is exactly a missing one, stuck and
//! persistently failing channels are flagged and cleared, a true jump is
//! re-acquired, an inconsistent filter is reported, and a gate that is not
//! committed changes nothing. Every filter kind. Where a test is about the
//! gate's rejections and re-acquisitions themselves, the supervisor is the
//! `fixed` one (no jumps, `Q` as given): `jumps_and_adaptation.rs` specifies
//! what the jumps and the adaptation change.

mod common;

use common::*;
use estimator::{
    build_filter, FilterKind, Noise, RowOutcome, StateEstimator, Supervisor, SupervisorSettings, UnscentedParams,
};

fn filter(kind: FilterKind, case: &LinearCase, r_scale: f64) -> Box<dyn StateEstimator> {
    overconfident(kind, case, 1.0, r_scale)
}

/// The filter told `q_scale`·Q and `r_scale`·R.
fn overconfident(kind: FilterKind, case: &LinearCase, q_scale: f64, r_scale: f64) -> Box<dyn StateEstimator> {
    let noise = Noise::new(&case.q * q_scale, &case.r * r_scale).unwrap();
    build_filter(kind, case.model.clone(), noise, &case.prior, UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 })
        .unwrap()
}

fn supervisor() -> Supervisor {
    Supervisor::new(SupervisorSettings::default(), 3).unwrap()
}

/// The supervisor without jumps or adaptation: every failing row rejected.
fn fixed_supervisor() -> Supervisor {
    Supervisor::new(SupervisorSettings::default().fixed(), 3).unwrap()
}

/// Predict, gate, commit: one sample; returns the outcome's rows.
fn step(f: &mut dyn StateEstimator, s: &mut Supervisor, u: &[f64], z: &[f64]) -> Vec<RowOutcome> {
    f.predict(u, 0.01).unwrap();
    let rows = s.gate(f, z).unwrap().rows.clone();
    s.commit(|_| {});
    rows
}

fn bits(f: &dyn StateEstimator) -> Vec<u64> {
    f.mean().iter().chain(f.covariance().iter()).map(|x| x.to_bits()).collect()
}

#[test]
fn the_gate_never_fires_on_healthy_data_and_the_filter_stays_consistent() {
    // 3 rows × 20 000 samples × 5 filters = 300 000 rows; at the default
    // probability 1e-6 per row, a consistent filter rejects none (P = 0.74).
    let case = linear_case(20_000, 11);
    for kind in FilterKind::ALL {
        let (mut f, mut s) = (filter(kind, &case, 1.0), supervisor());
        let mut unhealthy = 0;
        for (u, z) in case.inputs.iter().zip(&case.measurements) {
            step(f.as_mut(), &mut s, u, z);
            unhealthy += usize::from(!s.healthy());
        }
        assert_eq!(s.rejected(), 0, "{kind}");
        assert_eq!(unhealthy, 0, "{kind}");
        assert_eq!(s.reacquisitions(), 0, "{kind}");
        let mean = s.windowed_nis();
        assert!((0.7..1.3).contains(&mean), "{kind}: windowed normalised innovation {mean}");
    }
}

#[test]
fn a_rejected_row_is_exactly_a_missing_one() {
    let case = linear_case(300, 12);
    for kind in FilterKind::ALL {
        let (mut gated, mut s) = (filter(kind, &case, 1.0), fixed_supervisor());
        let mut plain = filter(kind, &case, 1.0);
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
            let mut spiked = z.clone();
            let mut missing = z.clone();
            if k % 50 == 49 {
                spiked[1] += 1e3; // a spike of about 2000 σ
                missing[1] = f64::NAN;
            }
            let rows = step(gated.as_mut(), &mut s, u, &spiked);
            plain.predict(u, 0.01).unwrap();
            plain.update(&missing).unwrap();
            assert_eq!(rows[1] == RowOutcome::Rejected, k % 50 == 49, "{kind} sample {k}");
            assert_eq!(bits(gated.as_ref()), bits(plain.as_ref()), "{kind} sample {k}");
        }
        assert_eq!(s.rejected(), 6, "{kind}");
        assert!(s.channels().iter().all(|c| !c.faulty), "{kind}: single spikes make no fault");
    }
}

#[test]
fn a_stuck_channel_is_left_out_and_flagged_until_it_moves() {
    let settings = SupervisorSettings::default();
    let case = linear_case(400, 13);
    for kind in FilterKind::ALL {
        let (mut f, mut s) = (filter(kind, &case, 1.0), supervisor());
        let mut changes = Vec::new();
        let held = case.measurements[100][2];
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
            let mut z = z.clone();
            if (100..200).contains(&k) {
                z[2] = held;
            }
            f.predict(u, 0.01).unwrap();
            let row = s.gate(f.as_mut(), &z).unwrap().rows[2];
            s.commit(|change| changes.push((k, change.channel, change.faulty)));
            // The value is the same from 100 on; the stuck_after-th repetition is the first left out.
            let stuck_from = 100 + settings.stuck_after as usize - 1;
            assert_eq!(row == RowOutcome::Stuck, (stuck_from..200).contains(&k), "{kind} sample {k}");
        }
        let flagged = 100 + (settings.stuck_after + settings.fault_after) as usize - 2;
        assert_eq!(changes, vec![(flagged, 2, true), (200, 2, false)], "{kind}");
        assert_eq!(s.channels()[2].stuck, 200 - (100 + settings.stuck_after as u64 - 1), "{kind}");
    }
}

#[test]
fn a_true_jump_of_the_state_is_reacquired_and_followed() {
    // The system jumps by 40 σ of its measurements at sample 300 (a load
    // step, a bad prior): every row fails the gate; after reacquire_after
    // samples the filter re-acquires and follows.
    let settings = SupervisorSettings::default();
    let mut case = linear_case(600, 14);
    let h = case.model.h().clone();
    let jump = nalgebra::DVector::from_column_slice(&[20.0, -15.0, 10.0, 12.0]);
    // The measurements of a state moved by `jump` (the dynamics are stable,
    // so the offset decays; a fresh truth run shifted at 300 keeps it simple).
    let offset_rows: Vec<nalgebra::DVector<f64>> = (0..300)
        .scan(jump.clone(), |x, _| {
            let now = x.clone();
            *x = case.model.a() * &*x;
            Some(&h * now)
        })
        .collect();
    for (k, z) in case.measurements.iter_mut().enumerate().skip(300) {
        for (v, o) in z.iter_mut().zip(offset_rows[k - 300].iter()) {
            *v += o;
        }
    }
    for kind in FilterKind::ALL {
        let (mut f, mut s) = (filter(kind, &case, 1.0), fixed_supervisor());
        let mut reacquired_at = None;
        let mut lost = 0;
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
            f.predict(u, 0.01).unwrap();
            let outcome = s.gate(f.as_mut(), z).unwrap().clone();
            s.commit(|_| {});
            if outcome.reacquired.is_some() && reacquired_at.is_none() {
                reacquired_at = Some(k);
            }
            lost += usize::from(s.lost());
        }
        let at = reacquired_at.unwrap_or_else(|| panic!("{kind}: never re-acquired"));
        assert!(at < 300 + settings.reacquire_after as usize + 2, "{kind}: re-acquired at {at}");
        assert!(lost <= settings.reacquire_after as usize + 2, "{kind}: lost for {lost} samples");
        // Followed: the last 200 samples pass the gate.
        assert!(s.channels().iter().all(|c| !c.faulty && c.bad_run == 0), "{kind}");
        assert_eq!(s.reacquisitions(), 1, "{kind}");
    }
}

#[test]
fn re_acquisitions_stop_at_their_inflation_budget_when_the_sensors_are_far_noisier_than_r() {
    // Q and R told 1e6 too small (1000 in σ): after each re-acquisition the
    // update collapses P onto the told R and the next rows fail again, so
    // without a budget the filter re-acquires every reacquire_after samples,
    // multiplying P by up to 1e4 each time (here every direction is observed
    // and P collapses again; S5's coefficients are not, and there P overflows
    // or loses its definiteness: studies/tests/s5_study.rs). With the
    // default budget (1e8) it stops after two re-acquisitions, P stays finite
    // and the filter reports itself unhealthy; a sample that passes the gate
    // whole gives the budget back.
    let case = linear_case(1_000, 19);
    let h = case.model.h().clone();
    for kind in FilterKind::ALL {
        let (mut f, mut s) = (overconfident(kind, &case, 1e-6, 1e-6), fixed_supervisor());
        let mut unbounded =
            Supervisor::new(SupervisorSettings { max_inflation: 1e300, ..SupervisorSettings::default().fixed() }, 3)
                .unwrap();
        let mut g = overconfident(kind, &case, 1e-6, 1e-6);
        let mut unbounded_failed = false;
        for (u, z) in case.inputs.iter().zip(&case.measurements) {
            step(f.as_mut(), &mut s, u, z);
            assert!(f.covariance().iter().all(|p| p.is_finite()), "{kind}");
            if !unbounded_failed {
                g.predict(u, 0.01).unwrap();
                unbounded_failed = unbounded.gate(g.as_mut(), z).is_err();
                unbounded.commit(|_| {});
            }
        }
        assert!(s.exhausted() && !s.healthy(), "{kind}");
        assert!(s.reacquisitions() <= 2, "{kind}: {} re-acquisitions", s.reacquisitions());
        assert!(
            unbounded_failed || unbounded.reacquisitions() > 50,
            "{kind}: without a budget it re-acquires on ({} times)",
            unbounded.reacquisitions()
        );
        // Measurements the filter predicts exactly pass whole: the budget is back.
        f.predict(&case.inputs[0], 0.01).unwrap();
        let z: Vec<f64> = (&h * f.mean()).iter().copied().collect();
        s.gate(f.as_mut(), &z).unwrap();
        s.commit(|_| {});
        assert!(!s.exhausted(), "{kind}");
    }
}

#[test]
fn an_inconsistent_filter_is_reported_and_a_consistent_one_is_not() {
    // R told to the filter 25 times too small: σ of the innovations 5 times
    // too small, which the gate alone would mostly hide.
    let case = linear_case(1500, 15);
    for kind in FilterKind::ALL {
        let (mut f, mut s) = (filter(kind, &case, 1.0 / 25.0), supervisor());
        let mut unhealthy = 0;
        for (u, z) in case.inputs.iter().zip(&case.measurements) {
            step(f.as_mut(), &mut s, u, z);
            unhealthy += usize::from(!s.consistent());
        }
        assert!(unhealthy > 1000, "{kind}: inconsistent for only {unhealthy} of 1500 samples");
        assert!(s.windowed_nis() > 3.0, "{kind}: {}", s.windowed_nis());
    }
}

#[test]
fn a_gate_that_is_not_committed_changes_nothing() {
    // What an FMU's read does: gate a copy, show it, drop it.
    let case = linear_case(300, 16);
    for kind in FilterKind::ALL {
        let (mut a, mut sa) = (filter(kind, &case, 1.0), supervisor());
        let (mut b, mut sb) = (filter(kind, &case, 1.0), supervisor());
        let mut copy = filter(kind, &case, 1.0);
        for (k, (u, z)) in case.inputs.iter().zip(&case.measurements).enumerate() {
            let mut z = z.clone();
            if k % 7 == 0 {
                z[0] += 500.0;
            }
            a.predict(u, 0.01).unwrap();
            copy.restore(&a.snapshot()).unwrap();
            sa.gate(copy.as_mut(), &[f64::NAN, 1e6, 3.0]).unwrap();
            sa.gate(a.as_mut(), &z).unwrap();
            sa.commit(|_| {});
            step(b.as_mut(), &mut sb, u, &z);
            assert_eq!(bits(a.as_ref()), bits(b.as_ref()), "{kind} sample {k}");
        }
        assert_eq!((sa.rejected(), sa.healthy()), (sb.rejected(), sb.healthy()));
    }
}

#[test]
fn settings_out_of_range_are_refused_with_the_reason() {
    let bad = [
        SupervisorSettings { gate_probability: 0.0, ..SupervisorSettings::default() },
        SupervisorSettings { fault_after: 0, ..SupervisorSettings::default() },
        SupervisorSettings { stuck_after: 1, ..SupervisorSettings::default() },
        SupervisorSettings { consistency_probability: 1.0, ..SupervisorSettings::default() },
        SupervisorSettings { consistency_margin: 0.5, ..SupervisorSettings::default() },
    ];
    for settings in bad {
        assert!(Supervisor::new(settings, 2).is_err(), "{settings:?}");
    }
    let off = SupervisorSettings { gate_probability: 1.0, ..SupervisorSettings::default() };
    let case = linear_case(50, 17);
    let (mut f, mut s) = (filter(FilterKind::Ckf, &case, 1.0), Supervisor::new(off, 3).unwrap());
    let mut z = case.measurements[10].clone();
    z[0] += 1e4;
    f.predict(&case.inputs[0], 0.01).unwrap();
    assert_eq!(s.gate(f.as_mut(), &z).unwrap().rows, vec![RowOutcome::Used; 3], "probability 1: no gate");
}

#[test]
fn a_saved_memory_continues_exactly_and_a_corrupt_one_is_refused() {
    // What an FMU state carries: save after 300 samples with faults along the
    // way, load into a fresh supervisor, and both go on bit for bit.
    let case = linear_case(600, 18);
    let zs: Vec<Vec<f64>> = case
        .measurements
        .iter()
        .enumerate()
        .map(|(k, z)| {
            let mut z = z.clone();
            if k % 23 == 0 {
                z[1] += 300.0;
            }
            if (250..320).contains(&k) {
                z[2] = 1.5;
            }
            z
        })
        .collect();
    for kind in FilterKind::ALL {
        let (mut f, mut s) = (filter(kind, &case, 1.0), supervisor());
        for (u, z) in case.inputs[..300].iter().zip(&zs) {
            step(f.as_mut(), &mut s, u, z);
        }
        let mut words = Vec::new();
        s.save(&mut words);
        let (mut g, mut t) = (filter(kind, &case, 1.0), supervisor());
        t.load(&words).unwrap();
        g.restore(&f.snapshot()).unwrap();
        for (u, z) in case.inputs[300..].iter().zip(&zs[300..]) {
            let a = step(f.as_mut(), &mut s, u, z);
            let b = step(g.as_mut(), &mut t, u, z);
            assert_eq!(a, b, "{kind}");
            assert_eq!(bits(f.as_ref()), bits(g.as_ref()), "{kind}");
            assert_eq!((s.healthy(), s.rejected(), s.channels()), (t.healthy(), t.rejected(), t.channels()));
        }
        let mut fresh = supervisor();
        assert!(fresh.load(&words[1..]).is_err(), "truncated");
        let mut flag = words.clone();
        flag[5 + 2] = 7; // channel 0's fault flag, after the header's five words
        assert!(fresh.load(&flag).is_err(), "a flag of 7");
        assert_eq!(fresh.rejected(), 0, "a refused memory changes nothing");
    }
}

#[test]
fn a_quantised_bias_step_is_taken_into_its_bias_state_and_a_spike_is_not() {
    // S4's four position channels, each with its offset as a state: channel 2 slips by
    // one slot (0.086 m) for good at telegram 150; channel 0 has a spike of one slot at
    // 100. With quantised steps the slip is taken into channel 2's offset after `after`
    // rejected telegrams at that multiple, and nothing else moves; the spike is rejected
    // once and taken for nothing. The watch is part of the saved memory.
    use estimator::models::PrwTrain;
    use estimator::{Gaussian, QuantizedSteps};
    let model =
        PrwTrain { jerk_intensity: 1.0, channel_noise_std: 1.5e-3, ..PrwTrain::new([25.0, 25.0, -25.0, -25.0]) };
    let noise = model.noise(0.02).unwrap();
    let offsets = [0.03, -0.02, 0.01, -0.04];
    let prior =
        Gaussian::diagonal(&[0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0], &[1e-2, 1e-2, 1e-2, 2.5e-3, 2.5e-3, 2.5e-3, 2.5e-3]);
    let steps = QuantizedSteps { quantum: 0.086, after: 3, tolerance: 0.01, bias_states: model.bias_states() };
    let mut noise_rng = rng(21);
    let zs: Vec<Vec<f64>> = (0..300)
        .map(|k| {
            let s = 5.0 * 0.02 * k as f64;
            (0..4)
                .map(|c| {
                    let mut z = s + model.levers[c] + offsets[c] + 1.5e-3 * normal(&mut noise_rng);
                    if c == 2 && k >= 150 {
                        z += 0.086;
                    }
                    if c == 0 && k == 100 {
                        z += 0.086;
                    }
                    z
                })
                .collect()
        })
        .collect();
    for kind in FilterKind::ALL {
        let mut f = build_filter(kind, model, noise.clone(), &prior, UnscentedParams::default()).unwrap();
        let mut s = Supervisor::new(SupervisorSettings::default(), 4).unwrap().with_steps(steps.clone()).unwrap();
        let mut taken = Vec::new();
        let mut saved = None;
        for (k, z) in zs.iter().enumerate() {
            if k > 0 {
                f.predict(&[], 0.02).unwrap();
            }
            let outcome = s.gate(f.as_mut(), z).unwrap();
            for (c, step) in outcome.steps.iter().enumerate().filter(|(_, step)| **step != 0.0) {
                taken.push((k, c, *step));
            }
            s.commit(|_| {});
            if k == 151 {
                // Mid-watch: two rejections of channel 2 at +1 slot are remembered.
                let mut words = Vec::new();
                s.save(&mut words);
                saved = Some((words, f.snapshot()));
            }
        }
        assert_eq!(taken, vec![(152, 2, 0.086)], "{kind}");
        let offset = f.mean()[PrwTrain::OFFSETS + 2] - f.mean().iter().skip(PrwTrain::OFFSETS).sum::<f64>() / 4.0;
        let truth = offsets[2] + 0.086 - (offsets.iter().sum::<f64>() + 0.086) / 4.0;
        assert!((offset - truth).abs() < 3e-3, "{kind}: {offset} against {truth}");
        assert_eq!(s.channels()[0].rejected, 1, "{kind}: the spike");
        // The saved memory carries the watch: resumed at 152 it takes the same step.
        let (words, snapshot) = saved.unwrap();
        let mut g = build_filter(kind, model, noise.clone(), &prior, UnscentedParams::default()).unwrap();
        g.restore(&snapshot).unwrap();
        let mut t = Supervisor::new(SupervisorSettings::default(), 4).unwrap().with_steps(steps.clone()).unwrap();
        t.load(&words).unwrap();
        g.predict(&[], 0.02).unwrap();
        assert_eq!(t.gate(g.as_mut(), &zs[152]).unwrap().steps, vec![0.0, 0.0, 0.086, 0.0], "{kind}");
    }
    let bad = QuantizedSteps { after: 1, ..steps.clone() };
    assert!(Supervisor::new(SupervisorSettings::default(), 4).unwrap().with_steps(bad).is_err());
    let bad = QuantizedSteps { tolerance: 0.05, ..steps };
    assert!(Supervisor::new(SupervisorSettings::default(), 4).unwrap().with_steps(bad).is_err());
}
