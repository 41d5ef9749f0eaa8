"""Loading a CSV log: ``pipeline.load`` against a bare ``polars.read_csv`` (issue 14.1, 14.6).

Writes t,u,y CSV logs of ``--rows`` (default 1 M and 10 M rows; the 10 M one is about
400 MB) into a temporary folder, then measures, interleaved, every repetition in a fresh
subprocess (imports, and a first read of a 1000-row log, done before the measurement):

(a) ``pipeline.load(path, input="u", output="y", time="t")`` -> a Record;
(b) the floor: ``polars.read_csv(path)`` (inference on its default 100 rows);
(c) for reference, (b) and then ``to_numpy()`` of its columns (polars reads a column in
    pieces, one per thread's share of the file: contiguous arrays take one copy).

Per run: CPU time (``time.process_time``, all threads) and wall time of the call; the
growth of the peak RSS (``VmHWM`` reset through ``/proc/self/clear_refs`` just before the
call, minus ``VmRSS`` then), which includes the file's pages that polars maps; and the
growth of the peak anonymous memory (``RssAnon`` sampled every millisecond by a thread, in
separate memory runs so that the sampler does not touch the timings), which is what the
process itself allocates. Memory is compared with the raw arrays t, u, y (24 bytes a row).

    python benchmarks/load_speed.py [--rows 1000000 10000000] [--reps 5] [--mem-reps 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CHILD = r"""
import json, sys, threading, time
import polars as pl
import pipeline
import pipeline.api

variant, path, sample, warm = sys.argv[1], sys.argv[2], sys.argv[3] == "1", sys.argv[4]
# imports and first-call set-up (pydantic models, polars' thread pool) outside the
# measurement: both variants read a 1000-row copy of the log first
pipeline.load(warm, input="u", output="y", time="t") if variant == "load" else pl.read_csv(warm)

def status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) * 1024
    return 0

peak = [0]
stop = threading.Event()
def sampler():
    while not stop.is_set():
        peak[0] = max(peak[0], status("RssAnon:"))
        time.sleep(0.001)

with open("/proc/self/clear_refs", "w") as f:
    f.write("5")
rss0, anon0 = status("VmRSS:"), status("RssAnon:")
if sample:
    thread = threading.Thread(target=sampler, daemon=True)
    thread.start()
cpu, wall = time.process_time(), time.perf_counter()
if variant == "load":
    out = pipeline.load(path, input="u", output="y", time="t")
    rows = out.n_samples
elif variant == "numpy":
    out = pl.read_csv(path)
    arrays = [out[c].to_numpy() for c in out.columns]
    rows = arrays[0].size
else:
    out = pl.read_csv(path)
    rows = out.height
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
if sample:
    stop.set()
    thread.join()
peak[0] = max(peak[0], status("RssAnon:"))
print(json.dumps({"cpu": cpu, "wall": wall, "hwm": status("VmHWM:") - rss0,
                  "anon": peak[0] - anon0 if sample else None, "rows": rows}))
"""

VARIANTS = {"load": "pipeline.load", "bare": "bare pl.read_csv",
            "numpy": "read_csv + to_numpy"}


def write_log(path: Path, rows: int) -> None:
    """A step test: 10 Hz, a step every 2000 s, a first-order response with noise."""
    import polars as pl

    t = np.arange(rows) * 0.1
    u = np.floor(t / 2000.0) % 2
    rng = np.random.default_rng(0)
    y = 2.0 * u + rng.normal(0.0, 0.01, rows)
    pl.DataFrame({"t": t, "u": u, "y": y}).write_csv(path)


def run(variant: str, path: Path, sample: bool) -> dict:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    warm = path.with_name("warm.csv")
    out = subprocess.run([sys.executable, "-c", CHILD, variant, str(path), str(int(sample)),
                          str(warm)],
                         capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[1_000_000, 10_000_000])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--mem-reps", type=int, default=2)
    ap.add_argument("--dir", default=None)
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} CPUs, {platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()}, load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        for rows in args.rows:
            path = Path(tmp) / f"log_{rows}.csv"
            write_log(path, rows)
            write_log(path.with_name("warm.csv"), 1000)
            raw = 24 * rows
            size = path.stat().st_size
            times: dict[str, list[dict]] = {v: [] for v in VARIANTS}
            mems: dict[str, list[dict]] = {v: [] for v in VARIANTS}
            for _ in range(args.reps):
                for v in VARIANTS:
                    times[v].append(run(v, path, sample=False))
            for _ in range(args.mem_reps):
                for v in VARIANTS:
                    mems[v].append(run(v, path, sample=True))
            print(f"\n{rows:,} rows, file {size / 2**20:.0f} MiB, raw t,u,y arrays "
                  f"{raw / 2**20:.0f} MiB; {args.reps} timing and {args.mem_reps} memory "
                  "runs per variant, interleaved")
            med = {v: {k: statistics.median(r[k] for r in times[v]) for k in ("cpu", "wall")}
                   for v in VARIANTS}
            for v, label in VARIANTS.items():
                cpus = ", ".join(f"{r['cpu']:.2f}" for r in times[v])
                hwm = max(r["hwm"] for r in mems[v])
                anon = max(r["anon"] for r in mems[v])
                print(f"  {label:18s} CPU {med[v]['cpu']:.3f} s  wall {med[v]['wall']:.3f} s"
                      f"  (CPU runs: {cpus})"
                      f"  peak RSS +{hwm / 2**20:.0f} MiB ({hwm / raw:.2f}x raw)"
                      f"  peak anon +{anon / 2**20:.0f} MiB ({anon / raw:.2f}x raw)")
            print(f"  ratio load/bare: CPU {med['load']['cpu'] / med['bare']['cpu']:.2f}, "
                  f"wall {med['load']['wall'] / med['bare']['wall']:.2f}")


if __name__ == "__main__":
    main()
