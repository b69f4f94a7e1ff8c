//! The fixed-interval smoother on S1:
//! - for every filter kind, over the study's four cases at 5 % noise (a seed and noise
//!   other than the study's), the smoothed load is never worse than the filtered one, in
//!   RMSE and in correlation, and its σ is never wider. The backward pass takes each step's
//!   filtered and predicted Gaussians as the filter had them and the cross-covariance by
//!   the filter's own rule (the cubature points for the CKF family, the unscented ones for
//!   the UKF, the Jacobian for the EKF);
//! - behind the supervisor, a row its gate rejected stays out of the smoothed pass (the
//!   loop's own transitions, gathered by `RunRecorder`);
//! - the square-root form, from the SRCKF's roots, is the covariance form to rounding.

use analyzer::metrics::{correlation, rmse};
use estimator::models::Oscillator2DofLoad;
use estimator::{
    cross_covariance, linearised_cross_covariance, smooth, smooth_square_root, Discretized, FilterKind, Gaussian,
    RootGaussian, RunRecorder, Sample, SigmaPoints, SmoothingStep, SquareRootStep, SupervisedFilter, Supervisor,
    SupervisorSettings,
};
use studies::s1::Tuning;
use truth::s1::{simulate, Case, Settings};

/// The filter's `(filtered, predicted)` Gaussians of a run: the predicted ones at the
/// samples after the first, as the filter had them before its update.
fn run(kind: FilterKind, case: &Case, settings: &Settings) -> (Vec<f64>, Vec<Gaussian>, Vec<Gaussian>, Tuning) {
    let (truth, measurements) = simulate(case, settings);
    let tuning = Tuning::new(settings, measurements.noise_std);
    let mut filter = tuning.filter(kind, case, tuning.noise()).unwrap();
    let (mut filtered, mut predicted) = (Vec::new(), Vec::new());
    for (k, z) in measurements.acceleration.iter().enumerate() {
        if k > 0 {
            filter.predict(&[], settings.dt()).unwrap();
            predicted.push(Gaussian { mean: filter.mean().clone(), covariance: filter.covariance() });
        }
        filter.update(z).unwrap();
        filtered.push(Gaussian { mean: filter.mean().clone(), covariance: filter.covariance() });
    }
    (truth.load, filtered, predicted, tuning)
}

#[test]
fn on_s1_the_smoothed_load_is_never_worse_than_the_filtered_for_any_filter_kind() {
    let settings = Settings { duration: 10.0, noise_fraction: 0.05, seed: 7, ..Settings::default() };
    let load = Oscillator2DofLoad::LOAD;
    for case in Case::ALL {
        for kind in FilterKind::ALL {
            let (truth, filtered, predicted, tuning) = run(kind, &case, &settings);
            let mut process = Discretized::rk4(Oscillator2DofLoad::new(case.chain()), tuning.rk4_substeps);
            let points = match kind {
                FilterKind::Ukf => Some(SigmaPoints::unscented(6, tuning.unscented).unwrap()),
                FilterKind::Ekf => None,
                _ => Some(SigmaPoints::cubature(6)),
            };
            let steps: Vec<SmoothingStep> = filtered
                .iter()
                .zip(&predicted)
                .enumerate()
                .map(|(k, (f, p))| {
                    let t = k as f64 * settings.dt();
                    let cross = match &points {
                        Some(points) => cross_covariance(&mut process, points, f, t, settings.dt(), &[]),
                        None => linearised_cross_covariance(&mut process, f, t, settings.dt(), &[]),
                    };
                    SmoothingStep { filtered: f.clone(), predicted: p.clone(), cross: cross.unwrap() }
                })
                .collect();
            let smoothed = smooth(&steps, filtered.last().unwrap()).unwrap();
            // From 1 s on: the filter's start-up is not what is compared.
            let from = (1.0 / settings.dt()) as usize;
            let of = |g: &[Gaussian]| g[from..].iter().map(|g| g.mean[load]).collect::<Vec<_>>();
            let (f, s, t) = (of(&filtered), of(&smoothed), &truth[from..]);
            let what = format!(
                "{case} {kind}: RMSE {:.4} filtered, {:.4} smoothed; correlation {:.5}, {:.5}",
                rmse(t, &f),
                rmse(t, &s),
                correlation(t, &f),
                correlation(t, &s)
            );
            eprintln!("{what}");
            assert!(rmse(t, &s) <= rmse(t, &f), "{what}");
            assert!(correlation(t, &s) >= correlation(t, &f), "{what}");
            for (g_s, g_f) in smoothed.iter().zip(&filtered) {
                assert!(g_s.covariance[(load, load)] <= g_f.covariance[(load, load)] * (1.0 + 1e-9), "{what}");
            }
        }
    }
}

/// The SRCKF behind the supervisor as the FMU runs it over `rows`, smoothed from the
/// transitions the loop keeps (`RunRecorder`); and the rows its gate rejected.
fn supervised_and_smoothed(
    case: &Case,
    settings: &Settings,
    rows: &[[f64; 2]],
    noise_std: [f64; 2],
) -> (Vec<Gaussian>, u64) {
    let tuning = Tuning::new(settings, noise_std);
    let filter = tuning.filter(FilterKind::SrCkf, case, tuning.noise()).unwrap();
    let supervisor = Supervisor::new(SupervisorSettings::default(), 2)
        .and_then(|s| s.with_jump_states(6, &Oscillator2DofLoad::UNKNOWN_INPUTS))
        .unwrap();
    let mut supervised = SupervisedFilter::new(filter, supervisor).unwrap();
    supervised.keep_transitions();
    let mut recorder = RunRecorder::new();
    let samples = rows.iter().enumerate().map(|(k, z)| Sample { time: k as f64 * settings.dt(), z, controls: &[] });
    supervised.run(settings.dt(), samples, |step| recorder.observe(step).unwrap()).unwrap();
    (recorder.smooth().unwrap(), supervised.supervisor().rejected())
}

