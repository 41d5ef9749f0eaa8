"""Figures of per-event consistency: each step's gain and dominant time constant (with
95 % intervals) against the operating point and against time, and the static map (the
settled output against the input level, with the fitted curve when it is not a line)."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..record import in_time_unit
from ..results import EventEstimate, StaticMap
from .drawing import literal_text
from .plots import DPI, png_of

#: Number the points of a consistency panel up to this many steps (beyond, the labels
#: would cover the points; the table numbers them).
MAX_NUMBERED = 40


def _errorbar(ax, x, v, ci, colour, label=None):
    lo = np.array([c[0] for c in ci])
    hi = np.array([c[1] for c in ci])
    v = np.asarray(v, dtype=float)
    ax.errorbar(x, v, yerr=[np.maximum(v - lo, 0), np.maximum(hi - v, 0)], fmt="o",
                color=colour, capsize=3, ms=5, label=label)


def _focus(ax, vals) -> None:
    """Keep the estimates in view when some intervals are enormous (the bars run off the
    axes instead of squashing the points to a line)."""
    v = np.asarray(vals, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return
    lo, hi = float(v.min()), float(v.max())
    pad = max(hi - lo, 0.25 * max(abs(lo), abs(hi)), 1e-12)
    ax.set_ylim(lo - pad, hi + pad)


def consistency_figure(est: list[EventEstimate], units: dict[str, str], *,
                       dpi: int = DPI) -> bytes:
    """Six panels: K and T against the operating point (input and output level, mid-step)
    and against time; steps up and steps down in two colours, numbered by event."""
    fig = Figure(figsize=(13, 6.4))
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 3)
    t_unit = units.get("time", "s")
    k_unit = f"{units.get('output', '-')}/{units.get('input', '-')}" if units else ""
    level = [0.5 * (e.u0 + e.u1) for e in est]
    out_level = [0.5 * (e.y0 + e.y_inf) for e in est]
    tu = units.get("time")
    t0 = [in_time_unit(e.t0, tu) for e in est]
    Ts = [in_time_unit(e.T, tu) for e in est]
    T_ci = [(in_time_unit(e.T_ci[0], tu), in_time_unit(e.T_ci[1], tu)) for e in est]
    for row, (name, vals, cis, unit) in enumerate((
            ("gain K", [e.K for e in est], [e.K_ci for e in est], k_unit),
            ("dominant time constant", Ts, T_ci, t_unit))):
        for col, (x, xlabel) in enumerate(((level, "input level (mid-step)" + (
                f" [{units['input']}]" if units.get("input") else "")),
                (out_level, "output level (mid-step)" + (
                    f" [{units['output']}]" if units.get("output") else "")),
                (t0, f"step time [{t_unit}]"))):
            ax = axes[row][col]
            for up, colour, lab in ((True, "#c44e52", "steps up"),
                                    (False, "#4c72b0", "steps down")):
                sel = [i for i, e in enumerate(est) if e.up == up]
                if sel:
                    _errorbar(ax, [x[i] for i in sel], [vals[i] for i in sel],
                              [cis[i] for i in sel], colour, lab if row == col == 0 else None)
            numbered = zip(x, vals, est, strict=True) if len(est) <= MAX_NUMBERED else ()
            for xi, vi, e in numbered:
                ax.annotate(f"#{e.index}", (xi, vi), xytext=(4, 4), textcoords="offset points",
                            fontsize=7)
            ax.set_xlabel(xlabel)
            ax.set_ylabel(f"{name} [{unit}]" if unit else name)
            ax.grid(alpha=0.3)
            _focus(ax, vals)
    axes[0][0].legend(loc="upper left", fontsize=8, framealpha=0.8)  # fixed: no search
    fig.suptitle("Each step identified on its own (95 % intervals)")
    literal_text(fig)  # before the layout draws the unit names
    fig.tight_layout()
    return png_of(fig, dpi)


def static_map_figure(m: StaticMap, units: dict[str, str], *, dpi: int = DPI) -> bytes:
    """The step levels (settled output against input), the line, and the quadratic when
    the map is clearly not a line."""
    fig = Figure(figsize=(6.5, 4.2))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    u = np.array(m.u)
    ax.plot(u, m.y, "o", color="#222222", label="step levels (asymptotes)")
    grid = np.linspace(u.min(), u.max(), 200)
    a, b = m.line
    ax.plot(grid, a + b * grid, "--", color="#4c72b0", label=f"line (RMS {m.rms_line:.3g})")
    if m.nonlinear:
        qa, qb, qc = m.quadratic
        ax.plot(grid, qa + qb * grid + qc * grid**2, "-", color="#c44e52",
                label=f"quadratic (RMS {m.rms_quadratic:.3g})")
    ax.set_xlabel("input" + (f" [{units['input']}]" if units.get("input") else ""))
    ax.set_ylabel("settled output" + (f" [{units['output']}]" if units.get("output") else ""))
    ax.set_title("Static map")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.8)
    literal_text(fig)  # before the layout draws the unit names
    fig.tight_layout()
    return png_of(fig, dpi)
