"""Report writing for a long record with full plots, this checkout against a base commit.

    python benchmarks/report_speed.py [--base 6ff9e78] [--samples 1000000] [--reps 3]

A 1 M-sample first-order log with two steps (identification on the first, validation on
the second) is analysed with the graphical first-order method, then only
:func:`pipeline.report.build.render` with ``plots_mode="full"`` is timed (overview,
ranking bars, identification and validation overlays). The base commit (before the
curves were decimated to the pixels and the legends fixed, ``loc="best"``) is exported
with ``git archive`` and run with the same interpreter; the two sides run in separate
processes, alternating. Prints the median render time of each side, their range, the
ratio base/now and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from end_to_end import export  # the base commit's tree (this folder is on sys.path)

ROOT = Path(__file__).resolve().parent.parent

#: Run in each side's tree: build the record, analyse it, time the report (stdout: s).
SIDE = """
import sys, time
import numpy as np
from pipeline.analysis import AnalysisOptions, analyse
from pipeline.models import ProcessModel
from pipeline.report.build import render
from pipeline.results import RunResult
from pipeline.synth import step_record

n = int(sys.argv[1])
dt = 0.01
rec = step_record(ProcessModel("first_order", {"K": 2.0, "T": 400.0}), u0=0.0,
                  changes=[(0.1 * n * dt, 1.0), (0.55 * n * dt, 0.0)], t_end=(n - 1) * dt,
                  dt=dt, y0=0.0, noise=0.01, seed=1)
res = analyse(rec, AnalysisOptions(methods=("first_order",), consistency=False))
run = RunResult([res], config="bench")
doc = run.to_doc()
t = time.perf_counter()
md, html, files = render(run, doc, title="bench", plots_mode="full")
print(time.perf_counter() - t, len(files), rec.n_samples)
"""


def timed_render(tree: Path, samples: int) -> tuple[float, int]:
    """Seconds of one full-plot render of ``tree``'s code, and how many PNGs it drew."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "-c", SIDE, str(samples)], cwd=tree, env=env,
                         check=True, capture_output=True, text=True).stdout.split()
    assert int(out[2]) == samples
    return float(out[0]), int(out[1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", default="6ff9e78")
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = export(a.base, Path(tmp))
        times: dict[str, list[float]] = {"base": [], "now": []}
        pngs: dict[str, int] = {}
        for _ in range(a.reps):
            for side, tree in (("base", base), ("now", ROOT)):
                seconds, pngs[side] = timed_render(tree, a.samples)
                times[side].append(seconds)
    med = {s: statistics.median(v) for s, v in times.items()}
    print(f"report of a {a.samples:,}-sample record, full plots ({pngs['now']} PNGs), "
          f"{a.reps} interleaved runs each, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}, "
          f"load {os.getloadavg()[0]:.2f}")
    print()
    print("| side | render median (s) | range (s) |")
    print("|---|---:|---:|")
    for side in ("base", "now"):
        label = "now" if side == "now" else f"base {a.base}"
        print(f"| {label} | {med[side]:.2f} | {min(times[side]):.2f}-{max(times[side]):.2f} |")
    print(f"\nratio base/now: {med['base'] / med['now']:.1f}x faster")


if __name__ == "__main__":
    main()
