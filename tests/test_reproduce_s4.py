"""`kalfmu reproduce --study s4 --quick`: S4's table through the packaged FMU, read from
the `table.json` it writes beside its logs.

- Every filter kind runs through the FMU and gives, to the last bit, what the same filter
  gives in-process on the same telegrams (position, speed, offsets, weights).
- The table has the raw average, the paper's pipeline and ours, and the paper's figures:
  ours has the smallest mean and largest speed errors and position error; every spike,
  slot slip and offset is caught, with false alarms under 0.1 % of the
  channel-telegrams.
- Each run is logged, the analyzer reads it, and the runs are compared in one recording.
- Beside its accuracy, each filter's σ of speed and position is checked by the analyzer's
  figures, which the table carries as the comparison has them: their 1σ and 2σ coverage,
  mean (e/σ)² with its reading, and the run's NIS/rows with its reading.
"""

from __future__ import annotations

import json
import subprocess

import pytest

FILTERS = ["CKF", "SRCKF", "SVD-CKF", "UKF", "EKF"]
READINGS = {"consistent", "too wide", "too narrow"}
ESTIMATORS = ["raw_average", "paper_fused", "paper_fused_ukf", "ours"]


@pytest.fixture(scope="module")
def reproduced(kalfmu_bin, fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s4", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out, json.loads((out / "s4" / "table.json").read_text())


@pytest.fixture(scope="module")
def paper_run(reproduced) -> dict:
    """The paper's test run, the only profile with --quick."""
    _, table = reproduced
    assert [p["profile"] for p in table["profiles"]] == ["paper"]
    return table["profiles"][0]


def test_the_table_has_the_papers_figures_and_every_estimator(reproduced, paper_run):
    _, table = reproduced
    assert table["study"] == "S4" and table["seed"] == 1
    assert table["paper"] == {
        "mean_abs_error_reduction_from_raw": 0.326,
        "raw_average_speed_range": 11.09,
        "paper_fused_ukf_speed_range": 5.62,
    }
    assert table["units"]["mean_abs_error"] == "m/s" and table["units"]["position_max_abs_error"] == "m"
    assert paper_run["compared_filter"] == "SRCKF"
    comparison = paper_run["comparison"]
    for name in ESTIMATORS:
        scores = comparison[name]
        assert 0.0 <= scores["in_etcs_band_fraction"] <= 1.0, name
        # The paper's speed range is of the estimate, beside the truth's 5.6 m/s.
        assert scores["speed"]["true_range"] == pytest.approx(5.6)
    assert comparison["raw_average"]["mean_abs_error_reduction_from_raw"] == 0.0


def test_every_filter_through_the_fmu_equals_the_library_in_process(paper_run):
    differences = {f["filter"]: f["fmu_vs_in_process_max_abs_difference"] for f in paper_run["filters"]}
    assert differences == {name: 0.0 for name in FILTERS}
    assert all(f["failure"] is None for f in paper_run["filters"])


def test_ours_beats_the_raw_average_and_the_papers_pipeline(reproduced, paper_run):
    _, table = reproduced
    c = paper_run["comparison"]
    raw, filtered, ours = c["raw_average"]["speed"], c["paper_fused_ukf"]["speed"], c["ours"]["speed"]
    assert ours["mean_abs_error"] < filtered["mean_abs_error"] < raw["mean_abs_error"]
    assert ours["max_abs_error"] < filtered["max_abs_error"] < raw["max_abs_error"]
    assert c["ours"]["position_max_abs_error"] < c["raw_average"]["position_max_abs_error"]
    # Ours cuts the raw average's mean speed error by more than the paper's pipeline
    # does in the paper.
    reduction = c["ours"]["mean_abs_error_reduction_from_raw"]
    assert reduction == pytest.approx(1 - ours["mean_abs_error"] / raw["mean_abs_error"])
    assert reduction > table["paper"]["mean_abs_error_reduction_from_raw"]
    ours_detected = {k["name"]: k for k in c["our_detection"]["kinds"]}
    for kind in ["spike", "slot slip", "offset"]:
        assert ours_detected[kind]["injected"] > 0, kind
        assert ours_detected[kind]["detected"] == ours_detected[kind]["injected"], kind
    paper_false = c["paper_detection"]["false_alarm_fraction"]
    our_false = c["our_detection"]["false_alarm_fraction"]
    assert our_false < 0.001 < paper_false
    detection = c["our_detection"]
    assert our_false == detection["false_alarms"] / detection["channel_telegrams"]
    assert detection["channel_telegrams"] == 4 * paper_run["telegrams"]


def test_each_run_is_logged_and_compared_in_one_recording(reproduced, analyzer_bin):
    out, _ = reproduced
    for name in FILTERS:
        log = out / "s4" / f"paper_{name.lower().replace('-', '')}.mcap"
        proc = subprocess.run([str(analyzer_bin), "report", str(log)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.startswith(f"{name}: ") and "speed" in proc.stdout
    assert (out / "s4" / "paper.rrd").stat().st_size > 0


def assert_reading_of_its_interval(value: float, interval: list[float], reading: str, where) -> None:
    """`reading` is what `value` says against the 95 % interval of an honest σ."""
    assert reading in READINGS, where
    low, high = interval
    expected = "too wide" if value < low else "too narrow" if value > high else "consistent"
    assert reading == expected, (where, value, interval, reading)


def test_every_filter_has_the_sigma_figures_of_speed_and_position_and_its_nis(paper_run):
    assert [f["filter"] for f in paper_run["filters"]] == FILTERS
    for f in paper_run["filters"]:
        for signal in ["speed", "position"]:
            figures, where = f[signal], (f["filter"], signal)
            assert 0.0 <= figures["one_sigma_coverage"] <= figures["two_sigma_coverage"] <= 1.0, where
            normalised = figures["normalised_error"]
            assert normalised["mean_square"] > 0, where
            assert_reading_of_its_interval(
                normalised["mean_square"], normalised["interval"], normalised["reading"], where
            )
        nis = f["nis"]
        assert nis["ratio"] > 0 and nis["rows_used_mean"] > 0, (f["filter"], nis)
        assert_reading_of_its_interval(nis["ratio"], nis["interval"], nis["reading"], f["filter"])


def test_the_sigma_figures_are_the_comparisons(reproduced, paper_run):
    out, _ = reproduced
    comparison = json.loads((out / "s4" / "paper.json").read_text())
    assert comparison["labels"] == FILTERS
    for f, run in zip(paper_run["filters"], comparison["runs"], strict=True):
        for signal in ["speed", "position"]:
            (pair,) = [p for p in run["pairs"] if p["truth"] == signal]
            for field in ["one_sigma_coverage", "two_sigma_coverage", "normalised_error"]:
                assert f[signal][field] == pair[field], (f["filter"], signal, field)
        assert f["nis"] == run["nis"], f["filter"]
