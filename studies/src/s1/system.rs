//! S1 as a system of two FMUs: the plant FMU (`kalfmu_s1_chain`: the case's chain, load,
//! seed and accelerometer noise) wired to the estimator FMU (`kalfmu_s1_load`: the
//! study's tuning) in an SSP archive, run by a Jacobi master over the `fmi` importer
//! (`cosim::system_master`), and scored against the plant's truth at the same time
//! stamps, beside the in-process co-simulation of the same case (the estimator FMU fed
//! the truth simulator's measurements, `fmu_run.rs`).

use std::path::Path;

use anyhow::{bail, Context};
use cosim::fmu_driver::{filter_enumeration, ImportedFmu};
use cosim::ssp::{self, Component, Connection, Experiment, System};
use estimator::FilterKind;
use log_format::read::read_log;
use log_format::write::ESTIMATE;
use start_values::ssv::{Parameter, ParameterSet, ValueKind};
use start_values::StartValues;
use truth::s1::{chain_parameters, Case, LoadKind, Settings};

use super::Tuning;

/// The plant's and the estimator's names in the system.
pub const PLANT: &str = "plant";
/// See [`PLANT`].
pub const ESTIMATOR: &str = "estimator";

const PLANT_FMU: &str = "resources/kalfmu_s1_chain.fmu";
const ESTIMATOR_FMU: &str = "resources/kalfmu_s1_load.fmu";

/// The system of `case` at `settings` with `kind` in the estimator: the plant given the
/// case's chain, load and seed and the accelerometer noise `noise_std` (m/s²), the
/// estimator the study's parameters for that noise, and `start_values` over them.
pub fn system(
    case: &Case,
    settings: &Settings,
    noise_std: [f64; 2],
    kind: FilterKind,
    start_values: &StartValues,
    estimator: &ImportedFmu,
) -> anyhow::Result<System> {
    if case.unseen.is_some() {
        bail!("the S1 plant FMU has the paper's loads and the band to 20 Hz; {case} is not one it builds");
    }
    let mut parameters = ParameterSet::new("s1_system");
    let mut put = |component: &str, name: &str, value: f64, kind: ValueKind| {
        let name = format!("{component}.{name}");
        parameters.parameters.retain(|p| p.name != name);
        parameters.parameters.push(Parameter { name, value, kind, unit: None, description: None });
    };
    let dt = settings.dt();
    let load_source = match case.load {
        LoadKind::Random => 2.0,
        LoadKind::Harmonic => 3.0,
    };
    for (name, value) in chain_parameters(&case.chain()) {
        put(PLANT, name, value, ValueKind::Real);
    }
    put(PLANT, "integration_step", dt / settings.truth_substeps() as f64, ValueKind::Real);
    put(PLANT, "load_source", load_source, ValueKind::Integer);
    put(PLANT, "load_seed", settings.seed as f64, ValueKind::Integer);
    put(PLANT, "load_rms", settings.load_rms, ValueKind::Real);
    put(PLANT, "noise_seed", settings.seed as f64, ValueKind::Integer);
    put(PLANT, "z1_ddot_noise_std", noise_std[0], ValueKind::Real);
    put(PLANT, "z2_ddot_noise_std", noise_std[1], ValueKind::Real);
    let tuning = Tuning::new(settings, noise_std);
    for (name, value) in super::fmu_run::parameters(&tuning, case, settings) {
        put(ESTIMATOR, name, value, ValueKind::Real);
    }
    for (name, value) in tuning.fmu_integers() {
        put(ESTIMATOR, name, f64::from(value), ValueKind::Integer);
    }
    put(ESTIMATOR, "filter", f64::from(filter_enumeration(kind)), ValueKind::Integer);
    for (name, value) in start_values.iter() {
        let kind =
            estimator.value_kind(name).with_context(|| format!("start value {name}: no parameter of the FMU"))?;
        put(ESTIMATOR, name, value, kind);
    }
    let measured = ["z1_ddot", "z2_ddot"];
    Ok(System {
        name: "s1_system".into(),
        components: vec![
            Component {
                name: PLANT.into(),
                source: PLANT_FMU.into(),
                connectors: measured.iter().map(|n| (n.to_string(), false)).collect(),
            },
            Component {
                name: ESTIMATOR.into(),
                source: ESTIMATOR_FMU.into(),
                connectors: measured.iter().map(|n| (n.to_string(), true)).collect(),
            },
        ],
        connections: measured
            .iter()
            .map(|n| Connection { from: (PLANT.into(), n.to_string()), to: (ESTIMATOR.into(), n.to_string()) })
            .collect(),
        parameters,
        experiment: Experiment { start: 0.0, stop: settings.samples() as f64 * dt, step: dt },
    })
}

/// Writes `system` as an `.ssp` at `out`, with the packaged FMUs of `fmu_dir`.
pub fn write(system: &System, fmu_dir: &Path, out: &Path) -> anyhow::Result<()> {
    let plant = fmu_dir.join("kalfmu_s1_chain.fmu");
    let estimator = fmu_dir.join("kalfmu_s1_load.fmu");
    ssp::write(system, &[(PLANT_FMU, &plant), (ESTIMATOR_FMU, &estimator)], out)
}

