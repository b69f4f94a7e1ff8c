"""`kalfmu robustness` in its short version, through the packaged FMUs: the
table of every FMU it covers, what holds of it, and `--shard K/N` splitting its
episodes. The full run (200 episodes per FMU) and what it measures are in
docs/supervisor.md.

What the short version holds to (20 seeded episodes per FMU):

* on clean data no input is flagged faulty and the filter is always healthy;
* a stuck input and a dropout are recovered from within the FMU's bound (S1);
* at least half of all episodes are recovered from within the bound, on every
  FMU (the rest are the findings the full run lists);
* two shards together run every episode once.
"""

from __future__ import annotations

import re
import subprocess

import pytest

EPISODES = 20


def robustness(kalfmu_bin, fmu_dir, *extra: str) -> str:
    out = subprocess.run(
        [str(kalfmu_bin), "robustness", "--fmu-dir", str(fmu_dir), "--episodes", str(EPISODES), *extra],
        check=True,
        capture_output=True,
        text=True,
    )
    return out.stdout


def tables(text: str) -> dict[str, dict[str, tuple[int, int]]]:
    """Per study: per fault kind, (recovered within the bound, episodes)."""
    result: dict[str, dict[str, tuple[int, int]]] = {}
    study = None
    for line in text.splitlines():
        header = re.match(r"^(S\d) \(", line)
        if header:
            study = header.group(1)
            result[study] = {}
            continue
        row = re.match(r"^  (\S+(?: \S+)?)\s+(\d+)\s+(\d+) of (\d+)", line)
        if study and row:
            result[study][row.group(1)] = (int(row.group(3)), int(row.group(4)))
    return result


@pytest.fixture(scope="module")
def whole(kalfmu_bin, fmu_dir) -> str:
    return robustness(kalfmu_bin, fmu_dir)


def test_every_fmu_has_its_table_and_its_clean_run_raises_no_alarm(whole):
    found = tables(whole)
    assert set(found) == {"S1", "S2", "S3", "S4", "S5"}, whole
    for study, rows in found.items():
        assert sum(n for _, n in rows.values()) == EPISODES, (study, rows)
    clean = re.findall(r"clean run: (\d+) samples flagged faulty, (\d+) not healthy", whole)
    assert clean == [("0", "0")] * 5, whole


def test_stuck_inputs_and_dropouts_are_recovered_from_within_the_bound(whole):
    s1 = tables(whole)["S1"]
    for kind in ("stuck", "dropout"):
        recovered, episodes = s1[kind]
        assert recovered == episodes > 0, (kind, s1)


def test_at_least_half_of_the_episodes_are_recovered_from_within_the_bound(whole):
    for study, rows in tables(whole).items():
        recovered = sum(r for r, _ in rows.values())
        assert recovered >= EPISODES // 2, (study, rows)


def test_two_shards_run_every_episode_once(kalfmu_bin, fmu_dir):
    halves = [tables(robustness(kalfmu_bin, fmu_dir, "--studies", "s1", "--shard", f"{k}/2"))["S1"] for k in (1, 2)]
    counted = {kind: sum(h.get(kind, (0, 0))[1] for h in halves) for kind in set(halves[0]) | set(halves[1])}
    whole = tables(robustness(kalfmu_bin, fmu_dir, "--studies", "s1"))["S1"]
    assert counted == {kind: n for kind, (_, n) in whole.items()}


def test_wiring_mistakes_are_named_where_the_inputs_contradict_each_other_and_make_the_filter_unhealthy_elsewhere(
    kalfmu_bin, fmu_dir
):
    """`--wiring` on S4 (four telegrams of one position: the flipped one is
    named within 2 s and no right one is blamed) and S2 (an axle box's own
    force follows it, and only its fault signature in the other inputs
    names it: every flipped input is named within 2 s, though a right one
    may be blamed too, and one whose estimate leaves its σ makes the filter
    unhealthy within 2 s)."""
    out = subprocess.run(
        [str(kalfmu_bin), "robustness", "--fmu-dir", str(fmu_dir), "--wiring", "--studies", "s2,s4"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    rows: dict[tuple[str, str], tuple[int, ...]] = {}
    study = None
    for line in out.splitlines():
        header = re.match(r"^(S\d) \(.*clean run: (\d+) samples", line)
        if header:
            study = header.group(1)
            assert header.group(2) == "0", line
            continue
        row = re.match(r"^  (\S+(?: \S+)?)\s+(\d+)\s+(\d+) of (\d+)\s+\S+(?: s)?\s+(\d+)\s+(\d+)\s+(\d+) of (\d+)", line)
        if study and row:
            rows[(study, row.group(1))] = tuple(int(g) for g in row.groups()[1:])
    runs, named, _, blamed, beyond, unhealthy, _ = rows[("S4", "flipped")]
    assert named == runs == 4 and blamed == 0, out
    runs, named, _, blamed, beyond, unhealthy, _ = rows[("S2", "flipped")]
    assert named == runs == 7 and beyond > 0 and unhealthy == beyond, out
