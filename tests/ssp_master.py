"""A small Jacobi master over fmpy for SSP systems, as a user's own loop would run one.

fmpy reads the archive (`read_ssd` and `read_ssv` validate it against the SSP 1.0
schemas); its runner, `simulate_ssp`, reads outputs only after each step and records
them at the step's start, and records connectors only. This master keeps the FMI
meaning of a communication point instead:

- every component is instantiated with the parameters the system binds
  (`<component>.<variable>` in its parameter set), and in initialisation mode its
  connected inputs get its sources' outputs at the start (sources first: no feedback);
- at each communication point t = start + k·h the connected inputs are set to their
  sources' outputs of t, the recorded variables are read (an estimator then shows its
  estimate at t given the measurements up to t), and every component steps to t + h.

The communication step is the archive's `org.kalfmu.communication-step` annotation.
"""

from __future__ import annotations

import shutil
import tempfile
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.ssp.ssd import find_components, read_ssd, read_ssv

SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
STEP_ANNOTATION = "org.kalfmu.communication-step"


def experiment(ssp: Path) -> tuple[float, float, float]:
    """(start, stop, step) of the archive's default experiment."""
    with zipfile.ZipFile(ssp) as zf:
        root = ET.fromstring(zf.read("SystemStructure.ssd"))
    e = root.find(f"{SSD}DefaultExperiment")
    step = next(a for a in e.iter() if a.get("type") == STEP_ANNOTATION)[0].get("size")
    return float(e.get("startTime")), float(e.get("stopTime")), float(step)


def parameter_sets(ssp: Path) -> list:
    """The parameter sets the system binds, each validated."""
    with zipfile.ZipFile(ssp) as zf:
        root = ET.fromstring(zf.read("SystemStructure.ssd"))
    system = root.find(f"{SSD}System")
    sources = [b.get("source") for b in system.iter(f"{SSD}ParameterBinding")]
    return [read_ssv(str(ssp), resource=s) for s in sources]


class Component:
    """One FMU of the system, instantiated through fmpy."""

    def __init__(self, element, ssp_dir: Path):
        self.name = element.name
        fmu = ssp_dir / element.source
        self.description = read_model_description(str(fmu))
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.unzipped = extract(str(fmu))
        self.fmu = FMU2Slave(
            guid=self.description.guid,
            unzipDirectory=self.unzipped,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=self.name,
        )

    def set(self, name: str, value) -> None:
        v = self.variables[name]
        if v.type == "Real":
            self.fmu.setReal([v.valueReference], [float(value)])
        elif v.type in ("Integer", "Enumeration"):
            self.fmu.setInteger([v.valueReference], [int(float(value))])
        elif v.type == "Boolean":
            self.fmu.setBoolean([v.valueReference], [str(value).lower() in ("true", "1")])
        else:
            raise ValueError(f"{self.name}.{name}: {v.type} values are not taken")

    def get(self, name: str) -> float:
        return self.fmu.getReal([self.variables[name].valueReference])[0]


def run_jacobi(ssp: Path, record: list[tuple[str, str]]) -> dict:
    """Runs the system over its default experiment; returns `time` and one array per
    recorded `component.variable`."""
    start, stop, h = experiment(ssp)
    ssd = read_ssd(str(ssp))
    parameters = [p for s in parameter_sets(ssp) for p in s.parameters]
    elements = find_components(ssd.system)
    feeds = [(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections]
    directory = Path(tempfile.mkdtemp())
    try:
        with zipfile.ZipFile(ssp) as zf:
            zf.extractall(directory)
        order: list[Component] = []
        pending = list(elements)
        while pending:
            ready = [e for e in pending if all(s in [c.name for c in order] for s, _, t, _ in feeds if t == e.name)]
            if not ready:
                raise ValueError("the system has feedback: this master runs chains only")
            element = ready[0]
            pending.remove(element)
            c = Component(element, directory)
            c.fmu.instantiate()
            c.fmu.setupExperiment(startTime=start, stopTime=stop)
            for p in parameters:
                if p.name.startswith(c.name + "."):
                    c.set(p.name[len(c.name) + 1 :], p.value)
            c.fmu.enterInitializationMode()
            c.inputs = [(t_var, next(o for o in order if o.name == s), s_var) for s, s_var, t, t_var in feeds if t == c.name]
            for var, source, output in c.inputs:
                c.set(var, source.get(output))
            c.fmu.exitInitializationMode()
            order.append(c)
        by_name = {c.name: c for c in order}
        steps = round((stop - start) / h)
        out = {"time": np.empty(steps + 1), **{f"{c}.{v}": np.empty(steps + 1) for c, v in record}}
        t = start
        for k in range(steps + 1):
            for c in order:
                for var, source, output in c.inputs:
                    c.set(var, source.get(output))
            out["time"][k] = t
            for comp, var in record:
                out[f"{comp}.{var}"][k] = by_name[comp].get(var)
            if k < steps:
                for c in order:
                    c.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                t += h
        for c in order:
            c.fmu.terminate()
            c.fmu.freeInstance()
            shutil.rmtree(c.unzipped, ignore_errors=True)
        return out
    finally:
        shutil.rmtree(directory, ignore_errors=True)


def check_bindings(ssp: Path, directory: Path) -> dict:
    """Validates the archive against the SSP schemas (fmpy's readers) and checks that
    every parameter it binds is a parameter of the FMU it names; returns the components
    by name."""
    ssd = read_ssd(str(ssp))  # validates against SystemStructureDescription.xsd
    components = {c.name: c for c in ssd.system.elements}
    with zipfile.ZipFile(ssp) as zf:
        zf.extractall(directory)
    variables = {
        name: {v.name: v for v in read_model_description(str(directory / c.source)).modelVariables}
        for name, c in components.items()
    }
    for parameter_set in parameter_sets(ssp):  # each validated against SystemStructureParameterValues.xsd
        for p in parameter_set.parameters:
            component, name = p.name.split(".", 1)
            assert variables[component][name].causality == "parameter", p.name
    return components

