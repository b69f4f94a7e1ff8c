"""The `input_timing_check` output of the packaged S1 FMU under fmpy's
`simulate_fmu` (docs/fmu-interface.md, "Input timing check").

What fmpy 0.3's `simulateCS` does, FMI 2.0 (`fmpy/simulation.py`): it sets
the parameters' start values, calls `fmi2EnterInitializationMode`, applies
the input table at the start time (`input.apply(time)`) and calls
`fmi2ExitInitializationMode`; then, per communication step, it applies the
input table at the current time (`input.apply(time, after_event=True)`) and
calls `fmi2DoStep(time, step)`. So it hands over the inputs of `t` before
`fmi2DoStep(t, h)`, Jacobi's ordering, and sets the row of the start time
twice: in initialisation mode and before the first step, the same values.
The call log (`fmi_call_logger`) is checked for exactly that order.

Hence, on a moving plant (S1's chain under the paper's harmonic load, the
FMU's default chain, the accelerations with 2 % noise): the FMU with its
defaults (`input_timing` = 1) logs no warning at all and its check reads 1,
from the second step on (at the first the row repeated, which alone says
nothing); with `input_timing` = 2 it reads 2 and one warning tells to set
`input_timing` = 1. Without an input table nothing is set in initialisation
mode and the check stays 0.

The FMU is the session's packaged one (conftest.py).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import fmi2Warning

DT = 0.005  # the FMU's default sample_time
DURATION = 1.0
INPUTS = ["z1_ddot", "z2_ddot"]


@pytest.fixture(scope="module")
def fmu(s1_fmu) -> Path:
    return s1_fmu


def chain_accelerations(time: np.ndarray) -> np.ndarray:
    """S1's chain with the FMU's defaults (k1 piecewise linear 5, 20, 30 N/m with
    breaks at 0.1, 0.2 m; c1 5, k2 15, c2 3; m1 4, m2 8) under the paper's harmonic
    load on m2, RK4 at DT / 5: both accelerations at each time."""

    def spring(z):
        a = abs(z)
        return np.copysign(5 * min(a, 0.1) + 20 * max(min(a, 0.2) - 0.1, 0) + 30 * max(a - 0.2, 0), z)

    def load(t):
        return sum(A * np.sin(2 * np.pi * f * t) for A, f in [(8, 1), (6, 2), (5, 3), (4, 5), (3, 7)])

    def accelerations(t, x):
        coupling = 15 * (x[1] - x[0]) + 3 * (x[3] - x[2])
        return np.array([(coupling - spring(x[0]) - 5 * x[2]) / 4, (load(t) - coupling) / 8])

    def f(t, x):
        return np.concatenate([x[2:], accelerations(t, x)])

    x, out, dt = np.zeros(4), [], DT / 5
    for t in time:
        out.append(accelerations(t, x))
        for i in range(5):
            s = t + i * dt
            k1 = f(s, x)
            k2 = f(s + dt / 2, x + dt / 2 * k1)
            k3 = f(s + dt / 2, x + dt / 2 * k2)
            k4 = f(s + dt, x + dt * k3)
            x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.array(out)


@pytest.fixture(scope="module")
def plant():
    """The input table (row k at k·DT) and the sensors' noise std."""
    time = np.arange(round(DURATION / DT) + 1) * DT
    acc = chain_accelerations(time)
    noise_std = 0.02 * np.sqrt(np.mean(acc**2, axis=0))
    z = acc + noise_std * np.random.default_rng(3).standard_normal(acc.shape)
    signals = np.zeros(len(time), dtype=[("time", np.float64)] + [(n, np.float64) for n in INPUTS])
    signals["time"] = time
    for i, name in enumerate(INPUTS):
        signals[name] = z[:, i]
    return signals, {f"r_{n}_std": float(s) for n, s in zip(INPUTS, noise_std)}


