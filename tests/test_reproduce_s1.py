"""`kalfmu reproduce --study s1 --quick`: S1's table through the packaged FMU, read from
the `table.json` it writes beside its logs.

- Every filter runs on every case (stiffness and damping nonlinearity, random and
  harmonic load), none fails, and the paper's SRCKF figures sit beside ours.
- Every filter's load correlates with the truth at least as well as the project's goal
  (0.998 with the stiffness nonlinearity, 0.999 with the damping one).
- Read right after the step, the estimate is the prediction of t + dt from the
  measurements up to t: it correlates worse than the estimate that has the
  measurement of its own instant.
- Each run is logged and each case compared (JSON and recording).
- Beside the paper's cases, the table has a case the set-up was not made for (`--quick`
  runs one; the full run all six of `truth::s1::Case::UNSEEN` at 1 %, 2 % and 5 % noise),
  marked as unpublished, without paper figures, run by the SRCKF, logged and compared, with
  a finite correlation and its σ figures.
- Start values given with `--set` are printed in the header and written in the settings,
  and they change the runs.
- Beside its accuracy, each filter's σ of the load is checked by the analyzer's figures,
  which the table carries as the comparison has them: the 1σ and 2σ coverage of F, its
  mean (e/σ)² with its reading, and the run's NIS/rows with its reading. F's ±2σ holds at
  least 90 % of its errors for every filter (0.944 to 0.958 in the quick run).
"""

from __future__ import annotations

import json
import math
import re
import subprocess

import pytest

FILTERS = ["CKF", "SRCKF", "SVD-CKF", "UKF", "EKF"]
CASES = ["stiffness/random", "damping/random", "stiffness/harmonic", "damping/harmonic"]
# The paper's SRCKF figures (Gong et al. 2024): correlation, running-RMSE peak and the
# bound after the start (N); it gives no bound for the harmonic loads.
PAPER = {
    "stiffness/random": {"correlation": 0.997, "running_rmse_peak": 17.553, "running_rmse_max_converged": 2.052},
    "damping/random": {"correlation": 0.999, "running_rmse_peak": 1.258, "running_rmse_max_converged": 0.033},
    "stiffness/harmonic": {"correlation": 0.997, "running_rmse_peak": 0.866, "running_rmse_max_converged": None},
    "damping/harmonic": {"correlation": 0.999, "running_rmse_peak": 0.234, "running_rmse_max_converged": None},
}
CORRELATION_GOAL = {"stiffness": 0.998, "damping": 0.999}
READINGS = {"consistent", "too wide", "too narrow"}


UNSEEN_LOADS = {"band20", "steps", "chirp"}


def reproduce(kalfmu_bin, fmu_dir, out, *extra: str) -> subprocess.CompletedProcess:
    """`kalfmu reproduce --study s1 --quick` into OUT, with EXTRA arguments."""
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s1", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(out), *extra],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc


