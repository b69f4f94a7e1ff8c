"""How to log a co-simulation of a kalfmu FMU so that `analyzer report` (and
Foxglove, PlotJuggler, `rerun mcap`) can read it: the S1 load estimator
driven by fmpy, logged with the `mcap` Python package. Copy and adapt.

    python tests/mcap_example.py OUT.mcap [--fmu kalfmu_s1_load.fmu] [--table s1.csv]
    analyzer report OUT.mcap

Without --fmu/--table the script builds both with cargo (the FMU with
`package-fmus`, a 5 s table with `scenarios s1-export`).

The format (docs/log-format.md), in short:

- MCAP, zstd chunks, summary section; message encoding `json`, schema
  encoding `jsonschema`; a metadata record named `kalfmu` (strings only:
  study, case, seed, filter, parameters as JSON, software);
- channels `/measurements` (what the FMU was fed), `/truth` (the true values,
  named as the estimates they are compared with) and `/estimate` (the FMU's
  outputs: `X`, `X_std`, `nis`);
- one message per sample: `log_time = publish_time =` simulation time in
  integer ns, body `{"timestamp": {"sec", "nsec"}, "<signal>": value, …}` with
  every signal of the channel, `null` for a missing or non-finite value;
- one JSON Schema per channel, each signal with its `unit` (from the FMU's
  modelDescription) and a `description` ending in `[unit]`.
"""

from __future__ import annotations

import argparse
import json
import math
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


def schema(topic: str, signals: list[Signal]) -> dict:
    """The JSON Schema of a channel (no `$ref`, every field required)."""
    properties = {
        "timestamp": {
            "type": "object",
            "description": "simulation time",
            "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
            "required": ["sec", "nsec"],
        }
    }
    for s in signals:
        properties[s.name] = {"type": ["number", "null"], "unit": s.unit, "description": f"{s.description} [{s.unit}]"}
    return {"title": topic, "type": "object", "properties": properties, "required": ["timestamp"] + [s.name for s in signals]}


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
        self._channels: dict[str, tuple[int, list[str]]] = {}
        self._sequence = 0

    def add_channel(self, topic: str, signals: list[Signal]) -> None:
        data = json.dumps(schema(topic, signals)).encode()
        schema_id = self._writer.register_schema(name="kalfmu" + topic.replace("/", "."), encoding="jsonschema", data=data)
        channel_id = self._writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id)
        self._channels[topic] = (channel_id, [s.name for s in signals])

    def write(self, topic: str, time: float, values) -> None:
        """One sample: `values` in the order of the channel's signals."""
        channel_id, names = self._channels[topic]
        if len(values) != len(names):
            raise ValueError(f"{topic}: {len(values)} values for {len(names)} signals")
        ns = int(round(time * 1e9))
        body = {"timestamp": {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}}
        for name, v in zip(names, values):
            v = float(v)
            body[name] = v if math.isfinite(v) else None  # missing or NaN -> null
        data = json.dumps(body, allow_nan=False, separators=(",", ":")).encode()
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
    """`scenarios s1-export` CSV: `# key = value` lines, a header, then the
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
    parser.add_argument("--table", type=Path, help="`scenarios s1-export` CSV (default: export 5 s)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        if args.fmu is None or args.table is None:
            from conftest import build_fmus, build_scenarios  # the cargo helpers of the test suite

            if args.fmu is None:
                args.fmu = build_fmus(Path(tmp)) / "kalfmu_s1_load.fmu"
            if args.table is None:
                args.table = Path(tmp) / "s1.csv"
                subprocess.run(
                    [str(build_scenarios()), "s1-export", "--duration", "5", "--out", str(args.table)], check=True
                )
        run = run_s1(args.fmu, args.table)
        write_s1_log(args.out, run, args.fmu)
    print(f"wrote {args.out}: {len(run.time)} samples of {run.metadata['case']}")


if __name__ == "__main__":
    main()
