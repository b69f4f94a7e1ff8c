//! The S2 plant: the truth's vehicle–track model (`truth::s2`: the car as built, on one
//! rail of a ballasted track through Hertz contacts, Zhai's explicit integration at
//! 1e-4 s) recorded by the vehicle's data acquisition (`truth::s2::recording`), as an FMU
//! that drives `kalfmu_s2_wheel_rail`. The track (random of a spectrum, a corrugation, a
//! weld) and the speed are parameters; the outputs are the seven noisy accelerations (the
//! estimator's inputs), the same without noise and the four wheel–rail forces as an
//! instrumented wheelset records them (to compare its outputs with).
//!
//! Given the study's track, seed, speed, rate and noise σ, and stepped at the study's
//! sample time, it gives the study's truth and measurements to the bit: the same
//! recording and the same noise stream.

use truth::s2::cases::{as_built, sensor_noise, Case};
use truth::s2::irregularity::TrackSpectrum;
use truth::s2::parameters::Track;
use truth::s2::plant::{Settings as PlantSettings, Simulation, SimulationState};
use truth::s2::recording::{Recording, RecordingState};
use truth::sensor_noise::SensorNoise;

use super::{read_position, write_position, Plant, PlantDescriptor};
use crate::estimators::DefaultExperiment;
use crate::serialize::{Reader, Writer};
use crate::variables::{EnumerationType, Kind, Parameters, Role, Variable};

/// The rail under the run.
pub static S2_TRACK: EnumerationType = EnumerationType {
    name: "S2Track",
    items: &[
        (1, "random", "a random track of track_spectrum and track_seed"),
        (2, "corrugation", "a corrugation of 0.1 mm over 0.5 m waves, met by the front wheel 0.5 s in"),
        (3, "weld", "a weld, 0.3 mm over 1.0 m with 0.3 mm over 0.1 m, met by the front wheel 1 s in"),
    ],
};

/// The random track's spectrum.
pub static S2_SPECTRUM: EnumerationType = EnumerationType {
    name: "S2Spectrum",
    items: &[
        (1, "fra_5", "FRA class 5 (the study's)"),
        (2, "fra_6", "FRA class 6"),
        (3, "german_low", "German spectrum, low interference"),
        (4, "german_high", "German spectrum, high interference"),
    ],
};

/// The seven accelerations, as the estimator's inputs are named.
const CHANNELS: [&str; 7] = ["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"];

pub(super) fn descriptor() -> PlantDescriptor {
    let mut v = Vec::new();
    for (k, name) in CHANNELS.into_iter().enumerate() {
        v.push(Variable {
            name: name.into(),
            ..Variable::output(
                "",
                "m/s2",
                Role::PlantOutput(k),
                "measured vertical acceleration (up), as the data acquisition records it, plus the sensor's \
                 white noise (noise_seed, <name>_noise_std), drawn anew at each communication point",
            )
        });
    }
    for (k, name) in CHANNELS.into_iter().enumerate() {
        v.push(Variable {
            name: format!("{name}_true").into(),
            ..Variable::output("", "m/s2", Role::PlantOutput(7 + k), "the same acceleration without noise")
        });
    }
    for j in 0..4 {
        v.push(Variable {
            name: format!("F_N{}", j + 1).into(),
            ..Variable::output(
                "",
                "N",
                Role::PlantOutput(14 + j),
                "true vertical wheel-rail force of this wheelset, as an instrumented wheelset's acquisition records it",
            )
        });
    }
    let positive = |var: Variable| var.bounded(Some(0.0), None);
    v.extend([
        positive(Variable::parameter("speed", "m/s", 80.0 / 3.6, "the vehicle's speed")),
        Variable::parameter(
            "sample_rate",
            "1/s",
            1000.0,
            "the data acquisition's rate (Hz); every communication step must be a whole number of its samples",
        )
        .bounded(Some(1.0), Some(10_000.0)),
        Variable {
            kind: Kind::Enumeration(&S2_TRACK),
            unit: None,
            ..Variable::parameter("track", "1", 1.0, "the rail: 1 random, 2 corrugation, 3 weld")
        },
        Variable {
            kind: Kind::Enumeration(&S2_SPECTRUM),
            unit: None,
            ..Variable::parameter(
                "track_spectrum",
                "1",
                1.0,
                "the random track's spectrum: 1 FRA class 5, 2 FRA class 6, 3 German low, 4 German high interference",
            )
        },
        Variable::integer_parameter("track_seed", 1, (0, i32::MAX as u32), "seed of the random track"),
        positive(Variable::parameter(
            "track_length",
            "m",
            100.0,
            "how far the car body runs over the random track: beyond it the rail is perfect",
        )),
        Variable::integer_parameter("noise_seed", 1, (0, i32::MAX as u32), "seed of the accelerometers' noise"),
    ]);
    for name in CHANNELS {
        let parameter =
            Variable::parameter("", "m/s2", 0.05, "standard deviation of the white noise on this input (0: none)");
        v.push(positive(Variable { name: format!("{name}_noise_std").into(), ..parameter }));
    }
    PlantDescriptor {
        model_identifier: "kalfmu_s2_track",
        model_name: "kalfmu S2 vehicle on track (plant)",
        description: "The truth of study S2 as a plant: a railway vehicle on a ballasted track through Hertz \
                      contacts, with seven noisy accelerometers and the wheel-rail forces",
        documentation: "<p>The truth simulator of study S2 (the vertical wheel-rail forces of a four-axle vehicle \
         from its bounce accelerations): the car as it runs (laden with 2 t, primary springs 5 % stiffer and damper blow-off 10 % \
         steeper than the catalogue car an estimator is given) on one rail of a ballasted track (rail modes over \
         discrete sleepers), coupled through nonlinear Hertz contacts that can lose contact, integrated with \
         Zhai's explicit two-step method at 1e-4 s. It starts in static equilibrium at the start time, at \
         {speed}, over the rail {track}.</p>\
         <p>Its accelerations are recorded as a data acquisition does, at {sample_rate}: a linear-phase \
         anti-alias filter, time-stamped for its delay, so the plant runs its simulation half the filter ahead \
         of the time it stands at. It is the pair of <code>kalfmu_s2_wheel_rail</code>: connect the seven \
         accelerations to the estimator's inputs of the same names and compare its <code>F_N1</code> … \
         <code>F_N4</code> with the plant's.</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 4.0, step: 0.001 },
        build,
        guid: String::new(),
    }
    .finish()
}

