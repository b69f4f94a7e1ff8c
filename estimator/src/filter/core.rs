//! What every filter holds besides its covariance representation: the model,
//! the noise, the clock, the held input, the mean and the update diagnostics,
//! with the argument checks every filter makes the same way.

use nalgebra::{DMatrix, DVector};

use crate::error::{check_len, FilterError, Stage};
use crate::filter::Innovation;
use crate::gaussian::Gaussian;
use crate::model::{Component, Model, BLOCK_POINTS};
use crate::noise::Noise;

#[derive(Debug, Clone)]
pub(crate) struct Core<M> {
    pub model: M,
    pub noise: Noise,
    pub t: f64,
    /// The input of the last `predict`, used by `update` (`h(t, x, u)`).
    pub u: DVector<f64>,
    pub x: DVector<f64>,
    /// The candidate mean of the step in progress, committed on success.
    pub x_next: DVector<f64>,
    pub innovation: Innovation,
    /// Row by row, the measurement `z` as passed to `update`.
    pub z: DVector<f64>,
    /// `Cov(x(t), x(t + dt))` of the last prediction, once a smoother asked
    /// for it ([`StateEstimator::keep_cross_covariance`](crate::StateEstimator::keep_cross_covariance)).
    pub cross: Option<nalgebra::DMatrix<f64>>,
    /// Scratch of the model differences: a probe state and the model's
    /// values at `x̂ + δ` and `x̂` (each `max(n, m)` long).
    probes: [Vec<f64>; 3],
    /// Blocks of offset states for the transition differences.
    probe_blocks: ProbeBlocks,
}

/// A block of states and its transition, with the model's scratch.
#[derive(Debug, Clone)]
struct ProbeBlocks {
    x: Vec<Component>,
    y: Vec<Component>,
    scratch: Vec<f64>,
}

impl<M: Model> Core<M> {
    pub fn new(model: M, noise: Noise, t0: f64, prior: &Gaussian) -> Result<Self, FilterError> {
        // Here and not in a step: reading the environment allocates.
        crate::linalg::read_environment();
        let n = model.state_dim();
        let m = model.measurement_dim();
        check_len("process noise Q", n, noise.state_dim())?;
        check_len("measurement noise R", m, noise.measurement_dim())?;
        prior.validate(n)?;
        if !t0.is_finite() {
            return Err(FilterError::InvalidSetting(format!("initial time must be finite, got {t0}")));
        }
        Ok(Self {
            u: DVector::zeros(model.input_dim()),
            x: prior.mean.clone(),
            x_next: DVector::zeros(n),
            innovation: Innovation::new(m),
            z: DVector::zeros(m),
            cross: None,
            probes: std::array::from_fn(|_| vec![0.0; n.max(m)]),
            probe_blocks: ProbeBlocks {
                x: vec![[0.0; BLOCK_POINTS]; n],
                y: vec![[0.0; BLOCK_POINTS]; n],
                scratch: vec![0.0; 2 * n + m],
            },
            model,
            noise,
            t: t0,
        })
    }

    pub fn n(&self) -> usize {
        self.x.len()
    }

    pub fn m(&self) -> usize {
        self.z.len()
    }

