//! The S3 truth: the whole car ([`vehicle`](super::vehicle)) on two rails, each S2's rail
//! on its own sleepers and ballast ([`TrackModel`]; the sleepers are not shared, so the
//! track does not couple the rails), through a contact per wheel
//! ([`contact`](super::contact)), integrated with Zhai's explicit two-step method
//! ([`zhai_step`], `[Zhai1996]`) at Δt = 1e-4 s.
//!
//! The state is the car's 31 coordinates, then the left rail's modes, sleepers and ballast
//! blocks, then the right rail's. Both rails' windows move with the car body together, as
//! S2's does.
//!
//! The run starts in static equilibrium on a level track: both rails' static deflection
//! under the four static wheel loads, the wheels compressed into the rails by
//! `G·P0^{2/3}`, every spring at its static length. The car body's centre starts at x = 0.

use super::contact::{Contact, ContactForces, ContactState};
use super::irregularity::{Irregularity, Rails};
use super::parameters::{Track, Vehicle};
use super::vehicle::{bogie, index, wheelset, Coordinate, Pose, VehicleModel, CAR_BODY, DOFS, SIDES};
use crate::s2::plant::zhai_step;
use crate::s2::track::{Layout, TrackModel};

/// How to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Speed (m/s); 80 km/h by default.
    pub speed: f64,
    /// Integration step (s).
    pub dt: f64,
    /// Rail modes in each rail's window.
    pub modes: usize,
    /// Sleeper spacings in each rail's window.
    pub supports: usize,
}

impl Default for Settings {
    /// 80 km/h, Δt = 1e-4 s, and a window of 80 spacings (48 m) with 80 modes, the modal
    /// density of S2's (up to 1.44 kHz): 13.8 m of rail either side of the 20.4 m wheel
    /// span, where a static deflection has decayed by `e^{−1.15·13.8}` ≈ 1e-7.
    fn default() -> Self {
        Self { speed: 80.0 / 3.6, dt: 1e-4, modes: 80, supports: 80 }
    }
}

impl Settings {
    /// Checks that the settings can be run on `vehicle` and `track`: a positive speed and
    /// step, a step the explicit method resolves (the creep's damping, the highest rail
    /// mode), at least one mode, and a window longer than the wheel span by 4 m either side.
    pub fn validate(&self, vehicle: &Vehicle, track: &Track) -> Result<(), String> {
        if !(self.speed > 0.0 && self.speed.is_finite()) {
            return Err(format!("speed must be positive, got {}", self.speed));
        }
        if !(self.dt > 0.0 && self.dt.is_finite()) {
            return Err(format!("dt must be positive, got {}", self.dt));
        }
        if self.modes == 0 {
            return Err("at least one rail mode is needed".into());
        }
        let length = self.supports as f64 * track.sleeper_spacing;
        let span = 2.0 * (vehicle.vertical.half_bogie_spacing + vehicle.vertical.half_wheelbase);
        if length < span + 8.0 {
            return Err(format!("the window of {length} m must exceed the wheel span of {span} m by 8 m"));
        }
        // Creep acts on a wheelset as a damper of rate f/V: the explicit step must resolve it
        // (with room for a patch grown under twice the static load).
        let creep_rate = (2.0 * vehicle.lateral_creep / vehicle.vertical.wheelset_mass)
            .max(2.0 * vehicle.longitudinal_creep * vehicle.contact_half_span.powi(2) / vehicle.wheelset_yaw_inertia)
            / self.speed;
        if self.dt * creep_rate * 1.6 > 1.0 {
            return Err(format!(
                "at {} m/s the creep forces damp the wheelsets at {creep_rate:.0} /s, too fast for dt = {} s: \
                 a higher speed or a shorter step",
                self.speed, self.dt
            ));
        }
        let highest = (track.rail_bending_stiffness / track.rail_mass_per_metre).sqrt()
            * (self.modes as f64 * std::f64::consts::PI / length).powi(2);
        if self.dt * highest > 1.0 {
            return Err(format!(
                "dt = {} s does not resolve the highest rail mode ({:.0} rad/s): fewer modes or a shorter step",
                self.dt, highest
            ));
        }
        Ok(())
    }
}

