"""`kalfmu reproduce --study s4 --quick`: S4's table through the packaged FMU.

- Every filter kind runs through the FMU and gives, to the last bit, what the same filter
  gives in-process on the same telegrams (position, speed, offsets, weights).
- The table has the raw average, the paper's pipeline and ours: ours has the smallest
  mean and largest speed errors and position error; every spike, slot slip and offset
  is caught, with false alarms under 0.1 % of the channel-telegrams.
- Each run is logged, the analyzer reads it, and the runs are compared in one recording.
"""

from __future__ import annotations

import subprocess

import pytest

FILTERS = ["CKF", "SRCKF", "SVD-CKF", "UKF", "EKF"]


@pytest.fixture(scope="module")
def reproduced(kalfmu_bin, fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s4", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out, proc.stdout


def row(stdout: str, name: str) -> list[float]:
    line = next(line for line in stdout.splitlines() if line[:22].strip() == name)  # the label column
    return [float(v.rstrip("%")) for v in line[len(name) :].split() if v != "—"]


def test_every_filter_through_the_fmu_equals_the_library_in_process(reproduced):
    _, stdout = reproduced
    line = next(line for line in stdout.splitlines() if line.startswith("vs library"))
    values = {name: float(line.split(f" {name}: ")[1].split()[0]) for name in FILTERS}
    assert values == {name: 0.0 for name in FILTERS}, line


def test_ours_beats_the_raw_average_and_the_papers_pipeline(reproduced):
    _, stdout = reproduced
    raw, filtered, ours = row(stdout, "raw average"), row(stdout, "paper: fused + UKF"), row(stdout, "ours")
    # mean |e|, (vs raw), max |e|, speed range, e range, position |e| max, in band.
    assert ours[0] < filtered[0] < raw[0]
    assert ours[2] < filtered[2] < raw[1]
    assert ours[5] < raw[4]
    for kind in ["spike", "slot slip", "offset"]:
        injected, _, detected = row(stdout, kind)
        assert detected == injected, kind
    paper_false, our_false = row(stdout, "false alarms")
    assert our_false < 0.1 < paper_false


def test_each_run_is_logged_and_compared_in_one_recording(reproduced, analyzer_bin):
    out, _ = reproduced
    for name in FILTERS:
        log = out / "s4" / f"paper_{name.lower().replace('-', '')}.mcap"
        proc = subprocess.run([str(analyzer_bin), "report", str(log)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.startswith(f"{name}: ") and "speed" in proc.stdout
    assert (out / "s4" / "paper.rrd").stat().st_size > 0
