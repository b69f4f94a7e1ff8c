"""The packaged S1 estimator FMU (`kalfmu_s1_load.fmu`, FMI 2.0 Co-Simulation)
driven through fmpy, as an importer drives it.

What is specified here:

- the FMU passes both static checkers (fmpy's validation, fmutool -check);
- `fmpy.simulate_fmu` on the S1 input table (`scenarios s1-export`), as it
  is, gives the estimates of the library run in-process (`scenarios replay`)
  at the time stamps fmpy records them, and those track the true load at
  their own time stamps;
- step by step (`fmpy.fmi2.FMU2Slave`): reads after the inputs of t are the
  library's estimates at t (direct feedthrough), reads after the step its
  predictions; the timing rules hold for communication steps of 1 ms and
  10 ms at a 5 ms sample time and for the Gauss-Seidel input timing;
  illegal calls are refused and leave the instance as it was, instances are
  independent, FMU states roll back and restore in a new instance exactly,
  NaN inputs are skipped and counted, and tunable parameters change between
  steps and fixed ones do not.

Time (fmu/src/timing.rs, the FMU's documentation/index.html): an input set at
communication point t is the measurement at t. The table holds the plant's
outputs of t_k = k·dt, k = 0 … n; fmpy sets row k at t_k (its linear
interpolation is exact on that grid), reads the outputs at t_0 after the
inputs (the estimate at t_0 given row 0) and after each fmi2DoStep(t_k, dt)
(the estimate at t_k+1 predicted from rows 0 … k).
"""

from __future__ import annotations

import itertools
import math
import subprocess
import sys
from ctypes import byref
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, free, calloc, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Error,
    fmi2Warning,
)
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu

from models import run_replay

DT = 0.005  # the FMU's default sample_time, and the study's 200 Hz
DURATION = 5.0
STATES = ["z1", "z2", "F", "z1_dot", "z2_dot", "F_dot"]  # the order of the filter state
FMUTOOL = Path(sys.executable).with_name("fmutool")


# --------------------------------------------------------------------------
# Fixtures: the model description, the S1 input table, the extracted FMU.
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class S1Table:
    """`scenarios s1-export`: row k is the plant's output at time[k] = k·dt."""

    time: np.ndarray
    z: np.ndarray  # (n, 2): z1_ddot, z2_ddot
    load: np.ndarray  # the true F
    noise_std: tuple[float, float]
    meta: dict


def read_s1_table(path: Path) -> S1Table:
    lines = path.read_text().splitlines()
    meta = dict(line[2:].split(" = ", 1) for line in lines if line.startswith("# ") and " = " in line)
    body = [line for line in lines if not line.startswith("#")]
    assert body[0] == "time,z1_ddot,z2_ddot,F_true"
    data = np.loadtxt(body[1:], delimiter=",", ndmin=2)
    noise = (float(meta["z1_ddot_noise_std"]), float(meta["z2_ddot_noise_std"]))
    return S1Table(time=data[:, 0], z=data[:, 1:3], load=data[:, 3], noise_std=noise, meta=meta)


@pytest.fixture(scope="module")
def s1_table(scenarios_bin, tmp_path_factory) -> S1Table:
    """The stiffness/random case of S1, 5 s at 200 Hz, seed 1, 2 % noise."""
    out = tmp_path_factory.mktemp("s1") / "s1.csv"
    subprocess.run(
        [str(scenarios_bin), "s1-export", "--case", "stiffness/random", "--duration", str(DURATION)]
        + ["--seed", "1", "--noise", "0.02", "--out", str(out)],
        check=True,
    )
    table = read_s1_table(out)
    assert table.meta["case"] == "stiffness/random" and float(table.meta["sample_time"]) == DT
    assert len(table.time) == round(DURATION / DT) + 1
    np.testing.assert_allclose(table.time, np.arange(len(table.time)) * DT, rtol=0, atol=1e-12)
    return table


@pytest.fixture(scope="module")
def model_description(s1_fmu):
    return read_model_description(str(s1_fmu))


@pytest.fixture(scope="module")
def defaults(model_description) -> dict[str, float]:
    """Start values of the parameters, by name."""
    return {v.name: float(v.start) for v in model_description.modelVariables if v.causality == "parameter"}


@pytest.fixture(scope="module")
def unzipped(s1_fmu, tmp_path_factory) -> Path:
    return Path(extract(str(s1_fmu), tmp_path_factory.mktemp("unzipped")))


# --------------------------------------------------------------------------
# The reference: the library filter in-process (`scenarios replay`).
# --------------------------------------------------------------------------


def replay_spec(params: dict[str, float], measurements: np.ndarray, first_at_prior: bool = True) -> dict:
    """A replay spec with the filter the FMU builds from `params`: the same
    Q as `noise()` in fmu/src/estimators/s1_load.rs (diagonal z, z_dot
    variances; the (F, F_dot) block q·[dt³/3, dt²/2; dt²/2, dt]), R, prior and
    dt. NaN in `measurements` is a missing value (null). Row 0 is measured at
    the prior's time (the FMU's start), unless `first_at_prior` is false."""
    dt = params["sample_time"]
    qz, qv, q = params["q_z_std"], params["q_z_dot_std"], params["load_noise_intensity"]
    Q = np.zeros((6, 6))
    for i in (0, 1):
        Q[i, i] = qz * qz
        Q[i + 3, i + 3] = qv * qv
    Q[2, 2] = q * (dt * dt * dt) / 3.0
    Q[2, 5] = Q[5, 2] = q * (dt * dt) / 2.0
    Q[5, 5] = q * dt
    r1, r2 = params["r_z1_ddot_std"], params["r_z2_ddot_std"]
    p0 = [params[f"p0_{s}_std"] for s in STATES]
    return {
        "model": "oscillator_2dof_stiffness",
        "substeps": int(params["rk4_substeps"]),
        "q": Q.tolist(),
        "r": [r1 * r1, r2 * r2],
        "x0": [params[f"x0_{s}"] for s in STATES],
        "p0": [s * s for s in p0],
        "dt": dt,
        "measurements": [[None if math.isnan(v) else float(v) for v in row] for row in measurements],
        "first_at_prior": first_at_prior,
    }


