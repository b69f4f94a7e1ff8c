//! Agreement properties: on a linear-Gaussian model every filter *is* the
//! Kalman filter; on a nonlinear model the cubature filters agree with each
//! other as far as exact arithmetic says they must.

mod common;

use common::*;
use estimator::models::LinearGaussian;
use estimator::{
    CubatureKalman, ExtendedKalman, FilterKind, Gaussian, Noise, SquareRootCubature, StateEstimator, SvdCubature,
    UnscentedKalman, UnscentedParams,
};
use nalgebra::{DMatrix, DVector};

const STEPS: usize = 1000;

fn filters_on(model: &LinearGaussian, noise: &Noise, prior: &Gaussian) -> Vec<(String, Box<dyn StateEstimator>)> {
    let mut v: Vec<(String, Box<dyn StateEstimator>)> = vec![
        ("CKF".into(), Box::new(CubatureKalman::cubature(model.clone(), noise.clone(), prior).unwrap())),
        ("SRCKF".into(), Box::new(SquareRootCubature::new(model.clone(), noise.clone(), prior).unwrap())),
        ("SVD-CKF".into(), Box::new(SvdCubature::svd_cubature(model.clone(), noise.clone(), prior).unwrap())),
        ("EKF".into(), Box::new(ExtendedKalman::new(model.clone(), noise.clone(), prior).unwrap())),
    ];
    for (alpha, beta, kappa) in [(1.0, 0.0, 0.0), (1.0, 2.0, 0.0), (0.5, 2.0, 0.0), (0.1, 2.0, 1.0), (1e-3, 2.0, 0.0)] {
        let params = UnscentedParams { alpha, beta, kappa };
        let ukf = UnscentedKalman::unscented(model.clone(), noise.clone(), prior, params).unwrap();
        v.push((format!("UKF(α={alpha}, β={beta}, κ={kappa})"), Box::new(ukf)));
    }
    v
}

/// Runs a filter over a case, returning its means and covariances after every update.
fn run(
    filter: &mut dyn StateEstimator,
    inputs: &[Vec<f64>],
    zs: &[Vec<f64>],
) -> (Vec<DVector<f64>>, Vec<DMatrix<f64>>) {
    let (mut xs, mut ps) = (Vec::new(), Vec::new());
    for (u, z) in inputs.iter().zip(zs) {
        filter.predict(u, 0.01).unwrap();
        filter.update(z).unwrap();
        xs.push(filter.mean().clone());
        ps.push(filter.covariance());
    }
    (xs, ps)
}

fn textbook(case: &LinearCase, zs: &[Vec<f64>]) -> (Vec<DVector<f64>>, Vec<DMatrix<f64>>) {
    let mut kf = TextbookKalman { x: case.prior.mean.clone(), p: case.prior.covariance.clone() };
    let (mut xs, mut ps) = (Vec::new(), Vec::new());
    for (u, z) in case.inputs.iter().zip(zs) {
        kf.predict(&case.model, &case.q, u);
        kf.update(&case.model, &case.r, z);
        xs.push(kf.x.clone());
        ps.push(kf.p.clone());
    }
    (xs, ps)
}

fn assert_all_equal_the_kalman_filter(case: &LinearCase, zs: &[Vec<f64>]) {
    let noise = Noise::new(case.q.clone(), case.r.clone()).unwrap();
    let (kx, kp) = textbook(case, zs);
    for (name, mut filter) in filters_on(&case.model, &noise, &case.prior) {
        let (xs, ps) = run(filter.as_mut(), &case.inputs, zs);
        let (gx, gp) = (relative_gap(&xs, &kx), relative_gap_m(&ps, &kp));
        assert!(
            gx < 1e-9 && gp < 1e-9,
            "{name}: mean gap {gx:e}, covariance gap {gp:e} (relative, max over {STEPS} steps)"
        );
    }
}

#[test]
fn every_filter_equals_the_textbook_kalman_filter_on_a_linear_gaussian_model() {
    let case = linear_case(STEPS, 11);
    assert_all_equal_the_kalman_filter(&case, &case.measurements);
}

