"""`analyzer report` on logs written from Python (tests/mcap_example.py), its
metrics checked against independent NumPy/SciPy computations on the same data.

What is specified here:

- the analyzer reads the log the Python example writes (fmpy + `mcap`) as it
  reads its own: the report succeeds, pairs /truth F with /estimate F (σ from
  F_std), over every sample, with the metadata and the FMU's units;
- correlation, RMSE, RMSE after convergence, the final relative error and the
  ±2σ coverage equal NumPy's on the paired samples (1e-12 relative; the
  coverage, a count, exactly);
- the running-RMSE statistics (peak, convergence time, max/mean/variance after
  convergence) equal those of a direct NumPy window at every sample: on the
  S1 run to 1e-12 relative; on a long synthetic log with a large start-up
  transient (which crosses the analyzer's periodic re-summation) within the
  rounding its running sum carries (see that test);
- the PSD agreement band equals the one computed from `scipy.signal.welch`
  (defaults, same segment length) by the same rule, exactly (same bins);
- logs other tools write are analysed as our own: JSON messages written
  with Python's `mcap`, and a ROS 2 bag (CDR, ros2msg schemas) written with
  `mcap-ros2-support`, each with an estimate a known offset from the truth,
  give that offset as their RMSE; a channel in an encoding the analyzer
  does not read is skipped with a warning.

The JSON report does not carry the spectra, only the band; the band depends
on the ratio of the two Welch spectra, so it tests the window, detrending,
overlap, segmentation, averaging and frequency axis — each variant of these
changes the band of at least one case below (checked) — but not a scaling
common to both spectra (fs·Σw², the one-sided doubling), which cancels.
"""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
from scipy import signal as sps

from fmpy import read_model_description
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from mcap_ros1.decoder import DecoderFactory
from mcap_ros2.writer import Writer as Ros2Writer

from mcap_example import KalfmuLog, Signal, run_s1, write_s1_log

REL = 1e-12  # relative tolerance of every metric, unless a test derives a wider one


def close(value, expected, rel=REL, abs=0.0):
    """pytest.approx without its default absolute tolerance of 1e-12, which
    would accept anything for the small variances compared here."""
    return value == pytest.approx(expected, rel=rel, abs=abs)


# --------------------------------------------------------------------------
# Helpers: running the analyzer, writing small synthetic logs.
# --------------------------------------------------------------------------


def report(analyzer_bin, log, tmp_path, *args: str) -> dict:
    """`analyzer report LOG --json OUT ARGS…`; returns the log's report (the
    JSON holds one per log given, under `runs`)."""
    out = tmp_path / f"{log.stem}{'_'.join(a.strip('-') for a in args)}.json"
    proc = subprocess.run(
        [str(analyzer_bin), "report", str(log), "--json", str(out), *args], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(out.read_text())["runs"][0]


def write_pair_log(path, time, truth, estimate):
    """A minimal log: /truth X and /estimate X sampled at `time`."""
    with KalfmuLog(path, {"study": "test_analyzer"}) as log:
        log.add_channel("/truth", [Signal("X", "1", "truth")])
        log.add_channel("/estimate", [Signal("X", "1", "estimate")])
        for t, a, b in zip(time, truth, estimate):
            log.write("/truth", t, [a])
            log.write("/estimate", t, [b])
    return path


def rmse(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e * e)))


def window_samples(window: float, dt: float) -> int:
    return max(round(window / dt), 1)


def direct_running_rmse(e: np.ndarray, w: int) -> np.ndarray:
    """RMSE over the trailing window of w samples (fewer at the start), each
    window summed afresh."""
    first = [rmse(e[: k + 1]) for k in range(min(w - 1, len(e)))]
    full = np.sqrt(np.mean(np.lib.stride_tricks.sliding_window_view(e * e, w), axis=1)) if len(e) >= w else []
    return np.concatenate([first, full])


