"""Study S5's JSBSim truth (truth/s5_jsbsim/): the missile loads and flies, the
coefficients change at 10 s, the axes and angles come out in the paper's conventions
(docs/studies/s5.md), the measurements carry their stated noise, the log reads back, and
JSBSim's flight is compared with the doc's equations (flat Earth) integrated by RK4."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "truth" / "s5_jsbsim"))

import crosscheck  # noqa: E402
import fly  # noqa: E402

DEG = math.pi / 180


@pytest.fixture(scope="module")
def run():
    """The 20 s flight of the study, seed 1, no estimator."""
    return fly.fly(seed=1)


def start_with(**changes) -> dict:
    """A start in paper axes: level, 1000 m/s along x, at rest otherwise, with `changes`."""
    start = {"V": (1000.0, 0.0, 0.0), "omega": (0.0, 0.0, 0.0), "attitude": (0.0, 0.0, 0.0), "h": 10_000.0}
    start.update(changes)
    return start


def initial(start: dict) -> tuple[object, fly.Sample]:
    fdm = fly.load_missile()
    fly.set_start(fdm, start)
    fly.set_inputs(fdm, fly.COEFFICIENTS_BEFORE, np.zeros(3))
    fdm.run_ic()
    return fdm, fly.read_sample(fdm)


# --------------------------------------------------------------------------
# The flight
# --------------------------------------------------------------------------


def test_the_missile_flies_20_s_without_nan(run):
    # One sample every 5 ms from 0 to 20 s, each of every series.
    n = 4001
    np.testing.assert_array_equal(run.time, np.arange(n) * fly.SAMPLE_TIME)
    assert run.time[-1] == pytest.approx(20.0)
    assert run.measurements.shape == run.clean.shape == (n, 12) and run.states.shape == (n, 10)
    assert run.forces.shape == run.deflections.shape == (n, 3) and run.qbar.shape == run.rho.shape == (n,)
    for array in (run.measurements, run.clean, run.states, run.forces, run.qbar, run.rho):
        assert np.all(np.isfinite(array))
    speed = np.linalg.norm(run.states[:, :3], axis=1)
    assert speed[0] == pytest.approx(math.sqrt(1000**2 + 2 * 10**2))
    assert np.all(np.diff(speed) < 0), "no thrust: the drag slows it throughout"
    assert 300 < speed[-1] < 500 and 9_000 < run.states[:, 6].min() and run.states[:, 6].max() < 11_000
    # The start as the doc gives it, in paper axes.
    start = [1000, 10, 10, 15 * DEG, 3 * DEG, 3 * DEG, 10_000, 3 * DEG, 3 * DEG, 3 * DEG]
    np.testing.assert_allclose(run.states[0], start, rtol=1e-12, atol=1e-9)


@pytest.fixture(scope="module")
def roll_turn_run():
    """The 20 s flight through the second manoeuvre, `roll-turn`, seed 1, no estimator."""
    return fly.fly(seed=1, manoeuvre=fly.Manoeuvre.named("roll-turn"))


def assert_deflections_are_the_files(run, path: Path) -> None:
    """The run's deflections are the manoeuvre file's: the sum of the segments covering t,
    end-exclusive."""
    data = json.loads(path.read_text())
    assert run.time[-1] == pytest.approx(data["duration"])
    for i, name in enumerate(fly.DEFLECTION_NAMES):
        segments = data["controls"][name]
        assert segments, name
        expected = np.zeros(len(run.time))
        ns = np.round(run.time * 1e9).astype(np.int64)
        for t0, t1, degrees in segments:
            expected += np.where((ns >= round(t0 * 1e9)) & (ns < round(t1 * 1e9)), math.radians(degrees), 0.0)
        np.testing.assert_allclose(run.deflections[:, i], expected, rtol=0, atol=1e-15)
        # A segment's end belongs to what follows it.
        t0, t1, degrees = segments[0]
        k = int(round(t1 / fly.SAMPLE_TIME))
        assert run.deflections[k - 1, i] - run.deflections[k, i] == pytest.approx(
            math.radians(degrees) - sum(math.radians(d) for a, b, d in segments if a <= t1 < b)
        )


def test_the_manoeuvre_is_the_files(run):
    """Read from truth/data/s5_manoeuvre.json, not copied."""
    assert_deflections_are_the_files(run, fly.MANOEUVRE)
    assert run.metadata["manoeuvre"] == "truth/data/s5_manoeuvre.json"
    assert run.metadata["manoeuvre_name"] == "standard"


def test_the_roll_turn_manoeuvre_is_its_file_the_one_the_6dof_flies(run, roll_turn_run):
    """`roll-turn` is truth/data/s5_manoeuvre_roll_turn.json, the file the 6-DOF's
    `Manoeuvre::named("roll-turn")` compiles in: other deflections than the standard's,
    the same change of the coefficients at 10 s, and a flight that stays finite."""
    assert fly.MANOEUVRES["roll-turn"] == fly.ROOT / "truth" / "data" / "s5_manoeuvre_roll_turn.json"
    assert "s5_manoeuvre_roll_turn.json" in (fly.ROOT / "truth" / "src" / "s5" / "manoeuvre.rs").read_text()
    assert_deflections_are_the_files(roll_turn_run, fly.MANOEUVRES["roll-turn"])
    assert roll_turn_run.metadata["manoeuvre"] == "truth/data/s5_manoeuvre_roll_turn.json"
    assert roll_turn_run.metadata["manoeuvre_name"] == "roll-turn"
    assert not np.array_equal(roll_turn_run.deflections, run.deflections)
    np.testing.assert_array_equal(roll_turn_run.coefficients, run.coefficients)
    assert np.all(np.isfinite(roll_turn_run.states)) and np.all(np.isfinite(roll_turn_run.measurements))
    # Roll-heavy: the roll rate moves more than in the standard manoeuvre.
    roll_rms = lambda r: np.sqrt(np.mean(r.states[:, 7] ** 2))  # noqa: E731
    assert roll_rms(roll_turn_run) > roll_rms(run)
    with pytest.raises(ValueError, match="unknown manoeuvre"):
        fly.Manoeuvre.named("loop")


def test_the_coefficients_change_at_10_s_and_the_forces_jump(run):
    k = int(round(10.0 / fly.SAMPLE_TIME))
    assert run.time[k] == pytest.approx(10.0)
    np.testing.assert_array_equal(run.coefficients[:k], np.tile(fly.COEFFICIENTS_BEFORE, (k, 1)))
    np.testing.assert_array_equal(run.coefficients[k:], np.tile(fly.COEFFICIENTS_AFTER, (len(run.time) - k, 1)))

    def expected_force(i, c):
        alpha, beta = run.clean[i, 10], run.clean[i, 11]
        d = run.deflections[i]
        return run.qbar[i] * 1.6771 * np.array(
            [
                c[0] + c[1] * alpha + c[2] * beta + c[3] * d[0],
                c[4] + c[5] * alpha + c[6] * d[1],
                c[7] + c[8] * beta + c[9] * d[2],
            ]
        )

    # The forces of 9.995 s are Table 1's, those of 10 s and after Table 2's, each of its
    # own state.
    before, after = fly.COEFFICIENTS_BEFORE, fly.COEFFICIENTS_AFTER
    for i, table in [(k - 2, before), (k - 1, before), (k, after), (k + 1, after)]:
        np.testing.assert_allclose(run.forces[i], expected_force(i, table), rtol=1e-8)  # JSBSim's S: 3e-9 off
    # The jump at 10 s: q·S·ΔC of that state, about 25 % of the drag and 11 % of the
    # lateral force (ΔCx0, ΔCz0), far above the forces' drift over a step before it.
    jump = run.forces[k] - expected_force(k, fly.COEFFICIENTS_BEFORE)
    drift = np.abs(run.forces[k - 1] - run.forces[k - 2])
    assert np.all(np.abs(jump[[0, 2]]) > 20 * drift[[0, 2]])
    assert jump[0] / run.forces[k - 1, 0] == pytest.approx(0.25, abs=0.05)  # Cx0 −0.2302 → −0.2878
    assert jump[2] / run.forces[k - 1, 2] == pytest.approx(0.11, abs=0.03)  # Cz0 0.5303 → 0.5892


def test_alpha_beta_and_the_overloads_follow_the_docs_definitions(run):
    vx, vy, vz = run.states[:, 0], run.states[:, 1], run.states[:, 2]
    speed = np.linalg.norm(run.states[:, :3], axis=1)
    # JSBSim's aero/alpha-rad and aero/beta-rad are the doc's α, β of its body velocities.
    np.testing.assert_allclose(run.clean[:, 10], np.arctan2(-vy, vx), rtol=0, atol=1e-13)
    np.testing.assert_allclose(run.clean[:, 11], np.arcsin(vz / speed), rtol=0, atol=1e-13)
    # q is ½ρV² of the same state.
    np.testing.assert_allclose(run.qbar, 0.5 * run.rho * speed**2, rtol=1e-12)
    # The overloads are force/(m g), the force q S C(α, β, δ) of the same state.
    np.testing.assert_allclose(run.clean[:, 3:6] * fly.MASS * fly.GRAVITY, run.forces, rtol=1e-12)
    c, d = run.coefficients, run.deflections
    alpha, beta = run.clean[:, 10], run.clean[:, 11]
    coefficient = np.stack(
        [
            c[:, 0] + c[:, 1] * alpha + c[:, 2] * beta + c[:, 3] * d[:, 0],
            c[:, 4] + c[:, 5] * alpha + c[:, 6] * d[:, 1],
            c[:, 7] + c[:, 8] * beta + c[:, 9] * d[:, 2],
        ],
        axis=1,
    )
    # (rtol: JSBSim holds S = 1.6771 m² in ft² to 3e-9.)
    expected = run.qbar[:, None] * 1.6771 * coefficient / (980 * 9.8)
    np.testing.assert_allclose(run.clean[:, 3:6], expected, rtol=1e-8, atol=1e-12)
    # The other measurements are the states.
    np.testing.assert_array_equal(run.clean[:, 0:3], run.states[:, 7:10])
    np.testing.assert_array_equal(run.clean[:, 6:10], run.states[:, 3:7])


def test_the_measurement_noise_has_the_stated_sigma(run):
    noise = run.measurements - run.clean
    n = len(noise)
    std = noise.std(axis=0)
    np.testing.assert_allclose(std, fly.NOISE_STD, rtol=0.06)  # 4.2σ of the estimate's 1.1 %
    assert np.all(np.abs(noise.mean(axis=0)) < 4.5 * fly.NOISE_STD / math.sqrt(n))
    corr = np.corrcoef(noise.T)
    assert np.max(np.abs(corr - np.eye(12))) < 0.08, "white and independent across channels"
    lag1 = [np.corrcoef(noise[:-1, i], noise[1:, i])[0, 1] for i in range(12)]
    assert np.max(np.abs(lag1)) < 0.08, "white in time"
    # Seeded: the same seed, the same noise; another seed, another.
    again = fly.fly(0.1, seed=1)
    np.testing.assert_array_equal(again.measurements, run.measurements[: len(again.time)])
    assert not np.array_equal(fly.fly(0.1, seed=2).measurements, again.measurements)


# --------------------------------------------------------------------------
# Axes and angles
# --------------------------------------------------------------------------


def test_the_euler_conversion_round_trips_and_is_the_simple_mapping():
    rng = np.random.default_rng(3)
    for _ in range(200):
        pitch, yaw, roll = rng.uniform(-1.4, 1.4), rng.uniform(-3.1, 3.1), rng.uniform(-3.1, 3.1)
        phi, theta, psi = fly.jsbsim_attitude(pitch, yaw, roll)
        np.testing.assert_allclose(fly.paper_attitude(phi, theta, psi), (pitch, yaw, roll), atol=1e-12)
        # Both are yaw-pitch-roll sequences about the same axes: φ = θ', ψ = −ψ', γ = φ'.
        assert theta == pytest.approx(pitch, abs=1e-12) and phi == pytest.approx(roll, abs=1e-12)
        assert math.remainder(psi + yaw, 2 * math.pi) == pytest.approx(0, abs=1e-12)
        # The paper's DCM is JSBSim's in the paper's axes, and gives the doc's gravity and ḣ.
        C = fly.paper_dcm(pitch, yaw, roll)
        P = fly.PAPER_FROM_JSBSIM
        np.testing.assert_allclose(C, P @ fly.jsbsim_dcm(phi, theta, psi) @ P.T, atol=1e-12)
        g = C @ [0, -9.8, 0]
        sp, cp, sg, cg = math.sin(pitch), math.cos(pitch), math.sin(roll), math.cos(roll)
        np.testing.assert_allclose(g, [-9.8 * sp, -9.8 * cp * cg, 9.8 * cp * sg], atol=1e-12)
        v = rng.normal(size=3)
        assert (C.T @ v)[1] == pytest.approx(v[0] * sp + v[1] * cp * cg - v[2] * cp * sg, abs=1e-12)


@pytest.mark.parametrize(
    "attitude, jsbsim_euler",
    [
        # pure pitch, nose up 10°: JSBSim θ' = +10°
        ((10 * DEG, 0, 0), (0, 10 * DEG, 0)),
        # pure yaw, nose left 10° (ψ > 0 about "up"): JSBSim's heading ψ' = 350°
        ((0, 10 * DEG, 0), (0, 0, 350 * DEG)),
        # pure roll, right wing down 10°: JSBSim φ' = +10°
        ((0, 0, 10 * DEG), (10 * DEG, 0, 0)),
    ],
    ids=["pitch", "yaw", "roll"],
)
def test_a_pure_start_comes_out_in_paper_axes(attitude, jsbsim_euler):
    fdm, sample = initial(start_with(attitude=attitude))
    got = np.array([fdm["attitude/phi-rad"], fdm["attitude/theta-rad"], fdm["attitude/psi-rad"]])
    np.testing.assert_allclose(np.remainder(got - jsbsim_euler + math.pi, 2 * math.pi) - math.pi, 0, atol=1e-9)
    np.testing.assert_allclose(sample.state[3:6], attitude, atol=1e-9)


def test_pure_rates_and_velocities_have_the_docs_signs():
    # ωz > 0 pitches the nose up: JSBSim q > 0, and the pitch φ grows.
    fdm, s = initial(start_with(omega=(0, 0, 0.1)))
    assert fdm["velocities/q-rad_sec"] == pytest.approx(0.1) and fdm["velocities/r-rad_sec"] == 0
    # ωy > 0 yaws the nose left: JSBSim r < 0, and the paper's ψ grows.
    fdm, s = initial(start_with(omega=(0, 0.1, 0)))
    assert fdm["velocities/r-rad_sec"] == pytest.approx(-0.1)
    # ωx > 0 rolls the right wing down: JSBSim p > 0, and γ grows.
    fdm, s = initial(start_with(omega=(0.1, 0, 0)))
    assert fdm["velocities/p-rad_sec"] == pytest.approx(0.1)
    for omega, grows in [((0, 0, 0.1), 3), ((0, 0.1, 0), 4), ((0.1, 0, 0), 5)]:
        still = fly.Manoeuvre(0.05, 1e9, {n: [] for n in fly.DEFLECTION_NAMES})
        r = fly.fly(0.05, start=start_with(omega=omega), manoeuvre=still)
        assert r.states[-1, grows] > 0.003, (omega, r.states[-1, 3:6])
    # Vy > 0 (up in the body) is a negative α; Vz > 0 (to the right) a positive β, whose
    # lateral force C_z β (C_z^β < 0) pushes to the left.
    fdm, s = initial(start_with(V=(1000.0, 20.0, 0.0)))
    assert fdm["velocities/w-fps"] < 0 and s.measurement[10] == pytest.approx(-math.atan(0.02))
    fdm, s = initial(start_with(V=(1000.0, 0.0, 20.0)))
    assert fdm["velocities/v-fps"] > 0 and s.measurement[11] == pytest.approx(math.asin(20 / math.hypot(1000, 20)))
    fly.set_inputs(fdm, np.r_[fly.COEFFICIENTS_BEFORE[:7], 0.0, fly.COEFFICIENTS_BEFORE[8:]], np.zeros(3))
    fdm.run()
    assert fly.read_sample(fdm).force[2] < 0
    # Normal force up at α > 0 (C_y^α > 0): JSBSim's Z force is negative (upward).
    fdm, s = initial(start_with(V=(1000.0, -20.0, 0.0)))
    assert s.force[1] > 0 and fdm["forces/fbz-aero-lbs"] < 0
    # The drag: C_x0 < 0 decelerates.
    assert s.force[0] < 0 and fdm["forces/fbx-aero-lbs"] < 0


# --------------------------------------------------------------------------
# The estimator hook and the log
# --------------------------------------------------------------------------


class PassThrough:
    """An 'estimator' that believes its sensors: enough to exercise the hook."""

    name = "pass-through"

    def __init__(self):
        self.calls = []

    def __call__(self, t, z, delta):
        self.calls.append((t, z.copy(), delta.copy()))
        return {"phi": z[6], "phi_std": 1e-3, "h": z[9], "h_std": 1.0, "omega_z": z[2]}


def test_the_estimator_is_called_every_5_ms_with_the_measurements_of_t(tmp_path, analyzer_bin):
    estimator = PassThrough()
    log = tmp_path / "estimated.mcap"
    r = fly.fly(1.0, seed=4, estimator=estimator, log=log)
    times = np.array([c[0] for c in estimator.calls])
    np.testing.assert_allclose(times, r.time, atol=1e-12)
    np.testing.assert_array_equal(np.array([c[1] for c in estimator.calls]), r.measurements)
    np.testing.assert_array_equal(np.array([c[2] for c in estimator.calls]), r.deflections)
    assert r.estimates == ["phi", "phi_std", "h", "h_std", "omega_z"]
    report = tmp_path / "report.json"
    subprocess.run([str(analyzer_bin), "report", str(log), "--json", str(report)], check=True, capture_output=True)
    runs = json.loads(report.read_text())["runs"]
    assert runs[0]["metadata"]["filter"] == "pass-through" and runs[0]["metadata"]["study"] == "S5"
    pairs = {p["truth"]: p for p in runs[0]["pairs"]}
    assert set(pairs) == {"phi", "h", "omega_z"}
    assert pairs["phi"]["rmse"] == pytest.approx(1e-3, rel=0.2) and pairs["h"]["rmse"] == pytest.approx(1.0, rel=0.2)
    assert pairs["phi"]["two_sigma_coverage"] == pytest.approx(0.95, abs=0.05)


def test_the_log_reads_back(run, tmp_path, analyzer_bin):
    from mcap.reader import make_reader
    from mcap_ros1.decoder import DecoderFactory

    log = tmp_path / "jsbsim.mcap"
    fly.write_log(log, run)
    with open(log, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        topics = {c.topic: c.id for c in summary.channels.values()}
        assert set(topics) == {"/measurements", "/truth"}
        counts = summary.statistics.channel_message_counts
        assert counts[topics["/measurements"]] == counts[topics["/truth"]] == len(run.time)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}["kalfmu"]
        assert metadata["study"] == "S5" and metadata["case"] == "jsbsim" and metadata["seed"] == "1"
        assert json.loads(metadata["parameters"])["jsbsim_dt"] == pytest.approx(0.00025)
        truth = [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(topics=["/truth"])]
    assert truth[2000][0] == 10_000_000_000
    assert truth[2000][1].Cz_b == fly.COEFFICIENTS_AFTER[8] and truth[1999][1].Cz_b == fly.COEFFICIENTS_BEFORE[8]
    assert truth[0][1].Vy == pytest.approx(10.0) and truth[0][1].alpha == pytest.approx(math.atan2(-10, 1000))
    # The analyzer refuses a log without /estimate; it reads this one with the raw
    # measurements as the "estimate": their error from the truth is the noise.
    refused = subprocess.run([str(analyzer_bin), "report", str(log)], capture_output=True, text=True)
    assert refused.returncode != 0 and "/estimate is missing" in refused.stderr
    report = tmp_path / "report.json"
    subprocess.run(
        [str(analyzer_bin), "report", str(log), "--estimate-topic", "/measurements", "--json", str(report)],
        check=True,
        capture_output=True,
    )
    pairs = {p["truth"]: p for p in json.loads(report.read_text())["runs"][0]["pairs"]}
    assert set(pairs) == set(fly.MEASUREMENT_NAMES)
    for name, sigma in zip(fly.MEASUREMENT_NAMES, fly.NOISE_STD):
        assert pairs[name]["samples"] == len(run.time)
        assert pairs[name]["rmse"] == pytest.approx(sigma, rel=0.06), name


# --------------------------------------------------------------------------
# JSBSim against the doc's equations
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def doc_flight():
    """The doc's equations (flat Earth, g = 9.8, ISA at h), RK4 at 2.5 ms."""
    return crosscheck.integrate()


