//! Specification: a scale on the process noise is put on the states named and on those
//! their noise couples to, `Q = D·Q₀·D` with `D = √s` there and 1 elsewhere, exactly
//! (from `Q₀`, whatever scales came before) and with a root that stays `D·S_Q₀`, lower
//! triangular; with no states named it is on all of `Q`.

use estimator::Noise;
use nalgebra::DMatrix;

/// A load model's `Q₀`: two positions with their own noise, the load (state 2) and its
/// rate (state 3) driven by one white noise, so coupled.
fn q0() -> DMatrix<f64> {
    let mut q = DMatrix::zeros(4, 4);
    (q[(0, 0)], q[(1, 1)]) = (1e-6, 4e-6);
    (q[(2, 2)], q[(2, 3)], q[(3, 2)], q[(3, 3)]) = (1.0 / 3.0, 0.5, 0.5, 1.0);
    q
}

fn noise() -> Noise {
    Noise::new(q0(), DMatrix::identity(1, 1)).unwrap()
}

#[test]
fn the_load_and_the_rate_its_noise_drives_take_the_scale_and_the_positions_keep_theirs() {
    let mut n = noise();
    let load_only = [false, false, true, false];
    for s in [0.01, 7.0, 0.3] {
        n.set_q_scale(s, &load_only).unwrap();
        let d = [1.0, 1.0, s.sqrt(), s.sqrt()];
        for i in 0..4 {
            for j in 0..4 {
                let expected = d[i] * q0()[(i, j)] * d[j];
                assert!((n.q()[(i, j)] - expected).abs() <= 1e-15 * expected.abs(), "s = {s}: Q[{i},{j}]");
            }
        }
        let root = n.q_sqrt();
        assert!((root * root.transpose() - n.q()).abs().max() <= 1e-14, "s = {s}: S_Q·S_Qᵀ = Q");
        assert!((0..4).all(|i| (i + 1..4).all(|j| root[(i, j)] == 0.0)), "s = {s}: the root stays lower triangular");
        assert_eq!(n.q_scale(), s);
    }
}

#[test]
fn without_named_states_the_scale_is_on_all_of_q_and_scale_one_gives_q_back_bit_for_bit() {
    let mut n = noise();
    n.set_q_scale(5.0, &[]).unwrap();
    assert!((n.q() - q0() * 5.0).abs().max() <= 1e-15);
    n.set_q_scale(1.0, &[false, false, true, false]).unwrap();
    assert_eq!(n.q(), &q0());
}

#[test]
fn a_bad_scale_or_a_mask_of_the_wrong_length_changes_nothing() {
    let mut n = noise();
    n.set_q_scale(2.0, &[true, false, false, false]).unwrap();
    let before = n.q().clone();
    for s in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(n.set_q_scale(s, &[]).is_err(), "scale {s}");
    }
    assert!(n.set_q_scale(3.0, &[true]).is_err());
    assert_eq!(n.q(), &before);
}
