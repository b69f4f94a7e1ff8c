//! A bare loop of filter steps on one of the benchmark's cases (`benches/cases`: a study's
//! model with its tuning and a simulated measurement sequence), for profilers: unlike the
//! criterion benchmark it does a known number of steps, so instruction counts divide into
//! a per-step figure.
//!
//! ```text
//! cargo build --release -p estimator --example step_loop
//! valgrind --tool=callgrind target/release/examples/step_loop wheel_rail_24 srckf 2000
//! perf record -g target/release/examples/step_loop missile_20 ukf 50000
//! ```
//!
//! Arguments: the case (`s1_6`, `wheel_rail_24`, `wheel_rail_roll_42`, `missile_20`), the
//! filter (`ckf`, `srckf`, `svd`, `ukf`, `ekf`) and the number of predict + update steps
//! (default 10000). The measurement sequence repeats every `STEPS` steps; the filter is
//! reset at each repeat, as the benchmark does outside its timed region.

#[path = "../benches/cases/mod.rs"]
mod cases;

use std::time::Instant;

use cases::{built, checked_step, Case, FilterVisitor, STEPS};
use estimator::{FilterError, Model, StateEstimator};

/// Runs `steps` steps of the filter named `kind` and ignores the others.
struct StepLoop {
    kind: &'static str,
    steps: usize,
}

impl FilterVisitor for StepLoop {
    fn visit<M, F: StateEstimator>(&mut self, case: &Case<M>, kind: &str, filter: Result<F, FilterError>) {
        if kind != self.kind {
            return;
        }
        let mut filter = built(case, kind, filter);
        let start = Instant::now();
        for k in 0..self.steps {
            let j = k % STEPS;
            if j == 0 && k > 0 {
                filter.reset(0.0, &case.prior).unwrap_or_else(|e| panic!("{}/{kind}: reset failed: {e}", case.name));
            }
            checked_step(case, kind, &mut filter, j);
        }
        let elapsed = start.elapsed();
        println!(
            "{}/{kind}: {} steps, {:.2} µs per step, final estimate {:?}",
            case.name,
            self.steps,
            elapsed.as_secs_f64() * 1e6 / self.steps as f64,
            filter.mean().as_slice()
        );
    }
}

fn run<M: Model + Clone>(case: Case<M>, visitor: &mut StepLoop) {
    case.for_each_filter(visitor);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: step_loop <s1_6|wheel_rail_24|wheel_rail_roll_42|missile_20> <ckf|srckf|svd|ukf|ekf> [steps]";
    let kind = match args.get(2).map(String::as_str) {
        Some("ckf") => "CKF",
        Some("srckf") => "SRCKF",
        Some("svd") => "SVD-CKF",
        Some("ukf") => "UKF",
        Some("ekf") => "EKF",
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    };
    let steps = match args.get(3).map(|s| s.parse::<usize>()) {
        None => 10_000,
        Some(Ok(steps)) => steps,
        Some(Err(_)) => {
            eprintln!("{usage}: the step count is an integer");
            std::process::exit(2);
        }
    };
    let visitor = &mut StepLoop { kind, steps };
    match args.get(1).map(String::as_str) {
        Some("s1_6") => run(cases::s1(), visitor),
        Some("wheel_rail_24") => run(cases::wheel_rail(), visitor),
        Some("wheel_rail_roll_42") => run(cases::wheel_rail_roll(), visitor),
        Some("missile_20") => run(cases::missile(), visitor),
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    }
}
