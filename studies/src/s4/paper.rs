//! The paper's pipeline over a recorded run (`[MaglevUKF2024]`, §2, eq. (19)), and the raw
//! average it is compared with.
//!
//! Per telegram `k ≥ 1` (time `k·Δt`) the train knows the four raw speeds
//! `v_i(k − 1) = (P_i(k) − P_i(k − 1))/Δt` of eq. (2) (the paper's `t = k`). Then:
//!
//! 1. [`PaperFusion`]`::<4>`: Grubbs' test on the four, the rejected one replaced by the
//!    best-supported reading, the adaptive inverse-variance weights of eqs. (9)–(11) and
//!    the fused speed `V(t) = Σ w_i(t)·v_i(t)` (eq. (19));
//! 2. the paper's UKF on `V`: one state, the speed, as a random walk, measured directly —
//!    [`LinearGaussian`] with `A = [1]`, `B` of shape 1 × 0 (no input), `H = [1]`;
//!    `Q = 0.01`, `R = 0.1`, `Δt = 0.02 s`, `α = 1e-3`, `β = 2`, `κ = 0` (§2.2). The
//!    paper gives no prior; ours is the first fused speed with variance `R`, and the
//!    first filtered speed is that prior (not updated with the reading it came from).
//!    Every later telegram is one predict over `Δt` and one update with `V`.
//!
//!    The filter is the crate's scaled UKF (`estimator::points::unscented`,
//!    `estimator::filter::sigma_point`): the standard weights of Wan & van der Merwe,
//!    `W_0^m = λ/(n + λ)` for the mean, `W_0^c = λ/(n + λ) + 1 − α² + β` for the
//!    covariance, `1/(2(n + λ))` for the `2n` other points, the means (`x̂`, `ẑ`) taken
//!    with `W^m` and every covariance (`P`, `P_zz`, `P_xz`) with `W^c`. The seed's
//!    weights (15) read the same in our copy of its text, but eq. (17) forms `P_zz` with
//!    the mean weights `W_a` (a swap in its eq. (15)). On
//!    this model the difference vanishes: `n = 1`, `α = 1e-3` give `λ = −0.999 999`,
//!    `W_0^m = −999 999`, `W_0^c = −999 996`, `W_l = 500 000`, and with `f` and `g` linear
//!    the centre point sits exactly on the mean, so its weight multiplies a zero deviation
//!    and only the equal outer weights count. The UKF here *is* the scalar Kalman filter
//!    (the tests check it to 1e-6 m/s), its gain settling at `≈ 0.27`, the Riccati fixed
//!    point of `Q = 0.01`, `R = 0.1`.
//!
//! **Position.** The paper's pipeline estimates no position beyond the channels' own: its
//! position at telegram `k` is here the mean of the four channel positions there (the raw
//! average), `P̄(k) = ¼·Σ_i P_i(k)`; the levers cancel in the mean (head +25 m, tail
//! −25 m), so it reads the reference point's position, with a quarter of each channel's
//! faults in it.
//!
//! **Raw average.** The baseline the paper calls the measured speed (§3.1, "由测速定位系统
//! 传感器测量值直接平均处理计算得到的车速值"): the plain mean of the four raw speeds.
//!
//! Every series of a [`PaperRun`] has one entry per speed sample `a = 0 … n − 2`, known
//! at telegram `a + 1`, time `(a + 1)·Δt`.

use estimator::fusion::{ChannelStatus, GrubbsSettings, PaperFusion};
use estimator::models::LinearGaussian;
use estimator::{build_filter, FilterError, FilterKind, Gaussian, Noise, UnscentedParams};
use nalgebra::DMatrix;

use truth::s4::channels::Channel;
use truth::s4::recording::Recording;

/// The paper's tuning (§2.1 and §2.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperSettings {
    /// Grubbs' test: the paper states neither its level nor whether it retests; the
    /// default is one pass at `α = 0.05` (`estimator::fusion::grubbs`).
    pub grubbs: GrubbsSettings,
    /// The unscented transform: `α = 1e-3`, `β = 2`, `κ = 0`.
    pub unscented: UnscentedParams,
    /// Process noise variance `Q` ((m/s)² per telegram): 0.01.
    pub process_noise: f64,
    /// Measurement noise variance `R` ((m/s)²): 0.1.
    pub measurement_noise: f64,
}

impl Default for PaperSettings {
    fn default() -> Self {
        Self {
            grubbs: GrubbsSettings::default(),
            unscented: UnscentedParams { alpha: 1e-3, beta: 2.0, kappa: 0.0 },
            process_noise: 0.01,
            measurement_noise: 0.1,
        }
    }
}

