"""What a run is doing, on stderr: a progress bar for the records and for the stages after
them, and the ``pipeline`` logger (:mod:`pipeline.log`) for per-record timing.

* :class:`Tracker` - records done, failures, elapsed time, ETA, and the stage the current
  record is in (``load``, ``analyse``) when it runs in this process: a single long file
  shows which step it is in instead of a bar stuck at 0/1;
* :class:`Stages` - after the records: the report sections (counted per record), writing
  the files, the history, the JUnit file; the bar does not freeze at 20/20 while the
  report is written.

Both draw only when ``show`` is True (:func:`show_progress`); both log each step at INFO
(seen with ``--verbose``). Stage messages come from the job through the logger: a log
record with ``extra={"stage": ...}`` updates the bar (:class:`_StageHandler`).
"""

from __future__ import annotations

import logging
import sys
import time
from contextlib import AbstractContextManager
from typing import Any

from ..log import console, logger

log = logger(__name__)


def show_progress(progress: bool | None) -> bool:
    """``progress`` when given, else whether stderr is a terminal."""
    if progress is not None:
        return progress
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def is_failure(result) -> bool:
    """True for a failed record result."""
    return not getattr(result, "ok", True)


def _bar(label: str, *fields: str):
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(),
                    *(TextColumn(f) for f in fields), TimeElapsedColumn(),
                    TextColumn("ETA"), TimeRemainingColumn(), console=console(),
                    transient=False)


class _StageHandler(logging.Handler):
    """Shows the ``stage`` of log records (from this process) on a bar's task."""

    def __init__(self, tracker: Tracker) -> None:
        super().__init__(logging.DEBUG)
        self.tracker = tracker

    def emit(self, record: logging.LogRecord) -> None:
        stage = getattr(record, "stage", None)
        if stage is not None:
            self.tracker.stage(stage)


class Tracker(AbstractContextManager):
    """Counts finished records and failures; draws a rich progress bar when ``show``."""

    def __init__(self, total: int, show: bool) -> None:
        self.total = total
        self.show = show
        self.completed = 0
        self.failures = 0
        self._progress = None
        self._task = None
        self._handler = None
        self._level = logging.NOTSET
        self._current = ""

    def __enter__(self) -> Tracker:
        if self.show:
            self._progress = _bar("records", "failures: {task.fields[failures]}",
                                  "{task.fields[stage]}")
            self._progress.start()
            self._task = self._progress.add_task("records", total=self.total, failures=0,
                                                 stage="")
            # stage records are INFO: let them reach the bar (the console handler, when
            # configured, still filters by its own level)
            root = logging.getLogger("pipeline")
            self._level = root.level
            root.setLevel(min(root.getEffectiveLevel(), logging.INFO))
            self._handler = _StageHandler(self)
            root.addHandler(self._handler)
        return self

    def start(self, name: str) -> None:
        """A record starts in this process."""
        self._current = name
        self.stage("start")

    def stage(self, stage: str) -> None:
        if self._progress is not None:
            text = f"{self._current}: {stage}" if self._current else stage
            self._progress.update(self._task, stage=text)

    def done(self, result, seconds: float | None = None) -> None:
        self.completed += 1
        self.failures += int(is_failure(result))
        self._current = ""
        name = getattr(result, "name", "?")
        took = "" if seconds is None else f" in {seconds:.2f} s"
        if is_failure(result):
            log.info("%s: failed%s (%d/%d)", name, took, self.completed, self.total)
        else:
            log.info("%s: done%s, %d event(s), %d fit(s) (%d/%d)", name, took,
                     len(getattr(result, "events", ()) or ()),
                     len(getattr(result, "fits", ()) or ()), self.completed, self.total)
        if self._progress is not None:
            self._progress.update(self._task, advance=1, failures=self.failures, stage="")

    def __exit__(self, *exc) -> None:
        if self._handler is not None:
            root = logging.getLogger("pipeline")
            root.removeHandler(self._handler)
            root.setLevel(self._level)
        if self._progress is not None:
            self._progress.stop()
        return None


class Stages(AbstractContextManager):
    """The steps after the records; a bar (when ``show``) and an INFO line per step."""

    def __init__(self, show: bool) -> None:
        self.show = show
        self._progress = None
        self._task = None
        self._name = ""
        self._t0 = 0.0

    def __enter__(self) -> Stages:
        if self.show:
            self._progress = _bar("{task.description}")
            self._progress.start()
        return self

    def step(self, name: str, total: int = 1) -> None:
        """Start step ``name`` (the previous one is done)."""
        self._finish()
        self._name, self._t0 = name, time.perf_counter()
        if self._progress is not None:
            self._task = self._progress.add_task(name, total=total)

    def advance(self, n: int = 1) -> None:
        if self._progress is not None and self._task is not None:
            self._progress.update(self._task, advance=n)

    def counting(self, mapper):
        """``mapper`` whose results advance the current step, one per item."""

        def mapped(f, *iterables) -> Any:
            for item in mapper(f, *iterables):
                self.advance()
                yield item

        return mapped

    def _finish(self) -> None:
        if not self._name:
            return
        if self._progress is not None and self._task is not None:
            task = self._progress.tasks[-1]
            self._progress.update(self._task, completed=task.total)
        log.info("%s: %.2f s", self._name, time.perf_counter() - self._t0)
        self._name = ""

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self._finish()
        if self._progress is not None:
            self._progress.stop()
        return None
