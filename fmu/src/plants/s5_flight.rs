//! The S5 plant: the truth's 6-DOF missile (`truth::s5::plant::FlyingPlant`: the study's
//! airframe on a flat Earth in the ISA, RK4 at its own fine step) with its twelve flight
//! sensors, as an FMU that drives `kalfmu_s5_missile`. The rudders follow one of the
//! study's manoeuvres (by parameter) or inputs held over each step; the force coefficients
//! change at a time of the user's, from one set of the user's to another. The outputs are
//! the noisy measurements and the deflections (the estimator's inputs and controls) and the
//! true coefficients and motion (to compare its outputs with).
//!
//! Given the study's manoeuvre, coefficients, start, seed, integration step and noise σ,
//! and stepped at the study's sample time, it gives the study's truth and measurements to
//! the bit: both are the same plant and the same noise stream (`truth::s5::flight`).

use estimator::models::Airframe;
use truth::s5::flight::sensor_noise;
use truth::s5::manoeuvre::Manoeuvre;
use truth::s5::parameters::{start, AFTER, BEFORE, NAMES, SENSOR_STD};
use truth::s5::plant::{Flight, FlyingPlant, Motion};
use truth::sensor_noise::SensorNoise;

use super::{integration_steps, read_position, write_position, Plant, PlantDescriptor};
use crate::estimators::DefaultExperiment;
use crate::serialize::{Reader, Writer};
use crate::variables::{EnumerationType, Kind, Parameters, Role, Variable};

/// Where the rudder deflections come from.
pub static MANOEUVRE: EnumerationType = EnumerationType {
    name: "S5Manoeuvre",
    items: &[
        (1, "input", "the inputs delta_x_command, delta_y_command, delta_z_command, held over each communication step"),
        (2, "standard", "the study's manoeuvre: 3-2-1-1s, doublets and steps on every rudder over 20 s"),
        (
            3,
            "roll_turn",
            "a roll-heavy manoeuvre with a sustained pull, over 20 s, that the estimators were not tuned on",
        ),
    ],
};

/// The twelve measurements, in the estimator's order: name, unit, the true quantity.
const MEASUREMENTS: [(&str, &str, &str); 12] = [
    ("omega_x", "rad/s", "true roll rate (body x)"),
    ("omega_y", "rad/s", "true yaw rate (body y, up)"),
    ("omega_z", "rad/s", "true pitch rate (body z, right)"),
    ("Nx", "1", "true overload along body x, in g: the aerodynamic force over m·g"),
    ("Ny", "1", "true overload along body y, in g"),
    ("Nz", "1", "true overload along body z, in g"),
    ("phi", "rad", "true pitch angle"),
    ("psi", "rad", "true yaw angle"),
    ("gamma", "rad", "true roll angle"),
    ("h", "m", "true altitude"),
    ("alpha", "rad", "true angle of attack atan2(-Vy, Vx)"),
    ("beta", "rad", "true sideslip asin(Vz/V)"),
];

/// The deflections: output, the input that sets it, and their descriptions.
const RUDDERS: [(&str, &str, &str, &str); 3] = [
    (
        "delta_x",
        "delta_x_command",
        "the roll rudder deflection held from now on: connect it to the estimator's control of the same name",
        "the roll rudder deflection when manoeuvre is 1 (input), held from the communication point it is set at \
         over the step; ignored otherwise",
    ),
    (
        "delta_y",
        "delta_y_command",
        "the pitch rudder deflection held from now on (drives Cy and the pitch moment)",
        "the pitch rudder deflection when manoeuvre is 1 (input), held likewise; ignored otherwise",
    ),
    (
        "delta_z",
        "delta_z_command",
        "the yaw rudder deflection held from now on (drives Cz and the yaw moment)",
        "the yaw rudder deflection when manoeuvre is 1 (input), held likewise; ignored otherwise",
    ),
];

/// The motion states, in the truth's order: name of the start parameter, unit, description.
const START: [(&str, &str, &str); 10] = [
    ("Vx_start", "m/s", "body velocity along x at the start"),
    ("Vy_start", "m/s", "body velocity along y (up) at the start"),
    ("Vz_start", "m/s", "body velocity along z (right) at the start"),
    ("phi_start", "rad", "pitch angle at the start"),
    ("psi_start", "rad", "yaw angle at the start"),
    ("gamma_start", "rad", "roll angle at the start"),
    ("h_start", "m", "altitude at the start"),
    ("omega_x_start", "rad/s", "roll rate at the start"),
    ("omega_y_start", "rad/s", "yaw rate at the start"),
    ("omega_z_start", "rad/s", "pitch rate at the start"),
];

/// The body velocities, the motion states no measurement shows.
const VELOCITIES: [(&str, &str); 3] = [
    ("Vx", "true body velocity along x"),
    ("Vy", "true body velocity along y (up)"),
    ("Vz", "true body velocity along z (right)"),
];

