"""Study S5's second truth: JSBSim flies the tactical missile of docs/studies/s5.md
(`missile.xml`, beside this file), and every 5 ms this driver hands JSBSim's outputs —
the twelve measurements in the paper's axes and units, with seeded white noise — and
the three deflections to an estimator, as a flight simulator would, then logs the run in
the kalfmu MCAP format (docs/log-format.md) for the analyzer.

    python truth/s5_jsbsim/fly.py OUT.mcap [--seed 1] [--duration 20] [--manoeuvre standard]
        [--fmu kalfmu_s5_missile.fmu [--values FILE.ssv …] [--set NAME=VALUE …]]

`--manoeuvre NAME` flies one of `MANOEUVRES` (`standard`, the published one, or
`roll-turn`): the same files `truth::s5::manoeuvre::Manoeuvre::named` compiles in, so both
truths fly the same deflections. `--values` (SSP parameter-value files, as `kalfmu-tune
--ssv` writes them) and then `--set` give the FMU's start values, a later one replacing an
earlier one, each set by its variable's type before initialisation ends.

As a module: `fly(...)` returns a `Run` (arrays per 5 ms sample) and, given `log`, writes
the log; `estimator` is any callable `(t, measurements[12], deflections[3]) -> {name:
value}` called at each sample with the measurements of that instant (`FmuEstimator`
wraps an FMU as one).

Conventions (the doc's, implemented here and in missile.xml):

- Paper body axes x forward, y up, z right; JSBSim's x forward, y right, z down. A paper
  vector is `PAPER_FROM_JSBSIM @ (JSBSim vector)`: (a_x, a_y, a_z) = (a_x', −a_z', a_y').
  So V = (u, −w, v), ω = (p, −r, q), forces (X, Y, Z) = (F_x', −F_z', F_y').
- The paper's earth frame is (north, up, east) = `PAPER_FROM_JSBSIM @ (north, east, down)`;
  its Euler angles rotate yaw ψ about "up", then pitch φ about the new z (right wing),
  then roll γ about x. Derived from JSBSim's direction cosine matrix (`paper_attitude`);
  this comes out as φ = θ', ψ = −ψ' (nose left positive: the opposite of a heading),
  γ = φ' (the tests check both).
- α = atan2(−Vy, Vx) = JSBSim's `aero/alpha-rad`, β = asin(Vz/V) = its `aero/beta-rad`.
- Overloads N = (X, Y, Z)/(m·g), m = 980 kg, g = 9.8 m/s² (the doc's), from JSBSim's
  aerodynamic forces of the same step (its `accelerations/N*` lag a step).
- Rates are JSBSim's `velocities/[pqr]-rad_sec`, the body's rate relative to the Earth
  (the inertial ones, `[pqr]i`, differ by the Earth's rotation, ≤ 7.3e-5 rad/s).

Integration: JSBSim at 0.25 ms (20 steps per sample) with Adams–Bashforth 4 on all four
integrators (its defaults are rectangular Euler for the rotational rate and attitude,
AB2/AB3 for translation), the rate integrators restarted after each jump of the inputs
(`restart_orders`); see `INTEGRATORS` and the README of this folder for the errors.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time as wallclock
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import jsbsim
import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
MANOEUVRE = ROOT / "truth" / "data" / "s5_manoeuvre.json"
#: The manoeuvres by name, as `truth::s5::manoeuvre::Manoeuvre::named` knows them: the
#: published one, and `roll-turn`, one the estimators were not tuned on.
MANOEUVRES = {"standard": MANOEUVRE, "roll-turn": ROOT / "truth" / "data" / "s5_manoeuvre_roll_turn.json"}

sys.path.insert(0, str(ROOT / "tests"))
from mcap_example import KalfmuLog, Signal  # noqa: E402  (the log writer, shared with the example)

# --------------------------------------------------------------------------
# The study's numbers (docs/studies/s5.md)
# --------------------------------------------------------------------------

FT = 0.3048  # m per ft
LBF = 4.4482216152605  # N per lbf
SLUG = 14.593902937206364  # kg per slug

MASS = 980.0  # kg
GRAVITY = 9.8  # m/s², the doc's g: the overloads are in these g
SAMPLE_TIME = 0.005  # s

COEFFICIENT_NAMES = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"]
#: Table 1's true values (until the change) and Table 2's (from it on).
COEFFICIENTS_BEFORE = np.array([-0.2302, 0.1735, 0.3148, 0.3149, -0.0944, 9.2596, -0.8647, 0.5303, -8.7916, 0.2229])
COEFFICIENTS_AFTER = np.array([-0.2878, 0.2041, 0.3703, 0.3499, -0.1049, 9.7469, -0.9608, 0.5892, -9.2543, 0.2477])

STATE_NAMES = ["Vx", "Vy", "Vz", "phi", "psi", "gamma", "h", "omega_x", "omega_y", "omega_z"]
MEASUREMENT_NAMES = ["omega_x", "omega_y", "omega_z", "Nx", "Ny", "Nz", "phi", "psi", "gamma", "h", "alpha", "beta"]
DEFLECTION_NAMES = ["delta_x", "delta_y", "delta_z"]
#: White noise per channel (σ, in the channel's unit): rates, overloads, attitude, altitude, α β.
NOISE_STD = np.array([1e-3] * 3 + [1e-3] * 3 + [1e-3] * 3 + [1.0] + [2e-3] * 2)

UNITS = {
    "Vx": "m/s", "Vy": "m/s", "Vz": "m/s", "phi": "rad", "psi": "rad", "gamma": "rad", "h": "m",
    "omega_x": "rad/s", "omega_y": "rad/s", "omega_z": "rad/s", "Nx": "1", "Ny": "1", "Nz": "1",
    "alpha": "rad", "beta": "rad", "delta_x": "rad", "delta_y": "rad", "delta_z": "rad",
}  # fmt: skip
DESCRIPTIONS = {
    "Vx": "body velocity along x (forward)", "Vy": "body velocity along y (up)",
    "Vz": "body velocity along z (right)", "phi": "pitch angle", "psi": "yaw angle (nose left positive)",
    "gamma": "roll angle (right wing down positive)", "h": "altitude above sea level",
    "omega_x": "roll rate (body x)", "omega_y": "yaw rate (body y, nose left positive)",
    "omega_z": "pitch rate (body z, nose up positive)", "Nx": "overload along x, X/(m g), g = 9.8",
    "Ny": "overload along y, Y/(m g)", "Nz": "overload along z, Z/(m g)",
    "alpha": "angle of attack atan2(-Vy, Vx)", "beta": "sideslip asin(Vz/V)",
    "delta_x": "roll deflection", "delta_y": "pitch deflection (C_y, m_z)", "delta_z": "yaw deflection (C_z, m_y)",
}  # fmt: skip

#: The doc's start, in paper axes (V m/s, ω rad/s, attitude rad, h m).
START = {
    "V": (1000.0, 10.0, 10.0),
    "omega": tuple(math.radians(3.0) for _ in range(3)),
    "attitude": (math.radians(15.0), math.radians(3.0), math.radians(3.0)),  # pitch φ, yaw ψ, roll γ
    "h": 10_000.0,
}

#: JSBSim's integrators (`simulation/integrator/...`): 0 none, 1 rectangular Euler,
#: 2 trapezoidal, 3 AB2, 4 AB3, 5 AB4, 6 Buss 1, 7 local linearisation, 8 Buss 2. Its
#: defaults are 1, 3, 1, 4 (Euler for the rotational rate and the attitude quaternion).
INTEGRATORS = {
    "rate/rotational": 5,
    "rate/translational": 5,
    "position/rotational": 5,
    "position/translational": 5,
}
#: JSBSim steps per 5 ms sample (its dt = SAMPLE_TIME / SUBSTEPS).
SUBSTEPS = 20
#: Where the flight starts on JSBSim's WGS84 Earth (not given by the paper) [est].
LATITUDE_DEG = 45.0
LONGITUDE_DEG = 0.0

# --------------------------------------------------------------------------
# Axes and angles
# --------------------------------------------------------------------------

#: paper vector = PAPER_FROM_JSBSIM @ JSBSim vector (body axes, and earth axes
#: (north, up, east) from (north, east, down)).
PAPER_FROM_JSBSIM = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _rx(a: float) -> np.ndarray:  # frame rotations (passive): v_new = R @ v_old
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def jsbsim_dcm(phi: float, theta: float, psi: float) -> np.ndarray:
    """Body from local NED of JSBSim's Euler angles: yaw ψ' about down, pitch θ' about
    the new y (right), roll φ' about x."""
    return _rx(phi) @ _ry(theta) @ _rz(psi)


