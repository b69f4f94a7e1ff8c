//! Half of a four-axle vehicle on one rail, vertical (Zhai): the car body (bounce, pitch),
//! two bogies (bounce, pitch) and four wheelsets (bounce), ten degrees of freedom, in the
//! order `[z_c, β_c, z_t1, β_t1, z_t2, β_t2, z_w1, z_w2, z_w3, z_w4]`, front first. The
//! primary dampers are piecewise linear in the relative velocity (eq. (1) of the paper),
//! the secondary suspension linear. Coordinates point down; a point at `d` ahead of a
//! body's centre moves by `z − d·β`.

use super::parameters::{Vehicle, G};

/// Degrees of freedom of the vehicle.
pub const DOFS: usize = 10;

/// The vehicle's equations of motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleModel {
    /// The whole vehicle's data.
    pub vehicle: Vehicle,
}

/// Index of wheelset `j` (0 to 3) in the state.
pub const fn wheelset(j: usize) -> usize {
    6 + j
}

impl VehicleModel {
    /// Masses and inertias of the half vehicle, in state order.
    pub fn inertia(&self) -> [f64; DOFS] {
        let v = &self.vehicle;
        let (mc, ic, mt, it, mw) = (
            v.car_body_mass / 2.0,
            v.car_body_pitch_inertia / 2.0,
            v.bogie_mass / 2.0,
            v.bogie_pitch_inertia / 2.0,
            v.wheelset_mass / 2.0,
        );
        [mc, ic, mt, it, mt, it, mw, mw, mw, mw]
    }

    /// Force of a primary damper at relative velocity `velocity` (eq. (1)): `C₁·v` up to
    /// the knee `δ`, then `C₁·δ + C₂·(|v| − δ)` with the sign of `v`.
    pub fn primary_damper(&self, velocity: f64) -> f64 {
        let v = &self.vehicle;
        let knee = v.primary_damper_knee;
        if velocity.abs() <= knee {
            v.primary_damping * velocity
        } else {
            velocity.signum() * (v.primary_damping * knee + v.primary_damping_beyond * (velocity.abs() - knee))
        }
    }

    /// The secondary forces on the car body (N, down) and the primary forces on the bogies
    /// (N, down) for the state `(u, v)`.
    pub fn suspension_forces(&self, u: &[f64], v: &[f64]) -> ([f64; 2], [f64; 4]) {
        let p = &self.vehicle;
        let (lc, lt) = (p.half_bogie_spacing, p.half_wheelbase);
        let mut secondary = [0.0; 2];
        let mut primary = [0.0; 4];
        for (i, d) in [lc, -lc].into_iter().enumerate() {
            let (z, b) = (2 + 2 * i, 3 + 2 * i);
            let stretch = u[z] - (u[0] - d * u[1]);
            let rate = v[z] - (v[0] - d * v[1]);
            secondary[i] = p.secondary_stiffness * stretch + p.secondary_damping * rate;
            for (k, e) in [lt, -lt].into_iter().enumerate() {
                let j = 2 * i + k;
                let stretch = u[wheelset(j)] - (u[z] - e * u[b]);
                let rate = v[wheelset(j)] - (v[z] - e * v[b]);
                primary[j] = p.primary_stiffness * stretch + self.primary_damper(rate);
            }
        }
        (secondary, primary)
    }

    /// The accelerations into `a` for the state `(u, v)` and the wheel–rail forces
    /// `contact` (N, pushing the wheels up).
    pub fn accelerations(&self, u: &[f64], v: &[f64], contact: &[f64; 4], a: &mut [f64]) {
        let p = &self.vehicle;
        let (lc, lt) = (p.half_bogie_spacing, p.half_wheelbase);
        let inertia = self.inertia();
        let (secondary, primary) = self.suspension_forces(u, v);
        let mut force = [0.0; DOFS];
        force[0] = secondary[0] + secondary[1];
        force[1] = -(lc * secondary[0] - lc * secondary[1]);
        for i in 0..2 {
            force[2 + 2 * i] = primary[2 * i] + primary[2 * i + 1] - secondary[i];
            force[3 + 2 * i] = -(lt * primary[2 * i] - lt * primary[2 * i + 1]);
        }
        for j in 0..4 {
            force[wheelset(j)] = -primary[j] - contact[j];
        }
        for (k, (f, m)) in force.iter().zip(inertia).enumerate() {
            // Gravity acts on the bounce coordinates, not on the pitch angles.
            let weight = if k == 1 || k == 3 || k == 5 { 0.0 } else { m * G };
            a[k] = (f + weight) / m;
        }
    }

    /// The static state on the rail: each wheel carries an eighth of the vehicle's weight,
    /// and sits `contact_compression` below the rail top under it, which is at `rail[j]`
    /// (m, down) under wheel `j`.
    pub fn static_state(&self, rail: &[f64; 4], contact_compression: f64) -> [f64; DOFS] {
        let p = &self.vehicle;
        let inertia = self.inertia();
        let (mc, mt) = (inertia[0], inertia[2]);
        let secondary = -mc * G / 2.0;
        let primary = (secondary - mt * G) / 2.0;
        let mut u = [0.0; DOFS];
        for j in 0..4 {
            u[wheelset(j)] = rail[j] + contact_compression;
        }
        // Each bogie level is a beam on two springs: statically determinate.
        let mut bogie_points = [0.0; 2];
        for i in 0..2 {
            let points = [0, 1].map(|k| u[wheelset(2 * i + k)] - primary / p.primary_stiffness);
            u[2 + 2 * i] = (points[0] + points[1]) / 2.0;
            u[3 + 2 * i] = (points[1] - points[0]) / (2.0 * p.half_wheelbase);
            bogie_points[i] = u[2 + 2 * i] - secondary / p.secondary_stiffness;
        }
        u[0] = (bogie_points[0] + bogie_points[1]) / 2.0;
        u[1] = (bogie_points[1] - bogie_points[0]) / (2.0 * p.half_bogie_spacing);
        u
    }
}
