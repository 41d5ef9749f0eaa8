"""Where a long log's run peaks in memory: the resident set sampled per stage and per step of
the analysis, and with ``--stacks`` the Python stack where each step peaked (issue 14 item 6).

    python benchmarks/memory_stages.py LOG.csv [--out DIR] [--events all] [--traced] [--stacks]

``LOG.csv`` is a ``time,u,y`` log, e.g. one that ``benchmarks/scale.py --keep DIR`` wrote.
The stages of ``pipeline run`` are run in this process as ``benchmarks/scale.py`` runs
them (load, segment, analyse with event 0 identifying, or with ``--events all`` every
event as ``pipeline identify --events all`` does, report), while a thread reads the
resident set (``/proc/self/statm``) every 2 ms. Each stage and each analysis step
(:data:`STEPS`, wrapped to say when they run) gets its peak over the resident set after
the imports, against the raw ``t, u, y`` arrays (``3 x 8 x samples`` bytes), and with
``--stacks`` the stack of the main thread when the sampler saw it (to the GIL's switch
interval: the step named is exact, the line within it approximate; holding the frames
keeps a function that just returned alive with its locals, so those peaks run high).
``tracemalloc`` does not see the C allocators' retention (glibc's freed heap, polars'
jemalloc pages), which is part of what the process holds, so the resident set is what is
measured. The command line's allocator settings are made as it makes them
(:mod:`pipeline.memory`).

With ``--traced`` the analysis runs under ``tracemalloc`` instead (several times slower),
and each step's peak is of the memory Python and numpy hold (the loaded record excluded:
it is read before tracing starts), and what was held when it was entered: the live
arrays, without what the C allocators keep of freed memory; the difference to the
resident set is that retention.

Linux only (``/proc``).
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

#: The analysis steps timed on their own: (module, function) as the analysis calls them.
STEPS = [("pipeline.analysis", "segment"), ("pipeline.analysis", "event_states"),
         ("pipeline.analysis", "_event_fits"), ("pipeline.analysis", "_with_information_criteria"),
         ("pipeline.analysis", "recommend"), ("pipeline.grading.consistency", "event_estimates"),
         ("pipeline.grading.consistency", "step_gains"), ("pipeline.analysis", "grade"),
         ("pipeline.grading.verdicts", "closed_loop_flag"),
         ("pipeline.grading.verdicts", "fit_flags"),
         ("pipeline.analysis", "_joint_fits"), ("pipeline.analysis", "_held_out"),
         ("pipeline.refine.joint", "refine_span"), ("pipeline.refine.joint", "cross_validate"),
         ("pipeline.refine.joint", "_stepped_folds"), ("pipeline.refine", "_finish")]
PAGE = os.sysconf("SC_PAGE_SIZE")


def rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE


class Sampler:
    """The peak resident set of each labelled stage, and the stack at it (``stacks``)."""

    def __init__(self, stacks: bool = False) -> None:
        self.label: str | None = None
        self.stacks = stacks
        self.peaks: dict[str, tuple[int, list[str]]] = {}
        self.main = threading.main_thread().ident
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop:
            r, label = rss(), self.label
            if label and r > self.peaks.get(label, (0, []))[0]:
                self.peaks[label] = (r, self._stack() if self.stacks else [])
            time.sleep(0.002)

    def _stack(self) -> list[str]:
        """The main thread's innermost frames. Holding them (until the next look) keeps a
        function that returned meanwhile alive with its locals, so the stacks are
        opt-in (``--stacks``): without them the peaks are the run's own."""
        frame = sys._current_frames().get(self.main)
        stack = [f"{Path(f.filename).name}:{f.lineno} {f.name}"
                 for f in traceback.extract_stack(frame)][-6:] if frame else []
        return stack

    def __enter__(self) -> Sampler:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop = True
        self._thread.join()

    def wrap(self, module: ModuleType, name: str) -> None:
        """Label the calls of ``module.name`` (nested under the current label)."""
        f = getattr(module, name)

        @functools.wraps(f)
        def labelled(*args, **kwargs):
            outer = self.label
            self.label = f"{outer}/{name}" if outer else name
            try:
                return f(*args, **kwargs)
            finally:
                self.label = outer

        setattr(module, name, labelled)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("log", type=Path)
    ap.add_argument("--out", type=Path, default=None, help="report folder (a temporary one)")
    ap.add_argument("--events", default="0", help="identification events: all, or 0,2")
    ap.add_argument("--traced", action="store_true",
                    help="the analysis' live Python/numpy memory per step (tracemalloc)")
    ap.add_argument("--stacks", action="store_true",
                    help="the stack where each step peaked (holds the main thread's frames "
                    "for a moment: the peaks can be higher than the run's own)")
    a = ap.parse_args()
    events = "all" if a.events == "all" else tuple(int(v) for v in a.events.split(","))
    if a.traced:
        traced(a.log, events)
        return
    import importlib

    import pipeline
    from pipeline.memory import large_arrays_mapped, polars_returns_freed_pages

    polars_returns_freed_pages()  # as the command line does, before polars is imported
    large_arrays_mapped()
    import pipeline.io.delimited  # noqa: F401  (imported before the baseline is read)
    from pipeline.analysis import AnalysisOptions
    from pipeline.report.build import write_run
    from pipeline.results import RunResult

    base = rss()
    with Sampler(a.stacks) as s, tempfile.TemporaryDirectory() as tmp:
        for module, name in STEPS:
            s.wrap(importlib.import_module(module), name)

        def stage(label, fn):
            s.label = label
            value = fn()
            time.sleep(0.01)  # the sampler's last look
            s.label = None
            return value

        rec = stage("load", lambda: pipeline.load(a.log, input="u", output="y", time="time"))
        stage("segment", lambda: pipeline.segment(rec))
        res = stage("analyse", lambda: pipeline.analyse(rec, AnalysisOptions(events=events)))
        run = RunResult([res], config=str(a.log), created="2026-01-01T00:00:00+00:00")
        stage("report", lambda: write_run(a.out or Path(tmp), run, run.to_doc(), title="m"))
    raw = 3 * 8 * rec.n_samples
    print(f"{rec.n_samples:,} samples; imports {base / 1e6:.0f} MB; raw arrays "
          f"{raw / 1e6:.0f} MB (3x: {3 * raw / 1e6:.0f} MB)")
    for label, (peak, stack) in sorted(s.peaks.items(), key=lambda kv: -kv[1][0]):
        print(f"{label:42s} {(peak - base) / 1e6:7.0f} MB over the imports = "
              f"{(peak - base) / raw:.2f}x raw")
        for line in stack:
            print(f"{'':6s}{line}")


