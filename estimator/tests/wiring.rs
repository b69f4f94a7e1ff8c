//! The wiring checks as a specification, on a linear-Gaussian oscillator
//! read by three redundant position sensors: the filters are exactly
//! consistent (the truth is the model) and each channel is contradicted by
//! the other two, as S4's telegrams are. The scores are standard normal on
//! healthy data and flag nothing; a flipped sign, a unit error and an offset
//! on one channel make it inconsistent, left out, with a fit that names the
//! mistake, and it is taken back after the mistake ends. Where the
//! checks only name (the default: the data cannot always say which channel
//! is wrong), the channel stays in the updates and the filter is
//! inconsistent while it disagrees.

mod common;

use common::*;
use estimator::models::LinearGaussian;
use estimator::{
    build_filter, FilterKind, Gaussian, Noise, RowOutcome, StateEstimator, Supervisor, SupervisorSettings,
};
use nalgebra::{DMatrix, DVector};

const STEPS: usize = 6000;
const FROM: usize = 2000;
const TO: usize = 4000;

/// A lightly driven oscillator of unit amplitude (period 1.26 s at 100 Hz),
/// its position read by three sensors with 0.01 of noise: the model, `Q`,
/// `R` and the measurements.
fn oscillator() -> (LinearGaussian, DMatrix<f64>, DMatrix<f64>, Vec<Vec<f64>>) {
    let (c, s) = (estimator::math::cos(0.05), estimator::math::sin(0.05));
    let a = DMatrix::from_row_slice(2, 2, &[c, s, -s, c]);
    let model =
        LinearGaussian::new(a, DMatrix::zeros(2, 1), DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 1.0, 0.0, 1.0, 0.0]));
    let q = DMatrix::identity(2, 2) * 1e-6;
    let r = DMatrix::identity(3, 3) * 1e-4;
    let mut rng = rng(5);
    let mut x = DVector::from_column_slice(&[1.0, 0.0]);
    let zs = (0..STEPS)
        .map(|_| {
            x = model.a() * &x + correlated(&mut rng, &q);
            (0..3).map(|_| x[0] + 0.01 * normal(&mut rng)).collect()
        })
        .collect();
    (model, q, r, zs)
}

/// The checks with the worst channel left out: each channel here is
/// contradicted by the other two.
fn checked() -> SupervisorSettings {
    SupervisorSettings { wiring_sigmas: 8.0, wiring_leaves_out: true, ..SupervisorSettings::default() }
}

/// Runs `kind` over the linear case with `fault` applied to channel 0 from
/// `FROM` to `TO`; returns per sample the rows' outcomes, and the supervisor.
fn run(kind: FilterKind, fault: impl Fn(f64) -> f64, each: impl FnMut(usize, &Supervisor)) -> Vec<Vec<RowOutcome>> {
    run_with(checked(), kind, fault, each)
}

fn run_with(
    settings: SupervisorSettings,
    kind: FilterKind,
    fault: impl Fn(f64) -> f64,
    each: impl FnMut(usize, &Supervisor),
) -> Vec<Vec<RowOutcome>> {
    let (model, q, r, zs) = oscillator();
    let noise = Noise::new(q, r).unwrap();
    let prior = Gaussian { mean: DVector::zeros(2), covariance: DMatrix::identity(2, 2) };
    let mut f: Box<dyn StateEstimator> = build_filter(kind, model, noise, &prior, Default::default()).unwrap();
    let mut s = Supervisor::new(settings, 3).unwrap();
    let mut each = each;
    let mut rows = Vec::with_capacity(STEPS);
    let u = [0.0];
    for (k, z) in zs.iter().enumerate() {
        let mut z = z.clone();
        if (FROM..TO).contains(&k) {
            z[0] = fault(z[0]);
        }
        f.predict(&u, 0.01).unwrap();
        rows.push(s.gate(f.as_mut(), &z).unwrap().rows.clone());
        s.commit(|_| {});
        each(k, &s);
    }
    rows
}

