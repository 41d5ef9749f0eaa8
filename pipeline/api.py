"""Convenience entry points of the public API (``pipeline.load``, ``pipeline.identify``).

Thin wrappers over the one analysis path: :func:`pipeline.io.load_record` and
:func:`pipeline.analysis.analyse`.
"""

from __future__ import annotations

import os
from pathlib import Path

from .analysis import AnalysisOptions, analyse
from .config import DataConfig
from .io import load_record
from .methods import identify as identify_event
from .record import Record, make_record, with_setpoint
from .results import RecordResult

__all__ = ["identify", "identify_event", "load"]


def load(path: str | os.PathLike, **data) -> Record:
    """Load one log as a :class:`~pipeline.record.Record`.

    ``data`` are the keys of a config's ``data:`` section, e.g.
    ``load("log.csv", input="u", output="y", time="t", units={"output": "degC"})``.
    """
    return load_record(Path(path), DataConfig(path=str(path), **data))


def identify(t, u, y, *, methods: tuple[str, ...] | str = "all",
             events: tuple[int, ...] | str = (0,), initial_input: float | None = None,
             units: dict[str, str] | None = None, name: str = "arrays",
             setpoint=None) -> RecordResult:
    """Identify models from numpy arrays: segment, run the methods on the identification
    events, validate on the others, grade, recommend: ``result.recommended`` is the fit to
    use (its ``verdict`` and ``flags`` say whether to trust it). ``setpoint``: a closed
    loop's setpoint beside ``u`` (the controller output) and ``y``; ``result.loop`` is
    then the running controller read off the arrays."""
    record = make_record(t, u, y, name=name, source=f"<{name}>", units=units,
                         initial_input=initial_input)
    if setpoint is not None:
        record = with_setpoint(record, setpoint, "r")
    return analyse(record, AnalysisOptions(events=events, methods=methods))