/// One instant of the truth, in the fixed orders of [`cases`](super::cases).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The 20 vertical accelerations (m/s², up, less gravity): axle boxes left 1–4,
    /// right 1–4; bogie frames above them, the same order; car body corners front left,
    /// front right, rear left, rear right.
    pub accelerations: [f64; 20],
    /// The primary springs' compressions (m), left 1–4, right 1–4.
    pub deflections: [f64; 8],
    /// The wheelsets' lateral accelerations at the axle (m/s², left), 1–4.
    pub lateral_accelerations: [f64; 4],
    /// The vertical contact forces (N), left 1–4, right 1–4.
    pub contact: [f64; 8],
    /// The lateral contact forces on the wheels (N, left), left 1–4, right 1–4.
    pub lateral_contact: [f64; 8],
}

/// The coupled car–track system being integrated.
#[derive(Debug, Clone)]
pub struct Simulation {
    vehicle: VehicleModel,
    contact_law: Contact,
    track: TrackModel,
    /// The left and right rails' layouts.
    layouts: [Layout; 2],
    irregularity: Irregularity,
    speed: f64,
    dt: f64,
    time: f64,
    /// Where the windows start along the track (m).
    origin: f64,
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    a_previous: Option<Vec<f64>>,
    wheel_shapes: Vec<f64>,
    /// Per side (left, right), per wheelset.
    contact: [[ContactForces; 4]; 2],
}

impl Simulation {
    /// The system at rest in static equilibrium, the car body's centre at x = 0, or why the
    /// settings cannot be run.
    pub fn new(
        vehicle: Vehicle,
        track: Track,
        irregularity: Irregularity,
        settings: &Settings,
    ) -> Result<Self, String> {
        vehicle.validate()?;
        settings.validate(&vehicle, &track)?;
        let track = TrackModel::new(track, settings.modes, settings.supports);
        let left = track.layout(DOFS);
        let right = track.layout(left.end);
        let size = right.end;
        let mut simulation = Self {
            vehicle: VehicleModel::new(vehicle),
            contact_law: Contact::new(&vehicle),
            layouts: [left, right],
            irregularity,
            speed: settings.speed,
            dt: settings.dt,
            time: 0.0,
            origin: -track.length / 2.0,
            wheel_shapes: vec![0.0; 4 * track.modes],
            track,
            u: vec![0.0; size],
            v: vec![0.0; size],
            a: vec![0.0; size],
            a_previous: None,
            contact: [[ContactForces::default(); 4]; 2],
        };
        simulation.update_wheel_shapes();
        let load = vehicle.static_wheel_load();
        let deflection = simulation.track.static_deflection(&simulation.wheel_shapes, &[load; 4]);
        for layout in simulation.layouts {
            simulation.u[layout.modes..layout.end].copy_from_slice(&deflection);
        }
        let compression = simulation.contact_law.static_compression();
        let wheelsets: [f64; 4] = std::array::from_fn(|j| simulation.rail(0, j) + compression);
        simulation.u[..DOFS].copy_from_slice(&simulation.vehicle.static_state(&wheelsets));
        simulation.evaluate();
        Ok(simulation)
    }

    /// The wheelsets' positions along the track (m), front first.
    pub fn wheel_positions(&self) -> [f64; 4] {
        let centre = self.speed * self.time;
        self.vehicle.vehicle.vertical.wheel_offsets().map(|d| centre + d)
    }

    /// The time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The displacements of every degree of freedom: the car's ([`index`]), then the left
    /// rail's track, then the right's.
    pub fn displacements(&self) -> &[f64] {
        &self.u
    }

    /// The velocities of every degree of freedom.
    pub fn velocities(&self) -> &[f64] {
        &self.v
    }

    /// The accelerations of every degree of freedom, now.
    pub fn accelerations(&self) -> &[f64] {
        &self.a
    }

    /// Changes the state (displacements, velocities) by `change`, as a blow or a release
    /// would: for free-vibration tests. The integrator restarts from the new state.
    pub fn perturb(&mut self, change: impl FnOnce(&mut [f64], &mut [f64])) {
        change(&mut self.u, &mut self.v);
        self.a_previous = None;
        self.evaluate();
    }

    /// The contact forces now: per side (left, right), per wheelset.
    pub fn contact(&self) -> &[[ContactForces; 4]; 2] {
        &self.contact
    }