def replay(scenarios_bin, params, measurements, first_at_prior: bool = True) -> dict:
    """The library's SRCKF: `means`/`std` after each update, `predicted_means`/
    `predicted_std` before it, `nis`."""
    out = run_replay(scenarios_bin, replay_spec(params, measurements, first_at_prior), "SRCKF")
    out["std"] = np.sqrt(np.einsum("kii->ki", out["covariances"]))
    out["predicted_means"] = np.array(out["predicted_means"], dtype=float)
    out["predicted_std"] = np.array(out["predicted_std"], dtype=float)
    out["nis"] = np.array(out["nis"], dtype=float)
    return out


def as_read(ref: dict) -> dict:
    """What fmpy records from the library's run: at t_0 the estimate given row
    0 (the outputs read after the inputs at the start), at t_k (k >= 1) the
    prediction from rows 0 … k-1 (read after the step), with the NIS of the
    latest update."""
    return {
        "means": np.vstack([ref["means"][:1], ref["predicted_means"][1:]]),
        "std": np.vstack([ref["std"][:1], ref["predicted_std"][1:]]),
        "nis": np.concatenate([ref["nis"][:1], ref["nis"][:-1]]),
    }


#: Makes the FMU's ground damper evaluate k·|v| exactly as the replay model's
#: `PiecewiseLinear::linear(5)` does: with the default breakpoints the three
#: equal slopes give the same law but round differently in the last bit
#: (k·ε₁ + k·(a − ε₁) ≠ k·a), which the filter carries on at the 1e-13 level.
SAME_LAW = {"eps1": 1e300, "eps2": 1e300}


# --------------------------------------------------------------------------
# Static checks.
# --------------------------------------------------------------------------



def test_the_shared_library_depends_only_on_libc_libm_and_libgcc_s(s1_fmu, unzipped, model_description):
    """The binary in the FMU links nothing but the C runtime (libc, libm,
    libgcc_s, and the dynamic loader): importers on other machines need no
    extra library."""
    identifier = model_description.coSimulation.modelIdentifier
    so = unzipped / "binaries" / "linux64" / f"{identifier}.so"
    assert so.is_file()
    out = subprocess.run(["ldd", str(so)], check=True, capture_output=True, text=True).stdout
    names = [line.split()[0] for line in out.splitlines() if line.strip()]
    allowed = ("linux-vdso.so", "libc.so", "libm.so", "libgcc_s.so", "ld-linux", "/lib64/ld-linux")
    assert names and all(n.startswith(allowed) for n in names), out
    assert any(n.startswith("libc.so") for n in names), out

def test_fmpy_validation_finds_no_problem(s1_fmu):
    """fmpy's validation (XSD, names, ModelStructure, start values,
    causality/variability, units) reports no problem."""
    assert validate_fmu(str(s1_fmu)) == []


