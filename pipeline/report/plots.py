"""Matplotlib figures for the reports, returned as PNG bytes (Agg backend, no display).

Every axis is labelled with its quantity and unit, every figure with more than one curve
has a legend, and events are shaded and numbered. Long curves are decimated to the pixels
they fill, legends sit at fixed places (``loc="best"`` searches every point of every curve:
70 % of a million-sample report), and user text is drawn literally
(:mod:`pipeline.report.drawing`).
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402

from ..record import Record, in_time_unit  # noqa: E402
from .drawing import columns_of, decimate, literal_text  # noqa: E402

ROLE_COLOURS = {"identification": "#4c72b0", "validation": "#55a868", "unused": "#bbbbbb"}
DPI = 110
SUMMARY_DPI = 72
MAX_NUMBERED = 40  # events numbered on a plot up to this many (beyond, the table does)


#: Colours of the PNG palette: a line plot's antialiased RGBA at 256 colours looks the
#: same and takes about a third of the bytes (issue 29: the nightly HTML of 20 logs was
#: 15 MB; a validation overlay 90 KB -> 26 KB).
PALETTE_COLOURS = 256


def png_of(fig, dpi: int = DPI) -> bytes:
    """PNG bytes of a figure, its user text drawn literally, in a 256-colour palette
    (Pillow's fast octree quantiser; pyplot figures are closed after)."""
    from PIL import Image

    literal_text(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight",
                pil_kwargs={"compress_level": 1})  # re-encoded below: speed, not size
    plt.close(fig)
    buf.seek(0)
    with Image.open(buf) as im:
        pal = im.convert("RGB").quantize(colors=PALETTE_COLOURS,
                                         method=Image.Quantize.FASTOCTREE)
    out = io.BytesIO()
    pal.save(out, format="png", optimize=True)
    return out.getvalue()


def _label(record: Record, which: str) -> str:
    name = record.input_name if which == "input" else record.output_name
    unit = record.units.get(which)
    return f"{which} {name} [{unit}]" if unit else f"{which} {name}"


def _tu(record: Record, seconds):
    """Times in the user's time unit (the data are in seconds)."""
    return in_time_unit(seconds, record.units.get("time"))


def _time_label(record: Record) -> str:
    return f"time [{record.units.get('time', 's')}]"


def _shade(ax, record: Record, events, roles, *, labels: bool) -> None:
    """Each event's window shaded in its role's colour with a dashed line at its start,
    one collection per role (one artist per event made a 2000-event record's overview
    quadratic in matplotlib's autoscaling: 114 s); lined and numbered when there are
    few events."""
    spans: dict[str, list[tuple[float, float]]] = {}
    for ev in events:
        spans.setdefault(roles.get(ev.index, "unused"), []).append(
            (_tu(record, ev.t0), _tu(record, record.t[ev.i_end - 1])))
    across = ax.get_xaxis_transform()  # x in data, y from the bottom (0) to the top (1)
    for role, windows in spans.items():
        colour = ROLE_COLOURS[role]
        ax.add_collection(PolyCollection(
            [[(a, 0.0), (a, 1.0), (b, 1.0), (b, 0.0)] for a, b in windows], transform=across,
            facecolors=colour, edgecolors="none", alpha=0.12,
            label=f"{role} event" if labels else None), autolim=False)
        if len(events) <= MAX_NUMBERED:  # beyond, dense dashes draw stripes
            ax.add_collection(LineCollection(
                [[(a, 0.0), (a, 1.0)] for a, _ in windows], transform=across,
                colors=colour, linewidths=0.8, linestyles="--"), autolim=False)
    if labels and len(events) <= MAX_NUMBERED:
        for ev in events:
            ax.annotate(f"#{ev.index} {ev.kind}", (_tu(record, ev.t0), 1.0),
                        xycoords=("data", "axes fraction"), xytext=(3, -12),
                        textcoords="offset points", fontsize=8,
                        color=ROLE_COLOURS[roles.get(ev.index, "unused")])


def overview(record: Record, events, roles, *, dpi: int = DPI) -> bytes:
    """The whole record: output on top, input below, events shaded and numbered."""
    fig, (ax_y, ax_u) = plt.subplots(2, 1, sharex=True, figsize=(11, 5.2),
                                     gridspec_kw={"height_ratios": [2, 1]})
    t = _tu(record, record.t)
    px = columns_of(fig, dpi)
    ax_y.plot(*decimate(t, record.y, px), color="#333333", lw=0.9, label="measured output")
    ax_u.step(*decimate(t, record.u, px), where="post", color="#c44e52", lw=1.0,
              label="input")
    for ax in (ax_y, ax_u):
        _shade(ax, record, events, roles, labels=ax is ax_y)
        ax.grid(alpha=0.3)
    ax_y.set_ylabel(_label(record, "output"))
    ax_u.set_ylabel(_label(record, "input"))
    ax_u.set_xlabel(_time_label(record))
    ax_y.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8)
    ax_y.set_title(f"{record.name}: record and events")
    return png_of(fig, dpi)


