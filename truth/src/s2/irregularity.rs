//! The vertical rail irregularities of S2, as functions of the distance along the track
//! (m): a random profile from a standard spectrum, a corrugation, and a weld (eq. (25) of
//! the paper). Values point down, as the model's coordinates do: a positive value is a dip
//! of the rail top.
//!
//! ## Track spectra
//!
//! A random profile is drawn from one of four one-sided vertical-profile densities
//! ([`TrackSpectrum`], by name):
//!
//! | name | spectrum | constants |
//! |---|---|---|
//! | `fra5` | FRA class 5 `[FRA-PSD]`, the study's default | `A_v` = 0.2095 cm²·rad/m, `Ω_c` = 0.8245 rad/m, k = 0.25 |
//! | `fra6` | FRA class 6 `[FRA-PSD]`, the best American class | `A_v` = 0.0339 cm²·rad/m, `Ω_c` = 0.8245 rad/m, k = 0.25 |
//! | `german-low` | German high-speed, low interference `[German-PSD]` | `A_v` = 4.032e-7 m·rad, `Ω_c` = 0.8246 rad/m, `Ω_r` = 0.0206 rad/m |
//! | `german-high` | German high-speed, high interference `[German-PSD]` | `A_v` = 1.080e-6 m·rad, the same `Ω_c`, `Ω_r` |
//!
//! FRA: `S(Ω) = k·A_v·Ω_c²/(Ω²·(Ω² + Ω_c²))`; German:
//! `S(Ω) = A_v·Ω_c²/((Ω² + Ω_r²)·(Ω² + Ω_c²))`, both in m²/(rad/m) with Ω in rad/m, and
//! both read as one-sided densities (the variance is `∫₀^∞ S dΩ`), as the literature that
//! samples them by a sum of cosines does `[Zhai2015]`. Over the sampled 1–120 m
//! wavelengths the RMS is 9.5 mm (FRA 5), 3.8 mm (FRA 6), 2.6 mm (German low) and 4.2 mm
//! (German high). Within that band the four have nearly one shape (`Ω_r` bends the German
//! ones only beyond 120 m) and differ in level: in density FRA 6 is 6.2 times below
//! FRA 5, German high 4.9 times and German low 13 times. The two
//! German spectra and FRA 6 are tracks the S2 estimator was not tuned on;
//! `cases::Settings::spectrum` picks one for the random case, and a seed draws the same
//! phases whatever the spectrum.

use estimator::math;
use std::fmt;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A one-sided vertical-profile density `S(Ω)` in m²/(rad/m), Ω in rad/m.
pub trait Spectrum {
    /// The one-sided density at `omega` rad/m.
    fn density(&self, omega: f64) -> f64;

    /// The variance of the profile between two wavelengths (m²): the density's integral
    /// from `2π/longest` to `2π/shortest`, by Simpson's rule in log Ω.
    fn variance(&self, shortest: f64, longest: f64) -> f64 {
        simpson_log(|omega| self.density(omega), shortest, longest)
    }
}

/// `∫ S(Ω) dΩ` from `2π/longest` to `2π/shortest` by Simpson's rule in log Ω (4000 panels).
fn simpson_log(density: impl Fn(f64) -> f64, shortest: f64, longest: f64) -> f64 {
    let (a, b) = (math::ln(std::f64::consts::TAU / longest), math::ln(std::f64::consts::TAU / shortest));
    let n = 4000;
    let h = (b - a) / n as f64;
    // ∫ S(Ω) dΩ = ∫ S(e^u)·e^u du.
    let f = |u: f64| density(math::exp(u)) * math::exp(u);
    let inner: f64 = (1..n).map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 }).sum();
    (f(a) + inner + f(b)) * h / 3.0
}

/// The American (FRA) vertical profile spectrum of a track class:
/// `S(Ω) = k·A_v·Ω_c² / (Ω²·(Ω² + Ω_c²))`, k = 0.25, in m²/(rad/m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FraSpectrum {
    /// Roughness `A_v` (m²·rad/m).
    pub roughness: f64,
    /// Cut-off `Ω_c` (rad/m).
    pub cutoff: f64,
}