def test_jsbsim_departs_from_the_flat_earth_equations_by_its_world(run, doc_flight):
    """The mismatch between S5's two truths (measured, see the folder's README): mostly
    the atmosphere (US 1976 takes h as geometric: ρ is 0.19 % higher at 10 km than the
    doc's ISA of h), the Earth's curvature (h, the attitude to the local level) and
    rotation (the heading, the rates)."""
    d = crosscheck.max_differences(run.states, doc_flight.states)
    print("JSBSim vs the doc's equations, largest difference over 20 s:", d)
    bounds = {
        "V": 1.0,  # m/s
        "alpha": 0.05,  # deg
        "beta": 0.02,
        "omega_x": 0.06,  # deg/s
        "omega_y": 0.2,
        "omega_z": 0.7,
        "phi": 0.2,  # deg
        "psi": 0.6,
        "gamma": 0.3,
        "h": 20.0,  # m
    }
    for name, bound in bounds.items():
        assert d[name] < bound, (name, d[name])
    # Not identical either: the worlds differ measurably.
    assert d["h"] > 3 and d["V"] > 0.1


def test_jsbsim_on_a_flat_still_planet_is_the_docs_equations(tmp_path):
    """With a planet 1000× the Earth's radius, still, g = 9.8, and the doc's equations
    given US 1976's air, the two integrations agree to their integration error: the
    aircraft file, its axes and the conversions are the doc's model."""
    flat = fly.fly(planet=crosscheck.planet_file(tmp_path, "flat"))
    ref = crosscheck.integrate(density=crosscheck.us76_density)
    d = crosscheck.max_differences(flat.states, ref.states)
    print("JSBSim (flat, still planet) vs the doc's equations with US 1976 air:", d)
    bounds = {"V": 0.005, "h": 0.01, "omega_x": 1e-3, "omega_y": 2e-3, "omega_z": 1e-2}  # m/s, m, deg/s
    bounds.update({n: 2e-3 for n in ("alpha", "beta", "phi", "psi", "gamma")})  # deg
    for name, bound in bounds.items():
        assert d[name] < bound, (name, d[name])


