//! The S1 truth simulator: the physical two-mass chain of `[Gong2024]`
//! (continuous piecewise-linear element, load on m₂) driven by a load that
//! varies continuously in time, integrated with RK4 at a fine step (1e-4 s by
//! default, 50 steps per 200 Hz sample) and sampled at the estimator rate.
//!
//! It differs from what the estimator assumes in the ways a real test does:
//! the load is not a random walk, the integration is 50× finer, and the
//! accelerometers are noisy (noise is added by the study, not here).
//!
//! The simulator is a plant that is stepped ([`ChainPlant`]): the study's batch run and
//! a master stepping it (a plant FMU) run the same code, so both give the same truth.

use estimator::models::Oscillator2Dof;

use super::load::Load;

/// The true history at the sample times `tₖ = k·dt`, `k = 0 … n` (the chain
/// starts at rest at `t = 0`, where the load already acts).
#[derive(Debug, Clone, Default)]
pub struct Truth {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// `[z₁, z₂, ż₁, ż₂]` at each sample (m, m/s).
    pub motion: Vec<[f64; 4]>,
    /// The load `F` (N).
    pub load: Vec<f64>,
    /// Its rate `Ḟ` (N/s).
    pub load_rate: Vec<f64>,
    /// The noise-free accelerations `[z̈₁, z̈₂]` (m/s²).
    pub acceleration: Vec<[f64; 2]>,
}

impl Truth {
    /// The RMS of each acceleration over the whole history (m/s²).
    pub fn acceleration_rms(&self) -> [f64; 2] {
        let n = self.acceleration.len() as f64;
        let rms = |i: usize| (self.acceleration.iter().map(|a| a[i] * a[i]).sum::<f64>() / n).sqrt();
        [rms(0), rms(1)]
    }
}

/// Where the chain's load comes from.
#[derive(Debug, Clone)]
pub enum LoadSource {
    /// A law of time (the study's loads), evaluated at every RK4 stage.
    Law(Load),
    /// A value set from outside (a master's input), held over each step: a
    /// Co-Simulation input without derivatives.
    Held(f64),
}

/// S1's chain as a plant that is stepped: at rest at `t = 0`, advanced by whole RK4
/// steps of `h`. [`simulate`] is this plant stepped sample by sample, so a master that
/// steps it gets the study's truth to the bit.
#[derive(Debug, Clone)]
pub struct ChainPlant {
    chain: Oscillator2Dof,
    source: LoadSource,
    h: f64,
    /// `[z₁, z₂, ż₁, ż₂]`.
    x: [f64; 4],
    /// RK4 steps taken.
    steps: usize,
    /// A law's values on the grid of half steps (index `2j` is `t = j·h`), from `table_first`.
    table: Vec<f64>,
    table_first: usize,
}

impl ChainPlant {
    /// Half steps tabulated at a time: a whole number of the load's anchors.
    const TABLE: usize = 8 * Load::ANCHOR;