impl FraSpectrum {
    /// Class 5. [src: `[FRA-PSD]`]
    pub const CLASS_5: FraSpectrum = FraSpectrum { roughness: 0.2095e-4, cutoff: 0.8245 };
    /// Class 6. [src: `[FRA-PSD]`]
    pub const CLASS_6: FraSpectrum = FraSpectrum { roughness: 0.0339e-4, cutoff: 0.8245 };

    /// The one-sided density at `omega` rad/m.
    pub fn density(&self, omega: f64) -> f64 {
        let c2 = self.cutoff * self.cutoff;
        0.25 * self.roughness * c2 / (omega * omega * (omega * omega + c2))
    }

    /// The variance of the profile between two wavelengths (m²): the spectrum's integral
    /// from `2π/longest` to `2π/shortest`, by Simpson's rule in log Ω.
    pub fn variance(&self, shortest: f64, longest: f64) -> f64 {
        simpson_log(|omega| self.density(omega), shortest, longest)
    }
}

impl Spectrum for FraSpectrum {
    fn density(&self, omega: f64) -> f64 {
        FraSpectrum::density(self, omega)
    }
}

/// The German high-speed vertical profile spectrum:
/// `S(Ω) = A_v·Ω_c² / ((Ω² + Ω_r²)·(Ω² + Ω_c²))`, in m²/(rad/m). [src: `[German-PSD]`]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GermanSpectrum {
    /// Roughness `A_v` (m·rad).
    pub roughness: f64,
    /// Cut-off `Ω_c` (rad/m).
    pub cutoff: f64,
    /// Roll-off `Ω_r` (rad/m).
    pub rolloff: f64,
}

impl GermanSpectrum {
    /// Low interference (the better track). [src: `[German-PSD]`]
    pub const LOW_INTERFERENCE: GermanSpectrum =
        GermanSpectrum { roughness: 4.032e-7, cutoff: 0.8246, rolloff: 0.0206 };
    /// High interference. [src: `[German-PSD]`]
    pub const HIGH_INTERFERENCE: GermanSpectrum =
        GermanSpectrum { roughness: 1.080e-6, cutoff: 0.8246, rolloff: 0.0206 };

    /// The one-sided density at `omega` rad/m.
    pub fn density(&self, omega: f64) -> f64 {
        let (c2, r2, o2) = (self.cutoff * self.cutoff, self.rolloff * self.rolloff, omega * omega);
        self.roughness * c2 / ((o2 + r2) * (o2 + c2))
    }

    /// The variance between two wavelengths (m²), by Simpson's rule as
    /// [`FraSpectrum::variance`].
    pub fn variance(&self, shortest: f64, longest: f64) -> f64 {
        simpson_log(|omega| self.density(omega), shortest, longest)
    }
}

impl Spectrum for GermanSpectrum {
    fn density(&self, omega: f64) -> f64 {
        GermanSpectrum::density(self, omega)
    }
}

/// One of the named track spectra of the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrackSpectrum {
    /// An FRA class.
    Fra(FraSpectrum),
    /// A German high-speed spectrum.
    German(GermanSpectrum),
}

impl TrackSpectrum {
    /// FRA class 5, the study's default.
    pub const FRA_5: TrackSpectrum = TrackSpectrum::Fra(FraSpectrum::CLASS_5);
    /// FRA class 6.
    pub const FRA_6: TrackSpectrum = TrackSpectrum::Fra(FraSpectrum::CLASS_6);
    /// German, low interference.
    pub const GERMAN_LOW: TrackSpectrum = TrackSpectrum::German(GermanSpectrum::LOW_INTERFERENCE);
    /// German, high interference.
    pub const GERMAN_HIGH: TrackSpectrum = TrackSpectrum::German(GermanSpectrum::HIGH_INTERFERENCE);
    /// The four named spectra.
    pub const ALL: [TrackSpectrum; 4] =
        [TrackSpectrum::FRA_5, TrackSpectrum::FRA_6, TrackSpectrum::GERMAN_LOW, TrackSpectrum::GERMAN_HIGH];

