//! The S1 plant: the truth simulator's two-mass chain (`truth::s1::plant::ChainPlant`,
//! RK4 at its own fine step) with its two accelerometers, as an FMU that drives
//! `kalfmu_s1_load`. The load is a built-in law of the study (by parameter) or an
//! input held over each step; the outputs are the noisy accelerations (the
//! estimator's inputs) and the true load and motion (to compare its outputs with).
//!
//! Given the study's chain, load, seed, integration step and noise σ, and stepped at
//! the study's sample time, it gives the study's truth and measurements to the bit:
//! both are the same plant and the same noise stream (`truth::s1::accelerometer_noise`).

use truth::s1::accelerometer_noise;
use truth::s1::load::Load;
use truth::s1::plant::{ChainPlant, LoadSource};
use truth::sensor_noise::SensorNoise;

use super::{integration_steps, read_position, write_position, Plant, PlantDescriptor};
use crate::estimators::s1_load::{chain, chain_variables};
use crate::estimators::DefaultExperiment;
use crate::serialize::{Reader, Writer};
use crate::variables::{EnumerationType, Kind, Parameters, Role, Variable};

/// Where the chain's load comes from.
pub static LOAD_SOURCE: EnumerationType = EnumerationType {
    name: "S1LoadSource",
    items: &[
        (1, "input", "the input load, held over each communication step"),
        (2, "random", "the study's random load: seeded, band-limited from 0.1 to 10 Hz (load_seed, load_rms)"),
        (3, "harmonic", "the study's harmonic load: sines at 1, 2, 3, 5 and 7 Hz of 8, 6, 5, 4 and 3 N"),
        (4, "band_20", "a seeded band-limited random load, flat from 0.2 to 20 Hz (load_seed, load_rms)"),
    ],
};

/// The outputs, by `Role::PlantOutput` index.
const OUTPUTS: [(&str, &str, &str); 9] = [
    ("z1_ddot", "m/s2", "measured acceleration of mass 1: the true one plus the sensor's noise (noise_seed, z1_ddot_noise_std), drawn anew at each communication point"),
    ("z2_ddot", "m/s2", "measured acceleration of mass 2: the true one plus the sensor's noise (noise_seed, z2_ddot_noise_std), drawn anew at each communication point"),
    ("F", "N", "true load on mass 2"),
    ("z1", "m", "true displacement of mass 1"),
    ("z2", "m", "true displacement of mass 2"),
    ("z1_dot", "m/s", "true velocity of mass 1"),
    ("z2_dot", "m/s", "true velocity of mass 2"),
    ("z1_ddot_true", "m/s2", "true acceleration of mass 1 (no noise)"),
    ("z2_ddot_true", "m/s2", "true acceleration of mass 2 (no noise)"),
];

pub(super) fn descriptor() -> PlantDescriptor {
    let mut v = vec![Variable {
        role: Role::PlantInput(0),
        ..Variable::measurement(
            "load",
            "N",
            0,
            "the load on mass 2 when load_source is 1 (input), held from the communication point it is set at \
             over the step; ignored otherwise",
        )
    }];
    for (k, (name, unit, description)) in OUTPUTS.into_iter().enumerate() {
        v.push(Variable::output(name, unit, Role::PlantOutput(k), description));
    }
    v.extend(chain_variables());
    let positive = |var: Variable| var.bounded(Some(0.0), None);
    v.extend([
        Variable::parameter(
            "integration_step",
            "s",
            1e-4,
            "the plant's RK4 step; every communication step must be a whole number of them",
        )
        .bounded(Some(1e-9), None),
        Variable {
            kind: Kind::Enumeration(&LOAD_SOURCE),
            unit: None,
            ..Variable::parameter(
                "load_source",
                "1",
                2.0,
                "where the load comes from: 1 the input, 2 the study's random load, 3 its harmonic load, \
                 4 a band-limited random load to 20 Hz",
            )
        },
        Variable::integer_parameter("load_seed", 1, (0, i32::MAX as u32), "seed of the random loads"),
        positive(Variable::parameter("load_rms", "N", 10.0, "RMS of the random loads")),
        Variable::integer_parameter("noise_seed", 1, (0, i32::MAX as u32), "seed of the accelerometers' noise"),
        positive(Variable::parameter(
            "z1_ddot_noise_std",
            "m/s2",
            0.01,
            "standard deviation of the white noise on z1_ddot (0: none)",
        )),
        positive(Variable::parameter(
            "z2_ddot_noise_std",
            "m/s2",
            0.01,
            "standard deviation of the white noise on z2_ddot (0: none)",
        )),
    ]);
    PlantDescriptor {
        model_identifier: "kalfmu_s1_chain",
        model_name: "kalfmu S1 two-mass chain (plant)",
        description: "The truth of study S1 as a plant: a 2-DOF nonlinear spring-damper chain under a load, \
                      with two noisy accelerometers",
        documentation: "<p>The truth simulator of study S1 (Gong, Chen, Li, Wang, <i>Dynamic load identification \
         method for multi-degree-of-freedom nonlinear systems based on SRCKF</i>, J. Xihua Univ. 43(1), 2024): \
         ground —(k1, c1)— m1 —(k2, c2)— m2, the load F on the free mass m2, k1 and c1 continuous \
         piecewise-linear laws of three slopes. The chain starts at rest at the start time and is integrated \
         with RK4 at {integration_step}, finer than any estimator's step; the load is a law of time evaluated at \
         every RK4 stage, or the input held over each communication step (an input without derivatives).</p>\
         <p>It is the pair of <code>kalfmu_s1_load</code>: connect <code>z1_ddot</code> and <code>z2_ddot</code> \
         to the estimator's inputs of the same names, and compare its <code>F</code> with the plant's. Its noise \
         is white and Gaussian, drawn anew at each communication point from the stream of {noise_seed}, so the \
         measurements are those of a sensor sampled at the communication step.</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 10.0, step: 0.005 },
        build,
        guid: String::new(),
    }
    .finish()
}

