//! The batched model calls give the point-by-point numbers bit for bit, so a
//! filter's result does not depend on whether a model overrides them.

use estimator::math;
use estimator::models::{
    atmosphere, Airframe, Missile6Dof, Oscillator2Dof, Oscillator2DofLoad, RollVehicle, VerticalVehicle, WheelRailRoll,
    WheelRailVertical,
};
use estimator::{Component, Discretized, Observation, Process, VectorField, BLOCK_POINTS};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `BLOCK_POINTS` points of dimension `n`, spread wide enough to cross the dampers' breakpoints.
fn block(n: usize, seed: u64) -> Vec<Component> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| std::array::from_fn(|_| rng.random_range(-0.5..0.5))).collect()
}

fn point(block: &[Component], p: usize) -> Vec<f64> {
    block.iter().map(|c| c[p]).collect()
}

fn assert_block_equals_pointwise<M: Process + Observation>(model: M, what: &str) {
    let n = model.state_dim();
    assert_blocks_equal_points(model, &[], |seed| block(n, seed), what);
}

/// The block calls of `model` at the blocks `points(seed)` with the inputs `u` give, at
/// every point, the point calls' numbers to the bit.
fn assert_blocks_equal_points<M: Process + Observation>(
    mut model: M,
    u: &[f64],
    points: impl Fn(u64) -> Vec<Component>,
    what: &str,
) {
    let (n, m) = (model.state_dim(), model.measurement_dim());
    let mut scratch = vec![0.0; 2 * n + m];
    for seed in 0..20 {
        let x = points(seed);
        let (mut x_next, mut z) = (vec![[0.0; BLOCK_POINTS]; n], vec![[0.0; BLOCK_POINTS]; m]);
        model.transition_block(0.3, 0.005, &x, u, &mut x_next, &mut scratch);
        model.observe_block(0.3, &x, u, &mut z, &mut scratch);
        for p in 0..BLOCK_POINTS {
            let (mut x1, mut z1) = (vec![0.0; n], vec![0.0; m]);
            model.transition(0.3, 0.005, &point(&x, p), u, &mut x1);
            model.observe(0.3, &point(&x, p), u, &mut z1);
            let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&point(&x_next, p)), bits(&x1), "{what}: transition of point {p}, seed {seed}");
            assert_eq!(bits(&point(&z, p)), bits(&z1), "{what}: observation of point {p}, seed {seed}");
        }
    }
}

#[test]
fn the_s2_model_s_vectorised_block_law_equals_its_point_law_bit_for_bit() {
    let model = WheelRailVertical { vehicle: VerticalVehicle::zhai_passenger() };
    assert_block_equals_pointwise(Discretized::rk4(model, 1), "wheel-rail, 1 RK4 step");
    assert_block_equals_pointwise(Discretized::rk4(model, 3), "wheel-rail, 3 RK4 steps");
}

/// Eq. (7) of S2 point by point, force by force, as the model was first written: the
/// reference its lane-by-lane law must reproduce to the bit.
fn s2_accelerations_by_forces(vehicle: &VerticalVehicle, z: &[f64], v: &[f64], f_n: &[f64]) -> [f64; 10] {
    let (lc, lt) = (vehicle.half_bogie_spacing, vehicle.half_wheelbase);
    let mut f_s = [0.0; 2];
    let mut f_p = [0.0; 4];
    for (i, d) in [lc, -lc].into_iter().enumerate() {
        f_s[i] = vehicle.secondary_stiffness * (z[2 + i] - z[0] - d * z[1])
            + vehicle.secondary_damping * (v[2 + i] - v[0] - d * v[1]);
        for (k, e) in [lt, -lt].into_iter().enumerate() {
            let j = 2 * i + k;
            f_p[j] = vehicle.primary_stiffness * (z[6 + j] - z[2 + i] - e * z[4 + i])
                + vehicle.primary_damper.force(v[6 + j] - v[2 + i] - e * v[4 + i]);
        }
    }
    let mut a = [0.0; 10];
    a[0] = (f_s[0] + f_s[1]) / vehicle.car_body_mass;
    a[1] = (f_s[0] - f_s[1]) * lc / vehicle.car_body_pitch_inertia;
    for i in 0..2 {
        a[2 + i] = (f_p[2 * i] + f_p[2 * i + 1] - f_s[i]) / vehicle.bogie_mass;
        a[4 + i] = (f_p[2 * i] - f_p[2 * i + 1]) * lt / vehicle.bogie_pitch_inertia;
    }
    for j in 0..4 {
        a[6 + j] = (-f_p[j] - vehicle.static_wheel_load + f_n[j]) / vehicle.wheelset_mass;
    }
    a
}