def logged_metadata(log: Path) -> dict:
    """The metadata `kalfmu` of an MCAP log."""
    from mcap.reader import make_reader

    with open(log, "rb") as f:
        return {m.name: m.metadata for m in make_reader(f).iter_metadata()}["kalfmu"]


def test_an_fmu_plugs_in_as_the_estimator(s1_fmu, tmp_path):
    """`FmuEstimator` drives a packaged FMU at each sample (set the inputs of t, read,
    step 5 ms): here S1's, fed two of our signals. The run's `filter` is the kind the FMU
    runs (S1's default, SRCKF), named as our own runs name it; `fmu` is the FMU."""
    estimator = fly.FmuEstimator(s1_fmu, inputs={"z1_ddot": "Nx", "z2_ddot": "Ny"})
    try:
        r = fly.fly(0.2, estimator=estimator, log=tmp_path / "s1_fmu.mcap")
    finally:
        estimator.close()
    assert r.metadata["filter"] == "SRCKF" and r.metadata["fmu"] == "kalfmu_s1_load"
    metadata = logged_metadata(tmp_path / "s1_fmu.mcap")
    assert metadata["filter"] == "SRCKF" and metadata["fmu"] == "kalfmu_s1_load"
    assert "F" in r.estimates and "nis" in r.estimates
    assert r.estimate.shape == (len(r.time), len(r.estimates)) and np.all(np.isfinite(r.estimate))
    # The filter moved: its estimate after the first sample is not its prior.
    assert not np.array_equal(r.estimate[0], r.estimate[-1])
    with pytest.raises(ValueError, match="no input named"):
        fly.FmuEstimator(s1_fmu)  # S1 has no input omega_x


