#!/usr/bin/env python3
"""Time our filters beside filterpy, on identical models and data, in one run.

For each model — S1 (two-mass chain, stiffness-nonlinear, n = 6, m = 2) and
study S2's wheel-rail model (Zhai's car, n = 24, m = 7, 1 kHz) — this script

1. simulates the measurements (seeded; tests/models.py),
2. times filterpy's UnscentedKalmanFilter with MerweScaledSigmaPoints(alpha=1,
   beta=0, kappa=0) — the cubature rule — per predict + update, with the model
   and RK4 step in NumPy (tests/models.py, operation for operation as the Rust),
3. times our filters through `kalfmu replay` with "repeat" (its `step_ns`:
   predict + update + storing the estimate, measured inside the binary; repeat
   sized to --seconds, the fastest of --trials runs; filterpy likewise takes
   the fastest of --filterpy-repeat runs: on a shared machine interference
   only ever adds time),
4. checks that CKF, SRCKF and UKF(1, 0, 0) reproduce filterpy's estimates
   (relative measures of tests/models.py::relative_differences <= 1e-8);
   SVD-CKF and EKF are other methods and are timed only,

and prints a table: model, filter, ns/step ours, ns/step filterpy, ratio
(filterpy / ours). Exits 1 if an estimate disagrees.

    .venv/bin/python bench/filterpy_compare.py [--bin target/release/kalfmu]

Without --bin it runs `cargo build --release --workspace` first. filterpy's
time includes the NumPy model (that is what using filterpy on this model costs);
both sides store the mean and covariance of every step.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import filterpy  # noqa: E402
import numpy as np  # noqa: E402
import scipy  # noqa: E402
from models import relative_differences, run_filterpy, run_replay, s1_spec, wheel_rail_spec  # noqa: E402

TOL = 1e-8
FILTERS = [("CKF", None, True), ("SRCKF", None, True), ("UKF", (1.0, 0.0, 0.0), True), ("SVD-CKF", None, False), ("EKF", None, False)]


def build() -> Path:
    subprocess.run(["cargo", "build", "--release", "--workspace"], cwd=ROOT, check=True)
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"], cwd=ROOT, check=True, capture_output=True, text=True
    )
    return Path(json.loads(meta.stdout)["target_directory"]) / "release" / "kalfmu"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", type=Path, help="the kalfmu binary (default: build it with cargo --release)")
    parser.add_argument("--steps", type=int, default=1000, help="samples per model (default 1000)")
    parser.add_argument("--seconds", type=float, default=1.0, help="target time of each of our timing runs (s)")
    parser.add_argument("--trials", type=int, default=5, help="timing runs of ours; the fastest is shown")
    parser.add_argument("--filterpy-repeat", type=int, default=3, help="runs of filterpy; the fastest is shown")
    args = parser.parse_args()
    binary = args.bin or build()

    print(
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; Python {platform.python_version()}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}, filterpy {filterpy.__version__}; {args.steps} steps"
    )
    rows, failed = [], False
    cases = [("S1 (n=6)", s1_spec(steps=args.steps)), ("wheel-rail (n=24)", wheel_rail_spec(steps=args.steps))]
    for label, spec in cases:
        ref_means, ref_covs, fp_seconds = run_filterpy(spec, 1.0, 0.0, 0.0, repeat=args.filterpy_repeat)
        fp_ns = fp_seconds * 1e9
        for name, ukf, compare in FILTERS:
            probe = run_replay(binary, spec, name, ukf=ukf)
            repeat = max(1, round(args.seconds * 1e9 / (probe["step_ns"] * args.steps)))
            trials = [run_replay(binary, spec, name, ukf=ukf, repeat=repeat) for _ in range(args.trials)]
            out = min(trials, key=lambda o: o["step_ns"])
            if compare:
                mean_rel, cov_rel = relative_differences(out["means"], out["covariances"], ref_means, ref_covs)
                ok = mean_rel <= TOL and cov_rel <= TOL
                failed |= not ok
                agree = f"{mean_rel:.1e} / {cov_rel:.1e}" + ("" if ok else "  FAIL")
            else:
                agree = "(other method)"
            shown = name if ukf is None else f"{name}{tuple(ukf)}"
            rows.append((label, shown, out["step_ns"], fp_ns, fp_ns / out["step_ns"], agree, repeat))

    header = ("model", "filter", "ns/step ours", "ns/step filterpy UKF(1,0,0)", "ratio", "rel. diff mean / cov", "repeat")
    table = [header] + [(m, f, f"{o:,.0f}", f"{p:,.0f}", f"{r:,.0f}x", a, str(n)) for m, f, o, p, r, a, n in rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(header))]
    for i, r in enumerate(table):
        print("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |")
        if i == 0:
            print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    if failed:
        print(f"estimates disagree with filterpy beyond {TOL}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
