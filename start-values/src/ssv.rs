//! FMU start values as an SSP parameter-value file (SSV, [SSP1] §6, schema
//! `SystemStructureParameterValues.xsd` 1.0): a `ssv:ParameterSet` (attributes `version`
//! "1.0" and `name`, both required) holding `ssv:Parameters`, one `ssv:Parameter` per
//! value (attribute `name`, the FMU variable's name), each with one `ssv:Real` (attribute
//! `value`, an `xs:double`; `unit` optional, naming a unit of the set's `ssv:Units`, whose
//! `ssc:Unit` elements of the common namespace give its SI exponents). Importers that
//! take SSP parameter sets (and our own commands, through [`read`]) apply them to the FMU.
//!
//! The reader takes any conforming SSV 1.x file, its parameters of type `Real`, `Integer`
//! or `Boolean` as numbers (an FMU stores all three as one), and refuses the others by name.

use std::fmt::Write as _;
use std::path::Path;

/// The SSV namespace.
pub const NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureParameterValues";
/// The SSP common namespace (units).
pub const COMMON_NAMESPACE: &str = "http://ssp-standard.org/SSP1/SystemStructureCommon";
/// The SSV version written.
pub const VERSION: &str = "1.0";

/// The type a value is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueKind {
    /// `ssv:Real`.
    Real,
    /// `ssv:Integer` (an FMU's Integer or Enumeration).
    Integer,
    /// `ssv:Boolean`.
    Boolean,
}

/// One parameter value.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// The FMU variable it sets.
    pub name: String,
    /// Its value.
    pub value: f64,
    /// The type it is written as (a number of an Integer or Boolean is whole, 0 or 1).
    pub kind: ValueKind,
    /// Its unit, one of the set's [`Unit`]s.
    pub unit: Option<String>,
    /// A note for the reader (the `description` attribute).
    pub description: Option<String>,
}

/// A unit: its name and the exponents of `kg, m, s, A, K, mol, cd, rad`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unit {
    /// The unit's name, as the parameters' `unit` attributes give it.
    pub name: String,
    /// Exponents of kg, m, s, A, K, mol, cd, rad.
    pub exponents: [i32; 8],
}

/// The base units in the order of [`Unit::exponents`], as the schema names them.
const BASE_UNITS: [&str; 8] = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"];

/// A parameter set: a whole SSV file.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterSet {
    /// Its name (required by the schema).
    pub name: String,
    /// What it is (the `description` attribute).
    pub description: Option<String>,
    /// The tool that wrote it (the `generationTool` attribute).
    pub generation_tool: Option<String>,
    /// The values, in order.
    pub parameters: Vec<Parameter>,
    /// The units the values use.
    pub units: Vec<Unit>,
}

impl ParameterSet {
    /// An empty set called `name`.
    pub fn new(name: &str) -> Self {
        Self { name: name.into(), description: None, generation_tool: None, parameters: Vec::new(), units: Vec::new() }
    }

    /// The values as `(name, value)` pairs, in order.
    pub fn values(&self) -> Vec<(String, f64)> {
        self.parameters.iter().map(|p| (p.name.clone(), p.value)).collect()
    }
}

/// `s` escaped for an XML attribute value in double quotes (white space other than the
/// blank as character references: a parser would normalise it to blanks).
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            '\t' => out.push_str("&#9;"),
            c => out.push(c),
        }
    }
    out
}

/// An `xs:double` that reads back to the same bits: the shortest exponent form
/// (`1.56e6`), `INF`, `-INF`, `NaN`.
fn double(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v.is_infinite() {
        if v > 0.0 { "INF" } else { "-INF" }.into()
    } else {
        format!("{v:e}")
    }
}

