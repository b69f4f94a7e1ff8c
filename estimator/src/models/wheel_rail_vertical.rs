//! Study S2: the vertical vehicle on one rail (half a four-axle vehicle: car body in bounce
//! and pitch, two bogies in bounce and pitch, four wheelsets in bounce), with the four
//! wheel–rail forces `F_N1..4` as unknown random walks, eq. (7) of the paper:
//!
//! ```text
//! m_c·z̈_c   = F_s1 + F_s2                      I_c·β̈_c  = (F_s1 − F_s2)·l_c
//! m_t·z̈_ti  = F_p(2i−1) + F_p(2i) − F_si       I_t·β̈_ti = (F_p(2i−1) − F_p(2i))·l_t
//! m_w·z̈_wj  = −F_pj − P_st + F_Nj              Ḟ_Nj = 0 (+ noise)
//! ```
//!
//! Coordinates point up and are deviations from static equilibrium (so gravity and the
//! static suspension forces cancel, and the static wheel load `P_st` is what `F_N` carries
//! at rest); a point at `d` ahead of a body's centre rises by `z + d·β`. The suspension
//! forces act from the relative displacements and velocities, `F_si = K_s·(z_ti − z_c −
//! d_i·β_c) + C_s·(…)`, `F_pj = K_p·(z_wj − z_ti − e_j·β_ti) + C_p(…)`, the primary damper
//! piecewise linear in its velocity (eq. (1)). There is no track in this model: the wheels
//! are driven by `F_N` alone.
//!
//! State (24): `[z_c, β_c, z_t1, z_t2, β_t1, β_t2, z_w1..4, their 10 velocities, F_N1..4]`;
//! measurements (7): `[z̈_c, z̈_t1, z̈_t2, z̈_w1..4]` (m/s², up).

use crate::model::{Component, Observation, VectorField};
use crate::models::PiecewiseLinear;

/// The vehicle as the estimator knows it: the half on one rail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerticalVehicle {
    /// Car body mass on this rail (kg): half the car body.
    pub car_body_mass: f64,
    /// Car body pitch inertia on this rail (kg·m²).
    pub car_body_pitch_inertia: f64,
    /// Bogie mass on this rail (kg).
    pub bogie_mass: f64,
    /// Bogie pitch inertia on this rail (kg·m²).
    pub bogie_pitch_inertia: f64,
    /// Wheelset mass on this rail (kg).
    pub wheelset_mass: f64,
    /// Primary stiffness per axle box (N/m).
    pub primary_stiffness: f64,
    /// Primary damper law of the relative velocity (N).
    pub primary_damper: PiecewiseLinear,
    /// Secondary stiffness per side (N/m).
    pub secondary_stiffness: f64,
    /// Secondary damping per side (N·s/m).
    pub secondary_damping: f64,
    /// Half the bogie spacing `l_c` (m).
    pub half_bogie_spacing: f64,
    /// Half the wheelbase `l_t` (m).
    pub half_wheelbase: f64,
    /// The static wheel load `P_st` (N).
    pub static_wheel_load: f64,
}

/// Gravity for the static wheel load (m/s²).
const G: f64 = 9.81;

impl VerticalVehicle {
    /// Half of a vehicle given whole (masses and pitch inertias of the whole car body,
    /// bogie and wheelset; suspension per axle box and per side): `P_st` is an eighth of its
    /// weight.
    #[allow(clippy::too_many_arguments)]
    pub fn half_of(
        car_body: (f64, f64),
        bogie: (f64, f64),
        wheelset_mass: f64,
        primary: (f64, PiecewiseLinear),
        secondary: (f64, f64),
        half_bogie_spacing: f64,
        half_wheelbase: f64,
    ) -> Self {
        Self {
            car_body_mass: car_body.0 / 2.0,
            car_body_pitch_inertia: car_body.1 / 2.0,
            bogie_mass: bogie.0 / 2.0,
            bogie_pitch_inertia: bogie.1 / 2.0,
            wheelset_mass: wheelset_mass / 2.0,
            primary_stiffness: primary.0,
            primary_damper: primary.1,
            secondary_stiffness: secondary.0,
            secondary_damping: secondary.1,
            half_bogie_spacing,
            half_wheelbase,
            static_wheel_load: (car_body.0 + 2.0 * bogie.0 + 4.0 * wheelset_mass) * G / 8.0,
        }
    }

    /// Half of Zhai's high-speed passenger car (`[Zhai2015]`), its primary damper
    /// blowing off to a third of its slope beyond 0.1 m/s: the catalogue vehicle of study S2.
    pub fn zhai_passenger() -> Self {
        let damper = PiecewiseLinear::new([6e3, 2e3, 2e3], [0.1, 0.1]).expect("a valid damper law");
        Self::half_of((34e3, 2.277e6), (3e3, 2_710.0), 1_400.0, (0.55e6, damper), (0.4e6, 8e4), 9.0, 1.2)
    }

    /// The accelerations of the ten coordinates, in state order, for positions `z`,
    /// velocities `v` and the wheel–rail forces `f_n`.
    pub fn accelerations(&self, z: &[f64], v: &[f64], f_n: &[f64]) -> [f64; 10] {
        self.accelerations_lanes::<1>(z.as_chunks().0, v.as_chunks().0, f_n.as_chunks().0).map(|[a]| a)
    }