def simulate(fmu: Path, signals, start_values: dict):
    """simulate_fmu with the FMU's debug logging on; returns the result, the
    FMU's messages as (status, text) and fmpy's log of the FMI calls."""
    messages: list[tuple[int, str]] = []
    calls: list[str] = []

    def logger(_env, _name, status, _category, message):
        messages.append((status, message.decode()))

    result = simulate_fmu(
        str(fmu),
        stop_time=DURATION,
        output_interval=DT,
        input=signals,
        output=["input_timing_check", "filter_healthy"],
        start_values=start_values,
        debug_logging=True,
        logger=logger,
        fmi_call_logger=calls.append,
    )
    return result, messages, calls


def warnings(messages) -> list[str]:
    return [text for status, text in messages if status == fmi2Warning]


def test_fmpy_sets_the_inputs_of_the_start_time_in_initialisation_mode_and_again_before_the_first_step(
    fmu, plant
):
    """fmpy's order of calls, as the module documentation says: the inputs set
    between fmi2EnterInitializationMode and fmi2ExitInitializationMode, and set
    again (the same values) before each fmi2DoStep."""
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    input_vrs = "[" + ", ".join(str(vr[n]) for n in INPUTS) + "]"
    signals, sensors = plant
    _, _, calls = simulate(fmu, signals, sensors)
    names = [call.split("(", 1)[0] for call in calls]
    enter, leave = names.index("fmi2EnterInitializationMode"), names.index("fmi2ExitInitializationMode")
    first_step = names.index("fmi2DoStep")

    def input_sets(lo, hi):
        return [c for c in calls[lo:hi] if c.startswith("fmi2SetReal(") and f"vr={input_vrs}" in c]

    in_initialisation, before_first_step = input_sets(enter, leave), input_sets(leave, first_step)
    assert len(in_initialisation) == 1 and len(before_first_step) == 1, calls[: first_step + 1]
    values = [re.search(r"value=\[([^\]]*)\]", c).group(1) for c in in_initialisation + before_first_step]
    assert values[0] == values[1], values
    # Every later step too is preceded by the inputs (those of its start).
    steps = [i for i, n in enumerate(names) if n == "fmi2DoStep"]
    assert all(len(input_sets(a, b)) == 1 for a, b in zip(steps, steps[1:]))


def test_under_fmpy_the_default_fmu_is_silent_and_its_check_fits(fmu, plant):
    """input_timing = 1 (the default) under fmpy's Jacobi ordering: no warning
    at all, a healthy filter, and input_timing_check 0 at the start and after
    the first step (the repeated row), 1 from the second step on."""
    signals, sensors = plant
    result, messages, _ = simulate(fmu, signals, sensors)
    assert warnings(messages) == []
    assert result["filter_healthy"].all()
    check = result["input_timing_check"]
    assert len(check) == len(signals)
    assert list(check[:2]) == [0, 0] and (check[2:] == 1).all(), check[:5]


def test_under_fmpy_the_gauss_seidel_timing_is_told_to_switch(fmu, plant):
    """input_timing = 2 under fmpy's ordering: input_timing_check reads 2 from
    the second step on, and one warning names the parameter and the value to set."""
    signals, sensors = plant
    result, messages, _ = simulate(fmu, signals, {**sensors, "input_timing": 2})
    check = result["input_timing_check"]
    assert list(check[:2]) == [0, 0] and (check[2:] == 2).all(), check[:5]
    about = [w for w in warnings(messages) if "input_timing" in w]
    assert len(about) == 1, warnings(messages)
    assert "set input_timing = 1 (communication_point)" in about[0], about[0]


def test_without_inputs_in_initialisation_mode_the_check_stays_undecided(fmu, plant):
    """No input table: nothing set in initialisation mode (nor later), nothing
    compared: 0 throughout, and no warning on input_timing under either value."""
    _, sensors = plant
    for timing in (1, 2):
        result, messages, _ = simulate(fmu, None, {**sensors, "input_timing": timing})
        assert (result["input_timing_check"] == 0).all(), timing
        assert not [w for w in warnings(messages) if "input_timing" in w], timing
