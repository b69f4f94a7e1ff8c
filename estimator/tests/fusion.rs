//! The S4 fusion stages as a specification: Student's t against published
//! and closed-form values, Grubbs' critical values against the tables and its
//! documented blind spot (two faulty channels mask each other), the support
//! replacement, the adaptive weights on seeded noisy channels, and the whole
//! per-telegram fusion: permutation-invariant, NaN-proof, allocation-free.
// The counting allocator needs `unsafe impl GlobalAlloc`.
#![allow(unsafe_code)]

use estimator::math;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::f64::consts::PI;

use estimator::fusion::{
    grubbs, student_t, support, AdaptiveWeights, ChannelStatus, Grubbs, GrubbsSettings, PaperFusion, WeightBasis,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn close(got: f64, expected: f64, rel: f64) -> bool {
    (got - expected).abs() <= rel * expected.abs().max(1e-300)
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

// ---------------------------------------------------------------- Student's t

#[test]
fn t_quantiles_match_published_values() {
    // (ν, p, t_p): 40-digit mpmath (betainc), rounded to 17 digits; tables agree to their digits.
    let cases = [
        (1.0, 0.975, 12.706204736174692),
        (2.0, 0.975, 4.302652729749462),
        (2.0, 0.99375, 8.860200034654316),
        (3.0, 0.95, 2.353363434801823),
        (5.0, 0.995, 4.032142983555227),
        (10.0, 0.975, 2.2281388519862744),
        (30.0, 0.999, 3.385184866829305),
        (100.0, 0.975, 1.9839715185235518),
        (1000.0, 0.975, 1.962339080826408),
        (2.5, 0.9, 1.7302509288071768),
        (0.5, 0.9, 10.270324410234512),
        (4.0, 0.6, 0.27072229470759734),
    ];
    for (dof, p, expected) in cases {
        let got = student_t::quantile(dof, p);
        assert!(close(got, expected, 1e-12), "t({dof}) at {p}: {got} vs {expected}");
        assert!((student_t::cdf(dof, got) - p).abs() < 1e-13, "cdf of the quantile, ν = {dof}");
    }
}

#[test]
fn t_cdf_matches_published_values() {
    let cases = [
        (2.0, 1.0, 0.7886751345948129),
        (3.0, 2.5, 0.9561466764959672),
        (10.0, -1.3, 0.11138290860342227),
        (4.5, 0.7, 0.740780198844191),
        (30.0, 4.0, 0.9998090771819581),
    ];
    for (dof, t, expected) in cases {
        assert!(close(student_t::cdf(dof, t), expected, 1e-13), "t({dof}) cdf at {t}");
    }
}

#[test]
fn one_degree_of_freedom_is_the_cauchy_distribution() {
    for t in [-50.0, -3.0, -0.2, 0.0, 0.7, 1.0, 12.0, 1e6] {
        let expected = 0.5 + math::atan(t) / PI;
        assert!((student_t::cdf(1.0, t) - expected).abs() < 1e-14, "cdf at {t}");
    }
    // tan(π(p − ½)) = −cot(πp), well conditioned for small p.
    for p in [1e-9, 0.01, 0.3, 0.5, 0.8, 0.975, 0.999] {
        let expected = if p < 0.5 { -1.0 / math::tan(PI * p) } else { 1.0 / math::tan(PI * (1.0 - p)) };
        let got = student_t::quantile(1.0, p);
        assert!((got - expected).abs() <= 1e-10 * expected.abs().max(1.0), "quantile at {p}: {got} vs {expected}");
    }
    // The upper tail 1/(πt) far out, where 1 − cdf would have lost every digit.
    assert!(close(student_t::upper_tail(1.0, 1e12), 1.0 / (PI * 1e12), 1e-10));
}

#[test]
fn two_degrees_of_freedom_have_a_closed_form() {
    // F(t) = ½ + t/(2√(2 + t²)); the upper q point is (1 − 2q)/√(2q(1 − q)).
    for t in [-7.0, -1.0, 0.3, 2.0, 50.0] {
        let expected = 0.5 + t / (2.0 * f64::sqrt(2.0 + t * t));
        assert!((student_t::cdf(2.0, t) - expected).abs() < 1e-14, "cdf at {t}");
    }
    for q in [1e-12, 1e-6, 0.00625, 0.025, 0.2] {
        let expected = (1.0 - 2.0 * q) / f64::sqrt(2.0 * q * (1.0 - q));
        assert!(close(student_t::inverse_upper_tail(2.0, q), expected, 1e-11), "upper point at {q}");
    }
}

#[test]
fn many_degrees_of_freedom_approach_the_normal() {
    let z975 = 1.959_963_984_540_054;
    let t = student_t::quantile(1e6, 0.975);
    // t_ν ≈ z + (z³ + z)/(4ν): 2.4e-6 above the normal point at ν = 1e6.
    assert!(close(t, 1.9599663568141068, 1e-8), "{t}");
    assert!((t - z975).abs() < 3e-6);
    let normal_cdf_1 = 0.841_344_746_068_542_9;
    assert!((student_t::cdf(1e6, 1.0) - normal_cdf_1).abs() < 1e-6);
}

#[test]
fn far_tails_and_symmetry_keep_their_digits() {
    // mpmath: the upper 1e-12 point of t(3), 10331.108244292485; and 1e-9.
    assert!(close(student_t::inverse_upper_tail(3.0, 1e-12), 10331.108244292485, 1e-12));
    assert!(close(student_t::inverse_upper_tail(3.0, 1e-9), 1033.1096745038078, 1e-12));
    for dof in [0.7, 2.0, 9.0] {
        for t in [0.1, 1.5, 40.0] {
            assert!((student_t::cdf(dof, -t) - (1.0 - student_t::cdf(dof, t))).abs() < 1e-15);
            assert_eq!(student_t::upper_tail(dof, t), student_t::cdf(dof, -t));
        }
        for p in [0.01, 0.2, 0.45] {
            assert_eq!(student_t::quantile(dof, p), -student_t::inverse_upper_tail(dof, p));
            // 1 − p rounds, and the far tail of t(0.7) magnifies that: agreement to 1e-13 only.
            assert!(close(student_t::quantile(dof, p), -student_t::quantile(dof, 1.0 - p), 1e-13));
        }
    }
}

#[test]
fn invalid_t_arguments_give_nan_and_the_ends_give_infinities() {
    assert!(student_t::cdf(0.0, 1.0).is_nan());
    assert!(student_t::cdf(-1.0, 1.0).is_nan());
    assert!(student_t::cdf(f64::NAN, 1.0).is_nan());
    assert!(student_t::cdf(3.0, f64::NAN).is_nan());
    assert!(student_t::quantile(3.0, 1.5).is_nan());
    assert!(student_t::quantile(3.0, f64::NAN).is_nan());
    assert_eq!(student_t::quantile(3.0, 1.0), f64::INFINITY);
    assert_eq!(student_t::quantile(3.0, 0.0), f64::NEG_INFINITY);
    assert_eq!(student_t::quantile(3.0, 0.5), 0.0);
    assert_eq!(student_t::cdf(3.0, f64::INFINITY), 1.0);
    assert_eq!(student_t::cdf(3.0, f64::NEG_INFINITY), 0.0);
}

// ---------------------------------------------------------------- Grubbs

#[test]
fn grubbs_critical_values_match_the_published_table() {
    // Two-sided α = 0.05, four-digit tables (e.g. Grubbs & Beck 1972 as reprinted
    // by ASTM E178), and the same from 40-digit mpmath.
    let table = [
        (3, 1.1543, 1.1543048513440384),
        (4, 1.4812, 1.48125),
        (5, 1.7150, 1.7150373123433638),
        (6, 1.8871, 1.8871451177839331),
        (7, 2.0200, 2.019968507679597),
        (8, 2.1266, 2.1266450871954654),
        (9, 2.2150, 2.215004223325533),
        (10, 2.2900, 2.2899540844796005),
        (20, 2.7082, 2.7082456458057544),
        (50, 3.1282, 3.128247334330972),
        (100, 3.3841, 3.384082901154891),
    ];
    for (n, printed, exact) in table {
        let g = grubbs::critical_value(n, 0.05);
        assert!((g - printed).abs() <= 0.5e-4 + 1e-12, "n = {n}: {g} vs the table's {printed}");
        assert!((g - exact).abs() < 1e-12, "n = {n}: {g} vs {exact}");
        assert!(g < grubbs::max_statistic(n));
    }
}

#[test]
fn four_channels_critical_value_is_exactly_1_48125() {
    // At n = 4 the t point has ν = 2 and t²/(2 + t²) = (1 − α/4)², so
    // G_crit = 1.5·(1 − α/4) = 1.48125: tables print 1.4812 or 1.4813 by how
    // they round the tie. One-sided: 1.5·(1 − α/2) = 1.4625.
    assert!((grubbs::critical_value(4, 0.05) - 1.48125).abs() < 1e-14);
    assert!((grubbs::critical_value_one_sided(4, 0.05) - 1.4625).abs() < 1e-14);
    assert_eq!(grubbs::max_statistic(4), 1.5);
}

#[test]
fn grubbs_statistic_never_exceeds_the_samuelson_bound() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed_0004);
    for _ in 0..2000 {
        let x: [f64; 4] = std::array::from_fn(|_| gauss(&mut rng) * 10f64.powi(rng.random_range(-3..3)));
        assert!(grubbs::statistic(&x).unwrap().statistic <= 1.5);
    }
    // The bound is met when three readings agree.
    let e = grubbs::statistic(&[5.0, 5.0, 5.0, -100.0]).unwrap();
    assert_eq!(e.index, 3);
    assert!((e.statistic - 1.5).abs() < 1e-12);
}

