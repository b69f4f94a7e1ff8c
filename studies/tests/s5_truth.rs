//! S5's first truth is right: a trimmed start stays trimmed and a disturbed one oscillates
//! as the moment model predicts; energy and kinematics are consistent; halving the step
//! changes nothing that matters; the manoeuvre leaves no coefficient unobservable.

use estimator::models::Airframe;
use studies::s5::excitation::cramer_rao;
use truth::s5::flight::{flight, simulate, Settings};
use truth::s5::manoeuvre::Manoeuvre;
use truth::s5::parameters::{start, NAMES};
use truth::s5::plant::{Flight, Motion};

/// The study's airframe without gravity, its coefficients with no trim offsets: a
/// symmetric missile whose equilibrium is α = β = 0.
fn symmetric() -> (Airframe, [f64; 10]) {
    let airframe = Airframe { gravity: 0.0, ..Airframe::tactical_missile() };
    let c = [0.0, 0.0, 0.0, 0.0, 0.0, 9.2596, -0.8647, 0.0, -8.7916, 0.2229];
    (airframe, c)
}

fn free_flight(airframe: Airframe, c: [f64; 10], x0: Motion, seconds: f64, dt: f64) -> Vec<Motion> {
    let f = Flight { airframe, coefficients: [c, c], manoeuvre: Manoeuvre::standard() };
    let mut x = x0;
    let mut out = vec![x];
    for _ in 0..(seconds / dt).round() as usize {
        x = f.step(&c, &[0.0; 3], dt, &x);
        out.push(x);
    }
    out
}

#[test]
fn a_trimmed_start_with_zero_rudder_stays_trimmed() {
    let (airframe, c) = symmetric();
    let x0 = [1000.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10_000.0, 0.0, 0.0, 0.0];
    let run = free_flight(airframe, c, x0, 2.0, 5e-4);
    for x in &run {
        assert!(x[1].abs() < 1e-12 && x[2].abs() < 1e-12, "no normal or lateral velocity: {x:?}");
        assert!(x[7..].iter().all(|w| w.abs() < 1e-12), "no rotation: {x:?}");
    }
}

#[test]
fn a_disturbed_start_oscillates_in_pitch_as_the_moment_model_predicts() {
    // The short period, linearised about α = 0, ω_z = 0 at 1000 m/s and 10 km:
    // α̇ = ω_z − (q·S·C_y^α/(m·V))·α,  ω̇_z = (q·S·L/I_z)·(m_z^α·α + m_z^ω·(L/V)·ω_z).
    let (airframe, c) = symmetric();
    let (v, h) = (1000.0, 10_000.0);
    let q = 0.5 * estimator::models::atmosphere::density(h) * v * v;
    let m = airframe.moments;
    let (s, l) = (airframe.area, airframe.length);
    let z_alpha = q * s * c[5] / (airframe.mass * v);
    let (m_alpha, m_q) = (
        q * s * l * m.pitch_stiffness / airframe.inertia[2],
        q * s * l * m.pitch_damping * l / v / airframe.inertia[2],
    );
    // s² + (Z_α − M_q)·s + (−M_α − Z_α·M_q) = 0
    let (b, k) = (z_alpha - m_q, -m_alpha - z_alpha * m_q);
    let (decay, frequency) = (b / 2.0, (k - b * b / 4.0).sqrt());

    let alpha0 = 1f64.to_radians();
    let x0 = [v * alpha0.cos(), -v * alpha0.sin(), 0.0, 0.0, 0.0, 0.0, h, 0.0, 0.0, 0.0];
    let dt = 1e-4;
    let run = free_flight(airframe, c, x0, 1.0, dt);
    // The pitch rate's successive maxima: their spacing is the damped period, their ratio
    // the decay over it.
    let w: Vec<f64> = run.iter().map(|x| x[9]).collect();
    let peaks: Vec<usize> = (1..w.len() - 1).filter(|&k| w[k] > w[k - 1] && w[k] >= w[k + 1] && w[k] > 0.0).collect();
    assert!(peaks.len() >= 2, "at least two periods in 1 s: {peaks:?}");
    let period = (peaks[1] - peaks[0]) as f64 * dt;
    let measured_frequency = 2.0 * std::f64::consts::PI / period;
    let measured_decay = (w[peaks[0]] / w[peaks[1]]).ln() / period;
    assert!((measured_frequency / frequency - 1.0).abs() < 0.02, "ω_d {measured_frequency} against {frequency}");
    assert!((measured_decay / decay - 1.0).abs() < 0.05, "σ {measured_decay} against {decay}");
    assert!(frequency > 10.0 && frequency < 30.0, "a short period of tens of rad/s: {frequency}");
}