def _output_axes(ax, record: Record, sl: slice, t, title: str, events, roles, *,
                 ncol: int = 1) -> None:
    """The output axes of an overlay: the events over ``sl`` shaded, the time span, the
    labels, the title, the grid and the legend beside the axes."""
    if events:
        _shade(ax, record, [e for e in events if e.i_start < sl.stop and e.i_end > sl.start],
               roles or {}, labels=False)
    ax.set_xlim(t[0], t[-1])
    ax.set_xlabel(_time_label(record))
    ax.set_ylabel(_label(record, "output"))
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, ncol=ncol)


def is_heavy(name: str, heavy: str | None) -> bool:
    """Whether the curve ``name`` (``label``, ``label: G(s)`` or ``label (MSE ...)``) is
    the recommended model's, whose label is ``heavy``."""
    return heavy is not None and (name == heavy or name.startswith((f"{heavy}:",
                                                                    f"{heavy} (")))


def overlay(record: Record, sl: slice, curves: Iterable[tuple[str, np.ndarray]],
            title: str, *, events=(), roles=None, marks: list[tuple[float, float, str]] = (),
            heavy: str | None = None, dpi: int = DPI) -> bytes:
    """Measured output over ``sl`` with model curves; optional read points ``marks``;
    ``heavy``: the label the recommended model's curve starts with (drawn heavier).
    ``curves`` is iterated once, each curve decimated as it comes: a generator holds one
    record-long curve at a time (a list of eight validation curves over a 10 M-sample
    record was 640 MB at once)."""
    fig, ax = plt.subplots(figsize=(11, 4.2))
    t = _tu(record, record.t[sl])
    px = columns_of(fig, dpi)
    ax.plot(*decimate(t, record.y[sl], px), color="#222222", lw=1.4, alpha=0.8,
            label="measured")
    styles = ["-", "--", "-.", ":"]
    n_curves = 0
    for k, (name, yh) in enumerate(curves):
        rec = is_heavy(name, heavy)
        ax.plot(*decimate(t, yh, px), lw=2.6 if rec else 1.3, ls=styles[(k // 10) % 4],
                label=name, zorder=3 if rec else 2)
        n_curves = k + 1
        del yh
    for tm, ym, text in marks:
        tm = _tu(record, tm)
        ax.plot([tm], [ym], "o", ms=4, color="black")
        ax.annotate(text, (tm, ym), xytext=(4, 4), textcoords="offset points", fontsize=7)
    _output_axes(ax, record, sl, t, title, events, roles, ncol=2 if n_curves > 12 else 1)
    return png_of(fig, dpi)


#: Lags of the residual autocorrelation in the compare plot, and the most residuals it
#: is read from (the first ones: lag products over 10 M samples would cost seconds).
ACF_LAGS, ACF_SAMPLES = 40, 1_000_000


def residual_acf(resid: np.ndarray, lags: int = ACF_LAGS) -> np.ndarray:
    """Autocorrelation of ``resid`` (finite samples, mean removed) at lags ``0..lags``, by
    direct products over at most :data:`ACF_SAMPLES` of them (no record-long FFT)."""
    e = np.asarray(resid, dtype=np.float64)
    e = e[np.isfinite(e)][:ACF_SAMPLES]
    e = e - e.mean() if e.size else e
    lags = max(0, min(lags, e.size - 2))
    c0 = float(e @ e)
    if not c0 > 0:
        return np.r_[1.0, np.zeros(lags)]
    return np.array([1.0] + [float(e[:-k] @ e[k:]) / c0 for k in range(1, lags + 1)])


def compare(record: Record, sl: slice, yhat: np.ndarray, label: str, fit_pct: float,
            *, events=(), roles=None, dpi: int = DPI) -> bytes:
    """MATLAB ``compare``'s view: the measured output and the recommended model simulated
    over the record (heavy), its fit % in the title, and below it the residuals'
    autocorrelation with the 95 % band of white noise, ``+-1.96/sqrt(n)`` (Ljung 1999,
    sec. 16.6: residuals correlated beyond it are dynamics the model misses)."""
    fig, (ax, ax_r) = plt.subplots(2, 1, figsize=(11, 6.0),
                                   gridspec_kw={"height_ratios": [2.2, 1]})
    t = _tu(record, record.t[sl])
    y = record.y[sl]
    px = columns_of(fig, dpi)
    ax.plot(*decimate(t, y, px), color="#222222", lw=1.0, alpha=0.8, label="measured")
    ax.plot(*decimate(t, yhat, px), color="#1f5fa8", lw=2.2, label=label)
    _output_axes(ax, record, sl, t, "Compare: measured and the recommended model simulated "
                 f"over the events (fit {fit_pct:.1f} %)", events, roles)
    resid = y - yhat
    n = int(np.count_nonzero(np.isfinite(resid)))
    acf = residual_acf(resid)
    k = np.arange(acf.size)
    ax_r.vlines(k[1:], 0.0, acf[1:], color="#1f5fa8", lw=1.5)
    ax_r.plot(k[1:], acf[1:], "o", ms=3, color="#1f5fa8", label="residual autocorrelation")
    band = 1.96 / math.sqrt(max(min(n, ACF_SAMPLES), 1))
    ax_r.axhspan(-band, band, color="#999999", alpha=0.25, label="95 % band of white noise")
    ax_r.axhline(0.0, color="#555555", lw=0.8)
    ax_r.set_xlim(0, max(acf.size - 1, 1) + 0.5)
    ax_r.set_xlabel("lag [samples]")
    ax_r.set_ylabel("autocorrelation")
    ax_r.grid(alpha=0.3)
    ax_r.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8)
    fig.tight_layout()
    return png_of(fig, dpi)


def criterion_bars(names: list[str], values: list[float], xlabel: str, title: str, *,
                   dpi: int = DPI) -> bytes:
    """Sorted horizontal bar chart of a criterion (best at the top), log scale if spread."""
    pairs = sorted(((v, n) for n, v in zip(names, values, strict=True) if math.isfinite(v)),
                   reverse=True)
    fig, ax = plt.subplots(figsize=(8, 0.38 * max(len(pairs), 2) + 1.2))
    if pairs:
        vals = [p[0] for p in pairs]
        ax.barh([p[1] for p in pairs], vals, color="#4c72b0")
        positive = [v for v in vals if v > 0]
        if len(positive) == len(vals) and max(vals) / min(vals) > 50:
            ax.set_xscale("log")
        for y, v in enumerate(vals):
            ax.annotate(f"{v:.3g}", (v, y), xytext=(3, -3), textcoords="offset points",
                        fontsize=7)
    ax.set_xlabel(xlabel)
    ax.set_title(title)
    ax.grid(axis="x", alpha=0.3)
    return png_of(fig, dpi)


def loop_figure(t, units: dict[str, str], dpi: int) -> bytes:
    """The tuned loop: output and setpoint above, the actuator below, on the model and on
    the interval's worst case."""
    fig, (ax_y, ax_u) = plt.subplots(2, 1, figsize=(8.0, 5.0), sharex=True,
                                     gridspec_kw={"height_ratios": [3, 2]})
    r = t.response
    ax_y.plot(r.t, r.r, color="#999999", lw=1.0, ls="--", label="setpoint")
    ax_y.plot(r.t, r.y, color="#4c72b0", lw=1.8, label="output, on the model")
    ax_u.plot(r.t, r.u, color="#4c72b0", lw=1.5, label="input, on the model")
    if t.worst_response is not None:
        w = t.worst_response
        ax_y.plot(w.t, w.y, color="#c44e52", lw=1.2, label="output, worst case in the interval")
        ax_u.plot(w.t, w.u, color="#c44e52", lw=1.0, label="input, worst case")
    yu, uu = units.get("output", ""), units.get("input", "")
    ax_y.set_ylabel(f"output change [{yu}]" if yu else "output change")
    ax_u.set_ylabel(f"input change [{uu}]" if uu else "input change")
    ax_u.set_xlabel("time [s]")
    ax_y.set_title("Tuned loop: setpoint step, then a load step at the plant input")
    ax_y.legend(loc="lower right", fontsize=8)
    ax_u.legend(loc="upper right", fontsize=8)
    for ax in (ax_y, ax_u):
        ax.grid(alpha=0.3)
    return png_of(fig, dpi)
