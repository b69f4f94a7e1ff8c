//! The car body's free vibrations on the S3 truth against the undamped estimates computed
//! from the parameters alone: bounce and pitch (the car body over the two bogies, 2 DOF
//! each) and roll (car body and bogies, lateral and roll, 4 DOF, with the gravity
//! stiffness of the heights). Each run starts in the estimate's mode shape, the dampers
//! removed, and its period is read from the zero crossings of the car body's coordinate.
//! The estimates hold the wheelsets fixed; the truth has them on Hertz springs, the
//! flexible track and creep: the tolerance, 2 %, covers that.

use nalgebra::{DMatrix, SymmetricEigen};
use truth::s2::parameters::G;
use truth::s3::irregularity::Irregularity;
use truth::s3::parameters::{Track, Vehicle};
use truth::s3::plant::{Settings, Simulation};
use truth::s3::vehicle::{bogie, index, Coordinate, CAR_BODY};

fn undamped() -> Vehicle {
    let mut v = Vehicle::PASSENGER;
    v.vertical.secondary_damping = 0.0;
    v.vertical.primary_damping = 0.0;
    v.vertical.primary_damping_beyond = 0.0;
    v.secondary_lateral_damping = 0.0;
    v.secondary_longitudinal_damping = 0.0;
    v
}

/// The undamped modes of `V(q) = ½·qᵀKq` with masses `m`: frequencies (Hz) and shapes,
/// lowest first. `K` is read from `V` exactly: `K_ij = V(e_i + e_j) − V(e_i) − V(e_j)`.
fn modes(m: &[f64], energy: impl Fn(&[f64]) -> f64) -> Vec<(f64, Vec<f64>)> {
    let n = m.len();
    let unit = |i: usize| (0..n).map(|k| if k == i { 1.0 } else { 0.0 }).collect::<Vec<_>>();
    let both = |i: usize, j: usize| (0..n).map(|k| if k == i || k == j { 1.0 } else { 0.0 }).collect::<Vec<_>>();
    let k = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            2.0 * energy(&unit(i))
        } else {
            energy(&both(i, j)) - energy(&unit(i)) - energy(&unit(j))
        }
    });
    let scale = DMatrix::from_fn(n, n, |i, j| if i == j { 1.0 / m[i].sqrt() } else { 0.0 });
    let eigen = SymmetricEigen::new(&scale * k * &scale);
    let mut out: Vec<(f64, Vec<f64>)> = (0..n)
        .map(|c| {
            let shape = (0..n).map(|i| eigen.eigenvectors[(i, c)] / m[i].sqrt()).collect();
            (eigen.eigenvalues[c].sqrt() / std::f64::consts::TAU, shape)
        })
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// Runs the undamped car for `seconds` at `speed` from `set` (applied to the static
/// state) and returns the frequency (Hz) of `body`'s coordinate `c` from its zero
/// crossings about its static value.
fn measured(speed: f64, seconds: f64, set: impl FnOnce(&mut [f64]), body: usize, c: Coordinate) -> f64 {
    let settings = Settings { speed, ..Settings::default() };
    let mut sim = Simulation::new(undamped(), Track::BALLASTED, Irregularity::None, &settings).expect("runs");
    let k = index(body, c).expect("a coordinate");
    let rest = sim.displacements()[k];
    sim.perturb(|u, _| set(u));
    let mut crossings = Vec::new();
    let mut previous = sim.displacements()[k] - rest;
    while sim.time() < seconds {
        sim.step();
        let x = sim.displacements()[k] - rest;
        if previous < 0.0 && x >= 0.0 {
            crossings.push(sim.time() - settings.dt * x / (x - previous));
        }
        previous = x;
    }
    assert!(crossings.len() >= 3, "{} crossings", crossings.len());
    (crossings.len() - 1) as f64 / (crossings[crossings.len() - 1] - crossings[0])
}

fn add(u: &mut [f64], body: usize, c: Coordinate, x: f64) {
    u[index(body, c).expect("a coordinate")] += x;
}

