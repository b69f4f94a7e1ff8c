//! The variable table is the single source of truth: the committed
//! `modelDescription/` files are exactly what it generates, `fmi-schema` reads
//! them back with the same GUID, value references and causalities, every
//! unit used is declared, and every default the shipped texts state is the
//! variable's start value.

use std::collections::HashMap;

use fmi_schema::fmi2::{Causality, Fmi2ModelDescription, ScalarVariableElement};
use kalfmu_fmu::catalogue::{self, Fmu};
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
    for fmu in &catalogue::all() {
        let d = fmu.description();
        assert!(
            committed(d.model_identifier()) == model_description(d),
            "modelDescription/{}/modelDescription.xml is stale: regenerate it with \
             `cargo run --release -p fmu --bin package-fmus -- --write-model-descriptions`",
            d.model_identifier()
        );
    }
}

#[test]
fn fmi_schema_reads_back_the_guid_the_value_references_and_the_causalities() {
    for fmu in &catalogue::all() {
        let d = fmu.description();
        d.check().unwrap();
        let md: Fmi2ModelDescription = fmi_schema::deserialize(&committed(d.model_identifier())).unwrap();
        assert_eq!(md.fmi_version, "2.0");
        assert_eq!(md.guid, d.guid());
        assert_eq!(md.co_simulation.as_ref().unwrap().model_identifier, d.model_identifier());
        assert!(md.model_exchange.is_none(), "Co-Simulation only");
        let vars: Vec<_> = md.get_model_variables().collect();
        assert_eq!(vars.len(), d.variables().len());
        for (vr, (parsed, ours)) in vars.iter().zip(d.variables()).enumerate() {
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
            .variables()
            .iter()
            .enumerate()
            .filter(|(_, v)| v.causality == variables::Causality::Output)
            .map(|(i, _)| i as u32 + 1)
            .collect();
        assert_eq!(outputs, expected, "<Outputs> must list every output once, in order");
        let declared: Vec<String> =
            md.unit_definitions.as_ref().map(|u| u.units.iter().map(|u| u.name.clone()).collect()).unwrap_or_default();
        for v in d.variables() {
            if let Some(unit) = v.unit {
                assert!(declared.iter().any(|n| n == unit), "unit {unit} of {} is not declared", v.name);
            }
        }
    }
}

#[test]
fn every_fmu_is_found_by_its_guid_and_only_by_it() {
    for fmu in &catalogue::all() {
        let d = fmu.description();
        assert_eq!(d.guid().len(), 38, "{{8-4-4-4-12}}");
        let found = catalogue::by_guid(d.guid()).unwrap();
        assert_eq!(found.description().model_identifier(), d.model_identifier());
    }
    assert!(catalogue::by_guid("{00000000-0000-0000-0000-000000000000}").is_none());
}

/// The supervisor's parameters, whose defaults differ between the FMUs (S4 takes a
/// resent telegram as stuck from its first repeat): every documentation states them.
const SUPERVISOR_PARAMETERS: [&str; 7] = [
    "gate_probability",
    "stuck_after",
    "fault_after",
    "reacquire_after",
    "consistency_window",
    "consistency_margin",
    "max_inflation",
];

/// The start values of a `modelDescription.xml`, by variable name (outputs have none).
/// Reads the layout [`model_description`] writes: a `<ScalarVariable name=…>` line, then
/// its type element.
fn start_values(xml: &str) -> HashMap<String, f64> {
    let mut starts = HashMap::new();
    for variable in xml.split("<ScalarVariable name=\"").skip(1) {
        let name = variable.split('"').next().unwrap();
        let element = variable.split("</ScalarVariable>").next().unwrap();
        if let Some(start) = element.split(" start=\"").nth(1) {
            let start = start.split('"').next().unwrap();
            let value = match start {
                "true" => 1.0,
                "false" => 0.0,
                number => number.parse().unwrap_or_else(|e| panic!("start of {name}: {number}: {e}")),
            };
            starts.insert(name.to_string(), value);
        }
    }
    starts
}

/// Every `description` attribute of a `modelDescription.xml` (the model's, the
/// variables', the enumeration items', the log categories'), unescaped.
fn description_attributes(xml: &str) -> Vec<String> {
    xml.split(" description=\"")
        .skip(1)
        .map(|rest| {
            let text = rest.split('"').next().unwrap();
            text.replace("&lt;", "<")
                .replace("&gt;", ">")
                .replace("&quot;", "\"")
                .replace("&apos;", "'")
                .replace("&amp;", "&")
        })
        .collect()
}

/// Whether `c` may be part of a variable name.
fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The value `text` starts with (`0.02`, `-25`, `1e8`, `5e-5`, `true`), if any.
fn leading_number(text: &str) -> Option<f64> {
    if text.starts_with("true") || text.starts_with("false") {
        return Some(if text.starts_with("true") { 1.0 } else { 0.0 });
    }
    let end = text.find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c))).unwrap_or(text.len());
    text[..end].parse().ok()
}

