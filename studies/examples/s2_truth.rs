//! The S2 truth simulator's speed and what it produces: each excitation of the study run
//! for a few seconds at 80 km/h, with the time per integration step, the real-time factor
//! (simulated time over wall time, one core) and the wheel–rail forces.
//!
//!   cargo run --release -p studies --example s2_truth [-- SECONDS]

use std::time::Instant;

use truth::s2::irregularity::{FraSpectrum, Irregularity, RandomProfile};
use truth::s2::parameters::{Track, Vehicle};
use truth::s2::plant::{Settings, Simulation};

fn main() {
    let seconds: f64 = std::env::args().nth(1).map_or(3.0, |s| s.parse().expect("SECONDS is a number"));
    let settings = Settings::default();
    let p0 = Vehicle::ZHAI_PASSENGER.static_wheel_load();
    let travel = settings.speed * seconds;
    let profile = RandomProfile::sample(&FraSpectrum::CLASS_5, 1, -20.0, travel + 20.0);
    println!(
        "vehicle–track truth: {} rail modes, {} supports ({} m window), Δt = {} s, {:.0} km/h, P0 = {:.1} kN",
        settings.modes,
        settings.supports,
        settings.supports as f64 * Track::BALLASTED.sleeper_spacing,
        settings.dt,
        settings.speed * 3.6,
        p0 / 1e3
    );
    println!(
        "random track: FRA class 5, 1–120 m, seed 1: sample RMS {:.2} mm, spectrum's integral {:.2} mm",
        profile.rms() * 1e3,
        FraSpectrum::CLASS_5.variance(1.0, 120.0).sqrt() * 1e3
    );
    println!(
        "{:<12} {:>10} {:>12} {:>22} {:>22}",
        "excitation", "µs/step", "real time ×", "wheel 1 min–max (kN)", "wheel 4 min–max (kN)"
    );
    for (name, irregularity) in [
        ("none", Irregularity::None),
        ("random", Irregularity::Random(profile)),
        ("corrugation", Irregularity::corrugation(20.0)),
        ("weld", Irregularity::weld(20.0)),
    ] {
        let mut sim = Simulation::new(Vehicle::ZHAI_PASSENGER, Track::BALLASTED, irregularity, &settings);
        let steps = (seconds / settings.dt).round() as usize;
        let mut range = [(f64::INFINITY, f64::NEG_INFINITY); 4];
        let start = Instant::now();
        for _ in 0..steps {
            sim.step();
            for (r, c) in range.iter_mut().zip(sim.contact()) {
                *r = (r.0.min(c), r.1.max(c));
            }
        }
        let wall = start.elapsed().as_secs_f64();
        println!(
            "{name:<12} {:>10.1} {:>12.1} {:>22} {:>22}",
            wall / steps as f64 * 1e6,
            seconds / wall,
            format!("{:.1}–{:.1}", range[0].0 / 1e3, range[0].1 / 1e3),
            format!("{:.1}–{:.1}", range[3].0 / 1e3, range[3].1 / 1e3)
        );
    }
}
