//! Shared fixtures of the specification tests: a textbook Kalman filter written
//! independently of the library, and seeded data sets.
#![allow(dead_code)]

use estimator::math;
use estimator::models::{LinearGaussian, Oscillator2Dof, Oscillator2DofLoad, VerticalVehicle, WheelRailVertical};
use estimator::{Discretized, Gaussian, Noise, VectorField};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The Kalman filter as textbooks print it: explicit inverse of S, `P = (I − K·H)·P⁻`.
pub struct TextbookKalman {
    pub x: DVector<f64>,
    pub p: DMatrix<f64>,
}

impl TextbookKalman {
    pub fn predict(&mut self, model: &LinearGaussian, q: &DMatrix<f64>, u: &[f64]) {
        let u = DVector::from_column_slice(u);
        self.x = model.a() * &self.x + model.b() * u;
        self.p = model.a() * &self.p * model.a().transpose() + q;
    }

    /// Update with the rows of `z` that are not NaN.
    pub fn update(&mut self, model: &LinearGaussian, r: &DMatrix<f64>, z: &[f64]) {
        let rows: Vec<usize> = (0..z.len()).filter(|&i| !z[i].is_nan()).collect();
        if rows.is_empty() {
            return;
        }
        let h = model.h().select_rows(rows.iter());
        let r = r.select_rows(rows.iter()).select_columns(rows.iter());
        let z = DVector::from_iterator(rows.len(), rows.iter().map(|&i| z[i]));
        let s = &h * &self.p * h.transpose() + r;
        let k = &self.p * h.transpose() * s.try_inverse().expect("S invertible");
        self.x = &self.x + &k * (z - &h * &self.x);
        let n = self.x.len();
        self.p = (DMatrix::identity(n, n) - &k * &h) * &self.p;
    }
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Draws `L·w` with `L·Lᵀ = cov`.
pub fn correlated(rng: &mut ChaCha8Rng, cov: &DMatrix<f64>) -> DVector<f64> {
    let l = cov.clone().cholesky().expect("SPD").l();
    let w = DVector::from_fn(cov.nrows(), |_, _| normal(rng));
    l * w
}

/// A stable 4-state, 2-input, 3-output linear system with full Q and R.
pub struct LinearCase {
    pub model: LinearGaussian,
    pub q: DMatrix<f64>,
    pub r: DMatrix<f64>,
    pub prior: Gaussian,
    pub inputs: Vec<Vec<f64>>,
    pub measurements: Vec<Vec<f64>>,
}

pub fn linear_case(steps: usize, seed: u64) -> LinearCase {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[0.95, 0.10, 0.00, 0.02, -0.08, 0.90, 0.05, 0.00, 0.00, 0.03, 0.97, 0.10, 0.01, 0.00, -0.10, 0.92],
    );
    let b = DMatrix::from_row_slice(4, 2, &[0.1, 0.0, 0.0, 0.2, 0.05, 0.05, 0.0, 0.1]);
    let h = DMatrix::from_row_slice(3, 4, &[1.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, -0.3, 0.2, 0.0, 0.0, 1.0]);
    let q = DMatrix::from_row_slice(
        4,
        4,
        &[0.02, 0.005, 0.0, 0.001, 0.005, 0.03, 0.002, 0.0, 0.0, 0.002, 0.01, 0.003, 0.001, 0.0, 0.003, 0.04],
    );
    let r = DMatrix::from_row_slice(3, 3, &[0.1, 0.02, 0.0, 0.02, 0.2, 0.01, 0.0, 0.01, 0.05]);
    let prior = Gaussian {
        mean: DVector::from_column_slice(&[1.0, -1.0, 0.5, 2.0]),
        covariance: DMatrix::identity(4, 4) * 2.0,
    };
    let model = LinearGaussian::new(a, b, h);
    let mut rng = rng(seed);
    let mut x = DVector::from_column_slice(&[0.0, 0.0, 1.0, 1.0]);
    let (mut inputs, mut measurements) = (Vec::new(), Vec::new());
    for k in 0..steps {
        let u = vec![math::sin(0.05 * k as f64), math::cos(0.013 * k as f64)];
        x = model.a() * &x + model.b() * DVector::from_column_slice(&u) + correlated(&mut rng, &q);
        let z = model.h() * &x + correlated(&mut rng, &r);
        inputs.push(u);
        measurements.push(z.iter().copied().collect());
    }
    LinearCase { model, q, r, prior, inputs, measurements }
}

/// Study S1's augmented model (stiffness-nonlinear chain), RK4 once per sample.
pub fn s1_model() -> Discretized<Oscillator2DofLoad> {
    Discretized::rk4(Oscillator2DofLoad::new(Oscillator2Dof::stiffness_nonlinear()), 1)
}