    /// The chain at rest at `t = 0`, under `source`, integrated with RK4 at `h` (s).
    pub fn new(chain: Oscillator2Dof, source: LoadSource, h: f64) -> Result<Self, String> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(format!("the integration step must be positive, got {h}"));
        }
        if let LoadSource::Held(f) = source {
            check_load(f)?;
        }
        Ok(Self { chain, source, h, x: [0.0; 4], steps: 0, table: Vec::new(), table_first: 0 })
    }

    /// Sets a held load (N) for the steps that follow; a law's plant refuses it.
    pub fn set_load(&mut self, value: f64) -> Result<(), String> {
        check_load(value)?;
        match &mut self.source {
            LoadSource::Held(f) => *f = value,
            LoadSource::Law(_) => return Err("the load follows its law; it cannot be set".into()),
        }
        Ok(())
    }

    /// The time of the last step, `steps·h` (s).
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.h
    }

    /// RK4 steps taken since `t = 0`.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The held load (N), for a plant whose load is set from outside.
    pub fn held_load(&self) -> Option<f64> {
        match self.source {
            LoadSource::Held(f) => Some(f),
            LoadSource::Law(_) => None,
        }
    }

    /// Puts the plant where [`ChainPlant::steps`] and [`ChainPlant::motion`] said it was
    /// (a saved state): the same steps after it give the same numbers, to the bit.
    pub fn resume(&mut self, motion: [f64; 4], steps: usize) -> Result<(), String> {
        if motion.iter().any(|x| !x.is_finite()) {
            return Err(format!("the motion must be finite, got {motion:?}"));
        }
        self.x = motion;
        self.steps = steps;
        Ok(())
    }

    /// `[z₁, z₂, ż₁, ż₂]` now (m, m/s).
    pub fn motion(&self) -> [f64; 4] {
        self.x
    }

    /// The load now (N): the law at the stage grid's point, or the held value.
    pub fn load(&mut self) -> f64 {
        self.stage_load(2 * self.steps)
    }

    /// The noise-free accelerations `[z̈₁, z̈₂]` now (m/s²).
    pub fn accelerations(&mut self) -> [f64; 2] {
        let x = self.x;
        let rates = self.rates(2 * self.steps, &x);
        [rates[2], rates[3]]
    }

    /// Advances `count` RK4 steps.
    pub fn advance(&mut self, count: usize) {
        let h = self.h;
        for _ in 0..count {
            // Stage times from the step count, so time never drifts.
            let j = 2 * self.steps;
            let x = self.x;
            let k1 = self.rates(j, &x);
            let k2 = self.rates(j + 1, &add(&x, 0.5 * h, &k1));
            let k3 = self.rates(j + 1, &add(&x, 0.5 * h, &k2));
            let k4 = self.rates(j + 2, &add(&x, h, &k3));
            for i in 0..4 {
                self.x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            self.steps += 1;
        }
    }

    /// `ẋ` at the stage of half-step index `j`.
    fn rates(&mut self, j: usize, x: &[f64; 4]) -> [f64; 4] {
        let load = self.stage_load(j);
        let (a1, a2) = self.chain.accelerations(x[0], x[1], x[2], x[3], load);
        [x[2], x[3], a1, a2]
    }

    /// The load at half-step index `j`, tabulating the law a piece at a time.
    fn stage_load(&mut self, j: usize) -> f64 {
        match &self.source {
            LoadSource::Held(f) => *f,
            LoadSource::Law(law) => {
                if !(self.table_first..self.table_first + self.table.len()).contains(&j) {
                    self.table_first = j - j % Load::ANCHOR;
                    law.tabulate_into(0.0, 0.5 * self.h, self.table_first, Self::TABLE, &mut self.table);
                }
                self.table[j - self.table_first]
            }
        }
    }
}

fn check_load(value: f64) -> Result<(), String> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(format!("the load must be finite, got {value}"))
    }
}

/// Simulates `samples` samples of `dt` from rest, with `substeps` RK4 steps
/// per sample: `samples + 1` instants with the start.
pub fn simulate(chain: &Oscillator2Dof, load: &Load, dt: f64, samples: usize, substeps: usize) -> Truth {
    let mut plant =
        ChainPlant::new(*chain, LoadSource::Law(load.clone()), dt / substeps as f64).expect("a positive step");
    let mut truth = Truth::default();
    let mut record = |t: f64, plant: &mut ChainPlant| {
        truth.time.push(t);
        truth.motion.push(plant.motion());
        truth.load.push(load.value(t));
        truth.load_rate.push(load.rate(t));
        truth.acceleration.push(plant.accelerations());
    };
    record(0.0, &mut plant);
    for k in 0..samples {
        plant.advance(substeps);
        record((k + 1) as f64 * dt, &mut plant);
    }
    truth
}

