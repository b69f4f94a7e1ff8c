//! The S3 wheel–rail force estimator: the eight vertical wheel–rail forces, left and right
//! of each wheelset, from the vertical accelerations of the eight axle boxes, of the bogie
//! frames above them and of the car body above the secondary springs (and, if fitted, the
//! eight primary deflections), study S3 (eq. (26) of [Chen2025]). The estimation model is
//! the library's `WheelRailRoll`: the whole car in bounce, pitch and roll (17 DOF), 42
//! states, the forces as random walks or, with `force_return_rate`, Gauss–Markov processes
//! returning to the static wheel load. No track: the wheels are driven by the forces alone.
//!
//! Parameters: the vehicle as the user has it, and the static wheel load from a weighbridge;
//! the filter set-up as S2's (the forces' noise as an intensity); the sensors' noise
//! (tunable). Outputs beyond the forces: per wheelset the sum and the difference of its two
//! forces with their σ from the covariance.

use estimator::models::{PiecewiseLinear, RollVehicle, WheelRailRoll};
use estimator::{build_filter, Discretized, FilterKind, Noise, StateEstimator, SupervisorSettings, UnscentedParams};

use super::wheel_rail::Layout;
use super::{no_quantized_steps, DefaultExperiment, Descriptor, MAX_DERIVED};
use crate::timing::Reading;
use crate::variables::{Parameters, Role, Variable};

/// The default return rate of the forces to the static wheel load (1/s), and the default
/// intensity of their driving noise (N²/s): the study's tuning (`studies::s3::study`).
const FORCE_RETURN_RATE: f64 = 5.0;
const FORCE_NOISE_INTENSITY: f64 = 1e9;
/// The default error of the model in a primary deflection (m): the study's
/// (`studies::s3::study`), chosen on one seed of its truth.
const DEFLECTION_MODEL_ERROR: f64 = 3e-4;

/// One measurement input's variables (literals: a variable's texts live as long as the
/// program, and a table is built per instance).
struct Input {
    /// The input, `WheelRailRoll::MEASUREMENT_NAMES` in row order.
    name: &'static str,
    /// Its description.
    description: &'static str,
    /// Its fault flag.
    fault: &'static str,
    /// Its sensor noise parameter.
    sensor_std: &'static str,
}

