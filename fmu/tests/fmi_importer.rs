//! The packaged estimator FMUs driven through a second importer, the `fmi`
//! crate (rust-fmi): the `.fmu` is unzipped, its `modelDescription.xml` parsed
//! and its shared library loaded with `dlopen`, as any co-simulation master
//! does. S5 (`kalfmu_s5_missile`, its defaults: the SVD-CKF) has its own check,
//! `s5_outputs_equal_the_library_run_in_process`: a missile flown by the
//! estimation model itself with known deflections, its measurements noisy, the
//! controls of t_k set with the measurements of t_k; the reference predicts
//! with the controls of the previous sample and updates holding those of the
//! current (`fmu/src/timing.rs`, rule 5), bit for bit. S4 (`kalfmu_s4_maglev`)
//! runs the generic checks below on telegrams of a train at 5 m/s with a spike, a
//! slot slip, a resend, a dropout and markers, against `PrwTrain` behind a supervisor
//! with resends stuck from the first repeat and slips as quantised steps. Each other
//! check runs on S1 (`kalfmu_s1_load`, several parameters off their
//! defaults, so that every one is seen to reach the filter), on S2
//! (`kalfmu_s2_wheel_rail`, its default parameters, whose vehicle is checked
//! to be the library's catalogue car, `VerticalVehicle::zhai_passenger`) and on
//! S3 (`kalfmu_s3_wheel_rail_lr`, its defaults, checked to be
//! `RollVehicle::zhai_passenger`, but a return rate of the forces and the car
//! body's roll inertia; its deflections a thousandth of the accelerations' sines);
//! the reference is the SRCKF built here from the estimator crate — the
//! study's model, RK4, `Q`, `R` and prior from the parameter values as the
//! FMU's documentation gives them — behind the same `Supervisor`:
//!
//! * `*_outputs_equal_the_library_run_in_process`: 1000 samples of synthetic
//!   accelerations (a seeded sum of sines about the static equilibrium, every
//!   97th sample of the second input missing) through the FMU as a master
//!   drives it (set the inputs of t, read, step, read); the read after the
//!   inputs equals the reference after its update at t, the read after the
//!   step its prediction to t + dt, every estimate, deviation and the NIS bit
//!   for bit, each `<input>_status` the supervisor's outcome of its row; the
//!   counts and flags at the end are the supervisor's;
//! * `*_communication_steps_shorter_and_longer_than_the_sample_time`: a master
//!   stepping by a fifth of the sample time and by two sample times (S1: 1 and
//!   10 ms at 5 ms); every read equals the reference run by the rules of
//!   `fmu/src/timing.rs`, bit for bit;
//! * `*_fmu_state_get_set_serialize_through_the_importer`: saved, restored and
//!   serialised states replay the same outputs, in the same instance and in a
//!   fresh one; garbage, truncated and foreign bytes are refused;
//! * `s4_input_status_says_what_became_of_each_telegram`: the `<input>_status`
//!   outputs on S4's telegrams: `rejected` at exactly the spike (its fault flag
//!   false), `stuck` on the resend, `missing` on the dropout, `used` elsewhere.
//!
//! The FMUs are packaged in-process the way `package-fmus` does it (`support/packaged.rs`), from the
//! `libkalfmu_fmu.so` that cargo builds for this very test run (under
//! `cargo test` the cdylib is only in `target/<profile>/deps/`). Set
//! `KALFMU_FMU_DIR=path/to/dir` (holding `<modelIdentifier>.fmu`, as
//! `package-fmus --out` writes them) to test released FMUs instead.
#![cfg(target_os = "linux")]

mod support {
    pub mod packaged;
}

use std::collections::HashMap;
use std::path::PathBuf;

use estimator::models::{
    Airframe, Missile6Dof, Oscillator2Dof, Oscillator2DofLoad, PiecewiseLinear, PrwTrain, RollVehicle, VerticalVehicle,
    WheelRailRoll, WheelRailVertical,
};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, QuantizedSteps, StateEstimator, SupervisedFilter,
    Supervisor, UnscentedParams,
};
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use kalfmu_fmu::estimators::{self, Descriptor};
use kalfmu_fmu::variables::Role;
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use support::packaged;

const SAMPLES: usize = 1000;

/// The `.fmu` of `model` under test (`support/packaged.rs`).
fn fmu_path(model: &str) -> PathBuf {
    packaged::fmu_path(model, "fmi_importer")
}

fn descriptor(model: &str) -> Descriptor {
    estimators::all().into_iter().find(|d| d.model_identifier == model).unwrap_or_else(|| panic!("no FMU {model}"))
}

/// One FMU under test: the parameters this test sets, and the filter the FMU
/// should run with them.
struct Setup {
    /// The FMU's variable table: its names, roles and defaults.
    descriptor: Descriptor,
    /// Real parameters set in initialisation mode; the others keep their defaults.
    reals: Vec<(&'static str, f64)>,
    /// `rk4_substeps`, for the models that integrate with RK4.
    substeps: Option<i32>,
    /// The `filter` set in initialisation mode (2: SRCKF; 3: SVD-CKF).
    filter: i32,
    /// The SRCKF the FMU should run, with the process noise of a prediction over `dt`.
    reference: fn(&Setup, f64) -> Box<dyn StateEstimator>,
    /// The supervisor the FMU should run, from the parameters.
    supervisor: fn(&Setup) -> Supervisor,
    /// `n` samples of inputs `dt` apart from a seed: the plant's outputs a master sets.
    measurements: fn(&Setup, usize, f64, u64) -> Vec<Vec<f64>>,
    /// The plant's outputs at any time `t`, for masters off the sample grid.
    signal: fn(&Setup, f64) -> Vec<f64>,
}

impl Setup {
    /// S1 with the chain, prior and noise off their defaults.
    fn s1() -> Self {
        let reals = vec![
            ("m1", 4.0),
            ("m2", 8.0),
            ("k11", 5.0),
            ("k12", 20.0),
            ("k13", 30.0),
            ("delta1", 0.1),
            ("delta2", 0.2),
            ("c11", 5.0),
            ("c12", 6.0),
            ("c13", 7.5),
            ("eps1", 0.05),
            ("eps2", 0.1),
            ("k2", 15.0),
            ("c2", 3.0),
            ("x0_z1", 0.0),
            ("x0_z2", 0.0),
            ("x0_F", 1.5),
            ("x0_z1_dot", 0.0),
            ("x0_z2_dot", 0.0),
            ("x0_F_dot", 0.0),
            ("p0_z1_std", 1e-3),
            ("p0_z2_std", 1e-3),
            ("p0_F_std", 20.0),
            ("p0_z1_dot_std", 1e-3),
            ("p0_z2_dot_std", 1e-3),
            ("p0_F_dot_std", 500.0),
            ("q_z_std", 1e-6),
            ("q_z_dot_std", 1e-5),
            ("load_noise_intensity", 1.0e6),
            ("r_z1_ddot_std", 0.01),
            ("r_z2_ddot_std", 0.02),
            ("sample_time", 0.005),
        ];
        Self {
            descriptor: descriptor("kalfmu_s1_load"),
            reals,
            substeps: Some(2),
            filter: 2,
            reference: s1_reference,
            supervisor: default_supervisor,
            measurements: accelerations,
            signal: tones,
        }
    }

    /// S2 with its defaults.
    fn s2() -> Self {
        let descriptor = descriptor("kalfmu_s2_wheel_rail");
        Self {
            descriptor,
            reals: Vec::new(),
            substeps: Some(1),
            filter: 2,
            reference: s2_reference,
            supervisor: default_supervisor,
            measurements: accelerations,
            signal: tones,
        }
    }

    /// S3 with its defaults but a return rate of the forces and a lighter car body in
    /// roll (both seen to reach the filter); deflections a thousandth of the tones.
    fn s3() -> Self {
        let descriptor = descriptor("kalfmu_s3_wheel_rail_lr");
        Self {
            descriptor,
            reals: vec![("force_return_rate", 2.0), ("car_body_roll_inertia", 6e4)],
            substeps: Some(1),
            filter: 2,
            reference: s3_reference,
            supervisor: default_supervisor,
            measurements: s3_measurements,
            signal: s3_tones,
        }
    }

