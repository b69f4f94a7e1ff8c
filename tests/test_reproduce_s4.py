"""`kalfmu reproduce --study s4 --quick`: S4's table through the packaged FMU, read from
the `table.json` it writes beside its logs.

- Every filter kind runs through the FMU and gives, to the last bit, what the same filter
  gives in-process on the same telegrams (position, speed, offsets, weights).
- The table has the raw average, the paper's pipeline and ours, and the paper's figures:
  ours has the smallest mean and largest speed errors and position error; every spike,
  slot slip and offset is caught, with false alarms under 0.1 % of the
  channel-telegrams.
- Each run is logged, the analyzer reads it, and the runs are compared in one recording,
  which holds ours and the study's baselines (the raw average, the paper's fused speed and
  its UKF): each baseline is a log the analyzer scores as the table does.
- Beside its accuracy, each filter's σ of speed and position is checked by the analyzer's
  figures, which the table carries as the comparison has them: their 1σ and 2σ coverage,
  mean (e/σ)² with its reading, and the run's NIS/rows with its reading.
- Every FMU run also smooths its speed and position (the FMU's fixed lag, 0.1 s = 5
  telegrams): each filter's smoothed figures are in the table, scored as ours; ours
  smoothed is printed below ours and is no worse than it.
- Beside the paper's run with the default faults, the same run with the frequent faults
  (ten times the rates), a case the settings were not chosen on: marked so, with more
  faults of every kind, ours and the paper's detections and accuracy, the FMU still equal
  to the library.
- Start values (`--set`) reach every FMU run and the in-process filter it is checked
  against; one the in-process filter does not take reaches the FMU only, and is listed.
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
    (out / "stdout.txt").write_text(proc.stdout)
    return out, json.loads((out / "s4" / "table.json").read_text())


@pytest.fixture(scope="module")
def paper_run(reproduced) -> dict:
    """The paper's test run with the default faults, the first of --quick's two cases."""
    _, table = reproduced
    cases = [(p["case"], p["profile"], p["faults"], p["tuned_on"]) for p in table["profiles"]]
    assert cases == [("paper", "paper", "default", True), ("paper_frequent", "paper", "frequent", False)]
    return table["profiles"][0]


@pytest.fixture(scope="module")
def frequent_run(reproduced) -> dict:
    """The paper's test run with the frequent faults: not tuned on."""
    _, table = reproduced
    return table["profiles"][1]


def test_the_table_has_the_papers_figures_and_every_estimator(reproduced, paper_run):
    _, table = reproduced
    assert table["study"] == "S4" and table["seed"] == 1
    assert table["settings"] == {"seed": 1, "quick": True, "start_values": {}, "start_values_fmu_only": []}
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


BASELINES = {"raw_average": ("raw_average", "raw average"), "paper_fused": ("paper_fused", "paper fused"),
             "paper_fused_ukf": ("paper_ukf", "paper UKF")}


def test_the_recording_holds_ours_and_the_baselines_whose_logs_hold_the_tables_series(
    reproduced, paper_run, analyzer_bin, tmp_path
):
    """The comparison recording shows ours (the SRCKF standing for the kinds, then its
    smoothed estimates) and the baselines the study compares it with. Each baseline is a
    log beside ours that the analyzer reads on its own: from telegram 1 (its first speed)
    on, its speed RMSE and fraction in the ETCS band are the table's figures of it, and
    only the paper's UKF has a σ."""
    out, _ = reproduced
    text = (out / "stdout.txt").read_text()
    assert "comparison recording (SRCKF, SRCKF smoothed, raw average, paper fused, paper UKF: " in text
    c = paper_run["comparison"]
    for key, (suffix, label) in BASELINES.items():
        log, report = out / "s4" / f"paper_{suffix}.mcap", tmp_path / f"{suffix}.json"
        proc = subprocess.run(
            [str(analyzer_bin), "report", str(log), "--json", str(report)], capture_output=True, text=True
        )
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.startswith(f"{label}: "), proc.stdout
        (speed,) = [p for p in json.loads(report.read_text())["runs"][0]["pairs"] if p["truth"] == "speed"]
        assert speed["samples"] == paper_run["telegrams"] - 1, key
        assert speed["rmse"] == pytest.approx(c[key]["speed"]["error"]["rms"], rel=1e-12), key
        assert speed["in_tolerance"] == pytest.approx(c[key]["in_etcs_band_fraction"], abs=1e-12), key
        assert (speed["two_sigma_coverage"] is not None) == (key == "paper_fused_ukf"), key


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