/// Where each group of outputs starts, by `Role::PlantOutput` index.
const DEFLECTIONS_AT: usize = 12;
const COEFFICIENTS_AT: usize = DEFLECTIONS_AT + 3;
const TRUE_MEASUREMENTS_AT: usize = COEFFICIENTS_AT + 10;
const VELOCITIES_AT: usize = TRUE_MEASUREMENTS_AT + 12;

pub(super) fn descriptor() -> PlantDescriptor {
    let mut v = Vec::new();
    for (j, (_, input, _, description)) in RUDDERS.into_iter().enumerate() {
        v.push(Variable { role: Role::PlantInput(j), ..Variable::measurement(input, "rad", 0, description) });
    }
    for (k, (name, unit, _)) in MEASUREMENTS.into_iter().enumerate() {
        v.push(Variable::output(
            name,
            unit,
            Role::PlantOutput(k),
            "measured, as its sensor gives it: the true value plus the sensor's white noise (noise_seed, \
             <name>_noise_std), drawn anew at each communication point",
        ));
    }
    for (j, (name, _, description, _)) in RUDDERS.into_iter().enumerate() {
        v.push(Variable::output(name, "rad", Role::PlantOutput(DEFLECTIONS_AT + j), description));
    }
    for (k, name) in NAMES.into_iter().enumerate() {
        v.push(Variable::output(
            name,
            "1",
            Role::PlantOutput(COEFFICIENTS_AT + k),
            "the true force coefficient in force from now on",
        ));
    }
    for (k, (name, unit, description)) in MEASUREMENTS.into_iter().enumerate() {
        v.push(Variable {
            name: format!("{name}_true").into(),
            ..Variable::output("", unit, Role::PlantOutput(TRUE_MEASUREMENTS_AT + k), description)
        });
    }
    for (k, (name, description)) in VELOCITIES.into_iter().enumerate() {
        v.push(Variable::output(name, "m/s", Role::PlantOutput(VELOCITIES_AT + k), description));
    }
    let positive = |var: Variable| var.bounded(Some(0.0), None);
    v.extend([
        Variable::parameter(
            "integration_step",
            "s",
            5e-4,
            "the plant's RK4 step; every communication step must be a whole number of them",
        )
        .bounded(Some(1e-9), None),
        Variable {
            kind: Kind::Enumeration(&MANOEUVRE),
            unit: None,
            ..Variable::parameter(
                "manoeuvre",
                "1",
                2.0,
                "where the rudder deflections come from: 1 the inputs, 2 the study's manoeuvre, 3 roll-turn",
            )
        },
        positive(Variable::parameter(
            "change_at",
            "s",
            10.0,
            "when the force coefficients change from the <name>_before to the <name>_after set",
        )),
    ]);
    for (name, value) in NAMES.into_iter().zip(BEFORE) {
        let parameter = Variable::parameter("", "1", value, "the force coefficient until change_at");
        v.push(Variable { name: format!("{name}_before").into(), ..parameter });
    }
    for (name, value) in NAMES.into_iter().zip(AFTER) {
        let parameter = Variable::parameter("", "1", value, "the force coefficient from change_at on");
        v.push(Variable { name: format!("{name}_after").into(), ..parameter });
    }
    for ((name, unit, description), value) in START.into_iter().zip(start()) {
        v.push(Variable::parameter(name, unit, value, description));
    }
    v.push(Variable::integer_parameter("noise_seed", 1, (0, i32::MAX as u32), "seed of the sensors' noise"));
    for ((name, unit, _), std) in MEASUREMENTS.into_iter().zip(SENSOR_STD) {
        let parameter =
            Variable::parameter("", unit, std, "standard deviation of the white noise on this measurement (0: none)");
        v.push(positive(Variable { name: format!("{name}_noise_std").into(), ..parameter }));
    }
    PlantDescriptor {
        model_identifier: "kalfmu_s5_flight",
        model_name: "kalfmu S5 missile in flight (plant)",
        description: "The truth of study S5 as a plant: a tactical missile's 6-DOF flight through a rudder \
                      manoeuvre, its force coefficients changing mid-flight, with twelve noisy flight sensors",
        documentation: "<p>The first truth of study S5 (Jiang, Yan, Li, <i>Online identification of aerodynamic \
         parameters of aircraft based on SVD-CKF</i>, 2024): the study's missile as a rigid body on a flat, \
         non-rotating Earth in the ISA, its forces from the ten-coefficient model and its moments from the \
         moment model, integrated with RK4 at {integration_step}, finer than any estimator's step. It starts at \
         the start time from the <code>*_start</code> motion (the study's: 1000 m/s at 10 km) and flies the \
         rudder inputs of {manoeuvre}; its coefficients change from the <code>*_before</code> set to the \
         <code>*_after</code> set at {change_at}. Over each RK4 step the coefficients are those in force at its \
         middle and the manoeuvre's deflections those at its middle (the study's manoeuvres switch on a 5 ms \
         grid); inputs are held over each communication step (inputs without derivatives).</p>\
         <p>It is the pair of <code>kalfmu_s5_missile</code>: connect the twelve measurements and the three \
         deflections to the estimator's inputs of the same names, and compare its coefficients with the \
         plant's. Its noise is white and Gaussian, drawn anew at each communication point from the stream of \
         {noise_seed}, so the measurements are those of sensors sampled at the communication step. The \
         airframe is the study's; an estimator's airframe parameters are the user's.</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 20.0, step: 0.005 },
        build,
        guid: String::new(),
    }
    .finish()
}