/// The measurements, in row order: the 20 accelerations (`WheelRailRoll::ACCELERATIONS`),
/// then the eight primary deflections (`WheelRailRoll::DEFLECTIONS`).
const INPUTS: [Input; 28] = [
    Input {
        name: "a_ab_L1",
        description: "measured vertical acceleration (up) of the left axle box of wheelset 1 (front) (NaN: missing)",
        fault: "a_ab_L1_fault",
        sensor_std: "r_a_ab_L1_std",
    },
    Input {
        name: "a_ab_R1",
        description: "measured vertical acceleration (up) of the right axle box of wheelset 1 (front) (NaN: missing)",
        fault: "a_ab_R1_fault",
        sensor_std: "r_a_ab_R1_std",
    },
    Input {
        name: "a_ab_L2",
        description: "measured vertical acceleration (up) of the left axle box of wheelset 2 (NaN: missing)",
        fault: "a_ab_L2_fault",
        sensor_std: "r_a_ab_L2_std",
    },
    Input {
        name: "a_ab_R2",
        description: "measured vertical acceleration (up) of the right axle box of wheelset 2 (NaN: missing)",
        fault: "a_ab_R2_fault",
        sensor_std: "r_a_ab_R2_std",
    },
    Input {
        name: "a_ab_L3",
        description: "measured vertical acceleration (up) of the left axle box of wheelset 3 (NaN: missing)",
        fault: "a_ab_L3_fault",
        sensor_std: "r_a_ab_L3_std",
    },
    Input {
        name: "a_ab_R3",
        description: "measured vertical acceleration (up) of the right axle box of wheelset 3 (NaN: missing)",
        fault: "a_ab_R3_fault",
        sensor_std: "r_a_ab_R3_std",
    },
    Input {
        name: "a_ab_L4",
        description: "measured vertical acceleration (up) of the left axle box of wheelset 4 (rear) (NaN: missing)",
        fault: "a_ab_L4_fault",
        sensor_std: "r_a_ab_L4_std",
    },
    Input {
        name: "a_ab_R4",
        description: "measured vertical acceleration (up) of the right axle box of wheelset 4 (rear) (NaN: missing)",
        fault: "a_ab_R4_fault",
        sensor_std: "r_a_ab_R4_std",
    },
    Input {
        name: "a_bf_L1",
        description: "measured vertical acceleration (up) of the front bogie frame above the left axle box of wheelset 1 (front) (NaN: missing)",
        fault: "a_bf_L1_fault",
        sensor_std: "r_a_bf_L1_std",
    },
    Input {
        name: "a_bf_R1",
        description: "measured vertical acceleration (up) of the front bogie frame above the right axle box of wheelset 1 (front) (NaN: missing)",
        fault: "a_bf_R1_fault",
        sensor_std: "r_a_bf_R1_std",
    },
    Input {
        name: "a_bf_L2",
        description: "measured vertical acceleration (up) of the front bogie frame above the left axle box of wheelset 2 (NaN: missing)",
        fault: "a_bf_L2_fault",
        sensor_std: "r_a_bf_L2_std",
    },
    Input {
        name: "a_bf_R2",
        description: "measured vertical acceleration (up) of the front bogie frame above the right axle box of wheelset 2 (NaN: missing)",
        fault: "a_bf_R2_fault",
        sensor_std: "r_a_bf_R2_std",
    },
    Input {
        name: "a_bf_L3",
        description: "measured vertical acceleration (up) of the rear bogie frame above the left axle box of wheelset 3 (NaN: missing)",
        fault: "a_bf_L3_fault",
        sensor_std: "r_a_bf_L3_std",
    },
    Input {
        name: "a_bf_R3",
        description: "measured vertical acceleration (up) of the rear bogie frame above the right axle box of wheelset 3 (NaN: missing)",
        fault: "a_bf_R3_fault",
        sensor_std: "r_a_bf_R3_std",
    },
    Input {
        name: "a_bf_L4",
        description: "measured vertical acceleration (up) of the rear bogie frame above the left axle box of wheelset 4 (rear) (NaN: missing)",
        fault: "a_bf_L4_fault",
        sensor_std: "r_a_bf_L4_std",
    },
    Input {
        name: "a_bf_R4",
        description: "measured vertical acceleration (up) of the rear bogie frame above the right axle box of wheelset 4 (rear) (NaN: missing)",
        fault: "a_bf_R4_fault",
        sensor_std: "r_a_bf_R4_std",
    },
    Input {
        name: "a_cb_FL",
        description: "measured vertical acceleration (up) of the car body above the left secondary spring of the front bogie (NaN: missing)",
        fault: "a_cb_FL_fault",
        sensor_std: "r_a_cb_FL_std",
    },
    Input {
        name: "a_cb_FR",
        description: "measured vertical acceleration (up) of the car body above the right secondary spring of the front bogie (NaN: missing)",
        fault: "a_cb_FR_fault",
        sensor_std: "r_a_cb_FR_std",
    },
    Input {
        name: "a_cb_RL",
        description: "measured vertical acceleration (up) of the car body above the left secondary spring of the rear bogie (NaN: missing)",
        fault: "a_cb_RL_fault",
        sensor_std: "r_a_cb_RL_std",
    },
    Input {
        name: "a_cb_RR",
        description: "measured vertical acceleration (up) of the car body above the right secondary spring of the rear bogie (NaN: missing)",
        fault: "a_cb_RR_fault",
        sensor_std: "r_a_cb_RR_std",
    },
    Input {
        name: "d_p_L1",
        description: "measured deflection of the left primary suspension of wheelset 1 (front), compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_L1_fault",
        sensor_std: "r_d_p_L1_std",
    },
    Input {
        name: "d_p_R1",
        description: "measured deflection of the right primary suspension of wheelset 1 (front), compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_R1_fault",
        sensor_std: "r_d_p_R1_std",
    },
    Input {
        name: "d_p_L2",
        description: "measured deflection of the left primary suspension of wheelset 2, compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_L2_fault",
        sensor_std: "r_d_p_L2_std",
    },
    Input {
        name: "d_p_R2",
        description: "measured deflection of the right primary suspension of wheelset 2, compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_R2_fault",
        sensor_std: "r_d_p_R2_std",
    },
    Input {
        name: "d_p_L3",
        description: "measured deflection of the left primary suspension of wheelset 3, compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_L3_fault",
        sensor_std: "r_d_p_L3_std",
    },
    Input {
        name: "d_p_R3",
        description: "measured deflection of the right primary suspension of wheelset 3, compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_R3_fault",
        sensor_std: "r_d_p_R3_std",
    },
    Input {
        name: "d_p_L4",
        description: "measured deflection of the left primary suspension of wheelset 4 (rear), compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_L4_fault",
        sensor_std: "r_d_p_L4_std",
    },
    Input {
        name: "d_p_R4",
        description: "measured deflection of the right primary suspension of wheelset 4 (rear), compression positive (the axle box up towards the frame); never set or NaN: missing",
        fault: "d_p_R4_fault",
        sensor_std: "r_d_p_R4_std",
    },
];

