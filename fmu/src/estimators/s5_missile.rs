//! The S5 missile estimator: the ten force coefficients of a tactical missile (eq. (4) of
//! `[Jiang2024]`) identified online with its rigid-body motion from twelve flight
//! measurements, the rudder deflections known (study S5, `docs/studies/s5.md`). The
//! estimation model is the library's `Missile6Dof`: 20 states, the motion
//! `Vx, Vy, Vz, φ, ψ, γ, h, ωx, ωy, ωz` and the coefficients as random walks; its known
//! input `u = (δx, δy, δz)` enters both the motion and the overloads, so the deflections
//! are controls (`Role::Control`), held from the communication point they are set at.
//!
//! Parameters: the airframe (`Airframe::tactical_missile()` by default), the prior of all 20
//! states, and the noise (tunable), with the defaults of the study's tuning
//! (`studies/src/s5/study.rs`, `Tuning::new(1.0)`): the FMU cannot depend on the study,
//! so the numbers are copied here.

use estimator::models::{Airframe, Missile6Dof, MomentModel};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, StateEstimator, SupervisorSettings, UnscentedParams,
};

use super::{bound_from_prior, no_derived_outputs, no_quantized_steps, DefaultExperiment, Descriptor};
use crate::variables::{Parameters, Role, Variable};

/// The measurements, in the model's order: name, unit, description, fault flag and its
/// description (literals: a variable's texts live as long as the program).
const INPUTS: [(&str, &str, &str, &str, &str); 12] = [
    ("omega_x", "rad/s", "measured roll rate (body x) (NaN: missing)", "omega_x_fault", FAULT),
    ("omega_y", "rad/s", "measured yaw rate (body y, up) (NaN: missing)", "omega_y_fault", FAULT),
    ("omega_z", "rad/s", "measured pitch rate (body z, right) (NaN: missing)", "omega_z_fault", FAULT),
    (
        "Nx",
        "1",
        "measured overload along body x, in g: the aerodynamic force over m·g (NaN: missing)",
        "Nx_fault",
        FAULT,
    ),
    ("Ny", "1", "measured overload along body y, in g (NaN: missing)", "Ny_fault", FAULT),
    ("Nz", "1", "measured overload along body z, in g (NaN: missing)", "Nz_fault", FAULT),
    ("phi", "rad", "measured pitch angle (NaN: missing)", "phi_fault", FAULT),
    ("psi", "rad", "measured yaw angle (NaN: missing)", "psi_fault", FAULT),
    ("gamma", "rad", "measured roll angle (NaN: missing)", "gamma_fault", FAULT),
    ("h", "m", "measured altitude (NaN: missing)", "h_fault", FAULT),
    ("alpha", "rad", "measured angle of attack atan2(-Vy, Vx) (NaN: missing)", "alpha_fault", FAULT),
    ("beta", "rad", "measured sideslip asin(Vz/V) (NaN: missing)", "beta_fault", FAULT),
];

const FAULT: &str = "the input is faulty: rejected by the gate, stuck or missing for fault_after samples in a row";

/// The controls, in the order of the model's `u`.
const CONTROLS: [(&str, &str); 3] = [
    ("delta_x", "roll rudder deflection, held from the communication point it is set at (never missing)"),
    ("delta_y", "pitch rudder deflection (drives Cy and the pitch moment), held likewise"),
    ("delta_z", "yaw rudder deflection (drives Cz and the yaw moment), held likewise"),
];