def test_fmutool_check_passes(s1_fmu):
    """`fmutool -input X.fmu -check` (fmu-manipulation-toolbox: XSD and
    FMI 2.0 semantics) exits with 0."""
    proc = subprocess.run([str(FMUTOOL), "-input", str(s1_fmu), "-check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "compliant with FMI-2.0" in proc.stdout + proc.stderr


# --------------------------------------------------------------------------
# simulate_fmu against the in-process library run.
# --------------------------------------------------------------------------


def simulate_s1(fmu: Path, table: S1Table, model_description, extra: dict | None = None, interval: float = DT):
    """`fmpy.simulate_fmu` over the table as it is: row k set at t_k, a
    communication step of `interval`, the sensor noise set to the exported std.
    Records every output and the inputs."""
    signals = np.zeros(len(table.time), dtype=[("time", np.float64), ("z1_ddot", np.float64), ("z2_ddot", np.float64)])
    signals["time"] = table.time
    signals["z1_ddot"], signals["z2_ddot"] = table.z[:, 0], table.z[:, 1]
    outputs = [v.name for v in model_description.modelVariables if v.causality == "output"]
    start = {"r_z1_ddot_std": table.noise_std[0], "r_z2_ddot_std": table.noise_std[1], **(extra or {})}
    result = simulate_fmu(
        str(fmu),
        stop_time=table.time[-1],
        output_interval=interval,
        input=signals,
        output=outputs + ["z1_ddot", "z2_ddot"],
        start_values=start,
    )
    assert len(result) == round(table.time[-1] / interval) + 1  # t = 0, then one row per step
    return result, start


@pytest.fixture(scope="module")
def simulated(s1_fmu, s1_table, model_description):
    """The default FMU (only the sensor noise set) over the table."""
    return simulate_s1(s1_fmu, s1_table, model_description)


def test_simulate_fmu_records_the_library_estimates_at_their_time_stamps(simulated, s1_table, defaults, scenarios_bin):
    """fmpy records at t_0 the estimate given row 0 and at t_k the prediction
    from rows 0 … k-1: F, F_std and every state and std equal the library's
    SRCKF (`scenarios replay`, same Q, R, prior, dt) there to 1e-12 relative."""
    result, start = simulated
    np.testing.assert_allclose(result["time"], s1_table.time, rtol=0, atol=1e-12)
    ref = as_read(replay(scenarios_bin, {**defaults, **start}, s1_table.z))
    for i, name in enumerate(STATES):
        mean, std = result[name], result[f"{name}_std"]
        scale = np.max(np.abs(ref["means"][:, i]))
        assert np.max(np.abs(mean - ref["means"][:, i])) <= 1e-12 * scale, name
        assert np.max(np.abs(std - ref["std"][:, i]) / ref["std"][:, i]) <= 1e-12, name
    assert np.max(np.abs(result["nis"] - ref["nis"])) <= 1e-12 * np.max(ref["nis"])


def test_with_the_same_damper_law_the_fmu_is_bit_identical_to_the_library(
    s1_fmu, s1_table, model_description, defaults, scenarios_bin
):
    """With the damper breakpoints out of reach (so the FMU's law rounds as the
    replay model's linear damper), every output equals the library's run bit
    for bit: the FMU layer adds nothing (same Q, R, prior, grid and inputs)."""
    result, start = simulate_s1(s1_fmu, s1_table, model_description, SAME_LAW)
    ref = as_read(replay(scenarios_bin, {**defaults, **start}, s1_table.z))
    for i, name in enumerate(STATES):
        assert np.array_equal(result[name], ref["means"][:, i]), name
        assert np.array_equal(result[f"{name}_std"], ref["std"][:, i]), name
    assert np.array_equal(result["nis"], ref["nis"])


def correlation_after(estimate, table: S1Table, t0: float = 1.0) -> float:
    after = table.time >= t0
    return float(np.corrcoef(estimate[after], table.load[after])[0, 1])


def test_the_outputs_after_each_step_track_the_load_at_their_own_time(simulated, s1_table, defaults, scenarios_bin):
    """What fmpy records after each step is the estimate at the step's end,
    predicted one sample ahead: after the first second it correlates with the
    true load at the same time stamp at >= 0.998, clearly better than the
    estimates of the previous sample stamped one sample late (what the FMU
    gave a live master before inputs were taken as measured at their
    communication point), with every sample used and the filter healthy."""
    result, start = simulated
    predicted = correlation_after(result["F"], s1_table)
    ref = replay(scenarios_bin, {**defaults, **start}, s1_table.z)
    one_late = correlation_after(np.concatenate([[np.nan], ref["means"][:-1, 2]]), s1_table)
    assert predicted >= 0.998
    assert 1.0 - predicted < 0.5 * (1.0 - one_late), (predicted, one_late)
    assert np.all(result["skipped_measurements"] == 0)
    assert np.all(result["filter_healthy"])


@pytest.mark.parametrize("interval", [0.001, 0.010])
def test_communication_steps_of_1_and_10_ms_at_a_5_ms_sample_time(
    interval, s1_fmu, s1_table, model_description, defaults, scenarios_bin
):
    """The rule for steps that are not the sample time. 1 ms: only every fifth
    communication point is a sample instant; there the outputs read after the
    step are the 5 ms run's bit for bit, and in between they are predictions to
    the time read (F_std grows through each sample interval). 10 ms: the
    sample inside each step is a prediction only, so the outputs are the
    library's with every odd row missing. Both track the load at their own
    time stamps."""
    result, start = simulate_s1(s1_fmu, s1_table, model_description, SAME_LAW, interval)
    on_grid = np.isclose(np.round(result["time"] / DT) * DT, result["time"], rtol=0, atol=1e-9)
    rows = np.round(result["time"][on_grid] / DT).astype(int)
    z = s1_table.z.copy()
    if interval > DT:
        z[1::2] = np.nan
    ref = as_read(replay(scenarios_bin, {**defaults, **start}, z))
    for i, name in enumerate(STATES):
        assert np.array_equal(result[name][on_grid], ref["means"][rows, i]), name
        assert np.array_equal(result[f"{name}_std"][on_grid], ref["std"][rows, i]), name
    if interval < DT:
        f_std = result["F_std"].reshape(-1)[1:].reshape(-1, 5)  # the five reads after t_k, up to t_k+1
        assert np.all(np.diff(f_std, axis=1) > 0)
    assert np.all(np.isfinite(result["F"]))
    # Predicted 5 ms ahead (1 ms: the reads at sample instants) or 10 ms ahead from every other sample.
    after = s1_table.time[rows] >= 1.0
    minimum = 0.998 if interval < DT else 0.99
    assert np.corrcoef(result["F"][on_grid][after], s1_table.load[rows][after])[0, 1] >= minimum


# --------------------------------------------------------------------------
# Step by step with FMU2Slave.
# --------------------------------------------------------------------------


#: Live slaves by their componentEnvironment. fmpy's logger proxy (which
#: formats the variadic message in C) keeps ONE global Python logger, the last
#: one registered; so every slave registers the same dispatcher, which routes
#: each message by the environment pointer the FMU hands back.
_SLAVES: dict[int, "Slave"] = {}
_KEYS = itertools.count(1)


def _dispatch(env, name, status, category, message):
    slave = _SLAVES.get(env or 0)
    if slave is not None:
        slave.messages.append((status, category.decode(), message.decode()))
        slave.names.add(name.decode())


_LOGGER = fmi2CallbackLoggerTYPE(_dispatch)


class Slave:
    """One FMU2Slave instance of the extracted FMU, with a logger that keeps
    every message as (status, category, text)."""

    def __init__(self, unzipped: Path, model_description, name: str, logging_on: bool = True):
        md = model_description
        self.name = name
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.real_outputs = [
            v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"
        ]
        self.messages: list[tuple[int, str, str]] = []
        self.names: set[str] = set()  # instance names the messages came with
        self.fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=str(unzipped),
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.key = next(_KEYS)
        _SLAVES[self.key] = self
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = _LOGGER
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        callbacks.componentEnvironment = self.key
        addLoggerProxy(byref(callbacks))  # (re)installs _LOGGER behind the C formatter
        self._callbacks = callbacks  # must outlive the instance
        self.fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)
        self.time = 0.0
        self.freed = False

    def errors(self) -> list[str]:
        return [m for s, _, m in self.messages if s == fmi2Error]

    def warnings(self) -> list[str]:
        return [m for s, _, m in self.messages if s == fmi2Warning]

    def initialize(self, **params: float) -> None:
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.set(**params)
        self.fmu.exitInitializationMode()

    def set(self, **values: float) -> None:
        if values:
            self.fmu.setReal([self.vr[k] for k in values], list(values.values()))

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.vr[k] for k in names])

    def inputs(self, z) -> None:
        self.fmu.setReal([self.vr["z1_ddot"], self.vr["z2_ddot"]], [float(z[0]), float(z[1])])

    def step(self, h: float = DT) -> None:
        self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def outputs(self) -> tuple[float, ...]:
        """Every Real output, then skipped_measurements and filter_healthy."""
        reals = self.fmu.getReal(self.real_outputs)
        skipped = self.fmu.getInteger([self.vr["skipped_measurements"]])
        healthy = self.fmu.getBoolean([self.vr["filter_healthy"]])
        return tuple(reals) + (skipped[0], healthy[0])

    def run(self, zs) -> list[tuple[float, ...]]:
        """One sample per row of `zs`, as a master: set the inputs of the
        current time, read the outputs (feedthrough), step."""
        return self.run_both(zs)[0]

    def run_both(self, zs) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
        """As `run`, also reading after each step: (at t after its inputs, right after the step to t + dt)."""
        at, after = [], []
        for z in zs:
            self.inputs(z)
            at.append(self.outputs())
            self.step()
            after.append(self.outputs())
        return at, after

    def free(self) -> None:
        if not self.freed:
            self.freed = True
            self.fmu.freeInstance()
            del _SLAVES[self.key]


