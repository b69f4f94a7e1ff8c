//! A study's system of FMUs (a plant FMU wired to an estimator FMU in an SSP archive) run
//! by the Jacobi master over the `fmi` importer (`cosim::system_master`), and scored: each
//! estimate against the plant's true value of the same name at the same time stamps, and
//! how fast the whole system ran. Each study says what its system holds (`s1/system.rs`,
//! `s2/system.rs`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use cosim::fmu_driver::ImportedFmu;
use cosim::ssp::{self, Component, Connection, Experiment, System};
use cosim::system_master::{self, Recorded};
use log_format::read::{read_log, Channel};
use log_format::write::{ESTIMATE, TRUTH};
use start_values::ssv::{Parameter, ParameterSet, ValueKind};
use start_values::StartValues;

/// The components' names in every study's system.
pub const PLANT: &str = "plant";
/// See [`PLANT`].
pub const ESTIMATOR: &str = "estimator";

/// The parameter set of a study's system: its FMUs' parameters bound as
/// `<component>.<name>`.
#[derive(Debug, Clone)]
pub struct Bindings(ParameterSet);

impl Bindings {
    /// No binding yet, in a set named `name`.
    pub fn new(name: &str) -> Self {
        Self(ParameterSet::new(name))
    }

    /// Binds `component.name` to `value`, over an earlier binding of that name.
    pub fn put(&mut self, component: &str, name: &str, value: f64, kind: ValueKind) {
        let name = format!("{component}.{name}");
        self.0.parameters.retain(|p| p.name != name);
        self.0.parameters.push(Parameter { name, value, kind, unit: None, description: None });
    }

    /// The user's start values over the estimator's bindings, each of the type the FMU
    /// gives its variable; refused for a name the FMU does not have.
    pub fn start_values(&mut self, start_values: &StartValues, estimator: &ImportedFmu) -> anyhow::Result<()> {
        for (name, value) in start_values.iter() {
            let kind =
                estimator.value_kind(name).with_context(|| format!("start value {name}: no parameter of the FMU"))?;
            self.put(ESTIMATOR, name, value, kind);
        }
        Ok(())
    }

    /// The set, every estimator binding checked to name a variable of `estimator`: a
    /// renamed parameter fails here, not in a run.
    pub fn checked(self, estimator: &ImportedFmu) -> anyhow::Result<ParameterSet> {
        for p in &self.0.parameters {
            if let Some(name) = p.name.strip_prefix("estimator.") {
                estimator.value_kind(name).with_context(|| format!("{name} is no parameter of the estimator FMU"))?;
            }
        }
        Ok(self.0)
    }
}

/// The system of a study: the plant FMU `plant_id` with its outputs `measured` connected to
/// the inputs of the same names of the estimator FMU `estimator_id` (each as
/// `resources/<id>.fmu`), `parameters` bound, over `experiment`.
pub fn plant_to_estimator(
    name: &str,
    (plant_id, estimator_id): (&str, &str),
    measured: &[&str],
    parameters: ParameterSet,
    experiment: Experiment,
) -> System {
    let connectors = |input: bool| measured.iter().map(|n| (n.to_string(), input)).collect();
    let source = |id: &str| format!("resources/{id}.fmu");
    System {
        name: name.into(),
        components: vec![
            Component { name: PLANT.into(), source: source(plant_id), connectors: connectors(false) },
            Component { name: ESTIMATOR.into(), source: source(estimator_id), connectors: connectors(true) },
        ],
        connections: measured
            .iter()
            .map(|n| Connection { from: (PLANT.into(), n.to_string()), to: (ESTIMATOR.into(), n.to_string()) })
            .collect(),
        parameters,
        experiment,
    }
}

/// Writes `system` as an `.ssp` at `out`, each component's FMU the packaged one of the same
/// file name in `fmu_dir` (where `package-fmus` writes them).
pub fn write(system: &System, fmu_dir: &Path, out: &Path) -> anyhow::Result<()> {
    let files: Vec<(&str, PathBuf)> = system
        .components
        .iter()
        .map(|c| {
            let file = Path::new(&c.source).file_name().with_context(|| format!("{} names no file", c.source))?;
            Ok((c.source.as_str(), fmu_dir.join(file)))
        })
        .collect::<anyhow::Result<_>>()?;
    let fmus: Vec<(&str, &Path)> = files.iter().map(|(source, path)| (*source, path.as_path())).collect();
    ssp::write(system, &fmus, out)
}

/// An estimate against the truth at the same time stamps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairFigures {
    /// Time stamps compared.
    pub samples: usize,
    /// RMSE over the whole run.
    pub rmse: f64,
    /// Correlation of the estimate with the truth.
    pub correlation: f64,
    /// Fraction of the time stamps whose error is within ±2σ.
    pub two_sigma_coverage: f64,
}

impl PairFigures {
    /// The figures of `estimate` (σ `sigma`) against `truth`.
    pub fn of(estimate: &[f64], sigma: &[f64], truth: &[f64]) -> Self {
        let n = estimate.len();
        let mean = |x: &[f64]| x.iter().sum::<f64>() / n as f64;
        let (me, mt) = (mean(estimate), mean(truth));
        let (mut see, mut stt, mut set, mut sq, mut covered) = (0.0, 0.0, 0.0, 0.0, 0);
        for ((e, t), s) in estimate.iter().zip(truth).zip(sigma) {
            let (de, dt) = (e - me, t - mt);
            see += de * de;
            stt += dt * dt;
            set += de * dt;
            sq += (e - t) * (e - t);
            covered += usize::from((e - t).abs() <= 2.0 * s);
        }
        Self {
            samples: n,
            rmse: (sq / n as f64).sqrt(),
            correlation: set / (see * stt).sqrt(),
            two_sigma_coverage: covered as f64 / n as f64,
        }
    }
}

