//! Once built, a filter allocates nothing per step: every buffer is the
//! filter's own. Counted with a global allocator that counts per thread (the
//! test harness runs tests on parallel threads).
// The counting allocator needs `unsafe impl GlobalAlloc`.
#![allow(unsafe_code)]

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use common::*;
use estimator::{
    build_filter, FilterKind, Gaussian, Model, Noise, StateEstimator, Supervisor, SupervisorSettings, UnscentedParams,
};

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_during(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

/// Steps each filter once to warm up, then counts allocations over many
/// steps with every measurement row present, some rows missing, and none.
fn assert_no_allocation_per_step(mut filter: Box<dyn StateEstimator>, zs: &[Vec<f64>], dt: f64) {
    let zs: Vec<Vec<f64>> = zs
        .iter()
        .enumerate()
        .map(|(k, z)| match k % 5 {
            1 => std::iter::once(f64::NAN).chain(z[1..].iter().copied()).collect(),
            2 => vec![f64::NAN; z.len()],
            _ => z.clone(),
        })
        .collect();
    filter.predict(&[], dt).unwrap();
    filter.update(&zs[0]).unwrap();
    let mut p = nalgebra::DMatrix::zeros(filter.state_dim(), filter.state_dim());
    let n = allocations_during(|| {
        for z in &zs {
            filter.predict(&[], dt).unwrap();
            let innovation = filter.update(z).unwrap();
            assert!(innovation.nis().is_finite());
            filter.write_covariance(&mut p);
            assert!(filter.variance(0) >= 0.0);
        }
    });
    assert_eq!(n, 0, "{} allocated {n} times in {} steps", filter.kind(), zs.len());
}

/// One filter of every kind on `model`.
fn every_filter<M: Model + Clone + 'static>(
    model: M,
    noise: &Noise,
    prior: &Gaussian,
    unscented: UnscentedParams,
) -> Vec<Box<dyn StateEstimator>> {
    FilterKind::ALL.map(|kind| build_filter(kind, model.clone(), noise.clone(), prior, unscented).unwrap()).into()
}

fn s1_filters() -> Vec<Box<dyn StateEstimator>> {
    let params = UnscentedParams { alpha: 0.5, beta: 2.0, kappa: 0.0 };
    every_filter(s1_model(), &s1_noise(), &s1_prior(), params)
}

#[test]
fn no_filter_allocates_per_step_on_the_s1_model() {
    let (zs, _) = s1_measurements(200, 0.005, 1.0, 0.05, 9);
    for filter in s1_filters() {
        assert_no_allocation_per_step(filter, &zs, 0.005);
    }
}

/// The supervisor's gate and bookkeeping allocate nothing per sample either,
/// with spikes rejected and a stuck channel left out along the way; with the
/// jumps and the adaptation on too (a spike on the load channel is a jump,
/// reviewed and retracted at the next sample).
#[test]
fn the_supervisor_allocates_nothing_per_sample() {
    let (zs, _) = s1_measurements(400, 0.005, 1.0, 0.05, 6);
    let settings = [SupervisorSettings::default(), SupervisorSettings::default().adaptive(200)];
    for (mut filter, settings) in settings.into_iter().flat_map(|s| s1_filters().into_iter().map(move |f| (f, s))) {
        let mut supervisor = Supervisor::new(settings, 2).unwrap();
        let mut z = vec![0.0; 2];
        let mut run = |filter: &mut Box<dyn StateEstimator>, range: std::ops::Range<usize>| {
            for k in range {
                z.copy_from_slice(&zs[k]);
                if k % 37 == 0 {
                    z[1] += 1e4;
                }
                if (200..240).contains(&k) {
                    z[0] = 0.25;
                }
                filter.predict(&[], 0.005).unwrap();
                supervisor.gate(filter.as_mut(), &z).unwrap();
                supervisor.commit(|_| {});
            }
        };
        run(&mut filter, 0..100);
        let kind = filter.kind();
        let n = allocations_during(|| run(&mut filter, 100..400));
        assert_eq!(n, 0, "{kind}: {n} allocations in 300 supervised samples");
    }
}

