//! A system of FMUs (an `.ssp` archive, [`crate::ssp`]) run as a Jacobi master runs it,
//! with initial values propagated: each FMU is instantiated with the system's parameters
//! and, in initialisation mode, the outputs of its sources at the start on its inputs
//! (sources first: the system must be free of feedback). Then at each communication point
//! `t` every connected input is set to its source's output of `t`, the recorded variables
//! are read (an estimator's outputs are then its estimate at `t` given the measurements
//! up to `t`, a plant's its values of `t`), and every FMU steps from `t` to `t + h`.

use std::path::Path;

use anyhow::{anyhow, bail, Context};
use start_values::StartValues;

use crate::fmu_driver::{ImportedFmu, Instance};
use crate::ssp::{self, System};

/// What a run recorded: the communication points and, per recorded variable, its value at each.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    /// The communication points `start + k·h` (s).
    pub time: Vec<f64>,
    /// One column per recorded `(component, variable)`, in the order asked.
    pub columns: Vec<Vec<f64>>,
}

/// One component running.
struct Running {
    name: String,
    fmu: ImportedFmu,
    instance: Instance,
    /// `(input vr, index of the source component, source output vr)`.
    inputs: Vec<(u32, usize, u32)>,
}

/// Runs the system in the `.ssp` at `path` over its default experiment (its FMUs unpacked
/// into `unpack`) and records `record`, each `(component, variable)`.
pub fn run(path: &Path, unpack: &Path, record: &[(&str, &str)]) -> anyhow::Result<Recorded> {
    let (system, fmus) = ssp::read(path, unpack)?;
    let order = sources_first(&system)?;
    let e = system.experiment;
    if !(e.step > 0.0 && e.stop > e.start) {
        bail!("{}: the default experiment [{}, {}] with step {} is empty", path.display(), e.start, e.stop, e.step);
    }
    let mut running: Vec<Running> = Vec::new();
    for &i in &order {
        let component = &system.components[i];
        let fmu = ImportedFmu::load(&fmus[i])?;
        let mut inputs = Vec::new();
        let mut values = Vec::new();
        for c in system.connections.iter().filter(|c| c.to.0 == component.name) {
            let source = running
                .iter()
                .position(|r| r.name == c.from.0)
                .ok_or_else(|| anyhow!("{} feeds {}, which comes first", c.from.0, c.to.0))?;
            let output = running[source].fmu.vr(&c.from.1)?;
            let mut value = [0.0];
            running[source].instance.read(&[output], &mut value)?;
            inputs.push((fmu.vr(&c.to.1)?, source, output));
            values.push(value[0]);
        }
        let mut parameters = StartValues::none();
        for (name, value) in system.parameters_of(&component.name) {
            parameters.insert(name, value);
        }
        let input_vrs: Vec<u32> = inputs.iter().map(|(vr, _, _)| *vr).collect();
        let instance = fmu
            .instantiate(&component.name, e.start, e.stop, &[], &[], &parameters, (&input_vrs, &values))
            .with_context(|| format!("component {}", component.name))?;
        running.push(Running { name: component.name.clone(), fmu, instance, inputs });
    }
    let recorded: Vec<(usize, u32)> = record
        .iter()
        .map(|(c, v)| {
            let i = running.iter().position(|r| r.name == *c).ok_or_else(|| anyhow!("no component {c}"))?;
            Ok((i, running[i].fmu.vr(v)?))
        })
        .collect::<anyhow::Result<_>>()?;
    let steps = ((e.stop - e.start) / e.step).round() as usize;
    let mut out =
        Recorded { time: Vec::with_capacity(steps + 1), columns: vec![Vec::with_capacity(steps + 1); record.len()] };
    for k in 0..=steps {
        for i in 0..running.len() {
            for j in 0..running[i].inputs.len() {
                let (input, source, output) = running[i].inputs[j];
                let mut value = [0.0];
                running[source].instance.read(&[output], &mut value)?;
                running[i].instance.set_inputs(&[input], &value)?;
            }
        }
        out.time.push(running[0].instance.time());
        for (column, &(i, vr)) in out.columns.iter_mut().zip(&recorded) {
            let mut value = [0.0];
            running[i].instance.read(&[vr], &mut value)?;
            column.push(value[0]);
        }
        if k < steps {
            for r in &mut running {
                r.instance.do_step(e.step).with_context(|| format!("component {}", r.name))?;
            }
        }
    }
    for r in running {
        r.instance.terminate()?;
    }
    Ok(out)
}

/// The components in an order where every source comes before what it feeds.
fn sources_first(system: &System) -> anyhow::Result<Vec<usize>> {
    let mut order: Vec<usize> = Vec::new();
    while order.len() < system.components.len() {
        let ready = (0..system.components.len()).find(|i| {
            !order.contains(i)
                && system
                    .connections
                    .iter()
                    .filter(|c| c.to.0 == system.components[*i].name)
                    .all(|c| order.iter().any(|&j| system.components[j].name == c.from.0))
        });
        match ready {
            Some(i) => order.push(i),
            None => bail!("the system has feedback (or a connection from no component): this master runs chains only"),
        }
    }
    Ok(order)
}
