//! S2's three cases, and the truth sampled as a vehicle's data acquisition would
//! record it: the accelerations with their noise, and the wheel–rail forces as an
//! instrumented wheelset records them.
//!
//! **The truth's vehicle is not the catalogue's.** The truth runs the car as it is on the
//! day: laden (2 t of passengers on the car body), its primary springs 5 % stiffer than the
//! catalogue (aged rubber) and its dampers' blow-off slope 10 % higher ([`as_built`]).
//!
//! ## Unseen tracks
//!
//! The random case draws its track from [`Settings::spectrum`], FRA class 5 by default. A
//! [`Scenario`] names a case together with its track: the paper's three (`random`,
//! `corrugation`, `weld`) and the random case on the three spectra the estimator was not
//! tuned on ([`Scenario::UNSEEN`]): `random/fra6`, `random/german-low`,
//! `random/german-high` (the spectra and their sources are in
//! [`irregularity`](super::irregularity)). `"random/german-high".parse::<Scenario>()`,
//! then [`Scenario::settings`] on the study's settings, or [`Scenario::simulate`]. Speed
//! and rate are the settings' as for every case: 40 to 160 km/h, 200 Hz or 1 kHz.

use std::fmt;

use super::daq::{check_recording, with_noise};
use super::irregularity::{Irregularity, RandomProfile, TrackSpectrum};
use super::parameters::{Track, Vehicle};
use super::plant::{Settings as PlantSettings, Simulation};
use super::recording::Recording;
use crate::sensor_noise::SensorNoise;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The excitations of the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    /// A random track, of [`Settings::spectrum`] (FRA class 5 by default).
    Random,
    /// A corrugation 0.1 mm / 0.5 m.
    Corrugation,
    /// A weld, 0.3 mm / 1.0 m plus 0.3 mm / 0.1 m.
    Weld,
}

impl Case {
    /// The three cases in the paper's order.
    pub const ALL: [Case; 3] = [Case::Random, Case::Corrugation, Case::Weld];

    /// Its name.
    pub fn name(&self) -> &'static str {
        match self {
            Case::Random => "random",
            Case::Corrugation => "corrugation",
            Case::Weld => "weld",
        }
    }

    /// The rail under the run: the front wheel (10.2 m ahead of the car body's centre at the
    /// start) meets a corrugation 0.5 s in and a weld 1 s in; a random track is sampled over
    /// the whole run.
    pub fn irregularity(&self, settings: &Settings) -> Irregularity {
        self.rail(settings.speed, settings.speed * settings.duration, &settings.spectrum, settings.seed)
    }

    /// The rail under a run at `speed` (m/s) over which the car body's centre covers `run`
    /// metres: a random track of `spectrum` and `seed` sampled over it (a perfect rail
    /// beyond), the corrugation and the weld met 0.5 s and 1 s in.
    pub fn rail(&self, speed: f64, run: f64, spectrum: &TrackSpectrum, seed: u64) -> Irregularity {
        let front = Vehicle::ZHAI_PASSENGER.wheel_offsets()[0];
        match self {
            Case::Random => {
                Irregularity::Random(RandomProfile::sample(spectrum, seed, -front - 1.0, run + front + 1.0))
            }
            Case::Corrugation => Irregularity::corrugation(front + 0.5 * speed),
            Case::Weld => Irregularity::weld(front + speed),
        }
    }
}

/// A case with the track it runs on: the name of a run of the study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    /// The excitation.
    pub case: Case,
    /// The random track's spectrum (only the random case draws a track).
    pub spectrum: TrackSpectrum,
}

impl Scenario {
    /// The paper's three cases, each on the default track.
    pub const PAPER: [Scenario; 3] = [
        Scenario { case: Case::Random, spectrum: TrackSpectrum::FRA_5 },
        Scenario { case: Case::Corrugation, spectrum: TrackSpectrum::FRA_5 },
        Scenario { case: Case::Weld, spectrum: TrackSpectrum::FRA_5 },
    ];

    /// The random case on the tracks the estimator was not tuned on.
    pub const UNSEEN: [Scenario; 3] = [
        Scenario { case: Case::Random, spectrum: TrackSpectrum::FRA_6 },
        Scenario { case: Case::Random, spectrum: TrackSpectrum::GERMAN_LOW },
        Scenario { case: Case::Random, spectrum: TrackSpectrum::GERMAN_HIGH },
    ];

    /// Every named scenario: the paper's, then the unseen.
    pub fn every() -> impl Iterator<Item = Scenario> {
        Scenario::PAPER.into_iter().chain(Scenario::UNSEEN)
    }

    /// Whether the paper published figures for it: its three cases, the random one on FRA
    /// class 5 (the corrugation and the weld draw no track).
    pub fn is_published(&self) -> bool {
        self.case != Case::Random || self.spectrum == TrackSpectrum::FRA_5
    }

    /// `base` with this scenario's track.
    pub fn settings(&self, base: &Settings) -> Settings {
        Settings { spectrum: self.spectrum, ..base.clone() }
    }

    /// Runs it: [`simulate`] of its case on `base` with its track.
    pub fn simulate(&self, base: &Settings) -> Truth {
        simulate(self.case, &self.settings(base))
    }
}

impl fmt::Display for Scenario {
    /// `random/<spectrum>` for the random case off FRA class 5, otherwise the case's name.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.case == Case::Random && self.spectrum != TrackSpectrum::FRA_5 {
            write!(f, "random/{}", self.spectrum)
        } else {
            f.write_str(self.case.name())
        }
    }
}