/// The description of an acceleration's fault flag.
const FAULT: &str = "the input is faulty: rejected by the gate, stuck or missing for fault_after samples in a row";
/// The description of a deflection's fault flag.
const DEFLECTION_FAULT: &str = "the input is faulty: rejected by the gate, stuck or missing for fault_after samples \
                                in a row (as it is for good where no deflection transducer is fitted)";

/// The estimated forces, `WheelRailRoll::FORCE_NAMES` in state order: name, its deviation's
/// name, description.
const FORCES: [(&str, &str, &str); 8] = [
    ("F_NL1", "F_NL1_std", "estimated vertical wheel-rail force of the left wheel of wheelset 1"),
    ("F_NR1", "F_NR1_std", "estimated vertical wheel-rail force of the right wheel of wheelset 1"),
    ("F_NL2", "F_NL2_std", "estimated vertical wheel-rail force of the left wheel of wheelset 2"),
    ("F_NR2", "F_NR2_std", "estimated vertical wheel-rail force of the right wheel of wheelset 2"),
    ("F_NL3", "F_NL3_std", "estimated vertical wheel-rail force of the left wheel of wheelset 3"),
    ("F_NR3", "F_NR3_std", "estimated vertical wheel-rail force of the right wheel of wheelset 3"),
    ("F_NL4", "F_NL4_std", "estimated vertical wheel-rail force of the left wheel of wheelset 4"),
    ("F_NR4", "F_NR4_std", "estimated vertical wheel-rail force of the right wheel of wheelset 4"),
];

/// The derived outputs of each wheelset: sum, its σ, difference (left − right), its σ;
/// `Role::Derived(4·j + i)`.
const WHEELSET_OUTPUTS: [[&str; 4]; 4] = [
    ["F_sum1", "F_sum1_std", "F_diff1", "F_diff1_std"],
    ["F_sum2", "F_sum2_std", "F_diff2", "F_diff2_std"],
    ["F_sum3", "F_sum3_std", "F_diff3", "F_diff3_std"],
    ["F_sum4", "F_sum4_std", "F_diff4", "F_diff4_std"],
];

/// Descriptions of the derived outputs, in the order of [`WHEELSET_OUTPUTS`]'s rows.
const WHEELSET_DESCRIPTIONS: [&str; 4] = [
    "sum of the wheelset's two forces, F_NL + F_NR: its vertical load on the track",
    "standard deviation of the sum, from the covariance of the two forces",
    "difference of the wheelset's two forces, F_NL - F_NR (left minus right): the load shift across it",
    "standard deviation of the difference, from the covariance of the two forces",
];

