//! The S2 truth is right: the vehicle–track coupled model against statics, its published
//! resonances, a closed-form beam on elastic foundation, its own finer step, and the
//! spectrum its random track is drawn from.

use estimator::models::WheelRailVertical;
use estimator::{Observation, VectorField};
use studies::s2::study::vertical_vehicle;
use truth::s2::irregularity::{FraSpectrum, Irregularity, RandomProfile};
use truth::s2::parameters::{Track, Vehicle, G};
use truth::s2::plant::{Settings, Simulation};
use truth::s2::track::TrackModel;
use truth::s2::vehicle::wheelset;

fn simulation(irregularity: Irregularity, settings: &Settings) -> Simulation {
    Simulation::new(Vehicle::ZHAI_PASSENGER, Track::BALLASTED, irregularity, settings)
}

#[test]
fn the_static_wheel_loads_are_the_weight_shares() {
    let v = Vehicle::ZHAI_PASSENGER;
    let p0 = (v.car_body_mass + 2.0 * v.bogie_mass + 4.0 * v.wheelset_mass) * G / 8.0;
    assert!((v.static_wheel_load() - p0).abs() < 1e-9 * p0);
    assert!((p0 - 55.9e3).abs() < 0.1e3, "Zhai's car: 55.9 kN, not {p0}");
    let sim = simulation(Irregularity::None, &Settings::default());
    for (j, p) in sim.contact().iter().enumerate() {
        assert!((p - p0).abs() < 1e-9 * p0, "wheel {j}: {p} N against {p0} N");
    }
    // In equilibrium: no acceleration anywhere at rest.
    let sample = simulation(Irregularity::None, &Settings { speed: 0.0, ..Settings::default() }).sample();
    assert!(sample.accelerations.iter().all(|a| a.abs() < 1e-6), "{:?}", sample.accelerations);
}

#[test]
fn a_perfect_track_keeps_the_static_loads() {
    let p0 = Vehicle::ZHAI_PASSENGER.static_wheel_load();
    // At rest; and at 80 km/h, where the start from rest to full speed (a jolt of 1 %)
    // dies out and sleeper passing, at 37 Hz, is the only excitation left.
    for (speed, start, settled) in [(0.0, 1e-6, 1e-6), (80.0 / 3.6, 0.01, 2e-3)] {
        let mut sim = simulation(Irregularity::None, &Settings { speed, ..Settings::default() });
        let (mut first, mut later): (f64, f64) = (0.0, 0.0);
        for n in 0..20_000 {
            sim.step();
            let worst = sim.contact().iter().fold(0.0_f64, |w, p| w.max((p - p0).abs() / p0));
            if n < 5000 {
                first = first.max(worst);
            } else {
                later = later.max(worst);
            }
        }
        assert!(first < start, "at {speed} m/s the loads leave P0 by {first} in the first 0.5 s");
        assert!(later < settled, "at {speed} m/s the loads leave P0 by {later} after 0.5 s");
    }
}

/// The frequency (Hz) of the largest peak of `x` (sampled every `dt`) between `lo` and
/// `hi` Hz, from its discrete Fourier transform on a 0.1 Hz grid.
fn peak_frequency(x: &[f64], dt: f64, lo: f64, hi: f64) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let power = |f: f64| {
        let (mut re, mut im) = (0.0, 0.0);
        for (k, v) in x.iter().enumerate() {
            let phase = std::f64::consts::TAU * f * k as f64 * dt;
            re += (v - mean) * phase.cos();
            im += (v - mean) * phase.sin();
        }
        re * re + im * im
    };
    let steps = ((hi - lo) / 0.1) as usize;
    (0..=steps).map(|i| lo + i as f64 * 0.1).max_by(|a, b| power(*a).total_cmp(&power(*b))).unwrap()
}