/// The paper's pipeline over one recording: one entry per speed sample `a`, known at
/// telegram `a + 1`.
#[derive(Debug, Clone, PartialEq)]
pub struct PaperRun {
    /// The time each sample is known, `(a + 1)·Δt` (s).
    pub time: Vec<f64>,
    /// The four raw speeds `v_i(a)` (m/s), in [`Channel::ALL`]'s order.
    pub raw: Vec<[f64; 4]>,
    /// Their plain mean (m/s): the baseline.
    pub raw_average: Vec<f64>,
    /// The fused speed `V` of eq. (19) (m/s); NaN where no channel was present.
    pub fused: Vec<f64>,
    /// The UKF's speed (m/s); NaN before the first fused speed.
    pub filtered: Vec<f64>,
    /// The UKF's variance of it ((m/s)²).
    pub filtered_variance: Vec<f64>,
    /// The weights `w_i` of eq. (10).
    pub weights: Vec<[f64; 4]>,
    /// What became of each channel's reading: used, replaced (with its donor), missing.
    pub status: Vec<[ChannelStatus; 4]>,
    /// `true` where Grubbs' test rejected the channel's reading (and it was replaced).
    pub rejected: Vec<[bool; 4]>,
    /// The position at telegram `a + 1` (m): the mean of the four channel positions.
    pub position: Vec<f64>,
}

impl PaperRun {
    /// How many speed samples (`n − 1` for `n` telegrams).
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True for a recording of fewer than two telegrams.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The telegram at which sample `a` is known: `a + 1`.
    pub fn telegram(a: usize) -> usize {
        a + 1
    }

    /// The rejections per telegram, `n` entries (telegram 0, with no speed, flags
    /// nothing): the flags [`crate::s4::metrics::score_detection`] takes.
    pub fn flags_by_telegram(&self) -> Vec<[bool; 4]> {
        std::iter::once([false; 4]).chain(self.rejected.iter().copied()).collect()
    }
}

/// The plain mean of the four raw speeds, per sample `a` (known at telegram `a + 1`).
pub fn raw_average(recording: &Recording) -> Vec<f64> {
    let raw = Channel::ALL.map(|c| recording.raw_speed(c));
    (0..recording.n_telegrams().saturating_sub(1)).map(|a| raw.iter().map(|v| v[a]).sum::<f64>() / 4.0).collect()
}

/// The mean of the four channel positions at every telegram (`n` values, m).
pub fn raw_average_position(recording: &Recording) -> Vec<f64> {
    (0..recording.n_telegrams()).map(|k| recording.position.iter().map(|p| p[k]).sum::<f64>() / 4.0).collect()
}

/// The paper's UKF on the fused speed: a random walk of the speed, measured directly.
fn paper_ukf(settings: &PaperSettings, first_speed: f64) -> Result<Box<dyn estimator::StateEstimator>, FilterError> {
    let model =
        LinearGaussian::new(DMatrix::from_element(1, 1, 1.0), DMatrix::zeros(1, 0), DMatrix::from_element(1, 1, 1.0));
    let noise = Noise::diagonal(&[settings.process_noise], &[settings.measurement_noise])?;
    let prior = Gaussian::diagonal(&[first_speed], &[settings.measurement_noise]);
    build_filter(FilterKind::Ukf, model, noise, &prior, settings.unscented)
}

/// Runs the paper's pipeline over `recording`: fusion per telegram, then the UKF.
/// Fails only on settings the fusion or the filter refuse.
pub fn run_paper(recording: &Recording, settings: &PaperSettings) -> Result<PaperRun, FilterError> {
    let n_samples = recording.n_telegrams().saturating_sub(1);
    let dt = recording.telegram_interval;
    let raw_by_channel = Channel::ALL.map(|c| recording.raw_speed(c));
    let positions = raw_average_position(recording);
    let mut fusion = PaperFusion::<4>::new(settings.grubbs)?;
    let mut filter: Option<Box<dyn estimator::StateEstimator>> = None;
    let mut run = PaperRun {
        time: Vec::with_capacity(n_samples),
        raw: Vec::with_capacity(n_samples),
        raw_average: Vec::with_capacity(n_samples),
        fused: Vec::with_capacity(n_samples),
        filtered: Vec::with_capacity(n_samples),
        filtered_variance: Vec::with_capacity(n_samples),
        weights: Vec::with_capacity(n_samples),
        status: Vec::with_capacity(n_samples),
        rejected: Vec::with_capacity(n_samples),
        position: Vec::with_capacity(n_samples),
    };
    for a in 0..n_samples {
        let raw: [f64; 4] = std::array::from_fn(|c| raw_by_channel[c][a]);
        let sample = fusion.fuse(&raw);
        let fused = sample.speed();
        match (&mut filter, fused) {
            (Some(f), Some(v)) => {
                f.predict(&[], dt)?;
                f.update(&[v])?;
            }
            (Some(f), None) => f.predict(&[], dt)?,
            (None, Some(v)) => filter = Some(paper_ukf(settings, v)?),
            (None, None) => {}
        }
        run.time.push(recording.time(PaperRun::telegram(a)));
        run.raw.push(raw);
        run.raw_average.push(raw.iter().sum::<f64>() / 4.0);
        run.fused.push(fused.unwrap_or(f64::NAN));
        run.filtered.push(filter.as_ref().map_or(f64::NAN, |f| f.mean()[0]));
        run.filtered_variance.push(filter.as_ref().map_or(f64::NAN, |f| f.variance(0)));
        run.weights.push(sample.weights());
        run.status.push(sample.status);
        run.rejected.push(sample.rejected());
        run.position.push(positions[PaperRun::telegram(a)]);
    }
    Ok(run)
}
