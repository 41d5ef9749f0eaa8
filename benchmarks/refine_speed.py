"""Refinement cost: the least-squares refinements against the graphical methods on the same
events, in the same run.

    python benchmarks/refine_speed.py [--reps 5] [--daisy]

For each record: the median wall time (of --reps runs) of all graphical step methods on
the identification event, of each ``lsq_<structure>`` on it (started from those graphical
models, as :func:`pipeline.analysis.analyse` does), and of the whole ``analyse`` (methods,
refinements, continuous validation, recommendation); the ratio refinements / graphical.
Records: the three synthetic plants of the issue (1 % noise, two steps), a long
event (the coarse-to-fine path) and, with ``--daisy`` (needs the dataset, e.g.
``PIPELINE_DATASETS_MIRROR``), DaISy 99-001 with ``events: [0]`` and ``events: all``.
Prints Markdown tables and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.events import EventData
from pipeline.methods import REGISTRY, identify, select_methods
from pipeline.models import ProcessModel
from pipeline.record import Record
from pipeline.segmentation.detect import segment
from pipeline.synth import step_record

PLANTS = {
    "FOPDT K 2, T 10, delay 2 (dt 0.5 s)": (ProcessModel(
        "first_order", {"K": 2.0, "T": 10.0, "delay": 2.0}), 10.0, 0.5),
    "two lags 10, 3, delay 1 (dt 0.5 s)": (ProcessModel(
        "two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 1.0}), 13.0, 0.5),
    "underdamped zeta 0.3, wn 1 (dt 0.1 s)": (ProcessModel(
        "second_order", {"K": 0.8, "zeta": 0.3, "wn": 1.0}), 3.3, 0.1),
    "two lags, long event: 4,160 samples after t0 (dt 0.005 s)": (ProcessModel(
        "two_lags", {"K": 1.5, "T1": 2.0, "T2": 0.6, "delay": 0.3}), 2.6, 0.005),
}


def median_time(f, reps: int) -> float:
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def synthetic(truth: ProcessModel, ts: float, dt: float) -> Record:
    return step_record(truth, u0=2.0, changes=[(2 * ts, 5.0), (10 * ts, 3.0)], t_end=18 * ts,
                       dt=dt, y0=7.0, noise=0.01 * truth.K * 3, seed=0)


def event_costs(record: Record, reps: int) -> tuple[int, float, dict[str, float]]:
    """Samples of event 0, graphical time, and each refinement's time on it."""
    ev = segment(record)[0]
    data = EventData.from_event(record, ev)
    ids = select_methods("all", ev.kind)
    graphical = [m for m in ids if REGISTRY[m].kind == "graphical"]
    t_graph = median_time(lambda: [identify(data, m) for m in graphical], reps)
    models = [f.model for f in (identify(data, m) for m in graphical) if f.ok]
    lsq = {m: median_time(lambda m=m: identify(data, m, models=models, state="rest"), reps)
           for m in ids if REGISTRY[m].kind == "refinement"}
    return ev.i_end - ev.i_base, t_graph, lsq


def daisy() -> Record:
    from pipeline.config import load_config
    from pipeline.io import load_record
    from pipeline.run import effective_data, resolve_specs

    cfg = load_config(Path(__file__).resolve().parent.parent / "configs" / "thermal.yaml")
    spec = resolve_specs(cfg)[0]
    return load_record(Path(spec.path), effective_data(cfg, spec))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--daisy", action="store_true")
    args = ap.parse_args()
    records = {name: synthetic(*p) for name, p in PLANTS.items()}
    if args.daisy:
        records["DaISy 99-001, event 0 (200 samples)"] = daisy()
    print(f"`python benchmarks/refine_speed.py --reps {args.reps}"
          f"{' --daisy' if args.daisy else ''}` on CPython {platform.python_version()}, "
          f"{os.cpu_count()} CPU(s), {platform.machine()}, load average "
          f"{os.getloadavg()[0]:.1f}\n")
    print("| record | samples fitted | graphical methods (ms) | " + " | ".join(
        m for m in REGISTRY if REGISTRY[m].kind == "refinement") + " | refinements / "
          "graphical |")
    print("|---|---:|---:|" + "---:|" * (len(REGISTRY) - sum(
        m.kind == "graphical" for m in REGISTRY.values())) + "---:|")
    for name, rec in records.items():
        n, tg, lsq = event_costs(rec, args.reps)
        cells = " | ".join(f"{1e3 * v:.1f}" for v in lsq.values())
        print(f"| {name} | {n} | {1e3 * tg:.1f} | {cells} | {sum(lsq.values()) / tg:.1f}x |")
    print("\n| record, whole `analyse` | identification events | wall time (ms) |")
    print("|---|---|---:|")
    runs = [(name, rec, (0,)) for name, rec in records.items()]
    if args.daisy:
        runs.append(("DaISy 99-001, all six events (joint fits, leave one out)",
                     records["DaISy 99-001, event 0 (200 samples)"], "all"))
    for name, rec, events in runs:
        t = median_time(lambda rec=rec, events=events: analyse(
            rec, AnalysisOptions(events=events)), args.reps)
        print(f"| {name} | {events} | {1e3 * t:.0f} |")


if __name__ == "__main__":
    main()
