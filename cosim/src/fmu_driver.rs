//! Drives a packaged FMU through the `fmi` crate's importer, as an external
//! co-simulation master would: instantiate, set parameters by name,
//! initialise, then at each communication point `t` set the inputs (the
//! plant's outputs of `t`), read the outputs, `fmi2DoStep(t, h)`, read again.
//! Nothing here knows the estimator inside.

use std::collections::HashMap;
use std::path::Path;

use anyhow::{anyhow, bail, Context};
use estimator::FilterKind;
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::schema::fmi2::{Causality, ScalarVariableElement};
use fmi::traits::{FmiImport, FmiInstance};
use start_values::ssv::ValueKind;
use start_values::StartValues;

/// An imported FMU: its variables by name, and instances made from it.
pub struct ImportedFmu {
    import: Fmi2Import,
    variables: HashMap<String, u32>,
    parameters: HashMap<String, ParameterType>,
    units: HashMap<String, String>,
}

/// The type of a parameter, which says which `fmi2Set…` takes its value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ParameterType {
    Real,
    /// Integer or Enumeration.
    Integer,
    Boolean,
    String,
}

/// The FMU's enumeration value of a filter kind (`FilterKind` in every modelDescription:
/// the library's order, from 1).
pub fn filter_enumeration(kind: FilterKind) -> i32 {
    FilterKind::ALL.iter().position(|k| *k == kind).expect("every kind is listed") as i32 + 1
}

impl ImportedFmu {
    /// Loads `<identifier>.fmu` from `dir`, where `package-fmus` writes them; if it is not
    /// there, says how to package it.
    pub fn load_packaged(dir: &Path, identifier: &str) -> anyhow::Result<Self> {
        let path = dir.join(format!("{identifier}.fmu"));
        if !path.is_file() {
            bail!(
                "{} not found: package the FMUs first (cargo run --release -p fmu --bin package-fmus), or run scripts/reproduce",
                path.display()
            );
        }
        Self::load(&path)
    }

