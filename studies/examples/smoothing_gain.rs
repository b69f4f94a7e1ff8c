//! What smoothing gains on S1 and S2, in-process, behind the supervisor as the FMUs run:
//! the filtered estimate, the fixed-lag one (LAG seconds, `SupervisedFilter::smooth_with_lag`,
//! what an FMU's `smoothing_lag` gives) and the fixed-interval one (the whole run,
//! `RunRecorder`), each scored against the truth after the first second and before the last
//! LAG (where the fixed-lag estimate has none). The gain share is how much of the
//! fixed-interval smoother's RMSE reduction the fixed lag gets.
//!
//! - S1: the SRCKF on the four cases at 5 % noise, seeds 1–10 (the load `F`).
//! - S2: the SRCKF on the four cases at 1 kHz, seeds 1–3 (the four wheel forces).
//!
//! Nothing is tuned here: the studies' own tuning, and a lag chosen before looking.
//!
//!   cargo run --release -p studies --example smoothing_gain -- [LAG]

use analyzer::metrics::{correlation, rmse};
use estimator::models::{Oscillator2DofLoad, WheelRailVertical};
use estimator::{FilterKind, RunRecorder, SupervisedFilter, Supervisor, SupervisorSettings};

/// The three estimates of the smoothed states of one run, per state, sample by sample
/// (`NaN` where the fixed-lag smoother has not reached yet).
struct Estimates {
    filtered: Vec<Vec<f64>>,
    lagged: Vec<Vec<f64>>,
    smoothed: Vec<Vec<f64>>,
}

/// Runs `supervised` over `rows` (`dt` apart) smoothing `states` with a lag of `lag` samples
/// and over the whole run.
fn run(mut supervised: SupervisedFilter, rows: &[&[f64]], dt: f64, states: &[usize], lag: usize) -> Estimates {
    let n = rows.len();
    supervised.smooth_with_lag(states, lag).expect("a fixed-lag smoother");
    let mut filtered = vec![vec![f64::NAN; n]; states.len()];
    let mut lagged = vec![vec![f64::NAN; n]; states.len()];
    let mut recorder = RunRecorder::new();
    for (k, z) in rows.iter().enumerate() {
        if k > 0 {
            supervised.predict(&[], dt).expect("predict");
        }
        supervised.hold_input(&[]).expect("hold");
        supervised.update(z, k as f64 * dt).expect("update");
        for (a, &s) in states.iter().enumerate() {
            filtered[a][k] = supervised.filter().mean()[s];
        }
        recorder.push(supervised.filter(), supervised.transition()).expect("a transition per sample");
        let estimate = supervised.lagged_estimate().expect("smoothing");
        if k >= lag {
            for (a, &m) in estimate.means.iter().enumerate() {
                lagged[a][k - lag] = m;
            }
        }
    }
    let full = recorder.smooth().expect("the fixed-interval smoother");
    let smoothed = states.iter().map(|&s| full.iter().map(|g| g.mean[s]).collect()).collect();
    Estimates { filtered, lagged, smoothed }
}

/// Correlation and RMSE of each estimate of one state against `truth` over `range`.
fn scores(truth: &[f64], e: &Estimates, a: usize, range: std::ops::Range<usize>) -> [(f64, f64); 3] {
    let t = &truth[range.clone()];
    [&e.filtered, &e.lagged, &e.smoothed].map(|x| (correlation(t, &x[a][range.clone()]), rmse(t, &x[a][range.clone()])))
}

fn line(label: &str, s: [(f64, f64); 3]) -> String {
    let [(cf, rf), (cl, rl), (cs, rs)] = s;
    format!(
        "{label:<34} corr {cf:.5} / {cl:.5} / {cs:.5}   RMSE {rf:.4} / {rl:.4} / {rs:.4}   ratio {:.3} / {:.3}   gain share {:.2}",
        rl / rf,
        rs / rf,
        (rf - rl) / (rf - rs)
    )
}

