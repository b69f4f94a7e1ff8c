"""How to log a co-simulation of a kalfmu FMU so that `analyzer report` (and
Foxglove, or Python with `mcap-ros1-support`) can read it: the S1 load
estimator driven by fmpy, logged with the `mcap` Python package. Copy and adapt.

    python tests/mcap_example.py OUT.mcap [--fmu kalfmu_s1_load.fmu] [--table s1.csv]
    analyzer report OUT.mcap

Without --fmu/--table the script builds both with cargo (the FMU with
`package-fmus`, a 5 s table with `kalfmu s1-export`).

The format (docs/log-format.md), in short:

- MCAP, zstd chunks, summary section; message encoding `ros1`, schema
  encoding `ros1msg`; a metadata record named `kalfmu` (strings only:
  study, case, seed, filter, parameters as JSON, software);
- channels `/measurements` (what the FMU was fed), `/truth` (the true values,
  named as the estimates they are compared with) and `/estimate` (the FMU's
  outputs: `X`, `X_std`, `nis`);
- one message per sample: `log_time = publish_time =` simulation time in
  integer ns, body every signal of the channel as a little-endian float64,
  in schema order (NaN for a missing value);
- one ROS 1 message definition per channel, named `kalfmu/<Topic>`: a line
  `float64 <signal>  # [<unit>] <description>` per signal, the unit from the
  FMU's modelDescription.
"""

from __future__ import annotations

import argparse
import json
import re
import struct
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import read_model_description, simulate_fmu
from mcap.writer import CompressionType, IndexType, Writer

# --------------------------------------------------------------------------
# The log writer: this part is independent of the FMU and of the study.
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Signal:
    name: str
    unit: str
    description: str


def schema_name(topic: str) -> str:
    """`kalfmu/` and the topic in CamelCase: /truth -> kalfmu/Truth."""
    parts = [p for p in re.split(r"[^A-Za-z0-9]+", topic) if p]
    name = "".join(p[0].upper() + p[1:] for p in parts)
    return "kalfmu/" + (name if name[:1].isalpha() else "Channel" + name)


def schema(topic: str, signals: list[Signal]) -> str:
    """The ROS 1 message definition of a channel: one float64 per signal."""
    lines = [
        f"# kalfmu log channel {topic}: one value per signal, NaN where missing; "
        "time is the message's log_time (docs/log-format.md)"
    ]
    for s in signals:
        description = s.description.replace("\n", " ").replace("\r", " ")
        lines.append(f"float64 {s.name}  # [{s.unit}] {description}")
    return "\n".join(lines) + "\n"


class KalfmuLog:
    """A kalfmu log being written: declare the channels, then write samples
    in time order (strictly increasing per channel), then close()."""

    def __init__(self, path: Path, metadata: dict[str, str]):
        self._file = open(path, "wb")
        self._writer = Writer(
            self._file,
            compression=CompressionType.ZSTD,
            index_types=IndexType.ALL & ~IndexType.ATTACHMENT,  # no empty attachment index
        )
        self._writer.start(profile="")
        self._writer.add_metadata("kalfmu", {k: str(v) for k, v in metadata.items()})
        self._channels: dict[str, tuple[int, struct.Struct]] = {}
        self._sequence = 0

    def add_channel(self, topic: str, signals: list[Signal]) -> None:
        data = schema(topic, signals).encode()
        schema_id = self._writer.register_schema(name=schema_name(topic), encoding="ros1msg", data=data)
        channel_id = self._writer.register_channel(topic=topic, message_encoding="ros1", schema_id=schema_id)
        self._channels[topic] = (channel_id, struct.Struct(f"<{len(signals)}d"))

    def write(self, topic: str, time: float, values) -> None:
        """One sample: `values` in the order of the channel's signals."""
        channel_id, layout = self._channels[topic]
        if len(values) != layout.size // 8:
            raise ValueError(f"{topic}: {len(values)} values for {layout.size // 8} signals")
        ns = int(round(time * 1e9))
        data = layout.pack(*(float(v) for v in values))  # a missing value is NaN
        self._writer.add_message(channel_id, log_time=ns, data=data, publish_time=ns, sequence=self._sequence)
        self._sequence += 1

    def close(self) -> None:
        self._writer.finish()
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# --------------------------------------------------------------------------
# The S1 study: the input table, the FMU run, and what goes on each channel.
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class S1Run:
    """What was logged: the table's rows (time k·dt, k = 0…n) and the FMU's
    outputs as fmpy records them, one row per row of the table."""

    time: np.ndarray
    z: np.ndarray  # (n, 2) z1_ddot, z2_ddot, as fed to the FMU
    load: np.ndarray  # true F
    result: np.ndarray  # simulate_fmu's structured array
    estimates: list[str]  # the names logged on /estimate
    metadata: dict[str, str]


