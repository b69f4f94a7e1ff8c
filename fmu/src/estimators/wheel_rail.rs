//! What the wheel–rail estimators (S2, S3) share: a vehicle model augmented with its
//! wheel–rail forces, its coordinates those of the car body and bogies and then of the
//! wheelsets, their velocities in the same order, then the forces; the same parameter
//! names for its process noise and its prior.

use estimator::Gaussian;

use crate::variables::Parameters;

/// The state layout: how many coordinates the car body and bogies have, how many the
/// wheelsets, and how many forces follow the velocities.
#[derive(Debug, Clone, Copy)]
pub(super) struct Layout {
    pub body: usize,
    pub wheelsets: usize,
    pub forces: usize,
}

impl Layout {
    fn states(&self) -> usize {
        2 * (self.body + self.wheelsets) + self.forces
    }

    /// The diagonal of `Q` over `dt`: the per-sample motion variances `q_body_std²` and
    /// `q_wheelset_std²` scaled by `dt / sample_time` (white noise), each force's
    /// `force_noise_intensity·dt`.
    pub fn process_noise(&self, p: &Parameters, dt: f64) -> Result<Vec<f64>, String> {
        let fraction = dt / p.positive("sample_time")?;
        let (body, wheelset) = (p.non_negative("q_body_std")?, p.non_negative("q_wheelset_std")?);
        let intensity = p.non_negative("force_noise_intensity")?;
        let mut q = Vec::with_capacity(self.states());
        for _ in 0..2 {
            q.extend(std::iter::repeat_n(body * body * fraction, self.body));
            q.extend(std::iter::repeat_n(wheelset * wheelset * fraction, self.wheelsets));
        }
        q.extend(std::iter::repeat_n(intensity * dt, self.forces));
        Ok(q)
    }

    /// The prior: at rest (`p0_motion_std` about zero), every force at the static wheel
    /// load `load` (`p0_force_std` about it).
    pub fn prior(&self, p: &Parameters, load: f64) -> Result<Gaussian, String> {
        let (motion, force) = (p.non_negative("p0_motion_std")?, p.non_negative("p0_force_std")?);
        let motion_states = self.states() - self.forces;
        let mut mean = vec![0.0; self.states()];
        mean[motion_states..].fill(load);
        let mut variances = vec![motion * motion; self.states()];
        variances[motion_states..].fill(force * force);
        Ok(Gaussian::diagonal(&mean, &variances))
    }
}

/// The plausible bound of a wheel–rail force and its σ: 100 times the static
/// wheel load (a wheel unloaded or hit by a hundred times its weight is a lost filter).
pub fn hundred_static_wheel_loads(p: &Parameters) -> Result<Option<f64>, String> {
    Ok(Some(100.0 * p.positive("static_wheel_load")?))
}
