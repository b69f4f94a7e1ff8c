//! The benchmark's cases, shared by the criterion benchmark (`filter_step.rs`) and the
//! bare loop for profilers (`examples/step_loop.rs`), so that a time and an instruction
//! count are of the same step: a model with its study's tuning, a simulated measurement
//! sequence, and the five filters built on it.

use estimator::math;
use estimator::models::{
    Airframe, Missile6Dof, Oscillator2Dof, Oscillator2DofLoad, RollVehicle, VerticalVehicle, WheelRailRoll,
    WheelRailVertical,
};
use estimator::{
    Component, CubatureKalman, Discretized, ExtendedKalman, FilterError, Gaussian, Model, Noise, Observation,
    SquareRootCubature, StateEstimator, SvdCubature, UnscentedKalman, UnscentedParams, VectorField,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::hint::black_box;

/// Sample time of every case (s).
pub const DT: f64 = 0.005;
/// Length of the simulated measurement sequence (10 s).
pub const STEPS: usize = 2000;
/// A model, the filter tuning and a simulated measurement sequence.
pub struct Case<M> {
    pub name: &'static str,
    pub model: M,
    pub noise: Noise,
    pub prior: Gaussian,
    pub m: usize,
    /// `STEPS` measurement vectors of length `m`, back to back.
    pub z: Vec<f64>,
}

impl<M> Case<M> {
    /// Measurement `k` of the sequence.
    pub fn measurement(&self, k: usize) -> &[f64] {
        &self.z[k * self.m..(k + 1) * self.m]
    }
}

impl<M: Model + Clone> Case<M> {
    /// Simulates `model` from `x0` with process noise of variances `q_true` and
    /// adds measurement noise of variances `r_true`: measurement `k` is taken
    /// at `t = (k + 1)·dt`, as a filter sees it after its `k + 1`-th predict.
    #[allow(clippy::too_many_arguments)]
    pub fn simulate(
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
    pub fn for_each_filter<V: FilterVisitor>(&self, visitor: &mut V) {
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
pub trait FilterVisitor {
    fn visit<M, F: StateEstimator>(&mut self, case: &Case<M>, kind: &str, filter: Result<F, FilterError>);
}

/// One predict + update with measurement `z`.
#[inline]
pub fn step<F: StateEstimator>(filter: &mut F, z: &[f64]) -> Result<(), FilterError> {
    filter.predict(&[], DT)?;
    black_box(filter.update(z)?);
    Ok(())
}

/// Unwraps a construction result with a clear message.
pub fn built<M, F>(case: &Case<M>, kind: &str, filter: Result<F, FilterError>) -> F {
    filter.unwrap_or_else(|e| panic!("{}/{kind}: the filter could not be built: {e}", case.name))
}

/// Fails loudly when a step errs.
pub fn checked_step<M, F: StateEstimator>(case: &Case<M>, kind: &str, filter: &mut F, k: usize) {
    if let Err(e) = step(filter, case.measurement(k)) {
        panic!("{}/{kind}: the filter failed at step {k} of {STEPS}: {e} (adjust Q/R/prior in the bench)", case.name);
    }
}

/// Study S1: state `[z₁, z₂, F, ż₁, ż₂, Ḟ]`, measurements `[z̈₁, z̈₂]`.
pub fn s1() -> Case<Discretized<Oscillator2DofLoad>> {
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
pub fn wheel_rail() -> Case<Discretized<WheelRailVertical>> {
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
pub fn wheel_rail_roll() -> Case<Discretized<WheelRailRoll>> {
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
pub struct MissileWithFins(Missile6Dof);

impl MissileWithFins {
    /// Roll, pitch and yaw deflections (rad).
    fn fins(t: f64) -> [f64; 3] {
        [0.01 * math::sin(1.3 * t), 0.03 * math::sin(0.7 * t), 0.02 * math::sin(0.9 * t)]
    }
}

impl VectorField for MissileWithFins {
    fn state_dim(&self) -> usize {
        self.0.state_dim()
    }

    fn derivative(&self, t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        self.0.derivative(t, x, &Self::fins(t), dxdt)
    }

    fn derivative_block(&self, t: f64, x: &[Component], _u: &[f64], dxdt: &mut [Component], scratch: &mut [f64]) {
        self.0.derivative_block(t, x, &Self::fins(t), dxdt, scratch)
    }
}

impl Observation for MissileWithFins {
    fn measurement_dim(&self) -> usize {
        self.0.measurement_dim()
    }

    fn observe(&self, t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.0.observe(t, x, &Self::fins(t), z)
    }

    fn observe_block(&self, t: f64, x: &[Component], _u: &[f64], z: &mut [Component], scratch: &mut [f64]) {
        self.0.observe_block(t, x, &Self::fins(t), z, scratch)
    }
}

/// Study S5: the missile from the study's start with its coefficients of Table 1, the
/// filter with the study's tuning (`studies/src/s5/study.rs`, `Tuning::new(1.0)`: the
/// coefficients' prior 20 % off with a σ of 30 %).
pub fn missile() -> Case<Discretized<MissileWithFins>> {
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
