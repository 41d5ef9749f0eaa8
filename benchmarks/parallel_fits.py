"""Both cores on one log (issue 30 item 3): ``identify --workers 2`` against ``--workers 1``.

    python benchmarks/parallel_fits.py [--sizes 200000:40,2000:4] [--reps 2]
                                       [--events all] [--keep DIR]

For each ``samples:events`` size a staircase log (:func:`scale.write_log`: a first-order
plant with delay, white noise, every window about eight time constants) is written as
CSV, then, interleaved, ``--reps`` times each: ``pipeline identify FILE --input u
--output y --time time --method all --events EVENTS --json --workers W`` for W = 1 and 2,
each in a fresh process.

Per run: the wall time, and the CPU the whole machine spent meanwhile (user + system
from ``/proc/stat``). ``wait4``'s CPU would miss the workers: they are the fork server's
children, and the command never reaps the fork server. Run it on an otherwise quiet
host. The two documents are compared with every ``seconds`` and the creation time taken
out: they must be equal (the script exits 1 otherwise).
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scale import write_log  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def machine_cpu() -> float:
    """Seconds of user + system CPU all processors have spent since boot (/proc/stat)."""
    with open("/proc/stat") as f:
        fields = f.readline().split()[1:]
    user, nice, system = (int(x) for x in fields[:3])
    return (user + nice + system) / os.sysconf("SC_CLK_TCK")


def run(argv: list[str]) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    c, t = machine_cpu(), time.perf_counter()
    p = subprocess.run(argv, capture_output=True, env=env, cwd=ROOT, check=False)
    wall, cpu = time.perf_counter() - t, machine_cpu() - c
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(argv)}: exit {p.returncode}: {p.stderr.decode()[-400:]}")
    return {"wall": wall, "cpu": cpu, "doc": without_times(json.loads(p.stdout))}


def without_times(x):
    if isinstance(x, dict):
        return {k: without_times(v) for k, v in x.items() if k not in ("seconds", "created")}
    if isinstance(x, list):
        return [without_times(v) for v in x]
    return x


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200000:40,2000:4")
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--events", default="all")
    ap.add_argument("--keep", type=Path)
    args = ap.parse_args()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=ROOT).stdout.strip()
    print(f"{commit}; {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}; identify --method all --events {args.events}")
    print("\n| samples | events | workers | wall (median) | machine CPU (median) | wall ratio "
          "| CPU ratio | same document |")
    print("|---:|---:|---:|---:|---:|---:|---:|---|")
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for size in args.sizes.split(","):
            n, k = (int(x) for x in size.split(":"))
            path = folder / f"staircase_{n}_{k}.csv"
            write_log(path, n, k)
            runs: dict[int, list[dict]] = {1: [], 2: []}
            for _ in range(args.reps):
                for w in (1, 2):
                    runs[w].append(run([sys.executable, "-m", "pipeline", "identify", str(path),
                                        "--input", "u", "--output", "y", "--time", "time",
                                        "--method", "all", "--events", args.events, "--json",
                                        "--workers", str(w)]))
            same = all(r["doc"] == runs[1][0]["doc"] for w in (1, 2) for r in runs[w])
            failed |= not same
            med = {w: {f: statistics.median(r[f] for r in runs[w]) for f in ("wall", "cpu")}
                   for w in (1, 2)}
            for w in (1, 2):
                ratio = (f"{med[w]['wall'] / med[1]['wall']:.2f}x | "
                         f"{med[w]['cpu'] / med[1]['cpu']:.2f}x")
                print(f"| {n:,} | {k} | {w} | {med[w]['wall']:.2f} s | {med[w]['cpu']:.2f} s | "
                      f"{ratio} | {'yes' if same else 'NO'} |")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
