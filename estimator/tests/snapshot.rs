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

#[test]
fn a_held_input_is_the_one_the_update_sees_and_a_non_finite_one_changes_nothing() {
    use estimator::models::{Airframe, Missile6Dof};
    use estimator::{Discretized, Gaussian, Noise};
    // The missile's overloads depend on the deflections: the update must see the input
    // held last, as if the prediction had been made with it.
    let model = || Discretized::rk4(Missile6Dof { airframe: Airframe::tactical_missile() }, 1);
    let mut mean = vec![1000.0, -20.0, 10.0, 0.2, 0.05, 0.05, 10_000.0, 0.01, 0.02, 0.03];
    mean.extend([-0.23, 0.17, 0.31, 0.31, -0.09, 9.26, -0.86, 0.53, -8.79, 0.22]);
    let mut variances = vec![1.0, 1.0, 1.0, 1e-4, 1e-4, 1e-4, 1.0, 1e-4, 1e-4, 1e-4];
    variances.extend([1e-4; 10]);
    let prior = Gaussian::diagonal(&mean, &variances);
    let noise = Noise::diagonal(&[1e-6; 20], &[1e-6; 12]).unwrap();
    let z = [0.01, 0.02, 0.03, -6.0, 5.0, 19.0, 0.2, 0.05, 0.05, 10_000.0, 0.02, 0.01];
    let (old, new) = ([0.0, 0.01, -0.01], [0.02, -0.03, 0.01]);
    for kind in FilterKind::ALL {
        let build = || build_filter(kind, model(), noise.clone(), &prior, UnscentedParams::default()).unwrap();
        let (mut held, mut restored, mut stale) = (build(), build(), build());
        for f in [&mut held, &mut restored, &mut stale] {
            f.predict(&old, 0.005).unwrap();
        }
        held.hold_input(&new).unwrap();
        let mut snapshot = restored.snapshot();
        snapshot.input.copy_from_slice(&new);
        restored.restore(&snapshot).unwrap();
        let refused = held.hold_input(&[f64::NAN, 0.0, 0.0]);
        assert!(matches!(refused, Err(FilterError::NonFinite { .. })), "{kind}: {refused:?}");
        for f in [&mut held, &mut restored, &mut stale] {
            f.update(&z).unwrap();
        }
        assert_eq!(held.mean(), restored.mean(), "{kind}: the held input is the snapshot's, bit for bit");
        assert_ne!(held.mean(), stale.mean(), "{kind}: the update sees the held input, not the prediction's");
    }
}