pub(super) fn descriptor() -> Descriptor {
    let defaults = RollVehicle::zhai_passenger();
    let [damping, beyond, _] = defaults.primary_damper.slopes();
    let [knee, _] = defaults.primary_damper.breaks();
    let mut v = Vec::new();
    for (row, input) in INPUTS.iter().enumerate() {
        let unit = if WheelRailRoll::DEFLECTIONS.contains(&row) { "m" } else { "m/s2" };
        v.push(Variable::measurement(input.name, unit, row, input.description));
    }
    for (row, input) in INPUTS.iter().enumerate() {
        let description = if WheelRailRoll::DEFLECTIONS.contains(&row) { DEFLECTION_FAULT } else { FAULT };
        v.push(Variable::flag(input.fault, Role::ChannelFault(row), description));
    }
    for (k, (force, std, description)) in FORCES.into_iter().enumerate() {
        let state = WheelRailRoll::FORCES + k;
        v.push(Variable::output(force, "N", Role::Estimate(state), description));
        v.push(Variable::output(std, "N", Role::EstimateStd(state), "standard deviation of the force"));
    }
    for (j, names) in WHEELSET_OUTPUTS.into_iter().enumerate() {
        for (i, (name, description)) in names.into_iter().zip(WHEELSET_DESCRIPTIONS).enumerate() {
            v.push(Variable::output(name, "N", Role::Derived(4 * j + i), description));
        }
    }
    let positive = |var: Variable| var.bounded(Some(0.0), None);
    // Zhai's high-speed passenger car, whole ([Zhai2015]); the primary damper's
    // blow-off slope and knee are the project's estimates, as S2's.
    v.extend([
        positive(Variable::parameter("car_body_mass", "kg", defaults.car_body_mass, "car body mass")),
        positive(Variable::parameter(
            "car_body_pitch_inertia",
            "kg.m2",
            defaults.car_body_pitch_inertia,
            "car body pitch inertia",
        )),
        positive(Variable::parameter(
            "car_body_roll_inertia",
            "kg.m2",
            defaults.car_body_roll_inertia,
            "car body roll inertia",
        )),
        positive(Variable::parameter("bogie_mass", "kg", defaults.bogie_mass, "bogie frame mass")),
        positive(Variable::parameter(
            "bogie_pitch_inertia",
            "kg.m2",
            defaults.bogie_pitch_inertia,
            "bogie frame pitch inertia",
        )),
        positive(Variable::parameter(
            "bogie_roll_inertia",
            "kg.m2",
            defaults.bogie_roll_inertia,
            "bogie frame roll inertia",
        )),
        positive(Variable::parameter("wheelset_mass", "kg", defaults.wheelset_mass, "wheelset mass")),
        positive(Variable::parameter(
            "wheelset_roll_inertia",
            "kg.m2",
            defaults.wheelset_roll_inertia,
            "wheelset roll inertia",
        )),
        positive(Variable::parameter(
            "primary_stiffness",
            "N/m",
            defaults.primary_stiffness,
            "primary vertical stiffness per axle box",
        )),
        Variable::parameter("primary_damping", "N.s/m", damping, "primary damper: slope up to primary_damper_knee"),
        Variable::parameter("primary_damping_beyond", "N.s/m", beyond, "primary damper: slope beyond the knee"),
        positive(Variable::parameter(
            "primary_damper_knee",
            "m/s",
            knee,
            "primary damper: relative velocity of the knee",
        )),
        positive(Variable::parameter(
            "secondary_stiffness",
            "N/m",
            defaults.secondary_stiffness,
            "secondary vertical stiffness per side of a bogie",
        )),
        Variable::parameter(
            "secondary_damping",
            "N.s/m",
            defaults.secondary_damping,
            "secondary vertical damping per side of a bogie",
        ),
        positive(Variable::parameter(
            "half_bogie_spacing",
            "m",
            defaults.half_bogie_spacing,
            "half the distance between the bogie centres",
        )),
        positive(Variable::parameter("half_wheelbase", "m", defaults.half_wheelbase, "half the bogie wheelbase")),
        positive(Variable::parameter(
            "primary_half_span",
            "m",
            defaults.primary_half_span,
            "half the lateral distance between the left and right primary springs",
        )),
        positive(Variable::parameter(
            "secondary_half_span",
            "m",
            defaults.secondary_half_span,
            "half the lateral distance between the left and right secondary springs",
        )),
        positive(Variable::parameter(
            "contact_half_span",
            "m",
            defaults.contact_half_span,
            "half the lateral distance between the wheels' contact points (the rolling circles)",
        )),
        positive(Variable::parameter(
            "static_wheel_load",
            "N",
            defaults.static_wheel_load,
            "static load of one wheel on its rail, as weighed (default: an eighth of the catalogue weight)",
        )),
        // Chosen with the force intensity below on one seed of the study's truth
        // (docs/studies/s3.md): with random walks the side-to-side patterns no
        // accelerometer sees wander without bound (11 % of the wheel load in 2 s at rest).
        Variable::parameter(
            "force_return_rate",
            "1/s",
            FORCE_RETURN_RATE,
            "rate at which each force returns to static_wheel_load: 1 / its correlation time (0: random walks, the paper's model)",
        )
        .bounded(Some(0.0), None),
        Variable::integer_parameter("rk4_substeps", 1, (1, 1000), "RK4 steps per filter sample"),
        positive(Variable::parameter(
            "p0_motion_std",
            "1",
            0.1,
            "initial standard deviation of the 34 motion states, each in its own SI unit",
        )),
        positive(Variable::parameter("p0_force_std", "N", 0.1, "initial standard deviation of the forces")),
        Variable::tunable(
            "q_body_std",
            "1",
            3e-5,
            "process noise std per sample of the car-body and bogie coordinates and their velocities, each in its own SI unit (see the documentation)",
        )
        .bounded(Some(0.0), None),
        Variable::tunable(
            "q_wheelset_std",
            "1",
            1e-5,
            "process noise std per sample of the wheelset coordinates (m, rad) and their velocities (m/s, rad/s) (see the documentation)",
        )
        .bounded(Some(0.0), None),
        Variable::tunable(
            "force_noise_intensity",
            "N2/s",
            FORCE_NOISE_INTENSITY,
            "intensity of the forces' driving noise: variance q·dt per step",
        )
        .bounded(Some(0.0), None),
    ]);
    v.push(
        Variable::tunable(
            "deflection_model_error",
            "m",
            DEFLECTION_MODEL_ERROR,
            "the model's error in a primary deflection (the car as built, its track and lateral motion, which the model has not), added to each deflection sensor's noise",
        )
        .bounded(Some(0.0), None),
    );
    for (row, input) in INPUTS.iter().enumerate() {
        let (unit, std) = if WheelRailRoll::DEFLECTIONS.contains(&row) { ("m", 1e-4) } else { ("m/s2", 0.05) };
        v.push(
            Variable::tunable(input.sensor_std, unit, std, "noise std of the input's sensor").bounded(Some(0.0), None),
        );
    }
    Descriptor {
        model_identifier: "kalfmu_s3_wheel_rail_lr",
        model_name: "kalfmu S3 left/right wheel-rail forces (17-DOF vehicle with roll)",
        description: "Identifies the eight vertical wheel-rail forces, left and right of each wheelset, from axle-box, bogie-frame and car-body accelerations (and primary deflections, if fitted)",
        documentation: "<p>Study S3: the vertical wheel-rail forces of a four-axle vehicle, left and right of each \
         wheelset, identified online with an SRCKF from the vertical accelerations of the eight axle boxes, of the \
         bogie frames above them and of the car body above the four secondary springs (eq. (26) of the paper). The \
         model is the whole car: car body and bogies in bounce, pitch and roll, wheelsets in bounce and roll (17 \
         DOF), primary dampers piecewise linear, secondary suspension linear; the eight forces F_N are states. \
         Coordinates are deviations from static equilibrium, up, left positive; the forces include the static wheel \
         load. The eight primary deflections (compression positive) are optional inputs: a master without \
         deflection transducers never sets them (or sets NaN), and they are missing; their fault flags then read \
         faulty.</p>\
         <p>The force model: each force returns to the static wheel load at the rate {force_return_rate}, \
         the inverse of its correlation time, driven by white noise of {force_noise_intensity}; a rate of 0 makes \
         them random walks, the paper's model. With random walks, the force patterns the suspension balances without moving the car (a \
         roll moment of one wheelset taken by another's through the bogies and the car body) give no acceleration \
         at all: no accelerometer sees them, and their estimate wanders; a positive rate pulls them back to the \
         static load, primary deflections see them directly. A deflection's noise in R is its sensor's and the \
         model's error in it, {deflection_model_error}: the model has neither the track nor the lateral motion. Outputs beyond the forces: per wheelset the sum \
         F_NL + F_NR and the difference F_NL - F_NR with their σ from the covariance.</p>\
         <p>Left out, which a real vehicle has: the track (the wheels are driven by the forces alone), all lateral \
         and yaw motion, the contact points' shift with the wheelset's lateral displacement (the contact half span \
         is fixed), the lateral contact forces' moments.</p>\
         <p>Defaults: Zhai's high-speed passenger car; S2's set-up, the motion states' noise at {q_body_std} and \
         {q_wheelset_std} per sample; a sample every {sample_time}, as axle-box data acquisition records.</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 4.0, step: 0.001 },
        build_filter: build,
        build_noise: noise,
        default_filter: FilterKind::SrCkf,
        // The forces' noise adapts upwards only, for S2's reason: their driving
        // noise is set for the impacts (a weld moves a force by tens of kN in a
        // few ms), which a smooth stretch says nothing of; learnt there, its
        // scale would fall to its bound and the next weld fail the gate. The
        // jumps are taken, and one that a sensor alone explains is shown at
        // its sample, as S2's.
        supervision: SupervisorSettings {
            min_process_noise_scale: 1.0,
            wiring_sigmas: 8.0,
            show_single_row_jumps: true,
            local_jumps: true,
            // Each axle box drags its own force along: only the other
            // channels show its wiring mistake, through the dynamics.
            wiring_signatures: true,
            ..SupervisorSettings::default()
        },
        derive,
        build_steps: no_quantized_steps,
        unknown_inputs: &WheelRailRoll::UNKNOWN_INPUTS,
        plausible_bound: super::wheel_rail::hundred_static_wheel_loads,
        smoothed_states: &WheelRailRoll::UNKNOWN_INPUTS,
        guid: String::new(),
    }
    .finish()
}

