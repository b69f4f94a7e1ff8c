//! Study S3: the whole car in bounce, pitch and roll (car body and two bogies in all three,
//! four wheelsets in bounce and roll: 17 DOF), with the eight vertical wheel–rail forces
//! `F_NLj`, `F_NRj` as unknown states, eq. (26) of `[Chen2025]`:
//!
//! ```text
//! m_c·z̈_c  = Σ F_s                     I_cy·β̈_c  = Σ x_i·F_s        I_cx·φ̈_c  = Σ ±d_s·F_s
//! m_t·z̈_ti = Σ F_p − Σ F_si            I_ty·β̈_ti = Σ e_j·F_p        I_tx·φ̈_ti = Σ ±d_w·F_p − Σ ±d_s·F_si
//! m_w·z̈_wj = −F_pLj − F_pRj − 2P₀ + F_NLj + F_NRj
//! I_wx·φ̈_wj = −d_w·(F_pLj − F_pRj) + a₀·(F_NLj − F_NRj)
//! Ḟ_N = −r·(F_N − P₀)  (+ noise)
//! ```
//!
//! Coordinates point up and are deviations from static equilibrium, as in
//! [`WheelRailVertical`](super::WheelRailVertical): a point `x` ahead of a body's centre
//! and `y` to its left (left positive) rises by `z + x·β + y·φ`, and a vertical force there
//! gives the moments `x·F` (pitch) and `y·F` (roll). Each secondary spring sits at
//! `(±l_c, ±d_s)`, each primary at `(±l_t, ±d_w)` of its bogie, each contact at `±a₀` of its
//! wheelset. `F_p` and `F_s` are the springs' compressions times their stiffness plus the
//! dampers' forces (the primary damper piecewise linear, as in S2).
//!
//! **The force model.** `r` is the forces' return rate (1/s). With `r = 0` each force is a
//! random walk, the paper's model: then the static force patterns that the suspension
//! balances without moving the car (a roll moment of one wheelset taken by another's,
//! through the bogies and the car body: three such patterns of `F_L − F_R`) give no
//! acceleration at all, so no accelerometer sees them and their estimate wanders. With
//! `r > 0` the forces are Gauss–Markov processes returning to the weighed static wheel load
//! `P₀` with the correlation time `1/r`: the wandering patterns are pulled back to where a
//! train on straight track keeps them. Primary deflection transducers see the patterns
//! directly. (Without a track, the car's bounce, pitch and roll and each bogie's pitch with
//! its wheelsets following are resisted by no spring either; they move no force, and
//! `estimator/tests/wheel_rail_roll.rs` counts all of these.)
//!
//! **What it leaves out**, which the truth has: the track (the wheels are driven by `F_N`
//! alone), all lateral and yaw motion, the contact points' shift with the wheelset's lateral
//! displacement (`a₀` is fixed), the lateral contact forces' moments, and the roll
//! stiffness of gravity acting on centres of mass above the roll axes.
//!
//! State (42): the 17 positions `[z_c, β_c, φ_c, z_t1, β_t1, φ_t1, z_t2, β_t2, φ_t2, z_w1,
//! φ_w1, …, z_w4, φ_w4]`, their 17 velocities, then `[F_NL1, F_NR1, …, F_NL4, F_NR4]`.
//! Measurements (28): the vertical accelerations (m/s², up) of both axle boxes of each
//! wheelset, of the bogie frame above each axle box and of the car body above each
//! secondary spring (20), then the eight primary deflections (m, compression positive),
//! which a user without deflection transducers leaves missing.

use crate::model::{Component, Observation, VectorField};
use crate::models::PiecewiseLinear;

