"""Trend plots of the run history (:mod:`pipeline.gate.history`) as PNG bytes.

What an engineer reads off a trend is whether a plant moved, so each line is one record,
on its recommended model of each run (the model to use: which method that is may change
from night to night, the plant does not), normalised to a reference: the baseline's
recommended model when given, else the record's first run in the history. One figure per
model parameter of :data:`pipeline.models.PARAMETERS` present, and one of the validation
MSE; 1 is "as the reference", a 10 % gain drift is a line at 1.10.

The normalisation is the regression gate's (:func:`pipeline.gate.param_scale`):
``1 + (value - reference) / scale``, which is ``value / reference`` for a gain or a time
constant (scale = |reference|) and keeps a dead time or a zero that starts at 0 finite
(scale = the model's time scale). The MSE is ``value / reference``. The gain, the dead
time and the MSE keep their meaning when the recommended structure changes; the other
parameters are drawn only on runs whose recommended model has the reference's structure
(a two-lag T is not a first-order T). Only ``ok`` fits are drawn. With more records than
``max_lines``, the ``max_lines`` records whose last point is furthest from 1 are drawn
(the title says so): a drift is never crowded out.

Matplotlib's object API with the Agg canvas: no pyplot state, safe in worker threads.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from io import BytesIO

import matplotlib
import matplotlib.dates as mdates
import polars as pl
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..gate import param_scale
from ..models import PARAMETERS
from .drawing import literal_text

MSE = "mse_validation"
#: What keeps its meaning when the recommended structure changes (the gate's rule too).
SHARED = ("K", "delay", MSE)
LABELS = {**{p.name: p.label for p in PARAMETERS.values()}, MSE: "validation MSE"}

#: A record's reference model: ``(structure, params, validation MSE)``.
Reference = tuple[str | None, Mapping[str, float], float | None]


def history_figures(df: pl.DataFrame, record: str | None = None, *,
                    reference: Mapping[str, Reference] | None = None, max_lines: int = 12,
                    dpi: int = 100) -> list[tuple[str, bytes]]:
    """``(title, PNG bytes)`` for each parameter and the validation MSE over the runs.

    ``reference`` maps record names to their baseline model (:func:`baseline_reference`);
    records it does not name are normalised to their first run.
    """
    rows = recommended_rows(df, record)
    if rows.is_empty():
        return []
    what = "the baseline" if reference else "the first run"
    figures = []
    for column in [p for p in PARAMETERS if p in rows.columns] + [MSE]:
        frame, note = plot_frame(rows, column, reference, max_lines)
        if frame.is_empty():
            continue
        title = f"{LABELS.get(column, column)} over runs, relative to {what}"
        if record is not None:
            title += f": {record}"
        title += note
        figures.append((title, trend_png(frame, title, column, what, dpi=dpi)))
    return figures


def baseline_reference(doc) -> dict[str, Reference]:
    """The recommended model of each record of a baseline
    (:class:`~pipeline.schema.ResultsDoc`), for :func:`history_figures`."""
    out: dict[str, Reference] = {}
    for rec in doc.records:
        r = rec.recommended
        if r is None:
            continue
        fit = next((f for f in rec.fits if (f.event, f.label) == (r.event, r.label)), None)
        mse = fit.metrics.mse_validation if fit is not None else None
        out[rec.name] = (r.structure, dict(r.params or {}), mse)
    return out


def recommended_rows(df: pl.DataFrame, record: str | None = None) -> pl.DataFrame:
    """The ok rows of each record's recommended model (where a run names none, e.g. a
    history written before the ``recommended`` column: its ranked-best fit), oldest
    first."""
    if "status" not in df.columns:
        return df.clear()
    marks = [pl.col(c).fill_null(False) for c in ("recommended", "best") if c in df.columns]
    if not marks:
        return df.clear()
    mark = marks[0]
    if len(marks) == 2:  # a run whose record named no recommended model: its best fit
        mark = pl.when(marks[0].any().over("time", "record")).then(marks[0]).otherwise(marks[1])
    frame = df.filter((pl.col("status") == "ok") & mark)
    if record is not None:
        frame = frame.filter(pl.col("record") == record)
    return frame.sort("time", maintain_order=True)


def _scale(column: str, row: Mapping) -> tuple[float, float] | None:
    """``(reference value, signed scale)`` of ``column`` on a reference model row (None
    when it has no usable value)."""
    value = row.get(column)
    if value is None:
        return None
    value = float(value)
    if column == MSE:
        return (value, value) if value > 0 else None
    params = {p: float(row[p]) for p in PARAMETERS if row.get(p) is not None}
    scale = param_scale(column, row.get("structure"), params)
    if not scale > 0:
        return None
    return value, -scale if value < 0 else scale


def plot_frame(rows: pl.DataFrame, column: str, reference: Mapping[str, Reference] | None,
               max_lines: int) -> tuple[pl.DataFrame, str]:
    """``time, record, ratio`` of one column (:func:`recommended_rows` in), and a note for
    the title when records were left out."""
    if column not in rows.columns:
        return pl.DataFrame(), ""
    data = rows.drop_nulls(column)
    if data.is_empty():
        return pl.DataFrame(), ""
    refs = []
    for first in data.group_by("record", maintain_order=True).first().iter_rows(named=True):
        row = first
        if reference and first["record"] in reference:
            structure, params, mse = reference[first["record"]]
            row = {"structure": structure, **params, MSE: mse}
        ref = _scale(column, row)
        if ref is not None:
            refs.append({"record": first["record"], "ref": ref[0], "den": ref[1],
                         "ref_structure": row.get("structure")})
    if not refs:
        return pl.DataFrame(), ""
    frame = data.join(pl.DataFrame(refs), on="record", how="inner")
    if column not in SHARED:  # another structure's T is another quantity: left out
        frame = frame.filter(pl.col("structure").eq_missing(pl.col("ref_structure")))
    frame = (frame
             .select("time", "record",
                     (1.0 + (pl.col(column) - pl.col("ref")) / pl.col("den")).alias("ratio")))
    names = frame.get_column("record").unique(maintain_order=True)
    note = ""
    if len(names) > max_lines:
        far = (frame.group_by("record").agg(pl.col("ratio").last())
               .sort((pl.col("ratio") - 1.0).abs(), descending=True).head(max_lines))
        frame = frame.filter(pl.col("record").is_in(far.get_column("record").to_list()))
        note = f" (the {max_lines} of {len(names)} records that moved most)"
    return frame.sort("time", maintain_order=True), note


#: Title characters per line (8 inches at 10 pt): longer titles wrap instead of running
#: off the figure (issue 29: history titles were clipped).
TITLE_WIDTH = 78


def trend_figure(frame: pl.DataFrame, title: str, column: str, what: str, *,
                 dpi: int = 100) -> Figure:
    """One line per record of ``ratio`` against ``time``: a distinct colour per record
    (tab10, then tab20 beyond ten; a dashed second round beyond twenty), the legend
    beside the axes (not over the lines), the title wrapped to the figure."""
    lines = textwrap.wrap(title, TITLE_WIDTH, max_lines=4, placeholder=" ...") or [""]
    fig = Figure(figsize=(8.0, 4.0 + 0.2 * (len(lines) - 1)), dpi=dpi)
    FigureCanvasAgg(fig)
    # the top margin makes room for the title's lines; the legend beside the axes is
    # taken in by the tight bounding box of the PNG
    fig.subplots_adjust(left=0.11, right=0.98, bottom=0.16,
                        top=0.91 - 0.055 * (len(lines) - 1))
    ax = fig.add_subplot()
    ax.axhline(1.0, color="0.5", linewidth=0.8, linestyle="--")
    groups = list(frame.group_by("record", maintain_order=True))
    cmap = matplotlib.colormaps["tab10" if len(groups) <= 10 else "tab20"]
    for k, ((name,), part) in enumerate(groups):
        times = part.get_column("time").to_list()
        ratios = part.get_column("ratio").to_list()
        colour = cmap(k % cmap.N)
        ax.plot(times, ratios, marker="o", markersize=3, linewidth=1.2, label=str(name),
                color=colour, linestyle="-" if k < cmap.N else "--")
    values = frame.get_column("ratio")
    if column == MSE and values.min() > 0 and values.max() > 100 * values.min():
        ax.set_yscale("log")
    locator = mdates.AutoDateLocator()
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
    ax.set_xlabel("run time (UTC)")
    ax.set_ylabel(f"recommended model, 1 = {what}")
    ax.set_title("\n".join(lines), fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    literal_text(fig)  # record names are text, not mathtext
    return fig


def trend_png(frame: pl.DataFrame, title: str, column: str, what: str, *, dpi: int = 100
              ) -> bytes:
    """:func:`trend_figure` as PNG bytes."""
    fig = trend_figure(frame, title, column, what, dpi=dpi)
    buf = BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    return buf.getvalue()