    /// S5 with its defaults (the SVD-CKF, the study's tuning).
    fn s5() -> Self {
        let descriptor = descriptor("kalfmu_s5_missile");
        Self {
            descriptor,
            reals: Vec::new(),
            substeps: Some(1),
            filter: 3,
            reference: s5_reference,
            supervisor: default_supervisor,
            measurements: accelerations,
            signal: tones,
        }
    }

    /// S4 with its defaults but a higher jerk intensity (every one is seen to reach the filter).
    fn s4() -> Self {
        let descriptor = descriptor("kalfmu_s4_maglev");
        Self {
            descriptor,
            reals: vec![("jerk_intensity", 3.0), ("prior_position", 0.25)],
            substeps: None,
            filter: 2,
            reference: s4_reference,
            supervisor: s4_supervisor,
            measurements: s4_telegrams,
            signal: s4_signal,
        }
    }

    fn model(&self) -> &'static str {
        self.descriptor.model_identifier
    }

    /// The same FMU and filter: a setup of its own to change the parameters of.
    fn same(other: &Setup) -> Self {
        Self {
            descriptor: descriptor(other.model()),
            reals: other.reals.clone(),
            substeps: other.substeps,
            filter: other.filter,
            reference: other.reference,
            supervisor: other.supervisor,
            measurements: other.measurements,
            signal: other.signal,
        }
    }

    /// A Real parameter's value: as set here, or the FMU's default.
    fn get(&self, name: &str) -> f64 {
        let set = self.reals.iter().find(|(n, _)| *n == name).map(|(_, v)| *v);
        let default = || self.descriptor.variables.iter().find(|v| v.name == name).and_then(|v| v.start);
        set.or_else(default).unwrap_or_else(|| panic!("no parameter {name}"))
    }

    fn sample_time(&self) -> f64 {
        self.get("sample_time")
    }

    /// The names of the variables of this role, in table order.
    fn names(&self, role: impl Fn(Role) -> bool) -> Vec<&str> {
        self.descriptor.variables.iter().filter(|v| role(v.role)).map(|v| &*v.name).collect()
    }

    /// The inputs, in measurement-row order.
    fn inputs(&self) -> Vec<&str> {
        (0..self.descriptor.measurement_dim()).flat_map(|row| self.names(|r| r == Role::Measurement(row))).collect()
    }

    /// The controls, in the order of the model's input.
    fn controls(&self) -> Vec<&str> {
        (0..self.descriptor.control_dim()).flat_map(|j| self.names(|r| r == Role::Control(j))).collect()
    }

    /// The outputs compared: every estimate and standard deviation as
    /// `(name, state index, standard deviation?)`, in table order; then `nis`.
    fn estimates(&self) -> Vec<(&str, usize, bool)> {
        let of = |role: Role| match role {
            Role::Estimate(i) => Some((i, false)),
            Role::EstimateStd(i) => Some((i, true)),
            _ => None,
        };
        self.descriptor.variables.iter().filter_map(|v| of(v.role).map(|(i, std)| (&*v.name, i, std))).collect()
    }

    fn reference_filter(&self) -> Box<dyn StateEstimator> {
        (self.reference)(self, self.sample_time())
    }

    fn reference_filter_over(&self, dt: f64) -> Box<dyn StateEstimator> {
        (self.reference)(self, dt)
    }

    /// What the FMU's outputs should be for a filter's belief: the estimates, then the NIS.
    fn expected_outputs(&self, belief: &dyn StateEstimator, nis: f64) -> Vec<f64> {
        self.estimates()
            .iter()
            .map(|(_, i, std)| if *std { belief.variance(*i).max(0.0).sqrt() } else { belief.mean()[*i] })
            .chain([nis])
            .collect()
    }
}

const UKF: UnscentedParams = UnscentedParams { alpha: 1e-3, beta: 2.0, kappa: 0.0 };

/// S1's SRCKF: the chain, RK4, `F̈` white with the given intensity discretised
/// exactly over `dt`, the per-sample position and velocity variances scaled
/// by `dt / sample_time`, a diagonal prior.
fn s1_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let chain = Oscillator2Dof {
        m1: p("m1"),
        m2: p("m2"),
        k1: PiecewiseLinear::new([p("k11"), p("k12"), p("k13")], [p("delta1"), p("delta2")]).unwrap(),
        c1: PiecewiseLinear::new([p("c11"), p("c12"), p("c13")], [p("eps1"), p("eps2")]).unwrap(),
        k2: p("k2"),
        c2: p("c2"),
    };
    let model = Discretized::rk4(Oscillator2DofLoad::new(chain), s.substeps.unwrap_or(1) as usize);
    let q = p("load_noise_intensity");
    let fraction = dt / p("sample_time");
    let mut qm = DMatrix::zeros(6, 6);
    for i in [0, 1] {
        qm[(i, i)] = p("q_z_std") * p("q_z_std") * fraction;
        qm[(i + 3, i + 3)] = p("q_z_dot_std") * p("q_z_dot_std") * fraction;
    }
    qm[(2, 2)] = q * dt.powi(3) / 3.0;
    qm[(2, 5)] = q * dt.powi(2) / 2.0;
    qm[(5, 2)] = qm[(2, 5)];
    qm[(5, 5)] = q * dt;
    let r =
        DMatrix::from_diagonal(&DVector::from_column_slice(&[p("r_z1_ddot_std").powi(2), p("r_z2_ddot_std").powi(2)]));
    let noise = Noise::new(qm, r).unwrap();
    let names = ["z1", "z2", "F", "z1_dot", "z2_dot", "F_dot"];
    let mean: Vec<f64> = names.iter().map(|n| p(&format!("x0_{n}"))).collect();
    let variances: Vec<f64> = names.iter().map(|n| p(&format!("p0_{n}_std")).powi(2)).collect();
    let prior = Gaussian::diagonal(&mean, &variances);
    build_filter(FilterKind::SrCkf, model, noise, &prior, UKF).unwrap()
}

/// S2's vehicle: half of the vehicle given whole, with the weighed static wheel load.
fn s2_vehicle(s: &Setup) -> VerticalVehicle {
    let p = |n: &str| s.get(n);
    let beyond = p("primary_damping_beyond");
    let damper = PiecewiseLinear::new([p("primary_damping"), beyond, beyond], [p("primary_damper_knee"); 2]).unwrap();
    VerticalVehicle {
        static_wheel_load: p("static_wheel_load"),
        ..VerticalVehicle::half_of(
            (p("car_body_mass"), p("car_body_pitch_inertia")),
            (p("bogie_mass"), p("bogie_pitch_inertia")),
            p("wheelset_mass"),
            (p("primary_stiffness"), damper),
            (p("secondary_stiffness"), p("secondary_damping")),
            p("half_bogie_spacing"),
            p("half_wheelbase"),
        )
    }
}

/// S2's SRCKF: its vehicle, RK4; the motion states' per-sample variances
/// scaled by `dt / sample_time`, the forces' random walk `intensity·dt`; `R`
/// from the sensors' deviations; the prior at equilibrium with the forces at
/// the static wheel load.
fn s2_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let vehicle = s2_vehicle(s);
    let model = Discretized::rk4(WheelRailVertical { vehicle }, s.substeps.unwrap_or(1) as usize);
    let fraction = dt / p("sample_time");
    let (body, wheelset) = (p("q_body_std").powi(2) * fraction, p("q_wheelset_std").powi(2) * fraction);
    // Positions, then velocities: car body and bogies (6) before the wheelsets (4).
    let mut q = [[body; 6].as_slice(), &[wheelset; 4], &[body; 6], &[wheelset; 4]].concat();
    q.extend([p("force_noise_intensity") * dt; 4]);
    let r: Vec<f64> = s.inputs().iter().map(|n| p(&format!("r_{n}_std")).powi(2)).collect();
    let noise = Noise::diagonal(&q, &r).unwrap();
    let mut mean = [0.0; 24];
    mean[WheelRailVertical::FORCES..].fill(vehicle.static_wheel_load);
    let mut variances = [p("p0_motion_std").powi(2); 24];
    variances[WheelRailVertical::FORCES..].fill(p("p0_force_std").powi(2));
    let prior = Gaussian::diagonal(&mean, &variances);
    build_filter(FilterKind::SrCkf, model, noise, &prior, UKF).unwrap()
}

