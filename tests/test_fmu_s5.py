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
(`scenarios s5-export`, 10 s before the coefficients change) through the FMU
with its defaults and the sensors' noise set, as a user of fmpy would: the
twelve measurements and the three deflections as one input table. It
identifies every coefficient and stays healthy, and no sensor is flagged.
"""

from __future__ import annotations

import subprocess

import numpy as np
from fmpy import read_model_description, simulate_fmu

from test_fmu import read_s5_table

COEFFICIENTS = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"]
HALF = 9.995  # the last sample before the change at 10 s


def test_the_first_half_of_the_flight_identifies_every_coefficient(s5_fmu, scenarios_bin, tmp_path):
    """At the end of the first half every coefficient is within 1 % of the
    truth (0.001 absolute where |C| < 0.05, e.g. Cy0), inside 3σ of its
    estimate; every sample is taken, the filter stays healthy and no sensor is
    flagged faulty."""
    path = tmp_path / "s5.csv"
    subprocess.run(
        [str(scenarios_bin), "s5-export", "--duration", str(HALF), "--seed", "1", "--out", str(path)], check=True
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