/// The recording, its noise, and the noise of the communication point it stands at.
struct VehicleOnTrack {
    recording: Recording,
    /// Samples per second.
    rate: f64,
    noise: SensorNoise<7>,
    current_noise: [f64; 7],
}

fn build(p: &Parameters) -> Result<Box<dyn Plant>, String> {
    let seed = |name: &str| -> Result<u64, String> { Ok(p.non_negative(name)? as u64) };
    let case = match p.get("track")? as i32 {
        1 => Case::Random,
        2 => Case::Corrugation,
        3 => Case::Weld,
        other => return Err(format!("track must be 1 … 3, got {other}")),
    };
    let spectrum = match p.get("track_spectrum")? as i32 {
        1 => TrackSpectrum::FRA_5,
        2 => TrackSpectrum::FRA_6,
        3 => TrackSpectrum::GERMAN_LOW,
        4 => TrackSpectrum::GERMAN_HIGH,
        other => return Err(format!("track_spectrum must be 1 … 4, got {other}")),
    };
    let speed = p.positive("speed")?;
    let rail = case.rail(speed, p.positive("track_length")?, &spectrum, seed("track_seed")?);
    let plant = PlantSettings { speed, ..PlantSettings::default() };
    let simulation = Simulation::new(as_built(), Track::BALLASTED, rail, &plant);
    let rate = p.positive("sample_rate")?;
    let recording = Recording::new(simulation, plant.dt, rate)?;
    let std: Vec<f64> = CHANNELS.iter().map(|c| p.non_negative(&format!("{c}_noise_std"))).collect::<Result<_, _>>()?;
    let mut noise = sensor_noise(seed("noise_seed")?, std.try_into().expect("seven channels"));
    let current_noise = noise.measure([0.0; 7]);
    Ok(Box::new(VehicleOnTrack { recording, rate, noise, current_noise }))
}

impl Plant for VehicleOnTrack {
    fn set_input(&mut self, j: usize, _value: f64) -> Result<(), String> {
        Err(format!("the S2 plant has no input {j}"))
    }

    fn advance(&mut self, h: f64) -> Result<(), String> {
        let samples = (h * self.rate).round();
        if samples < 1.0 || (samples / self.rate - h).abs() > 1e-9 * h {
            return Err(format!("the communication step {h} s is not a whole number of samples at {} Hz", self.rate));
        }
        self.recording.advance(samples as usize);
        self.current_noise = self.noise.measure([0.0; 7]);
        Ok(())
    }

    fn outputs(&mut self, out: &mut [f64]) {
        let (accelerations, contact) = self.recording.sample();
        for k in 0..7 {
            out[k] = accelerations[k] + self.current_noise[k];
            out[7 + k] = accelerations[k];
        }
        out[14..18].copy_from_slice(&contact);
    }

    fn save(&self) -> Vec<u8> {
        let state = self.recording.state();
        let mut w = Writer(Vec::new());
        w.f64(state.simulation.time);
        w.f64(state.simulation.origin);
        w.f64s(&state.simulation.u);
        w.f64s(&state.simulation.v);
        match &state.simulation.a_previous {
            None => w.u8(0),
            Some(a) => {
                w.u8(1);
                w.f64s(a);
            }
        }
        w.u64(state.first as u64);
        w.u64(state.sample as u64);
        w.u32(state.raw.len() as u32);
        for (accelerations, contact) in &state.raw {
            accelerations.iter().chain(contact).for_each(|&x| w.f64(x));
        }
        write_position(&mut w, self.noise.position());
        w.f64s(&self.current_noise);
        w.0
    }

    fn restore(&mut self, saved: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(saved);
        let (time, origin, u, v) = (r.f64()?, r.f64()?, r.f64s()?, r.f64s()?);
        let a_previous = match r.u8()? {
            0 => None,
            _ => Some(r.f64s()?),
        };
        let (first, sample) = (r.u64()? as usize, r.u64()? as usize);
        let n = r.u32()? as usize;
        if n > saved.len() / (11 * 8) {
            return Err("the plant state is truncated".into());
        }
        let mut raw = Vec::with_capacity(n);
        for _ in 0..n {
            let mut row = [0.0; 11];
            for x in &mut row {
                *x = r.f64()?;
            }
            raw.push((std::array::from_fn(|c| row[c]), std::array::from_fn(|j| row[7 + j])));
        }
        let position = read_position(&mut r)?;
        let current_noise: [f64; 7] = r.f64s()?.try_into().map_err(|_| "the S2 plant has seven sensors")?;
        r.finish()?;
        let simulation = SimulationState { time, origin, u, v, a_previous };
        let mut recording = self.recording.clone();
        recording.resume(&RecordingState { simulation, raw, first, sample })?;
        self.recording = recording;
        self.noise.set_position(position);
        self.current_noise = current_noise;
        Ok(())
    }
}
