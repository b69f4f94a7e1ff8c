//! The wiring checks where an unknown input follows a channel, as a
//! specification: two masses on springs, the first driven by an unknown
//! force (a random-walk state), each read by an accelerometer. A flipped
//! accelerometer on the driven mass drags the force along: its own
//! innovations stay white, and only the other mass's accelerometer shows the
//! mistake, through the spring, samples later. The channel's fault signature
//! through the filter's dynamics names that channel and no other, and
//! nothing on healthy data. (Here the channel's own scores see the flip too;
//! on S3's whole car they do not, and the signatures name it:
//! `kalfmu robustness --wiring`.)

mod common;

use common::*;
use estimator::models::LinearGaussian;
use estimator::{build_filter, FilterKind, Gaussian, Noise, RowOutcome, Supervisor, SupervisorSettings};
use nalgebra::{DMatrix, DVector};

const STEPS: usize = 3000;
const FROM: usize = 1000;
const DT: f64 = 0.01;

/// The chain (`[x₁, v₁, x₂, v₂, F]`, masses 1, springs 400 and 200, light
/// dampers, one step of semi-implicit Euler per sample), `Q`, `R`, and the
/// measurements `[a₁, a₂]` of a run of it.
fn chain() -> (LinearGaussian, DMatrix<f64>, DMatrix<f64>, Vec<Vec<f64>>) {
    let (k1, k2, c) = (400.0, 200.0, 2.0);
    // Accelerations as rows of H: a₁ = F − k₁(x₁ − x₂) − c·v₁, a₂ = k₁(x₁ − x₂) − k₂·x₂ − c·v₂.
    let h = DMatrix::from_row_slice(2, 5, &[-k1, -c, k1, 0.0, 1.0, k1, 0.0, -k1 - k2, -c, 0.0]);
    let mut a = DMatrix::identity(5, 5);
    for (v, row) in [(1, 0), (3, 1)] {
        for j in 0..5 {
            a[(v, j)] += DT * h[(row, j)];
        }
    }
    for (x, v) in [(0, 1), (2, 3)] {
        for j in 0..5 {
            a[(x, j)] += DT * a[(v, j)];
        }
    }
    let model = LinearGaussian::new(a, DMatrix::zeros(5, 1), h);
    let mut q = DMatrix::identity(5, 5) * 1e-10;
    q[(4, 4)] = 4.0;
    let r = DMatrix::identity(2, 2) * 0.01;
    let mut rng = rng(11);
    let mut x = DVector::zeros(5);
    let zs = (0..STEPS)
        .map(|_| {
            x = model.a() * &x + correlated(&mut rng, &q);
            let z = model.h() * &x;
            (0..2).map(|i| z[i] + 0.1 * normal(&mut rng)).collect()
        })
        .collect();
    (model, q, r, zs)
}

/// What a run shows per sample: the rows' statuses as a user reads them, the
/// filter's health and its mean.
struct Run {
    statuses: Vec<Vec<RowOutcome>>,
    healthy: Vec<bool>,
    means: Vec<Vec<f64>>,
}

/// Runs `kind` with `settings` over the chain, `a₁` flipped from `FROM` on
/// when `flipped`.
fn run(settings: SupervisorSettings, kind: FilterKind, flipped: bool) -> Run {
    let (model, q, r, zs) = chain();
    let prior = Gaussian { mean: DVector::zeros(5), covariance: DMatrix::identity(5, 5) };
    let mut filter = build_filter(kind, model, Noise::new(q, r).unwrap(), &prior, Default::default()).unwrap();
    let mut supervisor = Supervisor::new(settings, 2).unwrap();
    let mut shown = Run { statuses: Vec::new(), healthy: Vec::new(), means: Vec::new() };
    for (k, z) in zs.iter().enumerate() {
        let mut z = z.clone();
        if flipped && k >= FROM {
            z[0] = -z[0];
        }
        if k > 0 {
            filter.predict(&[0.0], DT).unwrap();
        }
        supervisor.gate(filter.as_mut(), &z).unwrap();
        supervisor.commit(|_| {});
        shown.statuses.push(supervisor.statuses().collect());
        shown.healthy.push(supervisor.healthy());
        shown.means.push(filter.mean().iter().copied().collect());
    }
    shown
}

fn signatures() -> SupervisorSettings {
    SupervisorSettings {
        wiring_sigmas: 8.0,
        wiring_leaves_out: true,
        wiring_signatures: true,
        ..SupervisorSettings::default()
    }
}

fn first_inconsistent(rows: &[Vec<RowOutcome>], channel: usize) -> Option<usize> {
    rows.iter().position(|r| r[channel] == RowOutcome::Inconsistent)
}

#[test]
fn on_healthy_data_no_signature_names_a_channel() {
    for kind in [FilterKind::Ckf, FilterKind::SrCkf, FilterKind::Ekf] {
        let rows = run(signatures(), kind, false).statuses;
        for channel in 0..2 {
            assert_eq!(first_inconsistent(&rows, channel), None, "{kind}: channel {channel} named on healthy data");
        }
    }
}

#[test]
fn a_flipped_channel_that_its_unknown_input_follows_is_named_by_its_signature_within_two_seconds() {
    for kind in [FilterKind::Ckf, FilterKind::SrCkf, FilterKind::Ekf] {
        let rows = run(signatures(), kind, true).statuses;
        let named = first_inconsistent(&rows, 0).unwrap_or_else(|| panic!("{kind}: the flipped a₁ is never named"));
        assert!(named >= FROM && named - FROM <= (2.0 / DT) as usize, "{kind}: named {} samples after", named - FROM);
        assert_eq!(first_inconsistent(&rows, 1), None, "{kind}: the right a₂ is blamed");
    }
}

fn named_by_signatures() -> SupervisorSettings {
    SupervisorSettings { wiring_sigmas: 8.0, wiring_signatures: true, ..SupervisorSettings::default() }
}

#[test]
fn named_and_kept_a_flipped_channel_is_the_one_named_and_the_filter_is_unhealthy_within_two_seconds() {
    for kind in [FilterKind::Ckf, FilterKind::SrCkf, FilterKind::Ekf] {
        let shown = run(named_by_signatures(), kind, true);
        let named =
            first_inconsistent(&shown.statuses, 0).unwrap_or_else(|| panic!("{kind}: the flipped a₁ is never named"));
        assert!(named >= FROM && named - FROM <= (2.0 / DT) as usize, "{kind}: named {} samples after", named - FROM);
        assert_eq!(first_inconsistent(&shown.statuses, 1), None, "{kind}: the right a₂ is blamed");
        let within = FROM..FROM + (2.0 / DT) as usize;
        assert!(shown.healthy[within].iter().any(|&h| !h), "{kind}: healthy throughout with a₁ flipped");
        let clean = run(named_by_signatures(), kind, false);
        assert!(
            clean.statuses.iter().flatten().all(|&s| s != RowOutcome::Inconsistent),
            "{kind}: a clean channel named"
        );
        assert!(clean.healthy[FROM..].iter().all(|&h| h), "{kind}: unhealthy on clean data");
    }
}

#[test]
fn named_and_kept_the_signatures_change_no_estimate() {
    for kind in [FilterKind::Ckf, FilterKind::SrCkf, FilterKind::Ekf] {
        let with = run(named_by_signatures(), kind, true);
        let without = run(SupervisorSettings { wiring_signatures: false, ..named_by_signatures() }, kind, true);
        let bits = |means: &[Vec<f64>]| means.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&with.means), bits(&without.means), "{kind}: the signatures moved the estimate");
    }
}