@pytest.fixture
def new_slave(unzipped, model_description):
    """Makes instances (each its own FMU2Slave); frees them after the test."""
    made: list[Slave] = []

    def make(name: str = "s1", logging_on: bool = True) -> Slave:
        made.append(Slave(unzipped, model_description, name, logging_on))
        return made[-1]

    yield make
    for slave in made:
        slave.free()


def sensor(table: S1Table) -> dict[str, float]:
    return {"r_z1_ddot_std": table.noise_std[0], "r_z2_ddot_std": table.noise_std[1]}


BAD_STEP = 25  # the bad call comes after this many good steps
STEPS = 60

#: (phase, the bad call, what the error message says). Phases: "instantiated"
#: (after fmi2Instantiate and SetupExperiment), "initialization" (between
#: Enter- and ExitInitializationMode, after the parameters), "stepping"
#: (after BAD_STEP steps, between setting the inputs and the next DoStep).
BAD_CALLS = {
    "doStep before initialization": (
        "instantiated",
        lambda s: s.fmu.doStep(0.0, DT),
        "fmi2DoStep: illegal call sequence",
    ),
    "doStep in initialization mode": (
        "initialization",
        lambda s: s.fmu.doStep(0.0, DT),
        "fmi2DoStep: illegal call sequence",
    ),
    "exitInitializationMode before entering it": (
        "instantiated",
        lambda s: s.fmu.exitInitializationMode(),
        "fmi2ExitInitializationMode: illegal call sequence",
    ),
    "getReal before initialization mode": (
        "instantiated",
        lambda s: s.get("F"),
        "fmi2GetReal: illegal call sequence",
    ),
    "exitInitializationMode twice": (
        "stepping",
        lambda s: s.fmu.exitInitializationMode(),
        "fmi2ExitInitializationMode: illegal call sequence",
    ),
    "enterInitializationMode after initialization": (
        "stepping",
        lambda s: s.fmu.enterInitializationMode(),
        "fmi2EnterInitializationMode: illegal call sequence",
    ),
    "setupExperiment after initialization": (
        "stepping",
        lambda s: s.fmu.setupExperiment(startTime=0.0),
        "fmi2SetupExperiment: illegal call sequence",
    ),
    "setReal on a fixed parameter after initialization": (
        "stepping",
        lambda s: s.set(m1=5.0),
        "is a fixed parameter",
    ),
    "setReal on an output": ("stepping", lambda s: s.set(F=1.0), "is an output and cannot be set"),
    "setReal on an output in initialization mode": (
        "initialization",
        lambda s: s.set(F=1.0),
        "is an output and cannot be set",
    ),
    "setReal on an input and an output at once (all or nothing)": (
        "stepping",
        lambda s: s.set(z1_ddot=1e3, F=1.0),
        "is an output and cannot be set",
    ),
    "setReal of a tunable parameter out of its bounds": (
        "stepping",
        lambda s: s.set(r_z2_ddot_std=-1.0),
        "is outside [0",
    ),
    "getReal with an unknown value reference": (
        "stepping",
        lambda s: s.fmu.getReal([s.vr["F"], 100_000]),
        "unknown value reference 100000",
    ),
    "doStep at a wrong communication point": (
        "stepping",
        lambda s: s.fmu.doStep(s.time + DT, DT),
        "does not match the FMU time",
    ),
    "doStep with a zero step": ("stepping", lambda s: s.fmu.doStep(s.time, 0.0), "must be positive"),
    "doStep with a negative step": ("stepping", lambda s: s.fmu.doStep(s.time, -DT), "must be positive"),
    "doStep with a NaN step": ("stepping", lambda s: s.fmu.doStep(s.time, math.nan), "must be positive"),
}