@pytest.mark.parametrize("value, kind", [(3, "SVD-CKF"), (4, "UKF")])
def test_the_filter_set_is_the_filter_recorded(s1_fmu, value, kind):
    """`filter` is read back from the FMU after initialisation and named through its
    model description's enumeration: setting it changes the label."""
    estimator = fly.FmuEstimator(s1_fmu, {"filter": value}, inputs={"z1_ddot": "Nx", "z2_ddot": "Ny"})
    try:
        assert estimator.name == kind and estimator.fmu == "kalfmu_s1_load"
    finally:
        estimator.close()


def test_the_command_line_records_the_filter_of_set(s5_fmu, tmp_path, capsys):
    """As `kalfmu reproduce --study s5` calls it: `--fmu <S5's> --set filter=N` logs
    the run with `filter` the kind N names (not the FMU's default, SVD-CKF) and `fmu` the
    FMU's identifier."""
    labels = {}
    for value in (1, 4):
        log = tmp_path / f"jsbsim_{value}.mcap"
        fly.main([str(log), "--fmu", str(s5_fmu), "--duration", "0.05", "--set", f"filter={value}"])
        metadata = logged_metadata(log)
        assert metadata["fmu"] == "kalfmu_s5_missile"
        labels[value] = metadata["filter"]
    assert labels == {1: "CKF", 4: "UKF"}