class Traced:
    """Each labelled step's ``tracemalloc`` peak (nested steps: every open one shares it)
    and the traced memory when it was entered (the largest over its calls)."""

    def __init__(self) -> None:
        self.open: list[str] = []
        self.peaks: dict[str, int] = {}
        self.entered: dict[str, int] = {}

    def _mark(self) -> int:
        import tracemalloc

        current, peak = tracemalloc.get_traced_memory()
        for label in self.open:
            self.peaks[label] = max(self.peaks.get(label, 0), peak)
        tracemalloc.reset_peak()
        return current

    def wrap(self, module: ModuleType, name: str) -> None:
        f = getattr(module, name)

        @functools.wraps(f)
        def labelled(*args, **kwargs):
            current = self._mark()
            label = f"{self.open[-1]}/{name}" if self.open else name
            self.entered[label] = max(self.entered.get(label, 0), current)
            self.open.append(label)
            try:
                return f(*args, **kwargs)
            finally:
                self._mark()
                self.open.pop()

        setattr(module, name, labelled)


def traced(log: Path, events) -> None:
    """The ``--traced`` mode (see the module docstring)."""
    import importlib
    import tracemalloc

    import pipeline
    from pipeline.analysis import AnalysisOptions

    probe = Traced()
    for module, name in STEPS:
        probe.wrap(importlib.import_module(module), name)
    probe.wrap(pipeline, "analyse")
    rec = pipeline.load(log, input="u", output="y", time="time")
    raw = 3 * 8 * rec.n_samples
    tracemalloc.start()
    pipeline.analyse(rec, AnalysisOptions(events=events))
    held = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    print(f"{rec.n_samples:,} samples; raw arrays {raw / 1e6:.0f} MB; traced memory "
          f"beside the record, x raw (held after the analysis: {held / raw:.2f}x)")
    for label, peak in sorted(probe.peaks.items(), key=lambda kv: -kv[1]):
        print(f"{label:58s} peak {peak / raw:5.2f}x   entered at "
              f"{probe.entered.get(label, 0) / raw:5.2f}x")


if __name__ == "__main__":
    main()
