"""The packaged S3 estimator FMU (`kalfmu_s3_wheel_rail_lr.fmu`) through fmpy: what
is particular to S3. The battery every estimator FMU passes runs on S3 too, in
test_fmu.py (parametrised, test ids `s3`): fmpy's validation and `fmutool
-check`, a shared library on the C runtime only, illegal calls refused and
changing nothing, independent interleaved instances, FMU states that roll
back and continue identically in a new instance, NaN inputs skipped, counted
and reported once per input, tunable against fixed parameters, a measurement
entering once however often the inputs are set, steps of several samples and
steps between samples; `fmu/tests/random_calls.rs` drives it with random call
sequences.

Here, each run a master of the FMU's defaults (sample_time 1 ms) that sets the
inputs of t, reads the outputs (the update at t) and steps:

* the interface the study driver relies on: the 28 inputs in the model's row
  order, the eight forces with their σ, the sums and differences with theirs,
  the parameters by name;
* at rest (the sensors' noise only, 0.01 m/s², told to the FMU: a constant
  input would read as a stuck sensor; deflections never set) each wheelset's
  sum stays at twice the static wheel load, the forces within 3σ of it (with
  random walks the differences no accelerometer sees wander, their σ growing),
  within 2 % with force_return_rate 5/s (the default); the derived outputs are the forces'
  sum and difference, and their σ fit the forces' (|σ_L − σ_R| ≤ σ_sum,
  σ_diff ≤ σ_L + σ_R);
* left/right-mirrored inputs give mirrored forces (F_NLj ↔ F_NRj, F_diff's sign
  flipped, F_sum the same) to rounding;
* deflection inputs never set give the estimates of deflections set NaN (each
  row `missing`), and deflections set change the estimates;
* with a side-to-side roll of the whole car, `force_return_rate` > 0 changes the
  estimated differences.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description

from test_fmu import slaves

ACCELERATIONS = (
    [f"a_ab_{s}{j}" for j in range(1, 5) for s in "LR"]
    + [f"a_bf_{s}{j}" for j in range(1, 5) for s in "LR"]
    + ["a_cb_FL", "a_cb_FR", "a_cb_RL", "a_cb_RR"]
)
DEFLECTIONS = [f"d_p_{s}{j}" for j in range(1, 5) for s in "LR"]
FORCES = [f"F_N{s}{j}" for j in range(1, 5) for s in "LR"]
DERIVED = [f"F_{kind}{j}{std}" for j in range(1, 5) for kind in ("sum", "diff") for std in ("", "_std")]
PARAMETERS = [
    "car_body_mass",
    "car_body_pitch_inertia",
    "car_body_roll_inertia",
    "bogie_mass",
    "bogie_pitch_inertia",
    "bogie_roll_inertia",
    "wheelset_mass",
    "wheelset_roll_inertia",
    "primary_stiffness",
    "primary_damping",
    "primary_damping_beyond",
    "primary_damper_knee",
    "secondary_stiffness",
    "secondary_damping",
    "half_bogie_spacing",
    "half_wheelbase",
    "primary_half_span",
    "secondary_half_span",
    "contact_half_span",
    "static_wheel_load",
    "rk4_substeps",
    "p0_motion_std",
    "p0_force_std",
    "q_body_std",
    "q_wheelset_std",
    "force_noise_intensity",
    "force_return_rate",
]
#: The forces and their σ, then the derived outputs: the columns a run returns.
WATCHED = [n for f in FORCES for n in (f, f"{f}_std")] + DERIVED
DT = 0.001
NOISE = 0.01  # the sensors' noise at rest (m/s²), told to the FMU


def mirrored(name: str) -> str:
    """The input or force on the other side: L ↔ R (a_ab_L1 ↔ a_ab_R1, a_cb_FL ↔ a_cb_FR,
    F_NL1 ↔ F_NR1)."""
    swap = str.maketrans("LR", "RL")
    if name.startswith("a_cb_"):
        return name[:-1] + name[-1].translate(swap)
    return name[:-2] + name[-2].translate(swap) + name[-1]


@pytest.fixture(scope="module")
def s3(s3_fmu, tmp_path_factory):
    md = read_model_description(str(s3_fmu))
    unzipped = Path(extract(str(s3_fmu), str(tmp_path_factory.mktemp("unzipped-s3"))))
    return md, unzipped


@pytest.fixture
def new_s3(s3):
    """Instances of the S3 FMU."""
    md, unzipped = s3
    yield from slaves(unzipped, md)


def run(slave, rows: np.ndarray, names: list[str], **params: float) -> np.ndarray:
    """A master: the parameters in initialisation mode, then per row the inputs
    `names` set, the WATCHED outputs read (the update at t), a step. Inputs not in
    `names` are never set."""
    slave.initialize(**params)
    vrs = [slave.vr[n] for n in names]
    watched = [slave.vr[n] for n in WATCHED]
    out = []
    for z in rows:
        slave.fmu.setReal(vrs, [float(x) for x in z])
        out.append(slave.fmu.getReal(watched))
        slave.step(DT)
    return np.array(out)


def column(out: np.ndarray, name: str) -> np.ndarray:
    return out[:, WATCHED.index(name)]


def at_rest(n: int, seed: int) -> np.ndarray:
    return NOISE * np.random.default_rng(seed).standard_normal((n, len(ACCELERATIONS)))


QUIET = {f"r_{n}_std": NOISE for n in ACCELERATIONS}


def test_the_interface_has_the_names_the_study_driver_uses(s3):
    md, _ = s3
    variables = {v.name: v for v in md.modelVariables}
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    assert inputs == ACCELERATIONS + DEFLECTIONS
    for name in inputs:
        assert variables[f"{name}_fault"].causality == "output"
        assert variables[f"{name}_status"].causality == "output"
        assert variables[f"r_{name}_std"].variability == "tunable"
        assert variables[name].unit == ("m" if name.startswith("d_p_") else "m/s2")
    for name in FORCES + [f"{f}_std" for f in FORCES] + DERIVED:
        assert variables[name].causality == "output" and variables[name].unit == "N", name
    for name in PARAMETERS:
        assert variables[name].causality == "parameter", name
    assert variables["force_return_rate"].variability == "fixed"
    assert float(variables["force_return_rate"].start) == 5.0
    assert float(variables["static_wheel_load"].start) == pytest.approx((34e3 + 2 * 3e3 + 4 * 1.4e3) * 9.81 / 8)
    assert float(variables["r_a_ab_L1_std"].start) == 0.05 and float(variables["r_d_p_L1_std"].start) == 1e-4
    assert md.coSimulation.modelIdentifier == "kalfmu_s3_wheel_rail_lr"
    assert float(md.defaultExperiment.stepSize) == DT


def check_sums_and_differences(out: np.ndarray, p0: float) -> None:
    """The derived outputs are each wheelset's F_NL + F_NR and F_NL - F_NR, their σ
    between |σ_L - σ_R| and σ_L + σ_R."""
    for j in range(1, 5):
        left, right = column(out, f"F_NL{j}"), column(out, f"F_NR{j}")
        np.testing.assert_allclose(column(out, f"F_sum{j}"), left + right, rtol=1e-12)
        np.testing.assert_allclose(column(out, f"F_diff{j}"), left - right, rtol=0, atol=1e-9 * p0)
        sl, sr = column(out, f"F_NL{j}_std"), column(out, f"F_NR{j}_std")
        tol = 1e-9 * (sl + sr)
        for std in (column(out, f"F_sum{j}_std"), column(out, f"F_diff{j}_std")):
            assert (std <= sl + sr + tol).all()
            assert (std >= np.abs(sl - sr) - tol).all()


def test_at_rest_the_forces_stay_at_the_static_wheel_load_and_the_sums_and_differences_fit(s3, new_s3):
    """2 s at rest. Each wheelset's sum stays at twice the static wheel load within
    0.25 % all along. With random walks (force_return_rate 0) the differences the suspension
    balances without moving the car are seen by no accelerometer: their σ grows
    without bound (tens of kN after 2 s) and the forces stay within 3σ of the static
    load; with force_return_rate 5/s every force ends within 2 % of it (the random
    walks: up to 11 %), the differences' σ bounded."""
    p0 = static_wheel_load(s3)
    z = at_rest(2000, 5)
    slave = new_s3("random walks")
    walks = run(slave, z, ACCELERATIONS, **QUIET, force_return_rate=0.0)
    assert np.isfinite(walks).all()
    assert slave.fmu.getBoolean([slave.vr["filter_healthy"]]) == [True]
    slave = new_s3("returning")
    returns = run(slave, z, ACCELERATIONS, **QUIET, force_return_rate=5.0)
    assert np.isfinite(returns).all()
    assert slave.fmu.getBoolean([slave.vr["filter_healthy"]]) == [True]
    for out in (walks, returns):
        check_sums_and_differences(out, p0)
        for j in range(1, 5):
            assert (np.abs(column(out, f"F_sum{j}") - 2 * p0) < 5e-3 * p0).all(), j
        for force in FORCES:
            error = np.abs(column(out, force) - p0)[1:]
            assert (error <= 3 * column(out, f"{force}_std")[1:]).all(), force
    for force in FORCES:
        assert abs(column(returns, force)[-1] - p0) < 0.02 * p0, force
    for j in range(1, 5):
        assert abs(column(returns, f"F_diff{j}")[-1]) < 0.04 * p0
        assert column(returns, f"F_diff{j}_std")[-1] < 0.2 * column(walks, f"F_diff{j}_std")[-1]