    /// Unpacks and loads the `.fmu` at `path`.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let import: Fmi2Import =
            fmi::import::from_path(path).with_context(|| format!("cannot import the FMU {}", path.display()))?;
        let description = import.model_description();
        let variables =
            description.model_variables.variables.iter().map(|v| (v.name.clone(), v.value_reference)).collect();
        let parameters = description
            .model_variables
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Parameter)
            .map(|v| {
                let kind = match v.elem {
                    ScalarVariableElement::Real(_) => ParameterType::Real,
                    ScalarVariableElement::Integer(_) | ScalarVariableElement::Enumeration => ParameterType::Integer,
                    ScalarVariableElement::Boolean(_) => ParameterType::Boolean,
                    ScalarVariableElement::String => ParameterType::String,
                };
                (v.name.clone(), kind)
            })
            .collect();
        let units = units_of(path)?;
        Ok(Self { import, variables, parameters, units })
    }

    /// The value reference of the variable `name`.
    pub fn vr(&self, name: &str) -> anyhow::Result<u32> {
        self.variables.get(name).copied().ok_or_else(|| anyhow!("the FMU has no variable '{name}'"))
    }

    /// The unit declared for `name` (empty if none).
    pub fn unit(&self, name: &str) -> String {
        self.units.get(name).cloned().unwrap_or_default()
    }

    /// A new instance, initialised from `start_time` to `stop_time` with these
    /// parameters (Reals and Integers/Enumerations by name), then the user's
    /// `start_values` over them, each set by its parameter's type, and the
    /// plant's outputs at the start on the `inputs` (value references), as a
    /// master propagating initial values sets them in initialisation mode.
    #[allow(clippy::too_many_arguments)]
    pub fn instantiate(
        &self,
        name: &str,
        start_time: f64,
        stop_time: f64,
        reals: &[(&str, f64)],
        integers: &[(&str, i32)],
        start_values: &StartValues,
        inputs: (&[u32], &[f64]),
    ) -> anyhow::Result<Instance> {
        // Checked before anything is instantiated, so that a misspelt name costs no run.
        let typed =
            start_values.iter().map(|(n, v)| self.typed_start_value(n, v)).collect::<anyhow::Result<Vec<_>>>()?;
        let mut cs = self.import.instantiate_cs(name, false, true).map_err(|e| anyhow!("fmi2Instantiate: {e}"))?;
        FmiInstance::enter_initialization_mode(&mut cs, None, start_time, Some(stop_time))
            .map_err(|e| anyhow!("fmi2SetupExperiment/EnterInitializationMode: {e}"))?;
        let (vrs, values): (Vec<u32>, Vec<f64>) = reals
            .iter()
            .map(|(n, v)| self.vr(n).map(|vr| (vr, *v)))
            .collect::<anyhow::Result<Vec<_>>>()?
            .into_iter()
            .unzip();
        Common::set_real(&mut cs, &vrs, &values).map_err(|e| anyhow!("fmi2SetReal of the parameters: {e}"))?;
        let (vrs, values): (Vec<u32>, Vec<i32>) = integers
            .iter()
            .map(|(n, v)| self.vr(n).map(|vr| (vr, *v)))
            .collect::<anyhow::Result<Vec<_>>>()?
            .into_iter()
            .unzip();
        Common::set_integer(&mut cs, &vrs, &values).map_err(|e| anyhow!("fmi2SetInteger of the parameters: {e}"))?;
        for (vr, name, value) in typed {
            match value {
                Typed::Real(v) => Common::set_real(&mut cs, &[vr], &[v]).map(|_| ()),
                Typed::Integer(v) => Common::set_integer(&mut cs, &[vr], &[v]).map(|_| ()),
                Typed::Boolean(v) => Common::set_boolean(&mut cs, &[vr], &[v]).map(|_| ()),
            }
            .map_err(|e| anyhow!("start value {name}: the FMU refused it: {e}"))?;
        }
        Common::set_real(&mut cs, inputs.0, inputs.1)
            .map_err(|e| anyhow!("fmi2SetReal of the inputs in initialisation mode: {e}"))?;
        Common::exit_initialization_mode(&mut cs).map_err(|e| anyhow!("fmi2ExitInitializationMode: {e}"))?;
        Ok(Instance { cs, time: start_time })
    }

    /// The type an SSP parameter set writes the value of parameter `name` as, if it is one.
    pub fn value_kind(&self, name: &str) -> Option<ValueKind> {
        self.parameters.get(name).and_then(|t| match t {
            ParameterType::Real => Some(ValueKind::Real),
            ParameterType::Integer => Some(ValueKind::Integer),
            ParameterType::Boolean => Some(ValueKind::Boolean),
            ParameterType::String => None,
        })
    }

    /// Whether the FMU takes every one of `start_values`: an error names the first it does
    /// not (no such parameter, a fraction for an Integer, …), before anything runs.
    /// The filter is not one: the studies run every kind and label their logs by it.
    pub fn check_start_values(&self, start_values: &StartValues) -> anyhow::Result<()> {
        if start_values.get("filter").is_some() {
            bail!("the filter is the study's choice, not a start value: drop 'filter' from --set/--values");
        }
        start_values.iter().try_for_each(|(n, v)| self.typed_start_value(n, v).map(|_| ()))
    }

    /// The value reference of the parameter `name` and `value` as its type has it; an error
    /// names what is wrong (no such parameter, a fraction for an Integer, …).
    fn typed_start_value<'n>(&self, name: &'n str, value: f64) -> anyhow::Result<(u32, &'n str, Typed)> {
        let kind = self.parameters.get(name).ok_or_else(|| match self.variables.contains_key(name) {
            true => anyhow!("start value {name}: '{name}' is not a parameter of the FMU"),
            false => anyhow!("start value {name}: the FMU has no variable '{name}'"),
        })?;
        let integral = || -> anyhow::Result<i32> {
            if value.fract() != 0.0 || value.abs() > i32::MAX as f64 {
                bail!("start value {name}: {value} is not an Integer, which the parameter is");
            }
            Ok(value as i32)
        };
        let typed = match kind {
            ParameterType::Real => Typed::Real(value),
            ParameterType::Integer => Typed::Integer(integral()?),
            ParameterType::Boolean => match value {
                0.0 => Typed::Boolean(0),
                1.0 => Typed::Boolean(1),
                _ => bail!("start value {name}: a Boolean is 0 or 1, got {value}"),
            },
            ParameterType::String => bail!("start value {name}: String parameters are not taken"),
        };
        Ok((self.vr(name)?, name, typed))
    }
}

