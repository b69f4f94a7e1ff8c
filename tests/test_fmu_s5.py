"""The packaged S5 estimator FMU (`kalfmu_s5_missile.fmu`) through fmpy: what
is particular to S5. The battery every estimator FMU passes runs on S5 too, in
test_fmu.py (parametrised, test ids `s5`, driven with the study's flight and
its deflections): fmpy's validation and `fmutool -check`, a shared library on
the C runtime only, illegal calls refused and changing nothing, independent
interleaved instances, FMU states that roll back and continue identically in
a new instance, NaN measurements skipped, counted and reported once per
input, tunable against fixed parameters, inputs entering once however often
they are set, steps of several samples and steps between samples. Through the
`fmi` crate (`fmu/tests/fmi_importer.rs`) its outputs equal the library's
filters bit for bit; `fmu/tests/random_calls.rs` drives it with random call
sequences; `scripts/valgrind-fmu` runs it under memcheck.

Here: `fmpy.simulate_fmu` flies the first half of the study's flight
(`kalfmu s5-export`, 10 s before the coefficients change) through the FMU
with its defaults and the sensors' noise set, as a user of fmpy would: the
twelve measurements and the three deflections as one input table. It
identifies every coefficient and stays healthy, and no sensor is flagged.
With the sensors' noise told a thousand times too small, the SVD-CKF spends
its re-acquisitions' inflation budget and flies on, unhealthy, while the
Cholesky CKF stops with the reason.
"""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2Discard

from test_fmu import read_s5_table, slaves

COEFFICIENTS = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"]
HALF = 9.995  # the last sample before the change at 10 s


def test_the_first_half_of_the_flight_identifies_every_coefficient(s5_fmu, kalfmu_bin, tmp_path):
    """At the end of the first half every coefficient is within 1 % of the
    truth (0.001 absolute where |C| < 0.05, e.g. Cy0), inside 3σ of its
    estimate; every sample is taken, the filter stays healthy and no sensor is
    flagged faulty."""
    path = tmp_path / "s5.csv"
    subprocess.run(
        [str(kalfmu_bin), "s5-export", "--duration", str(HALF), "--seed", "1", "--out", str(path)], check=True
    )
    table = read_s5_table(path)
    dt = 0.005
    time = table.time
    assert np.allclose(np.diff(time), dt) and abs(time[-1] - HALF) < 1e-9
    signals = np.zeros(len(time), dtype=[("time", np.float64)] + [(n, np.float64) for n in table.input_names])
    signals["time"] = time
    for j, name in enumerate(table.input_names):
        signals[name] = table.inputs[:, j]

    md = read_model_description(str(s5_fmu))
    faults = [v.name for v in md.modelVariables if v.name.endswith("_fault")]
    assert len(faults) == 12
    outputs = COEFFICIENTS + [f"{c}_std" for c in COEFFICIENTS] + faults + ["filter_healthy", "skipped_measurements"]
    result = simulate_fmu(
        str(s5_fmu),
        stop_time=time[-1],
        output_interval=dt,
        input=signals,
        output=outputs,
        start_values=table.sensor,
    )
    assert len(result) == len(time)
    assert result["filter_healthy"].all()
    assert (result["skipped_measurements"] == 0).all()
    for name in faults:
        assert not result[name].any(), name
    for name in COEFFICIENTS:
        estimate, std, true = result[name][-1], result[f"{name}_std"][-1], table.truth[name][-1]
        error = abs(estimate - true)
        assert error < max(0.01 * abs(true), 1e-3), (name, estimate, true)
        assert error < 3 * std, (name, estimate, true, std)


def test_sensors_told_a_thousand_times_too_fine_spend_the_budget_and_say_so(s5_fmu, kalfmu_bin, tmp_path):
    """The r_<input>_std told a thousandth of the sensors' noise: no inflation
    of the covariance makes the filter agree with them. The default SVD-CKF
    re-acquires until max_inflation is spent, logs that once, and flies on
    unhealthy with finite outputs; the Cholesky CKF (filter = 1) loses its
    covariance's definiteness and says so: fmi2Discard with the reason, the
    outputs the last good estimate."""
    path = tmp_path / "s5.csv"
    subprocess.run([str(kalfmu_bin), "s5-export", "--duration", "2", "--out", str(path)], check=True)
    table = read_s5_table(path)
    md = read_model_description(str(s5_fmu))
    unzipped = Path(extract(str(s5_fmu), str(tmp_path / "unzipped")))
    told = {name: std / 1000 for name, std in table.sensor.items()}
    made = slaves(unzipped, md)
    new_slave = next(made)
    try:
        for kind in (3, 1):  # SVD-CKF, CKF
            slave = new_slave(f"filter-{kind}")
            slave.fmu.setupExperiment(startTime=0.0)
            slave.fmu.enterInitializationMode()
            slave.set(**told)
            slave.fmu.setInteger([slave.vr["filter"]], [kind])
            slave.fmu.exitInitializationMode()
            spent = "no more re-acquisitions"
            if kind == 3:
                out = slave.run(table.inputs)
                assert all(math.isfinite(v) for v in out[-1][:-2])
                assert out[-1][-1] == 0  # filter_healthy
                assert len([m for m in slave.warnings() if spent in m]) == 1, slave.warnings()
                assert not slave.errors()
            else:
                with pytest.raises(FMICallException) as raised:
                    slave.run(table.inputs)
                assert raised.value.status == fmi2Discard
                (error,) = [text for status, _, text in slave.messages if status == fmi2Discard]
                assert "not positive definite" in error and "the outputs are the last good estimate" in error
    finally:
        next(made, None)
