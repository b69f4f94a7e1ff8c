//! Cost of one filter cycle — `predict(&[], dt)` then `update(&z)` — for every
//! filter kind (CKF, SRCKF, SVD-CKF, UKF with α = 1, β = 0, κ = 0, EKF) on four
//! models:
//!
//! * `s1_6`: study S1, `Discretized::rk4(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()), 1)`,
//!   n = 6, m = 2;
//! * `wheel_rail_24`: study S2, `Discretized::rk4(WheelRailVertical { .. }, 1)` for Zhai's
//!   passenger car, n = 24, m = 7, with the study's tuning;
//! * `wheel_rail_roll_42`: study S3, `Discretized::rk4(WheelRailRoll { .. }, 1)` for Zhai's
//!   passenger car with roll, its forces returning to the static load, n = 42, m = 28 (the
//!   20 accelerations and the eight deflections), with the study's tuning;
//! * `missile_20`: study S5, `Discretized::rk4(Missile6Dof { .. }, 1)` for the tactical
//!   missile with its fins moved as sinusoids of `t`, n = 20, m = 12, with the study's
//!   tuning,
//!
//! all at `dt = 0.005 s` (`cases/`, which `examples/step_loop.rs` shares). Benchmarks are
//! named `step/<model>/<filter>`; `scripts/benchmark` prints them as the README's table.
//!
//! The same SRCKF cycle through the supervised loop (`SupervisedFilter`: predict, then
//! the gated update and its commit) is `supervised/<model>/<settings>`, with the
//! supervisor as it was before jumps and adaptation (`gate`, `SupervisorSettings::fixed`),
//! with jumps of the model's unknown inputs (`jumps`, adaptation off) and with both, the
//! default (`jumps+adaptation`). The last two differ by what the adaptation costs. The
//! default with a fixed-lag smoother of the unknown inputs, 100 samples back, and its
//! estimate read every step (`jumps+adaptation+lag100`: an FMU with `smoothing_lag`
//! 0.1 s at 1 kHz) shows what the smoothed outputs cost beside it.
//!
//! The measurements are simulated once, before any timing: the same model from
//! a non-zero initial state with seeded process noise, plus seeded measurement
//! noise. The timed loop cycles through them; when the sequence wraps, the
//! filter is reset (`StateEstimator::reset`) outside the timed region, so one
//! iteration is exactly one predict + update.
//!
//! Before the criterion groups run, every filter is run over the whole sequence
//! once (it must not fail), and the heap allocations per step (a counting
//! global allocator, 1000 steps after construction and one warm-up step) are
//! printed as `allocations per step: <model>/<filter> = <count>`.
//!
//! ```text
//! cargo bench -p estimator --bench filter_step
//! ```

// The counting global allocator needs `unsafe impl GlobalAlloc`; nothing else here is unsafe.
#![allow(unsafe_code)]

mod cases;

use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use cases::{built, checked_step, Case, FilterVisitor, DT, STEPS};
use criterion::Criterion;
use estimator::models::{Missile6Dof, Oscillator2DofLoad, WheelRailRoll, WheelRailVertical};
use estimator::{
    FilterError, Model, SquareRootCubature, StateEstimator, SupervisedFilter, Supervisor, SupervisorSettings,
};

/// Counts every `alloc`, `alloc_zeroed` and `realloc` call, then defers to [`System`].
struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged; the caller upholds `GlobalAlloc::alloc`'s contract.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `System` with `layout` (every allocation goes through it).
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: as for `dealloc`; the caller upholds `GlobalAlloc::realloc`'s contract.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Steps counted for the allocation figure (after one warm-up step).
const ALLOC_STEPS: usize = 1000;

/// Sanity run over the whole sequence, then the allocation count.
struct CheckAndCountAllocations;

impl FilterVisitor for CheckAndCountAllocations {
    fn visit<M, F: StateEstimator>(&mut self, case: &Case<M>, kind: &str, filter: Result<F, FilterError>) {
        let mut filter = built(case, kind, filter);
        for k in 0..STEPS {
            checked_step(case, kind, &mut filter, k);
        }
        assert!(filter.mean().iter().all(|v| v.is_finite()), "{}/{kind}: the final estimate is not finite", case.name);

        filter.reset(0.0, &case.prior).unwrap_or_else(|e| panic!("{}/{kind}: reset failed: {e}", case.name));
        checked_step(case, kind, &mut filter, 0);
        let before = ALLOCATIONS.load(Ordering::Relaxed);
        for k in 1..=ALLOC_STEPS {
            checked_step(case, kind, &mut filter, k);
        }
        let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
        println!("allocations per step: {}/{kind} = {}", case.name, allocations as f64 / ALLOC_STEPS as f64);
    }
}

/// The timed benchmark: one iteration is one predict + update.
struct Bench<'c>(&'c mut Criterion);

impl FilterVisitor for Bench<'_> {
    fn visit<M, F: StateEstimator>(&mut self, case: &Case<M>, kind: &str, filter: Result<F, FilterError>) {
        let mut filter = built(case, kind, filter);
        let mut next = 0usize;
        let mut group = self.0.benchmark_group(format!("step/{}", case.name));
        group.sample_size(50).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2));
        group.bench_function(kind, |b| {
            b.iter_custom(|iters| {
                let mut elapsed = Duration::ZERO;
                let mut left = iters;
                while left > 0 {
                    if next == STEPS {
                        // End of the sequence: restart, outside the timed region.
                        filter.reset(0.0, &case.prior).unwrap_or_else(|e| panic!("{}/{kind}: {e}", case.name));
                        next = 0;
                    }
                    let run = left.min((STEPS - next) as u64) as usize;
                    let start = Instant::now();
                    for k in next..next + run {
                        checked_step(case, kind, &mut filter, k);
                    }
                    elapsed += start.elapsed();
                    next += run;
                    left -= run as u64;
                }
                elapsed
            })
        });
        group.finish();
    }
}