def paper_dcm(pitch: float, yaw: float, roll: float) -> np.ndarray:
    """Body (x fwd, y up, z right) from earth (north, up, east) of the paper's angles:
    yaw ψ about up, pitch φ about the new z (right wing), roll γ about x. Its middle
    column is "up" in body axes: gravity (0, −g, 0) in body axes is −g·C[:, 1] =
    (−g sinφ, −g cosφ cosγ, g cosφ sinγ), the doc's terms."""
    return _rx(roll) @ _rz(pitch) @ _ry(yaw)


def paper_angles_of(dcm: np.ndarray) -> tuple[float, float, float]:
    """(pitch φ, yaw ψ, roll γ) of a `paper_dcm`."""
    pitch = math.asin(max(-1.0, min(1.0, dcm[0, 1])))
    return pitch, math.atan2(-dcm[0, 2], dcm[0, 0]), math.atan2(-dcm[2, 1], dcm[1, 1])


def jsbsim_angles_of(dcm: np.ndarray) -> tuple[float, float, float]:
    """(φ', θ', ψ') of a `jsbsim_dcm`, ψ' in [0, 2π) as JSBSim reports it."""
    theta = -math.asin(max(-1.0, min(1.0, dcm[0, 2])))
    return math.atan2(dcm[1, 2], dcm[2, 2]), theta, math.atan2(dcm[0, 1], dcm[0, 0]) % (2 * math.pi)


