//! One S4 run through the packaged estimator FMU (`kalfmu_s4_maglev`), driven as the
//! train's computer drives it ([`cosim::master`]): at each telegram the four
//! channels' positions (NaN where a telegram did not arrive; a resent one as it came) and
//! no marker. The user sets the study's tuning (the channels' noise, the motion's jerk,
//! the prior, its position from the first telegrams); the rest is the FMU's defaults, the
//! study's set-up, and the user's start values go over both. The log has the true
//! position and speed, and the FMU's fixed-lag smoothed position and speed (`/smoothed`,
//! `smoothing_lag` [`crate::smoothed::SMOOTHING_LAG`]: 5 telegrams).

use std::collections::BTreeMap;
use std::path::Path;

use estimator::FilterKind;
use log_format::write::SignalSpec;
use start_values::StartValues;

use super::ours::{first_position, Tuning, CHANNEL_NOISE_PARAMETERS};
use cosim::fmu_driver::ImportedFmu;
use cosim::master::{self, Counts, Setup};
use truth::s4::recording::Recording;

/// The FMU's identifier.
pub const IDENTIFIER: &str = "kalfmu_s4_maglev";

/// The FMU's inputs: the four channels in [`truth::s4::channels::Channel::ALL`]'s order, then the marker.
const INPUTS: [(&str, &str); 5] = [
    ("P_head_left", "head-left channel's position telegram (NaN: not received)"),
    ("P_head_right", "head-right channel's position telegram (NaN: not received)"),
    ("P_tail_left", "tail-left channel's position telegram (NaN: not received)"),
    ("P_tail_right", "tail-right channel's position telegram (NaN: not received)"),
    ("marker_position", "absolute position at a marker (none in these runs)"),
];

/// The FMU's outputs an in-process run of ours gives too, and which `reproduce` checks
/// against it: position and speed, then the channels' offsets and weights.
pub const COMPARED: [&str; 10] = [
    "position",
    "speed",
    "offset_head_left",
    "offset_head_right",
    "offset_tail_left",
    "offset_tail_right",
    "weight_head_left",
    "weight_head_right",
    "weight_tail_left",
    "weight_tail_right",
];

/// The FMU's other outputs that are logged.
const OTHER_OUTPUTS: [&str; 7] =
    ["position_std", "speed_std", "acceleration", "acceleration_std", "fused_speed", "fused_speed_std", "nis"];

/// The FMU's outputs whose fixed-lag smoothed values are logged on `/smoothed`: those the
/// truth has.
pub const SMOOTHED: [&str; 2] = ["position", "speed"];

/// What the user sets: every number of `tuning` (the channels' noise, the jerk, the
/// prior: its position by default the first telegrams' mean less their levers, as
/// [`super::ours::run`] starts), and the recording's telegram interval as the sample time.
/// [`Tuning::set`] takes each of these names but `sample_time`.
pub fn parameters(recording: &Recording, tuning: &Tuning) -> Vec<(&'static str, f64)> {
    let mut p = vec![
        ("sample_time", recording.telegram_interval),
        ("jerk_intensity", tuning.jerk_intensity),
        ("offset_walk", tuning.offset_walk),
        ("prior_position", tuning.prior_position.unwrap_or_else(|| first_position(recording))),
        ("prior_position_std", tuning.position_prior_std),
        ("prior_speed", tuning.prior_speed),
        ("prior_speed_std", tuning.speed_prior_std),
        ("prior_acceleration", tuning.prior_acceleration),
        ("prior_acceleration_std", tuning.acceleration_prior_std),
        ("prior_offset_std", tuning.offset_prior_std),
        ("r_marker_position_std", tuning.marker_noise_std),
        ("ukf_alpha", tuning.unscented.alpha),
        ("ukf_beta", tuning.unscented.beta),
        ("ukf_kappa", tuning.unscented.kappa),
    ];
    p.extend(CHANNEL_NOISE_PARAMETERS.into_iter().zip(tuning.channel_noise_std));
    p
}