    /// Checks `u` and `dt` and holds `u` for the update.
    pub fn begin_predict(&mut self, u: &[f64], dt: f64) -> Result<(), FilterError> {
        check_len("input u", self.u.len(), u.len())?;
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(FilterError::InvalidSetting(format!(
                "predict: time step must be positive and finite, got {dt}"
            )));
        }
        if u.iter().any(|v| !v.is_finite()) {
            return Err(FilterError::NonFinite { stage: Stage::Predict, quantity: "input u" });
        }
        self.u.copy_from_slice(u);
        Ok(())
    }

    /// Checks `u` and holds it for the next update.
    pub fn hold_input(&mut self, u: &[f64]) -> Result<(), FilterError> {
        check_len("input u", self.u.len(), u.len())?;
        if u.iter().any(|v| !v.is_finite()) {
            return Err(FilterError::NonFinite { stage: Stage::Update, quantity: "input u" });
        }
        self.u.copy_from_slice(u);
        Ok(())
    }

    /// Checks `z`, keeps a copy and selects its usable rows; returns their number.
    pub fn begin_update(&mut self, z: &[f64]) -> Result<usize, FilterError> {
        check_len("measurement z", self.m(), z.len())?;
        self.z.copy_from_slice(z);
        Ok(self.innovation.select_rows(z))
    }

    /// See [`StateEstimator::transition_differences`](crate::StateEstimator::transition_differences).
    /// The offset states go through the model in blocks, as sigma points do.
    pub fn transition_differences(
        &mut self,
        u: &[f64],
        dt: f64,
        offsets: &mut DMatrix<f64>,
    ) -> Result<(), FilterError> {
        let n = self.n();
        check_len("input u", self.u.len(), u.len())?;
        check_len("state offsets", n, offsets.nrows())?;
        let [_, _, base] = &mut self.probes;
        self.model.transition(self.t, dt, self.x.as_slice(), u, &mut base[..n]);
        let blocks = &mut self.probe_blocks;
        let mut lanes = [usize::MAX; BLOCK_POINTS];
        let mut filled = 0;
        for j in 0..=offsets.ncols() {
            let last = j == offsets.ncols();
            if !last && offsets.column(j).iter().any(|v| *v != 0.0) {
                for i in 0..n {
                    blocks.x[i][filled] = self.x[i] + offsets[(i, j)];
                }
                lanes[filled] = j;
                filled += 1;
            }
            if filled == BLOCK_POINTS || (last && filled > 0) {
                for (i, component) in blocks.x.iter_mut().enumerate() {
                    component[filled..].fill(self.x[i]);
                }
                self.model.transition_block(self.t, dt, &blocks.x, u, &mut blocks.y, &mut blocks.scratch);
                for (lane, &column) in lanes[..filled].iter().enumerate() {
                    for i in 0..n {
                        offsets[(i, column)] = blocks.y[i][lane] - base[i];
                    }
                }
                filled = 0;
            }
        }
        ensure_finite(offsets.as_slice(), Stage::Predict, "transition differences")
    }

    /// See [`StateEstimator::observation_differences`](crate::StateEstimator::observation_differences).
    pub fn observation_differences(
        &mut self,
        offsets: &DMatrix<f64>,
        out: &mut DMatrix<f64>,
    ) -> Result<(), FilterError> {
        let (n, m) = (self.n(), self.m());
        check_len("state offsets", n, offsets.nrows())?;
        check_len("observation differences", m, out.nrows())?;
        check_len("observation differences' columns", offsets.ncols(), out.ncols())?;
        let [probe, plus, base] = &mut self.probes;
        self.model.observe(self.t, self.x.as_slice(), self.u.as_slice(), &mut base[..m]);
        for (column, mut response) in offsets.column_iter().zip(out.column_iter_mut()) {
            if column.iter().all(|v| *v == 0.0) {
                response.fill(0.0);
                continue;
            }
            for i in 0..n {
                probe[i] = self.x[i] + column[i];
            }
            self.model.observe(self.t, &probe[..n], self.u.as_slice(), &mut plus[..m]);
            for r in 0..m {
                response[r] = plus[r] - base[r];
            }
        }
        ensure_finite(out.as_slice(), Stage::Update, "observation differences")
    }

    pub fn check_noise(&self, noise: &Noise) -> Result<(), FilterError> {
        check_len("process noise Q", self.n(), noise.state_dim())?;
        check_len("measurement noise R", self.m(), noise.measurement_dim())
    }

    pub fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError> {
        prior.validate(self.n())?;
        if !t0.is_finite() {
            return Err(FilterError::InvalidSetting(format!("initial time must be finite, got {t0}")));
        }
        self.t = t0;
        self.x.copy_from(&prior.mean);
        self.u.fill(0.0);
        self.innovation.record_none();
        Ok(())
    }
}

impl<M: Model> Core<M> {
    /// Writes the snapshot, with `covariance` the filter's own representation,
    /// into `out`'s buffers.
    pub fn snapshot_into(
        &self,
        kind: crate::filter::FilterKind,
        covariance: &nalgebra::DMatrix<f64>,
        out: &mut crate::filter::Snapshot,
    ) {
        let copy = |to: &mut Vec<f64>, from: &[f64]| {
            to.clear();
            to.extend_from_slice(from);
        };
        out.kind = kind;
        out.time = self.t;
        copy(&mut out.input, self.u.as_slice());
        copy(&mut out.mean, self.x.as_slice());
        copy(&mut out.covariance, covariance.as_slice());
    }

