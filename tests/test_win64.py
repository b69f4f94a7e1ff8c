"""Every FMU's win64 binary, run on Windows' ABI under wine, against its linux64 binary.

One small FMI 2.0 master of our own (`win64/master.c`, the importer's side only) is
compiled twice from the same source: with gcc for Linux and with mingw-w64 for Windows.
Each FMU is driven by the same script through both builds: the linux64 `.so` natively,
the win64 `.dll` under wine. What is specified here:

- every FMU packs `binaries/linux64/<id>.so` and `binaries/win64/<id>.dll` beside one
  modelDescription;
- the two binaries give the same statuses and the same outputs, bit for bit, on the same
  inputs: every estimator under every filter kind (its inputs those of the behavioural
  tests, `test_fmu.case`), every plant at its defaults, each through an FMU state saved,
  serialised, deserialised and restored mid-run (which replays the same outputs), and a
  step that fails with fmi2Discard, at the same step on both (S5's CKF told sensors a
  thousand times better than they are, as in `test_fmu_s5.py`). They can because every
  elementary function is computed by Rust code (`estimator::math`), not by the platform's
  C library, which rounds `exp`, `sin`, `cbrt` … differently on each.

Wine 8 lacks `ProcessPrng`, which Rust's standard library imports on Windows: the stub
`win64/bcryptprimitives.c` (why, beside it) is built and put beside the Windows master.
"""

from __future__ import annotations

import os
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description

from conftest import FMUS, PLANT_FMUS, packaged
from test_fmu import case, read_s5_table, s1_table  # noqa: F401 (case and s1_table: fixtures)

HERE = Path(__file__).parent / "win64"
STEPS = 160  # communication steps per run
SAVED_AT, REPLAYED = 80, 12  # the FMU state is taken after SAVED_AT steps; REPLAYED steps are run twice


def bits(x: float) -> str:
    return f"{np.float64(x).view(np.uint64):016x}"


@pytest.fixture(scope="session")
def masters(tmp_path_factory) -> tuple[Path, Path]:
    """The master built for Linux and for Windows, the latter beside the ProcessPrng stub."""
    out = tmp_path_factory.mktemp("masters")
    linux, windows = out / "master", out / "master.exe"
    subprocess.run(["gcc", "-O1", "-Wall", "-Werror", "-o", str(linux), str(HERE / "master.c"), "-ldl"], check=True)
    mingw = "x86_64-w64-mingw32-gcc"
    subprocess.run([mingw, "-O1", "-Wall", "-Werror", "-o", str(windows), str(HERE / "master.c")], check=True)
    stub = [mingw, "-shared", "-O1", "-Wall", "-Werror", "-o", str(out / "bcryptprimitives.dll")]
    subprocess.run(stub + [str(HERE / "bcryptprimitives.c"), "-ladvapi32"], check=True)
    return linux, windows


@pytest.fixture(scope="session")
def wine_environment(tmp_path_factory) -> dict[str, str]:
    """A wine prefix of the test session's own, the stub preferred to wine's DLL."""
    prefix = tmp_path_factory.mktemp("wineprefix")
    env = dict(os.environ, WINEPREFIX=str(prefix), WINEDEBUG="-all", WINEDLLOVERRIDES="bcryptprimitives=n,b")
    subprocess.run(["wineboot", "--init"], env=env, check=True, capture_output=True, timeout=300)
    return env


def run_both(fmu: Path, script: str, masters, wine_environment, directory: Path) -> tuple[str, str]:
    """Runs `script` on the FMU's linux64 binary and on its win64 binary under wine; returns
    both outputs."""
    unzipped = Path(extract(str(fmu), str(directory / "unzipped")))
    md = read_model_description(str(fmu))
    identifier = md.coSimulation.modelIdentifier
    resources = (unzipped / "resources").as_uri()
    (directory / "script.txt").write_text(script)
    linux, windows = masters
    so = unzipped / "binaries" / "linux64" / f"{identifier}.so"
    dll = unzipped / "binaries" / "win64" / f"{identifier}.dll"
    common = [md.guid, resources, str(directory / "script.txt")]
    native = subprocess.run([str(linux), str(so), *common, str(directory / "linux.txt")], capture_output=True)
    assert native.returncode == 0, native.stderr.decode()[-2000:]
    emulated = subprocess.run(
        ["wine", str(windows), str(dll), *common, str(directory / "win64.txt")],
        env=wine_environment,
        capture_output=True,
        timeout=600,
    )
    assert emulated.returncode == 0, emulated.stderr.decode()[-2000:]
    return (directory / "linux.txt").read_text(), (directory / "win64.txt").read_text()


