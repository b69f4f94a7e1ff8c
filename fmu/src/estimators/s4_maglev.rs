//! The S4 estimator: a maglev train's position, speed and acceleration from its four
//! long-stator (PRW) position channels, each channel's offset a state
//! (`estimator::models::PrwTrain`), an absolute marker when one passes. Resent telegrams
//! are stuck from their first repeat, spikes fail the gate, slot slips are the
//! supervisor's quantised bias steps of one slot pitch (`studies::s4::ours`).

use estimator::models::PrwTrain;
use estimator::{
    build_filter, FilterKind, Gaussian, Noise, QuantizedSteps, StateEstimator, SupervisorSettings, UnscentedParams,
};
use nalgebra::DMatrix;

use super::{bound_from_prior, DefaultExperiment, Descriptor, MAX_DERIVED};
use crate::timing::Reading;
use crate::variables::{Parameters, Role, Variable};

/// One channel's variables.
struct ChannelVariables {
    /// The position input.
    input: &'static str,
    /// Its fault flag.
    fault: &'static str,
    /// Its sensor noise parameter.
    sensor_std: &'static str,
    /// The lever parameter and its default (m: head ahead of the reference point, tail
    /// behind, 50 m apart [est: `docs/studies/s4.md`]).
    lever: (&'static str, f64),
    /// The offset state's output and its σ.
    offset: (&'static str, &'static str),
    /// The weight output.
    weight: &'static str,
}

/// The four channels, in measurement-row order.
const CHANNELS: [ChannelVariables; 4] = [
    ChannelVariables {
        input: "P_head_left",
        fault: "P_head_left_fault",
        sensor_std: "r_P_head_left_std",
        lever: ("lever_head_left", 25.0),
        offset: ("offset_head_left", "offset_head_left_std"),
        weight: "weight_head_left",
    },
    ChannelVariables {
        input: "P_head_right",
        fault: "P_head_right_fault",
        sensor_std: "r_P_head_right_std",
        lever: ("lever_head_right", 25.0),
        offset: ("offset_head_right", "offset_head_right_std"),
        weight: "weight_head_right",
    },
    ChannelVariables {
        input: "P_tail_left",
        fault: "P_tail_left_fault",
        sensor_std: "r_P_tail_left_std",
        lever: ("lever_tail_left", -25.0),
        offset: ("offset_tail_left", "offset_tail_left_std"),
        weight: "weight_tail_left",
    },
    ChannelVariables {
        input: "P_tail_right",
        fault: "P_tail_right_fault",
        sensor_std: "r_P_tail_right_std",
        lever: ("lever_tail_right", -25.0),
        offset: ("offset_tail_right", "offset_tail_right_std"),
        weight: "weight_tail_right",
    },
];

/// The marker input (measurement row 4).
const MARKER: &str = "marker_position";

/// The derived outputs: the fused speed and its σ, then the four weights.
const FUSED_SPEED: usize = 0;
const FUSED_SPEED_STD: usize = 1;
const WEIGHTS: usize = 2;

/// A motion state: its output and σ, unit, prior mean and σ parameters with their
/// defaults, description.
struct MotionState {
    output: &'static str,
    std: &'static str,
    unit: &'static str,
    prior: (&'static str, f64),
    prior_std: (&'static str, f64),
    description: &'static str,
}

const MOTION: [MotionState; 3] = [
    MotionState {
        output: "position",
        std: "position_std",
        unit: "m",
        prior: ("prior_position", 0.0),
        prior_std: ("prior_position_std", 1.0),
        description: "position of the reference point along the guideway: the true one plus the mean of the channels' offsets (exact with markers)",
    },
    MotionState {
        output: "speed",
        std: "speed_std",
        unit: "m/s",
        prior: ("prior_speed", 0.0),
        prior_std: ("prior_speed_std", 150.0),
        description: "filtered speed: the reference point's speed at the time read",
    },
    MotionState {
        output: "acceleration",
        std: "acceleration_std",
        unit: "m/s2",
        prior: ("prior_acceleration", 0.0),
        prior_std: ("prior_acceleration_std", 3.0),
        description: "the reference point's acceleration",
    },
];

pub(super) fn descriptor() -> Descriptor {
    let non_negative = |var: Variable| var.bounded(Some(0.0), None);
    let mut v = Vec::new();
    for (row, channel) in CHANNELS.iter().enumerate() {
        v.push(Variable::measurement(
            channel.input,
            "m",
            row,
            "the channel's position telegram: the sensor's position along the guideway (NaN: not received; a repeat bit for bit is a resent telegram)",
        ));
    }
    v.push(
        Variable::measurement(
            MARKER,
            "m",
            PrwTrain::MARKER,
            "the reference point's absolute position read at a marker as one passes (NaN between markers)",
        )
        .intermittent(),
    );
    for (row, channel) in CHANNELS.iter().enumerate() {
        v.push(Variable::flag(
            channel.fault,
            Role::ChannelFault(row),
            "the channel is faulty: rejected by the gate, stuck (resent) or missing for fault_after telegrams in a row",
        ));
    }
    for (i, m) in MOTION.iter().enumerate() {
        v.push(Variable::output(m.output, m.unit, Role::Estimate(i), m.description));
        v.push(Variable::output(m.std, m.unit, Role::EstimateStd(i), "standard deviation of the estimate"));
    }
    v.push(Variable::output(
        "fused_speed",
        "m/s",
        Role::Derived(FUSED_SPEED),
        "fused speed: the mean speed over the last telegram interval, v - a·sample_time/2 (what the paper's ΔP/Δt reads)",
    ));
    v.push(Variable::output(
        "fused_speed_std",
        "m/s",
        Role::Derived(FUSED_SPEED_STD),
        "standard deviation of the fused speed",
    ));
    for (c, channel) in CHANNELS.iter().enumerate() {
        let (offset, offset_std) = channel.offset;
        v.push(Variable::output(
            offset,
            "m",
            Role::Estimate(PrwTrain::OFFSETS + c),
            "the channel's offset: its installation error and slot slips",
        ));
        v.push(Variable::output(
            offset_std,
            "m",
            Role::EstimateStd(PrwTrain::OFFSETS + c),
            "standard deviation of the offset",
        ));
        v.push(Variable::output(
            channel.weight,
            "1",
            Role::Derived(WEIGHTS + c),
            "the channel's share in the speed's correction by the next telegram (0 while it is faulty)",
        ));
    }
    for &ChannelVariables { lever: (lever, default), .. } in &CHANNELS {
        v.push(Variable::parameter(lever, "m", default, "the channel's sensor ahead of the reference point"));
    }
    for m in &MOTION {
        v.push(Variable::parameter(m.prior.0, m.unit, m.prior.1, "prior mean of the state"));
        let (std, deviation) = m.prior_std;
        v.push(non_negative(Variable::parameter(std, m.unit, deviation, "prior standard deviation of the state")));
    }
    v.push(non_negative(Variable::parameter(
        "prior_offset_std",
        "m",
        0.05,
        "prior standard deviation of each channel's offset (around 0)",
    )));
    v.extend([
        non_negative(Variable::tunable(
            "jerk_intensity",
            "m2/s5",
            10.0,
            "white-jerk intensity of the constant-acceleration model (10: jumps of the acceleration; 0.01: jerk-limited runs)",
        )),
        non_negative(Variable::tunable(
            "offset_walk",
            "m2/s",
            0.0,
            "random-walk intensity of the channels' offsets (0: constants)",
        )),
    ]);
    for channel in &CHANNELS {
        v.push(non_negative(Variable::tunable(channel.sensor_std, "m", 1.5e-3, "noise std of the channel's position")));
    }
    v.push(non_negative(Variable::tunable("r_marker_position_std", "m", 0.01, "noise std of a marker reading")));
    v.extend([
        Variable::parameter("slot_pitch", "m", 0.086, "the long stator's slot pitch: the step of a slot slip")
            .bounded(Some(1e-6), None),
        Variable::integer_parameter(
            "slip_after",
            3,
            (2, 1_000_000),
            "telegrams in a row a channel must be rejected at the same multiple of the slot pitch to be re-based by it",
        ),
        Variable::parameter(
            "slip_tolerance",
            "m",
            0.01,
            "how close to the multiple of the slot pitch the channel's innovation must come",
        )
        .bounded(Some(1e-9), None),
    ]);
    Descriptor {
        model_identifier: "kalfmu_s4_maglev",
        model_name: "kalfmu S4 maglev speed and position from four PRW channels",
        description: "Fuses a maglev train's four long-stator position channels into its position, speed and acceleration, flagging faulty channels",
        documentation: "<p>Study S4, after <i>Weighted fusion-based unscented Kalman filter positioning algorithm for normal-conducting high-speed maglev trains</i> (2024): four redundant long-stator (PRW) position channels, head and tail, \
         left and right, a telegram every {sample_time}, fused into the train's position, speed and acceleration \
         with their σ. The paper differences each channel's positions into a speed, rejects outliers by Grubbs' test, weights \
         the rest adaptively and runs a UKF on the fused speed; this estimator filters the four positions instead \
         (a constant-acceleration model driven by white jerk, each channel's offset a state), which does not \
         multiply the position noise by √2/sample_time as differencing consecutive telegrams does.</p>\
         <p>Faults: a telegram not received is NaN (missing); a resent telegram repeats the last position bit for \
         bit and is left out from its first repeat, hence {stuck_after}; a spike fails the innovation gate; a slot \
         slip (the channel reads a slot pitch off from then on) is seen as {slip_after} rejected telegrams within \
         {slip_tolerance} of the same multiple of {slot_pitch} and re-based into the channel's offset; an \
         installation offset is learnt in the offset. Without markers the position is the reference point plus the mean of the four offsets, which no \
         data separates; a marker reading pins it.</p>\
         <p>Outputs: speed is the speed at the time read (the filtered speed); fused_speed is the mean speed over \
         the last telegram interval, v - a·sample_time/2, the quantity the paper's ΔP/Δt estimates; each channel's \
         weight is its share in the speed's correction by the next telegram, 0 while it is faulty.</p>\
         <p>Defaults: the paper's test run ({jerk_intensity} for its jumps of 2.5 m/s²; 0.01 for a jerk-limited \
         run to 500 km/h), channel noise {r_P_head_left_std}, {r_P_head_right_std}, {r_P_tail_left_std}, \
         {r_P_tail_right_std}, offsets within {prior_offset_std}, levers {lever_head_left}, {lever_head_right}, \
         {lever_tail_left}, {lever_tail_right}. Set <code>prior_position</code> to the first telegrams' mean less \
         their levers.</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 113.9, step: 0.02 },
        build_filter: build,
        build_noise: noise,
        default_filter: FilterKind::SrCkf,
        // A live position channel never repeats a reading bit for bit: a resent telegram
        // is stuck from its first repeat.
        // The acceleration's noise adapts upwards only: learnt on a steady
        // run, its scale falls until the speed lags the braking after a
        // dropout (seed 1: the largest speed error 0.41 m/s instead of 0.11,
        // the position 0.049 m instead of 0.0045, though the mean error falls
        // from 0.016 to 0.009 m/s). The jumps are taken. The wiring is
        // checked: four telegrams of one position contradict each other (a
        // flipped telegram is named 0.78 s after it starts: kalfmu robustness --wiring).
        supervision: SupervisorSettings {
            stuck_after: 2,
            min_process_noise_scale: 1.0,
            wiring_sigmas: 8.0,
            wiring_leaves_out: true,
            ..SupervisorSettings::default()
        },
        derive,
        build_steps: steps,
        unknown_inputs: &PrwTrain::UNKNOWN_INPUTS,
        // The motion: position, speed and acceleration (the offsets are means to it).
        plausible_bound: bound_from_prior,
        smoothed_states: &[0, 1, 2],
        guid: String::new(),
    }
    .finish()
}

fn model(p: &Parameters) -> Result<PrwTrain, String> {
    let mut levers = [0.0; 4];
    for (lever, channel) in levers.iter_mut().zip(&CHANNELS) {
        *lever = p.finite(channel.lever.0)?;
    }
    Ok(PrwTrain {
        marker: true,
        jerk_intensity: p.non_negative("jerk_intensity")?,
        offset_walk: p.non_negative("offset_walk")?,
        ..PrwTrain::new(levers)
    })
}

fn build(
    p: &Parameters,
    kind: FilterKind,
    ukf: UnscentedParams,
    noise: Noise,
) -> Result<Box<dyn StateEstimator>, String> {
    let mut mean = vec![0.0; PrwTrain::STATES];
    let mut variances = vec![p.non_negative("prior_offset_std")?.powi(2); PrwTrain::STATES];
    for (i, m) in MOTION.iter().enumerate() {
        mean[i] = p.finite(m.prior.0)?;
        variances[i] = p.non_negative(m.prior_std.0)?.powi(2);
    }
    let prior = Gaussian::diagonal(&mean, &variances);
    build_filter(kind, model(p)?, noise, &prior, ukf).map_err(|e| e.to_string())
}

/// `Q` over `dt` from the jerk and the offsets' walk (exact), `R` from each channel's and
/// the marker's noise.
fn noise(p: &Parameters, dt: f64) -> Result<Noise, String> {
    let q = model(p)?.process_noise(dt);
    let mut r = DMatrix::zeros(PrwTrain::MARKER + 1, PrwTrain::MARKER + 1);
    for (c, channel) in CHANNELS.iter().enumerate() {
        r[(c, c)] = p.non_negative(channel.sensor_std)?.powi(2);
    }
    r[(PrwTrain::MARKER, PrwTrain::MARKER)] = p.non_negative("r_marker_position_std")?.powi(2);
    Noise::new(q, r).map_err(|e| e.to_string())
}

/// Slot slips: steps of one slot pitch in a channel's offset; the marker has none.
fn steps(p: &Parameters) -> Result<Option<QuantizedSteps>, String> {
    Ok(Some(QuantizedSteps {
        quantum: p.positive("slot_pitch")?,
        after: p.positive("slip_after")? as u32,
        tolerance: p.positive("slip_tolerance")?,
        bias_states: model(p)?.bias_states(),
    }))
}

/// The fused speed with its σ, and the channels' weights, from the belief read.
fn derive(p: &Parameters, reading: &Reading<'_>, out: &mut [f64]) {
    debug_assert!(out.len() >= WEIGHTS + 4 && WEIGHTS + 4 <= MAX_DERIVED);
    let covariance = reading.belief.covariance();
    let dt = p.get("sample_time").unwrap_or(f64::NAN);
    (out[FUSED_SPEED], out[FUSED_SPEED_STD]) =
        PrwTrain::interval_speed(reading.belief.mean().as_slice(), &covariance, dt);
    let mut r = [f64::NAN; 4];
    for (rc, channel) in r.iter_mut().zip(&CHANNELS) {
        *rc = p.get(channel.sensor_std).map_or(f64::NAN, |s| s * s);
    }
    let included: [bool; 4] = std::array::from_fn(|c| !reading.faulty[c]);
    out[WEIGHTS..WEIGHTS + 4].copy_from_slice(&PrwTrain::speed_weights(&covariance, r, included));
}
