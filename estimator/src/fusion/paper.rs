//! The paper's preprocessing and fusion per telegram, section 2.1: Grubbs'
//! test on the `N` channel speeds, replacement of each rejected speed by the
//! best-supported one, then the adaptive inverse-variance weights and the fused
//! speed `V(t) = Σ w_i(t)·v_i(t)` of eq. (19). (The UKF on `V` is a model of
//! its own, not part of this stage.)

use super::grubbs::{Grubbs, GrubbsSettings};
use super::support::replace_rejected;
use super::weights::{AdaptiveWeights, WeightBasis, Weighting};
use crate::FilterError;

/// What became of one channel's reading in a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChannelStatus {
    /// Passed Grubbs' test and was weighted as read.
    Used,
    /// Rejected by Grubbs' test and replaced by the reading of the donor
    /// channel (the best-supported one) before weighting.
    Replaced {
        /// The channel whose reading took its place.
        donor: usize,
    },
    /// Missing (NaN or infinite): no test, no weight, moments untouched.
    Missing,
}

/// One telegram's fusion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FusedSample<const N: usize> {
    /// The fate of each channel.
    pub status: [ChannelStatus; N],
    /// The readings that were weighted: as read, or the donor's value where
    /// replaced; missing ones stay non-finite.
    pub cleaned: [f64; N],
    /// The weights, the variance estimates and the fused value of eqs. (9)–(11).
    pub weighting: Weighting<N>,
}

impl<const N: usize> FusedSample<N> {
    /// The fused speed `V`; `None` when every channel was missing.
    pub fn speed(&self) -> Option<f64> {
        self.weighting.value
    }

    /// The weights `w_i` (0 for a missing channel).
    pub fn weights(&self) -> [f64; N] {
        self.weighting.weights
    }

    /// `true` for each channel Grubbs' test rejected.
    pub fn rejected(&self) -> [bool; N] {
        self.status.map(|s| matches!(s, ChannelStatus::Replaced { .. }))
    }

    /// What the weights rest on.
    pub fn basis(&self) -> WeightBasis {
        self.weighting.basis
    }
}

/// The paper's fusion of `N` redundant readings (four PRW speeds in S4),
/// sample by sample; allocation-free per sample.
///
/// ```
/// use estimator::fusion::{ChannelStatus, GrubbsSettings, PaperFusion};
///
/// let mut fusion = PaperFusion::<4>::new(GrubbsSettings::default()).unwrap();
/// let sample = fusion.fuse(&[5.01, 4.99, 5.00, 0.0]); // the last telegram was resent: speed 0
/// assert_eq!(sample.status[3], ChannelStatus::Replaced { donor: 2 });
/// assert!((sample.speed().unwrap() - 5.0).abs() < 0.02);
/// ```
#[derive(Debug, Clone)]
pub struct PaperFusion<const N: usize> {
    grubbs: Grubbs<N>,
    weights: AdaptiveWeights<N>,
}

impl<const N: usize> PaperFusion<N> {
    /// A fusion with no samples yet; fails on a Grubbs level outside `(0, 1)`.
    pub fn new(grubbs: GrubbsSettings) -> Result<Self, FilterError> {
        Ok(Self { grubbs: Grubbs::new(grubbs)?, weights: AdaptiveWeights::new() })
    }

    /// The outlier test.
    pub fn grubbs(&self) -> &Grubbs<N> {
        &self.grubbs
    }

    /// The running moments behind the weights.
    pub fn weights(&self) -> &AdaptiveWeights<N> {
        &self.weights
    }

    /// Forgets the moments (the test keeps its settings).
    pub fn reset(&mut self) {
        self.weights.reset();
    }

    /// Fuses one sample: test, replace, update the moments, weight.
    pub fn fuse(&mut self, readings: &[f64; N]) -> FusedSample<N> {
        let rejected = self.grubbs.rejected(readings);
        let mut cleaned = *readings;
        let donor = replace_rejected(&mut cleaned, &rejected);
        let status = std::array::from_fn(|i| match donor {
            _ if !readings[i].is_finite() => ChannelStatus::Missing,
            Some(donor) if rejected[i] => ChannelStatus::Replaced { donor },
            _ => ChannelStatus::Used,
        });
        let weighting = self.weights.update(&cleaned);
        FusedSample { status, cleaned, weighting }
    }
}