fn grubbs4() -> Grubbs<4> {
    Grubbs::new(GrubbsSettings::default()).unwrap()
}

#[test]
fn a_single_spike_among_four_readings_is_rejected() {
    let test = grubbs4();
    assert_eq!(test.rejected(&[5.0, 5.02, 4.98, 9.0]), [false, false, false, true]);
    // A resent telegram: the channel's speed reads 0.
    assert_eq!(test.rejected(&[0.0, 5.6, 5.58, 5.61]), [true, false, false, false]);
    // Healthy noise is kept.
    assert_eq!(test.rejected(&[5.0, 5.1, 4.9, 5.05]), [false; 4]);
}

#[test]
fn a_spike_must_stand_far_out_of_the_others_spread() {
    // G = 1.426 < 1.48125: a 0.5 m/s spike among readings spread by 0.2 m/s is kept.
    let e = grubbs::statistic(&[5.0, 5.1, 4.9, 5.5]).unwrap();
    assert!((e.statistic - 1.4260).abs() < 1e-3, "{}", e.statistic);
    assert_eq!(grubbs4().rejected(&[5.0, 5.1, 4.9, 5.5]), [false; 4]);
}

#[test]
fn two_equal_spikes_mask_each_other() {
    // Documented behaviour: {a, a, b, b} gives G = √3/2 whatever b − a, far
    // below 1.48125; two spikes of opposite sign hide each other too.
    let e = grubbs::statistic(&[5.0, 5.0, 9.0, 9.0]).unwrap();
    assert!((e.statistic - 3f64.sqrt() / 2.0).abs() < 1e-12);
    let test = grubbs4();
    assert_eq!(test.rejected(&[5.0, 5.01, 9.0, 9.0]), [false; 4]);
    assert_eq!(test.rejected(&[5.0, 5.01, 9.0, 1.0]), [false; 4]);
    // Retesting does not help: the first pass already finds nothing.
    let retest = Grubbs::<4>::new(GrubbsSettings { alpha: 0.05, max_rejections: 3 }).unwrap();
    assert_eq!(retest.rejected(&[5.0, 5.01, 9.0, 9.0]), [false; 4]);
}

