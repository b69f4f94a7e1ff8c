//! A first probe of S2, before the study exists (issue 19): the truth (80 km/h, 4 s) sampled
//! at RATE Hz with white noise of 2 % of each channel's RMS; the SRCKF on the 24-state model
//! of eq. (7) with the paper's set-up (22) except the force noise Q_F (N² per sample) and R,
//! set from the noise added; the estimator's car-body mass scaled by MASS_SCALE. Prints,
//! for wheel 1 and each excitation, the correlation, the RMSE after 0.5 s and its ratio to
//! the force's dynamic standard deviation.
//!
//!   cargo run --release -p scenarios --example s2_explore -- [MASS_SCALE] [Q_F] [RATE]
use analyzer::metrics::correlation;
use estimator::models::{PiecewiseLinear, VerticalVehicle, WheelRailVertical};
use estimator::{build_filter, Discretized, FilterKind, Gaussian, Noise, UnscentedParams};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use scenarios::s2::irregularity::{FraSpectrum, Irregularity, RandomProfile};
use scenarios::s2::parameters::{Track, Vehicle};
use scenarios::s2::plant::{Settings, Simulation};

fn main() {
    let mass_error: f64 = std::env::args().nth(1).map_or(1.0, |s| s.parse().unwrap());
    let q_force: f64 = std::env::args().nth(2).map_or(1e9, |s| s.parse().unwrap());
    let rate: f64 = std::env::args().nth(3).map_or(200.0, |s| s.parse().unwrap());
    let settings = Settings::default();
    let seconds = 4.0;
    let travel = settings.speed * seconds;
    for (name, irr) in [
        ("random", Irregularity::Random(RandomProfile::sample(&FraSpectrum::CLASS_5, 1, -20.0, travel + 20.0))),
        ("corrugation", Irregularity::corrugation(15.0)),
        ("weld", Irregularity::weld(40.0)),
    ] {
        let mut sim = Simulation::new(Vehicle::ZHAI_PASSENGER, Track::BALLASTED, irr, &settings);
        let per_sample = (1.0 / rate / settings.dt).round() as usize;
        let mut samples = vec![sim.sample()];
        while sim.time() < seconds {
            for _ in 0..per_sample {
                sim.step();
            }
            samples.push(sim.sample());
        }
        let mut rms = [0.0; 7];
        for s in &samples {
            for (r, a) in rms.iter_mut().zip(s.accelerations) {
                *r += a * a;
            }
        }
        let std: Vec<f64> = rms.iter().map(|r| 0.02 * (r / samples.len() as f64).sqrt()).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let v = Vehicle::ZHAI_PASSENGER;
        let damper = PiecewiseLinear::new(
            [v.primary_damping, v.primary_damping_beyond, v.primary_damping_beyond],
            [v.primary_damper_knee; 2],
        )
        .unwrap();
        let vehicle = VerticalVehicle::half_of(
            (v.car_body_mass * mass_error, v.car_body_pitch_inertia),
            (v.bogie_mass, v.bogie_pitch_inertia),
            v.wheelset_mass,
            (v.primary_stiffness, damper),
            (v.secondary_stiffness, v.secondary_damping),
            v.half_bogie_spacing,
            v.half_wheelbase,
        );
        let model = Discretized::rk4(WheelRailVertical { vehicle }, 1);
        let mut q = vec![1e-3; 6];
        q.extend([1e-6; 4]);
        q.extend([1e-3; 6]);
        q.extend([1e-6; 4]);
        q.extend([q_force; 4]);
        let r: Vec<f64> = std.iter().map(|s| s * s).collect();
        let noise = Noise::diagonal(&q, &r).unwrap();
        let mut mean = vec![0.0; 24];
        for m in &mut mean[20..] {
            *m = vehicle.static_wheel_load;
        }
        let prior = Gaussian::diagonal(&mean, &[1e-2; 24]);
        let mut filter = build_filter(
            FilterKind::SrCkf,
            model,
            noise,
            &prior,
            UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 },
        )
        .unwrap();
        let (mut est, mut truth) = (Vec::new(), Vec::new());
        for (k, s) in samples.iter().enumerate() {
            let z: Vec<f64> = s
                .accelerations
                .iter()
                .zip(&std)
                .map(|(a, sd)| {
                    let n: f64 = StandardNormal.sample(&mut rng);
                    a + sd * n
                })
                .collect::<Vec<f64>>();
            if k > 0 {
                filter.predict(&[], 1.0 / rate).unwrap();
            }
            filter.update(&z).unwrap();
            est.push(filter.mean()[20]);
            truth.push(s.contact[0]);
        }
        let skip = (0.5 * rate) as usize;
        let c = correlation(&truth[skip..], &est[skip..]);
        let rmse = (truth[skip..].iter().zip(&est[skip..]).map(|(a, b)| (a - b).powi(2)).sum::<f64>()
            / (truth.len() - skip) as f64)
            .sqrt();
        let m = truth[skip..].iter().sum::<f64>() / (truth.len() - skip) as f64;
        let dyn_std = (truth[skip..].iter().map(|a| (a - m).powi(2)).sum::<f64>() / (truth.len() - skip) as f64).sqrt();
        println!(
            "{name}: corr {c:.4}, RMSE {:.3} kN, dynamic std {:.3} kN, RMSE/std {:.2}",
            rmse / 1e3,
            dyn_std / 1e3,
            rmse / dyn_std
        );
    }
}
