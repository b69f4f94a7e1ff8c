"""The FMUs' binaries for other platforms, each run on its own ABI, against the linux64 binary.

One small FMI 2.0 master of our own (`platforms/master.c`, the importer's side only) is
compiled from the same source for each platform: with gcc for Linux on x86-64, with
mingw-w64 for Windows, with Debian's cross gcc for Linux on aarch64. Each FMU is driven by
the same script through the linux64 build natively and through the other platform's build
on its binary. What is specified here:

- every FMU packs `binaries/linux64/<id>.so` and `binaries/win64/<id>.dll` beside one
  modelDescription;
- the two binaries give the same statuses and the same outputs, bit for bit, on the same
  inputs: every estimator under every filter kind (its inputs those of the behavioural
  tests, `test_fmu.case`), every plant at its defaults, each through an FMU state saved,
  serialised, deserialised and restored mid-run (which replays the same outputs), and a
  step that fails with fmi2Discard, at the same step on both (S5's CKF told sensors a
  thousand times better than they are, as in `test_fmu_s5.py`). They can because every
  elementary function is computed by Rust code (`estimator::math`), not by the platform's
  C library, which rounds `exp`, `sin`, `cbrt` … differently on each;
- the library built for linux-aarch64 (not packed: FMI 2.0 names no platform folder for
  it) gives the same, bit for bit, as the linux64 library on its portable kernels
  (`KALFMU_PORTABLE=1`), the loops an aarch64 CPU runs; against the x86-64 default, whose
  AVX2 kernels fuse a multiply and an add into one rounding, its outputs differ by
  rounding only (`test_aarch64_and_the_avx2_kernels_differ_by_rounding_only`).

The win64 binaries run under wine. Wine 8 lacks `ProcessPrng`, which Rust's standard
library imports on Windows: the stub `platforms/bcryptprimitives.c` (why, beside it) is
built and put beside the Windows master. The aarch64 library runs under qemu-user; its
tests run only where its tool chain is (`scripts/setup --aarch64`; `scripts/check-aarch64`
runs them) and are skipped, with the reason, elsewhere.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description

from conftest import FMUS, PLANT_FMUS, ROOT, packaged, target_dir
from test_fmu import case, read_s5_table, s1_table  # noqa: F401 (case and s1_table: fixtures)

HERE = Path(__file__).parent / "platforms"
STEPS = 160  # communication steps per run
SAVED_AT, REPLAYED = 80, 12  # the FMU state is taken after SAVED_AT steps; REPLAYED steps are run twice
AARCH64 = "aarch64-unknown-linux-gnu"
AARCH64_SYSROOT = Path("/usr/aarch64-linux-gnu")  # Debian's libc6-dev-arm64-cross, for qemu-user


def bits(x: float) -> str:
    return f"{np.float64(x).view(np.uint64):016x}"


def compile_master(compiler: str, out: Path, *libraries: str) -> Path:
    flags = ["-O1", "-Wall", "-Werror"]
    subprocess.run([compiler, *flags, "-o", str(out), str(HERE / "master.c"), *libraries], check=True)
    return out


@pytest.fixture(scope="session")
def linux_master(tmp_path_factory) -> Path:
    """The master built for this machine, Linux on x86-64, which runs the linux64 binaries."""
    return compile_master("gcc", tmp_path_factory.mktemp("linux64") / "master", "-ldl")


@dataclass(frozen=True)
class Platform:
    """How to run an FMU's binary for another platform, and what it is compared with."""

    name: str
    command: list[str]  # runs the master built for the platform, its arguments to follow
    environment: dict[str, str]
    reference_environment: dict[str, str]  # of the linux64 run it must equal

    def binary(self, unzipped: Path, identifier: str) -> Path:
        if self.name == "win64":
            return unzipped / "binaries" / "win64" / f"{identifier}.dll"
        return target_dir() / AARCH64 / "release" / "libkalfmu_fmu.so"  # one library serves every FMU


@pytest.fixture(scope="session", params=["win64", "aarch64"])
def platform(request) -> Platform:
    return request.getfixturevalue(request.param)


@pytest.fixture(scope="session")
def win64(tmp_path_factory) -> Iterator[Platform]:
    """The master built by mingw-w64 beside the ProcessPrng stub, run by wine in a prefix of
    its own, the stub preferred to wine's DLL."""
    out = tmp_path_factory.mktemp("win64")
    mingw = "x86_64-w64-mingw32-gcc"
    master = compile_master(mingw, out / "master.exe")
    stub = [mingw, "-shared", "-O1", "-Wall", "-Werror", "-o", str(out / "bcryptprimitives.dll")]
    subprocess.run(stub + [str(HERE / "bcryptprimitives.c"), "-ladvapi32"], check=True)
    prefix = out / "wineprefix"
    prefix.mkdir()
    env = dict(os.environ, WINEPREFIX=str(prefix), WINEDEBUG="-all", WINEDLLOVERRIDES="bcryptprimitives=n,b")
    subprocess.run(["wineboot", "--init"], env=env, check=True, capture_output=True, timeout=300)
    # One wineserver for the whole session: by default it exits a few seconds after its last
    # client, and a wine started while it is exiting may fail before running anything (once
    # on CI: exit status 1, nothing on stderr). wineboot's own must be gone first: a second
    # server refuses to start (status 2).
    subprocess.run(["wineserver", "--wait"], env=env, check=True, timeout=60)
    subprocess.run(["wineserver", "--persistent"], env=env, check=True, timeout=60)
    yield Platform("win64", ["wine", str(master)], env, dict(os.environ))
    subprocess.run(["wineserver", "--kill"], env=env, timeout=60)


