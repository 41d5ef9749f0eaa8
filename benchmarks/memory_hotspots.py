"""The two steps where `pipeline identify LOG --method all --events all` peaked at 10 M samples
(issue 14 item 6), each run on its own on a long log and measured against the resident set
at its entry: the cross-validation's Gauss-Newton folds of every joint fit
(:func:`pipeline.refine.joint._stepped_folds`) and the closed-loop check
(:func:`pipeline.grading.closed_loop.closed_loop_flag`).

    python benchmarks/memory_hotspots.py LOG.csv RESULTS.json [--structures a,b]

``LOG.csv`` is a ``time,u,y`` log (``benchmarks/scale.py --keep DIR`` writes them);
``RESULTS.json`` the output of ``pipeline identify LOG.csv --input u --output y --time
time --method all --events all --json`` on it, whose joint fits give the models the folds
step from (so the whole analysis, 25 minutes at 10 M on the 2-vCPU host, is not run
again for each measurement). A thread reads the resident set (``/proc/self/statm``)
every millisecond; the command line's allocator settings are made as it makes them
(:mod:`pipeline.memory`), and freed heap is returned before each step. Figures are MB
(10^6 bytes) over the step's entry and that against the raw ``t, u, y`` arrays
(``3 x 8 x samples`` bytes). Linux only (``/proc``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
PAGE = os.sysconf("SC_PAGE_SIZE")


def rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE


class Peak:
    """The resident set's peak since :meth:`reset`, read by a thread every millisecond."""

    def __init__(self) -> None:
        self.value = 0
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self) -> None:
        while True:
            self.value = max(self.value, rss())
            time.sleep(0.001)

    def reset(self) -> int:
        entry = rss()
        self.value = entry
        return entry


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("log", type=Path)
    ap.add_argument("results", type=Path)
    ap.add_argument("--structures", default="", help="only these joint fits: a,b")
    a = ap.parse_args()
    from pipeline.memory import large_arrays_mapped, polars_returns_freed_pages, release

    polars_returns_freed_pages()  # as the command line does, before polars is imported
    large_arrays_mapped()
    import pipeline
    from pipeline.grading.closed_loop import closed_loop_flag
    from pipeline.models import ProcessModel
    from pipeline.refine import joint
    from pipeline.refine.event import event_states
    from pipeline.refine.refinement import RefineOptions

    rec = pipeline.load(a.log, input="u", output="y", time="time")
    events = pipeline.segment(rec)
    states = event_states(rec, events)
    ident = list(range(len(events)))
    raw = 24 * rec.n_samples
    doc = json.loads(a.results.read_text())["records"][0]
    only = set(filter(None, a.structures.split(",")))
    peak = Peak()
    print(f"{rec.n_samples:,} samples, {len(events)} events; raw arrays {raw / 1e6:.0f} MB")

    def report(label: str, entry: int, cpu: float) -> None:
        over = peak.value - entry
        print(f"{label:32s} peak over its entry {over / 1e6:5.0f} MB = {over / raw:.2f}x raw"
              f"  ({cpu:.1f} s CPU)", flush=True)

    release()
    entry, cpu = peak.reset(), time.process_time()
    closed_loop_flag(rec, events)
    report("closed_loop_flag", entry, time.process_time() - cpu)
    fold_options = replace(RefineOptions(), n_starts=1, bootstrap=0)  # as span_fit's
    for f in doc["fits"]:
        if not (f.get("events") and len(f["events"]) > 1 and f["status"] == "ok"):
            continue
        if only and f["structure"] not in only:
            continue
        model = ProcessModel(f["structure"], f["params"])
        release()
        entry, cpu = peak.reset(), time.process_time()
        joint._stepped_folds(rec, events, ident, model, joint.folds_of(ident), states,
                             fold_options)
        report(f"stepped folds, {f['structure']}", entry, time.process_time() - cpu)


if __name__ == "__main__":
    main()
