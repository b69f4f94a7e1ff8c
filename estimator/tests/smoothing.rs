//! Smoothing from the supervised loop:
//! - each filter's kept cross-covariance is the one its point rule (or the EKF's
//!   Jacobian) gives from the filtered belief;
//! - the fixed-lag estimate is the fixed-interval smoother's on the measurements
//!   so far, `L` samples back, for every filter kind, behind a supervisor that
//!   rejects spikes and takes jumps;
//! - a jump's loosened prediction keeps the smoother from carrying it back;
//! - a fixed-lag smoother saved and loaded goes on bit for bit.

mod common;

use common::*;
use estimator::models::Oscillator2DofLoad;
use estimator::{
    build_filter, cross_covariance, linearised_cross_covariance, smooth, FilterKind, FixedLagSmoother, Gaussian,
    SigmaPoints, SmoothingStep, StateEstimator, SupervisedFilter, Supervisor, SupervisorSettings, Transition,
    UnscentedParams,
};
use nalgebra::DMatrix;

const DT: f64 = 0.005;
const UNSCENTED: UnscentedParams = UnscentedParams { alpha: 0.5, beta: 2.0, kappa: 0.0 };

fn filter(kind: FilterKind) -> Box<dyn StateEstimator> {
    build_filter(kind, s1_model(), s1_noise(), &s1_prior(), UNSCENTED).unwrap()
}

fn belief(filter: &dyn StateEstimator) -> Gaussian {
    Gaussian { mean: filter.mean().clone(), covariance: filter.covariance() }
}

#[test]
fn each_filter_keeps_the_cross_covariance_its_own_rule_gives() {
    let (zs, _) = s1_measurements(60, DT, 1.0, 0.05, 3);
    for kind in FilterKind::ALL {
        let mut f = filter(kind);
        f.keep_cross_covariance();
        for z in &zs[..40] {
            f.predict(&[], DT).unwrap();
            f.update(z).unwrap();
        }
        let before = belief(f.as_ref());
        f.predict(&[], DT).unwrap();
        let kept = f.cross_covariance().unwrap().clone();
        // The model is time-invariant: the instant the points start from does not matter.
        let (mut process, t) = (s1_model(), 0.0);
        let recomputed = match kind {
            FilterKind::Ekf => linearised_cross_covariance(&mut process, &before, t, DT, &[]),
            FilterKind::Ukf => {
                let points = SigmaPoints::unscented(6, UNSCENTED).unwrap();
                cross_covariance(&mut process, &points, &before, t, DT, &[])
            }
            _ => cross_covariance(&mut process, &SigmaPoints::cubature(6), &before, t, DT, &[]),
        }
        .unwrap();
        let gap = (&kept - &recomputed).norm() / recomputed.norm();
        assert!(gap < 1e-9, "{kind}: kept and recomputed cross-covariances differ by {gap:e}");
    }
}

/// The filtered beliefs, the transitions to each sample after the first and the
/// fixed-lag estimates (means, variances, time) of a supervised run with spikes
/// on one channel and a step in the load the jump test catches.
struct Run {
    filtered: Vec<Gaussian>,
    transitions: Vec<Transition>,
    lagged: Vec<(f64, Vec<f64>, Vec<f64>)>,
    rejected: u64,
    jumps: u64,
}

fn supervised_run(kind: FilterKind, lag: usize, samples: usize) -> Run {
    // The load steps by 40 N at the middle sample (z₂ by about 5 m/s²).
    let (zs, _) = s1_measurements_with_step(samples, DT, 1.0, 0.05, 11, (samples / 2, 40.0));
    let supervisor = Supervisor::new(SupervisorSettings::default(), 2)
        .and_then(|s| s.with_jump_states(6, &Oscillator2DofLoad::UNKNOWN_INPUTS))
        .unwrap();
    let mut supervised = SupervisedFilter::new(filter(kind), supervisor).unwrap();
    let states = Oscillator2DofLoad::UNKNOWN_INPUTS;
    supervised.smooth_with_lag(&states, lag).unwrap();
    let mut run = Run { filtered: Vec::new(), transitions: Vec::new(), lagged: Vec::new(), rejected: 0, jumps: 0 };
    for (k, z) in zs.iter().enumerate() {
        let mut z = z.clone();
        if k % 53 == 17 {
            z[1] += 1e3;
        }
        if k > 0 {
            supervised.predict(&[], DT).unwrap();
        }
        supervised.hold_input(&[]).unwrap();
        supervised.update(&z, k as f64 * DT).unwrap();
        run.filtered.push(belief(supervised.filter()));
        if k > 0 {
            run.transitions.push(supervised.transition().unwrap().clone());
        }
        let lagged = supervised.lagged_estimate().unwrap();
        run.lagged.push((lagged.time, lagged.means.to_vec(), lagged.variances.to_vec()));
    }
    run.rejected = supervised.supervisor().rejected();
    run.jumps = supervised.supervisor().jumps();
    run
}