/// S1 data: the chain driven by a multi-sine load large enough to cross both
/// breakpoints of the spring, integrated at 1e-4 s, accelerations with noise.
/// `amplitude` scales the load (1: about ±12 N, z₁ up to about 0.13 m).
pub fn s1_measurements(steps: usize, dt: f64, amplitude: f64, noise_std: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
    s1_measurements_with_step(steps, dt, amplitude, noise_std, seed, (usize::MAX, 0.0))
}

/// [`s1_measurements`] with the load stepping by `step.1` at sample `step.0` (a real
/// step: both masses feel it).
pub fn s1_measurements_with_step(
    steps: usize,
    dt: f64,
    amplitude: f64,
    noise_std: f64,
    seed: u64,
    step: (usize, f64),
) -> (Vec<Vec<f64>>, Vec<f64>) {
    let chain = Oscillator2Dof::stiffness_nonlinear();
    let plant = Oscillator2DofLoad::new(chain);
    let load = |t: f64| {
        let stepped = if t >= step.0 as f64 * dt - 1e-12 { step.1 } else { 0.0 };
        amplitude * 8.0 * math::sin(2.0 * std::f64::consts::PI * 1.0 * t)
            + amplitude * 4.0 * math::cos(2.0 * std::f64::consts::PI * 3.0 * t)
            + stepped
    };
    let mut rng = rng(seed);
    let sub = 50;
    let h = dt / sub as f64;
    let mut x = [0.0_f64; 6];
    let mut rk4 = estimator::Rk4::new(6);
    let (mut zs, mut loads) = (Vec::new(), Vec::new());
    for k in 0..steps {
        for s in 0..sub {
            let t = k as f64 * dt + s as f64 * h;
            x[2] = load(t);
            let mut next = [0.0; 6];
            rk4.step(&plant, t, h, &x, &[], &mut next);
            x = next;
        }
        let t = (k + 1) as f64 * dt;
        x[2] = load(t);
        let mut d = [0.0; 6];
        plant.derivative(t, &x, &[], &mut d);
        zs.push(vec![d[3] + noise_std * normal(&mut rng), d[4] + noise_std * normal(&mut rng)]);
        loads.push(x[2]);
    }
    (zs, loads)
}

pub fn s1_noise() -> Noise {
    Noise::diagonal(&[1e-10, 1e-10, 1e-4, 1e-8, 1e-8, 4.0], &[1e-4, 1e-4]).unwrap()
}

pub fn s1_prior() -> Gaussian {
    Gaussian::diagonal(&[0.0; 6], &[1e-4, 1e-4, 25.0, 1e-4, 1e-4, 100.0])
}

/// `max_k ‖a_k − b_k‖ / max_k ‖b_k‖` over a run.
pub fn relative_gap(a: &[DVector<f64>], b: &[DVector<f64>]) -> f64 {
    let scale = b.iter().map(|v| v.norm()).fold(0.0, f64::max);
    a.iter().zip(b).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max) / scale
}

/// The same for matrices.
pub fn relative_gap_m(a: &[DMatrix<f64>], b: &[DMatrix<f64>]) -> f64 {
    let scale = b.iter().map(|v| v.norm()).fold(0.0, f64::max);
    a.iter().zip(b).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max) / scale
}

/// Study S2's 24-state wheel–rail model (RK4 once per sample) with a diagonal `Q`
/// (motion states small, the four forces 1e10), `R` of 0.05 m/s² per channel, a prior
/// at the static wheel load, and `samples` synthetic rows of seven sines.
pub fn wheel_rail_case(samples: usize) -> (Discretized<WheelRailVertical>, Noise, Gaussian, Vec<Vec<f64>>) {
    let model = Discretized::rk4(WheelRailVertical { vehicle: VerticalVehicle::zhai_passenger() }, 1);
    let mut q = vec![1e-8; 6];
    q.extend([1e-10; 4]);
    q.extend([1e-8; 6]);
    q.extend([1e-10; 4]);
    q.extend([1e10; 4]);
    let noise = Noise::diagonal(&q, &[2.5e-3; 7]).unwrap();
    let mut mean = [0.0; 24];
    mean[20..].fill(VerticalVehicle::zhai_passenger().static_wheel_load);
    let prior = Gaussian::diagonal(&mean, &[1e-2; 24]);
    let zs = (0..samples).map(|k| (0..7).map(|i| 0.5 * math::sin((k * (i + 1)) as f64 * 0.1)).collect()).collect();
    (model, noise, prior, zs)
}