def script_of(md, name: str, rows, setup: list[str], dt: float) -> str:
    """One instance: `setup` in initialisation mode, then a step per row of `rows` (the Real
    inputs in the model description's order), every Real output read before each step; the
    FMU state saved after SAVED_AT steps and restored after REPLAYED more, which are then run
    again."""
    inputs = [v.valueReference for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    outputs = " ".join(str(v.valueReference) for v in md.modelVariables if v.causality == "output" and v.type == "Real")
    lines = [f"instantiate {name}", f"setup {bits(0.0)}", "enter", *setup, "exit"]

    def step(k: int) -> None:
        for vr, x in zip(inputs, rows[k]):
            lines.append(f"real {vr} {bits(x)}")
        lines.append(f"get {outputs}")
        lines.append(f"step {bits(k * dt)} {bits(dt)}")

    for k in range(SAVED_AT):
        step(k)
    lines.append("save")
    for k in range(SAVED_AT, SAVED_AT + REPLAYED):
        step(k)
    lines.append("restore")
    for k in range(SAVED_AT, min(len(rows), STEPS)):
        step(k)
    lines += [f"get {outputs}", "last", "free"]
    return "\n".join(lines) + "\n"


def assert_same_and_replayed(linux: str, win64: str) -> None:
    """Both outputs are the same (`assert_agree`); in each instance's, what follows
    `restore` begins with what followed `save`, bit for bit."""
    assert_agree(linux, win64)
    for block in linux.split("instantiate ")[1:]:
        lines = block.splitlines()
        saved = next(i for i, line in enumerate(lines) if line.startswith("save"))
        restored = lines.index("restore 0")
        run = lines[saved + 1 : restored]
        assert run and lines[restored + 1 : restored + 1 + len(run)] == run, "the restored state replays the outputs"


def assert_agree(linux: str, win64: str) -> None:
    """The same calls with the same statuses and every number the same, bit for bit."""
    assert win64 == linux, first_difference(linux, win64)


def first_difference(a: str, b: str) -> str:
    for k, (x, y) in enumerate(zip(a.splitlines(), b.splitlines())):
        if x != y:
            return f"line {k + 1}: linux64 {x[:200]!r} against win64 {y[:200]!r}"
    return f"{len(a.splitlines())} lines against {len(b.splitlines())}"


@pytest.mark.parametrize("short", list(FMUS) + list(PLANT_FMUS))
def test_every_fmu_packs_both_binaries_beside_one_model_description(short, fmu_dir):
    identifier = {**FMUS, **PLANT_FMUS}[short]
    with zipfile.ZipFile(packaged(fmu_dir, identifier)) as zf:
        names = set(zf.namelist())
    assert {f"binaries/linux64/{identifier}.so", f"binaries/win64/{identifier}.dll", "modelDescription.xml"} <= names


def test_each_estimator_under_every_filter_kind_is_the_same_bit_for_bit(
    case, fmu_dir, masters, wine_environment, tmp_path
):
    md = case.model_description
    (kinds,) = [t for t in md.typeDefinitions if t.name == "FilterKind"]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    dt = float(md.defaultExperiment.stepSize)
    script = ""
    for item in kinds.items:
        setup = [f"int {vr['filter']} {item.value}"]
        setup += [f"real {vr[name]} {bits(std)}" for name, std in case.sensor.items()]
        script += script_of(md, f"filter-{item.value}", case.z, setup, dt)
    fmu = packaged(fmu_dir, md.coSimulation.modelIdentifier)
    linux, win64 = run_both(fmu, script, masters, wine_environment, tmp_path)
    assert linux.count("instantiate") == len(kinds.items) and " 0\n" in linux
    assert_same_and_replayed(linux, win64)


@pytest.mark.parametrize("short", list(PLANT_FMUS))
def test_each_plant_is_the_same_bit_for_bit(short, fmu_dir, masters, wine_environment, tmp_path):
    fmu = packaged(fmu_dir, PLANT_FMUS[short])
    md = read_model_description(str(fmu))
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    rows = np.zeros((STEPS, len(inputs)))
    linux, win64 = run_both(fmu, script_of(md, short, rows, [], float(md.defaultExperiment.stepSize)), masters, wine_environment, tmp_path)
    assert_same_and_replayed(linux, win64)


def test_a_discarded_step_is_the_same_bit_for_bit(s5_fmu, kalfmu_bin, masters, wine_environment, tmp_path):
    table_path = tmp_path / "s5.csv"
    subprocess.run([str(kalfmu_bin), "s5-export", "--duration", "2", "--out", str(table_path)], check=True)
    table = read_s5_table(table_path)
    md = read_model_description(str(s5_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outputs = " ".join(str(v.valueReference) for v in md.modelVariables if v.causality == "output" and v.type == "Real")
    inputs = [vr[n] for n in table.input_names]
    lines = ["instantiate ckf", f"setup {bits(0.0)}", "enter", f"int {vr['filter']} 1"]
    lines += [f"real {vr[name]} {bits(std / 1000)}" for name, std in table.sensor.items()]
    lines.append("exit")
    for k, row in enumerate(table.inputs):
        lines += [f"real {r} {bits(x)}" for r, x in zip(inputs, row)]
        lines += [f"get {outputs}", f"step {bits(table.time[k])} {bits(0.005)}"]
    lines += [f"get {outputs}", "last", "free"]
    linux, win64 = run_both(s5_fmu, "\n".join(lines) + "\n", masters, wine_environment, tmp_path)
    assert_agree(linux, win64)
    steps = [line for line in linux.splitlines() if line.startswith("step")]
    assert "step 2" in steps, "a step is discarded (fmi2Discard: 2)"
    assert all(s == "step skipped" for s in steps[steps.index("step 2") + 1 :]), "nothing is stepped after it"