/// The load estimate of a run against the true load at the same time stamps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadFigures {
    /// Time stamps compared.
    pub samples: usize,
    /// RMSE of `F` over the whole run (N).
    pub rmse: f64,
    /// Fraction of the time stamps whose error is within ±2σ.
    pub two_sigma_coverage: f64,
}

impl LoadFigures {
    fn of(estimate: &[f64], sigma: &[f64], truth: &[f64]) -> Self {
        let n = estimate.len();
        let errors = estimate.iter().zip(truth).map(|(e, t)| e - t);
        let rmse = (errors.clone().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
        let covered = errors.zip(sigma).filter(|(e, s)| e.abs() <= 2.0 * *s).count();
        Self { samples: n, rmse, two_sigma_coverage: covered as f64 / n as f64 }
    }
}

/// The system's run beside the in-process co-simulation's.
#[derive(Debug, Clone, PartialEq)]
pub struct Compared {
    /// The system's load estimate against the plant FMU's true load.
    pub system: LoadFigures,
    /// The in-process run's against the truth simulator's.
    pub in_process: LoadFigures,
    /// The largest difference between the two runs' load estimates at the same time stamp (N).
    pub largest_difference: f64,
    /// Whether the two runs' load estimates and σ are the same bit for bit.
    pub bit_for_bit: bool,
}

/// Runs the system in `ssp_path` (its FMUs unpacked into `unpack`) and compares it with
/// the in-process run logged at `in_process_log`.
pub fn run_and_compare(ssp_path: &Path, unpack: &Path, in_process_log: &Path) -> anyhow::Result<Compared> {
    let record = [(ESTIMATOR, "F"), (ESTIMATOR, "F_std"), (PLANT, "F")];
    let run = cosim::system_master::run(ssp_path, unpack, &record)?;
    let system = LoadFigures::of(&run.columns[0], &run.columns[1], &run.columns[2]);
    let log = read_log(in_process_log)?;
    let estimate = log.channel(ESTIMATE)?;
    let truth = log.channel(log_format::write::TRUTH)?;
    let signal = |channel: &log_format::read::Channel, name: &str| -> anyhow::Result<Vec<f64>> {
        Ok(channel.signal(name).with_context(|| format!("{} has no {name}", channel.topic))?.values.clone())
    };
    let (f, f_std, f_true) = (signal(estimate, "F")?, signal(estimate, "F_std")?, signal(truth, "F")?);
    // The master's communication points add up the step; the log stamps k·dt: the same to rounding.
    let same_instants = estimate.time.len() == run.time.len()
        && estimate.time.iter().zip(&run.time).all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(1.0));
    if !same_instants {
        bail!("the system's {} time stamps are not the in-process run's {}", run.time.len(), estimate.time.len());
    }
    let in_process = LoadFigures::of(&f, &f_std, &f_true);
    let largest_difference = f.iter().zip(&run.columns[0]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
    let bit_for_bit = same(&f, &run.columns[0]) && same(&f_std, &run.columns[1]);
    Ok(Compared { system, in_process, largest_difference, bit_for_bit })
}

/// Command-line arguments of `kalfmu s1-system`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The case: stiffness/random, damping/random, stiffness/harmonic or damping/harmonic.
    #[arg(long, default_value = "stiffness/random")]
    pub case: Case,
    /// The default experiment's duration in seconds.
    #[arg(long, default_value_t = 10.0)]
    pub duration: f64,
    /// Seed of the random load and of the measurement noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// Accelerometer noise as a fraction of each channel's RMS (of the study's run of the case).
    #[arg(long, default_value_t = Settings::default().noise_fraction)]
    pub noise: f64,
    /// The estimator's filter: CKF, SRCKF, SVD-CKF, UKF or EKF.
    #[arg(long, default_value = "SRCKF")]
    pub filter: FilterKind,
    /// Where the packaged FMUs are (`package-fmus` writes them to target/fmu).
    #[arg(long, default_value = "target/fmu")]
    pub fmu_dir: std::path::PathBuf,
    /// The `.ssp` file to write.
    #[arg(long, value_name = "FILE.ssp")]
    pub out: std::path::PathBuf,
}

/// `kalfmu s1-system`: writes the system of a case as an `.ssp` archive; its accelerometer
/// noise is the study's (the fraction of each channel's RMS over the case's run).
pub fn run(args: &Args) -> anyhow::Result<()> {
    let settings =
        Settings { duration: args.duration, seed: args.seed, noise_fraction: args.noise, ..Settings::default() };
    settings.validate().map_err(anyhow::Error::msg)?;
    let (_, measured) = truth::s1::simulate(&args.case, &settings);
    let estimator = ImportedFmu::load_packaged(&args.fmu_dir, "kalfmu_s1_load")?;
    let system = system(&args.case, &settings, measured.noise_std, args.filter, &StartValues::none(), &estimator)?;
    write(&system, &args.fmu_dir, &args.out)?;
    println!("{}", args.out.display());
    Ok(())
}
