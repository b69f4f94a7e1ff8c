//! What a plant FMU's instance does: the plant, built from the parameters at
//! `fmi2ExitInitializationMode`, its inputs held over each step, its outputs
//! those of the time it stands at. The shell (`instance.rs`) keeps the values,
//! the state and the logging, and calls in here.

use crate::ffi::Fmi2Status;
use crate::instance::Shell;
use crate::plants::{Plant, PlantDescriptor};
use crate::state::ModelState;
use crate::variables::{Parameters, Role};

/// A plant FMU's part of an instance.
pub struct Simulating {
    pub(crate) descriptor: PlantDescriptor,
    /// The plant, from `fmi2ExitInitializationMode` on.
    pub(crate) plant: Option<Box<dyn Plant>>,
    /// The output values are not those of the current time and inputs.
    outputs_stale: bool,
    /// The plant's outputs, by `Role::PlantOutput` index.
    outputs: Vec<f64>,
}

impl Simulating {
    pub fn new(descriptor: PlantDescriptor) -> Self {
        let outputs = vec![f64::NAN; descriptor.output_dim()];
        Self { descriptor, plant: None, outputs_stale: false, outputs }
    }

    /// Back to the state after `fmi2Instantiate`.
    pub fn reset(&mut self) {
        self.plant = None;
        self.outputs_stale = false;
    }

    /// After the shell applied new values (`old`: those they replaced): the plant
    /// takes its new inputs, or the whole call is refused and `old` restored.
    pub fn values_set(&mut self, shell: &mut Shell, updates: &[(usize, f64)], old: &[(usize, f64)]) -> Fmi2Status {
        let Some(plant) = self.plant.as_mut() else { return Fmi2Status::Ok };
        let input = |i: usize| match self.descriptor.variables[i].role {
            Role::PlantInput(j) => Some(j),
            _ => None,
        };
        for (n, &(i, value)) in updates.iter().enumerate() {
            let Some(j) = input(i) else { continue };
            if let Err(why) = plant.set_input(j, value) {
                // Undo the inputs this call gave the plant, latest first, then the values.
                for &(i, value) in old[..n].iter().rev() {
                    if let Some(j) = input(i) {
                        let _ = plant.set_input(j, value);
                    }
                }
                for &(i, value) in old {
                    shell.values[i] = value;
                }
                return shell
                    .error(&format!("input {} refused, values unchanged: {why}", self.descriptor.variables[i].name));
            }
            self.outputs_stale = true;
        }
        Fmi2Status::Ok
    }

    /// The plant of the current parameters, with the inputs as they stand.
    pub(crate) fn build(&self, values: &[f64]) -> Result<Box<dyn Plant>, String> {
        let mut plant = (self.descriptor.build)(&Parameters::new(&self.descriptor.variables, values))?;
        for (v, &x) in self.descriptor.variables.iter().zip(values) {
            if let Role::PlantInput(j) = v.role {
                plant.set_input(j, x).map_err(|why| format!("input {}: {why}", v.name))?;
            }
        }
        Ok(plant)
    }

    /// `fmi2ExitInitializationMode`: builds the plant from the parameters.
    pub fn exit_initialization(&mut self, shell: &mut Shell) -> Fmi2Status {
        match self.build(&shell.values) {
            Ok(plant) => {
                self.plant = Some(plant);
                shell.state = ModelState::StepComplete;
                self.outputs_stale = true;
                shell.log(
                    Fmi2Status::Ok,
                    "logEvents",
                    &format!("initialised: {} at t = {}", self.descriptor.model_identifier, shell.time),
                );
                Fmi2Status::Ok
            }
            Err(why) => shell.error(&format!("fmi2ExitInitializationMode: cannot build the plant: {why}")),
        }
    }

    /// In initialisation mode the outputs show the plant at the start, as the
    /// current parameters and inputs build it (left as they were while they do not).
    pub fn refresh_initial_outputs(&mut self, shell: &mut Shell) {
        if let Ok(mut plant) = self.build(&shell.values) {
            plant.outputs(&mut self.outputs);
            self.write_outputs(&mut shell.values);
        }
    }

    /// `fmi2DoStep(t, h)`, checked by the shell; on `fmi2OK` the shell moves the time to `t + h`.
    pub fn do_step(&mut self, shell: &mut Shell, _t: f64, h: f64) -> Fmi2Status {
        let Some(plant) = self.plant.as_mut() else {
            return shell.error("fmi2DoStep: no plant (internal state lost)");
        };
        if let Err(why) = plant.advance(h) {
            return shell.error(&format!("fmi2DoStep: {why}; the plant is where it was"));
        }
        self.outputs_stale = true;
        Fmi2Status::Ok
    }

    /// The outputs are computed afresh at the next get (after a restored FMU state).
    pub(crate) fn mark_outputs_stale(&mut self) {
        self.outputs_stale = true;
    }

    /// Before a get: the outputs of the current time and inputs.
    pub fn refresh_outputs(&mut self, shell: &mut Shell) {
        if !self.outputs_stale || shell.state != ModelState::StepComplete {
            return;
        }
        let Some(plant) = self.plant.as_mut() else { return };
        plant.outputs(&mut self.outputs);
        self.write_outputs(&mut shell.values);
        self.outputs_stale = false;
    }

    fn write_outputs(&self, values: &mut [f64]) {
        for (v, x) in self.descriptor.variables.iter().zip(values.iter_mut()) {
            if let Role::PlantOutput(k) = v.role {
                *x = self.outputs[k];
            }
        }
    }
}