/// S3's vehicle: the whole car with roll, with the weighed static wheel load.
fn s3_vehicle(s: &Setup) -> RollVehicle {
    let p = |n: &str| s.get(n);
    let beyond = p("primary_damping_beyond");
    RollVehicle {
        car_body_mass: p("car_body_mass"),
        car_body_pitch_inertia: p("car_body_pitch_inertia"),
        car_body_roll_inertia: p("car_body_roll_inertia"),
        bogie_mass: p("bogie_mass"),
        bogie_pitch_inertia: p("bogie_pitch_inertia"),
        bogie_roll_inertia: p("bogie_roll_inertia"),
        wheelset_mass: p("wheelset_mass"),
        wheelset_roll_inertia: p("wheelset_roll_inertia"),
        primary_stiffness: p("primary_stiffness"),
        primary_damper: PiecewiseLinear::new([p("primary_damping"), beyond, beyond], [p("primary_damper_knee"); 2])
            .unwrap(),
        secondary_stiffness: p("secondary_stiffness"),
        secondary_damping: p("secondary_damping"),
        half_bogie_spacing: p("half_bogie_spacing"),
        half_wheelbase: p("half_wheelbase"),
        primary_half_span: p("primary_half_span"),
        secondary_half_span: p("secondary_half_span"),
        contact_half_span: p("contact_half_span"),
        static_wheel_load: p("static_wheel_load"),
    }
}

/// S3's SRCKF: its vehicle and the forces' return rate, RK4; the motion states'
/// per-sample variances scaled by `dt / sample_time` (car body and bogies: 9
/// coordinates, wheelsets: 8), the forces' driving noise `intensity·dt`; `R` from
/// the sensors' deviations, the deflections' with the model's error added; the prior at equilibrium with the forces at the static
/// wheel load.
fn s3_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let vehicle = s3_vehicle(s);
    let model = Discretized::rk4(
        WheelRailRoll { vehicle, force_return_rate: p("force_return_rate") },
        s.substeps.unwrap_or(1) as usize,
    );
    let fraction = dt / p("sample_time");
    let (body, wheelset) = (p("q_body_std").powi(2) * fraction, p("q_wheelset_std").powi(2) * fraction);
    let mut q = [[body; 9].as_slice(), &[wheelset; 8], &[body; 9], &[wheelset; 8]].concat();
    q.extend([p("force_noise_intensity") * dt; 8]);
    let floor = |n: &str| if n.starts_with("d_p_") { p("deflection_model_error").powi(2) } else { 0.0 };
    let r: Vec<f64> = s.inputs().iter().map(|n| p(&format!("r_{n}_std")).powi(2) + floor(n)).collect();
    let noise = Noise::diagonal(&q, &r).unwrap();
    let mut mean = [0.0; 42];
    mean[WheelRailRoll::FORCES..].fill(vehicle.static_wheel_load);
    let mut variances = [p("p0_motion_std").powi(2); 42];
    variances[WheelRailRoll::FORCES..].fill(p("p0_force_std").powi(2));
    build_filter(FilterKind::SrCkf, model, noise, &Gaussian::diagonal(&mean, &variances), UKF).unwrap()
}

/// S3's inputs: `accelerations`, the deflections (m) a thousandth of them.
fn s3_measurements(s: &Setup, n: usize, dt: f64, seed: u64) -> Vec<Vec<f64>> {
    let mut rows = accelerations(s, n, dt, seed);
    for row in &mut rows {
        row[WheelRailRoll::DEFLECTIONS].iter_mut().for_each(|d| *d *= 1e-3);
    }
    rows
}

/// S3's inputs at `t`: `tones`, the deflections (m) a thousandth of them.
fn s3_tones(s: &Setup, t: f64) -> Vec<f64> {
    let mut z = tones(s, t);
    z[WheelRailRoll::DEFLECTIONS].iter_mut().for_each(|d| *d *= 1e-3);
    z
}

/// S5's airframe from the parameters (defaults: the library's tactical missile).
fn s5_airframe(s: &Setup) -> Airframe {
    let p = |n: &str| s.get(n);
    let mut a = Airframe::tactical_missile();
    a.mass = p("mass");
    a.area = p("area");
    a.length = p("length");
    a.inertia = [p("inertia_x"), p("inertia_y"), p("inertia_z")];
    a.moments.roll_control = p("m_x_delta");
    a.moments.roll_damping = p("m_x_omega");
    a.moments.yaw_stiffness = p("m_y_beta");
    a.moments.yaw_control = p("m_y_delta");
    a.moments.yaw_damping = p("m_y_omega");
    a.moments.pitch_stiffness = p("m_z_alpha");
    a.moments.pitch_control = p("m_z_delta");
    a.moments.pitch_damping = p("m_z_omega");
    a.gravity = p("gravity");
    a
}

/// S5's SVD-CKF: `Missile6Dof` on the airframe, RK4; the per-sample variances (velocities,
/// angles, altitude, rates; each coefficient's random walk relative to its prior mean,
/// 0.05 at least) scaled by `dt / sample_time`; `R` from the sensors' deviations; the
/// diagonal prior of the `prior_*` parameters.
fn s5_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let model = Discretized::rk4(Missile6Dof { airframe: s5_airframe(s) }, s.substeps.unwrap_or(1) as usize);
    let fraction = dt / p("sample_time");
    let var = |n: &str| p(n) * p(n) * fraction;
    let (v, angle, h, rate) = (var("q_velocity_std"), var("q_angle_std"), var("q_altitude_std"), var("q_rate_std"));
    let mut q = vec![v, v, v, angle, angle, angle, h, rate, rate, rate];
    let names = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"];
    for c in names {
        let std = p("q_coefficient_relative_std") * p(&format!("prior_{c}")).abs().max(0.05);
        q.push(std * std * fraction);
    }
    let r: Vec<f64> = s.inputs().iter().map(|n| p(&format!("r_{n}_std")).powi(2)).collect();
    let noise = Noise::diagonal(&q, &r).unwrap();
    let states = Missile6Dof::STATE_NAMES;
    let mean: Vec<f64> = states.iter().map(|n| p(&format!("prior_{n}"))).collect();
    let variances: Vec<f64> = states.iter().map(|n| p(&format!("prior_{n}_std")).powi(2)).collect();
    build_filter(FilterKind::SvdCkf, model, noise, &Gaussian::diagonal(&mean, &variances), UKF).unwrap()
}

/// The reference filter holding the controls `u` for its update, without moving: what
/// the FMU does when the controls of a sample are set (the filter holds the input of its
/// last prediction).
fn hold(filter: &mut dyn StateEstimator, u: &[f64]) {
    let mut snapshot = filter.snapshot();
    snapshot.input.copy_from_slice(u);
    filter.restore(&snapshot).unwrap();
}

