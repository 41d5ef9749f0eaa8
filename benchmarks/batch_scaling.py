"""Batch scaling: a cold ``pipeline run`` over the same synthetic logs, 1 worker against 2.

Writes ``--n`` synthetic logs (:func:`pipeline.synth.logs.write_synthetic_logs`, 4 steps
each, all methods) into a temporary folder and runs the real command line, each run a
fresh process (cold: the interpreter, the imports, the fork server and the workers all
start anew), for ``report.plots: none`` and ``report.plots: summary``, with ``--workers
1`` and ``--workers N``, interleaved (``--rounds`` rounds of the four runs). Checks that
1 and N workers give the same results.json records, and prints a Markdown snippet with
the wall times and the speed-ups (the issue 14 target: N=2 at least 1.8x one worker).

    python benchmarks/batch_scaling.py [--n 200] [--workers 2] [--rounds 1]
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
import time
from pathlib import Path

from pipeline.synth.logs import write_synthetic_logs

ROOT = Path(__file__).resolve().parents[1]
PLOTS = ("none", "summary")


def write_config(folder: Path, plots: str) -> Path:
    cfg = folder / f"bench_{plots}.yaml"
    cfg.write_text(f"name: bench\ndata:\n  path: logs\n  input: u\n  output: y\n"
                   f"  time: time\nreport:\n  plots: {plots}\n")
    return cfg


def cold_run(cfg: Path, workers: int, out: Path) -> float:
    """Wall time of one ``pipeline run`` process."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pipeline", "run", str(cfg), "--workers",
                    str(workers), "--out", str(out), "--quiet"], env=env, check=True,
                   cwd=cfg.parent, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def records(out: Path) -> list[dict]:
    return json.loads((out / "results.json").read_text())["records"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="number of logs")
    ap.add_argument("--workers", type=int, default=2, help="processes of the pool run")
    ap.add_argument("--rounds", type=int, default=1, help="interleaved rounds")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    times: dict[tuple[str, int], list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_synthetic_logs(folder / "logs", args.n, seed=args.seed)
        load0 = os.getloadavg()[0]
        for _ in range(args.rounds):
            for plots in PLOTS:
                cfg = write_config(folder, plots)
                for w in (1, args.workers):
                    out = folder / f"out_{plots}_{w}"
                    times.setdefault((plots, w), []).append(cold_run(cfg, w, out))
                    print(f"plots {plots}, {w} worker(s): {times[(plots, w)][-1]:.1f} s, "
                          f"load {os.getloadavg()[0]:.1f}", file=sys.stderr, flush=True)
                if records(folder / f"out_{plots}_1") != \
                        records(folder / f"out_{plots}_{args.workers}"):
                    raise SystemExit(f"plots {plots}: 1 and {args.workers} workers differ")
        load1 = os.getloadavg()[0]
    print(f"### Batch scaling: cold `pipeline run` over {args.n} logs\n")
    print(f"`python benchmarks/batch_scaling.py --n {args.n} --workers {args.workers} "
          f"--rounds {args.rounds}` on {platform.python_implementation()} "
          f"{platform.python_version()}, {os.cpu_count()} CPU(s); 1-minute load average "
          f"{load0:.1f} before and {load1:.1f} after. Wall time of the whole command "
          "(median over the rounds); results.json records identical for 1 and N workers.\n")
    print(f"| report.plots | 1 worker (s) | {args.workers} workers (s) | speed-up |")
    print("|---|---:|---:|---:|")
    for plots in PLOTS:
        t1 = statistics.median(times[(plots, 1)])
        tn = statistics.median(times[(plots, args.workers)])
        print(f"| {plots} | {t1:.1f} | {tn:.1f} | {t1 / tn:.2f}x |")


if __name__ == "__main__":
    main()