    /// [`accelerations`](Self::accelerations) lane by lane (`L = 1`: one point; a block of
    /// points), without branches, so that the compiler vectorises it across the points;
    /// the same operations in the same order in every lane.
    #[inline(always)]
    pub fn accelerations_lanes<const L: usize>(
        &self,
        z: &[[f64; L]],
        v: &[[f64; L]],
        f_n: &[[f64; L]],
    ) -> [[f64; L]; 10] {
        let (lc, lt) = (self.half_bogie_spacing, self.half_wheelbase);
        // Bogie i at d_i = ±l_c; in the state z_c is 0, β_c 1, z_ti 2 + i, β_ti 4 + i.
        let mut f_s = [[0.0; L]; 2];
        let mut f_p = [[0.0; L]; 4];
        for (i, d) in [lc, -lc].into_iter().enumerate() {
            for l in 0..L {
                let stretch = z[2 + i][l] - z[0][l] - d * z[1][l];
                let rate = v[2 + i][l] - v[0][l] - d * v[1][l];
                f_s[i][l] = self.secondary_stiffness * stretch + self.secondary_damping * rate;
            }
            for (k, e) in [lt, -lt].into_iter().enumerate() {
                let j = 2 * i + k;
                let mut rate = [0.0; L];
                for l in 0..L {
                    rate[l] = v[6 + j][l] - v[2 + i][l] - e * v[4 + i][l];
                }
                let damper = self.primary_damper.force_lanes(&rate);
                for l in 0..L {
                    let stretch = z[6 + j][l] - z[2 + i][l] - e * z[4 + i][l];
                    f_p[j][l] = self.primary_stiffness * stretch + damper[l];
                }
            }
        }
        let mut a = [[0.0; L]; 10];
        for l in 0..L {
            a[0][l] = (f_s[0][l] + f_s[1][l]) / self.car_body_mass;
            a[1][l] = (f_s[0][l] - f_s[1][l]) * lc / self.car_body_pitch_inertia;
            for i in 0..2 {
                a[2 + i][l] = (f_p[2 * i][l] + f_p[2 * i + 1][l] - f_s[i][l]) / self.bogie_mass;
                a[4 + i][l] = (f_p[2 * i][l] - f_p[2 * i + 1][l]) * lt / self.bogie_pitch_inertia;
            }
            for j in 0..4 {
                a[6 + j][l] = (-f_p[j][l] - self.static_wheel_load + f_n[j][l]) / self.wheelset_mass;
            }
        }
        a
    }
}

/// The augmented estimation model of eq. (7): 24 states, 7 accelerations measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelRailVertical {
    /// The vehicle the estimator assumes.
    pub vehicle: VerticalVehicle,
}

impl WheelRailVertical {
    /// Index of `F_N1` in the state; `F_N2..4` follow.
    pub const FORCES: usize = 20;
    /// The unknown inputs' states, the four forces: what a jump (a weld) moves.
    pub const UNKNOWN_INPUTS: [usize; 4] = [20, 21, 22, 23];
    /// Names of the state components, in order.
    pub const STATE_NAMES: [&'static str; 24] = [
        "z_c",
        "beta_c",
        "z_t1",
        "z_t2",
        "beta_t1",
        "beta_t2",
        "z_w1",
        "z_w2",
        "z_w3",
        "z_w4",
        "z_c_dot",
        "beta_c_dot",
        "z_t1_dot",
        "z_t2_dot",
        "beta_t1_dot",
        "beta_t2_dot",
        "z_w1_dot",
        "z_w2_dot",
        "z_w3_dot",
        "z_w4_dot",
        "F_N1",
        "F_N2",
        "F_N3",
        "F_N4",
    ];
    /// Names of the measurements, in order.
    pub const MEASUREMENT_NAMES: [&'static str; 7] =
        ["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"];
    /// The measured coordinates' indices among the ten: body, bogies and wheelsets bounce.
    const MEASURED: [usize; 7] = [0, 2, 3, 6, 7, 8, 9];
}

impl WheelRailVertical {
    /// `ẋ` lane by lane: `L = 1` for one point, or a block of points.
    #[inline(always)]
    fn derivative_lanes<const L: usize>(&self, x: &[[f64; L]], dxdt: &mut [[f64; L]]) {
        let a = self.vehicle.accelerations_lanes(&x[..10], &x[10..20], &x[20..24]);
        dxdt[..10].copy_from_slice(&x[10..20]);
        dxdt[10..20].copy_from_slice(&a);
        dxdt[20..24].fill([0.0; L]);
    }

    /// The seven measured accelerations lane by lane.
    #[inline(always)]
    fn observe_lanes<const L: usize>(&self, x: &[[f64; L]], z: &mut [[f64; L]]) {
        let a = self.vehicle.accelerations_lanes(&x[..10], &x[10..20], &x[20..24]);
        for (zi, k) in z.iter_mut().zip(Self::MEASURED) {
            *zi = a[k];
        }
    }
}

impl VectorField for WheelRailVertical {
    fn state_dim(&self) -> usize {
        24
    }

    fn derivative(&self, _t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        self.derivative_lanes::<1>(x.as_chunks().0, dxdt.as_chunks_mut().0);
    }

    #[inline(always)]
    fn derivative_block(&self, _t: f64, x: &[Component], _u: &[f64], dxdt: &mut [Component], _scratch: &mut [f64]) {
        self.derivative_lanes(x, dxdt);
    }
}

impl Observation for WheelRailVertical {
    fn measurement_dim(&self) -> usize {
        7
    }

    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.observe_lanes::<1>(x.as_chunks().0, z.as_chunks_mut().0);
    }

    #[inline(always)]
    fn observe_block(&self, _t: f64, x: &[Component], _u: &[f64], z: &mut [Component], _scratch: &mut [f64]) {
        self.observe_lanes(x, z);
    }
}
