"""Per-event consistency: is one linear time-invariant model right for the whole log?

Every step is identified on its own (:class:`EventEstimate`: its gain and dominant time
constant with 95 % intervals, at its operating point and time). Then:

* ``gain_inconsistent`` - the gains disagree beyond their intervals: a chi-square test of
  the gains around their weighted mean (significant at 0.1 %) *and* a spread that matters
  (the extreme gains differ by more than :data:`GAIN_SPREAD` of their mean), so tiny but
  significant differences on very clean data are not alarms;
* ``direction_asymmetry`` - steps up and steps down give different gains (Welch-type z on
  the two groups' weighted means, same two conditions);
* the static map - the settled (asymptotic) output against the input level, fitted with a
  line and a quadratic; "clearly not a line" when the quadratic halves the residual and
  its curvature is significant (an F test at 0.1 %). DaISy's lamp heats with the power
  ~ u^2: its step-level asymptotes follow y = a + b u^2.

Pure functions; the estimates come from :mod:`pipeline.analyse`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from .fit import Flag

#: The extreme per-event gains must differ by more than this share of their mean.
GAIN_SPREAD = 0.10
#: Significance of the consistency tests (a false alarm in one log of a thousand).
ALPHA = 1e-3


@dataclass(frozen=True)
class EventEstimate:
    """One step identified on its own: gain and dominant time constant with 95 %
    intervals, where (input/output levels before and after) and when (t0)."""

    index: int
    t0: float
    u0: float
    u1: float
    y0: float
    y_inf: float  # the asymptote: y0 + K (u1 - u0)
    K: float
    K_ci: tuple[float, float]
    T: float
    T_ci: tuple[float, float]
    method: str = ""

    @property
    def K_se(self) -> float:
        return max((self.K_ci[1] - self.K_ci[0]) / (2 * 1.959964), 1e-300)

    @property
    def up(self) -> bool:
        return self.u1 > self.u0


@dataclass(frozen=True)
class StaticMap:
    """Settled output against input level: the levels and the two fits."""

    u: tuple[float, ...]
    y: tuple[float, ...]
    line: tuple[float, float]  # (a, b): y = a + b u
    quadratic: tuple[float, float, float]  # (a, b, c): y = a + b u + c u^2
    rms_line: float
    rms_quadratic: float
    nonlinear: bool
    p_curvature: float


def gain_flags(estimates: list[EventEstimate], unit: str = "") -> list[Flag]:
    """``gain_inconsistent`` and ``direction_asymmetry`` from per-event gains."""
    out = []
    est = [e for e in estimates if math.isfinite(e.K) and e.K_se > 0]
    if len(est) < 2:
        return out
    K = np.array([e.K for e in est])
    se = np.array([e.K_se for e in est])
    w = 1.0 / se**2
    mean = float(np.sum(w * K) / np.sum(w))
    chi2 = float(np.sum(w * (K - mean) ** 2))
    p = float(stats.chi2.sf(chi2, len(est) - 1))
    spread = float((K.max() - K.min()) / abs(mean)) if mean else math.inf
    u = f" {unit}" if unit else ""
    if p < ALPHA and spread > GAIN_SPREAD:
        listing = ", ".join(f"{e.K:.3g}" for e in est)
        out.append(Flag(
            "gain_inconsistent",
            f"The steps' own gains disagree beyond their uncertainty: {listing}{u} "
            f"(events {', '.join(str(e.index) for e in est)}; extremes {spread:.0%} apart, "
            f"chi-square p = {p:.1g}). No single linear model fits every operating point: "
            "use the model near the level you will control at, or a gain schedule.",
            {"gains": listing, "spread": spread, "p": p, "mean": mean}))
    up = [e for e in est if e.up]
    down = [e for e in est if not e.up]
    if up and down:
        mu, su = _wmean(up)
        md, sd = _wmean(down)
        z = (mu - md) / math.hypot(su, sd)
        p2 = float(2 * stats.norm.sf(abs(z)))
        rel = abs(mu - md) / abs(mean) if mean else math.inf
        if p2 < ALPHA and rel > GAIN_SPREAD:
            out.append(Flag(
                "direction_asymmetry",
                f"Steps up give K = {mu:.3g}{u}, steps down {md:.3g}{u} ({rel:.0%} apart, "
                f"p = {p2:.1g}): the plant responds differently to increases and decreases.",
                {"K_up": mu, "K_down": md, "p": p2}))
    return out


def _wmean(est: list[EventEstimate]) -> tuple[float, float]:
    w = np.array([1.0 / e.K_se**2 for e in est])
    K = np.array([e.K for e in est])
    return float(np.sum(w * K) / np.sum(w)), float(1.0 / math.sqrt(np.sum(w)))


def static_map(estimates: list[EventEstimate]) -> StaticMap | None:
    """The input levels and asymptotic outputs of the steps (the first step's starting
    point included), a line and a quadratic through them. None with fewer than 4 levels
    (a quadratic through 3 points always fits)."""
    if not estimates:
        return None
    first = min(estimates, key=lambda e: e.t0)
    u = [first.u0] + [e.u1 for e in estimates]
    y = [first.y0] + [e.y_inf for e in estimates]
    ua, ya = np.array(u), np.array(y)
    if len(set(np.round(ua, 12))) < 4:
        return None
    line = np.polyfit(ua, ya, 1)
    quad = np.polyfit(ua, ya, 2)
    r1 = ya - np.polyval(line, ua)
    r2 = ya - np.polyval(quad, ua)
    n = ua.size
    ss1, ss2 = float(r1 @ r1), float(r2 @ r2)
    if ss2 <= 0:
        p = 0.0 if ss1 > 0 else 1.0
    else:
        F = (ss1 - ss2) / (ss2 / (n - 3))
        p = float(stats.f.sf(F, 1, n - 3)) if n > 3 else 1.0
    rms1, rms2 = math.sqrt(ss1 / n), math.sqrt(ss2 / n)
    nonlinear = p < ALPHA and rms2 < 0.5 * rms1
    return StaticMap(tuple(u), tuple(y), (float(line[1]), float(line[0])),
                     (float(quad[2]), float(quad[1]), float(quad[0])), rms1, rms2,
                     nonlinear, p)


def static_map_note(m: StaticMap | None, units: dict[str, str]) -> str | None:
    """A plain-words line for the report when the static map is clearly not a line."""
    if m is None or not m.nonlinear:
        return None
    a, b, c = m.quadratic
    yu = f" {units['output']}" if units.get("output") else ""
    return (f"The settled output is not a straight line of the input: y = {a:.4g} "
            f"{b:+.4g} u {c:+.4g} u^2 fits the step levels with RMS {m.rms_quadratic:.3g}{yu} "
            f"against {m.rms_line:.3g}{yu} for a line (curvature p = {m.p_curvature:.1g}).")