/// A system's run: what was recorded, each pair's figures, and its speed.
#[derive(Debug, Clone)]
pub struct SystemRun {
    /// The estimator's `<name>` and `<name>_std`, then the plant's `<name>`, of each pair.
    pub recorded: Recorded,
    /// Each pair's name and figures.
    pub pairs: Vec<(String, PairFigures)>,
    /// Simulated time over wall-clock time, the whole system on one core.
    pub real_time_factor: f64,
}

impl SystemRun {
    /// The estimator's values of the pair `k`, their σ, and the plant's truth.
    pub fn pair(&self, k: usize) -> (&[f64], &[f64], &[f64]) {
        let c = &self.recorded.columns;
        (&c[3 * k], &c[3 * k + 1], &c[3 * k + 2])
    }

    /// One line per pair, and the speed.
    pub fn summary(&self) -> String {
        let mut lines: Vec<String> = self
            .pairs
            .iter()
            .map(|(name, f)| {
                format!(
                    "{name}: RMSE {:.4}, correlation {:.5}, 2σ coverage {:.3} over {} time stamps",
                    f.rmse, f.correlation, f.two_sigma_coverage, f.samples
                )
            })
            .collect();
        lines.push(format!("the system ran at {:.1}× real time on one core", self.real_time_factor));
        lines.join("\n")
    }
}

/// Runs the system in `ssp` (its FMUs unpacked into `unpack`, removed afterwards) and
/// scores the estimator's outputs `pairs` against the plant's outputs of the same names.
pub fn run(ssp: &Path, unpack: &Path, pairs: &[&str]) -> anyhow::Result<SystemRun> {
    let names: Vec<(String, String, String)> =
        pairs.iter().map(|p| (p.to_string(), format!("{p}_std"), p.to_string())).collect();
    let record: Vec<(&str, &str)> = names
        .iter()
        .flat_map(|(e, s, t)| [(ESTIMATOR, e.as_str()), (ESTIMATOR, s.as_str()), (PLANT, t.as_str())])
        .collect();
    let start = Instant::now();
    let recorded = system_master::run(ssp, unpack, &record);
    let wall = start.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(unpack);
    let recorded = recorded?;
    let simulated = recorded.time.last().copied().unwrap_or(0.0) - recorded.time.first().copied().unwrap_or(0.0);
    let mut run = SystemRun { recorded, pairs: Vec::new(), real_time_factor: simulated / wall };
    run.pairs = (0..pairs.len())
        .map(|k| {
            let (e, s, t) = run.pair(k);
            (pairs[k].to_string(), PairFigures::of(e, s, t))
        })
        .collect();
    Ok(run)
}

/// A system's run beside the in-process co-simulation of the same case.
#[derive(Debug, Clone)]
pub struct Compared {
    /// The system's estimate of the first pair against the plant FMU's truth.
    pub system: PairFigures,
    /// The in-process run's against the truth simulator's.
    pub in_process: PairFigures,
    /// The largest difference between the two runs' estimates at the same time stamp, over every pair.
    pub largest_difference: f64,
    /// Whether the two runs' estimates and σ are the same bit for bit, every pair.
    pub bit_for_bit: bool,
    /// The system's run.
    pub run: SystemRun,
}

/// Runs the system in `ssp` (its FMUs unpacked into `unpack`) and compares its estimates of
/// `pairs` with those of the in-process run logged at `in_process_log`.
pub fn run_and_compare(ssp: &Path, unpack: &Path, pairs: &[&str], in_process_log: &Path) -> anyhow::Result<Compared> {
    let run = run(ssp, unpack, pairs)?;
    let log = read_log(in_process_log)?;
    let estimate = log.channel(ESTIMATE)?;
    let truth = log.channel(TRUTH)?;
    let signal = |channel: &Channel, name: &str| -> anyhow::Result<Vec<f64>> {
        Ok(channel.signal(name).with_context(|| format!("{} has no {name}", channel.topic))?.values.clone())
    };
    // The master's communication points add up the step; the log stamps k·dt: the same to rounding.
    let time = &run.recorded.time;
    let same_instants = estimate.time.len() == time.len()
        && estimate.time.iter().zip(time).all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(1.0));
    if !same_instants {
        bail!("the system's {} time stamps are not the in-process run's {}", time.len(), estimate.time.len());
    }
    let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
    let (mut largest_difference, mut bit_for_bit, mut in_process) = (0.0_f64, true, None);
    for (k, name) in pairs.iter().enumerate() {
        let (e, s, _) = run.pair(k);
        let (f, f_std) = (signal(estimate, name)?, signal(estimate, &format!("{name}_std"))?);
        largest_difference = f.iter().zip(e).map(|(a, b)| (a - b).abs()).fold(largest_difference, f64::max);
        bit_for_bit &= same(&f, e) && same(&f_std, s);
        if k == 0 {
            in_process = Some(PairFigures::of(&f, &f_std, &signal(truth, name)?));
        }
    }
    let in_process = in_process.context("no pair to compare")?;
    Ok(Compared { system: run.pairs[0].1, in_process, largest_difference, bit_for_bit, run })
}
