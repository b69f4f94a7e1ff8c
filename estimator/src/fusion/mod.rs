//! Fusion of redundant readings of one quantity, after study S4's paper `[MaglevUKF2024]`:
//! 基于加权融合UKF的常导高速磁浮列车测速定位算法 (weighted-fusion UKF speed
//! and position for normal-conducting high-speed maglev), which fuses the speeds
//! of four redundant PRW position channels at every 20 ms telegram.
//!
//! The stages, one file each, in the paper's order (section 2.1):
//!
//! 1. [`student_t`]: Student's t CDF and quantiles, for the critical values;
//! 2. [`grubbs`]: Grubbs' test flags an outlying reading;
//! 3. [`support`]: eqs. (3)–(7), the rejected reading is replaced by the one
//!    of highest support;
//! 4. [`weights`]: eqs. (9)–(11), running variance estimates, inverse-variance
//!    weights and the fused value;
//! 5. [`PaperFusion`]: stages 2–4 per sample, eq. (19).
//!
//! **Missing readings.** A NaN (or infinite) reading is missing. Grubbs' test
//! and the support run on the present readings (no test with fewer than
//! three), a missing reading is not replaced, its channel's moments are not
//! updated and it gets weight 0; with every channel missing there is no fused
//! value. Nothing here panics on NaN input or returns a NaN weight.
//!
//! ```
//! use estimator::fusion::{grubbs, student_t};
//!
//! assert!((student_t::quantile(2.0, 0.975) - 4.302_652_729_749).abs() < 1e-9);
//! assert!((grubbs::critical_value(4, 0.05) - 1.48125).abs() < 1e-12);
//! ```

pub mod grubbs;
mod paper;
pub mod student_t;
pub mod support;
pub mod weights;

pub use grubbs::{Grubbs, GrubbsSettings};
pub use paper::{ChannelStatus, FusedSample, PaperFusion};
pub use weights::{AdaptiveWeights, WeightBasis, Weighting};