#[test]
fn the_s2_model_s_lane_law_is_its_equations_force_by_force_bit_for_bit() {
    let vehicle = VerticalVehicle::zhai_passenger();
    for seed in 0..50 {
        let x = point(&block(24, 1000 + seed), (seed % 8) as usize);
        let forces: Vec<f64> = x[20..24].iter().map(|f| 8e4 * f).collect();
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&vehicle.accelerations(&x[..10], &x[10..20], &forces)),
            bits(&s2_accelerations_by_forces(&vehicle, &x[..10], &x[10..20], &forces)),
            "seed {seed}"
        );
    }
}

#[test]
fn the_s1_model_s_vectorised_block_law_equals_its_point_law_bit_for_bit() {
    for chain in [Oscillator2Dof::stiffness_nonlinear(), Oscillator2Dof::damping_nonlinear()] {
        assert_block_equals_pointwise(Discretized::rk4(Oscillator2DofLoad::new(chain), 2), "S1 model");
    }
}

#[test]
fn the_s3_model_s_vectorised_block_law_equals_its_point_law_bit_for_bit() {
    for force_return_rate in [0.0, 2.0] {
        let model = WheelRailRoll { vehicle: RollVehicle::zhai_passenger(), force_return_rate };
        assert_block_equals_pointwise(Discretized::rk4(model, 1), "S3 model");
    }
}

/// Missile states about the study's flight, spread across the atmosphere's layers (to
/// 35 km), through a roll of ±80° and with one point at rest (where the angles and the
/// rate damping take their defined values).
fn missile_block(seed: u64) -> Vec<Component> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let coefficients = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];
    let mut x: Vec<Component> = (0..20)
        .map(|i| {
            std::array::from_fn(|_| match i {
                0 => rng.random_range(-100.0..1500.0),
                1 | 2 => rng.random_range(-200.0..200.0),
                3..=5 => rng.random_range(-1.4..1.4),
                6 => rng.random_range(0.0..35_000.0),
                7..=9 => rng.random_range(-2.0..2.0),
                _ => coefficients[i - 10] * rng.random_range(0.5..1.5),
            })
        })
        .collect();
    for v in &mut x[..3] {
        v[(seed % 8) as usize] = 0.0;
    }
    x
}

#[test]
fn the_s5_model_s_vectorised_block_law_equals_its_point_law_bit_for_bit() {
    let model = Missile6Dof { airframe: Airframe::tactical_missile() };
    let fins = [0.01, -0.03, 0.02];
    assert_blocks_equal_points(Discretized::rk4(model, 1), &fins, missile_block, "missile, 1 RK4 step");
    assert_blocks_equal_points(Discretized::rk4(model, 2), &fins, missile_block, "missile, 2 RK4 steps");
}

