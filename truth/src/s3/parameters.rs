//! The physical data of the S3 truth: one whole-car set, each value with its source
//! (`docs/references.md`); `[est]` marks our own choice. The vertical data are S2's
//! ([`VerticalVehicle`], the high-speed passenger car of `[Zhai2015]`); this file adds the
//! roll data, the lateral spans, the heights and the lateral suspension and contact. The
//! track is S2's, one per rail ([`Track`]).
//!
//! Convention: the whole car on two rails. Masses and inertias are whole; the primary
//! suspension is one spring per axle box (eight), the secondary one spring per bogie side
//! (four), as the tables give them. Each wheel carries `P0 = (m_c + 2m_t + 4m_w)·g / 8`.
//! Coordinates: x forward, y to the left, z down (Zhai's vertical convention).

pub use crate::s2::parameters::Track;
pub use crate::s2::parameters::Vehicle as VerticalVehicle;

/// The whole car: S2's vertical data and what a car on two rails adds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    /// Masses, pitch inertias, vertical suspension, spans along the car, wheel radius.
    /// [src: `[Zhai2015]`, through S2]
    pub vertical: VerticalVehicle,
    /// Car body roll inertia `I_cx` (kg·m²). [src: `[Zhai2015]`]
    pub car_body_roll_inertia: f64,
    /// Car body yaw inertia `I_cz` (kg·m²): taken equal to the pitch inertia, as for a long
    /// thin box. [est]
    pub car_body_yaw_inertia: f64,
    /// Bogie roll inertia `I_tx` (kg·m²). [src: `[Zhai2015]`]
    pub bogie_roll_inertia: f64,
    /// Bogie yaw inertia `I_tz` (kg·m²): about the sum of its pitch and roll inertias, as
    /// for a flat frame. [est]
    pub bogie_yaw_inertia: f64,
    /// Wheelset roll inertia `I_wx` (kg·m²). [src: `[Zhai2015]`]
    pub wheelset_roll_inertia: f64,
    /// Wheelset yaw inertia `I_wz` (kg·m²): equal to the roll inertia (an axle is a rod
    /// along y). [est]
    pub wheelset_yaw_inertia: f64,
    /// Lateral half span of the primary springs `d_w` (m). [src: `[Zhai2015]`]
    pub primary_half_span: f64,
    /// Lateral half span of the secondary springs `d_s` (m). [src: `[Zhai2015]`]
    pub secondary_half_span: f64,
    /// Half the distance between the rolling circles `a0` (m). [src: `[Zhai2015]`]
    pub contact_half_span: f64,
    /// Height of the car body's centre of mass above the rail top (m). [est]
    pub car_body_height: f64,
    /// Height of the secondary springs' plane above the rail top (m). [est]
    pub secondary_height: f64,
    /// Height of the bogie frame's centre of mass above the rail top (m). [est]
    pub bogie_height: f64,
    /// Primary longitudinal stiffness per axle box (N/m): about 10 MN/m. [est]
    pub primary_longitudinal_stiffness: f64,
    /// Primary lateral stiffness per axle box (N/m): a few MN/m. [est]
    pub primary_lateral_stiffness: f64,
    /// Secondary longitudinal stiffness per side (N/m): an air spring's shear. [est]
    pub secondary_longitudinal_stiffness: f64,
    /// Secondary lateral stiffness per side (N/m): 0.1–0.2 MN/m. [est]
    pub secondary_lateral_stiffness: f64,
    /// Secondary longitudinal damping per side (N·s/m): the yaw dampers. [est]
    pub secondary_longitudinal_damping: f64,
    /// Secondary lateral damping per side (N·s/m). [est]
    pub secondary_lateral_damping: f64,
    /// Equivalent conicity `λ_eq` of the wheel–rail pair: new profiles on 1:40 rails
    /// give 0.1–0.2. [est]
    pub conicity: f64,
    /// Kalker's longitudinal creep coefficient `f11` at the static wheel load (N): of
    /// order 10 MN at 56 kN. [est, after `[Kalker1990]`]
    pub longitudinal_creep: f64,
    /// Kalker's lateral creep coefficient `f22` at the static wheel load (N). [est, after
    /// `[Kalker1990]`]
    pub lateral_creep: f64,
}

impl Vehicle {
    /// Zhai's high-speed passenger car (`[Zhai2015]`) with our lateral data.
    pub const PASSENGER: Vehicle = Vehicle {
        vertical: VerticalVehicle::ZHAI_PASSENGER,
        car_body_roll_inertia: 7.506e4,
        car_body_yaw_inertia: 2.277e6,
        bogie_roll_inertia: 2_260.0,
        bogie_yaw_inertia: 5_000.0,
        wheelset_roll_inertia: 915.0,
        wheelset_yaw_inertia: 915.0,
        primary_half_span: 0.978,
        secondary_half_span: 0.978,
        contact_half_span: 0.7465,
        car_body_height: 1.8,
        secondary_height: 0.95,
        bogie_height: 0.6,
        primary_longitudinal_stiffness: 10e6,
        primary_lateral_stiffness: 3e6,
        secondary_longitudinal_stiffness: 0.15e6,
        secondary_lateral_stiffness: 0.15e6,
        secondary_longitudinal_damping: 2e5,
        secondary_lateral_damping: 3e4,
        conicity: 0.1,
        longitudinal_creep: 10e6,
        lateral_creep: 9e6,
    };

