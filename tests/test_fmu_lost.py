"""A lost filter is never reported OK, and a noise setting decades off is refused
(`fmu/src/plausibility.rs`), through fmpy:

* S3 told its accelerometers' noise is 2e-13 m/s² (a typo for 2e-3) refuses
  fmi2ExitInitializationMode with a message that names the parameter; the
  quiet sensors of S3's own twist case (1e-4 m/s²) are taken;
* S1 whose load is dragged beyond 1000 prior σ (an offset of 3000 m/s² on both
  accelerometers for 1 s, which its wide noise setting lets through) returns
  fmi2Warning from fmi2DoStep, its outputs hold the last plausible estimate with
  filter_healthy false, and it says that it is lost; it restarts from where its
  states had been (`estimator/src/supervisor/restart.rs`), and once the offset
  ends the load is back at once and the filter healthy again.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import fmi2OK, fmi2Warning

from test_fmu import slaves
from test_fmu_s3 import ACCELERATIONS


@pytest.fixture(scope="module")
def s3(s3_fmu, tmp_path_factory):
    md = read_model_description(str(s3_fmu))
    return md, Path(extract(str(s3_fmu), str(tmp_path_factory.mktemp("unzipped-lost-s3"))))


@pytest.fixture(scope="module")
def s1(s1_fmu, tmp_path_factory):
    md = read_model_description(str(s1_fmu))
    return md, Path(extract(str(s1_fmu), str(tmp_path_factory.mktemp("unzipped-lost-s1"))))


def test_a_noise_parameter_fifteen_decades_below_its_signal_is_refused_by_name(s3):
    md, unzipped = s3
    for make in slaves(unzipped, md):
        typo = make("typo")
        typo.fmu.setupExperiment(startTime=0.0)
        typo.fmu.enterInitializationMode()
        typo.set(**{f"r_{n}_std": 2e-13 for n in ACCELERATIONS})
        with pytest.raises(Exception):
            typo.fmu.exitInitializationMode()
        assert any("r_a_ab_L1_std = 2e-13 m/s2 is more than nine decades below" in e for e in typo.errors()), typo.errors()
        quiet = make("quiet")
        quiet.initialize(**{f"r_{n}_std": 1e-4 for n in ACCELERATIONS})
        assert quiet.errors() == []


def test_a_lost_filter_returns_a_warning_with_the_last_plausible_estimate(s1):
    md, unzipped = s1
    for make in slaves(unzipped, md):
        s = make("lost")
        # Wide noise settings: 3000 m/s² on z2_ddot is 3000σ, a load jump of 24 kN
        # (1000 prior σ of p0_F_std = 20 N is 20 kN).
        s.initialize(r_z1_ddot_std=1.0, r_z2_ddot_std=1.0)
        rng = np.random.default_rng(3)
        statuses, loads, healthy = [], [], []
        for k in range(1000):
            z = 0.01 * rng.standard_normal(2)
            if 200 <= k < 400:
                z += 3000.0
            s.inputs(z)
            loads.append(s.get("F")[0])
            healthy.append(s.fmu.getBoolean([s.vr["filter_healthy"]])[0])
            # fmpy's doStep raises above fmi2Warning and returns nothing: the status itself.
            statuses.append(s.fmu.fmi2DoStep(s.fmu.component, s.time, s.dt, 1))
            s.time += s.dt
        assert all(status in (fmi2OK, fmi2Warning) for status in statuses)
        lost = [k for k, status in enumerate(statuses) if status == fmi2Warning]
        assert lost and 200 <= lost[0] and lost[-1] < 400, lost
        # After a lost step the outputs are the last plausible ones, the filter not healthy.
        for k in lost:
            assert abs(loads[k + 1]) <= 20_000.0 and not healthy[k + 1], k
        said = [w for w in s.warnings() if "the filter is lost" in w]
        assert said and "F is" in said[0], said
        assert any("the filter restarted" in w for w in s.warnings())
        # The offset ends: the load is back at once, and the filter healthy again within a window.
        assert max(abs(x) for x in loads[400:]) < 1.0
        assert all(healthy[k] for k in range(600, 1000))