def ssv_file(path: Path, values: dict[str, float]) -> Path:
    """An SSP parameter-value file of `values`, as `start_values::ssv` writes one."""
    parameters = "".join(
        f'<ssv:Parameter name="{n}"><ssv:Real value="{v:e}"/></ssv:Parameter>' for n, v in values.items()
    )
    path.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<ssv:ParameterSet xmlns:ssv="{fly.SSV[1:-1]}" version="1.0" name="test">'
        f"<ssv:Parameters>{parameters}</ssv:Parameters></ssv:ParameterSet>\n"
    )
    return path


def test_the_command_line_flies_a_manoeuvre_by_name_with_start_values_of_both_forms(s5_fmu, tmp_path):
    """`--manoeuvre roll-turn --values FILE.ssv --set …`: the run flies that manoeuvre, and
    the FMU takes the file's values and then `--set`'s, a later one replacing an earlier
    one, each by its type (rk4_substeps an Integer, filter an Enumeration): the log records
    what the FMU reports of them after initialisation."""
    values = ssv_file(tmp_path / "tuned.ssv", {"r_Nx_std": 2e-3, "rk4_substeps": 2, "filter": 1})
    log = tmp_path / "roll_turn.mcap"
    fly.main(
        [str(log), "--manoeuvre", "roll-turn", "--duration", "0.05", "--fmu", str(s5_fmu)]
        + ["--values", str(values), "--set", "filter=4", "--set", "q_rate_std=2e-6"]
    )
    metadata = logged_metadata(log)
    assert metadata["manoeuvre_name"] == "roll-turn"
    assert metadata["filter"] == "UKF", "--set after --values"
    assert json.loads(metadata["fmu_start_values"]) == {
        "r_Nx_std": 2e-3,
        "rk4_substeps": 2.0,
        "filter": 4.0,
        "q_rate_std": 2e-6,
    }
    assert fly.read_ssv(values) == {"r_Nx_std": 2e-3, "rk4_substeps": 2.0, "filter": 1.0}


def test_a_start_value_of_the_wrong_name_or_type_is_refused_before_the_flight(s5_fmu, tmp_path):
    log = tmp_path / "refused.mcap"
    with pytest.raises(ValueError, match="no parameter named mass_x"):
        fly.main([str(log), "--duration", "0.05", "--fmu", str(s5_fmu), "--set", "mass_x=1"])
    with pytest.raises(ValueError, match="rk4_substeps: 1.5 is not an Integer"):
        fly.main([str(log), "--duration", "0.05", "--fmu", str(s5_fmu), "--set", "rk4_substeps=1.5"])
    with pytest.raises(SystemExit):
        fly.main([str(log), "--duration", "0.05", "--set", "filter=1"])  # no FMU to give it to
    assert not log.exists()
