//! The S2 truth: the vehicle coupled to the track through nonlinear Hertz contacts,
//! `P = (δz/G)^{3/2}` for a compression `δz = z_w − z_r − η > 0` and zero when the wheel
//! leaves the rail, integrated with Zhai's explicit two-step method (ψ = φ = ½; a plain
//! Taylor step first) at Δt = 1e-4 s, and sampled at 200 Hz or 1 kHz.
//!
//! The run starts in static equilibrium: the track's static deflection under the four
//! static wheel loads, the wheels compressed into the rail by `G·P0^{2/3}`, the suspension
//! carrying the weights. The car body's centre starts at x = 0; the wheels are at
//! `[10.2, 7.8, −7.8, −10.2]` m for the default vehicle.

use super::irregularity::Irregularity;
use super::parameters::{Track, Vehicle};
use super::track::{Layout, TrackModel};
use super::vehicle::{wheelset, VehicleModel, DOFS};
use estimator::math;

/// Zhai's integration parameters ψ and φ.
const PSI: f64 = 0.5;
const PHI: f64 = 0.5;

/// One step of Zhai's explicit two-step method `[Zhai1996]` over `dt`: the displacements
/// `u` and velocities `v` move on from the accelerations now, `a`, and those of the step
/// before, `previous`; without them (the first step, or after a restart) a plain Taylor
/// step.
pub fn zhai_step(u: &mut [f64], v: &mut [f64], a: &[f64], previous: Option<&[f64]>, dt: f64) {
    match previous {
        None => {
            for k in 0..u.len() {
                u[k] += v[k] * dt + 0.5 * a[k] * dt * dt;
                v[k] += a[k] * dt;
            }
        }
        Some(previous) => {
            for k in 0..u.len() {
                u[k] += v[k] * dt + ((0.5 + PSI) * a[k] - PSI * previous[k]) * dt * dt;
                v[k] += ((1.0 + PHI) * a[k] - PHI * previous[k]) * dt;
            }
        }
    }
}

/// How to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Speed (m/s); 80 km/h by default.
    pub speed: f64,
    /// Integration step (s).
    pub dt: f64,
    /// Rail modes in the window.
    pub modes: usize,
    /// Sleeper spacings in the window.
    pub supports: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self { speed: 80.0 / 3.6, dt: 1e-4, modes: 100, supports: 100 }
    }
}

/// The state of a [`Simulation`] (see [`Simulation::state`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationState {
    /// Time (s).
    pub time: f64,
    /// Where the window starts along the track (m).
    pub origin: f64,
    /// Displacements.
    pub u: Vec<f64>,
    /// Velocities.
    pub v: Vec<f64>,
    /// The accelerations of the step before, once there is one.
    pub a_previous: Option<Vec<f64>>,
}

/// One sample of the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time (s).
    pub time: f64,
    /// Bounce accelerations (m/s², up, as accelerometers on the car body, the bogie frames
    /// and the axle boxes read them, less gravity) of the car body, the two bogies and the
    /// four wheelsets: the seven measurements of eq. (7).
    pub accelerations: [f64; 7],
    /// The four wheel–rail forces (N).
    pub contact: [f64; 4],
}

/// The coupled vehicle–track system being integrated.
#[derive(Debug, Clone)]
pub struct Simulation {
    vehicle: VehicleModel,
    track: TrackModel,
    layout: Layout,
    irregularity: Irregularity,
    hertz: f64,
    speed: f64,
    dt: f64,
    /// Time (s).
    time: f64,
    /// Where the window starts along the track (m).
    origin: f64,
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    a_previous: Option<Vec<f64>>,
    wheel_shapes: Vec<f64>,
    contact: [f64; 4],
}

impl Simulation {
    /// The system at rest in static equilibrium, the car body's centre at x = 0.
    pub fn new(vehicle: Vehicle, track: Track, irregularity: Irregularity, settings: &Settings) -> Self {
        let vehicle = VehicleModel { vehicle };
        let track = TrackModel::new(track, settings.modes, settings.supports);
        let layout = track.layout(DOFS);
        let size = layout.end;
        let mut simulation = Self {
            vehicle,
            layout,
            irregularity,
            hertz: vehicle.vehicle.hertz_coefficient(),
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
            contact: [0.0; 4],
        };
        simulation.update_wheel_shapes();
        let load = vehicle.vehicle.static_wheel_load();
        let deflection = simulation.track.static_deflection(&simulation.wheel_shapes, &[load; 4]);
        simulation.u[layout.modes..layout.end].copy_from_slice(&deflection);
        let mut rail = [0.0; 4];
        for (j, r) in rail.iter_mut().enumerate() {
            let shape = &simulation.wheel_shapes[j * simulation.track.modes..(j + 1) * simulation.track.modes];
            let (z, _) = simulation.track.rail_at(shape, &simulation.u, &simulation.v, layout);
            *r = z + simulation.irregularity.at(simulation.wheel_positions()[j]);
        }
        let compression = simulation.hertz * math::powf(load, 2.0 / 3.0);
        simulation.u[..DOFS].copy_from_slice(&vehicle.static_state(&rail, compression));
        simulation.evaluate();
        simulation
    }

