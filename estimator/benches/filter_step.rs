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
//! all at `dt = 0.005 s`. Benchmarks are named `step/<model>/<filter>`.
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

use std::alloc::{GlobalAlloc, Layout, System};
use std::hint::black_box;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use criterion::Criterion;
use estimator::models::{
    Airframe, Missile6Dof, Oscillator2Dof, Oscillator2DofLoad, RollVehicle, VerticalVehicle, WheelRailRoll,
    WheelRailVertical,
};
use estimator::{
    CubatureKalman, Discretized, ExtendedKalman, FilterError, Gaussian, Model, Noise, Observation, SquareRootCubature,
    StateEstimator, SupervisedFilter, Supervisor, SupervisorSettings, SvdCubature, UnscentedKalman, UnscentedParams,
    VectorField,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

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

/// Sample time of both models (s).
const DT: f64 = 0.005;
/// Length of the simulated measurement sequence (10 s).
const STEPS: usize = 2000;
/// Steps counted for the allocation figure (after one warm-up step).
const ALLOC_STEPS: usize = 1000;

/// A model, the filter tuning and a simulated measurement sequence.
struct Case<M> {
    name: &'static str,
    model: M,
    noise: Noise,
    prior: Gaussian,
    m: usize,
    /// `STEPS` measurement vectors of length `m`, back to back.
    z: Vec<f64>,
}

impl<M> Case<M> {
    /// Measurement `k` of the sequence.
    fn measurement(&self, k: usize) -> &[f64] {
        &self.z[k * self.m..(k + 1) * self.m]
    }
}

impl<M: Model + Clone> Case<M> {
    /// Simulates `model` from `x0` with process noise of variances `q_true` and
    /// adds measurement noise of variances `r_true`: measurement `k` is taken
    /// at `t = (k + 1)·dt`, as a filter sees it after its `k + 1`-th predict.
    #[allow(clippy::too_many_arguments)]
    fn simulate(
        name: &'static str,
        model: M,
        noise: Noise,
        prior: Gaussian,
        x0: &[f64],
        q_true: &[f64],
        r_true: &[f64],
        seed: u64,
    ) -> Self {
        let (n, m) = (model.state_dim(), model.measurement_dim());
        assert_eq!((x0.len(), q_true.len(), r_true.len()), (n, n, m), "{name}: inconsistent simulation settings");
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut truth = model.clone();
        let (mut x, mut x_next, mut y) = (x0.to_vec(), vec![0.0; n], vec![0.0; m]);
        let mut z = Vec::with_capacity(STEPS * m);
        for k in 0..STEPS {
            let t = k as f64 * DT;
            truth.transition(t, DT, &x, &[], &mut x_next);
            for (xi, (next, q)) in x.iter_mut().zip(x_next.iter().zip(q_true)) {
                *xi = next + q.sqrt() * rng.sample::<f64, _>(StandardNormal);
            }
            truth.observe(t + DT, &x, &[], &mut y);
            z.extend(y.iter().zip(r_true).map(|(yi, r)| yi + r.sqrt() * rng.sample::<f64, _>(StandardNormal)));
        }
        assert!(z.iter().all(|v| v.is_finite()), "{name}: the simulated measurements are not finite");
        Self { name, model, noise, prior, m, z }
    }

    /// Builds each of the five filters and hands it to `visitor`.
    fn for_each_filter<V: FilterVisitor>(&self, visitor: &mut V) {
        let (model, noise, prior) = (|| self.model.clone(), || self.noise.clone(), &self.prior);
        let ckf_equal = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
        visitor.visit(self, "CKF", CubatureKalman::cubature(model(), noise(), prior));
        visitor.visit(self, "SRCKF", SquareRootCubature::new(model(), noise(), prior));
        visitor.visit(self, "SVD-CKF", SvdCubature::svd_cubature(model(), noise(), prior));
        visitor.visit(self, "UKF", UnscentedKalman::unscented(model(), noise(), prior, ckf_equal));
        visitor.visit(self, "EKF", ExtendedKalman::new(model(), noise(), prior));
    }
}

/// Does something with one freshly built filter (monomorphised per filter type).
trait FilterVisitor {
    fn visit<M, F: StateEstimator>(&mut self, case: &Case<M>, kind: &str, filter: Result<F, FilterError>);
}

/// One predict + update with measurement `z`.
#[inline]
fn step<F: StateEstimator>(filter: &mut F, z: &[f64]) -> Result<(), FilterError> {
    filter.predict(&[], DT)?;
    black_box(filter.update(z)?);
    Ok(())
}

/// Unwraps a construction result with a clear message.
fn built<M, F>(case: &Case<M>, kind: &str, filter: Result<F, FilterError>) -> F {
    filter.unwrap_or_else(|e| panic!("{}/{kind}: the filter could not be built: {e}", case.name))
}

/// Fails loudly when a step errs.
fn checked_step<M, F: StateEstimator>(case: &Case<M>, kind: &str, filter: &mut F, k: usize) {
    if let Err(e) = step(filter, case.measurement(k)) {
        panic!("{}/{kind}: the filter failed at step {k} of {STEPS}: {e} (adjust Q/R/prior in the bench)", case.name);
    }
}

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
fn supervised_variants() -> [(&'static str, SupervisorSettings, usize); 4] {
    let default = SupervisorSettings::default();
    [
        ("gate", default.fixed(), 0),
        ("jumps", default.adaptive(0), 0),
        ("jumps+adaptation", default, 0),
        ("jumps+adaptation+lag100", default, FIXED_LAG),
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

/// Study S1: state `[z₁, z₂, F, ż₁, ż₂, Ḟ]`, measurements `[z̈₁, z̈₂]`.
fn s1() -> Case<Discretized<Oscillator2DofLoad>> {
    let model = Discretized::rk4(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()), 1);
    let noise = Noise::diagonal(&[1e-8, 1e-8, 1e-2, 1e-6, 1e-6, 10.0], &[1e-4, 1e-4]).expect("valid S1 noise");
    let prior = Gaussian::diagonal(&[0.0; 6], &[1e-2, 1e-2, 100.0, 1e-2, 1e-2, 100.0]);
    // The truth starts displaced (beyond the first breakpoint of k₁) and its
    // load drifts as a second-order random walk.
    let x0 = [0.15, 0.25, 2.0, 0.0, 0.0, 0.0];
    let q_true = [0.0, 0.0, 0.0, 0.0, 0.0, 1e-3];
    Case::simulate("s1_6", model, noise, prior, &x0, &q_true, &[1e-4, 1e-4], 1)
}

/// Study S2: the half vehicle on one rail (Zhai's passenger car), the four wheel–rail
/// forces as random walks, seven accelerometers; the study's tuning
/// (`studies/src/s2/study.rs`).
fn wheel_rail() -> Case<Discretized<WheelRailVertical>> {
    let vehicle = VerticalVehicle::zhai_passenger();
    let model = Discretized::rk4(WheelRailVertical { vehicle }, 1);
    let motion: Vec<f64> = [1e-8; 6].into_iter().chain([1e-10; 4]).collect();
    let q: Vec<f64> = motion.iter().chain(&motion).copied().chain([1e10 * DT / 1e-3; 4]).collect();
    let noise = Noise::diagonal(&q, &[2.5e-3; 7]).expect("valid S2 noise");
    let mut mean = [0.0; 24];
    mean[20..].fill(vehicle.static_wheel_load);
    let prior = Gaussian::diagonal(&mean, &[1e-2; 24]);
    // The truth starts displaced and moving, its forces off the static load and drifting.
    let mut x0 = mean;
    for i in 0..10 {
        x0[i] = 1e-4 * (i as f64 + 1.0);
        x0[10 + i] = if i % 2 == 0 { 0.02 } else { -0.01 };
    }
    for (j, f) in x0[20..].iter_mut().enumerate() {
        *f += 1e3 * (j as f64 - 1.5);
    }
    let q_true: Vec<f64> = [0.0; 20].into_iter().chain([1e6; 4]).collect();
    Case::simulate("wheel_rail_24", model, noise, prior, &x0, &q_true, &[2.5e-3; 7], 3)
}

/// Study S3: the whole car with roll (Zhai's passenger car), the eight wheel–rail forces
/// returning to the static load at 5 /s, 20 accelerometers and eight deflection
/// transducers; the study's tuning (`studies/src/s3/study.rs`).
fn wheel_rail_roll() -> Case<Discretized<WheelRailRoll>> {
    let vehicle = RollVehicle::zhai_passenger();
    let model = Discretized::rk4(WheelRailRoll { vehicle, force_return_rate: 5.0 }, 1);
    let motion: Vec<f64> = [9e-7 * DT; 9].into_iter().chain([1e-7 * DT; 8]).collect();
    let q: Vec<f64> = motion.iter().chain(&motion).copied().chain([1e9 * DT; 8]).collect();
    let r: Vec<f64> = [2.5e-3; 20].into_iter().chain([1e-10; 8]).collect();
    let noise = Noise::diagonal(&q, &r).expect("valid S3 noise");
    let mut mean = [0.0; 42];
    mean[WheelRailRoll::FORCES..].fill(vehicle.static_wheel_load);
    let prior = Gaussian::diagonal(&mean, &[1e-2; 42]);
    // The truth starts displaced and moving, its forces off the static load and drifting.
    let mut x0 = mean;
    for i in 0..17 {
        x0[i] = 1e-4 * (i as f64 + 1.0);
        x0[17 + i] = if i % 2 == 0 { 0.02 } else { -0.01 };
    }
    for (j, f) in x0[WheelRailRoll::FORCES..].iter_mut().enumerate() {
        *f += 1e3 * (j as f64 - 3.5);
    }
    let q_true: Vec<f64> = [0.0; 34].into_iter().chain([1e6; 8]).collect();
    Case::simulate("wheel_rail_roll_42", model, noise, prior, &x0, &q_true, &r, 4)
}

/// Study S5's 20-state estimation model, `Missile6Dof` for the tactical missile, its fins
/// moved as fixed sinusoids of `t` (the bench's filters take no inputs; the study's
/// manoeuvre is a pattern of steps, which costs a step the same).
#[derive(Debug, Clone, Copy)]
struct MissileWithFins(Missile6Dof);

impl MissileWithFins {
    /// Roll, pitch and yaw deflections (rad).
    fn fins(t: f64) -> [f64; 3] {
        [0.01 * (1.3 * t).sin(), 0.03 * (0.7 * t).sin(), 0.02 * (0.9 * t).sin()]
    }
}

impl VectorField for MissileWithFins {
    fn state_dim(&self) -> usize {
        self.0.state_dim()
    }

    fn derivative(&self, t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        self.0.derivative(t, x, &Self::fins(t), dxdt)
    }
}

impl Observation for MissileWithFins {
    fn measurement_dim(&self) -> usize {
        self.0.measurement_dim()
    }

    fn observe(&self, t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.0.observe(t, x, &Self::fins(t), z)
    }
}

/// Study S5: the missile from the study's start with its coefficients of Table 1, the
/// filter with the study's tuning (`studies/src/s5/study.rs`, `Tuning::new(1.0)`: the
/// coefficients' prior 20 % off with a σ of 30 %).
fn missile() -> Case<Discretized<MissileWithFins>> {
    let model = Discretized::rk4(MissileWithFins(Missile6Dof { airframe: Airframe::tactical_missile() }), 1);
    let deg = f64::to_radians;
    let start = [1000.0, 10.0, 10.0, deg(15.0), deg(3.0), deg(3.0), 10_000.0, deg(3.0), deg(3.0), deg(3.0)];
    let coefficients = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];
    let x0: Vec<f64> = start.into_iter().chain(coefficients).collect();
    let mean: Vec<f64> = start.into_iter().chain(coefficients.map(|c| 1.2 * c)).collect();
    let motion_std = [5.0, 5.0, 5.0, 0.01, 0.01, 0.01, 10.0, 0.01, 0.01, 0.01];
    let std: Vec<f64> = motion_std.into_iter().chain(coefficients.map(|c| (0.3 * c).abs().max(0.02))).collect();
    let prior = Gaussian::diagonal(&mean, &std.iter().map(|s| s * s).collect::<Vec<_>>());
    let motion_q = [1e-6, 1e-6, 1e-6, 1e-12, 1e-12, 1e-12, 1e-6, 1e-12, 1e-12, 1e-12];
    let q: Vec<f64> =
        motion_q.into_iter().chain(mean[10..].iter().map(|c| (5e-5 * c.abs().max(0.05)).powi(2))).collect();
    let r = [1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1.0, 4e-6, 4e-6];
    let noise = Noise::diagonal(&q, &r).expect("valid S5 noise");
    Case::simulate("missile_20", model, noise, prior, &x0, &[0.0; 20], &r, 5)
}

fn main() {
    let (s1, wheel_rail, wheel_rail_roll, missile) = (s1(), wheel_rail(), wheel_rail_roll(), missile());

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