def running_statistics(time, truth, estimate, window) -> dict:
    """The analyzer's running-RMSE statistics (analyzer/src/metrics.rs, as
    documented there) from the direct window. The convergence time is a
    simulation time: that of the first converged sample."""
    dt = time[1] - time[0]
    e = estimate - truth
    n = len(e)
    running = direct_running_rmse(e, window_samples(window, dt))
    above = np.flatnonzero(running > 2 * rmse(e[n // 2 :]))
    start = min(above[-1] + 1 if len(above) else 0, n - 1)
    tail = running[start:]
    return {
        "convergence_time": time[start],
        "rmse_converged": rmse(e[start:]),
        "running_rmse_peak": running.max(),
        "running_rmse_max_converged": tail.max(),
        "running_rmse_mean_converged": tail.mean(),
        "running_rmse_var_converged": tail.var(),
    }


def agreement_band(f, a, b, db=3.0):
    """The widest run of bins above DC where 10·log10(a/b) is within ±db
    (the first of equally wide runs); (f_low, f_high) or None."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = (a > 0) & (b > 0) & (np.abs(10 * np.log10(a / b)) <= db)
    best, start = None, None
    for k in range(1, len(a) + 1):
        inside = k < len(a) and ok[k]
        if inside and start is None:
            start = k
        elif not inside and start is not None:
            if best is None or k - 1 - start > best[1] - best[0]:
                best = (start, k - 1)
            start = None
    return None if best is None else (f[best[0]], f[best[1]])


def scipy_band(truth, estimate, fs, segment, **welch_options):
    n = min(segment, len(truth))
    f, pt = sps.welch(truth, fs=fs, nperseg=n, **welch_options)
    _, pe = sps.welch(estimate, fs=fs, nperseg=n, **welch_options)
    return agreement_band(f, pt, pe)


def assert_band(json_band, expected):
    assert (json_band is None) == (expected is None), (json_band, expected)
    if expected is not None:
        np.testing.assert_allclose(json_band, expected, rtol=1e-12, atol=0)


# --------------------------------------------------------------------------
# The S1 log written by the example.
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def s1_log(kalfmu_bin, s1_fmu, tmp_path_factory):
    """The example's log of the FMU over 5 s of stiffness/random (seed 1, 2 %
    noise), and what it logged."""
    tmp = tmp_path_factory.mktemp("s1log")
    table = tmp / "s1.csv"
    subprocess.run(
        [str(kalfmu_bin), "s1-export", "--case", "stiffness/random", "--duration", "5"]
        + ["--seed", "1", "--noise", "0.02", "--out", str(table)],
        check=True,
    )
    run = run_s1(s1_fmu, table)
    write_s1_log(tmp / "s1.mcap", run, s1_fmu)
    return tmp / "s1.mcap", run


@pytest.fixture(scope="module")
def paired(s1_log):
    """The samples the analyzer compares: truth and estimate at t_0 … t_n."""
    _, run = s1_log
    out = run.result
    assert np.allclose(out["time"], run.time, rtol=0, atol=1e-12)
    return run.time, run.load, out["F"], out["F_std"]


def test_the_python_log_is_valid_mcap_with_the_fmu_units(s1_log, s1_fmu):
    """Read back with the `mcap` reader and Foxglove's ROS 1 decoder
    (`mcap-ros1-support`): three ros1/ros1msg channels, one message per sample
    t_0 … t_n, each decoding to the values written, the units of the
    modelDescription, the `kalfmu` metadata record."""
    path, run = s1_log
    units = {v.name: v.unit for v in read_model_description(str(s1_fmu)).modelVariables}
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        counts = {summary.channels[c].topic: k for c, k in summary.statistics.channel_message_counts.items()}
        assert counts == {"/measurements": 1001, "/truth": 1001, "/estimate": 1001}
        for channel in summary.channels.values():
            sch = summary.schemas[channel.schema_id]
            assert (channel.message_encoding, sch.encoding) == ("ros1", "ros1msg")
            fields = [line.split("#")[0].split() for line in sch.data.decode().splitlines()]
            for kind, name in filter(None, fields):
                assert kind == "float64"
                assert f"float64 {name}  # [{units[name]}] " in sch.data.decode(), (channel.topic, name)
        [meta] = [m for m in reader.iter_metadata() if m.name == "kalfmu"]
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        decoded = {"/measurements": [], "/truth": [], "/estimate": []}
        for _, channel, message, ros in reader.iter_decoded_messages():
            decoded[channel.topic].append((message.log_time, ros))
    ns = [int(round(t * 1e9)) for t in run.time]
    assert [t for t, _ in decoded["/truth"]] == ns
    assert [m.F for _, m in decoded["/truth"]] == list(run.load)
    assert [m.z2_ddot for _, m in decoded["/measurements"]] == list(run.z[:, 1])
    assert [m.F_std for _, m in decoded["/estimate"]] == list(run.result["F_std"])
    assert meta.metadata == run.metadata
    assert {"study", "case", "seed", "filter", "parameters", "software"} <= meta.metadata.keys()
    assert json.loads(meta.metadata["parameters"])["r_z1_ddot_std"] > 0


def test_the_analyzer_reads_the_python_log_and_pairs_f(analyzer_bin, s1_log, tmp_path):
    """`analyzer report LOG --json OUT` succeeds and pairs F with F over all
    1001 samples, with σ (so a ±2σ coverage), the unit N and the metadata."""
    path, run = s1_log
    rep = report(analyzer_bin, path, tmp_path)
    assert rep["metadata"] == run.metadata
    [pair] = rep["pairs"]
    assert (pair["truth"], pair["estimate"], pair["unit"], pair["samples"]) == ("F", "F", "N", 1001)
    assert pair["two_sigma_coverage"] is not None
    assert pair["correlation"] > 0.998  # the FMU identifies the load


def test_whole_record_metrics_equal_numpy(analyzer_bin, s1_log, paired, tmp_path):
    """Correlation (numpy.corrcoef), RMSE, RMSE after convergence and the
    final relative error (none where the truth ends below 1e-3 of its RMS)
    equal NumPy's to 1e-12 relative; the ±2σ coverage
    (a count over 1000) exactly."""
    path, _ = s1_log
    time, truth, estimate, sigma = paired
    pair = report(analyzer_bin, path, tmp_path)["pairs"][0]
    e = estimate - truth
    assert close(pair["correlation"], np.corrcoef(truth, estimate)[0, 1])
    assert close(pair["rmse"], rmse(e))
    if abs(truth[-1]) > 1e-3 * np.sqrt(np.mean(truth**2)):
        assert close(pair["final_relative_error"], abs(e[-1]) / abs(truth[-1]))
    else:  # a truth that ends near zero has no meaningful final relative error
        assert pair["final_relative_error"] is None
    assert pair["two_sigma_coverage"] == np.mean(np.abs(e) <= 2 * sigma)
    start = int(np.argmin(np.abs(time - pair["convergence_time"])))
    assert close(pair["rmse_converged"], rmse(e[start:]))


@pytest.mark.parametrize("window", [0.05, 0.3, 1.0])
def test_running_rmse_statistics_on_the_s1_log(analyzer_bin, s1_log, paired, tmp_path, window):
    """With windows of 10, 60 and 200 samples, the running-RMSE statistics
    equal those of the direct NumPy window to 1e-12 relative (the
    convergence time to 1e-12 s)."""
    path, _ = s1_log
    time, truth, estimate, _ = paired
    pair = report(analyzer_bin, path, tmp_path, "--rmse-window", str(window))["pairs"][0]
    expected = running_statistics(time, truth, estimate, window)
    assert close(pair["convergence_time"], expected.pop("convergence_time"), rel=0, abs=1e-12)
    for key, value in expected.items():
        assert close(pair[key], value), key


def test_running_rmse_statistics_on_a_long_log_with_a_transient(analyzer_bin, tmp_path):
    """13 000 samples (past the analyzer's periodic re-summation), an error of
    10 for the first 0.5 s then of 1e-3 (noise), window 3 s, the record
    starting at t = 1 s. The start-up transient is found (convergence near
    4.5 s of simulation time) and every statistic equals the direct window's
    to 1e-12 relative: the analyzer re-sums its window when a large error
    leaves it, so no cancellation error is left behind."""
    dt, n, window = 0.001, 13_000, 3.0
    rng = np.random.default_rng(11)
    time = 1.0 + np.arange(n) * dt
    truth = np.sin(2 * np.pi * 0.7 * time)
    estimate = truth + np.where(time < 1.5, 10.0, 1e-3 * rng.standard_normal(n))
    log = write_pair_log(tmp_path / "long.mcap", time, truth, estimate)
    pair = report(analyzer_bin, log, tmp_path, "--rmse-window", str(window))["pairs"][0]
    expected = running_statistics(time, truth, estimate, window)
    assert 4.4 < expected["convergence_time"] < 4.6
    assert close(pair["convergence_time"], expected.pop("convergence_time"), rel=0, abs=1e-9)
    for key, value in expected.items():
        assert close(pair[key], value), key


# --------------------------------------------------------------------------
# The Welch PSD, through the agreement band.
# --------------------------------------------------------------------------


@pytest.mark.parametrize("segment", [128, 256, 1024])
def test_psd_band_on_the_s1_log_equals_scipy(analyzer_bin, s1_log, paired, tmp_path, segment):
    """The band of the S1 log with segments of 128, 256 and 1024 samples (the
    default, longer than the 1001 samples: cut to the record, as scipy does)
    is the band of scipy.signal.welch's spectra, bin for bin."""
    path, _ = s1_log
    _, truth, estimate, _ = paired
    pair = report(analyzer_bin, path, tmp_path, "--psd-segment", str(segment))["pairs"][0]
    assert_band(pair["psd_agreement_band"], scipy_band(truth, estimate, 200.0, segment))


def psd_cases():
    """(name, fs, segment, truth, estimate), each sensitive to some part of
    the estimate: the window (an on-bin sine leaks beyond its neighbours
    only through a non-periodic-Hann window), detrending (an offset, a
    ramp), and overlap, segmentation and averaging (independent noise)."""
    fs, n = 100.0, 2100
    t = np.arange(n) / fs
    rng = np.random.default_rng(3)
    sine = np.sin(2 * np.pi * (40 * fs / 256) * t + 0.3)
    yield "window", fs, 256, sine, sine + 1e-6 * rng.standard_normal(n)
    x = rng.standard_normal(n)
    yield "ramp", fs, 256, x, x + 5.0 + 2.0 * t
    yield "offset", fs, 256, x, x + 5.0
    yield "noise", fs, 256, x, x + 0.9 * rng.standard_normal(n)
    yield "noise, odd segment", fs, 255, x, x + 0.9 * rng.standard_normal(n)


PSD_CASES = list(psd_cases())

#: Other Welch estimates; each must change the band of at least one case,
#: or the cases would not tell it from scipy's defaults.
VARIANTS = {
    "symmetric Hann": lambda seg: {"window": sps.windows.hann(seg, sym=True)},
    "Hamming": lambda seg: {"window": "hamming"},
    "boxcar": lambda seg: {"window": "boxcar"},
    "no detrending": lambda seg: {"detrend": False},
    "linear detrending": lambda seg: {"detrend": "linear"},
    "no overlap": lambda seg: {"noverlap": 0},
    "3/4 overlap": lambda seg: {"noverlap": 3 * seg // 4},
    "median averaging": lambda seg: {"average": "median"},
}


@pytest.mark.parametrize("case", PSD_CASES, ids=[c[0] for c in PSD_CASES])
def test_psd_band_on_synthetic_logs_equals_scipy(analyzer_bin, tmp_path, case):
    """On each synthetic case the analyzer's band is the band of scipy's
    Welch spectra (defaults, same segment), bin for bin."""
    name, fs, segment, truth, estimate = case
    log = write_pair_log(tmp_path / "psd.mcap", np.arange(len(truth)) / fs, truth, estimate)
    pair = report(analyzer_bin, log, tmp_path, "--psd-segment", str(segment))["pairs"][0]
    assert_band(pair["psd_agreement_band"], scipy_band(truth, estimate, fs, segment))


def test_the_psd_cases_tell_each_variant_from_scipys_defaults():
    """The cases above have power: every Welch variant (window, detrending,
    overlap, averaging) or the last segment left out gives another band in at
    least one of them."""
    default = [scipy_band(a, b, fs, seg) for _, fs, seg, a, b in PSD_CASES]

    def differs(bands):
        return any(x != y for x, y in zip(bands, default))

    for variant, options in VARIANTS.items():
        assert differs([scipy_band(a, b, fs, seg, **options(seg)) for _, fs, seg, a, b in PSD_CASES]), variant
    def without_last_segment(x, seg):
        step = seg - seg // 2
        segments = (len(x) - seg // 2) // step  # scipy's count
        return x[: (segments - 2) * step + seg]

    dropped = [
        scipy_band(without_last_segment(a, seg), without_last_segment(b, seg), fs, seg)
        for _, fs, seg, a, b in PSD_CASES
    ]
    assert differs(dropped), "last segment left out"


# --------------------------------------------------------------------------
# Logs other tools write: JSON messages (Python's `mcap`) and a ROS 2 bag
# (`mcap-ros2-support`, CDR with ros2msg schemas). The analyzer pairs
# /truth X with /estimate X by name as in its own logs; the time of a sample
# is the message's log_time.
# --------------------------------------------------------------------------

OFFSET = 0.25  # estimate = truth + OFFSET, so the RMSE is OFFSET
STD = 0.2  # every |error| = 0.25 ≤ 2σ = 0.4: a ±2σ coverage of 1


def known_error_samples(n=400, rate=100.0):
    """Time, a truth with two tones, and an estimate OFFSET above it."""
    time = np.arange(n) / rate
    truth = np.sin(2 * np.pi * 1.5 * time) + 0.3 * np.sin(2 * np.pi * 7.0 * time)
    return time, truth, truth + OFFSET


def test_a_json_log_from_python_mcap_is_analysed_with_its_known_error(analyzer_bin, tmp_path):
    """JSON messages with a jsonschema, as `mcap.writer.Writer` and json.dumps
    write them (a bare NaN included, a string field beside the numbers, one
    schema for every topic): the report pairs F with F over every sample, σ
    from F_std (which no /truth message has, so /truth has no F_std to pair),
    the unit from the schema, and measures RMSE = OFFSET."""
    time, truth, estimate = known_error_samples()
    path = tmp_path / "python_json.mcap"
    schema = {
        "type": "object",
        "properties": {
            "F": {"type": "number", "description": "[N] load"},
            "F_std": {"type": "number", "description": "[N] its deviation"},
            "label": {"type": "string"},
        },
    }
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start(profile="", library="test_analyzer")
        schema_id = w.register_schema("Load", "jsonschema", json.dumps(schema).encode())
        ids = {t: w.register_channel(t, "json", schema_id) for t in ("/truth", "/estimate", "/measurements")}
        w.add_metadata("kalfmu", {"study": "json"})
        for k, (t, a, b) in enumerate(zip(time, truth, estimate)):
            ns = int(round(t * 1e9))
            messages = {
                "/truth": {"F": a, "label": "true"},
                "/estimate": {"F": b, "F_std": STD, "label": "ekf"},
                # json.dumps writes a NaN as the bare token NaN, which is not JSON.
                "/measurements": {"F": float("nan") if k == 3 else a / 8},
            }
            for topic, message in messages.items():
                w.add_message(ids[topic], log_time=ns, data=json.dumps(message).encode(), publish_time=ns, sequence=k)
        w.finish()
    rep = report(analyzer_bin, path, tmp_path)
    assert rep["metadata"] == {"study": "json"}
    [pair] = rep["pairs"]
    assert (pair["truth"], pair["estimate"], pair["unit"], pair["samples"]) == ("F", "F", "N", len(time))
    assert close(pair["rmse"], OFFSET)
    assert close(pair["rmse"], rmse(estimate - truth))
    assert close(pair["correlation"], 1.0)
    assert pair["two_sigma_coverage"] == 1.0


ROS2_SCHEMA = """\
std_msgs/Header header
float64 load  # [N] load on mass 2
float64 load_std  # [N] its deviation
float64[3] position
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def test_a_ros2_bag_from_mcap_ros2_is_analysed_with_its_known_error(analyzer_bin, tmp_path):
    """CDR messages with a ros2msg schema (a std_msgs/Header stamp, float64
    fields, a fixed array), as `mcap_ros2.writer.Writer` writes a ROS 2 bag:
    the header is not a signal, load pairs with load, σ from load_std (ROS 2
    field names are lower case), and the report
    measures RMSE = OFFSET; the array's elements are signals of their own,
    paired by name too (position[i] exact: RMSE 0)."""
    time, truth, estimate = known_error_samples()
    path = tmp_path / "ros2.mcap"
    with open(path, "wb") as f:
        w = Ros2Writer(f)
        schema = w.register_msgdef("kalfmu_msgs/msg/Load", ROS2_SCHEMA)
        for k, (t, a, b) in enumerate(zip(time, truth, estimate)):
            ns = int(round(t * 1e9))
            # A stamp a second off log_time: the analyzer's time is log_time.
            header = {"stamp": {"sec": int(t) + 1, "nanosec": ns % 1_000_000_000}, "frame_id": "base_link"}
            position = [a, 2 * a, 3.0]
            for topic, value, std in (("/truth", a, 0.0), ("/estimate", b, STD)):
                message = {"header": header, "load": value, "load_std": std, "position": position}
                w.write_message(topic, schema, message, log_time=ns, publish_time=ns, sequence=k)
        w.finish()
    rep = report(analyzer_bin, path, tmp_path)
    pairs = {p["truth"]: p for p in rep["pairs"]}
    # load_std is on /truth too here, and paired by name like any namesake signal.
    assert set(pairs) == {"load", "load_std", "position[0]", "position[1]", "position[2]"}
    pair = pairs["load"]
    assert (pair["estimate"], pair["unit"], pair["samples"]) == ("load", "N", len(time))
    assert close(pair["rmse"], OFFSET)
    assert pair["two_sigma_coverage"] == 1.0
    assert pairs["position[1]"]["rmse"] == 0.0


def test_a_channel_in_an_encoding_the_analyzer_does_not_read_is_skipped_with_a_warning(analyzer_bin, tmp_path):
    """A protobuf channel beside JSON truth and estimates: `analyzer report`
    warns that it is skipped and why, then reports the others; as the only
    data it is an error naming the file and the reason."""
    time, truth, estimate = known_error_samples(n=50)
    path = tmp_path / "with_protobuf.mcap"
    only = tmp_path / "only_protobuf.mcap"
    for target, with_json in ((path, True), (only, False)):
        with open(target, "wb") as f:
            w = Writer(f)
            w.start(profile="", library="test_analyzer")
            proto = w.register_channel("/imu", "protobuf", w.register_schema("pkg.Imu", "protobuf", b""))
            if with_json:
                schema_id = w.register_schema("Load", "jsonschema", b'{"type": "object"}')
                ids = [w.register_channel(t, "json", schema_id) for t in ("/truth", "/estimate")]
            for k, (t, a, b) in enumerate(zip(time, truth, estimate)):
                ns = int(round(t * 1e9))
                w.add_message(proto, log_time=ns, data=b"\x08\x01", publish_time=ns)
                if with_json:
                    w.add_message(ids[0], log_time=ns, data=json.dumps({"x": a}).encode(), publish_time=ns)
                    w.add_message(ids[1], log_time=ns, data=json.dumps({"x": b}).encode(), publish_time=ns)
            w.finish()
    proc = subprocess.run([str(analyzer_bin), "report", str(path)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "warning: " in proc.stderr and "channel /imu is skipped: message encoding 'protobuf' is not read" in proc.stderr
    proc = subprocess.run([str(analyzer_bin), "report", str(only)], capture_output=True, text=True)
    assert proc.returncode == 1
    assert f"{only}: no channel can be read: /imu: message encoding 'protobuf' is not read" in proc.stderr
