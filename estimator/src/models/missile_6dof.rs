//! Study S5: a tactical missile's rigid-body 6-DOF in body axes (eq. (1) of
//! `[Jiang2024]`) with its ten force coefficients (eq. (3)) as states, identified online from
//! twelve measurements (eq. (2)). The conventions — axes x forward, y up, z right; the
//! drag read along +x; the overloads as accelerometers read them — are those of
//! `docs/studies/s5.md`, where each departure from the printed equations is argued.

use super::atmosphere;
use crate::math;
use crate::model::{Component, Observation, VectorField};

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

/// [`Air`] at the `L` points of a block, one array per quantity.
struct AirLanes<const L: usize> {
    speed: [f64; L],
    dynamic_pressure: [f64; L],
    alpha: [f64; L],
    beta: [f64; L],
}

/// `f` at each lane: the model's laws are written lane by lane, without branches, so that
/// the compiler vectorises them across a block's points.
#[inline(always)]
fn lanes<const L: usize>(f: impl FnMut(usize) -> f64) -> [f64; L] {
    std::array::from_fn(f)
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
        let air = self.air_lanes(&[[velocity[0]], [velocity[1]], [velocity[2]]], &[h]);
        Air { speed: air.speed[0], dynamic_pressure: air.dynamic_pressure[0], alpha: air.alpha[0], beta: air.beta[0] }
    }

    /// [`air`](Self::air) lane by lane. The angles and the atmosphere are transcendental:
    /// they go one lane at a time through the same functions as a single point.
    #[inline(always)]
    fn air_lanes<const L: usize>(&self, velocity: &[[f64; L]], h: &[f64; L]) -> AirLanes<L> {
        let [vx, vy, vz] = [&velocity[0], &velocity[1], &velocity[2]];
        let speed = lanes(|p| (vx[p] * vx[p] + vy[p] * vy[p] + vz[p] * vz[p]).sqrt());
        let (mut alpha, mut beta, mut density) = ([0.0; L], [0.0; L], [0.0; L]);
        for p in 0..L {
            alpha[p] = math::atan2(-vy[p], vx[p]);
            // At rest the sideslip is undefined; zero keeps the model finite for any point.
            beta[p] = if speed[p] > 0.0 { math::asin((vz[p] / speed[p]).clamp(-1.0, 1.0)) } else { 0.0 };
            density[p] = atmosphere::density(h[p]);
        }
        AirLanes { speed, dynamic_pressure: lanes(|p| 0.5 * density[p] * speed[p] * speed[p]), alpha, beta }
    }

    /// The aerodynamic force (N, body axes) of the coefficients `c` (eq. (4)'s order) at
    /// `air` with deflections `delta` (rad).
    pub fn force(&self, air: &Air, c: &[f64], delta: &[f64]) -> [f64; 3] {
        let air = AirLanes {
            speed: [air.speed],
            dynamic_pressure: [air.dynamic_pressure],
            alpha: [air.alpha],
            beta: [air.beta],
        };
        self.force_lanes(&air, c.as_chunks().0, delta).map(|[f]| f)
    }

    /// [`force`](Self::force) lane by lane.
    #[inline(always)]
    fn force_lanes<const L: usize>(&self, air: &AirLanes<L>, c: &[[f64; L]], delta: &[f64]) -> [[f64; L]; 3] {
        let qs = lanes::<L>(|p| air.dynamic_pressure[p] * self.area);
        let (alpha, beta) = (&air.alpha, &air.beta);
        [
            lanes(|p| qs[p] * (c[0][p] + c[1][p] * alpha[p] + c[2][p] * beta[p] + c[3][p] * delta[0])),
            lanes(|p| qs[p] * (c[4][p] + c[5][p] * alpha[p] + c[6][p] * delta[1])),
            lanes(|p| qs[p] * (c[7][p] + c[8][p] * beta[p] + c[9][p] * delta[2])),
        ]
    }

    /// The aerodynamic moment (N·m, body axes) at `air` with rates `omega` and `delta`,
    /// lane by lane.
    #[inline(always)]
    fn moment_lanes<const L: usize>(&self, air: &AirLanes<L>, omega: &[[f64; L]], delta: &[f64]) -> [[f64; L]; 3] {
        let m = &self.moments;
        let qsl = lanes::<L>(|p| air.dynamic_pressure[p] * self.area * self.length);
        // At rest the rates cannot be made dimensionless; zero drops their damping.
        let reduced = lanes::<L>(|p| if air.speed[p] > 0.0 { self.length / air.speed[p] } else { 0.0 });
        let (alpha, beta) = (&air.alpha, &air.beta);
        [
            lanes(|p| qsl[p] * (m.roll_control * delta[0] + m.roll_damping * omega[0][p] * reduced[p])),
            lanes(|p| {
                qsl[p]
                    * (m.yaw_stiffness * beta[p] + m.yaw_control * delta[2] + m.yaw_damping * omega[1][p] * reduced[p])
            }),
            lanes(|p| {
                qsl[p]
                    * (m.pitch_stiffness * alpha[p]
                        + m.pitch_control * delta[1]
                        + m.pitch_damping * omega[2][p] * reduced[p])
            }),
        ]
    }

    /// The derivative of the ten motion states `x` (`Vx, Vy, Vz, φ, ψ, γ, h, ωx, ωy, ωz`)
    /// under the coefficients `c` and deflections `delta`: eq. (1), with `X` along +x.
    pub fn motion_derivative(&self, x: &[f64], c: &[f64], delta: &[f64], dxdt: &mut [f64]) {
        self.motion_derivative_lanes::<1>(x.as_chunks().0, c.as_chunks().0, delta, dxdt.as_chunks_mut().0);
    }

    /// [`motion_derivative`](Self::motion_derivative) lane by lane, the same operations in
    /// the same order: bit for bit the point law at every lane.
    #[inline(always)]
    fn motion_derivative_lanes<const L: usize>(
        &self,
        x: &[[f64; L]],
        c: &[[f64; L]],
        delta: &[f64],
        dxdt: &mut [[f64; L]],
    ) {
        let [vx, vy, vz, phi, _psi, gamma, h, wx, wy, wz] =
            [&x[0], &x[1], &x[2], &x[3], &x[4], &x[5], &x[6], &x[7], &x[8], &x[9]];
        let air = self.air_lanes(&x[..3], h);
        let [fx, fy, fz] = self.force_lanes(&air, c, delta);
        let [mx, my, mz] = self.moment_lanes(&air, &x[7..10], delta);
        let (g, m) = (self.gravity, self.mass);
        let [ix, iy, iz] = self.inertia;
        let (mut sin_phi, mut cos_phi, mut tan_phi) = ([0.0; L], [0.0; L], [0.0; L]);
        let (mut sin_gamma, mut cos_gamma) = ([0.0; L], [0.0; L]);
        for p in 0..L {
            (sin_phi[p], cos_phi[p]) = math::sin_cos(phi[p]);
            tan_phi[p] = math::tan(phi[p]);
            (sin_gamma[p], cos_gamma[p]) = math::sin_cos(gamma[p]);
        }
        let yaw_pitch = lanes::<L>(|p| wy[p] * cos_gamma[p] - wz[p] * sin_gamma[p]);
        dxdt[0] = lanes(|p| wz[p] * vy[p] - wy[p] * vz[p] - g * sin_phi[p] + fx[p] / m);
        dxdt[1] = lanes(|p| wx[p] * vz[p] - wz[p] * vx[p] - g * cos_phi[p] * cos_gamma[p] + fy[p] / m);
        dxdt[2] = lanes(|p| wy[p] * vx[p] - wx[p] * vy[p] + g * cos_phi[p] * sin_gamma[p] + fz[p] / m);
        dxdt[3] = lanes(|p| wy[p] * sin_gamma[p] + wz[p] * cos_gamma[p]);
        dxdt[4] = lanes(|p| yaw_pitch[p] / cos_phi[p]);
        dxdt[5] = lanes(|p| wx[p] - yaw_pitch[p] * tan_phi[p]);
        dxdt[6] = lanes(|p| vx[p] * sin_phi[p] + vy[p] * cos_phi[p] * cos_gamma[p] - vz[p] * cos_phi[p] * sin_gamma[p]);
        dxdt[7] = lanes(|p| ((iy - iz) * wy[p] * wz[p] + mx[p]) / ix);
        dxdt[8] = lanes(|p| ((iz - ix) * wz[p] * wx[p] + my[p]) / iy);
        dxdt[9] = lanes(|p| ((ix - iy) * wx[p] * wy[p] + mz[p]) / iz);
    }

    /// The twelve measurements of eq. (2) of the motion `x` under `c` and `delta`:
    /// `ωx, ωy, ωz; Nx, Ny, Nz; φ, ψ, γ; h; α, β`, the overloads the aerodynamic force
    /// over `m·g`.
    pub fn measure(&self, x: &[f64], c: &[f64], delta: &[f64], z: &mut [f64]) {
        self.measure_lanes::<1>(x.as_chunks().0, c.as_chunks().0, delta, z.as_chunks_mut().0);
    }

    /// [`measure`](Self::measure) lane by lane, bit for bit the point law at every lane.
    #[inline(always)]
    fn measure_lanes<const L: usize>(&self, x: &[[f64; L]], c: &[[f64; L]], delta: &[f64], z: &mut [[f64; L]]) {
        let air = self.air_lanes(&x[..3], &x[6]);
        let force = self.force_lanes(&air, c, delta);
        let weight = self.mass * self.gravity;
        z[..3].copy_from_slice(&x[7..10]);
        for (zi, f) in z[3..6].iter_mut().zip(force) {
            *zi = lanes(|p| f[p] / weight);
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

    #[inline(always)]
    fn derivative_block(&self, _t: f64, x: &[Component], u: &[f64], dxdt: &mut [Component], _scratch: &mut [f64]) {
        self.airframe.motion_derivative_lanes(&x[..10], &x[10..], u, &mut dxdt[..10]);
        dxdt[10..].fill([0.0; _]);
    }
}

impl Observation for Missile6Dof {
    fn measurement_dim(&self) -> usize {
        12
    }

    fn observe(&self, _t: f64, x: &[f64], u: &[f64], z: &mut [f64]) {
        self.airframe.measure(&x[..10], &x[10..], u, z);
    }

    #[inline(always)]
    fn observe_block(&self, _t: f64, x: &[Component], u: &[f64], z: &mut [Component], _scratch: &mut [f64]) {
        self.airframe.measure_lanes(&x[..10], &x[10..], u, z);
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
        assert!((air.alpha - math::atan(50.0 / 1000.0)).abs() < 1e-15);
        assert!((air.beta - math::asin(30.0 / air.speed)).abs() < 1e-15);
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
