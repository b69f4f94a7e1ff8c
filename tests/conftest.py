"""Shared fixtures: the release build of the `scenarios` binary, built once per session."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))  # `import models`


def build_scenarios(root: Path = ROOT) -> Path:
    """`cargo build --release -p scenarios`; returns the path of the binary
    (honouring CARGO_TARGET_DIR through `cargo metadata`)."""
    subprocess.run(["cargo", "build", "--release", "-p", "scenarios"], cwd=root, check=True)
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=root,
        check=True,
        capture_output=True,
        text=True,
    )
    binary = Path(json.loads(meta.stdout)["target_directory"]) / "release" / "scenarios"
    if not binary.is_file():
        raise FileNotFoundError(f"cargo build succeeded but {binary} is missing")
    return binary


@pytest.fixture(scope="session")
def scenarios_bin() -> Path:
    """Path of target/release/scenarios, built once for the whole session."""
    yield build_scenarios()