def paper_attitude(phi: float, theta: float, psi: float) -> tuple[float, float, float]:
    """The paper's (pitch φ, yaw ψ, roll γ) of JSBSim's (roll φ', pitch θ', yaw ψ')."""
    P = PAPER_FROM_JSBSIM
    return paper_angles_of(P @ jsbsim_dcm(phi, theta, psi) @ P.T)


def jsbsim_attitude(pitch: float, yaw: float, roll: float) -> tuple[float, float, float]:
    """JSBSim's (φ', θ', ψ') of the paper's (pitch φ, yaw ψ, roll γ)."""
    P = PAPER_FROM_JSBSIM
    return jsbsim_angles_of(P.T @ paper_dcm(pitch, yaw, roll) @ P)


def paper_vector(v) -> np.ndarray:
    return PAPER_FROM_JSBSIM @ np.asarray(v, dtype=float)


def jsbsim_vector(v) -> np.ndarray:
    return PAPER_FROM_JSBSIM.T @ np.asarray(v, dtype=float)


# --------------------------------------------------------------------------
# The manoeuvre
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Manoeuvre:
    """`truth/data/s5_manoeuvre.json`: per control, segments [t_start, t_end, degrees];
    a deflection is the sum of the segments covering t (end-exclusive)."""

    duration: float
    change_at: float
    segments: dict  # name -> list of (start ns, end ns, rad)
    source: Path = MANOEUVRE  # the file it was read from

    @classmethod
    def load(cls, path: Path = MANOEUVRE) -> "Manoeuvre":
        data = json.loads(Path(path).read_text())
        segments = {
            name: [(_ns(a), _ns(b), math.radians(deg)) for a, b, deg in data["controls"][name]]
            for name in DEFLECTION_NAMES
        }
        return cls(float(data["duration"]), float(data["change_at"]), segments, Path(path))

    @classmethod
    def named(cls, name: str) -> "Manoeuvre":
        """The manoeuvre `name` of `MANOEUVRES`."""
        if name not in MANOEUVRES:
            raise ValueError(f"unknown manoeuvre {name!r}; expected one of {', '.join(MANOEUVRES)}")
        return cls.load(MANOEUVRES[name])

    def deflections(self, t: float) -> np.ndarray:
        """The three deflections (rad) at t (s); t is compared in integer ns."""
        ns = _ns(t)
        return np.array([sum(d for a, b, d in self.segments[name] if a <= ns < b) for name in DEFLECTION_NAMES])

    def deflection_table(self, times: np.ndarray) -> np.ndarray:
        """`deflections` at each of `times` (s), shape (n, 3)."""
        ns = np.round(np.asarray(times) * 1e9).astype(np.int64)
        table = np.zeros((len(ns), 3))
        for i, name in enumerate(DEFLECTION_NAMES):
            for a, b, d in self.segments[name]:
                table[(ns >= a) & (ns < b), i] += d
        return table

    def coefficients(self, t: float) -> np.ndarray:
        """Table 1's values before `change_at`, Table 2's from it on."""
        return COEFFICIENTS_AFTER if _ns(t) >= _ns(self.change_at) else COEFFICIENTS_BEFORE


def _ns(t: float) -> int:
    return int(round(t * 1e9))


def _shown(path: Path) -> str:
    """A file's path as a log names it: from the repository's root where it is inside."""
    path = Path(path).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


# --------------------------------------------------------------------------
# JSBSim
# --------------------------------------------------------------------------


def load_missile(
    dt: float = SAMPLE_TIME / SUBSTEPS, integrators: dict | None = None, planet: Path | None = None
) -> jsbsim.FGFDMExec:
    """A JSBSim executive with missile.xml loaded from this folder (nothing is installed
    into JSBSim's own tree), its step `dt` and `integrators`; `planet`, a JSBSim
    `<planet>` file, replaces its WGS84 Earth (the cross-check uses one)."""
    jsbsim.FGJSBBase().debug_lvl = 0  # no banner
    fdm = jsbsim.FGFDMExec(None)
    fdm.set_debug_level(0)
    if planet is not None and not fdm.load_planet(str(planet), False):
        raise RuntimeError(f"JSBSim could not load the planet {planet}")
    fdm.set_aircraft_path(str(HERE))
    if not fdm.load_model("missile", False):
        raise RuntimeError(f"JSBSim could not load {HERE / 'missile.xml'}")
    fdm.set_dt(dt)
    for name, kind in (INTEGRATORS if integrators is None else integrators).items():
        fdm[f"simulation/integrator/{name}"] = kind
    return fdm


