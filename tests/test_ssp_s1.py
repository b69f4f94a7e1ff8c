"""S1 as an SSP system (`kalfmu s1-system`): the plant FMU `kalfmu_s1_chain` wired to
the estimator FMU `kalfmu_s1_load`, with the parameter set of one case.

What is specified here:

- the archive validates against the SSP 1.0 schemas (fmpy's `read_ssd`, `read_ssv`),
  and every parameter it binds is a parameter of the FMU it names;
- run by a small Jacobi master of ours over fmpy (`ssp_master.py`, the FMI meaning of a
  communication point), the estimator's load follows the plant's true load at the same
  time stamps (the figures asserted), with an honest σ;
- the plant's measurements are the study's (`kalfmu s1-export` of the same case), bit
  for bit, and so the estimator in the system equals the estimator fed the study's
  table by the same master, bit for bit;
- fmpy's own runner, `simulate_ssp`, reads the outputs only after each step and records
  them at the step's start: its row at t holds the plant's outputs of t + h
  (`docs/masters.md` says what that means for an estimator).
"""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import read_ssd

from ssp_master import Component, check_bindings, experiment, parameter_sets, run_jacobi
from test_fmu import read_s1_table

#: The case, seed and length of the system under test: not the study's default seed.
CASE, SEED, DURATION = "stiffness/random", 4, 5.0


@pytest.fixture(scope="module")
def system(kalfmu_bin, fmu_dir, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ssp") / "s1_system.ssp"
    subprocess.run(
        [str(kalfmu_bin), "s1-system", "--case", CASE, "--seed", str(SEED), "--duration", str(DURATION)]
        + ["--fmu-dir", str(fmu_dir), "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return out


@pytest.fixture(scope="module")
def run(system) -> dict:
    return run_jacobi(system, [("estimator", "F"), ("estimator", "F_std"), ("plant", "F")] + PLANT_MEASUREMENTS)


PLANT_MEASUREMENTS = [("plant", "z1_ddot"), ("plant", "z2_ddot")]


@pytest.fixture(scope="module")
def table(kalfmu_bin, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp_table") / "s1.csv"
    subprocess.run(
        [str(kalfmu_bin), "s1-export", "--case", CASE, "--seed", str(SEED), "--duration", str(DURATION)]
        + ["--noise", "0.02", "--out", str(out)],
        check=True,
    )
    return read_s1_table(out)


def test_the_archive_validates_and_binds_only_parameters_of_its_fmus(system, tmp_path):
    components = check_bindings(system, tmp_path)
    assert sorted(components) == ["estimator", "plant"]
    ssd = read_ssd(str(system))
    pairs = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    assert pairs == {("plant", n, "estimator", n) for n in ("z1_ddot", "z2_ddot")}
    assert experiment(system) == (0.0, DURATION, 0.005)
    (parameters,) = parameter_sets(system)
    assert len(parameters.parameters) > 40


def test_the_estimate_follows_the_plants_load_at_the_same_time_stamps(run):
    error = run["estimator.F"] - run["plant.F"]
    assert len(error) == round(DURATION / 0.005) + 1
    rmse = float(np.sqrt(np.mean(error**2)))
    coverage = float(np.mean(np.abs(error) <= 2.0 * run["estimator.F_std"]))
    correlation = float(np.corrcoef(run["estimator.F"], run["plant.F"])[0, 1])
    print(f"system run: F RMSE {rmse:.4f} N, correlation {correlation:.5f}, 2σ coverage {coverage:.3f}")
    assert rmse < 0.5, "the load RMS is 10 N: 5 % of it"
    assert correlation > 0.998
    assert 0.9 <= coverage <= 0.995


def test_the_plant_measures_the_studys_data_and_the_estimator_equals_its_run_on_them(run, table, system):
    for k, (_, name) in enumerate(PLANT_MEASUREMENTS):
        assert np.array_equal(run[f"plant.{name}"], table.z[:, k]), name
    assert np.allclose(run["plant.F"], table.load, rtol=0, atol=1e-9)
    # The estimator alone, with the parameters the system binds, fed the study's table.
    directory = Path(system).parent / "alone"
    with zipfile.ZipFile(system) as zf:
        zf.extractall(directory)
    element = next(c for c in read_ssd(str(system)).system.elements if c.name == "estimator")
    estimator = Component(element, directory)
    estimator.fmu.instantiate()
    estimator.fmu.setupExperiment(startTime=0.0, stopTime=DURATION)
    for p in parameter_sets(system)[0].parameters:
        if p.name.startswith("estimator."):
            estimator.set(p.name[len("estimator.") :], p.value)
    estimator.fmu.enterInitializationMode()
    for k, name in enumerate(("z1_ddot", "z2_ddot")):
        estimator.set(name, table.z[0, k])
    estimator.fmu.exitInitializationMode()
    alone = []
    for k, t in enumerate(run["time"]):
        for j, name in enumerate(("z1_ddot", "z2_ddot")):
            estimator.set(name, table.z[k, j])
        alone.append(estimator.get("F"))
        if k + 1 < len(run["time"]):
            estimator.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=0.005)
    estimator.fmu.terminate()
    estimator.fmu.freeInstance()
    assert np.array_equal(np.array(alone), run["estimator.F"])


def test_fmpys_runner_records_the_outputs_after_each_step_at_its_start(system, run):
    (parameters,) = parameter_sets(system)
    rows = simulate_ssp(str(system), stop_time=0.5, step_size=0.005, parameter_set=parameters)
    n = len(rows)
    assert rows["time"][1] == 0.005
    for name in ("z1_ddot", "z2_ddot"):
        # Row k, stamped t_k, holds the plant's measurement of t_k + h.
        assert np.array_equal(rows[f"plant.{name}"], run[f"plant.{name}"][1 : n + 1]), name
        assert not np.array_equal(rows[f"plant.{name}"], run[f"plant.{name}"][:n])