def static_wheel_load(s3) -> float:
    """The default static wheel load (N)."""
    return float(next(v.start for v in s3[0].modelVariables if v.name == "static_wheel_load"))


def test_mirrored_inputs_give_mirrored_forces(s3, new_s3):
    """Tones of their own on every sensor, and the same with left and right swapped.
    No gate: tones not from the model fail it now and then, and a row at the gate's
    bound may go either way by rounding."""
    n = 1500
    rng = np.random.default_rng(11)
    t = DT * np.arange(n)
    # Different tones left and right (a roll), on the sensors' noise.
    tones = {name: 0.05 * np.sin(rng.uniform(5, 40) * t + rng.uniform(0, 2 * math.pi)) for name in ACCELERATIONS}
    z = at_rest(n, 7) + np.column_stack([tones[name] for name in ACCELERATIONS])
    swap = [ACCELERATIONS.index(mirrored(name)) for name in ACCELERATIONS]
    out = run(new_s3("straight"), z, ACCELERATIONS, **QUIET, gate_probability=1.0)
    back = run(new_s3("mirrored"), z[:, swap], ACCELERATIONS, **QUIET, gate_probability=1.0)
    assert np.isfinite(out).all() and np.isfinite(back).all()
    p0 = static_wheel_load(s3)
    for j in range(1, 5):
        for side in "LR":
            force = f"F_N{side}{j}"
            other = mirrored(force)
            np.testing.assert_allclose(column(back, other), column(out, force), rtol=0, atol=1e-6 * p0)
            np.testing.assert_allclose(column(back, f"{other}_std"), column(out, f"{force}_std"), rtol=1e-6)
        np.testing.assert_allclose(column(back, f"F_sum{j}"), column(out, f"F_sum{j}"), rtol=0, atol=1e-6 * p0)
        np.testing.assert_allclose(column(back, f"F_diff{j}"), -column(out, f"F_diff{j}"), rtol=0, atol=1e-6 * p0)
        for std in (f"F_sum{j}_std", f"F_diff{j}_std"):
            np.testing.assert_allclose(column(back, std), column(out, std), rtol=1e-6)
    # The input is a roll: the differences are not all 0.
    assert max(np.abs(column(out, f"F_diff{j}")).max() for j in range(1, 5)) > 1e-3 * p0


