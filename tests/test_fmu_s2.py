"""The packaged S2 estimator FMU (`kalfmu_s2_wheel_rail.fmu`) through fmpy: what
is particular to S2. The battery every estimator FMU passes runs on S2 too, in
test_fmu.py (parametrised, test ids `s2`): fmpy's validation and `fmutool
-check`, a shared library on the C runtime only, illegal calls refused and
changing nothing, independent interleaved instances, FMU states that roll
back and continue identically in a new instance, NaN inputs skipped, counted
and reported once per input, tunable against fixed parameters, a measurement
entering once however often the inputs are set, steps of several samples and
steps between samples. Through the `fmi` crate (`fmu/tests/fmi_importer.rs`)
its outputs equal the library's SRCKF bit for bit; `fmu/tests/random_calls.rs`
drives it with random call sequences; `scripts/valgrind-fmu` runs it under
memcheck.

Here: driven by fmpy with the accelerations of a vehicle at rest (sensor noise
only: a constant input would read as a stuck sensor), it reports the static
wheel load on every wheel and stays healthy. fmpy records the outputs after
each step: the forces one sample ahead, whose variance is the update's plus
one step of their random walk, `force_noise_intensity·dt` (the update's own
standard deviation settles near 0.8 kN, under that step's 100 kN).
"""

from __future__ import annotations

import numpy as np
from fmpy import read_model_description, simulate_fmu

INPUTS = ["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"]


def test_a_vehicle_at_rest_carries_its_static_wheel_loads(s2_fmu):
    md = read_model_description(str(s2_fmu))
    start = {v.name: float(v.start) for v in md.modelVariables if v.name == "static_wheel_load"}
    assert 54e3 < start["static_wheel_load"] < 58e3
    dt = 0.001
    time = np.arange(0, 2.0 + dt / 2, dt)
    signals = np.zeros(len(time), dtype=[("time", np.float64)] + [(n, np.float64) for n in INPUTS])
    signals["time"] = time
    noise = np.random.default_rng(5)
    for name in INPUTS:
        signals[name] = 0.01 * noise.standard_normal(len(time))
    outputs = [f"F_N{j}" for j in range(1, 5)] + [f"F_N{j}_std" for j in range(1, 5)] + ["filter_healthy"]
    result = simulate_fmu(
        str(s2_fmu),
        stop_time=time[-1],
        output_interval=dt,
        input=signals,
        output=outputs,
        start_values={f"r_{n}_std": 0.01 for n in INPUTS},
    )
    assert len(result) == len(time)
    step = np.sqrt(1e13 * dt)  # force_noise_intensity's default, over one sample
    for j in range(1, 5):
        force, std = result[f"F_N{j}"], result[f"F_N{j}_std"]
        assert abs(force[-1] - start["static_wheel_load"]) < 0.01 * start["static_wheel_load"]
        assert step < std[-1] < np.sqrt(step**2 + 2e3**2), std[-1]
    assert result["filter_healthy"].all()
