//! Study S1's truth: the physical two-mass chain (continuous piecewise-linear
//! element, load on m₂) under a load that varies continuously in time
//! ([`load`](mod@load)), integrated finely ([`plant`]), and the two accelerometers with
//! white noise of a fixed fraction of each channel's RMS. The four cases are
//! the paper's (stiffness- or damping-nonlinear chain × random or harmonic load).
//!
//! ## Unseen cases
//!
//! [`Case::UNSEEN`] holds six more: each chain under each of three loads the
//! estimators were not tuned on ([`UnseenLoad`]; their construction is in
//! [`load`](mod@load)): `stiffness/band20`, `stiffness/steps`, `stiffness/chirp`,
//! `damping/band20`, `damping/steps`, `damping/chirp`. They are named and
//! parsed like the paper's (`"stiffness/chirp".parse::<Case>()`), run through
//! the same [`simulate`], and are in none of [`Case::ALL`]'s loops, so the
//! paper's tables do not move. Such a case has `unseen: Some(..)`, which
//! replaces its load; its `load` field is then [`LoadKind::Random`], the
//! paper's case whose filter set-up it is scored with, but the paper
//! published no figures for it ([`Case::is_published`] is false). The seed
//! draws the band and the steps as it draws the random load; the noise is
//! `noise_fraction` of each channel's RMS as in every case, 1 % to 5 % (and
//! beyond) alike.

pub mod load;
pub mod plant;

use std::fmt;

use estimator::models::Oscillator2Dof;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::sensor_noise::SensorNoise;

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

/// A load the estimators were not tuned on (the module documentation of
/// [`load`](mod@load) gives each).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnseenLoad {
    /// Band-limited random load, flat from 0.2 to 20 Hz.
    Band20,
    /// The random load plus a seeded train of steps.
    Steps,
    /// A logarithmic chirp from 0.1 to 15 Hz over the run.
    Chirp,
}

impl UnseenLoad {
    /// The three.
    pub const ALL: [UnseenLoad; 3] = [UnseenLoad::Band20, UnseenLoad::Steps, UnseenLoad::Chirp];

    /// Its name in a case's name: `band20`, `steps`, `chirp`.
    pub fn name(&self) -> &'static str {
        match self {
            UnseenLoad::Band20 => "band20",
            UnseenLoad::Steps => "steps",
            UnseenLoad::Chirp => "chirp",
        }
    }
}

/// One of the four published cases, or one of the six unseen ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Case {
    /// The nonlinear element.
    pub nonlinearity: Nonlinearity,
    /// The paper's load; in an unseen case [`LoadKind::Random`], the case whose
    /// set-up it is scored with (`unseen` says what the load is).
    pub load: LoadKind,
    /// `None` in the paper's cases; otherwise the load, in place of `load`.
    pub unseen: Option<UnseenLoad>,
}

impl Case {
    /// The four cases in the paper's order.
    pub const ALL: [Case; 4] = [
        Case { nonlinearity: Nonlinearity::Stiffness, load: LoadKind::Random, unseen: None },
        Case { nonlinearity: Nonlinearity::Damping, load: LoadKind::Random, unseen: None },
        Case { nonlinearity: Nonlinearity::Stiffness, load: LoadKind::Harmonic, unseen: None },
        Case { nonlinearity: Nonlinearity::Damping, load: LoadKind::Harmonic, unseen: None },
    ];

    /// The six unseen cases: each chain under each [`UnseenLoad`].
    pub const UNSEEN: [Case; 6] = [
        Case::unseen(Nonlinearity::Stiffness, UnseenLoad::Band20),
        Case::unseen(Nonlinearity::Stiffness, UnseenLoad::Steps),
        Case::unseen(Nonlinearity::Stiffness, UnseenLoad::Chirp),
        Case::unseen(Nonlinearity::Damping, UnseenLoad::Band20),
        Case::unseen(Nonlinearity::Damping, UnseenLoad::Steps),
        Case::unseen(Nonlinearity::Damping, UnseenLoad::Chirp),
    ];

    /// The chain `nonlinearity` under the unseen load `load`.
    pub const fn unseen(nonlinearity: Nonlinearity, load: UnseenLoad) -> Case {
        Case { nonlinearity, load: LoadKind::Random, unseen: Some(load) }
    }

    /// Whether the paper published figures for the case: the four of [`Case::ALL`].
    pub fn is_published(&self) -> bool {
        self.unseen.is_none()
    }

    /// Every case by name: the paper's four, then the six unseen.
    pub fn every() -> impl Iterator<Item = Case> {
        Case::ALL.into_iter().chain(Case::UNSEEN)
    }

    /// The physical chain of the case.
    pub fn chain(&self) -> Oscillator2Dof {
        match self.nonlinearity {
            Nonlinearity::Stiffness => Oscillator2Dof::stiffness_nonlinear(),
            Nonlinearity::Damping => Oscillator2Dof::damping_nonlinear(),
        }
    }
}