def test_every_run_has_its_smoothed_figures_and_ours_smoothed_is_no_worse(reproduced, paper_run, frequent_run):
    """Each filter's smoothed speed and position (`/smoothed`, the estimate of 0.1 s
    before the newest telegram) scored from telegram 1 to the last the lag leaves, n − 6;
    ours' (the SRCKF's) no worse than its filtered speed and position by more than 5 %,
    on both fault models."""
    out, _ = reproduced
    text = (out / "stdout.txt").read_text().splitlines()
    for run in [paper_run, frequent_run]:
        c = run["comparison"]
        raw = c["raw_average"]["speed"]["mean_abs_error"]
        for f in run["filters"]:
            s, where = f["smoothed"], (run["case"], f["filter"])
            assert s is not None and s["lag"] == 0.1 and s["telegrams"] == run["telegrams"] - 6, where
            assert s["speed"]["error"]["n"] == s["telegrams"] and 0.0 <= s["in_etcs_band_fraction"] <= 1.0, where
            assert s["mean_abs_error_reduction_from_raw"] == pytest.approx(1 - s["speed"]["mean_abs_error"] / raw)
            for signal in ["speed_sigma", "position_sigma"]:
                assert 0.0 <= s[signal]["one_sigma_coverage"] <= s[signal]["two_sigma_coverage"] <= 1.0, where
        (smoothed,) = [f["smoothed"] for f in run["filters"] if f["filter"] == run["compared_filter"]]
        filtered = c["ours"]
        for figure in ["mean_abs_error", "max_abs_error"]:
            assert smoothed["speed"][figure] <= 1.05 * filtered["speed"][figure], (run["case"], figure)
        assert smoothed["position_max_abs_error"] <= 1.05 * filtered["position_max_abs_error"], run["case"]
        assert smoothed["in_etcs_band_fraction"] >= filtered["in_etcs_band_fraction"], run["case"]
    # Printed in the speed table, right below ours.
    rows = [i for i, line in enumerate(text) if line.startswith("ours smoothed (0.1 s) ")]
    assert len(rows) == 2 and all(text[i - 1].startswith("ours ") for i in rows), rows


def detections(run: dict, detector: str) -> dict:
    """`{kind: (injected, detected)}` of a run's `paper_detection` or `our_detection`."""
    return {k["name"]: (k["injected"], k["detected"]) for k in run["comparison"][detector]["kinds"]}


def test_the_frequent_faults_are_a_case_not_tuned_on_with_more_faults_of_every_kind(paper_run, frequent_run):
    """The same run, seed and noise; only the faults come ten times as often: more of
    each kind that has a rate (the offsets, one per channel, are the same)."""
    assert frequent_run["telegrams"] == paper_run["telegrams"]
    assert frequent_run["duration"] == paper_run["duration"]
    default, frequent = detections(paper_run, "our_detection"), detections(frequent_run, "our_detection")
    assert list(frequent) == list(default)
    for kind in ["dropout", "resend", "spike", "slot slip"]:
        assert frequent[kind][0] > default[kind][0], kind
    assert frequent["offset"][0] == default["offset"][0] == 4
    # The ground truth is the same for both detectors.
    assert {k: v[0] for k, v in detections(frequent_run, "paper_detection").items()} == {
        k: v[0] for k, v in frequent.items()
    }


def test_on_the_frequent_faults_both_pipelines_are_scored_and_the_fmu_equals_the_library(frequent_run):
    differences = {f["filter"]: f["fmu_vs_in_process_max_abs_difference"] for f in frequent_run["filters"]}
    assert differences == {name: 0.0 for name in FILTERS}
    c = frequent_run["comparison"]
    for name in ESTIMATORS:
        assert 0.0 <= c[name]["in_etcs_band_fraction"] <= 1.0, name
        assert c[name]["speed"]["mean_abs_error"] > 0 and c[name]["position_max_abs_error"] > 0, name
    for detector in ["paper_detection", "our_detection"]:
        for kind, (injected, detected) in detections(frequent_run, detector).items():
            assert 0 <= detected <= injected, (detector, kind)
        d = c[detector]
        assert 0.0 <= d["false_alarm_fraction"] == d["false_alarms"] / d["channel_telegrams"] < 1.0, detector
    # Ours still beats the raw average, on speed and on position.
    assert c["ours"]["speed"]["mean_abs_error"] < c["raw_average"]["speed"]["mean_abs_error"]
    assert c["ours"]["position_max_abs_error"] < c["raw_average"]["position_max_abs_error"]
    for f in frequent_run["filters"]:
        assert f["failure"] is None and f["nis"]["ratio"] > 0, f["filter"]
        assert 0.0 <= f["speed"]["one_sigma_coverage"] <= f["speed"]["two_sigma_coverage"] <= 1.0, f["filter"]