/// The supervised loops the benchmarks compare, by name: the supervisor's settings and
/// the fixed-lag smoother's lag in samples (0: none).
fn supervised_variants() -> [(&'static str, SupervisorSettings, usize); 5] {
    let default = SupervisorSettings::default();
    // S2's and S3's wiring checks: the channels' own scores and their fault
    // signatures, the likeliest channel named and kept.
    let signatures = SupervisorSettings { wiring_sigmas: 8.0, wiring_signatures: true, ..default };
    [
        ("gate", default.fixed(), 0),
        ("jumps", default.adaptive(0), 0),
        ("jumps+adaptation", default, 0),
        ("jumps+adaptation+lag100", default, FIXED_LAG),
        ("jumps+adaptation+signatures", signatures, 0),
    ]
}

/// The fixed-lag smoother's lag of the last variant: 0.1 s at 1 kHz, as an FMU's
/// `smoothing_lag` of 0.1 s on S2 and S3 (the unknown inputs smoothed).
const FIXED_LAG: usize = 100;

/// The SRCKF of `case` through the supervised loop with each of [`supervisor_settings`],
/// the jumps in `unknown_inputs`: allocations per step, then the timed cycle.
fn bench_supervised<M: Model + Clone + 'static>(criterion: &mut Criterion, case: &Case<M>, unknown_inputs: &[usize]) {
    let n = case.model.state_dim();
    let build = |settings: SupervisorSettings, lag: usize| {
        let filter = SquareRootCubature::new(case.model.clone(), case.noise.clone(), &case.prior)
            .unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let supervisor = Supervisor::new(settings, case.m)
            .and_then(|s| s.with_jump_states(n, unknown_inputs))
            .unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let mut supervised =
            SupervisedFilter::new(Box::new(filter), supervisor).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        if lag > 0 {
            supervised.smooth_with_lag(unknown_inputs, lag).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        }
        supervised
    };
    let cycle = |supervised: &mut SupervisedFilter, k: usize| {
        let step =
            supervised.predict(&[], DT).and_then(|()| supervised.update(case.measurement(k), (k + 1) as f64 * DT));
        if let Err(e) = step {
            panic!("{}: the supervised SRCKF failed at step {k}: {e}", case.name);
        }
        supervised.take_events(|event| {
            black_box(event);
        });
        // What an FMU's read of the smoothed outputs costs, when there are any.
        if let Some(estimate) = supervised.lagged_estimate() {
            black_box(estimate.means);
        }
    };
    for (name, settings, lag) in supervised_variants() {
        let mut supervised = build(settings, lag);
        for k in 0..=ALLOC_STEPS {
            if k == 1 {
                ALLOCATIONS.store(0, Ordering::Relaxed);
            }
            cycle(&mut supervised, k);
        }
        let allocations = ALLOCATIONS.load(Ordering::Relaxed) as f64 / ALLOC_STEPS as f64;
        println!("allocations per step: supervised/{}/{name} = {allocations}", case.name);
    }
    let mut group = criterion.benchmark_group(format!("supervised/{}", case.name));
    group.sample_size(50).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2));
    for (name, settings, lag) in supervised_variants() {
        let mut supervised = build(settings, lag);
        let mut next = 0usize;
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let mut elapsed = Duration::ZERO;
                for _ in 0..iters {
                    if next == STEPS {
                        // End of the sequence: a new loop, outside the timed region.
                        supervised = build(settings, lag);
                        next = 0;
                    }
                    let start = Instant::now();
                    cycle(&mut supervised, next);
                    elapsed += start.elapsed();
                    next += 1;
                }
                elapsed
            })
        });
    }
    group.finish();
}

fn main() {
    let (s1, wheel_rail, wheel_rail_roll, missile) =
        (cases::s1(), cases::wheel_rail(), cases::wheel_rail_roll(), cases::missile());

    s1.for_each_filter(&mut CheckAndCountAllocations);
    wheel_rail.for_each_filter(&mut CheckAndCountAllocations);
    wheel_rail_roll.for_each_filter(&mut CheckAndCountAllocations);
    missile.for_each_filter(&mut CheckAndCountAllocations);

    let mut criterion = Criterion::default().configure_from_args();
    s1.for_each_filter(&mut Bench(&mut criterion));
    wheel_rail.for_each_filter(&mut Bench(&mut criterion));
    wheel_rail_roll.for_each_filter(&mut Bench(&mut criterion));
    missile.for_each_filter(&mut Bench(&mut criterion));
    bench_supervised(&mut criterion, &s1, &Oscillator2DofLoad::UNKNOWN_INPUTS);
    bench_supervised(&mut criterion, &wheel_rail, &WheelRailVertical::UNKNOWN_INPUTS);
    bench_supervised(&mut criterion, &wheel_rail_roll, &WheelRailRoll::UNKNOWN_INPUTS);
    bench_supervised(&mut criterion, &missile, &Missile6Dof::UNKNOWN_INPUTS);
    criterion.final_summary();
}