/// The whole car as the estimator knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollVehicle {
    /// Car body mass (kg).
    pub car_body_mass: f64,
    /// Car body pitch inertia `I_cy` (kg·m²).
    pub car_body_pitch_inertia: f64,
    /// Car body roll inertia `I_cx` (kg·m²).
    pub car_body_roll_inertia: f64,
    /// Mass of one bogie (kg).
    pub bogie_mass: f64,
    /// Bogie pitch inertia `I_ty` (kg·m²).
    pub bogie_pitch_inertia: f64,
    /// Bogie roll inertia `I_tx` (kg·m²).
    pub bogie_roll_inertia: f64,
    /// Mass of one wheelset (kg).
    pub wheelset_mass: f64,
    /// Wheelset roll inertia `I_wx` (kg·m²).
    pub wheelset_roll_inertia: f64,
    /// Primary vertical stiffness per axle box (N/m).
    pub primary_stiffness: f64,
    /// Primary damper law of the relative velocity, per axle box (N).
    pub primary_damper: PiecewiseLinear,
    /// Secondary vertical stiffness per side of a bogie (N/m).
    pub secondary_stiffness: f64,
    /// Secondary vertical damping per side of a bogie (N·s/m).
    pub secondary_damping: f64,
    /// Half the bogie spacing `l_c` (m).
    pub half_bogie_spacing: f64,
    /// Half the wheelbase `l_t` (m).
    pub half_wheelbase: f64,
    /// Half the lateral span of the primary springs `d_w` (m).
    pub primary_half_span: f64,
    /// Half the lateral span of the secondary springs `d_s` (m).
    pub secondary_half_span: f64,
    /// Half the distance between the rolling circles `a₀` (m).
    pub contact_half_span: f64,
    /// The static wheel load `P₀` (N), weighed: what each `F_N` carries at rest.
    pub static_wheel_load: f64,
}

/// Gravity for the static wheel load (m/s²).
const G: f64 = 9.81;

impl RollVehicle {
    /// Zhai's high-speed passenger car (`[Zhai2015]`), its primary damper blowing off to a
    /// third of its slope beyond 0.1 m/s as in S2: the catalogue vehicle of study S3, with
    /// `P₀` an eighth of its weight.
    pub fn zhai_passenger() -> Self {
        let damper = PiecewiseLinear::new([6e3, 2e3, 2e3], [0.1, 0.1]).expect("a valid damper law");
        let (car_body, bogie, wheelset) = (34e3, 3e3, 1_400.0);
        Self {
            car_body_mass: car_body,
            car_body_pitch_inertia: 2.277e6,
            car_body_roll_inertia: 7.506e4,
            bogie_mass: bogie,
            bogie_pitch_inertia: 2_710.0,
            bogie_roll_inertia: 2_260.0,
            wheelset_mass: wheelset,
            wheelset_roll_inertia: 915.0,
            primary_stiffness: 0.55e6,
            primary_damper: damper,
            secondary_stiffness: 0.4e6,
            secondary_damping: 8e4,
            half_bogie_spacing: 9.0,
            half_wheelbase: 1.2,
            primary_half_span: 0.978,
            secondary_half_span: 0.978,
            contact_half_span: 0.7465,
            static_wheel_load: (car_body + 2.0 * bogie + 4.0 * wheelset) * G / 8.0,
        }
    }