#[test]
fn retesting_removes_a_second_outlier_only_when_two_of_three_nearly_coincide() {
    let readings = [5.0, 5.0 + 1e-7, 7.0, 20.0];
    assert_eq!(grubbs4().rejected(&readings), [false, false, false, true]);
    let retest = Grubbs::<4>::new(GrubbsSettings { alpha: 0.05, max_rejections: 2 }).unwrap();
    assert_eq!(retest.rejected(&readings), [false, false, true, true]);
    // With three readings left the bound is 1.15470 against 1.15430: {0, ε, 1}
    // loses its 1 only for ε < 0.0298.
    assert_eq!(retest.rejected(&[5.0, 5.05, 7.0, 20.0]), [false, false, true, true]);
    assert_eq!(retest.rejected(&[5.0, 5.3, 7.0, 20.0]), [false, false, false, true]);
}

#[test]
fn grubbs_ignores_missing_readings() {
    let test = grubbs4();
    assert_eq!(test.rejected(&[5.0, f64::NAN, 5.01, 9.0]), [false, false, false, true]);
    assert_eq!(test.rejected(&[5.0, f64::NAN, f64::INFINITY, 9.0]), [false; 4]);
    assert_eq!(test.rejected(&[f64::NAN; 4]), [false; 4]);
    assert_eq!(test.critical(3), grubbs::critical_value(3, 0.05));
    assert_eq!(test.critical(2), f64::INFINITY);
}