#[test]
fn on_healthy_data_the_scores_are_standard_normal_and_nothing_is_flagged() {
    for kind in FilterKind::ALL {
        let mut scores = Vec::new();
        let rows = run(
            kind,
            |z| z,
            |k, s| {
                // One score per channel every 200 samples (a window): nearly independent.
                if k >= 400 && k % 200 == 0 {
                    for c in s.channels() {
                        scores.extend([c.bias_score(), c.scale_score()]);
                    }
                }
            },
        );
        assert!(rows.iter().flatten().all(|r| *r != RowOutcome::Inconsistent), "{kind}: a false alarm");
        let n = scores.len() as f64;
        let mean = scores.iter().sum::<f64>() / n;
        let std = (scores.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!(mean.abs() < 0.5 && (0.7..1.4).contains(&std), "{kind}: scores {mean} ± {std} over {n}");
    }
}

#[test]
fn a_flipped_channel_is_left_out_within_a_window_named_and_taken_back_after() {
    for kind in FilterKind::ALL {
        let mut fit_at_flag = None;
        let rows = run(
            kind,
            |z| -z,
            |k, s| {
                if s.channels()[0].inconsistent && fit_at_flag.is_none() {
                    fit_at_flag = Some((k, s.channels()[0].wiring_fit()));
                }
            },
        );
        let (at, (scale, _)) = fit_at_flag.unwrap_or_else(|| panic!("{kind}: the flip is never flagged"));
        assert!((FROM..FROM + 200).contains(&at), "{kind}: flagged at {at}");
        assert!((scale + 1.0).abs() < 0.5, "{kind}: scale {scale} at the flag");
        assert!(rows[at + 1..TO].iter().all(|r| r[0] == RowOutcome::Inconsistent), "{kind}: left out until the end");
        assert!(rows.iter().all(|r| r[1..].iter().all(|o| *o != RowOutcome::Inconsistent)), "{kind}: another blamed");
        assert_eq!(rows[STEPS - 1][0], RowOutcome::Used, "{kind}: taken back after the flip");
    }
}

#[test]
fn a_unit_error_or_an_offset_is_flagged_with_a_fit_that_names_it() {
    for (fault, expect) in [(9.81, "scale"), (1.0 / 9.81, "scale"), (0.0, "offset")] {
        let mut fit = None;
        run(
            FilterKind::SrCkf,
            |z| if fault == 0.0 { z + 5.0 } else { z * fault },
            |_, s| {
                if s.channels()[0].inconsistent && fit.is_none() {
                    fit = Some(s.channels()[0].wiring_fit());
                }
            },
        );
        let (scale, offset) = fit.unwrap_or_else(|| panic!("{fault}: never flagged"));
        match expect {
            // Rough (the re-acquisition the gate's rejections trigger has
            // dragged the state a little by then), but on the side of its
            // factor that names the cause: above 4, below 1/4.
            "scale" => assert!(if fault > 1.0 { scale > 4.0 } else { scale < 0.25 }, "×{fault}: scale {scale}"),
            _ => assert!((offset - 5.0).abs() < 2.5, "offset 5: fit {offset}"),
        }
    }
}

#[test]
fn where_the_checks_only_name_a_flipped_channel_stays_used_and_the_filter_is_unhealthy_while_it_disagrees() {
    let named = SupervisorSettings { wiring_sigmas: 8.0, ..SupervisorSettings::default() };
    assert!(!named.wiring_leaves_out, "naming is the default");
    for kind in FilterKind::ALL {
        let (mut named_at, mut healthy) = (None, Vec::with_capacity(STEPS));
        let rows = run_with(
            named,
            kind,
            |z| -z,
            |k, s| {
                if s.channels()[0].inconsistent && named_at.is_none() {
                    named_at = Some(k);
                }
                healthy.push(s.healthy());
            },
        );
        let at = named_at.unwrap_or_else(|| panic!("{kind}: the flip is never named"));
        assert!((FROM..FROM + 200).contains(&at), "{kind}: named at {at}");
        assert!(
            rows.iter().flatten().all(|r| *r != RowOutcome::Inconsistent),
            "{kind}: a row left out as inconsistent"
        );
        assert!(healthy[..FROM].iter().all(|&h| h), "{kind}: unhealthy before the flip");
        assert!(!healthy[at], "{kind}: healthy while named");
        assert!(healthy[STEPS - 1], "{kind}: not healthy again after the flip");
    }
}

#[test]
fn a_check_that_only_names_changes_no_estimate() {
    let (model, q, r, zs) = oscillator();
    let noise = Noise::new(q, r).unwrap();
    let prior = Gaussian { mean: DVector::zeros(2), covariance: DMatrix::identity(2, 2) };
    let means = |settings: SupervisorSettings| -> Vec<u64> {
        let mut f: Box<dyn StateEstimator> =
            build_filter(FilterKind::SrCkf, model.clone(), noise.clone(), &prior, Default::default()).unwrap();
        let mut s = Supervisor::new(settings, 3).unwrap();
        let mut out = Vec::new();
        for (k, z) in zs.iter().enumerate() {
            let mut z = z.clone();
            if (FROM..TO).contains(&k) {
                z[0] = -z[0];
            }
            f.predict(&[0.0], 0.01).unwrap();
            s.gate(f.as_mut(), &z).unwrap();
            s.commit(|_| {});
            out.extend(f.mean().iter().map(|x| x.to_bits()));
        }
        out
    };
    let named = SupervisorSettings { wiring_sigmas: 8.0, ..SupervisorSettings::default() };
    assert_eq!(means(named), means(SupervisorSettings::default()), "the estimates moved");
}
