//! The batched model calls give the point-by-point numbers bit for bit, so a
//! filter's result does not depend on whether a model overrides them.

use estimator::models::{
    Oscillator2Dof, Oscillator2DofLoad, RollVehicle, VerticalVehicle, WheelRailRoll, WheelRailVertical,
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

fn assert_block_equals_pointwise<M: Process + Observation>(mut model: M, what: &str) {
    let (n, m) = (model.state_dim(), model.measurement_dim());
    let mut scratch = vec![0.0; 2 * n + m];
    for seed in 0..20 {
        let x = block(n, seed);
        let (mut x_next, mut z) = (vec![[0.0; BLOCK_POINTS]; n], vec![[0.0; BLOCK_POINTS]; m]);
        model.transition_block(0.3, 0.005, &x, &[], &mut x_next, &mut scratch);
        model.observe_block(0.3, &x, &[], &mut z, &mut scratch);
        for p in 0..BLOCK_POINTS {
            let (mut x1, mut z1) = (vec![0.0; n], vec![0.0; m]);
            model.transition(0.3, 0.005, &point(&x, p), &[], &mut x1);
            model.observe(0.3, &point(&x, p), &[], &mut z1);
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
