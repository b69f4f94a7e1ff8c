//! Support degrees between redundant readings, and the replacement of rejected
//! readings by the best-supported one: the paper's eqs. (3)–(7).
//!
//! ```text
//! L_ij = √((x_i² − 2·x_i·x_j + x_j²)/2) = |x_i − x_j|/√2        (3)
//! l_ij = L_ij / max_{i,j} L_ij = |x_i − x_j| / max_{i,j}|x_i − x_j|   (4)   (0 when all are equal)
//! S_ij = 1 − l_ij = S_ji                                        (5)
//! S    = [S_ij], with S_ii = 1 on the diagonal                  (6)
//! S_i  = ¼ · Σ_{j=1..4} S_ji                                     (7)
//! ```
//!
//! The `1/√2` of (3) cancels in (4). The sum in (7) runs over all four
//! channels, the reading itself (`S_ii = 1`) and the rejected readings
//! included, and the maximum in (4) is over all pairs, so an outlier stretches
//! the scale of everyone's support. Here the sum and the maximum run over the
//! `m` present (finite) readings, and `¼` becomes `1/m`; with all four present
//! this is the paper's formula exactly. Since `S_i = 1 − Σ_j |x_i − x_j| / (m·D)`
//! with `D` the range, the best-supported reading is the one with the smallest
//! sum of distances to the others: a sample median.
//!
//! "通过支持度计算公式,将支持度最高的数据代替异常数据": each rejected reading
//! is overwritten by the reading of highest support. The paper does not say
//! whether a rejected reading may be the donor; here it may not (only present,
//! unrejected readings are candidates).
//!
//! **Ties are the rule, not the exception.** A sum of distances is constant
//! between the two middle order statistics, so with four readings the two
//! middle ones always have equal support (`S = 1 − (x₍₃₎ + x₍₄₎ − x₍₁₎ − x₍₂₎)/(4D)`
//! for both), and Grubbs' outlier is always an extreme. Supports within
//! `1e-12` count as equal; among them the reading closest to the mean of the
//! candidates wins (for three candidates beside an extreme outlier, that is
//! their median), then the smaller value, then the lower index. The choice
//! depends on the values only, so relabelling the channels relabels the donor.

/// The support `S_i` of eq. (7) for every present reading; 0 for a missing
/// (non-finite) one. A present reading's support lies in `[1/m, 1]`.
pub fn support<const N: usize>(readings: &[f64; N]) -> [f64; N] {
    let present = |x: f64| x.is_finite();
    let n_present = readings.iter().filter(|x| present(**x)).count();
    // Halved, so that neither a difference nor the range can overflow.
    let half = readings.map(|x| 0.5 * x);
    let (lo, hi) = half
        .iter()
        .filter(|x| present(**x))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)));
    let range = hi - lo;
    std::array::from_fn(|i| {
        if !present(readings[i]) {
            return 0.0;
        }
        let distance: f64 = if range > 0.0 {
            half.iter().filter(|x| present(**x)).map(|&x| (half[i] - x).abs() / range).sum()
        } else {
            0.0
        };
        (n_present as f64 - distance) / n_present as f64
    })
}

/// Supports closer than this are equal.
const TIE: f64 = 1e-12;

/// The present reading with the highest support (over all present readings)
/// among those with `candidate[i]`, ties broken as the module documentation
/// says. `None` when no candidate is present.
pub fn most_supported<const N: usize>(readings: &[f64; N], candidate: &[bool; N]) -> Option<usize> {
    let s = support(readings);
    let candidates = || (0..N).filter(|&i| candidate[i] && readings[i].is_finite());
    let n_candidates = candidates().count();
    if n_candidates == 0 {
        return None;
    }
    let best = candidates().map(|i| s[i]).fold(f64::NEG_INFINITY, f64::max);
    let mean = candidates().map(|i| 0.5 * readings[i]).sum::<f64>() / n_candidates as f64;
    let key = |i: usize| ((0.5 * readings[i] - mean).abs(), readings[i], i);
    candidates()
        .filter(|&i| s[i] >= best - TIE)
        .min_by(|&a, &b| key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal))
}

/// Overwrites every rejected present reading with the best-supported
/// unrejected one (support over all present readings, the rejected included,
/// as in the paper) and returns that donor's index; `None`, and nothing
/// changed, when no reading is rejected or none is left to donate.
pub fn replace_rejected<const N: usize>(readings: &mut [f64; N], rejected: &[bool; N]) -> Option<usize> {
    let to_replace = |i: usize| rejected[i] && readings[i].is_finite();
    if !(0..N).any(to_replace) {
        return None;
    }
    let donor = most_supported(readings, &rejected.map(|r| !r))?;
    let value = readings[donor];
    let replace = std::array::from_fn::<bool, N, _>(to_replace);
    for (x, _) in readings.iter_mut().zip(replace).filter(|(_, r)| *r) {
        *x = value;
    }
    Some(donor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn support_matches_the_paper_by_hand() {
        // x = (0, 1, 2, 4): D = 4; Σ_j |x_i − x_j| = 7, 5, 5, 9; S_i = (4 − Σ/4)/4.
        let s = support(&[0.0, 1.0, 2.0, 4.0]);
        for (got, sum) in s.iter().zip([7.0, 5.0, 5.0, 9.0]) {
            assert!((got - (4.0 - sum / 4.0) / 4.0).abs() < 1e-15);
        }
    }

    #[test]
    fn equal_readings_support_each_other_fully() {
        assert_eq!(support(&[5.6; 4]), [1.0; 4]);
        assert_eq!(support(&[5.6, f64::NAN, 5.6, 5.6]), [1.0, 0.0, 1.0, 1.0]);
    }

    #[test]
    fn the_two_middle_readings_tie_and_the_median_of_the_candidates_wins() {
        let readings = [5.01, 4.99, 5.0, 0.0];
        let s = support(&readings);
        assert!((s[1] - s[2]).abs() < 1e-15 && s[1] > s[0] && s[0] > s[3], "{s:?}");
        assert_eq!(most_supported(&readings, &[true, true, true, false]), Some(2));
        let mut replaced = readings;
        assert_eq!(replace_rejected(&mut replaced, &[false, false, false, true]), Some(2));
        assert_eq!(replaced, [5.01, 4.99, 5.0, 5.0]);
    }

    #[test]
    fn huge_readings_do_not_overflow() {
        let s = support(&[f64::MAX, -f64::MAX, 0.0, 1.0]);
        assert!(s.iter().all(|x| x.is_finite() && *x > 0.0), "{s:?}");
    }
}
