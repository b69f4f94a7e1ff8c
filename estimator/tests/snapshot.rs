//! A snapshot restores a belief exactly: a fresh filter restored from it
//! continues bit-identically (what FMU state save/restore relies on).

mod common;

use common::*;
use estimator::{build_filter, FilterError, FilterKind, StateEstimator, UnscentedParams};

fn fresh(kind: FilterKind) -> Box<dyn StateEstimator> {
    build_filter(kind, s1_model(), s1_noise(), &s1_prior(), UnscentedParams { alpha: 0.5, beta: 2.0, kappa: 0.0 })
        .unwrap()
}

#[test]
fn a_restored_filter_continues_bit_identically() {
    let (zs, _) = s1_measurements(300, 0.005, 1.0, 0.05, 21);
    for kind in FilterKind::ALL {
        let mut original = fresh(kind);
        for z in &zs[..150] {
            original.predict(&[], 0.005).unwrap();
            original.update(z).unwrap();
        }
        let saved = original.snapshot();
        let mut restored = fresh(kind);
        restored.restore(&saved).unwrap();
        assert_eq!(restored.time(), original.time());
        for z in &zs[150..] {
            for f in [&mut original, &mut restored] {
                f.predict(&[], 0.005).unwrap();
                f.update(z).unwrap();
            }
            assert_eq!(restored.mean(), original.mean(), "{kind}");
            assert_eq!(restored.covariance(), original.covariance(), "{kind}");
        }
    }
}

#[test]
fn a_snapshot_of_another_kind_or_size_is_refused() {
    let saved = fresh(FilterKind::Ckf).snapshot();
    let err = fresh(FilterKind::SrCkf).restore(&saved).unwrap_err();
    assert_eq!(err, FilterError::InvalidSetting("snapshot of a CKF cannot restore a SRCKF".into()));
    let mut short = saved.clone();
    short.mean.pop();
    assert!(matches!(fresh(FilterKind::Ckf).restore(&short), Err(FilterError::Dimension { .. })));
    let mut nan = saved;
    nan.covariance[3] = f64::NAN;
    assert!(fresh(FilterKind::Ckf).restore(&nan).is_err());
}
