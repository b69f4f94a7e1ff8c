//! S3's 42-state model (`WheelRailRoll`): at rest it rests, it is symmetric left to right,
//! a side-to-side force difference rolls the wheelset by `a₀`, and its observability is what
//! the statics say: with the forces as random walks and accelerometers only, three
//! self-balancing patterns of `F_L − F_R` are unseen (beside the five motions no spring
//! resists without a track); deflection transducers, or forces that return to the static
//! load, leave only those motions unseen, and the sums `F_L + F_R` are seen in every set-up.

use estimator::models::{RollVehicle, WheelRailRoll};
use estimator::{Observation, VectorField};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const N: usize = 42;
const M: usize = 28;

fn model(force_return_rate: f64) -> WheelRailRoll {
    WheelRailRoll { vehicle: RollVehicle::zhai_passenger(), force_return_rate }
}

/// The state at rest: no deviation, every wheel carrying the static load.
fn rest(m: &WheelRailRoll) -> Vec<f64> {
    let mut x = vec![0.0; N];
    x[WheelRailRoll::FORCES..].fill(m.vehicle.static_wheel_load);
    x
}

fn derivative(m: &WheelRailRoll, x: &[f64]) -> Vec<f64> {
    let mut d = vec![0.0; N];
    m.derivative(0.0, x, &[], &mut d);
    d
}

fn observe(m: &WheelRailRoll, x: &[f64]) -> Vec<f64> {
    let mut z = vec![0.0; M];
    m.observe(0.0, x, &[], &mut z);
    z
}

#[test]
fn at_rest_nothing_moves_and_nothing_is_measured() {
    for r in [0.0, 1.0] {
        let m = model(r);
        assert!(derivative(&m, &rest(&m)).iter().all(|&d| d == 0.0));
        assert!(observe(&m, &rest(&m)).iter().all(|&z| z == 0.0));
    }
}

/// The mirror image of a state: bounce and pitch kept, roll reversed, left and right
/// forces swapped.
fn mirrored_state(x: &[f64]) -> Vec<f64> {
    let mut y = x.to_vec();
    for (c, name) in WheelRailRoll::COORDINATE_NAMES.iter().enumerate() {
        if name.starts_with("phi") {
            y[c] = -x[c];
            y[17 + c] = -x[17 + c];
        }
    }
    for j in 0..4 {
        y[WheelRailRoll::FORCES + 2 * j] = x[WheelRailRoll::FORCES + 2 * j + 1];
        y[WheelRailRoll::FORCES + 2 * j + 1] = x[WheelRailRoll::FORCES + 2 * j];
    }
    y
}

/// The row of the measurement on the other side: `L` ↔ `R` (the car body's `FL` ↔ `FR`).
fn mirrored_row(row: usize) -> usize {
    let name = WheelRailRoll::MEASUREMENT_NAMES[row];
    let other = if let Some(corner) = name.strip_prefix("a_cb_") {
        // Front or rear, then the side.
        format!("a_cb_{}{}", &corner[..1], if corner.ends_with('L') { 'R' } else { 'L' })
    } else if name.contains("_L") {
        name.replace("_L", "_R")
    } else {
        name.replace("_R", "_L")
    };
    WheelRailRoll::MEASUREMENT_NAMES.iter().position(|&n| n == other).expect("every sensor has its mirror")
}

#[test]
fn the_mirror_image_of_a_state_is_measured_as_the_mirror_image() {
    let m = model(0.5);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let mut x = rest(&m);
        for v in &mut x[..34] {
            *v = rng.random_range(-0.02..0.02);
        }
        for f in &mut x[WheelRailRoll::FORCES..] {
            *f += rng.random_range(-5e3..5e3);
        }
        let (z, z_mirror) = (observe(&m, &x), observe(&m, &mirrored_state(&x)));
        for row in 0..M {
            let (a, b) = (z[row], z_mirror[mirrored_row(row)]);
            assert!(
                (a - b).abs() <= 1e-9 * (1.0 + a.abs()),
                "{}: {a} against {b}",
                WheelRailRoll::MEASUREMENT_NAMES[row]
            );
        }
    }
}

#[test]
fn a_side_to_side_force_difference_rolls_its_wheelset_and_nothing_else_at_once() {
    let m = model(0.0);
    let v = m.vehicle;
    let mut x = rest(&m);
    let delta = 1e3;
    x[WheelRailRoll::FORCES + 2] += delta; // F_NL2
    x[WheelRailRoll::FORCES + 3] -= delta; // F_NR2
    let d = derivative(&m, &x);
    let phi_w2 = WheelRailRoll::COORDINATE_NAMES.iter().position(|&n| n == "phi_w2").unwrap();
    for (c, &a) in d[17..34].iter().enumerate() {
        let expected = if c == phi_w2 { 2.0 * v.contact_half_span * delta / v.wheelset_roll_inertia } else { 0.0 };
        assert!((a - expected).abs() < 1e-12, "{}: {a}", WheelRailRoll::COORDINATE_NAMES[c]);
    }
    // Its axle boxes see it with opposite signs: ±d_w·φ̈.
    let z = observe(&m, &x);
    let (left, right) = (z[2], z[3]);
    assert!((left + right).abs() < 1e-12 && (left - v.primary_half_span * d[17 + phi_w2]).abs() < 1e-9);
}