/// S5's flight: the missile of the prior's start flown by RK4 at a tenth of `dt` with the
/// true coefficients (Table 1), deflections of a few tenths of a degree held over each
/// sample (a seeded sum of sines per control), the twelve measurements with the sensors'
/// noise and every 97th altitude missing. Returns `(measurements, controls)` per sample.
fn s5_flight(s: &Setup, n: usize, dt: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let airframe = s5_airframe(s);
    let coefficients = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let tones: Vec<(f64, f64)> = (0..3).map(|_| (rng.random_range(1.0..6.0), rng.random_range(0.0..6.0))).collect();
    let mut x: Vec<f64> = Missile6Dof::STATE_NAMES[..10].iter().map(|n| s.get(&format!("prior_{n}"))).collect();
    let sensor: Vec<f64> = s.inputs().iter().map(|n| s.get(&format!("r_{n}_std"))).collect();
    let derivative = |x: &[f64], u: &[f64]| {
        let mut d = vec![0.0; 10];
        airframe.motion_derivative(x, &coefficients, u, &mut d);
        d
    };
    let (mut zs, mut us) = (Vec::new(), Vec::new());
    for k in 0..n {
        let t = k as f64 * dt;
        let u: Vec<f64> = tones.iter().map(|(w, phase)| 0.005 * (w * t + phase).sin()).collect();
        let mut z = vec![0.0; 12];
        airframe.measure(&x, &coefficients, &u, &mut z);
        for (zi, std) in z.iter_mut().zip(&sensor) {
            *zi += std * (rng.random::<f64>() - 0.5) * 12f64.sqrt();
        }
        if k % 97 == 96 {
            z[9] = f64::NAN;
        }
        let h = dt / 10.0;
        for _ in 0..10 {
            let step = |x: &[f64], d: &[f64], c: f64| -> Vec<f64> { x.iter().zip(d).map(|(a, b)| a + c * b).collect() };
            let k1 = derivative(&x, &u);
            let k2 = derivative(&step(&x, &k1, h / 2.0), &u);
            let k3 = derivative(&step(&x, &k2, h / 2.0), &u);
            let k4 = derivative(&step(&x, &k3, h), &u);
            for i in 0..10 {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        zs.push(z);
        us.push(u);
    }
    (zs, us)
}

/// Measured accelerations of `m` inputs about the static equilibrium (the
/// models' coordinates): per input a seeded sum of four sines plus white noise
/// of 0.01·(i + 1) m/s²; every 97th sample of the second input is missing (NaN).
/// The supervisor with the FMU's defaults.
fn default_supervisor(s: &Setup) -> Supervisor {
    let n = s.reference_filter().state_dim();
    Supervisor::new(s.descriptor.supervision, s.inputs().len())
        .and_then(|supervisor| supervisor.with_jump_states(n, s.descriptor.unknown_inputs))
        .unwrap()
}

/// S4's lever parameters, in channel order.
const S4_LEVERS: [&str; 4] = ["lever_head_left", "lever_head_right", "lever_tail_left", "lever_tail_right"];

/// S4's reference: `PrwTrain` with the marker row, `Q` exact over `dt`, `R` from each
/// channel's noise, a diagonal prior.
fn s4_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let levers = S4_LEVERS.map(p);
    let model = PrwTrain {
        marker: true,
        jerk_intensity: p("jerk_intensity"),
        offset_walk: p("offset_walk"),
        ..PrwTrain::new(levers)
    };
    let r =
        ["r_P_head_left_std", "r_P_head_right_std", "r_P_tail_left_std", "r_P_tail_right_std", "r_marker_position_std"]
            .map(|n| p(n).powi(2));
    let noise = Noise::new(model.process_noise(dt), DMatrix::from_diagonal(&DVector::from_column_slice(&r))).unwrap();
    let offset = p("prior_offset_std").powi(2);
    let prior = Gaussian::diagonal(
        &[p("prior_position"), p("prior_speed"), p("prior_acceleration"), 0.0, 0.0, 0.0, 0.0],
        &[
            p("prior_position_std").powi(2),
            p("prior_speed_std").powi(2),
            p("prior_acceleration_std").powi(2),
            offset,
            offset,
            offset,
            offset,
        ],
    );
    build_filter(FilterKind::SrCkf, model, noise, &prior, UKF).unwrap()
}

/// S4's supervisor: resent telegrams stuck from the first repeat, slot slips as
/// quantised steps of the offsets.
fn s4_supervisor(s: &Setup) -> Supervisor {
    let settings = s.descriptor.supervision;
    let steps = QuantizedSteps {
        quantum: s.get("slot_pitch"),
        after: 3,
        tolerance: s.get("slip_tolerance"),
        bias_states: PrwTrain { marker: true, ..PrwTrain::new([0.0; 4]) }.bias_states(),
    };
    let n = s.reference_filter().state_dim();
    Supervisor::new(settings, 5)
        .and_then(|supervisor| supervisor.with_steps(steps))
        .and_then(|supervisor| supervisor.with_jump_states(n, s.descriptor.unknown_inputs))
        .unwrap()
}

/// S4's telegrams: a train at 5 m/s from 0.3 m, the four channels at their levers with
/// offsets and 1.5 mm of noise; a spike on the first channel at sample 300, a slot slip
/// of the third from 500 on, the second resent at 700–703, the fourth not received at
/// 800–805; a marker reading every 50th sample, NaN between.
fn s4_telegrams(s: &Setup, n: usize, dt: f64, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let levers = S4_LEVERS.map(|l| s.get(l));
    let offsets = [0.03, -0.02, 0.01, -0.04];
    let mut rows: Vec<Vec<f64>> = Vec::with_capacity(n);
    for k in 0..n {
        let position = 0.3 + 5.0 * dt * k as f64;
        let mut z: Vec<f64> =
            (0..4).map(|c| position + levers[c] + offsets[c] + 1.5e-3 * (rng.random::<f64>() - 0.5) * 3.46).collect();
        if k == 300 {
            z[0] += 0.2;
        }
        if k >= 500 {
            z[2] += 0.086;
        }
        if (700..704).contains(&k) {
            z[1] = rows[k - 1][1];
        }
        if (800..806).contains(&k) {
            z[3] = f64::NAN;
        }
        z.push(if k % 50 == 0 { position + 0.01 * (rng.random::<f64>() - 0.5) } else { f64::NAN });
        rows.push(z);
    }
    rows
}

/// Input i at `t`: a tone of (7 + 4i) rad/s and a small one of 53 rad/s.
fn tones(s: &Setup, t: f64) -> Vec<f64> {
    (0..s.inputs().len())
        .map(|i| 0.5 * ((7.0 + 4.0 * i as f64) * t).sin() + 0.1 * (53.0 * t + i as f64).cos())
        .collect()
}

/// S4's channels at `t`: the train of `s4_telegrams` without its faults, a 1 mm tone of
/// 53 rad/s in place of the noise (a live channel never repeats), no marker.
fn s4_signal(s: &Setup, t: f64) -> Vec<f64> {
    let levers = S4_LEVERS.map(|l| s.get(l));
    let offsets = [0.03, -0.02, 0.01, -0.04];
    let position = 0.3 + 5.0 * t;
    (0..4).map(|c| position + levers[c] + offsets[c] + 1e-3 * (53.0 * t + c as f64).sin()).chain([f64::NAN]).collect()
}

fn accelerations(s: &Setup, n: usize, dt: f64, seed: u64) -> Vec<Vec<f64>> {
    let m = s.inputs().len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let tones: Vec<Vec<(f64, f64, f64)>> = (0..m)
        .map(|_| {
            (0..4)
                .map(|_| {
                    let amplitude = rng.random_range(0.05..0.5);
                    (amplitude, rng.random_range(0.5..12.0), rng.random_range(0.0..std::f64::consts::TAU))
                })
                .collect()
        })
        .collect();
    let signal =
        |tones: &[(f64, f64, f64)], t: f64| tones.iter().map(|(amp, w, phi)| amp * (w * t + phi).sin()).sum::<f64>();
    (0..n)
        .map(|k| {
            let t = (k + 1) as f64 * dt;
            let mut z: Vec<f64> = tones
                .iter()
                .enumerate()
                .map(|(i, tones)| signal(tones, t) + 0.01 * (i + 1) as f64 * (rng.random::<f64>() - 0.5))
                .collect();
            if k % 97 == 96 {
                z[1] = f64::NAN;
            }
            z
        })
        .collect()
}

/// One instance of the imported FMU with the value references by name.
struct Fmu {
    instance: InstanceCS,
    vr: HashMap<String, u32>,
    inputs: Vec<u32>,
    controls: Vec<u32>,
    outputs: Vec<u32>,
    /// The `<input>_status` outputs, in measurement-row order.
    statuses: Vec<u32>,
}

impl Fmu {
    fn new(import: &Fmi2Import, setup: &Setup, name: &str) -> Self {
        let vr: HashMap<String, u32> = import
            .model_description()
            .model_variables
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        let inputs = setup.inputs().iter().map(|n| vr[*n]).collect();
        let controls = setup.controls().iter().map(|n| vr[*n]).collect();
        let outputs = setup.estimates().iter().map(|(n, _, _)| vr[*n]).chain([vr["nis"]]).collect();
        let statuses = setup.inputs().iter().map(|n| vr[&format!("{n}_status")]).collect();
        let instance = import.instantiate_cs(name, false, true).expect("fmi2Instantiate");
        Self { instance, vr, inputs, controls, outputs, statuses }
    }

    /// SetupExperiment + EnterInitializationMode, the parameters, ExitInitializationMode.
    fn initialise(&mut self, setup: &Setup, stop: f64) {
        self.initialise_with_timing(setup, stop, 1);
    }

    /// [`Fmu::initialise`] with `input_timing` = `timing`.
    fn initialise_with_timing(&mut self, setup: &Setup, stop: f64, timing: i32) {
        FmiInstance::enter_initialization_mode(&mut self.instance, None, 0.0, Some(stop)).expect("initialisation");
        Common::set_integer(&mut self.instance, &[self.vr["input_timing"]], &[timing]).expect("input_timing");
        let (vrs, values): (Vec<u32>, Vec<f64>) = setup.reals.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_real(&mut self.instance, &vrs, &values).expect("fmi2SetReal of the parameters");
        Common::set_integer(&mut self.instance, &[self.vr["filter"]], &[setup.filter])
            .expect("fmi2SetInteger of filter");
        if let Some(substeps) = setup.substeps {
            Common::set_integer(&mut self.instance, &[self.vr["rk4_substeps"]], &[substeps])
                .expect("fmi2SetInteger of rk4_substeps");
        }
        Common::exit_initialization_mode(&mut self.instance).expect("fmi2ExitInitializationMode");
    }

    /// Sets the inputs at the current communication point.
    fn set_inputs(&mut self, z: &[f64]) {
        Common::set_real(&mut self.instance, &self.inputs, z).expect("fmi2SetReal of the inputs");
    }

    /// Sets the controls at the current communication point.
    fn set_controls(&mut self, u: &[f64]) {
        Common::set_real(&mut self.instance, &self.controls, u).expect("fmi2SetReal of the controls");
    }

    /// The outputs compared (`Setup::estimates`, then `nis`).
    fn read(&mut self) -> Vec<f64> {
        let mut out = vec![0.0; self.outputs.len()];
        Common::get_real(&mut self.instance, &self.outputs, &mut out).expect("fmi2GetReal");
        out
    }

    fn do_step(&mut self, t: f64, h: f64) {
        self.instance.do_step(t, h, true).unwrap_or_else(|e| panic!("fmi2DoStep({t}, {h}): {e}"));
    }

    /// A master's sample `k`: the inputs and controls of `t_k`, `fmi2DoStep(t_k, dt)`; the outputs after it.
    fn step(&mut self, k: usize, dt: f64, z: &[f64], u: &[f64]) -> Vec<f64> {
        self.set_inputs(z);
        self.set_controls(u);
        self.do_step(k as f64 * dt, dt);
        self.read()
    }
}

/// The FMU driven as a master drives it, sample by sample, against the
/// reference behind its own supervisor (see the module documentation).
fn outputs_equal_the_library_run_in_process(setup: &Setup) {
    let model = setup.model();
    let dt = setup.sample_time();
    let z = (setup.measurements)(setup, SAMPLES + 1, dt, 20240611);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.co_simulation.as_ref().map(|cs| cs.model_identifier.as_str()), Some(model));
    let mut fmu = Fmu::new(&import, setup, model);
    assert_eq!(Common::get_version(&fmu.instance), "2.0");
    assert_eq!(Common::get_types_platform(&fmu.instance), "default");
    fmu.initialise(setup, SAMPLES as f64 * dt);

    let mut reference = setup.reference_filter();
    let mut supervisor = (setup.supervisor)(setup);
    // The NIS of the latest update (a quantised step restores the belief, which keeps no innovation).
    let mut nis = reference.innovation().nis();
    for (k, zk) in z.iter().enumerate() {
        let t = k as f64 * dt;
        if k > 0 {
            // The read right after the step to t: the prediction from the measurements before t.
            reference.predict(&[], dt).unwrap();
            let after_step = fmu.read();
            let expected = setup.expected_outputs(reference.as_ref(), nis);
            assert_eq!(bits(&[after_step]), bits(&[expected]), "{model}: after the step to sample {k}");
        }
        fmu.set_inputs(zk);
        nis = supervisor.gate(reference.as_mut(), zk).unwrap().nis;
        // As a read before the commit shows them: this sample's outcomes, the
        // wiring verdicts of the last commit.
        let rows: Vec<i32> = supervisor.statuses().map(estimators::status_value).collect();
        supervisor.commit(|_| {});
        supervisor.scale_process_noise_of(reference.as_mut()).unwrap();
        let expected = setup.expected_outputs(reference.as_ref(), nis);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}: at sample {k}");
        // Each input's status is the supervisor's: its row's outcome, or
        // inconsistent where its wiring is named and it is kept.
        let mut statuses = vec![0; rows.len()];
        Common::get_integer(&mut fmu.instance, &fmu.statuses, &mut statuses).expect("fmi2GetInteger");
        assert_eq!(statuses, rows, "{model}: the input statuses at sample {k}");
        if k < SAMPLES {
            fmu.do_step(t, dt);
        }
    }

    // The counts and flags are the supervisor's. (These sums of sines are no
    // trajectory of the model: the filter may rightly find them inconsistent.)
    let missing = z.iter().flatten().filter(|v| v.is_nan()).count();
    let names = ["skipped_measurements", "rejected_measurements"];
    let mut counts = [0; 2];
    Common::get_integer(&mut fmu.instance, &names.map(|n| fmu.vr[n]), &mut counts).expect("fmi2GetInteger");
    assert_eq!(counts, [missing as i32, supervisor.rejected() as i32], "{model}: {names:?}");
    // A fault flag per input that has one (S4's intermittent marker has none).
    let flagged: Vec<(&str, usize)> = setup
        .descriptor
        .variables
        .iter()
        .filter_map(|v| if let Role::ChannelFault(row) = v.role { Some((&*v.name, row)) } else { None })
        .collect();
    let flags: Vec<&str> = ["filter_healthy"].into_iter().chain(flagged.iter().map(|(n, _)| *n)).collect();
    let vrs: Vec<u32> = flags.iter().map(|n| fmu.vr[*n]).collect();
    let mut got = vec![0; flags.len()];
    Common::get_boolean(&mut fmu.instance, &vrs, &mut got).expect("fmi2GetBoolean");
    let channels = flagged.iter().map(|(_, row)| supervisor.channels()[*row].faulty);
    let expected: Vec<i32> = [supervisor.healthy()].into_iter().chain(channels).map(i32::from).collect();
    assert_eq!(got, expected, "{model}: {flags:?}");
    let last = fmu.instance.last_successful_time().expect("fmi2GetRealStatus");
    assert!((last - SAMPLES as f64 * dt).abs() < 1e-9, "{model}: last successful time {last}");
    // A step past the stop time is refused (and the instance still answers).
    assert!(fmu.instance.do_step(SAMPLES as f64 * dt, dt, true).is_err(), "{model}: a step past the stop time");
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

