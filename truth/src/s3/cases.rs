//! S3's cases, and the truth sampled as the car's data acquisition would record it (S2's
//! anti-alias filter and decimation, [`AntiAlias`]): 20 vertical accelerations, the
//! optional primary deflections and lateral axle-box accelerations, each with seeded noise
//! of a fraction of its channel's RMS, and the true contact forces.
//!
//! Channel orders are fixed and named ([`ACCELERATIONS`], [`DEFLECTIONS`],
//! [`LATERAL_ACCELERATIONS`], [`CONTACT`], [`LATERAL_CONTACT`]): wheelsets 1 to 4 front
//! first, all left channels before the right ones. The car is the settings' own, by default
//! the catalogue car as built ([`as_built`]): what the estimator's user has is the catalogue.

use std::fmt;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::irregularity::{Irregularity, TrackSpectra};
use super::parameters::{Track, Vehicle};
use super::plant::{Sample, Settings as PlantSettings, Simulation};
use crate::s2::daq::{check_recording, with_noise, AntiAlias};

/// The vertical accelerations: axle boxes (at ±d_w), the bogie frames above them, the car
/// body's corners above the secondary springs (at ±l_c, ±d_s).
pub const ACCELERATIONS: [&str; 20] = [
    "a_ab_L1", "a_ab_L2", "a_ab_L3", "a_ab_L4", "a_ab_R1", "a_ab_R2", "a_ab_R3", "a_ab_R4", "a_bf_L1", "a_bf_L2",
    "a_bf_L3", "a_bf_L4", "a_bf_R1", "a_bf_R2", "a_bf_R3", "a_bf_R4", "a_cb_FL", "a_cb_FR", "a_cb_RL", "a_cb_RR",
];
/// The primary springs' compressions (optional sensors).
pub const DEFLECTIONS: [&str; 8] = ["d_p_L1", "d_p_L2", "d_p_L3", "d_p_L4", "d_p_R1", "d_p_R2", "d_p_R3", "d_p_R4"];
/// The wheelsets' lateral accelerations at the axle boxes (optional sensors).
pub const LATERAL_ACCELERATIONS: [&str; 4] = ["a_lat_1", "a_lat_2", "a_lat_3", "a_lat_4"];
/// The vertical contact forces.
pub const CONTACT: [&str; 8] = ["F_NL1", "F_NL2", "F_NL3", "F_NL4", "F_NR1", "F_NR2", "F_NR3", "F_NR4"];
/// The lateral contact forces (for reference).
pub const LATERAL_CONTACT: [&str; 8] = ["F_YL1", "F_YL2", "F_YL3", "F_YL4", "F_YR1", "F_YR2", "F_YR3", "F_YR4"];

/// The excitations of S3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    /// A random track: vertical profile and cross-level of [`Settings::spectra`].
    Random,
    /// A dipped joint, 1 mm deep, on the left rail only.
    Joint,
    /// A warped track: 6 mm of cross-level change over 20 m.
    Twist,
    /// The random track with a random alignment as well.
    RandomAlignment,
}

impl Case {
    /// The four cases.
    pub const ALL: [Case; 4] = [Case::Random, Case::Joint, Case::Twist, Case::RandomAlignment];

    /// Its name.
    pub fn name(&self) -> &'static str {
        match self {
            Case::Random => "random",
            Case::Joint => "joint",
            Case::Twist => "twist",
            Case::RandomAlignment => "random_alignment",
        }
    }

    /// The rails under the run: the front wheel (10.2 m ahead of the car body's centre at
    /// the start) meets the joint 1 s in and the twist 0.5 s in; a random track fades in
    /// from 1 m ahead of it and is sampled past the end of the run and its filter.
    pub fn irregularity(&self, settings: &Settings) -> Irregularity {
        let front = settings.vehicle.vertical.wheel_offsets()[0];
        let end = settings.speed * (settings.duration + 0.5) + front + 2.0;
        match self {
            Case::Random => Irregularity::random(&settings.spectra, settings.seed, front + 1.0, end, false),
            Case::RandomAlignment => Irregularity::random(&settings.spectra, settings.seed, front + 1.0, end, true),
            Case::Joint => Irregularity::dipped_joint(front + settings.speed),
            Case::Twist => Irregularity::twist(front + 0.5 * settings.speed),
        }
    }
}

impl fmt::Display for Case {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Parses a name of [`Case::name`].
impl std::str::FromStr for Case {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Case::ALL.into_iter().find(|c| c.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Case::ALL.iter().map(Case::name).collect();
            format!("unknown S3 case '{s}'; expected one of {}", names.join(", "))
        })
    }
}

/// How to run the study.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Speed (m/s); 80 km/h.
    pub speed: f64,
    /// Sampling rate of the measurements (Hz): 200 or 1000.
    pub rate: f64,
    /// Simulated time (s).
    pub duration: f64,
    /// Seed of the random track and of the sensor noise.
    pub seed: u64,
    /// Sensor noise: white, this fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// The random track's spectra; German low interference.
    pub spectra: TrackSpectra,
    /// The car that runs: by default [`as_built`].
    pub vehicle: Vehicle,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            speed: 80.0 / 3.6,
            rate: 1000.0,
            duration: 4.0,
            seed: 1,
            noise_fraction: 0.02,
            spectra: TrackSpectra::GERMAN_LOW,
            vehicle: as_built(),
        }
    }
}

