//! The S3 truth at rest: on a level, perfect track the car stands still, each wheel
//! carrying its share of the weight, left as right.

use truth::s3::irregularity::Irregularity;
use truth::s3::parameters::{Track, Vehicle};
use truth::s3::plant::{Settings, Simulation};
use truth::s3::vehicle::{index, Coordinate, DOFS};

fn at_rest() -> Simulation {
    Simulation::new(Vehicle::PASSENGER, Track::BALLASTED, Irregularity::None, &Settings::default()).expect("runs")
}

#[test]
fn each_wheel_carries_an_eighth_of_the_weight_left_as_right() {
    let sim = at_rest();
    let share = Vehicle::PASSENGER.static_wheel_load();
    let forces = sim.sample().contact;
    for (k, f) in forces.iter().enumerate() {
        assert!((f / share - 1.0).abs() < 1e-9, "wheel {k}: {f} N against {share} N");
    }
    for j in 0..4 {
        assert!((forces[j] - forces[4 + j]).abs() < 1e-6, "wheelset {}: {} vs {}", j + 1, forces[j], forces[4 + j]);
    }
    // The car's weight, whole, is on the rails.
    let v = Vehicle::PASSENGER.vertical;
    let weight = (v.car_body_mass + 2.0 * v.bogie_mass + 4.0 * v.wheelset_mass) * truth::s2::parameters::G;
    assert!((forces.iter().sum::<f64>() / weight - 1.0).abs() < 1e-9);
}

/// On a perfect track the only excitation is the rail's changing stiffness between and over
/// the sleepers (37 Hz at 80 km/h): it moves every wheel alike, left as right, and the car
/// as S2's half car on one rail. Nothing moves sideways or rolls.
#[test]
fn a_perfect_track_keeps_the_car_still_but_for_the_sleepers_passing_as_in_s2() {
    let mut sim = at_rest();
    let settings = Settings::default();
    let s2_settings =
        truth::s2::plant::Settings { modes: settings.modes, supports: settings.supports, ..Default::default() };
    let mut s2 = truth::s2::plant::Simulation::new(
        Vehicle::PASSENGER.vertical,
        Track::BALLASTED,
        truth::s2::irregularity::Irregularity::None,
        &s2_settings,
    );
    let share = Vehicle::PASSENGER.static_wheel_load();
    let start = std::time::Instant::now();
    let (mut force, mut body, mut asymmetry, mut lateral, mut against_s2) =
        (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    // 1 s: 22 m at 80 km/h, the windows moving on 37 times.
    for _ in 0..10_000 {
        sim.step();
        s2.step();
        let s = sim.sample();
        force = s.contact.iter().fold(force, |m, f| m.max((f / share - 1.0).abs()));
        body = s.accelerations[16..].iter().fold(body, |m, a| m.max(a.abs()));
        asymmetry = (0..4).fold(asymmetry, |m, j| m.max((s.contact[j] - s.contact[4 + j]).abs()));
        against_s2 = (0..4).fold(against_s2, |m, j| m.max((s.contact[j] - s2.contact()[j]).abs()));
        let u = &sim.displacements()[..DOFS];
        for body in 0..7 {
            for c in [Coordinate::Lateral, Coordinate::Roll, Coordinate::Yaw] {
                lateral = lateral.max(index(body, c).map_or(0.0, |k| u[k].abs()));
            }
        }
    }
    let wall = start.elapsed().as_secs_f64();
    eprintln!(
        "perfect track, 1 s: largest force change {force:.2e} of P0, against S2 {against_s2:.2e} N, L − R \
         {asymmetry:.2e} N, car body {body:.2e} m/s², lateral/roll/yaw {lateral:.2e}; both S2 and S3 in {wall:.2} s"
    );
    assert!(force < 0.01, "force change {force}");
    assert!(against_s2 < 0.02 * force * share, "{against_s2} N from S2's forces");
    assert!(asymmetry < 1e-6, "L − R {asymmetry} N");
    assert!(body < 0.01, "car body {body} m/s²");
    assert!(lateral < 1e-12, "lateral {lateral}");
}

#[test]
fn bad_settings_are_refused() {
    let run = |settings: &Settings| Simulation::new(Vehicle::PASSENGER, Track::BALLASTED, Irregularity::None, settings);
    assert!(run(&Settings { speed: 0.0, ..Settings::default() }).is_err());
    assert!(run(&Settings { dt: f64::NAN, ..Settings::default() }).is_err());
    assert!(run(&Settings { supports: 30, ..Settings::default() }).is_err());
    assert!(run(&Settings { dt: 1e-3, ..Settings::default() }).is_err());
    let broken = Vehicle { conicity: 0.0, ..Vehicle::PASSENGER };
    assert!(Simulation::new(broken, Track::BALLASTED, Irregularity::None, &Settings::default()).is_err());
}
