"""Loading a closed-loop CSV log with its setpoint (issue 32): ``pipeline.load`` with
``setpoint="r"`` against the same load without it, on the same file.

The setpoint is read by loading the file a second time with the setpoint as its input
(``pipeline/io/__init__.py::_with_setpoint``: every format and every quirk policy apply to
it as to the input, at the price of a second read). Writes a t,r,u,y CSV of ``--rows``
rows, then measures, interleaved, each repetition in a fresh subprocess (imports and a
1000-row warm-up read first): CPU time of the call and the growth of the peak RSS
(``VmHWM`` reset through ``/proc/self/clear_refs`` just before it).

    python benchmarks/setpoint_load.py [--rows 1000000] [--reps 5]
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
import json, re, sys, time
import pipeline

with_sp, path, warm = sys.argv[1] == "1", sys.argv[2], sys.argv[3]
keys = {"input": "u", "output": "y", "time": "t", **({"setpoint": "r"} if with_sp else {})}
pipeline.load(warm, **keys)

def kib(field):  # a /proc/self/status field, in bytes
    text = open("/proc/self/status").read()
    return int(re.search(field + r":\s+(\d+)", text).group(1)) * 1024

open("/proc/self/clear_refs", "w").write("5")  # the peak (VmHWM) from here
rss0 = kib("VmRSS")
cpu = time.process_time()
rec = pipeline.load(path, **keys)
cpu = time.process_time() - cpu
print(json.dumps({"cpu": cpu, "hwm": kib("VmHWM") - rss0, "rows": rec.n_samples,
                  "r": rec.r is not None}))
"""


def write_log(path: Path, rows: int) -> None:
    """A PI loop's log shape: 10 Hz, a setpoint step every 2000 s, noise on everything."""
    import polars as pl

    t = np.arange(rows) * 0.1
    r = 50.0 + 5.0 * (np.floor(t / 2000.0) % 2)
    rng = np.random.default_rng(0)
    y = r + rng.normal(0.0, 0.05, rows)
    u = 25.0 + 2.5 * (r - y)
    pl.DataFrame({"t": t, "r": r, "u": u, "y": y}).write_csv(path)


def run(with_sp: bool, path: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1]),
           "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", CHILD, str(int(with_sp)), str(path),
                          str(path.with_name("warm.csv"))],
                         capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "loop.csv"
        write_log(path, a.rows)
        write_log(path.with_name("warm.csv"), 1000)
        runs: dict[bool, list[dict]] = {False: [], True: []}
        for _ in range(a.reps):
            for with_sp in (False, True):
                runs[with_sp].append(run(with_sp, path))
    assert all(r["r"] for r in runs[True]) and not any(r["r"] for r in runs[False])
    med = {k: {m: statistics.median(r[m] for r in v) for m in ("cpu", "hwm")}
           for k, v in runs.items()}
    ratios = [b["cpu"] / a_["cpu"] for a_, b in zip(runs[False], runs[True], strict=True)]
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPU(s), "
          f"{a.rows} rows, {a.reps} interleaved pairs")
    print("| load | CPU (s) | peak RSS growth (MB) |")
    print("|---|---:|---:|")
    for k, name in ((False, "without the setpoint"), (True, "with `setpoint: r`")):
        print(f"| {name} | {med[k]['cpu']:.3f} | {med[k]['hwm'] / 1e6:.0f} |")
    print(f"\nCPU ratio, with / without (median of pairs): {statistics.median(ratios):.2f}")


if __name__ == "__main__":
    main()