#[test]
fn missing_rows_are_left_out_exactly_as_a_kalman_filter_on_the_remaining_rows() {
    let case = linear_case(STEPS, 12);
    // Row 1 missing every third sample, everything missing every seventh.
    let zs: Vec<Vec<f64>> = case
        .measurements
        .iter()
        .enumerate()
        .map(|(k, z)| {
            let mut z = z.clone();
            if k % 3 == 0 {
                z[1] = f64::NAN;
            }
            if k % 7 == 0 {
                z.fill(f64::NAN);
            }
            z
        })
        .collect();
    assert_all_equal_the_kalman_filter(&case, &zs);
}

fn s1_run(filter: &mut dyn StateEstimator, zs: &[Vec<f64>]) -> (Vec<DVector<f64>>, Vec<DMatrix<f64>>) {
    let inputs = vec![vec![]; zs.len()];
    let (mut xs, mut ps) = (Vec::new(), Vec::new());
    for (u, z) in inputs.iter().zip(zs) {
        filter.predict(u, 0.005).unwrap();
        filter.update(z).unwrap();
        xs.push(filter.mean().clone());
        ps.push(filter.covariance());
    }
    (xs, ps)
}

#[test]
fn ckf_srckf_and_ukf_alpha1_beta0_kappa0_agree_on_the_nonlinear_s1_model() {
    let (zs, _) = s1_measurements(STEPS, 0.005, 1.0, 0.05, 3);
    let ckf = CubatureKalman::cubature(s1_model(), s1_noise(), &s1_prior()).unwrap();
    let (cx, cp) = s1_run(&mut { ckf }, &zs);
    let srckf = SquareRootCubature::new(s1_model(), s1_noise(), &s1_prior()).unwrap();
    let (sx, sp) = s1_run(&mut { srckf }, &zs);
    let cubature_ukf = UnscentedKalman::unscented(
        s1_model(),
        s1_noise(),
        &s1_prior(),
        UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 },
    )
    .unwrap();
    let (ux, up) = s1_run(&mut { cubature_ukf }, &zs);
    let (gx, gp) = (relative_gap(&sx, &cx), relative_gap_m(&sp, &cp));
    assert!(gx < 1e-8 && gp < 1e-8, "SRCKF vs CKF: mean {gx:e}, covariance {gp:e}");
    let (gx, gp) = (relative_gap(&ux, &cx), relative_gap_m(&up, &cp));
    assert!(gx < 1e-12 && gp < 1e-12, "UKF(1,0,0) vs CKF: mean {gx:e}, covariance {gp:e}");
}

/// The SVD-CKF spreads its points with `U·√Σ·Uᵀ`, the CKF with the Cholesky
/// factor `L`: the two point sets are rotations of each other, so the filters
/// are equal in exact arithmetic exactly where the cubature rule is exact.
/// The S1 spring law is piecewise linear: while every point stays on its first
/// piece (|z₁| < δ₁ = 0.1 m, a small load) the rule is exact and the two
/// filters must agree to rounding.
#[test]
fn svd_ckf_equals_the_ckf_while_the_s1_model_stays_on_one_linear_piece() {
    let (zs, _) = s1_measurements(STEPS, 0.005, 0.3, 0.05, 4);
    let (cx, cp) = s1_run(&mut CubatureKalman::cubature(s1_model(), s1_noise(), &s1_prior()).unwrap(), &zs);
    let (vx, vp) = s1_run(&mut SvdCubature::svd_cubature(s1_model(), s1_noise(), &s1_prior()).unwrap(), &zs);
    let (gx, gp) = (relative_gap(&vx, &cx), relative_gap_m(&vp, &cp));
    assert!(gx < 1e-8 && gp < 1e-8, "SVD-CKF vs CKF: mean {gx:e}, covariance {gp:e}");
    assert!(cx.iter().all(|x| x[0].abs() < 0.08), "the test case must stay on the first piece of the spring law");
}