#[test]
fn a_roll_rate_decays_as_the_roll_damping_predicts() {
    let (airframe, c) = symmetric();
    let (v, h) = (1000.0, 10_000.0);
    let q = 0.5 * estimator::models::atmosphere::density(h) * v * v;
    let rate =
        q * airframe.area * airframe.length * airframe.moments.roll_damping * airframe.length / v / airframe.inertia[0];
    let x0 = [v, 0.0, 0.0, 0.0, 0.0, 0.0, h, 0.1, 0.0, 0.0];
    let run = free_flight(airframe, c, x0, 0.5, 1e-4);
    let expected = 0.1 * (rate * 0.5).exp();
    assert!((run.last().unwrap()[7] / expected - 1.0).abs() < 1e-6, "{} against {expected}", run.last().unwrap()[7]);
}

#[test]
fn without_air_energy_and_angular_momentum_are_kept_and_the_euler_rates_match_the_rotation() {
    // No aerodynamic force or moment: a torque-free body falling freely. Its mechanical
    // energy, rotational energy and angular momentum are constants of the motion, and the
    // attitude integrated as a rotation matrix (Ċ = C·[ω]×) must give the Euler angles that
    // eq. (1)'s angle rates give.
    let airframe = Airframe { area: 0.0, ..Airframe::tactical_missile() };
    let [ix, iy, iz] = airframe.inertia;
    let x0 = [300.0, 20.0, -10.0, 0.3, 0.2, 0.1, 5_000.0, 0.5, 0.3, -0.2];
    let dt = 1e-4;
    let (mut x, mut rotation) = (x0, euler_to_matrix(x0[3], x0[4], x0[5]));
    let energy = |x: &Motion| 0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) + 9.8 * x[6];
    let spin = |x: &Motion| 0.5 * (ix * x[7] * x[7] + iy * x[8] * x[8] + iz * x[9] * x[9]);
    let momentum = |x: &Motion| ((ix * x[7]).powi(2) + (iy * x[8]).powi(2) + (iz * x[9]).powi(2)).sqrt();
    let f = Flight { airframe, coefficients: [[0.0; 10]; 2], manoeuvre: Manoeuvre::standard() };
    for _ in 0..20_000 {
        let omega = [x[7], x[8], x[9]];
        let next = f.step(&[0.0; 10], &[0.0; 3], dt, &x);
        let omega_next = [next[7], next[8], next[9]];
        rotation = rotate(&rotation, &omega, &omega_next, dt);
        x = next;
    }
    assert!((energy(&x) / energy(&x0) - 1.0).abs() < 1e-9, "specific energy");
    assert!((spin(&x) / spin(&x0) - 1.0).abs() < 1e-9, "rotational energy");
    assert!((momentum(&x) / momentum(&x0) - 1.0).abs() < 1e-9, "angular momentum");
    let (phi, psi, gamma) = matrix_to_euler(&rotation);
    for (a, b, name) in [(phi, x[3], "pitch"), (psi, x[4], "yaw"), (gamma, x[5], "roll")] {
        assert!((a - b).abs() < 1e-6, "{name}: rotation {a}, Euler rates {b}");
    }
}

