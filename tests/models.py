"""NumPy re-implementations of the estimation models of `estimator`, operation
for operation, so that a Python filter (filterpy) sees the same discrete model
as the Rust filters up to the last bit (or close to it).

Every formula below mirrors a Rust source file; the order of floating-point
operations is kept, because it decides the rounding:

- `PiecewiseLinear`       <- estimator/src/models/piecewise.rs
- `Oscillator2Dof*`       <- estimator/src/models/oscillator_2dof.rs
- `SpringChainForces`     <- estimator/src/models/spring_chain.rs
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
    "SpringChainForces",
    "Rk4Discretized",
    "MODELS",
    "simulate",
    "s1_spec",
    "chain_spec",
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


class SpringChainForces:
    """Ten 100 kg masses from the ground, 1e5 N/m springs, dampers 2e3 N s/m up
    to 0.1 m/s and 5e2 beyond; forces on masses 2, 4, 6, 9 (0-based); sensors
    at masses 0, 1, 3, 4, 6, 7, 9. State [z(10), zdot(10), F(4)]."""

    MASSES = 10
    FORCES = np.array([2, 4, 6, 9])
    SENSORS = np.array([0, 1, 3, 4, 6, 7, 9])
    n = 24
    m = 7

    def __init__(self) -> None:
        self.mass = 100.0
        self.stiffness = 1e5
        self.damper = PiecewiseLinear((2e3, 5e2, 5e2), (0.1, 0.1))

    def accelerations(self, x: np.ndarray) -> np.ndarray:
        k = self.MASSES
        z, v, f = x[:k], x[k : 2 * k], x[2 * k :]
        # Element i joins mass i-1 (or the ground) to mass i.
        dz = np.empty(k)
        dv = np.empty(k)
        dz[0], dv[0] = z[0], v[0]
        dz[1:] = z[1:] - z[:-1]
        dv[1:] = v[1:] - v[:-1]
        element = self.stiffness * dz + self.damper.force_array(dv)
        above = np.append(element[1:], 0.0)
        inv_mass = 1.0 / self.mass  # multiplied, as the Rust model does (no divisions in the hot loop)
        out = (above - element) * inv_mass
        out[self.FORCES] += f * inv_mass
        return out

    def derivative(self, x: np.ndarray) -> np.ndarray:
        k = self.MASSES
        out = np.zeros(self.n)
        out[:k] = x[k : 2 * k]
        out[k : 2 * k] = self.accelerations(x)
        return out

    def observe(self, x: np.ndarray) -> np.ndarray:
        return self.accelerations(x)[self.SENSORS]


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


#: Spec names of `scenarios replay` -> NumPy model factories.
MODELS = {
    "oscillator_2dof_stiffness": lambda: Oscillator2DofLoad(Oscillator2Dof.stiffness_nonlinear()),
    "oscillator_2dof_damping": lambda: Oscillator2DofLoad(Oscillator2Dof.damping_nonlinear()),
    "spring_chain_24": SpringChainForces,
}


# --------------------------------------------------------------------------
# Harness shared by the tests and bench/filterpy_compare.py: simulated data,
# the filterpy reference run, the `scenarios replay` run and the comparison.
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


def simulate(model_name: str, steps: int, dt: float, seed: int, accel_sigma: float, missing_every: int = 0):
    """Truth and accelerometer rows for `model_name`, the unknown forces a sum
    of sines; the truth integrated with 10 RK4 sub-steps per sample. Row k is
    the measurement at t = (k + 1)·dt (replay predicts, then updates). Every
    `missing_every`-th row (if > 0) is fully missing (None)."""
    rng = np.random.default_rng(seed)
    field = MODELS[model_name]()
    if isinstance(field, Oscillator2DofLoad):
        slots = np.array([2])

        def loads(t):
            return np.array([4.0 * math.sin(2 * math.pi * 0.4 * t) + 2.0 * math.sin(2 * math.pi * 1.3 * t + 0.5) + 1.0])

    else:
        slots = 2 * SpringChainForces.MASSES + np.arange(4)
        amp = np.array([800.0, -500.0, 600.0, 400.0])
        freq = np.array([1.5, 3.0, 0.7, 5.0])
        phase = rng.uniform(0, 2 * math.pi, 4)

        def loads(t):
            return amp * np.sin(2 * math.pi * freq * t + phase)

    x = np.zeros(field.n)
    sub = 10
    h = dt / sub
    truth, rows = [], []
    for k in range(steps):
        t0 = k * dt
        for s in range(sub):
            x = _truth_step(field, x, t0 + s * h, h, loads, slots)
        t = (k + 1) * dt
        x[slots] = loads(t)
        truth.append(x.copy())
        z = field.observe(x) + accel_sigma * rng.standard_normal(field.m)
        rows.append(None if missing_every and (k + 1) % missing_every == 0 else [float(v) for v in z])
    return np.array(truth), rows


def s1_spec(steps: int = 1000, seed: int = 20240607, missing_every: int = 97) -> dict:
    """Replay spec (without "filter") for study S1, stiffness-nonlinear chain, dt = 5 ms."""
    dt, sigma = 0.005, 0.01
    _, rows = simulate("oscillator_2dof_stiffness", steps, dt, seed, sigma, missing_every)
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


def chain_spec(steps: int = 1000, seed: int = 7, missing_every: int = 0) -> dict:
    """Replay spec (without "filter") for the 24-state spring chain, dt = 1 ms."""
    dt, sigma = 1e-3, 0.01
    n, m = SpringChainForces.n, SpringChainForces.m
    _, rows = simulate("spring_chain_24", steps, dt, seed, sigma, missing_every)
    return {
        "model": "spring_chain_24",
        "substeps": 1,
        # Process noise large enough that P stays well conditioned (with 1e-12 on
        # positions the filters agree only to ~1e-9, filterpy with itself too).
        "q": [1e-8] * 10 + [1e-5] * 10 + [1e3] * 4,
        "r": [sigma**2] * m,
        "x0": [0.0] * n,
        "p0": [1e-4] * 10 + [1e-2] * 10 + [1e6] * 4,
        "dt": dt,
        "measurements": [r if r is not None else [None] * m for r in rows],
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
    """`scenarios replay --input spec.json --output out.json`; returns the parsed
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
            raise RuntimeError(f"scenarios replay failed ({proc.returncode}): {proc.stderr.strip()}")
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