fn vehicle(p: &Parameters) -> Result<RollVehicle, String> {
    let damper = PiecewiseLinear::new(
        [p.finite("primary_damping")?, p.finite("primary_damping_beyond")?, p.finite("primary_damping_beyond")?],
        [p.positive("primary_damper_knee")?; 2],
    )
    .map_err(|e| e.to_string())?;
    Ok(RollVehicle {
        car_body_mass: p.positive("car_body_mass")?,
        car_body_pitch_inertia: p.positive("car_body_pitch_inertia")?,
        car_body_roll_inertia: p.positive("car_body_roll_inertia")?,
        bogie_mass: p.positive("bogie_mass")?,
        bogie_pitch_inertia: p.positive("bogie_pitch_inertia")?,
        bogie_roll_inertia: p.positive("bogie_roll_inertia")?,
        wheelset_mass: p.positive("wheelset_mass")?,
        wheelset_roll_inertia: p.positive("wheelset_roll_inertia")?,
        primary_stiffness: p.positive("primary_stiffness")?,
        primary_damper: damper,
        secondary_stiffness: p.positive("secondary_stiffness")?,
        secondary_damping: p.finite("secondary_damping")?,
        half_bogie_spacing: p.positive("half_bogie_spacing")?,
        half_wheelbase: p.positive("half_wheelbase")?,
        primary_half_span: p.positive("primary_half_span")?,
        secondary_half_span: p.positive("secondary_half_span")?,
        contact_half_span: p.positive("contact_half_span")?,
        static_wheel_load: p.positive("static_wheel_load")?,
    })
}