// ---------------------------------------------------------------- support

#[test]
fn support_replacement_picks_the_reading_closest_to_the_others() {
    let mut readings = [4.0, 5.0, 5.1, 20.0];
    let rejected = grubbs4().rejected(&readings);
    assert_eq!(rejected, [false, false, false, true]);
    assert_eq!(support::replace_rejected(&mut readings, &rejected), Some(1));
    assert_eq!(readings, [4.0, 5.0, 5.1, 5.0]);
}

#[test]
fn support_of_the_spike_is_the_lowest() {
    let s = support::support(&[5.0, 5.02, 4.98, 9.0]);
    assert!(s[3] < s[0] && s[3] < s[1] && s[3] < s[2], "{s:?}");
    assert!(s.iter().all(|x| (0.25..=1.0).contains(x)));
}

#[test]
fn no_rejection_changes_nothing() {
    let mut readings = [5.0, 5.02, f64::NAN, 4.98];
    assert_eq!(support::replace_rejected(&mut readings, &[false; 4]), None);
    assert_eq!(readings[..2], [5.0, 5.02]);
    assert!(readings[2].is_nan());
}

// ---------------------------------------------------------------- weights

/// `n` samples of four channels reading `speed(k)` plus Gaussian noise of the given σ.
fn noisy_channels(seed: u64, n: usize, sigma: [f64; 4], speed: impl Fn(usize) -> f64) -> Vec<[f64; 4]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|k| std::array::from_fn(|i| speed(k) + sigma[i] * gauss(&mut rng))).collect()
}

