//! Speed of the S3 truth: the whole car on two rails (31 DOF, each rail's modes and
//! supports) stepped at its Δt of 1e-4 s, on the random track at 80 km/h.
//!
//! `step/s3_plant/1000` is 1000 plant steps, 0.1 s of simulated time: the plant runs
//! faster than real time when it takes less than 100 ms. Before criterion runs, the
//! real-time factor of 2 s of simulated time (the plant and the sampling of its signals,
//! one core) is printed as `real-time factor: s3 plant = <simulated / wall-clock>`.
//!
//! ```text
//! cargo bench -p truth --bench s3_plant
//! ```

use std::time::Instant;

use criterion::Criterion;
use truth::s3::cases::{as_built, Case, Settings as CaseSettings};
use truth::s3::parameters::Track;
use truth::s3::plant::{Settings, Simulation};

/// Steps per timed iteration: 0.1 s of simulated time.
const STEPS: usize = 1000;

/// The plant on a random track long enough for every timed iteration (300 s).
fn simulation() -> Simulation {
    let case = CaseSettings { duration: 300.0, ..CaseSettings::default() };
    let plant = Settings { speed: case.speed, ..Settings::default() };
    Simulation::new(as_built(), Track::BALLASTED, Case::Random.irregularity(&case), &plant)
        .expect("the default plant runs")
}

fn main() {
    let mut sim = simulation();
    let steps = (2.0 / Settings::default().dt).round() as usize;
    let start = Instant::now();
    for _ in 0..steps {
        sim.step();
        std::hint::black_box(sim.sample());
    }
    let factor = sim.time() / start.elapsed().as_secs_f64();
    println!("real-time factor: s3 plant = {factor:.2}");

    let mut criterion = Criterion::default().configure_from_args();
    criterion.bench_function(&format!("step/s3_plant/{STEPS}"), |b| {
        b.iter(|| {
            for _ in 0..STEPS {
                sim.step();
            }
        })
    });
    criterion.final_summary();
}
