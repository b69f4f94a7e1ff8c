"""NumPy re-implementations of the estimation models of `estimator`, operation
for operation, so that a Python filter (filterpy) sees the same discrete model
as the Rust filters up to the last bit (or close to it).

Every formula below mirrors a Rust source file; the order of floating-point
operations is kept, because it decides the rounding:

- `PiecewiseLinear`       <- estimator/src/models/piecewise.rs
- `Oscillator2Dof*`       <- estimator/src/models/oscillator_2dof.rs
- `VerticalVehicle`, `WheelRailVertical`
                          <- estimator/src/models/wheel_rail_vertical.rs
- `Rk4Discretized`        <- estimator/src/integrate.rs (`Rk4::step`, `Discretized`)

A model offers `n`, `m`, `derivative(x)`, `observe(x)`; `Rk4Discretized`
turns it into `transition(x, dt)` (filterpy's `fx`) and `observe(x)` (`hx`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "PiecewiseLinear",
    "Oscillator2Dof",
    "Oscillator2DofLoad",
    "VerticalVehicle",
    "WheelRailVertical",
    "Rk4Discretized",
    "MODELS",
    "simulate",
    "s1_spec",
    "wheel_rail_spec",
    "run_filterpy",
    "run_replay",
    "relative_differences",
]


@dataclass(frozen=True)
class PiecewiseLinear:
    """Continuous odd law with slopes k1, k2, k3 and breakpoints 0 <= d1 <= d2."""

    slopes: tuple[float, float, float]
    breaks: tuple[float, float]

    @staticmethod
    def linear(k: float) -> "PiecewiseLinear":
        return PiecewiseLinear((k, k, k), (math.inf, math.inf))

    def force(self, b: float) -> float:
        k1, k2, k3 = self.slopes
        d1, d2 = self.breaks
        a = abs(b)
        if a <= d1:
            magnitude = k1 * a
        elif a <= d2:
            magnitude = k1 * d1 + k2 * (a - d1)
        else:
            magnitude = k1 * d1 + k2 * (d2 - d1) + k3 * (a - d2)
        return math.copysign(magnitude, b)

    def force_array(self, b: np.ndarray) -> np.ndarray:
        """`force` elementwise; the same operations per element, hence the same bits."""
        k1, k2, k3 = self.slopes
        d1, d2 = self.breaks
        a = np.abs(b)
        # Each branch is evaluated where it is selected: no inf*0 from linear laws.
        with np.errstate(invalid="ignore"):
            magnitude = np.where(
                a <= d1,
                k1 * a,
                np.where(a <= d2, k1 * d1 + k2 * (a - d1), k1 * d1 + k2 * (d2 - d1) + k3 * (a - d2)),
            )
        return np.copysign(magnitude, b)


@dataclass(frozen=True)
class Oscillator2Dof:
    """ground -(k1, c1)- m1 -(k2, c2)- m2, load F on m2."""

    m1: float
    m2: float
    k1: PiecewiseLinear
    c1: PiecewiseLinear
    k2: float
    c2: float

    @staticmethod
    def stiffness_nonlinear() -> "Oscillator2Dof":
        """Table 1: k1 piecewise (5, 20, 30 N/m; 0.1, 0.2 m)."""
        return Oscillator2Dof(
            m1=4.0,
            m2=8.0,
            k1=PiecewiseLinear((5.0, 20.0, 30.0), (0.1, 0.2)),
            c1=PiecewiseLinear.linear(5.0),
            k2=15.0,
            c2=3.0,
        )

    @staticmethod
    def damping_nonlinear() -> "Oscillator2Dof":
        """Table 2: c1 piecewise (2, 30, 40 N s/m; 0.05, 0.10 m/s)."""
        return Oscillator2Dof(
            m1=4.0,
            m2=8.0,
            k1=PiecewiseLinear.linear(10.0),
            c1=PiecewiseLinear((2.0, 30.0, 40.0), (0.05, 0.10)),
            k2=15.0,
            c2=3.0,
        )

    def accelerations(self, z1: float, z2: float, v1: float, v2: float, load: float) -> tuple[float, float]:
        coupling = self.k2 * (z2 - z1) + self.c2 * (v2 - v1)
        ground = self.k1.force(z1) + self.c1.force(v1)
        return (coupling - ground) / self.m1, (load - coupling) / self.m2


class Oscillator2DofLoad:
    """State [z1, z2, F, z1dot, z2dot, Fdot], measurements [z1ddot, z2ddot]."""

    n = 6
    m = 2

    def __init__(self, chain: Oscillator2Dof):
        self.chain = chain

    def derivative(self, x: np.ndarray) -> np.ndarray:
        a1, a2 = self.chain.accelerations(x[0], x[1], x[3], x[4], x[2])
        return np.array([x[3], x[4], x[5], a1, a2, 0.0])

    def observe(self, x: np.ndarray) -> np.ndarray:
        a1, a2 = self.chain.accelerations(x[0], x[1], x[3], x[4], x[2])
        return np.array([a1, a2])


@dataclass(frozen=True)
class VerticalVehicle:
    """The half of a four-axle vehicle on one rail, as the estimator knows it
    (masses and pitch inertias on this rail, suspension per axle box and per side)."""

    car_body_mass: float
    car_body_pitch_inertia: float
    bogie_mass: float
    bogie_pitch_inertia: float
    wheelset_mass: float
    primary_stiffness: float
    primary_damper: PiecewiseLinear
    secondary_stiffness: float
    secondary_damping: float
    half_bogie_spacing: float
    half_wheelbase: float
    static_wheel_load: float

    #: Gravity for the static wheel load (m/s²).
    G = 9.81

    @staticmethod
    def half_of(car_body, bogie, wheelset_mass, primary, secondary, half_bogie_spacing, half_wheelbase):
        """Half of a vehicle given whole; `P_st` is an eighth of its weight."""
        return VerticalVehicle(
            car_body_mass=car_body[0] / 2.0,
            car_body_pitch_inertia=car_body[1] / 2.0,
            bogie_mass=bogie[0] / 2.0,
            bogie_pitch_inertia=bogie[1] / 2.0,
            wheelset_mass=wheelset_mass / 2.0,
            primary_stiffness=primary[0],
            primary_damper=primary[1],
            secondary_stiffness=secondary[0],
            secondary_damping=secondary[1],
            half_bogie_spacing=half_bogie_spacing,
            half_wheelbase=half_wheelbase,
            static_wheel_load=(car_body[0] + 2.0 * bogie[0] + 4.0 * wheelset_mass) * VerticalVehicle.G / 8.0,
        )

    @staticmethod
    def zhai_passenger() -> "VerticalVehicle":
        """Half of Zhai's high-speed passenger car, the primary damper blowing off to a
        third of its slope beyond 0.1 m/s (P_st = 55.9 kN)."""
        damper = PiecewiseLinear((6e3, 2e3, 2e3), (0.1, 0.1))
        return VerticalVehicle.half_of((34e3, 2.277e6), (3e3, 2_710.0), 1_400.0, (0.55e6, damper), (0.4e6, 8e4), 9.0, 1.2)

    def accelerations(self, z: np.ndarray, v: np.ndarray, f_n: np.ndarray) -> np.ndarray:
        """The ten accelerations in state order; each element computed as in the Rust
        loops (bogie i at d = +l_c, -l_c; wheelset j = 2i + k at e = +l_t, -l_t)."""
        lc, lt = self.half_bogie_spacing, self.half_wheelbase
        d = np.array([lc, -lc])
        stretch = z[2:4] - z[0] - d * z[1]
        rate = v[2:4] - v[0] - d * v[1]
        f_s = self.secondary_stiffness * stretch + self.secondary_damping * rate
        bogie = np.array([0, 0, 1, 1])  # the bogie of wheelset j
        e = np.array([lt, -lt, lt, -lt])
        stretch = z[6:10] - z[2 + bogie] - e * z[4 + bogie]
        rate = v[6:10] - v[2 + bogie] - e * v[4 + bogie]
        f_p = self.primary_stiffness * stretch + self.primary_damper.force_array(rate)
        a = np.empty(10)
        a[0] = (f_s[0] + f_s[1]) / self.car_body_mass
        a[1] = (f_s[0] - f_s[1]) * lc / self.car_body_pitch_inertia
        a[2:4] = (f_p[0::2] + f_p[1::2] - f_s) / self.bogie_mass
        a[4:6] = (f_p[0::2] - f_p[1::2]) * lt / self.bogie_pitch_inertia
        a[6:10] = (-f_p - self.static_wheel_load + f_n) / self.wheelset_mass
        return a


class WheelRailVertical:
    """Study S2's estimation model, eq. (7): state [z_c, beta_c, z_t1, z_t2,
    beta_t1, beta_t2, z_w1..4, their 10 velocities, F_N1..4]; measurements the
    bounce accelerations [z_c, z_t1, z_t2, z_w1..4] (m/s², up)."""

    FORCES = 20
    MEASURED = np.array([0, 2, 3, 6, 7, 8, 9])
    n = 24
    m = 7

    def __init__(self, vehicle: VerticalVehicle):
        self.vehicle = vehicle

    def derivative(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.n)
        out[:10] = x[10:20]
        out[10:20] = self.vehicle.accelerations(x[:10], x[10:20], x[20:24])
        return out

    def observe(self, x: np.ndarray) -> np.ndarray:
        return self.vehicle.accelerations(x[:10], x[10:20], x[20:24])[self.MEASURED]


class Rk4Discretized:
    """`substeps` classical RK4 steps of dt/substeps per sample, in the operation
    order of `Rk4::step`: stages `x + 0.5*h*k`, `x + h*k3`, and
    `x + h/6*(k1 + 2*k2 + 2*k3 + k4)` (sums from the left)."""

    def __init__(self, field, substeps: int = 1):
        self.field = field
        self.substeps = max(1, int(substeps))
        self.n = field.n
        self.m = field.m

    def step(self, x: np.ndarray, h: float) -> np.ndarray:
        f = self.field.derivative
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def transition(self, x: np.ndarray, dt: float) -> np.ndarray:
        h = dt / self.substeps
        x = np.asarray(x, dtype=float)
        for _ in range(self.substeps):
            x = self.step(x, h)
        return x

    def observe(self, x: np.ndarray) -> np.ndarray:
        return self.field.observe(np.asarray(x, dtype=float))


#: Spec names of `kalfmu replay` -> NumPy model factories.
MODELS = {
    "oscillator_2dof_stiffness": lambda: Oscillator2DofLoad(Oscillator2Dof.stiffness_nonlinear()),
    "oscillator_2dof_damping": lambda: Oscillator2DofLoad(Oscillator2Dof.damping_nonlinear()),
    "wheel_rail_vertical_24": lambda: WheelRailVertical(VerticalVehicle.zhai_passenger()),
}


# --------------------------------------------------------------------------
# Harness shared by the tests and bench/filterpy_compare.py: simulated data,
# the filterpy reference run, the `kalfmu replay` run and the comparison.
# --------------------------------------------------------------------------


def _truth_step(field, x: np.ndarray, t: float, h: float, loads, slots) -> np.ndarray:
    """One RK4 step of the physical system: the force slots of the augmented
    state are set from the known loads(t) at every stage and not integrated."""

    def f(tt: float, xx: np.ndarray) -> np.ndarray:
        xx = xx.copy()
        xx[slots] = loads(tt)
        d = field.derivative(xx)
        d[slots] = 0.0
        return d

    k1 = f(t, x)
    k2 = f(t + 0.5 * h, x + 0.5 * h * k1)
    k3 = f(t + 0.5 * h, x + 0.5 * h * k2)
    k4 = f(t + h, x + h * k3)
    return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def simulate(
    model_name: str,
    steps: int,
    dt: float,
    seed: int,
    accel_sigma: float | None = None,
    missing_every: int = 0,
    noise_fraction: float | None = None,
):
    """Truth and accelerometer rows for `model_name`, the unknown forces a sum
    of sines (S1's load; for the wheel-rail model the static wheel load plus
    two sines per wheel, phases seeded); the truth integrated with 10 RK4 sub-steps
    per sample. Row k is the measurement at t = (k + 1)·dt (replay predicts,
    then updates). The noise is white, of standard deviation `accel_sigma` on
    every channel or, with `noise_fraction`, that fraction of each channel's
    RMS (as study S2 sets it). Every `missing_every`-th row (if > 0) is fully
    missing (None). Returns the truth (steps × n), the rows and the noise's
    standard deviation per channel."""
    if (accel_sigma is None) == (noise_fraction is None):
        raise ValueError("give accel_sigma or noise_fraction")
    rng = np.random.default_rng(seed)
    field = MODELS[model_name]()
    if isinstance(field, Oscillator2DofLoad):
        slots = np.array([2])

        def loads(t):
            return np.array([4.0 * math.sin(2 * math.pi * 0.4 * t) + 2.0 * math.sin(2 * math.pi * 1.3 * t + 0.5) + 1.0])

    else:
        slots = WheelRailVertical.FORCES + np.arange(4)
        static = field.vehicle.static_wheel_load
        # Per wheel (columns), a slow part (long-wavelength track geometry) and a P2-like
        # part (a dipped weld's 35-70 Hz): 34 to 78 kN in all. Wheels 1 and 2 move at up to
        # 0.18-0.21 and 0.12-0.15 m/s against their bogie (1000 samples, seeds 1, 2 and 7),
        # past the primary dampers' 0.1 m/s knee.
        amp = np.array([[2e3, -1.5e3, 1e3, 1.2e3], [20e3, -15e3, 10e3, 8e3]])
        freq = np.array([[1.5, 2.0, 2.5, 3.0], [35.0, 42.0, 58.0, 71.0]])
        phase = rng.uniform(0, 2 * math.pi, (2, 4))

        def loads(t):
            return static + (amp * np.sin(2 * math.pi * freq * t + phase)).sum(axis=0)

    x = np.zeros(field.n)
    sub = 10
    h = dt / sub
    truth, clean = [], []
    for k in range(steps):
        t0 = k * dt
        for s in range(sub):
            x = _truth_step(field, x, t0 + s * h, h, loads, slots)
        t = (k + 1) * dt
        x[slots] = loads(t)
        truth.append(x.copy())
        clean.append(field.observe(x))
    clean = np.array(clean)
    if noise_fraction is not None:
        sigma = noise_fraction * np.sqrt(np.mean(clean**2, axis=0))
    else:
        sigma = np.full(field.m, float(accel_sigma))
    z = clean + sigma * rng.standard_normal((steps, field.m))
    rows = [None if missing_every and (k + 1) % missing_every == 0 else [float(v) for v in z[k]] for k in range(steps)]
    return np.array(truth), rows, sigma


def s1_spec(steps: int = 1000, seed: int = 20240607, missing_every: int = 97) -> dict:
    """Replay spec (without "filter") for study S1, stiffness-nonlinear chain, dt = 5 ms."""
    dt, sigma = 0.005, 0.01
    _, rows, _ = simulate("oscillator_2dof_stiffness", steps, dt, seed, sigma, missing_every)
    return {
        "model": "oscillator_2dof_stiffness",
        "substeps": 1,
        "q": [1e-8, 1e-8, 1e-2, 1e-6, 1e-6, 10.0],
        "r": [[sigma**2, 0.0], [0.0, sigma**2]],
        "x0": [0.0] * 6,
        "p0": [1e-2, 1e-2, 100.0, 1e-2, 1e-2, 100.0],
        "dt": dt,
        "measurements": [r if r is not None else [None, None] for r in rows],
    }


def wheel_rail_spec(steps: int = 1000, seed: int = 7, missing_every: int = 0) -> dict:
    """Replay spec (without "filter") for study S2's 24-state wheel-rail model on
    Zhai's car at 1 kHz: the model's own response to wheel-rail forces of the
    static wheel load (55.9 kN) plus sines (34 to 78 kN), the
    accelerometer noise 2 % of each channel's RMS, and the study's noise
    (studies/src/s2/study.rs `Tuning`: motion noise 1e-8 car body and
    bogies, 1e-10 wheelsets, per sample; the forces' random walk 1e13 N²/s; R
    from the noise). The prior is at rest under the static load, as the
    study's, but with standard deviations of 1 mm (1 mrad), 1 cm/s (10 mrad/s)
    and 1 kN rather than its 1e-2 on everything: 10 cm of doubt on the
    positions makes the estimate ill-conditioned in the data (filterpy moves
    by over 10 % when the measurements move by one ulp), and no two
    implementations can agree there."""
    dt = 1e-3
    model = MODELS["wheel_rail_vertical_24"]()
    _, rows, sigma = simulate("wheel_rail_vertical_24", steps, dt, seed, missing_every=missing_every, noise_fraction=0.02)
    motion = [1e-8] * 6 + [1e-10] * 4
    return {
        "model": "wheel_rail_vertical_24",
        "substeps": 1,
        "q": motion + motion + [1e13 * dt] * 4,
        "r": [float(s) ** 2 for s in sigma],
        "x0": [0.0] * 20 + [model.vehicle.static_wheel_load] * 4,
        "p0": [1e-6] * 10 + [1e-4] * 10 + [1e6] * 4,
        "dt": dt,
        "measurements": [r if r is not None else [None] * model.m for r in rows],
    }


def _matrix(value, n: int) -> np.ndarray:
    a = np.array(value, dtype=float)
    return np.diag(a) if a.ndim == 1 else a.reshape(n, n)


def run_filterpy(spec: dict, alpha: float, beta: float, kappa: float, repeat: int = 1):
    """filterpy's UnscentedKalmanFilter with MerweScaledSigmaPoints(alpha, beta,
    kappa) on the spec's model and data: per row `predict(dt=dt)` then
    `update(z)` (`update(None)` for a fully missing row). Returns the means,
    covariances (after each update) and the seconds per predict+update of the
    fastest repetition (on a shared machine interference only ever adds time;
    the last repetition's estimates are returned)."""
    import time

    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    model = Rk4Discretized(MODELS[spec["model"]](), spec.get("substeps", 1))
    n, m, dt = model.n, model.m, spec["dt"]
    zs = [None if all(v is None for v in row) else np.array(row, dtype=float) for row in spec["measurements"]]
    if any(z is not None and np.isnan(z).any() for z in zs):
        raise ValueError("filterpy cannot use partially missing rows")
    steps = len(zs)
    means = np.empty((steps, n))
    covs = np.empty((steps, n, n))
    fastest = float("inf")
    for _ in range(repeat):
        points = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
        ukf = UnscentedKalmanFilter(dim_x=n, dim_z=m, dt=dt, hx=model.observe, fx=model.transition, points=points)
        ukf.x = np.array(spec["x0"], dtype=float)
        ukf.P = _matrix(spec["p0"], n)
        ukf.Q = _matrix(spec["q"], n)
        ukf.R = _matrix(spec["r"], m)
        start = time.perf_counter()
        for k, z in enumerate(zs):
            ukf.predict(dt=dt)
            ukf.update(z)
            means[k] = ukf.x
            covs[k] = ukf.P
        fastest = min(fastest, time.perf_counter() - start)
    return means, covs, fastest / steps


def run_replay(binary, spec: dict, filter_name: str, ukf=None, repeat: int = 1) -> dict:
    """`kalfmu replay --input spec.json --output out.json`; returns the parsed
    output with "means" and "covariances" as NumPy arrays."""
    import json
    import subprocess
    import tempfile
    from pathlib import Path

    full = dict(spec, filter=filter_name, repeat=repeat)
    if ukf is not None:
        full["ukf"] = dict(zip(("alpha", "beta", "kappa"), ukf))
    with tempfile.TemporaryDirectory() as tmp:
        spec_path, out_path = Path(tmp) / "spec.json", Path(tmp) / "out.json"
        spec_path.write_text(json.dumps(full))
        proc = subprocess.run(
            [str(binary), "replay", "--input", str(spec_path), "--output", str(out_path)],
            capture_output=True,
            text=True,
        )
        if proc.returncode != 0:
            raise RuntimeError(f"kalfmu replay failed ({proc.returncode}): {proc.stderr.strip()}")
        out = json.loads(out_path.read_text())
    out["means"] = np.array(out["means"], dtype=float)
    out["covariances"] = np.array(out["covariances"], dtype=float)
    return out


def relative_differences(means, covs, ref_means, ref_covs) -> tuple[float, float]:
    """The two agreement measures the tests bound (reference = filterpy):

    mean:        max over k, i of |x_k,i - ref_k,i| / max_k |ref_k,i|
                 (each state component on the scale it reaches over the run)
    covariance:  max over k, i, j of |P_k,ij - ref_k,ij| / sqrt(ref_k,ii * ref_k,jj)
                 (each entry on the scale of its standard deviations)
    """
    scale = np.max(np.abs(ref_means), axis=0)
    mean_rel = float(np.max(np.abs(means - ref_means) / scale))
    sd = np.sqrt(np.einsum("kii->ki", ref_covs))
    cov_rel = float(np.max(np.abs(covs - ref_covs) / (sd[:, :, None] * sd[:, None, :])))
    return mean_rel, cov_rel
