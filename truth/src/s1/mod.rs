//! Study S1's truth: the physical two-mass chain (continuous piecewise-linear
//! element, load on m₂) under a load that varies continuously in time
//! ([`load`]), integrated finely ([`plant`]), and the two accelerometers with
//! white noise of a fixed fraction of each channel's RMS. The four cases are
//! the paper's (stiffness- or damping-nonlinear chain × random or harmonic load).

pub mod load;
pub mod plant;

use std::fmt;

use estimator::models::Oscillator2Dof;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use load::Load;
use plant::Truth;

/// Which element of the ground link is nonlinear.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Nonlinearity {
    /// Table 1: the spring `k₁`.
    Stiffness,
    /// Table 2: the damper `c₁`.
    Damping,
}

/// Which load drives the chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoadKind {
    /// Band-limited random load.
    Random,
    /// Harmonics at 1, 2, 3, 5, 7 Hz.
    Harmonic,
}

/// One of the four published cases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Case {
    /// The nonlinear element.
    pub nonlinearity: Nonlinearity,
    /// The load.
    pub load: LoadKind,
}

impl Case {
    /// The four cases in the paper's order.
    pub const ALL: [Case; 4] = [
        Case { nonlinearity: Nonlinearity::Stiffness, load: LoadKind::Random },
        Case { nonlinearity: Nonlinearity::Damping, load: LoadKind::Random },
        Case { nonlinearity: Nonlinearity::Stiffness, load: LoadKind::Harmonic },
        Case { nonlinearity: Nonlinearity::Damping, load: LoadKind::Harmonic },
    ];

    /// The physical chain of the case.
    pub fn chain(&self) -> Oscillator2Dof {
        match self.nonlinearity {
            Nonlinearity::Stiffness => Oscillator2Dof::stiffness_nonlinear(),
            Nonlinearity::Damping => Oscillator2Dof::damping_nonlinear(),
        }
    }
}

impl fmt::Display for Case {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = match self.nonlinearity {
            Nonlinearity::Stiffness => "stiffness",
            Nonlinearity::Damping => "damping",
        };
        let l = match self.load {
            LoadKind::Random => "random",
            LoadKind::Harmonic => "harmonic",
        };
        write!(f, "{n}/{l}")
    }
}

/// Parses the [`Display`](fmt::Display) form, e.g. `stiffness/random`.
impl std::str::FromStr for Case {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Case::ALL.into_iter().find(|c| c.to_string() == s).ok_or_else(|| {
            let names: Vec<String> = Case::ALL.iter().map(Case::to_string).collect();
            format!("unknown case '{s}'; expected one of {}", names.join(", "))
        })
    }
}

/// Study settings; `Default` is the published set-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Estimator sample rate (Hz); default 200.
    pub rate: f64,
    /// Simulated duration (s); default 60.
    pub duration: f64,
    /// Truth integration step (s); default 1e-4 (rounded to a whole number per sample).
    pub truth_step: f64,
    /// Accelerometer noise standard deviation as a fraction of each channel's RMS; default 0.02.
    pub noise_fraction: f64,
    /// Seed of the random load and of the measurement noise; default 1.
    pub seed: u64,
    /// RMS of the random load (N); default 10.
    pub load_rms: f64,
    /// Window of the running RMSE (s); default 1.
    pub rmse_window: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            rate: 200.0,
            duration: 60.0,
            truth_step: 1e-4,
            noise_fraction: 0.02,
            seed: 1,
            load_rms: 10.0,
            rmse_window: 1.0,
        }
    }
}

impl Settings {
    /// The sample time `1/rate`.
    pub fn dt(&self) -> f64 {
        1.0 / self.rate
    }

    /// Number of samples.
    pub fn samples(&self) -> usize {
        (self.duration * self.rate).round() as usize
    }

    /// Truth RK4 steps per sample.
    pub fn truth_substeps(&self) -> usize {
        ((self.dt() / self.truth_step).round() as usize).max(1)
    }

    /// Checks that the settings make sense, saying what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [("rate", self.rate), ("duration", self.duration), ("truth step", self.truth_step)];
        if let Some((name, v)) = positive.iter().find(|(_, v)| !(*v > 0.0 && v.is_finite())) {
            return Err(format!("{name} must be positive, got {v}"));
        }
        if !(self.noise_fraction >= 0.0 && self.noise_fraction.is_finite()) {
            return Err(format!("noise fraction must be non-negative, got {}", self.noise_fraction));
        }
        if self.samples() < 10 {
            return Err(format!("duration × rate gives only {} samples", self.samples()));
        }
        Ok(())
    }
}

/// The noisy accelerometer signals the estimator sees.
#[derive(Debug, Clone)]
pub struct Measurements {
    /// `[z̈₁, z̈₂]` with noise (m/s²).
    pub acceleration: Vec<[f64; 2]>,
    /// The noise standard deviation of each channel (m/s²): the sensor specification.
    pub noise_std: [f64; 2],
}

/// Adds white Gaussian noise of `fraction × RMS` to each acceleration channel.
pub fn measure(truth: &Truth, fraction: f64, seed: u64) -> Measurements {
    // A stream of its own, so the noise does not change when the load's draw does.
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x05EE_D0FA_11CE);
    let rms = truth.acceleration_rms();
    let noise_std = [fraction * rms[0], fraction * rms[1]];
    let acceleration = truth
        .acceleration
        .iter()
        .map(|a| {
            let w: [f64; 2] = [StandardNormal.sample(&mut rng), StandardNormal.sample(&mut rng)];
            [a[0] + noise_std[0] * w[0], a[1] + noise_std[1] * w[1]]
        })
        .collect();
    Measurements { acceleration, noise_std }
}

/// Runs the truth simulator of a case and returns the truth and the measurements.
pub fn simulate(case: &Case, settings: &Settings) -> (Truth, Measurements) {
    simulate_with(case, settings, &load(case, settings))
}

/// The load of a case: the seeded random load or the harmonics.
pub fn load(case: &Case, settings: &Settings) -> Load {
    match case.load {
        LoadKind::Random => Load::random(settings.seed, settings.load_rms),
        LoadKind::Harmonic => Load::harmonic(),
    }
}

/// Runs the truth simulator of a case under `load` (a case's load, or one
/// changed for a study) and returns the truth and the measurements.
pub fn simulate_with(case: &Case, settings: &Settings, load: &Load) -> (Truth, Measurements) {
    let truth = plant::simulate(&case.chain(), load, settings.dt(), settings.samples(), settings.truth_substeps());
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    (truth, measurements)
}
