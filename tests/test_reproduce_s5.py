"""`kalfmu reproduce --study s5`: the paper's Tables 1 and 2 through the packaged FMU.

- Every filter runs through the FMU and gives, to the last bit, what the same filter gives
  in-process on the same measurements and deflections.
- Both tables list the ten coefficients with the paper's SVD-CKF beside each filter's
  relative error; every filter is within the paper's 3 % (the issue's goal is 1 %).
- Each filter's run is logged and the analyzer reads it.
- The second truth: JSBSim flies the missile and steps the FMU through fmpy, once per
  filter; its tables follow, every filter within 3 % there too, and each run is
  labelled by the filter the FMU ran.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

FILTERS = ["CKF", "SRCKF", "SVD-CKF", "UKF", "EKF"]
NAMES = ["Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d"]


@pytest.fixture(scope="module")
def reproduced(kalfmu_bin, fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s5", "--fmu-dir", str(fmu_dir), "--out", str(out)]
        + ["--python", sys.executable],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out, proc.stdout


def table(stdout: str, title: str) -> list[list[str]]:
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(title)) + 2
    return [line.split() for line in lines[start : start + 10]]


@pytest.mark.parametrize("title", ["Table 1", "Table 2"])
def test_both_tables_list_every_coefficient_within_three_percent_for_every_filter(reproduced, title):
    _, stdout = reproduced
    rows = table(stdout, title)
    assert [r[0] for r in rows] == NAMES
    for r in rows:
        ours = [float(v) for v in r[4:]]
        assert len(ours) == len(FILTERS) and all(abs(v) < 3.0 for v in ours), r


def test_every_filter_through_the_fmu_equals_the_library_in_process(reproduced):
    _, stdout = reproduced
    line = next(line for line in stdout.splitlines() if line.startswith("vs library"))
    values = [float(v) for v in line.split(")")[-1].split()]
    assert values == [0.0] * len(FILTERS), line


def test_jsbsim_steps_the_fmu_for_every_filter_within_three_percent(reproduced):
    _, stdout = reproduced
    second = stdout[stdout.index("truth 2: JSBSim") :]
    for title in ["Table 1", "Table 2"]:
        rows = table(second, title)
        assert [r[0] for r in rows] == NAMES
        for r in rows:
            ours = [float(v) for v in r[4:]]
            assert len(ours) == len(FILTERS) and all(abs(v) < 3.0 for v in ours), r


def test_each_filter_is_logged_and_the_analyzer_reads_it(reproduced, analyzer_bin, tmp_path):
    out, _ = reproduced
    for name in FILTERS:
        log = out / "s5" / f"6dof_{name.lower().replace('-', '')}.mcap"
        proc = subprocess.run([str(analyzer_bin), "report", str(log)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert "Cz_d" in proc.stdout
    assert (out / "s5" / "6dof.rrd").stat().st_size > 0


def test_each_jsbsim_run_is_labelled_by_the_filter_the_fmu_ran(reproduced, analyzer_bin):
    """The JSBSim driver reads the filter back from the FMU: each of its logs is
    the run of the kind reproduce asked for, as the analyzer names it."""
    out, _ = reproduced
    for name in FILTERS:
        log = out / "s5" / f"jsbsim_{name.lower().replace('-', '')}.mcap"
        proc = subprocess.run([str(analyzer_bin), "report", str(log)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.startswith(f"{name}: "), proc.stdout[:200]