    /// The measurements and forces now.
    pub fn sample(&self) -> Sample {
        let car = &self.vehicle.vehicle;
        let v = &car.vertical;
        let (dw, ds, lt, lc) = (car.primary_half_span, car.secondary_half_span, v.half_wheelbase, v.half_bogie_spacing);
        // Vertical accelerations, measured up: the model's coordinates point down.
        let up = |body: usize, arm: [f64; 3]| -Pose::of(body, &self.a).point(arm)[2];
        let mut accelerations = [0.0; 20];
        for (side, s) in SIDES.into_iter().enumerate() {
            for j in 0..4 {
                let x = if j % 2 == 0 { lt } else { -lt };
                accelerations[4 * side + j] = up(wheelset(j), [0.0, s * dw, 0.0]);
                accelerations[8 + 4 * side + j] = up(bogie(j / 2), [x, s * dw, 0.0]);
            }
        }
        for (k, (x, s)) in [(lc, 1.0), (lc, -1.0), (-lc, 1.0), (-lc, -1.0)].into_iter().enumerate() {
            accelerations[16 + k] = up(CAR_BODY, [x, s * ds, 0.0]);
        }
        let lateral_accelerations = std::array::from_fn(|j| {
            self.a[index(wheelset(j), Coordinate::Lateral).expect("a wheelset moves sideways")]
        });
        Sample {
            accelerations,
            deflections: self.vehicle.primary_compressions(&self.u),
            lateral_accelerations,
            contact: std::array::from_fn(|k| self.contact[k / 4][k % 4].normal),
            lateral_contact: std::array::from_fn(|k| self.contact[k / 4][k % 4].lateral),
        }
    }

    /// The displacement of rail `side` (0 left, 1 right) under wheelset `j` (m, down).
    fn rail(&self, side: usize, j: usize) -> f64 {
        let modes = self.track.modes;
        let shape = &self.wheel_shapes[j * modes..(j + 1) * modes];
        self.track.rail_at(shape, &self.u, &self.v, self.layouts[side]).0
    }

    fn update_wheel_shapes(&mut self) {
        let positions = self.wheel_positions();
        let modes = self.track.modes;
        for (j, x) in positions.iter().enumerate() {
            let shape = &mut self.wheel_shapes[j * modes..(j + 1) * modes];
            self.track.mode_shapes(x - self.origin, shape);
        }
    }

    /// The contact forces and every acceleration at the current state.
    fn evaluate(&mut self) {
        self.update_wheel_shapes();
        let positions = self.wheel_positions();
        let mut generalised = [[0.0; 5]; 4];
        for (j, x) in positions.iter().enumerate() {
            let rails: Rails = self.irregularity.at(*x);
            let (pose, rate) = (Pose::of(wheelset(j), &self.u), Pose::of(wheelset(j), &self.v));
            for (side, s) in SIDES.into_iter().enumerate() {
                let state = ContactState {
                    lateral: pose.lateral - rails.alignment,
                    vertical: pose.vertical,
                    roll: pose.roll,
                    yaw: pose.yaw,
                    lateral_rate: rate.lateral,
                    roll_rate: rate.roll,
                    yaw_rate: rate.yaw,
                    rail: self.rail(side, j) + rails.dip(s),
                };
                let forces = self.contact_law.forces(s, &state, self.speed);
                for (g, f) in generalised[j].iter_mut().zip(forces.generalised) {
                    *g += f;
                }
                self.contact[side][j] = forces;
            }
        }
        self.vehicle.accelerations(&self.u[..DOFS], &self.v[..DOFS], &generalised, &mut self.a[..DOFS]);
        for (side, layout) in self.layouts.into_iter().enumerate() {
            let loads = self.contact[side].map(|f| f.normal);
            self.track.accelerations(&self.u, &self.v, layout, &self.wheel_shapes, &loads, &mut self.a);
        }
    }

    /// One integration step of Δt.
    pub fn step(&mut self) {
        zhai_step(&mut self.u, &mut self.v, &self.a, self.a_previous.as_deref(), self.dt);
        match &mut self.a_previous {
            Some(previous) => previous.copy_from_slice(&self.a),
            None => self.a_previous = Some(self.a.clone()),
        }
        self.time += self.dt;
        // The windows follow the car body: one spacing on whenever the body has gone one on.
        let spacing = self.track.track.sleeper_spacing;
        while self.speed * self.time - (self.origin + self.track.length / 2.0) >= spacing {
            self.origin += spacing;
            if let Some(previous) = self.a_previous.as_mut() {
                for layout in self.layouts {
                    self.track.shift(layout, &mut [&mut self.u, &mut self.v, previous]);
                }
            }
        }
        self.evaluate();
    }
}