def test_the_printed_table_marks_the_frequent_faults_and_leaves_the_papers_figures_out(reproduced):
    out, _ = reproduced
    text = (out / "stdout.txt").read_text()
    heading = next(line for line in text.splitlines() if line.startswith("paper_frequent: "))
    assert "not the paper's" in heading and "×10" in heading, heading
    paper_lines = [line for line in text.splitlines() if "the paper: mean error" in line]
    assert len(paper_lines) == 1, "the paper's figures beside its own case only"
    assert "the paper has no figures of frequent faults" in text
    assert (out / "s4" / "paper_frequent.rrd").stat().st_size > 0


def reproduce_with(kalfmu_bin, fmu_dir, out, *assignments: str) -> tuple[str, dict]:
    """`reproduce --study s4 --quick` with `--set` of each of `assignments`: its output
    and its table."""
    sets = [arg for a in assignments for arg in ("--set", a)]
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s4", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(out)]
        + sets,
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout, json.loads((out / "s4" / "table.json").read_text())


def test_start_values_reach_the_fmu_and_the_in_process_filter_alike(kalfmu_bin, fmu_dir, reproduced, tmp_path):
    """Values of the tuning (the jerk, one channel's noise): every FMU run and the
    in-process filter it is checked against take them, and stay equal to the last bit;
    ours moves with them."""
    stdout, table = reproduce_with(kalfmu_bin, fmu_dir, tmp_path, "jerk_intensity=3", "r_P_tail_left_std=0.002")
    assert table["settings"]["start_values"] == {"jerk_intensity": 3.0, "r_P_tail_left_std": 0.002}
    assert table["settings"]["start_values_fmu_only"] == []
    header = stdout.splitlines()[1]
    assert header.startswith("start values") and "jerk_intensity=" in header and "r_P_tail_left_std=" in header
    for case in table["profiles"]:
        differences = {f["filter"]: f["fmu_vs_in_process_max_abs_difference"] for f in case["filters"]}
        assert differences == {name: 0.0 for name in FILTERS}, case["case"]
    # Logged as the FMU was given them.
    from mcap.reader import make_reader

    with open(tmp_path / "s4" / "paper_srckf.mcap", "rb") as f:
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}["kalfmu"]
    parameters = json.loads(metadata["parameters"])
    assert parameters["jerk_intensity"] == 3.0 and parameters["r_P_tail_left_std"] == 0.002
    assert parameters["r_P_head_left_std"] == 1.5e-3, "the other channels keep the study's"
    _, untouched = reproduced
    mean_error = lambda t: t["profiles"][0]["comparison"]["ours"]["speed"]["mean_abs_error"]  # noqa: E731
    assert mean_error(table) != mean_error(untouched)


def test_a_start_value_the_in_process_filter_does_not_have_is_the_fmus_only(kalfmu_bin, fmu_dir, tmp_path):
    """`gate_probability` (the FMU's supervisor) reaches the FMU runs, which the table
    and the `vs library` line say; the runs still succeed."""
    stdout, table = reproduce_with(kalfmu_bin, fmu_dir, tmp_path, "gate_probability=0.999999")
    assert table["settings"]["start_values_fmu_only"] == ["gate_probability"]
    vs_library = [line for line in stdout.splitlines() if line.startswith("vs library")]
    assert len(vs_library) == 2 and all("in the FMU only" in line and "gate_probability" in line for line in vs_library)
    for case in table["profiles"]:
        for f in case["filters"]:
            assert f["failure"] is None and f["fmu_vs_in_process_max_abs_difference"] >= 0.0, f["filter"]


def test_an_unknown_start_value_is_refused_before_any_run(kalfmu_bin, fmu_dir, tmp_path):
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s4", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)]
        + ["--set", "jerk_intensty=3"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode != 0 and "jerk_intensty" in proc.stderr, proc.stderr
    assert not (tmp_path / "s4" / "paper_ckf.mcap").exists(), "refused before any run"