/// The states: output, its deviation, unit, prior-mean and prior-std parameters, and the
/// outputs' descriptions. The motion outputs carry `est_`: the inputs have their names.
const STATES: [(&str, &str, &str, &str, &str, &str); 20] = [
    ("est_Vx", "est_Vx_std", "m/s", "prior_Vx", "prior_Vx_std", "estimated body velocity along x"),
    ("est_Vy", "est_Vy_std", "m/s", "prior_Vy", "prior_Vy_std", "estimated body velocity along y (up)"),
    ("est_Vz", "est_Vz_std", "m/s", "prior_Vz", "prior_Vz_std", "estimated body velocity along z (right)"),
    ("est_phi", "est_phi_std", "rad", "prior_phi", "prior_phi_std", "estimated pitch angle"),
    ("est_psi", "est_psi_std", "rad", "prior_psi", "prior_psi_std", "estimated yaw angle"),
    ("est_gamma", "est_gamma_std", "rad", "prior_gamma", "prior_gamma_std", "estimated roll angle"),
    ("est_h", "est_h_std", "m", "prior_h", "prior_h_std", "estimated altitude"),
    ("est_omega_x", "est_omega_x_std", "rad/s", "prior_omega_x", "prior_omega_x_std", "estimated roll rate"),
    ("est_omega_y", "est_omega_y_std", "rad/s", "prior_omega_y", "prior_omega_y_std", "estimated yaw rate"),
    ("est_omega_z", "est_omega_z_std", "rad/s", "prior_omega_z", "prior_omega_z_std", "estimated pitch rate"),
    ("Cx0", "Cx0_std", "1", "prior_Cx0", "prior_Cx0_std", "estimated axial force coefficient at zero angles"),
    ("Cx_a", "Cx_a_std", "1", "prior_Cx_a", "prior_Cx_a_std", "estimated axial force derivative in alpha"),
    ("Cx_b", "Cx_b_std", "1", "prior_Cx_b", "prior_Cx_b_std", "estimated axial force derivative in beta"),
    ("Cx_d", "Cx_d_std", "1", "prior_Cx_d", "prior_Cx_d_std", "estimated axial force derivative in delta_x"),
    ("Cy0", "Cy0_std", "1", "prior_Cy0", "prior_Cy0_std", "estimated normal force coefficient at zero angles"),
    ("Cy_a", "Cy_a_std", "1", "prior_Cy_a", "prior_Cy_a_std", "estimated normal force derivative in alpha"),
    ("Cy_d", "Cy_d_std", "1", "prior_Cy_d", "prior_Cy_d_std", "estimated normal force derivative in delta_y"),
    ("Cz0", "Cz0_std", "1", "prior_Cz0", "prior_Cz0_std", "estimated lateral force coefficient at zero angles"),
    ("Cz_b", "Cz_b_std", "1", "prior_Cz_b", "prior_Cz_b_std", "estimated lateral force derivative in beta"),
    ("Cz_d", "Cz_d_std", "1", "prior_Cz_d", "prior_Cz_d_std", "estimated lateral force derivative in delta_z"),
];

/// The true coefficients before the change (Table 1 of the seed): the prior is 1.2 times
/// them, as a wind-tunnel estimate 20 % off.
const TABLE_1: [f64; 10] = [-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229];

/// The default prior of each coefficient (the study's tuning): its Table 1 value times
/// this, with a std of this percentage of its magnitude, and at least the floor. The
/// documentation states the rule; a test checks it states these numbers.
const PRIOR_COEFFICIENT_FACTOR: f64 = 1.2;
const PRIOR_COEFFICIENT_STD_PERCENT: f64 = 30.0;
const PRIOR_COEFFICIENT_STD_FLOOR: f64 = 0.02;

/// The prior std of the motion: the navigation system at launch.
const MOTION_PRIOR_STD: [f64; 10] = [5.0, 5.0, 5.0, 0.01, 0.01, 0.01, 10.0, 0.01, 0.01, 0.01];

/// The sensors' noise parameters, in input order: name, unit, default (`SENSOR_STD`).
const SENSOR_STD: [(&str, &str, f64); 12] = [
    ("r_omega_x_std", "rad/s", 1e-3),
    ("r_omega_y_std", "rad/s", 1e-3),
    ("r_omega_z_std", "rad/s", 1e-3),
    ("r_Nx_std", "1", 1e-3),
    ("r_Ny_std", "1", 1e-3),
    ("r_Nz_std", "1", 1e-3),
    ("r_phi_std", "rad", 1e-3),
    ("r_psi_std", "rad", 1e-3),
    ("r_gamma_std", "rad", 1e-3),
    ("r_h_std", "m", 1.0),
    ("r_alpha_std", "rad", 2e-3),
    ("r_beta_std", "rad", 2e-3),
];