    /// Its name: `fra5`, `fra6`, `german-low`, `german-high`; `custom` for any other.
    pub fn name(&self) -> &'static str {
        match *self {
            s if s == TrackSpectrum::FRA_5 => "fra5",
            s if s == TrackSpectrum::FRA_6 => "fra6",
            s if s == TrackSpectrum::GERMAN_LOW => "german-low",
            s if s == TrackSpectrum::GERMAN_HIGH => "german-high",
            _ => "custom",
        }
    }

    /// What it is, for a table's header.
    pub fn description(&self) -> &'static str {
        match self.name() {
            "fra5" => "FRA class 5",
            "fra6" => "FRA class 6",
            "german-low" => "German high-speed, low interference",
            "german-high" => "German high-speed, high interference",
            _ => "a custom spectrum",
        }
    }

    /// The one-sided density at `omega` rad/m.
    pub fn density(&self, omega: f64) -> f64 {
        match self {
            TrackSpectrum::Fra(s) => s.density(omega),
            TrackSpectrum::German(s) => s.density(omega),
        }
    }

    /// The variance between two wavelengths (m²).
    pub fn variance(&self, shortest: f64, longest: f64) -> f64 {
        match self {
            TrackSpectrum::Fra(s) => s.variance(shortest, longest),
            TrackSpectrum::German(s) => s.variance(shortest, longest),
        }
    }
}

impl Spectrum for TrackSpectrum {
    fn density(&self, omega: f64) -> f64 {
        TrackSpectrum::density(self, omega)
    }
}

impl From<FraSpectrum> for TrackSpectrum {
    fn from(spectrum: FraSpectrum) -> Self {
        TrackSpectrum::Fra(spectrum)
    }
}

impl From<GermanSpectrum> for TrackSpectrum {
    fn from(spectrum: GermanSpectrum) -> Self {
        TrackSpectrum::German(spectrum)
    }
}

impl fmt::Display for TrackSpectrum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Parses a name of [`TrackSpectrum::name`]: `fra5`, `fra6`, `german-low`, `german-high`.
impl std::str::FromStr for TrackSpectrum {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        TrackSpectrum::ALL.into_iter().find(|t| t.name() == s).ok_or_else(|| {
            let names: Vec<&str> = TrackSpectrum::ALL.iter().map(TrackSpectrum::name).collect();
            format!("unknown track spectrum '{s}'; expected one of {}", names.join(", "))
        })
    }
}

/// A seeded sample of a spectrum over a stretch of track, tabulated on a fine grid and
/// read by cubic interpolation (the sum of cosines is too slow to evaluate every step).
#[derive(Debug, Clone, PartialEq)]
pub struct RandomProfile {
    start: f64,
    step: f64,
    values: Vec<f64>,
}

impl RandomProfile {
    /// Wavelengths sampled (m): 1 to 120 m, as `[Zhai2015]` advises.
    pub const WAVELENGTHS: (f64, f64) = (1.0, 120.0);
    /// Lines of the sum of cosines.
    pub const LINES: usize = 2000;
    /// Grid of the table (m): 1 cm, 100 points per shortest wavelength.
    pub const GRID: f64 = 0.01;

