//! A bare loop of filter steps on study S2's 24-state wheel–rail model (Zhai's passenger
//! car, the study's tuning at 1 kHz), for profilers: unlike the criterion benchmark it does
//! a known number of steps, so instruction counts divide into a per-step figure.
//!
//! ```text
//! cargo build --release -p estimator --example step_loop
//! valgrind --tool=callgrind target/release/examples/step_loop srckf 2000
//! perf record -g target/release/examples/step_loop srckf 50000
//! ```
//!
//! Arguments: the filter (`ckf`, `srckf`, `svd`, `ukf`, `ekf`; default `srckf`)
//! and the number of predict + update steps (default 10000). The measurements
//! are the model's own response from a displaced, moving start with wheel–rail forces
//! that step about the static wheel load every 0.2 s, plus seeded noise; the sequence
//! repeats every 2000 steps.

use std::time::Instant;

use estimator::models::{VerticalVehicle, WheelRailVertical};
use estimator::{build_filter, Discretized, FilterKind, Gaussian, Noise, Observation, Process, UnscentedParams};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

const DT: f64 = 0.001;
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

    let vehicle = VerticalVehicle::zhai_passenger();
    let p_st = vehicle.static_wheel_load;
    let mut model = Discretized::rk4(WheelRailVertical { vehicle }, 1);
    let (n, m) = (model.state_dim(), model.measurement_dim());
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut x = vec![0.0; n];
    for i in 0..10 {
        x[i] = 1e-4 * (i + 1) as f64;
        x[10 + i] = if i % 2 == 0 { 0.02 } else { -0.01 };
    }
    let (mut x_next, mut y) = (vec![0.0; n], vec![0.0; m]);
    let mut z = Vec::with_capacity(SEQUENCE * m);
    for k in 0..SEQUENCE {
        if k % 200 == 0 {
            for f in &mut x[WheelRailVertical::FORCES..] {
                *f = p_st + 5e3 * rng.sample::<f64, _>(StandardNormal);
            }
        }
        model.transition(k as f64 * DT, DT, &x, &[], &mut x_next);
        x.copy_from_slice(&x_next);
        model.observe((k + 1) as f64 * DT, &x, &[], &mut y);
        z.extend(y.iter().map(|v| v + 0.05 * rng.sample::<f64, _>(StandardNormal)));
    }

    // The study's tuning (studies/src/s2/study.rs, `Tuning`): motion noise 1e-8 (car body,
    // bogies) and 1e-10 (wheelsets) per sample, force intensity 1e13 N²/s, prior 1e-2
    // about the static load.
    let motion: Vec<f64> = [1e-8; 6].into_iter().chain([1e-10; 4]).collect();
    let q: Vec<f64> = motion.iter().chain(&motion).copied().chain([1e13 * DT; 4]).collect();
    let noise = Noise::diagonal(&q, &[0.05 * 0.05; 7]).expect("valid noise");
    let mut mean = [0.0; 24];
    mean[WheelRailVertical::FORCES..].fill(p_st);
    let prior = Gaussian::diagonal(&mean, &[1e-2; 24]);
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
        &filter.mean().as_slice()[WheelRailVertical::FORCES..]
    );
}
