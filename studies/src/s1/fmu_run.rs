//! One S1 case through the packaged estimator FMU, driven as a co-simulation master
//! drives it ([`cosim::master`]): the chain and the study's tuning as parameters, the
//! two noisy accelerations as inputs; the log has the true load and motion beside them,
//! and the FMU's fixed-lag smoothed load (`/smoothed`).

use std::collections::BTreeMap;
use std::path::Path;

use estimator::FilterKind;
use log_format::write::SignalSpec;
use start_values::StartValues;

use super::Tuning;
use cosim::fmu_driver::ImportedFmu;
use cosim::master::{self, Setup};
use truth::s1::plant::Truth;
use truth::s1::{Case, Measurements, Settings};

/// The FMU's inputs, in the order of the measurement vector.
const INPUTS: [(&str, &str); 2] =
    [("z1_ddot", "measured acceleration of mass 1"), ("z2_ddot", "measured acceleration of mass 2")];

/// The FMU's outputs that are logged on `/estimate`; those without `_std`
/// have a namesake on `/truth`.
const OUTPUTS: [&str; 13] = [
    "F",
    "F_std",
    "z1",
    "z1_std",
    "z2",
    "z2_std",
    "z1_dot",
    "z1_dot_std",
    "z2_dot",
    "z2_dot_std",
    "F_dot",
    "F_dot_std",
    "nis",
];

/// The FMU's Real parameters of a case: the paper's chain, the sample time and the
/// study's one tuning.
pub(crate) fn parameters(tuning: &Tuning, case: &Case, settings: &Settings) -> Vec<(&'static str, f64)> {
    let mut p = truth::s1::chain_parameters(&case.chain()).to_vec();
    p.push(("sample_time", settings.dt()));
    p.push(("smoothing_lag", crate::smoothed::SMOOTHING_LAG));
    p.extend(tuning.fmu_parameters());
    p
}

/// One simulated case: what the truth simulator produced for it.
pub struct Simulated<'a> {
    /// The case.
    pub case: &'a Case,
    /// The study settings.
    pub settings: &'a Settings,
    /// The true history.
    pub truth: &'a Truth,
    /// The noisy accelerations.
    pub measurements: &'a Measurements,
    /// The user's start values over the study's parameters.
    pub start_values: &'a StartValues,
}

/// Runs `kind` on a simulated case through the FMU and writes the log to
/// `log`; `progress` is called every 1000 samples.
pub fn run(
    fmu: &ImportedFmu,
    kind: FilterKind,
    sim: &Simulated<'_>,
    log: &Path,
    progress: &dyn Fn(),
) -> anyhow::Result<()> {
    let Simulated { case, settings, truth, measurements, start_values } = *sim;
    let tuning = Tuning::new(settings, measurements.noise_std);
    let params = parameters(&tuning, case, settings);
    let integers = tuning.fmu_integers();
    let truth_names = ["F", "z1", "z2", "z1_dot", "z2_dot", "F_dot"];
    let truth_specs: Vec<SignalSpec> =
        truth_names.iter().map(|n| SignalSpec::new(n, &fmu.unit(n), "true value (truth simulator)")).collect();
    let metadata = BTreeMap::from([
        ("study".to_string(), "S1".to_string()),
        ("case".to_string(), case.to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("noise_fraction".to_string(), settings.noise_fraction.to_string()),
    ]);
    let setup = Setup {
        fmu,
        filter: kind,
        parameters: &params,
        integers: &integers,
        start_values,
        inputs: &INPUTS,
        outputs: &OUTPUTS,
        smoothed: &["F"],
        truth: &truth_specs,
        metadata,
    };
    master::run(
        &setup,
        &truth.time,
        settings.dt(),
        |k| measurements.acceleration[k].to_vec(),
        |k| {
            let [z1, z2, v1, v2] = truth.motion[k];
            vec![truth.load[k], z1, z2, v1, v2, truth.load_rate[k]]
        },
        log,
        |k| {
            if k % 1000 == 999 {
                progress();
            }
        },
    )?;
    Ok(())
}
