//! S5 as a system of two FMUs: the plant FMU (`kalfmu_s5_flight`: the study's missile
//! flying a manoeuvre, its coefficients changing mid-flight, its twelve sensors' noise)
//! wired to the estimator FMU (`kalfmu_s5_missile`: the study's tuning) in an SSP archive,
//! the twelve measurements and the three deflections connected by name, and scored: each
//! estimated coefficient against the plant's at the same time stamps.

use std::path::PathBuf;

use cosim::fmu_driver::{filter_enumeration, ImportedFmu};
use cosim::ssp::{Experiment, System};
use estimator::models::Missile6Dof;
use estimator::FilterKind;
use start_values::ssv::ValueKind;
use start_values::StartValues;
use truth::s5::flight::Settings;
use truth::s5::manoeuvre::Manoeuvre;
use truth::s5::parameters::{AFTER, BEFORE, NAMES, SENSOR_STD};

use super::fmu_run;
use super::study::Tuning;
use crate::system::{plant_to_estimator, Bindings, ESTIMATOR, PLANT};

const PLANT_FMU: &str = "kalfmu_s5_flight";

/// The deflections, connected by name beside the measurements.
const DEFLECTIONS: [&str; 3] = ["delta_x", "delta_y", "delta_z"];

/// The plant's value of its `manoeuvre` parameter for the manoeuvre of that name.
fn manoeuvre_item(name: &str) -> anyhow::Result<f64> {
    match name {
        "standard" => Ok(2.0),
        "roll-turn" => Ok(3.0),
        _ => anyhow::bail!("the S5 plant FMU flies standard and roll-turn, not {name}"),
    }
}

/// The system of the manoeuvre `manoeuvre` at `settings` with `kind` in the estimator: the
/// plant given the study's coefficients, their change, its integration step, the seed and
/// the sensors' noise; the estimator the study's tuning for that noise, and
/// `start_values` over it.
pub fn system(
    manoeuvre: &str,
    settings: &Settings,
    kind: FilterKind,
    start_values: &StartValues,
    estimator: &ImportedFmu,
) -> anyhow::Result<System> {
    let flight = Manoeuvre::named(manoeuvre).map_err(anyhow::Error::msg)?;
    let mut parameters = Bindings::new("s5_system");
    let mut put =
        |component: &str, name: &str, value: f64, kind: ValueKind| parameters.put(component, name, value, kind);
    put(PLANT, "manoeuvre", manoeuvre_item(manoeuvre)?, ValueKind::Integer);
    put(PLANT, "change_at", flight.change_at, ValueKind::Real);
    for ((name, before), after) in NAMES.iter().zip(BEFORE).zip(AFTER) {
        put(PLANT, &format!("{name}_before"), before, ValueKind::Real);
        put(PLANT, &format!("{name}_after"), after, ValueKind::Real);
    }
    put(PLANT, "integration_step", settings.sample_time / settings.truth_substeps as f64, ValueKind::Real);
    put(PLANT, "noise_seed", settings.seed as f64, ValueKind::Integer);
    for (name, std) in Missile6Dof::MEASUREMENT_NAMES.iter().zip(SENSOR_STD) {
        put(PLANT, &format!("{name}_noise_std"), settings.noise_scale * std, ValueKind::Real);
    }
    let tuning = Tuning::new(settings.noise_scale);
    for (name, value) in fmu_run::parameters(settings, &tuning) {
        put(ESTIMATOR, name, value, ValueKind::Real);
    }
    for (name, value) in fmu_run::integers(&tuning) {
        put(ESTIMATOR, name, f64::from(value), ValueKind::Integer);
    }
    put(ESTIMATOR, "filter", f64::from(filter_enumeration(kind)), ValueKind::Integer);
    parameters.start_values(start_values, estimator)?;
    let measured: Vec<&str> = Missile6Dof::MEASUREMENT_NAMES.iter().copied().chain(DEFLECTIONS).collect();
    let dt = settings.sample_time;
    let experiment = Experiment { start: 0.0, stop: (flight.duration / dt).round() * dt, step: dt };
    let parameters = parameters.checked(estimator)?;
    Ok(plant_to_estimator("s5_system", (PLANT_FMU, fmu_run::IDENTIFIER), &measured, parameters, experiment))
}

/// Command-line arguments of `kalfmu s5-system`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The manoeuvre: standard (the study's) or roll-turn (one the estimators were not tuned on).
    #[arg(long, default_value = "standard")]
    pub manoeuvre: String,
    /// Seed of the sensors' noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// The sensors' noise as a multiple of the study's.
    #[arg(long, default_value_t = Settings::default().noise_scale)]
    pub noise_scale: f64,
    /// The estimator's filter: CKF, SRCKF, SVD-CKF, UKF or EKF.
    #[arg(long, default_value = "SVD-CKF")]
    pub filter: FilterKind,
    /// Where the packaged FMUs are (`package-fmus` writes them to target/fmu).
    #[arg(long, default_value = "target/fmu")]
    pub fmu_dir: PathBuf,
    /// The `.ssp` file to write.
    #[arg(long, value_name = "FILE.ssp")]
    pub out: PathBuf,
    /// Then run it under the Jacobi master and print the coefficients' figures against the
    /// plant's truth and the system's speed.
    #[arg(long)]
    pub run: bool,
}

/// `kalfmu s5-system`: writes the system of a manoeuvre as an `.ssp` archive.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if !(args.noise_scale > 0.0 && args.noise_scale.is_finite()) {
        anyhow::bail!("--noise-scale must be positive, got {}", args.noise_scale);
    }
    let settings = Settings { seed: args.seed, noise_scale: args.noise_scale, ..Settings::default() };
    let estimator = ImportedFmu::load_packaged(&args.fmu_dir, fmu_run::IDENTIFIER)?;
    let system = system(&args.manoeuvre, &settings, args.filter, &StartValues::none(), &estimator)?;
    crate::system::write(&system, &args.fmu_dir, &args.out)?;
    println!("{}", args.out.display());
    if args.run {
        let unpack = args.out.with_extension("fmus");
        println!("{}", crate::system::run(&args.out, &unpack, &NAMES)?.summary());
    }
    Ok(())
}
