//! One S1 case through the packaged estimator FMU, driven as a co-simulation master
//! drives it ([`cosim::master`]): the chain and the study's tuning as parameters, the
//! two noisy accelerations as inputs; the log has the true load and motion beside them.

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

/// The FMU parameters of a case: the paper's chain and the study's one tuning.
fn parameters(case: &Case, settings: &Settings, measurements: &Measurements) -> Vec<(&'static str, f64)> {
    let chain = case.chain();
    let (k, c) = (chain.k1, chain.c1);
    let (ks, kb) = (k.slopes(), k.breaks());
    let (cs, cb) = (c.slopes(), c.breaks());
    // A linear element is a law of three equal slopes; its breakpoints are then irrelevant.
    let breaks = |b: [f64; 2], default: [f64; 2]| if b[0].is_finite() { b } else { default };
    let (kb, cb) = (breaks(kb, [0.1, 0.2]), breaks(cb, [0.05, 0.1]));
    let mut p = vec![
        ("m1", chain.m1),
        ("m2", chain.m2),
        ("k11", ks[0]),
        ("k12", ks[1]),
        ("k13", ks[2]),
        ("delta1", kb[0]),
        ("delta2", kb[1]),
        ("c11", cs[0]),
        ("c12", cs[1]),
        ("c13", cs[2]),
        ("eps1", cb[0]),
        ("eps2", cb[1]),
        ("k2", chain.k2),
        ("c2", chain.c2),
        ("sample_time", settings.dt()),
        ("ukf_alpha", 1.0),
        ("ukf_beta", 2.0),
        ("ukf_kappa", 0.0),
    ];
    p.extend(Tuning::new(settings, measurements.noise_std).fmu_parameters());
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
    let params = parameters(case, settings, measurements);
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
        integers: &[("rk4_substeps", 1)],
        start_values,
        inputs: &INPUTS,
        outputs: &OUTPUTS,
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