/// The moment coefficients (`MomentModel`, in its field order): parameter and description.
const MOMENTS: [(&str, &str); 8] = [
    ("m_x_delta", "roll moment coefficient per rad of delta_x"),
    ("m_x_omega", "roll damping: m_x per unit of omega_x·L/V"),
    ("m_y_beta", "yaw stiffness: m_y per rad of beta"),
    ("m_y_delta", "yaw moment coefficient per rad of delta_z"),
    ("m_y_omega", "yaw damping: m_y per unit of omega_y·L/V"),
    ("m_z_alpha", "pitch stiffness: m_z per rad of alpha"),
    ("m_z_delta", "pitch moment coefficient per rad of delta_y"),
    ("m_z_omega", "pitch damping: m_z per unit of omega_z·L/V"),
];

/// The start of the flight (`docs/studies/s5.md`): body velocity (1000, 10, 10) m/s,
/// attitude (15°, 3°, 3°), rates 3°/s each, at 10 km.
fn start() -> [f64; 10] {
    let deg = f64::to_radians;
    [1000.0, 10.0, 10.0, deg(15.0), deg(3.0), deg(3.0), 10_000.0, deg(3.0), deg(3.0), deg(3.0)]
}

pub(super) fn descriptor() -> Descriptor {
    let mut v = Vec::new();
    for (row, (name, unit, description, _, _)) in INPUTS.into_iter().enumerate() {
        v.push(Variable::measurement(name, unit, row, description));
    }
    for (j, (name, description)) in CONTROLS.into_iter().enumerate() {
        v.push(Variable::control(name, "rad", j, description));
    }
    for (row, (_, _, _, flag, description)) in INPUTS.into_iter().enumerate() {
        v.push(Variable::flag(flag, Role::ChannelFault(row), description));
    }
    // The coefficients first: they are what the study identifies.
    for i in (Missile6Dof::COEFFICIENTS..20).chain(0..Missile6Dof::COEFFICIENTS) {
        let (name, std, unit, _, _, description) = STATES[i];
        v.push(Variable::output(name, unit, Role::Estimate(i), description));
        v.push(Variable::output(std, unit, Role::EstimateStd(i), "standard deviation of the estimate"));
    }
    let positive = |var: Variable| var.bounded(Some(0.0), None);
    let airframe = Airframe::tactical_missile();
    let m = airframe.moments;
    v.extend([
        positive(Variable::parameter("mass", "kg", airframe.mass, "missile mass")),
        positive(Variable::parameter("area", "m2", airframe.area, "reference area S")),
        positive(Variable::parameter("length", "m", airframe.length, "reference length L")),
        positive(Variable::parameter("inertia_x", "kg.m2", airframe.inertia[0], "moment of inertia about x")),
        positive(Variable::parameter("inertia_y", "kg.m2", airframe.inertia[1], "moment of inertia about y")),
        positive(Variable::parameter("inertia_z", "kg.m2", airframe.inertia[2], "moment of inertia about z")),
    ]);
    let moments = [
        m.roll_control,
        m.roll_damping,
        m.yaw_stiffness,
        m.yaw_control,
        m.yaw_damping,
        m.pitch_stiffness,
        m.pitch_control,
        m.pitch_damping,
    ];
    for ((name, description), value) in MOMENTS.into_iter().zip(moments) {
        v.push(Variable::parameter(name, "1", value, description));
    }
    v.push(positive(Variable::parameter("gravity", "m/s2", airframe.gravity, "gravity (flat, non-rotating Earth)")));
    v.push(Variable::integer_parameter("rk4_substeps", 1, (1, 1000), "RK4 steps per filter sample"));
    let start = start();
    for (i, &(_, _, unit, mean, std, _)) in STATES.iter().enumerate() {
        let (value, deviation) = if i < Missile6Dof::COEFFICIENTS {
            (start[i], MOTION_PRIOR_STD[i])
        } else {
            let c = TABLE_1[i - Missile6Dof::COEFFICIENTS];
            let std = PRIOR_COEFFICIENT_STD_PERCENT / 100.0 * c.abs();
            (PRIOR_COEFFICIENT_FACTOR * c, std.max(PRIOR_COEFFICIENT_STD_FLOOR))
        };
        v.push(Variable::parameter(mean, unit, value, "prior mean of the state"));
        v.push(positive(Variable::parameter(std, unit, deviation, "prior standard deviation of the state")));
    }
    let non_negative = |var: Variable| var.bounded(Some(0.0), None);
    v.extend([
        non_negative(Variable::tunable("q_velocity_std", "m/s", 1e-3, "process noise std per sample of Vx, Vy, Vz")),
        non_negative(Variable::tunable("q_angle_std", "rad", 1e-6, "process noise std per sample of phi, psi, gamma")),
        non_negative(Variable::tunable("q_altitude_std", "m", 1e-3, "process noise std per sample of h")),
        non_negative(Variable::tunable(
            "q_rate_std",
            "rad/s",
            1e-6,
            "process noise std per sample of omega_x, omega_y, omega_z",
        )),
        non_negative(Variable::tunable(
            "q_coefficient_relative_std",
            "1",
            5e-5,
            "random-walk std per sample of each coefficient, times max(|its prior mean|, 0.05)",
        )),
    ]);
    for (name, unit, value) in SENSOR_STD {
        v.push(non_negative(Variable::tunable(name, unit, value, "noise std of the sensor of that input")));
    }
    Descriptor {
        model_identifier: "kalfmu_s5_missile",
        model_name: "kalfmu S5 missile force coefficients (6-DOF, 20 states)",
        description: "Identifies a tactical missile's ten force coefficients and its motion from rates, overloads, attitude, altitude and air angles, the rudder deflections known",
        documentation: "<p>Study S5: the ten force coefficients of eq. (4) (C_x = Cx0 + Cx_a·α + Cx_b·β + Cx_d·δx, \
         C_y = Cy0 + Cy_a·α + Cy_d·δy, C_z = Cz0 + Cz_b·β + Cz_d·δz) identified online with an SVD-CKF, with the \
         rigid-body motion, from the twelve measurements of eq. (2) every {sample_time}: the body rates, the \
         overloads (the aerodynamic force over m·g, as accelerometers read it), the attitude (pitch φ, yaw ψ, roll \
         γ), the altitude and the air angles. Body axes x forward, y up, z right; the conventions are those of docs/studies/s5.md. \
         The coefficients are random walks; a change is caught by the supervisor's re-acquisition.</p>\
         <p>The rudder deflections delta_x, delta_y, delta_z are known inputs (controls) of the model: they drive the \
         motion and the overloads. The controls set at communication point t are the deflections held over [t, t+h), \
         as a control computer outputs them; they enter the update at t (the overloads of t depend on them) and the \
         prediction from it, through every sample inside a longer step (see Time below). A control is never missing: \
         a NaN or infinite value is refused by fmi2SetReal with fmi2Error, the previous value kept.</p>\
         <p>Defaults: the airframe of Airframe::tactical_missile() ({mass}, {area}, {length}, the project's \
         inertias and moment model); the study's tuning: the prior motion from the launch (velocities within \
         {prior_Vx_std}, {prior_Vy_std}, {prior_Vz_std}, angles within {prior_phi_std}, {prior_psi_std}, \
         {prior_gamma_std}, altitude within {prior_h_std}), the prior coefficients 1.2 times Table 1 with a std of \
         30 % (0.02 at least), motion process noise small (the model is the truth's up to the integration step), \
         coefficient random walks of {q_coefficient_relative_std} of their magnitude per sample, the sensors' noise \
         of docs/studies/s5.md.</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 20.0, step: 0.005 },
        build_filter: build,
        build_noise: noise,
        default_filter: FilterKind::SvdCkf,
        supervision: SupervisorSettings { wiring_sigmas: 8.0, ..SupervisorSettings::default() },
        derive: no_derived_outputs,
        build_steps: no_quantized_steps,
        unknown_inputs: &Missile6Dof::UNKNOWN_INPUTS,
        plausible_bound: bound_from_prior,
        smoothed_states: &Missile6Dof::UNKNOWN_INPUTS,
        guid: String::new(),
    }
    .finish()
}