/// The car body's and bogies' bounce, pitch and roll (9), the wheelsets' bounce and roll
/// (8), eight forces.
const LAYOUT: Layout = Layout { body: 9, wheelsets: 8, forces: 8 };

fn build(
    p: &Parameters,
    kind: FilterKind,
    ukf: UnscentedParams,
    noise: Noise,
) -> Result<Box<dyn StateEstimator>, String> {
    let vehicle = vehicle(p)?;
    let substeps = p.positive("rk4_substeps")? as usize;
    let force_return_rate = p.non_negative("force_return_rate")?;
    let prior = LAYOUT.prior(p, vehicle.static_wheel_load)?;
    let model = Discretized::rk4(WheelRailRoll { vehicle, force_return_rate }, substeps);
    build_filter(kind, model, noise, &prior, ukf).map_err(|e| e.to_string())
}

/// `Q` over `dt`: the per-sample motion variances scale with `dt / sample_time` (white
/// noise; the body's are the car body's and the bogies' nine coordinates and their
/// velocities, the wheelsets' their eight), the forces' with the intensity; `R` from the
/// sensors' noise, and for the deflections the model's error in them.
fn noise(p: &Parameters, dt: f64) -> Result<Noise, String> {
    let q = LAYOUT.process_noise(p, dt)?;
    let model_error = p.non_negative("deflection_model_error")?;
    let r: Vec<f64> = INPUTS
        .iter()
        .enumerate()
        .map(|(row, input)| {
            let floor = if WheelRailRoll::DEFLECTIONS.contains(&row) { model_error } else { 0.0 };
            p.non_negative(input.sensor_std).map(|s| s * s + floor * floor)
        })
        .collect::<Result<_, _>>()?;
    Noise::diagonal(&q, &r).map_err(|e| e.to_string())
}