@pytest.fixture(scope="module")
def reproduced(kalfmu_bin, fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    reproduce(kalfmu_bin, fmu_dir, out)
    return out, json.loads((out / "s1" / "table.json").read_text())


def filters(table: dict) -> dict[tuple[str, str], dict]:
    """Every (case, filter) entry of the paper's cases."""
    return {(c["case"], f["filter"]): f for c in table["cases"] if c["published"] for f in c["filters"]}


def unseen(table: dict) -> list[dict]:
    """The cases the set-up was not made for."""
    return [c for c in table["cases"] if not c["published"]]


def comparison_of(out, case: dict):
    """The comparison JSON of a table's case: `<case>.json`, or for an unseen case
    `unseen/<case>_noise<percent>.json`."""
    stem = case["case"].replace("/", "_")
    if not case["published"]:
        stem = f"unseen/{stem}_noise{100 * case['noise_fraction']:.1f}".replace(".", "p")
    return json.loads((out / "s1" / f"{stem}.json").read_text())


def test_the_table_has_every_filter_on_every_case_beside_the_papers_figures(reproduced):
    _, table = reproduced
    assert table["study"] == "S1"
    # --quick: 10 s of signal at the paper's 200 Hz.
    assert table["settings"]["duration"] == 10.0 and table["settings"]["rate"] == 200.0
    assert table["units"]["rmse_converged"] == "N" and table["units"]["convergence_time"] == "s"
    assert [c["case"] for c in table["cases"] if c["published"]] == CASES
    assert table["settings"]["quick"] is True and table["settings"]["start_values"] == {}
    for case in [c for c in table["cases"] if c["published"]]:
        assert case["failure"] is None, case
        assert case["noise_fraction"] == table["settings"]["noise_fraction"]
        assert case["paper"] == PAPER[case["case"]]
        assert [f["filter"] for f in case["filters"]] == FILTERS
        for f in case["filters"]:
            assert f["failure"] is None, (case["case"], f)
            ours = f["feedthrough"]
            assert ours["rmse_converged"] > 0 and ours["running_rmse_peak"] >= ours["running_rmse_max_converged"]
            low, high = ours["psd_agreement_band"]
            assert 0 < low < high


def test_every_filter_reaches_the_correlation_goal(reproduced):
    _, table = reproduced
    for (case, kind), f in filters(table).items():
        goal = CORRELATION_GOAL[case.split("/")[0]]
        assert goal <= f["feedthrough"]["correlation"] <= 1.0, (case, kind, f["feedthrough"])


def test_the_prediction_after_the_step_correlates_worse_than_the_estimate_of_its_instant(reproduced):
    _, table = reproduced
    for (case, kind), f in filters(table).items():
        feedthrough, after_step = f["feedthrough"], f["after_step"]
        assert 0.99 < after_step["correlation"] < feedthrough["correlation"], (case, kind, f)
        assert after_step["rmse_converged"] > feedthrough["rmse_converged"], (case, kind, f)


def test_each_run_is_logged_and_each_case_compared(reproduced):
    out, _ = reproduced
    for case in CASES:
        stem = case.replace("/", "_")
        for name in FILTERS:
            assert (out / "s1" / f"{stem}_{name.lower().replace('-', '')}.mcap").is_file()
        comparison = json.loads((out / "s1" / f"{stem}.json").read_text())
        assert comparison["labels"] == FILTERS
        assert (out / "s1" / f"{stem}.rrd").stat().st_size > 0


def assert_reading_of_its_interval(value: float, interval: list[float], reading: str, where) -> None:
    """`reading` is what `value` says against the 95 % interval of an honest σ."""
    assert reading in READINGS, where
    low, high = interval
    expected = "too wide" if value < low else "too narrow" if value > high else "consistent"
    assert reading == expected, (where, value, interval, reading)


def test_every_filter_has_the_sigma_figures_of_the_load_and_of_its_innovations(reproduced):
    _, table = reproduced
    for (case, kind), f in filters(table).items():
        ours, where = f["feedthrough"], (case, kind)
        one, two = ours["one_sigma_coverage"], ours["two_sigma_coverage"]
        assert 0.0 <= one <= two <= 1.0, (where, one, two)
        normalised = ours["normalised_error"]
        assert normalised["mean_square"] > 0, where
        assert_reading_of_its_interval(
            normalised["mean_square"], normalised["interval"], normalised["reading"], where
        )
        nis = f["nis"]
        assert nis["ratio"] > 0 and nis["rows_used_mean"] > 0, (where, nis)
        assert_reading_of_its_interval(nis["ratio"], nis["interval"], nis["reading"], where)


def test_the_two_sigma_band_of_the_load_holds_at_least_ninety_percent_of_its_errors(reproduced):
    _, table = reproduced
    coverage = {key: f["feedthrough"]["two_sigma_coverage"] for key, f in filters(table).items()}
    assert all(c >= 0.9 for c in coverage.values()), coverage


def test_the_sigma_figures_are_the_comparisons(reproduced):
    out, table = reproduced
    for case in table["cases"]:
        comparison = comparison_of(out, case)
        for f, run in zip(case["filters"], comparison["runs"], strict=True):
            (load,) = [p for p in run["pairs"] if p["truth"] == "F"]
            for field in ["one_sigma_coverage", "two_sigma_coverage", "normalised_error"]:
                assert f["feedthrough"][field] == load[field], (case["case"], f["filter"], field)
            assert f["nis"] == run["nis"], (case["case"], f["filter"])


def test_quick_adds_one_unseen_case_without_paper_figures_run_by_the_srckf(reproduced):
    out, table = reproduced
    (case,) = unseen(table)
    chain, load = case["case"].split("/")
    assert chain in CORRELATION_GOAL and load in UNSEEN_LOADS, case["case"]
    assert case["paper"] is None and case["failure"] is None, case
    assert case["noise_fraction"] == table["settings"]["noise_fraction"]
    assert [f["filter"] for f in case["filters"]] == ["SRCKF"]
    stem = f"{case['case'].replace('/', '_')}_noise2p0"
    assert (out / "s1" / "unseen" / f"{stem}_srckf.mcap").is_file()
    assert (out / "s1" / "unseen" / f"{stem}.rrd").stat().st_size > 0
    assert comparison_of(out, case)["labels"] == ["SRCKF"]


def test_the_unseen_case_has_a_finite_correlation_and_its_sigma_figures(reproduced):
    _, table = reproduced
    for case in unseen(table):
        (f,) = case["filters"]
        ours, where = f["feedthrough"], case["case"]
        assert f["failure"] is None and math.isfinite(ours["correlation"]), (where, f)
        assert -1.0 <= ours["correlation"] <= 1.0 and ours["rmse_converged"] > 0, (where, ours)
        assert math.isfinite(f["after_step"]["correlation"]), where
        one, two = ours["one_sigma_coverage"], ours["two_sigma_coverage"]
        assert 0.0 <= one <= two <= 1.0, (where, one, two)
        normalised = ours["normalised_error"]
        assert normalised["mean_square"] > 0, where
        assert_reading_of_its_interval(normalised["mean_square"], normalised["interval"], normalised["reading"], where)
        nis = f["nis"]
        assert nis["ratio"] > 0 and nis["rows_used_mean"] > 0, (where, nis)
        assert_reading_of_its_interval(nis["ratio"], nis["interval"], nis["reading"], where)


def test_the_unseen_case_is_printed_apart_with_blank_paper_columns(kalfmu_bin, fmu_dir, tmp_path):
    proc = reproduce(kalfmu_bin, fmu_dir, tmp_path)
    lines = proc.stdout.splitlines()
    block = next(i for i, line in enumerate(lines) if line.startswith("unseen cases"))
    header, row = lines[block + 1], lines[block + 2]
    assert header.startswith("unseen case, noise")
    assert row.split()[:3] == ["stiffness/band20", "2%", "SRCKF"], row
    # The three paper columns are blank, not zero, where a paper's case has its figures.
    paper_row = next(line for line in lines if line.startswith("stiffness/random") and " SRCKF " in line)
    spans = [(m.start(), m.end()) for m in re.finditer("paper", header)]
    main_header = next(line for line in lines if line.startswith("case "))
    assert len(spans) == 3 and spans == [(m.start(), m.end()) for m in re.finditer("paper", main_header)]
    for start, end in spans:
        assert row[start:end].strip() == "", (row, start)
        assert paper_row[start - 2 : end].strip() not in {"", "0.000"}, (paper_row, start)


def test_start_values_are_printed_written_and_change_the_runs(kalfmu_bin, fmu_dir, reproduced, tmp_path):
    _, default = reproduced
    proc = reproduce(kalfmu_bin, fmu_dir, tmp_path, "--set", "load_noise_intensity=3e6")
    assert "start values, over the study's in every FMU run: load_noise_intensity=3e6" in proc.stdout
    table = json.loads((tmp_path / "s1" / "table.json").read_text())
    assert table["settings"]["start_values"] == {"load_noise_intensity": 3e6}
    # Each run, the unseen case's too, has the value: its figures move.
    moved = [c["filters"][0]["feedthrough"]["rmse_converged"] for c in table["cases"]]
    before = [c["filters"][0]["feedthrough"]["rmse_converged"] for c in default["cases"]]
    assert len(moved) == len(before) and all(a != b for a, b in zip(moved, before)), (moved, before)


def test_the_tuning_command_writes_a_log_with_its_whole_log_smoothed_estimates(reproduced, analyzer_bin, tmp_path):
    """`kalfmu-tune LOG --evaluate --smoothed-log OUT` on an FMU run's log: the filtered
    estimates it writes on /estimate are the FMU's (the same figures against the truth, to
    the last digit, for every state), and its /smoothed, each sample given the whole log,
    is compared with them by the analyzer like a second run, with a smaller load RMSE."""
    from conftest import build_release_binary

    out, _ = reproduced
    log = out / "s1" / "stiffness_random_srckf.mcap"
    smoothed_log = tmp_path / "smoothed.mcap"
    tune = build_release_binary("kalfmu-tune")
    proc = subprocess.run(
        [str(tune), str(log), "--evaluate", "--smoothed-log", str(smoothed_log)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"wrote {smoothed_log}: 2001 samples" in proc.stdout

    def report(path, *topics):
        json_path = tmp_path / f"{path.stem}_{len(topics)}.json"
        args = [a for t in topics for a in ("--estimate-topic", t)]
        done = subprocess.run(
            [str(analyzer_bin), "report", str(path), *args, "--json", str(json_path)], capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr
        return json.loads(json_path.read_text())

    fmu = report(log)["runs"][0]
    both = report(smoothed_log, "/estimate", "/smoothed")
    assert both["labels"] == ["SRCKF", "SRCKF smoothed"]
    filtered, smoothed = both["runs"]
    fmu_pairs = {p["truth"]: p for p in fmu["pairs"]}
    for pair in filtered["pairs"]:
        for figure in ["rmse", "correlation"]:
            assert pair[figure] == fmu_pairs[pair["truth"]][figure], (pair["truth"], figure)
    (filtered_load,) = [p for p in filtered["pairs"] if p["truth"] == "F"]
    (smoothed_load,) = [p for p in smoothed["pairs"] if p["truth"] == "F"]
    assert smoothed_load["rmse"] < 0.9 * filtered_load["rmse"]


def test_the_smoothing_lag_is_reproduces_own(kalfmu_bin, fmu_dir, tmp_path):
    """The smoothed figures are printed for the lag reproduce sets: a --set of it is
    refused before any run, naming it, rather than printed under the wrong lag."""
    proc = subprocess.run(
        [str(kalfmu_bin), "reproduce", "--study", "s1", "--quick", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path),
         "--set", "smoothing_lag=0.2"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode != 0
    assert "smoothing_lag = 0.2" in proc.stderr and "0.1 s" in proc.stderr, proc.stderr
    assert not (tmp_path / "s1").exists(), "nothing ran"