#[test]
fn s1_outputs_equal_the_library_run_in_process() {
    outputs_equal_the_library_run_in_process(&Setup::s1());
}

/// S4 on telegrams with a spike, a slot slip, a resend, a dropout and markers: the
/// supervisor's stuck rows and quantised steps as the FMU runs them.
#[test]
fn s4_outputs_equal_the_library_run_in_process() {
    outputs_equal_the_library_run_in_process(&Setup::s4());
}

#[test]
fn s2_outputs_equal_the_library_run_in_process() {
    let setup = Setup::s2();
    // The FMU's default vehicle is the library's catalogue car, weight and all.
    assert_eq!(s2_vehicle(&setup), VerticalVehicle::zhai_passenger());
    outputs_equal_the_library_run_in_process(&setup);
}

#[test]
fn s3_outputs_equal_the_library_run_in_process() {
    let setup = Setup::s3();
    let defaults = Setup { reals: Vec::new(), ..Setup::s3() };
    // The FMU's default vehicle is the library's catalogue car, weight and all.
    assert_eq!(s3_vehicle(&defaults), RollVehicle::zhai_passenger());
    assert_ne!(s3_vehicle(&setup), RollVehicle::zhai_passenger());
    outputs_equal_the_library_run_in_process(&setup);
}

/// S5 driven as a master drives it, sample by sample: the measurements and the
/// controls of t_k set, read, step, read; against the library's SVD-CKF behind
/// its own supervisor, predicting with the controls of t_(k-1) and updating
/// with those of t_k held. The counts at the end are the supervisor's.
#[test]
fn s5_outputs_equal_the_library_run_in_process() {
    let setup = Setup::s5();
    assert_eq!(s5_airframe(&setup), Airframe::tactical_missile(), "the default airframe is the library's");
    let (model, dt) = (setup.model(), setup.sample_time());
    let samples = 600;
    let (z, u) = s5_flight(&setup, samples + 1, dt, 5);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let mut fmu = Fmu::new(&import, &setup, model);
    fmu.initialise(&setup, samples as f64 * dt);
    let mut reference = setup.reference_filter();
    let mut supervisor = default_supervisor(&setup);
    for k in 0..=samples {
        if k > 0 {
            reference.predict(&u[k - 1], dt).unwrap();
            let expected = setup.expected_outputs(reference.as_ref(), reference.innovation().nis());
            assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}: after the step to sample {k}");
        }
        fmu.set_inputs(&z[k]);
        fmu.set_controls(&u[k]);
        hold(reference.as_mut(), &u[k]);
        let nis = supervisor.gate(reference.as_mut(), &z[k]).unwrap().nis;
        supervisor.commit(|_| {});
        supervisor.scale_process_noise_of(reference.as_mut()).unwrap();
        let expected = setup.expected_outputs(reference.as_ref(), nis);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}: at sample {k}");
        if k < samples {
            fmu.do_step(k as f64 * dt, dt);
        }
    }
    // The deflections matter: an update holding the previous sample's would differ.
    let mut stale = setup.reference_filter();
    stale.predict(&u[0], dt).unwrap();
    let mut fresh = setup.reference_filter();
    fresh.restore(&stale.snapshot()).unwrap();
    hold(fresh.as_mut(), &u[1]);
    stale.update(&z[1]).unwrap();
    fresh.update(&z[1]).unwrap();
    assert_ne!(stale.mean().as_slice(), fresh.mean().as_slice(), "the controls of t enter the update at t");
    let names = ["skipped_measurements", "rejected_measurements"];
    let mut counts = [0; 2];
    Common::get_integer(&mut fmu.instance, &names.map(|n| fmu.vr[n]), &mut counts).expect("fmi2GetInteger");
    let missing = z.iter().flatten().filter(|v| v.is_nan()).count();
    assert_eq!(counts, [missing as i32, supervisor.rejected() as i32], "{model}: {names:?}");
    // The coefficients moved from the prior towards Table 1's (C_y^α: 1.2 × 9.2596 at the start).
    let mut cy_a = [0.0];
    Common::get_real(&mut fmu.instance, &[fmu.vr["Cy_a"]], &mut cy_a).expect("fmi2GetReal");
    assert!((cy_a[0] - 9.2596).abs() < 0.5 * (1.2 * 9.2596 - 9.2596), "Cy_a = {}", cy_a[0]);
    // A non-finite control is refused, changing nothing.
    let before = fmu.read();
    assert!(Common::set_real(&mut fmu.instance, &[fmu.controls[0]], &[f64::NAN]).is_err(), "a NaN control");
    let mut held = [0.0];
    Common::get_real(&mut fmu.instance, &[fmu.controls[0]], &mut held).expect("fmi2GetReal of a control");
    assert_eq!(held[0].to_bits(), u[samples][0].to_bits(), "the control kept");
    assert_eq!(bits(&[fmu.read()]), bits(&[before]), "the outputs kept");
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