    /// The wheels' positions along the track (m).
    pub fn wheel_positions(&self) -> [f64; 4] {
        let centre = self.speed * self.time;
        self.vehicle.vehicle.wheel_offsets().map(|d| centre + d)
    }

    /// The time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The wheel–rail forces now (N).
    pub fn contact(&self) -> [f64; 4] {
        self.contact
    }

    /// The measurements and forces now.
    pub fn sample(&self) -> Sample {
        // The model's coordinates point down; the measurements up.
        let mut accelerations = [0.0; 7];
        for (m, k) in accelerations.iter_mut().zip([0, 2, 4, wheelset(0), wheelset(1), wheelset(2), wheelset(3)]) {
            *m = -self.a[k];
        }
        Sample { time: self.time, accelerations, contact: self.contact }
    }

    /// Changes the state (displacements, velocities) by `change`, as a blow or a release
    /// would: for free-vibration tests. The integrator restarts from the new state.
    pub fn perturb(&mut self, change: impl FnOnce(&mut [f64], &mut [f64])) {
        change(&mut self.u, &mut self.v);
        self.a_previous = None;
        self.evaluate();
    }

    /// The displacements of every degree of freedom: the vehicle's, then the track's.
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

    /// What makes the system where it is, beside its construction: the time, the
    /// window's origin, the displacements, the velocities and the accelerations of the step
    /// before (the rest is computed from these).
    pub fn state(&self) -> SimulationState {
        SimulationState {
            time: self.time,
            origin: self.origin,
            u: self.u.clone(),
            v: self.v.clone(),
            a_previous: self.a_previous.clone(),
        }
    }

    /// Back to a [`Simulation::state`] of a system built alike: the same steps after it give
    /// the same numbers, to the bit.
    pub fn resume(&mut self, state: &SimulationState) -> Result<(), String> {
        let n = self.u.len();
        let sizes_fit =
            state.u.len() == n && state.v.len() == n && state.a_previous.as_ref().is_none_or(|a| a.len() == n);
        if !sizes_fit {
            return Err(format!("a state of another system ({} degrees of freedom, this one {n})", state.u.len()));
        }
        let finite = [state.time, state.origin].iter().chain(&state.u).chain(&state.v).all(|x| x.is_finite());
        if !finite {
            return Err("the state is not finite".into());
        }
        self.time = state.time;
        self.origin = state.origin;
        self.u.copy_from_slice(&state.u);
        self.v.copy_from_slice(&state.v);
        self.a_previous.clone_from(&state.a_previous);
        self.evaluate();
        Ok(())
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
        let modes = self.track.modes;
        let positions = self.wheel_positions();
        for (j, x) in positions.iter().enumerate() {
            let shape = &self.wheel_shapes[j * modes..(j + 1) * modes];
            let (rail, _) = self.track.rail_at(shape, &self.u, &self.v, self.layout);
            let compression = self.u[wheelset(j)] - rail - self.irregularity.at(*x);
            self.contact[j] = if compression > 0.0 { math::powf(compression / self.hertz, 1.5) } else { 0.0 };
        }
        self.vehicle.accelerations(&self.u[..DOFS], &self.v[..DOFS], &self.contact, &mut self.a[..DOFS]);
        self.track.accelerations(&self.u, &self.v, self.layout, &self.wheel_shapes, &self.contact, &mut self.a);
    }

    /// One integration step of Δt.
    pub fn step(&mut self) {
        zhai_step(&mut self.u, &mut self.v, &self.a, self.a_previous.as_deref(), self.dt);
        match &mut self.a_previous {
            Some(previous) => previous.copy_from_slice(&self.a),
            None => self.a_previous = Some(self.a.clone()),
        }
        self.time += self.dt;
        // The window follows the car body: one spacing on whenever the body has gone one on.
        let spacing = self.track.track.sleeper_spacing;
        while self.speed * self.time - (self.origin + self.track.length / 2.0) >= spacing {
            self.origin += spacing;
            let previous = self.a_previous.as_mut().expect("set above");
            self.track.shift(self.layout, &mut [&mut self.u, &mut self.v, previous]);
        }
        self.evaluate();
    }
}
