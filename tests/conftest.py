"""Shared fixtures: the release builds of the `kalfmu` and `analyzer`
binaries and of the estimator FMUs, each built once per session."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))  # `import models`


def target_dir(root: Path = ROOT) -> Path:
    """Cargo's target directory (honouring CARGO_TARGET_DIR), from `cargo metadata`."""
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=root,
        check=True,
        capture_output=True,
        text=True,
    )
    return Path(json.loads(meta.stdout)["target_directory"])


def build_release_binary(name: str, root: Path = ROOT) -> Path:
    """`cargo build --release --workspace`; returns the path of the binary NAME.

    Always the whole workspace, as the main job builds it: a single-package
    build resolves other features on shared crates (log, chrono, ...) and would
    rebuild much of the rerun tree a second time."""
    subprocess.run(["cargo", "build", "--release", "--workspace"], cwd=root, check=True)
    binary = target_dir(root) / "release" / name
    if not binary.is_file():
        raise FileNotFoundError(f"cargo build succeeded but {binary} is missing")
    return binary


def build_kalfmu(root: Path = ROOT) -> Path:
    """The release `kalfmu` binary."""
    return build_release_binary("kalfmu", root)


def build_analyzer(root: Path = ROOT) -> Path:
    """The release `analyzer` binary."""
    return build_release_binary("analyzer", root)


def build_fmus(out: Path, root: Path = ROOT) -> Path:
    """The release build, its win64 library (after it: package-fmus takes only a DLL as
    new as the linux64 library), then `package-fmus --out OUT`; returns OUT, which
    holds one `<modelIdentifier>.fmu` per estimator and per plant, for linux64 and win64."""
    packager = build_release_binary("package-fmus", root)
    windows = ["cargo", "build", "--release", "-p", "fmu", "--lib", "--target", "x86_64-pc-windows-gnu"]
    subprocess.run(windows, cwd=root, check=True)
    subprocess.run([str(packager), "--out", str(out)], cwd=root, check=True, capture_output=True, text=True)
    return out


@pytest.fixture(scope="session")
def kalfmu_bin() -> Path:
    """Path of target/release/kalfmu, built once for the whole session."""
    yield build_kalfmu()


@pytest.fixture(scope="session")
def analyzer_bin() -> Path:
    """Path of target/release/analyzer, built once for the whole session."""
    yield build_analyzer()


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    """Every FMU, estimators and plants, built and packaged once for the whole
    session into a pytest temporary directory."""
    yield build_fmus(tmp_path_factory.mktemp("fmus"))


def packaged(directory: Path, identifier: str) -> Path:
    fmu = directory / f"{identifier}.fmu"
    if not fmu.is_file():
        raise FileNotFoundError(f"package-fmus succeeded but {fmu} is missing")
    return fmu


@pytest.fixture(scope="session")
def s1_fmu(fmu_dir) -> Path:
    """Path of kalfmu_s1_load.fmu."""
    yield packaged(fmu_dir, "kalfmu_s1_load")


@pytest.fixture(scope="session")
def s2_fmu(fmu_dir) -> Path:
    """Path of kalfmu_s2_wheel_rail.fmu."""
    yield packaged(fmu_dir, "kalfmu_s2_wheel_rail")


@pytest.fixture(scope="session")
def s3_fmu(fmu_dir) -> Path:
    """Path of kalfmu_s3_wheel_rail_lr.fmu."""
    yield packaged(fmu_dir, "kalfmu_s3_wheel_rail_lr")


@pytest.fixture(scope="session")
def s4_fmu(fmu_dir) -> Path:
    """Path of kalfmu_s4_maglev.fmu."""
    yield packaged(fmu_dir, "kalfmu_s4_maglev")


@pytest.fixture(scope="session")
def s5_fmu(fmu_dir) -> Path:
    """Path of kalfmu_s5_missile.fmu."""
    yield packaged(fmu_dir, "kalfmu_s5_missile")


#: Every estimator FMU, by the short name its parametrised tests carry in their ids.
FMUS = {
    "s1": "kalfmu_s1_load",
    "s2": "kalfmu_s2_wheel_rail",
    "s3": "kalfmu_s3_wheel_rail_lr",
    "s4": "kalfmu_s4_maglev",
    "s5": "kalfmu_s5_missile",
}

#: The FMUs the generic behavioural tests (`case`) drive: each input is a
#: measurement with its `r_<input>_std` or a control (S5's deflections).
CASE_FMUS = list(FMUS)


#: Every plant FMU, by the short name its parametrised tests carry in their ids.
PLANT_FMUS = {"s1_plant": "kalfmu_s1_chain", "s2_plant": "kalfmu_s2_track", "s5_plant": "kalfmu_s5_flight"}


@pytest.fixture(scope="session", params=list(FMUS) + list(PLANT_FMUS))
def any_fmu(request, fmu_dir) -> Path:
    """Path of each FMU in turn, estimators and plants: a test using it runs once per FMU."""
    yield packaged(fmu_dir, {**FMUS, **PLANT_FMUS}[request.param])
