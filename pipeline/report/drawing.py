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

from ..quoting import printable


def decimate(x: np.ndarray, y: np.ndarray, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` reduced to the samples holding the minimum and the maximum of ``y`` in
    each of ``columns`` equal slices of the ``x`` range (``x`` increasing), in order;
    unchanged when it has at most ``2 * columns`` samples. A slice whose values are all
    NaN keeps one NaN (a gap in the data stays a gap in the line).

    Hand-written with numpy (matplotlib draws every point it is given): O(samples).
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
    col = np.minimum(((x - x[0]) * (columns / span)).astype(np.int64), columns - 1)
    starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
    bins = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, n]))
    finite = np.isfinite(y)
    lo = np.minimum.reduceat(np.where(finite, y, np.inf), starts)
    hi = np.maximum.reduceat(np.where(finite, y, -np.inf), starts)
    keep = np.zeros(n, dtype=bool)
    for extreme, fill in ((lo, np.inf), (hi, -np.inf)):
        # the first sample of each column at its extreme (in a column of NaNs only, its
        # first sample: the NaN that keeps the gap)
        hit = np.flatnonzero(np.where(finite, y, fill) == extreme[bins])
        keep[hit[np.r_[True, bins[hit][1:] != bins[hit][:-1]]]] = True
    return x[keep], y[keep]


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
