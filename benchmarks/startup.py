"""Start-up time of the command line, interleaved with a bare interpreter.

Runs, round-robin ``--rounds`` times: a bare ``python -c pass``; ``pipeline --help``;
``pipeline methods``; and ``python -c "import pipeline.methods"`` (what ``pipeline
methods`` imported before the catalogue was shipped as data). Prints the median wall time
of each and its ratio to the bare interpreter as a Markdown snippet. Every command is a
fresh process (``python -m pipeline`` with this checkout first on PYTHONPATH).

    python benchmarks/startup.py [--rounds 15]
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = {
    "python -c pass": ["-c", "pass"],
    "pipeline --help": ["-m", "pipeline", "--help"],
    "pipeline methods": ["-m", "pipeline", "methods"],
    "import pipeline.methods (before)": ["-c", "import pipeline.methods"],
}


def wall(args: list[str], env: dict) -> tuple[float, float]:
    """(wall, CPU) seconds of one fresh process; CPU (user + system) is what contention
    from other processes inflates least."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, *args], env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return t, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    rounds = ap.parse_args().rounds
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    times: dict[str, list[float]] = {k: [] for k in COMMANDS}
    cpu: dict[str, list[float]] = {k: [] for k in COMMANDS}
    load0 = os.getloadavg()[0]
    for _ in range(rounds):
        for name, args in COMMANDS.items():
            t, c = wall(args, env)
            times[name].append(t)
            cpu[name].append(c)
    load1 = os.getloadavg()[0]
    med = {k: statistics.median(v) for k, v in times.items()}
    bare = med["python -c pass"]
    print(f"### Start-up ({rounds} interleaved rounds: wall time median and minimum, "
          "CPU time median)\n")
    print(f"`python benchmarks/startup.py --rounds {rounds}` on "
          f"{platform.python_implementation()} {platform.python_version()}, "
          f"{os.cpu_count()} CPU(s); 1-minute load average {load0:.1f} before and "
          f"{load1:.1f} after.\n")
    print("| command | wall median (s) | wall min (s) | CPU median (s) | wall vs bare python |")
    print("|---|---|---|---|---|")
    for k, v in times.items():
        print(f"| `{k}` | {med[k]:.3f} | {min(v):.3f} | {statistics.median(cpu[k]):.3f} | "
              f"{med[k] / bare:.1f}x |")


if __name__ == "__main__":
    main()