    /// `z(x) = Σ_k √(2·S(Ω_k)·ΔΩ)·cos(Ω_k·x + φ_k)` over `[start, end]`, the lines evenly
    /// spaced in Ω and their phases uniform and seeded: the same phases for every spectrum
    /// of the same seed.
    pub fn sample<S: Spectrum + ?Sized>(spectrum: &S, seed: u64, start: f64, end: f64) -> Self {
        let (shortest, longest) = Self::WAVELENGTHS;
        let (lo, hi) = (std::f64::consts::TAU / longest, std::f64::consts::TAU / shortest);
        let d_omega = (hi - lo) / Self::LINES as f64;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let lines: Vec<(f64, f64, f64)> = (0..Self::LINES)
            .map(|k| {
                let omega = lo + (k as f64 + 0.5) * d_omega;
                let amplitude = (2.0 * spectrum.density(omega) * d_omega).sqrt();
                (omega, amplitude, rng.random::<f64>() * std::f64::consts::TAU)
            })
            .collect();
        // Two points beyond each end, for the cubic.
        let points = ((end - start) / Self::GRID).ceil() as usize + 4;
        let values = (0..points)
            .map(|i| {
                let x = start + (i as f64 - 1.0) * Self::GRID;
                lines.iter().map(|(omega, amplitude, phase)| amplitude * math::cos(omega * x + phase)).sum()
            })
            .collect();
        Self { start, step: Self::GRID, values }
    }

    /// The profile at `x` (m), by Catmull–Rom interpolation; 0 outside the sampled stretch.
    pub fn at(&self, x: f64) -> f64 {
        let u = (x - self.start) / self.step + 1.0;
        let i = u.floor();
        if i < 1.0 || i as usize + 2 >= self.values.len() {
            return 0.0;
        }
        let (i, t) = (i as usize, u - i);
        let (p0, p1, p2, p3) = (self.values[i - 1], self.values[i], self.values[i + 1], self.values[i + 2]);
        p1 + 0.5 * t * (p2 - p0 + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)))
    }

    /// The RMS of the tabulated profile (m).
    pub fn rms(&self) -> f64 {
        (self.values.iter().map(|v| v * v).sum::<f64>() / self.values.len() as f64).sqrt()
    }
}

/// What the rail under the wheels looks like.
#[derive(Debug, Clone, PartialEq)]
pub enum Irregularity {
    /// A perfect rail.
    None,
    /// A random profile.
    Random(RandomProfile),
    /// A corrugation `½·a·(1 − cos 2πx/λ)` from `start` on.
    Corrugation {
        /// Depth `a` (m).
        depth: f64,
        /// Wavelength `λ` (m).
        wavelength: f64,
        /// Where it begins (m).
        start: f64,
    },
    /// A weld at `at` (eq. (25)): a long wave `a₁/λ₁` over `[at, at + λ₁)` and a short wave
    /// `a₂/λ₂` centred in it.
    Weld {
        /// Where the weld zone begins (m).
        at: f64,
        /// Long wave depth and wavelength (m).
        long: (f64, f64),
        /// Short wave depth and wavelength (m).
        short: (f64, f64),
    },
}

impl Irregularity {
    /// The paper's corrugation, 0.1 mm deep, 0.5 m long, from `start` on.
    pub fn corrugation(start: f64) -> Self {
        Irregularity::Corrugation { depth: 0.1e-3, wavelength: 0.5, start }
    }

    /// The paper's weld at `at`: 0.3 mm / 1.0 m plus 0.3 mm / 0.1 m.
    pub fn weld(at: f64) -> Self {
        Irregularity::Weld { at, long: (0.3e-3, 1.0), short: (0.3e-3, 0.1) }
    }

    /// The dip of the rail top at `x` (m).
    pub fn at(&self, x: f64) -> f64 {
        use std::f64::consts::TAU;
        match self {
            Irregularity::None => 0.0,
            Irregularity::Random(profile) => profile.at(x),
            Irregularity::Corrugation { depth, wavelength, start } => {
                if x < *start {
                    0.0
                } else {
                    0.5 * depth * (1.0 - math::cos(TAU * (x - start) / wavelength))
                }
            }
            Irregularity::Weld { at, long: (a1, l1), short: (a2, l2) } => {
                let s = x - at;
                if !(0.0..*l1).contains(&s) {
                    return 0.0;
                }
                let mut z = 0.5 * a1 * (1.0 - math::cos(TAU * s / l1));
                if ((l1 - l2) / 2.0..(l1 + l2) / 2.0).contains(&s) {
                    z += 0.5 * a2 * (1.0 - math::cos(std::f64::consts::PI / l2 * (2.0 * s - l1 + l2)));
                }
                z
            }
        }
    }
}
