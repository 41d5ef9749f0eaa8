"""Run history: one parquet file that grows by one row per record, event and method per run.

Columns (one schema, :data:`SCHEMA`): ``time`` (the run, UTC), ``record``, ``event``,
``method``, ``status``, ``structure``, ``verdict``, ``best`` (the ranked-best fit of files
written before pipeline 0.3, which :func:`pipeline.report.history_plots.recommended_rows`
falls back on; null since), ``recommended`` (the record's recommended model), one
column per parameter of :data:`pipeline.models.PARAMETERS` (null when the model has no
such parameter), one per metric of :class:`pipeline.schema.MetricsDoc` (null when not
computed), the tuned controller's ``Kc``, ``Ti``, ``Td`` (ideal form, seconds; ``Kc``
signed) and ``tuning_verdict`` on the recommended model's row (null elsewhere, and ``Ti``
null without integral action), the running controller's ``running_Kc``, ``running_Ti``,
``running_Td`` on a closed-loop log's row of its plant fitted through the loop (method
``plant_through_loop``, event null), and ``pipeline_version``. A record that failed has
one row with null event and method and status ``failed``.

:func:`history_rows` is pure; :func:`append_history` reads the existing file, appends
(polars ``concat(how="diagonal_relaxed")``, so files written by older versions with fewer
columns still append), writes a temporary file and renames it over the old one, keeping
the file's mode (:func:`pipeline.files.write_atomic`). A parquet file that is not a
history (:func:`schema_problem`: a column that is not ours, or one of ours of another
type) is refused, one line naming the file, and left untouched: appending would rewrite
it with its types changed.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Mapping
from contextlib import nullcontext
from datetime import UTC, datetime
from pathlib import Path

import polars as pl

from ..errors import UserError
from ..files import locked, refuse_special, through_link, write_atomic
from ..models import PARAMETERS
from ..schema import THROUGH_LOOP, MetricsDoc, ResultsDoc

METRICS = tuple(MetricsDoc.model_fields)

SCHEMA: dict[str, pl.DataType] = {
    "time": pl.Datetime("us", "UTC"),
    "record": pl.String(),
    "event": pl.Int64(),
    "method": pl.String(),
    "status": pl.String(),
    "structure": pl.String(),
    "verdict": pl.String(),
    "best": pl.Boolean(),  # the ranked-best fit, written before 0.3; null since
    "recommended": pl.Boolean(),
    **{p: pl.Float64() for p in PARAMETERS},
    **{m: pl.Float64() for m in METRICS},
    "Kc": pl.Float64(),
    "Ti": pl.Float64(),
    "Td": pl.Float64(),
    "tuning_verdict": pl.String(),
    "running_Kc": pl.Float64(),
    "running_Ti": pl.Float64(),
    "running_Td": pl.Float64(),
    "pipeline_version": pl.String(),
}


def as_utc(run_time: datetime | None) -> datetime:
    """``run_time`` in UTC; a naive time is taken as UTC, ``None`` is now."""
    if run_time is None:
        return datetime.now(UTC)
    if run_time.tzinfo is None:
        return run_time.replace(tzinfo=UTC)
    return run_time.astimezone(UTC)


def history_rows(results: ResultsDoc, run_time: datetime | None) -> pl.DataFrame:
    """The rows one run adds: one per record, event and method (pure)."""
    t = as_utc(run_time)
    rows = []
    for rec in results.records:
        base = {"time": t, "record": rec.name, "pipeline_version": results.pipeline_version}
        if rec.status != "ok":
            rows.append({**base, "status": rec.status})
            continue
        for fit in rec.fits:
            params = fit.params or {}
            metrics = fit.metrics.model_dump()
            key = (fit.label, fit.event)
            chosen = rec.recommended is not None and key == (rec.recommended.label,
                                                             rec.recommended.event)
            rows.append({
                **base, "event": fit.event, "method": fit.label, "status": fit.status,
                "structure": fit.structure, "verdict": fit.verdict,
                "recommended": chosen,
                **{p: _number(params.get(p)) for p in PARAMETERS},
                **{m: _number(metrics.get(m)) for m in METRICS},
                **(_tuning_columns(rec.tuning) if chosen else {}),
            })
        if rec.running_loop is not None:
            rows.append({**base, **_loop_columns(rec.running_loop)})
    return pl.DataFrame(rows, schema=SCHEMA)


def _loop_columns(loop) -> dict:
    """A closed-loop log's row: the plant fitted through the loop (method
    :data:`pipeline.schema.THROUGH_LOOP`, its parameters) and the running controller's settings."""
    out: dict = {"method": THROUGH_LOOP, "status": "ok" if loop.plant else "not_applicable",
                 "recommended": False}
    if loop.plant is not None:
        out |= {"structure": loop.plant.structure,
                **{p: _number(loop.plant.params.get(p)) for p in PARAMETERS}}
    c = loop.controller
    if c is not None:
        out |= {"running_Kc": _number(c.Kc), "running_Ti": _number(c.Ti),
                "running_Td": _number(c.Td)}
    return out