/// Car-body bounce: 0.8–1.5 Hz for passenger cars (Iwnicki, Handbook of Railway Vehicle
/// Dynamics, 2006, ch. 11; about 1.2 Hz for this set). P2, the
/// unsprung masses bouncing on the track: 35–55 Hz for support stiffness 60–150 MN/m
/// (`[Zhai2015]`), 30–90 Hz in general (`[Jenkins1974]`).
#[test]
fn the_car_body_bounce_and_the_p2_resonance_fall_in_the_published_ranges() {
    let settings = Settings { speed: 0.0, ..Settings::default() };
    let mut sim = simulation(Irregularity::None, &settings);
    // Free vibration from a lifted car body (bounce) and a struck wheelset (P2).
    let mut body = Vec::new();
    let mut contact = Vec::new();
    sim.perturb(|u, v| {
        u[0] -= 5e-3;
        v[wheelset(0)] += 0.05;
    });
    for n in 0..60_000 {
        sim.step();
        if n % 10 == 0 {
            body.push(sim.displacements()[0]);
        }
        if n < 2000 {
            contact.push(sim.contact()[0]);
        }
    }
    let bounce = peak_frequency(&body, 10.0 * settings.dt, 0.3, 5.0);
    assert!((0.8..=1.5).contains(&bounce), "car-body bounce at {bounce} Hz");
    let p2 = peak_frequency(&contact, settings.dt, 20.0, 150.0);
    assert!((35.0..=55.0).contains(&p2), "P2 at {p2} Hz");
}

#[test]
fn halving_the_step_changes_the_weld_peaks_by_under_one_percent() {
    let peaks = |dt: f64| {
        let settings = Settings { dt, ..Settings::default() };
        let mut sim = simulation(Irregularity::weld(20.0), &settings);
        let mut peak = [0.0_f64; 4];
        // Until every wheel has passed the weld (the last starts 10.2 m behind the centre).
        while sim.time() < (20.0 + 10.2 + 2.0) / settings.speed {
            sim.step();
            for (p, c) in peak.iter_mut().zip(sim.contact()) {
                *p = p.max(c);
            }
        }
        peak
    };
    let (coarse, fine) = (peaks(1e-4), peaks(5e-5));
    let p0 = Vehicle::ZHAI_PASSENGER.static_wheel_load();
    for j in 0..4 {
        assert!(coarse[j] > 1.2 * p0, "wheel {j}: the weld raises the force ({})", coarse[j]);
        let change = (coarse[j] - fine[j]).abs() / fine[j];
        assert!(change < 0.01, "wheel {j}: peak {} N at 1e-4 s, {} N at 5e-5 s", coarse[j], fine[j]);
    }
}

/// A single wheel load on the rail against Winkler's closed form for a beam on an elastic
/// foundation (Hetényi, Beams on Elastic Foundation, 1946): `w₀ = P·β/(2k)`,
/// `β = (k/(4EI))^{1/4}`, with the supports smeared into `k = k_s/a` (pad, ballast and
/// subgrade in series; no ballast shear, which Winkler has not).
#[test]
fn a_single_wheel_load_deflects_the_rail_as_a_beam_on_elastic_foundation() {
    let mut track = Track::BALLASTED;
    track.ballast_shear_stiffness = 0.0;
    let model = TrackModel::new(track, 100, 100);
    let support = 1.0 / (1.0 / track.pad_stiffness + 1.0 / track.ballast_stiffness + 1.0 / track.subgrade_stiffness);
    let k = support / track.sleeper_spacing;
    let beta = (k / (4.0 * track.rail_bending_stiffness)).powf(0.25);
    let load = 55.9e3;
    let winkler = |x: f64| load * beta / (2.0 * k) * (-beta * x).exp() * ((beta * x).cos() + (beta * x).sin());
    let mut under = vec![0.0; model.modes];
    // Over a sleeper (30.3 m is one) and between two.
    for position in [30.3, 30.0] {
        model.mode_shapes(position, &mut under);
        let u = model.static_deflection(&under, &[load]);
        let mut shape = vec![0.0; model.modes];
        for offset in [0.0, 0.6, 1.2, 2.4] {
            model.mode_shapes(position + offset, &mut shape);
            let w: f64 = shape.iter().zip(&u[..model.modes]).map(|(s, q)| s * q).sum();
            let expected = winkler(offset);
            assert!(
                (w - expected).abs() < 0.03 * winkler(0.0),
                "load at {position} m, {offset} m away: {w} m against {expected} m"
            );
        }
    }
}