/// Parses `random`, `corrugation`, `weld` (on FRA class 5) and `random/<spectrum>` with a
/// spectrum of [`TrackSpectrum::name`] (`random/fra5` is `random`).
impl std::str::FromStr for Scenario {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let unknown = || {
            let names: Vec<String> = Scenario::every().map(|c| c.to_string()).collect();
            format!("unknown S2 case '{s}'; expected one of {}", names.join(", "))
        };
        let (name, spectrum) = match s.split_once('/') {
            Some(("random", spectrum)) => ("random", spectrum.parse::<TrackSpectrum>().map_err(|_| unknown())?),
            Some(_) => return Err(unknown()),
            None => (s, TrackSpectrum::FRA_5),
        };
        let case = Case::ALL.into_iter().find(|c| c.name() == name).ok_or_else(unknown)?;
        Ok(Scenario { case, spectrum })
    }
}

/// How to run the study.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Speed (m/s); 80 km/h.
    pub speed: f64,
    /// Sampling rate of the measurements (Hz): 200 (the paper) or 1000 (axle-box data
    /// acquisition).
    pub rate: f64,
    /// Simulated time (s).
    pub duration: f64,
    /// Seed of the random track and of the sensor noise.
    pub seed: u64,
    /// Sensor noise: white, this fraction of each channel's RMS.
    pub noise_fraction: f64,
    /// The random track's spectrum; FRA class 5.
    pub spectrum: TrackSpectrum,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            speed: 80.0 / 3.6,
            rate: 1000.0,
            duration: 4.0,
            seed: 1,
            noise_fraction: 0.02,
            spectrum: TrackSpectrum::FRA_5,
        }
    }
}

impl Settings {
    /// Checks that the settings can be run: a positive speed and duration, a rate whose
    /// sample time is a whole number of the truth's integration steps, a noise fraction of
    /// at least zero.
    pub fn validate(&self) -> Result<(), String> {
        check_recording(self.speed, self.rate, self.duration, self.noise_fraction, PlantSettings::default().dt)
    }
}

/// The truth at the sample times.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Truth {
    /// Sample times (s), from 0.
    pub time: Vec<f64>,
    /// The seven accelerations as the data acquisition records them, noise-free (m/s², up).
    pub accelerations: Vec<[f64; 7]>,
    /// The four wheel–rail forces as an instrumented wheelset's acquisition records them (N).
    pub contact: Vec<[f64; 4]>,
}

/// What the sensors recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurements {
    /// The seven accelerations with their noise (m/s², up).
    pub accelerations: Vec<[f64; 7]>,
    /// The noise's standard deviation per channel (m/s²).
    pub noise_std: [f64; 7],
}

/// The car as it runs: the catalogue vehicle laden with 2 t on the car body, primary springs
/// 5 % stiffer, damper blow-off slope 10 % higher. [est]
pub fn as_built() -> Vehicle {
    let catalogue = Vehicle::ZHAI_PASSENGER;
    Vehicle {
        car_body_mass: catalogue.car_body_mass + 2_000.0,
        // The passengers sit along the car: the pitch inertia grows as a uniform load would.
        car_body_pitch_inertia: catalogue.car_body_pitch_inertia * (catalogue.car_body_mass + 2_000.0)
            / catalogue.car_body_mass,
        primary_stiffness: catalogue.primary_stiffness * 1.05,
        primary_damping_beyond: catalogue.primary_damping_beyond * 1.10,
        ..catalogue
    }
}

/// Runs the truth of `case` on the as-built car and records it at `settings.rate` as the
/// vehicle's data acquisition would ([`AntiAlias`]): the accelerations, and the forces as an
/// instrumented wheelset's acquisition at the same rate would record them. Nothing above
/// half the rate can be estimated from the samples, and point samples of the forces would
/// fold it into the band, where no estimate could follow it.
pub fn simulate(case: Case, settings: &Settings) -> Truth {
    let plant = PlantSettings { speed: settings.speed, ..PlantSettings::default() };
    let sim = Simulation::new(as_built(), Track::BALLASTED, case.irregularity(settings), &plant);
    let mut recording = Recording::new(sim, plant.dt, settings.rate).expect("a rate the settings checked");
    let samples = (settings.duration * settings.rate).round() as usize;
    let mut truth = Truth::default();
    for k in 0..=samples {
        if k > 0 {
            recording.advance(1);
        }
        let (accelerations, contact) = recording.sample();
        truth.time.push(k as f64 / settings.rate);
        truth.accelerations.push(accelerations);
        truth.contact.push(contact);
    }
    truth
}

/// The sensors' noise of `seed` on the seven accelerations, of standard deviations `std`
/// (m/s²): the stream [`measure`] draws from.
pub fn sensor_noise(seed: u64, std: [f64; 7]) -> SensorNoise<7> {
    SensorNoise::new(ChaCha8Rng::seed_from_u64(seed ^ NOISE_STREAM), std)
}

/// The noise's stream apart from the track's: the track's seed must not also draw the noise.
const NOISE_STREAM: u64 = 0x5EED_0F5E_5501;

/// Adds seeded white noise of `fraction` of each channel's RMS to the accelerations.
pub fn measure(truth: &Truth, fraction: f64, seed: u64) -> Measurements {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ NOISE_STREAM);
    let (accelerations, noise_std) = with_noise(&truth.accelerations, fraction, &mut rng);
    Measurements { accelerations, noise_std }
}
