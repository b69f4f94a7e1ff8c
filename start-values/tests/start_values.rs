//! Specification: start values are one value per name, the SSV files first and `--set`
//! after them, a later value replacing an earlier one in its place; over a study's
//! defaults they replace the defaults of their names and add the others after them.

use start_values::ssv::{self, Parameter, ParameterSet, ValueKind};
use start_values::{Assignment, Options, StartValues};

fn set(text: &str) -> Assignment {
    text.parse().unwrap()
}

#[test]
fn a_later_value_replaces_an_earlier_one_in_its_place() {
    let mut values = StartValues::none();
    values.insert("a", 1.0);
    values.insert("b", 2.0);
    values.insert("a", 3.0);
    assert_eq!(values.iter().collect::<Vec<_>>(), [("a", 3.0), ("b", 2.0)]);
    assert_eq!(values.get("b"), Some(2.0));
    assert_eq!(values.get("c"), None);
}

#[test]
fn set_lines_win_over_the_files_and_later_files_over_earlier_ones() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let file = |name: &str, values: &[(&str, f64)]| {
        let mut set = ParameterSet::new(name);
        for (n, v) in values {
            set.parameters.push(Parameter {
                name: n.to_string(),
                value: *v,
                kind: ValueKind::Real,
                unit: None,
                description: None,
            });
        }
        let path = dir.join(format!("start_values_{}_{name}.ssv", std::process::id()));
        ssv::write(&path, &set).unwrap();
        path
    };
    let first = file("first", &[("q", 1.0), ("r", 2.0), ("s", 3.0)]);
    let second = file("second", &[("r", 20.0)]);
    let options = Options { set: vec![set("s=30"), set("t=4")], values: vec![first, second] };
    let values = StartValues::from_options(&options).unwrap();
    assert_eq!(values.iter().collect::<Vec<_>>(), [("q", 1.0), ("r", 20.0), ("s", 30.0), ("t", 4.0)]);
    assert_eq!(values.summary(), "q=1e0 r=2e1 s=3e1 t=4e0");
}

#[test]
fn an_unreadable_file_is_an_error_that_names_it() {
    let options = Options { set: vec![], values: vec!["no/such/file.ssv".into()] };
    let error = StartValues::from_options(&options).unwrap_err();
    assert!(error.contains("no/such/file.ssv"), "{error}");
}

#[test]
fn over_the_defaults_they_replace_their_names_in_place_and_add_the_rest() {
    let mut values = StartValues::none();
    values.insert("extra", 9.0);
    values.insert("m2", 5.0);
    let merged = values.over(&[("m1", 1.0), ("m2", 2.0)]);
    let expected: Vec<(String, f64)> = vec![("m1".into(), 1.0), ("m2".into(), 5.0), ("extra".into(), 9.0)];
    assert_eq!(merged, expected);
    assert_eq!(StartValues::none().summary(), "none");
}

#[test]
fn the_header_names_the_values_and_those_only_the_fmu_takes_and_is_absent_without_any() {
    assert_eq!(StartValues::none().header(&[]), None);
    let mut values = StartValues::none();
    values.insert("q", 1.0);
    values.insert("m1", 4.0);
    assert_eq!(
        values.header(&[]).unwrap(),
        "start values, over the study's in every FMU run and in the in-process filter: q=1e0 m1=4e0"
    );
    assert_eq!(
        values.header(&["m1".into()]).unwrap(),
        "start values, over the study's in every FMU run and in the in-process filter: q=1e0 m1=4e0; \
         in the FMU only (the in-process filter has no such parameter): m1"
    );
}