/// A master stepping by `h` over `samples` sample times, setting the plant's
/// outputs (`signal`) at every communication point and reading before and
/// after each step; every read must equal the library filter run by the rules
/// of `fmu/src/timing.rs`:
/// * at a sample instant that is a communication point, the update with the
///   inputs there (read after them) — once;
/// * samples inside a step: prediction only;
/// * a read off the grid: the prediction from the last sample to that time,
///   with the process noise of that interval.
fn check_master(setup: &Setup, h: f64, samples: usize) {
    let (model, ts) = (setup.model(), setup.sample_time());
    let duration = samples as f64 * ts;
    let signal = |t: f64| (setup.signal)(setup, t);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let mut fmu = Fmu::new(&import, setup, &format!("master-{h}"));
    fmu.initialise(setup, duration);
    let mut reference = setup.reference_filter();
    let mut supervisor = (setup.supervisor)(setup);
    let scaled_states = supervisor.scaled_states().to_vec();
    let steps = (duration / h).round() as usize;
    let mut k = 0; // the reference's sample
    let on_grid = |t: f64| ((t / ts).round() * ts - t).abs() < 1e-9;
    // The NIS shown is that of the update the belief came from: the
    // supervisor's, which an undone re-acquisition takes from its rival.
    let expected_at = |reference: &dyn StateEstimator, nis: f64, t: f64, k: usize| -> Vec<f64> {
        let dt = t - k as f64 * ts;
        if dt.abs() < 1e-9 {
            return setup.expected_outputs(reference, nis);
        }
        let mut ahead = setup.reference_filter_over(dt);
        ahead.restore(&reference.snapshot()).unwrap();
        ahead.set_process_noise_scale(reference.noise().q_scale(), &scaled_states).unwrap();
        ahead.predict(&[], dt).unwrap();
        setup.expected_outputs(ahead.as_ref(), nis)
    };
    let mut nis = reference.innovation().nis();
    // The master's clock, as masters keep it and the FMU follows it: t += h.
    let mut t = 0.0;
    for j in 0..=steps {
        let z = signal(t);
        fmu.set_inputs(&z);
        if on_grid(t) {
            supervisor.gate(reference.as_mut(), &z).unwrap();
            supervisor.commit(|_| {});
            supervisor.scale_process_noise_of(reference.as_mut()).unwrap();
            nis = supervisor.pending().nis;
        }
        let expected = expected_at(reference.as_ref(), nis, t, k);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}, h {h}: read at t = {t}");
        if j == steps {
            break;
        }
        fmu.do_step(t, h);
        while ((k + 1) as f64 * ts) <= (t + h) + 1e-9 {
            reference.predict(&[], ts).unwrap();
            k += 1;
        }
        t += h;
        let expected = expected_at(reference.as_ref(), nis, t, k);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}, h {h}: read after the step to t = {t}");
    }
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

/// Communication steps of a fifth of the sample time and of two: 1 and 10 ms
/// at S1's 5 ms, 0.2 and 2 ms at S2's 1 ms, 4 and 40 ms at S4's 20 ms; 100 samples each.
fn communication_steps_shorter_and_longer_than_the_sample_time(setup: &Setup) {
    let ts = setup.sample_time();
    check_master(setup, ts / 5.0, 100);
    check_master(setup, 2.0 * ts, 100);
}