def drive(slave: Slave, table: S1Table, bad=None) -> list[tuple[float, ...]]:
    """The standard run (sensor noise set in initialization mode, STEPS rows of
    the table), with the bad call `bad(phase)` hooked into every phase."""
    bad = bad or (lambda phase: None)
    slave.fmu.setupExperiment(startTime=0.0)
    bad("instantiated")
    slave.fmu.enterInitializationMode()
    slave.set(**sensor(table))
    bad("initialization")
    slave.fmu.exitInitializationMode()
    out = []
    for k in range(STEPS):
        slave.inputs(table.z[k])
        if k == BAD_STEP:
            bad("stepping")
        slave.step()
        out.append(slave.outputs())
    return out


@pytest.fixture
def clean_run(new_slave, s1_table):
    return drive(new_slave("clean"), s1_table)


@pytest.mark.parametrize("case", list(BAD_CALLS))
def test_an_illegal_call_is_refused_and_changes_nothing(case, new_slave, s1_table, clean_run):
    """Each illegal call returns fmi2Error (fmpy raises), logs why — the order
    errors as "illegal call sequence" — and leaves the instance as it was: it
    then steps on and gives exactly the outputs of an instance that never saw
    the call."""
    phase, call, message = BAD_CALLS[case]
    slave = new_slave("bad")
    seen = []

    def bad(now):
        if now == phase:
            with pytest.raises(FMICallException) as raised:
                call(slave)
            assert raised.value.status == fmi2Error
            seen.append(now)

    assert drive(slave, s1_table, bad) == clean_run
    assert seen == [phase]
    errors = slave.errors()
    assert len(errors) == 1 and message in errors[0], errors
    assert ("illegal call sequence" in errors[0]) == ("illegal call sequence" in message)
    assert slave.get("m1", "r_z2_ddot_std") == [4.0, s1_table.noise_std[1]]


def test_interleaved_instances_are_independent(new_slave, s1_table):
    """Two instances with different inputs and noise, stepped alternately, give
    exactly what each gives when run alone."""
    za, zb = s1_table.z[:150], -0.5 * s1_table.z[300:450]
    a_alone = new_slave("a-alone")
    a_alone.initialize(**sensor(s1_table))
    expected_a = a_alone.run(za)
    b_alone = new_slave("b-alone")
    b_alone.initialize(r_z1_ddot_std=0.02, r_z2_ddot_std=0.05)
    expected_b = b_alone.run(zb)
    a_alone.free()
    b_alone.free()

    a, b = new_slave("a"), new_slave("b")
    a.initialize(**sensor(s1_table))
    b.initialize(r_z1_ddot_std=0.02, r_z2_ddot_std=0.05)
    got_a, got_b = [], []
    for za_k, zb_k in zip(za, zb):
        got_a += a.run([za_k])
        got_b += b.run([zb_k])
    assert got_a == expected_a
    assert got_b == expected_b
    assert got_a != got_b
    assert a.names == {"a"} and b.names == {"b"}  # each logs as itself


def test_get_and_set_fmu_state_roll_back_exactly(new_slave, s1_table):
    """Run 200 steps, save the state, run 200 more, restore, run the same 200
    again: the outputs are identical (==), and so is the time."""
    slave = new_slave()
    slave.initialize(**sensor(s1_table))
    slave.run(s1_table.z[:200])
    state = slave.fmu.getFMUstate()
    saved_time = slave.time
    first = slave.run(s1_table.z[200:400])
    slave.fmu.setFMUstate(state)
    slave.time = saved_time
    again = slave.run(s1_table.z[200:400])
    assert again == first
    slave.fmu.freeFMUstate(state)
    assert not slave.errors()


def test_a_serialized_state_continues_identically_in_a_new_instance(new_slave, s1_table):
    """A state serialized after 200 steps, de-serialized into a freshly
    instantiated instance (still in Instantiated) and set there, continues
    exactly as the original does — parameters included."""
    original = new_slave("original")
    original.initialize(**sensor(s1_table))
    original.run(s1_table.z[:200])
    state = original.fmu.getFMUstate()
    data = original.fmu.serializeFMUstate(state)
    original.fmu.freeFMUstate(state)
    assert data.startswith(b"KALFMUS\0")
    expected = original.run(s1_table.z[200:400])

    fresh = new_slave("fresh")  # only instantiated: default noise, time 0
    restored = fresh.fmu.deSerializeFMUstate(data)
    fresh.fmu.setFMUstate(restored)
    fresh.fmu.freeFMUstate(restored)
    fresh.time = 200 * DT
    assert fresh.get("r_z1_ddot_std", "r_z2_ddot_std") == list(s1_table.noise_std)
    assert fresh.run(s1_table.z[200:400]) == expected
    assert not fresh.errors()