def set_start(
    fdm: jsbsim.FGFDMExec, start: dict = START, latitude: float = LATITUDE_DEG, longitude: float = LONGITUDE_DEG
) -> None:
    """The initial conditions of a start in paper axes (see START)."""
    u, v, w = jsbsim_vector(start["V"])
    p, q, r = jsbsim_vector(start["omega"])
    phi, theta, psi = jsbsim_attitude(*start["attitude"])
    for name, value in [
        ("ic/lat-geod-deg", latitude),
        ("ic/long-gc-deg", longitude),
        ("ic/h-sl-ft", start["h"] / FT),
        ("ic/phi-rad", phi),
        ("ic/theta-rad", theta),
        ("ic/psi-true-rad", psi),
        ("ic/u-fps", u / FT),
        ("ic/v-fps", v / FT),
        ("ic/w-fps", w / FT),
        ("ic/p-rad_sec", p),
        ("ic/q-rad_sec", q),
        ("ic/r-rad_sec", r),
    ]:
        fdm[name] = value


def set_inputs(fdm: jsbsim.FGFDMExec, coefficients: np.ndarray, deflections: np.ndarray) -> None:
    for name, c in zip(COEFFICIENT_NAMES, coefficients):
        fdm[f"missile/{name}"] = float(c)
    for name, d in zip(DEFLECTION_NAMES, deflections):
        fdm[f"missile/{name}-rad"] = float(d)


@dataclass
class Sample:
    """What JSBSim says of one instant, in paper axes and SI units."""

    state: np.ndarray  # the 10 motion states, STATE_NAMES
    measurement: np.ndarray  # the 12 noise-free measurements, MEASUREMENT_NAMES
    force: np.ndarray  # aerodynamic force (X, Y, Z), N
    qbar: float  # dynamic pressure, Pa
    rho: float  # density, kg/m³
    inertial_rates: np.ndarray  # (ωx, ωy, ωz) relative to the inertial frame, rad/s
    gravity: float  # JSBSim's gravity magnitude there, m/s²


def read_sample(fdm: jsbsim.FGFDMExec) -> Sample:
    """The state JSBSim has after `run_ic()` or `run()`: its forces, α, β are of that state."""
    V = paper_vector([fdm["velocities/u-fps"], fdm["velocities/v-fps"], fdm["velocities/w-fps"]]) * FT
    omega = paper_vector([fdm["velocities/p-rad_sec"], fdm["velocities/q-rad_sec"], fdm["velocities/r-rad_sec"]])
    omega_i = paper_vector([fdm["velocities/pi-rad_sec"], fdm["velocities/qi-rad_sec"], fdm["velocities/ri-rad_sec"]])
    attitude = paper_attitude(fdm["attitude/phi-rad"], fdm["attitude/theta-rad"], fdm["attitude/psi-rad"])
    h = fdm["position/h-sl-meters"]
    force = paper_vector([fdm["forces/fbx-aero-lbs"], fdm["forces/fby-aero-lbs"], fdm["forces/fbz-aero-lbs"]]) * LBF
    state = np.array([*V, *attitude, h, *omega])
    overload = force / (MASS * GRAVITY)
    measurement = np.array([*omega, *overload, *attitude, h, fdm["aero/alpha-rad"], fdm["aero/beta-rad"]])
    return Sample(
        state,
        measurement,
        force,
        fdm["aero/qbar-psf"] * LBF / FT**2,
        fdm["atmosphere/rho-slugs_ft3"] * SLUG / FT**3,
        omega_i,
        fdm["accelerations/gravity-ft_sec2"] * FT,
    )


def restart_orders(integrators: dict) -> list[dict]:
    """The rate integrators to use for the steps after a jump of the derivatives.

    The deflections are piecewise constant and the coefficients change at once, so the
    accelerations jump there; JSBSim's Adams–Bashforth methods extrapolate the derivative
    history across the jump, an error of order dt at each jump (first-order convergence
    overall, measured). As a multistep method is started, the rates' integrators restart
    after a jump: rectangular Euler on the first step (the only derivative is the new
    one), then AB2, AB3, and the chosen method (history of only post-jump derivatives).
    The attitude and position integrate rates and velocities, which are continuous."""
    rates = {name: kind for name, kind in integrators.items() if name.startswith("rate/")}
    if not rates or any(kind not in (3, 4, 5) for kind in rates.values()):
        return []  # not Adams–Bashforth: nothing to restart
    return [{name: min(order, kind) for name, kind in rates.items()} for order in (1, 3, 4)] + [rates]


