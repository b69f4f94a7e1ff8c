//! SSP 1.0 systems (System Structure and Parameterization, Modelica Association): an
//! `.ssp` archive holds `SystemStructure.ssd` (the FMUs as components, their connectors
//! and connections, the default experiment), the FMUs under `resources/`, and a
//! parameter set (`.ssv`) the system binds. What is written here opens in any SSP
//! importer (fmpy's reader validates it against the standard's schemas); what is read is
//! the subset written: components of FMUs, Real connectors, connections one to one,
//! parameter sets (`start_values::ssv`) bound at the system level, with names
//! `<component>.<variable>`.
//!
//! SSP 1.0 has no communication step; the archive carries it as an annotation of the
//! default experiment, of the type [`STEP_ANNOTATION`].

use std::fs::{self, File};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context};
use start_values::ssv::{self, ParameterSet};
use zip::write::SimpleFileOptions;

/// The type of the default experiment's annotation that holds the communication step.
pub const STEP_ANNOTATION: &str = "org.kalfmu.communication-step";

const SSD_NS: &str = "http://ssp-standard.org/SSP1/SystemStructureDescription";
const SSC_NS: &str = "http://ssp-standard.org/SSP1/SystemStructureCommon";

/// A system of FMUs.
#[derive(Debug, Clone, PartialEq)]
pub struct System {
    /// The system's name.
    pub name: String,
    /// The components, in the order the master instantiates and steps them.
    pub components: Vec<Component>,
    /// Output to input, one to one.
    pub connections: Vec<Connection>,
    /// The bound parameter set, its names `<component>.<variable>`.
    pub parameters: ParameterSet,
    /// The default experiment.
    pub experiment: Experiment,
}

/// An FMU in a system.
#[derive(Debug, Clone, PartialEq)]
pub struct Component {
    /// Its instance name.
    pub name: String,
    /// The `.fmu` inside the archive (`resources/<identifier>.fmu`).
    pub source: String,
    /// The connected variables: `(name, is an input)`.
    pub connectors: Vec<(String, bool)>,
}

/// An output of one component fed to an input of another.
#[derive(Debug, Clone, PartialEq)]
pub struct Connection {
    /// `(component, output)`.
    pub from: (String, String),
    /// `(component, input)`.
    pub to: (String, String),
}

/// The default experiment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Experiment {
    /// Start time (s).
    pub start: f64,
    /// Stop time (s).
    pub stop: f64,
    /// Communication step (s).
    pub step: f64,
}

impl System {
    /// The parameters of `component`, by variable name.
    pub fn parameters_of(&self, component: &str) -> Vec<(&str, f64)> {
        let prefix = format!("{component}.");
        self.parameters.parameters.iter().filter_map(|p| p.name.strip_prefix(&prefix).map(|n| (n, p.value))).collect()
    }
}

/// Writes `system` as an `.ssp` archive at `out`, with the FMU of each component read
/// from `fmus` (`(source, path)`) and its parameter set as `resources/<name>.ssv`.
pub fn write(system: &System, fmus: &[(&str, &Path)], out: &Path) -> anyhow::Result<()> {
    let file = File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut zip = zip::ZipWriter::new(file);
    let options = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let ssv = format!("resources/{}.ssv", system.name);
    let mut entries: Vec<(String, Vec<u8>)> = vec![
        ("SystemStructure.ssd".into(), ssd(system, &ssv).into_bytes()),
        (ssv, ssv::to_xml(&system.parameters).into_bytes()),
    ];
    for component in &system.components {
        let (_, path) = fmus
            .iter()
            .find(|(source, _)| *source == component.source)
            .ok_or_else(|| anyhow!("no FMU given for {}", component.source))?;
        let bytes = fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        entries.push((component.source.clone(), bytes));
    }
    for (name, bytes) in entries {
        zip.start_file(name.as_str(), options).with_context(|| format!("{}: {name}", out.display()))?;
        zip.write_all(&bytes).with_context(|| format!("{}: {name}", out.display()))?;
    }
    zip.finish().with_context(|| format!("{}", out.display()))?;
    Ok(())
}