/// Every default `text` states, the one way the generator writes it: `(default X`
/// right after the variable's name, `<code>name</code> ` in HTML and `name ` in plain
/// text. An `Err` is a `(default ` after no name, or with no number.
fn stated_defaults(text: &str) -> Vec<Result<(String, f64), String>> {
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(at) = text[from..].find("(default ") {
        let at = from + at;
        let before = text[..at].strip_suffix(' ').unwrap_or("");
        let before = before.strip_suffix("</code>").unwrap_or(before);
        let name_start = before.rfind(|c: char| !is_name_char(c)).map_or(0, |i| i + 1);
        let name = &before[name_start..];
        let context = &text[text.floor_char_boundary(at.saturating_sub(60))..text.ceil_char_boundary(at + 30)];
        found.push(match leading_number(&text[at + "(default ".len()..]) {
            Some(value) if !name.is_empty() => Ok((name.to_string(), value)),
            _ => Err(format!("a default stated after no variable name, or without a number: …{context}…")),
        });
        from = at + 1;
    }
    found
}

/// The occurrences of a variable's name directly followed by a number in `text`
/// (`stuck_after 2`): a default stated outside the generator's pattern.
fn bare_values<'a>(text: &'a str, names: impl Iterator<Item = &'a String>) -> Vec<String> {
    let mut found = Vec::new();
    for name in names {
        for (at, _) in text.match_indices(name.as_str()) {
            let starts_word = !text[..at].ends_with(is_name_char);
            let after = &text[at + name.len()..];
            let value = after.strip_prefix(' ').map(|v| v.strip_prefix('±').unwrap_or(v));
            if starts_word && value.and_then(leading_number).is_some() {
                found.push(format!("{name}{}", &after[..after.ceil_char_boundary(12)]));
            }
        }
    }
    found
}

/// The prose of `documentation/index.html` (everything before the variable tables, whose
/// value-reference and start columns are numbers beside names), without its tags.
fn prose(html: &str) -> String {
    let text = html.split("<h2>Inputs</h2>").next().unwrap();
    let mut out = String::with_capacity(text.len());
    let mut in_tag = false;
    for c in text.chars() {
        match c {
            '<' => in_tag = true,
            '>' if in_tag => in_tag = false,
            c if !in_tag => out.push(c),
            _ => {}
        }
    }
    out
}

#[test]
fn every_default_the_shipped_texts_state_is_the_start_value_in_the_model_description() {
    for fmu in &catalogue::all() {
        let d = fmu.description();
        let xml = committed(d.model_identifier());
        let starts = start_values(&xml);
        let html = d.documentation_page();
        let mut checked = HashMap::<&str, Vec<String>>::new();
        let texts = std::iter::once(("documentation/index.html", html)).chain(
            description_attributes(&xml).into_iter().map(|description| ("a description attribute", description)),
        );
        for (source, text) in texts {
            for stated in stated_defaults(&text) {
                let (name, value) = stated.unwrap_or_else(|e| panic!("{} {source}: {e}", d.model_identifier()));
                let start = starts.get(&name).unwrap_or_else(|| {
                    let id = d.model_identifier();
                    panic!("{id} {source}: a `(default {value})` after `{name}`, which is no parameter or input")
                });
                assert_eq!(value, *start, "{} {source}: the default of {name}", d.model_identifier());
                checked.entry(source).or_default().push(name);
            }
        }
        let in_html = checked.get("documentation/index.html").cloned().unwrap_or_default();
        // A plant has no supervisor.
        for name in SUPERVISOR_PARAMETERS.iter().filter(|_| matches!(fmu, Fmu::Estimator(_))) {
            assert!(
                in_html.iter().any(|n| n == name),
                "{}: the documentation states no default of {name}",
                d.model_identifier()
            );
        }
        eprintln!(
            "{}: {} defaults checked in documentation/index.html, {} in description attributes ({})",
            d.model_identifier(),
            in_html.len(),
            checked.get("a description attribute").map_or(0, Vec::len),
            in_html.join(", ")
        );
    }
}

#[test]
fn the_shipped_texts_write_no_value_beside_a_variable_name_but_its_default() {
    for fmu in &catalogue::all() {
        let d = fmu.description();
        let xml = committed(d.model_identifier());
        let starts = start_values(&xml);
        let texts = std::iter::once(prose(&d.documentation_page())).chain(description_attributes(&xml));
        let bare: Vec<String> = texts.flat_map(|text| bare_values(&text, starts.keys())).collect();
        assert!(
            bare.is_empty(),
            "{}: a value written beside a variable's name, not as `{{name}}` (its default): {bare:?}",
            d.model_identifier()
        );
    }
}