def aarch64_missing() -> list[str]:
    """What of the aarch64 tool chain this machine lacks."""
    missing = [tool for tool in ("aarch64-linux-gnu-gcc", "qemu-aarch64") if shutil.which(tool) is None]
    if not (AARCH64_SYSROOT / "lib").is_dir():
        missing.append(f"{AARCH64_SYSROOT} (libc6-dev-arm64-cross)")
    targets = subprocess.run(["rustup", "target", "list", "--installed"], cwd=ROOT, capture_output=True, text=True)
    if AARCH64 not in targets.stdout.split():
        missing.append(f"Rust's target {AARCH64}")
    return missing


@pytest.fixture(scope="session")
def aarch64(tmp_path_factory) -> Platform:
    """The library built for linux-aarch64 and the master built by the cross gcc, run by
    qemu-user; compared with the linux64 library on its portable kernels."""
    missing = aarch64_missing()
    if missing:
        reason = f"no aarch64 tool chain here ({', '.join(missing)})"
        pytest.skip(f"{reason}: bash scripts/check-aarch64 installs it and runs these tests")
    out = tmp_path_factory.mktemp("aarch64")
    build = ["cargo", "build", "--release", "-p", "fmu", "--lib", "--target", AARCH64]
    subprocess.run(build, cwd=ROOT, check=True)
    master = compile_master("aarch64-linux-gnu-gcc", out / "master", "-ldl")
    portable = dict(os.environ, KALFMU_PORTABLE="1")
    return Platform("aarch64", ["qemu-aarch64", "-L", str(AARCH64_SYSROOT), str(master)], dict(os.environ), portable)


def run_both(
    fmu: Path, script: str, linux_master: Path, platform: Platform, directory: Path, reference_environment=None
) -> tuple[str, str]:
    """Runs `script` on the FMU's linux64 binary (in the platform's reference environment
    unless another is given) and on its binary for `platform`; returns both outputs."""
    unzipped = Path(extract(str(fmu), str(directory / "unzipped")))
    md = read_model_description(str(fmu))
    identifier = md.coSimulation.modelIdentifier
    resources = (unzipped / "resources").as_uri()
    (directory / "script.txt").write_text(script)
    so = unzipped / "binaries" / "linux64" / f"{identifier}.so"
    common = [md.guid, resources, str(directory / "script.txt")]
    reference = directory / "linux64.txt"
    native = subprocess.run(
        [str(linux_master), str(so), *common, str(reference)],
        env=reference_environment or platform.reference_environment,
        capture_output=True,
    )
    assert native.returncode == 0, native.stderr.decode()[-2000:]
    other = directory / f"{platform.name}.txt"
    # Its messages go to a file, not a pipe: the processes wine starts beside the master
    # (services, the device manager) live on with the session's wineserver and would hold
    # a pipe open.
    messages = directory / f"{platform.name}.stderr"
    with messages.open("wb") as sink:
        emulated = subprocess.run(
            [*platform.command, str(platform.binary(unzipped, identifier)), *common, str(other)],
            env=platform.environment,
            stdout=sink,
            stderr=sink,
            timeout=600,
        )
    ran = other.read_text()[-500:] if other.exists() else "(no output file)"
    said = messages.read_text(errors="replace")[-2000:]
    assert emulated.returncode == 0, f"{said}\nthe master's output ended with:\n{ran}"
    return reference.read_text(), other.read_text()


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


def assert_same_and_replayed(linux: str, other: str) -> None:
    """Both outputs are the same (`assert_agree`); in each instance's, what follows
    `restore` begins with what followed `save`, bit for bit."""
    assert_agree(linux, other)
    for block in linux.split("instantiate ")[1:]:
        lines = block.splitlines()
        saved = next(i for i, line in enumerate(lines) if line.startswith("save"))
        restored = lines.index("restore 0")
        run = lines[saved + 1 : restored]
        assert run and lines[restored + 1 : restored + 1 + len(run)] == run, "the restored state replays the outputs"


def assert_agree(linux: str, other: str) -> None:
    """The same calls with the same statuses and every number the same, bit for bit."""
    assert other == linux, first_difference(linux, other)


