//! The contact of one wheel with its rail: conical treads on knife-edge rails, Hertz
//! normal force, Kalker's linear creep.
//!
//! **Geometry.** The treads are cones of slope `λ_c` (set so that the equivalent conicity
//! is λ_eq, [`Vehicle::tread_slope`]); the rails are knife edges `a0` either side of the
//! track's centre line, moved sideways together by the alignment `y_a`. A wheelset at
//! `y_r = y − y_a` from the track's centre touches rail `s` (+1 left, −1 right) at its
//! lateral arm `s·a0 − y_r`: the contact point stays on the rail while the wheelset moves,
//! so the levers of the vertical forces change with `y_r`. The wheel's material at the
//! contact has moved across by `y_r − r0·φ` (the roll carries the rim), so its rolling
//! radius is `r0 + s·λ_c·(y_r − r0·φ)`, and the compression of the contact is
//!
//! `δ_s = z + (s·a0 − y_r)·φ + s·λ_c·(y_r − r0·φ) − z_rail − η_s`.
//!
//! **Forces.** Normal: Hertz `N = (δ/G)^{3/2}` for δ > 0, none when the wheel leaves the
//! rail; it acts along the tread's normal, whose generalised forces are `−N·∂δ/∂q` (the
//! lateral component `−N·(s·λ_c − φ)`). With the shifted levers this gives a wheelset the
//! gravitational stiffness of a cone, `2·W·λ_eq/a0` laterally for an axle load W
//! `[Wickens2003]` (the test below finds it within 0.1 %). Creep (Kalker's linear
//! theory `[Kalker1990]`, without spin): longitudinal creepage
//! `ξ_x = −s·a0·ψ̇/V − (r_s − r0)/r0`, lateral `ξ_y = (ẏ − r0·φ̇)/V − ψ`, forces
//! `F = −f·ξ` with the coefficients scaled by the contact patch, `(N/P0)^{2/3}`. The
//! lateral creep force acts at rail height, `r0` below the axle: it rolls the wheelset and
//! so loads one wheel and unloads the other.
//!
//! Left out: spin creep, creep saturation (Coulomb), the flange, contact angle terms beyond
//! the cone, the rails' own lateral and roll motion.

use super::parameters::Vehicle;
use estimator::math;

/// What a contact needs of the wheelset and the rail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// The wheelset's lateral displacement from the alignment, `y − y_a` (m).
    pub lateral: f64,
    /// The wheelset's bounce (m, down).
    pub vertical: f64,
    /// The wheelset's roll (rad).
    pub roll: f64,
    /// The wheelset's yaw (rad).
    pub yaw: f64,
    /// The wheelset's lateral velocity (m/s).
    pub lateral_rate: f64,
    /// The wheelset's roll rate (rad/s).
    pub roll_rate: f64,
    /// The wheelset's yaw rate (rad/s).
    pub yaw_rate: f64,
    /// The rail's displacement under the wheel plus the vertical irregularity (m, down).
    pub rail: f64,
}

/// The forces of one contact.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactForces {
    /// The normal (vertical) force, pushing the wheel up and the rail down (N).
    pub normal: f64,
    /// The whole lateral force of the rail on the wheel, creep and normal (N, left).
    pub lateral: f64,
    /// The generalised forces on the wheelset, `[y, z, φ, β, ψ]`.
    pub generalised: [f64; 5],
}

/// The wheel–rail contact law of a car.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    slope: f64,
    half_span: f64,
    radius: f64,
    hertz: f64,
    static_load: f64,
    longitudinal_creep: f64,
    lateral_creep: f64,
}

impl Contact {
    /// The contact of `vehicle`'s wheels.
    pub fn new(vehicle: &Vehicle) -> Self {
        Self {
            slope: vehicle.tread_slope(),
            half_span: vehicle.contact_half_span,
            radius: vehicle.vertical.wheel_radius,
            hertz: vehicle.vertical.hertz_coefficient(),
            static_load: vehicle.static_wheel_load(),
            longitudinal_creep: vehicle.longitudinal_creep,
            lateral_creep: vehicle.lateral_creep,
        }
    }

    /// The compression of the contact under the static wheel load (m).
    pub fn static_compression(&self) -> f64 {
        self.hertz * math::powf(self.static_load, 2.0 / 3.0)
    }