/// Eq. (1) and (2) of S5 point by point, as the model was first written: the reference
/// its lane-by-lane law must reproduce to the bit.
fn s5_as_first_written(a: &Airframe, x: &[f64], c: &[f64], delta: &[f64]) -> ([f64; 10], [f64; 12]) {
    let [vx, vy, vz, phi, _psi, gamma, h, wx, wy, wz] = [x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9]];
    let speed = (vx * vx + vy * vy + vz * vz).sqrt();
    let beta = if speed > 0.0 { math::asin((vz / speed).clamp(-1.0, 1.0)) } else { 0.0 };
    let alpha = math::atan2(-vy, vx);
    let q = 0.5 * atmosphere::density(h) * speed * speed;
    let qs = q * a.area;
    let f = [
        qs * (c[0] + c[1] * alpha + c[2] * beta + c[3] * delta[0]),
        qs * (c[4] + c[5] * alpha + c[6] * delta[1]),
        qs * (c[7] + c[8] * beta + c[9] * delta[2]),
    ];
    let mm = &a.moments;
    let qsl = q * a.area * a.length;
    let reduced = if speed > 0.0 { a.length / speed } else { 0.0 };
    let moment = [
        qsl * (mm.roll_control * delta[0] + mm.roll_damping * wx * reduced),
        qsl * (mm.yaw_stiffness * beta + mm.yaw_control * delta[2] + mm.yaw_damping * wy * reduced),
        qsl * (mm.pitch_stiffness * alpha + mm.pitch_control * delta[1] + mm.pitch_damping * wz * reduced),
    ];
    let (g, m) = (a.gravity, a.mass);
    let [ix, iy, iz] = a.inertia;
    let (sin_phi, cos_phi) = math::sin_cos(phi);
    let (sin_gamma, cos_gamma) = math::sin_cos(gamma);
    let yaw_pitch = wy * cos_gamma - wz * sin_gamma;
    let d = [
        wz * vy - wy * vz - g * sin_phi + f[0] / m,
        wx * vz - wz * vx - g * cos_phi * cos_gamma + f[1] / m,
        wy * vx - wx * vy + g * cos_phi * sin_gamma + f[2] / m,
        wy * sin_gamma + wz * cos_gamma,
        yaw_pitch / cos_phi,
        wx - yaw_pitch * math::tan(phi),
        vx * sin_phi + vy * cos_phi * cos_gamma - vz * cos_phi * sin_gamma,
        ((iy - iz) * wy * wz + moment[0]) / ix,
        ((iz - ix) * wz * wx + moment[1]) / iy,
        ((ix - iy) * wx * wy + moment[2]) / iz,
    ];
    let w = m * g;
    let z = [wx, wy, wz, f[0] / w, f[1] / w, f[2] / w, phi, x[4], gamma, h, alpha, beta];
    (d, z)
}

#[test]
fn the_s5_model_s_lane_law_is_its_equations_as_first_written_bit_for_bit() {
    let airframe = Airframe::tactical_missile();
    let delta = [0.01, -0.03, 0.02];
    let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
    for seed in 0..50 {
        let x = point(&missile_block(2000 + seed), (seed % 8) as usize);
        let (d, z) = s5_as_first_written(&airframe, &x[..10], &x[10..], &delta);
        let (mut d1, mut z1) = ([0.0; 10], [0.0; 12]);
        airframe.motion_derivative(&x[..10], &x[10..], &delta, &mut d1);
        airframe.measure(&x[..10], &x[10..], &delta, &mut z1);
        assert_eq!(bits(&d1), bits(&d), "derivative, seed {seed}");
        assert_eq!(bits(&z1), bits(&z), "measurement, seed {seed}");
    }
}

/// A model with only the point-by-point methods.
struct PointOnly(Oscillator2DofLoad);

impl VectorField for PointOnly {
    fn state_dim(&self) -> usize {
        6
    }
    fn derivative(&self, t: f64, x: &[f64], u: &[f64], dxdt: &mut [f64]) {
        self.0.derivative(t, x, u, dxdt)
    }
}

impl Observation for PointOnly {
    fn measurement_dim(&self) -> usize {
        2
    }
    fn observe(&self, t: f64, x: &[f64], u: &[f64], z: &mut [f64]) {
        self.0.observe(t, x, u, z)
    }
}

#[test]
fn the_default_block_methods_equal_the_point_methods_bit_for_bit() {
    let model = PointOnly(Oscillator2DofLoad::new(Oscillator2Dof::damping_nonlinear()));
    let mut scratch = vec![0.0; 12];
    let x = block(6, 99);
    let mut d = vec![[0.0; BLOCK_POINTS]; 6];
    model.derivative_block(0.0, &x, &[], &mut d, &mut scratch);
    for p in 0..BLOCK_POINTS {
        let mut d1 = vec![0.0; 6];
        model.derivative(0.0, &point(&x, p), &[], &mut d1);
        assert_eq!(point(&d, p), d1, "point {p}");
    }
    assert_block_equals_pointwise(Discretized::rk4(model, 2), "S1 model through the defaults");
}