/// Per wheelset the sum and the difference of its two forces and their σ:
/// `var = P_LL + P_RR ± 2·P_LR`.
fn derive(_: &Parameters, reading: &Reading<'_>, out: &mut [f64]) {
    debug_assert!(out.len() >= 16 && 16 <= MAX_DERIVED);
    let (mean, covariance) = (reading.belief.mean(), reading.belief.covariance());
    for j in 0..4 {
        let (l, r) = (WheelRailRoll::FORCES + 2 * j, WheelRailRoll::FORCES + 2 * j + 1);
        let (p_ll, p_rr, p_lr) = (covariance[(l, l)], covariance[(r, r)], covariance[(l, r)]);
        out[4 * j] = mean[l] + mean[r];
        out[4 * j + 1] = (p_ll + p_rr + 2.0 * p_lr).max(0.0).sqrt();
        out[4 * j + 2] = mean[l] - mean[r];
        out[4 * j + 3] = (p_ll + p_rr - 2.0 * p_lr).max(0.0).sqrt();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_names_are_the_model_s() {
        let inputs: Vec<&str> = INPUTS.iter().map(|i| i.name).collect();
        assert_eq!(inputs, WheelRailRoll::MEASUREMENT_NAMES);
        for input in &INPUTS {
            assert_eq!(input.fault, format!("{}_fault", input.name));
            assert_eq!(input.sensor_std, format!("r_{}_std", input.name));
        }
        let forces: Vec<&str> = FORCES.iter().map(|f| f.0).collect();
        assert_eq!(forces, WheelRailRoll::FORCE_NAMES);
        for (force, std, _) in FORCES {
            assert_eq!(std, format!("{force}_std"));
        }
        for (j, names) in WHEELSET_OUTPUTS.iter().enumerate() {
            let n = j + 1;
            assert_eq!(
                names,
                &[&*format!("F_sum{n}"), &format!("F_sum{n}_std"), &format!("F_diff{n}"), &format!("F_diff{n}_std")]
            );
        }
    }

    #[test]
    fn the_defaults_are_the_catalogue_car() {
        let d = descriptor();
        let values: Vec<f64> = d.variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
        let p = Parameters::new(&d.variables, &values);
        assert_eq!(vehicle(&p).unwrap(), RollVehicle::zhai_passenger());
        assert!((p.get("static_wheel_load").unwrap() - 45_600.0 * 9.81 / 8.0).abs() < 1e-9);
    }
}
