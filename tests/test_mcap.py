"""MCAP loader: fixtures written with the mcap writers from the synthetic plants.

The plant: K = 2.5, T = 7 s, input 1.5 -> 3.5 at t0 = 13.7 s from y0 = -4, small noise.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader
from mcap.writer import CompressionType, IndexType
from mcap.writer import Writer as McapWriter
from mcap_protobuf.writer import Writer as ProtobufWriter
from mcap_ros2.writer import Writer as Ros2Writer

from pipeline.errors import UserError
from pipeline.io.mcap import (
    Signal,
    format_inspect,
    inspect_mcap,
    load_mcap,
    parse_path,
    parse_signal,
)
from pipeline.methods import identify
from pipeline.models import ProcessModel
from pipeline.segmentation.detect import event_data
from pipeline.synth import staircase, step_record

PLANT = ProcessModel("first_order", {"K": 2.5, "T": 7.0})
U0, U1, T_STEP, Y0, NOISE = 1.5, 3.5, 13.7, -4.0, 0.01
BASE_NS = 1_700_000_000_123_000_000
FLOAT64 = "float64 data"
HEADER = """================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
"""
TEMPERATURE = "std_msgs/Header header\nfloat64 value\n" + HEADER
COMMAND = "std_msgs/Header header\nfloat64 data\n" + HEADER
JOINTS = "std_msgs/Header header\nstring[] name\nfloat64[] position\n" + HEADER

Event = tuple[int, str, object]  # (log time ns, topic, payload)
RAW = b"raw:"  # a payload written as these bytes, not as JSON


# -- helpers ----------------------------------------------------------------------------


def truth(dt: float = 0.1, t_end: float = 70.0):
    return step_record(PLANT, u0=U0, changes=[(T_STEP, U1)], t_end=t_end, dt=dt, y0=Y0,
                       noise=NOISE, seed=3)


def log_ns(t: float) -> int:
    return BASE_NS + round(t * 1e9)


def stamp(t_ns: int) -> dict:
    return {"stamp": {"sec": t_ns // 10**9, "nanosec": t_ns % 10**9}, "frame_id": "plate"}


def first_order(t, u, y) -> tuple[float, float]:
    fit = identify(event_data(t, u, y, initial_input=U0), "first_order")
    assert fit.ok, fit.reason
    return fit.model.params["K"], fit.model.params["T"]


def csv_first_order(tmp_path: Path, t, u, y) -> tuple[float, float]:
    """Identification from the CSV export of the same samples, read back with polars."""
    csv = tmp_path / "export.csv"
    pl.DataFrame({"t": t, "u": u, "y": y}).write_csv(csv)
    df = pl.read_csv(csv)
    return first_order(*(df[c].to_numpy() for c in ("t", "u", "y")))


def write_json(path: Path, events: list[Event], *, encodings: dict[str, str] | None = None,
               **writer_options) -> Path:
    """JSON channels (no schema) with the plain mcap writer; ``encodings`` overrides the
    message encoding of a topic; ``None`` payloads register the channel only."""
    with open(path, "wb") as f:
        w = McapWriter(f, **writer_options)
        w.start()
        ids: dict[str, int] = {}
        for t, topic, payload in sorted(events, key=lambda e: e[0]):
            if topic not in ids:
                enc = (encodings or {}).get(topic, "json")
                ids[topic] = w.register_channel(topic, enc, schema_id=0)
            if isinstance(payload, bytes) and payload.startswith(RAW):
                w.add_message(ids[topic], t, payload[len(RAW):], t)
            elif payload is not None:
                w.add_message(ids[topic], t, json.dumps(payload).encode(), t)
        w.finish()
    return path


def write_ros2(path: Path, events: list[Event], schemas: dict[str, tuple[str, str]],
               **writer_options) -> Path:
    """ROS 2 CDR messages; ``schemas`` maps a topic to (type name, ros2msg text)."""
    with open(path, "wb") as f:
        w = Ros2Writer(f, **writer_options)
        registered = {topic: w.register_msgdef(*s) for topic, s in schemas.items()}
        for t, topic, payload in sorted(events, key=lambda e: e[0]):
            w.write_message(topic, registered[topic], payload, log_time=t)
        w.finish()
    return path


def proto_classes() -> dict[str, type]:
    """Protobuf classes built at runtime from a FileDescriptorProto."""
    F = descriptor_pb2.FieldDescriptorProto
    fdp = descriptor_pb2.FileDescriptorProto(name="plant_test.proto", package="plant",
                                             syntax="proto3")
    time = fdp.message_type.add(name="Time")
    time.field.add(name="sec", number=1, type=F.TYPE_INT64, label=F.LABEL_OPTIONAL)
    time.field.add(name="nanosec", number=2, type=F.TYPE_UINT32, label=F.LABEL_OPTIONAL)
    sample = fdp.message_type.add(name="Sample")
    sample.field.add(name="stamp", number=1, type=F.TYPE_MESSAGE, type_name=".plant.Time",
                     label=F.LABEL_OPTIONAL)
    sample.field.add(name="value", number=2, type=F.TYPE_DOUBLE, label=F.LABEL_OPTIONAL)
    sample.field.add(name="xs", number=3, type=F.TYPE_DOUBLE, label=F.LABEL_REPEATED)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(fdp)
    return {n: message_factory.GetMessageClass(pool.FindMessageTypeByName(f"plant.{n}"))
            for n in ("Time", "Sample")}


def write_protobuf(path: Path, events: list[Event]) -> Path:
    cls = proto_classes()["Sample"]
    with open(path, "wb") as f, ProtobufWriter(f) as w:
        for t, topic, value in sorted(events, key=lambda e: e[0]):
            w.write_message(topic, cls(value=value, xs=[value, -value]), log_time=t,
                            publish_time=t)
    return path


def same_stamp_events(rec, payload: Callable[[float], object]) -> list[Event]:
    ev: list[Event] = []
    for t, u, y in zip(rec.t, rec.u, rec.y, strict=True):
        ev += [(log_ns(t), "/u", payload(u)), (log_ns(t), "/y", payload(y))]
    return ev


def json_file(tmp_path: Path, rec=None, **options) -> Path:
    rec = rec if rec is not None else truth()
    return write_json(tmp_path / "log.mcap", same_stamp_events(rec, lambda v: {"data": v}),
                      **options)


# -- (1) identical time stamps: same samples, same identification as the CSV ------------


def _same_stamp_file(tmp_path: Path, encoding: str, rec) -> tuple[Path, Signal, Signal]:
    path = tmp_path / f"{encoding}.mcap"
    if encoding == "json":
        write_json(path, same_stamp_events(rec, lambda v: {"data": v}))
        return path, Signal("/u", "data"), Signal("/y", "data")
    if encoding == "ros2":
        write_ros2(path, same_stamp_events(rec, lambda v: {"data": v}),
                   {"/u": ("std_msgs/msg/Float64", FLOAT64),
                    "/y": ("std_msgs/msg/Float64", FLOAT64)})
        return path, Signal("/u", "data"), Signal("/y", "data")
    write_protobuf(path, same_stamp_events(rec, float))
    return path, Signal("/u", "value"), Signal("/y", "xs[0]")


@pytest.mark.parametrize("encoding", ["json", "ros2", "protobuf"])
def test_same_stamps_identify_like_the_csv(tmp_path, encoding):
    rec = truth()
    path, inp, out = _same_stamp_file(tmp_path, encoding, rec)
    got = load_mcap(path, inp, out, initial_input=U0)
    np.testing.assert_allclose(got.t, rec.t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got.u, rec.u)
    np.testing.assert_array_equal(got.y, rec.y)
    assert got.sample_time == pytest.approx(0.1)
    assert got.notes == ("t = 0 is log time 1700000000.123000000 s",)
    assert (got.input_name, got.output_name, got.source) == (str(inp), str(out), str(path))
    K, T = first_order(got.t, got.u, got.y)
    K_csv, T_csv = csv_first_order(tmp_path, rec.t, rec.u, rec.y)
    assert K == pytest.approx(K_csv, rel=1e-9) and T == pytest.approx(T_csv, rel=1e-9)
    assert K == pytest.approx(2.5, rel=0.02) and T == pytest.approx(7.0, rel=0.03)


def test_same_topic_two_fields(tmp_path):
    rec = truth()
    events = [(log_ns(t), "/plant", {"cmd": u, "meas": {"y": y}})
              for t, u, y in zip(rec.t, rec.u, rec.y, strict=True)]
    path = write_json(tmp_path / "one.mcap", events)
    got = load_mcap(path, Signal("/plant", "cmd"), Signal("/plant", "meas.y"))
    np.testing.assert_array_equal(got.y, rec.y)
    np.testing.assert_array_equal(got.u, rec.u)


# -- (2) different rates, jitter: aligned on a grid --------------------------------------


def test_different_rates_within_one_percent(tmp_path):
    ref = truth(dt=0.05)
    K_ref, T_ref = first_order(ref.t, ref.u, ref.y)
    rng = np.random.default_rng(7)
    t_in = np.union1d(np.arange(0, 70.0001, 0.2), [T_STEP])  # 5 Hz and on change
    u_in = staircase(t_in, U0, [(T_STEP, U1)])
    t_out = ref.t + rng.uniform(-0.01, 0.01, ref.t.size)  # 20 Hz with jitter
    y_out = Y0 + (U1 - U0) * PLANT.unit_step(t_out - T_STEP) + rng.normal(0, NOISE, t_out.size)
    events = [(log_ns(t), "/lamp/cmd", {"data": u}) for t, u in zip(t_in, u_in, strict=True)]
    events += [(log_ns(t), "/plate/temp", {"header": stamp(log_ns(t)), "value": y})
               for t, y in zip(t_out, y_out, strict=True)]
    path = write_ros2(tmp_path / "rates.mcap", events,
                      {"/lamp/cmd": ("std_msgs/msg/Float64", FLOAT64),
                       "/plate/temp": ("plant_msgs/msg/Temperature", TEMPERATURE)})
    got = load_mcap(path, Signal("/lamp/cmd", "data"), Signal("/plate/temp", "value"),
                    initial_input=U0)
    assert got.sample_time == pytest.approx(0.05)
    assert any("resampled onto a uniform grid of 0.05 s" in n for n in got.notes)
    assert not any("gap" in n for n in got.notes)
    K, T = first_order(got.t, got.u, got.y)
    assert K == pytest.approx(K_ref, rel=0.01) and T == pytest.approx(T_ref, rel=0.01)
    coarse = load_mcap(path, Signal("/lamp/cmd", "data"), Signal("/plate/temp", "value"),
                       sample_time=0.5)
    assert coarse.sample_time == pytest.approx(0.5)


def test_gap_is_reported(tmp_path):
    rec = truth()
    keep = (rec.t < 30) | (rec.t > 36.05)  # the output misses 6 s
    events = [(log_ns(t), "/u", {"data": u}) for t, u in zip(rec.t, rec.u, strict=True)]
    events += [(log_ns(t), "/y", {"data": y})
               for t, y in zip(rec.t[keep], rec.y[keep], strict=True)]
    path = write_json(tmp_path / "gap.mcap", events)
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"))
    gaps = [n for n in got.notes if n.startswith("gap in output /y:data")]
    assert len(gaps) == 1 and "6.2 s from t = 29.9 s" in gaps[0], got.notes
    assert "interpolated" in gaps[0]
    quiet = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"), max_gap=10.0)
    assert not any(n.startswith("gap") for n in quiet.notes)


# -- (3) header stamps as the time base --------------------------------------------------


def test_header_stamp_time_base(tmp_path):
    rec = truth()
    rng = np.random.default_rng(11)
    events: list[Event] = []
    for t, u, y in zip(rec.t, rec.u, rec.y, strict=True):
        s = log_ns(t)
        lat_u, lat_y = rng.integers(1_000_000, 60_000_000, 2)  # 1..60 ms latency
        events += [(s + int(lat_u), "/lamp/cmd", {"header": stamp(s), "data": u}),
                   (s + int(lat_y), "/plate/temp", {"header": stamp(s), "value": y})]
    path = write_ros2(tmp_path / "stamped.mcap", events,
                      {"/lamp/cmd": ("plant_msgs/msg/Command", COMMAND),
                       "/plate/temp": ("plant_msgs/msg/Temperature", TEMPERATURE)})
    inp, out = Signal("/lamp/cmd", "data"), Signal("/plate/temp", "value")
    got = load_mcap(path, inp, out, stamp="header.stamp", initial_input=U0)
    np.testing.assert_allclose(got.t, rec.t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got.y, rec.y)
    assert got.notes == ("t = 0 is header stamp 1700000000.123000000 s",)
    K, T = first_order(got.t, got.u, got.y)
    K_csv, T_csv = csv_first_order(tmp_path, rec.t, rec.u, rec.y)
    assert K == pytest.approx(K_csv, rel=1e-9) and T == pytest.approx(T_csv, rel=1e-9)
    by_log_time = load_mcap(path, inp, out)
    assert any("resampled" in n for n in by_log_time.notes)


def _stamped_events(rec, latency_ms: tuple[int, int], reset_at: float | None = None,
                    seed: int = 12) -> list[Event]:
    """Messages stamped at their sample times, logged ``latency_ms`` later; from
    ``reset_at`` on, the stamp clock restarts 30 s earlier (a second recording)."""
    rng = np.random.default_rng(seed)
    events: list[Event] = []
    for t, u, y in zip(rec.t, rec.u, rec.y, strict=True):
        s = log_ns(t)
        st = s - 30 * 10**9 if reset_at is not None and t >= reset_at else s
        lat_u, lat_y = rng.integers(latency_ms[0] * 10**6, latency_ms[1] * 10**6, 2)
        events += [(s + int(lat_u), "/u", {"header": stamp(st), "data": u}),
                   (s + int(lat_y), "/y", {"header": stamp(st), "data": y})]
    return events


def test_stamps_that_jump_back_are_refused_not_interleaved(tmp_path):
    """The stamp clock restarts 30 s back halfway (two recordings in one file): sorting
    would interleave them into one record (issue 31). Refused, naming the signal, the
    jump and the message; with the log time the same file loads."""
    rec = truth()
    path = write_json(tmp_path / "two.mcap", _stamped_events(rec, (1, 20), reset_at=35.0))
    with pytest.raises(UserError) as exc:
        load_mcap(path, Signal("/u", "data"), Signal("/y", "data"), stamp="header.stamp")
    msg = exc.value.message
    assert ("input /u:data: its header stamps jump back by 29.9 s at message 351 of 701 "
            "finite ones") in msg
    assert "omit stamp" in msg and "\n" not in msg
    assert load_mcap(path, Signal("/u", "data"), Signal("/y", "data")).n_samples > 600


def test_stamps_a_little_out_of_order_are_sorted_with_a_note(tmp_path):
    """Latencies of 1-250 ms on a 0.1 s grid: messages arrive behind a later stamp by up
    to a quarter of a second; sorted, with a note, the record as logged."""
    rec = truth()
    path = write_json(tmp_path / "late.mcap", _stamped_events(rec, (1, 250)))
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"), stamp="header.stamp")
    np.testing.assert_array_equal(got.y, rec.y)
    np.testing.assert_allclose(got.t, rec.t, rtol=0, atol=1e-12)
    late = [n for n in got.notes if "arrived behind a later header stamp" in n]
    assert len(late) == 2 and all("sorted by time" in n for n in late), got.notes


def test_stamp_fallback_and_float_seconds(tmp_path):
    rec = truth()
    events = [(log_ns(t) + 5_000_000, "/u", {"data": u})
              for t, u in zip(rec.t, rec.u, strict=True)]
    events += [(log_ns(t) + 9_000_000, "/y", {"t": log_ns(t) / 1e9, "data": y})
               for t, y in zip(rec.t, rec.y, strict=True)]
    path = write_json(tmp_path / "mixed.mcap", events)
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"), stamp="t")
    assert any("input /u:data: the topic has no stamp 't'; its log time is used" in n
               for n in got.notes)
    with pytest.raises(UserError, match="stamp 'header.stamp' found in neither topic"):
        load_mcap(path, Signal("/u", "data"), Signal("/y", "data"), stamp="header.stamp")


# -- (4) array elements ------------------------------------------------------------------


def test_array_index_fields(tmp_path):
    rec = truth()
    events = [(log_ns(t), "/cmd", {"header": stamp(log_ns(t)), "name": ["a", "b", "c"],
                                   "position": [0.0, -1.0, u]})
              for t, u in zip(rec.t, rec.u, strict=True)]
    events += [(log_ns(t), "/meas", {"header": stamp(log_ns(t)), "name": ["a", "b"],
                                     "position": [y, 0.0]})
               for t, y in zip(rec.t, rec.y, strict=True)]
    path = write_ros2(tmp_path / "joints.mcap", events,
                      {"/cmd": ("sensor_msgs/msg/JointState", JOINTS),
                       "/meas": ("sensor_msgs/msg/JointState", JOINTS)})
    got = load_mcap(path, parse_signal("/cmd:position[2]"), parse_signal("/meas:position[0]"))
    np.testing.assert_array_equal(got.u, rec.u)
    np.testing.assert_array_equal(got.y, rec.y)
    nested = [(log_ns(t), "/s", {"readings": [{"value": 0}, {"value": v}]})
              for t, v in zip(rec.t, rec.y, strict=True)]
    nested += [(log_ns(t), "/c", {"data": u}) for t, u in zip(rec.t, rec.u, strict=True)]
    got = load_mcap(write_json(tmp_path / "nested.mcap", nested), Signal("/c", "data"),
                    Signal("/s", "readings[1].value"))
    np.testing.assert_array_equal(got.y, rec.y)


def test_parse_signal_and_path():
    assert parse_signal("/plate/temp:temperature.value") == Signal("/plate/temp",
                                                                  "temperature.value")
    assert parse_signal("ns:/a:b[3].c") == Signal("ns:/a", "b[3].c")
    assert parse_path("a.b[2][0].c") == ("a", "b", 2, 0, "c")
    for bad in ("/lamp/cmd", ":data", "/a:", "/a:b..c", "/a:b[x]", "/a:b["):
        with pytest.raises(UserError, match="expected TOPIC:FIELD"):
            parse_signal(bad)


# -- (6) inspect -------------------------------------------------------------------------


def _inspect_fixture(tmp_path: Path, **writer_options) -> Path:
    events: list[Event] = []
    for k in range(40):
        t = log_ns(0.25 * k)
        events.append((t, "/lamp/cmd", {"data": 1.0}))
        if k % 2 == 0:
            events.append((t + 1000, "/plate/temp", {"header": stamp(t), "value": 20.0}))
    return write_ros2(tmp_path / "inspect.mcap", events,
                      {"/lamp/cmd": ("std_msgs/msg/Float64", FLOAT64),
                       "/plate/temp": ("plant_msgs/msg/Temperature", TEMPERATURE)},
                      **writer_options)


def test_inspect_lists_topics_counts_fields(tmp_path):
    info = inspect_mcap(_inspect_fixture(tmp_path))
    topics = {t["topic"]: t for t in info["topics"]}
    assert info["indexed"] and info["message_count"] == 60 and not info["notes"]
    assert topics["/lamp/cmd"]["count"] == 40 and topics["/plate/temp"]["count"] == 20
    assert topics["/lamp/cmd"]["fields"] == ["data"]
    assert topics["/plate/temp"]["fields"] == ["header.stamp.sec", "header.stamp.nanosec",
                                               "value"]
    assert topics["/plate/temp"]["schema"] == "plant_msgs/msg/Temperature"
    assert topics["/lamp/cmd"]["message_encoding"] == "cdr"
    assert topics["/lamp/cmd"]["rate_hz"] == pytest.approx(4.0)
    assert info["start"] == pytest.approx(1_700_000_000.123)
    assert info["duration"] == pytest.approx(9.75, abs=1e-5)
    from rich.console import Console

    console = Console(record=True, width=200)
    console.print(format_inspect(info))
    text = console.export_text()
    assert "/plate/temp" in text and "header.stamp.sec" in text and "40" in text


def test_inspect_unindexed_and_json(tmp_path):
    rec = truth()
    path = json_file(tmp_path, rec, index_types=IndexType.NONE)
    info = inspect_mcap(path)
    assert not info["indexed"] and "sequential scan" in info["notes"][0]
    assert {t["topic"]: (t["count"], t["fields"]) for t in info["topics"]} == {
        "/u": (rec.n_samples, ["data"]), "/y": (rec.n_samples, ["data"])}


# -- (7) errors name the file, the topic and the field -----------------------------------


def _truncated(tmp_path: Path) -> Path:
    path = json_file(tmp_path)
    path.write_bytes(path.read_bytes()[:40])
    return path


def _not_mcap(tmp_path: Path) -> Path:
    path = tmp_path / "log.mcap"
    path.write_text("t,u,y\n0,1,2\n")
    return path


def _with_status(tmp_path: Path) -> Path:
    rec = truth()
    events = same_stamp_events(rec, lambda v: {"data": v, "label": "ok"})
    events += [(log_ns(0), "/empty", None), (log_ns(0), "/cbor", "x"),
               (log_ns(0), "/bad", {"data": 1.0}), (log_ns(1), "/bad", RAW + b"{bad")]
    return write_json(tmp_path / "log.mcap", events, encodings={"/cbor": "cbor"})


ERRORS = [
    ("truncated", _truncated, "/u", "data",
     ["log.mcap", "input /u:data", "output /y:data", "truncated or damaged"]),
    ("not mcap", _not_mcap, "/u", "data", ["log.mcap", "not an MCAP file"]),
    ("missing topic", _with_status, "/nope", "data",
     ["log.mcap", "topic '/nope' field 'data' (input)", "not found",
      "/bad, /cbor, /empty, /u, /y"]),
    ("wrong field", _with_status, "/u", "dta",
     ["log.mcap", "topic '/u' field 'dta'", "no 'dta' in the message (it has: data, label)"]),
    ("non-numeric", _with_status, "/u", "label",
     ["log.mcap", "topic '/u' field 'label'", "is str ('ok'), expected a number"]),
    ("empty topic", _with_status, "/empty", "data",
     ["log.mcap", "topic '/empty' field 'data'", "no messages"]),
    ("undecodable message", _with_status, "/bad", "data",
     ["log.mcap", "topic '/bad' field 'data'", "could not be decoded as json"]),
    ("unknown encoding", _with_status, "/cbor", "data",
     ["log.mcap", "topic '/cbor' field 'data'", "message encoding 'cbor'", "not supported"]),
]


@pytest.mark.parametrize("case", ERRORS, ids=[e[0] for e in ERRORS])
def test_errors_are_one_line_user_errors(tmp_path, case):
    _, make, topic, fld, expected = case
    path = make(tmp_path)
    with pytest.raises(UserError) as info:
        load_mcap(path, Signal(topic, fld), Signal("/y", "data"))
    message = info.value.message
    assert "\n" not in message and str(path) in message
    for text in expected:
        assert text in message, message


def test_wrong_nested_field_lists_numeric_fields(tmp_path):
    path = _inspect_fixture(tmp_path)
    with pytest.raises(UserError) as info:
        load_mcap(path, Signal("/lamp/cmd", "data"), Signal("/plate/temp", "header.stamp.s"))
    assert ("topic '/plate/temp' field 'header.stamp.s' (output): no 's' in header.stamp "
            "(it has: sec, nanosec); expected a numeric field, e.g. header.stamp.sec, "
            "header.stamp.nanosec, value") in info.value.message


def test_bad_options(tmp_path):
    path = json_file(tmp_path)
    with pytest.raises(UserError, match="sample_time = -1"):
        load_mcap(path, Signal("/u", "data"), Signal("/y", "data"), sample_time=-1)
    with pytest.raises(UserError, match="cannot open"):
        load_mcap(tmp_path / "none.mcap", Signal("/u", "data"), Signal("/y", "data"))


# -- (8) logs without an index, cut off logs --------------------------------------------


def _summary_start(path: Path) -> int:
    with open(path, "rb") as f:
        reader = make_reader(f)
        reader.get_summary()
        f.seek(-(8 + 29), 2)  # footer record (1 + 8 + 20 bytes) + magic
        data = f.read(29)
    return int.from_bytes(data[9:17], "little")


@pytest.mark.parametrize("how", ["no index", "summary cut off"])
def test_unindexed_file_is_scanned(tmp_path, how):
    rec = truth()
    if how == "no index":
        path = json_file(tmp_path, rec, index_types=IndexType.NONE)
    else:
        path = json_file(tmp_path, rec)
        path.write_bytes(path.read_bytes()[:_summary_start(path)])
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"))
    np.testing.assert_array_equal(got.y, rec.y)
    scan = [n for n in got.notes if "sequential scan" in n]
    assert len(scan) == 1 and got.source == str(path)
    assert any("damaged or cut off" in n for n in got.notes) == (how == "summary cut off")


def test_truncated_in_a_chunk_keeps_the_complete_part(tmp_path):
    rec = truth()
    path = json_file(tmp_path, rec, chunk_size=4096)
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * 0.7)])
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"))
    n = got.n_samples
    assert 0.4 * rec.n_samples < n < 0.8 * rec.n_samples
    np.testing.assert_array_equal(got.y, rec.y[:n])
    assert any("damaged or cut off" in note for note in got.notes)
    assert any("no summary or index" in note for note in got.notes)


def test_damaged_chunk_is_skipped_with_a_note(tmp_path):
    rec = truth()
    path = json_file(tmp_path, rec, chunk_size=4096, compression=CompressionType.NONE)
    with open(path, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    bad = chunks[len(chunks) // 2]
    data = bytearray(path.read_bytes())
    middle = bad.chunk_start_offset + bad.chunk_length // 2
    data[middle:middle + 8] = b"\xff" * 8
    path.write_bytes(bytes(data))
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"))
    assert 0.7 * rec.n_samples < got.n_samples < rec.n_samples
    assert any(f"chunk at byte {bad.chunk_start_offset}" in n for n in got.notes), got.notes
    assert any(n.startswith("gap in input /u:data and output /y:data") for n in got.notes)


@pytest.mark.parametrize("flip, where", [(True, "middle"), (True, "first"), (False, "")])
def test_a_flipped_bit_in_a_crash_cut_log_is_never_data(tmp_path, flip, where):
    """A log cut off by a crash (no summary: read by the sequential scan) with one digit
    of one output value changed inside a chunk: that chunk's CRC fails, so it is skipped
    with a note and the value never reaches the record (it was read as data before:
    issue 31). In the first chunk, which defines the channels, the channels are still
    taken from it and the later chunks read. The twin without the flip reads every
    sample, with no damaged chunk."""
    rec = truth()
    path = json_file(tmp_path, rec, chunk_size=4096, compression=CompressionType.NONE)
    with open(path, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    bad = chunks[0 if where == "first" else len(chunks) // 2]
    data = bytearray(path.read_bytes()[:_summary_start(path)])
    if flip:
        at = data.index(b'{"data": ', bad.chunk_start_offset + 100) + len(b'{"data": ')
        end = data.index(b"}", at)
        value = float(data[at:end])
        digit = next(i for i in range(at, end) if data[i:i + 1].isdigit() and i > at + 1)
        data[digit] = ord("7") if data[digit] != ord("7") else ord("3")
        flipped = float(data[at:end])
        assert flipped != value and (value in rec.y or value in rec.u)
    path.write_bytes(bytes(data))
    got = load_mcap(path, Signal("/u", "data"), Signal("/y", "data"))
    damaged = [n for n in got.notes if "chunk" in n and "CRC" in n]
    if flip:
        assert flipped not in got.y and flipped not in got.u
        assert 0.7 * rec.n_samples < got.n_samples < rec.n_samples
        assert len(damaged) == 1, got.notes
        if where == "middle":  # (the first chunk gone, the two series start apart and
            assert set(got.y) <= set(rec.y)  # y is interpolated to u's first stamp)
    else:
        np.testing.assert_array_equal(got.y, rec.y)
        assert not damaged, got.notes


# -- the example log ---------------------------------------------------------------------


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(f).iter_messages()]


def test_example_log(tmp_path):
    from pipeline.synth.mcap_example import EXAMPLE, write_example_mcap

    path = write_example_mcap(tmp_path / "lamp_plate.mcap")
    assert path.stat().st_size < 100_000
    committed = Path(__file__).resolve().parent.parent / "datasets/examples/lamp_plate.mcap"
    assert _messages(committed) == _messages(path)  # the committed file is this function's
    rec = load_mcap(path, Signal(*EXAMPLE["input"]), Signal(*EXAMPLE["output"]),
                    sample_time=0.5, max_gap=5.0, initial_input=EXAMPLE["u0"])
    assert not any(n.startswith("gap") for n in rec.notes)
    fit = identify(event_data(rec.t, rec.u, rec.y,
                                         initial_input=EXAMPLE["u0"]), "first_order")
    p = fit.model.params
    assert math.isclose(p["K"], EXAMPLE["K"], rel_tol=0.03)
    assert math.isclose(p["T"] + p["delay"], EXAMPLE["T"] + EXAMPLE["delay"], rel_tol=0.05)