    /// The forces at side `side` (+1 left, −1 right) at speed `speed` (m/s, > 0).
    pub fn forces(&self, side: f64, w: &ContactState, speed: f64) -> ContactForces {
        let (s, a0, r0, slope) = (side, self.half_span, self.radius, self.slope);
        let lever = s * a0 - w.lateral;
        let across = w.lateral - r0 * w.roll;
        let compression = w.vertical + lever * w.roll + s * slope * across - w.rail;
        if compression <= 0.0 {
            return ContactForces::default();
        }
        let normal = math::powf(compression / self.hertz, 1.5);
        // The contact patch grows as N^{2/3}, and Kalker's coefficients with its area.
        let patch = math::powf(normal / self.static_load, 2.0 / 3.0);
        let radius_change = s * slope * across;
        let longitudinal_creepage = -s * a0 * w.yaw_rate / speed - radius_change / r0;
        let lateral_creepage = (w.lateral_rate - r0 * w.roll_rate) / speed - w.yaw;
        let fx = -self.longitudinal_creep * patch * longitudinal_creepage;
        let fy = -self.lateral_creep * patch * lateral_creepage;
        let normal_lateral = -normal * (s * slope - w.roll);
        ContactForces {
            normal,
            lateral: fy + normal_lateral,
            generalised: [fy + normal_lateral, -normal, -normal * (lever - s * slope * r0) - r0 * fy, 0.0, -lever * fx],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wheelset moved `y` across and left to settle on its rails under its axle load W
    /// (bounce and roll in equilibrium, no creepage): its rolling radii differ by
    /// `2·λ_eq·y`, the equivalent conicity's definition, and the normal forces pull it back
    /// with the cone's gravitational stiffness, `2·W·λ/a0` to first order `[Wickens2003]`:
    /// half from the normals' lean as the wheelset rolls, half from the load moving onto
    /// the wheel whose lever has shortened.
    #[test]
    fn the_cone_has_its_conicity_and_its_gravitational_stiffness() {
        let car = Vehicle::PASSENGER;
        let contact = Contact::new(&car);
        let (a0, r0, slope) = (car.contact_half_span, car.vertical.wheel_radius, car.tread_slope());
        let axle_load = 2.0 * car.static_wheel_load();
        let y = 1e-3;
        let at = |vertical: f64, roll: f64| {
            let state = ContactState {
                lateral: y,
                vertical,
                roll,
                yaw: 0.0,
                lateral_rate: 0.0,
                roll_rate: 0.0,
                yaw_rate: 0.0,
                rail: 0.0,
            };
            [1.0, -1.0].map(|s| contact.forces(s, &state, 20.0))
        };
        // Newton on (bounce, roll) for N_L + N_R = W and no roll moment.
        let residual = |z: f64, roll: f64| {
            let [l, r] = at(z, roll);
            [l.normal + r.normal - axle_load, l.generalised[2] + r.generalised[2]]
        };
        let (mut z, mut roll) = (contact.static_compression(), -slope * y / (a0 - slope * r0));
        for _ in 0..20 {
            let f = residual(z, roll);
            let (hz, hr) = (1e-9, 1e-9);
            let (fz, fr) = (residual(z + hz, roll), residual(z, roll + hr));
            let j = [[(fz[0] - f[0]) / hz, (fr[0] - f[0]) / hr], [(fz[1] - f[1]) / hz, (fr[1] - f[1]) / hr]];
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            z -= (j[1][1] * f[0] - j[0][1] * f[1]) / det;
            roll -= (j[0][0] * f[1] - j[1][0] * f[0]) / det;
        }
        let [left, right] = at(z, roll);
        let radius_difference = 2.0 * slope * (y - r0 * roll);
        let stiffness = -(left.generalised[0] + right.generalised[0]) / y;
        let cone = 2.0 * axle_load * car.conicity / a0;
        eprintln!(
            "settled: N_L − N_R = {:.0} N, Δr/2y = {:.4}, gravitational stiffness {stiffness:.0} N/m against {cone:.0}",
            left.normal - right.normal,
            radius_difference / (2.0 * y)
        );
        assert!((radius_difference / (2.0 * y) / car.conicity - 1.0).abs() < 1e-3);
        assert!((stiffness / cone - 1.0).abs() < 0.01, "{stiffness} N/m against {cone} N/m");
    }
}
