//! Study S4: a maglev train's motion along the guideway and its four long-stator (PRW)
//! position channels, each with its own offset (`[MaglevUKF2024]`; `docs/studies/s4.md`).
//!
//! The state is the reference point's position `s`, speed `v` and acceleration `a`, a
//! constant acceleration driven by white jerk (the continuous Wiener-process acceleration
//! model, Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and
//! Navigation*, 2001, §6.2.3), and the offsets `d₁..d₄` of the four channels, random
//! constants with an optional small random walk:
//!
//! ```text
//! s' = s + v·Δt + a·Δt²/2     v' = v + a·Δt     a' = a     (+ jerk noise, exact)
//! dᵢ' = dᵢ                                                    (+ offset walk)
//! zᵢ  = s + leverᵢ + dᵢ        i = 0..3 (head-left, head-right, tail-left, tail-right)
//! z₄  = s                      (optional: an absolute marker; NaN when none passes)
//! ```
//!
//! **Why the offsets are states.** Each channel reads its sensor's position, the
//! reference position plus a known lever, plus an installation offset of 10–50 mm
//! (our estimate, `docs/studies/s4.md`) and, after a slot slip, ±86 mm more, against a noise of 1.5 mm. A
//! model without them would see a channel 10–50 mm away from the others, 7–30σ: the
//! innovation gate would reject whole channels for good, or, with `R` opened to let them
//! in, the four would be averaged into one 30 mm-wide blur. As states, the differences
//! between channels are learnt within a few telegrams and each channel is gated on its
//! own noise.
//!
//! **What stays unknown.** Without a marker the four rows see `s + dᵢ` only: adding `δ` to
//! `s` and `−δ` to every `dᵢ` changes no measurement and no prediction (the direction
//! `u = (1, 0, 0, −1, −1, −1, −1)` has `H·u = 0` and `F·u = u`). The common part of the
//! offsets therefore stays at its prior (each `dᵢ ~ N(0, σ²)`, so their mean has σ/2),
//! and `s` is the reference position as the four channels see it on average: the true
//! one plus the mean of the installation offsets. A marker row (`z₄ = s`, at a known
//! absolute position) observes that direction and pins it.

use nalgebra::DMatrix;

use crate::error::FilterError;
use crate::model::{Component, Observation, Process};
use crate::noise::Noise;

/// The train and its four position channels as the estimator knows them, with the
/// noise tuning of one filter: see the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrwTrain {
    /// Each channel's sensor position ahead of the reference point along the train (m):
    /// the channel reads the reference position plus this (plus its offset).
    pub levers: [f64; 4],
    /// Whether the measurement has a fifth row, an absolute marker reading `s`.
    pub marker: bool,
    /// Continuous-time intensity of the white jerk driving the acceleration (m²/s⁵):
    /// over `Δt` the acceleration wanders by `√(q·Δt)` (1σ).
    pub jerk_intensity: f64,
    /// Continuous-time intensity of the offsets' random walk (m²/s); 0 makes them
    /// random constants.
    pub offset_walk: f64,
    /// Standard deviation of one channel's position noise (m), the sensor's
    /// specification: `R = σ²` for each of the four rows.
    pub channel_noise_std: f64,
    /// Standard deviation of a marker reading (m), for the fifth row.
    pub marker_noise_std: f64,
}

