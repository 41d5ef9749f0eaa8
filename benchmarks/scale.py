"""Scale (issue 14): a long plant-historian log, stage by stage, against the bare read.

    python benchmarks/scale.py [--sizes 1000000:200,10000000:2000] [--reps 1]
                               [--cli-sizes 1000000:200] [--keep DIR]

For each ``samples:events`` size a staircase log of a first-order plant with delay (white
noise, a nonzero operating point, every window about eight time constants) is written
as CSV (``time,u,y``). Then, interleaved, ``--reps`` times:

* **bare**: a fresh Python process that runs ``polars.read_csv(path)`` and takes the
  three columns as numpy arrays: the I/O floor the issue measures against;
* **pipeline**: a fresh process that runs, each stage timed on its own (CPU and wall):
  ``load`` (:func:`pipeline.load`), ``segment`` (:func:`pipeline.segment`), ``graphical``
  (every graphical method on every event, :func:`pipeline.identify_event`), ``analyse``
  (:func:`pipeline.analyse` with event 0 identifying: graphical methods and the
  least-squares refinements on it, validation on every other event, the per-step
  consistency) and ``report`` (results.json, report.md and report.html with the
  default plots);
* **cli** (only for ``--cli-sizes``): ``pipeline identify FILE --method all --events all``
  as a user runs it, whole-process CPU.

Peak memory is the process's own high-water resident set (``VmHWM`` of
``/proc/self/status`` at its end, for the CLI run ``wait4``'s maximum resident set); the
pipeline's is also given net of the interpreter and imports (its resident set before
loading, ``VmRSS``). The logs are written by a child process: ``ru_maxrss`` carries the
forking process's resident set across ``exec`` on Linux, so a driver that had written a
10 M-sample log itself (about 560 MB) made every worker's imports look that large.
Raw arrays are ``3 x 8 x samples`` bytes. Growth exponents compare consecutive sizes:
``log(cost2 / cost1) / log(samples2 / samples1)`` (both samples and events grow).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def write_log(path: Path, n: int, n_events: int, dt: float = 0.1, seed: int = 0) -> None:
    """A staircase log: ``n`` samples, ``n_events`` input steps alternating about 5 (heights
    1.2 to 2.8), K = 2, T = window / 8, delay 3 samples, y about 10 + 2 u, noise 0.02."""
    import numpy as np
    import polars as pl
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    w = n // (n_events + 1)
    levels = 5.0 + (-1.0) ** np.arange(n_events) * rng.uniform(0.6, 1.4, n_events)
    u = np.full(n, 5.0)
    for k in range(n_events):
        u[(k + 1) * w:] = levels[k]
    T = w * dt / 8
    a = math.exp(-dt / T)
    delayed = np.concatenate([np.full(3, 5.0), u[:-3]])
    y = 10.0 + lfilter([0.0, 2.0 * (1 - a)], [1.0, -a], delayed - 5.0, zi=[0.0])[0] \
        + 2.0 * 5.0 + rng.normal(0.0, 0.02, n)
    pl.DataFrame({"time": np.arange(n) * dt, "u": u, "y": y}).write_csv(path)


def measured(argv: list[str], timeout: float | None = None) -> dict | None:
    """Run ``argv`` in a fresh process: wall, CPU (user + system) and peak RSS (``wait4``);
    None when it runs longer than ``timeout`` seconds (it is killed then)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    t = time.perf_counter()
    with tempfile.TemporaryFile() as sink:
        p = subprocess.Popen(argv, stdout=sink, stderr=subprocess.DEVNULL, env=env, cwd=ROOT)
        timer = threading.Timer(timeout, p.kill) if timeout else None
        if timer:
            timer.start()
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        if timer:
            timer.cancel()
        sink.seek(0)
        out = sink.read()
    wall = time.perf_counter() - t
    if timeout and wall >= timeout and p.returncode < 0:
        return None
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(argv)}: exit {p.returncode}")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime,
            "rss": usage.ru_maxrss * 1024, "out": out.decode()}


# -- the measured processes ---------------------------------------------------------------

