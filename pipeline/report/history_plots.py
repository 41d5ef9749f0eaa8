"""Trend plots of the run history (:mod:`pipeline.history`) as PNG bytes.

One figure per model parameter present in the history (the parameter table,
:data:`pipeline.models.PARAMETERS`, gives the columns and labels) and one of the
validation MSE, each over the run times, one line per (record, method)
(and event, when a record has several identification events). Only ``ok`` fits are
drawn. With more series than ``max_lines`` only the records' best fits are drawn, and
if that is still too many, the first ``max_lines`` series by name (the title says so).

Matplotlib's object API with the Agg canvas: no pyplot state, safe in worker threads.
"""

from __future__ import annotations

from io import BytesIO

import matplotlib.dates as mdates
import polars as pl
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..history import PARAMS
from ..models import PARAMETERS
from .drawing import literal_text

LABELS = {**{p.name: p.label + (f" ({p.unit()})" if p.kind in ("time", "frequency") else "")
             for p in PARAMETERS.values()}, "mse_validation": "validation MSE"}


def history_figures(df: pl.DataFrame, record: str | None = None, *, max_lines: int = 12,
                    dpi: int = 100) -> list[tuple[str, bytes]]:
    """``(title, PNG bytes)`` for each parameter and the validation MSE over the runs."""
    frame, note = plot_frame(df, record, max_lines)
    if frame.is_empty():
        return []
    figures = []
    for column in [p for p in PARAMS if p in frame.columns] + ["mse_validation"]:
        if column not in frame.columns or frame.get_column(column).drop_nulls().is_empty():
            continue
        title = f"{LABELS.get(column, column)} over runs"
        if record is not None:
            title += f": {record}"
        figures.append((title + note, trend_png(frame, column, title + note, dpi=dpi)))
    return figures


def plot_frame(df: pl.DataFrame, record: str | None, max_lines: int
               ) -> tuple[pl.DataFrame, str]:
    """The ok fit rows to draw, with a ``series`` label column, and a title note."""
    frame = df.filter(pl.col("status") == "ok")
    if record is not None:
        frame = frame.filter(pl.col("record") == record)
    if frame.is_empty():
        return frame, ""
    multi = (frame.group_by("time", "record", "method")
             .agg(pl.col("event").n_unique().alias("k")).get_column("k").max() or 1) > 1
    label = [pl.col("record"), pl.lit(" / "), pl.col("method")]
    if multi:
        label += [pl.lit(" / ev "), pl.col("event").cast(pl.String)]
    frame = frame.with_columns(pl.concat_str(label).alias("series"))
    note = ""
    if frame.get_column("series").n_unique() > max_lines and "best" in frame.columns:
        frame = frame.filter(pl.col("best").fill_null(False))
        note = " (best fits)"
    series = sorted(frame.get_column("series").unique().to_list())
    if len(series) > max_lines:
        frame = frame.filter(pl.col("series").is_in(series[:max_lines]))
        note += f" (first {max_lines} of {len(series)} series)"
    return frame.sort("time"), note


def trend_png(frame: pl.DataFrame, column: str, title: str, *, dpi: int = 100) -> bytes:
    """One line per series of ``column`` against ``time``, as PNG bytes."""
    fig = Figure(figsize=(8.0, 4.0), dpi=dpi)  # fixed margins: one draw per PNG
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=0.11, right=0.98, bottom=0.16, top=0.91)
    ax = fig.add_subplot()
    data = frame.select("time", "series", column).drop_nulls(column)
    for (name,), part in data.group_by("series", maintain_order=True):
        ax.plot(part.get_column("time").to_list(), part.get_column(column).to_list(),
                marker="o", markersize=3, linewidth=1.2, label=name)
    values = data.get_column(column)
    if column == "mse_validation" and values.min() > 0 and values.max() > 100 * values.min():
        ax.set_yscale("log")
    locator = mdates.AutoDateLocator()
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
    ax.set_xlabel("run time (UTC)")
    ax.set_ylabel(LABELS.get(column, column))
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    literal_text(fig)  # record names are text, not mathtext
    buf = BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()