    /// Restores time, input and mean; returns the covariance part for the filter.
    /// For [`StateEstimator::mix_with`](crate::StateEstimator::mix_with):
    /// checks `other` and `weight`, writes `d = x − x_o` into `x_next`
    /// (scratch between steps) and returns `other`'s covariance words; the
    /// mean is mixed by [`Core::mix_mean`] once the covariance is.
    pub fn mix_difference<'a>(
        &mut self,
        kind: crate::filter::FilterKind,
        other: &'a crate::filter::Snapshot,
        weight: f64,
    ) -> Result<&'a [f64], FilterError> {
        crate::filter::check_weight(weight)?;
        other.check(kind, self.n(), self.u.len())?;
        for ((d, x), o) in self.x_next.iter_mut().zip(self.x.iter()).zip(&other.mean) {
            *d = x - o;
        }
        Ok(&other.covariance)
    }

    /// The mean of the mixture: `w·x + (1 − w)·x_o`.
    pub fn mix_mean(&mut self, other: &crate::filter::Snapshot, weight: f64) {
        for (x, o) in self.x.iter_mut().zip(&other.mean) {
            *x = weight * *x + (1.0 - weight) * o;
        }
    }

    /// [`StateEstimator::mix_with`](crate::StateEstimator::mix_with) for a
    /// filter that keeps `P` itself (`p`; `scratch` of its size takes the
    /// mixture and is swapped in once it is finite).
    pub fn mix_covariance(
        &mut self,
        kind: crate::filter::FilterKind,
        p: &mut nalgebra::DMatrix<f64>,
        scratch: &mut nalgebra::DMatrix<f64>,
        other: &crate::filter::Snapshot,
        weight: f64,
    ) -> Result<(), FilterError> {
        let other_p = self.mix_difference(kind, other, weight)?;
        let n = self.n();
        let spread = weight * (1.0 - weight);
        let d = self.x_next.as_slice();
        let mixed = scratch.as_mut_slice();
        for j in 0..n {
            for i in 0..n {
                let k = j * n + i;
                mixed[k] = weight * p.as_slice()[k] + (1.0 - weight) * other_p[k] + spread * d[i] * d[j];
            }
        }
        crate::filter::core::ensure_finite(
            scratch.as_slice(),
            crate::error::Stage::Update,
            "covariance P of the mixture",
        )?;
        std::mem::swap(p, scratch);
        self.mix_mean(other, weight);
        Ok(())
    }

    /// [`StateEstimator::add_process_noise`](crate::StateEstimator::add_process_noise)
    /// for a filter that keeps `P` itself (`scratch` of its size takes the sum
    /// and is swapped in once it is finite).
    pub fn add_process_noise_to(
        &self,
        p: &mut nalgebra::DMatrix<f64>,
        scratch: &mut nalgebra::DMatrix<f64>,
        factor: f64,
        states: &[bool],
    ) -> Result<(), FilterError> {
        let n = self.n();
        crate::filter::check_process_noise_factor(factor, states, n)?;
        let q = self.noise.q();
        scratch.copy_from(p);
        for j in (0..n).filter(|&j| crate::filter::selected(states, j)) {
            for i in (0..n).filter(|&i| crate::filter::selected(states, i)) {
                scratch[(i, j)] += factor * q[(i, j)];
            }
        }
        let what = "covariance P with the added process noise";
        crate::filter::core::ensure_finite(scratch.as_slice(), crate::error::Stage::Predict, what)?;
        std::mem::swap(p, scratch);
        Ok(())
    }

    pub fn restore<'a>(
        &mut self,
        kind: crate::filter::FilterKind,
        snapshot: &'a crate::filter::Snapshot,
    ) -> Result<&'a [f64], FilterError> {
        snapshot.check(kind, self.n(), self.u.len())?;
        self.t = snapshot.time;
        self.u.copy_from_slice(&snapshot.input);
        self.x.copy_from_slice(&snapshot.mean);
        self.innovation.record_none();
        Ok(&snapshot.covariance)
    }
}

