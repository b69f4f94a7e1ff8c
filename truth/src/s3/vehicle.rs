//! The whole car as rigid bodies on springs: the car body and the two bogies with five
//! coordinates each (lateral `y`, bounce `z`, roll `φ`, pitch `β`, yaw `ψ`), the four
//! wheelsets with four (no pitch: they spin at `V/r0`), 31 degrees of freedom in the
//! order car body, bogie 1, bogie 2, wheelsets 1 to 4, front first.
//!
//! **Signs.** x forward, y to the left, z down. Roll `φ` lowers the left side, pitch `β`
//! raises the front (S2's convention), yaw `ψ` turns the nose to the left. A point at arm
//! `(r_x, r_y, r_z)` from a body's centre of mass moves by
//! `(−r_y·ψ + r_z·β, y + r_x·ψ − r_z·φ, z + r_y·φ − r_x·β)`.
//!
//! **Suspension.** Each spring joins a point of an upper body to a point of a lower one at
//! the same place; it carries its static load (the weight above it) as a preload plus
//! linear stiffness and damping in x, y and z on the relative displacement of its two
//! points, the primary vertical dampers piecewise linear as in S2. Its force acts on each
//! body at the point's displaced arm, so that a preload acting below (above) a centre of
//! mass that rolls or pitches tips it over: the gravity (pendulum) stiffness of the heights,
//! `−m·g·h` in roll and pitch. The bodies have no longitudinal freedom: longitudinal
//! forces act through the moments only.

use super::parameters::{Vehicle, VerticalVehicle};
use crate::s2::parameters::G;
use crate::s2::vehicle::VehicleModel as VerticalModel;

/// Degrees of freedom of the car.
pub const DOFS: usize = 31;
/// Rigid bodies: car body, two bogies, four wheelsets.
pub const BODIES: usize = 7;
/// The car body's body index.
pub const CAR_BODY: usize = 0;

/// The body index of bogie `i` (0 front, 1 rear).
pub const fn bogie(i: usize) -> usize {
    1 + i
}

/// The body index of wheelset `j` (0 to 3, front first).
pub const fn wheelset(j: usize) -> usize {
    3 + j
}

/// A body's coordinates, in the order of [`Pose`]'s fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coordinate {
    /// `y` (m, left).
    Lateral,
    /// `z` (m, down).
    Vertical,
    /// `φ` (rad, left side down).
    Roll,
    /// `β` (rad, front up).
    Pitch,
    /// `ψ` (rad, nose left).
    Yaw,
}

impl Coordinate {
    /// The five, in [`Pose`]'s order.
    pub const ALL: [Coordinate; 5] =
        [Coordinate::Lateral, Coordinate::Vertical, Coordinate::Roll, Coordinate::Pitch, Coordinate::Yaw];
}

/// Where coordinate `c` of body `body` sits in the state; `None` for a wheelset's pitch,
/// which is not a degree of freedom.
pub fn index(body: usize, c: Coordinate) -> Option<usize> {
    let k = c as usize;
    match body {
        0..=2 => Some(5 * body + k),
        3..=6 => {
            let start = 15 + 4 * (body - 3);
            match c {
                Coordinate::Pitch => None,
                Coordinate::Yaw => Some(start + 3),
                _ => Some(start + k),
            }
        }
        _ => None,
    }
}

/// A body's displacement (or velocity, or acceleration) from its nominal place.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pose {
    /// `y` (m).
    pub lateral: f64,
    /// `z` (m).
    pub vertical: f64,
    /// `φ` (rad).
    pub roll: f64,
    /// `β` (rad).
    pub pitch: f64,
    /// `ψ` (rad).
    pub yaw: f64,
}

impl Pose {
    /// Body `body`'s pose in the state vector `x`.
    pub fn of(body: usize, x: &[f64]) -> Self {
        let read = |c| index(body, c).map_or(0.0, |k| x[k]);
        Pose {
            lateral: read(Coordinate::Lateral),
            vertical: read(Coordinate::Vertical),
            roll: read(Coordinate::Roll),
            pitch: read(Coordinate::Pitch),
            yaw: read(Coordinate::Yaw),
        }
    }

    /// The displacement `(x, y, z)` of the body's point at arm `r` (small rotations).
    pub fn point(&self, r: [f64; 3]) -> [f64; 3] {
        [
            -r[1] * self.yaw + r[2] * self.pitch,
            self.lateral + r[0] * self.yaw - r[2] * self.roll,
            self.vertical + r[1] * self.roll - r[0] * self.pitch,
        ]
    }