def first_difference(a: str, b: str) -> str:
    for k, (x, y) in enumerate(zip(a.splitlines(), b.splitlines())):
        if x != y:
            return f"line {k + 1}: linux64 {x[:200]!r} against the other {y[:200]!r}"
    return f"{len(a.splitlines())} lines against {len(b.splitlines())}"


def estimator_script(case) -> str:
    """An instance per filter kind, each on the case's inputs and sensor σ."""
    md = case.model_description
    (kinds,) = [t for t in md.typeDefinitions if t.name == "FilterKind"]
    vr = {v.name: v.valueReference for v in md.modelVariables}
    dt = float(md.defaultExperiment.stepSize)
    script = ""
    for item in kinds.items:
        setup = [f"int {vr['filter']} {item.value}"]
        setup += [f"real {vr[name]} {bits(std)}" for name, std in case.sensor.items()]
        script += script_of(md, f"filter-{item.value}", case.z, setup, dt)
    return script


def outputs_read(text: str) -> np.ndarray:
    """What every successful `get` returned: a row per call, a column per output."""
    rows = [[int(word, 16) for word in line.split()[2:]] for line in text.splitlines() if line.startswith("get 0 ")]
    return np.array(rows, dtype=np.uint64).view(np.float64)


@pytest.mark.parametrize("short", list(FMUS) + list(PLANT_FMUS))
def test_every_fmu_packs_both_binaries_beside_one_model_description(short, fmu_dir):
    identifier = {**FMUS, **PLANT_FMUS}[short]
    with zipfile.ZipFile(packaged(fmu_dir, identifier)) as zf:
        names = set(zf.namelist())
    assert {f"binaries/linux64/{identifier}.so", f"binaries/win64/{identifier}.dll", "modelDescription.xml"} <= names


def test_each_estimator_under_every_filter_kind_is_the_same_bit_for_bit(
    case, platform, fmu_dir, linux_master, tmp_path
):
    md = case.model_description
    fmu = packaged(fmu_dir, md.coSimulation.modelIdentifier)
    linux, other = run_both(fmu, estimator_script(case), linux_master, platform, tmp_path)
    assert linux.count("instantiate") > 1 and " 0\n" in linux
    assert_same_and_replayed(linux, other)


@pytest.mark.parametrize("short", list(PLANT_FMUS))
def test_each_plant_is_the_same_bit_for_bit(short, platform, fmu_dir, linux_master, tmp_path):
    fmu = packaged(fmu_dir, PLANT_FMUS[short])
    md = read_model_description(str(fmu))
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    rows = np.zeros((STEPS, len(inputs)))
    script = script_of(md, short, rows, [], float(md.defaultExperiment.stepSize))
    linux, other = run_both(fmu, script, linux_master, platform, tmp_path)
    assert_same_and_replayed(linux, other)


def test_a_discarded_step_is_the_same_bit_for_bit(s5_fmu, kalfmu_bin, platform, linux_master, tmp_path):
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
    linux, other = run_both(s5_fmu, "\n".join(lines) + "\n", linux_master, platform, tmp_path)
    assert_agree(linux, other)
    steps = [line for line in linux.splitlines() if line.startswith("step")]
    assert "step 2" in steps, "a step is discarded (fmi2Discard: 2)"
    assert all(s == "step skipped" for s in steps[steps.index("step 2") + 1 :]), "nothing is stepped after it"


def test_aarch64_and_the_avx2_kernels_differ_by_rounding_only(case, aarch64, fmu_dir, linux_master, tmp_path):
    """The x86-64 default (AVX2 with FMA) against aarch64: every output of every filter
    within 10⁻⁶ of its largest size over the run (measured: 5·10⁻⁸ and below). The
    SVD-CKF's too: its points come from the symmetric root U·√Σ·Uᵀ, the same for every
    basis U of an eigenspace; from U·√Σ, whose basis the roundings chose where eigenvalues
    are equal or nearly (a diagonal prior), S2's forces were 3 % apart
    (docs/fmu-interface.md)."""
    md = case.model_description
    fmu = packaged(fmu_dir, md.coSimulation.modelIdentifier)
    default = {k: v for k, v in os.environ.items() if k != "KALFMU_PORTABLE"}
    linux, other = run_both(fmu, estimator_script(case), linux_master, aarch64, tmp_path, default)
    (kinds,) = [t for t in md.typeDefinitions if t.name == "FilterKind"]
    instances = zip(kinds.items, linux.split("instantiate ")[1:], other.split("instantiate ")[1:], strict=True)
    compared = 0
    for kind, ours, theirs in instances:  # in the script's order
        a, b = outputs_read(ours), outputs_read(theirs)
        assert a.shape == b.shape and a.size > 0
        scale = np.abs(a).max(axis=0)  # each output's largest size over the run
        relative = np.abs(a - b) / np.where(scale > 0, scale, 1.0)
        assert relative.max() <= 1e-6, f"{kind.name}: {relative.max():.1e} of an output's size"
        compared += 1
    assert compared == len(kinds.items)
