//! The irregularities of the two rails, as functions of the distance along the track (m):
//! each rail's vertical dip (down, as the model's coordinates) and the alignment, the
//! lateral offset of both rails together (left); the gauge stays nominal.
//!
//! **Random track** `[German-PSD]`: a mean vertical profile `z_v` of the German vertical
//! spectrum and a cross-level `c` (rad) of its cross-level spectrum,
//! `S_c(Ω) = (A_v/b²)·Ω_c²·Ω² / ((Ω² + Ω_r²)·(Ω² + Ω_c²)·(Ω² + Ω_s²))`, Ω_s = 0.438 rad/m,
//! b = 0.75 m, both sampled as S2 samples a profile (wavelengths 1–120 m, a sum of
//! cosines, seeded; [`RandomProfile`]), independently. The rails are
//! `z_L = z_v + b·c`, `z_R = z_v − b·c`: the cross-level is the height difference over
//! `2b`. The alignment, when asked for, has the vertical spectrum's form with `A_a`. The
//! random track fades in over [`Irregularity::FADE`] metres ahead of the front wheel's
//! start, so that the run starts in static equilibrium on a level track.
//!
//! **Dips** (a dipped joint on one rail, or on both): `½·a·(1 − cos 2πs/L)` over a length
//! L from `at` on, a depth per rail. **Twist**: a cross-level that changes linearly by
//! `change` over `length` from `start` on and then stays, the left rail going down by half
//! of it and the right up by half.

use crate::s2::irregularity::{GermanSpectrum, RandomProfile, Spectrum};
use estimator::math;

/// Half the distance between the rolling circles `b` in the cross-level spectrum's
/// definition (m). [src: `[German-PSD]`]
const CROSS_LEVEL_HALF_SPAN: f64 = 0.75;

/// The German cross-level spectrum (rad²/(rad/m)). [src: `[German-PSD]`]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossLevelSpectrum {
    /// The vertical spectrum whose `A_v`, `Ω_c`, `Ω_r` it takes.
    pub vertical: GermanSpectrum,
    /// `Ω_s` (rad/m).
    pub corner: f64,
}

impl Spectrum for CrossLevelSpectrum {
    fn density(&self, omega: f64) -> f64 {
        let v = &self.vertical;
        let (c2, r2, s2, o2) = (v.cutoff * v.cutoff, v.rolloff * v.rolloff, self.corner * self.corner, omega * omega);
        let b2 = CROSS_LEVEL_HALF_SPAN * CROSS_LEVEL_HALF_SPAN;
        v.roughness / b2 * c2 * o2 / ((o2 + r2) * (o2 + c2) * (o2 + s2))
    }
}

/// The spectra of one German track quality.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSpectra {
    /// Vertical profile.
    pub vertical: GermanSpectrum,
    /// Cross-level.
    pub cross_level: CrossLevelSpectrum,
    /// Alignment.
    pub alignment: GermanSpectrum,
}

impl TrackSpectra {
    /// Low interference, the better track: `A_a` = 2.119e-7 m·rad. [src: `[German-PSD]`]
    pub const GERMAN_LOW: TrackSpectra = TrackSpectra {
        vertical: GermanSpectrum::LOW_INTERFERENCE,
        cross_level: CrossLevelSpectrum { vertical: GermanSpectrum::LOW_INTERFERENCE, corner: 0.438 },
        alignment: GermanSpectrum { roughness: 2.119e-7, ..GermanSpectrum::LOW_INTERFERENCE },
    };
    /// High interference: `A_a` = 6.125e-7 m·rad. [src: `[German-PSD]`]
    pub const GERMAN_HIGH: TrackSpectra = TrackSpectra {
        vertical: GermanSpectrum::HIGH_INTERFERENCE,
        cross_level: CrossLevelSpectrum { vertical: GermanSpectrum::HIGH_INTERFERENCE, corner: 0.438 },
        alignment: GermanSpectrum { roughness: 6.125e-7, ..GermanSpectrum::HIGH_INTERFERENCE },
    };
}

/// A random track: its profiles and where it fades in.
#[derive(Debug, Clone, PartialEq)]
pub struct RandomTrack {
    /// The mean vertical profile (m).
    pub vertical: RandomProfile,
    /// The cross-level (rad).
    pub cross_level: RandomProfile,
    /// The alignment (m), if the track has one.
    pub alignment: Option<RandomProfile>,
    /// Where the fade-in begins (m).
    pub start: f64,
}

/// The rails at one place.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Rails {
    /// The left rail's dip (m, down).
    pub left: f64,
    /// The right rail's dip (m, down).
    pub right: f64,
    /// The alignment (m, left).
    pub alignment: f64,
}

impl Rails {
    /// The dip of rail `side` (+1 left, −1 right).
    pub fn dip(&self, side: f64) -> f64 {
        if side > 0.0 {
            self.left
        } else {
            self.right
        }
    }
}