    /// The accelerations of the 17 coordinates (state order) and the eight primary
    /// compressions, lane by lane, for positions `z`, velocities `v` and forces `f_n`.
    #[inline(always)]
    pub fn accelerations_lanes<const L: usize>(
        &self,
        z: &[[f64; L]],
        v: &[[f64; L]],
        f_n: &[[f64; L]],
    ) -> ([[f64; L]; 17], [[f64; L]; 8]) {
        let (lc, lt, dw, ds, a0) = (
            self.half_bogie_spacing,
            self.half_wheelbase,
            self.primary_half_span,
            self.secondary_half_span,
            self.contact_half_span,
        );
        let mut a = [[0.0; L]; 17];
        let mut deflection = [[0.0; L]; 8];
        for (i, x) in [lc, -lc].into_iter().enumerate() {
            let t = 3 + 3 * i; // the bogie's z, β, φ
            for y in [ds, -ds] {
                for l in 0..L {
                    let stretch = z[t][l] + y * z[t + 2][l] - (z[0][l] + x * z[1][l] + y * z[2][l]);
                    let rate = v[t][l] + y * v[t + 2][l] - (v[0][l] + x * v[1][l] + y * v[2][l]);
                    let f = self.secondary_stiffness * stretch + self.secondary_damping * rate;
                    a[0][l] += f;
                    a[1][l] += x * f;
                    a[2][l] += y * f;
                    a[t][l] -= f;
                    a[t + 2][l] -= y * f;
                }
            }
            for (k, e) in [lt, -lt].into_iter().enumerate() {
                let j = 2 * i + k;
                let w = 9 + 2 * j; // the wheelset's z, φ
                for (s, y) in [dw, -dw].into_iter().enumerate() {
                    let mut rate = [0.0; L];
                    for l in 0..L {
                        deflection[2 * j + s][l] =
                            z[w][l] + y * z[w + 1][l] - (z[t][l] + e * z[t + 1][l] + y * z[t + 2][l]);
                        rate[l] = v[w][l] + y * v[w + 1][l] - (v[t][l] + e * v[t + 1][l] + y * v[t + 2][l]);
                    }
                    let damper = self.primary_damper.force_lanes(&rate);
                    for l in 0..L {
                        let f = self.primary_stiffness * deflection[2 * j + s][l] + damper[l];
                        a[t][l] += f;
                        a[t + 1][l] += e * f;
                        a[t + 2][l] += y * f;
                        a[w][l] -= f;
                        a[w + 1][l] -= y * f;
                    }
                }
                for l in 0..L {
                    let (left, right) = (f_n[2 * j][l], f_n[2 * j + 1][l]);
                    a[w][l] += left + right - 2.0 * self.static_wheel_load;
                    a[w + 1][l] += a0 * (left - right);
                }
            }
        }
        let body = [self.car_body_mass, self.car_body_pitch_inertia, self.car_body_roll_inertia];
        let bogie = [self.bogie_mass, self.bogie_pitch_inertia, self.bogie_roll_inertia];
        let wheelset = [self.wheelset_mass, self.wheelset_roll_inertia];
        let inertia = |c: usize| match c {
            0..=2 => body[c],
            3..=8 => bogie[(c - 3) % 3],
            _ => wheelset[(c - 9) % 2],
        };
        for (c, ac) in a.iter_mut().enumerate() {
            let m = inertia(c);
            for x in ac.iter_mut() {
                *x /= m;
            }
        }
        (a, deflection)
    }
}

/// The augmented estimation model of eq. (26): 42 states, 20 accelerations and eight
/// primary deflections measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelRailRoll {
    /// The vehicle the estimator assumes.
    pub vehicle: RollVehicle,
    /// The forces' return rate to the static wheel load `r` (1/s); 0: random walks, the
    /// paper's model.
    pub force_return_rate: f64,
}