/// `chain` under the names of the S1 estimator FMU's parameters (`kalfmu_s1_load`): the
/// masses, the ground link's spring and damper as three slopes and two breakpoints each,
/// the coupling. One list for the study's FMU runs and for the logs the tuning tests
/// simulate, which may not depend on the study.
pub fn chain_parameters(chain: &Oscillator2Dof) -> [(&'static str, f64); 14] {
    let (k, c) = (chain.k1, chain.c1);
    let (ks, kb) = (k.slopes(), k.breaks());
    let (cs, cb) = (c.slopes(), c.breaks());
    // A linear element is a law of three equal slopes whose breakpoints are not finite.
    // The FMUs take finite breakpoints only: 1e300, beyond any motion, keeps the law on
    // its first slope, evaluated as the linear law is, to the bit (finite breakpoints
    // inside the motion would give the same law but round differently past them, and a
    // plant FMU would no longer be the study's truth bit for bit).
    let breaks = |b: [f64; 2]| if b[0].is_finite() { b } else { [1e300, 1e300] };
    let (kb, cb) = (breaks(kb), breaks(cb));
    [
        ("m1", chain.m1),
        ("m2", chain.m2),
        ("k11", ks[0]),
        ("k12", ks[1]),
        ("k13", ks[2]),
        ("delta1", kb[0]),
        ("delta2", kb[1]),
        ("c11", cs[0]),
        ("c12", cs[1]),
        ("c13", cs[2]),
        ("eps1", cb[0]),
        ("eps2", cb[1]),
        ("k2", chain.k2),
        ("c2", chain.c2),
    ]
}

impl fmt::Display for Case {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = match self.nonlinearity {
            Nonlinearity::Stiffness => "stiffness",
            Nonlinearity::Damping => "damping",
        };
        let l = match (self.unseen, self.load) {
            (Some(unseen), _) => unseen.name(),
            (None, LoadKind::Random) => "random",
            (None, LoadKind::Harmonic) => "harmonic",
        };
        write!(f, "{n}/{l}")
    }
}

/// Parses the [`Display`](fmt::Display) form, e.g. `stiffness/random` or
/// `damping/chirp`: any of [`Case::ALL`] and [`Case::UNSEEN`].
impl std::str::FromStr for Case {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Case::every().find(|c| c.to_string() == s).ok_or_else(|| {
            let names: Vec<String> = Case::every().map(|c| c.to_string()).collect();
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
    let rms = truth.acceleration_rms();
    let noise_std = [fraction * rms[0], fraction * rms[1]];
    let mut noise = accelerometer_noise(seed, noise_std);
    let acceleration = truth.acceleration.iter().map(|&a| noise.measure(a)).collect();
    Measurements { acceleration, noise_std }
}

/// The accelerometers' noise on `[z̈₁, z̈₂]` (m/s²), of standard deviations `std`: a stream
/// of its own, seeded from `seed`, so that it does not change when the load's draw does.
pub fn accelerometer_noise(seed: u64, std: [f64; 2]) -> SensorNoise<2> {
    SensorNoise::new(ChaCha8Rng::seed_from_u64(seed ^ 0x05EE_D0FA_11CE), std)
}

/// Runs the truth simulator of a case and returns the truth and the measurements.
pub fn simulate(case: &Case, settings: &Settings) -> (Truth, Measurements) {
    simulate_with(case, settings, &load(case, settings))
}

/// The load of a case: the seeded random load or the harmonics; in an unseen
/// case the band to 20 Hz, the steps over `settings.duration` (both seeded,
/// RMS `load_rms`) or the chirp over `settings.duration` (RMS `load_rms`).
pub fn load(case: &Case, settings: &Settings) -> Load {
    match (case.unseen, case.load) {
        (None, LoadKind::Random) => Load::random(settings.seed, settings.load_rms),
        (None, LoadKind::Harmonic) => Load::harmonic(),
        (Some(UnseenLoad::Band20), _) => {
            let (band, components) = Load::BAND_20;
            Load::band_limited(settings.seed, settings.load_rms, band, components)
        }
        (Some(UnseenLoad::Steps), _) => Load::steps(settings.seed, settings.load_rms, settings.duration),
        (Some(UnseenLoad::Chirp), _) => Load::chirp(settings.load_rms, Load::CHIRP_BAND, settings.duration),
    }
}

/// Runs the truth simulator of a case under `load` (a case's load, or one
/// changed for a study) and returns the truth and the measurements.
pub fn simulate_with(case: &Case, settings: &Settings, load: &Load) -> (Truth, Measurements) {
    let truth = plant::simulate(&case.chain(), load, settings.dt(), settings.samples(), settings.truth_substeps());
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    (truth, measurements)
}