def read_table(path: Path) -> tuple[dict[str, str], np.ndarray]:
    """`kalfmu s1-export` CSV: `# key = value` lines, a header, then the
    rows time, z1_ddot, z2_ddot, F_true (row k at time k·dt)."""
    lines = Path(path).read_text().splitlines()
    meta = dict(line[2:].split(" = ", 1) for line in lines if line.startswith("# ") and " = " in line)
    body = [line for line in lines if not line.startswith("#")]
    assert body[0] == "time,z1_ddot,z2_ddot,F_true", body[0]
    return meta, np.loadtxt(body[1:], delimiter=",", ndmin=2)


def run_s1(fmu: Path, table: Path) -> S1Run:
    """Runs the FMU over the table with fmpy.simulate_fmu, one communication
    step per sample, with the sensor noise of the table as R.

    Time: the table holds the plant's outputs of t_k = k·dt and fmpy sets row
    k at communication point t_k, which the FMU takes as the measurement at
    t_k. fmpy reads the outputs at t_0 after the inputs (the estimate given
    row 0) and after each step to t_k (the estimate at t_k predicted from the
    rows before): each is the estimate at the time stamp it is recorded with."""
    meta, rows = read_table(table)
    time, z, load = rows[:, 0], rows[:, 1:3], rows[:, 3]
    dt = float(meta["sample_time"])
    inputs = np.zeros(len(time), dtype=[("time", float), ("z1_ddot", float), ("z2_ddot", float)])
    inputs["time"] = time
    inputs["z1_ddot"], inputs["z2_ddot"] = z[:, 0], z[:, 1]
    md = read_model_description(str(fmu))
    estimates = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    parameters = {  # the parameters set; the sensor noise is the table's
        "sample_time": dt,
        "r_z1_ddot_std": float(meta["z1_ddot_noise_std"]),
        "r_z2_ddot_std": float(meta["z2_ddot_noise_std"]),
    }
    result = simulate_fmu(
        str(fmu),
        stop_time=time[-1],
        output_interval=dt,
        input=inputs,
        output=estimates,
        start_values=parameters,
    )
    # The filter kind: the parameter's start value, named by its enumeration item.
    kind = next(v for v in md.modelVariables if v.name == "filter")
    filter_name = next(i.name for i in kind.declaredType.items if i.value == kind.start)
    metadata = {
        "study": "S1",
        "case": meta["case"],
        "seed": meta["seed"],
        "filter": filter_name,
        "parameters": json.dumps(parameters),
        "software": md.generationTool,
        "fmu": md.coSimulation.modelIdentifier,
        "driver": "fmpy simulate_fmu (tests/mcap_example.py): outputs read at t_0 after the inputs, then after each step",
    }
    return S1Run(time, z, load, result, estimates, metadata)


def write_s1_log(path: Path, run: S1Run, fmu: Path) -> None:
    """Writes `run` as a kalfmu log; units and descriptions from the FMU."""
    variables = {v.name: v for v in read_model_description(str(fmu)).modelVariables}

    def signal(name: str, description: str | None = None) -> Signal:
        v = variables[name]
        return Signal(name, v.unit or "1", description or v.description or name)

    with KalfmuLog(path, run.metadata) as log:
        log.add_channel("/measurements", [signal("z1_ddot"), signal("z2_ddot")])
        log.add_channel("/truth", [signal("F", "true load on mass 2")])  # named as the estimate: paired
        log.add_channel("/estimate", [signal(name) for name in run.estimates])
        assert len(run.result) == len(run.time)
        for t_k, z, load, out in zip(run.time, run.z, run.load, run.result):
            assert abs(out["time"] - t_k) < 1e-9, (out["time"], t_k)
            log.write("/measurements", t_k, z)
            log.write("/truth", t_k, [load])
            log.write("/estimate", t_k, [out[name] for name in run.estimates])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Runs the S1 FMU with fmpy and logs the run in the kalfmu MCAP format.")
    parser.add_argument("out", type=Path, help="the MCAP log to write")
    parser.add_argument("--fmu", type=Path, help="kalfmu_s1_load.fmu (default: build it)")
    parser.add_argument("--table", type=Path, help="`kalfmu s1-export` CSV (default: export 5 s)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        if args.fmu is None or args.table is None:
            from conftest import build_fmus, build_kalfmu  # the cargo helpers of the test suite

            if args.fmu is None:
                args.fmu = build_fmus(Path(tmp)) / "kalfmu_s1_load.fmu"
            if args.table is None:
                args.table = Path(tmp) / "s1.csv"
                subprocess.run(
                    [str(build_kalfmu()), "s1-export", "--duration", "5", "--out", str(args.table)], check=True
                )
        run = run_s1(args.fmu, args.table)
        write_s1_log(args.out, run, args.fmu)
    print(f"wrote {args.out}: {len(run.time)} samples of {run.metadata['case']}")


if __name__ == "__main__":
    main()