/// An `xs:double`'s lexical form as a number.
fn parse_double(s: &str) -> Option<f64> {
    match s.trim() {
        "INF" | "+INF" => Some(f64::INFINITY),
        "-INF" => Some(f64::NEG_INFINITY),
        "NaN" => Some(f64::NAN),
        // Rust's float syntax also takes "inf" and "nan", which xs:double does not.
        t if t.chars().all(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-')) => t.parse().ok(),
        _ => None,
    }
}

/// The SSV document of `set`.
pub fn to_xml(set: &ParameterSet) -> String {
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = write!(
        x,
        "<ssv:ParameterSet xmlns:ssv=\"{NAMESPACE}\" xmlns:ssc=\"{COMMON_NAMESPACE}\" version=\"{VERSION}\" name=\"{}\"",
        escape(&set.name)
    );
    if let Some(d) = &set.description {
        let _ = write!(x, " description=\"{}\"", escape(d));
    }
    if let Some(t) = &set.generation_tool {
        let _ = write!(x, " generationTool=\"{}\"", escape(t));
    }
    x.push_str(">\n  <ssv:Parameters>\n");
    for p in &set.parameters {
        let _ = write!(x, "    <ssv:Parameter name=\"{}\"", escape(&p.name));
        if let Some(d) = &p.description {
            let _ = write!(x, " description=\"{}\"", escape(d));
        }
        let _ = match p.kind {
            ValueKind::Real => write!(x, ">\n      <ssv:Real value=\"{}\"", double(p.value)),
            ValueKind::Integer => write!(x, ">\n      <ssv:Integer value=\"{}\"", p.value),
            ValueKind::Boolean => write!(x, ">\n      <ssv:Boolean value=\"{}\"", p.value != 0.0),
        };
        if let Some(u) = &p.unit {
            let _ = write!(x, " unit=\"{}\"", escape(u));
        }
        x.push_str("/>\n    </ssv:Parameter>\n");
    }
    x.push_str("  </ssv:Parameters>\n");
    if !set.units.is_empty() {
        x.push_str("  <ssv:Units>\n");
        for u in &set.units {
            let _ = write!(x, "    <ssc:Unit name=\"{}\">\n      <ssc:BaseUnit", escape(&u.name));
            for (base, e) in BASE_UNITS.iter().zip(u.exponents) {
                if e != 0 {
                    let _ = write!(x, " {base}=\"{e}\"");
                }
            }
            x.push_str("/>\n    </ssc:Unit>\n");
        }
        x.push_str("  </ssv:Units>\n");
    }
    x.push_str("</ssv:ParameterSet>\n");
    x
}

/// Writes `set` to `path`.
pub fn write(path: &Path, set: &ParameterSet) -> Result<(), String> {
    std::fs::write(path, to_xml(set)).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads the SSV file at `path`.
pub fn read(path: &Path) -> Result<ParameterSet, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Whether `node` is the element `name` of namespace `namespace`.
fn is(node: &roxmltree::Node<'_, '_>, namespace: &str, name: &str) -> bool {
    node.is_element() && node.tag_name().name() == name && node.tag_name().namespace() == Some(namespace)
}

/// Parses an SSV document.
pub fn parse(text: &str) -> Result<ParameterSet, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not well-formed XML: {e}"))?;
    let root = doc.root_element();
    if !is(&root, NAMESPACE, "ParameterSet") {
        return Err(format!(
            "the root element is {{{}}}{}, not the ParameterSet of {NAMESPACE}",
            root.tag_name().namespace().unwrap_or(""),
            root.tag_name().name()
        ));
    }
    let version = root.attribute("version").ok_or("the ParameterSet has no version")?;
    if !version.starts_with("1.") {
        return Err(format!("SSV version {version}; this reader reads 1.x"));
    }
    let name = root.attribute("name").ok_or("the ParameterSet has no name")?;
    let mut set = ParameterSet::new(name);
    set.description = root.attribute("description").map(String::from);
    set.generation_tool = root.attribute("generationTool").map(String::from);
    let mut parameters = root.children().filter(|n| is(n, NAMESPACE, "Parameters"));
    let list = parameters.next().ok_or("the ParameterSet has no Parameters element")?;
    if parameters.next().is_some() {
        return Err("the ParameterSet has two Parameters elements".into());
    }
    for p in list.children().filter(|n| is(n, NAMESPACE, "Parameter")) {
        let name = p.attribute("name").ok_or("a Parameter has no name")?;
        if set.parameters.iter().any(|q| q.name == name) {
            return Err(format!("parameter {name} is given twice"));
        }
        let typed = p
            .children()
            .find(|n| n.is_element() && n.tag_name().namespace() == Some(NAMESPACE))
            .ok_or_else(|| format!("parameter {name} has no value element"))?;
        let text = typed.attribute("value").ok_or_else(|| format!("parameter {name} has no value"))?;
        let (value, kind) = match typed.tag_name().name() {
            "Real" => (parse_double(text), ValueKind::Real),
            "Integer" => (text.trim().parse::<i32>().ok().map(f64::from), ValueKind::Integer),
            "Boolean" => {
                let value = match text.trim() {
                    "true" | "1" => Some(1.0),
                    "false" | "0" => Some(0.0),
                    _ => None,
                };
                (value, ValueKind::Boolean)
            }
            other => return Err(format!("parameter {name} is of type {other}; an FMU start value here is a number")),
        };
        let value = value.ok_or_else(|| format!("parameter {name}: '{text}' is not a {}", typed.tag_name().name()))?;
        set.parameters.push(Parameter {
            name: name.into(),
            value,
            kind,
            unit: typed.attribute("unit").map(String::from),
            description: p.attribute("description").map(String::from),
        });
    }
    if let Some(units) = root.children().find(|n| is(n, NAMESPACE, "Units")) {
        for u in units.children().filter(|n| is(n, COMMON_NAMESPACE, "Unit")) {
            let name = u.attribute("name").ok_or("a Unit has no name")?;
            let mut exponents = [0; 8];
            if let Some(base) = u.children().find(|n| is(n, COMMON_NAMESPACE, "BaseUnit")) {
                for (e, key) in exponents.iter_mut().zip(BASE_UNITS) {
                    if let Some(v) = base.attribute(key) {
                        *e = v.trim().parse().map_err(|_| format!("unit {name}: exponent {key}='{v}'"))?;
                    }
                }
            }
            set.units.push(Unit { name: name.into(), exponents });
        }
    }
    // A unit the Units element does not define is kept as it is: the schema cannot check
    // it, and other tools write such files.
    Ok(set)
}
