"""JSBSim's flight against the equations of docs/studies/s5.md (flat non-rotating Earth,
g = 9.8 m/s², ISA), integrated here by RK4 from the same start through the same
manoeuvre: how far the two truths of S5 part, and why.

    python truth/s5_jsbsim/crosscheck.py

prints the largest difference over the flight of V, α, β, the rates, the attitude and h,
for four pairs:

1. JSBSim as `fly` runs it (WGS84 rotating Earth, J2 gravity, US 1976 atmosphere)
   against the doc's equations: the mismatch between the two truths;
2. the same JSBSim flight against the doc's equations with JSBSim's atmosphere (the ISA
   law at the geopotential altitude of h, as US 1976 has it, where the doc's ρ(h) takes
   h as geopotential) and JSBSim's gravity at the start;
3. JSBSim on a still (non-rotating) WGS84 Earth against 2: the Earth's rotation removed;
4. JSBSim on a nearly flat still planet (radius 1000× the Earth's, g = 9.8 m/s² at
   10 km, no J2) against the doc's equations with JSBSim's atmosphere: what is left is
   integration error, which validates missile.xml and the axis conversions.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import fly

# The airframe and moment model of the doc (paper axes).
AREA, LENGTH = 1.6771, 3.85
INERTIA = (150.0, 1210.0, 1210.0)
MX_D, MX_W = -0.01, -0.05
MY_B, MY_D, MY_W = -0.275, 0.10, -0.7
MZ_A, MZ_D, MZ_W = -0.275, 0.389, -0.7
EARTH_RADIUS = 6_356_766.0  # m, US 1976's radius for geopotential altitude


def isa_density(h: float) -> float:
    """The doc's ISA ([ISO2533]; estimator/src/models/atmosphere.rs) at h taken as
    geopotential altitude, to 20 km and the lapse of the next layer beyond."""
    if h < 11_000.0:
        t = 288.15 - 0.0065 * h
        p = 101_325.0 * (t / 288.15) ** 5.25588
    elif h < 20_000.0:
        t = 216.65
        p = 22_632.06 * math.exp(-9.80665 / 287.053 / t * (h - 11_000.0))
    else:
        t = 216.65 + 0.001 * (h - 20_000.0)
        p = 5_474.889 * (216.65 / t) ** 34.1632
    return p / (287.053 * t)


def us76_density(h: float) -> float:
    """US 1976 (JSBSim's) at the geometric altitude h: the same law at the geopotential
    altitude h·R/(R + h)."""
    return isa_density(h * EARTH_RADIUS / (EARTH_RADIUS + h))


def derivative(x, c, d, g: float, density) -> list[float]:
    """docs/studies/s5.md's equations: x = (Vx, Vy, Vz, φ, ψ, γ, h, ωx, ωy, ωz)."""
    vx, vy, vz, phi, _psi, gamma, h, wx, wy, wz = x
    v = math.sqrt(vx * vx + vy * vy + vz * vz)
    alpha, beta = math.atan2(-vy, vx), math.asin(vz / v)
    q = 0.5 * density(h) * v * v
    qs, qsl, lv = q * AREA, q * AREA * LENGTH, LENGTH / v
    fx = qs * (c[0] + c[1] * alpha + c[2] * beta + c[3] * d[0])
    fy = qs * (c[4] + c[5] * alpha + c[6] * d[1])
    fz = qs * (c[7] + c[8] * beta + c[9] * d[2])
    mx = qsl * (MX_D * d[0] + MX_W * wx * lv)
    my = qsl * (MY_B * beta + MY_D * d[2] + MY_W * wy * lv)
    mz = qsl * (MZ_A * alpha + MZ_D * d[1] + MZ_W * wz * lv)
    ix, iy, iz = INERTIA
    m = fly.MASS
    sp, cp = math.sin(phi), math.cos(phi)
    sg, cg = math.sin(gamma), math.cos(gamma)
    yaw_pitch = wy * cg - wz * sg
    return [
        wz * vy - wy * vz - g * sp + fx / m,
        wx * vz - wz * vx - g * cp * cg + fy / m,
        wy * vx - wx * vy + g * cp * sg + fz / m,
        wy * sg + wz * cg,
        yaw_pitch / cp,
        wx - yaw_pitch * math.tan(phi),
        vx * sp + vy * cp * cg - vz * cp * sg,
        ((iy - iz) * wy * wz + mx) / ix,
        ((iz - ix) * wz * wx + my) / iy,
        ((ix - iy) * wx * wy + mz) / iz,
    ]


@dataclass
class Flight:
    time: np.ndarray
    states: np.ndarray  # (n, 10)


def integrate(
    duration: float | None = None,
    *,
    g: float = 9.8,
    density=isa_density,
    start: dict = fly.START,
    manoeuvre: fly.Manoeuvre | None = None,
    substeps: int = 2,
) -> Flight:
    """RK4 of the doc's equations, `substeps` steps per 5 ms sample; the deflections and
    coefficients are those of each step's start (every switch of the manoeuvre is on the
    5 ms grid, so RK4 keeps its order)."""
    manoeuvre = fly.Manoeuvre.load() if manoeuvre is None else manoeuvre
    duration = manoeuvre.duration if duration is None else duration
    n = int(round(duration / fly.SAMPLE_TIME)) + 1
    h = fly.SAMPLE_TIME / substeps
    x = [*start["V"], *start["attitude"], start["h"], *start["omega"]]
    rows = [x]
    for k in range(1, n):
        for j in range(substeps):
            t = (k - 1) * fly.SAMPLE_TIME + j * h
            c, d = manoeuvre.coefficients(t).tolist(), manoeuvre.deflections(t).tolist()
            k1 = derivative(x, c, d, g, density)
            k2 = derivative([a + 0.5 * h * b for a, b in zip(x, k1)], c, d, g, density)
            k3 = derivative([a + 0.5 * h * b for a, b in zip(x, k2)], c, d, g, density)
            k4 = derivative([a + h * b for a, b in zip(x, k3)], c, d, g, density)
            x = [a + h / 6 * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
        rows.append(x)
    return Flight(np.arange(n) * fly.SAMPLE_TIME, np.array(rows))


def quantities(states: np.ndarray) -> dict[str, np.ndarray]:
    """V, α, β, rates, attitude, h of motion states (paper axes)."""
    v = np.linalg.norm(states[:, :3], axis=1)
    return {
        "V": v,
        "alpha": np.arctan2(-states[:, 1], states[:, 0]),
        "beta": np.arcsin(states[:, 2] / v),
        "omega_x": states[:, 7],
        "omega_y": states[:, 8],
        "omega_z": states[:, 9],
        "phi": states[:, 3],
        "psi": states[:, 4],
        "gamma": states[:, 5],
        "h": states[:, 6],
    }


UNIT = {"V": "m/s", "h": "m", "alpha": "deg", "beta": "deg", "phi": "deg", "psi": "deg", "gamma": "deg"}
UNIT.update({f"omega_{a}": "deg/s" for a in "xyz"})


def max_differences(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """The largest |a − b| over the flight per quantity, angles and rates in degrees."""
    qa, qb = quantities(a), quantities(b)
    out = {}
    for name in qa:
        diff = qa[name] - qb[name]
        if name == "psi":
            diff = (diff + math.pi) % (2 * math.pi) - math.pi
        scale = 1.0 if name in ("V", "h") else 180 / math.pi
        out[name] = float(np.max(np.abs(diff)) * scale)
    return out


def planet_file(directory: Path, name: str) -> Path:
    """`still`: WGS84 without rotation; `flat`: a still sphere 1000× the Earth's radius,
    no J2, its gravity 9.8 m/s² at 10 km (its curvature and gravity gradient 1000× and
    10⁶× smaller than the Earth's)."""
    if name == "still":
        body = '<rotation_rate unit="RAD/SEC"> 0 </rotation_rate>'
    elif name == "flat":
        radius = 6.371e9
        body = (
            f'<semimajor_axis unit="M"> {radius} </semimajor_axis>'
            f'<semiminor_axis unit="M"> {radius} </semiminor_axis>'
            '<rotation_rate unit="RAD/SEC"> 0 </rotation_rate>'
            f'<GM unit="M3/SEC2"> {9.8 * (radius + fly.START["h"]) ** 2!r} </GM>'
            "<J2> 0 </J2>"
        )
    else:
        raise ValueError(name)
    path = directory / f"{name}.xml"
    path.write_text(f'<?xml version="1.0"?>\n<planet name="{name}">{body}</planet>\n')
    return path


def table(duration: float | None = None) -> list[tuple[str, dict[str, float]]]:
    """The four comparisons of the module's docstring."""
    with tempfile.TemporaryDirectory() as tmp:
        jsb = fly.fly(duration)
        still = fly.fly(duration, planet=planet_file(Path(tmp), "still"))
        flat = fly.fly(duration, planet=planet_file(Path(tmp), "flat"))
    doc = integrate(duration)
    g0 = float(jsb.gravity[0])
    air_g = integrate(duration, g=g0, density=us76_density)
    doc_jsb_air = integrate(duration, density=us76_density)
    return [
        ("JSBSim (WGS84, rotating) vs doc equations", max_differences(jsb.states, doc.states)),
        (f"JSBSim (WGS84, rotating) vs doc with US76 air, g={g0:.4f}", max_differences(jsb.states, air_g.states)),
        (f"JSBSim (WGS84, still) vs doc with US76 air, g={g0:.4f}", max_differences(still.states, air_g.states)),
        ("JSBSim (flat, still, g=9.8) vs doc with US76 air", max_differences(flat.states, doc_jsb_air.states)),
    ]


def main() -> None:
    rows = table()
    names = list(rows[0][1])
    print("largest difference over 20 s (angles in deg, rates in deg/s)")
    print(f"{'':58s}" + "".join(f"{n:>10s}" for n in names))
    print(f"{'':58s}" + "".join(f"{'[' + UNIT[n] + ']':>10s}" for n in names))
    for label, diffs in rows:
        print(f"{label:58s}" + "".join(f"{diffs[n]:10.4g}" for n in names))


if __name__ == "__main__":
    main()