fn add(x: &[f64; 4], h: f64, k: &[f64; 4]) -> [f64; 4] {
    [x[0] + h * k[0], x[1] + h * k[1], x[2] + h * k[2], x[3] + h * k[3]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plant_stepped_in_any_pieces_is_the_plant_stepped_at_once() {
        let chain = Oscillator2Dof::stiffness_nonlinear();
        let plant = ChainPlant::new(chain, LoadSource::Law(Load::random(5, 10.0)), 1e-4).unwrap();
        let (mut once, mut pieces) = (plant.clone(), plant);
        // 10,000 steps: across the law's tabulated pieces (4,096 steps each).
        once.advance(10_000);
        let mut done = 0;
        for piece in [1, 36, 4_000, 59, 5_904].into_iter().cycle() {
            let piece = piece.min(10_000 - done);
            pieces.advance(piece);
            done += piece;
            if done == 10_000 {
                break;
            }
        }
        assert_eq!(once.motion().map(f64::to_bits), pieces.motion().map(f64::to_bits));
        assert_eq!(once.accelerations().map(f64::to_bits), pieces.accelerations().map(f64::to_bits));
        assert_eq!(once.time(), 1.0);
    }

    #[test]
    fn a_held_load_is_the_constant_law_to_the_bit() {
        let chain = Oscillator2Dof::damping_nonlinear();
        let mut held = ChainPlant::new(chain, LoadSource::Held(2.5), 1e-4).unwrap();
        let mut law = ChainPlant::new(chain, LoadSource::Law(Load::constant(2.5)), 1e-4).unwrap();
        held.advance(3_000);
        law.advance(3_000);
        assert_eq!(held.motion().map(f64::to_bits), law.motion().map(f64::to_bits));
        assert_eq!(held.load(), 2.5);
        // A new held value acts from the next step on.
        held.set_load(-1.0).unwrap();
        assert_eq!(held.load(), -1.0);
        let before = held.accelerations();
        held.advance(1);
        assert_ne!(held.accelerations(), before);
    }

    #[test]
    fn bad_loads_and_steps_are_refused_and_change_nothing() {
        let chain = Oscillator2Dof::stiffness_nonlinear();
        assert!(ChainPlant::new(chain, LoadSource::Held(0.0), 0.0).is_err());
        assert!(ChainPlant::new(chain, LoadSource::Held(f64::NAN), 1e-4).is_err());
        let mut held = ChainPlant::new(chain, LoadSource::Held(1.0), 1e-4).unwrap();
        assert!(held.set_load(f64::INFINITY).is_err());
        assert_eq!(held.load(), 1.0);
        let mut law = ChainPlant::new(chain, LoadSource::Law(Load::harmonic()), 1e-4).unwrap();
        let err = law.set_load(1.0).unwrap_err();
        assert!(err.contains("law"), "{err}");
    }

    #[test]
    fn static_load_settles_at_the_static_deflection_of_the_chain() {
        // A constant 2 N on the stiffness-nonlinear chain: the spring law reaches
        // 2 N on its second piece, at z₁ = δ₁ + (2 − k₁₁·δ₁)/k₁₂ = 0.175 m, and
        // z₂ = z₁ + F/k₂, once the motion has died out (after 100 s it is down to ~2e-6 m).
        let chain = Oscillator2Dof::stiffness_nonlinear();
        let truth = simulate(&chain, &Load::constant(2.0), 0.005, 20_000, 10);
        let last = truth.motion.last().unwrap();
        assert!((last[0] - 0.175).abs() < 1e-5, "z1 = {}", last[0]);
        assert!((last[1] - (0.175 + 2.0 / 15.0)).abs() < 1e-5, "z2 = {}", last[1]);
    }

    #[test]
    fn halving_the_step_changes_the_samples_by_the_rk4_error_only() {
        let chain = Oscillator2Dof::stiffness_nonlinear();
        let load = Load::random(3, 10.0);
        let fine = simulate(&chain, &load, 0.005, 2000, 50);
        let finer = simulate(&chain, &load, 0.005, 2000, 100);
        let gap =
            fine.acceleration.iter().zip(&finer.acceleration).map(|(a, b)| (a[1] - b[1]).abs()).fold(0.0, f64::max);
        let scale = finer.acceleration.iter().map(|a| a[1].abs()).fold(0.0, f64::max);
        assert!(gap < 1e-6 * scale, "RK4 at 1e-4 s is not converged: gap {gap}, scale {scale}");
    }
}
