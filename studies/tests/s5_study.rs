//! The S5 study: the SRCKF on the 20-state model identifies every coefficient of the
//! paper's missile before and after the change, and comes back quickly; the Monte Carlo
//! command prints its tables and splits its runs between shards. With `R` told far too
//! small, the square-root filters fly on, reported unhealthy, because the supervisor's
//! re-acquisitions stop at their inflation budget.

use estimator::{FilterKind, SupervisorSettings};
use studies::s5::study::{run_filter, run_supervised, Tuning};
use truth::s5::flight::{measure, simulate, Settings};
use truth::s5::parameters::{AFTER, BEFORE, NAMES};

#[test]
fn the_srckf_identifies_every_coefficient_within_one_percent_before_and_after_the_change() {
    let settings = Settings::default();
    let truth = simulate(&settings);
    let z = measure(&truth, 1.0, settings.seed);
    let e = run_filter(FilterKind::SrCkf, &Tuning::new(1.0), &truth, &z, settings.sample_time, &[]).unwrap();
    let (before, end) = (1999, truth.time.len() - 1);
    for i in 0..10 {
        let (b, a) =
            ((e.coefficients[before][i] / BEFORE[i] - 1.0).abs(), (e.coefficients[end][i] / AFTER[i] - 1.0).abs());
        assert!(b < 0.01 && a < 0.01, "{}: {:.3} % before, {:.3} % after", NAMES[i], 100.0 * b, 100.0 * a);
    }
    // Back within 3 % of the new values half a second after the change, and for good.
    let back = 2000 + 100;
    for k in back..=end {
        for i in 0..10 {
            let r = (e.coefficients[k][i] / AFTER[i] - 1.0).abs();
            assert!(r < 0.03, "{} at {:.3} s: {:.2} %", NAMES[i], truth.time[k], 100.0 * r);
        }
    }
}

#[test]
fn with_r_told_a_thousand_times_too_small_the_square_root_filters_fly_on_unhealthy() {
    // Our sensors, the filter told a thousandth of their σ: no inflation makes it agree
    // with them. Without a budget each re-acquisition multiplies the coefficients' σ by
    // up to 100 until P is no longer finite (SRCKF: 2.7 s into the flight); with the
    // default budget the filter keeps only what passes the gate, and says so.
    let settings = Settings::default();
    let truth = simulate(&settings);
    let z = measure(&truth, 1.0, settings.seed);
    let told = Tuning::new(1e-3);
    let dt = settings.sample_time;
    for kind in [FilterKind::SrCkf, FilterKind::SvdCkf] {
        let e = run_supervised(kind, &told, &truth, &z, dt, &[], SupervisorSettings::default())
            .unwrap_or_else(|error| panic!("{kind}: {error}"));
        let end = truth.time.len() - 1;
        assert!(e.std[end].iter().all(|s| s.is_finite()), "{kind}");
        assert!(!e.healthy[end], "{kind}: R is wrong, and the filter must say so");
        assert!(e.healthy.iter().filter(|h| !**h).count() > end / 2, "{kind}");
    }
    let unbounded = SupervisorSettings { max_inflation: 1e300, ..SupervisorSettings::default() };
    let error = run_supervised(FilterKind::SrCkf, &told, &truth, &z, dt, &[], unbounded)
        .expect_err("without the budget the SRCKF's P leaves the floats");
    assert!(error.contains("not finite"), "{error}");
}
