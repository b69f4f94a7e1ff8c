//! S2 as a system of two FMUs: the plant FMU (`kalfmu_s2_track`: the car as built on the
//! scenario's track, its data acquisition and the sensors' noise) wired to the estimator
//! FMU (`kalfmu_s2_wheel_rail`: the user's catalogue car, the weighed wheel load and the
//! study's tuning) in an SSP archive.

use std::path::PathBuf;

use anyhow::Context;
use cosim::fmu_driver::{filter_enumeration, ImportedFmu};
use cosim::ssp::{Experiment, System};
use estimator::FilterKind;
use start_values::ssv::ValueKind;
use truth::s2::cases::{as_built, measure, simulate, Case, Scenario, Settings};
use truth::s2::irregularity::TrackSpectrum;
use truth::s2::parameters::Vehicle;

use super::fmu_run;
use super::study::Tuning;
use crate::system::{plant_to_estimator, Bindings, ESTIMATOR, PLANT};

const PLANT_FMU: &str = "kalfmu_s2_track";
const ESTIMATOR_FMU: &str = "kalfmu_s2_wheel_rail";

/// The seven accelerations, connected by name.
const MEASURED: [&str; 7] = ["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"];

/// The forces scored.
pub const FORCES: [&str; 4] = ["F_N1", "F_N2", "F_N3", "F_N4"];

/// The system of `scenario` at `settings` with `kind` in the estimator: the plant given the
/// scenario's track, the speed, the rate, the seed and the sensors' noise `noise_std`
/// (m/s²), the estimator the catalogue car, the as-built car's weighed wheel load and the
/// study's tuning for that noise.
pub fn system(
    scenario: Scenario,
    settings: &Settings,
    noise_std: [f64; 7],
    kind: FilterKind,
    estimator: &ImportedFmu,
) -> anyhow::Result<System> {
    let mut parameters = Bindings::new("s2_system");
    let mut put =
        |component: &str, name: &str, value: f64, kind: ValueKind| parameters.put(component, name, value, kind);
    let track = match scenario.case {
        Case::Random => 1.0,
        Case::Corrugation => 2.0,
        Case::Weld => 3.0,
    };
    let spectrum = [TrackSpectrum::FRA_5, TrackSpectrum::FRA_6, TrackSpectrum::GERMAN_LOW, TrackSpectrum::GERMAN_HIGH]
        .iter()
        .position(|s| *s == scenario.spectrum)
        .context("a spectrum the plant FMU does not have")? as f64
        + 1.0;
    put(PLANT, "speed", settings.speed, ValueKind::Real);
    put(PLANT, "sample_rate", settings.rate, ValueKind::Real);
    put(PLANT, "track", track, ValueKind::Integer);
    put(PLANT, "track_spectrum", spectrum, ValueKind::Integer);
    put(PLANT, "track_seed", settings.seed as f64, ValueKind::Integer);
    put(PLANT, "track_length", settings.speed * settings.duration, ValueKind::Real);
    put(PLANT, "noise_seed", settings.seed as f64, ValueKind::Integer);
    for (name, std) in MEASURED.iter().zip(noise_std) {
        put(PLANT, &format!("{name}_noise_std"), std, ValueKind::Real);
    }
    let tuning = Tuning::new(settings, noise_std);
    let weighed = as_built().static_wheel_load();
    for (name, value) in fmu_run::parameters(&Vehicle::ZHAI_PASSENGER, weighed, &tuning) {
        put(ESTIMATOR, name, value, ValueKind::Real);
    }
    for (name, value) in tuning.fmu_integers() {
        put(ESTIMATOR, name, f64::from(value), ValueKind::Integer);
    }
    put(ESTIMATOR, "filter", f64::from(filter_enumeration(kind)), ValueKind::Integer);
    let dt = 1.0 / settings.rate;
    let experiment = Experiment { start: 0.0, stop: (settings.duration * settings.rate).round() * dt, step: dt };
    let parameters = parameters.checked(estimator)?;
    Ok(plant_to_estimator("s2_system", (PLANT_FMU, ESTIMATOR_FMU), &MEASURED, parameters, experiment))
}

/// Command-line arguments of `kalfmu s2-system`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The case on its track: random, corrugation, weld, random/fra6, random/german-low, random/german-high.
    #[arg(long, default_value = "random")]
    pub case: Scenario,
    /// The default experiment's duration in seconds.
    #[arg(long, default_value_t = Settings::default().duration)]
    pub duration: f64,
    /// Speed (km/h).
    #[arg(long, default_value_t = 80.0)]
    pub speed: f64,
    /// Sampling rate (Hz): 1000 or 200.
    #[arg(long, default_value_t = Settings::default().rate)]
    pub rate: f64,
    /// Seed of the random track and of the measurement noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// Sensor noise as a fraction of each channel's RMS (of the study's run of the case).
    #[arg(long, default_value_t = Settings::default().noise_fraction)]
    pub noise: f64,
    /// The estimator's filter: CKF, SRCKF, SVD-CKF, UKF or EKF.
    #[arg(long, default_value = "SRCKF")]
    pub filter: FilterKind,
    /// Where the packaged FMUs are (`package-fmus` writes them to target/fmu).
    #[arg(long, default_value = "target/fmu")]
    pub fmu_dir: PathBuf,
    /// The `.ssp` file to write.
    #[arg(long, value_name = "FILE.ssp")]
    pub out: PathBuf,
    /// Then run it under the Jacobi master and print the forces' figures against the
    /// plant's truth and the system's speed.
    #[arg(long)]
    pub run: bool,
}

/// `kalfmu s2-system`: writes the system of a case as an `.ssp` archive; the sensors'
/// noise is the study's (the fraction of each channel's RMS over the case's run).
pub fn run(args: &Args) -> anyhow::Result<()> {
    let settings = Settings {
        duration: args.duration,
        speed: args.speed / 3.6,
        rate: args.rate,
        seed: args.seed,
        noise_fraction: args.noise,
        ..args.case.settings(&Settings::default())
    };
    settings.validate().map_err(anyhow::Error::msg)?;
    let truth = simulate(args.case.case, &settings);
    let noise_std = measure(&truth, settings.noise_fraction, settings.seed).noise_std;
    let estimator = ImportedFmu::load_packaged(&args.fmu_dir, "kalfmu_s2_wheel_rail")?;
    let system = system(args.case, &settings, noise_std, args.filter, &estimator)?;
    crate::system::write(&system, &args.fmu_dir, &args.out)?;
    println!("{}", args.out.display());
    if args.run {
        let unpack = args.out.with_extension("fmus");
        println!("{}", crate::system::run(&args.out, &unpack, &FORCES)?.summary());
    }
    Ok(())
}