impl PrwTrain {
    /// Index of the position `s` in the state.
    pub const POSITION: usize = 0;
    /// Index of the speed `v`.
    pub const SPEED: usize = 1;
    /// Index of the acceleration `a`.
    pub const ACCELERATION: usize = 2;
    /// The unknown input's state, the acceleration (traction and braking): what a jump moves.
    pub const UNKNOWN_INPUTS: [usize; 1] = [2];
    /// Index of the first channel's offset `d₁`; `d_i` is at `OFFSETS + i`.
    pub const OFFSETS: usize = 3;
    /// The state dimension.
    pub const STATES: usize = 7;
    /// Names of the state components, in order.
    pub const STATE_NAMES: [&'static str; 7] =
        ["position", "speed", "acceleration", "offset_1", "offset_2", "offset_3", "offset_4"];
    /// Row of the marker in the measurement, when there is one.
    pub const MARKER: usize = 4;

    /// Four channels with these levers, no marker; the noise tuning 0 (set it).
    pub fn new(levers: [f64; 4]) -> Self {
        Self {
            levers,
            marker: false,
            jerk_intensity: 0.0,
            offset_walk: 0.0,
            channel_noise_std: 0.0,
            marker_noise_std: 0.0,
        }
    }

    /// The exact discretisation over `dt` of the continuous process noise: the jerk
    /// `q` through the kinematic chain, `∫₀^Δt e^{Aτ}·G·q·Gᵀ·e^{Aᵀτ} dτ` with
    /// `e^{Aτ}·G = (τ²/2, τ, 1)`, i.e.
    ///
    /// ```text
    /// q·[Δt⁵/20  Δt⁴/8  Δt³/6]
    ///   [Δt⁴/8   Δt³/3  Δt²/2]
    ///   [Δt³/6   Δt²/2  Δt   ]
    /// ```
    ///
    /// and `offset_walk·Δt` on each offset (`7 × 7`).
    pub fn process_noise(&self, dt: f64) -> DMatrix<f64> {
        let q = self.jerk_intensity;
        let (t2, t3) = (dt * dt, dt * dt * dt);
        let (t4, t5) = (t2 * t2, t2 * t3);
        let mut m = DMatrix::zeros(Self::STATES, Self::STATES);
        let block = [[t5 / 20.0, t4 / 8.0, t3 / 6.0], [t4 / 8.0, t3 / 3.0, t2 / 2.0], [t3 / 6.0, t2 / 2.0, dt]];
        for (i, row) in block.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                m[(i, j)] = q * v;
            }
        }
        for i in Self::OFFSETS..Self::STATES {
            m[(i, i)] = self.offset_walk * dt;
        }
        m
    }

    /// The measurement noise: `channel_noise_std²` on the four channels, and
    /// `marker_noise_std²` on the marker row if there is one.
    pub fn measurement_noise(&self) -> DMatrix<f64> {
        let m = self.measurement_dim();
        let mut r = DMatrix::zeros(m, m);
        for i in 0..4 {
            r[(i, i)] = self.channel_noise_std * self.channel_noise_std;
        }
        if self.marker {
            r[(Self::MARKER, Self::MARKER)] = self.marker_noise_std * self.marker_noise_std;
        }
        r
    }

    /// Each channel's share in the correction of the speed by a telegram of all the
    /// channels `included`: `|K_v,i| / Σⱼ |K_v,j|` with `K = P·Hᵀ·(H·P·Hᵀ + R)⁻¹` from the
    /// covariance `p` (`7 × 7`, or larger with the state first) and the channels' noise
    /// variances `r` over those rows; 0 for a channel not included, and for all when none
    /// is, when `H·P·Hᵀ + R` is singular, and when a telegram would not correct the speed
    /// at all (the speed uncorrelated with the positions, as in a diagonal prior: shares of
    /// nothing, which rounding alone would otherwise decide). With the four in, equally
    /// noisy and their offsets learnt, each weighs about ¼.
    pub fn speed_weights(p: &DMatrix<f64>, r: [f64; 4], included: [bool; 4]) -> [f64; 4] {
        // Row i of H is e_s + e_dᵢ: P·Hᵀ's column i and H·P·Hᵀ's entries from P directly;
        // a channel left out is decoupled (identity in S, zero in P·Hᵀ).
        let (s, v) = (Self::POSITION, Self::SPEED);
        let d = |i: usize| Self::OFFSETS + i;
        let mut innovation = nalgebra::Matrix4::<f64>::identity();
        let mut speed_cross = nalgebra::RowVector4::<f64>::zeros();
        for i in (0..4).filter(|&i| included[i]) {
            speed_cross[i] = p[(v, s)] + p[(v, d(i))];
            for j in (0..4).filter(|&j| included[j]) {
                innovation[(i, j)] = p[(s, s)] + p[(s, d(j))] + p[(d(i), s)] + p[(d(i), d(j))];
            }
            innovation[(i, i)] += r[i];
        }
        let mut weights = [0.0; 4];
        let Some(inverse) = innovation.try_inverse() else { return weights };
        let gain = speed_cross * inverse;
        let total: f64 = (0..4).filter(|&i| included[i]).map(|i| gain[i].abs()).sum();
        // A gain's scale: a speed correlated fully with channel i has |K_v,i| up to
        // √(P_vv / S_ii); below 10⁻⁹ of it the correlation is rounding, not information.
        let scale: f64 = (0..4).filter(|&i| included[i]).map(|i| (p[(v, v)] / innovation[(i, i)]).sqrt()).sum();
        if total > 1e-9 * scale && total.is_finite() {
            for i in (0..4).filter(|&i| included[i]) {
                weights[i] = gain[i].abs() / total;
            }
        }
        weights
    }

    /// The mean speed over the last `dt` (the paper's `ΔP/Δt`, on the fused position)
    /// from the state `x` and its covariance `p`: `v − a·Δt/2`, exact under the model's
    /// constant acceleration, with its standard deviation `√(P_vv − Δt·P_va + Δt²/4·P_aa)`.
    pub fn interval_speed(x: &[f64], p: &DMatrix<f64>, dt: f64) -> (f64, f64) {
        let (v, a) = (Self::SPEED, Self::ACCELERATION);
        let mean = x[v] - x[a] * dt / 2.0;
        let variance = p[(v, v)] - dt * p[(v, a)] + dt * dt / 4.0 * p[(a, a)];
        (mean, variance.max(0.0).sqrt())
    }

    /// Per measurement row, the state that carries its bias: each channel's offset (its
    /// slot slips are steps of that state, `QuantizedSteps`); the marker has none.
    pub fn bias_states(&self) -> Vec<Option<usize>> {
        (0..self.measurement_dim()).map(|row| (row < 4).then_some(Self::OFFSETS + row)).collect()
    }

    /// `Q` over `dt` and `R`, for a filter that steps every `dt`.
    pub fn noise(&self, dt: f64) -> Result<Noise, FilterError> {
        Noise::new(self.process_noise(dt), self.measurement_noise())
    }

    /// The transition lane by lane: `L = 1` for one point, or a block of points.
    #[inline(always)]
    fn transition_lanes<const L: usize>(dt: f64, x: &[[f64; L]], x_next: &mut [[f64; L]]) {
        let half_dt2 = dt * dt / 2.0;
        for l in 0..L {
            let (s, v, a) = (x[0][l], x[1][l], x[2][l]);
            x_next[0][l] = s + v * dt + a * half_dt2;
            x_next[1][l] = v + a * dt;
            x_next[2][l] = a;
        }
        x_next[Self::OFFSETS..Self::STATES].copy_from_slice(&x[Self::OFFSETS..Self::STATES]);
    }

    /// The measurement lane by lane.
    #[inline(always)]
    fn observe_lanes<const L: usize>(&self, x: &[[f64; L]], z: &mut [[f64; L]]) {
        for (i, (zi, lever)) in z.iter_mut().zip(self.levers).enumerate() {
            for l in 0..L {
                zi[l] = x[Self::POSITION][l] + lever + x[Self::OFFSETS + i][l];
            }
        }
        if self.marker {
            z[Self::MARKER] = x[Self::POSITION];
        }
    }
}

