//! The supervised loop as a specification, on a linear-Gaussian model with
//! controls, a spike, a stuck channel and a dropout, for every filter kind:
//! `run` is the predict–hold–gate–commit cycle made by hand (the commit's
//! adapted scale on `Q` taken by the filter), bit for bit; the
//! steps one by one (as the FMU makes them) give the same; an update previewed on
//! a copy and then committed is the update made directly; a failure says at
//! which sample it stopped, and no later sample is observed.

mod common;

use common::*;
use estimator::{
    build_filter, Event, FilterError, FilterKind, Noise, Sample, StateEstimator, SupervisedFilter, Supervisor,
    SupervisorSettings, UnscentedParams,
};

const DT: f64 = 0.01;

fn filter(kind: FilterKind, case: &LinearCase) -> Box<dyn StateEstimator> {
    let noise = Noise::new(case.q.clone(), case.r.clone()).unwrap();
    build_filter(kind, case.model.clone(), noise, &case.prior, UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 })
        .unwrap()
}

fn supervisor() -> Supervisor {
    Supervisor::new(SupervisorSettings::default(), 3).unwrap()
}

/// The case's measurements with a spike on row 0 at sample 40, row 1 stuck from
/// sample 60 to 79 and row 2 missing from 100 to 104.
fn faulty_measurements(case: &LinearCase) -> Vec<Vec<f64>> {
    let mut zs = case.measurements.clone();
    zs[40][0] += 100.0;
    for k in 61..80 {
        zs[k][1] = zs[60][1];
    }
    for z in &mut zs[100..105] {
        z[2] = f64::NAN;
    }
    zs
}

fn samples<'a>(zs: &'a [Vec<f64>], us: &'a [Vec<f64>]) -> impl Iterator<Item = Sample<'a>> {
    zs.iter().zip(us).enumerate().map(|(k, (z, u))| Sample { time: k as f64 * DT, z, controls: u })
}

fn bits(f: &dyn StateEstimator) -> Vec<u64> {
    f.mean().iter().chain(f.covariance().iter()).map(|x| x.to_bits()).collect()
}

#[test]
fn run_is_the_predict_hold_gate_commit_cycle_bit_for_bit() {
    let case = linear_case(150, 7);
    let zs = faulty_measurements(&case);
    for kind in FilterKind::ALL {
        let mut looped = SupervisedFilter::new(filter(kind, &case), supervisor()).unwrap();
        let (mut beliefs, mut events) = (Vec::new(), Vec::new());
        looped
            .run(DT, samples(&zs, &case.inputs), |step| {
                beliefs.push(bits(step.filter));
                events.extend(step.events.iter().copied());
            })
            .unwrap();

        let (mut by_hand, mut s) = (filter(kind, &case), supervisor());
        let mut hand_events = Vec::new();
        for (k, z) in zs.iter().enumerate() {
            if k > 0 {
                by_hand.predict(&case.inputs[k - 1], DT).unwrap();
            }
            by_hand.hold_input(&case.inputs[k]).unwrap();
            s.gate(by_hand.as_mut(), z).unwrap();
            let time = k as f64 * DT;
            s.commit(|c| hand_events.push(Event::Fault { channel: c.channel, faulty: c.faulty, time }));
            s.scale_process_noise_of(by_hand.as_mut()).unwrap();
            assert_eq!(beliefs[k], bits(by_hand.as_ref()), "{kind}: sample {k}");
        }
        assert_eq!(looped.supervisor().rejected(), s.rejected(), "{kind}");
        assert!(looped.supervisor().rejected() > 0, "{kind}: the spike and the stuck run are left out");
        let faults: Vec<Event> = events.iter().copied().filter(|e| matches!(e, Event::Fault { .. })).collect();
        assert_eq!(faults, hand_events, "{kind}");
        assert!(
            faults.iter().any(|e| matches!(e, Event::Fault { channel: 1, faulty: true, .. })),
            "{kind}: the stuck channel is flagged: {faults:?}"
        );
        assert_eq!(looped.skipped(), 5, "{kind}: the dropout's rows are counted as missing");
    }
}

#[test]
fn the_steps_one_by_one_and_a_committed_preview_are_the_loop() {
    let case = linear_case(120, 11);
    let zs = faulty_measurements(&case);
    for kind in FilterKind::ALL {
        let mut looped = SupervisedFilter::new(filter(kind, &case), supervisor()).unwrap();
        let mut beliefs = Vec::new();
        looped.run(DT, samples(&zs, &case.inputs), |step| beliefs.push(bits(step.filter))).unwrap();

        // Every other sample's update is first previewed on a copy (an FMU's read), then
        // committed from it; the others are made directly.
        let mut stepped = SupervisedFilter::new(filter(kind, &case), supervisor()).unwrap();
        let mut reader = filter(kind, &case);
        let mut copy = stepped.filter().snapshot();
        for (k, z) in zs.iter().enumerate() {
            if k > 0 {
                stepped.predict(&case.inputs[k - 1], DT).unwrap();
            }
            stepped.hold_input(&case.inputs[k]).unwrap();
            let time = k as f64 * DT;
            if k % 2 == 0 {
                stepped.filter().snapshot_into(&mut copy);
                reader.restore(&copy).unwrap();
                let before = bits(stepped.filter());
                stepped.preview(reader.as_mut(), z).unwrap();
                assert_eq!(before, bits(stepped.filter()), "{kind}: a preview leaves the filter alone");
                stepped.commit_preview(reader.as_ref(), &mut copy, z, time).unwrap();
            } else {
                stepped.update(z, time).unwrap();
            }
            assert_eq!(beliefs[k], bits(stepped.filter()), "{kind}: sample {k}");
        }
        assert_eq!(stepped.supervisor().rejected(), looped.supervisor().rejected(), "{kind}");
        assert_eq!((stepped.skipped(), stepped.nis().to_bits()), (looped.skipped(), looped.nis().to_bits()), "{kind}");
    }
}

