//! The adapted S1 filter, told a load noise ten times too large or too small, is
//! consistent within 3 s: from then on its normalised innovations average one per row
//! and its load errors one per σ², as with the intensity the study derives from the
//! load's spectrum (seeds and noise other than the study's).

use estimator::models::Oscillator2DofLoad;
use estimator::{FilterKind, Sample, SupervisedFilter, Supervisor, SupervisorSettings};
use studies::s1::Tuning;
use truth::s1::{simulate, Case, Settings};

/// Mean NIS per row and mean (e/σ)² of the load over the samples from 3 s on.
fn consistency(case: &Case, settings: &Settings, factor: f64, supervision: SupervisorSettings) -> (f64, f64) {
    let (truth, measurements) = simulate(case, settings);
    let mut tuning = Tuning::new(settings, measurements.noise_std);
    tuning.load_intensity *= factor;
    let filter = tuning.filter(FilterKind::SrCkf, case, tuning.noise()).unwrap();
    let supervisor = Supervisor::new(supervision, 2)
        .and_then(|s| s.with_jump_states(6, &Oscillator2DofLoad::UNKNOWN_INPUTS))
        .unwrap();
    let mut supervised = SupervisedFilter::new(filter, supervisor).unwrap();
    let samples = truth.time.iter().zip(&measurements.acceleration).map(|(&time, z)| Sample { time, z, controls: &[] });
    let (mut nis, mut rows, mut squared, mut count) = (0.0, 0usize, 0.0, 0usize);
    supervised
        .run(settings.dt(), samples, |step| {
            if step.sample.time < 3.0 {
                return;
            }
            (nis, rows) = (nis + step.outcome.nis, rows + step.outcome.dof);
            let (f, var) = (step.filter.mean()[Oscillator2DofLoad::LOAD], step.filter.covariance()[(2, 2)]);
            squared += (f - truth.load[step.index]).powi(2) / var;
            count += 1;
        })
        .unwrap();
    (nis / rows as f64, squared / count as f64)
}

#[test]
fn told_the_load_noise_ten_times_wrong_either_way_the_filter_is_consistent_within_3_s() {
    let settings = Settings { duration: 30.0, noise_fraction: 0.03, seed: 4, ..Settings::default() };
    for case in ["stiffness/random", "damping/harmonic"] {
        let case: Case = case.parse().unwrap();
        for factor in [0.1, 1.0, 10.0] {
            let (nis, squared) = consistency(&case, &settings, factor, SupervisorSettings::default());
            let (nis_fixed, squared_fixed) =
                consistency(&case, &settings, factor, SupervisorSettings::default().adaptive(0));
            let what = format!("{case}, load noise ×{factor}: NIS per row {nis:.3} ({nis_fixed:.3} unadapted), (e/σ)² of F {squared:.3} ({squared_fixed:.3})");
            assert!((nis - 1.0).abs() < 0.05 && (squared - 1.0).abs() < 0.1, "{what}");
            if factor != 1.0 {
                // What the adaptation mends: unadapted, the same filter is not consistent.
                assert!((nis_fixed - 1.0).abs() > 0.25, "{what}");
            }
        }
    }
}