def test_nan_inputs_are_skipped_counted_and_never_reach_the_outputs(new_slave, s1_table, defaults, scenarios_bin):
    """NaN inputs leave their rows out of the update: they are counted in
    skipped_measurements, reported once per input, every output stays finite,
    filter_healthy stays true, and the estimates are the library's with those
    values missing."""
    z = s1_table.z[:120].copy()
    z[10:20, 0] = np.nan  # z1_ddot missing
    z[40:45, 1] = np.nan  # z2_ddot missing
    z[60:70, :] = np.nan  # both: prediction only
    slave = new_slave()
    slave.initialize(**sensor(s1_table), **SAME_LAW)
    out = np.array(slave.run(z))
    assert np.all(np.isfinite(out))
    skipped, healthy = out[:, -2], out[:, -1]
    assert list(skipped) == list(np.cumsum(np.isnan(z).sum(axis=1)))
    assert skipped[-1] == 10 + 5 + 20
    assert np.all(healthy == 1)
    assert slave.fmu.getBoolean([slave.vr["filter_healthy"]]) == [1]
    # A prediction-only stretch loses information on the load.
    f_std = out[:, slave.real_outputs.index(slave.vr["F_std"])]
    assert np.all(np.diff(f_std[60:70]) > 0)
    missing = [m for m in slave.warnings() if "treated as missing" in m]
    assert len(missing) == 2 and "z1_ddot" in missing[0] and "z2_ddot" in missing[1], missing

    ref = replay(scenarios_bin, {**defaults, **sensor(s1_table), **SAME_LAW}, z)
    for i, name in enumerate(STATES):
        assert np.array_equal(out[:, slave.real_outputs.index(slave.vr[name])], ref["means"][:, i]), name


def test_a_tunable_parameter_changes_between_steps_a_fixed_one_does_not(new_slave, s1_table):
    """r_z2_ddot_std (tunable) can be set between steps and acts from the next
    step on (a noisier sensor: a wider load estimate than without the change);
    m1 (fixed) is refused there and keeps its value."""
    baseline, tuned = new_slave("baseline"), new_slave("tuned")
    for slave in (baseline, tuned):
        slave.initialize(**sensor(s1_table))
    assert baseline.run(s1_table.z[:100]) == tuned.run(s1_table.z[:100])

    tuned.set(r_z2_ddot_std=10 * s1_table.noise_std[1])
    assert tuned.get("r_z2_ddot_std") == [10 * s1_table.noise_std[1]]
    with pytest.raises(FMICallException):
        tuned.set(m1=5.0)
    assert tuned.get("m1") == [4.0]
    assert any("fixed parameter" in m for m in tuned.errors())

    f_std = baseline.real_outputs.index(baseline.vr["F_std"])
    after_base = baseline.run(s1_table.z[100:150])
    after_tuned = tuned.run(s1_table.z[100:150])
    assert all(t[f_std] > b[f_std] for b, t in zip(after_base, after_tuned))


def test_reads_after_the_inputs_are_the_library_estimates_and_after_the_step_its_predictions(
    new_slave, s1_table, defaults, scenarios_bin
):
    """A master sets the plant's outputs of t, reads, steps, reads. The first
    read is the library's estimate at t given the measurements up to t (direct
    feedthrough), the second its prediction to t + dt, each bit for bit; the
    estimate at t identifies the load at its own time (>= 0.9995 after 1 s)."""
    slave = new_slave()
    slave.initialize(**sensor(s1_table), **SAME_LAW)
    n = len(s1_table.time) - 1
    at, after = (np.array(rows) for rows in slave.run_both(s1_table.z[:n]))
    ref = replay(scenarios_bin, {**defaults, **sensor(s1_table), **SAME_LAW}, s1_table.z)
    column = {name: slave.real_outputs.index(slave.vr[name]) for name in STATES + [f"{s}_std" for s in STATES]}
    for i, name in enumerate(STATES):
        assert np.array_equal(at[:, column[name]], ref["means"][:n, i]), name
        assert np.array_equal(at[:, column[f"{name}_std"]], ref["std"][:n, i]), name
        assert np.array_equal(after[:, column[name]], ref["predicted_means"][1:, i]), name
        assert np.array_equal(after[:, column[f"{name}_std"]], ref["predicted_std"][1:, i]), name
    after_1s = s1_table.time[:n] >= 1.0
    assert np.corrcoef(at[after_1s, column["F"]], s1_table.load[:n][after_1s])[0, 1] >= 0.9995


def test_a_measurement_enters_once_however_often_the_inputs_are_set_and_read(new_slave, s1_table):
    """Reads change nothing, and inputs set again before the step replace the
    earlier ones: an instance that reads several times, and first sets wrong
    inputs (read with them) before the right ones, gives exactly the outputs
    of one that sets the right inputs once."""
    plain, busy = new_slave("plain"), new_slave("busy")
    for slave in (plain, busy):
        slave.initialize(**sensor(s1_table))
    expected = plain.run(s1_table.z[:50])
    got = []
    for z in s1_table.z[:50]:
        busy.inputs(-3.0 * z)
        busy.outputs()
        busy.inputs(z)
        got.append(busy.outputs())
        assert busy.outputs() == got[-1]
        busy.step()
        busy.outputs()
    assert got == expected


