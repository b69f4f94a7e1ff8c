//! How strongly the other channels contradict one wiring mistake: the data's own
//! limit for a wiring check (docs/supervisor.md § Wiring checks).
//!
//! ```sh
//! cargo run --release -p studies --example wiring_evidence -- s3 a_ab_L1 flip
//! ```
//!
//! Two plain SRCKFs (no supervisor) on S2's or S3's default case with one input
//! flipped, or read 9.81 times too large (`g`) or too small (`over-g`), from 1.5 s:
//! one takes the data as they come, the other with the mistake put right. Their
//! log-likelihood difference over the time after the mistake's start is what any
//! test of the innovations could have to name it (for a flip; a unit mistake also
//! changes the noise's scale, which this difference leaves out).
use estimator::models::{WheelRailRoll, WheelRailVertical};
use estimator::*;
use studies::s3::study::{user_vehicle as s3_vehicle, ForceModel, Tuning as S3Tuning};
use truth::s2::parameters::Vehicle;

fn filter_for(study: &str) -> Box<dyn StateEstimator> {
    if study == "s2" {
        use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
        let settings = Settings { duration: 4.4, seed: 1, ..Settings::default() };
        let truth = simulate(Case::Random, &settings);
        let m = measure(&truth, settings.noise_fraction, settings.seed);
        let tuning = studies::s2::study::Tuning::new(&settings, m.noise_std);
        let vehicle = studies::s2::study::user_vehicle(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load());
        let model = Discretized::rk4(WheelRailVertical { vehicle }, tuning.rk4_substeps);
        build_filter(FilterKind::SrCkf, model, tuning.noise(), &tuning.prior(&vehicle), tuning.unscented).unwrap()
    } else {
        use truth::s3::cases::{measure, simulate, Case, Settings};
        let settings = Settings { duration: 4.4, seed: 1, ..Settings::default() };
        let truth = simulate(Case::Random, &settings).unwrap();
        let m = measure(&truth, settings.noise_fraction, settings.seed);
        let vehicle = s3_vehicle(settings.vehicle.static_wheel_load());
        let tuning = S3Tuning::new(&settings, &m, ForceModel::Returning(S3Tuning::FORCE_RETURN_RATE));
        let model = Discretized::rk4(WheelRailRoll { vehicle, force_return_rate: tuning.forces.rate() }, 1);
        let unscented = UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 };
        build_filter(FilterKind::SrCkf, model, tuning.noise().unwrap(), &tuning.prior(&vehicle), unscented).unwrap()
    }
}

fn main() {
    let study = std::env::args().nth(1).expect("a study: s2 or s3");
    let input = std::env::args().nth(2).expect("an input name, e.g. a_ab_L1");
    let kind = std::env::args().nth(3).unwrap_or("flip".into());
    let bench =
        if study == "s2" { studies::robustness::benches::s2(4.4, 1) } else { studies::robustness::benches::s3(4.4, 1) };
    let channel = bench.inputs.iter().position(|i| *i == input).unwrap_or_else(|| panic!("no input {input}"));
    // S3's model also has the primary deflections, which its default case leaves missing.
    let m_total = filter_for(&study).measurement_dim();
    let start = (1.5 / bench.dt) as usize;
    let mut faulty: Vec<Vec<f64>> = bench
        .z
        .iter()
        .map(|r| {
            let mut r = r.clone();
            r.resize(m_total, f64::NAN);
            r
        })
        .collect();
    let right = faulty.clone();
    for row in &mut faulty[start..] {
        row[channel] = match kind.as_str() {
            "flip" => -row[channel],
            "g" => row[channel] * 9.81,
            "over-g" => row[channel] / 9.81,
            other => panic!("no mistake {other}: flip, g or over-g"),
        };
    }
    let mut ll = [0.0f64; 2];
    let mut filters = [filter_for(&study), filter_for(&study)];
    let marks = [0.1, 0.2, 0.5, 1.0, 2.0];
    let mut next = 0;
    for k in 0..faulty.len() {
        for (i, data) in [&faulty, &right].into_iter().enumerate() {
            if k > 0 {
                filters[i].predict(&[], bench.dt).unwrap();
            }
            let inn = filters[i].update(&data[k]).unwrap();
            if k >= start {
                ll[i] += inn.log_likelihood();
            }
        }
        if next < marks.len() && k == start + (marks[next] / bench.dt) as usize {
            println!(
                "{} ch {} {kind}: after {:.1} s log-likelihood, right over as-is: {:+.1} nats",
                study,
                bench.inputs[channel],
                marks[next],
                ll[1] - ll[0]
            );
            next += 1;
        }
    }
}