def _stage(name: str, timings: dict, fn):
    c, w = time.process_time(), time.perf_counter()
    value = fn()
    timings[name] = {"cpu": time.process_time() - c, "wall": time.perf_counter() - w,
                     "hwm": _status_bytes("VmHWM")}  # the high-water mark so far
    return value


def _status_bytes(field: str) -> int:
    """A ``/proc/self/status`` memory field (``VmRSS``, ``VmHWM``) in bytes."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024
    return 0


def worker_bare(path: str) -> None:
    import polars as pl

    c = time.process_time()
    df = pl.read_csv(path)
    arrays = [df[k].to_numpy() for k in ("time", "u", "y")]
    print(json.dumps({"cpu": time.process_time() - c, "n": len(arrays[0]),
                      "hwm": _status_bytes("VmHWM")}))


def worker_write(path: str, n: str, n_events: str) -> None:
    write_log(Path(path), int(n), int(n_events))


def worker_pipeline(path: str, out: str) -> None:
    import pipeline
    from pipeline.memory import large_arrays_mapped, polars_returns_freed_pages

    polars_returns_freed_pages()  # as the command line does, before polars is imported
    large_arrays_mapped()
    # the loaders are imported on first use: import them before the clock starts
    import pipeline.io.delimited  # noqa: F401
    from pipeline.analysis import AnalysisOptions
    from pipeline.events import EventData
    from pipeline.methods import select_methods
    from pipeline.report.build import write_run
    from pipeline.results import RunResult

    rss_imports = _status_bytes("VmRSS")
    t: dict = {}
    rec = _stage("load", t, lambda: pipeline.load(path, input="u", output="y", time="time"))
    events = _stage("segment", t, lambda: pipeline.segment(rec))

    def graphical():
        n = 0
        for ev in events:
            data = EventData.from_event(rec, ev)
            for m in select_methods("all", ev.kind):
                if not m.startswith("lsq_"):
                    pipeline.identify_event(data, m)
                    n += 1
        return n

    n_fits = _stage("graphical", t, graphical)
    res = _stage("analyse", t, lambda: pipeline.analyse(rec, AnalysisOptions(events=(0,))))
    run = RunResult([res], config=path, created="2026-01-01T00:00:00+00:00")
    _stage("report", t, lambda: write_run(Path(out), run, run.to_doc(), title="scale"))
    print(json.dumps({"stages": t, "rss_imports": rss_imports, "events": len(events),
                      "graphical_fits": n_fits, "hwm": _status_bytes("VmHWM")}))


# -- the driver -----------------------------------------------------------------------------

def _sizes(text: str) -> list[tuple[int, int]]:
    return [tuple(int(float(v)) for v in item.split(":")) for item in text.split(",") if item]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="1000000:200,10000000:2000")
    ap.add_argument("--cli-sizes", default="1000000:200")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--keep", type=Path, default=None, help="write the logs here")
    ap.add_argument("--cli-timeout", type=float, default=900.0,
                    help="seconds before the CLI run is stopped (reported as not finished)")
    a = ap.parse_args()
    py = sys.executable
    me = str(Path(__file__).resolve())
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = a.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        cli_sizes = set(_sizes(a.cli_sizes))
        for n, n_events in _sizes(a.sizes):
            path = folder / f"scale_{n}_{n_events}.csv"
            if not path.exists():  # in a child: the driver stays small (see the docstring)
                subprocess.run([py, me, "--worker", "write", str(path), str(n),
                                str(n_events)], check=True, env={**os.environ,
                                                                 "PYTHONPATH": str(ROOT)})
            bare, pipe, cli = [], [], []
            for _ in range(a.reps):
                bare.append(measured([py, me, "--worker", "bare", str(path)]))
                pipe.append(measured([py, me, "--worker", "pipeline", str(path),
                                      str(Path(tmp) / f"out_{n}")]))
                if (n, n_events) in cli_sizes:
                    cli.append(measured([py, "-m", "pipeline", "identify", str(path),
                                         "--input", "u", "--output", "y", "--time", "time",
                                         "--method", "all", "--events", "all", "--json"],
                                        timeout=a.cli_timeout))
            rows.append(summarise(n, n_events, path, bare, pipe, cli, a.cli_timeout))
            report(rows[-1:], header=len(rows) == 1)
    report_growth(rows)


def _median(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


def summarise(n, n_events, path, bare, pipe, cli, cli_timeout) -> dict:
    docs = [json.loads(r["out"]) for r in pipe]
    stages = {k: statistics.median(d["stages"][k]["cpu"] for d in docs)
              for k in docs[0]["stages"]}
    walls = {k: statistics.median(d["stages"][k]["wall"] for d in docs)
             for k in docs[0]["stages"]}
    bare_cpu = statistics.median(json.loads(r["out"])["cpu"] for r in bare)
    raw = 3 * 8 * n
    return {"n": n, "events": n_events, "file_mb": path.stat().st_size / 1e6,
            "bare_cpu": bare_cpu, "bare_process_cpu": _median(bare, "cpu"),
            "bare_rss": statistics.median(json.loads(r["out"])["hwm"] for r in bare),
            "stages": stages, "walls": walls,
            "pipe_cpu": _median(pipe, "cpu"), "pipe_rss": statistics.median(
                d["hwm"] for d in docs),
            "pipe_rss_net": statistics.median(d["hwm"] - d["rss_imports"] for d in docs),
            "hwm_net": {k: statistics.median(d["stages"][k]["hwm"] - d["rss_imports"]
                                             for d in docs) for k in docs[0]["stages"]},
            "raw": raw, "cli_ran": bool(cli), "cli_timeout": cli_timeout,
            "cli_cpu": _median(cli, "cpu") if cli and None not in cli else None,
            "cli_rss": _median(cli, "rss") if cli and None not in cli else None,
            "graphical_fits": docs[0]["graphical_fits"], "found": docs[0]["events"]}


def report(rows: list[dict], header: bool = True) -> None:
    if header:
        print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
              f"{platform.python_version()}", flush=True)
    for r in rows:
        print(f"\n{r['n']:,} samples, {r['events']} events ({r['found']} found), "
              f"{r['file_mb']:.0f} MB CSV; bare read {r['bare_cpu']:.2f} s CPU "
              f"(process {r['bare_process_cpu']:.2f} s, peak {r['bare_rss'] / 1e6:.0f} MB)")
        for k, v in r["stages"].items():
            print(f"  {k:10s} {v:8.2f} s CPU {r['walls'][k]:8.2f} s wall  "
                  f"{v / r['bare_cpu']:7.2f}x bare; peak so far "
                  f"{r['hwm_net'][k] / r['raw']:.2f}x the raw arrays")
        print(f"  whole process {r['pipe_cpu']:.2f} s CPU; peak {r['pipe_rss'] / 1e6:.0f} MB, "
              f"{r['pipe_rss_net'] / 1e6:.0f} MB over the imports = "
              f"{r['pipe_rss_net'] / r['raw']:.2f}x the raw arrays ({r['raw'] / 1e6:.0f} MB); "
              f"{r['graphical_fits']} graphical fits")
        if r["cli_cpu"] is not None:
            print(f"  `pipeline identify --method all --events all`: {r['cli_cpu']:.2f} s CPU"
                  f" = {r['cli_cpu'] / r['bare_process_cpu']:.1f}x the bare read's process; "
                  f"peak {r['cli_rss'] / 1e6:.0f} MB")
        elif r["cli_ran"]:
            print(f"  `pipeline identify --method all --events all`: not finished in "
                  f"{r['cli_timeout']:.0f} s (stopped)")
        sys.stdout.flush()


def report_growth(rows: list[dict]) -> None:
    for a, b in zip(rows, rows[1:], strict=False):
        grow = math.log(b["n"] / a["n"])
        parts = ", ".join(
            f"{k} {math.log(max(b['stages'][k], 1e-9) / max(a['stages'][k], 1e-9)) / grow:.2f}"
            for k in a["stages"])
        print(f"\ngrowth exponent {a['n']:,}/{a['events']} -> {b['n']:,}/{b['events']}: {parts}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        {"bare": worker_bare, "pipeline": worker_pipeline,
         "write": worker_write}[sys.argv[2]](*sys.argv[3:])
    else:
        main()