#[test]
fn s1_communication_steps_shorter_and_longer_than_the_sample_time() {
    communication_steps_shorter_and_longer_than_the_sample_time(&Setup::s1());
}

#[test]
fn s2_communication_steps_shorter_and_longer_than_the_sample_time() {
    communication_steps_shorter_and_longer_than_the_sample_time(&Setup::s2());
}

#[test]
fn s3_communication_steps_shorter_and_longer_than_the_sample_time() {
    communication_steps_shorter_and_longer_than_the_sample_time(&Setup::s3());
}

#[test]
fn s4_communication_steps_shorter_and_longer_than_the_sample_time() {
    communication_steps_shorter_and_longer_than_the_sample_time(&Setup::s4());
}

/// The measurements and controls of `n` samples for `setup` (controls only for S5).
fn flight_or_measurements(setup: &Setup, n: usize, dt: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    if setup.controls().is_empty() {
        ((setup.measurements)(setup, n, dt, seed), vec![Vec::new(); n])
    } else {
        s5_flight(setup, n, dt, seed)
    }
}

/// With `smoothing_lag` = 0.02 s (4 samples of S1 and S4, 20 of S2, S3 and S5), a
/// master's sample by sample (set the inputs of t, read, step, read): every
/// `<name>_smoothed`, `<name>_smoothed_std` and `smoothed_time` equals the
/// library's fixed-lag smoother behind the same supervisor (`SupervisedFilter::
/// smooth_with_lag`), bit for bit, at both reads; `smoothed_time` is the lag
/// before the time read once that much has passed; a saved state replays the
/// smoothed outputs bit for bit; with `smoothing_lag` 0 they are the estimates.
fn smoothed_outputs_equal_the_library_fixed_lag_smoother(setup: &Setup) {
    let (model, dt, samples, lag_time) = (setup.model(), setup.sample_time(), 300, 0.02);
    let lag = (lag_time / dt).round() as usize;
    let (z, u) = flight_or_measurements(setup, samples + 1, dt, 31);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let states = setup.descriptor.smoothed_states;
    let named = |suffix: &str| -> Vec<String> {
        states
            .iter()
            .map(|&i| {
                let estimate = setup.names(|r| r == Role::Estimate(i))[0];
                format!("{estimate}{suffix}")
            })
            .collect()
    };
    let mut smoothed_setup = Setup::same(setup);
    smoothed_setup.reals.push(("smoothing_lag", lag_time));
    let mut fmu = Fmu::new(&import, &smoothed_setup, model);
    fmu.initialise(&smoothed_setup, samples as f64 * dt);
    let vrs: Vec<u32> = named("_smoothed")
        .iter()
        .chain(&named("_smoothed_std"))
        .map(|n| fmu.vr[n.as_str()])
        .chain([fmu.vr["smoothed_time"]])
        .collect();
    let read = |fmu: &mut Fmu| {
        let mut out = vec![0.0; vrs.len()];
        Common::get_real(&mut fmu.instance, &vrs, &mut out).expect("fmi2GetReal of the smoothed outputs");
        out
    };
    let mut reference = SupervisedFilter::new(setup.reference_filter(), (setup.supervisor)(setup)).unwrap();
    reference.smooth_with_lag(states, lag).unwrap();
    let expected = |reference: &mut SupervisedFilter| {
        let e = reference.lagged_estimate().unwrap();
        e.means
            .iter()
            .copied()
            .chain(e.variances.iter().map(|v| v.max(0.0).sqrt()))
            .chain([e.time])
            .collect::<Vec<f64>>()
    };
    let mut saved = None;
    let mut after_save = Vec::new();
    for k in 0..=samples {
        let t = k as f64 * dt;
        if k > 0 {
            reference.predict(&u[k - 1], dt).unwrap();
            let got = read(&mut fmu);
            assert_eq!(
                bits(std::slice::from_ref(&got)),
                bits(&[expected(&mut reference)]),
                "{model}: after the step to sample {k}"
            );
            if saved.is_some() {
                after_save.push(got);
            }
        }
        fmu.set_inputs(&z[k]);
        fmu.set_controls(&u[k]);
        reference.hold_input(&u[k]).unwrap();
        reference.update(&z[k], t).unwrap();
        let got = read(&mut fmu);
        assert_eq!(bits(std::slice::from_ref(&got)), bits(&[expected(&mut reference)]), "{model}: at sample {k}");
        let time = *got.last().unwrap();
        let target = k.saturating_sub(lag) as f64 * dt;
        assert!((time - target).abs() < 1e-9 * (1.0 + t), "{model}: smoothed_time {time} at sample {k}, not {target}");
        if saved.is_some() {
            after_save.push(got);
        }
        if k < samples {
            fmu.do_step(t, dt);
        }
        if k == samples / 2 {
            saved = Some(fmu.instance.get_fmu_state().expect("fmi2GetFMUstate"));
        }
    }
    // Back to the saved state: the same smoothed outputs, bit for bit.
    fmu.instance.set_fmu_state(saved.as_ref().unwrap()).ok().expect("fmi2SetFMUstate");
    let mut replayed = Vec::new();
    for k in samples / 2 + 1..=samples {
        replayed.push(read(&mut fmu));
        fmu.set_inputs(&z[k]);
        fmu.set_controls(&u[k]);
        replayed.push(read(&mut fmu));
        if k < samples {
            fmu.do_step(k as f64 * dt, dt);
        }
    }
    assert_eq!(bits(&replayed), bits(&after_save), "{model}: the smoothed outputs after fmi2SetFMUstate");
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");

    // Without a lag the smoothed outputs are the estimates, of the time read.
    let mut plain = Fmu::new(&import, setup, "plain");
    plain.initialise(setup, samples as f64 * dt);
    let estimates: Vec<u32> = states
        .iter()
        .map(|&i| plain.vr[setup.names(|r| r == Role::Estimate(i))[0]])
        .chain(states.iter().map(|&i| plain.vr[setup.names(|r| r == Role::EstimateStd(i))[0]]))
        .collect();
    for k in 0..5 {
        plain.set_inputs(&z[k]);
        plain.set_controls(&u[k]);
        plain.do_step(k as f64 * dt, dt);
        let mut want = vec![0.0; estimates.len()];
        Common::get_real(&mut plain.instance, &estimates, &mut want).expect("fmi2GetReal");
        let got = read(&mut plain);
        let count = want.len();
        assert_eq!(bits(&[got[..count].to_vec()]), bits(&[want]), "{model}: lag 0 at step {k}");
        assert!((got[count] - (k + 1) as f64 * dt).abs() < 1e-12, "{model}: smoothed_time with lag 0");
    }
}

#[test]
fn s1_smoothed_outputs_equal_the_library_fixed_lag_smoother() {
    smoothed_outputs_equal_the_library_fixed_lag_smoother(&Setup::s1());
}

#[test]
fn s2_smoothed_outputs_equal_the_library_fixed_lag_smoother() {
    smoothed_outputs_equal_the_library_fixed_lag_smoother(&Setup::s2());
}

#[test]
fn s3_smoothed_outputs_equal_the_library_fixed_lag_smoother() {
    smoothed_outputs_equal_the_library_fixed_lag_smoother(&Setup::s3());
}

#[test]
fn s4_smoothed_outputs_equal_the_library_fixed_lag_smoother() {
    smoothed_outputs_equal_the_library_fixed_lag_smoother(&Setup::s4());
}

#[test]
fn s5_smoothed_outputs_equal_the_library_fixed_lag_smoother() {
    smoothed_outputs_equal_the_library_fixed_lag_smoother(&Setup::s5());
}