/// Runs `jobs` on both cores, keeping their order.
fn on_both_cores<T: Send, R: Send>(jobs: Vec<T>, f: impl Fn(T) -> R + Sync) -> Vec<R> {
    let half = jobs.len().div_ceil(2);
    let mut jobs = jobs;
    let second = jobs.split_off(half);
    std::thread::scope(|scope| {
        let other = scope.spawn(|| second.into_iter().map(&f).collect::<Vec<_>>());
        let mut first: Vec<R> = jobs.into_iter().map(&f).collect();
        first.extend(other.join().expect("a worker"));
        first
    })
}

fn s1(lag_s: f64) {
    use studies::s1::Tuning;
    use truth::s1::{simulate, Case, Settings};
    println!("S1, SRCKF, 5 % noise: corr and RMSE (N) filtered / fixed lag {lag_s} s / fixed interval");
    let jobs: Vec<(u64, Case)> = (1..=10).flat_map(|seed| Case::ALL.map(|case| (seed, case))).collect();
    let lines = on_both_cores(jobs, |(seed, case)| {
        let settings = Settings { noise_fraction: 0.05, seed, ..Settings::default() };
        let (truth, measurements) = simulate(&case, &settings);
        let tuning = Tuning::new(&settings, measurements.noise_std);
        let filter = tuning.filter(FilterKind::SrCkf, &case, tuning.noise()).expect("the filter");
        let supervisor = Supervisor::new(SupervisorSettings::default(), 2)
            .and_then(|s| s.with_jump_states(6, &Oscillator2DofLoad::UNKNOWN_INPUTS))
            .expect("the supervisor");
        let supervised = SupervisedFilter::new(filter, supervisor).expect("the loop");
        let rows: Vec<&[f64]> = measurements.acceleration.iter().map(|z| &z[..]).collect();
        let dt = settings.dt();
        let lag = (lag_s / dt).round() as usize;
        let e = run(supervised, &rows, dt, &[Oscillator2DofLoad::LOAD], lag);
        let range = (1.0 / dt) as usize..rows.len() - lag;
        line(&format!("{case} seed {seed}"), scores(&truth.load, &e, 0, range))
    });
    for l in lines {
        println!("{l}");
    }
}

fn s2(lag_s: f64) {
    use studies::s2::study::{supervised_filter, user_vehicle, Tuning};
    use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
    use truth::s2::parameters::Vehicle;
    println!("S2, SRCKF, 1 kHz: corr and RMSE (N) filtered / fixed lag {lag_s} s / fixed interval, per wheel");
    let jobs: Vec<(u64, Case)> = (1..=3).flat_map(|seed| Case::ALL.map(|case| (seed, case))).collect();
    let lines = on_both_cores(jobs, |(seed, case)| {
        let settings = Settings { seed, ..Settings::default() };
        let vehicle = user_vehicle(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load());
        let truth = simulate(case, &settings);
        let measurements = measure(&truth, settings.noise_fraction, settings.seed);
        let tuning = Tuning::new(&settings, measurements.noise_std);
        let supervised = supervised_filter(FilterKind::SrCkf, vehicle, &tuning).expect("the loop");
        let rows: Vec<&[f64]> = measurements.accelerations.iter().map(|z| &z[..]).collect();
        let lag = (lag_s / tuning.dt).round() as usize;
        let states: Vec<usize> = (0..4).map(|j| WheelRailVertical::FORCES + j).collect();
        let e = run(supervised, &rows, tuning.dt, &states, lag);
        let range = (0.5 / tuning.dt) as usize..rows.len() - lag;
        (0..4)
            .map(|j| {
                let wheel: Vec<f64> = truth.contact.iter().map(|c| c[j]).collect();
                line(&format!("{} seed {seed} wheel {}", case.name(), j + 1), scores(&wheel, &e, j, range.clone()))
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    for l in lines {
        println!("{l}");
    }
}

fn main() {
    let lag: f64 = std::env::args().nth(1).map_or(0.1, |s| s.parse().expect("LAG in seconds"));
    s1(lag);
    s2(lag);
}