impl Process for PrwTrain {
    fn state_dim(&self) -> usize {
        Self::STATES
    }

    fn transition(&mut self, _t: f64, dt: f64, x: &[f64], _u: &[f64], x_next: &mut [f64]) {
        Self::transition_lanes::<1>(dt, x.as_chunks().0, x_next.as_chunks_mut().0);
    }

    #[inline(always)]
    fn transition_block(
        &mut self,
        _t: f64,
        dt: f64,
        x: &[Component],
        _u: &[f64],
        x_next: &mut [Component],
        _scratch: &mut [f64],
    ) {
        Self::transition_lanes(dt, x, x_next);
    }
}

impl Observation for PrwTrain {
    fn measurement_dim(&self) -> usize {
        if self.marker {
            5
        } else {
            4
        }
    }

    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.observe_lanes::<1>(x.as_chunks().0, z.as_chunks_mut().0);
    }

    #[inline(always)]
    fn observe_block(&self, _t: f64, x: &[Component], _u: &[f64], z: &mut [Component], _scratch: &mut [f64]) {
        self.observe_lanes(x, z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::BLOCK_POINTS;
    use crate::{Gaussian, SquareRootCubature, StateEstimator};

    fn train() -> PrwTrain {
        PrwTrain {
            jerk_intensity: 3.0,
            offset_walk: 1e-8,
            channel_noise_std: 1.5e-3,
            marker_noise_std: 0.01,
            ..PrwTrain::new([25.0, 25.0, -25.0, -25.0])
        }
    }

    #[test]
    fn the_process_noise_is_the_integral_of_the_jerk_through_the_chain_and_positive_definite() {
        let model = train();
        let dt = 0.02;
        let q = model.process_noise(dt);
        // Simpson's rule on ∫₀^Δt e^{Aτ}·G·q·Gᵀ·e^{Aᵀτ} dτ, e^{Aτ}·G = (τ²/2, τ, 1):
        // exact on the entries of degree ≤ 3, and within (2/3)/n⁴ relative on the τ⁴ one
        // (4e-10 at n = 200 panels).
        let panels = 200;
        let h = dt / panels as f64;
        let mut integral = DMatrix::<f64>::zeros(3, 3);
        for k in 0..=panels {
            let tau = k as f64 * h;
            let weight = if k == 0 || k == panels {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            } * h
                / 3.0;
            let g = nalgebra::Vector3::new(tau * tau / 2.0, tau, 1.0);
            integral += weight * model.jerk_intensity * g * g.transpose();
        }
        for i in 0..3 {
            for j in 0..3 {
                let scale = integral[(i, j)].abs();
                assert!((q[(i, j)] - integral[(i, j)]).abs() <= 1e-9 * scale, "({i}, {j}): {} vs {}", q[(i, j)], scale);
            }
        }
        for i in PrwTrain::OFFSETS..PrwTrain::STATES {
            assert_eq!(q[(i, i)], model.offset_walk * dt);
        }
        // Positive definite: the Cholesky factorisation exists (kinematic block alone, and
        // all seven with the offsets' walk).
        assert!(q.view((0, 0), (3, 3)).into_owned().cholesky().is_some());
        assert!(q.clone().cholesky().is_some());
        assert!(model.noise(dt).is_ok());
        // Without the walk the offsets take no noise: PSD, which Noise accepts.
        let constant = PrwTrain { offset_walk: 0.0, ..model };
        assert!(constant.noise(dt).is_ok());
    }

    #[test]
    fn a_noise_free_constant_acceleration_is_predicted_exactly() {
        let mut model = train();
        let (s0, v0, a) = (12.0, 5.6, -2.5);
        let offsets = [0.03, -0.02, 0.01, -0.045];
        let mut x = vec![s0, v0, a, offsets[0], offsets[1], offsets[2], offsets[3]];
        let dt = 0.02;
        let mut next = vec![0.0; 7];
        for k in 1..=100 {
            model.transition(0.0, dt, &x, &[], &mut next);
            std::mem::swap(&mut x, &mut next);
            let t = k as f64 * dt;
            let s = s0 + v0 * t + a * t * t / 2.0;
            assert!((x[0] - s).abs() < 1e-12, "step {k}: {} vs {s}", x[0]);
            assert!((x[1] - (v0 + a * t)).abs() < 1e-12);
            assert_eq!(x[2], a);
            assert_eq!(&x[3..], &offsets);
        }
    }

    #[test]
    fn each_channel_reads_the_position_plus_its_lever_and_offset_and_the_marker_the_position() {
        let model = PrwTrain { marker: true, ..train() };
        let x = [100.0, 5.0, 0.0, 0.01, 0.02, 0.03, 0.04];
        let mut z = [0.0; 5];
        model.observe(0.0, &x, &[], &mut z);
        assert_eq!(z, [125.01, 125.02, 75.03, 75.04, 100.0]);
        assert_eq!(model.measurement_dim(), 5);
        assert_eq!(train().measurement_dim(), 4);
        assert_eq!(model.measurement_noise()[(4, 4)], 1e-4);
    }

    #[test]
    fn the_speed_weights_are_the_gain_s_shares_and_leave_out_what_is_excluded() {
        let r = [1.5e-3f64.powi(2); 4];
        // Learnt offsets (small σ), a loose position and speed: the four channels equal.
        let mut p = DMatrix::<f64>::zeros(7, 7);
        let diagonal = [1e-4, 1e-3, 1e-2, 1e-8, 1e-8, 1e-8, 1e-8];
        for (i, v) in diagonal.iter().enumerate() {
            p[(i, i)] = *v;
        }
        p[(0, 1)] = 2e-4;
        p[(1, 0)] = 2e-4;
        let w = PrwTrain::speed_weights(&p, r, [true; 4]);
        for wi in w {
            assert!((wi - 0.25).abs() < 1e-9, "{w:?}");
        }
        let w = PrwTrain::speed_weights(&p, r, [true, false, true, true]);
        assert_eq!(w[1], 0.0);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12 && (w[0] - 1.0 / 3.0).abs() < 1e-9, "{w:?}");
        // A channel whose offset is still unknown moves the speed less.
        p[(3, 3)] = 1e-2;
        let w = PrwTrain::speed_weights(&p, r, [true; 4]);
        assert!(w[0] < w[1] && (w[1] - w[2]).abs() < 1e-9, "{w:?}");
        // Against the gain computed with nalgebra's general inverse.
        let mut h = DMatrix::<f64>::zeros(4, 7);
        for i in 0..4 {
            h[(i, 0)] = 1.0;
            h[(i, 3 + i)] = 1.0;
        }
        let s = &h * &p * h.transpose() + DMatrix::<f64>::identity(4, 4) * 1.5e-3f64.powi(2);
        let k = &p * h.transpose() * s.try_inverse().unwrap();
        let total: f64 = (0..4).map(|i| k[(1, i)].abs()).sum();
        for i in 0..4 {
            assert!((w[i] - k[(1, i)].abs() / total).abs() < 1e-9, "{w:?}");
        }
        assert_eq!(PrwTrain::speed_weights(&p, r, [false; 4]), [0.0; 4]);
        // A diagonal prior: a telegram corrects the speed by nothing, shared by nobody,
        // also when rounding leaves a correlation of 10⁻¹⁵ (AVX2's fused roundings do).
        let mut p = DMatrix::<f64>::from_diagonal(&nalgebra::DVector::from_row_slice(&diagonal));
        assert_eq!(PrwTrain::speed_weights(&p, r, [true; 4]), [0.0; 4]);
        p[(0, 1)] = 1e-15 * (p[(0, 0)] * p[(1, 1)]).sqrt();
        p[(1, 0)] = p[(0, 1)];
        assert_eq!(PrwTrain::speed_weights(&p, r, [true; 4]), [0.0; 4]);
    }

    #[test]
    fn the_interval_speed_is_the_mean_speed_over_the_last_interval() {
        let x = [0.0, 5.6, 2.5, 0.0, 0.0, 0.0, 0.0];
        let mut p = DMatrix::<f64>::zeros(7, 7);
        p[(1, 1)] = 4e-4;
        p[(2, 2)] = 1e-2;
        p[(1, 2)] = 1e-4;
        p[(2, 1)] = 1e-4;
        let (speed, std) = PrwTrain::interval_speed(&x, &p, 0.02);
        // Over [t − Δt, t] at constant acceleration: (s(t) − s(t − Δt))/Δt = v − a·Δt/2.
        assert!((speed - (5.6 - 2.5 * 0.01)).abs() < 1e-15);
        assert!((std * std - (4e-4 - 0.02 * 1e-4 + 1e-4 * 1e-2)).abs() < 1e-18);
    }

    #[test]
    fn the_block_calls_give_the_point_calls_bit_for_bit() {
        let mut model = PrwTrain { marker: true, ..train() };
        let mut x = [[0.0; BLOCK_POINTS]; 7];
        for (i, c) in x.iter_mut().enumerate() {
            for (p, v) in c.iter_mut().enumerate() {
                *v = (i as f64 + 1.0) * 0.37 + p as f64 * 1.3e-3;
            }
        }
        let mut next = [[0.0; BLOCK_POINTS]; 7];
        let mut z = [[0.0; BLOCK_POINTS]; 5];
        model.transition_block(0.0, 0.02, &x, &[], &mut next, &mut [0.0; 14]);
        model.observe_block(0.0, &x, &[], &mut z, &mut [0.0; 12]);
        for p in 0..BLOCK_POINTS {
            let point: Vec<f64> = x.iter().map(|c| c[p]).collect();
            let (mut one_next, mut one_z) = ([0.0; 7], [0.0; 5]);
            model.transition(0.0, 0.02, &point, &[], &mut one_next);
            model.observe(0.0, &point, &[], &mut one_z);
            for i in 0..7 {
                assert_eq!(next[i][p].to_bits(), one_next[i].to_bits());
            }
            for i in 0..5 {
                assert_eq!(z[i][p].to_bits(), one_z[i].to_bits());
            }
        }
    }

    #[test]
    fn without_a_marker_the_common_offset_stays_at_its_prior_and_a_marker_pins_it() {
        // Noise-free channels with offsets; the filter learns their differences, not their mean.
        let run = |marker: bool| {
            let model = PrwTrain { marker, offset_walk: 0.0, ..train() };
            let noise = model.noise(0.02).unwrap();
            let prior = Gaussian::diagonal(
                &[0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                &[1.0, 1.0, 1.0, 2.5e-3, 2.5e-3, 2.5e-3, 2.5e-3],
            );
            let mut filter = SquareRootCubature::new(model, noise, &prior).unwrap();
            let offsets = [0.03, -0.02, 0.01, -0.045];
            for k in 1..=500 {
                filter.predict(&[], 0.02).unwrap();
                let s = 5.0 * k as f64 * 0.02;
                let mut z: Vec<f64> = (0..4).map(|i| s + model.levers[i] + offsets[i]).collect();
                if marker {
                    z.push(if k % 50 == 0 { s } else { f64::NAN });
                }
                filter.update(&z).unwrap();
            }
            // The variance along u = (1, 0, 0, −1, −1, −1, −1)/√5 and of the mean offset.
            let p = filter.covariance();
            let u = nalgebra::DVector::from_column_slice(&[1.0, 0.0, 0.0, -1.0, -1.0, -1.0, -1.0]) / 5f64.sqrt();
            let along = (u.transpose() * &p * &u)[(0, 0)];
            let mean_offset = filter.mean().rows(3, 4).sum() / 4.0;
            (along, mean_offset, filter.mean()[0] - 5.0 * 500.0 * 0.02)
        };
        let (along, mean_offset, position_error) = run(false);
        // Each offset's prior σ 0.05 m: along u the prior's variance is (1 + 4·2.5e-3)/5 at
        // first; the channels take out s's own 1 m², the offsets' part stays.
        assert!(along > 0.8 * 2.5e-3 * 4.0 / 5.0, "{along}");
        assert!(mean_offset.abs() < 1e-3, "{mean_offset}");
        // s is the reference plus the mean true offset (−6.25 mm).
        assert!((position_error + 0.00625).abs() < 1e-3, "{position_error}");
        let (along, mean_offset, position_error) = run(true);
        assert!(along < 1e-4, "{along}");
        assert!((mean_offset + 0.00625).abs() < 2e-3, "{mean_offset}");
        assert!(position_error.abs() < 2e-3, "{position_error}");
    }
}