#[test]
fn the_random_profile_has_the_spectrums_rms() {
    let spectrum = FraSpectrum::CLASS_5;
    let expected = spectrum.variance(1.0, 120.0).sqrt();
    // Wavelengths up to 120 m dominate: 3 km holds 25 of the longest.
    for seed in 1..4 {
        let profile = RandomProfile::sample(&spectrum, seed, 0.0, 3000.0);
        let rms = profile.rms();
        assert!((rms - expected).abs() < 0.1 * expected, "seed {seed}: RMS {rms} m against {expected} m");
        // The table reads back its own grid.
        let x = 1234.567;
        assert!((profile.at(x) - profile.at(x + 1e-9)).abs() < 1e-9);
    }
    // Class 6 is the smoother track.
    assert!(FraSpectrum::CLASS_6.variance(1.0, 120.0) < spectrum.variance(1.0, 120.0));
}

#[test]
fn the_deterministic_irregularities_have_their_depths_and_lengths() {
    let corrugation = Irregularity::corrugation(10.0);
    assert_eq!(corrugation.at(9.9), 0.0);
    assert!((corrugation.at(10.25) - 0.1e-3).abs() < 1e-15, "its depth half a wavelength in");
    assert!(corrugation.at(10.5).abs() < 1e-15);
    let weld = Irregularity::weld(5.0);
    assert_eq!(weld.at(4.99), 0.0);
    assert_eq!(weld.at(6.0), 0.0);
    // At the weld's centre both waves are at their depths (eq. (25)).
    assert!((weld.at(5.5) - 0.6e-3).abs() < 1e-12, "{}", weld.at(5.5));
    assert!((weld.at(5.45) - 0.5 * 0.3e-3 * (1.0 - (std::f64::consts::TAU * 0.45).cos())).abs() < 1e-12);
}

/// The estimator's eq. (7) and the truth's vehicle are written apart (coordinates up and
/// from equilibrium there, down and absolute here); given the truth's contact forces and
/// the same parameters they must give the same accelerations. What the estimator lacks is
/// the track and the contact, not the vehicle.
#[test]
fn the_estimators_vehicle_is_the_truths_without_the_track() {
    let v = Vehicle::ZHAI_PASSENGER;
    let model = WheelRailVertical { vehicle: vertical_vehicle(&v) };
    assert_eq!(model.vehicle.static_wheel_load, v.static_wheel_load());
    let settings = Settings::default();
    let mut sim = simulation(Irregularity::weld(12.0), &settings);
    let rest: Vec<f64> = sim.displacements()[..10].to_vec();
    // Truth order [z_c, β_c, z_t1, β_t1, z_t2, β_t2, z_w1..4]; the estimator's
    // [z_c, β_c, z_t1, z_t2, β_t1, β_t2, z_w1..4].
    let order = [0, 1, 2, 4, 3, 5, 6, 7, 8, 9];
    let mut checked = 0;
    while sim.time() < 0.6 {
        sim.step();
        let (u, v, a) = (sim.displacements(), sim.velocities(), sim.accelerations());
        // Up and from equilibrium; a pitch keeps its sign (a point at d rises by z + d·β).
        let mut x = [0.0; 24];
        for (k, &t) in order.iter().enumerate() {
            let sign = if t == 1 || t == 3 || t == 5 { 1.0 } else { -1.0 };
            x[k] = sign * (u[t] - rest[t]);
            x[10 + k] = sign * v[t];
        }
        x[20..].copy_from_slice(&sim.contact());
        let mut dxdt = [0.0; 24];
        model.derivative(0.0, &x, &[], &mut dxdt);
        for (k, &t) in order.iter().enumerate() {
            let sign = if t == 1 || t == 3 || t == 5 { 1.0 } else { -1.0 };
            let truth = sign * a[t];
            assert!(
                (dxdt[10 + k] - truth).abs() < 1e-6 * (1.0 + truth.abs()),
                "{}: {} against {truth}",
                WheelRailVertical::STATE_NAMES[10 + k],
                dxdt[10 + k]
            );
        }
        let mut z = [0.0; 7];
        model.observe(0.0, &x, &[], &mut z);
        assert_eq!(z[0], dxdt[10]);
        checked += 1;
    }
    assert!(checked > 5000 && sim.contact()[0] != v.static_wheel_load());
}