impl Settings {
    /// Checks that the settings can be run: a positive speed and duration, a rate whose
    /// sample time is a whole number of the truth's integration steps, a noise fraction of
    /// at least zero, and a valid car.
    pub fn validate(&self) -> Result<(), String> {
        check_recording(self.speed, self.rate, self.duration, self.noise_fraction, PlantSettings::default().dt)?;
        self.vehicle.validate()
    }
}

/// The truth at the sample times, each channel as the data acquisition records it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Truth {
    /// Sample times (s), from 0.
    pub time: Vec<f64>,
    /// [`ACCELERATIONS`], noise-free (m/s², up).
    pub accelerations: Vec<[f64; 20]>,
    /// [`DEFLECTIONS`], noise-free (m, compression from the static length).
    pub deflections: Vec<[f64; 8]>,
    /// [`LATERAL_ACCELERATIONS`], noise-free (m/s², left).
    pub lateral_accelerations: Vec<[f64; 4]>,
    /// [`CONTACT`] (N).
    pub contact: Vec<[f64; 8]>,
    /// [`LATERAL_CONTACT`] (N, on the wheel, left).
    pub lateral_contact: Vec<[f64; 8]>,
}

/// What the sensors recorded.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Measurements {
    /// [`ACCELERATIONS`] with their noise (m/s², up).
    pub accelerations: Vec<[f64; 20]>,
    /// Their noise's standard deviation per channel.
    pub accelerations_noise_std: [f64; 20],
    /// [`DEFLECTIONS`] with their noise (m).
    pub deflections: Vec<[f64; 8]>,
    /// Their noise's standard deviation per channel.
    pub deflections_noise_std: [f64; 8],
    /// [`LATERAL_ACCELERATIONS`] with their noise (m/s²).
    pub lateral_accelerations: Vec<[f64; 4]>,
    /// Their noise's standard deviation per channel.
    pub lateral_accelerations_noise_std: [f64; 4],
}

/// The car as it runs, S2's as-built car on two rails: the catalogue car laden with 2 t on
/// the car body (its pitch and roll inertias grown as a uniform load would grow them),
/// primary springs 5 % stiffer, damper blow-off slope 10 % higher. [est]
pub fn as_built() -> Vehicle {
    let catalogue = Vehicle::PASSENGER;
    let vertical = crate::s2::cases::as_built();
    let laden = vertical.car_body_mass / catalogue.vertical.car_body_mass;
    Vehicle { vertical, car_body_roll_inertia: catalogue.car_body_roll_inertia * laden, ..catalogue }
}

/// Runs the truth of `case` on the settings' car and records it at `settings.rate` as the
/// data acquisition would ([`AntiAlias`]), forces included; or why the settings cannot be
/// run.
pub fn simulate(case: Case, settings: &Settings) -> Result<Truth, String> {
    settings.validate()?;
    let plant = PlantSettings { speed: settings.speed, ..PlantSettings::default() };
    let mut sim = Simulation::new(settings.vehicle, Track::BALLASTED, case.irregularity(settings), &plant)?;
    let daq = AntiAlias::new(plant.dt, settings.rate);
    let per_sample = (1.0 / (settings.rate * plant.dt)).round() as usize;
    let samples = (settings.duration * settings.rate).round() as usize;
    // The filter reaches half its length past the last sample.
    let steps = samples * per_sample + daq.half_length();
    let mut signals: Vec<Sample> = Vec::with_capacity(steps + 1);
    for step in 0..=steps {
        if step > 0 {
            sim.step();
        }
        signals.push(sim.sample());
    }
    let record = |k: usize, value: &dyn Fn(&Sample) -> f64| daq.at(k * per_sample, |i| value(&signals[i]));
    let times = 0..=samples;
    Ok(Truth {
        time: times.clone().map(|k| k as f64 / settings.rate).collect(),
        accelerations: times.clone().map(|k| std::array::from_fn(|c| record(k, &|s| s.accelerations[c]))).collect(),
        deflections: times.clone().map(|k| std::array::from_fn(|c| record(k, &|s| s.deflections[c]))).collect(),
        lateral_accelerations: times
            .clone()
            .map(|k| std::array::from_fn(|c| record(k, &|s| s.lateral_accelerations[c])))
            .collect(),
        contact: times.clone().map(|k| std::array::from_fn(|c| record(k, &|s| s.contact[c]))).collect(),
        lateral_contact: times.map(|k| std::array::from_fn(|c| record(k, &|s| s.lateral_contact[c]))).collect(),
    })
}

/// Adds seeded white noise of `fraction` of each channel's RMS to the accelerations, the
/// deflections and the lateral accelerations.
pub fn measure(truth: &Truth, fraction: f64, seed: u64) -> Measurements {
    // Its own stream: the track's seed must not also draw the noise.
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_0F5E_5503);
    let (accelerations, accelerations_noise_std) = with_noise(&truth.accelerations, fraction, &mut rng);
    let (deflections, deflections_noise_std) = with_noise(&truth.deflections, fraction, &mut rng);
    let (lateral_accelerations, lateral_accelerations_noise_std) =
        with_noise(&truth.lateral_accelerations, fraction, &mut rng);
    Measurements {
        accelerations,
        accelerations_noise_std,
        deflections,
        deflections_noise_std,
        lateral_accelerations,
        lateral_accelerations_noise_std,
    }
}
