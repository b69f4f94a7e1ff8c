//! A tuning probe of S4's filter, in-process: for each jerk intensity of a sweep, on the
//! paper's run and on the 500 km/h run, ten noise-and-fault seeds with the default faults,
//! the SRCKF behind the supervisor. Prints per intensity the largest speed error and its
//! RMS (from telegram 50 on), the telegrams the gate rejected that no fault excuses, the
//! spikes it let through, and the worst seed's rejections on the same run without faults.
//! It is the sweep `Tuning::jerk_limited`'s documentation quotes, behind the choice of
//! `Tuning::paper` (10 m²/s⁵) and `Tuning::jerk_limited` (0.01): small enough to smooth
//! the speed, large enough to follow the run without rejecting good telegrams. A probe,
//! it makes no claim of its own; `studies/tests/s4_ours.rs` checks the chosen tunings
//! against the goals.
//!
//!   cargo run --release -p studies --example s4_tuning_sweep

use estimator::FilterKind;
use studies::s4::metrics::rejection_excused;
use studies::s4::ours::{run, Run, Settings, Tuning};
use truth::s4::channels::simulate;
use truth::s4::faults::{FaultKind, Faults};
use truth::s4::profile::Profile;
use truth::s4::recording::Recording;

/// Seeds 1 … this per intensity.
const SEEDS: u64 = 10;
/// The first telegram scored: the filter's start-up left out.
const SETTLED: usize = 50;

/// The largest speed error and its RMS over telegrams `SETTLED..`, each estimate against
/// the truth at its telegram (m/s).
fn speed_errors(recording: &Recording, out: &Run) -> (f64, f64) {
    let errors: Vec<f64> =
        (SETTLED..recording.n_telegrams()).map(|k| out.estimates[k].speed - recording.truth[k].speed).collect();
    let max = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    (max, (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt())
}

fn main() {
    for (name, profile, intensities) in [
        ("paper", Profile::paper(), vec![0.3, 1.0, 3.0, 10.0, 30.0, 100.0]),
        ("high", Profile::high_speed(), vec![0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0]),
    ] {
        for q in intensities {
            let tuning = Tuning { jerk_intensity: q, ..Tuning::paper() };
            let settings = Settings::new(FilterKind::SrCkf, tuning);
            let (mut max, mut mean_square) = (0.0f64, 0.0);
            let (mut false_rejections, mut missed_spikes, mut channel_telegrams) = (0, 0, 0);
            let mut clean_rejections_worst = 0;
            for seed in 1..=SEEDS {
                let recording = simulate(&profile, &Faults::default(), seed);
                let out = run(&recording, &settings).expect("the filter runs");
                let (seed_max, seed_rms) = speed_errors(&recording, &out);
                max = max.max(seed_max);
                mean_square += seed_rms.powi(2) / SEEDS as f64;
                for (k, estimate) in out.estimates.iter().enumerate() {
                    false_rejections +=
                        (0..4).filter(|&c| estimate.rejected[c] && !rejection_excused(&recording, c, k)).count();
                }
                channel_telegrams += 4 * recording.n_telegrams();
                for fault in &recording.faults {
                    if let FaultKind::Spike { .. } = fault.kind {
                        if !out.estimates[fault.telegrams.start].rejected[fault.channel as usize] {
                            missed_spikes += 1;
                        }
                    }
                }
                let clean = run(&simulate(&profile, &Faults::none(), seed), &settings).expect("the filter runs");
                let rejected: usize = clean.estimates.iter().map(|e| e.rejected.iter().filter(|&&r| r).count()).sum();
                clean_rejections_worst = clean_rejections_worst.max(rejected);
            }
            println!(
                "{name} q={q}: speed error max {max:.4} m/s, RMS {:.4} m/s; false rejections \
                 {false_rejections}/{channel_telegrams}; missed spikes {missed_spikes}; rejections without faults \
                 (worst seed) {clean_rejections_worst}",
                mean_square.sqrt()
            );
        }
    }
}
