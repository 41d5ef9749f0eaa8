"""End to end: ``pipeline run CONFIG`` at this checkout against a base commit, interleaved.

    python benchmarks/end_to_end.py [--base 9e48577] [--config configs/thermal.yaml]
                                    [--reps 5]

The base commit is exported with ``git archive`` into a temporary folder and run with the
same interpreter (``python -m pipeline`` with that folder first on ``sys.path``), so both
sides share the machine, the libraries and the load of the moment; the runs alternate.
Prints the median wall time of each side, their range, the ratio now/base and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def export(ref: str, into: Path) -> Path:
    """The tree of ``ref`` unpacked into ``into``."""
    archive = into / "base.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "-o", str(archive), ref], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into / "tree", filter="data")
    return into / "tree"


def timed_run(tree: Path, config: Path, out: Path) -> float:
    """Wall time of one ``pipeline run`` of ``tree``'s code."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pipeline", "run", str(config), "--out", str(out)],
                   cwd=tree, env=env, check=True, capture_output=True)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", default="9e48577")
    ap.add_argument("--config", default="configs/thermal.yaml")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        base = export(a.base, tmp)
        times: dict[str, list[float]] = {"base": [], "now": []}
        for k in range(a.reps):
            for side, tree in (("base", base), ("now", ROOT)):
                times[side].append(timed_run(tree, tree / a.config, tmp / f"{side}{k}"))
    med = {s: statistics.median(v) for s, v in times.items()}
    print(f"`pipeline run {a.config}`, {a.reps} interleaved runs each, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, load {os.getloadavg()[0]:.2f}")
    print()
    print("| side | median (s) | range (s) |")
    print("|---|---:|---:|")
    for side in ("base", "now"):
        print(f"| {side if side == 'now' else 'base ' + a.base} | {med[side]:.2f} | "
              f"{min(times[side]):.2f}-{max(times[side]):.2f} |")
    print(f"\nratio now/base: {med['now'] / med['base']:.2f}")


if __name__ == "__main__":
    main()