fn ssd(system: &System, ssv: &str) -> String {
    let mut x = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<ssd:SystemStructureDescription xmlns:ssc=\"{SSC_NS}\" \
         xmlns:ssd=\"{SSD_NS}\" version=\"1.0\" name=\"{}\">\n  <ssd:System name=\"{}\">\n    \
         <ssd:ParameterBindings>\n      <ssd:ParameterBinding source=\"{}\"/>\n    </ssd:ParameterBindings>\n    \
         <ssd:Elements>\n",
        esc(&system.name),
        esc(&system.name),
        esc(ssv)
    );
    for c in &system.components {
        x += &format!(
            "      <ssd:Component name=\"{}\" type=\"application/x-fmu-sharedlibrary\" source=\"{}\">\n        \
             <ssd:Connectors>\n",
            esc(&c.name),
            esc(&c.source)
        );
        for (name, input) in &c.connectors {
            let kind = if *input { "input" } else { "output" };
            x += &format!(
                "          <ssd:Connector name=\"{}\" kind=\"{kind}\"><ssc:Real/></ssd:Connector>\n",
                esc(name)
            );
        }
        x += "        </ssd:Connectors>\n      </ssd:Component>\n";
    }
    x += "    </ssd:Elements>\n    <ssd:Connections>\n";
    for c in &system.connections {
        x += &format!(
            "      <ssd:Connection startElement=\"{}\" startConnector=\"{}\" endElement=\"{}\" endConnector=\"{}\"/>\n",
            esc(&c.from.0),
            esc(&c.from.1),
            esc(&c.to.0),
            esc(&c.to.1)
        );
    }
    let e = system.experiment;
    x += &format!(
        "    </ssd:Connections>\n  </ssd:System>\n  <ssd:DefaultExperiment startTime=\"{:?}\" stopTime=\"{:?}\">\n    \
         <ssd:Annotations>\n      <ssc:Annotation type=\"{STEP_ANNOTATION}\"><step size=\"{:?}\"/></ssc:Annotation>\n    \
         </ssd:Annotations>\n  </ssd:DefaultExperiment>\n</ssd:SystemStructureDescription>\n",
        e.start, e.stop, e.step
    );
    x
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Reads the `.ssp` at `path` and unpacks its FMUs into `dir`: the system, and where
/// each component's FMU now is (in the order of the components).
pub fn read(path: &Path, dir: &Path) -> anyhow::Result<(System, Vec<PathBuf>)> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut archive = zip::ZipArchive::new(file).with_context(|| format!("{} is not a zip archive", path.display()))?;
    let mut text = |name: &str| -> anyhow::Result<String> {
        let mut s = String::new();
        archive
            .by_name(name)
            .with_context(|| format!("{} has no {name}", path.display()))?
            .read_to_string(&mut s)
            .with_context(|| format!("{}: {name}", path.display()))?;
        Ok(s)
    };
    let ssd_text = text("SystemStructure.ssd")?;
    let doc =
        roxmltree::Document::parse(&ssd_text).with_context(|| format!("{}: SystemStructure.ssd", path.display()))?;
    let root = doc.root_element();
    fn ssd(node: &roxmltree::Node, name: &str) -> bool {
        node.tag_name().namespace() == Some(SSD_NS) && node.tag_name().name() == name
    }
    fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
        node.children().find(|c| ssd(c, name))
    }
    let attribute = |node: &roxmltree::Node, name: &str| -> anyhow::Result<String> {
        node.attribute(name).map(str::to_owned).ok_or_else(|| anyhow!("<{}> without {name}", node.tag_name().name()))
    };
    let system_node = child(root, "System").ok_or_else(|| anyhow!("SystemStructure.ssd has no System"))?;
    let mut components = Vec::new();
    for c in child(system_node, "Elements").into_iter().flat_map(|e| e.children()).filter(|c| c.is_element()) {
        if !ssd(&c, "Component") {
            bail!("element <{}> in the system: this master runs components of FMUs only", c.tag_name().name());
        }
        let connectors = child(c, "Connectors")
            .into_iter()
            .flat_map(|n| n.children().filter(|n| ssd(n, "Connector")))
            .map(|n| Ok((attribute(&n, "name")?, attribute(&n, "kind")? == "input")))
            .collect::<anyhow::Result<Vec<_>>>()?;
        components.push(Component { name: attribute(&c, "name")?, source: attribute(&c, "source")?, connectors });
    }
    let connections = child(system_node, "Connections")
        .into_iter()
        .flat_map(|n| n.children().filter(|n| ssd(n, "Connection")))
        .map(|n| {
            Ok(Connection {
                from: (attribute(&n, "startElement")?, attribute(&n, "startConnector")?),
                to: (attribute(&n, "endElement")?, attribute(&n, "endConnector")?),
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let sources: Vec<String> = child(system_node, "ParameterBindings")
        .into_iter()
        .flat_map(|n| n.children().filter(|n| ssd(n, "ParameterBinding")))
        .map(|n| attribute(&n, "source"))
        .collect::<anyhow::Result<_>>()?;
    let experiment_node = child(root, "DefaultExperiment").ok_or_else(|| anyhow!("no DefaultExperiment"))?;
    let number = |node: &roxmltree::Node, name: &str| -> anyhow::Result<f64> {
        attribute(node, name)?.trim().parse().map_err(|e| anyhow!("{name}: {e}"))
    };
    let step_node = experiment_node
        .descendants()
        .find(|n| n.attribute("type") == Some(STEP_ANNOTATION))
        .and_then(|a| a.children().find(|n| n.is_element()))
        .ok_or_else(|| anyhow!("the default experiment has no {STEP_ANNOTATION} annotation"))?;
    let experiment = Experiment {
        start: number(&experiment_node, "startTime")?,
        stop: number(&experiment_node, "stopTime")?,
        step: number(&step_node, "size")?,
    };
    let name = attribute(&system_node, "name")?;
    let mut parameters = ParameterSet::new(&name);
    for source in &sources {
        let set = ssv::parse(&text(source)?).map_err(|e| anyhow!("{}: {source}: {e}", path.display()))?;
        parameters.parameters.extend(set.parameters);
    }
    fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut unpacked = Vec::new();
    for c in &components {
        let target = dir.join(Path::new(&c.source).file_name().ok_or_else(|| anyhow!("bad source {}", c.source))?);
        let mut bytes = Vec::new();
        archive
            .by_name(&c.source)
            .with_context(|| format!("{} has no {}", path.display(), c.source))?
            .read_to_end(&mut bytes)?;
        fs::write(&target, bytes).with_context(|| format!("cannot write {}", target.display()))?;
        unpacked.push(target);
    }
    Ok((System { name, components, connections, parameters, experiment }, unpacked))
}
