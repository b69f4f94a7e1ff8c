//! Specification: an SSV file written by `start_values::ssv` is well-formed XML in the SSP 1.0
//! parameter-value namespace, laid out as the schema has it (`ssv:ParameterSet` with
//! `version` and `name`, `ssv:Parameters`, `ssv:Parameter name=…` each with one
//! `ssv:Real value=…`, then `ssv:Units` of `ssc:Unit`/`ssc:BaseUnit`), and reads back to
//! the same set, every value bit for bit; the reader refuses what is not such a file.

use std::path::PathBuf;

use start_values::ssv::{self, Parameter, ParameterSet, Unit, ValueKind, COMMON_NAMESPACE, NAMESPACE};

fn sample_set() -> ParameterSet {
    let values = [1.56e6, 0.1 + 0.2, 5e-324, 1e300, 123_456_789.123_456_79, 3.0e-5];
    let mut set = ParameterSet::new("kalfmu_s1_load tuned from \"run <1>\" & co");
    set.description = Some("a description with <markup>, 'quotes' &\nnew lines\tand tabs".into());
    set.generation_tool = Some("kalfmu-tune test".into());
    for (k, value) in values.into_iter().enumerate() {
        set.parameters.push(Parameter {
            name: format!("param_{k}"),
            value,
            kind: ValueKind::Real,
            unit: (k % 2 == 0).then(|| "N2/s3".to_string()),
            description: Some(format!("95 % interval [{:e}, {:e}]", value / 2.0, value * 2.0)),
        });
    }
    set.units.push(Unit { name: "N2/s3".into(), exponents: [2, 2, -7, 0, 0, 0, 0, 0] });
    set
}

fn scratch(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("ssv_round_trip_{}_{name}", std::process::id()))
}

#[test]
fn a_written_set_is_well_formed_ssp_xml_and_reads_back_bit_for_bit() {
    let set = sample_set();
    let path = scratch("set.ssv");
    ssv::write(&path, &set).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>"));

    // Well-formed, and every element where the schema puts it.
    let doc = roxmltree::Document::parse(&text).expect("well-formed XML");
    let root = doc.root_element();
    assert_eq!((root.tag_name().namespace(), root.tag_name().name()), (Some(NAMESPACE), "ParameterSet"));
    assert_eq!(root.attribute("version"), Some("1.0"));
    assert_eq!(root.attribute("name"), Some(set.name.as_str()));
    assert_eq!(root.attribute("description"), set.description.as_deref(), "white space survives as references");
    let children: Vec<_> = root.children().filter(|n| n.is_element()).collect();
    let names: Vec<(&str, &str)> =
        children.iter().map(|n| (n.tag_name().namespace().unwrap(), n.tag_name().name())).collect();
    assert_eq!(names, [(NAMESPACE, "Parameters"), (NAMESPACE, "Units")], "the schema's order");
    let parameters: Vec<_> = children[0].children().filter(|n| n.is_element()).collect();
    assert_eq!(parameters.len(), set.parameters.len());
    for (node, p) in parameters.iter().zip(&set.parameters) {
        assert_eq!((node.tag_name().namespace(), node.tag_name().name()), (Some(NAMESPACE), "Parameter"));
        assert_eq!(node.attribute("name"), Some(p.name.as_str()));
        let typed: Vec<_> = node.children().filter(|n| n.is_element()).collect();
        assert_eq!(typed.len(), 1, "exactly one type element");
        assert_eq!((typed[0].tag_name().namespace(), typed[0].tag_name().name()), (Some(NAMESPACE), "Real"));
        let value: f64 = typed[0].attribute("value").unwrap().parse().unwrap();
        assert_eq!(value.to_bits(), p.value.to_bits(), "{}", p.name);
        assert_eq!(typed[0].attribute("unit"), p.unit.as_deref());
    }
    let unit = children[1].children().find(|n| n.is_element()).unwrap();
    assert_eq!((unit.tag_name().namespace(), unit.tag_name().name()), (Some(COMMON_NAMESPACE), "Unit"));
    let base = unit.children().find(|n| n.is_element()).unwrap();
    assert_eq!((base.tag_name().namespace(), base.tag_name().name()), (Some(COMMON_NAMESPACE), "BaseUnit"));
    assert_eq!((base.attribute("kg"), base.attribute("m"), base.attribute("s")), (Some("2"), Some("2"), Some("-7")));

    // And back.
    let read = ssv::read(&path).unwrap();
    assert_eq!(read, set);
    for (a, b) in read.parameters.iter().zip(&set.parameters) {
        assert_eq!(a.value.to_bits(), b.value.to_bits());
    }
    let _ = std::fs::remove_file(&path);
}

#[test]
fn the_reader_takes_other_tools_number_types_and_refuses_what_is_not_an_ssv() {
    let other = format!(
        "<ssv:ParameterSet xmlns:ssv=\"{NAMESPACE}\" version=\"1.0\" name=\"p\"><ssv:Parameters>\
         <ssv:Parameter name=\"a\"><ssv:Real value=\"1.5E+06\" unit=\"N\"/></ssv:Parameter>\
         <ssv:Parameter name=\"n\"><ssv:Integer value=\"3\"/></ssv:Parameter>\
         <ssv:Parameter name=\"b\"><ssv:Boolean value=\"true\"/></ssv:Parameter>\
         </ssv:Parameters></ssv:ParameterSet>"
    );
    let set = ssv::parse(&other).unwrap();
    assert_eq!(set.values(), [("a".to_string(), 1.5e6), ("n".to_string(), 3.0), ("b".to_string(), 1.0)]);

    let string_typed = other.replace("<ssv:Integer value=\"3\"/>", "<ssv:String value=\"x\"/>");
    assert!(ssv::parse(&string_typed).unwrap_err().contains("parameter n is of type String"));
    let wrong_namespace = other.replace(NAMESPACE, "http://example.invalid/other");
    assert!(ssv::parse(&wrong_namespace).unwrap_err().contains("not the ParameterSet"));
    assert!(ssv::parse("<ssv:ParameterSet").unwrap_err().contains("not well-formed"));
    let version_two = other.replace("version=\"1.0\"", "version=\"2.0\"");
    assert!(ssv::parse(&version_two).unwrap_err().contains("version 2.0"));
    let twice = other.replace("name=\"n\"", "name=\"a\"");
    assert!(ssv::parse(&twice).unwrap_err().contains("given twice"));
    let bad_number = other.replace("1.5E+06", "inf");
    assert!(ssv::parse(&bad_number).unwrap_err().contains("is not a Real"));
}