    /// The generalised forces `[y, z, φ, β, ψ]` of a force `f` acting at the body's point
    /// of nominal arm `r`, taken about the arm as the body has turned it.
    pub fn generalised(&self, r: [f64; 3], f: [f64; 3]) -> [f64; 5] {
        let moved = self.point(r);
        let arm = [r[0] + moved[0], r[1] + moved[1] - self.lateral, r[2] + moved[2] - self.vertical];
        [f[1], f[2], arm[1] * f[2] - arm[2] * f[1], -arm[0] * f[2] + arm[2] * f[0], arm[0] * f[1] - arm[1] * f[0]]
    }
}

/// How a spring's vertical damper behaves.
#[derive(Debug, Clone, Copy, PartialEq)]
enum VerticalDamper {
    /// Linear (N·s/m).
    Linear(f64),
    /// S2's piecewise linear primary damper.
    Primary,
}

/// A spring–damper between an upper and a lower body.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Spring {
    upper: usize,
    lower: usize,
    upper_arm: [f64; 3],
    lower_arm: [f64; 3],
    /// x, y, z (N/m).
    stiffness: [f64; 3],
    /// x, y (N·s/m).
    damping: [f64; 2],
    vertical_damper: VerticalDamper,
    /// The static load it carries (N): it pushes the upper body up.
    preload: f64,
}

/// The car's equations of motion.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleModel {
    /// The car's data.
    pub vehicle: Vehicle,
    vertical: VerticalModel,
    /// The four secondary springs (bogie 1 left, right, bogie 2 left, right), then the
    /// eight primary ones (left wheelsets 1 to 4, right wheelsets 1 to 4).
    springs: Vec<Spring>,
    /// Per body: mass, mass, roll, pitch and yaw inertia.
    inertia: [[f64; 5]; BODIES],
}

/// The sides, left then right: `s = +1` is left (y > 0).
pub const SIDES: [f64; 2] = [1.0, -1.0];

impl VehicleModel {
    /// The car's springs and inertias.
    pub fn new(vehicle: Vehicle) -> Self {
        let v = &vehicle.vertical;
        let (lc, lt) = (v.half_bogie_spacing, v.half_wheelbase);
        let (ds, dw) = (vehicle.secondary_half_span, vehicle.primary_half_span);
        let r0 = v.wheel_radius;
        // Arms down from each centre of mass to the spring planes; the primary springs act
        // at the axle's height.
        let car_to_secondary = vehicle.car_body_height - vehicle.secondary_height;
        let bogie_to_secondary = vehicle.bogie_height - vehicle.secondary_height;
        let bogie_to_primary = vehicle.bogie_height - r0;
        let mut springs = Vec::with_capacity(12);
        for (i, x) in [lc, -lc].into_iter().enumerate() {
            for s in SIDES {
                springs.push(Spring {
                    upper: CAR_BODY,
                    lower: bogie(i),
                    upper_arm: [x, s * ds, car_to_secondary],
                    lower_arm: [0.0, s * ds, bogie_to_secondary],
                    stiffness: [
                        vehicle.secondary_longitudinal_stiffness,
                        vehicle.secondary_lateral_stiffness,
                        v.secondary_stiffness,
                    ],
                    damping: [vehicle.secondary_longitudinal_damping, vehicle.secondary_lateral_damping],
                    vertical_damper: VerticalDamper::Linear(v.secondary_damping),
                    preload: v.car_body_mass * G / 4.0,
                });
            }
        }
        for s in SIDES {
            for j in 0..4 {
                let x = if j % 2 == 0 { lt } else { -lt };
                springs.push(Spring {
                    upper: bogie(j / 2),
                    lower: wheelset(j),
                    upper_arm: [x, s * dw, bogie_to_primary],
                    lower_arm: [0.0, s * dw, 0.0],
                    stiffness: [
                        vehicle.primary_longitudinal_stiffness,
                        vehicle.primary_lateral_stiffness,
                        v.primary_stiffness,
                    ],
                    damping: [0.0, 0.0],
                    vertical_damper: VerticalDamper::Primary,
                    preload: (v.car_body_mass + 2.0 * v.bogie_mass) * G / 8.0,
                });
            }
        }
        let car = [
            v.car_body_mass,
            v.car_body_mass,
            vehicle.car_body_roll_inertia,
            v.car_body_pitch_inertia,
            vehicle.car_body_yaw_inertia,
        ];
        let frame =
            [v.bogie_mass, v.bogie_mass, vehicle.bogie_roll_inertia, v.bogie_pitch_inertia, vehicle.bogie_yaw_inertia];
        // A wheelset's pitch is no freedom; its slot is never read.
        let axle = [
            v.wheelset_mass,
            v.wheelset_mass,
            vehicle.wheelset_roll_inertia,
            f64::INFINITY,
            vehicle.wheelset_yaw_inertia,
        ];
        Self {
            vehicle,
            vertical: VerticalModel { vehicle: *v },
            springs,
            inertia: [car, frame, frame, axle, axle, axle, axle],
        }
    }

