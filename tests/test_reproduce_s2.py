"""`kalfmu reproduce --study s2`: the main job's S2 table, through the packaged FMU, read
from the `table.json` it writes beside its logs.

- It runs every filter on every case and gives, per wheelset, every filter's figures
  beside the paper's SRCKF figures (wheelset 1), and per filter the worst wheel.
- The FMU driven by a master gives what the same filter gives in-process on the same
  measurements, to the last bit (the "vs library" difference is 0 for every run).
- It leaves one log per run, which the analyzer reads and whose forces are those of the
  FMU at their own time stamps, and one comparison per case (JSON and recording).
- A weld's peak force is found within 5 % (the study's goal, and a check that the figure
  measures something: a filter that missed the weld would fail it).
- Beside its accuracy, each wheel's σ is checked by the analyzer's figures, which the table
  carries as the comparison has them: the 1σ and 2σ coverage of each wheel's force, its
  mean (e/σ)² with its reading (and the wheel farthest from 1), and the run's NIS/rows
  with its reading.
- Beside the paper's cases, the table has a track the set-up was not made for (`--quick`
  runs one; the full run the three of `truth::s2::cases::Scenario::UNSEEN`, each at its
  speed, at both rates), marked as unpublished, without paper figures, run by the SRCKF
  through the FMU and in-process alike, with finite correlations and its σ figures.
- Start values given with `--set` are printed and written in the settings; one the
  in-process filter has reaches it too, so the FMU still equals the library.
- Every run also has the FMU's fixed-lag smoothed forces (`smoothing_lag` 0.1 s), each
  wheel's figures and the worst wheel's beside the filtered ones; the SRCKF's smoothed
  forces correlate with the truth no worse than its filtered forces.
"""

from __future__ import annotations

import json
import math
import subprocess

import pytest

FILTERS = ["CKF", "SRCKF", "SVD-CKF", "UKF", "EKF"]
CASES = ["random", "corrugation", "weld"]
# The paper's SRCKF figures for wheelset 1: correlation, running-RMSE mean (kN) and
# variance (kN²).
PAPER = {
    "random": {"correlation": 0.988, "running_rmse_mean": 0.175, "running_rmse_variance": 0.027},
    "corrugation": {"correlation": 0.999, "running_rmse_mean": 0.142, "running_rmse_variance": 0.028},
    "weld": {"correlation": 0.969, "running_rmse_mean": 0.101, "running_rmse_variance": 0.004},
}
READINGS = {"consistent", "too wide", "too narrow"}
# The FMU's smoothing_lag in every run (s).
SMOOTHING_LAG = 0.1


UNSEEN_TRACKS = {"random/german-low", "random/german-high", "random/fra6"}


def reproduce(kalfmu_bin, fmu_dir, out, *extra: str) -> subprocess.CompletedProcess:
    """`kalfmu reproduce --study s2 --quick` into OUT, with EXTRA arguments."""
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s2", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(out), *extra],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc


