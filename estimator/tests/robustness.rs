//! Failure is a value: bad input and numerical breakdown give typed errors,
//! a failed step leaves the belief as it was, and the square-root and SVD
//! filters keep running where rounding breaks the Cholesky CKF.

mod common;

use estimator::models::LinearGaussian;
use estimator::{
    CubatureKalman, ExtendedKalman, FilterError, Gaussian, Noise, Observation, Process, SquareRootCubature, Stage,
    StateEstimator, SvdCubature,
};
use nalgebra::{DMatrix, DVector};

/// A triple integrator observed through `x₁` and `x₁ + x₂`, started from a
/// prior whose three states are 99.9 % correlated.
fn near_perfect_sensor_case(r: f64) -> (LinearGaussian, Noise, Gaussian) {
    let a = DMatrix::from_row_slice(3, 3, &[1.0, 0.01, 0.0, 0.0, 1.0, 0.01, 0.0, 0.0, 1.0]);
    let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 1.0, 1.0, 0.0]);
    let model = LinearGaussian::new(a, DMatrix::zeros(3, 0), h);
    let noise = Noise::diagonal(&[1e-12; 3], &[r, r]).unwrap();
    let p0 = (DMatrix::from_element(3, 3, 0.999) + DMatrix::identity(3, 3) * 0.001) * 1e4;
    (model, noise, Gaussian { mean: DVector::zeros(3), covariance: p0 })
}

/// Runs 500 steps on the true trajectory `x = (1, 2, 0.5)` integrated; returns
/// the step of the first error (and the error), or the final error in `x₃` over its σ.
fn run(filter: &mut dyn StateEstimator, r: f64) -> Result<f64, (usize, FilterError)> {
    let mut rng = common::rng(1);
    let mut x = [1.0, 2.0, 0.5];
    for k in 0..500 {
        x = [x[0] + 0.01 * x[1], x[1] + 0.01 * x[2], x[2]];
        let z = [x[0] + r.sqrt() * common::normal(&mut rng), x[0] + x[1] + r.sqrt() * common::normal(&mut rng)];
        filter.predict(&[], 0.01).map_err(|e| (k, e))?;
        filter.update(&z).map_err(|e| (k, e))?;
    }
    Ok((filter.mean()[2] - x[2]).abs() / filter.variance(2).sqrt())
}

fn square_root_and_svd_survive_where_the_ckf_fails(r: f64) {
    let (model, noise, prior) = near_perfect_sensor_case(r);
    let mut ckf = CubatureKalman::cubature(model.clone(), noise.clone(), &prior).unwrap();
    let (step, err) = run(&mut ckf, r).unwrap_err();
    assert!(step < 5, "CKF failed only at step {step}");
    assert_eq!(err, FilterError::NotPositiveDefinite { stage: Stage::Predict, matrix: "state covariance P" });
    let survivors: [Box<dyn StateEstimator>; 2] = [
        Box::new(SquareRootCubature::new(model.clone(), noise.clone(), &prior).unwrap()),
        Box::new(SvdCubature::svd_cubature(model, noise, &prior).unwrap()),
    ];
    for mut filter in survivors {
        let z_score =
            run(filter.as_mut(), r).unwrap_or_else(|(k, e)| panic!("{} failed at step {k}: {e}", filter.kind()));
        assert!(z_score < 4.0, "{}: final error is {z_score} σ", filter.kind());
        assert!(filter.variance(2).sqrt() < 1e-3, "{} did not converge", filter.kind());
    }
}

#[test]
fn srckf_and_svd_ckf_keep_running_with_a_near_perfect_sensor_where_the_ckf_fails() {
    square_root_and_svd_survive_where_the_ckf_fails(1e-14);
}

#[test]
fn srckf_and_svd_ckf_keep_running_with_a_zero_measurement_noise_where_the_ckf_fails() {
    // R = 0 is what study S5 prints for most of its channels.
    square_root_and_svd_survive_where_the_ckf_fails(0.0);
}