#[test]
fn a_failure_names_its_sample_and_stops_the_run() {
    let case = linear_case(30, 3);
    let mut inputs = case.inputs.clone();
    inputs[12][0] = f64::NAN;
    let mut supervised = SupervisedFilter::new(filter(FilterKind::SrCkf, &case), supervisor()).unwrap();
    let mut observed = Vec::new();
    let error = supervised
        .run(DT, samples(&case.measurements, &inputs), |step| observed.push(step.index))
        .expect_err("a NaN control is refused");
    assert_eq!((error.sample, error.time), (12, 12.0 * DT));
    assert!(matches!(error.error, FilterError::NonFinite { .. }), "{error:?}");
    assert!(error.to_string().starts_with("t = 0.120 s (sample 12): "), "{error}");
    assert_eq!(observed, (0..12).collect::<Vec<_>>(), "samples 0 to 11, then the run stops");
    assert!(supervised.filter().mean().iter().all(|x| x.is_finite()), "the refused control changed nothing");
}

#[test]
fn a_supervisor_of_another_size_is_refused() {
    let case = linear_case(1, 1);
    let two = Supervisor::new(SupervisorSettings::default(), 2).unwrap();
    assert!(SupervisedFilter::new(filter(FilterKind::Ckf, &case), two).is_err());
}

/// A scalar random walk seen through noise: the Kalman filter's normalised
/// innovations are independent χ²(1) draws, so a window of `w` of them sums to
/// χ²(w) and the consistency test's false-alarm rate per sample is the one its
/// bound is set to.
fn random_walk_run(settings: SupervisorSettings, n: usize, seed: u64) -> (usize, usize) {
    use estimator::models::LinearGaussian;
    use estimator::Gaussian;
    use nalgebra::DMatrix;
    let one = || DMatrix::from_element(1, 1, 1.0);
    let model = LinearGaussian::new(one(), DMatrix::zeros(1, 1), one());
    let (q, r) = (0.01, 1.0);
    let noise = Noise::new(one() * q, one() * r).unwrap();
    // The prior at the filter's steady state, so that no start-up transient is counted.
    let p_steady = 0.5 * (q + (q * q + 4.0 * q * r).sqrt());
    let prior = Gaussian::diagonal(&[0.0], &[p_steady]);
    let filter = build_filter(FilterKind::Ckf, model, noise, &prior, UnscentedParams::default()).unwrap();
    let mut supervised = SupervisedFilter::new(filter, Supervisor::new(settings, 1).unwrap()).unwrap();
    let mut rng = rng(seed);
    let mut x = normal(&mut rng) * p_steady.sqrt();
    let zs: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            if k > 0 {
                x += q.sqrt() * normal(&mut rng);
            }
            vec![x + r.sqrt() * normal(&mut rng)]
        })
        .collect();
    let controls = vec![vec![0.0]; n];
    let (mut inconsistent, mut counted) = (0, 0);
    supervised
        .run(1.0, samples(&zs, &controls), |step| {
            // Once the window is full: before, it holds fewer samples than its bound is for.
            if step.index >= settings.window {
                counted += 1;
                inconsistent += usize::from(!step.supervisor.consistent());
            }
        })
        .unwrap();
    (inconsistent, counted)
}

#[test]
fn a_consistent_filter_is_called_inconsistent_at_the_rate_its_window_bound_is_set_to() {
    // Margin 1: the bound is the χ²(window) quantile of 1 − consistency_probability, so a
    // consistent filter is flagged on that share of its samples (measured: 0.0118 on this
    // seed). Over 200,000 samples of overlapping 50-sample windows the share's standard
    // deviation is about 0.15 of it.
    let probe = SupervisorSettings {
        consistency_probability: 0.01,
        consistency_margin: 1.0,
        window: 50,
        ..SupervisorSettings::default()
    };
    let (flagged, counted) = random_walk_run(probe, 200_000, 5);
    let rate = flagged as f64 / counted as f64;
    assert!((0.005..0.02).contains(&rate), "false-alarm rate {rate} per sample, bound set to 0.01");

    // The defaults (1e-6 per sample before a margin of 3 on a 200-sample window): the
    // bound is about 930 (3 × 310) against a χ²(200) sum, whose probability of exceeding it is
    // far below 1e-100. A consistent filter is never called unhealthy.
    let (flagged, counted) = random_walk_run(SupervisorSettings::default(), 200_000, 6);
    assert_eq!(flagged, 0, "{flagged} of {counted} samples flagged with the defaults");
}