/// Runs `kind` through the FMU over `recording` and writes the log to `log`, with the FMU's
/// smoothed position and speed (`smoothing_lag` set beside [`parameters`]: not a number of
/// the tuning, the in-process filter has none).
pub fn run(
    fmu: &ImportedFmu,
    kind: FilterKind,
    recording: &Recording,
    tuning: &Tuning,
    case: &str,
    start_values: &StartValues,
    log: &Path,
) -> anyhow::Result<Counts> {
    let mut parameters = parameters(recording, tuning);
    parameters.push(("smoothing_lag", crate::smoothed::SMOOTHING_LAG));
    // Speed first: the study is about it, and the recording's first tab is the first signal's.
    let truth = [
        SignalSpec::new("speed", "m/s", "true speed of the reference point"),
        // The requirement the study is judged by, drawn and scored by the analyzer
        // (`X_tolerance`, docs/log-format.md).
        SignalSpec::new(
            "speed_tolerance",
            "m/s",
            "ETCS speed accuracy (SUBSET-041 §5.3.1): ±2 km/h below 30 km/h, rising linearly to ±12 km/h at 500 km/h",
        ),
        SignalSpec::new("position", "m", "true position of the reference point"),
    ];
    let metadata = BTreeMap::from([("study".to_string(), "S4".to_string()), ("case".to_string(), case.to_string())]);
    let outputs = [COMPARED.as_slice(), &OTHER_OUTPUTS].concat();
    let setup = Setup {
        fmu,
        filter: kind,
        parameters: &parameters,
        integers: &[],
        start_values,
        inputs: &INPUTS,
        outputs: &outputs,
        smoothed: &SMOOTHED,
        truth: &truth,
        metadata,
    };
    let times: Vec<f64> = (0..recording.n_telegrams()).map(|k| recording.time(k)).collect();
    master::run(
        &setup,
        &times,
        recording.telegram_interval,
        |k| {
            let mut z: Vec<f64> =
                (0..4).map(|c| if recording.received[c][k] { recording.position[c][k] } else { f64::NAN }).collect();
            z.push(f64::NAN);
            z
        },
        |k| {
            let truth = &recording.truth[k];
            vec![truth.speed, super::metrics::etcs_speed_band(truth.speed), truth.position]
        },
        log,
        |_| {},
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use start_values::SetByName;
    use truth::s4::channels::simulate;
    use truth::s4::faults::Faults;
    use truth::s4::profile::Profile;

    /// Every number the FMU runs are given but the recording's clock is one the
    /// in-process filter takes by the same name, so that a start value reaches both.
    #[test]
    fn set_changes_exactly_the_parameter_of_its_name() {
        let recording = simulate(&Profile::paper(), &Faults::none(), 1);
        let tuning = Tuning::paper();
        let study = parameters(&recording, &tuning);
        let mut names: Vec<&str> = study.iter().map(|(n, _)| *n).filter(|&n| n != "sample_time").collect();
        names.sort_unstable();
        let mut taken = Tuning::NAMES.to_vec();
        taken.sort_unstable();
        assert_eq!(names, taken);
        for &(name, old) in &study {
            let mut changed = tuning;
            if name == "sample_time" {
                assert!(changed.set(name, 2.0 * old).is_err(), "the clock is the recording's");
                continue;
            }
            let new = 1.5 * old + 0.25;
            changed.set(name, new).unwrap();
            for (&(n, before), (m, after)) in study.iter().zip(parameters(&recording, &changed)) {
                assert_eq!(n, m);
                assert_eq!(after, if n == name { new } else { before }, "{n} after setting {name}");
            }
        }
    }

    #[test]
    fn set_refuses_names_it_does_not_have_and_values_the_fmu_refuses() {
        let mut tuning = Tuning::paper();
        let unknown = tuning.set("gate_probability", 0.99).unwrap_err();
        assert!(unknown.contains("gate_probability") && unknown.contains("jerk_intensity"), "{unknown}");
        assert!(tuning.set("jerk_intensity", -1.0).is_err());
        assert!(tuning.set("prior_speed", f64::NAN).is_err());
        assert!(tuning.set("prior_speed", -3.0).is_ok(), "a mean may be negative");
        assert_eq!(tuning, Tuning { prior_speed: -3.0, ..Tuning::paper() }, "a refused value changes nothing");
    }
}
