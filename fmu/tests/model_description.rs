//! The variable table is the single source of truth: the committed
//! `modelDescription/` files are exactly what it generates, `fmi-schema` reads
//! them back with the same GUID, value references and causalities, and every
//! unit used is declared.

use fmi_schema::fmi2::{Causality, Fmi2ModelDescription, ScalarVariableElement};
use kalfmu_fmu::estimators;
use kalfmu_fmu::model_description::model_description;
use kalfmu_fmu::variables::{self, Kind};

fn committed(identifier: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../modelDescription")
        .join(identifier)
        .join("modelDescription.xml");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn committed_model_descriptions_are_what_the_table_generates() {
    for d in &estimators::all() {
        assert!(
            committed(d.model_identifier) == model_description(d),
            "modelDescription/{}/modelDescription.xml is stale: regenerate it with \
             `cargo run --release -p fmu --bin package-fmus -- --write-model-descriptions`",
            d.model_identifier
        );
    }
}

#[test]
fn fmi_schema_reads_back_the_guid_the_value_references_and_the_causalities() {
    for d in &estimators::all() {
        estimators::check(d).unwrap();
        let md: Fmi2ModelDescription = fmi_schema::deserialize(&committed(d.model_identifier)).unwrap();
        assert_eq!(md.fmi_version, "2.0");
        assert_eq!(md.guid, d.guid());
        assert_eq!(md.co_simulation.as_ref().unwrap().model_identifier, d.model_identifier);
        assert!(md.model_exchange.is_none(), "Co-Simulation only");
        let vars: Vec<_> = md.get_model_variables().collect();
        assert_eq!(vars.len(), d.variables.len());
        for (vr, (parsed, ours)) in vars.iter().zip(&d.variables).enumerate() {
            assert_eq!(parsed.name, ours.name);
            assert_eq!(parsed.value_reference as usize, vr, "{}", ours.name);
            let causality = match ours.causality {
                variables::Causality::Parameter => Causality::Parameter,
                variables::Causality::Input => Causality::Input,
                variables::Causality::Output => Causality::Output,
            };
            assert_eq!(parsed.causality, causality, "{}", ours.name);
            let same_type = matches!(
                (&parsed.elem, ours.kind),
                (ScalarVariableElement::Real(_), Kind::Real)
                    | (ScalarVariableElement::Integer(_), Kind::Integer)
                    | (ScalarVariableElement::Boolean(_), Kind::Boolean)
                    | (ScalarVariableElement::Enumeration, Kind::Enumeration(_))
            );
            assert!(same_type, "{}: {:?} vs {:?}", ours.name, parsed.elem, ours.kind);
            if let (ScalarVariableElement::Real(r), Some(start)) = (&parsed.elem, ours.start) {
                assert_eq!(r.start, Some(start), "{}", ours.name);
            }
        }
        let outputs: Vec<u32> = md.model_structure.outputs.unknowns.iter().map(|u| u.index).collect();
        let expected: Vec<u32> = d
            .variables
            .iter()
            .enumerate()
            .filter(|(_, v)| v.causality == variables::Causality::Output)
            .map(|(i, _)| i as u32 + 1)
            .collect();
        assert_eq!(outputs, expected, "<Outputs> must list every output once, in order");
        let declared: Vec<String> =
            md.unit_definitions.as_ref().map(|u| u.units.iter().map(|u| u.name.clone()).collect()).unwrap_or_default();
        for v in &d.variables {
            if let Some(unit) = v.unit {
                assert!(declared.iter().any(|n| n == unit), "unit {unit} of {} is not declared", v.name);
            }
        }
    }
}

#[test]
fn every_estimator_is_found_by_its_guid_and_only_by_it() {
    for d in &estimators::all() {
        assert_eq!(d.guid().len(), 38, "{{8-4-4-4-12}}");
        assert_eq!(estimators::by_guid(d.guid()).unwrap().model_identifier, d.model_identifier);
    }
    assert!(estimators::by_guid("{00000000-0000-0000-0000-000000000000}").is_none());
}
