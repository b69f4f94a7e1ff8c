//! Tuning from data: the noise parameters of an estimator fitted to a recorded log of
//! its measurements (and known inputs), with no truth, by maximising the innovation
//! log-likelihood of the filter [Schweppe1965; Mehra1970]
//!
//! ```text
//! ℓ(θ) = Σ_k −½ (ln det S_k + ν_kᵀ S_k⁻¹ ν_k + m_k ln 2π)
//! ```
//!
//! over the logarithms of the parameters (so they stay positive), with a robust cap on
//! each row's normalised innovation so that a gross error cannot pull the fit
//! ([`likelihood`]). The optimiser is argmin's Nelder–Mead ([`optimise`]); the intervals
//! come from the curvature of `ℓ` at the optimum ([`intervals`]); [`fit`] is the whole
//! procedure, generic over what builds the filter ([`likelihood::FilterFactory`]), so a
//! test model and an FMU's estimator table ([`fmu_estimator`]) go through the same code.
//!
//! Around it: reading a log ([`log_input`]), the results as FMU start values in an SSP
//! parameter-value file and as `NAME=VALUE` assignments (the `start-values` crate,
//! which every command that runs an estimator reads them with), the NIS consistency band ([`consistency`]), the report
//! ([`report`]) and `--shard K/N` (the `shard` crate the sweeps use). The command is `kalfmu-tune`
//! (`src/main.rs`, `docs/tuning.md`).

pub mod consistency;
pub mod fit;
pub mod fmu_estimator;
pub mod intervals;
pub mod likelihood;
pub mod log_input;
pub mod optimise;
pub mod record;
pub mod report;
pub mod smoothed_log;

pub use fit::{fit, Fit, FitOptions};
pub use fmu_estimator::FmuEstimator;
pub use likelihood::{Evaluation, FilterFactory, Likelihood, RobustCap};
pub use record::Record;
pub use shard::Shard;
pub use start_values::{ssv, Assignment};
