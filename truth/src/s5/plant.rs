//! S5's first truth, "as the paper has it": the rigid-body 6-DOF of eq. (1) on a flat,
//! non-rotating Earth in the ISA, its forces from the coefficient model (3) and its moments
//! from the moment model, integrated by RK4 at a step ten times finer than the 5 ms
//! sampling. The equations are the estimator's (`estimator::models::Airframe`): the paper's
//! truth and estimator share them, and so does this one; the outside truth with its own
//! Earth and atmosphere is JSBSim (`truth/s5_jsbsim/`).

use estimator::models::Airframe;

use super::manoeuvre::Manoeuvre;

/// The truth's state: the ten motion states of `docs/studies/s5.md`.
pub type Motion = [f64; 10];

/// The rigid body flying the manoeuvre, its coefficients switching at `change_at`.
#[derive(Debug, Clone)]
pub struct Flight {
    /// The airframe.
    pub airframe: Airframe,
    /// The coefficients before and after the change.
    pub coefficients: [[f64; 10]; 2],
    /// The rudder inputs.
    pub manoeuvre: Manoeuvre,
}

impl Flight {
    /// The coefficients in force over the sample interval `[k·T, (k+1)·T)`: taken at its
    /// middle, so that a change on the grid is never missed by a rounding of `k·T`.
    pub fn coefficients_over(&self, k: usize, sample_time: f64) -> &[f64; 10] {
        self.coefficients_at((k as f64 + 0.5) * sample_time)
    }

    /// The coefficients in force at `t`: those after the change from `change_at` on.
    pub fn coefficients_at(&self, t: f64) -> &[f64; 10] {
        &self.coefficients[usize::from(t >= self.manoeuvre.change_at)]
    }

    /// Advances `x` by one RK4 step of `dt` under the coefficients `c` and deflections
    /// `delta`.
    pub fn step(&self, c: &[f64; 10], delta: &[f64; 3], dt: f64, x: &Motion) -> Motion {
        let f = |x: &Motion| {
            let mut d = [0.0; 10];
            self.airframe.motion_derivative(x, c, delta, &mut d);
            d
        };
        let add = |x: &Motion, k: &Motion, h: f64| -> Motion { std::array::from_fn(|i| x[i] + h * k[i]) };
        let k1 = f(x);
        let k2 = f(&add(x, &k1, dt / 2.0));
        let k3 = f(&add(x, &k2, dt / 2.0));
        let k4 = f(&add(x, &k3, dt));
        std::array::from_fn(|i| x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    }

    /// The motion at every sample `k·sample_time` from `start` to the manoeuvre's end,
    /// `substeps` RK4 steps per sample: the [`FlyingPlant`] stepped sample by sample.
    /// Refused for a flight that diverges.
    pub fn fly(&self, start: &Motion, sample_time: f64, substeps: usize) -> Result<Vec<Motion>, String> {
        let samples = (self.manoeuvre.duration / sample_time).round() as usize;
        let mut plant = FlyingPlant::new(self.clone(), *start, sample_time / substeps as f64, None)?;
        let mut out = Vec::with_capacity(samples + 1);
        out.push(plant.motion());
        for _ in 0..samples {
            plant.advance(substeps)?;
            out.push(plant.motion());
        }
        Ok(out)
    }
}

/// The flight as a plant that is stepped: from a start motion at `t = 0`, advanced by whole
/// RK4 steps of `h`. Over each step the coefficients are those in force at its middle, and
/// the deflections the manoeuvre's at its middle or, when set from outside, the held ones
/// (a Co-Simulation input without derivatives). [`Flight::fly`] is this plant stepped sample
/// by sample, so a master that steps it at the sample time gets the study's truth to the bit.
#[derive(Debug, Clone)]
pub struct FlyingPlant {
    flight: Flight,
    /// Deflections set from outside (rad), in place of the manoeuvre's.
    held: Option<[f64; 3]>,
    h: f64,
    x: Motion,
    /// RK4 steps taken.
    steps: usize,
}

impl FlyingPlant {
    /// `flight` from `start` at `t = 0`, integrated with RK4 at `h` (s); its deflections
    /// `held` from outside (then settable, [`FlyingPlant::set_deflections`]) or, with
    /// `None`, the manoeuvre's.
    pub fn new(flight: Flight, start: Motion, h: f64, held: Option<[f64; 3]>) -> Result<Self, String> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(format!("the integration step must be positive, got {h}"));
        }
        check_finite("start motion", &start)?;
        if let Some(delta) = held {
            check_finite("deflections", &delta)?;
        }
        Ok(Self { flight, held, h, x: start, steps: 0 })
    }

    /// Holds the deflections `delta` (rad) over the steps that follow; a plant flying its
    /// manoeuvre refuses them.
    pub fn set_deflections(&mut self, delta: [f64; 3]) -> Result<(), String> {
        check_finite("deflections", &delta)?;
        match &mut self.held {
            Some(held) => *held = delta,
            None => return Err("the deflections follow the manoeuvre; they cannot be set".into()),
        }
        Ok(())
    }

    /// Whether the deflections are set from outside.
    pub fn holds_deflections(&self) -> bool {
        self.held.is_some()
    }

    /// RK4 steps taken since `t = 0`.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The motion now.
    pub fn motion(&self) -> Motion {
        self.x
    }

    /// Puts the plant where [`FlyingPlant::steps`] and [`FlyingPlant::motion`] said it was
    /// (a saved state): the same steps after it give the same numbers, to the bit.
    pub fn resume(&mut self, motion: Motion, steps: usize) -> Result<(), String> {
        check_finite("motion", &motion)?;
        self.x = motion;
        self.steps = steps;
        Ok(())
    }

    /// The coefficients in force over the next step.
    pub fn coefficients(&self) -> &[f64; 10] {
        self.flight.coefficients_at((self.steps as f64 + 0.5) * self.h)
    }

    /// The deflections `δx, δy, δz` (rad) over the next step.
    pub fn deflections(&self) -> [f64; 3] {
        self.held.unwrap_or_else(|| self.flight.manoeuvre.deflection((self.steps as f64 + 0.5) * self.h))
    }

    /// The twelve measurements now, noise-free, under the coefficients and deflections of
    /// the next step (the overloads depend on both).
    pub fn measurements(&self) -> [f64; 12] {
        let mut z = [0.0; 12];
        self.flight.airframe.measure(&self.x, self.coefficients(), &self.deflections(), &mut z);
        z
    }

    /// Advances `count` RK4 steps; refused, with nothing changed, when the motion would stop
    /// being finite (a flight that diverges: coefficients or a start it cannot fly).
    pub fn advance(&mut self, count: usize) -> Result<(), String> {
        let (x, steps) = (self.x, self.steps);
        for _ in 0..count {
            self.x = self.flight.step(self.coefficients(), &self.deflections(), self.h, &self.x);
            self.steps += 1;
        }
        if self.x.iter().any(|v| !v.is_finite()) {
            let diverged = self.steps as f64 * self.h;
            (self.x, self.steps) = (x, steps);
            return Err(format!("the flight diverges before t = {diverged} s: its motion is no longer finite"));
        }
        Ok(())
    }
}

fn check_finite(what: &str, values: &[f64]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(format!("the {what} must be finite, got {values:?}"))
    }
}
