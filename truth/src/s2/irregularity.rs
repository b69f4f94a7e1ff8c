//! The vertical rail irregularities of S2, as functions of the distance along the track
//! (m): a random profile from a standard spectrum, a corrugation, and a weld (eq. (25) of
//! the paper). Values point down, as the model's coordinates do: a positive value is a dip
//! of the rail top.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

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
        let (a, b) = ((std::f64::consts::TAU / longest).ln(), (std::f64::consts::TAU / shortest).ln());
        let n = 4000;
        let h = (b - a) / n as f64;
        // ∫ S(Ω) dΩ = ∫ S(e^u)·e^u du.
        let f = |u: f64| self.density(u.exp()) * u.exp();
        let inner: f64 = (1..n).map(|i| f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 }).sum();
        (f(a) + inner + f(b)) * h / 3.0
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
    /// spaced in Ω and their phases uniform and seeded.
    pub fn sample(spectrum: &FraSpectrum, seed: u64, start: f64, end: f64) -> Self {
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
                lines.iter().map(|(omega, amplitude, phase)| amplitude * (omega * x + phase).cos()).sum()
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
                    0.5 * depth * (1.0 - (TAU * (x - start) / wavelength).cos())
                }
            }
            Irregularity::Weld { at, long: (a1, l1), short: (a2, l2) } => {
                let s = x - at;
                if !(0.0..*l1).contains(&s) {
                    return 0.0;
                }
                let mut z = 0.5 * a1 * (1.0 - (TAU * s / l1).cos());
                if ((l1 - l2) / 2.0..(l1 + l2) / 2.0).contains(&s) {
                    z += 0.5 * a2 * (1.0 - (std::f64::consts::PI / l2 * (2.0 * s - l1 + l2)).cos());
                }
                z
            }
        }
    }
}
