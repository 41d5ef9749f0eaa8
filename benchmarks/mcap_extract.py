"""MCAP extraction: ``load_mcap`` against the floor of a plain library loop.

Writes a log of ``--messages`` ROS 2 ``std_msgs/msg/Float64`` messages (input and output
topics, half each, at identical 100 Hz time stamps) plus a bulky unrelated
``/camera/image`` topic (``sensor_msgs/msg/CompressedImage``, ``--image-kb`` of
incompressible bytes every ``--image-period`` seconds), then times, in the same run,

(a) ``pipeline.io.mcap.load_mcap`` extracting u and y (identical stamps: no resampling);
(b) the floor: a plain loop over ``mcap``'s reader with the ROS 2 decoder factory
    (``iter_decoded_messages(topics=...)``, default arguments) into Python lists -> numpy;
(b') the same loop with ``log_time_order=False`` (no ordering heap), for reference.

Every repetition of every variant runs in a fresh subprocess (variants interleaved); it
reports the wall time of the extraction and the growth of its peak RSS (``VmHWM`` reset
through ``/proc/self/clear_refs`` right before the call, minus ``VmRSS`` then). Memory is
compared with the extracted arrays ``t, u, y`` (3 x 8 bytes per sample). The log is
deleted at the end unless ``--keep``.

    python benchmarks/mcap_extract.py [--messages 1000000] [--reps 5] [--dir /tmp]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

INPUT, OUTPUT, CAMERA = "/lamp/cmd", "/plate/temp", "/camera/image"
RATE_HZ = 100.0
START_NS = 1_700_000_000_000_000_000
IMAGE_SCHEMA = """std_msgs/Header header
string format
uint8[] data
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
"""
VARIANTS = {"a": "load_mcap", "b": "floor (library loop)",
            "b_unordered": "floor, log_time_order=False"}


# -- the log ----------------------------------------------------------------------------


def cdr_float64(value: float) -> bytes:
    """A ``std_msgs/msg/Float64`` message in little-endian plain CDR."""
    return struct.pack("<4sd", b"\x00\x01\x00\x00", value)


def cdr_image(t_ns: int, payload: bytes) -> bytes:
    """A ``sensor_msgs/msg/CompressedImage`` in little-endian plain CDR."""

    def string(s: bytes, offset: int) -> bytes:
        body = struct.pack("<I", len(s) + 1) + s + b"\x00"
        pad = (-(offset + len(body))) % 4  # the next uint32 is 4-aligned
        return body + b"\x00" * pad

    out = bytearray(b"\x00\x01\x00\x00")
    out += struct.pack("<II", t_ns // 10**9, t_ns % 10**9)
    out += string(b"camera", len(out) - 4)
    out += string(b"jpeg", len(out) - 4)
    out += struct.pack("<I", len(payload)) + payload
    return bytes(out)


def write_log(path: Path, messages: int, image_kb: int, image_period: float) -> dict:
    """Write the benchmark log; returns what was written."""
    from mcap.writer import Writer

    n = messages // 2
    t_ns = START_NS + np.round(np.arange(n) * (1e9 / RATE_HZ)).astype(np.int64)
    rng = np.random.default_rng(0)
    u = np.where((np.arange(n) // 3000) % 2 == 0, 2.0, 5.0)
    y = 35.0 + 4.0 * (u - 2.0) + rng.normal(0.0, 0.05, n)
    every = max(1, round(image_period * RATE_HZ))
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="pipeline benchmarks/mcap_extract.py")
        scalar = w.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
        image = w.register_schema("sensor_msgs/msg/CompressedImage", "ros2msg",
                                  IMAGE_SCHEMA.encode())
        cu, cy = (w.register_channel(topic, "cdr", scalar) for topic in (INPUT, OUTPUT))
        cc = w.register_channel(CAMERA, "cdr", image)
        images = 0
        for k in range(n):
            tk = int(t_ns[k])
            w.add_message(cu, tk, cdr_float64(float(u[k])), tk)
            w.add_message(cy, tk, cdr_float64(float(y[k])), tk)
            if k % every == 0:
                w.add_message(cc, tk, cdr_image(tk, rng.bytes(image_kb * 1024)), tk)
                images += 1
        w.finish()
    return {"samples": n, "images": images, "bytes": path.stat().st_size,
            "checksum_u": float(u.sum()), "checksum_y": float(y.sum())}


# -- the variants (each in its own process) ---------------------------------------------


def variant_a(path: Path) -> tuple[np.ndarray, ...]:
    from pipeline.io.mcap import Signal, load_mcap

    rec = load_mcap(path, Signal(INPUT, "data"), Signal(OUTPUT, "data"))
    return rec.t, rec.u, rec.y


def variant_b(path: Path, log_time_order: bool = True) -> tuple[np.ndarray, ...]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    times: dict[str, list[int]] = {INPUT: [], OUTPUT: []}
    values: dict[str, list[float]] = {INPUT: [], OUTPUT: []}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(
                topics=[INPUT, OUTPUT], log_time_order=log_time_order):
            times[channel.topic].append(message.log_time)
            values[channel.topic].append(decoded.data)
    t_u = np.array(times[INPUT], dtype=np.int64)
    return t_u, np.array(values[INPUT]), np.array(values[OUTPUT])


def _status(key: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) * 1024
    raise KeyError(key)


def run_variant(name: str, path: Path) -> dict:
    """One timed, memory-measured extraction in this (fresh) process."""
    import mcap.reader  # noqa: F401 -- imports are not part of the measurement
    import mcap_ros2.decoder  # noqa: F401

    import pipeline.io.mcap  # noqa: F401

    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # reset VmHWM to the current RSS
    rss0 = _status("VmRSS:")
    t0 = time.perf_counter()
    if name == "a":
        arrays = variant_a(path)
    else:
        arrays = variant_b(path, log_time_order=(name == "b"))
    wall = time.perf_counter() - t0
    peak = _status("VmHWM:")
    n = int(arrays[1].size)
    return {"variant": name, "wall_s": wall, "rss_growth": peak - rss0, "samples": n,
            "array_bytes": 3 * 8 * n, "checksum_u": float(arrays[1].sum()),
            "checksum_y": float(arrays[2].sum())}


def spawn(name: str, path: Path) -> dict:
    out = subprocess.run([sys.executable, __file__, "--variant", name, "--path", str(path)],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


# -- report -----------------------------------------------------------------------------


def machine() -> str:
    cpu = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    ram = _meminfo_gb()
    return (f"{os.cpu_count()} CPUs (nproc), {cpu}, {ram:.0f} GB RAM, Python "
            f"{platform.python_version()}, {platform.system()} {platform.release()}")


def _meminfo_gb() -> float:
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) / 1024**2
    return float("nan")


def summarise(results: list[dict], written: dict) -> dict:
    by = {v: [r for r in results if r["variant"] == v] for v in VARIANTS}
    med = {v: statistics.median(r["wall_s"] for r in rs) for v, rs in by.items()}
    mem = {v: max(r["rss_growth"] for r in rs) for v, rs in by.items()}
    arrays = by["a"][0]["array_bytes"]
    for v, rs in by.items():
        for r in rs:
            assert r["samples"] == written["samples"], (v, r["samples"])
            assert abs(r["checksum_u"] - written["checksum_u"]) < 1e-6 * written["samples"]
            assert abs(r["checksum_y"] - written["checksum_y"]) < 1e-6 * written["samples"]
    return {"median_s": med, "peak_rss_growth": mem, "array_bytes": arrays,
            "ratio": med["a"] / med["b"], "ratio_unordered": med["a"] / med["b_unordered"],
            "walls": {v: [round(r["wall_s"], 3) for r in rs] for v, rs in by.items()}}


def print_report(s: dict, written: dict, args: argparse.Namespace) -> None:
    mb = 1024**2
    print(f"machine: {machine()}")
    print(f"log: {args.messages} Float64 messages ({written['samples']} per topic, 100 Hz) + "
          f"{written['images']} x {args.image_kb} KiB images = {written['bytes'] / mb:.0f} MiB")
    print(f"extracted arrays t, u, y: {s['array_bytes'] / mb:.1f} MiB")
    print(f"{'variant':34s} {'median s':>9s} {'peak RSS growth':>16s} {'x arrays':>9s}")
    for v, label in VARIANTS.items():
        g = s["peak_rss_growth"][v]
        print(f"{label:34s} {s['median_s'][v]:9.3f} {g / mb:12.1f} MiB "
              f"{g / s['array_bytes']:9.2f}")
    print(f"ratio (a)/(b) = {s['ratio']:.3f}; (a)/(b') = {s['ratio_unordered']:.3f}; "
          f"runs: {s['walls']}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--messages", type=int, default=1_000_000)
    p.add_argument("--image-kb", type=int, default=80)
    p.add_argument("--image-period", type=float, default=5.0)
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--dir", default=None, help="where to write the log (default: tmp)")
    p.add_argument("--keep", action="store_true")
    p.add_argument("--variant", help=argparse.SUPPRESS)
    p.add_argument("--path", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.variant:
        print(json.dumps(run_variant(args.variant, Path(args.path))))
        return
    path = Path(tempfile.mkdtemp(dir=args.dir)) / "bench.mcap"
    try:
        t0 = time.perf_counter()
        written = write_log(path, args.messages, args.image_kb, args.image_period)
        print(f"wrote {path} in {time.perf_counter() - t0:.1f} s")
        results = [spawn(v, path) for _ in range(args.reps) for v in VARIANTS]
        print_report(summarise(results, written), written, args)
    finally:
        if not args.keep:
            path.unlink(missing_ok=True)
            path.parent.rmdir()


if __name__ == "__main__":
    main()