# --------------------------------------------------------------------------
# The run
# --------------------------------------------------------------------------

Estimator = Callable[[float, np.ndarray, np.ndarray], dict]


@dataclass
class Run:
    """A flight, one row per 5 ms sample (t = k·5 ms, k = 0…n)."""

    time: np.ndarray
    measurements: np.ndarray  # (n, 12) with noise: what the estimator was fed
    clean: np.ndarray  # (n, 12) noise-free
    states: np.ndarray  # (n, 10) motion states, paper axes
    coefficients: np.ndarray  # (n, 10) in force
    deflections: np.ndarray  # (n, 3) rad
    forces: np.ndarray  # (n, 3) N, paper axes
    qbar: np.ndarray  # Pa
    rho: np.ndarray  # kg/m³
    inertial_rates: np.ndarray  # (n, 3)
    gravity: np.ndarray  # m/s²
    estimates: list[str] = field(default_factory=list)  # the estimator's output names
    estimate: np.ndarray | None = None  # (n, len(estimates))
    metadata: dict = field(default_factory=dict)
    steps_per_second: float = 0.0  # JSBSim steps per second of wall-clock time, driver included


def fly(
    duration: float | None = None,
    seed: int = 1,
    estimator: Estimator | None = None,
    log: Path | None = None,
    *,
    start: dict = START,
    manoeuvre: Manoeuvre | None = None,
    substeps: int = SUBSTEPS,
    integrators: dict | None = None,
    latitude: float = LATITUDE_DEG,
    longitude: float = LONGITUDE_DEG,
    restart: bool = True,
    planet: Path | None = None,
) -> Run:
    """Flies the manoeuvre (its 20 s unless `duration`) from `start`, the coefficients
    changing at its `change_at`; every 5 ms forms the measurements, adds seeded white
    noise (NOISE_STD), calls `estimator(t, measurements, deflections)` if given, and
    returns the run (also logged to `log` if given).

    Timing: before the JSBSim step that ends at t the deflections and coefficients of t
    are set, so the forces JSBSim reports at t (and the derivatives it integrates from
    t) are those of t; the step integrates from the derivatives of the previous instant.
    A deflection or coefficient change at t thus acts from t on, as the manoeuvre's
    end-exclusive segments say."""
    manoeuvre = Manoeuvre.load() if manoeuvre is None else manoeuvre
    duration = manoeuvre.duration if duration is None else duration
    dt = SAMPLE_TIME / substeps
    integrators = INTEGRATORS if integrators is None else integrators
    fdm = load_missile(dt, integrators, planet)
    set_start(fdm, start, latitude, longitude)
    rng = np.random.default_rng(seed)

    n = int(round(duration / SAMPLE_TIME)) + 1
    rows: dict[str, list] = {k: [] for k in ("z", "clean", "x", "c", "d", "f", "qbar", "rho", "wi", "g", "e")}
    names: list[str] = []
    steps = 0

    def sample(k: int, c: np.ndarray, d: np.ndarray) -> None:
        t = k * SAMPLE_TIME
        s = read_sample(fdm)
        if not np.all(np.isfinite(s.state)):
            raise FloatingPointError(f"JSBSim's state is not finite at t = {t:.3f} s: {s.state}")
        z = s.measurement + rng.standard_normal(12) * NOISE_STD
        for key, value in [("z", z), ("clean", s.measurement), ("x", s.state), ("c", c), ("d", d), ("f", s.force)]:
            rows[key].append(value)
        rows["qbar"].append(s.qbar)
        rows["rho"].append(s.rho)
        rows["wi"].append(s.inertial_rates)
        rows["g"].append(s.gravity)
        if estimator is not None:
            out = estimator(t, z.copy(), d.copy())
            if not names:
                names.extend(out)
            elif list(out) != names:
                raise ValueError(f"the estimator's outputs changed at t = {t}: {list(out)} after {names}")
            rows["e"].append([float(out[name]) for name in names])

    # The rate integrators' order after a jump of the inputs (see `restart_orders`).
    ramp = restart_orders(integrators) if restart else []
    since_jump = 0

    clock = wallclock.perf_counter()
    c, d = manoeuvre.coefficients(0.0), manoeuvre.deflections(0.0)
    set_inputs(fdm, c, d)
    fdm.run_ic()  # its derivative history is that of t = 0 repeated: a jump too
    sample(0, c, d)
    # The inputs at the end of every JSBSim step, and where they change.
    step_times = np.arange((n - 1) * substeps + 1) * dt
    deflections = manoeuvre.deflection_table(step_times)
    after = np.round(step_times * 1e9) >= _ns(manoeuvre.change_at)
    jumps = np.r_[False, np.any(np.diff(deflections, axis=0) != 0, axis=1) | (np.diff(after) != 0)]
    for k in range(1, n):
        for j in range(1, substeps + 1):
            step = (k - 1) * substeps + j
            t = step_times[step]
            if since_jump < len(ramp):
                for name, kind in ramp[since_jump].items():
                    fdm[f"simulation/integrator/{name}"] = kind
            since_jump += 1
            if jumps[step]:
                c, d = (COEFFICIENTS_AFTER if after[step] else COEFFICIENTS_BEFORE), deflections[step]
                set_inputs(fdm, c, d)
                since_jump = 0  # the derivatives of this step's end jump
            if not fdm.run():
                raise RuntimeError(f"JSBSim stopped at t = {t:.4f} s")
            steps += 1
        sample(k, c, d)
    elapsed = wallclock.perf_counter() - clock

    run = Run(
        time=np.arange(n) * SAMPLE_TIME,
        measurements=np.array(rows["z"]),
        clean=np.array(rows["clean"]),
        states=np.array(rows["x"]),
        coefficients=np.array(rows["c"]),
        deflections=np.array(rows["d"]),
        forces=np.array(rows["f"]),
        qbar=np.array(rows["qbar"]),
        rho=np.array(rows["rho"]),
        inertial_rates=np.array(rows["wi"]),
        gravity=np.array(rows["g"]),
        estimates=names,
        estimate=np.array(rows["e"]) if estimator is not None else None,
        steps_per_second=steps / elapsed if elapsed > 0 else float("inf"),
    )
    parameters = {
        "sample_time": SAMPLE_TIME,
        "jsbsim_dt": dt,
        "jsbsim_integrators": integrators,
        "jsbsim_restart_after_jumps": restart,
        "planet": "WGS84 (JSBSim's default)" if planet is None else str(planet),
        "latitude_deg": latitude,
        "longitude_deg": longitude,
        "duration": duration,
        "change_at": manoeuvre.change_at,
        "noise_std": dict(zip(MEASUREMENT_NAMES, NOISE_STD.tolist())),
        "start": {k: list(v) if isinstance(v, tuple) else v for k, v in start.items()},
        "overload_g": GRAVITY,
        "mass": MASS,
    }
    run.metadata = {
        "study": "S5",
        "case": "jsbsim",
        "seed": str(seed),
        "filter": getattr(estimator, "name", type(estimator).__name__) if estimator is not None else "none",
        **({"fmu": estimator.fmu} if getattr(estimator, "fmu", None) else {}),
        **({"fmu_start_values": json.dumps(estimator.start_values)} if getattr(estimator, "start_values", None) else {}),
        "parameters": json.dumps(parameters),
        "software": f"JSBSim {jsbsim.__version__} (PyPI jsbsim); kalfmu truth/s5_jsbsim/fly.py",
        "truth": "JSBSim, truth/s5_jsbsim/missile.xml: WGS84 rotating Earth with J2 gravity, US 1976 atmosphere",
        "manoeuvre": _shown(manoeuvre.source),
        "manoeuvre_name": next((n for n, f in MANOEUVRES.items() if f.resolve() == Path(manoeuvre.source).resolve()), ""),
        "driver": "truth/s5_jsbsim/fly.py: every 5 ms the estimator gets the measurements and deflections of t",
    }
    if log is not None:
        write_log(log, run)
    return run