#[test]
fn a_failed_step_leaves_the_belief_unchanged_and_reset_recovers() {
    let (model, noise, prior) = near_perfect_sensor_case(1e-14);
    let mut ckf = CubatureKalman::cubature(model, noise, &prior).unwrap();
    let snapshot = |f: &CubatureKalman<LinearGaussian>| (f.mean().clone(), f.covariance(), f.time());
    let mut failed = None;
    for k in 0..10 {
        let before = snapshot(&ckf);
        if ckf.predict(&[], 0.01).is_err() {
            failed = Some(before);
            break;
        }
        let before = snapshot(&ckf);
        if ckf.update(&[0.01 * k as f64, 0.02 * k as f64]).is_err() {
            failed = Some(before);
            break;
        }
    }
    let (mean, cov, time) = failed.expect("expected the CKF to fail early");
    assert_eq!(ckf.time(), time);
    assert_eq!(ckf.mean(), &mean);
    assert_eq!(ckf.covariance(), cov);
    ckf.reset(0.0, &prior).unwrap();
    assert_eq!(ckf.time(), 0.0);
    assert_eq!(ckf.mean(), &prior.mean);
}

/// A model whose transition returns NaN beyond |x| > 10.
#[derive(Clone)]
struct Blows;
impl Process for Blows {
    fn state_dim(&self) -> usize {
        1
    }
    fn transition(&mut self, _t: f64, _dt: f64, x: &[f64], _u: &[f64], out: &mut [f64]) {
        out[0] = if x[0].abs() > 10.0 { f64::NAN } else { 2.0 * x[0] };
    }
}
impl Observation for Blows {
    fn measurement_dim(&self) -> usize {
        1
    }
    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        z[0] = x[0];
    }
}

#[test]
fn a_model_returning_nan_is_a_non_finite_error_not_a_nan_estimate() {
    let noise = Noise::diagonal(&[0.1], &[0.1]).unwrap();
    let prior = Gaussian::diagonal(&[1.0], &[1.0]);
    let filters: [Box<dyn StateEstimator>; 4] = [
        Box::new(CubatureKalman::cubature(Blows, noise.clone(), &prior).unwrap()),
        Box::new(SquareRootCubature::new(Blows, noise.clone(), &prior).unwrap()),
        Box::new(SvdCubature::svd_cubature(Blows, noise.clone(), &prior).unwrap()),
        Box::new(ExtendedKalman::new(Blows, noise, &prior).unwrap()),
    ];
    for mut f in filters {
        let err = (0..10).find_map(|_| f.predict(&[], 1.0).err()).expect("the state doubles past 10");
        assert!(matches!(err, FilterError::NonFinite { stage: Stage::Predict, .. }), "{}: {err}", f.kind());
        assert!(f.mean().iter().all(|v| v.is_finite()) && f.variance(0).is_finite(), "{}", f.kind());
    }
}

#[test]
fn wrong_sizes_and_bad_time_steps_are_refused_with_what_was_wrong() {
    let (model, noise, prior) = near_perfect_sensor_case(1e-2);
    let mut f = SquareRootCubature::new(model.clone(), noise.clone(), &prior).unwrap();
    assert_eq!(f.update(&[1.0]).unwrap_err(), FilterError::Dimension { what: "measurement z", expected: 2, got: 1 });
    assert_eq!(f.predict(&[1.0], 0.1).unwrap_err(), FilterError::Dimension { what: "input u", expected: 0, got: 1 });
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(f.predict(&[], dt).unwrap_err().to_string().contains("time step must be positive"), "dt = {dt}");
    }
    let bad_prior = Gaussian::diagonal(&[0.0; 2], &[1.0; 2]);
    let err = SquareRootCubature::new(model.clone(), noise, &bad_prior).unwrap_err();
    assert_eq!(err, FilterError::Dimension { what: "initial mean", expected: 3, got: 2 });
    let wrong_r = Noise::diagonal(&[1.0; 3], &[1.0]).unwrap();
    let err = CubatureKalman::cubature(model, wrong_r, &prior).unwrap_err();
    assert_eq!(err.to_string(), "measurement noise R has length 1, the model needs 2");
}

#[test]
fn a_fully_missing_measurement_is_a_prediction_only() {
    let (model, noise, prior) = near_perfect_sensor_case(1e-2);
    let mut f = SquareRootCubature::new(model, noise, &prior).unwrap();
    f.predict(&[], 0.01).unwrap();
    let (mean, cov) = (f.mean().clone(), f.covariance());
    let innovation = f.update(&[f64::NAN, f64::INFINITY]).unwrap();
    assert_eq!(innovation.rows_used(), 0);
    assert_eq!((innovation.nis(), innovation.log_likelihood()), (0.0, 0.0));
    assert!(innovation.residual().iter().all(|v| v.is_nan()));
    assert_eq!(f.mean(), &mean);
    assert_eq!(f.covariance(), cov);
}
