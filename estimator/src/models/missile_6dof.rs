//! Study S5: a tactical missile's rigid-body 6-DOF in body axes (eq. (1) of
//! `[Jiang2024]`) with its ten force coefficients (eq. (3)) as states, identified online from
//! twelve measurements (eq. (2)). The conventions — axes x forward, y up, z right; the
//! drag read along +x; the overloads as accelerometers read them — are those of
//! `docs/studies/s5.md`, where each departure from the printed equations is argued.

use super::atmosphere;
use crate::model::{Observation, VectorField};

/// The airframe: what the estimator knows of the missile besides its force coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Airframe {
    /// Mass (kg).
    pub mass: f64,
    /// Reference area (m²).
    pub area: f64,
    /// Reference length (m).
    pub length: f64,
    /// Moments of inertia about x, y, z (kg·m²).
    pub inertia: [f64; 3],
    /// The moment coefficients.
    pub moments: MomentModel,
    /// Gravity (m/s²), constant: a flat, non-rotating Earth.
    pub gravity: f64,
}

/// The moment model `(Mx, My, Mz) = q·S·L·(m_x, m_y, m_z)` (per radian; rates made
/// dimensionless by `L/V`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MomentModel {
    /// `m_x = roll_control·δx + roll_damping·ωx·L/V`.
    pub roll_control: f64,
    /// See `roll_control`.
    pub roll_damping: f64,
    /// `m_y = yaw_stiffness·β + yaw_control·δz + yaw_damping·ωy·L/V`.
    pub yaw_stiffness: f64,
    /// See `yaw_stiffness`.
    pub yaw_control: f64,
    /// See `yaw_stiffness`.
    pub yaw_damping: f64,
    /// `m_z = pitch_stiffness·α + pitch_control·δy + pitch_damping·ωz·L/V`.
    pub pitch_stiffness: f64,
    /// See `pitch_stiffness`.
    pub pitch_control: f64,
    /// See `pitch_stiffness`.
    pub pitch_damping: f64,
}

/// Where the air is, seen from the body: speed, dynamic pressure, angles of attack and
/// sideslip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Air {
    /// Airspeed (m/s).
    pub speed: f64,
    /// Dynamic pressure `½ρV²` (Pa).
    pub dynamic_pressure: f64,
    /// Angle of attack `atan2(−Vy, Vx)` (rad).
    pub alpha: f64,
    /// Sideslip `asin(Vz/V)` (rad).
    pub beta: f64,
}

impl Airframe {
    /// The paper's missile (mass, area, length) with the project's inertias and moment
    /// model (our estimates, `docs/studies/s5.md`).
    pub fn tactical_missile() -> Self {
        Self {
            mass: 980.0,
            area: 1.6771,
            length: 3.85,
            inertia: [150.0, 1_210.0, 1_210.0],
            moments: MomentModel {
                roll_control: -0.01,
                roll_damping: -0.05,
                yaw_stiffness: -0.275,
                yaw_control: 0.10,
                yaw_damping: -0.7,
                pitch_stiffness: -0.275,
                pitch_control: 0.389,
                pitch_damping: -0.7,
            },
            gravity: 9.8,
        }
    }

    /// The air seen by a body moving at `velocity` (body axes) at altitude `h`.
    pub fn air(&self, velocity: &[f64], h: f64) -> Air {
        let [vx, vy, vz] = [velocity[0], velocity[1], velocity[2]];
        let speed = (vx * vx + vy * vy + vz * vz).sqrt();
        // At rest the angles are undefined; zero keeps the model finite for any point.
        let beta = if speed > 0.0 { (vz / speed).clamp(-1.0, 1.0).asin() } else { 0.0 };
        Air { speed, dynamic_pressure: 0.5 * atmosphere::density(h) * speed * speed, alpha: (-vy).atan2(vx), beta }
    }

    /// The aerodynamic force (N, body axes) of the coefficients `c` (eq. (4)'s order) at
    /// `air` with deflections `delta` (rad).
    pub fn force(&self, air: &Air, c: &[f64], delta: &[f64]) -> [f64; 3] {
        let qs = air.dynamic_pressure * self.area;
        [
            qs * (c[0] + c[1] * air.alpha + c[2] * air.beta + c[3] * delta[0]),
            qs * (c[4] + c[5] * air.alpha + c[6] * delta[1]),
            qs * (c[7] + c[8] * air.beta + c[9] * delta[2]),
        ]
    }