# --------------------------------------------------------------------------
# The log
# --------------------------------------------------------------------------

#: Noise-free measurements logged on /truth besides the states (the other seven
#: measurements are states of the same name, and equal to them).
TRUTH_MEASUREMENTS = ["Nx", "Ny", "Nz", "alpha", "beta"]


def _signal(name: str, what: str | None = None) -> Signal:
    if name.endswith("_std") and name[:-4] in UNITS:
        return Signal(name, UNITS[name[:-4]], f"standard deviation of {name[:-4]}")
    if name in COEFFICIENT_NAMES:
        return Signal(name, "1", what or f"force coefficient {name} (eq. (4))")
    return Signal(name, UNITS.get(name, "1"), what or DESCRIPTIONS.get(name, name))


def write_log(path: Path, run: Run) -> None:
    """/measurements (the 12 with noise, and the deflections), /truth (the 10 motion
    states, the 10 coefficients in force, the noise-free Nx Ny Nz α β), /estimate (the
    estimator's outputs, if any), metadata `kalfmu`."""
    index = [MEASUREMENT_NAMES.index(name) for name in TRUTH_MEASUREMENTS]
    with KalfmuLog(Path(path), run.metadata) as log:
        log.add_channel(
            "/measurements",
            [_signal(n, f"measured {DESCRIPTIONS[n]}") for n in MEASUREMENT_NAMES]
            + [_signal(n) for n in DEFLECTION_NAMES],
        )
        log.add_channel(
            "/truth",
            [_signal(n, f"true {DESCRIPTIONS[n]}") for n in STATE_NAMES]
            + [_signal(n, f"true {n} (in force)") for n in COEFFICIENT_NAMES]
            + [_signal(n, f"true {DESCRIPTIONS[n]} (noise-free)") for n in TRUTH_MEASUREMENTS],
        )
        if run.estimate is not None:
            log.add_channel("/estimate", [_signal(n) for n in run.estimates])
        for k, t in enumerate(run.time):
            log.write("/measurements", t, [*run.measurements[k], *run.deflections[k]])
            log.write("/truth", t, [*run.states[k], *run.coefficients[k], *run.clean[k, index]])
            if run.estimate is not None:
                log.write("/estimate", t, run.estimate[k])