#[test]
fn the_fixed_lag_estimate_is_the_fixed_interval_smoother_on_the_measurements_so_far() {
    let (lag, samples) = (15, 240);
    for kind in FilterKind::ALL {
        let run = supervised_run(kind, lag, samples);
        assert!(run.rejected > 0 && run.jumps > 0, "{kind}: the run must reject spikes and take a jump");
        for k in [3, lag, lag + 1, 100, samples / 2 + 5, samples - 1] {
            let steps: Vec<SmoothingStep> = (0..k)
                .map(|j| SmoothingStep {
                    filtered: run.filtered[j].clone(),
                    predicted: run.transitions[j].predicted.clone(),
                    cross: run.transitions[j].cross.clone(),
                })
                .collect();
            let smoothed = smooth(&steps, &run.filtered[k]).unwrap();
            let target = k.saturating_sub(lag);
            let (time, means, variances) = &run.lagged[k];
            assert!((time - target as f64 * DT).abs() < 1e-9, "{kind} at sample {k}: the estimate is of {time} s");
            for (a, &s) in Oscillator2DofLoad::UNKNOWN_INPUTS.iter().enumerate() {
                let reference = &smoothed[target];
                let sigma = reference.covariance[(s, s)].sqrt();
                let mean_gap = (means[a] - reference.mean[s]).abs() / sigma;
                let variance_gap = (variances[a] - reference.covariance[(s, s)]).abs() / reference.covariance[(s, s)];
                assert!(
                    mean_gap < 1e-7 && variance_gap < 1e-7,
                    "{kind} at sample {k}, state {s}: mean off by {mean_gap:e} σ, variance by {variance_gap:e}"
                );
            }
        }
    }
}

#[test]
fn a_saved_fixed_lag_smoother_goes_on_bit_for_bit() {
    let run = supervised_run(FilterKind::SrCkf, 10, 60);
    let states = Oscillator2DofLoad::UNKNOWN_INPUTS;
    let mut original = FixedLagSmoother::new(6, &states, 10).unwrap();
    original.start(0.0, &run.filtered[0].mean, &run.filtered[0].covariance);
    let push = |s: &mut FixedLagSmoother, j: usize| {
        let f = &run.filtered[j + 1];
        s.push((j + 1) as f64 * DT, &run.transitions[j], &f.mean, &f.covariance).unwrap();
    };
    for j in 0..30 {
        push(&mut original, j);
    }
    let mut words = Vec::new();
    original.save(&mut words);
    let mut loaded = FixedLagSmoother::new(6, &states, 10).unwrap();
    assert_eq!(loaded.load(&words).unwrap(), words.len());
    for j in 30..59 {
        push(&mut original, j);
        push(&mut loaded, j);
        let bits = |s: &FixedLagSmoother| {
            let e = s.estimate().unwrap();
            (e.time.to_bits(), e.means.iter().chain(e.variances).map(|v| v.to_bits()).collect::<Vec<_>>())
        };
        assert_eq!(bits(&original), bits(&loaded), "after step {j}");
    }
    // A truncated or foreign state is refused and changes nothing.
    let before = loaded.estimate().unwrap().means.to_vec();
    assert!(loaded.load(&words[..words.len() - 1]).is_err());
    let mut wrong_lag = FixedLagSmoother::new(6, &states, 3).unwrap();
    assert!(wrong_lag.load(&words).is_err());
    assert_eq!(loaded.estimate().unwrap().means, &before[..]);
}

#[test]
fn a_singular_prediction_restarts_the_smoother_at_the_belief() {
    let states = [0, 1];
    let mut smoother = FixedLagSmoother::new(3, &states, 4).unwrap();
    let belief = Gaussian::diagonal(&[1.0, 2.0, 3.0], &[1.0, 1.0, 1.0]);
    smoother.start(0.0, &belief.mean, &belief.covariance);
    let singular =
        Transition { cross: DMatrix::identity(3, 3), predicted: Gaussian::diagonal(&[0.0; 3], &[1.0, 0.0, 1.0]) };
    let next = Gaussian::diagonal(&[4.0, 5.0, 6.0], &[0.5, 0.5, 0.5]);
    assert!(smoother.push(0.1, &singular, &next.mean, &next.covariance).is_err());
    let estimate = smoother.estimate().unwrap();
    assert_eq!((estimate.time, estimate.means), (0.1, &[4.0, 5.0][..]));
}

/// The load steps at the middle sample; the gate takes it as a jump and loosens
/// the prediction there, so the smoother does not carry the step back to before
/// it (without that, the smoother carries the step back to the samples before it).
#[test]
fn a_jump_is_not_carried_back_before_it_happened() {
    let (lag, samples) = (15, 240);
    let load = Oscillator2DofLoad::UNKNOWN_INPUTS[0];
    for kind in FilterKind::ALL {
        let run = supervised_run(kind, lag, samples);
        for k in [samples / 2 - 5, samples / 2 - 1] {
            let filtered = &run.filtered[k];
            let (_, means, _) = &run.lagged[k + lag];
            let off = (means[0] - filtered.mean[load]).abs() / filtered.covariance[(load, load)].sqrt();
            assert!(off < 3.0, "{kind}: the smoothed load {k} samples in is {off:.1} σ from the filtered");
        }
        let after = run.lagged[samples / 2 + lag].1[0];
        let settled = run.filtered[samples / 2 + lag].mean[load];
        assert!(
            (after - settled).abs() < 0.1 * settled.abs(),
            "{kind}: smoothed {after} at the step, {settled} after it"
        );
    }
}