/// The `StateEstimator` methods every filter answers from its `core` field
/// alike: dimensions, time, mean, innovation and noise.
macro_rules! core_accessors {
    () => {
        fn state_dim(&self) -> usize {
            self.core.n()
        }

        fn measurement_dim(&self) -> usize {
            self.core.m()
        }

        fn time(&self) -> f64 {
            self.core.t
        }

        fn mean(&self) -> &nalgebra::DVector<f64> {
            &self.core.x
        }

        fn innovation(&self) -> &crate::filter::Innovation {
            &self.core.innovation
        }

        fn noise(&self) -> &crate::noise::Noise {
            &self.core.noise
        }

        fn set_noise(&mut self, noise: crate::noise::Noise) -> Result<(), crate::error::FilterError> {
            self.core.check_noise(&noise)?;
            self.core.noise = noise;
            Ok(())
        }

        fn set_measurement_variances(&mut self, variances: &[f64]) -> Result<(), crate::error::FilterError> {
            self.core.noise.set_r_diagonal(variances)
        }

        fn set_process_noise_scale(&mut self, scale: f64, states: &[bool]) -> Result<(), crate::error::FilterError> {
            self.core.noise.set_q_scale(scale, states)
        }

        fn hold_input(&mut self, u: &[f64]) -> Result<(), crate::error::FilterError> {
            self.core.hold_input(u)
        }

        fn transition_differences(
            &mut self,
            u: &[f64],
            dt: f64,
            offsets: &mut nalgebra::DMatrix<f64>,
        ) -> Result<(), crate::error::FilterError> {
            self.core.transition_differences(u, dt, offsets)
        }

        fn observation_differences(
            &mut self,
            offsets: &nalgebra::DMatrix<f64>,
            out: &mut nalgebra::DMatrix<f64>,
        ) -> Result<(), crate::error::FilterError> {
            self.core.observation_differences(offsets, out)
        }

        fn keep_cross_covariance(&mut self) {
            let n = self.core.n();
            self.core.cross.get_or_insert_with(|| nalgebra::DMatrix::zeros(n, n));
        }

        fn cross_covariance(&self) -> Option<&nalgebra::DMatrix<f64>> {
            self.core.cross.as_ref()
        }
    };
}
pub(crate) use core_accessors;

/// The `predict` and `update` of [`StateEstimator`](crate::StateEstimator)
/// for a filter with inherent `predict_body(lanes, u, dt)` and
/// `update_body(lanes, z)`: each body runs compiled with AVX2 and FMA when the
/// CPU has them, with the matching kernels (see `with_avx2!`).
macro_rules! steps_with_avx2 {
    (<$($g:ident: $bound:path),*> $filter:ty) => {
        fn predict(&mut self, u: &[f64], dt: f64) -> Result<(), crate::error::FilterError> {
            crate::linalg::with_avx2!(fn<$($g: $bound),*>(lanes, filter: &mut $filter = self, u: &[f64] = u, dt: f64 = dt) -> Result<(), crate::error::FilterError> {
                filter.predict_body(lanes, u, dt)
            })
        }

        fn update(&mut self, z: &[f64]) -> Result<&crate::filter::Innovation, crate::error::FilterError> {
            crate::linalg::with_avx2!(fn<$($g: $bound),*>(lanes, filter: &mut $filter = self, z: &[f64] = z) -> Result<(), crate::error::FilterError> {
                filter.update_body(lanes, z)
            })?;
            Ok(&self.core.innovation)
        }
    };
}
pub(crate) use steps_with_avx2;

/// `Err(NonFinite)` unless every value is finite.
#[inline]
pub(crate) fn ensure_finite(values: &[f64], stage: Stage, quantity: &'static str) -> Result<(), FilterError> {
    if all_finite(values) {
        Ok(())
    } else {
        Err(FilterError::NonFinite { stage, quantity })
    }
}

/// Whether every value is finite, without a branch per value: `x − x` is 0
/// for a finite `x` and NaN otherwise, so the lane sums stay 0 exactly when
/// all values are finite (the compiler vectorises the lanes).
#[allow(clippy::eq_op)] // `x − x` is the point: it is NaN for ±∞ and NaN.
#[inline]
fn all_finite(values: &[f64]) -> bool {
    const LANES: usize = 8;
    let mut acc = [0.0; LANES];
    let chunks = values.chunks_exact(LANES);
    let rest = chunks.remainder();
    for chunk in chunks {
        for l in 0..LANES {
            acc[l] += chunk[l] - chunk[l];
        }
    }
    let rest: f64 = rest.iter().map(|v| v - v).sum();
    acc.iter().sum::<f64>() + rest == 0.0
}

#[cfg(test)]
mod tests {
    use super::all_finite;

    #[test]
    fn any_nan_or_infinity_anywhere_is_found() {
        for len in [0, 1, 7, 8, 9, 33] {
            let values: Vec<f64> = (0..len).map(|i| i as f64 * 1e300 - 3e301).collect();
            assert!(all_finite(&values), "len {len}");
            for i in 0..len {
                for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let mut v = values.clone();
                    v[i] = bad;
                    assert!(!all_finite(&v), "{bad} at {i} of {len}");
                }
            }
        }
    }
}