/// A start value as the parameter's type has it.
enum Typed {
    Real(f64),
    Integer(i32),
    Boolean(i32),
}

/// A running instance.
pub struct Instance {
    cs: InstanceCS,
    time: f64,
}

impl Instance {
    /// The communication point the instance is at.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Sets the inputs at the current communication point.
    pub fn set_inputs(&mut self, inputs: &[u32], values: &[f64]) -> anyhow::Result<()> {
        Common::set_real(&mut self.cs, inputs, values)
            .map(|_| ())
            .map_err(|e| anyhow!("fmi2SetReal at t = {}: {e}", self.time))
    }

    /// Reads `outputs` into `values`; every one must be finite.
    pub fn read(&mut self, outputs: &[u32], values: &mut [f64]) -> anyhow::Result<()> {
        Common::get_real(&mut self.cs, outputs, values)
            .map_err(|e| anyhow!("fmi2GetReal at t = {}: {e}", self.time))?;
        if values.iter().any(|v| !v.is_finite()) {
            bail!("the FMU returned a non-finite output at t = {}", self.time);
        }
        Ok(())
    }

    /// Reads `outputs` into `values` as they are, non-finite ones too (a
    /// study of faults reads what a lost filter shows).
    pub fn read_as_is(&mut self, outputs: &[u32], values: &mut [f64]) -> anyhow::Result<()> {
        Common::get_real(&mut self.cs, outputs, values)
            .map(|_| ())
            .map_err(|e| anyhow!("fmi2GetReal at t = {}: {e}", self.time))
    }

    /// Reads the Boolean `outputs` into `values` (fmi2Boolean: 0 false, else true).
    pub fn read_booleans(&mut self, outputs: &[u32], values: &mut [i32]) -> anyhow::Result<()> {
        Common::get_boolean(&mut self.cs, outputs, values)
            .map(|_| ())
            .map_err(|e| anyhow!("fmi2GetBoolean at t = {}: {e}", self.time))
    }

    /// Reads the Integer `outputs` into `values`.
    pub fn read_integers(&mut self, outputs: &[u32], values: &mut [i32]) -> anyhow::Result<()> {
        Common::get_integer(&mut self.cs, outputs, values)
            .map(|_| ())
            .map_err(|e| anyhow!("fmi2GetInteger at t = {}: {e}", self.time))
    }

    /// `fmi2DoStep(t, h)` from the current communication point; whether the
    /// FMU returned fmi2Warning (a step made, with something to say: a lost filter).
    pub fn do_step(&mut self, h: f64) -> anyhow::Result<bool> {
        let res = self.cs.do_step(self.time, h, true).map_err(|e| anyhow!("fmi2DoStep at t = {}: {e}", self.time))?;
        self.time += h;
        Ok(matches!(res, fmi::fmi2::Fmi2Res::Warning))
    }

    /// `fmi2Terminate`.
    pub fn terminate(mut self) -> anyhow::Result<()> {
        Common::terminate(&mut self.cs).map_err(|e| anyhow!("fmi2Terminate: {e}"))?;
        Ok(())
    }
}

/// The `unit` of every variable, read from the FMU's `modelDescription.xml`
/// (`fmi-schema` does not keep units).
fn units_of(path: &Path) -> anyhow::Result<HashMap<String, String>> {
    let file = std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut archive = zip::ZipArchive::new(file).with_context(|| format!("{} is not a zip archive", path.display()))?;
    let mut xml = String::new();
    std::io::Read::read_to_string(
        &mut archive
            .by_name("modelDescription.xml")
            .with_context(|| format!("{} has no modelDescription.xml", path.display()))?,
        &mut xml,
    )?;
    let attribute = |text: &str, key: &str| -> Option<String> {
        let start = text.find(&format!("{key}=\""))? + key.len() + 2;
        Some(text[start..start + text[start..].find('"')?].to_string())
    };
    let mut units = HashMap::new();
    for variable in xml.split("<ScalarVariable ").skip(1) {
        let body = variable.split("</ScalarVariable>").next().unwrap_or_default();
        if let (Some(name), Some(unit)) = (attribute(body, "name"), attribute(body, "unit")) {
            units.insert(name, unit);
        }
    }
    Ok(units)
}