# --------------------------------------------------------------------------
# The FMU as an estimator
# --------------------------------------------------------------------------


class FmuEstimator:
    """An estimator FMU (FMI 2.0 Co-Simulation, e.g. `kalfmu_s5_missile`) as the
    callable `fly` wants, driven by fmpy as a master drives it: at each sample t set the
    inputs of t, read every Real output (the estimate given the measurements up to t),
    then `fmi2DoStep(t, 5 ms)`.

    `inputs` maps each FMU input to one of our signals (MEASUREMENT_NAMES and
    DEFLECTION_NAMES); by default each of ours feeds the input of the same name, the
    estimator model's names (`Missile6Dof::MEASUREMENT_NAMES`), which the S5 FMU uses.
    `parameters` (start values by name) are set before
    initialisation ends, each by its variable's type: a Real by fmi2SetReal, an Integer or
    an Enumeration (the filter) by fmi2SetInteger, which must be integral, a Boolean by
    fmi2SetBoolean, 0 or 1; `start_values` is what the FMU reports of them afterwards.

    `name` (the run's metadata `filter`) is the filter kind the FMU runs, read back after
    initialisation from its `filter` parameter and named by the item of its enumeration
    type in the model description, spelt as our own runs spell it ("SVD-CKF" for the item
    SVD_CKF); `fmu` (metadata `fmu`) is the FMU's model identifier. An FMU without an
    enumeration `filter` is named by its model identifier."""

    def __init__(self, fmu: Path, parameters: dict | None = None, inputs: dict[str, str] | None = None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.path = Path(fmu)
        md = read_model_description(str(fmu))
        variables = {v.name: v for v in md.modelVariables}
        ours = MEASUREMENT_NAMES + DEFLECTION_NAMES
        inputs = inputs or {name: name for name in ours}
        missing = [n for n in inputs if n not in variables or variables[n].causality != "input"]
        if missing:
            raise ValueError(f"{fmu}: no input named {missing}")
        unknown = [s for s in inputs.values() if s not in ours]
        if unknown:
            raise ValueError(f"no signal named {unknown} (we have {ours})")
        parameters = parameters or {}
        # Checked before anything is instantiated, so that a misspelt name costs no run.
        typed = [(variables.get(n), _typed(fmu, variables.get(n), n, value)) for n, value in parameters.items()]
        self._inputs = [variables[n].valueReference for n in inputs]
        self._sources = [ours.index(s) for s in inputs.values()]
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        self._outputs = [variables[n].valueReference for n in self.outputs]
        self.fmu = md.coSimulation.modelIdentifier
        self.name = self.fmu
        self._unzipped = extract(str(fmu))
        self._fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self._unzipped,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="s5",
        )
        self._fmu.instantiate()
        self._fmu.setupExperiment(startTime=0.0)
        self._fmu.enterInitializationMode()
        for variable, value in typed:
            {"Real": self._fmu.setReal, "Integer": self._fmu.setInteger, "Boolean": self._fmu.setBoolean}[
                _setter(variable)
            ]([variable.valueReference], [value])
        self._fmu.exitInitializationMode()
        self.start_values = {variable.name: self._read(variable) for variable, _ in typed}
        self.name = self._filter_kind(variables.get("filter")) or self.fmu

    def _read(self, variable) -> float:
        """The value the FMU reports of `variable`, as a number."""
        get = {"Real": self._fmu.getReal, "Integer": self._fmu.getInteger, "Boolean": self._fmu.getBoolean}
        return float(get[_setter(variable)]([variable.valueReference])[0])

    def _filter_kind(self, variable) -> str | None:
        """The name of the filter kind the FMU runs: the item of the `filter` enumeration
        with the value the FMU reports, None if it has no such enumeration. FMI item names
        are identifiers (SVD_CKF); our filters' names have a hyphen (SVD-CKF,
        `FilterKind::name`), hence `_` to `-`."""
        if variable is None or variable.type != "Enumeration" or variable.declaredType is None:
            return None
        value = self._fmu.getInteger([variable.valueReference])[0]
        items = {int(item.value): item.name for item in variable.declaredType.items}
        if value not in items:
            raise ValueError(f"{self.path}: filter = {value}, not an item of {variable.declaredType.name} {items}")
        return items[value].replace("_", "-")

    def __call__(self, t: float, measurements: np.ndarray, deflections: np.ndarray) -> dict:
        signals = [*map(float, measurements), *map(float, deflections)]
        self._fmu.setReal(self._inputs, [signals[i] for i in self._sources])
        values = self._fmu.getReal(self._outputs)
        self._fmu.doStep(currentCommunicationPoint=t, communicationStepSize=SAMPLE_TIME)
        return dict(zip(self.outputs, values))

    def close(self) -> None:
        import shutil

        self._fmu.terminate()
        self._fmu.freeInstance()
        shutil.rmtree(self._unzipped, ignore_errors=True)


