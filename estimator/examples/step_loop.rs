//! A bare loop of filter steps on the 24-state chain, for profilers: unlike the
//! criterion benchmark it does a known number of steps, so instruction counts
//! divide into a per-step figure.
//!
//! ```text
//! cargo build --release -p estimator --example step_loop
//! valgrind --tool=callgrind target/release/examples/step_loop srckf 2000
//! perf record -g target/release/examples/step_loop srckf 50000
//! ```
//!
//! Arguments: the filter (`ckf`, `srckf`, `svd`, `ukf`, `ekf`; default `srckf`)
//! and the number of predict + update steps (default 10000). The measurements
//! are the model's own response from a displaced, moving start with forces
//! that step every second, plus seeded noise; the sequence repeats every 2000 steps.

use std::time::Instant;

use estimator::models::SpringChainForces;
use estimator::{build_filter, Discretized, FilterKind, Gaussian, Noise, Observation, Process, UnscentedParams};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

const DT: f64 = 0.005;
const SEQUENCE: usize = 2000;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = match args.get(1).map(String::as_str).unwrap_or("srckf") {
        "ckf" => FilterKind::Ckf,
        "srckf" => FilterKind::SrCkf,
        "svd" => FilterKind::SvdCkf,
        "ukf" => FilterKind::Ukf,
        "ekf" => FilterKind::Ekf,
        other => {
            eprintln!("unknown filter {other:?}: use ckf, srckf, svd, ukf or ekf");
            std::process::exit(2);
        }
    };
    let steps: usize = args.get(2).map_or(10_000, |s| s.parse().expect("the step count is an integer"));

    let mut model = Discretized::rk4(SpringChainForces::default(), 1);
    let (n, m) = (model.state_dim(), model.measurement_dim());
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut x: Vec<f64> = (0..n).map(|i| if i < 10 { 1e-3 * (i + 1) as f64 } else { 0.0 }).collect();
    for i in 0..10 {
        x[10 + i] = if i % 2 == 0 { 0.3 } else { -0.2 };
    }
    let (mut x_next, mut y) = (vec![0.0; n], vec![0.0; m]);
    let mut z = Vec::with_capacity(SEQUENCE * m);
    for k in 0..SEQUENCE {
        if k % 200 == 0 {
            for f in &mut x[20..] {
                *f = 500.0 * rng.sample::<f64, _>(StandardNormal);
            }
        }
        model.transition(k as f64 * DT, DT, &x, &[], &mut x_next);
        x.copy_from_slice(&x_next);
        model.observe((k + 1) as f64 * DT, &x, &[], &mut y);
        z.extend(y.iter().map(|v| v + 0.1 * rng.sample::<f64, _>(StandardNormal)));
    }

    let q: Vec<f64> = [1e-12; 10].into_iter().chain([1e-8; 10]).chain([1e2; 4]).collect();
    let noise = Noise::diagonal(&q, &[1e-2; 7]).expect("valid noise");
    let p0: Vec<f64> = [1e-4; 10].into_iter().chain([1e-1; 10]).chain([1e6; 4]).collect();
    let prior = Gaussian::diagonal(&[0.0; 24], &p0);
    let ukf = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
    let mut filter = build_filter(kind, model, noise, &prior, ukf).expect("the filter builds");

    let start = Instant::now();
    for k in 0..steps {
        let j = k % SEQUENCE;
        if j == 0 && k > 0 {
            filter.reset(0.0, &prior).expect("reset");
        }
        filter.predict(&[], DT).expect("predict");
        filter.update(&z[j * m..(j + 1) * m]).expect("update");
    }
    let elapsed = start.elapsed();
    println!(
        "{kind:?}: {steps} steps, {:.2} µs per step, final force estimates {:?}",
        elapsed.as_secs_f64() * 1e6 / steps as f64,
        &filter.mean().as_slice()[20..]
    );
}