/// Across the breakpoints the rule is not exact and the rotated point sets
/// see the kinks differently: the positions, weakly observable from
/// accelerations, drift apart by several σ, and which filter tracks the load
/// better in one run is chance (over 24 seeds either does better in some).
/// What must hold is that both identify the load, and equally well on
/// average: each run's RMSE under 10 % of the load's amplitude, the mean RMSEs
/// within a quarter of each other (measured: at most 8 %, the CKF's on seed 4;
/// the SVD-CKF's mean 0.88 of the CKF's).
#[test]
fn svd_ckf_identifies_the_load_as_well_as_the_ckf_across_the_breakpoints() {
    let seeds = 1..=24;
    let (mut ckf, mut svd) = (Vec::new(), Vec::new());
    for seed in seeds.clone() {
        let (zs, loads) = s1_measurements(STEPS, 0.005, 2.0, 0.05, seed);
        let (cx, _) = s1_run(&mut CubatureKalman::cubature(s1_model(), s1_noise(), &s1_prior()).unwrap(), &zs);
        let (vx, _) = s1_run(&mut SvdCubature::svd_cubature(s1_model(), s1_noise(), &s1_prior()).unwrap(), &zs);
        assert!(cx.iter().any(|x| x[0].abs() > 0.1), "seed {seed}: the test case must cross the first breakpoint");
        let rmse = |xs: &[DVector<f64>]| {
            let squares = xs.iter().zip(&loads).skip(200).map(|(x, f)| (x[2] - f).powi(2));
            (squares.sum::<f64>() / (STEPS - 200) as f64).sqrt()
        };
        let amplitude = loads.iter().fold(0.0_f64, |m, f| m.max(f.abs()));
        let (rc, rv) = (rmse(&cx), rmse(&vx));
        assert!(
            rc < 0.1 * amplitude && rv < 0.1 * amplitude,
            "seed {seed}: load RMSE CKF {rc}, SVD-CKF {rv} (amplitude {amplitude})"
        );
        ckf.push(rc);
        svd.push(rv);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let ratio = mean(&svd) / mean(&ckf);
    assert!((0.8..1.25).contains(&ratio), "mean load RMSE over seeds {seeds:?}: SVD-CKF / CKF = {ratio}");
}

#[test]
fn filters_report_their_kind() {
    let case = linear_case(1, 1);
    let noise = Noise::new(case.q.clone(), case.r.clone()).unwrap();
    let kinds: Vec<FilterKind> = filters_on(&case.model, &noise, &case.prior).iter().map(|(_, f)| f.kind()).collect();
    assert_eq!(
        &kinds[..5],
        &[FilterKind::Ckf, FilterKind::SrCkf, FilterKind::SvdCkf, FilterKind::Ekf, FilterKind::Ukf]
    );
}

/// The same properties on the portable kernels, what a CPU without AVX2 and
/// FMA runs (there, and under `KALFMU_PORTABLE=1`, the tests above run them
/// already; `portable.rs` compares the two paths with each other).
mod on_the_portable_kernels {
    use estimator::with_portable_kernels;

    #[test]
    fn every_filter_equals_the_textbook_kalman_filter_on_a_linear_gaussian_model() {
        with_portable_kernels(super::every_filter_equals_the_textbook_kalman_filter_on_a_linear_gaussian_model);
    }

    #[test]
    fn missing_rows_are_left_out_exactly_as_a_kalman_filter_on_the_remaining_rows() {
        with_portable_kernels(super::missing_rows_are_left_out_exactly_as_a_kalman_filter_on_the_remaining_rows);
    }

    #[test]
    fn ckf_srckf_and_ukf_alpha1_beta0_kappa0_agree_on_the_nonlinear_s1_model() {
        with_portable_kernels(super::ckf_srckf_and_ukf_alpha1_beta0_kappa0_agree_on_the_nonlinear_s1_model);
    }

    #[test]
    fn svd_ckf_equals_the_ckf_while_the_s1_model_stays_on_one_linear_piece() {
        with_portable_kernels(super::svd_ckf_equals_the_ckf_while_the_s1_model_stays_on_one_linear_piece);
    }

    #[test]
    fn svd_ckf_identifies_the_load_as_well_as_the_ckf_across_the_breakpoints() {
        with_portable_kernels(super::svd_ckf_identifies_the_load_as_well_as_the_ckf_across_the_breakpoints);
    }
}