    /// The vertical data.
    pub fn vertical(&self) -> &VerticalVehicle {
        &self.vehicle.vertical
    }

    /// The eight primary springs' compressions from their static length (m, positive when
    /// the axle box comes up towards the frame), left wheelsets 1 to 4, then right.
    pub fn primary_compressions(&self, u: &[f64]) -> [f64; 8] {
        std::array::from_fn(|k| {
            let spring = &self.springs[4 + k];
            let upper = Pose::of(spring.upper, u).point(spring.upper_arm);
            let lower = Pose::of(spring.lower, u).point(spring.lower_arm);
            upper[2] - lower[2]
        })
    }

    /// The accelerations into `a` (length [`DOFS`]) for the state `(u, v)` and the
    /// generalised forces of the wheel–rail contacts on each wheelset, `[y, z, φ, β, ψ]`.
    pub fn accelerations(&self, u: &[f64], v: &[f64], contact: &[[f64; 5]; 4], a: &mut [f64]) {
        let poses: [Pose; BODIES] = std::array::from_fn(|b| Pose::of(b, u));
        let rates: [Pose; BODIES] = std::array::from_fn(|b| Pose::of(b, v));
        let mut force = [[0.0; 5]; BODIES];
        for spring in &self.springs {
            let (up, low) = (&poses[spring.upper], &poses[spring.lower]);
            let (up_rate, low_rate) = (&rates[spring.upper], &rates[spring.lower]);
            let (pu, pl) = (up.point(spring.upper_arm), low.point(spring.lower_arm));
            let (vu, vl) = (up_rate.point(spring.upper_arm), low_rate.point(spring.lower_arm));
            let stretch: [f64; 3] = std::array::from_fn(|k| pl[k] - pu[k]);
            let rate: [f64; 3] = std::array::from_fn(|k| vl[k] - vu[k]);
            let damper = match spring.vertical_damper {
                VerticalDamper::Linear(c) => c * rate[2],
                VerticalDamper::Primary => self.vertical.primary_damper(rate[2]),
            };
            // On the upper body; the lower one feels the opposite.
            let f = [
                spring.stiffness[0] * stretch[0] + spring.damping[0] * rate[0],
                spring.stiffness[1] * stretch[1] + spring.damping[1] * rate[1],
                -spring.preload + spring.stiffness[2] * stretch[2] + damper,
            ];
            let on_upper = up.generalised(spring.upper_arm, f);
            let on_lower = low.generalised(spring.lower_arm, f.map(|x| -x));
            for k in 0..5 {
                force[spring.upper][k] += on_upper[k];
                force[spring.lower][k] += on_lower[k];
            }
        }
        for (j, q) in contact.iter().enumerate() {
            for k in 0..5 {
                force[wheelset(j)][k] += q[k];
            }
        }
        for (body, (f, m)) in force.iter().zip(&self.inertia).enumerate() {
            for (k, c) in Coordinate::ALL.into_iter().enumerate() {
                if let Some(i) = index(body, c) {
                    // Gravity pulls on the bounce only.
                    let weight = if c == Coordinate::Vertical { m[k] * G } else { 0.0 };
                    a[i] = (f[k] + weight) / m[k];
                }
            }
        }
    }

    /// The static state over wheelsets at rest at the bounce displacements `wheelsets`
    /// (m, down), level: every spring at its static length, so that it carries just its
    /// preload. Each bogie (the car body) takes the mean of its two wheelsets (bogies) and
    /// the pitch between them.
    pub fn static_state(&self, wheelsets: &[f64; 4]) -> [f64; DOFS] {
        let v = self.vertical();
        let mut u = [0.0; DOFS];
        let mut set = |body, c, x| {
            if let Some(k) = index(body, c) {
                u[k] = x;
            }
        };
        let mut bogies = [0.0; 2];
        for (j, z) in wheelsets.iter().enumerate() {
            set(wheelset(j), Coordinate::Vertical, *z);
        }
        for (i, b) in bogies.iter_mut().enumerate() {
            let (front, rear) = (wheelsets[2 * i], wheelsets[2 * i + 1]);
            *b = (front + rear) / 2.0;
            set(bogie(i), Coordinate::Vertical, *b);
            set(bogie(i), Coordinate::Pitch, (rear - front) / (2.0 * v.half_wheelbase));
        }
        set(CAR_BODY, Coordinate::Vertical, (bogies[0] + bogies[1]) / 2.0);
        set(CAR_BODY, Coordinate::Pitch, (bogies[1] - bogies[0]) / (2.0 * v.half_bogie_spacing));
        u
    }
}