/// Each state's scale for the linear analysis: m, rad, m/s, rad/s and 10 kN, so that the
/// singular values compare like with like.
fn scale(i: usize) -> f64 {
    match i {
        0..=16 => 1e-3,
        17..=33 => 1e-2,
        _ => 1e4,
    }
}

/// The model linearised at rest in scaled states: `A` (42×42) and `C` (the rows asked).
fn linearised(m: &WheelRailRoll, rows: &[usize]) -> (DMatrix<f64>, DMatrix<f64>) {
    let (mut a, mut c) = (DMatrix::zeros(N, N), DMatrix::zeros(rows.len(), N));
    let x0 = rest(m);
    for i in 0..N {
        let h = 1e-6 * scale(i);
        let (mut up, mut down) = (x0.clone(), x0.clone());
        up[i] += h;
        down[i] -= h;
        let (du, dd) = (derivative(m, &up), derivative(m, &down));
        for k in 0..N {
            a[(k, i)] = (du[k] - dd[k]) / (2.0 * h) * scale(i) / scale(k);
        }
        let (zu, zd) = (observe(m, &up), observe(m, &down));
        for (r, &row) in rows.iter().enumerate() {
            c[(r, i)] = (zu[row] - zd[row]) / (2.0 * h) * scale(i);
        }
    }
    (a, c)
}

/// The states at rest that nothing measured ever tells from rest: the null space of
/// `[A; C]` (the Popov–Belevitch–Hautus test at the eigenvalue 0), as scaled state vectors.
fn unseen_resting_states(m: &WheelRailRoll, rows: &[usize]) -> Vec<DVector<f64>> {
    let (a, c) = linearised(m, rows);
    let mut stacked = DMatrix::zeros(N + rows.len(), N);
    stacked.view_mut((0, 0), (N, N)).copy_from(&a);
    stacked.view_mut((N, 0), (rows.len(), N)).copy_from(&c);
    let svd = stacked.svd(false, true);
    let v_t = svd.v_t.expect("asked for");
    let largest = svd.singular_values.max();
    (0..N).filter(|&k| svd.singular_values[k] < 1e-9 * largest).map(|k| v_t.row(k).transpose()).collect()
}

/// The force combinations among the unseen resting states: an orthonormal basis of their
/// force parts (8 × k).
fn unseen_force_patterns(unseen: &[DVector<f64>]) -> DMatrix<f64> {
    let parts: Vec<_> = unseen.iter().map(|u| u.rows(WheelRailRoll::FORCES, 8).into_owned()).collect();
    if parts.is_empty() {
        return DMatrix::zeros(8, 0);
    }
    let svd = DMatrix::from_columns(&parts).svd(true, false);
    let u = svd.u.expect("asked for");
    let kept: Vec<_> = (0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] > 1e-6)
        .map(|k| u.column(k).into_owned())
        .collect();
    if kept.is_empty() {
        DMatrix::zeros(8, 0)
    } else {
        DMatrix::from_columns(&kept)
    }
}

/// The share of a force combination `w` (its squared norm) that lies in the unseen
/// patterns: 0 if every bit of it is seen, 1 if none.
fn unseen_share(patterns: &DMatrix<f64>, w: &[f64; 8]) -> f64 {
    let w = DVector::from_row_slice(w).normalize();
    (patterns.transpose() * w).norm_squared()
}

fn accelerations() -> Vec<usize> {
    WheelRailRoll::ACCELERATIONS.collect()
}

fn every_sensor() -> Vec<usize> {
    (0..M).collect()
}

#[test]
fn random_walk_forces_seen_by_accelerometers_leave_three_side_to_side_patterns_unseen() {
    let unseen = unseen_resting_states(&model(0.0), &accelerations());
    // Five motions no spring resists in a model without track (the whole car's bounce,
    // pitch and roll, and each bogie's pitch with its wheelsets following) and three
    // patterns of forces the suspension balances.
    assert_eq!(unseen.len(), 8);
    let patterns = unseen_force_patterns(&unseen);
    assert_eq!(patterns.ncols(), 3);
    for j in 0..4 {
        let mut sum = [0.0; 8];
        sum[2 * j] = 1.0;
        sum[2 * j + 1] = 1.0;
        assert!(unseen_share(&patterns, &sum) < 1e-6, "the sum of wheelset {} is seen", j + 1);
        let mut difference = [0.0; 8];
        difference[2 * j] = 1.0;
        difference[2 * j + 1] = -1.0;
        let share = unseen_share(&patterns, &difference);
        // Of the four side-to-side differences only their sum (the car's roll moment, which
        // nothing balances) is pinned: three quarters of each is in the unseen patterns.
        assert!((share - 0.75).abs() < 1e-6, "L{0} − R{0}: {share}", j + 1);
    }
}

#[test]
fn deflection_transducers_or_returning_forces_leave_only_the_free_motions_unseen() {
    for (m, rows, what) in
        [(model(0.0), every_sensor(), "deflections"), (model(0.5), accelerations(), "return rate 0.5/s")]
    {
        let unseen = unseen_resting_states(&m, &rows);
        assert_eq!(unseen.len(), 5, "{what}");
        assert_eq!(unseen_force_patterns(&unseen).ncols(), 0, "{what}");
    }
}
