//! The Sage–Husa estimate of `R` where `R` is identifiable: a linear model
//! whose innovations are not dominated by the state's spread. Told 10 times
//! too small or too large, it learns the true variances, and the filter
//! then estimates as well as one told the truth.

mod common;

use common::*;
use estimator::math;
use estimator::{build_filter, FilterKind, Noise, SageHusa, UnscentedParams};
use nalgebra::{DMatrix, DVector};

#[test]
fn a_wrong_r_is_learnt_and_the_estimates_recover_their_accuracy() {
    let case = linear_case(1, 21);
    let true_r = [0.1, 0.2, 0.05];
    let r = DMatrix::from_diagonal(&DVector::from_column_slice(&true_r));
    let mut rng = rng(22);
    let mut x = DVector::from_column_slice(&[0.0, 0.0, 1.0, 1.0]);
    let (mut states, mut zs, mut us) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..20_000 {
        let u = vec![math::sin(0.05 * k as f64), math::cos(0.013 * k as f64)];
        x = case.model.a() * &x + case.model.b() * DVector::from_column_slice(&u) + correlated(&mut rng, &case.q);
        zs.push((case.model.h() * &x + correlated(&mut rng, &r)).iter().copied().collect::<Vec<f64>>());
        states.push(x.clone());
        us.push(u);
    }
    let run = |scale: f64, learn: bool| -> (f64, Vec<f64>) {
        let told: Vec<f64> = true_r.iter().map(|v| v * scale).collect();
        let noise = Noise::new(case.q.clone(), DMatrix::from_diagonal(&DVector::from_column_slice(&told))).unwrap();
        let params = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
        let mut f = build_filter(FilterKind::SrCkf, case.model.clone(), noise, &case.prior, params).unwrap();
        let mut sage_husa = SageHusa::new(&told, 0.999, 1e-3).unwrap();
        let mut squared = 0.0;
        for (k, (u, z)) in us.iter().zip(&zs).enumerate() {
            f.predict(u, 0.01).unwrap();
            f.update(z).unwrap();
            if learn {
                let v = sage_husa.learn(f.innovation());
                f.set_measurement_variances(v).unwrap();
            }
            if k >= 10_000 {
                squared += (f.mean() - &states[k]).norm_squared();
            }
        }
        ((squared / 10_000.0).sqrt(), sage_husa.variances().to_vec())
    };
    let (right, _) = run(1.0, false);
    for scale in [0.1, 10.0] {
        let (wrong, _) = run(scale, false);
        let (learnt, variances) = run(scale, true);
        for (v, t) in variances.iter().zip(&true_r) {
            assert!((v / t - 1.0).abs() < 0.15, "R × {scale}: learnt {variances:?}, true {true_r:?}");
        }
        assert!(
            learnt < 1.02 * right && wrong > 1.05 * right,
            "R × {scale}: {learnt} (told wrong {wrong}, right {right})"
        );
    }
}

#[test]
fn settings_out_of_range_are_refused() {
    assert!(SageHusa::new(&[1.0], 1.0, 1e-3).is_err());
    assert!(SageHusa::new(&[1.0], 0.99, 0.0).is_err());
    assert!(SageHusa::new(&[0.0], 0.99, 1e-3).is_err());
    let full = Noise::new(DMatrix::identity(1, 1), DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.5, 1.0])).unwrap();
    assert!(full.clone().set_r_diagonal(&[1.0, 1.0]).is_err(), "a full R takes no variances in place");
}
