//! Start values as `kalfmu-tune` hands them over, in its two forms: an SSV file (`--values`)
//! and `--set NAME=VALUE` lines. Read back through `StartValues::from_options`, both must
//! change the S1 and S2 tunings the same way, and so the in-process runs; a name a tuning
//! does not take stops an in-process command before any run.

use std::path::PathBuf;

use estimator::FilterKind;
use start_values::ssv::{self, Parameter, ParameterSet, ValueKind};
use start_values::{Assignment, Options, SetByName, StartValues};
use studies::s1::{self, Tuning};
use truth::s1::{Case, Settings};

/// The values a tuning of S1's noise might give: a load intensity and a sensor's noise.
const TUNED: [(&str, f64); 2] = [("load_noise_intensity", 2.71e6), ("r_z2_ddot_std", 0.031)];

/// A file in the system's temporary directory, removed when dropped.
struct TempFile(PathBuf);

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// `values` written as an SSV file the way `kalfmu-tune --ssv` writes one.
fn ssv_file(name: &str, values: &[(&str, f64)]) -> TempFile {
    let path = std::env::temp_dir().join(format!("kalfmu-start-values-{}-{name}.ssv", std::process::id()));
    let mut set = ParameterSet::new("tuned");
    set.parameters = values
        .iter()
        .map(|&(name, value)| Parameter {
            name: name.into(),
            value,
            kind: ValueKind::Real,
            unit: None,
            description: None,
        })
        .collect();
    ssv::write(&path, &set).unwrap();
    TempFile(path)
}

/// `values` as `--set` lines, as `kalfmu-tune` prints them.
fn set_lines(values: &[(&str, f64)]) -> Options {
    let set = values.iter().map(|&(name, value)| Assignment { name: name.into(), value }.to_string());
    Options { set: set.map(|line| line.parse().unwrap()).collect(), values: Vec::new() }
}

#[test]
fn an_ssv_file_changes_the_s1_tuning_as_the_set_lines_do() {
    let file = ssv_file("s1", &TUNED);
    let from_file = StartValues::from_options(&Options { set: Vec::new(), values: vec![file.0.clone()] }).unwrap();
    let from_lines = StartValues::from_options(&set_lines(&TUNED)).unwrap();
    let settings = Settings { duration: 2.0, ..Settings::default() };
    let study = Tuning::new(&settings, [0.01, 0.02]);
    let (mut by_file, mut by_lines) = (study.clone(), study.clone());
    by_file.set_all(&from_file).unwrap();
    by_lines.set_all(&from_lines).unwrap();
    assert_eq!(by_file, by_lines);
    assert_ne!(by_file, study, "the values changed the tuning");
    let written = by_file.fmu_parameters();
    for (name, value) in TUNED {
        assert!(written.contains(&(name, value)), "{name} = {value} in {written:?}");
    }
    // The in-process run takes them as well, to the last bit.
    let case = Case::ALL[0];
    let (truth, measurements) = truth::s1::simulate(&case, &settings);
    let run = |values: &StartValues| s1::run_filter(FilterKind::SrCkf, &case, &settings, &truth, &measurements, values);
    let (file_run, lines_run, default_run) = (run(&from_file), run(&from_lines), run(&StartValues::none()));
    assert!(file_run.failure.is_none(), "{:?}", file_run.failure);
    assert_eq!(file_run.load, lines_run.load);
    assert_ne!(file_run.load, default_run.load);
}

#[test]
fn an_ssv_file_changes_the_s2_tuning_as_the_set_lines_do() {
    use studies::s2::study::Tuning;
    let tuned = [("force_noise_intensity", 3.3e12), ("r_z_w1_ddot_std", 0.7), ("p0_force_std", 250.0)];
    let file = ssv_file("s2", &tuned);
    let from_file = StartValues::from_options(&Options { set: Vec::new(), values: vec![file.0.clone()] }).unwrap();
    let from_lines = StartValues::from_options(&set_lines(&tuned)).unwrap();
    let study = Tuning::new(&truth::s2::cases::Settings::default(), [0.1; 7]);
    let (mut by_file, mut by_lines) = (study.clone(), study.clone());
    by_file.set_all(&from_file).unwrap();
    by_lines.set_all(&from_lines).unwrap();
    assert_eq!(by_file, by_lines);
    assert_ne!(by_file, study);
    for (name, value) in tuned {
        assert!(by_file.fmu_parameters().contains(&(name, value)), "{name}");
    }
}

#[test]
fn an_in_process_command_refuses_a_name_its_tuning_does_not_take_before_any_run() {
    // A name of the FMU that the in-process filter does not have: the chain's first mass.
    let start_values = Options { set: vec!["m1=4.5".parse().unwrap()], values: Vec::new() };
    let args = s1::sweep::Args {
        seeds: 1,
        noise: vec![0.02],
        duration: 1.0,
        filter: FilterKind::SrCkf,
        shard: "1/1".parse().unwrap(),
        start_values,
    };
    let error = s1::sweep::run(&args).unwrap_err().to_string();
    assert!(error.contains("'m1' is not a parameter the in-process S1 filter takes"), "{error}");
    let args = s1::sweep::Args { start_values: set_lines(&[("q_z_std", -1.0)]), ..args };
    let error = s1::sweep::run(&args).unwrap_err().to_string();
    assert!(error.contains("q_z_std") && error.contains("not negative"), "{error}");
}

/// The names of the parameters of the FMU `model_identifier`.
fn fmu_parameter_names(model_identifier: &str) -> Vec<String> {
    let descriptor = kalfmu_fmu::estimators::all()
        .into_iter()
        .find(|d| d.model_identifier == model_identifier)
        .expect("an estimator FMU");
    let parameters =
        descriptor.variables.into_iter().filter(|v| v.causality == kalfmu_fmu::variables::Causality::Parameter);
    parameters.map(|v| v.name.into_owned()).collect()
}

#[test]
fn every_name_a_study_sets_or_takes_is_a_parameter_of_its_fmu() {
    // S1: the chain (truth::s1::chain_parameters), the sample time and the tuning.
    let s1 = fmu_parameter_names("kalfmu_s1_load");
    let chain = Case::ALL.iter().chain(&Case::UNSEEN).flat_map(|c| truth::s1::chain_parameters(&c.chain()));
    let s1_names = chain.map(|(n, _)| n).chain(["sample_time"]).chain(Tuning::NAMES);
    for name in s1_names {
        assert!(s1.iter().any(|p| p == name), "S1 sets {name}, which the FMU does not have");
    }
    // S2: the catalogue car (Vehicle::fmu_parameters), the weighed load, the sample time
    // and the tuning.
    let s2 = fmu_parameter_names("kalfmu_s2_wheel_rail");
    let vehicle = truth::s2::parameters::Vehicle::ZHAI_PASSENGER.fmu_parameters().map(|(n, _)| n);
    let s2_names = vehicle.into_iter().chain(["static_wheel_load", "sample_time"]);
    for name in s2_names.chain(studies::s2::study::Tuning::NAMES) {
        assert!(s2.iter().any(|p| p == name), "S2 sets {name}, which the FMU does not have");
    }
}