/// The missile, its integration step and its sensors, and the noise of the communication
/// point it stands at.
struct Missile {
    plant: FlyingPlant,
    h: f64,
    noise: SensorNoise<12>,
    /// The noise of the current communication point, per measurement.
    current_noise: [f64; 12],
}

fn build(p: &Parameters) -> Result<Box<dyn Plant>, String> {
    let set = |suffix: &str| -> Result<[f64; 10], String> {
        let values: Vec<f64> = NAMES.iter().map(|n| p.finite(&format!("{n}{suffix}"))).collect::<Result<_, _>>()?;
        Ok(values.try_into().expect("ten coefficients"))
    };
    let (mut manoeuvre, held) = match p.get("manoeuvre")? as i32 {
        // The shell sets the inputs as they stand right after.
        1 => (Manoeuvre::quiet(0.0), Some([0.0; 3])),
        2 => (Manoeuvre::standard(), None),
        3 => (Manoeuvre::roll_turn(), None),
        other => return Err(format!("manoeuvre must be 1 … 3, got {other}")),
    };
    manoeuvre.change_at = p.non_negative("change_at")?;
    let flight =
        Flight { airframe: Airframe::tactical_missile(), coefficients: [set("_before")?, set("_after")?], manoeuvre };
    let motion: Vec<f64> = START.iter().map(|(name, _, _)| p.finite(name)).collect::<Result<_, _>>()?;
    let h = p.positive("integration_step")?;
    let plant = FlyingPlant::new(flight, motion.try_into().expect("ten motion states"), h, held)?;
    let std: Vec<f64> = MEASUREMENTS
        .iter()
        .map(|(name, _, _)| p.non_negative(&format!("{name}_noise_std")))
        .collect::<Result<_, _>>()?;
    let mut noise = sensor_noise(p.non_negative("noise_seed")? as u64, std.try_into().expect("twelve sensors"));
    let current_noise = noise.measure([0.0; 12]);
    Ok(Box::new(Missile { plant, h, noise, current_noise }))
}

impl Plant for Missile {
    fn set_input(&mut self, j: usize, value: f64) -> Result<(), String> {
        if j >= RUDDERS.len() {
            return Err(format!("the S5 missile has three inputs, not {}", j + 1));
        }
        if !self.plant.holds_deflections() {
            // The rudders follow the manoeuvre: the inputs are ignored, as their descriptions say.
            return Ok(());
        }
        let mut delta = self.plant.deflections();
        delta[j] = value;
        self.plant.set_deflections(delta)
    }

    fn advance(&mut self, h: f64) -> Result<(), String> {
        self.plant.advance(integration_steps(h, self.h)?)?;
        self.current_noise = self.noise.measure([0.0; 12]);
        Ok(())
    }

    fn outputs(&mut self, out: &mut [f64]) {
        let z = self.plant.measurements();
        let motion = self.plant.motion();
        for k in 0..12 {
            out[k] = z[k] + self.current_noise[k];
            out[TRUE_MEASUREMENTS_AT + k] = z[k];
        }
        out[DEFLECTIONS_AT..COEFFICIENTS_AT].copy_from_slice(&self.plant.deflections());
        out[COEFFICIENTS_AT..TRUE_MEASUREMENTS_AT].copy_from_slice(self.plant.coefficients());
        out[VELOCITIES_AT..].copy_from_slice(&motion[..3]);
    }

    fn save(&self) -> Vec<u8> {
        let mut w = Writer(Vec::with_capacity(256));
        w.f64s(&self.plant.motion());
        w.u64(self.plant.steps() as u64);
        w.f64s(&self.plant.deflections());
        write_position(&mut w, self.noise.position());
        w.f64s(&self.current_noise);
        w.0
    }

    fn restore(&mut self, saved: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(saved);
        let motion: Motion = r.f64s()?.try_into().map_err(|_| "an S5 flight's motion has ten numbers")?;
        let steps = r.u64()? as usize;
        let deflections: [f64; 3] = r.f64s()?.try_into().map_err(|_| "an S5 missile has three rudders")?;
        let position = read_position(&mut r)?;
        let current_noise: [f64; 12] = r.f64s()?.try_into().map_err(|_| "an S5 missile has twelve sensors")?;
        r.finish()?;
        if current_noise.iter().any(|x| !x.is_finite()) {
            return Err("the saved noise is not finite".into());
        }
        let mut plant = self.plant.clone();
        plant.resume(motion, steps)?;
        if plant.holds_deflections() {
            plant.set_deflections(deflections)?;
        }
        self.plant = plant;
        self.noise.set_position(position);
        self.current_noise = current_noise;
        Ok(())
    }
}
