//! The physical data of the S2 truth: one vehicle set and one track set, each value with
//! its source (`docs/references.md`). `[est]` marks our own choice.
//!
//! Convention: a vertical model of one rail, carrying half the vehicle. Masses and pitch
//! inertias are halved; the primary suspension is one axle box per wheel, the secondary
//! one spring per bogie side, as the tables give them per side. Each wheel then carries
//! `P0 = (m_c + 2m_t + 4m_w)·g / 8`. Coordinates point down (Zhai's convention).

use estimator::math;

/// Gravity (m/s²).
pub const G: f64 = 9.81;

/// The vehicle, whole (the model halves what it must).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    /// Car body mass (kg). [src: Zhai, Vehicle–Track Coupled Dynamics, high-speed passenger set]
    pub car_body_mass: f64,
    /// Car body pitch inertia (kg·m²). [src: Zhai]
    pub car_body_pitch_inertia: f64,
    /// Bogie frame mass (kg). [src: Zhai]
    pub bogie_mass: f64,
    /// Bogie pitch inertia (kg·m²). [src: Zhai]
    pub bogie_pitch_inertia: f64,
    /// Wheelset mass (kg). [src: Zhai]
    pub wheelset_mass: f64,
    /// Primary vertical stiffness per axle box (N/m). [src: Zhai]
    pub primary_stiffness: f64,
    /// Primary damper, slope up to the knee (N·s/m). [src: Zhai, C_pz]
    pub primary_damping: f64,
    /// Primary damper, slope beyond the knee (N·s/m): eq. (1) of the paper, a blow-off
    /// valve at a third of the low-speed slope. [est]
    pub primary_damping_beyond: f64,
    /// Primary damper knee: relative velocity where the slope changes (m/s). [est]
    pub primary_damper_knee: f64,
    /// Secondary vertical stiffness per side (N/m). [src: Zhai]
    pub secondary_stiffness: f64,
    /// Secondary vertical damping per side (N·s/m). [src: Zhai]
    pub secondary_damping: f64,
    /// Half the bogie spacing (m). [src: Zhai]
    pub half_bogie_spacing: f64,
    /// Half the wheelbase (m). [src: Zhai]
    pub half_wheelbase: f64,
    /// Wheel radius (m). [src: Zhai]
    pub wheel_radius: f64,
}

impl Vehicle {
    /// Zhai's high-speed passenger car (`[Zhai2015]`).
    pub const ZHAI_PASSENGER: Vehicle = Vehicle {
        car_body_mass: 34_000.0,
        car_body_pitch_inertia: 2.277e6,
        bogie_mass: 3_000.0,
        bogie_pitch_inertia: 2_710.0,
        wheelset_mass: 1_400.0,
        primary_stiffness: 0.55e6,
        primary_damping: 6e3,
        primary_damping_beyond: 2e3,
        primary_damper_knee: 0.1,
        secondary_stiffness: 0.4e6,
        secondary_damping: 8e4,
        half_bogie_spacing: 9.0,
        half_wheelbase: 1.2,
        wheel_radius: 0.4575,
    };

    /// The static load of one wheel on its rail (N): an eighth of the vehicle's weight.
    pub fn static_wheel_load(&self) -> f64 {
        (self.car_body_mass + 2.0 * self.bogie_mass + 4.0 * self.wheelset_mass) * G / 8.0
    }

    /// The Hertz coefficient `G` of a conical tread (m/N^(2/3)):
    /// `4.57·R^−0.149·1e-8`. [src: `[Zhai2015]`]
    pub fn hertz_coefficient(&self) -> f64 {
        4.57e-8 * math::powf(self.wheel_radius, -0.149)
    }

    /// The wheels' positions along the track relative to the car body's centre (m), front
    /// first: `l_c + l_t`, `l_c − l_t`, `−l_c + l_t`, `−l_c − l_t`.
    pub fn wheel_offsets(&self) -> [f64; 4] {
        let (lc, lt) = (self.half_bogie_spacing, self.half_wheelbase);
        [lc + lt, lc - lt, -lc + lt, -lc - lt]
    }

    /// The vehicle under the names of the S2 estimator FMU's parameters
    /// (`kalfmu_s2_wheel_rail`), as a user sets their catalogue car in it; the static wheel
    /// load, which the user weighs rather than computes, is not among them. One list for
    /// the study's FMU runs and for the logs the tuning tests simulate, which may not
    /// depend on the study.
    pub fn fmu_parameters(&self) -> [(&'static str, f64); 13] {
        [
            ("car_body_mass", self.car_body_mass),
            ("car_body_pitch_inertia", self.car_body_pitch_inertia),
            ("bogie_mass", self.bogie_mass),
            ("bogie_pitch_inertia", self.bogie_pitch_inertia),
            ("wheelset_mass", self.wheelset_mass),
            ("primary_stiffness", self.primary_stiffness),
            ("primary_damping", self.primary_damping),
            ("primary_damping_beyond", self.primary_damping_beyond),
            ("primary_damper_knee", self.primary_damper_knee),
            ("secondary_stiffness", self.secondary_stiffness),
            ("secondary_damping", self.secondary_damping),
            ("half_bogie_spacing", self.half_bogie_spacing),
            ("half_wheelbase", self.half_wheelbase),
        ]
    }
}

/// One rail of a ballasted track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Track {
    /// Rail mass per metre (kg/m). [src: CHN60]
    pub rail_mass_per_metre: f64,
    /// Rail bending stiffness `E·I` (N·m²): 2.059e11 Pa × 3.217e-5 m⁴. [src: CHN60]
    pub rail_bending_stiffness: f64,
    /// Fastener / pad stiffness (N/m). [src]
    pub pad_stiffness: f64,
    /// Fastener / pad damping (N·s/m). [src]
    pub pad_damping: f64,
    /// Sleeper spacing (m). [src]
    pub sleeper_spacing: f64,
    /// Sleeper mass per rail (kg). [src]
    pub sleeper_mass: f64,
    /// Ballast block mass (kg). [src]
    pub ballast_mass: f64,
    /// Ballast vertical stiffness (N/m). [src]
    pub ballast_stiffness: f64,
    /// Ballast vertical damping (N·s/m). [src]
    pub ballast_damping: f64,
    /// Shear stiffness between neighbouring ballast blocks (N/m). [src]
    pub ballast_shear_stiffness: f64,
    /// Shear damping between neighbouring ballast blocks (N·s/m). [src]
    pub ballast_shear_damping: f64,
    /// Subgrade stiffness (N/m). [src]
    pub subgrade_stiffness: f64,
    /// Subgrade damping (N·s/m). [src]
    pub subgrade_damping: f64,
}

impl Track {
    /// The ballasted track of `[Zhai2015]` (CHN60 rail, Zhai's ballast model).
    pub const BALLASTED: Track = Track {
        rail_mass_per_metre: 60.64,
        rail_bending_stiffness: 2.059e11 * 3.217e-5,
        pad_stiffness: 6.0e7,
        pad_damping: 5.0e4,
        sleeper_spacing: 0.6,
        sleeper_mass: 237.0,
        ballast_mass: 341.3,
        ballast_stiffness: 2.4e8,
        ballast_damping: 5.88e4,
        ballast_shear_stiffness: 7.8e7,
        ballast_shear_damping: 8e4,
        subgrade_stiffness: 6.5e7,
        subgrade_damping: 3.1e4,
    };
}