fn airframe(p: &Parameters) -> Result<Airframe, String> {
    let moment = |i: usize| p.finite(MOMENTS[i].0);
    Ok(Airframe {
        mass: p.positive("mass")?,
        area: p.positive("area")?,
        length: p.positive("length")?,
        inertia: [p.positive("inertia_x")?, p.positive("inertia_y")?, p.positive("inertia_z")?],
        moments: MomentModel {
            roll_control: moment(0)?,
            roll_damping: moment(1)?,
            yaw_stiffness: moment(2)?,
            yaw_control: moment(3)?,
            yaw_damping: moment(4)?,
            pitch_stiffness: moment(5)?,
            pitch_control: moment(6)?,
            pitch_damping: moment(7)?,
        },
        gravity: p.positive("gravity")?,
    })
}

fn build(
    p: &Parameters,
    kind: FilterKind,
    ukf: UnscentedParams,
    noise: Noise,
) -> Result<Box<dyn StateEstimator>, String> {
    let airframe = airframe(p)?;
    let substeps = p.positive("rk4_substeps")? as usize;
    let mean: Vec<f64> = STATES.iter().map(|s| p.finite(s.3)).collect::<Result<_, _>>()?;
    let variances: Vec<f64> = STATES.iter().map(|s| p.non_negative(s.4).map(|x| x * x)).collect::<Result<_, _>>()?;
    let prior = Gaussian::diagonal(&mean, &variances);
    let model = Discretized::rk4(Missile6Dof { airframe }, substeps);
    build_filter(kind, model, noise, &prior, ukf).map_err(|e| e.to_string())
}

