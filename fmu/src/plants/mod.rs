//! The plant FMUs: the studies' truths as FMUs a master steps beside an estimator
//! FMU. Each is a [`PlantDescriptor`]: its variable table and the function that
//! builds the plant from parameter values. They run in the same shell as the
//! estimators (`instance.rs`, the C ABI, the state masks, the logging, the FMU
//! state); adding one is adding a file here and a line in [`all`].

mod s1_chain;
mod s2_track;
mod s5_flight;

use crate::estimators::{guid_of, DefaultExperiment};
use crate::model_description;
use crate::serialize::{Reader, Writer};
use crate::variables::{check_table, Parameters, Role, Variable};

/// A plant as the shell steps it: inputs held over each step, outputs of the
/// time it stands at. A plant integrates internally at its own (finer) step.
pub trait Plant {
    /// Sets input `j` (the variable of `Role::PlantInput(j)`), held from now on
    /// over the steps that follow; refused, with nothing changed, if the plant
    /// cannot take it.
    fn set_input(&mut self, j: usize, value: f64) -> Result<(), String>;
    /// Advances `h` seconds; refused, with nothing changed, when `h` is no whole
    /// number of the plant's own steps.
    fn advance(&mut self, h: f64) -> Result<(), String>;
    /// The outputs now: `out[k]` is that of `Role::PlantOutput(k)`.
    fn outputs(&mut self, out: &mut [f64]);
    /// Everything that makes the plant where it is (its parameters aside).
    fn save(&self) -> Vec<u8>;
    /// Back to what [`Plant::save`] gave, for a plant built from the same parameters;
    /// refused, with nothing changed, for bytes that are not such a state.
    fn restore(&mut self, saved: &[u8]) -> Result<(), String>;
}

/// How many integration steps of `step` the communication step `h` is; refused when it is
/// no whole number of them.
fn integration_steps(h: f64, step: f64) -> Result<usize, String> {
    let steps = (h / step).round();
    if steps < 1.0 || (steps * step - h).abs() > 1e-9 * h {
        return Err(format!("the communication step {h} s is not a whole number of integration steps ({step} s)"));
    }
    Ok(steps as usize)
}

/// Writes a noise stream's position (a `u128`) as two `u64`.
fn write_position(w: &mut Writer, position: u128) {
    w.u64(position as u64);
    w.u64((position >> 64) as u64);
}

/// Reads what [`write_position`] wrote.
fn read_position(r: &mut Reader<'_>) -> Result<u128, String> {
    Ok(u128::from(r.u64()?) | (u128::from(r.u64()?) << 64))
}

/// Builds the plant at the start from the parameter values.
pub type BuildPlant = fn(&Parameters) -> Result<Box<dyn Plant>, String>;

/// Everything that makes one plant FMU.
#[derive(Debug)]
pub struct PlantDescriptor {
    /// `modelIdentifier` (also the name of the binary in the FMU).
    pub model_identifier: &'static str,
    /// `modelName`.
    pub model_name: &'static str,
    /// `description`.
    pub description: &'static str,
    /// HTML paragraphs on the plant, for `documentation/index.html`.
    pub documentation: &'static str,
    /// The variables; value reference = position.
    pub variables: Vec<Variable>,
    /// `<DefaultExperiment>`.
    pub default_experiment: DefaultExperiment,
    /// Plant construction.
    pub build: BuildPlant,
    guid: String,
}

impl PlantDescriptor {
    /// Completes a description: the GUID from the whole table.
    fn finish(mut self) -> Self {
        self.guid = guid_of(self.model_identifier, &self.variables);
        self
    }

    /// The GUID: a hash of the identifier, the crate version and the variable table.
    pub fn guid(&self) -> &str {
        &self.guid
    }

    /// Number of inputs.
    pub fn input_dim(&self) -> usize {
        self.variables.iter().filter(|v| matches!(v.role, Role::PlantInput(_))).count()
    }

    /// Number of outputs.
    pub fn output_dim(&self) -> usize {
        self.variables.iter().filter(|v| matches!(v.role, Role::PlantOutput(_))).count()
    }
}

/// Every plant FMU, built afresh (as [`crate::estimators::all`]).
pub fn all() -> Vec<PlantDescriptor> {
    vec![s1_chain::descriptor(), s2_track::descriptor(), s5_flight::descriptor()]
}

/// Checks the table invariants the shell relies on: every input and output index
/// has its one variable, and every default the documentation states is a variable's.
pub fn check(descriptor: &PlantDescriptor) -> Result<(), String> {
    let vars = &descriptor.variables;
    check_table(vars)?;
    for j in 0..descriptor.input_dim() {
        if vars.iter().filter(|v| v.role == Role::PlantInput(j)).count() != 1 {
            return Err(format!("plant input {j} must have exactly one variable"));
        }
    }
    for k in 0..descriptor.output_dim() {
        if vars.iter().filter(|v| v.role == Role::PlantOutput(k)).count() != 1 {
            return Err(format!("plant output {k} must have exactly one variable"));
        }
    }
    let estimator_only = |r: Role| !matches!(r, Role::Parameter | Role::PlantInput(_) | Role::PlantOutput(_));
    if let Some(v) = vars.iter().find(|v| estimator_only(v.role)) {
        return Err(format!("variable {} has a role only an estimator has", v.name));
    }
    for name in model_description::mentioned_variables(descriptor.documentation) {
        if !vars.iter().any(|v| v.name == name && v.start.is_some()) {
            return Err(format!("the documentation states the default of {name}, which is no parameter or input"));
        }
    }
    Ok(())
}
