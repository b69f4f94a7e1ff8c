//! S1 as a system of two FMUs: the plant FMU (`kalfmu_s1_chain`: the case's chain, load,
//! seed and accelerometer noise) wired to the estimator FMU (`kalfmu_s1_load`: the
//! study's tuning) in an SSP archive, run by a Jacobi master over the `fmi` importer
//! (`cosim::system_master`), and scored against the plant's truth at the same time
//! stamps, beside the in-process co-simulation of the same case (the estimator FMU fed
//! the truth simulator's measurements, `fmu_run.rs`).

use anyhow::bail;
use cosim::fmu_driver::{filter_enumeration, ImportedFmu};
use cosim::ssp::{Experiment, System};
use estimator::FilterKind;
use start_values::ssv::ValueKind;
use start_values::StartValues;
use truth::s1::{chain_parameters, Case, LoadKind, Settings};

use super::Tuning;
use crate::system::{plant_to_estimator, Bindings, ESTIMATOR, PLANT};

const PLANT_FMU: &str = "kalfmu_s1_chain";
const ESTIMATOR_FMU: &str = "kalfmu_s1_load";

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
    let mut parameters = Bindings::new("s1_system");
    let mut put =
        |component: &str, name: &str, value: f64, kind: ValueKind| parameters.put(component, name, value, kind);
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
    parameters.start_values(start_values, estimator)?;
    let measured = ["z1_ddot", "z2_ddot"];
    let experiment = Experiment { start: 0.0, stop: settings.samples() as f64 * dt, step: dt };
    let parameters = parameters.checked(estimator)?;
    Ok(plant_to_estimator("s1_system", (PLANT_FMU, ESTIMATOR_FMU), &measured, parameters, experiment))
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
    /// Then run it under the Jacobi master and print the load's figures against the plant's
    /// truth and the system's speed.
    #[arg(long)]
    pub run: bool,
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
    crate::system::write(&system, &args.fmu_dir, &args.out)?;
    println!("{}", args.out.display());
    if args.run {
        let unpack = args.out.with_extension("fmus");
        println!("{}", crate::system::run(&args.out, &unpack, &["F"])?.summary());
    }
    Ok(())
}