#[test]
fn weights_sum_to_one_and_favour_the_quieter_channels() {
    let sigma = [0.05, 0.1, 0.2, 0.4];
    let data = noisy_channels(7, 20_000, sigma, |_| 0.5);
    let mut weights = AdaptiveWeights::<4>::new();
    let mut last = None;
    for x in &data {
        let w = weights.update(x);
        assert!((w.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        last = Some(w);
    }
    let w = last.unwrap();
    assert_eq!(w.basis, WeightBasis::Estimated);
    assert!(w.weights[0] > w.weights[1] && w.weights[1] > w.weights[2] && w.weights[2] > w.weights[3], "{w:?}");
    // The estimates of eq. (9) find each σ² (the cross term 0.5·e has died down).
    for (v, s) in w.variances.iter().zip(sigma) {
        assert!(close(v.unwrap(), s * s, 0.3), "{v:?} vs {}", s * s);
    }
    // Near the optimum 1/σ² weights: 0.753, 0.188, 0.047, 0.012.
    let inverse = sigma.map(|s| 1.0 / (s * s));
    let total: f64 = inverse.iter().sum();
    for (got, best) in w.weights.iter().zip(inverse.map(|x| x / total)) {
        assert!((got - best).abs() < 0.05, "{got} vs {best}");
    }
    // Eq. (11): the fused variance is below the quietest channel's.
    assert!(w.variance.unwrap() < w.variances[0].unwrap());
}

#[test]
fn a_moving_speed_leaks_into_the_variance_estimates() {
    // Documented behaviour: eq. (9) uses uncentred moments, so at 5.6 m/s the
    // term x·(e_i − ē) swamps σ_i² = 1e-4 for long: some estimates stay ≤ 0
    // and take the quietest positive one (the weights stay finite and sum to 1).
    let data = noisy_channels(11, 500, [0.01; 4], |_| 5.6);
    let mut weights = AdaptiveWeights::<4>::new();
    let mut n_floored = 0;
    for x in &data {
        let w = weights.update(x);
        assert!(w.weights.iter().all(|v| v.is_finite() && *v > 0.0));
        assert!((w.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        n_floored += matches!(w.basis, WeightBasis::Floored(_)) as usize;
    }
    assert!(n_floored > 50, "{n_floored} samples had an estimate ≤ 0");
}

#[test]
fn a_missing_channel_gets_zero_weight_and_the_rest_share_one() {
    let mut weights = AdaptiveWeights::<4>::new();
    for x in noisy_channels(3, 200, [0.05, 0.1, 0.2, 0.4], |_| 0.5) {
        weights.update(&x);
    }
    let before = weights.n_samples(1, 1);
    let w = weights.update(&[0.5, f64::NAN, 0.6, 0.4]);
    assert_eq!(w.weights[1], 0.0);
    assert_eq!(w.variances[1], None);
    assert!((w.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert_eq!(weights.n_samples(1, 1), before, "a missing channel's moments are not updated");
    assert_eq!(weights.n_samples(0, 0), before + 1);
    let none = weights.update(&[f64::NAN; 4]);
    assert_eq!((none.value, none.weights, none.basis), (None, [0.0; 4], WeightBasis::NoReadings));
}

// ---------------------------------------------------------------- the paper's fusion

fn fusion4() -> PaperFusion<4> {
    PaperFusion::new(GrubbsSettings::default()).unwrap()
}

/// S4-like speeds: four channels at 5 m/s with 0.1 m/s noise, one channel in
/// turn reading a resent telegram (0) or a slot slip (±4.3 m/s) now and then,
/// and some telegrams missing (NaN).
fn spiky_channels(seed: u64, n: usize) -> (Vec<f64>, Vec<[f64; 4]>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth: Vec<f64> = (0..n).map(|k| 0.2 + 0.01 * k as f64).map(|v| v.min(5.6)).collect();
    let data = truth
        .iter()
        .map(|&v| {
            let mut x: [f64; 4] = std::array::from_fn(|_| v + 0.1 * gauss(&mut rng));
            let i = rng.random_range(0..4);
            match rng.random_range(0..100) {
                0..=2 => x[i] = 0.0,
                3..=5 => x[i] += if rng.random_bool(0.5) { 4.3 } else { -4.3 },
                6 => x[i] = f64::NAN,
                _ => {}
            }
            x
        })
        .collect();
    (truth, data)
}

#[test]
fn a_resent_telegram_is_replaced_and_fused_away() {
    let mut fusion = fusion4();
    let s = fusion.fuse(&[5.01, 4.99, 5.0, 0.0]);
    assert_eq!(
        s.status,
        [ChannelStatus::Used, ChannelStatus::Used, ChannelStatus::Used, ChannelStatus::Replaced { donor: 2 }]
    );
    assert_eq!(s.rejected(), [false, false, false, true]);
    assert_eq!(s.cleaned, [5.01, 4.99, 5.0, 5.0]);
    assert!((s.weights().iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert!((s.speed().unwrap() - 5.0).abs() < 0.02);
}

#[test]
fn the_fusion_beats_the_plain_mean_on_spiky_channels() {
    let (truth, data) = spiky_channels(2024, 3000);
    let mut fusion = fusion4();
    let (mut fused_error, mut mean_error, mut n_rejected) = (0.0, 0.0, 0);
    for (v, x) in truth.iter().zip(&data) {
        let s = fusion.fuse(x);
        fused_error += (s.speed().unwrap() - v).abs();
        let present: Vec<f64> = x.iter().copied().filter(|x| x.is_finite()).collect();
        mean_error += (present.iter().sum::<f64>() / present.len() as f64 - v).abs();
        n_rejected += s.rejected().iter().filter(|r| **r).count();
    }
    let n = truth.len() as f64;
    let (fused_error, mean_error) = (fused_error / n, mean_error / n);
    assert!(n_rejected > 100, "{n_rejected} rejections");
    assert!(fused_error < 0.75 * mean_error, "mean |error|: fused {fused_error}, plain mean {mean_error}");
}

#[test]
fn weights_and_speed_are_invariant_to_channel_order() {
    let (_, data) = spiky_channels(99, 1500);
    let perm = [2, 0, 3, 1]; // channel i of the original is channel perm[i] of the permuted
    let (mut a, mut b) = (fusion4(), fusion4());
    for x in &data {
        let mut y = [0.0; 4];
        for (&value, &slot) in x.iter().zip(&perm) {
            y[slot] = value;
        }
        let (sa, sb) = (a.fuse(x), b.fuse(&y));
        for (i, &j) in perm.iter().enumerate() {
            assert!((sa.weights()[i] - sb.weights()[j]).abs() < 1e-9);
            let relabelled = match sa.status[i] {
                ChannelStatus::Replaced { donor } => ChannelStatus::Replaced { donor: perm[donor] },
                other => other,
            };
            assert_eq!(relabelled, sb.status[j]);
        }
        match (sa.speed(), sb.speed()) {
            (Some(u), Some(v)) => assert!((u - v).abs() < 1e-9),
            (u, v) => assert_eq!(u, v),
        }
    }
}

#[test]
fn nan_readings_are_missing_and_never_reach_the_output() {
    let mut fusion = fusion4();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..2000 {
        let x: [f64; 4] = std::array::from_fn(|_| match rng.random_range(0..10) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            _ => 5.0 + 0.1 * gauss(&mut rng),
        });
        let s = fusion.fuse(&x);
        let n_present = x.iter().filter(|v| v.is_finite()).count();
        assert!(s.weights().iter().all(|w| w.is_finite() && *w >= 0.0));
        for ((status, weight), reading) in s.status.iter().zip(s.weights()).zip(x) {
            assert_eq!(*status == ChannelStatus::Missing, !reading.is_finite());
            if !reading.is_finite() {
                assert_eq!(weight, 0.0);
            }
        }
        match s.speed() {
            Some(v) => assert!(v.is_finite() && (s.weights().iter().sum::<f64>() - 1.0).abs() < 1e-12),
            None => assert_eq!(n_present, 0),
        }
    }
}

// ---------------------------------------------------------------- allocations

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn fusing_a_sample_allocates_nothing() {
    let (_, data) = spiky_channels(1, 500);
    let mut fusion = fusion4();
    let before = ALLOCATIONS.with(Cell::get);
    let mut sum = 0.0;
    for x in &data {
        sum += fusion.fuse(x).speed().unwrap_or(0.0);
    }
    assert_eq!(ALLOCATIONS.with(Cell::get) - before, 0);
    assert!(sum.is_finite());
}