def test_the_gauss_seidel_timing_takes_the_inputs_as_measured_at_the_step_end(
    new_slave, s1_table, defaults, scenarios_bin
):
    """input_timing = 2 (step_end): a master that hands over the plant's
    outputs of t + dt before fmi2DoStep(t, dt) reads after the step the
    library's estimate at t + dt given them (bit for bit); setting the inputs
    does not change the outputs before the step."""
    slave = new_slave()
    slave.fmu.setupExperiment(startTime=0.0)
    slave.fmu.enterInitializationMode()
    slave.set(**sensor(s1_table), **SAME_LAW)
    slave.fmu.setInteger([slave.vr["input_timing"]], [2])
    slave.fmu.exitInitializationMode()
    got = []
    for z in s1_table.z[1:200]:
        before = slave.outputs()
        slave.inputs(z)
        assert slave.outputs() == before
        slave.step()
        got.append(slave.outputs())
    ref = replay(scenarios_bin, {**defaults, **sensor(s1_table), **SAME_LAW}, s1_table.z[1:200], first_at_prior=False)
    got = np.array(got)
    for i, name in enumerate(STATES):
        assert np.array_equal(got[:, slave.real_outputs.index(slave.vr[name])], ref["means"][:, i]), name


def test_a_step_of_several_samples_predicts_through_the_samples_inside_it(new_slave, s1_table):
    """A communication step of 4·sample_time updates at its start and predicts
    through the three samples inside it (a held input is not a new
    measurement): its estimates equal those of four steps of sample_time whose
    later three have no input (NaN). No warning is logged."""
    estimates = STATES + [f"{s}_std" for s in STATES]
    coarse, fine = new_slave("coarse"), new_slave("fine")
    for slave in (coarse, fine):
        slave.initialize(**sensor(s1_table))
    for k in range(0, 80, 4):
        z = s1_table.z[k]
        coarse.inputs(z)
        coarse.step(4 * DT)
        fine.inputs(z)
        fine.step(DT)
        for _ in range(3):
            fine.inputs([math.nan, math.nan])
            fine.step(DT)
        assert coarse.get(*estimates) == fine.get(*estimates), k
    assert not coarse.warnings() and not coarse.errors()


def test_a_step_between_samples_warns_once_and_reads_the_prediction_to_its_end(new_slave, s1_table):
    """A step that ends between two samples returns OK, logs the documented
    warning (once) and reads the prediction to its end: its F_std lies between
    those at the samples around it. Stepping back onto the grid continues the
    same filter: the estimates equal an instance stepping by sample_time
    (without an input at the sample the odd step skipped)."""
    odd, even = new_slave("odd"), new_slave("even")
    for slave in (odd, even):
        slave.initialize(**sensor(s1_table))
        slave.inputs(s1_table.z[0])
    even.step(DT)
    std_at_1 = even.get("F_std")[0]
    even.inputs([math.nan, math.nan])
    even.step(DT)
    std_at_2 = even.get("F_std")[0]

    odd.step(1.5 * DT)  # the sample at 0.005 is inside the step: a prediction
    assert std_at_1 < odd.get("F_std")[0] < std_at_2
    odd.step(0.5 * DT)  # back on the grid at 0.010
    estimates = STATES + [f"{s}_std" for s in STATES]
    assert odd.get(*estimates) == even.get(*estimates)
    odd.step(0.25 * DT)  # off the grid again: no second warning
    warnings = odd.warnings()
    assert len(warnings) == 1, warnings
    assert "not a sample instant" in warnings[0] and "reported once" in warnings[0]
    assert not [w for w in even.warnings() if "sample instant" in w]


# --------------------------------------------------------------------------
# Gross measurement errors through the packaged FMU (estimator::Supervisor).
# --------------------------------------------------------------------------


def inject(table: S1Table, fault: str) -> tuple[np.ndarray, np.ndarray]:
    """The table's accelerations with `fault` from row 300 (1.5 s); returns
    them and a mask of the corrupted (or missing) values."""
    z = table.z.copy()
    rms = np.sqrt(np.mean(z**2, axis=0))
    bad = np.zeros_like(z, dtype=bool)
    if fault == "spikes":
        for k, c, sign in [(300, 1, 1), (400, 0, -1), (500, 1, -1), (700, 0, 1)]:
            z[k, c] += sign * 100 * rms[c]
            bad[k, c] = True
    elif fault == "saturation":
        # 2× the RMS: these 5 s never reach 3× (scenarios s1-faults clips 60 s at 3×).
        limit = 2 * rms[0]
        bad[:, 0] = np.abs(z[:, 0]) > limit
        z[:, 0] = np.clip(z[:, 0], -limit, limit)
    elif fault == "stuck":
        z[301:500, 0] = z[300, 0]
        bad[301:500, 0] = True
    elif fault == "drift":
        k = np.arange(301, 800)
        z[k, 0] += rms[0] * (k - 300) * DT
        bad[k, 0] = True
    elif fault == "dropout":
        z[300:400, 1] = np.nan
        z[600:650, :] = np.nan
        bad[300:400, 1] = bad[600:650, :] = True
    return z, bad


