"""FMU start values from an SSP parameter-value file (SSV, SSP 1.0), as `kalfmu-tune --ssv`
writes them (`start_values::ssv`), given to fmpy's `simulate_fmu(start_values=…)`, which
sets each by its variable's type before initialisation ends:

- fmpy's own SSV reader (`fmpy.ssp.ssd.read_ssv`) reads the file into the dict
  `simulate_fmu` takes;
- on the packaged S1 FMU the values take effect: the FMU reports them back, a Real (the
  accelerometers' noise) and an Enumeration written as a Real (`filter`, 4: the UKF), and
  the estimate's σ grows with the noise it is told;
- a name the FMU does not have is an error, not a value silently dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.ssp.ssd import read_ssv

H = 0.005  # the S1 FMU's sample time (s)
#: The accelerometers' noise the SSV file sets (m/s²), twenty times the FMU's default.
TOLD_STD = 0.2


def ssv_text(parameters: dict[str, float]) -> str:
    """An SSV document laid out as `start_values::ssv::to_xml` writes one: every value an
    `ssv:Real` in the shortest exponent form, with a unit of the set's `ssv:Units`."""
    body = "".join(
        f'    <ssv:Parameter name="{name}">\n      <ssv:Real value="{value:e}"{unit}/>\n    </ssv:Parameter>\n'
        for name, value in parameters.items()
        for unit in [' unit="m/s2"' if name.startswith("r_") else ""]
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssv:ParameterSet xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
        'xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" version="1.0" name="kalfmu_s1_load tuned" '
        'generationTool="tests/test_fmu_start_values.py">\n'
        f"  <ssv:Parameters>\n{body}  </ssv:Parameters>\n"
        '  <ssv:Units>\n    <ssc:Unit name="m/s2">\n      <ssc:BaseUnit m="1" s="-2"/>\n    </ssc:Unit>\n'
        "  </ssv:Units>\n</ssv:ParameterSet>\n"
    )


def start_values_of(path: Path) -> dict[str, float]:
    """The file's values by name, as numbers (fmpy's reader keeps the text)."""
    parameter_set = read_ssv(str(path), validate=False)  # fmpy ships no SSV schema to validate against
    assert all(p.type == "Real" for p in parameter_set.parameters)
    return {p.name: float(p.value) for p in parameter_set.parameters}


def signals() -> np.ndarray:
    """0.5 s of both accelerations: a small harmonic on the second mass, the first at rest."""
    time = np.arange(100) * H
    table = np.zeros(len(time), dtype=[("time", np.float64), ("z1_ddot", np.float64), ("z2_ddot", np.float64)])
    table["time"], table["z2_ddot"] = time, 0.5 * np.sin(2 * np.pi * 2 * time)
    return table


def simulate(fmu: Path, start_values: dict) -> np.ndarray:
    return simulate_fmu(
        str(fmu),
        stop_time=signals()["time"][-1],
        output_interval=H,
        input=signals(),
        output=["F", "F_std", "r_z1_ddot_std", "r_z2_ddot_std", "filter"],
        start_values=start_values,
    )


def test_an_ssv_files_values_given_to_simulate_fmu_take_effect(s1_fmu, tmp_path):
    path = tmp_path / "tuned.ssv"
    path.write_text(ssv_text({"r_z1_ddot_std": TOLD_STD, "r_z2_ddot_std": TOLD_STD, "filter": 4}))
    start_values = start_values_of(path)
    assert start_values == {"r_z1_ddot_std": TOLD_STD, "r_z2_ddot_std": TOLD_STD, "filter": 4.0}

    told = simulate(s1_fmu, start_values)
    default = simulate(s1_fmu, {})
    # The FMU reports what it was given, each by its type (filter: an Enumeration).
    assert np.all(told["r_z1_ddot_std"] == TOLD_STD) and np.all(told["r_z2_ddot_std"] == TOLD_STD)
    assert np.all(told["filter"] == 4) and np.all(default["filter"] != 4)
    assert np.all(default["r_z1_ddot_std"] != TOLD_STD)
    # Told noisier accelerometers, it trusts them less: the load's σ is larger.
    assert np.all(np.isfinite(told["F"])) and np.all(np.isfinite(default["F"]))
    assert told["F_std"][-1] > default["F_std"][-1] > 0


def test_a_name_the_fmu_lacks_is_an_error(s1_fmu, tmp_path):
    path = tmp_path / "misspelt.ssv"
    path.write_text(ssv_text({"r_z1_ddot_sdt": TOLD_STD}))
    with pytest.raises(Exception, match="r_z1_ddot_sdt"):
        simulate(s1_fmu, start_values_of(path))