/// 400 samples, a saved state, 300 more; the state restored and serialised
/// replays those 300 bit for bit. S5 flies its missile with controls, under
/// `input_timing` `timing`.
fn fmu_state_get_set_serialize_through_the_importer(setup: &Setup, timing: i32) {
    let model = setup.model();
    let dt = setup.sample_time();
    let (first, second) = (400, 300);
    let (z, u) = if setup.controls().is_empty() {
        ((setup.measurements)(setup, first + second, dt, 77), vec![Vec::new(); first + second])
    } else {
        s5_flight(setup, first + second, dt, 77)
    };
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let mut a = Fmu::new(&import, setup, "a");
    a.initialise_with_timing(setup, 100.0, timing);
    for k in 0..first {
        a.step(k, dt, &z[k], &u[k]);
    }
    let saved = a.instance.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    assert_eq!(a.instance.serialize_fmu_state(&saved).expect("again"), bytes, "serialising is deterministic");
    let run =
        |fmu: &mut Fmu| -> Vec<Vec<f64>> { (first..first + second).map(|k| fmu.step(k, dt, &z[k], &u[k])).collect() };
    let original = run(&mut a);

    // Back in the same instance: the same outputs, bit for bit.
    a.instance.set_fmu_state(&saved).ok().expect("fmi2SetFMUstate");
    assert_eq!(bits(&run(&mut a)), bits(&original), "{model}: replay after fmi2SetFMUstate");

    // fmi2GetFMUstate into an existing state overwrites it.
    a.instance.update_fmu_state(&saved).ok().expect("fmi2GetFMUstate into an existing state");
    let later = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    assert_ne!(later, bytes, "{model}: the updated state is the later one");
    let again = a.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    a.instance.set_fmu_state(&again).ok().expect("fmi2SetFMUstate of the deserialised state");
    assert_eq!(bits(&run(&mut a)), bits(&original), "{model}: replay after deserialising in the same instance");

    // A fresh instance, never initialised, restores the serialised bytes.
    let mut b = Fmu::new(&import, setup, "b");
    let restored = b.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    b.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(bits(&run(&mut b)), bits(&original), "{model}: replay in a fresh instance");

    // Garbage, truncated or foreign bytes are refused.
    assert!(b.instance.deserialize_fmu_state(&vec![0x5a; bytes.len()]).is_err(), "garbage of the right length");
    assert!(b.instance.deserialize_fmu_state(&bytes[..bytes.len() - 1]).is_err(), "truncated");
    let mut other = bytes.clone();
    other[20] ^= 0x01; // inside the GUID
    assert!(b.instance.deserialize_fmu_state(&other).is_err(), "another FMU's GUID");
    Common::terminate(&mut a.instance).expect("fmi2Terminate a");
    Common::terminate(&mut b.instance).expect("fmi2Terminate b");
}

#[test]
fn s1_fmu_state_get_set_serialize_through_the_importer() {
    fmu_state_get_set_serialize_through_the_importer(&Setup::s1(), 1);
}

#[test]
fn s2_fmu_state_get_set_serialize_through_the_importer() {
    fmu_state_get_set_serialize_through_the_importer(&Setup::s2(), 1);
}

#[test]
fn s3_fmu_state_get_set_serialize_through_the_importer() {
    fmu_state_get_set_serialize_through_the_importer(&Setup::s3(), 1);
}

#[test]
fn s4_fmu_state_get_set_serialize_through_the_importer() {
    for timing in [1, 2] {
        fmu_state_get_set_serialize_through_the_importer(&Setup::s4(), timing);
    }
}

#[test]
fn s5_fmu_state_get_set_serialize_through_the_importer() {
    // step_end saves the controls of the FMU's time apart from the inputs the master sets next.
    for timing in [1, 2] {
        fmu_state_get_set_serialize_through_the_importer(&Setup::s5(), timing);
    }
}

fn bits(rows: &[Vec<f64>]) -> Vec<Vec<u64>> {
    rows.iter().map(|r| r.iter().map(|x| x.to_bits()).collect()).collect()
}

/// The `InputStatus` values of the `<input>_status` outputs.
const USED: i32 = 1;
const REJECTED: i32 = 2;
const MISSING: i32 = 3;
const STUCK: i32 = 4;

/// S4 on `s4_telegrams` (a spike on the first channel at sample 300, the second resent
/// at 700–703, the fourth not received at 800–805, a marker every 50th): each input's
/// `<input>_status` is what became of it in the update the read shows. After the
/// inputs of t_k (the feedthrough update) and after the step from t_k (the same update,
/// the latest) the first channel reads `rejected` at exactly the spike and `used`
/// around it while its fault flag stays false; the second `stuck` on the repeats, the
/// fourth `missing` on the NaN, the marker `used` only where one passes. Before any
/// update every status is `missing`; a read between samples (a prediction) and a
/// restored FMU state show the latest update's.
#[test]
fn s4_input_status_says_what_became_of_each_telegram() {
    let setup = Setup::s4();
    let (model, dt) = (setup.model(), setup.sample_time());
    let samples = 900;
    let z = s4_telegrams(&setup, samples + 1, dt, 20240611);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let mut fmu = Fmu::new(&import, &setup, model);
    fmu.initialise(&setup, 100.0);
    let inputs = setup.inputs();
    let statuses = fmu.statuses.clone();
    let fault = fmu.vr["P_head_left_fault"];
    let read_statuses = |fmu: &mut Fmu| {
        let mut got = vec![0; statuses.len()];
        Common::get_integer(&mut fmu.instance, &statuses, &mut got).expect("fmi2GetInteger of the statuses");
        got
    };
    assert_eq!(read_statuses(&mut fmu), vec![MISSING; inputs.len()], "before any update");

    let expected = |k: usize| -> Vec<i32> {
        let head_left = if k == 300 { REJECTED } else { USED };
        let head_right = if (700..704).contains(&k) { STUCK } else { USED };
        let tail_right = if (800..806).contains(&k) { MISSING } else { USED };
        let marker = if k.is_multiple_of(50) { USED } else { MISSING };
        vec![head_left, head_right, USED, tail_right, marker]
    };
    // The slot slip of the third channel from 500 on fails the gate until it is taken as a step.
    let checked = |k: usize| if (500..510).contains(&k) { [0, 1, 3, 4].as_slice() } else { [0, 1, 2, 3, 4].as_slice() };
    let mut saved = None;
    for (k, zk) in z[..samples].iter().enumerate() {
        fmu.set_inputs(zk);
        let at = read_statuses(&mut fmu);
        fmu.do_step(k as f64 * dt, dt);
        let after = read_statuses(&mut fmu);
        for &c in checked(k) {
            assert_eq!(at[c], expected(k)[c], "{} after the inputs of sample {k}", inputs[c]);
            assert_eq!(after[c], expected(k)[c], "{} after the step from sample {k}", inputs[c]);
        }
        if (299..=301).contains(&k) {
            let mut flag = [1];
            Common::get_boolean(&mut fmu.instance, &[fault], &mut flag).expect("fmi2GetBoolean");
            assert_eq!(flag, [0], "one spike at sample {k} makes no fault");
        }
        if k == 300 {
            saved = Some(fmu.instance.get_fmu_state().expect("fmi2GetFMUstate"));
        }
    }

    // Half a sample on from the update at the last sample: a prediction, which shows
    // that update's statuses (a step from a sample without new inputs would update
    // with the held ones, bit for bit repeats: stuck).
    fmu.set_inputs(&z[samples]);
    fmu.do_step(samples as f64 * dt, 0.5 * dt);
    assert_eq!(read_statuses(&mut fmu), expected(samples), "between samples");

    // The state saved after the spike's step, restored here and in a fresh instance.
    let saved = saved.expect("the state after sample 300");
    let bytes = fmu.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    fmu.instance.set_fmu_state(&saved).ok().expect("fmi2SetFMUstate");
    assert_eq!(read_statuses(&mut fmu), expected(300), "restored");
    let mut fresh = Fmu::new(&import, &setup, "fresh");
    let restored = fresh.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    fresh.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(read_statuses(&mut fresh), expected(300), "restored in a fresh instance");
}