/// `Q` over `dt`: every per-sample variance scales with `dt / sample_time` (white noise
/// on the motion, random walks of the coefficients); `R` from the sensors' noise.
fn noise(p: &Parameters, dt: f64) -> Result<Noise, String> {
    let fraction = dt / p.positive("sample_time")?;
    let per_sample = |name: &str| p.non_negative(name).map(|s| s * s * fraction);
    let (v, angle, h, rate) = (
        per_sample("q_velocity_std")?,
        per_sample("q_angle_std")?,
        per_sample("q_altitude_std")?,
        per_sample("q_rate_std")?,
    );
    let mut q = vec![v, v, v, angle, angle, angle, h, rate, rate, rate];
    let relative = p.non_negative("q_coefficient_relative_std")?;
    for s in &STATES[Missile6Dof::COEFFICIENTS..] {
        let std = relative * p.finite(s.3)?.abs().max(0.05);
        q.push(std * std * fraction);
    }
    let r: Vec<f64> = SENSOR_STD.iter().map(|s| p.non_negative(s.0).map(|x| x * x)).collect::<Result<_, _>>()?;
    Noise::diagonal(&q, &r).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_documentation_states_the_rule_of_the_default_coefficient_priors() {
        let rule = format!(
            "{PRIOR_COEFFICIENT_FACTOR} times Table 1 with a std of {PRIOR_COEFFICIENT_STD_PERCENT} % \
             ({PRIOR_COEFFICIENT_STD_FLOOR} at least)"
        );
        let documentation = descriptor().documentation.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(documentation.contains(&rule), "the documentation does not say: {rule}");
    }
}