    /// The static load of one wheel on its rail (N): an eighth of the car's weight.
    pub fn static_wheel_load(&self) -> f64 {
        self.vertical.static_wheel_load()
    }

    /// The slope `λ_c` of the conical treads that gives the equivalent conicity: the
    /// wheelset rolls as it moves across (its roll carries the contact across the tread by
    /// `r0·φ`), so a cone of slope λ_eq would make a rolling-radius difference of
    /// `2·λ_eq·a0/(a0 − λ_eq·r0)·y`. The cone `λ_c = λ_eq·a0/(a0 + λ_eq·r0)` makes it
    /// `2·λ_eq·y`, the equivalent conicity's definition.
    pub fn tread_slope(&self) -> f64 {
        let (a0, r0) = (self.contact_half_span, self.vertical.wheel_radius);
        self.conicity * a0 / (a0 + self.conicity * r0)
    }

    /// Klingel's kinematic wavelength of a free wheelset (m): `2π·√(r0·a0/λ_eq)`
    /// `[Wickens2003]`.
    pub fn kinematic_wavelength(&self) -> f64 {
        std::f64::consts::TAU * (self.vertical.wheel_radius * self.contact_half_span / self.conicity).sqrt()
    }

    /// Checks that every mass, inertia, span and height is positive, every stiffness,
    /// damping and creep coefficient at least zero, the conicity positive, and the heights
    /// ordered (car body above the secondary plane, bogie below it).
    pub fn validate(&self) -> Result<(), String> {
        let v = &self.vertical;
        let positive = [
            ("car_body_mass", v.car_body_mass),
            ("car_body_pitch_inertia", v.car_body_pitch_inertia),
            ("bogie_mass", v.bogie_mass),
            ("bogie_pitch_inertia", v.bogie_pitch_inertia),
            ("wheelset_mass", v.wheelset_mass),
            ("half_bogie_spacing", v.half_bogie_spacing),
            ("half_wheelbase", v.half_wheelbase),
            ("wheel_radius", v.wheel_radius),
            ("car_body_roll_inertia", self.car_body_roll_inertia),
            ("car_body_yaw_inertia", self.car_body_yaw_inertia),
            ("bogie_roll_inertia", self.bogie_roll_inertia),
            ("bogie_yaw_inertia", self.bogie_yaw_inertia),
            ("wheelset_roll_inertia", self.wheelset_roll_inertia),
            ("wheelset_yaw_inertia", self.wheelset_yaw_inertia),
            ("primary_half_span", self.primary_half_span),
            ("secondary_half_span", self.secondary_half_span),
            ("contact_half_span", self.contact_half_span),
            ("bogie_height", self.bogie_height),
            ("conicity", self.conicity),
            ("primary_stiffness", v.primary_stiffness),
            ("secondary_stiffness", v.secondary_stiffness),
        ];
        if let Some((name, value)) = positive.iter().find(|(_, x)| !(*x > 0.0 && x.is_finite())) {
            return Err(format!("{name} must be positive, got {value}"));
        }
        let at_least_zero = [
            ("primary_damping", v.primary_damping),
            ("primary_damping_beyond", v.primary_damping_beyond),
            ("primary_damper_knee", v.primary_damper_knee),
            ("secondary_damping", v.secondary_damping),
            ("primary_longitudinal_stiffness", self.primary_longitudinal_stiffness),
            ("primary_lateral_stiffness", self.primary_lateral_stiffness),
            ("secondary_longitudinal_stiffness", self.secondary_longitudinal_stiffness),
            ("secondary_lateral_stiffness", self.secondary_lateral_stiffness),
            ("secondary_longitudinal_damping", self.secondary_longitudinal_damping),
            ("secondary_lateral_damping", self.secondary_lateral_damping),
            ("longitudinal_creep", self.longitudinal_creep),
            ("lateral_creep", self.lateral_creep),
        ];
        if let Some((name, value)) = at_least_zero.iter().find(|(_, x)| !(*x >= 0.0 && x.is_finite())) {
            return Err(format!("{name} must be at least 0, got {value}"));
        }
        if !(self.car_body_height > self.secondary_height && self.secondary_height > self.bogie_height) {
            return Err(format!(
                "the heights must rise from the bogie ({}) to the secondary plane ({}) to the car body ({})",
                self.bogie_height, self.secondary_height, self.car_body_height
            ));
        }
        Ok(())
    }
}