def _setter(variable) -> str:
    """Which fmi2Set/Get call a variable's type takes: Real, Integer (Enumerations too) or
    Boolean."""
    return "Integer" if variable.type == "Enumeration" else variable.type


def _typed(fmu: Path, variable, name: str, value: float):
    """`value` as the parameter `variable` (named `name`, None if the FMU has none) takes
    it; a ValueError says what is wrong, as the Rust master says it."""
    if variable is None or variable.causality != "parameter":
        raise ValueError(f"{fmu}: no parameter named {name}")
    kind = _setter(variable)
    if kind == "Real":
        return float(value)
    if kind == "Integer":
        if not float(value).is_integer():
            raise ValueError(f"start value {name}: {value} is not an Integer, which the parameter is")
        return int(value)
    if kind == "Boolean":
        if float(value) not in (0.0, 1.0):
            raise ValueError(f"start value {name}: a Boolean is 0 or 1, got {value}")
        return bool(value)
    raise ValueError(f"start value {name}: {variable.type} parameters are not taken")


#: The SSV namespace (SSP 1.0, SystemStructureParameterValues), as kalfmu-tune writes it.
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"


def read_ssv(path: Path) -> dict[str, float]:
    """The start values of an SSP parameter-value file (`ssv:ParameterSet`, as
    `start_values::ssv` writes it): each `ssv:Parameter`'s name with the value of its
    `ssv:Real`, `ssv:Integer` or `ssv:Boolean` (true/false as 1/0), in order."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    if root.tag != f"{SSV}ParameterSet":
        raise ValueError(f"{path}: not an SSV file (its root is {root.tag}, not ssv:ParameterSet)")
    values = {}
    for parameter in root.iter(f"{SSV}Parameter"):
        name = parameter.get("name")
        for kind in ("Real", "Integer", "Boolean"):
            typed = parameter.find(f"{SSV}{kind}")
            if typed is not None:
                text = typed.get("value")
                values[name] = float({"true": 1, "false": 0}.get(text, text)) if kind == "Boolean" else float(text)
                break
        else:
            raise ValueError(f"{path}: parameter {name} is not a Real, Integer or Boolean")
    return values


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="JSBSim flies S5's missile; logs the run in the kalfmu MCAP format.")
    parser.add_argument("out", type=Path, help="the MCAP log to write")
    parser.add_argument("--seed", type=int, default=1, help="the measurement noise's seed")
    parser.add_argument("--duration", type=float, help="seconds (default: the manoeuvre's 20 s)")
    parser.add_argument(
        "--manoeuvre", choices=list(MANOEUVRES), default="standard", help="the manoeuvre flown (default: standard)"
    )
    parser.add_argument("--fmu", type=Path, help="an estimator FMU to drive (e.g. kalfmu_s5_missile.fmu)")
    parser.add_argument(
        "--values",
        action="append",
        default=[],
        type=Path,
        metavar="FILE.ssv",
        help="FMU start values from an SSP parameter-value file (repeatable; applied before --set)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="an FMU parameter, set before initialisation ends (repeatable; e.g. filter=3)",
    )
    args = parser.parse_args(argv)
    parameters = {}
    for file in args.values:
        parameters.update(read_ssv(file))
    for item in args.set:
        name, _, value = item.partition("=")
        if not name or not value:
            parser.error(f"--set {item}: expected NAME=VALUE")
        try:
            parameters[name] = float(value)
        except ValueError:
            parser.error(f"--set {item}: {value!r} is not a number")
    if parameters and not args.fmu:
        parser.error("--set and --values give an FMU's start values: name the FMU with --fmu")
    estimator = FmuEstimator(args.fmu, parameters) if args.fmu else None
    try:
        run = fly(args.duration, args.seed, estimator, args.out, manoeuvre=Manoeuvre.named(args.manoeuvre))
    finally:
        if estimator is not None:
            estimator.close()
    print(
        f"wrote {args.out}: {len(run.time)} samples over {run.time[-1]:.3f} s, "
        f"JSBSim at {run.steps_per_second:,.0f} steps/s (driver included)"
    )


if __name__ == "__main__":
    main()