    /// The aerodynamic moment (N·m, body axes) at `air` with rates `omega` and `delta`.
    pub fn moment(&self, air: &Air, omega: &[f64], delta: &[f64]) -> [f64; 3] {
        let m = &self.moments;
        let qsl = air.dynamic_pressure * self.area * self.length;
        let reduced = if air.speed > 0.0 { self.length / air.speed } else { 0.0 };
        [
            qsl * (m.roll_control * delta[0] + m.roll_damping * omega[0] * reduced),
            qsl * (m.yaw_stiffness * air.beta + m.yaw_control * delta[2] + m.yaw_damping * omega[1] * reduced),
            qsl * (m.pitch_stiffness * air.alpha + m.pitch_control * delta[1] + m.pitch_damping * omega[2] * reduced),
        ]
    }

    /// The derivative of the ten motion states `x` (`Vx, Vy, Vz, φ, ψ, γ, h, ωx, ωy, ωz`)
    /// under the coefficients `c` and deflections `delta`: eq. (1), with `X` along +x.
    pub fn motion_derivative(&self, x: &[f64], c: &[f64], delta: &[f64], dxdt: &mut [f64]) {
        let [vx, vy, vz, phi, _psi, gamma, h, wx, wy, wz] =
            [x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9]];
        let air = self.air(&x[..3], h);
        let [fx, fy, fz] = self.force(&air, c, delta);
        let [mx, my, mz] = self.moment(&air, &x[7..10], delta);
        let (g, m) = (self.gravity, self.mass);
        let [ix, iy, iz] = self.inertia;
        let (sin_phi, cos_phi) = phi.sin_cos();
        let (sin_gamma, cos_gamma) = gamma.sin_cos();
        let yaw_pitch = wy * cos_gamma - wz * sin_gamma;
        dxdt[0] = wz * vy - wy * vz - g * sin_phi + fx / m;
        dxdt[1] = wx * vz - wz * vx - g * cos_phi * cos_gamma + fy / m;
        dxdt[2] = wy * vx - wx * vy + g * cos_phi * sin_gamma + fz / m;
        dxdt[3] = wy * sin_gamma + wz * cos_gamma;
        dxdt[4] = yaw_pitch / cos_phi;
        dxdt[5] = wx - yaw_pitch * phi.tan();
        dxdt[6] = vx * sin_phi + vy * cos_phi * cos_gamma - vz * cos_phi * sin_gamma;
        dxdt[7] = ((iy - iz) * wy * wz + mx) / ix;
        dxdt[8] = ((iz - ix) * wz * wx + my) / iy;
        dxdt[9] = ((ix - iy) * wx * wy + mz) / iz;
    }

    /// The twelve measurements of eq. (2) of the motion `x` under `c` and `delta`:
    /// `ωx, ωy, ωz; Nx, Ny, Nz; φ, ψ, γ; h; α, β`, the overloads the aerodynamic force
    /// over `m·g`.
    pub fn measure(&self, x: &[f64], c: &[f64], delta: &[f64], z: &mut [f64]) {
        let air = self.air(&x[..3], x[6]);
        let force = self.force(&air, c, delta);
        let weight = self.mass * self.gravity;
        z[..3].copy_from_slice(&x[7..10]);
        for (zi, f) in z[3..6].iter_mut().zip(force) {
            *zi = f / weight;
        }
        z[6..10].copy_from_slice(&x[3..7]);
        z[10] = air.alpha;
        z[11] = air.beta;
    }
}

/// The 20-state estimation model: the motion and the ten coefficients, the latter
/// constant (random walks in the filter); inputs the three deflections (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Missile6Dof {
    /// The airframe the estimator assumes.
    pub airframe: Airframe,
}