@pytest.fixture(scope="module")
def reproduced(kalfmu_bin, fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    reproduce(kalfmu_bin, fmu_dir, out)
    return out, json.loads((out / "s2" / "table.json").read_text())


def runs(table: dict) -> dict[tuple[str, str], dict]:
    """Every (case, filter) run of the paper's cases."""
    return {(c["case"], f["filter"]): f for c in table["cases"] if c["published"] for f in c["filters"]}


def unseen(table: dict) -> list[dict]:
    """The tracks the set-up was not made for."""
    return [c for c in table["cases"] if not c["published"]]


def unseen_stem(case: dict) -> str:
    """Where an unseen track's logs and comparison are, under `s2/unseen/`."""
    return f"{case['case'].replace('/', '_')}_{case['speed'] * 3.6:.0f}kmh_{case['rate']:.0f}hz"


def test_the_table_has_every_wheel_of_every_filter_and_case_beside_the_paper(reproduced):
    _, table = reproduced
    assert table["study"] == "S2"
    assert table["units"]["running_rmse_mean"] == "kN" and table["units"]["running_rmse_variance"] == "kN²"
    assert [c["case"] for c in table["cases"] if c["published"]] == CASES
    assert table["settings"]["quick"] is True
    assert table["settings"]["start_values"] == {} and table["settings"]["start_values_fmu_only"] == []
    for case in [c for c in table["cases"] if c["published"]]:
        assert case["failure"] is None, case
        assert (case["speed"], case["rate"]) == (table["settings"]["speed"], table["settings"]["rate"])
        # The paper's wheelset-1 figures sit beside ours.
        assert case["paper"] == PAPER[case["case"]]
        assert [f["filter"] for f in case["filters"]] == FILTERS
    for (case, kind), run in runs(table).items():
        assert run["failure"] is None, (case, kind, run)
        assert [w["wheelset"] for w in run["wheels"]] == [1, 2, 3, 4]
        for w in run["wheels"]:
            assert -1.0 <= w["correlation"] <= 1.0, (case, kind, w)
            assert w["running_rmse_mean"] > 0 and w["running_rmse_variance"] >= 0
            assert w["rmse_over_dynamic_std"] == pytest.approx(w["rmse"] / w["dynamic_std"])
            assert 0.0 <= w["two_sigma_coverage"] <= 1.0


def test_the_worst_wheel_is_the_worst_of_the_four(reproduced):
    _, table = reproduced
    for (case, kind), run in runs(table).items():
        wheels, worst = run["wheels"], run["worst_wheel"]
        assert worst["correlation_min"] == min(w["correlation"] for w in wheels), (case, kind)
        assert worst["rmse_over_dynamic_std_max"] == max(w["rmse_over_dynamic_std"] for w in wheels), (case, kind)
        assert worst["two_sigma_coverage_min"] == min(w["two_sigma_coverage"] for w in wheels), (case, kind)
        assert worst["after_step_correlation_min"] == min(w["after_step_correlation"] for w in wheels), (case, kind)


def test_every_filter_through_the_fmu_equals_the_library_in_process_to_the_last_bit(reproduced):
    _, table = reproduced
    differences = {key: run["fmu_vs_in_process_max_abs_difference"] for key, run in runs(table).items()}
    assert differences == {(c, f): 0.0 for c in CASES for f in FILTERS}


def test_the_weld_peak_is_found_within_five_percent_by_the_srckf(reproduced):
    _, table = reproduced
    errors = [w["weld_peak_error"] for w in runs(table)[("weld", "SRCKF")]["wheels"]]
    assert len(errors) == 4 and all(abs(e) <= 5.0 for e in errors), errors
    # The other cases have no weld, and so no peak error.
    for case in ["random", "corrugation"]:
        assert {w["weld_peak_error"] for w in runs(table)[(case, "SRCKF")]["wheels"]} == {None}


def test_each_run_is_logged_and_each_case_compared(reproduced, analyzer_bin, tmp_path):
    out, _ = reproduced
    for case in CASES:
        for name in FILTERS:
            log = out / "s2" / f"{case}_{name.lower().replace('-', '')}.mcap"
            assert log.is_file(), log
        comparison = json.loads((out / "s2" / f"{case}.json").read_text())
        assert comparison["labels"] == FILTERS
        signals = {p["truth"] for p in comparison["runs"][0]["pairs"]}
        assert signals == {"F_N1", "F_N2", "F_N3", "F_N4"}
        assert (out / "s2" / f"{case}.rrd").stat().st_size > 0
    report = subprocess.run(
        [str(analyzer_bin), "report", "--json", str(tmp_path / "weld.json"), str(out / "s2" / "weld_srckf.mcap")],
        capture_output=True,
        text=True,
    )
    assert report.returncode == 0, report.stderr
    run = json.loads((tmp_path / "weld.json").read_text())["runs"][0]
    assert run["metadata"]["study"] == "S2" and run["metadata"]["filter"] == "SRCKF"
    # 2.5 s at 1 kHz: the reads at t = 0, 1 ms, …, 2.5 s.
    assert {p["samples"] for p in run["pairs"]} == {2501}


def assert_reading_of_its_interval(value: float, interval: list[float], reading: str, where) -> None:
    """`reading` is what `value` says against the 95 % interval of an honest σ."""
    assert reading in READINGS, where
    low, high = interval
    expected = "too wide" if value < low else "too narrow" if value > high else "consistent"
    assert reading == expected, (where, value, interval, reading)


def test_every_wheel_of_every_filter_has_its_sigma_figures_and_every_run_its_nis(reproduced):
    _, table = reproduced
    for (case, kind), run in runs(table).items():
        for w in run["wheels"]:
            where = (case, kind, w["wheelset"])
            assert 0.0 <= w["one_sigma_coverage"] <= w["two_sigma_coverage"] <= 1.0, where
            normalised = w["normalised_error"]
            assert normalised["mean_square"] > 0, where
            assert_reading_of_its_interval(
                normalised["mean_square"], normalised["interval"], normalised["reading"], where
            )
        nis = run["nis"]
        assert nis["ratio"] > 0 and nis["rows_used_mean"] > 0, (case, kind, nis)
        assert_reading_of_its_interval(nis["ratio"], nis["interval"], nis["reading"], (case, kind))


def test_the_worst_wheels_sigma_figures_are_the_worst_of_the_four(reproduced):
    _, table = reproduced
    for (case, kind), run in runs(table).items():
        wheels, worst = run["wheels"], run["worst_wheel"]
        assert worst["one_sigma_coverage_min"] == min(w["one_sigma_coverage"] for w in wheels), (case, kind)
        # Farthest from 1 in ratio: a σ twice too wide is as far off as one twice too narrow.
        farthest = max(wheels, key=lambda w: abs(math.log(w["normalised_error"]["mean_square"])))
        assert worst["normalised_error_worst_wheelset"] == farthest["wheelset"], (case, kind)
        assert worst["normalised_error_worst"] == farthest["normalised_error"], (case, kind)


def test_the_sigma_figures_are_the_comparisons(reproduced):
    out, table = reproduced
    for case in table["cases"]:
        stem = case["case"] if case["published"] else f"unseen/{unseen_stem(case)}"
        comparison = json.loads((out / "s2" / f"{stem}.json").read_text())
        for f, run in zip(case["filters"], comparison["runs"], strict=True):
            for w, pair in zip(f["wheels"], run["pairs"], strict=True):
                assert pair["truth"] == f"F_N{w['wheelset']}"
                for field in ["one_sigma_coverage", "two_sigma_coverage", "normalised_error"]:
                    assert w[field] == pair[field], (case["case"], f["filter"], w["wheelset"], field)
            assert f["nis"] == run["nis"], (case["case"], f["filter"])


def test_quick_adds_one_unseen_track_without_paper_figures_run_by_the_srckf(reproduced):
    out, table = reproduced
    (case,) = unseen(table)
    assert case["case"] in UNSEEN_TRACKS and case["paper"] is None and case["failure"] is None, case
    assert 40 <= case["speed"] * 3.6 <= 160 and case["rate"] in {200.0, 1000.0}, case
    assert [f["filter"] for f in case["filters"]] == ["SRCKF"]
    assert (out / "s2" / "unseen" / f"{unseen_stem(case)}_srckf.mcap").is_file()
    assert (out / "s2" / "unseen" / f"{unseen_stem(case)}.rrd").stat().st_size > 0


def test_the_unseen_track_has_finite_correlations_its_sigma_figures_and_equals_the_library(reproduced):
    _, table = reproduced
    for case in unseen(table):
        (run,) = case["filters"]
        where = case["case"]
        assert run["failure"] is None, (where, run)
        assert run["fmu_vs_in_process_max_abs_difference"] == 0.0, where
        assert isinstance(run["rejected_rows"], int) and run["rejected_rows"] >= 0, where
        assert [w["wheelset"] for w in run["wheels"]] == [1, 2, 3, 4]
        for w in run["wheels"]:
            assert math.isfinite(w["correlation"]) and -1.0 <= w["correlation"] <= 1.0, (where, w)
            assert 0.0 <= w["one_sigma_coverage"] <= w["two_sigma_coverage"] <= 1.0, (where, w)
            assert w["weld_peak_error"] is None
            n = w["normalised_error"]
            assert_reading_of_its_interval(n["mean_square"], n["interval"], n["reading"], (where, w["wheelset"]))
        assert run["worst_wheel"]["correlation_min"] == min(w["correlation"] for w in run["wheels"])
        nis = run["nis"]
        assert nis["ratio"] > 0 and nis["rows_used_mean"] > 0, (where, nis)
        assert_reading_of_its_interval(nis["ratio"], nis["interval"], nis["reading"], where)


def test_a_start_value_the_library_has_reaches_both_the_fmu_and_the_library(kalfmu_bin, fmu_dir, reproduced, tmp_path):
    _, default = reproduced
    proc = reproduce(kalfmu_bin, fmu_dir, tmp_path, "--set", "force_noise_intensity=2e12")
    assert "start values, over the study's in every FMU run and in the in-process filter: force_noise_intensity=2e12" in proc.stdout
    table = json.loads((tmp_path / "s2" / "table.json").read_text())
    assert table["settings"]["start_values"] == {"force_noise_intensity": 2e12}
    assert table["settings"]["start_values_fmu_only"] == []
    changed = {(c["case"], f["filter"]): f for c in table["cases"] for f in c["filters"]}
    before = {(c["case"], f["filter"]): f for c in default["cases"] for f in c["filters"]}
    assert changed.keys() == before.keys()
    for key, run in changed.items():
        # The runs moved, and the in-process filter moved with the FMU.
        assert run["wheels"][0]["rmse"] != before[key]["wheels"][0]["rmse"], key
        assert run["fmu_vs_in_process_max_abs_difference"] == 0.0, key


def test_every_run_has_its_smoothed_forces_and_the_srckf_s_are_no_worse_than_its_filtered(reproduced):
    _, table = reproduced
    worse = []
    for case in table["cases"]:
        for run in case["filters"]:
            where = (case["case"], run["filter"])
            wheels = run["wheels"]
            for w in wheels:
                smoothed = w["smoothed"]
                assert smoothed["lag"] == SMOOTHING_LAG, where
                assert -1.0 <= smoothed["correlation"] <= 1.0 and smoothed["rmse"] > 0, (where, w["wheelset"])
                # Over the truth's dynamic σ where the smoothed forces are: up to one lag before the end.
                assert smoothed["rmse_over_dynamic_std"] == pytest.approx(smoothed["rmse"] / w["dynamic_std"], rel=0.1)
                assert 0.0 <= smoothed["one_sigma_coverage"] <= smoothed["two_sigma_coverage"] <= 1.0, where
                # A smoother has the filter's data and more: the study's filter gets no worse.
                if run["filter"] == "SRCKF" and smoothed["correlation"] < w["correlation"] - 0.01:
                    worse.append((where, w["wheelset"], w["correlation"], smoothed["correlation"]))
            worst = run["worst_wheel"]["smoothed"]
            assert worst["correlation_min"] == min(w["smoothed"]["correlation"] for w in wheels), where
            assert worst["rmse_over_dynamic_std_max"] == max(w["smoothed"]["rmse_over_dynamic_std"] for w in wheels)
            assert worst["two_sigma_coverage_min"] == min(w["smoothed"]["two_sigma_coverage"] for w in wheels)
    assert worse == [], worse
