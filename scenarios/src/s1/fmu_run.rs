//! One S1 case through the packaged estimator FMU, driven as a co-simulation
//! master drives it: at each sample instant `t` the truth simulator's noisy
//! accelerations of `t` are set as the FMU's inputs, the outputs are read
//! (the estimate at `t` given the measurements up to `t`, by direct
//! feedthrough), `fmi2DoStep(t, dt)` is called, and the outputs are read
//! again (the estimate at `t + dt` predicted from the measurements up to `t`).
//! The run is logged in the kalfmu MCAP format (`docs/log-format.md`): the
//! measurements, the truth, both readings (`/estimate`, `/prediction`).

use std::collections::BTreeMap;
use std::path::Path;

use analyzer::log::{LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, PREDICTION, TRUTH};
use anyhow::Context;
use estimator::FilterKind;

use super::plant::Truth;
use super::{Case, Measurements, Settings, Tuning};
use crate::fmu_driver::{filter_enumeration, ImportedFmu};

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
    let Simulated { case, settings, truth, measurements } = *sim;
    let dt = settings.dt();
    let instants = truth.time.len();
    let params = parameters(case, settings, measurements);
    let mut instance = fmu.instantiate(
        &format!("s1-{case}-{kind}"),
        truth.time[0],
        truth.time[instants - 1],
        &params,
        &[("filter", filter_enumeration(kind)), ("rk4_substeps", 1)],
    )?;
    let inputs = [fmu.vr("z1_ddot")?, fmu.vr("z2_ddot")?];
    let outputs: Vec<u32> = OUTPUTS.iter().map(|n| fmu.vr(n)).collect::<anyhow::Result<_>>()?;

    let parameters_json =
        serde_json::to_string(&params.iter().map(|(n, v)| (n.to_string(), *v)).collect::<BTreeMap<_, _>>())?;
    let metadata = BTreeMap::from([
        ("study".to_string(), "S1".to_string()),
        ("case".to_string(), case.to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("filter".to_string(), kind.name().to_string()),
        ("noise_fraction".to_string(), settings.noise_fraction.to_string()),
        ("parameters".to_string(), parameters_json),
        ("software".to_string(), format!("kalfmu {}", env!("CARGO_PKG_VERSION"))),
    ]);
    let mut w = LogWriter::create(log, &metadata)?;
    let unit = |n: &str| fmu.unit(n);
    let ch_m = w.add_channel(
        MEASUREMENTS,
        &[
            SignalSpec::new("z1_ddot", &unit("z1_ddot"), "measured acceleration of mass 1"),
            SignalSpec::new("z2_ddot", &unit("z2_ddot"), "measured acceleration of mass 2"),
        ],
    )?;
    let truth_names = ["F", "z1", "z2", "z1_dot", "z2_dot", "F_dot"];
    let truth_specs: Vec<SignalSpec> =
        truth_names.iter().map(|n| SignalSpec::new(n, &unit(n), "true value (truth simulator)")).collect();
    let ch_t = w.add_channel(TRUTH, &truth_specs)?;
    let specs =
        |what: &str| -> Vec<SignalSpec> { OUTPUTS.iter().map(|n| SignalSpec::new(n, &unit(n), what)).collect() };
    let ch_e = w.add_channel(ESTIMATE, &specs("FMU output read at t after the inputs of t were set"))?;
    let ch_p = w.add_channel(PREDICTION, &specs("FMU output read right after fmi2DoStep(t - dt, dt)"))?;

    let mut out = vec![0.0; outputs.len()];
    for k in 0..instants {
        let (t, z) = (truth.time[k], measurements.acceleration[k]);
        let context = || format!("{case} {kind} at t = {t} s");
        instance.set_inputs(&inputs, &z).with_context(context)?;
        instance.read(&outputs, &mut out).with_context(context)?;
        let [z1, z2, v1, v2] = truth.motion[k];
        w.write(ch_m, t, &z)?;
        w.write(ch_t, t, &[truth.load[k], z1, z2, v1, v2, truth.load_rate[k]])?;
        w.write(ch_e, t, &out)?;
        if k + 1 < instants {
            instance.do_step(dt).with_context(context)?;
            instance.read(&outputs, &mut out).with_context(context)?;
            w.write(ch_p, truth.time[k + 1], &out)?;
        }
        if k % 1000 == 999 {
            progress();
        }
    }
    instance.terminate()?;
    w.finish()?;
    Ok(())
}