#[test]
fn car_body_bounce_and_pitch_match_the_two_degree_of_freedom_estimates() {
    let car = undamped();
    let v = car.vertical;
    let (ks, kp, lc) = (v.secondary_stiffness, v.primary_stiffness, v.half_bogie_spacing);
    // Bounce: car body and both bogies together, four secondary and eight primary springs.
    let bounce = modes(&[v.car_body_mass, 2.0 * v.bogie_mass], |q| {
        0.5 * 4.0 * ks * (q[1] - q[0]).powi(2) + 0.5 * 8.0 * kp * q[1].powi(2)
    });
    // Pitch: the car body's pitch and the bogies bouncing against each other (front −b,
    // rear +b), with the secondary longitudinal springs and the weight acting below and
    // at the car body's centre of mass.
    let below = car.car_body_height - car.secondary_height;
    let pitch = modes(&[v.car_body_pitch_inertia, 2.0 * v.bogie_mass], |q| {
        2.0 * ks * (lc * q[0] - q[1]).powi(2)
            + 4.0 * kp * q[1].powi(2)
            + 0.5 * 4.0 * car.secondary_longitudinal_stiffness * (below * q[0]).powi(2)
            - 0.5 * v.car_body_mass * G * below * q[0].powi(2)
    });
    let (f_bounce, shape) = &bounce[0];
    let a = 5e-3 / shape[0];
    let got_bounce = measured(
        80.0 / 3.6,
        4.5,
        |u| {
            add(u, CAR_BODY, Coordinate::Vertical, a * shape[0]);
            add(u, bogie(0), Coordinate::Vertical, a * shape[1]);
            add(u, bogie(1), Coordinate::Vertical, a * shape[1]);
        },
        CAR_BODY,
        Coordinate::Vertical,
    );
    let (f_pitch, shape) = &pitch[0];
    let a = 5e-4 / shape[0];
    let got_pitch = measured(
        80.0 / 3.6,
        4.5,
        |u| {
            add(u, CAR_BODY, Coordinate::Pitch, a * shape[0]);
            add(u, bogie(0), Coordinate::Vertical, -a * shape[1]);
            add(u, bogie(1), Coordinate::Vertical, a * shape[1]);
        },
        CAR_BODY,
        Coordinate::Pitch,
    );
    eprintln!("bounce: {got_bounce:.4} Hz against {f_bounce:.4} Hz; pitch: {got_pitch:.4} Hz against {f_pitch:.4} Hz");
    assert!((got_bounce / f_bounce - 1.0).abs() < 0.02);
    assert!((got_pitch / f_pitch - 1.0).abs() < 0.02);
}

#[test]
fn car_body_sway_and_roll_match_the_four_degree_of_freedom_estimate() {
    let car = undamped();
    let v = car.vertical;
    let (ds, dw) = (car.secondary_half_span, car.primary_half_span);
    // Arms down from the centres of mass to the spring planes (the primary at the axle).
    let car_to_secondary = car.car_body_height - car.secondary_height;
    let bogie_to_secondary = car.bogie_height - car.secondary_height;
    let bogie_to_primary = car.bogie_height - v.wheel_radius;
    let secondary_load = v.car_body_mass * G / 4.0;
    let primary_load = (v.car_body_mass + 2.0 * v.bogie_mass) * G / 8.0;
    // q = [y_c, φ_c, y_t, φ_t], both bogies alike; the wheelsets held.
    let energy = |q: &[f64]| {
        let (yc, rc, yt, rt) = (q[0], q[1], q[2], q[3]);
        let secondary_shear = (yt - bogie_to_secondary * rt) - (yc - car_to_secondary * rc);
        let secondary = 0.5 * 4.0 * car.secondary_lateral_stiffness * secondary_shear.powi(2)
            + 0.5 * 4.0 * v.secondary_stiffness * (ds * (rt - rc)).powi(2);
        let primary = 0.5 * 8.0 * car.primary_lateral_stiffness * (yt - bogie_to_primary * rt).powi(2)
            + 0.5 * 8.0 * v.primary_stiffness * (dw * rt).powi(2);
        // Each load tips the body it rests on, or hangs from, by load × height difference.
        let gravity = -0.5 * 4.0 * secondary_load * car_to_secondary * rc.powi(2)
            - 0.5 * 4.0 * secondary_load * (-bogie_to_secondary) * rt.powi(2)
            - 0.5 * 8.0 * primary_load * bogie_to_primary * rt.powi(2);
        secondary + primary + gravity
    };
    let roll =
        modes(&[v.car_body_mass, car.car_body_roll_inertia, 2.0 * v.bogie_mass, 2.0 * car.bogie_roll_inertia], energy);
    for (mode, name, seconds) in [(0, "lower sway", 8.0), (1, "upper roll", 4.0)] {
        let (expected, shape) = &roll[mode];
        let a = 5e-3 / shape[1];
        let got = measured(
            80.0 / 3.6,
            seconds,
            |u| {
                add(u, CAR_BODY, Coordinate::Lateral, a * shape[0]);
                add(u, CAR_BODY, Coordinate::Roll, a * shape[1]);
                for i in 0..2 {
                    add(u, bogie(i), Coordinate::Lateral, a * shape[2]);
                    add(u, bogie(i), Coordinate::Roll, a * shape[3]);
                }
            },
            CAR_BODY,
            Coordinate::Roll,
        );
        eprintln!("{name}: {got:.4} Hz against {expected:.4} Hz (shape y_c/φ_c = {:.3} m/rad)", shape[0] / shape[1]);
        assert!((got / expected - 1.0).abs() < 0.02, "{name}");
    }
}
