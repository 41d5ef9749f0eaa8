"""What every report figure does before it is saved: curves decimated to the pixels they
fill, and user text drawn literally.

* :func:`decimate` keeps, per pixel column of a curve, the samples holding its minimum
  and its maximum (in time order): the drawn line covers the same pixels as the full
  curve (every peak and every step edge survives) from at most two points per column, so
  a million-sample record draws as fast as a short one. This is the min/max ("M4"
  without the first and last points) aggregation of Jugel et al., "M4: A
  Visualization-Oriented Time Series Data Aggregation", PVLDB 7(10), 2014.
* :func:`literal_text` turns matplotlib's mathtext (``$...$``) and TeX off for the
  titles, labels, legends and annotations of a figure: a ``$`` or a ``\\frac`` in a file,
  column or unit name is text, not a formula that fails to parse, and a control character
  is shown as its escape. Tick labels keep mathtext (a log axis writes its 10^k with it).
"""

from __future__ import annotations

import numpy as np
from matplotlib.text import Text

from ..memory import CHUNK
from ..quoting import printable


def decimate(x: np.ndarray, y: np.ndarray, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` reduced to the samples holding the minimum and the maximum of ``y`` in
    each of ``columns`` equal slices of the ``x`` range (``x`` increasing), in order;
    unchanged when it has at most ``2 * columns`` samples. A slice whose values are all
    NaN keeps one NaN (a gap in the data stays a gap in the line).

    Hand-written with numpy (matplotlib draws every point it is given): O(samples), in
    chunks of :data:`pipeline.memory.CHUNK` samples (a 10 M-sample curve's per-sample
    temporaries, about 40 bytes a sample, were 400 MB at once). A slice that spans two
    chunks takes the lower minimum and the higher maximum of its two parts, the earlier
    sample on a tie: the same samples as one pass over the whole curve.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    n = y.size
    columns = max(int(columns), 1)
    if n <= 2 * columns:
        return x, y
    span = x[-1] - x[0]
    if not np.isfinite(span) or span <= 0:
        return x[[0, -1]], y[[0, -1]]
    scale = columns / span
    parts: list[list[np.ndarray]] = []  # per chunk: columns, lowest, its sample, highest, its
    for a in range(0, n, CHUNK):
        b = min(a + CHUNK, n)
        col = np.minimum(((x[a:b] - x[0]) * scale).astype(np.int64), columns - 1)
        starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])  # where a column begins
        part = [col[starts], *_extremes(starts, y[a:b], a)]
        if parts and parts[-1][0][-1] == part[0][0]:  # a column across the chunk boundary
            prev = parts[-1]
            if part[1][0] < prev[1][-1]:
                prev[1][-1], prev[2][-1] = part[1][0], part[2][0]
            if part[3][0] > prev[3][-1]:
                prev[3][-1], prev[4][-1] = part[3][0], part[4][0]
            part = [v[1:] for v in part]
        if part[0].size:  # (empty: the whole chunk was that one column)
            parts.append(part)
    keep = np.unique(np.concatenate([v for p in parts for v in (p[2], p[4])]))
    return x[keep], y[keep]


def _extremes(starts: np.ndarray, y: np.ndarray, offset: int) -> list[np.ndarray]:
    """Per pixel column (beginning at the samples ``starts`` of ``y``): the minimum of
    ``y`` and the first sample at it (``offset`` added), the maximum and the first sample
    at it; non-finite values count as +inf for the minimum and -inf for the maximum (a
    column of NaNs only: its first sample)."""
    bins = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, y.size]))
    finite = np.isfinite(y)
    out = []
    for reduce, fill in ((np.minimum, np.inf), (np.maximum, -np.inf)):
        filled = np.where(finite, y, fill)
        extreme = reduce.reduceat(filled, starts)
        hit = np.flatnonzero(filled == extreme[bins])
        first = hit[np.r_[True, bins[hit][1:] != bins[hit][:-1]]]
        out += [extreme, first + offset]
    return out


def columns_of(fig, dpi: float) -> int:
    """The pixel width of a figure saved at ``dpi`` (an upper bound on any axes' width)."""
    return max(int(round(fig.get_figwidth() * dpi)), 1)


def literal_text(fig) -> None:
    """Draw the figure's titles, axis labels, legends and annotations as plain text (no
    mathtext, no TeX): they carry file, column, unit and record names."""
    texts: list[Text] = [*fig.texts]
    if getattr(fig, "_suptitle", None) is not None:
        texts.append(fig._suptitle)
    legends = list(fig.legends)
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label,
                  ax.yaxis.label, *ax.texts]
        if ax.get_legend() is not None:
            legends.append(ax.get_legend())
    for legend in legends:
        texts += [*legend.get_texts(), legend.get_title()]
    for t in texts:
        t.set_usetex(False)
        t.set_parse_math(False)
        t.set_text(printable(t.get_text(), lines=True))  # no glyph for a control character