impl WheelRailRoll {
    /// Index of `F_NL1` in the state; `F_NR1, F_NL2, …, F_NR4` follow.
    pub const FORCES: usize = 34;
    /// The unknown inputs' states, the eight forces: what a jump (a joint) moves.
    pub const UNKNOWN_INPUTS: [usize; 8] = [34, 35, 36, 37, 38, 39, 40, 41];
    /// Names of the 17 coordinates, in order.
    pub const COORDINATE_NAMES: [&'static str; 17] = [
        "z_c", "beta_c", "phi_c", "z_t1", "beta_t1", "phi_t1", "z_t2", "beta_t2", "phi_t2", "z_w1", "phi_w1", "z_w2",
        "phi_w2", "z_w3", "phi_w3", "z_w4", "phi_w4",
    ];
    /// Names of the eight forces, in order.
    pub const FORCE_NAMES: [&'static str; 8] = ["F_NL1", "F_NR1", "F_NL2", "F_NR2", "F_NL3", "F_NR3", "F_NL4", "F_NR4"];
    /// Names of the measurements, in order.
    pub const MEASUREMENT_NAMES: [&'static str; 28] = [
        "a_ab_L1", "a_ab_R1", "a_ab_L2", "a_ab_R2", "a_ab_L3", "a_ab_R3", "a_ab_L4", "a_ab_R4", "a_bf_L1", "a_bf_R1",
        "a_bf_L2", "a_bf_R2", "a_bf_L3", "a_bf_R3", "a_bf_L4", "a_bf_R4", "a_cb_FL", "a_cb_FR", "a_cb_RL", "a_cb_RR",
        "d_p_L1", "d_p_R1", "d_p_L2", "d_p_R2", "d_p_L3", "d_p_R3", "d_p_L4", "d_p_R4",
    ];
    /// The rows of the accelerations, the sensors every user has.
    pub const ACCELERATIONS: std::ops::Range<usize> = 0..20;
    /// The rows of the primary deflections, which only some users have.
    pub const DEFLECTIONS: std::ops::Range<usize> = 20..28;

    /// The names of the 42 states: the coordinates, their rates (`<name>_dot`), the forces.
    pub fn state_names() -> Vec<String> {
        let coordinates = Self::COORDINATE_NAMES.iter().map(|n| n.to_string());
        let rates = Self::COORDINATE_NAMES.iter().map(|n| format!("{n}_dot"));
        let forces = Self::FORCE_NAMES.iter().map(|n| n.to_string());
        coordinates.chain(rates).chain(forces).collect()
    }

    /// `ẋ` lane by lane: `L = 1` for one point, or a block of points.
    #[inline(always)]
    fn derivative_lanes<const L: usize>(&self, x: &[[f64; L]], dxdt: &mut [[f64; L]]) {
        let (a, _) = self.vehicle.accelerations_lanes(&x[..17], &x[17..34], &x[34..42]);
        dxdt[..17].copy_from_slice(&x[17..34]);
        dxdt[17..34].copy_from_slice(&a);
        let (r, p0) = (self.force_return_rate, self.vehicle.static_wheel_load);
        for (d, f) in dxdt[34..42].iter_mut().zip(&x[34..42]) {
            for l in 0..L {
                d[l] = -r * (f[l] - p0);
            }
        }
    }

    /// The 28 measurements lane by lane.
    #[inline(always)]
    fn observe_lanes<const L: usize>(&self, x: &[[f64; L]], z: &mut [[f64; L]]) {
        let vehicle = &self.vehicle;
        let (a, deflection) = vehicle.accelerations_lanes(&x[..17], &x[17..34], &x[34..42]);
        let (lc, lt, dw, ds) = (
            vehicle.half_bogie_spacing,
            vehicle.half_wheelbase,
            vehicle.primary_half_span,
            vehicle.secondary_half_span,
        );
        for j in 0..4 {
            let (t, w, e) = (3 + 3 * (j / 2), 9 + 2 * j, if j % 2 == 0 { lt } else { -lt });
            for (s, y) in [dw, -dw].into_iter().enumerate() {
                for l in 0..L {
                    z[2 * j + s][l] = a[w][l] + y * a[w + 1][l];
                    z[8 + 2 * j + s][l] = a[t][l] + e * a[t + 1][l] + y * a[t + 2][l];
                }
            }
        }
        for (i, x) in [lc, -lc].into_iter().enumerate() {
            for (s, y) in [ds, -ds].into_iter().enumerate() {
                for l in 0..L {
                    z[16 + 2 * i + s][l] = a[0][l] + x * a[1][l] + y * a[2][l];
                }
            }
        }
        z[20..28].copy_from_slice(&deflection);
    }
}

impl VectorField for WheelRailRoll {
    fn state_dim(&self) -> usize {
        42
    }

    fn derivative(&self, _t: f64, x: &[f64], _u: &[f64], dxdt: &mut [f64]) {
        self.derivative_lanes::<1>(x.as_chunks().0, dxdt.as_chunks_mut().0);
    }

    #[inline(always)]
    fn derivative_block(&self, _t: f64, x: &[Component], _u: &[f64], dxdt: &mut [Component], _scratch: &mut [f64]) {
        self.derivative_lanes(x, dxdt);
    }
}

impl Observation for WheelRailRoll {
    fn measurement_dim(&self) -> usize {
        28
    }

    fn observe(&self, _t: f64, x: &[f64], _u: &[f64], z: &mut [f64]) {
        self.observe_lanes::<1>(x.as_chunks().0, z.as_chunks_mut().0);
    }

    #[inline(always)]
    fn observe_block(&self, _t: f64, x: &[Component], _u: &[f64], z: &mut [Component], _scratch: &mut [f64]) {
        self.observe_lanes(x, z);
    }
}