impl Missile6Dof {
    /// Index of the first coefficient in the state.
    pub const COEFFICIENTS: usize = 10;
    /// The unknown inputs' states, the ten coefficients: what a jump (a change of the airframe) moves.
    pub const UNKNOWN_INPUTS: [usize; 10] = [10, 11, 12, 13, 14, 15, 16, 17, 18, 19];
    /// Names of the state components, in order.
    pub const STATE_NAMES: [&'static str; 20] = [
        "Vx", "Vy", "Vz", "phi", "psi", "gamma", "h", "omega_x", "omega_y", "omega_z", "Cx0", "Cx_a", "Cx_b", "Cx_d",
        "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d",
    ];
    /// Names of the measurements, in order.
    pub const MEASUREMENT_NAMES: [&'static str; 12] =
        ["omega_x", "omega_y", "omega_z", "Nx", "Ny", "Nz", "phi", "psi", "gamma", "h", "alpha", "beta"];
}

impl VectorField for Missile6Dof {
    fn state_dim(&self) -> usize {
        20
    }

    fn input_dim(&self) -> usize {
        3
    }

    fn derivative(&self, _t: f64, x: &[f64], u: &[f64], dxdt: &mut [f64]) {
        self.airframe.motion_derivative(&x[..10], &x[10..], u, &mut dxdt[..10]);
        dxdt[10..].fill(0.0);
    }
}

impl Observation for Missile6Dof {
    fn measurement_dim(&self) -> usize {
        12
    }

    fn observe(&self, _t: f64, x: &[f64], u: &[f64], z: &mut [f64]) {
        self.airframe.measure(&x[..10], &x[10..], u, z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(speed: f64, h: f64) -> [f64; 10] {
        [speed, 0.0, 0.0, 0.0, 0.0, 0.0, h, 0.0, 0.0, 0.0]
    }

    #[test]
    fn the_angles_follow_the_documents_signs() {
        let a = Airframe::tactical_missile();
        // Velocity below the nose (Vy < 0, y up): positive angle of attack; to the right
        // (Vz > 0, z right): positive sideslip.
        let air = a.air(&[1000.0, -50.0, 30.0], 10_000.0);
        assert!((air.alpha - (50.0f64 / 1000.0).atan()).abs() < 1e-15);
        assert!((air.beta - (30.0 / air.speed).asin()).abs() < 1e-15);
    }

    #[test]
    fn drag_decelerates_lift_is_up_and_the_stiffness_restores() {
        let a = Airframe::tactical_missile();
        let c = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];
        let mut x = level(1000.0, 10_000.0);
        x[1] = -50.0; // α ≈ 2.9°
        let mut d = [0.0; 10];
        a.motion_derivative(&x, &c, &[0.0; 3], &mut d);
        let air = a.air(&x[..3], x[6]);
        let force = a.force(&air, &c, &[0.0; 3]);
        assert!(force[0] < 0.0, "C_x0 < 0 is a drag along −x");
        assert!(force[1] > 0.0, "C_y^α > 0: lift up at positive α");
        assert!(d[9] < 0.0, "m_z^α < 0: a positive α pitches the nose down");
    }

    #[test]
    fn with_no_air_and_no_rotation_it_falls_at_g() {
        let mut a = Airframe::tactical_missile();
        a.area = 0.0;
        let mut d = [0.0; 10];
        // Pitched 90° up (nose up): gravity along −x.
        let mut x = level(0.0, 1_000.0);
        x[3] = std::f64::consts::FRAC_PI_2;
        a.motion_derivative(&x, &[0.0; 10], &[0.0; 3], &mut d);
        assert!((d[0] + 9.8).abs() < 1e-12 && d[1].abs() < 1e-12 && d[2].abs() < 1e-12, "{d:?}");
    }

    #[test]
    fn the_overloads_are_the_aerodynamic_force_over_the_weight() {
        let a = Airframe::tactical_missile();
        let c = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];
        let x = [1000.0, -20.0, 10.0, 0.2, 0.05, 0.05, 10_000.0, 0.01, 0.02, 0.03];
        let delta = [0.01, -0.02, 0.03];
        let mut z = [0.0; 12];
        a.measure(&x, &c, &delta, &mut z);
        let air = a.air(&x[..3], x[6]);
        let f = a.force(&air, &c, &delta);
        for k in 0..3 {
            assert_eq!(z[3 + k], f[k] / (980.0 * 9.8));
        }
        assert_eq!((z[0], z[6], z[9], z[10], z[11]), (0.01, 0.2, 10_000.0, air.alpha, air.beta));
    }
}
