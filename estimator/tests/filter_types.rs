//! Each filter's type says what it builds: the CKF, the SVD-CKF and the UKF
//! are distinct types (not one sigma-point type under three names), and every
//! constructor builds the kind its type is named after.

mod common;

use std::any::TypeId;

use common::*;
use estimator::models::LinearGaussian;
use estimator::{
    build_filter, CubatureKalman, ExtendedKalman, FilterKind, Noise, SquareRootCubature, StateEstimator, SvdCubature,
    UnscentedKalman, UnscentedParams,
};

#[test]
fn the_cubature_svd_and_unscented_filters_are_distinct_types() {
    let ckf = TypeId::of::<CubatureKalman<LinearGaussian>>();
    let svd = TypeId::of::<SvdCubature<LinearGaussian>>();
    let ukf = TypeId::of::<UnscentedKalman<LinearGaussian>>();
    assert_ne!(ckf, ukf, "CKF and UKF");
    assert_ne!(ckf, svd, "CKF and SVD-CKF");
    assert_ne!(svd, ukf, "SVD-CKF and UKF");
}

#[test]
fn each_constructor_builds_the_kind_its_type_is_named_after() {
    let case = linear_case(1, 1);
    let noise = Noise::new(case.q.clone(), case.r.clone()).unwrap();
    let (model, prior) = (&case.model, &case.prior);
    // The UKF with the cubature rule's parameters has the CKF's points, and is still a UKF.
    let cubature_like = UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 };
    let built: [(FilterKind, &dyn StateEstimator); 5] = [
        (FilterKind::Ckf, &CubatureKalman::cubature(model.clone(), noise.clone(), prior).unwrap()),
        (FilterKind::SrCkf, &SquareRootCubature::new(model.clone(), noise.clone(), prior).unwrap()),
        (FilterKind::SvdCkf, &SvdCubature::svd_cubature(model.clone(), noise.clone(), prior).unwrap()),
        (FilterKind::Ukf, &UnscentedKalman::unscented(model.clone(), noise.clone(), prior, cubature_like).unwrap()),
        (FilterKind::Ekf, &ExtendedKalman::new(model.clone(), noise.clone(), prior).unwrap()),
    ];
    for (kind, filter) in built {
        assert_eq!(filter.kind(), kind);
    }
    for kind in FilterKind::ALL {
        let filter = build_filter(kind, model.clone(), noise.clone(), prior, cubature_like).unwrap();
        assert_eq!(filter.kind(), kind, "build_filter({kind})");
    }
}