/// The chain, its integration step, its load and its accelerometers, and the noise
/// of the communication point it stands at.
struct Chain {
    plant: ChainPlant,
    h: f64,
    noise: SensorNoise<2>,
    /// The noise of the current communication point (`σ·w`, m/s²).
    current_noise: [f64; 2],
}

fn build(p: &Parameters) -> Result<Box<dyn Plant>, String> {
    let seed = |name: &str| -> Result<u64, String> { Ok(p.non_negative(name)? as u64) };
    let source = match p.get("load_source")? as i32 {
        // The shell sets the input as it stands right after.
        1 => LoadSource::Held(0.0),
        2 => LoadSource::Law(Load::random(seed("load_seed")?, p.non_negative("load_rms")?)),
        3 => LoadSource::Law(Load::harmonic()),
        4 => {
            let (band, components) = Load::BAND_20;
            LoadSource::Law(Load::band_limited(seed("load_seed")?, p.non_negative("load_rms")?, band, components))
        }
        other => return Err(format!("load_source must be 1 … 4, got {other}")),
    };
    let h = p.positive("integration_step")?;
    let plant = ChainPlant::new(chain(p)?, source, h)?;
    let std = [p.non_negative("z1_ddot_noise_std")?, p.non_negative("z2_ddot_noise_std")?];
    let mut noise = accelerometer_noise(seed("noise_seed")?, std);
    let current_noise = noise.measure([0.0; 2]);
    Ok(Box::new(Chain { plant, h, noise, current_noise }))
}

impl Plant for Chain {
    fn set_input(&mut self, j: usize, value: f64) -> Result<(), String> {
        match (j, self.plant.held_load()) {
            (0, Some(_)) => self.plant.set_load(value),
            // The load follows its law: the input is ignored, as its description says.
            (0, None) => Ok(()),
            _ => Err(format!("the S1 chain has one input, not {}", j + 1)),
        }
    }

    fn advance(&mut self, h: f64) -> Result<(), String> {
        self.plant.advance(integration_steps(h, self.h)?);
        self.current_noise = self.noise.measure([0.0; 2]);
        Ok(())
    }

    fn outputs(&mut self, out: &mut [f64]) {
        let a = self.plant.accelerations();
        let [z1, z2, z1_dot, z2_dot] = self.plant.motion();
        let values = [
            a[0] + self.current_noise[0],
            a[1] + self.current_noise[1],
            self.plant.load(),
            z1,
            z2,
            z1_dot,
            z2_dot,
            a[0],
            a[1],
        ];
        out.copy_from_slice(&values);
    }

    fn save(&self) -> Vec<u8> {
        let mut w = Writer(Vec::with_capacity(96));
        w.f64s(&self.plant.motion());
        w.u64(self.plant.steps() as u64);
        w.f64(self.plant.held_load().unwrap_or(0.0));
        write_position(&mut w, self.noise.position());
        w.f64s(&self.current_noise);
        w.0
    }

    fn restore(&mut self, saved: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(saved);
        let motion: [f64; 4] = r.f64s()?.try_into().map_err(|_| "an S1 chain's motion has four numbers")?;
        let steps = r.u64()? as usize;
        let held = r.f64()?;
        let position = read_position(&mut r)?;
        let current_noise: [f64; 2] = r.f64s()?.try_into().map_err(|_| "an S1 chain has two sensors")?;
        r.finish()?;
        if current_noise.iter().any(|x| !x.is_finite()) {
            return Err("the saved noise is not finite".into());
        }
        let mut plant = self.plant.clone();
        plant.resume(motion, steps)?;
        if plant.held_load().is_some() {
            plant.set_load(held)?;
        }
        self.plant = plant;
        self.noise.set_position(position);
        self.current_noise = current_noise;
        Ok(())
    }
}
