"""S5 as an SSP system (`kalfmu s5-system`): the plant FMU `kalfmu_s5_flight` (the study's
missile flying a manoeuvre, its ten force coefficients changing at 10 s, its twelve noisy
sensors) wired to the estimator FMU `kalfmu_s5_missile` (the study's tuning, SVD-CKF), on
the manoeuvre the estimator was not tuned on (`roll-turn`) and another seed.

What is specified here:

- the archive validates against the SSP 1.0 schemas and binds only parameters of its FMUs,
  and connects the twelve measurements and the three deflections by name;
- run by the small Jacobi master over fmpy (`ssp_master.py`), each estimated coefficient
  ends each half of the flight (its last second, before and after the change) within 1 %
  of the plant's (the paper claims 3 % for SVD-CKF), and its ±2σ covers the error at
  95 % of the time stamps or more from 0.5 s after the start and after the change.
  This truth is the estimator's own equations (the outside truth of S5 is JSBSim's): the
  figures say the system runs as the study does, not how the estimator fares on a model
  unlike its own.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from fmpy.ssp.ssd import read_ssd

from ssp_master import check_bindings, experiment, run_jacobi

MANOEUVRE, SEED = "roll-turn", 3
COEFFICIENTS = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"]
MEASURED = ["omega_x", "omega_y", "omega_z", "Nx", "Ny", "Nz", "phi", "psi", "gamma", "h", "alpha", "beta"]
DEFLECTIONS = ["delta_x", "delta_y", "delta_z"]
CHANGE_AT = 10.0


@pytest.fixture(scope="module")
def system(kalfmu_bin, fmu_dir, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ssp_s5") / "s5_system.ssp"
    subprocess.run(
        [str(kalfmu_bin), "s5-system", "--manoeuvre", MANOEUVRE, "--seed", str(SEED)]
        + ["--fmu-dir", str(fmu_dir), "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return out


def test_the_archive_validates_and_binds_only_parameters_of_its_fmus(system, tmp_path):
    components = check_bindings(system, tmp_path)
    assert sorted(components) == ["estimator", "plant"]
    ssd = read_ssd(str(system))
    pairs = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    assert pairs == {("plant", n, "estimator", n) for n in MEASURED + DEFLECTIONS}
    assert experiment(system) == (0.0, 20.0, 0.005)


def test_each_estimated_coefficient_follows_the_plants_through_the_change(system):
    record = [(c, n) for n in COEFFICIENTS for c in ("estimator", "plant")]
    record += [("estimator", n + "_std") for n in COEFFICIENTS]
    run = run_jacobi(system, record)
    t = run["time"]
    halves = [(0.5, CHANGE_AT), (CHANGE_AT + 0.5, 20.0)]
    for n in COEFFICIENTS:
        estimate, truth, sigma = run[f"estimator.{n}"], run[f"plant.{n}"], run[f"estimator.{n}_std"]
        before, after = truth[t < CHANGE_AT], truth[t > CHANGE_AT]
        assert np.all(before == before[0]) and np.all(after == after[0]) and before[0] != after[0], n
        for start, end in halves:
            last = (t > end - 1.0) & (t <= end)
            relative = float(abs(np.mean((estimate[last] - truth[last]) / truth[last])))
            window = (t >= start) & (t <= end)
            coverage = float(np.mean(np.abs(estimate[window] - truth[window]) <= 2.0 * sigma[window]))
            print(f"{n} to {end:g} s: relative error over the last second {relative:.4f}, 2σ coverage {coverage:.3f}")
            assert relative < 0.01, f"{n} within 1 % at {end:g} s"
            assert coverage >= 0.95, f"{n}'s 2σ covers from {start:g} s"