def _tuning_columns(t) -> dict:
    """The tuned settings a history keeps (ideal form, seconds), when there are some."""
    if t is None or t.status != "ok" or t.controller is None:
        return {}
    c = t.controller
    return {"Kc": _number(c.Kc), "Ti": _number(c.Ti), "Td": _number(c.Td),
            "tuning_verdict": t.verdict}


def _number(v) -> float | None:
    if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v):
        return float(v)
    return None


def append_history(path: str | os.PathLike, results: ResultsDoc,
                   run_time: datetime | None = None, *, lock: bool = True) -> pl.DataFrame:
    """Append the rows of one run (``results``: a results document) to the parquet file
    at ``path`` (created with its folder when absent); returns the whole history.
    ``lock=False``: the caller holds :func:`history_lock` already (a run takes it before
    it holds SIGTERM to publish, so that a run waiting for it still stops at once)."""
    p = through_link(Path(path), "history")
    new = history_rows(results, run_time)
    # read, add, replace: one run at a time, or rows are lost (four runs appending at once
    # kept 1 of 4 rows without it, issue 31)
    with history_lock(p) if lock else nullcontext():
        frame = pl.concat([load_history(p), new], how="diagonal_relaxed") if p.exists() \
            else new
        buf = io.BytesIO()
        frame.write_parquet(buf)
        write_atomic(p, buf.getvalue(), "history", through=True)
    return frame


def history_lock(path: str | os.PathLike, lost: str = "this run's rows were not added"):
    """The history's lock (:func:`pipeline.files.locked`): one run at a time reads, adds
    to and replaces it; one lock for every link to one file. ``lost``: what a run that
    cannot get it did not write (a run takes it before it publishes anything)."""
    p = through_link(Path(path), "history")
    return locked(p, "the history", LOCK_WAIT, lost)


#: How long a run waits for another run's history append (seconds) before it says so.
LOCK_WAIT = 120.0


def load_history(path: str | os.PathLike) -> pl.DataFrame:
    """The history at ``path``, sorted by time (stable within a run)."""
    p = Path(path)
    if not p.exists():
        raise UserError(f"{p}: history file not found")
    refuse_special(p, "expected a parquet history file")
    try:
        frame = pl.read_parquet(p)
    except (OSError, pl.exceptions.PolarsError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UserError(f"{p}: not a readable parquet history file ({first})") from None
    problem = schema_problem(frame.schema)
    if problem:
        raise UserError(f"{p}: not a pipeline history file ({problem}); expected the columns "
                        "of a pipeline history: time (datetime, UTC), record, event, method, "
                        "status, ..., pipeline_version")
    return frame.sort("time", maintain_order=True)


#: The columns every history has had since the first version.
REQUIRED = ("time", "record", "method")


def schema_problem(schema: Mapping[str, pl.DataType]) -> str | None:
    """What makes ``schema`` not a history's (None when it is one): a required column
    (:data:`REQUIRED`) missing, a column that is not in :data:`SCHEMA`, or one of ours of
    another type. A file an older version wrote has fewer columns, never other types."""
    missing = [c for c in REQUIRED if c not in schema]
    if missing:
        return f"no column {missing[0]!r}"
    for name, dtype in schema.items():
        if name not in SCHEMA:
            return f"column {name[:40]!r} is not one of ours"
        if dtype != SCHEMA[name]:
            return f"column {name!r} is {dtype}, not {SCHEMA[name]}"
    return None


def run_times(frame: pl.DataFrame) -> list[datetime]:
    """The distinct run times of a history, oldest first."""
    return frame.get_column("time").unique().sort().to_list()