@pytest.mark.parametrize("fault", ["spikes", "saturation", "stuck", "drift", "dropout"])
def test_gross_errors_are_flagged_and_the_load_stays_within_its_sigma(fault, new_slave, s1_table):
    """Each fault on S1 through FMU2Slave (reads after the inputs): no good
    sample is rejected; every spike is rejected (rejected_measurements)
    without flagging its input; a saturated input costs the load nothing; a
    sustained fault raises `<input>_fault` within 5 samples of its start (a
    drift, which starts at zero, within 40),
    logged once with the input and the time; the load stays within 6σ of the
    truth after the first second (8σ with the drift, which leaks in for the
    0.1 s before it fails the gate; the other channel keeps the load
    observable); nothing is accepted silently."""
    z, bad = inject(s1_table, fault)
    slave = new_slave(fault)
    slave.initialize(**sensor(s1_table))
    names = ["F", "F_std"]
    rows = []
    for zk in z:
        slave.inputs(zk)
        rows.append(
            slave.get(*names)
            + list(slave.fmu.getInteger([slave.vr["rejected_measurements"], slave.vr["skipped_measurements"]]))
            + list(slave.fmu.getBoolean([slave.vr[n] for n in ("z1_ddot_fault", "z2_ddot_fault", "filter_healthy")]))
        )
        slave.step()
    out = np.array(rows, dtype=float)
    f, f_std, rejected, skipped, faults = out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 4:6]
    after = s1_table.time >= 1.0
    # A drift leaks into the state for the 0.1 s before it fails the gate.
    bound = 8.0 if fault == "drift" else 6.0
    assert np.max(np.abs(f - s1_table.load)[after] / f_std[after]) < bound
    assert skipped[-1] == np.isnan(z).sum()
    warnings = slave.warnings()
    newly_rejected = np.diff(rejected, prepend=0) > 0
    # While the fault lasts, only corrupted samples are rejected. (After a
    # drift the input may stay out for a while: the state it pulled while left
    # out comes back slowly; scenarios s1-faults measures it over 60 s.)
    during = np.arange(len(z)) <= np.max(np.nonzero(bad.any(axis=1))[0])
    assert not np.any(newly_rejected & ~bad.any(axis=1) & during), "a good sample rejected"
    if fault == "spikes":
        assert rejected[-1] == 4 and not faults.any()
        assert np.array_equal(newly_rejected, bad.any(axis=1))
    elif fault == "saturation":
        # Isolated peaks clipped by little (59 samples, most within the gate's
        # width): what is rejected is clipped, and the load does not stray.
        assert bad.sum() >= 5 and rejected[-1] <= bad.sum()
    else:
        channel = int(np.argmax(bad.sum(axis=0)))
        first = int(np.argmax(bad[:, channel]))
        raised = int(np.argmax(faults[:, channel]))
        # A drift starts at zero: it fails the gate once it exceeds the noise (about 0.1 s).
        delay = 40 if fault == "drift" else 5
        assert faults[:, channel].any() and first <= raised <= first + delay, (first, raised)
        name = ["z1_ddot", "z2_ddot"][channel]
        episodes = [w for w in warnings if w.startswith(f"input {name} is faulty from t =")]
        assert 1 <= len(episodes) == int(np.sum(np.diff(faults[:, channel]) > 0)), warnings
    assert not slave.errors()


def test_a_true_load_step_is_followed_and_the_gate_can_be_turned_off(new_slave, s1_table):
    """A step of 100 N (10× the load's RMS) in the measured accelerations —
    here made by adding m2·100/m2 to z2_ddot, the jump a true step causes at
    once — fails the gate until the filter re-acquires (logged), after which
    F follows within 0.1 s; with gate_probability = 1 nothing is rejected."""
    z = s1_table.z.copy()
    z[400:, 1] += 100.0 / 8.0  # m2 = 8 kg: a 100 N step on mass 2
    gated, open_ = new_slave("gated"), new_slave("open")
    gated.initialize(**sensor(s1_table))
    open_.initialize(**sensor(s1_table), gate_probability=1.0)
    for slave in (gated, open_):
        rows = []
        for zk in z:
            slave.inputs(zk)
            rows.append(slave.get("F")[0])
            slave.step()
        slave.f = np.array(rows)
    assert any("re-acquired at t =" in w for w in gated.warnings()), gated.warnings()
    assert gated.fmu.getInteger([gated.vr["rejected_measurements"]])[0] > 0
    assert open_.fmu.getInteger([open_.vr["rejected_measurements"]])[0] == 0
    # 0.1 s after the step both estimates carry it (an extra 100 N).
    k = 400 + 20
    assert abs(gated.f[k] - open_.f[k]) < 5.0, (gated.f[k], open_.f[k])


def test_ten_samples_of_a_million_on_both_inputs_change_nothing_silently(new_slave, s1_table):
    """The glitch that once gave a load of -7.6e6 N with F_std 0.08 N and
    filter_healthy true: ten samples of ±1e6 m/s² (each a little different,
    so not stuck) on both inputs. Every one is rejected (none is used even
    when the filter re-acquires: they are beyond implausible_sigmas),
    filter_healthy is false while every input is rejected, both inputs are
    flagged, and the load stays within 4σ of the truth throughout."""
    z = s1_table.z.copy()
    z[300:310] = 1e6 * np.array([1.0, -1.0]) * (1.0 + 0.01 * np.arange(10))[:, None]
    slave = new_slave()
    slave.initialize(**sensor(s1_table))
    rows = []
    for zk in z:
        slave.inputs(zk)
        f, f_std = slave.get("F", "F_std")
        flags = slave.fmu.getBoolean([slave.vr[n] for n in ("filter_healthy", "z1_ddot_fault", "z2_ddot_fault")])
        rows.append([f, f_std, *flags])
        slave.step()
    out = np.array(rows)
    after = s1_table.time >= 1.0
    assert np.max(np.abs(out[:, 0] - s1_table.load)[after] / out[after, 1]) < 4.0
    assert slave.fmu.getInteger([slave.vr["rejected_measurements"]])[0] == 20
    assert not out[300:310, 2].any() and out[320:, 2].all()
    assert out[302:310, 3].all() and out[302:310, 4].all() and not out[320:, 3:].any()