/// What the rails under the car look like.
#[derive(Debug, Clone, PartialEq)]
pub enum Irregularity {
    /// A perfect track.
    None,
    /// A random track.
    Random(RandomTrack),
    /// A cosine dip of each rail over `[at, at + length)`.
    Dip {
        /// Where it begins (m).
        at: f64,
        /// Its length (m).
        length: f64,
        /// The left rail's depth (m).
        left: f64,
        /// The right rail's depth (m).
        right: f64,
    },
    /// A twist: the cross-level changes by `change` over `length` from `start` on.
    Twist {
        /// Where it begins (m).
        start: f64,
        /// Over how long (m).
        length: f64,
        /// The change of the rails' height difference, left below right (m).
        change: f64,
    },
}

impl Irregularity {
    /// The random track's fade-in (m).
    pub const FADE: f64 = 10.0;

    /// A random track over `[start, end]` of `spectra`, from one seed: the vertical
    /// profile, the cross-level and the alignment each draw their own phases from it.
    pub fn random(spectra: &TrackSpectra, seed: u64, start: f64, end: f64, alignment: bool) -> Self {
        Irregularity::Random(RandomTrack {
            vertical: RandomProfile::sample(&spectra.vertical, seed, start, end),
            cross_level: RandomProfile::sample(&spectra.cross_level, seed ^ 0xC055_1E7E, start, end),
            alignment: alignment.then(|| RandomProfile::sample(&spectra.alignment, seed ^ 0xA119_0000, start, end)),
            start,
        })
    }

    /// A dipped joint of one rail, 1 mm deep over 1 m ([est]), at `at`, on the left rail.
    pub fn dipped_joint(at: f64) -> Self {
        Irregularity::Dip { at, length: 1.0, left: 1e-3, right: 0.0 }
    }

    /// A warped track: the cross-level changes by 6 mm over 20 m from `start` on.
    pub fn twist(start: f64) -> Self {
        Irregularity::Twist { start, length: 20.0, change: 6e-3 }
    }

    /// The rails at `x` (m).
    pub fn at(&self, x: f64) -> Rails {
        match self {
            Irregularity::None => Rails::default(),
            Irregularity::Random(track) => {
                let s = (x - track.start) / Self::FADE;
                if s <= 0.0 {
                    return Rails::default();
                }
                let fade = if s >= 1.0 { 1.0 } else { 0.5 * (1.0 - math::cos(std::f64::consts::PI * s)) };
                let (mean, half) = (track.vertical.at(x), CROSS_LEVEL_HALF_SPAN * track.cross_level.at(x));
                Rails {
                    left: fade * (mean + half),
                    right: fade * (mean - half),
                    alignment: track.alignment.as_ref().map_or(0.0, |a| fade * a.at(x)),
                }
            }
            Irregularity::Dip { at, length, left, right } => {
                let s = x - at;
                if !(0.0..*length).contains(&s) {
                    return Rails::default();
                }
                let shape = 0.5 * (1.0 - math::cos(std::f64::consts::TAU * s / length));
                Rails { left: left * shape, right: right * shape, alignment: 0.0 }
            }
            Irregularity::Twist { start, length, change } => {
                let half = 0.5 * change * ((x - start) / length).clamp(0.0, 1.0);
                Rails { left: half, right: -half, alignment: 0.0 }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cross-level spectrum is S3's own (the vertical and alignment ones are S2's
    /// form): a sample's variance, averaged over three seeds, is its integral over 1–120 m.
    /// The density is nearly flat in Ω from 120 m down to 14 m wavelengths, so 400 m hold
    /// only a few of the longest waves and the variance scatters by 10–30 % (over one whole
    /// period of the sum of cosines, 2017 m, it is exact: 0.999, 1.000, 1.000 of the integral
    /// for seeds 0–2, but that takes 25 s); a wrong normalisation, a factor 2 or 2π, fails.
    #[test]
    fn the_sampled_cross_level_has_its_spectrum_variance() {
        let spectrum = TrackSpectra::GERMAN_LOW.cross_level;
        let expected = spectrum.variance(1.0, 120.0);
        let seeds = 3;
        let variance: f64 =
            (0..seeds).map(|seed| RandomProfile::sample(&spectrum, seed, 0.0, 400.0).rms().powi(2)).sum::<f64>()
                / seeds as f64;
        let height = 2.0 * CROSS_LEVEL_HALF_SPAN * expected.sqrt();
        eprintln!(
            "cross-level RMS {:.3e} rad against {:.3e} rad: a rail-height difference of {:.2} mm RMS",
            variance.sqrt(),
            expected.sqrt(),
            height * 1e3
        );
        assert!((0.7..1.4).contains(&(variance / expected)), "{variance} against {expected}");
    }

    #[test]
    fn a_dip_on_one_rail_is_half_mean_and_half_cross_level() {
        let joint = Irregularity::dipped_joint(5.0);
        let middle = joint.at(5.5);
        assert!((middle.left - 1e-3).abs() < 1e-15 && middle.right == 0.0);
        assert_eq!(joint.at(4.9), Rails::default());
        let twist = Irregularity::twist(0.0);
        let end = twist.at(30.0);
        assert!((end.left - end.right - 6e-3).abs() < 1e-15 && (end.left + end.right).abs() < 1e-15);
    }
}