def test_deflections_never_set_are_missing_as_nan_and_set_ones_change_the_estimates(new_s3):
    n = 500
    z = at_rest(n, 9)
    unset = new_s3("unset")
    out = run(unset, z, ACCELERATIONS, **QUIET)
    statuses = unset.fmu.getInteger([unset.vr[f"{d}_status"] for d in DEFLECTIONS])
    assert statuses == [3] * len(DEFLECTIONS)  # missing
    # Each is reported once as never set, and flagged faulty (missing for fault_after samples).
    for d in DEFLECTIONS:
        assert sum(f"input {d} has never been set" in m for m in unset.warnings()) == 1, d
    faults = unset.fmu.getBoolean([unset.vr[f"{n}_fault"] for n in ACCELERATIONS + DEFLECTIONS])
    assert faults == [False] * len(ACCELERATIONS) + [True] * len(DEFLECTIONS)
    nan = run(new_s3("nan"), np.column_stack([z, np.full((n, 8), np.nan)]), ACCELERATIONS + DEFLECTIONS, **QUIET)
    assert np.array_equal(out, nan), "never set is missing, as NaN"
    measured = new_s3("measured")
    deflections = 1e-5 * np.random.default_rng(10).standard_normal((n, 8))
    set_ = run(measured, np.column_stack([z, deflections]), ACCELERATIONS + DEFLECTIONS, **QUIET)
    statuses = measured.fmu.getInteger([measured.vr[f"{d}_status"] for d in DEFLECTIONS])
    assert statuses == [1] * len(DEFLECTIONS)  # used
    assert np.isfinite(set_).all()
    assert not np.allclose(set_, out, rtol=1e-6, atol=0)
    # The deflections pin the force patterns no accelerometer sees: the differences' σ falls.
    for j in range(1, 5):
        assert column(set_, f"F_diff{j}_std")[-1] < column(out, f"F_diff{j}_std")[-1]


def test_a_force_return_rate_changes_the_estimates_of_a_side_to_side_roll(s3, new_s3):
    n = 1500
    t = DT * np.arange(n)
    roll = 0.2 * np.sin(2 * math.pi * 1.5 * t)  # the whole car rolling at 1.5 Hz
    sign = np.array([1.0 if "_L" in name or name.endswith("L") else -1.0 for name in ACCELERATIONS])
    z = at_rest(n, 13) + roll[:, None] * sign
    walks = run(new_s3("random walks"), z, ACCELERATIONS, **QUIET, force_return_rate=0.0)
    returns = run(new_s3("returning"), z, ACCELERATIONS, **QUIET, force_return_rate=5.0)
    assert np.isfinite(walks).all() and np.isfinite(returns).all()
    p0 = static_wheel_load(s3)
    change = max(np.abs(column(returns, f"F_diff{j}") - column(walks, f"F_diff{j}")).max() for j in range(1, 5))
    assert change > 1e-3 * p0, change