#[test]
fn with_air_the_energy_changes_by_the_aerodynamic_work() {
    let f = flight();
    let dt = 5e-4;
    let mut x = start();
    let e0 = 0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) + 9.8 * x[6];
    let mut work = 0.0;
    let power = |x: &Motion, c: &[f64; 10], delta: &[f64; 3]| {
        let air = f.airframe.air(&x[..3], x[6]);
        let force = f.airframe.force(&air, c, delta);
        (force[0] * x[0] + force[1] * x[1] + force[2] * x[2]) / f.airframe.mass
    };
    for k in 0..4000 {
        let (c, delta) = (*f.coefficients_over(k, 0.005), f.manoeuvre.held(k, 0.005));
        for _ in 0..10 {
            let next = f.step(&c, &delta, dt, &x);
            // Simpson's rule on the step, the middle from a half step.
            let middle = f.step(&c, &delta, dt / 2.0, &x);
            work += dt / 6.0 * (power(&x, &c, &delta) + 4.0 * power(&middle, &c, &delta) + power(&next, &c, &delta));
            x = next;
        }
    }
    let e = 0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) + 9.8 * x[6];
    assert!(((e - e0) / work - 1.0).abs() < 1e-6, "energy change {} against the aerodynamic work {work}", e - e0);
    assert!(work < -1e5, "drag takes energy away: {work}");
}

#[test]
fn halving_the_step_changes_the_flight_negligibly() {
    let f = flight();
    let coarse = f.fly(&start(), 0.005, 10).unwrap();
    let fine = f.fly(&start(), 0.005, 20).unwrap();
    let scales = [1000.0, 1000.0, 1000.0, 1.0, 1.0, 1.0, 10_000.0, 1.0, 1.0, 1.0];
    for (a, b) in coarse.iter().zip(&fine) {
        for i in 0..10 {
            assert!(((a[i] - b[i]) / scales[i]).abs() < 1e-9, "state {i}: {} against {}", a[i], b[i]);
        }
    }
}

#[test]
fn the_manoeuvre_leaves_no_coefficient_unobservable() {
    let settings = Settings::default();
    let truth = simulate(&settings);
    let f = flight();
    for first in [0, 2000] {
        let bound = cramer_rao(&f, &truth.motion[first], first, 2000, 0.005, 10, 1.0).expect("informative run");
        for i in 0..10 {
            let relative = bound[10 + i] / truth.coefficients[first][i].abs();
            assert!(
                relative < 0.005,
                "{} from sample {first}: Cramér–Rao σ {:.2} % of its value",
                NAMES[i],
                100.0 * relative
            );
        }
    }
}

/// Body to Earth: `R_y(ψ)·R_z(φ)·R_x(γ)` (Earth axes x, y up, z), the paper's order.
fn euler_to_matrix(phi: f64, psi: f64, gamma: f64) -> [[f64; 3]; 3] {
    let (sf, cf) = phi.sin_cos();
    let (sp, cp) = psi.sin_cos();
    let (sg, cg) = gamma.sin_cos();
    let ry = [[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]];
    let rz = [[cf, -sf, 0.0], [sf, cf, 0.0], [0.0, 0.0, 1.0]];
    let rx = [[1.0, 0.0, 0.0], [0.0, cg, -sg], [0.0, sg, cg]];
    mul(&mul(&ry, &rz), &rx)
}

fn matrix_to_euler(c: &[[f64; 3]; 3]) -> (f64, f64, f64) {
    (c[1][0].asin(), (-c[2][0]).atan2(c[0][0]), (-c[1][2]).atan2(c[1][1]))
}

fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// One step of `Ċ = C·[ω]×` by the exponential of the rotation over the step, ω taken
/// at the step's middle (second order, which the 1e-4 s step makes ample).
fn rotate(c: &[[f64; 3]; 3], omega: &[f64; 3], omega_next: &[f64; 3], dt: f64) -> [[f64; 3]; 3] {
    let w: [f64; 3] = std::array::from_fn(|i| 0.5 * (omega[i] + omega_next[i]) * dt);
    let angle = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let k = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
    let k2 = mul(&k, &k);
    let (a, b) = if angle > 0.0 { (angle.sin() / angle, (1.0 - angle.cos()) / (angle * angle)) } else { (1.0, 0.5) };
    let exp: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j)) + a * k[i][j] + b * k2[i][j]));
    mul(c, &exp)
}
