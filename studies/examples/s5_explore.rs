//! A tuning probe of S5, in-process: the flight, each sensor's noise, each filter kind on
//! the 20-state model; prints per filter the coefficients' relative errors just before the
//! change (9.995 s) and at the end (20 s), and the time to come back within 3 % and 1 %
//! after the change.
//!
//!   cargo run --release -p studies --example s5_explore -- [NOISE_SCALE] [COEFF_Q]

use estimator::FilterKind;
use studies::s5::study::{run_filter, Tuning};
use truth::s5::flight::{measure, simulate, Settings};
use truth::s5::parameters::{AFTER, BEFORE, NAMES};

fn main() {
    let mut args = std::env::args().skip(1);
    let scale: f64 = args.next().map_or(1.0, |s| s.parse().expect("NOISE_SCALE"));
    let coefficient_q: Option<f64> = args.next().map(|s| s.parse().expect("COEFF_Q"));
    let settings = Settings { noise_scale: scale, ..Settings::default() };
    let started = std::time::Instant::now();
    let truth = simulate(&settings);
    println!("truth: {} samples in {:.2} s", truth.time.len(), started.elapsed().as_secs_f64());
    let last = truth.motion.last().unwrap();
    println!(
        "end: V {:.1} m/s, h {:.0} m, pitch {:.1}°",
        (last[0] * last[0] + last[1] * last[1] + last[2] * last[2]).sqrt(),
        last[6],
        last[3].to_degrees()
    );
    let flight = truth::s5::flight::flight();
    for (half, first) in [("before", 0usize), ("after", 2000)] {
        let bound = studies::s5::excitation::cramer_rao(
            &flight,
            &truth.motion[first],
            first,
            2000,
            settings.sample_time,
            settings.truth_substeps,
            scale,
        );
        match bound {
            Some(b) => println!(
                "Cramér–Rao σ {half}: {}",
                (0..10)
                    .map(|i| format!(
                        "{} {:.1e} ({:.3} %)",
                        NAMES[i],
                        b[10 + i],
                        100.0 * b[10 + i] / truth.coefficients[first][i].abs()
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => println!("Cramér–Rao {half}: singular information"),
        }
    }
    let z = measure(&truth, scale, settings.seed);
    let mut tuning = Tuning::new(scale);
    if let Some(q) = coefficient_q {
        tuning.coefficient_relative_std = q;
    }
    let before = (10.0 / settings.sample_time) as usize - 1;
    for kind in FilterKind::ALL {
        let started = std::time::Instant::now();
        let e = match run_filter(kind, &tuning, &truth, &z, settings.sample_time, &[]) {
            Ok(e) => e,
            Err(e) => {
                println!("{kind}: failed: {e}");
                continue;
            }
        };
        let rel = |k: usize, truth: &[f64; 10]| -> Vec<f64> {
            (0..10).map(|i| (e.coefficients[k][i] - truth[i]) / truth[i]).collect()
        };
        let within = |bound: f64| {
            (before + 1..e.coefficients.len())
                .find(|&k| (k..e.coefficients.len()).all(|j| rel(j, &AFTER).iter().all(|r| r.abs() <= bound)))
                .map_or("never".to_string(), |k| format!("{:.2} s", truth.time[k] - 10.0))
        };
        println!(
            "{kind:<8} {:.1} s, rejected {}: back within 3 % {}, 1 % {}",
            started.elapsed().as_secs_f64(),
            e.rejected,
            within(0.03),
            within(0.01)
        );
        let (b, a) = (rel(before, &BEFORE), rel(e.coefficients.len() - 1, &AFTER));
        for i in 0..10 {
            println!(
                "   {:<5} before {:+8.4} %  σ {:.1e}   after {:+8.4} %  σ {:.1e}",
                NAMES[i],
                100.0 * b[i],
                e.std[before][i],
                100.0 * a[i],
                e.std.last().unwrap()[i]
            );
        }
    }
}