/// The supervised loop with a fixed-lag smoother (a lag of 40 samples, the
/// load states) allocates nothing per sample either, its reads included: every
/// other sample is updated as an FMU's read does it, previewed on a twin filter
/// and then committed.
#[test]
fn the_fixed_lag_smoother_allocates_nothing_per_sample() {
    let (zs, _) = s1_measurements(300, 0.005, 1.0, 0.05, 8);
    for (filter, mut reader) in s1_filters().into_iter().zip(s1_filters()) {
        let kind = filter.kind();
        let supervisor = Supervisor::new(SupervisorSettings::default(), 2).unwrap();
        let mut supervised = estimator::SupervisedFilter::new(filter, supervisor).unwrap();
        supervised.smooth_with_lag(&estimator::models::Oscillator2DofLoad::UNKNOWN_INPUTS, 40).unwrap();
        let mut copy = supervised.filter().snapshot();
        let mut run = |supervised: &mut estimator::SupervisedFilter, range: std::ops::Range<usize>| {
            for k in range {
                let t = k as f64 * 0.005;
                if k > 0 {
                    supervised.predict(&[], 0.005).unwrap();
                }
                assert!(supervised.lagged_estimate().unwrap().means[0].is_finite());
                if k % 2 == 0 {
                    supervised.update(&zs[k], t).unwrap();
                } else {
                    supervised.filter().snapshot_into(&mut copy);
                    reader.restore(&copy).unwrap();
                    supervised.preview(reader.as_mut(), &zs[k]).unwrap();
                    assert!(supervised.lagged_estimate_with_pending(reader.as_ref()).unwrap().means[0].is_finite());
                    supervised.commit_preview(reader.as_ref(), &mut copy, &zs[k], t).unwrap();
                }
                assert!(supervised.lagged_estimate().unwrap().variances[0] > 0.0);
            }
        };
        run(&mut supervised, 0..60);
        let n = allocations_during(|| run(&mut supervised, 60..300));
        assert_eq!(n, 0, "{kind}: {n} allocations in 240 smoothed samples");
    }
}

/// Copying a belief into a twin filter (what an FMU does for every read
/// between samples) allocates nothing once the snapshot's buffers exist, and
/// the twin then steps exactly as the original.
#[test]
fn copying_a_belief_between_twins_allocates_nothing_and_is_exact() {
    let (zs, _) = s1_measurements(50, 0.005, 1.0, 0.05, 4);
    for (mut original, mut twin) in s1_filters().into_iter().zip(s1_filters()) {
        for z in &zs[..20] {
            original.predict(&[], 0.005).unwrap();
            original.update(z).unwrap();
        }
        let mut copy = original.snapshot();
        let n = allocations_during(|| {
            for z in &zs[20..] {
                original.snapshot_into(&mut copy);
                twin.restore(&copy).unwrap();
                original.predict(&[], 0.005).unwrap();
                original.update(z).unwrap();
            }
        });
        assert_eq!(n, 0, "{}: {n} allocations copying beliefs", original.kind());
        original.snapshot_into(&mut copy);
        twin.restore(&copy).unwrap();
        for z in &zs[..10] {
            for f in [&mut original, &mut twin] {
                f.predict(&[], 0.005).unwrap();
                f.update(z).unwrap();
            }
        }
        let bits = |f: &dyn StateEstimator| -> Vec<u64> {
            f.mean().iter().chain(f.covariance().iter()).map(|x| x.to_bits()).collect()
        };
        assert_eq!(bits(original.as_ref()), bits(twin.as_ref()), "{}", original.kind());
    }
}

#[test]
fn no_filter_allocates_per_step_on_the_wheel_rail_model() {
    let (model, noise, prior, zs) = wheel_rail_case(100);
    for filter in every_filter(model, &noise, &prior, UnscentedParams::default()) {
        assert_no_allocation_per_step(filter, &zs, 0.001);
    }
}

/// The portable kernels (a CPU without AVX2, or the switch forcing them)
/// allocate nothing per step either.
#[test]
fn no_filter_allocates_per_step_on_the_portable_kernels() {
    estimator::with_portable_kernels(|| {
        no_filter_allocates_per_step_on_the_s1_model();
        no_filter_allocates_per_step_on_the_wheel_rail_model();
        the_supervisor_allocates_nothing_per_sample();
    });
}