#[test]
fn a_row_the_gate_rejected_stays_out_of_the_smoothed_pass() {
    let settings = Settings { duration: 4.0, noise_fraction: 0.02, seed: 5, ..Settings::default() };
    let case: Case = "stiffness/random".parse().unwrap();
    let (_, measurements) = simulate(&case, &settings);
    let clean: Vec<[f64; 2]> = measurements.acceleration.iter().map(|z| [z[0], z[1]]).collect();
    // One accelerometer sample 50σ off at 2 s, and the same sample missing.
    let at = (2.0 / settings.dt()) as usize;
    let (mut spiked, mut missing) = (clean.clone(), clean.clone());
    spiked[at][0] += 50.0 * measurements.noise_std[0];
    missing[at][0] = f64::NAN;
    let (with_spike, rejected) = supervised_and_smoothed(&case, &settings, &spiked, measurements.noise_std);
    let (without, none) = supervised_and_smoothed(&case, &settings, &missing, measurements.noise_std);
    assert_eq!((rejected, none), (1, 0), "the gate rejects the spike and nothing else");
    // Smoothing reaches back past the spike: had the rejected row entered the backward
    // pass, the samples before it would differ from the run without it.
    for (k, (a, b)) in with_spike.iter().zip(&without).enumerate() {
        let load = Oscillator2DofLoad::LOAD;
        assert!(
            (a.mean[load] - b.mean[load]).abs() <= 1e-9 * b.mean[load].abs().max(1.0),
            "sample {k}: {} vs {}",
            a.mean[load],
            b.mean[load]
        );
    }
}

#[test]
fn the_square_root_smoother_of_the_srckf_is_the_covariance_form_to_rounding() {
    let settings = Settings { duration: 5.0, noise_fraction: 0.05, seed: 3, ..Settings::default() };
    for case in ["stiffness/random", "damping/harmonic"] {
        let case: Case = case.parse().unwrap();
        let (_, measurements) = simulate(&case, &settings);
        let tuning = Tuning::new(&settings, measurements.noise_std);
        let mut filter = tuning.filter(FilterKind::SrCkf, &case, tuning.noise()).unwrap();
        let q_root = filter.noise().q_sqrt().clone();
        let root = |f: &dyn estimator::StateEstimator| f.sqrt_covariance().expect("the SRCKF keeps a root").clone();
        let (mut root_steps, mut steps) = (Vec::new(), Vec::new());
        let mut last: Option<(nalgebra::DVector<f64>, nalgebra::DMatrix<f64>)> = None;
        let mut process = Discretized::rk4(Oscillator2DofLoad::new(case.chain()), tuning.rk4_substeps);
        for (k, z) in measurements.acceleration.iter().enumerate() {
            let t = k as f64 * settings.dt();
            if let Some((mean, s)) = last.take() {
                filter.predict(&[], settings.dt()).unwrap();
                let filtered = Gaussian { mean: mean.clone(), covariance: &s * s.transpose() };
                let predicted = Gaussian { mean: filter.mean().clone(), covariance: filter.covariance() };
                let points = SigmaPoints::cubature(6);
                let dt = settings.dt();
                let cross = cross_covariance(&mut process, &points, &filtered, t - dt, dt, &[]).unwrap();
                steps.push(SmoothingStep { filtered, predicted, cross });
                root_steps.push(SquareRootStep {
                    filtered_mean: mean,
                    filtered_root: s,
                    predicted_mean: filter.mean().clone(),
                    predicted_root: root(filter.as_ref()),
                    process_noise_root: q_root.clone(),
                    t: t - dt,
                    dt,
                    u: Vec::new(),
                });
            }
            filter.update(z).unwrap();
            last = Some((filter.mean().clone(), root(filter.as_ref())));
        }
        let (mean, s) = last.unwrap();
        let covariance_form = smooth(&steps, &Gaussian { mean: mean.clone(), covariance: &s * s.transpose() }).unwrap();
        let last = RootGaussian { mean, root: s };
        let square_root = smooth_square_root(&mut process, &SigmaPoints::cubature(6), &root_steps, &last).unwrap();
        for (k, (g, RootGaussian { mean: m, root: r })) in covariance_form.iter().zip(&square_root).enumerate() {
            let p = r * r.transpose();
            for i in 0..6 {
                let scale = g.covariance[(i, i)].sqrt();
                assert!(
                    (m[i] - g.mean[i]).abs() <= 1e-6 * scale,
                    "{case} sample {k} state {i}: {} vs {}",
                    m[i],
                    g.mean[i]
                );
                assert!(
                    (p[(i, i)] / g.covariance[(i, i)] - 1.0).abs() < 1e-6,
                    "{case} sample {k} state {i}: variance {} vs {}",
                    p[(i, i)],
                    g.covariance[(i, i)]
                );
            }
        }
    }
}
