"""The worked example of README.md ("Put an FMU into your own master") runs as
it is written, on the FMU this suite packages, and does what the README says:
it steps `kalfmu_s1_load.fmu` as a master and prints the load estimate with
its sigma. A README example that goes stale (a renamed variable or parameter,
a changed call order, worse estimates) fails here.

The block is the one ```python block of README.md; the ```text block after it
is what the README says it prints, and must be. The code's only change before
it runs is the FMU's path: the README's `target/fmu/kalfmu_s1_load.fmu` becomes
the one conftest's `s1_fmu` fixture packaged.
"""

from __future__ import annotations

import contextlib
import io
import re

import numpy as np

from conftest import ROOT

README = ROOT / "README.md"
FMU_IN_README = '"target/fmu/kalfmu_s1_load.fmu"'


def readme_example() -> tuple[str, str]:
    """The README's one ```python block, and the ```text block after it (what
    the README says the example prints)."""
    text = README.read_text(encoding="utf-8")
    blocks = re.findall(r"^```python\n(.*?)^```$", text, flags=re.S | re.M)
    assert len(blocks) == 1, f"README.md should hold exactly one ```python block, found {len(blocks)}"
    after = text[text.index(blocks[0]) + len(blocks[0]) :]
    shown = re.search(r"^```text\n(.*?)^```$", after, flags=re.S | re.M)
    assert shown, "README.md should show the example's output in a ```text block after it"
    return blocks[0], shown.group(1)


def run_example(fmu_path) -> tuple[dict, str]:
    """Runs the example on `fmu_path`; returns the variables it left and what it printed."""
    code, _ = readme_example()
    assert code.count(FMU_IN_README) == 1, f"the example should name the FMU once as {FMU_IN_README}"
    code = code.replace(FMU_IN_README, repr(str(fmu_path)))
    namespace: dict = {"__name__": "readme_example"}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, f"{README} (the python example)", "exec"), namespace)
    return namespace, printed.getvalue()


def test_the_readme_example_steps_the_s1_fmu_and_prints_the_load_with_its_sigma(s1_fmu, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the example must not depend on the working directory
    ns, printed = run_example(s1_fmu)

    # It ran the whole record as a master: one read per communication point.
    time, F_est, F_std, F_true = ns["time"], np.array(ns["F_est"]), np.array(ns["F_std"]), ns["F_true"]
    assert len(time) == len(F_est) == len(F_std) == len(F_true) == 1000
    assert np.all(np.isfinite(F_est)) and np.all(F_std > 0)
    assert ns["healthy"], "the FMU reported filter_healthy false on clean data"

    # The estimates identify the load (docs/studies/s1.md: 0.9995 and more through the FMU).
    assert ns["correlation"] >= 0.999, ns["correlation"]
    assert abs(F_est[-1] - F_true[-1]) <= 4 * F_std[-1], (F_est[-1], F_std[-1], F_true[-1])
    # Its sigma means something: after the start-up, at least 90 % of the errors lie within 2 sigma.
    after_1s = time >= 1.0
    assert np.mean(np.abs(F_est - F_true)[after_1s] <= 2 * F_std[after_1s]) >= 0.9

    # What it printed is that estimate, its sigma, the truth and the correlation.
    lines = printed.splitlines()
    assert len(lines) == 2, printed
    assert lines[0] == f"F({time[-1]:.3f} s) = {F_est[-1]:.3f} N ± {F_std[-1]:.3f} N (1σ), true {F_true[-1]:.3f} N"
    assert lines[1] == f"correlation with the true load after 1 s: {ns['correlation']:.4f}; filter_healthy: True"

    # And it is what the README shows it prints.
    _, shown = readme_example()
    assert printed == shown, f"README.md shows\n{shown}but the example printed\n{printed}"
